"""Windows of consecutive seconds: round trip, never across a segment."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.features.windows import sequences


def random_groups(rng: np.random.Generator, n_groups: int) -> np.ndarray:
    sizes = rng.integers(0, 12, n_groups)
    ids = rng.permutation(n_groups) % max(n_groups // 2, 1)  # ids may repeat non-adjacently
    return np.repeat(ids, sizes)


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("seq_len", [1, 2, 3, 7])
def test_windows_round_trip_and_stay_in_their_segment(seed, seq_len):
    rng = np.random.default_rng(seed)
    group = random_groups(rng, 8)
    x = rng.normal(size=(len(group), 5))
    run = np.concatenate([[0], np.cumsum(np.diff(group) != 0)]).astype(int) if len(group) else group
    windows, kept = sequences(x, seq_len, group)

    assert windows.shape == (len(kept), seq_len, 5)
    assert kept.dtype == np.int64
    # Round trip: a window's last step is the row it belongs to, earlier steps the rows before.
    if len(kept):
        np.testing.assert_array_equal(windows[:, -1], x[kept])
        for i in range(seq_len):
            np.testing.assert_array_equal(windows[:, i], x[kept - seq_len + 1 + i])
        # Never across a segment: every row of a window is in the same run of ids.
        rows = kept[:, None] - np.arange(seq_len)[None, :]
        assert (run[rows] == run[kept][:, None]).all()
    # Exactly the first seq_len - 1 rows of every run are dropped.
    run_sizes = np.bincount(run) if len(group) else np.array([], dtype=int)
    assert len(kept) == np.clip(run_sizes - seq_len + 1, 0, None).sum()


def test_seq_len_one_keeps_every_row_and_known_example():
    x = np.arange(12, dtype=float).reshape(6, 2)
    w, kept = sequences(x, 1, np.zeros(6))
    assert w.shape == (6, 1, 2) and kept.tolist() == list(range(6))

    group = np.array([5, 5, 5, 9, 9, 5])  # the last 5 is a new segment
    w, kept = sequences(x, 2, group)
    assert kept.tolist() == [1, 2, 4]
    np.testing.assert_array_equal(w[2], [[6, 7], [8, 9]])


def test_windows_are_writable_copies():
    x = np.zeros((4, 3), dtype=np.float32)
    w, _ = sequences(x, 2, np.zeros(4))
    w[0, 0, 0] = 1.0  # a strided view of x would be read-only
    assert x[0, 0] == 0.0 and w.dtype == np.float32 and w.flags.c_contiguous


def test_bad_arguments():
    with pytest.raises(ValueError, match="seq_len"):
        sequences(np.zeros((3, 2)), 0, np.zeros(3))
    with pytest.raises(ValueError, match="2-D"):
        sequences(np.zeros(3), 1, np.zeros(3))
    with pytest.raises(ValueError, match="group"):
        sequences(np.zeros((3, 2)), 1, np.zeros(4))
    w, kept = sequences(np.zeros((2, 4)), 3, np.zeros(2))
    assert w.shape == (0, 3, 4) and kept.shape == (0,)
