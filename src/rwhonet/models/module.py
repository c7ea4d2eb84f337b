"""LightningModule around :class:`~rwhonet.models.whonet.WhONet` (paper §3.3, Table 1).

The same module trains the other networks ``model.arch`` selects
(:mod:`rwhonet.models.network`) with the same loss, optimizer and update.

The algorithm itself (loss, optimizer, the per-slice update, the epoch's
MAE) lives in :mod:`rwhonet.models.loop`; this module wires it into Lightning's
hooks, and R-WhONet's fine-tuning (:mod:`rwhonet.models.adapt`) runs the same
loop without a Trainer.

Why the training step holds its own mini-batch loop
----------------------------------------------------
WhONet is tiny (8.3 k parameters, one time step): a plain PyTorch step at
batch 128 costs about as much as Lightning's per-batch machinery (fetcher,
hooks, progress tracking, the optimizer closure and the strategy/precision
wrappers) adds on top of it (``benchmarks/bench_train.py`` measures both).
So each Lightning "batch" here is a *block* of ``steps_per_block``
mini-batches drawn from one shuffled permutation (:func:`rwhonet.models.loop.train_loader`), and
:meth:`WhONetModule.training_step` takes one optimizer step per mini-batch of
``batch_size`` samples with manual optimization
(:func:`rwhonet.models.loop.train_block`). The mini-batches and the update
sequence are exactly those of a one-step-per-batch loop over the same
permutation (a test checks that a block of 1 and a block of 64 give identical
weights); only the Lightning bookkeeping is paid once per block. The price:
Lightning's per-optimizer-step automation (gradient clipping, accumulation)
is not used. Each step's backward and optimizer step still go through the
Trainer (``manual_backward`` and Lightning's optimizer wrapper), so its
strategy and precision plugin apply: under DDP every step's gradients are
averaged across processes, and a mixed-precision plugin scales the loss.

Losses are accumulated in the module and logged once per epoch
(``train/loss``, ``val/loss``: mean absolute error in metres over the
epoch's samples, step = epoch) to the Trainer's loggers and to
``history``, so logging costs nothing per step. They are not put in
``trainer.callback_metrics`` (``self.log``), so no callback can monitor them;
nothing in the pipeline does (fixed epochs, as in the paper).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import lightning as L
import torch

from rwhonet.contracts import N_FEATURES
from rwhonet.models.checkpoint import load_whonet
from rwhonet.models.loop import (
    EpochLoss,
    batch_mae,
    make_optimizer,
    net_from_hparams,
    train_block,
)


class WhONetModule(L.LightningModule):
    """WhONet trained with MAE loss and Adamax (paper §3.3.1, Table 1).

    Every constructor argument is saved with ``save_hyperparameters()``, so
    ``WhONetModule.load_from_checkpoint(path)`` rebuilds the network with
    nothing else remembered (the G → R hand-off of paper §2.6).

    Optimizer: Adamax, as the paper states (§3.3.1; the authors' code builds
    Adam), with PyTorch's default betas and epsilon and no learning-rate decay.
    Only parameters with ``requires_grad`` are handed to it, so a freeze policy
    (:func:`rwhonet.models.freeze.apply_trainable`) applied before ``fit``
    holds.

    Args:
        n_features: input features per time step (40).
        hidden: hidden units per RNN layer (Table 1: 72).
        layers: stacked RNN layers (Table 1: 1).
        dropout: dropout rate (Table 1: 0.05).
        seq_len: one-second steps per input window (Table 1 "time step": 1);
            recorded so whoever loads a checkpoint knows how to window features.
        lr: Adamax learning rate (Table 1: 0.0007).
        batch_size: samples per optimizer step (Table 1: 128).
        arch: the network (``model.arch``: ``whonet``, ``gru`` or ``tcn``).
        channels: context features per level of the ``tcn`` (``model.channels``).
    """

    def __init__(
        self,
        n_features: int = N_FEATURES,
        hidden: int = 72,
        layers: int = 1,
        dropout: float = 0.05,
        seq_len: int = 1,
        lr: float = 7e-4,
        batch_size: int = 128,
        arch: str = "whonet",
        channels: int = 16,
    ) -> None:
        super().__init__()
        self.save_hyperparameters()
        # Checks the recipe too; loading a model file builds its network with the same call.
        self.net = net_from_hparams(self.hparams)
        # One optimizer step per mini-batch inside a block (module docstring).
        self.automatic_optimization = False
        # Per-epoch history as plain data; the training entry points return it.
        self.history: list[dict[str, Any]] = []
        # Batch losses of the running epoch, per stage.
        self._epoch_loss = {"train": EpochLoss(), "val": EpochLoss()}
        self._val_loss_m: float | None = None

    @classmethod
    def load(cls, path: Path | str) -> WhONetModule:
        """Rebuild a module from a model file (:mod:`rwhonet.models.checkpoint`), in eval mode.

        Args:
            path: a ``model.pt`` written for G, S or R.

        Returns:
            The module, built from the file's hyperparameters with its weights.
        """
        net, hparams = load_whonet(path)
        module = cls(**hparams)
        module.net.load_state_dict(net.state_dict())
        module.eval()
        return module

    # ------------------------------------------------------------------ model

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, n_features) windows -> (B,) predicted displacement error in metres."""
        return self.net(x)

    def training_step(self, batch: tuple[torch.Tensor, torch.Tensor], batch_idx: int) -> None:
        """One optimizer step per ``batch_size`` slice of the block (module docstring).

        Args:
            batch: ``(x, y)`` block of up to ``steps_per_block * batch_size``
                shuffled samples.
            batch_idx: index of the block in the epoch.
        """
        x, y = batch
        opt = self.optimizers()
        train_block(
            self.net,
            opt,
            x,
            y,
            self.hparams.batch_size,
            self._epoch_loss["train"],
            backward=self.manual_backward,
        )

    def validation_step(self, batch: tuple[torch.Tensor, torch.Tensor], batch_idx: int) -> None:
        """Accumulate the validation MAE (Lightning runs this in eval mode, without grad)."""
        x, y = batch
        self._epoch_loss["val"].add(batch_mae(self.net, x, y), len(y))

    def predict_step(self, batch: Any, batch_idx: int) -> torch.Tensor:
        """Predictions for ``Trainer.predict`` (a batch is ``x`` or ``(x, ...)``)."""
        x = batch[0] if isinstance(batch, list | tuple) else batch
        return self.net(x)

    def configure_optimizers(self) -> torch.optim.Optimizer:
        """Adamax over the trainable parameters (paper §3.3.1)."""
        return make_optimizer(self, self.hparams.lr)

    # ---------------------------------------------------------------- logging

    def on_train_epoch_start(self) -> None:
        self._val_loss_m = None

    def on_validation_epoch_end(self) -> None:
        mean = self._epoch_loss["val"].pop_mean()
        if self.trainer.sanity_checking:
            return
        self._val_loss_m = mean

    def on_train_epoch_end(self) -> None:
        # Lightning runs the epoch's validation before this hook, so both are known.
        total = self._epoch_loss["train"].pop_total()
        if total is not None and self.trainer.world_size > 1:
            # Each process saw its shard: the epoch's MAE is over all of them.
            total = self.trainer.strategy.reduce(total.to(self.device), reduce_op="sum").cpu()
        train_loss_m = None if total is None else float(total[0] / total[1])
        self.history.append(
            {"epoch": self.current_epoch, "train_loss": train_loss_m, "val_loss": self._val_loss_m}
        )
        metrics = {"train/loss": train_loss_m}
        if self._val_loss_m is not None:
            metrics["val/loss"] = self._val_loss_m
        # Straight to the loggers with step = epoch: Lightning's own step counter counts
        # blocks, not optimizer steps, and self.log's result collection would cost more
        # per call than a whole epoch of one mini-batch.
        for lg in self.loggers:
            lg.log_metrics(metrics, step=self.current_epoch)
