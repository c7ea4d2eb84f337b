"""DataModule: seeded shuffling in blocks of whole mini-batches, validation in order."""

from __future__ import annotations

import numpy as np
import torch

from rwhonet.models.datamodule import ArrayDataset, WhONetDataModule


def _data(n: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.arange(n * 2, dtype=np.float32).reshape(n, 1, 2)
    return x, np.arange(n, dtype=np.float32)


def test_dataset_takes_a_list_of_indices() -> None:
    x, y = _data(10)
    xb, yb = ArrayDataset(x, y)[[3, 1, 7]]
    assert torch.equal(yb, torch.tensor([3.0, 1.0, 7.0]))
    assert torch.equal(xb[:, 0, 0], 2 * yb)  # features stay with their label


def test_each_epoch_is_one_permutation_cut_into_blocks() -> None:
    x, y = _data(1000)
    dm = WhONetDataModule(x, y, batch_size=32, steps_per_block=4, seed=3)
    loader = dm.train_dataloader()
    epochs = [[yb.long() for _, yb in loader] for _ in range(2)]
    for blocks in epochs:
        assert [len(b) for b in blocks] == [128] * 7 + [1000 - 7 * 128]
        assert torch.equal(torch.cat(blocks).sort().values, torch.arange(1000))
    assert not torch.equal(torch.cat(epochs[0]), torch.cat(epochs[1]))  # reshuffled


def test_order_is_seeded_and_independent_of_block_size() -> None:
    x, y = _data(1000)

    def order(seed: int, steps: int) -> torch.Tensor:
        dm = WhONetDataModule(x, y, batch_size=32, steps_per_block=steps, seed=seed)
        return torch.cat([yb for _, yb in dm.train_dataloader()])

    torch.manual_seed(123)  # the global RNG must not matter
    a = order(5, 1)
    torch.manual_seed(456)
    assert torch.equal(a, order(5, 64))
    assert not torch.equal(a, order(6, 1))


def test_validation_in_order_or_none() -> None:
    x, y = _data(20)
    dm = WhONetDataModule(x, y, x[:10], y[:10], val_batch_size=4)
    assert dm.has_val
    assert torch.equal(torch.cat([yb for _, yb in dm.val_dataloader()]), torch.arange(10.0))
    empty = WhONetDataModule(x, y, x[:0], y[:0])
    assert not empty.has_val
    assert empty.val_dataloader() == []
