"""The gyro figures the navigation filter assumes, against what a fleet's drives say about them.

Run in a reproduced workspace or a world's folder (``build/worlds/<name>``): it
reads that folder's ``params.yaml``, samples, models and ``metrics/eval.json``
(the receiver drift, antenna and gyro latency the evaluation fitted). For each
combination of the grid of the filter's gyro figures (``rwhonet.nav.GyroSpec``
fields; angular ones in degrees, as ``params.yaml`` writes them) it runs the fused filter on the
control model's distances (R-WhONet's, or G's where the rule chose a continuous
recipe; every seed) and prints:

- ``train score``: the fixes' log score on the target *training* drives, every
  second of every segment (``NavTrack.fix_logpdf``: each fix's density under the
  filter's prediction made before it saw it), summed over the drives and averaged
  over seeds, nats; the higher, the better the figures predict that fleet's GNSS;
- ``test``: the mean end-of-outage error over the target *test* windows of
  ``--outage`` s as a share of the distance driven (sum over sum), fused and gyro
  alone, with the figures;
- with ``--per-window``, the same windows when each takes the grid's figures
  whose score over its own segment's seconds before it is highest (a choice an
  online filter bank could make, with the GNSS before each outage).

Nothing is written; the pipeline's figures stay those of ``params.yaml``
(``evaluate.navigation.gyro``). ``docs/positioning.md`` section 7 reports what
this gave on the built-in worlds.

Usage: python benchmarks/gyro_figures.py [--grid bias_instability=0.0025,0.01,0.04 ...]
[--outage 180] [--per-window]
"""

from __future__ import annotations

import argparse
import itertools
import json
from dataclasses import replace

import numpy as np

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation import position as P
from rwhonet.evaluation.model_errors import model_errors, refit_wpm
from rwhonet.evaluation.selection import choose, recommend, selection_scores
from rwhonet.evaluation.study import navigation_plan
from rwhonet.evaluation.uncertainty import fit_variances, training_errors
from rwhonet.nav import GyroSpec, NavInputs, run
from rwhonet.stages.evaluate import collect_predictions, fit_evidence, read_selection

ANGULAR = {"noise_density", "lsb", "bias_sd", "bias_instability", "temp_drift_per_k"}


def _grid(specs: list[str]) -> list[tuple[str, list[float]]]:
    axes = []
    for spec in specs:
        name, _, values = spec.partition("=")
        try:
            if name not in GyroSpec.__dataclass_fields__:
                raise ValueError(name)
            axes.append((name, [float(v) for v in values.split(",")]))
        except ValueError:
            fields = ", ".join(GyroSpec.__dataclass_fields__)
            raise SystemExit(
                f"--grid {spec!r}: expected <GyroSpec field>=v1,v2,... (fields: {fields})"
            ) from None
    return axes


