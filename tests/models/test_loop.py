"""The training algorithm (rwhonet.models.loop): what a step does, and that it learns."""

from __future__ import annotations

import random

import numpy as np
import pytest
import torch

from rwhonet.errors import InputError
from rwhonet.models.freeze import apply_trainable
from rwhonet.models.loop import (
    ArrayDataset,
    EpochLoss,
    batch_mae,
    make_optimizer,
    predict,
    seed_all,
    train_block,
    train_epoch,
    train_loader,
)
from rwhonet.models.module import WhONetModule
from rwhonet.models.whonet import WhONet


def test_a_known_linear_target_is_learned_and_the_loss_decreases(linear_data):
    x, y = linear_data
    seed_all(0)
    net = WhONet(hidden=32, dropout=0.0)
    opt = make_optimizer(net, lr=0.01)
    loader = train_loader(ArrayDataset(x, y), batch_size=32, seed=0)
    start = float(np.mean(np.abs(predict(net, x) - y)))
    losses = [train_epoch(net.train(), opt, loader, 32) for _ in range(40)]
    assert losses[-1] < losses[9] < losses[0]
    end = float(np.mean(np.abs(predict(net, x) - y)))
    spread = float(np.mean(np.abs(y - np.median(y))))  # what a constant would score
    assert end < 0.15 * spread < start


def test_train_block_steps_once_per_slice_in_order():
    torch.manual_seed(0)
    net = WhONet(n_features=3, hidden=4, dropout=0.0)
    opt = make_optimizer(net, lr=0.01)
    x, y = torch.rand(37, 1, 3), torch.rand(37)
    first_loss = batch_mae(net, x[:16], y[:16]).detach()
    losses = EpochLoss()
    train_block(net, opt, x, y, 16, losses)
    assert losses.sizes == [16, 16, 5]  # ceil(37 / 16) slices, the last one partial
    assert torch.equal(losses.losses[0], first_loss)  # each loss is taken before its step
    stepped = [p for p in net.parameters() if p is not net.rnn.weight_hh_l0]
    assert all(int(opt.state[p]["step"]) == 3 for p in stepped)
    assert net.rnn.weight_hh_l0 not in opt.state  # one time step: U_h never gets a gradient


def test_frozen_parameters_are_left_out_of_the_optimizer():
    net = WhONet(hidden=3)
    apply_trainable(net, "head")
    params = make_optimizer(net, 0.002).param_groups[0]["params"]
    assert [id(p) for p in params] == [id(net.head.weight), id(net.head.bias)]


def test_epoch_loss_is_sample_weighted_mean():
    acc = EpochLoss()
    acc.add(torch.tensor(1.0), 3)
    acc.add(torch.tensor(4.0, requires_grad=True), 1)
    assert acc.pop_mean() == pytest.approx((3 * 1.0 + 1 * 4.0) / 4)
    assert acc.pop_mean() is None  # reset for the next epoch


def test_seed_all_seeds_python_numpy_and_torch():
    def draws() -> tuple:
        return random.random(), np.random.random(), torch.rand(3).tolist()  # noqa: NPY002

    seed_all(1234)
    first = draws()
    seed_all(1234)
    assert draws() == first
    for bad in (-1, 2**32):
        with pytest.raises(ValueError):
            seed_all(bad)


def test_predict_checks_a_bare_networks_inputs(linear_data):
    x, _ = linear_data
    net = WhONet(hidden=4)
    assert predict(net, x[:5], seq_len=1).shape == (5,)
    with pytest.raises(InputError, match="40 features"):
        predict(net, x[:5, :, :30])
    with pytest.raises(InputError, match="2 time steps"):
        predict(net, x[:5], seq_len=2)
    module = WhONetModule(hidden=8, dropout=0.5)
    module.train()
    whole = predict(module, x, batch_size=10_000)
    assert whole.shape == (len(x),) and whole.dtype == np.float32
    np.testing.assert_allclose(predict(module, x, batch_size=7), whole, rtol=0, atol=1e-6)
    assert module.training  # restored
    assert predict(module, x[:0]).shape == (0,)


@pytest.mark.parametrize("n", [1000, 1001, 1003])
def test_shards_of_two_processes_are_the_mini_batches_of_one_at_twice_the_batch(n):
    data = ArrayDataset(np.arange(n, dtype=np.float32).reshape(n, 1, 1), np.zeros(n))

    def batches(batch_size, rank=0, world_size=1):
        loader = train_loader(
            data, batch_size=batch_size, seed=3, steps_per_block=4, rank=rank, world_size=world_size
        )
        epochs = []
        for _ in range(2):  # the generator advances between epochs in every process alike
            ids = [int(v) for x, _ in loader for v in x.flatten()]
            epochs.append([ids[i : i + batch_size] for i in range(0, len(ids), batch_size)])
        return epochs

    for one, rank0, rank1 in zip(batches(64), batches(32, 0, 2), batches(32, 1, 2), strict=True):
        merged = [sorted(a + b) for a, b in zip(rank0, rank1, strict=True)]
        # the last n % 2 samples of the epoch's permutation are left out, nothing else
        assert merged == [sorted(b) for b in one][: len(merged) - 1] + [merged[-1]]
        assert sum(map(len, merged)) == n - n % 2
        assert set(merged[-1]) <= set(one[-1])
