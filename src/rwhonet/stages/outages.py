"""The seconds and outage windows the evaluation scores, shared by adapt and evaluate.

Every model (every recipe and m, and the continuous recipe's recalibrations)
is scored on the same seconds and the same windows; the continuous recipe
must know them in advance to recalibrate before each window.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rwhonet.metrics.outage import window_starts


def evaluated_rows(frame: pd.DataFrame, m_grid: list[int]) -> np.ndarray:
    """Which test seconds are scored: those after the first ``max(m_grid)`` of each drive.

    Every model (and every m, and the continuous recipe) is scored on these
    same seconds, so no R-WhONet is scored on a second it was adapted on.
    """
    return frame["k"].to_numpy() >= max(m_grid)


def outage_windows(frame: pd.DataFrame, m_grid: list[int], outage_s: int) -> np.ndarray:
    """The rows of every outage window the evaluation scores, (W, outage_s) indices into ``frame``.

    Consecutive, non-overlapping windows over each segment's evaluated seconds
    (:func:`rwhonet.metrics.outage.window_starts`), the remainder dropped.
    """
    rows = np.flatnonzero(evaluated_rows(frame, m_grid))
    start, _ = window_starts(frame["group"].to_numpy()[rows], outage_s)
    return rows[start[:, None] + np.arange(outage_s)]
