"""In-memory data for WhONet: shuffled blocks of samples without per-sample collation.

The loaders themselves come from :mod:`rwhonet.models.loop`
(:func:`~rwhonet.models.loop.train_loader`, :func:`~rwhonet.models.loop.val_loader`),
which R-WhONet's fine-tuning iterates without a Trainer.
"""

from __future__ import annotations

import lightning as L
import numpy as np
import torch
from torch.utils.data import DataLoader

from rwhonet.models.loop import (
    STEPS_PER_BLOCK,
    VAL_BATCH_SIZE,
    ArrayDataset,
    train_loader,
    val_loader,
)

__all__ = ["STEPS_PER_BLOCK", "VAL_BATCH_SIZE", "ArrayDataset", "WhONetDataModule"]


class WhONetDataModule(L.LightningDataModule):
    """Training blocks and validation batches over in-memory arrays.

    Each epoch draws one permutation of the training samples (from a generator
    seeded with ``seed``, independent of the global RNG) and cuts it into
    blocks of ``steps_per_block * batch_size`` samples; the module slices each
    block into mini-batches of ``batch_size``. The sequence of mini-batches is
    therefore that of a plain ``shuffle=True`` loop at ``batch_size`` whatever
    ``steps_per_block`` is (the last mini-batch of an epoch may be smaller).

    Args:
        x: (N, T, F) float32 training features.
        y: (N,) float32 training labels in metres.
        x_val: validation features, or None / empty for no validation.
        y_val: validation labels, or None / empty.
        batch_size: samples per optimizer step.
        seed: seed of the shuffling generator.
        steps_per_block: mini-batches per Lightning batch (a speed knob only).
        val_batch_size: samples per validation batch (no gradients, so large).
    """

    def __init__(
        self,
        x: np.ndarray | torch.Tensor,
        y: np.ndarray | torch.Tensor,
        x_val: np.ndarray | torch.Tensor | None = None,
        y_val: np.ndarray | torch.Tensor | None = None,
        *,
        batch_size: int = 128,
        seed: int = 0,
        steps_per_block: int = STEPS_PER_BLOCK,
        val_batch_size: int = VAL_BATCH_SIZE,
    ) -> None:
        super().__init__()
        if batch_size < 1 or steps_per_block < 1 or val_batch_size < 1:
            raise ValueError("batch_size, steps_per_block and val_batch_size must be positive")
        self.train_set = ArrayDataset(x, y)
        has_val = x_val is not None and y_val is not None and len(y_val) > 0
        self.val_set = ArrayDataset(x_val, y_val) if has_val else None
        self.batch_size = batch_size
        self.seed = seed
        self.steps_per_block = steps_per_block
        self.val_batch_size = val_batch_size

    @property
    def has_val(self) -> bool:
        """Whether there is a validation set."""
        return self.val_set is not None

    def train_dataloader(self) -> DataLoader:
        """Shuffled blocks; the generator is re-seeded per call, so every fit sees one order.

        Under a distributed Trainer each process gets its share of every epoch
        (:class:`~rwhonet.models.loop.ShardSampler`); the Trainer must not add a
        ``DistributedSampler`` of its own (``use_distributed_sampler=False``).
        """
        trainer = self.trainer
        return train_loader(
            self.train_set,
            batch_size=self.batch_size,
            seed=self.seed,
            steps_per_block=self.steps_per_block,
            rank=trainer.global_rank if trainer is not None else 0,
            world_size=trainer.world_size if trainer is not None else 1,
        )

    def val_dataloader(self) -> DataLoader | list:
        """Validation batches in order; an empty list (no validation) without a validation set.

        Not sharded: every process scores the whole validation set (the same
        weights give the same ``val/loss`` everywhere, with no reduction).
        """
        if self.val_set is None:
            return []
        return val_loader(self.val_set, batch_size=self.val_batch_size)
