"""WhONet's training algorithm, once: the paper's update and the order samples are seen in.

Paper §3.3.1: mean-absolute-error loss, Adamax, one optimizer step per mini-batch
of ``batch_size`` shuffled samples. Everything that trains a WhONet goes
through :func:`train_block`: the LightningModule's ``training_step`` (G- and
S-WhONet, :mod:`rwhonet.models.module`) and the fine-tuning loop of R-WhONet
(:mod:`rwhonet.models.adapt`), which runs it without a Trainer.

- :class:`ArrayDataset`, :func:`train_loader`, :func:`val_loader`: in-memory
  samples, shuffled blocks of mini-batches from a seeded generator;
- :func:`make_optimizer`, :func:`batch_mae`, :func:`train_block`,
  :func:`train_epoch`, :class:`EpochLoss`: the update and the epoch's MAE;
- :func:`as_model_inputs`, :func:`predict`: input checks and batched inference;
  :func:`training_inputs`, :func:`training_hparams`: what G and S are trained on and
  with (one seed at a time or all at once).

Plain torch: importing this module does not import Lightning.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.utils.data import (
    BatchSampler,
    DataLoader,
    Dataset,
    RandomSampler,
    Sampler,
    SequentialSampler,
)

from rwhonet.config import ModelParams, TrainParams
from rwhonet.contracts import N_FEATURES
from rwhonet.errors import InputError, Problem
from rwhonet.models.gru import GRUNet
from rwhonet.models.network import Network
from rwhonet.models.tcn import TCNNet
from rwhonet.models.whonet import WhONet

# Mini-batches per training block (rwhonet.models.module): 64 x 128 = 8192 samples
# per Lightning batch amortises its per-batch cost to a few µs per optimizer step.
STEPS_PER_BLOCK = 64
VAL_BATCH_SIZE = 8192
PREDICT_BATCH_SIZE = 8192
MAX_PROBLEMS = 20  # non-finite rows listed per array; the count says how many more

# A WhONet's hyperparameters (WhONetModule's constructor arguments, saved with every model).
HPARAMS: tuple[str, ...] = (
    "n_features",
    "hidden",
    "layers",
    "dropout",
    "seq_len",
    "lr",
    "batch_size",
)
# The networks model.arch selects (rwhonet.models.network), and the hyperparameters each
# saves beyond HPARAMS. A WhONet's saves none: its model files stay those of the paper's
# network (no "arch" key means whonet).
ARCHS: dict[str, type[Network]] = {"whonet": WhONet, "gru": GRUNet, "tcn": TCNNet}
ARCH_HPARAMS: dict[str, tuple[str, ...]] = {
    "whonet": (),
    "gru": ("arch",),
    "tcn": ("arch", "channels"),
}
DEFAULT_ARCH = "whonet"
# numpy's legacy seeding accepts 32-bit unsigned seeds; Lightning enforces the same range.
SEED_MIN, SEED_MAX = 0, 2**32 - 1


# --------------------------------------------------------------------------- data


class ArrayDataset(Dataset):
    """Features and labels held in memory, indexed by a list of sample indices.

    A standard ``DataLoader(dataset, batch_size=128, shuffle=True)`` calls
    ``__getitem__`` once per sample and stacks the results in ``collate_fn``:
    128 Python calls and a stack per step, more than the model's own step costs
    here. This dataset is indexed with a whole list at once (one tensor
    gather), and :func:`train_loader` hands it those lists.

    Args:
        x: (N, T, F) float32 features.
        y: (N,) float32 labels in metres.
    """

    def __init__(self, x: np.ndarray | torch.Tensor, y: np.ndarray | torch.Tensor) -> None:
        # as_tensor shares memory with a float32 numpy array: no copy of the features.
        self.x = torch.as_tensor(x, dtype=torch.float32)
        self.y = torch.as_tensor(y, dtype=torch.float32)
        if len(self.x) != len(self.y):
            raise ValueError(f"x has {len(self.x)} samples but y has {len(self.y)}")

    def __len__(self) -> int:
        return len(self.y)

    def __getitem__(self, idx: list[int]) -> tuple[torch.Tensor, torch.Tensor]:
        index = torch.as_tensor(idx, dtype=torch.long)
        return self.x[index], self.y[index]


class ShardSampler(Sampler[int]):
    """One process's share of every epoch's permutation (distributed training).

    Every process draws the same permutation (same seeded generator) and takes
    its positions ``rank, rank + world_size, ...``; the last ``n % world_size``
    positions (at most ``world_size - 1`` samples, different ones each epoch)
    are left out so every process takes the same number of steps. Mini-batch
    ``k`` of all processes together is then positions ``[k * B, (k + 1) * B)``
    of the permutation, ``B = world_size * batch_size``: the mini-batches of one
    process at batch size ``B``.

    Args:
        order: the epoch's permutation (a seeded ``RandomSampler``).
        rank: this process's global rank.
        world_size: processes in all.
    """

    def __init__(self, order: Sampler[int], rank: int, world_size: int) -> None:
        if not 0 <= rank < world_size:
            raise ValueError(f"rank must be in [0, {world_size}), got {rank}")
        self.order = order
        self.rank = rank
        self.world_size = world_size

    def __iter__(self) -> Iterator[int]:
        order = list(self.order)
        usable = len(order) - len(order) % self.world_size
        return iter(order[self.rank : usable : self.world_size])

    def __len__(self) -> int:
        return len(self.order) // self.world_size


def train_loader(
    dataset: ArrayDataset,
    *,
    batch_size: int,
    seed: int,
    steps_per_block: int = STEPS_PER_BLOCK,
    rank: int = 0,
    world_size: int = 1,
) -> DataLoader:
    """Shuffled training blocks: the one sample order both training paths use.

    Each pass over the loader is one epoch: one permutation of the samples from
    a generator seeded with ``seed`` (independent of the global RNG; it advances
    from epoch to epoch), cut into blocks of ``steps_per_block * batch_size``
    samples that :func:`train_block` slices into mini-batches. The sequence of
    mini-batches is therefore that of a plain ``shuffle=True`` loop at
    ``batch_size`` whatever ``steps_per_block`` is. With ``world_size > 1`` each
    process gets its :class:`ShardSampler` share of the permutation.

    Args:
        dataset: the training samples.
        batch_size: samples per optimizer step (per process).
        seed: seed of the shuffling generator (the same in every process).
        steps_per_block: mini-batches per block (a speed knob only).
        rank: this process's global rank (distributed training).
        world_size: training processes in all.

    Returns:
        A ``DataLoader`` yielding ``(x, y)`` blocks; build it once per fit, since
        the generator is seeded here.
    """
    if batch_size < 1 or steps_per_block < 1:
        raise ValueError(
            f"batch_size and steps_per_block must be positive, got {batch_size}, {steps_per_block}"
        )
    generator = torch.Generator().manual_seed(seed)
    order: Sampler[int] = RandomSampler(dataset, generator=generator)
    if world_size > 1:
        order = ShardSampler(order, rank, world_size)
    blocks = BatchSampler(order, batch_size=batch_size * steps_per_block, drop_last=False)
    # batch_size=None: the sampler yields whole index lists, the dataset gathers them.
    return DataLoader(dataset, sampler=blocks, batch_size=None, num_workers=0)


def val_loader(dataset: ArrayDataset, *, batch_size: int = VAL_BATCH_SIZE) -> DataLoader:
    """Validation batches in order (no gradients, so large ones).

    Args:
        dataset: the validation samples.
        batch_size: samples per batch.

    Returns:
        A ``DataLoader`` yielding ``(x, y)`` batches in sample order.
    """
    batches = BatchSampler(SequentialSampler(dataset), batch_size=batch_size, drop_last=False)
    return DataLoader(dataset, sampler=batches, batch_size=None, num_workers=0)


# --------------------------------------------------------------------------- the update


def seed_all(seed: int) -> None:
    """Seed Python's, numpy's and torch's global generators, as ``L.seed_everything`` does.

    Args:
        seed: an integer in [0, 2**32 - 1].

    Raises:
        ValueError: for a seed out of that range.
    """
    seed = int(seed)
    if not SEED_MIN <= seed <= SEED_MAX:
        raise ValueError(f"seed must be in [{SEED_MIN}, {SEED_MAX}], got {seed}")
    random.seed(seed)
    # The legacy global generator on purpose: it is the one seed_everything seeds.
    np.random.seed(seed)  # noqa: NPY002
    torch.manual_seed(seed)


def arch_of(hparams: Mapping[str, Any]) -> str:
    """The network a set of hyperparameters is for (``whonet`` when they do not say)."""
    return str(hparams.get("arch", DEFAULT_ARCH))


def hparam_keys(arch: str) -> tuple[str, ...]:
    """The hyperparameters a model file of ``arch`` holds.

    Raises:
        ValueError: for an unknown architecture.
    """
    if arch not in ARCHS:
        raise ValueError(f"unknown model.arch {arch!r}; expected one of {sorted(ARCHS)}")
    return HPARAMS + ARCH_HPARAMS[arch]


def saved_hparams(hparams: Mapping[str, Any]) -> dict[str, Any]:
    """The hyperparameters saved with a model: :func:`hparam_keys` of its arch, no others.

    Raises:
        ValueError: when one is missing.
    """
    keys = hparam_keys(arch_of(hparams))
    missing = [k for k in keys if k not in hparams]
    if missing:
        raise ValueError(f"hyperparameters {missing} missing; expected {keys}")
    return {k: hparams[k] for k in keys}


def net_from_hparams(hparams: Mapping[str, Any]) -> Network:
    """Check a WhONetModule's hyperparameters and build its (freshly initialised) network.

    Args:
        hparams: the :data:`HPARAMS` and, for another network than WhONet, its
            :data:`ARCH_HPARAMS` (extra keys are ignored).

    Returns:
        The network ``arch`` names (:data:`ARCHS`; WhONet without ``arch``) of
        that shape; building it draws its initial weights from torch's global RNG.

    Raises:
        ValueError: for a non-positive ``seq_len``, ``batch_size`` or ``lr``, an
            unknown ``arch``, or a shape the network refuses.
    """
    seq_len, lr, batch_size = hparams["seq_len"], hparams["lr"], hparams["batch_size"]
    if seq_len < 1 or batch_size < 1 or lr <= 0:
        raise ValueError(
            f"seq_len and batch_size must be positive and lr > 0, got {seq_len}, {batch_size}, {lr}"
        )
    arch = arch_of(hparams)
    hparam_keys(arch)  # a known arch
    shape = {k: hparams[k] for k in ("n_features", "hidden", "layers", "dropout")}
    if arch == "tcn":
        return TCNNet(**shape, seq_len=seq_len, channels=hparams["channels"])
    return ARCHS[arch](**shape)


def make_optimizer(module: nn.Module, lr: float) -> torch.optim.Optimizer:
    """Adamax over the trainable parameters (paper §3.3.1).

    Adamax, as the paper states (the authors' code builds Adam), with PyTorch's
    default betas and epsilon and no learning-rate decay. Only parameters with
    ``requires_grad`` are handed to it, so a freeze policy applied before holds.

    Args:
        module: a network (:mod:`rwhonet.models.network`) or a module holding one.
        lr: learning rate (Table 1: 0.0007).

    Returns:
        The optimizer.
    """
    return torch.optim.Adamax([p for p in module.parameters() if p.requires_grad], lr=lr)


def batch_mae(net: nn.Module, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Mean absolute error of one batch in metres: the training loss of paper §3.3.1.

    Args:
        net: the network.
        x: (B, T, F) windows.
        y: (B,) labels in metres.

    Returns:
        The scalar loss (with its graph when grad is enabled).
    """
    return nn.functional.l1_loss(net(x), y)


class EpochLoss:
    """Batch losses of one epoch, reduced once to the exact MAE over its samples.

    Losses are kept as detached tensors (no ``.item()``: no host sync per step).
    """

    def __init__(self) -> None:
        self.losses: list[torch.Tensor] = []
        self.sizes: list[int] = []

    def add(self, loss: torch.Tensor, n: int) -> None:
        """Record one batch's mean loss and its number of samples."""
        self.losses.append(loss.detach())
        self.sizes.append(n)

    def pop_mean(self) -> float | None:
        """Sample-weighted mean of the recorded batch losses, then start a new epoch.

        Returns:
            The epoch's MAE in metres, or None when nothing was recorded.
        """
        total = self.pop_total()
        return None if total is None else float(total[0] / total[1])

    def pop_total(self) -> torch.Tensor | None:
        """Summed absolute error and sample count, then start a new epoch.

        Sums, unlike means, add up across distributed processes.

        Returns:
            A float64 CPU tensor ``[sum of |error| in metres, samples]``, or None
            when nothing was recorded.
        """
        losses, sizes = self.losses, self.sizes
        self.losses, self.sizes = [], []
        if not sizes:
            return None
        n = torch.tensor(sizes, dtype=torch.float64)
        return torch.stack([(torch.stack(losses).double().cpu() * n).sum(), n.sum()])


def train_block(
    net: nn.Module,
    optimizer: torch.optim.Optimizer,
    x: torch.Tensor,
    y: torch.Tensor,
    batch_size: int,
    epoch_loss: EpochLoss,
    backward: Callable[[torch.Tensor], None] | None = None,
) -> None:
    """One optimizer step per ``batch_size`` slice of a block, in order (paper §3.3.1).

    Args:
        net: the network, in training mode (dropout active).
        optimizer: from :func:`make_optimizer` (or Lightning's wrapper of it, whose
            ``step`` goes through the Trainer's strategy and precision plugin).
        x: (n, T, F) block of shuffled windows.
        y: (n,) their labels in metres.
        batch_size: samples per step; the last slice may be smaller.
        epoch_loss: receives each slice's loss before its step.
        backward: computes the gradients of a loss; default ``loss.backward()``.
            Under DDP it must be Lightning's ``manual_backward``, which re-arms
            the gradient all-reduce for every step of the block.
    """
    for start in range(0, len(y), batch_size):
        yb = y[start : start + batch_size]
        loss = batch_mae(net, x[start : start + batch_size], yb)
        epoch_loss.add(loss, len(yb))
        optimizer.zero_grad(set_to_none=True)
        if backward is None:
            loss.backward()
        else:
            backward(loss)
        optimizer.step()


def train_epoch(
    net: nn.Module, optimizer: torch.optim.Optimizer, loader: DataLoader, batch_size: int
) -> float | None:
    """One epoch over a :func:`train_loader`: every block through :func:`train_block`.

    This is what the Trainer does with :class:`~rwhonet.models.module.WhONetModule`
    and :class:`~rwhonet.models.datamodule.WhONetDataModule`, without it.

    Args:
        net: the network, in training mode.
        optimizer: from :func:`make_optimizer`.
        loader: from :func:`train_loader`.
        batch_size: samples per optimizer step.

    Returns:
        The epoch's training MAE in metres (None for an empty loader).
    """
    epoch_loss = EpochLoss()
    for x, y in loader:
        train_block(net, optimizer, x, y, batch_size, epoch_loss)
    return epoch_loss.pop_mean()


# --------------------------------------------------------------------------- inputs, inference


def as_model_inputs(
    x: Any,
    y: Any,
    what: str,
    *,
    seq_len: int | None,
    n_features: int | None = N_FEATURES,
    allow_empty: bool = False,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Check model inputs and return them as float32 tensors (sharing numpy memory).

    Args:
        x: (N, seq_len, n_features) windows.
        y: (N,) labels, or None.
        what: the inputs' name in error reports ("training samples").
        seq_len: required time steps, or None for any.
        n_features: required features per step, or None for any.
        allow_empty: accept N = 0.

    Returns:
        ``(x, y)`` float32 tensors (``y`` None when not given).

    Raises:
        InputError: listing every shape problem, or the first non-finite rows.
    """
    xa = np.ascontiguousarray(x, dtype=np.float32)
    ya = None if y is None else np.ascontiguousarray(y, dtype=np.float32)
    shape = f"(N, {seq_len or 'T'}, {n_features or 'F'})"
    problems = []
    if xa.ndim != 3:
        problems.append(Problem(what, None, "x", f"an array of shape {shape}", f"shape {xa.shape}"))
    else:
        if seq_len is not None and xa.shape[1] != seq_len:
            problems.append(
                Problem(what, None, "x", f"{seq_len} time steps (model.seq_len)", f"{xa.shape[1]}")
            )
        if n_features is not None and xa.shape[2] != n_features:
            problems.append(Problem(what, None, "x", f"{n_features} features", f"{xa.shape[2]}"))
        if len(xa) == 0 and not allow_empty:
            problems.append(Problem(what, None, "x", "at least one sample", "none"))
    if ya is not None and (ya.ndim != 1 or len(ya) != len(xa)):
        problems.append(
            Problem(what, None, "y", f"shape ({len(xa)},) like x's first axis", f"{ya.shape}")
        )
    if problems:
        raise InputError(problems, f"{what} do not fit the model")
    _check_finite(xa.reshape(len(xa), int(np.prod(xa.shape[1:]))), what, "x")
    if ya is not None:
        _check_finite(ya[:, None], what, "y")
    return torch.from_numpy(xa), None if ya is None else torch.from_numpy(ya)


def training_inputs(
    x: np.ndarray, y: np.ndarray, x_val: np.ndarray | None, y_val: np.ndarray | None, seq_len: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None, torch.Tensor | None]:
    """Training samples and validation samples checked (:func:`as_model_inputs`) as tensors.

    Args:
        x, y: the training windows and labels.
        x_val, y_val: the validation windows and labels; None / empty: no validation.
        seq_len: ``model.seq_len``.

    Returns:
        ``(x, y, x_val, y_val)``; the last two None without validation samples.

    Raises:
        InputError: when the arrays have the wrong shape or non-finite values.
    """
    x_t, y_t = as_model_inputs(x, y, "training samples", seq_len=seq_len)
    if x_val is None or y_val is None or len(x_val) + len(y_val) == 0:
        return x_t, y_t, None, None
    x_val_t, y_val_t = as_model_inputs(
        x_val, y_val, "validation samples", seq_len=seq_len, n_features=x_t.shape[2]
    )
    return x_t, y_t, x_val_t, y_val_t


def training_hparams(model: ModelParams, train: TrainParams, n_features: int) -> dict[str, Any]:
    """The hyperparameters of a network trained from scratch (``WhONetModule``'s arguments).

    Args:
        model: the network (``model:`` in params.yaml).
        train: the recipe (``train:``): its ``lr`` and ``batch_size``.
        n_features: input features per second (the training windows').
    """
    return {
        "n_features": n_features,
        "hidden": model.hidden,
        "layers": model.layers,
        "dropout": model.dropout,
        "seq_len": model.seq_len,
        "lr": train.lr,
        "batch_size": train.batch_size,
        "arch": model.arch,
        "channels": model.channels,
    }


def _check_finite(a: np.ndarray, what: str, column: str) -> None:
    """Raise InputError naming the first rows of a 2-D array that hold NaN or inf."""
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if len(bad) == 0:
        return
    problems = [
        Problem(what, int(i) + 1, column, "finite values", str(a[i][~np.isfinite(a[i])][:3]))
        for i in bad[:MAX_PROBLEMS]
    ]
    raise InputError(problems, f"{len(bad)} sample(s) of {what} hold NaN or inf in {column}")


def predict(
    model: nn.Module,
    x: np.ndarray,
    batch_size: int = PREDICT_BATCH_SIZE,
    *,
    seq_len: int | None = None,
) -> np.ndarray:
    """Predict the per-second displacement error (metres) for every window of ``x``.

    Runs in eval mode (no dropout) without autograd, in batches so memory stays
    bounded; the model's training mode is restored afterwards.

    Args:
        model: a :class:`~rwhonet.models.module.WhONetModule` or a bare network
            (:class:`~rwhonet.models.network.Network`).
        x: (N, seq_len, n_features) float32 windows.
        batch_size: windows per forward pass.
        seq_len: time steps ``x`` must have; defaults to the module's
            ``hparams["seq_len"]`` (a bare network does not record it).

    Returns:
        (N,) float32 predictions.

    Raises:
        InputError: when ``x`` does not match the model's inputs.
    """
    hp = getattr(model, "hparams", {})
    net = model if isinstance(model, Network) else getattr(model, "net", None)
    n_features = hp.get("n_features") or (net.n_features if isinstance(net, Network) else None)
    x_t = as_model_inputs(
        x,
        None,
        "prediction inputs",
        seq_len=seq_len if seq_len is not None else hp.get("seq_len"),
        n_features=n_features,
        allow_empty=True,
    )[0]
    was_training = model.training
    model.eval()
    try:
        with torch.inference_mode():
            parts = [model(x_t[i : i + batch_size]) for i in range(0, len(x_t), batch_size)]
    finally:
        model.train(was_training)
    if not parts:
        return np.zeros(0, dtype=np.float32)
    return torch.cat(parts).numpy().astype(np.float32, copy=False)
