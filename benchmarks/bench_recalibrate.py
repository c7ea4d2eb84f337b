"""What one recalibration costs, per recipe and m, on one CPU thread; prints its figures.

    .venv/bin/python benchmarks/bench_recalibrate.py [--repeats 7 --drive-s 3600]

A fleet recalibrates every car (and, with ``continuous``, before every outage),
so the cost per recalibration matters as much as the error it buys. For each
recipe of ``adapt.recipes`` (params.yaml) and each m of ``adapt.m_grid`` this
times :func:`rwhonet.models.adapt.recalibrate` on m seconds of random inputs
shaped like the real ones (min-max scaled windows in [0, 1], labels of a few
decimetres, rear-wheel angles of a car at 10-20 m/s), with G of the params'
architecture, ``torch.set_num_threads(1)``, in one warm process: the median and
range over ``--repeats`` runs. The gradient recipes' cost does not depend on
the weights' values (fixed epochs; ``steps`` may stop early on real data, so
its figure is an upper bound). Then ``continuous`` on one drive of
``--drive-s`` seconds with an outage window starting every 30 s: the whole
drive and the cost per window. Nothing is written.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="runs per recipe and m")
    ap.add_argument("--drive-s", type=int, default=3600, help="drive length for continuous")
    args = ap.parse_args()

    import torch

    from rwhonet.config import load_params
    from rwhonet.contracts import CONTINUOUS, N_FEATURES
    from rwhonet.libraries import quiet
    from rwhonet.models.adapt import AdaptData, continuous_predictions, recalibrate
    from rwhonet.models.whonet import WhONet

    quiet()
    torch.set_num_threads(1)
    params = load_params()
    model, adapt, seed = params.model, params.adapt, params.seeds[0]
    torch.manual_seed(seed)
    net = WhONet(N_FEATURES, model.hidden, model.layers, model.dropout).eval()
    hparams = {
        "seq_len": model.seq_len,
        "n_features": N_FEATURES,
        "hidden": model.hidden,
        "layers": model.layers,
        "dropout": model.dropout,
    }
    rng = np.random.default_rng(seed)
    radius = 0.294
    v_min = params.label.calibration_min_speed_m_s

    def drive(n: int) -> AdaptData:
        speed = rng.uniform(10.0, 20.0, n)
        angle = speed / radius
        return AdaptData(
            x=rng.random((n, model.seq_len, N_FEATURES), dtype=np.float32),
            y=rng.normal(0.3, 0.3, n).astype(np.float32),
            disp_gnss_m=speed * 1.01 + rng.normal(0.0, 0.03, n),
            angle_rl_rad=angle * (1 + rng.normal(0.0, 1e-3, n)),
            angle_rr_rad=angle * (1 + rng.normal(0.0, 1e-3, n)),
        )

    print(
        f"torch {torch.__version__}, 1 thread; WhONet hidden={model.hidden} layers={model.layers} "
        f"seq_len={model.seq_len}; adapt: epochs={adapt.epochs} batch={adapt.batch_size} "
        f"steps.max_steps={adapt.steps.max_steps} ridge_penalty={adapt.ridge_penalty:g}"
    )
    recipes = [r for r in adapt.recipes if r != CONTINUOUS]
    print(f"{'recipe':<12}" + "".join(f"{f'm={m}':>22}" for m in adapt.m_grid))
    for recipe in recipes:
        cells = []
        for m in adapt.m_grid:
            data = drive(m)
            # warm-up
            recalibrate(recipe, net, hparams, data, adapt=adapt, seed=seed, min_speed_m_s=v_min)
            runs = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                recalibrate(recipe, net, hparams, data, adapt=adapt, seed=seed, min_speed_m_s=v_min)
                runs.append(1e3 * (time.perf_counter() - start))
            cells.append(f"{statistics.median(runs):8.1f} ms ({min(runs):.1f}-{max(runs):.1f})")
        print(f"{recipe:<12}" + "".join(f"{c:>22}" for c in cells), flush=True)

    if CONTINUOUS in adapt.recipes:
        n, length = args.drive_s, max(params.evaluate.outages_s)
        data = drive(n)
        starts = np.arange(30, n - length, 30)
        windows = starts[:, None] + np.arange(length)[None, :]
        runs = []
        for _ in range(3):
            start = time.perf_counter()
            continuous_predictions(
                net,
                hparams,
                data,
                np.arange(n),
                windows,
                inner=adapt.continuous.inner,
                penalty=adapt.ridge_penalty,
                window_s=adapt.continuous.window_s,
                min_speed_m_s=v_min,
                source_radii=(radius, radius),
            )
            runs.append(time.perf_counter() - start)
        best = min(runs)
        print(
            f"continuous (inner {adapt.continuous.inner}, window_s={adapt.continuous.window_s}): "
            f"{n} s drive, {len(windows)} windows of {length} s: {best:.2f} s "
            f"= {1e3 * best / len(windows):.2f} ms per window (best of 3)"
        )


if __name__ == "__main__":
    main()
