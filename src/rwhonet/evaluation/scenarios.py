"""The paper's short-term complex scenarios: roundabouts, sharp turns, hard brakes, wet roads.

The R-WhONet paper (abstract, §1) evaluates the models on short GNSS outages
during challenging driving as well as on the 30-180 s outages. Its protocol is
WhONet's: in the authors' code (onyekpeu/WhONet, ``whonet.py``) each scenario
recording is scored by ``predictcs(..., outage1)`` with ``outage1 = 100``
samples at 10 Hz; ``predictcs`` (``function_files.py``) cuts the one-per-second
predictions into consecutive windows of ``int(outage / Ts) = 10`` seconds, the
remainder dropped. So a scenario outage here lasts ``evaluate.scenario_outage_s``
(10 s, that protocol's value, :data:`PROTOCOL_OUTAGE_S`), long enough to hold a roundabout or a hard
brake, short enough to be about the event rather than the road around it.

The recordings there are cut around the event by hand; here the events come
from the drives' scenario sidecars, through the samples' ``scenario`` column
(a second carries every tag of its rows: :mod:`rwhonet.data.scenarios`,
:func:`rwhonet.features.seconds.scenario_per_second`). An *event* of a tag is a
maximal run of consecutive seconds of one GNSS-valid segment of a target test
drive carrying it. Per event, :func:`scenario_windows` places the outage:

- an event of n ≤ L seconds gets one L-second window centred on it; a longer
  one ceil(n / L) consecutive windows, centred on it, so it is covered whole;
- windows stay inside the segment's scored seconds (those after the drive's
  first max(m) s, :func:`rwhonet.evaluation.windows.evaluated_rows`), shifted
  if the event is near an end; where the segment's scored seconds hold fewer
  windows than the event needs, as many as fit, centred (``not_fully_covered``);
- an event that touches the first max(m) s of its drive is left out: R-WhONet
  was adapted on those seconds (``in_adaptation_seconds``); so is one in a
  segment with fewer than L scored seconds (``segment_too_short``);
- an event cut by a GNSS gap (its sidecar interval runs across seconds the
  validate stage removed) is one event per piece, counted in ``split_by_gnss_gap``:
  no window spans the gap, there is no GNSS truth in it;
- two events of one tag whose windows would overlap are merged into one event
  spanning both (``merged``), so no second is scored twice for a tag; events of
  different tags overlap freely (a roundabout on a wet road is both).

Per window, CRSE and CTE as for the long outages (paper Eqs. 16-17,
:mod:`rwhonet.evaluation.scoring`); per tag and model the mean over windows,
per seed, then the mean over seeds with its 95 % interval. The continuous
recipe is recalibrated before each window of the long outages, not before a
scenario window: its error here is that of the shortest outage length's run
(each second predicted by the model fitted on the seconds before its window),
and a scenario window with a second outside those windows is not scored for it
(its own ``n_windows``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.evaluation.intervals import over_seeds
from rwhonet.evaluation.windows import evaluated_rows

SEPARATOR = ";"
# WhONet's scenario outage: outage1 = 100 samples at 10 Hz (onyekpeu/WhONet, whonet.py),
# scored by predictcs in consecutive windows of int(outage / Ts) = 10 s (module docstring).
PROTOCOL_OUTAGE_S = 10
PER_SECOND_MODELS = ("WPM", "R", "G", "S")
EVENT_COUNTS = (
    "events",
    "scored_events",
    "windows",
    "longer_than_outage",
    "merged",
    "not_fully_covered",
    "in_adaptation_seconds",
    "segment_too_short",
    "split_by_gnss_gap",
)


def protocol_note(outage_s: int) -> str:
    """How a scenario outage of ``outage_s`` stands to WhONet's protocol, for the reports."""
    if outage_s == PROTOCOL_OUTAGE_S:
        return "the WhONet scenario protocol"
    return f"WhONet's scenario protocol has {PROTOCOL_OUTAGE_S} s; evaluate.scenario_outage_s"


