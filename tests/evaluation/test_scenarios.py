"""Scenario outages: where each tagged event's windows go, known errors in, known CRSE/CTE out."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation.scenarios import (
    scenario_outage_scores,
    scenario_outage_summary,
    scenario_windows,
    tag_rows,
)
from rwhonet.evaluation.selection import choose
from rwhonet.evaluation.study import evaluate
from rwhonet.report.tables import render_report
from rwhonet.stages.sample_files import load_role

from .conftest import OVERRIDES

M_GRID = [10, 20]  # the first 20 s of each drive are not scored
L = 10


def _frame(segments, role="target_test"):
    """segments: ``(drive, n_seconds, {tag: [(start, stop), ...]})``, times within the segment."""
    parts, rank = [], {}
    for group, (drive, n, events) in enumerate(segments):
        tags = [set() for _ in range(n)]
        for tag, spans in events.items():
            for a, e in spans:
                for t in range(a, e):
                    tags[t].add(tag)
        k0 = rank.get(drive, 0)
        rank[drive] = k0 + n
        parts.append(
            pd.DataFrame(
                {
                    "drive": drive,
                    "group": group,
                    "k": np.arange(k0, k0 + n),
                    "role": role,
                    "scenario": [";".join(sorted(s)) for s in tags],
                }
            )
        )
    return pd.concat(parts, ignore_index=True)


def _counts(w, tag):
    return w.counts.set_index("tag").loc[tag]


def test_a_short_event_gets_one_window_centred_on_it():
    w = scenario_windows(_frame([("A", 200, {"hard_brake": [(100, 103)]})]), M_GRID, L)
    assert w.rows["hard_brake"].tolist() == [list(range(97, 107))]  # 3 s before, 4 s after
    c = _counts(w, "hard_brake")
    assert (c.events, c.scored_events, c.windows, c.longer_than_outage) == (1, 1, 1, 0)


def test_a_longer_event_is_covered_by_consecutive_windows():
    w = scenario_windows(_frame([("A", 200, {"roundabout": [(100, 125)]})]), M_GRID, L)
    rows = w.rows["roundabout"]
    assert rows[:, 0].tolist() == [98, 108, 118] and rows[-1, -1] == 127  # 30 s over 25
    c = _counts(w, "roundabout")
    assert (c.longer_than_outage, c.not_fully_covered) == (1, 0)


def test_windows_stay_in_the_scored_seconds_of_their_segment():
    # an event 2 s after the first scored second, and one 1 s before the segment's end
    frame = _frame([("A", 100, {"sharp_turn": [(22, 24), (98, 99)]})])
    w = scenario_windows(frame, M_GRID, L)
    assert w.rows["sharp_turn"][:, 0].tolist() == [20, 90]


def test_events_in_the_adaptation_seconds_or_a_short_segment_are_left_out_and_counted():
    frame = _frame(
        [
            ("A", 100, {"roundabout": [(5, 12), (15, 25), (60, 65)]}),  # two touch k < 20
            ("A", 8, {"roundabout": [(2, 4)]}),  # 8 scored seconds: no 10 s window fits
        ]
    )
    w = scenario_windows(frame, M_GRID, L)
    c = _counts(w, "roundabout")
    assert (c.events, c.in_adaptation_seconds, c.segment_too_short) == (4, 2, 1)
    assert (c.scored_events, c.windows) == (1, 1)


def test_nearby_events_of_a_tag_merge_and_other_tags_overlap_freely():
    events = {"roundabout": [(100, 103), (107, 109)], "wet_road": [(95, 120)]}
    w = scenario_windows(_frame([("A", 200, events)]), M_GRID, L)
    c = _counts(w, "roundabout")
    assert (c.events, c.merged, c.windows) == (2, 1, 1)
    assert w.rows["roundabout"].tolist() == [list(range(100, 110))]  # 100..108 merged: 9 s
    assert w.rows["wet_road"][:, 0].tolist() == [93, 103, 113]  # 30 s over 25, 2 s before


def test_an_event_cut_by_a_gnss_gap_is_one_event_per_piece():
    frame = _frame([("A", 100, {"wet_road": [(90, 100)]}), ("A", 60, {"wet_road": [(0, 5)]})])
    w = scenario_windows(frame, M_GRID, L)
    c = _counts(w, "wet_road")
    assert (c.events, c.split_by_gnss_gap, c.windows) == (2, 1, 2)
    assert w.rows["wet_road"][:, 0].tolist() == [90, 100]  # no window crosses the gap
    # drives of other roles are not scenario outages
    other = _frame([("B", 100, {"wet_road": [(50, 60)]})], role="source_test")
    assert scenario_windows(other, M_GRID, L).rows["wet_road"].shape == (0, L)


def test_tags_are_split_per_row():
    got = tag_rows(pd.Series(["", "a;b", None, "b"]))
    assert {t: v.tolist() for t, v in got.items()} == {
        "a": [False, True, False, False],
        "b": [False, True, False, True],
    }


@settings(max_examples=60, deadline=None, database=None)
@given(
    lengths=st.lists(st.integers(5, 150), min_size=1, max_size=3),
    spans=st.lists(st.tuples(st.integers(0, 149), st.integers(1, 40)), max_size=8),
)
def test_windows_never_overlap_cross_segments_or_touch_adaptation_seconds(lengths, spans):
    segments = []
    for n in lengths:
        events = [(a, min(a + d, n)) for a, d in spans if a < n]
        segments.append(("A", n, {"x": events}))
    frame = _frame(segments)
    rows = scenario_windows(frame, M_GRID, L).rows.get("x", np.empty((0, L), int))
    flat = rows.ravel()
    assert len(set(flat.tolist())) == len(flat)  # no second scored twice for a tag
    assert (frame["k"].to_numpy()[flat] >= max(M_GRID)).all()
    if len(rows):
        assert (np.diff(rows, axis=1) == 1).all()  # consecutive seconds
        assert (frame["group"].to_numpy()[rows] == frame["group"].to_numpy()[rows[:, :1]]).all()
    # every scored tagged second of a segment with room for its event's windows is covered
    tagged = frame["scenario"].to_numpy() == "x"
    covered = np.zeros(len(frame), bool)
    covered[flat] = True
    seg_scored = frame.groupby("group")["k"].transform(lambda k: (k >= max(M_GRID)).sum())
    room = seg_scored.to_numpy() >= 2 * max(lengths)
    adaptation_free = frame.groupby("group")["k"].transform("min").to_numpy() >= max(M_GRID)
    assert covered[tagged & room & adaptation_free].all()


def test_scores_are_means_over_windows_and_a_model_without_errors_skips_a_window():
    frame = _frame([("A", 200, {"roundabout": [(100, 103)], "wet_road": [(150, 170)]})])
    w = scenario_windows(frame, M_GRID, L)
    e = np.zeros(len(frame))
    e[frame["scenario"].to_numpy() == "wet_road"] = -0.2  # 0.2 m too far each wet second
    e[100] = 0.5
    gap = np.full(len(frame), 0.1)
    gap[155] = np.nan  # a model with no error at one second of the first wet window
    rows = scenario_outage_scores(w, {"G": e, "C": gap})
    got = {(r["tag"], r["model"]): r for r in rows}
    assert got[("roundabout", "G")]["crse"] == pytest.approx(0.5)
    assert got[("wet_road", "G")]["crse"] == pytest.approx(2.0)  # 10 wet seconds per window
    assert got[("wet_road", "G")]["cte"] == pytest.approx(2.0)
    assert got[("wet_road", "C")]["n_windows"] == 1 and got[("wet_road", "G")]["n_windows"] == 2
    per_seed = pd.DataFrame([{"seed": s, **r} for s in (1, 2) for r in rows])
    summary = scenario_outage_summary(per_seed, w.counts)
    assert summary["tag"].tolist()[0] == "wet_road"  # the tag with the most windows first
    assert summary.set_index(["tag", "model"]).loc[("wet_road", "G"), "crse_ci95"] == 0.0


def _hard_brake_study(samples_dir, params):
    """The study on the samples with one 3 s hard brake on drive B; G 0.1 / 0.3 m short."""
    frame = load_role(samples_dir, ("target_test", "source_test"), seq_len=1).frame
    b = frame.index[frame["drive"] == "B"][100:103]  # 3 s of B, well after its first 20 s
    frame.loc[b, "scenario"] = "hard_brake"
    label = frame["label_m"].to_numpy()
    preds = {}
    for seed, off in ((1, 0.1), (2, 0.3)):
        cols = {"G": label - off, "S": label}
        cols |= {f"R[{r}]@{m}": label for r in ("paper", "radius+G") for m in (10, 20)}
        cols |= {f"R[continuous]/{n}s": label for n in (30, 60)}
        preds[seed] = pd.DataFrame(cols, index=frame.index)
    return frame, b, label, evaluate(params, choose(params, {}), frame, preds)


def test_the_study_reports_scenario_outages_in_eval_json_and_tables(samples_dir, params):
    frame, b, label, ev = _hard_brake_study(samples_dir, params)
    tag = ev.eval_json["scenario_outages"]["tags"]["hard_brake"]
    assert ev.eval_json["scenario_outages"]["outage_s"] == 10
    assert (tag["events"], tag["windows"], tag["in_adaptation_seconds"]) == (1, 1, 0)
    g = tag["models"]["G"]
    assert g["crse_mean"] == pytest.approx(10 * 0.2) and g["cte_mean"] == pytest.approx(2.0)
    assert g["crse_ci95"] > 0 and tag["models"]["R"]["crse_mean"] == pytest.approx(0.0)
    start = int(b[0]) - 3  # centred: 3 s before, 4 s after
    wpm = np.abs(label[start : start + 10]).sum()
    assert tag["models"]["WPM"]["crse_mean"] == pytest.approx(wpm, abs=1e-4)
    assert set(tag["models"]) == {
        "WPM",
        "G",
        "S",
        "R",
        "WPM-m@20",
        "R[radius+G]@20",
        "R[continuous]",
    }
    md = render_report(ev, params, "provenance")
    assert "## Scenario outages — a 10 s GNSS outage" in md
    assert "| hard_brake | 1 | 1 | 1 |" in md
    assert "in consecutive 10 s outages)." in md
    assert "(the WhONet scenario protocol)" in ev.eval_json["scenario_outages"]["windows"]


def test_another_outage_length_is_not_passed_off_as_the_protocol_s(samples_dir):
    """WhONet's protocol scores 10 s outages; a report of 20 s ones says both lengths."""
    params = load_params(
        paths.PARAMS, overrides={**OVERRIDES, "seeds": [1, 2], "evaluate.scenario_outage_s": 20}
    )
    *_, ev = _hard_brake_study(samples_dir, params)
    assert ev.eval_json["scenario_outages"]["outage_s"] == 20
    windows = ev.eval_json["scenario_outages"]["windows"]
    assert "20 s outage windows" in windows and "protocol has 10 s" in windows
    md = render_report(ev, params, "provenance")
    assert "## Scenario outages — a 20 s GNSS outage" in md
    assert "in consecutive 10 s outages; 20 s here, evaluate.scenario_outage_s)." in md
