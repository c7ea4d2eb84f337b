"""Sequences of consecutive seconds for the RNN (paper Table 1: sequence length).

A window ending at second ``i`` holds seconds ``i - seq_len + 1 .. i``, oldest
first, and is labelled with second ``i``'s target. Windows never cross a group
boundary (a segment: seconds on either side of a GNSS cut are not consecutive),
so the first ``seq_len - 1`` seconds of each group have no window and are dropped.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view


def sequences(x: np.ndarray, seq_len: int, group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cut per-second rows into windows of ``seq_len`` consecutive seconds within a group.

    Args:
        x: ``(N, F)`` per-second features, rows in time order within each group.
        seq_len: number of seconds per window (>= 1).
        group: ``(N,)`` group (segment) id per row; a group is a run of equal
            consecutive ids (an id that reappears later starts a new group).

    Returns:
        ``(windows, kept_index)``: ``windows`` is a new ``(N', seq_len, F)``
        array with ``windows[j, -1] == x[kept_index[j]]``; ``kept_index`` is the
        int64 row index of each window's last second.

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
    n, f = x.shape
    if n < seq_len:
        return np.empty((0, seq_len, f), dtype=x.dtype), np.empty(0, dtype=np.int64)
    # Run id: increments wherever the group changes, so a window stays in one run
    # exactly when its first and last rows have the same run id.
    run = np.concatenate([[0], np.cumsum(group[1:] != group[:-1])])
    last = np.arange(seq_len - 1, n, dtype=np.int64)
    kept = last[run[last] == run[last - seq_len + 1]]
    # sliding_window_view over axis 0 gives (N - seq_len + 1, F, seq_len), a view;
    # window w ends at row w + seq_len - 1. Indexing copies only the kept windows.
    view = sliding_window_view(x, seq_len, axis=0)
    return np.ascontiguousarray(view[kept - seq_len + 1].transpose(0, 2, 1)), kept
