"""Training entry points: learning, determinism, prediction, fine-tuning, input errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.models.module import WhONetModule
from rwhonet.models.train import fine_tune, fit, predict, save_checkpoint


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


def test_predict_is_batched_in_eval_mode_and_restores_mode(linear_data):
    x, _ = linear_data
    module = WhONetModule(hidden=8, dropout=0.5)
    module.train()
    whole = predict(module, x, batch_size=10_000)
    assert whole.shape == (len(x),) and whole.dtype == np.float32
    np.testing.assert_allclose(predict(module, x, batch_size=7), whole, rtol=0, atol=1e-6)
    assert module.training  # restored
    assert predict(module, x[:0]).shape == (0,)


def test_fine_tune_starts_from_g_and_records_the_recipe(
    tmp_path, linear_data, model_params, train_params, adapt_params
):
    x, y = linear_data
    g = fit(x, y, model=model_params, train=train_params, seed=1)
    save_checkpoint(g, tmp_path / "g.ckpt")
    shift = 1.5  # the new vehicle's label differs by a constant
    before = np.mean(np.abs(predict(g.module, x[:50]) - (y[:50] + shift)))
    recipe = replace(adapt_params, epochs=40, lr=0.02, batch_size=16)
    r = fine_tune(tmp_path / "g.ckpt", x[:50], y[:50] + shift, adapt=recipe, seed=2)
    after = np.mean(np.abs(predict(r.module, x[:50]) - (y[:50] + shift)))
    assert after < 0.5 * before
    assert len(r.history) == 40 and r.history[0]["val_loss"] is None
    assert r.module.hparams.lr == 0.02 and r.module.hparams.batch_size == 16
    assert r.module.hparams.hidden == model_params.hidden
    save_checkpoint(r, tmp_path / "r.ckpt")
    assert WhONetModule.load_from_checkpoint(tmp_path / "r.ckpt").hparams.lr == 0.02


def test_fine_tune_rejects_inputs_that_do_not_fit_g(
    tmp_path, linear_data, model_params, train_params, adapt_params
):
    x, y = linear_data
    g = fit(x[:200], y[:200], model=model_params, train=replace(train_params, epochs=1), seed=1)
    save_checkpoint(g, tmp_path / "g.ckpt")
    with pytest.raises(InputError, match="39"):
        fine_tune(tmp_path / "g.ckpt", x[:50, :, :39], y[:50], adapt=adapt_params, seed=1)
    with pytest.raises(InputError, match="at least one sample"):
        fine_tune(tmp_path / "g.ckpt", x[:0], y[:0], adapt=adapt_params, seed=1)


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


def test_fine_tuning_is_deterministic(
    tmp_path, linear_data, model_params, train_params, adapt_params
):
    x, y = linear_data
    g = fit(x[:300], y[:300], model=model_params, train=replace(train_params, epochs=1), seed=1)
    save_checkpoint(g, tmp_path / "g.ckpt")
    runs = [fine_tune(tmp_path / "g.ckpt", x[:40], y[:40], adapt=adapt_params, seed=s)
            for s in (5, 5, 6)]  # fmt: skip
    preds = [predict(r.module, x) for r in runs]
    np.testing.assert_array_equal(preds[0], preds[1])
    assert not np.array_equal(preds[0], preds[2])  # one batch per epoch: dropout differs
