"""Training entry points: learning, determinism, prediction, fine-tuning, input errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.models.train import fit, predict


def test_a_tiny_fit_learns_a_linear_label(linear_data, model_params, train_params):
    x, y = linear_data
    recipe = replace(train_params, epochs=6, lr=0.03, batch_size=32)
    result = fit(x[:1000], y[:1000], x[1000:], y[1000:], model=model_params, train=recipe, seed=0)
    losses = [h["train_loss"] for h in result.history]
    assert len(losses) == 6
    assert losses[-1] < 0.5 * losses[0]
    baseline = np.mean(np.abs(y[1000:] - np.median(y[:1000])))  # best constant predictor
    assert result.history[-1]["val_loss"] < 0.5 * baseline
    assert result.seconds > 0 and result.samples_per_s > 0
    n_weights = sum(p.numel() for p in result.module.parameters())
    assert result.n_trainable == result.n_total == n_weights


def test_same_seed_same_predictions(linear_data, model_params, train_params):
    x, y = linear_data
    runs = [fit(x, y, model=model_params, train=train_params, seed=s) for s in (3, 3, 4)]
    preds = [predict(r.module, x) for r in runs]
    np.testing.assert_array_equal(preds[0], preds[1])
    assert runs[0].history == runs[1].history
    assert not np.array_equal(preds[0], preds[2])


def test_bad_training_inputs_name_what_is_wrong(linear_data, model_params, train_params):
    x, y = linear_data
    with pytest.raises(InputError) as err:
        fit(np.repeat(x, 2, axis=1), y, model=model_params, train=train_params, seed=0)
    assert err.value.problems[0].column == "x"
    assert "time steps" in err.value.problems[0].expected
    with pytest.raises(InputError) as err:
        fit(x, y[:-1], model=model_params, train=train_params, seed=0)
    assert err.value.problems[0].column == "y"
    bad = x.copy()
    bad[[4, 9], 0, 3] = np.nan
    with pytest.raises(InputError) as err:
        fit(bad, y, model=model_params, train=train_params, seed=0)
    assert [p.row for p in err.value.problems] == [5, 10]  # 1-based sample rows
    y_bad = y.copy()
    y_bad[0] = np.inf
    with pytest.raises(InputError) as err:
        fit(x, y, x[:5], y_bad[:5], model=model_params, train=train_params, seed=0)
    assert err.value.problems[0].file == "validation samples"
    assert err.value.problems[0].row == 1
