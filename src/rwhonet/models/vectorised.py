"""Several training seeds of one network trained at once, each bit for bit as :func:`fit` trains it.

Every seed's network is the same function of different weights, so the seeds
can share one forward and backward pass: their weights are stacked along a
new leading axis (``torch.func.stack_module_state``) and the network's
``features`` runs over all of them with ``torch.func.vmap``; the dropout,
head, loss and Adamax update follow on the stacked tensors. Nothing else
changes: every seed keeps its own initial weights (drawn as
:func:`rwhonet.models.train.fit` draws them), its own sample order (its own
:func:`~rwhonet.models.loop.train_loader`), and its own dropout masks, drawn
from a generator that stands in for the global one of a run of that seed
alone (each epoch's data-loader iterators draw from it too, as in a
Lightning fit). Adamax is elementwise and each seed's loss depends on its
own weights only, so each seed's weights after every step are those of its
own run, bit for bit on the same machine (``tests/models/test_vectorised.py``
checks it against :func:`~rwhonet.models.train.fit`, validation included).

What it saves is the per-step overhead that dominates these small networks:
one set of kernel calls per step for all seeds instead of one per seed
(``benchmarks/bench_train.py`` prints both). The dropout masks cannot be
shared (each seed's must be drawn as its own run draws them), so part of
the step still scales with the number of seeds.

Supported: ``whonet`` at one time step in one layer (the paper's network),
and ``tcn``. ``torch.func.vmap`` has no batching rule for ``nn.RNN`` /
``nn.GRU``, so a ``gru`` (or a WhONet with ``seq_len`` > 1) trains its seeds
one by one. The DVC pipeline trains each seed in its own stage (adding a seed
trains only that seed), so it does not call this; a run over all seeds at
once (a matrix of worlds, a study of seeds) can, and gets the same models.

Single CPU process, 32-bit only (``train.trainer`` at its defaults).
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.func import functional_call, stack_module_state, vmap

from rwhonet.config import ModelParams, TrainParams
from rwhonet.models.loop import (
    STEPS_PER_BLOCK,
    VAL_BATCH_SIZE,
    ArrayDataset,
    EpochLoss,
    batch_mae,
    net_from_hparams,
    seed_all,
    train_loader,
    training_hparams,
    training_inputs,
    val_loader,
)
from rwhonet.models.network import Network


@dataclass
class SeedFit:
    """One seed's trained network (eval mode) and its per-epoch history (as ``FitResult``'s)."""

    seed: int
    net: Network
    hparams: dict[str, Any]
    history: list[dict[str, Any]]


@dataclass
class SeedsFit:
    """Every seed's fit, and the wall time and throughput of training them together."""

    fits: list[SeedFit]
    seconds: float
    samples_per_s: float


class _Features(nn.Module):
    """``net.features`` as a module's forward (what ``functional_call`` calls)."""

    def __init__(self, net: Network) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net.features(x)


def supports(model: ModelParams) -> bool:
    """Whether this network's seeds can be trained together (module docstring)."""
    return model.arch == "tcn" or (
        model.arch == "whonet" and model.seq_len == 1 and model.layers == 1
    )


