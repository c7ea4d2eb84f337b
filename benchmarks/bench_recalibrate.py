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
its figure is an upper bound). ``shrink`` runs with evidence measured on
``--evidence-drives`` drives of ``--drive-s`` seconds shaped the same way, and
that measurement (:func:`rwhonet.models.adapt.evidence_terms`, once per seed in
the adapt stage) is timed too. Then every continuous recipe (``continuous``,
``continuous_shrink``) on one drive of ``--drive-s`` seconds with an outage
window starting every 30 s: the whole drive and the cost per window. Nothing
is written.
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
    ap.add_argument(
        "--evidence-drives", type=int, default=10, help="drives the shrink evidence is measured on"
    )
    args = ap.parse_args()

    import torch

    from rwhonet.config import load_params
    from rwhonet.contracts import (
        CONTINUOUS,
        CONTINUOUS_RECIPES,
        CONTINUOUS_SHRINK,
        N_FEATURES,
        SHRINK,
    )
    from rwhonet.libraries import quiet
    from rwhonet.models.adapt import (
        SHRINK_RIDGE,
        AdaptData,
        continuous_predictions,
        evidence_terms,
        recalibrate,
        shrink_evidence,
    )
    from rwhonet.models.loop import predict
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
    evidence = None
    if SHRINK in adapt.recipes or CONTINUOUS_SHRINK in adapt.recipes:
        n, length = args.evidence_drives, args.drive_s
        fleet = [drive(length) for _ in range(n)]

        def flat(name: str) -> np.ndarray:
            return np.concatenate([getattr(d, name) for d in fleet])

        g_pred = np.concatenate([predict(net, d.x).astype(np.float64) for d in fleet])
        start = time.perf_counter()
        terms = evidence_terms(
            np.repeat(np.arange(n), length),
            np.tile(np.arange(length), n),
            flat("disp_gnss_m"),
            flat("angle_rl_rad"),
            flat("angle_rr_rad"),
            g_pred,
            source_radii=(radius, radius),
            min_speed_m_s=v_min,
            min_rest_s=adapt.shrink.min_rest_s,
        )
        evidence = shrink_evidence(terms, "bench")
        print(
            f"shrink evidence: {n} drives of {length} s, {len(terms.k_s)} k each: "
            f"{time.perf_counter() - start:.2f} s (once per seed, G's predictions not included)"
        )
    recipes = [r for r in adapt.recipes if r not in CONTINUOUS_RECIPES]
    print(f"{'recipe':<12}" + "".join(f"{f'm={m}':>22}" for m in adapt.m_grid))
    for recipe in recipes:
        cells = []
        for m in adapt.m_grid:
            data = drive(m)
            kw = dict(
                adapt=adapt,
                seed=seed,
                min_speed_m_s=v_min,
                evidence=evidence,
                source_radii=(radius, radius),
            )
            recalibrate(recipe, net, hparams, data, **kw)  # warm-up
            runs = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                recalibrate(recipe, net, hparams, data, **kw)
                runs.append(1e3 * (time.perf_counter() - start))
            cells.append(f"{statistics.median(runs):8.1f} ms ({min(runs):.1f}-{max(runs):.1f})")
        print(f"{recipe:<12}" + "".join(f"{c:>22}" for c in cells), flush=True)

    n, length = args.drive_s, max(params.evaluate.outages_s)
    data = drive(n)
    starts = np.arange(30, n - length, 30)
    windows = starts[:, None] + np.arange(length)[None, :]
    for recipe in [r for r in adapt.recipes if r in CONTINUOUS_RECIPES]:
        inner = adapt.continuous.inner if recipe == CONTINUOUS else SHRINK_RIDGE
        runs = []
        for _ in range(3):
            start = time.perf_counter()
            continuous_predictions(
                net,
                hparams,
                data,
                np.arange(n),
                windows,
                inner=inner,
                penalty=adapt.ridge_penalty,
                window_s=adapt.continuous.window_s,
                min_speed_m_s=v_min,
                source_radii=(radius, radius),
                evidence=evidence if inner == SHRINK_RIDGE else None,
            )
            runs.append(time.perf_counter() - start)
        best = min(runs)
        print(
            f"{recipe} (inner {inner}, window_s={adapt.continuous.window_s}): "
            f"{n} s drive, {len(windows)} windows of {length} s: {best:.2f} s "
            f"= {1e3 * best / len(windows):.2f} ms per window (best of 3)"
        )


if __name__ == "__main__":
    main()
