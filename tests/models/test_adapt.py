"""R-WhONet's fine-tuning (rwhonet.models.adapt): from G, the recipe's weights, deterministic."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from rwhonet.errors import InputError
from rwhonet.models.adapt import fine_tune
from rwhonet.models.freeze import count_parameters
from rwhonet.models.loop import predict
from rwhonet.models.train import fit


@pytest.fixture(scope="module")
def g(linear_data):
    from rwhonet.config import ModelParams, TrainParams

    x, y = linear_data
    model = ModelParams(hidden=16, layers=1, dropout=0.05, seq_len=1)
    train = TrainParams(epochs=3, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)
    result = fit(x, y, model=model, train=train, seed=1)
    return result.module.net, dict(result.module.hparams)


def test_fine_tune_moves_g_towards_the_new_vehicle_and_records_the_recipe(
    g, linear_data, adapt_params
):
    net, hp = g
    x, y = linear_data
    shift = 1.5  # the new vehicle's label differs by a constant
    before_w = {k: v.clone() for k, v in net.state_dict().items()}
    before = np.mean(np.abs(predict(net, x[:50]) - (y[:50] + shift)))
    recipe = replace(adapt_params, epochs=40, lr=0.02, batch_size=16)
    r = fine_tune(net, hp, x[:50], y[:50] + shift, adapt=recipe, seed=2)
    after = np.mean(np.abs(predict(r.net, x[:50]) - (y[:50] + shift)))
    assert after < 0.5 * before
    assert len(r.history) == 40 and r.history[0]["val_loss"] is None
    assert r.history[-1]["train_loss"] < r.history[0]["train_loss"]
    assert r.hparams == {**hp, "lr": 0.02, "batch_size": 16}
    assert all(torch.equal(v, before_w[k]) for k, v in net.state_dict().items())  # G untouched


def test_fine_tuning_is_deterministic_for_a_seed(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    runs = [fine_tune(net, hp, x[:40], y[:40], adapt=adapt_params, seed=s) for s in (5, 5, 6)]
    preds = [predict(r.net, x) for r in runs]
    np.testing.assert_array_equal(preds[0], preds[1])
    assert not np.array_equal(preds[0], preds[2])  # one batch per epoch: dropout differs


def test_inputs_that_do_not_fit_g_are_refused(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    with pytest.raises(InputError, match="39"):
        fine_tune(net, hp, x[:50, :, :39], y[:50], adapt=adapt_params, seed=1)
    with pytest.raises(InputError, match="at least one sample"):
        fine_tune(net, hp, x[:0], y[:0], adapt=adapt_params, seed=1)


@pytest.mark.parametrize(
    ("policy", "frozen", "moving"), [("rnn", "head", "rnn"), ("head", "rnn", "head")]
)
def test_frozen_weights_do_not_move(g, linear_data, adapt_params, policy, frozen, moving):
    net, hp = g
    x, y = linear_data
    before = {k: v.clone() for k, v in net.state_dict().items()}
    r = fine_tune(net, hp, x[:50], y[:50] + 1.0, adapt=replace(adapt_params, trainable=policy),
                  seed=2)  # fmt: skip
    assert r.n_trainable == count_parameters(getattr(r.net, moving))[1]
    for k, v in r.net.state_dict().items():
        # With one time step h_{t-1} = 0, so U_h (weight_hh) gets no gradient and
        # never moves, trainable or not (as in the authors' one-step SimpleRNN).
        if k.startswith(frozen) or k.startswith("rnn.weight_hh"):
            assert torch.equal(v, before[k]), k
        else:
            assert not torch.equal(v, before[k]), k