def fit_seeds(
    x: np.ndarray,
    y: np.ndarray,
    x_val: np.ndarray | None = None,
    y_val: np.ndarray | None = None,
    *,
    seeds: list[int],
    model: ModelParams,
    train: TrainParams,
    steps_per_block: int = STEPS_PER_BLOCK,
) -> SeedsFit:
    """Train one network per seed on the same samples, all at once (module docstring).

    Args:
        x: (N, model.seq_len, 40) float32 windows.
        y: (N,) labels in metres.
        x_val: validation windows, or None / empty to skip validation.
        y_val: validation labels, or None / empty.
        seeds: the training seeds, distinct.
        model: the network (``model:`` in params.yaml); :func:`supports` it.
        train: the recipe (``train:``); its ``trainer`` must be the default single CPU
            process in 32-bit.
        steps_per_block: optimizer steps per block (changes nothing but speed, as in ``fit``).

    Returns:
        One :class:`SeedFit` per seed, in order: the weights and history
        :func:`rwhonet.models.train.fit` gives that seed.

    Raises:
        ValueError: an unsupported network or trainer, or repeated seeds.
        InputError: arrays of the wrong shape or with non-finite values.
    """
    if not supports(model):
        raise ValueError(
            f"model.arch={model.arch!r} (seq_len {model.seq_len}, {model.layers} layer(s)): "
            "torch.func.vmap has no batching rule for nn.RNN / nn.GRU; train its seeds one by one"
        )
    trainer = train.trainer
    if (trainer.accelerator, trainer.world_size, trainer.precision) != ("cpu", 1, "32-true"):
        raise ValueError("fit_seeds runs one CPU process in 32-bit (train.trainer's defaults)")
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must be distinct and at least one, got {seeds}")
    x_t, y_t, x_val_t, y_val_t = training_inputs(x, y, x_val, y_val, model.seq_len)
    val_set = None if x_val_t is None else ArrayDataset(x_val_t, y_val_t)
    torch.set_num_threads(train.num_threads)
    hparams = training_hparams(model, train, x_t.shape[2])
    caller_rng = torch.get_rng_state()
    dataset = ArrayDataset(x_t, y_t)
    nets, rngs, loaders = [], [], []
    for seed in seeds:
        seed_all(seed)  # what fit's L.seed_everything does to the generators
        nets.append(net_from_hparams(hparams))  # the initial weights of that seed's fit
        rngs.append(_generator_at(torch.get_rng_state()))  # its global RNG from here on
        loaders.append(
            train_loader(
                dataset, batch_size=train.batch_size, seed=seed, steps_per_block=steps_per_block
            )
        )
    stacked, buffers = stack_module_state([_Features(n) for n in nets])
    params = {k: nn.Parameter(v.detach().clone()) for k, v in stacked.items()}
    skeleton = _Features(copy.deepcopy(nets[0])).to("meta")
    features = vmap(lambda p, b, xs: functional_call(skeleton, (p, b), (xs,)))
    head_w, head_b = params["net.head.weight"], params["net.head.bias"]
    optimizer = torch.optim.Adamax(list(params.values()), lr=train.lr)
    keep = 1.0 - model.dropout
    histories: list[list[dict[str, Any]]] = [[] for _ in seeds]
    losses = [EpochLoss() for _ in seeds]
    start = time.perf_counter()
    try:
        for epoch in range(train.epochs):
            blocks = [
                _with_rng(g, lambda ld=ld: iter(ld)) for g, ld in zip(rngs, loaders, strict=True)
            ]
            for block in zip(*blocks, strict=True):
                xb = torch.stack([b[0] for b in block])  # (S, n, T, F): each seed's own samples
                yb = torch.stack([b[1] for b in block])
                for i in range(0, yb.shape[1], train.batch_size):
                    xs, ys = xb[:, i : i + train.batch_size], yb[:, i : i + train.batch_size]
                    h = features(params, buffers, xs)
                    if model.dropout > 0:  # nn.Dropout's CPU kernel: bernoulli_, div_, multiply
                        noise = torch.stack(
                            [torch.empty(h.shape[1:]).bernoulli_(keep, generator=g) for g in rngs]
                        )
                        h = h * noise.div_(keep)
                    # the head and loss per seed, as nn.Linear and l1_loss compute them
                    per_seed = [
                        nn.functional.l1_loss(
                            torch.addmm(head_b[s], h[s], head_w[s].t()).squeeze(-1), ys[s]
                        )
                        for s in range(len(seeds))
                    ]
                    for s, loss in enumerate(per_seed):
                        losses[s].add(loss, ys.shape[1])
                    optimizer.zero_grad(set_to_none=True)
                    torch.stack(per_seed).sum().backward()
                    optimizer.step()
            for s, (net, g) in enumerate(zip(nets, rngs, strict=True)):
                val_loss = None
                if val_set is not None:
                    _load(net, params, s)
                    val_loss = _with_rng(g, lambda net=net: _validate(net, val_set))
                histories[s].append(
                    {"epoch": epoch, "train_loss": losses[s].pop_mean(), "val_loss": val_loss}
                )
    finally:
        torch.set_rng_state(caller_rng)
    seconds = time.perf_counter() - start
    fits = []
    for s, (seed, net) in enumerate(zip(seeds, nets, strict=True)):
        _load(net, params, s)
        fits.append(SeedFit(seed, net.eval(), dict(hparams), histories[s]))
    n_samples = len(seeds) * len(dataset) * train.epochs
    return SeedsFit(fits, seconds, n_samples / seconds if seconds > 0 else float("nan"))


def _generator_at(state: torch.Tensor) -> torch.Generator:
    g = torch.Generator()
    g.set_state(state)
    return g


def _with_rng(g: torch.Generator, function):
    """``function()`` with ``g`` as torch's global generator (as in a run of that seed alone)."""
    torch.set_rng_state(g.get_state())
    try:
        return function()
    finally:
        g.set_state(torch.get_rng_state())


def _validate(net: Network, val_set: ArrayDataset) -> float | None:
    """The validation MAE as the LightningModule computes it (eval mode, no gradients)."""
    net.eval()
    loss = EpochLoss()
    with torch.inference_mode():
        for xv, yv in val_loader(val_set, batch_size=VAL_BATCH_SIZE):
            loss.add(batch_mae(net, xv, yv), len(yv))
    net.train()
    return loss.pop_mean()


def _load(net: Network, params: dict[str, torch.Tensor], s: int) -> None:
    """Seed ``s``'s slice of the stacked weights into its own network."""
    with torch.no_grad():
        for name, p in net.named_parameters():
            p.copy_(params[f"net.{name}"][s])
