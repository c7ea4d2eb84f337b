"""G's training on one process vs several (Lightning DDP, gloo on CPU); prints samples/s.

    .venv/bin/python benchmarks/bench_ddp.py [--samples 95000 --epochs 5 --repeats 2]

Each configuration runs in a fresh interpreter (DDP's launcher starts the
other ranks by running this script again): ``rwhonet.models.train.fit`` with
params.yaml's model and train sections, ``train.trainer`` set per row. Random
data shaped like the features (as ``bench_train.py``). Reported: training
samples per second of ``Trainer.fit`` (all processes together; validation
included), and the process's wall time, which adds interpreter start, imports
and, for DDP, starting the second rank and the process group. Rows:

- 1 process, batch 128: the pipeline's default.
- 2 processes x 64: the same global mini-batches as one process at 128
  (same results up to rounding; tests/stages/test_train_ddp.py).
- 2 processes x 128: an effective batch of 256, half the optimizer steps.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np

CONFIGS = [(1, 128), (2, 64), (2, 128)]  # (processes, batch size per process)


def one(samples: int, epochs: int, devices: int, batch_size: int) -> None:
    """Run one fit; rank 0 prints a JSON line with its figures."""
    from rwhonet.config import load_params
    from rwhonet.libraries import quiet
    from rwhonet.models.train import fit

    quiet()
    params = load_params()
    rng = np.random.default_rng(0)
    n_val = samples // 10
    x = rng.uniform(0, 1, (samples + n_val, params.model.seq_len, 40)).astype(np.float32)
    y = (0.3 * x[:, -1, 0] - 0.2 * x[:, -1, 7] + rng.normal(0, 0.05, len(x))).astype(np.float32)
    trainer = replace(
        params.train.trainer, devices=devices, strategy="ddp" if devices > 1 else "auto"
    )
    train = replace(params.train, epochs=epochs, batch_size=batch_size, trainer=trainer)
    r = fit(
        x[:samples], y[:samples], x[samples:], y[samples:], model=params.model, train=train, seed=0
    )
    if r.global_rank == 0:
        print(
            json.dumps(
                {
                    "samples_per_s": r.samples_per_s,
                    "fit_s": r.seconds,
                    "train_loss": r.history[-1]["train_loss"],
                }
            )
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=95_000)
    ap.add_argument("--epochs", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument(
        "--one", nargs=2, type=int, metavar=("DEVICES", "BATCH"), help=argparse.SUPPRESS
    )
    args = ap.parse_args()
    if args.one:
        one(args.samples, args.epochs, *args.one)
        return
    print(f"G training, {args.samples:,} samples x {args.epochs} epochs, {os.cpu_count()} CPUs")
    print(
        f"{'processes x batch':>18} {'samples/s (fit)':>16} {'fit s':>7} {'wall s':>7} "
        f"{'final train MAE':>16}"
    )
    for _ in range(args.repeats):
        for devices, batch in CONFIGS:
            start = time.perf_counter()
            out = subprocess.run(
                [
                    sys.executable,
                    __file__,
                    "--samples",
                    str(args.samples),
                    "--epochs",
                    str(args.epochs),
                    "--one",
                    str(devices),
                    str(batch),
                ],
                capture_output=True,
                text=True,
                check=True,
            )
            wall = time.perf_counter() - start
            row = json.loads(out.stdout.strip().splitlines()[-1])
            print(
                f"{f'{devices} x {batch}':>18} {row['samples_per_s']:>16,.0f} "
                f"{row['fit_s']:>7.1f} {wall:>7.1f} {row['train_loss']:>16.4f}"
            )


if __name__ == "__main__":
    main()
