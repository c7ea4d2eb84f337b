"""What serving costs: one-second prediction latency, batch throughput, `predict` and `recalibrate`.

    .venv/bin/python benchmarks/bench_serve.py [--steps 5000 --repeats 3]

Prints, on this machine:

1. single-step latency (one window of one second, batch 1), p50 and p99 over
   ``--steps`` calls after a warm-up, on one thread: PyTorch (``inference_mode``,
   ``torch.set_num_threads(1)``) and ONNX Runtime (``intra_op_num_threads=1``);
2. batch throughput (windows per second) at batch 3,600 (an hour of seconds);
3. ``rwhonet predict`` end to end on a one-hour simulated drive (36,000 rows):
   a fresh process reading the file, and the same drive piped through stdin,
   each writing CSV; and the streaming itself inside a warm process; then, where
   ``--real`` names a comma2k19 segment folder (default: the real RAV4 minute in
   ``../shared/real``), ``predict`` on it in a fresh process (a stream format: the
   resampler and the fixes' lag estimate run first);
4. ``rwhonet recalibrate`` end to end (a fresh process: reading and validating
   the drive, recalibrating at m = 50 s, scoring, exporting, registering in a
   fresh MLflow store) for the ``paper`` and ``radius+G`` recipes.

The base model is the workspace's G (``models/g/seed42/model.pt`` with
``data/processed``'s scaler and radii) when the pipeline has run, else a freshly
initialised WhONet of the same shape (the cost does not depend on the weights).
Nothing is written outside a temporary folder.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT / ".." / "shared" / "real" / "comma2k19-example1"


def percentiles(times_s: list[float]) -> tuple[float, float]:
    a = np.asarray(times_s) * 1e6
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


def hour_drive(folder: Path) -> Path:
    """A one-hour drive of the target car (the paper profile's V-Delta2 spec), as IO-VNBD CSV."""
    from rwhonet.config import load_params
    from rwhonet.sim import generate_route, simulate_drive, vehicles_from_params

    params = load_params()
    spec = next(d for d in params.sim.profiles["paper"].drives if d.name == "V-Delta2")
    car = vehicles_from_params(params, "paper")["target"]
    rng = np.random.default_rng(1)
    route = generate_route(spec, params.sim, car, rng)
    drive = simulate_drive(car, spec.tyre, route, 1, params.sim, name="V-Hour")
    path = folder / "V-Hour.csv"
    drive.frame.to_csv(path, index=False)
    return path


def base_bundle(folder: Path) -> tuple[dict, str]:
    from rwhonet import paths
    from rwhonet.io import read_json
    from rwhonet.serve.bundle import make_meta, write_bundle

    g = paths.model_dir("g", 42) / "model.pt"
    if g.is_file() and paths.SCALER.is_file() and paths.CALIBRATION.is_file():
        scaler, cal, which = read_json(paths.SCALER), read_json(paths.CALIBRATION), paths.rel(g)
    else:
        import torch

        from rwhonet.data.canonical import FEATURE_WHEEL_ORDER
        from rwhonet.models.checkpoint import save_whonet
        from rwhonet.models.whonet import WhONet

        torch.manual_seed(0)
        g = folder / "g.pt"
        hp = {
            "n_features": 40,
            "hidden": 72,
            "layers": 1,
            "dropout": 0.05,
            "seq_len": 1,
            "lr": 7e-4,
            "batch_size": 128,
        }
        save_whonet(WhONet(), hp, g)
        scaler = {
            "kind": "global",
            "wheels": list(FEATURE_WHEEL_ORDER),
            "min_rad_s": [0.0] * 4,
            "max_rad_s": [110.0] * 4,
        }
        cal, which = {"r_rl_m": 0.2917, "r_rr_m": 0.2916}, "a fresh WhONet"
    meta = make_meta({}, scaler, cal, "integrated", None, {"name": "whonet-G", "model": "G"})
    return write_bundle(g, meta, folder / "g"), which


def run(cmd: list[str], env: dict, stdin: Path | None = None) -> float:
    start = time.perf_counter()
    with open(stdin, "rb") if stdin else open(os.devnull, "rb") as f:
        out = subprocess.run(cmd, stdin=f, env=env, capture_output=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if out.returncode:
        sys.exit(f"{' '.join(cmd)} failed:\n{out.stderr.decode()[-2000:]}")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=5000, help="single-step calls timed")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each end-to-end command")
    ap.add_argument("--real", type=Path, default=REAL, help="a comma2k19 segment folder")
    args = ap.parse_args()

    import torch

    from rwhonet.libraries import quiet
    from rwhonet.models.checkpoint import load_whonet
    from rwhonet.serve.model import load_served

    quiet()
    torch.set_num_threads(1)
    tmp = Path(tempfile.mkdtemp(prefix="bench-serve-"))
    bundle, which = base_bundle(tmp)
    net, _ = load_whonet(bundle["model_safetensors"])
    served = load_served(bundle["model_onnx"])
    print(f"model: {which}; {os.cpu_count()} CPUs; torch {torch.__version__}, one thread\n")

    rng = np.random.default_rng(0)
    x1 = rng.uniform(0, 1, (1, 1, 40)).astype(np.float32)
    xt = torch.from_numpy(x1)
    session, name = served.session, served.session.get_inputs()[0].name
    timings: dict[str, list[float]] = {"PyTorch": [], "ONNX Runtime": []}
    with torch.inference_mode():
        for label, call in (
            ("PyTorch", lambda: net(xt)),
            ("ONNX Runtime", lambda: session.run(None, {name: x1})),
        ):
            for _ in range(500):
                call()
            for _ in range(args.steps):
                t = time.perf_counter()
                call()
                timings[label].append(time.perf_counter() - t)
    print(f"1. single-step latency (batch 1, one second), {args.steps} calls:")
    for label, ts in timings.items():
        p50, p99 = percentiles(ts)
        print(f"   {label:<13} p50 {p50:7.1f} us   p99 {p99:7.1f} us")
    print("   target: ONNX p99 < 100 us per one-second step\n")

    xb = rng.uniform(0, 1, (3600, 1, 40)).astype(np.float32)
    print("2. batch throughput, batch 3,600 (best of 20):")
    with torch.inference_mode():
        for label, call in (
            ("PyTorch", lambda: net(torch.from_numpy(xb))),
            ("ONNX Runtime", lambda: session.run(None, {name: xb})),
        ):
            best = min(_timed(call) for _ in range(20))
            print(f"   {label:<13} {3600 / best / 1e6:6.2f} M windows/s ({best * 1e3:.2f} ms)")

    drive = hour_drive(tmp)
    rows = sum(1 for _ in open(drive)) - 1
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT / "src"),
        "MLFLOW_TRACKING_URI": f"sqlite:///{tmp}/mlruns/mlflow.db",
    }
    cli = [sys.executable, "-m", "rwhonet.cli.main"]
    onnx = str(bundle["model_onnx"])
    print(f"\n3. rwhonet predict, one-hour drive ({rows:,} rows), {args.repeats} runs:")
    file_runs = [
        run(
            [
                *cli,
                "predict",
                "--model",
                onnx,
                "--drive",
                str(drive),
                "--output",
                str(tmp / "out.csv"),
                "--outage",
                "300:480",
                "--quiet",
            ],
            env,
        )
        for _ in range(args.repeats)
    ]
    pipe_runs = [
        run(
            [
                *cli,
                "predict",
                "--model",
                onnx,
                "--drive",
                "-",
                "--output",
                str(tmp / "out2.csv"),
                "--quiet",
            ],
            env,
            stdin=drive,
        )
        for _ in range(args.repeats)
    ]
    start_only = [
        run(
            [
                sys.executable,
                "-c",
                "import rwhonet.cli.main, rwhonet.cli.drive, rwhonet.cli.predict,"
                " rwhonet.serve.stream, rwhonet.data.incremental, rwhonet.data.drivefile,"
                " rwhonet.data.drivechecks, onnxruntime",
            ],
            env,
        )
        for _ in range(args.repeats)
    ]
    print(f"   file -> CSV, fresh process:        {_range(file_runs)} s")
    print(f"   stdin pipe -> CSV, fresh process:  {_range(pipe_runs)} s")
    print(f"   of which interpreter + imports:    {_range(start_only)} s")
    from rwhonet.cli import predict

    warm = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        predict.run(served, str(drive), str(tmp / "out3.csv"), [])
        warm.append(time.perf_counter() - t)
    print(f"   streaming in a warm process:       {_range(warm)} s")
    print("   target: a one-hour drive streamed in < 1 s")
    if args.real.is_dir():
        real = [
            run(
                [
                    *cli,
                    "predict",
                    "--model",
                    onnx,
                    "--drive",
                    str(args.real),
                    "--format",
                    "comma2k19",
                    "--nominal-radius",
                    "0.362",
                    "--output",
                    str(tmp / "real.csv"),
                    "--quiet",
                ],
                env,
            )
            for _ in range(args.repeats)
        ]
        print(f"   {args.real.name} (comma2k19 folder) -> CSV, fresh process: {_range(real)} s")
    else:
        print(f"   (no comma2k19 folder at {args.real}: its predict not timed)")

    print(
        f"\n4. rwhonet recalibrate end to end, m = 50 s, fresh process, {args.repeats} runs "
        "(2 cores):"
    )
    from rwhonet.tracking.registry import log_bundle
    from rwhonet.tracking.store import open_store

    client, exp = open_store(env["MLFLOW_TRACKING_URI"], "rwhonet")
    import pandas as pd

    example = pd.DataFrame(
        np.full((2, 40), 0.5, np.float32), columns=[f"x_{i:02d}" for i in range(40)]
    )
    log_bundle(
        client,
        client.create_run(exp, run_name="G").info.run_id,
        "whonet-G",
        bundle,
        example,
        {"model": "G"},
    )
    for recipe in ("radius+G", "paper"):
        walls = [
            run(
                [
                    *cli,
                    "recalibrate",
                    "--base",
                    "models:/whonet-G/latest",
                    "--drive",
                    str(drive),
                    "--seconds",
                    "50",
                    "--recipe",
                    recipe,
                ],
                env,
            )
            for _ in range(args.repeats)
        ]
        print(f"   {recipe:<9} {_range(walls)} s")
    print("   target: < 10 s")


def _timed(call) -> float:
    t = time.perf_counter()
    call()
    return time.perf_counter() - t


def _range(values: list[float]) -> str:
    return f"{min(values):.2f}-{max(values):.2f} (median {statistics.median(values):.2f})"


if __name__ == "__main__":
    main()
