"""WhONet's training algorithm without Lightning, shared by the Lightning and the lean paths.

Why this module exists
----------------------
The pipeline has one ``adapt@m`` DVC stage per m, each a fresh process that
fine-tunes G-WhONet on the first m ≤ 100 seconds of every target test drive.
Fitting takes under a second there, while ``import lightning`` takes 5-7 s
(shared/reference/stack-facts.md §0). So the adaptation stages use
:func:`fine_tune_lean`, which needs only torch, and the Lightning entry points
(:mod:`rwhonet.models.train`, :class:`~rwhonet.models.module.WhONetModule`,
:class:`~rwhonet.models.datamodule.WhONetDataModule`) are built from the same
pieces defined here, so the algorithm exists once:

- :func:`batch_mae`, :func:`make_optimizer`, :func:`train_block`: the update of
  paper §3.3.1 (MAE loss, Adamax, one step per ``batch_size`` slice);
- :func:`train_loader`: the seeded order of samples and blocks;
- :class:`EpochLoss`: the per-epoch MAE the history records;
- :func:`~rwhonet.models.freeze.apply_trainable` (re-exported): the freeze policy;
- :func:`as_model_inputs`, :func:`predict`: input checks and batched inference.

Nothing here may import Lightning (a test checks it in a fresh interpreter).
What a lean stage still pays at start-up is torch itself and ``torch._dynamo``,
which ``torch.optim`` imports when the first optimizer is built (1.1-1.4 s
measured; ``benchmarks/bench_train.py`` reports the cold start of both paths).

Same weights as the Lightning path
----------------------------------
:func:`fine_tune_lean` gives bit-identical weights, history and predictions to
:func:`rwhonet.models.train.fine_tune` for the same checkpoint, data, recipe
and seed, because every random draw happens in the same order on the same
generators:

1. :func:`seed_all` seeds Python, numpy and torch as ``L.seed_everything`` does;
2. the network is built from the checkpoint's hyperparameters before its
   weights are loaded, as ``load_from_checkpoint`` does, so the initialisation
   consumes the same global-RNG draws (and is then overwritten);
3. each epoch iterates the same ``DataLoader`` (:func:`train_loader`): its
   sampler has its own seeded generator, and creating its iterator draws one
   base seed from the global RNG, as it does under the Trainer;
4. dropout then draws from the global RNG in the same per-slice order.
"""

from __future__ import annotations

import random
import time
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.utils.data import BatchSampler, DataLoader, Dataset, RandomSampler, SequentialSampler

from rwhonet.config import AdaptParams
from rwhonet.errors import InputError, Problem
from rwhonet.models.freeze import POLICIES, Trainable, apply_trainable, count_parameters
from rwhonet.models.whonet import N_FEATURES, WhONet

# Mini-batches per training block (rwhonet.models.module): 64 x 128 = 8192 samples
# per Lightning batch amortises its per-batch cost to a few µs per optimizer step.
STEPS_PER_BLOCK = 64
VAL_BATCH_SIZE = 8192
PREDICT_BATCH_SIZE = 8192
MAX_PROBLEMS = 20  # non-finite rows listed per array; the count says how many more

# WhONetModule's constructor arguments, all saved as its hyperparameters.
HPARAMS: tuple[str, ...] = (
    "n_features", "hidden", "layers", "dropout", "seq_len", "lr", "batch_size",
)  # fmt: skip
# The prefix WhONetModule's state_dict gives the network's weights (``self.net``).
NET_PREFIX = "net."
# numpy's legacy seeding accepts 32-bit unsigned seeds; Lightning enforces the same range.
SEED_MIN, SEED_MAX = 0, 2**32 - 1

__all__ = [
    "HPARAMS", "POLICIES", "STEPS_PER_BLOCK", "VAL_BATCH_SIZE", "PREDICT_BATCH_SIZE",
    "Trainable", "ArrayDataset", "EpochLoss", "LeanFitResult",
    "apply_trainable", "count_parameters", "seed_all", "net_from_hparams", "make_optimizer",
    "batch_mae", "train_block", "train_epoch", "train_loader", "val_loader",
    "as_model_inputs", "predict", "read_checkpoint", "fine_tune_lean", "save_checkpoint_lean",
]  # fmt: skip


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


