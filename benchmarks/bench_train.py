"""How fast WhONet trains, adapts and is evaluated on this machine; prints its figures.

    .venv/bin/python benchmarks/bench_train.py [--samples 95000 --epochs 2 --repeats 2]
        [--arch whonet|gru|tcn --seq-len 32] [--seeds-only]

Data are random but shaped like the real features (min-max scaled wheel-speed
windows (N, seq_len, 40) in [0, 1], labels of a few decimetres); N = 95,000 is
about the paper fleet's 26 h of one-second samples. Settings come from
params.yaml (model, train, adapt, evaluate sections).

Training variants, all on the same data, model, Adamax, MAE loss and batch size:

- plain:          a hand-written PyTorch loop (the floor).
- lightning-naive: automatic optimisation, ``DataLoader(TensorDataset, shuffle=True)``
                  (per-sample ``__getitem__`` + collate), ``self.log`` every step, lean Trainer.
- lightning-auto: automatic optimisation, batched loading (one gather per batch),
                  no per-step logging.
- rwhonet block=1: ``rwhonet.models.train.fit`` with one optimizer step per Lightning batch.
- rwhonet block=K: ``fit`` as the pipeline runs it (K steps per Lightning batch).

- per-seed vs vectorised: every seed of ``seeds`` trained one after the other
  (``fit``) and all at once (:func:`rwhonet.models.vectorised.fit_seeds`, the same
  weights), for WhONet and for the networks with temporal context (``--arch``
  picks the one the rest of the benchmark runs; ``--seeds-only`` runs this part
  alone). Samples per second of wall time and per CPU second of this process:
  on a shared machine the wall figure moves with the other load, the CPU one
  much less.

Then the adaptation grid (adapt.m_grid x 4 drives, m samples each, adapt.epochs
epochs, in one process) with the paper recipe (``rwhonet.models.adapt.fine_tune``);
the cold-start cost of a stage process (a fresh interpreter importing its entry
point and building the optimizer), with and without Lightning, which is why the
adapt stage covers the whole grid in one process without a Trainer; and the
evaluation (CRSE/CTE windows for every evaluate.outages_s) on N seconds of errors.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from rwhonet.config import load_params
from rwhonet.libraries import quiet


def _plain(x, y, model, train, seed: int) -> float:
    """Samples/s of a plain PyTorch loop over the same model and batches."""
    import torch
    from torch import nn

    torch.set_num_threads(train.num_threads)
    torch.manual_seed(seed)
    net = _net(x.shape[2], model, train).train()
    opt = torch.optim.Adamax(net.parameters(), lr=train.lr)
    xt, yt = torch.from_numpy(x), torch.from_numpy(y)
    gen = torch.Generator().manual_seed(seed)
    n, bs = len(yt), train.batch_size
    start = time.perf_counter()
    for _ in range(train.epochs):
        perm = torch.randperm(n, generator=gen)
        for i in range(0, n, bs):
            idx = perm[i : i + bs]
            loss = nn.functional.l1_loss(net(xt[idx]), yt[idx])
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
    return n * train.epochs / (time.perf_counter() - start)


def _net(n_features: int, model, train):
    """The network ``model.arch`` selects, as fit builds it."""
    from rwhonet.models.loop import net_from_hparams, training_hparams

    return net_from_hparams(training_hparams(model, train, n_features))


def _lightning_baseline(x, y, model, train, seed: int, *, naive: bool) -> float:
    """Samples/s of a conventional one-step-per-batch LightningModule (the comparison)."""
    import lightning as L
    import torch
    from torch import nn
    from torch.utils.data import DataLoader, TensorDataset

    from rwhonet.models.datamodule import WhONetDataModule

    class Conventional(L.LightningModule):
        def __init__(self) -> None:
            super().__init__()
            self.net = _net(x.shape[2], model, train)

        def training_step(self, batch, batch_idx):
            xb, yb = batch
            loss = nn.functional.l1_loss(self.net(xb), yb)
            if naive:
                self.log("train/loss", loss)
            return loss

        def configure_optimizers(self):
            return torch.optim.Adamax(self.parameters(), lr=train.lr)

    torch.set_num_threads(train.num_threads)
    L.seed_everything(seed, verbose=False)
    xt, yt = torch.from_numpy(x), torch.from_numpy(y)
    if naive:
        loader = DataLoader(TensorDataset(xt, yt), batch_size=train.batch_size, shuffle=True)
    else:
        dm = WhONetDataModule(xt, yt, batch_size=train.batch_size, seed=seed, steps_per_block=1)
        loader = dm.train_dataloader()
    trainer = L.Trainer(
        accelerator="cpu",
        devices=1,
        max_epochs=train.epochs,
        logger=False,
        enable_progress_bar=False,
        enable_model_summary=False,
        enable_checkpointing=False,
        num_sanity_val_steps=0,
        log_every_n_steps=50,
        deterministic=True,
    )
    module = Conventional()
    start = time.perf_counter()
    trainer.fit(module, loader)
    return len(yt) * train.epochs / (time.perf_counter() - start)


# What a stage process pays before fitting: import the entry point and build the
# optimizer (torch.optim imports torch._dynamo on the first optimizer it builds).
COLD_START = {
    "train stage (Lightning)": (
        "import torch; from rwhonet.models.train import fit; "
        "torch.optim.Adamax(torch.nn.Linear(2, 1).parameters())"
    ),
    "adapt stage (no Lightning)": (
        "import torch; from rwhonet.stages import adapt; from rwhonet.models.adapt import "
        "fine_tune; torch.optim.Adamax(torch.nn.Linear(2, 1).parameters())"
    ),
}


def _cold_start_s(code: str) -> float:
    """Wall seconds of a fresh interpreter running ``code``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - start


