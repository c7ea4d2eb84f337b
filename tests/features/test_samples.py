"""Stacking labelled segments into model inputs (rwhonet.features.samples)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts as k
from rwhonet.features.samples import stack_segments


def _segment(start_id: int, n: int, shuffled: bool) -> pd.DataFrame:
    """``n`` seconds whose first feature is a row id (``start_id`` on), rows maybe out of order."""
    rng = np.random.default_rng(start_id)
    frame = pd.DataFrame(
        rng.uniform(0, 1, (n, len(k.SAMPLE_COLUMNS) - 1)), columns=k.SAMPLE_COLUMNS[:-1]
    )
    frame[k.SCENARIO] = ""
    frame["t_s"] = 100.0 + np.arange(1, n + 1)
    frame[k.FEATURE_COLUMNS[0]] = start_id + np.arange(n)
    return frame.sample(frac=1.0, random_state=1) if shuffled else frame


@pytest.mark.parametrize("seq_len", [1, 3])
def test_segments_stack_in_the_given_order_and_windows_never_cross_them(seq_len):
    segments = [
        ({"drive": "B", "segment": "B__s000", "role": "target_test"}, _segment(0, 8, True)),
        ({"drive": "A", "segment": "A__s000", "role": "target_test"}, _segment(100, 5, False)),
        ({"drive": "A", "segment": "A__s001", "role": "target_test"}, _segment(200, 6, True)),
    ]
    data = stack_segments(segments, seq_len)
    kept = [8, 5, 6]  # every second, however long the windows
    assert data.x.shape == (sum(kept), seq_len, k.N_FEATURES) and data.x.dtype == np.float32
    assert data.drives == ["B", "A"]
    assert list(data.frame["group"]) == [0] * kept[0] + [1] * kept[1] + [2] * kept[2]
    # each window: consecutive seconds of one segment, in time order, ending at its own;
    # a segment's first seconds are padded with that segment's first second
    ids = data.x[:, :, 0]
    assert np.all(np.diff(ids, axis=1) >= 0) and np.all(np.diff(ids, axis=1) <= 1)
    assert np.all(ids[:, 0] // 100 == ids[:, -1] // 100)
    rank = data.frame.groupby("group").cumcount().to_numpy()
    assert np.array_equal(ids[:, -1] - ids[:, 0], np.minimum(rank, seq_len - 1))
    for _, seg in data.frame.groupby("group"):
        assert np.all(np.diff(seg["t_s"].to_numpy()) == 1.0)  # shuffled rows come back sorted
    # k: the rank of the sample in its drive, across its segments
    assert list(data.frame.loc[data.frame.drive == "A", "k"]) == list(range(kept[1] + kept[2]))
    assert np.array_equal(data.y, data.frame[k.LABEL_M].to_numpy(np.float32))


def test_no_samples_stack_into_an_empty_set():
    data = stack_segments([], seq_len=1)
    assert len(data) == 0 and data.x.shape[0] == 0 and data.drives == []