def train_loader(
    dataset: ArrayDataset, *, batch_size: int, seed: int, steps_per_block: int = STEPS_PER_BLOCK
) -> DataLoader:
    """Shuffled training blocks: the one sample order both training paths use.

    Each pass over the loader is one epoch: one permutation of the samples from
    a generator seeded with ``seed`` (independent of the global RNG; it advances
    from epoch to epoch), cut into blocks of ``steps_per_block * batch_size``
    samples that :func:`train_block` slices into mini-batches. The sequence of
    mini-batches is therefore that of a plain ``shuffle=True`` loop at
    ``batch_size`` whatever ``steps_per_block`` is.

    Args:
        dataset: the training samples.
        batch_size: samples per optimizer step.
        seed: seed of the shuffling generator.
        steps_per_block: mini-batches per block (a speed knob only).

    Returns:
        A ``DataLoader`` yielding ``(x, y)`` blocks; build it once per fit, since
        the generator is seeded here.
    """
    if batch_size < 1 or steps_per_block < 1:
        raise ValueError(
            f"batch_size and steps_per_block must be positive, got {batch_size}, {steps_per_block}"
        )
    generator = torch.Generator().manual_seed(seed)
    blocks = BatchSampler(
        RandomSampler(dataset, generator=generator),
        batch_size=batch_size * steps_per_block,
        drop_last=False,
    )
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


def net_from_hparams(hparams: Mapping[str, Any]) -> WhONet:
    """Check a WhONetModule's hyperparameters and build its (freshly initialised) network.

    Args:
        hparams: the :data:`HPARAMS` (extra keys are ignored).

    Returns:
        A :class:`WhONet` of that shape; building it draws its initial weights
        from torch's global RNG.

    Raises:
        ValueError: for a non-positive ``seq_len``, ``batch_size`` or ``lr``, or
            a shape :class:`WhONet` refuses.
    """
    seq_len, lr, batch_size = hparams["seq_len"], hparams["lr"], hparams["batch_size"]
    if seq_len < 1 or batch_size < 1 or lr <= 0:
        raise ValueError(
            f"seq_len and batch_size must be positive and lr > 0, got {seq_len}, {batch_size}, {lr}"
        )
    return WhONet(
        n_features=hparams["n_features"],
        hidden=hparams["hidden"],
        layers=hparams["layers"],
        dropout=hparams["dropout"],
    )


def make_optimizer(module: nn.Module, lr: float) -> torch.optim.Optimizer:
    """Adamax over the trainable parameters (paper §3.3.1).

    Adamax, as the paper states (the authors' code builds Adam), with PyTorch's
    default betas and epsilon and no learning-rate decay. Only parameters with
    ``requires_grad`` are handed to it, so a freeze policy applied before holds.

    Args:
        module: a :class:`WhONet` or a module holding one.
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
        losses, sizes = self.losses, self.sizes
        self.losses, self.sizes = [], []
        if not sizes:
            return None
        n = torch.tensor(sizes, dtype=torch.float64)
        return float((torch.stack(losses).double().cpu() * n).sum() / n.sum())


def train_block(
    net: nn.Module,
    optimizer: torch.optim.Optimizer,
    x: torch.Tensor,
    y: torch.Tensor,
    batch_size: int,
    epoch_loss: EpochLoss,
) -> None:
    """One optimizer step per ``batch_size`` slice of a block, in order (paper §3.3.1).

    Args:
        net: the network, in training mode (dropout active).
        optimizer: from :func:`make_optimizer`.
        x: (n, T, F) block of shuffled windows.
        y: (n,) their labels in metres.
        batch_size: samples per step; the last slice may be smaller.
        epoch_loss: receives each slice's loss before its step.
    """
    for start in range(0, len(y), batch_size):
        yb = y[start : start + batch_size]
        loss = batch_mae(net, x[start : start + batch_size], yb)
        epoch_loss.add(loss, len(yb))
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
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
        model: a :class:`~rwhonet.models.module.WhONetModule` or a bare :class:`WhONet`.
        x: (N, seq_len, n_features) float32 windows.
        batch_size: windows per forward pass.
        seq_len: time steps ``x`` must have; defaults to the module's
            ``hparams["seq_len"]`` (a bare WhONet does not record it).

    Returns:
        (N,) float32 predictions.

    Raises:
        InputError: when ``x`` does not match the model's inputs.
    """
    hp = getattr(model, "hparams", {})
    net = model if isinstance(model, WhONet) else getattr(model, "net", None)
    n_features = hp.get("n_features") or (net.rnn.input_size if isinstance(net, WhONet) else None)
    x_t = as_model_inputs(
        x, None, "prediction inputs",
        seq_len=seq_len if seq_len is not None else hp.get("seq_len"),
        n_features=n_features, allow_empty=True,
    )[0]  # fmt: skip
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