def _inputs(segs: P.Segments, odometry: P.Odometry) -> NavInputs:
    """One run's distances over every segment, with the segments' sensors and fixes."""
    return NavInputs(
        segs.gather(odometry.dist_m),
        segs.gather(odometry.var_m2),
        segs.wheel_yaw,
        segs.gyro_yaw,
        segs.fix_e,
        segs.fix_n,
        segs.backwards,
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", nargs="+", default=["bias_instability=0.0025,0.01,0.04"])
    ap.add_argument("--outage", type=int, default=180, help="outage length, s")
    ap.add_argument("--per-window", action="store_true")
    args = ap.parse_args(argv)
    axes = _grid(args.grid)
    for needed in (paths.PARAMS, paths.EVAL_JSON):
        if not needed.is_file():
            raise SystemExit(f"{needed}: not there; run this in a reproduced project (make run)")
    params = load_params(paths.PARAMS)
    selection = read_selection(params, paths.SAMPLES, paths.MODELS)
    choice = choose(params, recommend(selection_scores(selection, params), params))
    frame, preds = collect_predictions(params, paths.SAMPLES, paths.MODELS)
    evidence = fit_evidence(params, selection, paths.MODELS)
    plan = navigation_plan(params, choice, frame)
    model = plan["control_model"]
    errors = [t for t in training_errors(evidence, [model], params) if not t.per_window]
    fits = fit_variances(evidence, errors, params)
    evaluated = json.loads(paths.EVAL_JSON.read_text())
    receiver = (evaluated.get("position_controls") or {}).get("receiver") or {}
    base = P.nav_config(params)
    geometry = (evaluated.get("position_controls") or {}).get("geometry") or {}
    if geometry.get("antenna_m") is not None:  # the antenna and latency it fitted, as it ran
        base = replace(
            base,
            antenna_m=tuple(geometry["antenna_m"]),
            gyro=replace(base.gyro, latency_s=geometry["gyro_latency_s"]),
        )
    if receiver.get("sigma_m") is not None:  # the drift the evaluation fitted, as it ran
        base = base.with_receiver(receiver["sigma_m"], receiver.get("tau_s"))
    train = evidence.frame
    train_gnss = train[k.DISP_GNSS_M].to_numpy(np.float64)
    train_segs = P.nav_segments(train, params, k.TARGET_TRAIN)
    train_runs = [
        r
        for t in errors
        for r in P.model_runs(
            t.model, t.seed, train_gnss - t.error, fits[(t.seed, t.model)], plan, [args.outage]
        )
        if r.control == "fused"
    ]
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    wpm_m, _ = refit_wpm(frame, params)
    test_runs = []
    for seed in params.seeds:
        e = model_errors(frame, preds[seed], wpm_m, params)[model]
        test_runs += [
            r
            for r in P.model_runs(model, seed, gnss - e, fits[(seed, model)], plan, [args.outage])
            if r.control in ("fused", "gyro")
        ]
    segs = P.nav_segments(frame, params)
    rows = P.target_windows(frame, params, args.outage)
    seg = segs.segment_of[rows[:, 0]]
    before = rows[:, 0] - segs.first_row[seg]
    print(f"{model} on {len(params.seeds)} seeds; {len(rows)} test windows of {args.outage} s")
    per_window = []
    for combo in itertools.product(*[values for _, values in axes]):
        figures = {
            name: float(np.radians(v)) if name in ANGULAR else v
            for (name, _), v in zip(axes, combo, strict=True)
        }
        cfg = replace(base, gyro=replace(base.gyro, **figures))
        score = 0.0
        for r in train_runs:
            score += run(_inputs(train_segs, r), cfg, "fused").fix_logpdf.sum() / len(params.seeds)
        ends = P.filter_windows(frame, params, test_runs, [args.outage], cfg)
        ends = ends[ends.counted.astype(bool)]
        pct = {
            c: 100 * g.horizontal_m.sum() / g.distance_m.sum() for c, g in ends.groupby("control")
        }
        label = " ".join(f"{n}={v:g}" for (n, _), v in zip(axes, combo, strict=True))
        print(
            f"{label} | train score {score:10.1f} | test fused {pct['fused']:.3f} % "
            f"gyro {pct['gyro']:.3f} %",
            flush=True,
        )
        if args.per_window:
            fused = [r for r in test_runs if r.control == "fused"]
            seen = []
            for r in fused:
                cum = np.cumsum(run(_inputs(segs, r), cfg, "fused").fix_logpdf, axis=1)
                seen.append(np.where(before > 0, cum[seg, np.maximum(before - 1, 0)], 0.0))
            mine = ends[ends.control == "fused"].sort_values(["seed", "window"])
            per_window.append((np.concatenate(seen), mine))
    if args.per_window:
        scores = np.stack([s for s, _ in per_window])  # (combos, runs x windows)
        keyed = [m.set_index(["seed", "window"]) for _, m in per_window]
        seeds = np.repeat(params.seeds, len(rows))
        windows = np.tile(np.arange(len(rows)), len(params.seeds))
        best = scores.argmax(axis=0)
        err = dist = 0.0
        for i, (s, w) in enumerate(zip(seeds, windows, strict=True)):
            row = keyed[best[i]]
            if (s, w) in row.index:
                err += row.at[(s, w), "horizontal_m"]
                dist += row.at[(s, w), "distance_m"]
        share = 100 * err / dist
        print(f"per window, the figures its segment's fixes scored highest: fused {share:.3f} %")


if __name__ == "__main__":
    main()
