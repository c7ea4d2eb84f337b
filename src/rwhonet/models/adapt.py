"""R-WhONet: G-WhONet recalibrated on a target drive's first m seconds (paper §2.6, §3.3.3).

The paper fine-tunes G with G's own recipe (Table 1) on the first m seconds of
each target test drive. The update is the training algorithm of
:mod:`rwhonet.models.loop`, run here for ``adapt.epochs`` epochs without a
Trainer: one stage process fine-tunes every drive at every m of the grid, and
Lightning's import and per-fit set-up would cost more than the fine-tuning
itself (``benchmarks/bench_train.py`` measures both).
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from rwhonet.config import AdaptParams
from rwhonet.models.freeze import apply_trainable
from rwhonet.models.loop import (
    ArrayDataset,
    as_model_inputs,
    make_optimizer,
    seed_all,
    train_epoch,
    train_loader,
)
from rwhonet.models.whonet import WhONet


@dataclass
class AdaptResult:
    """A recalibrated network and how it was obtained.

    Attributes:
        net: the fine-tuned network (a copy of the base network, in eval mode).
        hparams: its hyperparameters; ``lr`` and ``batch_size`` are the recipe's.
        history: one ``{"epoch", "train_loss", "val_loss"}`` dict per epoch
            (``train_loss``: MAE in metres; ``val_loss``: None, nothing held out).
        seconds: wall time of the fine-tuning epochs.
        n_trainable: trainable scalar weights (after the freeze policy).
        n_total: all scalar weights.
    """

    net: WhONet
    hparams: dict[str, Any]
    history: list[dict[str, Any]]
    seconds: float
    n_trainable: int
    n_total: int


def fine_tune(
    base: WhONet,
    hparams: dict[str, Any],
    x: np.ndarray,
    y: np.ndarray,
    *,
    adapt: AdaptParams,
    seed: int,
) -> AdaptResult:
    """Fine-tune a copy of ``base`` on one drive's first m seconds.

    A fresh Adamax (lr ``adapt.lr``) trains the weights the freeze policy
    ``adapt.trainable`` leaves trainable, for ``adapt.epochs`` passes over the
    m samples in shuffled mini-batches of ``adapt.batch_size``; no validation
    (m is 10-100 samples, there is nothing to spare). ``base`` is not modified.

    Args:
        base: G-WhONet's network.
        hparams: its hyperparameters (:data:`~rwhonet.models.loop.HPARAMS`).
        x: (m, seq_len, n_features) float32 windows of the first m seconds.
        y: (m,) labels in metres.
        adapt: the recipe (``adapt:`` in params.yaml).
        seed: seeds shuffling and dropout; the same seed and inputs give the same weights.

    Returns:
        The fine-tuned network, its hyperparameters, history, timing and parameter counts.

    Raises:
        InputError: when the arrays do not match the network's inputs or hold
            non-finite values.
    """
    x_t, y_t = as_model_inputs(
        x, y, "adaptation samples", seq_len=hparams["seq_len"], n_features=hparams["n_features"]
    )
    seed_all(seed)
    net = copy.deepcopy(base)
    n_trainable, n_total = apply_trainable(net, adapt.trainable)
    loader = train_loader(ArrayDataset(x_t, y_t), batch_size=adapt.batch_size, seed=seed)
    optimizer = make_optimizer(net, adapt.lr)
    net.train()
    history = []
    start = time.perf_counter()
    for epoch in range(adapt.epochs):
        loss_m = train_epoch(net, optimizer, loader, adapt.batch_size)
        history.append({"epoch": epoch, "train_loss": loss_m, "val_loss": None})
    seconds = time.perf_counter() - start
    net.eval()
    return AdaptResult(
        net=net,
        hparams={**hparams, "lr": adapt.lr, "batch_size": adapt.batch_size},
        history=history,
        seconds=seconds,
        n_trainable=n_trainable,
        n_total=n_total,
    )