# --------------------------------------------------------------------------- lean fine-tuning


@dataclass
class LeanFitResult:
    """What :func:`fine_tune_lean` produced: ``train.FitResult``'s fields, with a bare network.

    Attributes:
        net: the fine-tuned network (in eval mode).
        hparams: the hyperparameters a WhONetModule of this network records
            (:data:`HPARAMS`; ``lr`` and ``batch_size`` are the fine-tuning recipe's).
        history: one ``{"epoch", "train_loss", "val_loss"}`` dict per epoch;
            ``train_loss`` is the MAE in metres, ``val_loss`` None (no validation).
        seconds: wall time of the training epochs.
        samples_per_s: training samples processed per second of ``seconds``.
        n_trainable: trainable scalar weights (after the freeze policy).
        n_total: all scalar weights.
    """

    net: WhONet
    hparams: dict[str, Any]
    history: list[dict[str, Any]]
    seconds: float
    samples_per_s: float
    n_trainable: int
    n_total: int


def read_checkpoint(path: Path | str) -> dict[str, Any]:
    """Read a WhONetModule Lightning checkpoint with plain ``torch.load`` (no Lightning import).

    ``weights_only=True``: the checkpoint holds only dicts, numbers, strings and
    tensors (Lightning writes ``hyper_parameters`` as a plain dict), so nothing
    in it can run code or pull in Lightning classes when unpickled.

    Args:
        path: the ``.ckpt`` file.

    Returns:
        The checkpoint dict.

    Raises:
        InputError: when the file lacks ``state_dict`` or any of :data:`HPARAMS`.
    """
    ckpt = torch.load(path, map_location="cpu", weights_only=True)
    hp = ckpt.get("hyper_parameters") if isinstance(ckpt, dict) else None
    problems = []
    if not isinstance(ckpt, dict) or not isinstance(ckpt.get("state_dict"), Mapping):
        problems.append(Problem(str(path), None, "state_dict", "a state_dict", "none"))
    if not isinstance(hp, Mapping):
        problems.append(
            Problem(str(path), None, "hyper_parameters", "WhONetModule's hyperparameters", "none")
        )
    elif missing := [k for k in HPARAMS if k not in hp]:
        problems.append(
            Problem(str(path), None, "hyper_parameters", f"keys {HPARAMS}", f"{missing} missing")
        )
    if problems:
        raise InputError(problems, "not a WhONetModule checkpoint")
    return ckpt