def _grid(net, hparams, drives, adapt, seed: int) -> tuple[float, list[float]]:
    """Run the paper recipe at every (m, drive); return (wall seconds, per-run fit seconds)."""
    from rwhonet.models.adapt import AdaptData, fine_tune

    fit_s = []
    start = time.perf_counter()
    for m in adapt.m_grid:
        for xd, yd in drives:
            zeros = np.zeros(m)
            data = AdaptData(xd[:m], yd[:m], zeros, zeros, zeros)
            fit_s.append(fine_tune(net, hparams, data, adapt=adapt, seed=seed).seconds)
    return time.perf_counter() - start, fit_s


def _seeds_table(n: int, epochs: int, repeats: int, seq_len: int, seeds: list[int]) -> None:
    """Samples/s of training every seed one by one (fit) and all at once (fit_seeds)."""
    from rwhonet.models.train import fit
    from rwhonet.models.vectorised import fit_seeds, supports

    params = load_params()
    train = replace(params.train, epochs=epochs)
    rng = np.random.default_rng(0)
    print(
        f"Seeds {seeds}, N={n}, {epochs} epochs, batch {train.batch_size}: samples/s of wall time "
        "(per CPU second of this process), median of "
        f"{repeats}; vectorised = rwhonet.models.vectorised.fit_seeds, the same weights"
    )
    for arch, t in (("whonet", 1), ("tcn", seq_len), ("gru", seq_len)):
        model = replace(params.model, arch=arch, seq_len=t)
        x = rng.random((n, t, 40), dtype=np.float32)
        y = rng.normal(0.0, 0.3, n).astype(np.float32)
        runs: dict[str, list[tuple[float, float]]] = {"per-seed": [], "vectorised": []}
        for _ in range(repeats):
            runs["per-seed"].append(
                _timed_samples(
                    lambda x=x, y=y, model=model: [
                        fit(x, y, model=model, train=train, seed=s) for s in seeds
                    ],
                    len(seeds) * n * epochs,
                )
            )
            if supports(model):
                runs["vectorised"].append(
                    _timed_samples(
                        lambda x=x, y=y, model=model: fit_seeds(
                            x, y, model=model, train=train, seeds=seeds
                        ),
                        len(seeds) * n * epochs,
                    )
                )
        cells = []
        for name, got in runs.items():
            if not got:
                cells.append(f"{name}: (no vmap batching rule for nn.GRU)")
                continue
            wall = statistics.median(w for w, _ in got)
            cpu = statistics.median(c for _, c in got)
            cells.append(f"{name} {wall / 1e3:6.1f} k ({cpu / 1e3:6.1f} k per CPU s)")
        print(f"  {arch:<6} seq_len {t:>3}: " + "; ".join(cells), flush=True)


