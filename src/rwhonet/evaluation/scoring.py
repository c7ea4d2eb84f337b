"""Where a window is scored: CRSE and CTE per outage window, and their summaries (§3.2, §3.5).

The windows are :mod:`rwhonet.evaluation.windows`' (consecutive, non-overlapping,
never across a GNSS gap). Per window, with ``e_t`` the per-second displacement
error (label − prediction for a network, the label itself for WPM alone):

- CRSE = Σ_t |e_t|  (Eq. 16: Σ sqrt(e_t²))
- CTE  = |Σ_t e_t|  (Eq. 17 writes the signed sum; the authors' code and every
  table of the paper report its absolute value, so we do too)
- distance = Σ_t GNSS displacement (how far the vehicle went in the window).

Across windows: max, min, mean (Eq. 18) and population standard deviation
(Eq. 19, divided by N_s: ddof = 0), the rows of the paper's Tables 3-10.
Everything is vectorised over windows (one gather of shape (W, L)).
:func:`score_seed` applies this to every model, outage length and drive of
one training seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.errors import InputError, Problem
from rwhonet.evaluation.windows import MAX_PROBLEMS, window_starts

STATS = ("max", "min", "mean", "std")
QUANTITIES = ("crse_m", "cte_m", "distance_m")
SEED_VALUES = [f"{q}_{s}" for q in ("crse", "cte") for s in STATS]  # a summary row's scores
_SHORT = {"crse_m_": "crse_", "cte_m_": "cte_", "distance_m_": "dist_"}
CURVE_MODELS = ("WPM", "G", "S", "R")  # the models whose CRSE/CTE evolution is plotted

# Per model, its per-second error (label − prediction; NaN where it does not apply), or
# for a model whose predictions depend on the window (R[continuous]) one per outage length.
Errors = dict[str, "np.ndarray | dict[int, np.ndarray]"]


def window_metrics(
    e_m: Any, disp_gnss_m: Any, group: Any, outage_s: int, *, source: str = "<errors>"
) -> pd.DataFrame:
    """CRSE, CTE and distance of every outage window (paper Eqs. 16-17).

    Args:
        e_m: (N,) per-second displacement error in metres (label − prediction,
            or the label alone for WPM), in time order within each group.
        disp_gnss_m: (N,) GNSS displacement of each second in metres.
        group: (N,) group id (segment); windows never cross groups.
        outage_s: outage length L in seconds.
        source: name of the data, used in error messages.

    Returns:
        One row per window: ``window`` (0-based), ``group`` (its id),
        ``start`` (index of its first sample in the inputs), ``crse_m``,
        ``cte_m`` (absolute, see the module docstring), ``distance_m``.

    Raises:
        InputError: on mismatched lengths, non-finite values or unsorted groups.
    """
    e, d, g = _check(e_m, disp_gnss_m, group, source)
    start, _ = window_starts(g, outage_s)
    idx = start[:, None] + np.arange(int(outage_s))  # (W, L) sample indices
    e_w = e[idx]
    return pd.DataFrame(
        {
            "window": np.arange(len(start)),
            "group": g[start],
            "start": start,
            "crse_m": np.abs(e_w).sum(axis=1),
            "cte_m": np.abs(e_w.sum(axis=1)),
            "distance_m": d[idx].sum(axis=1),
        }
    )


def window_evolution(
    e_m: Any, group: Any, outage_s: int, *, source: str = "<errors>"
) -> pd.DataFrame:
    """How CRSE and CTE build up over the seconds of each window (paper Figs. 5-12).

    Args:
        e_m: (N,) per-second displacement error in metres.
        group: (N,) group id; windows as in :func:`window_metrics`.
        outage_s: outage length L in seconds.
        source: name of the data, used in error messages.

    Returns:
        Long format, W x L rows: ``window``, ``second`` (1..L into the outage),
        ``crse_m`` (Σ |e| so far) and ``cte_signed_m`` (Σ e so far, signed, so
        over- and under-estimation show; its absolute value at ``second == L``
        is the window's ``cte_m``).
    """
    e, _, g = _check(e_m, None, group, source)
    start, _ = window_starts(g, outage_s)
    L = int(outage_s)
    e_w = e[start[:, None] + np.arange(L)]
    return pd.DataFrame(
        {
            "window": np.repeat(np.arange(len(start)), L),
            "second": np.tile(np.arange(1, L + 1), len(start)),
            "crse_m": np.cumsum(np.abs(e_w), axis=1).ravel(),
            "cte_signed_m": np.cumsum(e_w, axis=1).ravel(),
        }
    )


def summarise(windows: pd.DataFrame) -> dict[str, Any]:
    """Max, min, mean and population std of CRSE, CTE and distance across windows (Eqs. 18-19).

    Args:
        windows: output of :func:`window_metrics` (several drives may be concatenated).

    Returns:
        ``{"n_windows": W, "crse_m_max": .., "crse_m_min": .., "crse_m_mean": ..,
        "crse_m_std": .., "cte_m_...": .., "distance_m_...": ..}``; the statistics
        are None when there is no window (a drive shorter than the outage).
    """
    out: dict[str, Any] = {"n_windows": len(windows)}
    for q in QUANTITIES:
        v = windows[q].to_numpy(np.float64)
        stats = (
            dict.fromkeys(STATS)
            if len(v) == 0
            else {"max": v.max(), "min": v.min(), "mean": v.mean(), "std": v.std(ddof=0)}
        )
        out.update({f"{q}_{s}": None if x is None else float(x) for s, x in stats.items()})
    return out


def _check(
    e_m: Any, disp_gnss_m: Any | None, group: Any, source: str
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Return float64 errors and displacements and the group ids; raise InputError if unfit."""
    e = np.asarray(e_m, dtype=np.float64)
    d = None if disp_gnss_m is None else np.asarray(disp_gnss_m, dtype=np.float64)
    g = np.asarray(group)
    problems = []
    for name, a in (("e_m", e), ("disp_gnss_m", d), ("group", g)):
        if a is not None and (a.ndim != 1 or len(a) != len(e)):
            problems.append(
                Problem(source, None, name, f"a 1-D array of {len(e)} values", f"{a.shape}")
            )
    if problems:
        raise InputError(problems, f"{source}: arrays of different shapes")
    for name, a in (("e_m", e), ("disp_gnss_m", d)):
        if a is None:
            continue
        bad = np.flatnonzero(~np.isfinite(a))
        problems += [
            Problem(source, int(i) + 1, name, "a finite number of metres", str(a[i]))
            for i in bad[:MAX_PROBLEMS]
        ]
    if problems:
        raise InputError(problems, f"{source}: non-finite errors or displacements")
    return e, d, g


def _stats(windows: pd.DataFrame) -> dict[str, Any]:
    """:func:`summarise` with the short keys of the summary table (crse_mean, dist_std...)."""
    out = {}
    for key, value in summarise(windows).items():
        for long, short in _SHORT.items():
            key = key.replace(long, short)
        out[key] = value
    return out


def score_seed(
    frame: pd.DataFrame, errors: Errors, outages_s: list[int]
) -> tuple[list[dict], list[pd.DataFrame], list[dict]]:
    """Windows of every model and outage on the evaluated rows of one training seed.

    Args:
        frame: the evaluated seconds (``drive, role, group, k, disp_gnss_m``).
        errors: every model's per-second error on those rows (:data:`Errors`).
        outages_s: the outage lengths L.

    Returns:
        Summary rows (per role and drive, and ``all`` per role), the mean CRSE/CTE
        curves over a window's seconds (:data:`CURVE_MODELS`, target test drives),
        and per window its CRSE with the seconds into the drive it starts at
        (target test drives, for CRSE against time).
    """
    rows, curves, timeline = [], [], []
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    group = frame["group"].to_numpy()
    drive = frame["drive"].to_numpy()
    role = frame["role"].to_numpy()
    rank = frame["k"].to_numpy()
    for model, per_model in errors.items():
        for L in outages_s:
            err = per_model[L] if isinstance(per_model, dict) else per_model
            scored = ~np.isnan(err)
            windows = window_metrics(err[scored], gnss[scored], group[scored], L)
            start = windows["start"].to_numpy()
            w_drive, w_role = drive[scored][start], role[scored][start]
            cells = [(r, "all", w_role == r) for r in dict.fromkeys(role[scored])]
            cells += [
                (r, d, w_drive == d) for r, d in dict.fromkeys(zip(w_role, w_drive, strict=True))
            ]
            for r, d, mask in cells:
                rows.append(
                    {"role": r, "drive": d, "model": model, "outage_s": L, **_stats(windows[mask])}
                )
            target = w_role == k.TARGET_TEST
            timeline += [
                {"model": model, "outage_s": L, "start_s": int(t), "crse": float(c)}
                for t, c in zip(rank[scored][start][target], windows["crse_m"][target], strict=True)
            ]
            if model in CURVE_MODELS:
                on = scored & (role == k.TARGET_TEST)
                evo = window_evolution(err[on], group[on], L)
                evo["cte_m"] = evo["cte_signed_m"].abs()
                mean = evo.groupby("second")[["crse_m", "cte_m"]].mean().reset_index()
                curves.append(mean.assign(outage_s=L, model=model))
    return rows, curves, timeline