def scenario_errors(frame: pd.DataFrame, errors: Mapping[str, np.ndarray]) -> pd.DataFrame:
    """Mean absolute per-second error on the target test seconds of each scenario tag.

    The short-term scenarios read per second (a second carries every tag of its
    rows, so tags overlap), on the evaluated seconds ``frame`` holds.
    """
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    models = PER_SECOND_MODELS
    err = pd.DataFrame({m: np.abs(errors[m][target]) for m in models})
    err["tag"] = frame.loc[target, k.SCENARIO].fillna("").str.split(SEPARATOR).to_numpy()
    long = err.explode("tag")
    long = long[long["tag"] != ""]
    out = long.groupby("tag").agg(n_seconds=("WPM", "size"), **{m: (m, "mean") for m in models})
    return out.reset_index()


@dataclass(frozen=True)
class ScenarioWindows:
    """Where the scenario outages are, per tag.

    Attributes:
        outage_s: the window length L, s.
        rows: per tag, (W, L) row indices of its windows into the frame they were placed on.
        counts: one row per tag: ``tag`` and :data:`EVENT_COUNTS`.
    """

    outage_s: int
    rows: Mapping[str, np.ndarray]
    counts: pd.DataFrame


def tag_rows(tags: pd.Series) -> dict[str, np.ndarray]:
    """Per tag, which rows carry it (``tags``: ';'-joined per row, ``""`` or missing for none)."""
    codes, uniques = pd.factorize(tags.fillna("").to_numpy(object))
    sets = [set(str(u).split(SEPARATOR)) - {""} for u in uniques]
    names = sorted(set().union(*sets)) if sets else []
    return {t: np.isin(codes, [i for i, s in enumerate(sets) if t in s]) for t in names}


