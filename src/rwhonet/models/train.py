"""Training, fine-tuning and prediction entry points (paper §3.3; no MLflow here).

The stage code tracks runs; these functions only take an optional Lightning
logger and return what happened as plain data (:class:`FitResult`). The
training algorithm, input checks and :func:`predict` come from
:mod:`rwhonet.models.core`; :func:`rwhonet.models.core.fine_tune_lean` is the
same fine-tuning without Lightning's import cost (what the ``adapt@m`` stages run).

All runs are on CPU: at batch 128 this 8.3 k-parameter network is bound by
per-step overhead, not arithmetic, so an accelerator would not pay for its
transfers. ``torch.set_num_threads`` is set from the params because a second
thread never helped at this size (shared/reference/stack-facts.md §3).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lightning as L
import numpy as np
import torch
from lightning.pytorch.callbacks import Callback
from lightning.pytorch.loggers import Logger

from rwhonet.config import AdaptParams, ModelParams, TrainParams
from rwhonet.models.core import STEPS_PER_BLOCK, apply_trainable, as_model_inputs, predict
from rwhonet.models.datamodule import WhONetDataModule
from rwhonet.models.module import WhONetModule
from rwhonet.stage import quiet

__all__ = ["FitResult", "fit", "fine_tune", "predict", "save_checkpoint", "load_module"]


@dataclass
class FitResult:
    """What a training or fine-tuning run produced.

    Attributes:
        module: the trained module (in eval mode).
        history: one ``{"epoch", "train_loss", "val_loss"}`` dict per epoch; losses
            are MAE in metres, ``val_loss`` is None without a validation set.
        seconds: wall time of ``Trainer.fit`` (training and validation).
        samples_per_s: training samples processed per second of ``seconds``.
        n_trainable: trainable scalar weights (after the freeze policy).
        n_total: all scalar weights.
        trainer: the Trainer, kept for :func:`save_checkpoint`.
    """

    module: WhONetModule
    history: list[dict[str, Any]]
    seconds: float
    samples_per_s: float
    n_trainable: int
    n_total: int
    trainer: L.Trainer | None = field(default=None, repr=False)


def fit(
    x: np.ndarray,
    y: np.ndarray,
    x_val: np.ndarray | None = None,
    y_val: np.ndarray | None = None,
    *,
    model: ModelParams,
    train: TrainParams,
    seed: int,
    logger: Logger | None = None,
    callbacks: list[Callback] | None = None,
    steps_per_block: int = STEPS_PER_BLOCK,
) -> FitResult:
    """Train a WhONet from scratch (G-WhONet or S-WhONet, paper §3.3.1-3.3.2).

    Args:
        x: (N, model.seq_len, 40) float32 scaled wheel-speed windows.
        y: (N,) labels in metres (GNSS − WPM displacement per second).
        x_val: validation windows, or None / empty to skip validation.
        y_val: validation labels, or None / empty.
        model: network shape (``model:`` in params.yaml).
        train: optimisation recipe (``train:`` in params.yaml).
        seed: seeds weights, dropout and shuffling; the same seed and inputs give
            identical weights on CPU.
        logger: an optional Lightning logger (gets hparams and per-epoch losses).
        callbacks: optional Lightning callbacks (called once per block of steps).
        steps_per_block: optimizer steps per Lightning batch; changes speed only.

    Returns:
        The trained module, its per-epoch history and timing.

    Raises:
        InputError: when the arrays have the wrong shape or non-finite values.
    """
    x_t, y_t = as_model_inputs(x, y, "training samples", seq_len=model.seq_len)
    has_val = x_val is not None and y_val is not None and len(x_val) + len(y_val) > 0
    if has_val:
        x_val_t, y_val_t = as_model_inputs(
            x_val, y_val, "validation samples", seq_len=model.seq_len, n_features=x_t.shape[2]
        )
    else:
        x_val_t = y_val_t = None
    torch.set_num_threads(train.num_threads)
    L.seed_everything(seed, workers=True, verbose=False)
    module = WhONetModule(
        n_features=x_t.shape[2],
        hidden=model.hidden,
        layers=model.layers,
        dropout=model.dropout,
        seq_len=model.seq_len,
        lr=train.lr,
        batch_size=train.batch_size,
    )
    n_trainable, n_total = apply_trainable(module, "all")
    data = WhONetDataModule(
        x_t, y_t, x_val_t, y_val_t,
        batch_size=train.batch_size, seed=seed, steps_per_block=steps_per_block,
    )  # fmt: skip
    return _run(module, data, train.epochs, logger, callbacks, n_trainable, n_total)


def fine_tune(
    ckpt_path: Path | str,
    x: np.ndarray,
    y: np.ndarray,
    *,
    adapt: AdaptParams,
    seed: int,
    logger: Logger | None = None,
    callbacks: list[Callback] | None = None,
    num_threads: int = 1,
    steps_per_block: int = STEPS_PER_BLOCK,
) -> FitResult:
    """Recalibrate G-WhONet on a target drive's first m seconds (R-WhONet, paper §2.6, §3.3.3).

    Loads the checkpoint (network shape from its saved hyperparameters; learning
    rate and batch size replaced by ``adapt``'s, so the R checkpoint records the
    recipe it was tuned with), applies the freeze policy ``adapt.trainable`` and
    trains with a fresh Adamax for ``adapt.epochs`` epochs, without validation
    (m is 10-100 samples; there is nothing to spare).
    :func:`rwhonet.models.core.fine_tune_lean` gives bit-identical weights
    without importing Lightning; this entry point adds loggers and callbacks.

    Args:
        ckpt_path: G-WhONet's Lightning checkpoint.
        x: (m, seq_len, 40) float32 windows of the first m seconds.
        y: (m,) labels in metres.
        adapt: fine-tuning recipe (``adapt:`` in params.yaml).
        seed: seeds dropout and shuffling.
        logger: an optional Lightning logger; also gets the trainable/total counts.
        callbacks: optional Lightning callbacks (called once per block of steps).
        num_threads: torch CPU threads.
        steps_per_block: optimizer steps per Lightning batch; changes speed only.

    Returns:
        The fine-tuned module, its history, timing and parameter counts.

    Raises:
        InputError: when the arrays do not match the checkpoint's inputs or hold
            non-finite values.
    """
    torch.set_num_threads(num_threads)
    L.seed_everything(seed, workers=True, verbose=False)
    module = WhONetModule.load_from_checkpoint(
        ckpt_path, map_location="cpu", lr=adapt.lr, batch_size=adapt.batch_size
    )
    x_t, y_t = as_model_inputs(
        x, y, "adaptation samples",
        seq_len=module.hparams.seq_len, n_features=module.hparams.n_features,
    )  # fmt: skip
    n_trainable, n_total = apply_trainable(module, adapt.trainable)
    if logger is not None:
        logger.log_hyperparams(
            {"trainable": adapt.trainable, "n_trainable_params": n_trainable,
             "n_total_params": n_total}
        )  # fmt: skip
    data = WhONetDataModule(
        x_t, y_t, batch_size=adapt.batch_size, seed=seed, steps_per_block=steps_per_block
    )
    return _run(module, data, adapt.epochs, logger, callbacks, n_trainable, n_total)


def save_checkpoint(result: FitResult, path: Path | str) -> None:
    """Write the run's Lightning checkpoint (weights and hyperparameters, no optimizer state).

    The optimizer state is left out: a fine-tuning run starts its own Adamax,
    and nothing resumes a finished run.

    Args:
        result: a :class:`FitResult` from :func:`fit` or :func:`fine_tune`.
        path: the ``.ckpt`` file to write (parent folders are created).
    """
    if result.trainer is None:
        raise ValueError("this FitResult has no trainer; it was not produced by fit/fine_tune")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    result.trainer.save_checkpoint(path, weights_only=True)


def load_module(path: Path | str) -> WhONetModule:
    """Load a checkpoint written by :func:`save_checkpoint`, on CPU, in eval mode.

    Args:
        path: the ``.ckpt`` file.

    Returns:
        The module, rebuilt from its saved hyperparameters.
    """
    module = WhONetModule.load_from_checkpoint(path, map_location="cpu")
    module.eval()
    return module


# --------------------------------------------------------------------------- internals


def _run(
    module: WhONetModule,
    data: WhONetDataModule,
    epochs: int,
    logger: Logger | None,
    callbacks: list[Callback] | None,
    n_trainable: int,
    n_total: int,
) -> FitResult:
    """Fit with a lean, quiet Trainer and time it."""
    quiet()
    # num_workers=0 is deliberate: worker processes cost more than they save for
    # in-memory tensors (stack-facts.md §3), so Lightning's hint is noise here.
    warnings.filterwarnings("ignore", message=r".*does not have many workers.*")
    trainer = L.Trainer(
        accelerator="cpu",
        devices=1,
        precision="32-true",
        max_epochs=epochs,
        logger=logger if logger is not None else False,
        callbacks=callbacks,
        enable_progress_bar=False,
        enable_model_summary=False,
        enable_checkpointing=False,
        deterministic=True,
        num_sanity_val_steps=0,
        # Nothing is logged per step; 1 only keeps the "fewer batches than the
        # logging interval" warning away (a block holds 64 steps).
        log_every_n_steps=1,
        limit_val_batches=1.0 if data.has_val else 0,
    )
    start = time.perf_counter()
    trainer.fit(module, datamodule=data)
    seconds = time.perf_counter() - start
    module.eval()
    n_samples = len(data.train_set) * trainer.current_epoch
    return FitResult(
        module=module,
        history=list(module.history),
        seconds=seconds,
        samples_per_s=n_samples / seconds if seconds > 0 else float("nan"),
        n_trainable=n_trainable,
        n_total=n_total,
        trainer=trainer,
    )
