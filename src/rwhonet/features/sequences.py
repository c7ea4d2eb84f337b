"""Sequences of consecutive seconds for the network (paper Table 1: sequence length).

A window ending at second ``i`` holds seconds ``i - seq_len + 1 .. i``, oldest
first, and is labelled with second ``i``'s target. Windows never cross a group
boundary (a segment: seconds on either side of a GNSS cut are not consecutive)
and never hold a later second: where a group has fewer than ``seq_len`` seconds
up to ``i``, the window is padded at its old end with the group's first second
(the network is told nothing about what came before the group's start). So
every second gets a window, whatever ``seq_len`` is, and models of any context
length are scored on the same seconds; with ``seq_len = 1`` a window is the
second itself. :class:`LabelledWindows` holds windows with their labels, what
the networks train on and are scored on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class LabelledWindows:
    """Windows and the label of each window's last second, one sample per second.

    Attributes:
        x: (N, seq_len, n_features) float32 windows, oldest second first.
        y: (N,) labels in metres (GNSS − WPM per second, paper Eq. 11).
    """

    x: np.ndarray
    y: np.ndarray

    def __len__(self) -> int:
        return len(self.y)


def sequences(x: np.ndarray, seq_len: int, group: np.ndarray) -> np.ndarray:
    """Cut per-second rows into windows of ``seq_len`` consecutive seconds within a group.

    Args:
        x: ``(N, F)`` per-second features, rows in time order within each group.
        seq_len: number of seconds per window (>= 1).
        group: ``(N,)`` group (segment) id per row; a group is a run of equal
            consecutive ids (an id that reappears later starts a new group).

    Returns:
        A new ``(N, seq_len, F)`` array: ``windows[i, -1] == x[i]``, and
        ``windows[i, j] == x[max(i - seq_len + 1 + j, start)]`` with ``start`` the
        first row of row ``i``'s group (module docstring).

    Raises:
        ValueError: for ``seq_len < 1``, a non-2-D ``x`` or a ``group`` of another length.
    """
    x = np.asarray(x)
    group = np.asarray(group)
    if seq_len < 1:
        raise ValueError(f"seq_len must be >= 1, got {seq_len}")
    if x.ndim != 2:
        raise ValueError(f"x must be 2-D (N, F), got shape {x.shape}")
    if group.shape != (x.shape[0],):
        raise ValueError(f"group must have shape ({x.shape[0]},), got {group.shape}")
    n = x.shape[0]
    row = np.arange(n, dtype=np.int64)
    # First row of each row's run of equal ids (a run starts wherever the id changes).
    starts = np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]])) if n else row
    start = starts[np.searchsorted(starts, row, side="right") - 1] if n else row
    rows = np.maximum(row[:, None] - np.arange(seq_len - 1, -1, -1)[None, :], start[:, None])
    return np.ascontiguousarray(x[rows])
