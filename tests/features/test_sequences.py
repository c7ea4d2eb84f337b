"""Windows of consecutive seconds: every second gets one, never across a segment or ahead."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.features.sequences import sequences


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
    windows = sequences(x, seq_len, group)

    # Every second has a window, ending at the second itself.
    assert windows.shape == (len(group), seq_len, 5)
    np.testing.assert_array_equal(windows[:, -1], x)
    for i in range(len(group)):
        first = int(np.flatnonzero(run == run[i])[0])  # the first row of i's segment
        for j in range(seq_len):
            # step j holds second i - (seq_len - 1 - j), or the segment's first second
            np.testing.assert_array_equal(windows[i, j], x[max(i - (seq_len - 1 - j), first)])


def test_a_later_second_or_another_segment_never_reaches_a_window():
    rng = np.random.default_rng(0)
    group = np.repeat([3, 1, 3], [6, 4, 7])
    x = rng.normal(size=(len(group), 4))
    before = sequences(x, 5, group)
    for i in range(len(group)):
        changed = x.copy()
        changed[i + 1 :] += 100.0  # every later second
        run = np.concatenate([[0], np.cumsum(np.diff(group) != 0)])
        changed[run != run[i]] -= 50.0  # every other segment
        np.testing.assert_array_equal(sequences(changed, 5, group)[i], before[i])


def test_known_example():
    x = np.arange(12, dtype=float).reshape(6, 2)
    w = sequences(x, 1, np.zeros(6))
    assert w.shape == (6, 1, 2)
    np.testing.assert_array_equal(w[:, 0], x)

    group = np.array([5, 5, 5, 9, 9, 5])  # the last 5 is a new segment
    w = sequences(x, 2, group)
    np.testing.assert_array_equal(w[0], [[0, 1], [0, 1]])  # padded with its own first second
    np.testing.assert_array_equal(w[2], [[2, 3], [4, 5]])
    np.testing.assert_array_equal(w[3], [[6, 7], [6, 7]])  # a new segment starts again
    np.testing.assert_array_equal(w[4], [[6, 7], [8, 9]])
    np.testing.assert_array_equal(w[5], [[10, 11], [10, 11]])


def test_windows_are_writable_copies():
    x = np.zeros((4, 3), dtype=np.float32)
    w = sequences(x, 2, np.zeros(4))
    w[0, 0, 0] = 1.0  # a strided view of x would be read-only
    assert x[0, 0] == 0.0 and w.dtype == np.float32 and w.flags.c_contiguous


def test_bad_arguments():
    with pytest.raises(ValueError, match="seq_len"):
        sequences(np.zeros((3, 2)), 0, np.zeros(3))
    with pytest.raises(ValueError, match="2-D"):
        sequences(np.zeros(3), 1, np.zeros(3))
    with pytest.raises(ValueError, match="group"):
        sequences(np.zeros((3, 2)), 1, np.zeros(4))
    assert sequences(np.zeros((2, 4)), 3, np.zeros(2)).shape == (2, 3, 4)
    assert sequences(np.zeros((0, 4)), 3, np.zeros(0)).shape == (0, 3, 4)
