"""Plain per-epoch lines of a fit, where no progress bar is drawn (CI, logs).

A terminal gets Lightning's own bar (``fit(progress=True)``); everywhere else
:class:`EpochLog` prints at most ``lines`` lines per fit, each with the epoch's
training and validation MAE, and never a carriage return.
"""

from __future__ import annotations

import math
import time

import lightning as L
from lightning.pytorch.callbacks import Callback


class EpochLog(Callback):
    """Print ``<name>: epoch e/E, train MAE .. m, val MAE .. m, t s`` every few epochs.

    Args:
        name: what is trained (``G-WhONet seed 42``).
        epochs: the fit's epochs.
        lines: lines per fit at most (the last epoch always has one).
    """

    def __init__(self, name: str, epochs: int, lines: int = 10) -> None:
        self.name, self.epochs = name, epochs
        self.every = max(1, math.ceil(epochs / lines))
        self._printed = 0
        self._start = time.perf_counter()

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._start = time.perf_counter()

    # The module records an epoch in its own on_train_epoch_end, which Lightning calls
    # after the callbacks' hooks: an epoch is reported when the next starts, or at the end.
    def on_train_epoch_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._report(trainer, pl_module, final=False)

    def on_train_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._report(trainer, pl_module, final=True)

    def _report(self, trainer: L.Trainer, pl_module: L.LightningModule, final: bool) -> None:
        history = getattr(pl_module, "history", [])
        done = len(history)
        if not trainer.is_global_zero or done == self._printed or not done:
            return
        if not final and done % self.every:
            return
        self._printed = done
        last = history[-1]
        losses = ", ".join(
            f"{stage} MAE {last[f'{stage}_loss']:.4f} m"
            for stage in ("train", "val")
            if last.get(f"{stage}_loss") is not None
        )
        print(
            f"{self.name}: epoch {done}/{self.epochs}, {losses}, "
            f"{time.perf_counter() - self._start:.1f} s",
            flush=True,
        )