def _timed_samples(fn: Callable[[], object], samples: int) -> tuple[float, float]:
    """(samples per wall second, samples per CPU second of this process) of ``fn()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return samples / (time.perf_counter() - wall), samples / (time.process_time() - cpu)


def _measure(name: str, fn: Callable[[], float], repeats: int, table: dict) -> None:
    runs = [fn() for _ in range(repeats)]
    table[name] = runs
    print(f"  {name:<18} {_fmt(runs)}", flush=True)


def _fmt(runs: list[float]) -> str:
    lo, hi, med = min(runs), max(runs), statistics.median(runs)
    return f"{med / 1e3:7.1f} k samples/s (median; range {lo / 1e3:.1f}-{hi / 1e3:.1f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=95_000, help="training samples (seconds)")
    ap.add_argument("--epochs", type=int, default=2, help="epochs per training measurement")
    ap.add_argument("--repeats", type=int, default=2, help="runs per training variant")
    ap.add_argument("--drives", type=int, default=4, help="target test drives in the grid")
    ap.add_argument("--steps-per-block", type=int, default=None, help="fit's block size")
    ap.add_argument("--arch", default=None, help="model.arch (default: params.yaml's)")
    ap.add_argument("--seq-len", type=int, default=32, help="seq_len of gru and tcn")
    ap.add_argument("--seeds-only", action="store_true", help="only per-seed vs vectorised")
    ap.add_argument("--seed-samples", type=int, default=20_000, help="N of that comparison")
    args = ap.parse_args()

    quiet()
    if args.seeds_only:
        seeds = load_params().seeds
        _seeds_table(args.seed_samples, args.epochs, args.repeats, args.seq_len, seeds)
        return
    t0 = time.perf_counter()
    import lightning  # noqa: F401  (import cost reported separately)
    import torch

    from rwhonet.evaluation.scoring import summarise, window_metrics
    from rwhonet.models.loop import STEPS_PER_BLOCK
    from rwhonet.models.train import fit

    import_s = time.perf_counter() - t0
    params = load_params()
    model, seed = params.model, params.seeds[0]
    if args.arch is not None and args.arch != model.arch:
        model = replace(model, arch=args.arch, seq_len=1 if args.arch == "whonet" else args.seq_len)
    train = replace(params.train, epochs=args.epochs)
    block = args.steps_per_block or STEPS_PER_BLOCK

    rng = np.random.default_rng(seed)
    n = args.samples
    x = rng.random((n, model.seq_len, 40), dtype=np.float32)
    y = rng.normal(0.0, 0.3, n).astype(np.float32)
    print(
        f"torch {torch.__version__}, {torch.get_num_threads()} default threads, "
        f"train.num_threads={train.num_threads}; import lightning+rwhonet.models {import_s:.1f} s"
    )
    print(
        f"G training: arch={model.arch}, N={n}, seq_len={model.seq_len}, hidden={model.hidden}, "
        f"batch={train.batch_size}, {train.epochs} epochs x {args.repeats} repeats"
    )
    _plain(x[:5000], y[:5000], model, replace(train, epochs=1), seed)  # warm-up
    table: dict[str, list[float]] = {}
    _measure("plain", lambda: _plain(x, y, model, train, seed), args.repeats, table)
    _measure(
        "lightning-naive",
        lambda: _lightning_baseline(x, y, model, train, seed, naive=True),
        args.repeats,
        table,
    )
    _measure(
        "lightning-auto",
        lambda: _lightning_baseline(x, y, model, train, seed, naive=False),
        args.repeats,
        table,
    )
    results = {}

    def ours(k: int) -> float:
        results[k] = fit(x, y, model=model, train=train, seed=seed, steps_per_block=k)
        return results[k].samples_per_s

    _measure("rwhonet block=1", lambda: ours(1), args.repeats, table)
    _measure(f"rwhonet block={block}", lambda: ours(block), args.repeats, table)
    plain = statistics.median(table["plain"])
    print("  Lightning overhead (plain samples/s / variant samples/s, medians):")
    for name, runs in table.items():
        med = statistics.median(runs)
        ms_step = 1e3 * train.batch_size / med
        print(f"    {name:<18} x{plain / med:.2f}  ({ms_step:.3f} ms per optimizer step)")

    adapt = params.adapt
    drives = [
        (
            rng.random((max(adapt.m_grid), model.seq_len, 40), dtype=np.float32),
            rng.normal(0.3, 0.3, max(adapt.m_grid)).astype(np.float32),
        )
        for _ in range(args.drives)
    ]
    g = results[block].module
    grid_s, fit_s = _grid(g.net, dict(g.hparams), drives, adapt, seed)
    n_runs = len(adapt.m_grid) * args.drives
    print(
        f"Adaptation grid: {len(adapt.m_grid)} m values x {args.drives} drives = {n_runs} "
        f"fine-tunes (m = {adapt.m_grid[0]}-{adapt.m_grid[-1]} samples, {adapt.epochs} epochs, "
        f"batch {adapt.batch_size}, the paper recipe), in one process; every recipe: "
        "benchmarks/bench_recalibrate.py"
    )
    print(
        f"  whole grid {grid_s:5.1f} s; {1e3 * grid_s / n_runs:4.0f} ms per fine-tune "
        f"(of which training {1e3 * statistics.median(fit_s):.0f} ms median)"
    )
    print("Cold start of a stage process (fresh interpreter: import + first optimizer), 3 runs:")
    cold = {}
    for name, code in COLD_START.items():
        runs = sorted(_cold_start_s(code) for _ in range(3))
        cold[name] = runs[1]
        print(f"  {name:<28} {runs[1]:.1f} s median (range {runs[0]:.1f}-{runs[-1]:.1f})")
    per_m = len(adapt.m_grid) * cold["adapt stage (no Lightning)"] + grid_s
    print(
        f"  the grid as one process per m would cost about {per_m:.0f} s "
        f"({len(adapt.m_grid)} cold starts + the grid), as one process "
        f"{cold['adapt stage (no Lightning)'] + grid_s:.0f} s"
    )

    group = np.repeat(np.arange(40), -(-n // 40))[:n]  # ~40 segments
    e = rng.normal(0.0, 0.5, n)
    d = rng.uniform(0.0, 30.0, n)
    print(f"Evaluation: {n} s of errors in 40 segments")
    for outage in params.evaluate.outages_s:
        reps = []
        for _ in range(5):
            start = time.perf_counter()
            w = window_metrics(e, d, group, outage)
            summarise(w)
            reps.append(time.perf_counter() - start)
        best = min(reps)
        if not len(w):
            print(f"  L={outage:>4} s: no window in {n} s of 40 segments (use more --samples)")
            continue
        print(
            f"  L={outage:>4} s: {len(w):5d} windows in {1e3 * best:6.2f} ms "
            f"= {1e6 * best / len(w):6.2f} µs per window (best of 5)"
        )


if __name__ == "__main__":
    main()
