"""Every seed trained at once gives each seed the weights and history of its own fit()."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from rwhonet.config import ModelParams, TrainerParams, TrainParams
from rwhonet.models.train import fit
from rwhonet.models.vectorised import fit_seeds, supports

SEEDS = [42, 43, 44]


@pytest.fixture(scope="module")
def samples() -> tuple[np.ndarray, np.ndarray]:
    """1,400 windows of 16 s with a label of the present and a past second."""
    rng = np.random.default_rng(5)
    x = rng.random((1400, 16, 40), dtype=np.float32)
    y = (x[:, -1, :4].sum(1) - 0.5 * x[:, -5, 7] - 1.5).astype(np.float32)
    return x, y


# The pipeline's shapes: WhONet of paper Table 1 (72 units, one step), the tcn at hidden 72.
@pytest.mark.parametrize(
    "model",
    [
        ModelParams(hidden=72, layers=1, dropout=0.05, seq_len=1),
        ModelParams(hidden=72, layers=1, dropout=0.05, seq_len=16, arch="tcn", channels=16),
    ],
    ids=["whonet", "tcn"],
)
def test_each_seed_gets_the_weights_and_history_of_its_own_fit(samples, model):
    x, y = samples
    x = x[:, -model.seq_len :]
    train = TrainParams(epochs=2, batch_size=64, lr=0.005, val_fraction=0.1, num_threads=1)
    together = fit_seeds(
        x[200:], y[200:], x[:200], y[:200], model=model, train=train, seeds=SEEDS, steps_per_block=3
    )
    assert [f.seed for f in together.fits] == SEEDS and together.samples_per_s > 0
    weights = []
    for f in together.fits:
        alone = fit(x[200:], y[200:], x[:200], y[:200], model=model, train=train, seed=f.seed)
        for (name, a), b in zip(
            alone.module.net.state_dict().items(), f.net.state_dict().values(), strict=True
        ):
            assert torch.equal(a, b), (f.seed, name)
        assert f.history == alone.history  # the same MAE per epoch, train and validation
        assert not f.net.training and f.hparams["arch"] == model.arch
        weights.append(f.net.head.weight.detach().clone())
    assert not torch.equal(weights[0], weights[1])  # the seeds do differ


def test_networks_without_a_batching_rule_and_other_trainers_are_refused(samples):
    x, y = samples
    train = TrainParams(epochs=1, batch_size=64, lr=0.005, val_fraction=0.1, num_threads=1)
    gru = ModelParams(hidden=8, layers=1, dropout=0.0, seq_len=4, arch="gru")
    deep = ModelParams(hidden=8, layers=1, dropout=0.0, seq_len=4)  # WhONet over 4 s: nn.RNN
    assert not supports(gru) and not supports(deep)
    for model in (gru, deep):
        with pytest.raises(ValueError, match="one by one"):
            fit_seeds(x[:, -4:], y, model=model, train=train, seeds=SEEDS)
    whonet = ModelParams(hidden=8, layers=1, dropout=0.0, seq_len=1)
    ddp = replace(train, trainer=TrainerParams(devices=2, strategy="ddp"))
    with pytest.raises(ValueError, match="one CPU process"):
        fit_seeds(x[:, -1:], y, model=whonet, train=ddp, seeds=SEEDS)
    with pytest.raises(ValueError, match="distinct"):
        fit_seeds(x[:, -1:], y, model=whonet, train=train, seeds=[1, 1])
