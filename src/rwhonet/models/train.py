"""Training G- and S-WhONet with Lightning (paper §3.3.1-3.3.2; no MLflow here).

The stage code tracks runs; :func:`fit` only takes an optional Lightning logger
and callbacks and returns what happened as plain data (:class:`FitResult`).
The training algorithm, input checks and :func:`predict` come from
:mod:`rwhonet.models.loop`; R-WhONet's fine-tuning is :mod:`rwhonet.models.adapt`.

By default a fit is one CPU process in 32-bit, bit-reproducible: at batch 128
this 8.3 k-parameter network is bound by per-step overhead, not arithmetic.
``train.trainer`` (:class:`~rwhonet.config.TrainerParams`) hands the Trainer
another accelerator, device count, strategy (``ddp``), node count or
precision (docs/scaling.md). ``torch.set_num_threads`` comes from the params:
at this size a second thread only adds synchronisation
(``benchmarks/bench_train.py``).
"""

from __future__ import annotations

import logging
import time
import warnings
from dataclasses import dataclass
from typing import Any

import lightning as L
import numpy as np
import torch
from lightning.pytorch.callbacks import Callback
from lightning.pytorch.loggers import Logger
from lightning.pytorch.strategies import DDPStrategy

from rwhonet.config import ModelParams, TrainerParams, TrainParams
from rwhonet.models.datamodule import WhONetDataModule
from rwhonet.models.freeze import apply_trainable
from rwhonet.models.loop import STEPS_PER_BLOCK, predict, training_hparams, training_inputs
from rwhonet.models.module import WhONetModule

__all__ = ["FitResult", "fit", "predict"]


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
        global_rank: this process's rank (distributed training; 0 in one process).
            Every process returns the same weights and history; only rank 0
            should write outputs.
        world_size: training processes in all.
    """

    module: WhONetModule
    history: list[dict[str, Any]]
    seconds: float
    samples_per_s: float
    n_trainable: int
    n_total: int
    global_rank: int = 0
    world_size: int = 1


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
    progress: bool = False,
) -> FitResult:
    """Train a WhONet from scratch (G-WhONet or S-WhONet, paper §3.3.1-3.3.2).

    Args:
        x: (N, model.seq_len, 40) float32 scaled wheel-speed windows.
        y: (N,) labels in metres (GNSS − WPM displacement per second).
        x_val: validation windows, or None / empty to skip validation.
        y_val: validation labels, or None / empty.
        model: network shape (``model:`` in params.yaml).
        train: optimisation recipe and Trainer settings (``train:`` in params.yaml;
            ``batch_size`` is per process).
        seed: seeds weights, dropout and shuffling; the same seed and inputs give
            identical weights on CPU in one process. Under DDP every process
            starts from the same seed (same initial weights and permutation).
        logger: an optional Lightning logger (gets hparams and per-epoch losses).
        callbacks: optional Lightning callbacks (called once per block of steps).
        steps_per_block: optimizer steps per Lightning batch; changes speed only.
        progress: draw Lightning's progress bar (a terminal; never in CI or a log).

    Returns:
        The trained module, its per-epoch history and timing.

    Raises:
        InputError: when the arrays have the wrong shape or non-finite values.
    """
    x_t, y_t, x_val_t, y_val_t = training_inputs(x, y, x_val, y_val, model.seq_len)
    torch.set_num_threads(train.num_threads)
    L.seed_everything(seed, workers=True, verbose=False)
    module = WhONetModule(**training_hparams(model, train, x_t.shape[2]))
    n_trainable, n_total = apply_trainable(module, "all")
    data = WhONetDataModule(
        x_t,
        y_t,
        x_val_t,
        y_val_t,
        batch_size=train.batch_size,
        seed=seed,
        steps_per_block=steps_per_block,
    )
    return _run(
        module,
        data,
        train.epochs,
        train.trainer,
        logger,
        callbacks,
        n_trainable,
        n_total,
        progress=progress,
    )


# --------------------------------------------------------------------------- internals


def _strategy(settings: TrainerParams) -> str | DDPStrategy:
    """The Trainer's strategy for ``train.trainer.strategy``."""
    if settings.strategy == "ddp":
        # With one time step the recurrent weights get no gradient at all (h0 = 0), and
        # DDP waits for every parameter's gradient unless told to look for unused ones.
        # gloo on CPU, NCCL on CUDA: Lightning picks by accelerator.
        return DDPStrategy(find_unused_parameters=True)
    return settings.strategy


def _run(
    module: WhONetModule,
    data: WhONetDataModule,
    epochs: int,
    settings: TrainerParams,
    logger: Logger | None,
    callbacks: list[Callback] | None,
    n_trainable: int,
    n_total: int,
    progress: bool = False,
) -> FitResult:
    """Fit with a lean, quiet Trainer (a bar only with ``progress``) and time it."""
    # Tips, "GPU available" and seeding notices say nothing to a pipeline user.
    logging.getLogger("lightning.pytorch.utilities.rank_zero").setLevel(logging.WARNING)
    logging.getLogger("lightning.fabric.utilities.rank_zero").setLevel(logging.WARNING)
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\).*")
    # num_workers=0 is deliberate: the samples are in-memory tensors, so worker
    # processes would only add inter-process copies; Lightning's hint is noise here.
    warnings.filterwarnings("ignore", message=r".*does not have many workers.*")
    trainer = L.Trainer(
        accelerator=settings.accelerator,
        devices=settings.devices,
        strategy=_strategy(settings),
        num_nodes=settings.num_nodes,
        precision=settings.precision,
        # The data module shards the training epochs itself (loop.ShardSampler) and
        # scores the whole validation set in every process.
        use_distributed_sampler=False,
        max_epochs=epochs,
        logger=logger if logger is not None else False,
        callbacks=callbacks,
        enable_progress_bar=progress,
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
    # Predictions and model files are made on the CPU, wherever the fit ran.
    module.cpu().eval()
    # Samples of all processes together (each leaves out at most world_size - 1 per epoch).
    n_samples = len(data.train_set) * trainer.current_epoch
    return FitResult(
        module=module,
        history=list(module.history),
        seconds=seconds,
        samples_per_s=n_samples / seconds if seconds > 0 else float("nan"),
        n_trainable=n_trainable,
        n_total=n_total,
        global_rank=trainer.global_rank,
        world_size=trainer.world_size,
    )
