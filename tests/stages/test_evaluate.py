"""Evaluation: same seconds for every model, after the largest m; known CRSE/CTE."""

import numpy as np
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.errors import InputError
from rwhonet.report.tables import render_report
from rwhonet.stages.evaluate import evaluate, model_columns
from rwhonet.stages.samples import load_role


@pytest.fixture
def params():
    return load_params(
        paths.PARAMS,
        overrides={"adapt.m_grid": [10, 20], "adapt.chosen_m": 20, "evaluate.outages_s": [30, 60]},
    )


def _frame(samples_dir, params, offsets):
    test = load_role(samples_dir, "target_test", seq_len=1)
    frame = test.frame.copy()
    for model, col in model_columns(params.adapt.m_grid, params.adapt.chosen_m).items():
        if col:
            frame[col] = frame["label_m"] - offsets.get(model, 0.0)
    return frame


def test_perfect_model_scores_zero_and_wpm_scores_the_label(samples_dir, params):
    ev = evaluate(params, _frame(samples_dir, params, {"G": 0.1}))
    s = ev.summary.set_index(["drive", "model", "outage_s"])
    assert s.loc[("all", "S", 30), "crse_mean"] == pytest.approx(0.0, abs=1e-9)
    assert s.loc[("all", "G", 30), "crse_mean"] == pytest.approx(3.0)  # 30 s x 0.1 m
    assert s.loc[("all", "G", 60), "cte_mean"] == pytest.approx(6.0)
    # windows: A seg0 300-20=280 -> 9 of 30 s, seg1 200 -> 6; B 400-20=380 -> 12
    assert s.loc[("all", "WPM", 30), "n_windows"] == 27
    assert s.loc[("A", "WPM", 60), "n_windows"] == 4 + 3
    ev_part = ev.per_second[ev.per_second["evaluated"]]
    expected = ev_part.loc[ev_part.drive == "B", "label_m"].to_numpy()[:360].reshape(-1, 30)
    assert s.loc[("B", "WPM", 30), "crse_mean"] == pytest.approx(np.abs(expected).sum(1).mean())
    assert s.loc[("B", "WPM", 30), "crse_max"] >= s.loc[("B", "WPM", 30), "cte_max"]


def test_no_model_is_scored_on_adaptation_seconds(samples_dir, params):
    ev = evaluate(params, _frame(samples_dir, params, {}))
    f = ev.per_second
    assert not f.loc[f["k"] < 20, "evaluated"].any() and f.loc[f["k"] >= 20, "evaluated"].all()


def test_eval_json_and_tables(samples_dir, params):
    ev = evaluate(params, _frame(samples_dir, params, {"R@20": -0.2}))
    j = ev.eval_json
    assert set(j["overall"]) == {"WPM", "G", "S", "R", "R@10", "R@20"}
    # R is the chosen m (20): the same predictions as R@20
    assert j["overall"]["R"]["30s"]["cte_mean"] == pytest.approx(6.0)
    assert j["overall"]["R@20"] == j["overall"]["R"]
    assert j["overall"]["R@10"]["30s"]["cte_mean"] == pytest.approx(0.0, abs=1e-9)
    assert set(j["per_drive"]) == {"A", "B"} and "R@10" not in j["per_drive"]["A"]
    md = render_report(
        ev.summary,
        outages_s=[30, 60],
        m_grid=[10, 20],
        chosen_m=20,
        eval_note="note",
        provenance="prov",
    )
    assert "## Table 2" in md and "## Table 6 — CTE, 60 s GNSS outages" in md
    assert "R-WhONet (m=20) CRSE (m)" in md


def test_too_short_drive_is_reported(samples_dir):
    p = load_params(paths.PARAMS, overrides={"adapt.m_grid": [10, 100], "adapt.chosen_m": 100})
    frame = _frame(samples_dir, p, {})
    frame = frame[(frame.drive == "B") | (frame.k < 250)]
    with pytest.raises(InputError, match="too short"):
        evaluate(p, frame)


def test_scenario_errors_per_tag(samples_dir, params):
    frame = _frame(samples_dir, params, {"G": 0.5})
    frame["scenario"] = ""
    frame.loc[frame.index[200:210], "scenario"] = "roundabout;wet_road"
    frame.loc[frame.index[210:215], "scenario"] = "wet_road"
    ev = evaluate(params, frame)
    sc = ev.scenarios.set_index("tag")
    assert sc.loc["wet_road", "n_seconds"] == 15 and sc.loc["roundabout", "n_seconds"] == 10
    assert sc.loc["roundabout", "G"] == pytest.approx(0.5)
    assert sc.loc["roundabout", "S"] == pytest.approx(0.0, abs=1e-12)
    expected = frame["label_m"].iloc[200:215].abs().mean()
    assert sc.loc["wet_road", "WPM"] == pytest.approx(expected)
    assert "" not in sc.index
