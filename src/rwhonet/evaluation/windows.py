"""Which seconds are scored, and how they are cut into outage windows (paper §3.5).

A test drive's seconds are cut into consecutive, non-overlapping windows of L
seconds (an "outage" of L s), never across a gap in the drive (``group``: one
GNSS-valid segment), the trailing remainder of each group dropped.

Every model (every recipe and m, and the continuous recipe's recalibrations)
is scored on the same seconds and the same windows: those after the first
``max(adapt.m_grid)`` seconds of each drive, so no R-WhONet is scored on a
second it was adapted on. The adapt stage imports this module too: the
continuous recipe must know the windows in advance to recalibrate before each.
How a window is scored (CRSE, CTE) is :mod:`rwhonet.evaluation.scoring`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.errors import InputError, Problem

MAX_PROBLEMS = 20


def window_starts(
    group: Any, outage_s: int, stride_s: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Start indices of the ``outage_s``-second windows of every group.

    Args:
        group: (N,) group id per second (any dtype); each group must be one
            contiguous run (samples sorted by group, then time).
        outage_s: window length L in seconds (= samples, one per second).
        stride_s: seconds from one window's start to the next (default L: consecutive,
            non-overlapping windows, the paper's; shorter: overlapping ones).

    Returns:
        ``(start, run)``: (W,) index of each window's first sample, in input
        order, and (W,) index of the run (0, 1, ... in order of appearance)
        the window belongs to.

    Raises:
        ValueError: when ``outage_s`` or ``stride_s`` is not a positive integer.
        InputError: when a group id appears in more than one run.
    """
    if isinstance(outage_s, bool) or int(outage_s) != outage_s or outage_s < 1:
        raise ValueError(f"outage_s must be a positive whole number of seconds, got {outage_s!r}")
    L = int(outage_s)
    step = L if stride_s is None else int(stride_s)
    if isinstance(stride_s, bool) or step != (stride_s or L) or step < 1:
        raise ValueError(f"stride_s must be a positive whole number of seconds, got {stride_s!r}")
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
    n_win = np.maximum(run_len - L, -1) // step + 1  # the remainder of each group is dropped
    run = np.repeat(np.arange(len(run_start)), n_win)
    # k-th window of its run: position in the flat list minus the run's first window.
    first = np.cumsum(n_win) - n_win
    k = np.arange(n_win.sum()) - np.repeat(first, n_win)
    return run_start[run] + step * k, run


def evaluated_rows(frame: pd.DataFrame, m_grid: list[int]) -> np.ndarray:
    """Which test seconds are scored: those after the first ``max(m_grid)`` of each drive.

    Every model (and every m, and the continuous recipe) is scored on these
    same seconds, so no R-WhONet is scored on a second it was adapted on.
    """
    return frame["k"].to_numpy() >= max(m_grid)


def outage_windows(frame: pd.DataFrame, m_grid: list[int], outage_s: int) -> np.ndarray:
    """The rows of every outage window the evaluation scores, (W, outage_s) indices into ``frame``.

    Consecutive, non-overlapping windows over each segment's evaluated seconds
    (:func:`window_starts`), the remainder dropped.
    """
    rows = np.flatnonzero(evaluated_rows(frame, m_grid))
    start, _ = window_starts(frame["group"].to_numpy()[rows], outage_s)
    return rows[start[:, None] + np.arange(outage_s)]


def evaluated_seconds(frame: pd.DataFrame, m_grid: list[int], outages_s: list[int]) -> np.ndarray:
    """Which rows are scored (:func:`evaluated_rows`), after checking the drives are long enough.

    A drive shorter than an outage length simply has no window of it (validate
    asks every target test drive for max(m) + the shortest outage); but every
    outage length must have a window on some target test drive.

    Raises:
        InputError: a test drive has fewer than the shortest outage left to score,
            or no target test drive is long enough for an outage length.
    """
    skip = max(m_grid)
    evaluated = evaluated_rows(frame, m_grid)
    shortest, longest = min(outages_s), max(outages_s)
    left = pd.Series(evaluated).groupby(frame["drive"].to_numpy(), sort=False).sum()
    short = [
        Problem(
            d,
            None,
            None,
            f"at least {shortest} s after the first {skip} s",
            f"{int(n)} s",
            fix="drop the drive, or shorten adapt.m_grid / evaluate.outages_s",
        )
        for d, n in left.items()
        if n < shortest
    ]
    if short:
        raise InputError(short, "test drives too short to evaluate the shortest outage")
    roles = frame["role"].to_numpy()
    target_max = left[pd.unique(frame["drive"].to_numpy()[roles == k.TARGET_TEST])].max()
    if not target_max >= longest:
        raise InputError(
            [
                Problem(
                    "target test drives",
                    None,
                    None,
                    f"one with at least {longest} s after the first {skip} s",
                    f"the longest has {int(target_max) if target_max == target_max else 0} s",
                    fix=f"drop {longest} from evaluate.outages_s, or add longer drives",
                )
            ],
            "no target test drive is long enough for the longest outage",
        )
    return evaluated
