"""Stacking the label stage's segments into model arrays."""

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.features.samples import split_tail
from rwhonet.stages.sample_files import load_role


def test_load_role_orders_and_ranks_per_drive(samples_dir):
    data = load_role(samples_dir, "target_test", seq_len=1)
    assert data.x.shape == (900, 1, 40) and data.x.dtype == np.float32
    assert data.drives == ["A", "B"]
    f = data.frame
    assert list(f.loc[f.drive == "A", "k"]) == list(range(500))
    assert list(f.loc[f.drive == "B", "k"]) == list(range(400))
    assert np.array_equal(data.y, f["label_m"].to_numpy(np.float32))


def test_sequences_keep_every_second_of_each_segment(samples_dir):
    data = load_role(samples_dir, "target_test", seq_len=3)
    assert data.x.shape == (900, 3, 40)
    # the last step of every window is the sample's own second
    one = load_role(samples_dir, "target_test", seq_len=1)
    key = one.frame.set_index(["segment", "t_s"]).index
    pos = key.get_indexer(data.frame.set_index(["segment", "t_s"]).index)
    assert np.array_equal(data.x[:, -1], one.x[pos, 0])


def test_split_tail_holds_out_end_of_each_segment(samples_dir):
    data = load_role(samples_dir, "target_test", seq_len=1)
    train, val = split_tail(data, 0.1)
    assert len(val) == 30 + 20 + 40 and len(train) + len(val) == len(data)
    for seg, g in val.frame.groupby("segment"):
        last_train = train.frame.loc[train.frame.segment == seg, "t_s"].max()
        assert g["t_s"].min() > last_train


def test_missing_role_is_an_input_error(samples_dir):
    with pytest.raises(InputError, match="source_train"):
        load_role(samples_dir, "source_train", seq_len=1)
