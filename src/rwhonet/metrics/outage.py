"""Position error over simulated GNSS outages: CRSE and CTE per window (paper §3.2, §3.5).

A test drive's per-second errors are cut into consecutive, non-overlapping
windows of L seconds (an "outage" of L s, paper §3.5), never across a gap in
the drive (``group``: one GNSS-valid segment), the trailing remainder of each
group dropped. Per window, with ``e_t`` the per-second displacement error
(label − prediction for a network, the label itself for WPM alone):

- CRSE = Σ_t |e_t|  (Eq. 16: Σ sqrt(e_t²))
- CTE  = |Σ_t e_t|  (Eq. 17 writes the signed sum; the authors' code and every
  table of the paper report its absolute value, so we do too)
- distance = Σ_t GNSS displacement (how far the vehicle went in the window).

Across windows: max, min, mean (Eq. 18) and population standard deviation
(Eq. 19, divided by N_s: ddof = 0), the rows of the paper's Tables 3-10.
Everything is vectorised over windows (one gather of shape (W, L)).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from rwhonet.errors import InputError, Problem

MAX_PROBLEMS = 20
STATS = ("max", "min", "mean", "std")
QUANTITIES = ("crse_m", "cte_m", "distance_m")


def window_starts(group: Any, outage_s: int) -> tuple[np.ndarray, np.ndarray]:
    """Start indices of the non-overlapping ``outage_s``-second windows of every group.

    Args:
        group: (N,) group id per second (any dtype); each group must be one
            contiguous run (samples sorted by group, then time).
        outage_s: window length L in seconds (= samples, one per second).

    Returns:
        ``(start, run)``: (W,) index of each window's first sample, in input
        order, and (W,) index of the run (0, 1, ... in order of appearance)
        the window belongs to.

    Raises:
        ValueError: when ``outage_s`` is not a positive integer.
        InputError: when a group id appears in more than one run.
    """
    if isinstance(outage_s, bool) or int(outage_s) != outage_s or outage_s < 1:
        raise ValueError(f"outage_s must be a positive whole number of seconds, got {outage_s!r}")
    L = int(outage_s)
    g = np.asarray(group)
    n = len(g)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    run_start = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    ids = g[run_start]
    if len(pd.unique(ids)) != len(ids):
        repeated = pd.Series(ids)[pd.Series(ids).duplicated()].unique()
        problems = [
            Problem(
                "<group ids>",
                int(run_start[np.flatnonzero(ids == gid)[1]]) + 1,
                "group",
                "each group's samples contiguous (sorted by group, then time)",
                f"group {gid!r} starts again here",
            )
            for gid in repeated[:MAX_PROBLEMS]
        ]
        raise InputError(problems, "samples are not sorted by group")
    run_len = np.diff(np.r_[run_start, n])
    n_win = run_len // L  # the remainder of each group is dropped
    run = np.repeat(np.arange(len(run_start)), n_win)
    # k-th window of its run: position in the flat list minus the run's first window.
    first = np.cumsum(n_win) - n_win
    k = np.arange(n_win.sum()) - np.repeat(first, n_win)
    return run_start[run] + L * k, run


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
