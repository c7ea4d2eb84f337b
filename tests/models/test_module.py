"""WhONetModule: checkpoint round trip, per-epoch logging, block size changes nothing."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest
import torch
from lightning.pytorch.loggers import Logger

from rwhonet.models.checkpoint import save_whonet
from rwhonet.models.module import WhONetModule
from rwhonet.models.train import fit, predict


class RecordingLogger(Logger):
    """A Lightning logger that keeps what it is given."""

    def __init__(self) -> None:
        super().__init__()
        self.metrics: list[tuple[int | None, dict[str, float]]] = []
        self.hparams: dict[str, Any] = {}

    @property
    def name(self) -> str:
        return "recording"

    @property
    def version(self) -> int:
        return 0

    def log_hyperparams(self, params: Any, *args: Any, **kwargs: Any) -> None:
        self.hparams.update(dict(params))

    def log_metrics(self, metrics: dict[str, float], step: int | None = None) -> None:
        self.metrics.append((step, dict(metrics)))


def test_hyperparameters_survive_a_model_file(tmp_path, linear_data, model_params, train_params):
    x, y = linear_data
    result = fit(x, y, model=model_params, train=train_params, seed=1)
    save_whonet(result.module.net, result.module.hparams, tmp_path / "model.pt")
    loaded = WhONetModule.load(tmp_path / "model.pt")
    assert dict(loaded.hparams) == {
        "n_features": 40,
        "hidden": 16,
        "layers": 1,
        "dropout": 0.05,
        "seq_len": 1,
        "lr": 0.01,
        "batch_size": 64,
        "arch": "whonet",  # the constructor's defaults; a WhONet's file holds neither
        "channels": 16,
    }
    assert not loaded.training
    for (k, a), (k2, b) in zip(
        result.module.state_dict().items(), loaded.state_dict().items(), strict=True
    ):
        assert k == k2 and torch.equal(a, b)
    np.testing.assert_array_equal(predict(loaded, x), predict(result.module, x))


def test_epoch_losses_logged_once_per_epoch(linear_data, model_params, train_params):
    x, y = linear_data
    logger = RecordingLogger()
    result = fit(
        x[:1000],
        y[:1000],
        x[1000:],
        y[1000:],
        model=model_params,
        train=train_params,
        seed=1,
        logger=logger,
    )
    assert logger.hparams["hidden"] == 16
    assert [step for step, _ in logger.metrics] == [0, 1, 2]
    assert all(set(m) == {"train/loss", "val/loss"} for _, m in logger.metrics)
    assert [h["epoch"] for h in result.history] == [0, 1, 2]
    assert [m["val/loss"] for _, m in logger.metrics] == [h["val_loss"] for h in result.history]
    # The last epoch's validation ran on the final weights: its MAE is the val-set MAE.
    mae = np.mean(np.abs(predict(result.module, x[1000:]) - y[1000:]))
    assert result.history[-1]["val_loss"] == pytest.approx(mae, rel=1e-5)


def test_no_validation_set_skips_validation(linear_data, model_params, train_params):
    x, y = linear_data
    logger = RecordingLogger()
    result = fit(x, y, x[:0], y[:0], model=model_params, train=train_params, seed=1, logger=logger)
    assert all(h["val_loss"] is None for h in result.history)
    assert all(set(m) == {"train/loss"} for _, m in logger.metrics)


def test_block_size_does_not_change_training(linear_data, model_params, train_params):
    x, y = linear_data
    params = replace(train_params, epochs=2, batch_size=32)
    one = fit(x, y, model=model_params, train=params, seed=4, steps_per_block=1)
    many = fit(x, y, model=model_params, train=params, seed=4, steps_per_block=16)
    for a, b in zip(one.module.parameters(), many.module.parameters(), strict=True):
        assert torch.equal(a, b)
    assert one.history == many.history


def test_optimizer_is_adamax_over_trainable_parameters() -> None:
    module = WhONetModule(n_features=2, hidden=3, lr=0.002)
    module.net.head.weight.requires_grad_(False)
    opt = module.configure_optimizers()
    assert isinstance(opt, torch.optim.Adamax)
    assert opt.defaults["lr"] == 0.002
    params = opt.param_groups[0]["params"]
    assert all(p is not module.net.head.weight for p in params)
    assert len(params) == len(list(module.parameters())) - 1


def test_callbacks_are_passed_to_the_trainer(linear_data, model_params, train_params):
    from lightning.pytorch.callbacks import Callback

    class CountEpochs(Callback):
        def __init__(self) -> None:
            self.n = 0

        def on_train_epoch_end(self, trainer, pl_module) -> None:
            self.n += 1

    x, y = linear_data
    counter = CountEpochs()
    fit(x, y, model=model_params, train=train_params, seed=0, callbacks=[counter])
    assert counter.n == train_params.epochs


def test_a_fast_dev_run_passes_through_every_hook(linear_data):
    import lightning as L

    from rwhonet.models.datamodule import WhONetDataModule

    x, y = linear_data
    module = WhONetModule(hidden=8)
    data = WhONetDataModule(x[:1000], y[:1000], x[1000:], y[1000:], batch_size=64, seed=0)
    trainer = L.Trainer(
        fast_dev_run=True,
        logger=False,
        enable_progress_bar=False,
        enable_model_summary=False,
        accelerator="cpu",
    )
    trainer.fit(module, datamodule=data)
    assert trainer.state.finished and len(module.history) == 1
    assert module.history[0]["train_loss"] > 0 and module.history[0]["val_loss"] > 0