def _span(a: int, e: int, lo: int, hi: int, L: int) -> tuple[int, int] | None:
    """The rows ``[start, end)`` of the windows covering rows ``[a, e)`` within ``[lo, hi)``."""
    n = e - a
    n_win = min(-(-n // L), (hi - lo) // L)
    if n_win == 0:
        return None
    size = n_win * L
    start = min(max(a - (size - n) // 2, lo), hi - size)
    return start, start + size


def scenario_windows(frame: pd.DataFrame, m_grid: list[int], outage_s: int) -> ScenarioWindows:
    """Place an outage over every tagged event of the target test drives (module docstring).

    Args:
        frame: test samples (every row of every test drive: ``drive, group, k,
            role, scenario``), in drive, segment, time order.
        m_grid: ``adapt.m_grid``; the first max(m) s of each drive are not scored.
        outage_s: the scenario outage length L, s.

    Returns:
        The windows and per tag how its events were handled.
    """
    L = int(outage_s)
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    group = frame["group"].to_numpy()
    drive = frame["drive"].to_numpy()
    n = len(frame)
    new = np.r_[True, group[1:] != group[:-1]] if n else np.zeros(0, bool)
    first = np.flatnonzero(new)
    end = np.r_[first[1:], n]
    # The scored seconds of a segment are a suffix of it (k grows along the drive).
    scored = evaluated_rows(frame, m_grid)
    n_unscored = np.add.reduceat((~scored).astype(np.int64), first) if n else first
    seg = np.cumsum(new) - 1  # segment number of each row
    lo_of, hi_of = first + n_unscored, end
    rows_out: dict[str, np.ndarray] = {}
    counts = []
    for tag, on in tag_rows(frame[k.SCENARIO]).items():
        on = on & target
        prev = np.r_[False, on[:-1]] & ~new
        starts = np.flatnonzero(on & ~prev)
        nxt = np.r_[on[1:], False] & np.r_[~new[1:], False]
        stops = np.flatnonzero(on & ~nxt) + 1
        c = dict.fromkeys(EVENT_COUNTS, 0)
        c["events"] = len(starts)
        # the next segment of the same drive goes on with the tag: a GNSS gap cut the event
        cut = (stops < n) & (stops == end[seg[stops - 1]])
        cut[cut] = (drive[stops[cut]] == drive[stops[cut] - 1]) & on[stops[cut]]
        c["split_by_gnss_gap"] = int(cut.sum())
        spans: list[list[int]] = []  # [a, e, events merged in, segment]
        windows = []
        for a, e in zip(starts, stops, strict=True):
            s = seg[a]
            if a < lo_of[s]:
                c["in_adaptation_seconds"] += 1
                continue
            if hi_of[s] - lo_of[s] < L:
                c["segment_too_short"] += 1
                continue
            c["scored_events"] += 1
            c["longer_than_outage"] += int(e - a > L)
            spans.append([a, e, 1, s])
            while len(spans) >= 2 and spans[-2][3] == spans[-1][3]:
                p, q = spans[-2], spans[-1]
                sp = _span(p[0], p[1], lo_of[s], hi_of[s], L)
                sq = _span(q[0], q[1], lo_of[s], hi_of[s], L)
                if sp[1] <= sq[0]:
                    break
                spans[-2:] = [[p[0], q[1], p[2] + q[2], s]]
                c["merged"] += 1
        for a, e, _, s in spans:
            start, stop = _span(a, e, lo_of[s], hi_of[s], L)
            c["not_fully_covered"] += int(start > a or stop < e)
            windows += [start + j * L + np.arange(L) for j in range((stop - start) // L)]
        rows = np.asarray(windows, np.int64).reshape(-1, L)
        c["windows"] = len(rows)
        rows_out[tag] = rows
        counts.append({"tag": tag, **c})
    table = pd.DataFrame(counts, columns=["tag", *EVENT_COUNTS])
    return ScenarioWindows(L, rows_out, table)


def scenario_outage_scores(
    windows: ScenarioWindows, errors: Mapping[str, np.ndarray]
) -> list[dict]:
    """Mean CRSE and CTE over each tag's windows, per model, for one seed.

    Args:
        windows: :func:`scenario_windows`.
        errors: per model, its per-second error on every row of the frame the
            windows were placed on (NaN where it has none).

    Returns:
        One row per tag and model: ``tag, model, crse, cte, n_windows`` (the
        windows where the model has an error every second; NaN means without any).
    """
    out = []
    for tag, rows in windows.rows.items():
        if not len(rows):
            continue
        for model, e in errors.items():
            ew = e[rows]
            ok = ~np.isnan(ew).any(axis=1)
            ew = ew[ok]
            out.append(
                {
                    "tag": tag,
                    "model": model,
                    "crse": float(np.abs(ew).sum(axis=1).mean()) if len(ew) else math.nan,
                    "cte": float(np.abs(ew.sum(axis=1)).mean()) if len(ew) else math.nan,
                    "n_windows": int(ok.sum()),
                }
            )
    return out


def scenario_outage_summary(per_seed: pd.DataFrame, counts: pd.DataFrame) -> pd.DataFrame:
    """Per tag and model: mean CRSE and CTE over seeds with their 95 % half-widths.

    Args:
        per_seed: :func:`scenario_outage_scores` rows with a ``seed`` column.
        counts: :attr:`ScenarioWindows.counts`, for the order of the tags (most
            windows first, then by name).

    Returns:
        ``tag, model, crse, crse_ci95, cte, cte_ci95, n_seeds, n_windows``.
    """
    if per_seed.empty:
        return pd.DataFrame(
            columns=["tag", "model", "crse", "crse_ci95", "cte", "cte_ci95", "n_seeds", "n_windows"]
        )
    out = over_seeds(per_seed, ["tag", "model"], ["crse", "cte"])
    n = per_seed.groupby(["tag", "model"], sort=False)["n_windows"].first()
    out = out.join(n, on=["tag", "model"])
    order = counts.sort_values(["windows", "tag"], ascending=[False, True])["tag"].tolist()
    rank = {t: i for i, t in enumerate(order)}
    key = out["tag"].map(rank)
    return out.assign(_rank=key).sort_values("_rank", kind="stable").drop(columns="_rank")