def fine_tune_lean(
    ckpt_path: Path | str,
    x: np.ndarray,
    y: np.ndarray,
    *,
    adapt: AdaptParams,
    seed: int,
    num_threads: int = 1,
    steps_per_block: int = STEPS_PER_BLOCK,
) -> LeanFitResult:
    """Recalibrate G-WhONet on a target drive's first m seconds, without Lightning (R-WhONet).

    Paper §2.6, §3.3.3. The same algorithm, order of random draws and result
    as :func:`rwhonet.models.train.fine_tune` (module docstring): the network
    shape comes from the checkpoint's hyperparameters, the learning rate and
    batch size from ``adapt``; the freeze policy ``adapt.trainable`` is
    applied; a fresh Adamax trains for ``adapt.epochs`` epochs without
    validation (m is 10-100 samples; there is nothing to spare).

    Args:
        ckpt_path: G-WhONet's Lightning checkpoint.
        x: (m, seq_len, 40) float32 windows of the first m seconds.
        y: (m,) labels in metres.
        adapt: fine-tuning recipe (``adapt:`` in params.yaml).
        seed: seeds dropout and shuffling.
        num_threads: torch CPU threads.
        steps_per_block: optimizer steps per block; changes nothing in the result.

    Returns:
        The fine-tuned network, its hyperparameters, history, timing and
        parameter counts.

    Raises:
        InputError: when the checkpoint is not a WhONetModule's, or the arrays
            do not match its inputs or hold non-finite values.
    """
    torch.set_num_threads(num_threads)
    seed_all(seed)
    ckpt = read_checkpoint(ckpt_path)
    hparams = {k: ckpt["hyper_parameters"][k] for k in HPARAMS}
    hparams.update(lr=adapt.lr, batch_size=adapt.batch_size)
    net = net_from_hparams(hparams)
    state = {
        k.removeprefix(NET_PREFIX): v
        for k, v in ckpt["state_dict"].items()
        if k.startswith(NET_PREFIX)
    }
    net.load_state_dict(state, strict=True)
    x_t, y_t = as_model_inputs(
        x, y, "adaptation samples", seq_len=hparams["seq_len"], n_features=hparams["n_features"]
    )
    n_trainable, n_total = apply_trainable(net, adapt.trainable)
    loader = train_loader(
        ArrayDataset(x_t, y_t),
        batch_size=adapt.batch_size,
        seed=seed,
        steps_per_block=steps_per_block,
    )
    optimizer = make_optimizer(net, adapt.lr)
    # The Trainer of the Lightning path runs with deterministic=True, which sets this
    # process-wide flag; set it too so both paths run the same kernels.
    torch.use_deterministic_algorithms(True)
    net.train()
    history = []
    start = time.perf_counter()
    for epoch in range(adapt.epochs):
        loss_m = train_epoch(net, optimizer, loader, adapt.batch_size)
        history.append({"epoch": epoch, "train_loss": loss_m, "val_loss": None})
    seconds = time.perf_counter() - start
    net.eval()
    return LeanFitResult(
        net=net,
        hparams=hparams,
        history=history,
        seconds=seconds,
        samples_per_s=len(y_t) * adapt.epochs / seconds if seconds > 0 else float("nan"),
        n_trainable=n_trainable,
        n_total=n_total,
    )


def save_checkpoint_lean(result: LeanFitResult, path: Path | str) -> None:
    """Write a checkpoint ``WhONetModule.load_from_checkpoint`` loads, without Lightning.

    The keys are those the Lightning path's ``trainer.save_checkpoint(path,
    weights_only=True)`` writes, with the same values, except ``loops``:

    - ``state_dict``: the network's weights under WhONetModule's names
      (``net.rnn.weight_ih_l0`` ...), which ``load_from_checkpoint`` loads strictly;
    - ``hyper_parameters`` (a plain dict of :data:`HPARAMS`) and
      ``hparams_name: "kwargs"``: what ``save_hyperparameters()`` records and
      ``load_from_checkpoint`` passes to the constructor;
    - ``pytorch-lightning_version``: the installed Lightning's version (read
      from package metadata, not by importing it). Lightning migrates a
      checkpoint from older versions on load; stamping the installed version
      says there is nothing to migrate, which is true, since these keys have
      the current format;
    - ``epoch``: epochs trained; ``global_step``: 0, as the Trainer records for
      this module (manual optimisation with the raw optimizer does not count
      Lightning optimizer steps).

    ``loops`` (the Trainer's progress counters) is left out: it is read only
    when a Trainer resumes a fit (``ckpt_path=``), which a weights-only
    checkpoint cannot do anyway (it has no optimizer state), and a fine-tune
    always starts its own Adamax.

    Args:
        result: from :func:`fine_tune_lean`.
        path: the ``.ckpt`` file to write (parent folders are created).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    state = OrderedDict((NET_PREFIX + k, v) for k, v in result.net.state_dict().items())
    checkpoint = {
        "epoch": len(result.history),
        "global_step": 0,
        "pytorch-lightning_version": version("lightning"),
        "state_dict": state,
        "hparams_name": "kwargs",
        "hyper_parameters": dict(result.hparams),
    }
    torch.save(checkpoint, path)
