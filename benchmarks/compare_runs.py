"""Two pipeline runs of one world, model against model: mean CRSE with 95 % intervals, and paired.

    .venv/bin/python benchmarks/compare_runs.py build/paper-whonet build/paper-tcn [--outage 180]

Each run is a project folder after ``dvc repro`` (``make variant`` writes
``build/<name>/``) of the same world (sim.profile) and seeds, differing in
something else, ``model.arch`` say. Both score the same test seconds and the
same outage windows (a window reaches back at most to its segment's first
second, so a network with context predicts every second a WhONet does), so
per model the comparison can be paired: per seed, the mean CRSE of the
longest outage's windows in run B minus that in run A, then the mean over seeds
with a 95 % t interval (:func:`rwhonet.evaluation.intervals.mean_ci95`).

Models: G, S and R (each run's own R: its recipe at its chosen m, from its
``metrics/eval.json``), each of those two recipes at its m in both runs, and
any model named with ``--also`` (``'R[paper]@50'``, ``'R[continuous]/180s'``).
The per-second errors come from ``reports/predictions/`` (label − prediction,
on the seconds the evaluation scores); a run's own ``eval.json`` values are
printed beside them as a check.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.evaluation.intervals import mean_ci95
from rwhonet.evaluation.windows import window_starts


def per_seed_crse(run: Path, model: str, outage_s: int, role: str) -> dict[int, float]:
    """Per seed: the mean CRSE over the run's ``outage_s`` windows of ``role``'s test drives."""
    frames = [
        pd.read_parquet(f) for f in sorted((run / "reports" / "predictions").glob("*.parquet"))
    ]
    frame = pd.concat(frames, ignore_index=True)
    frame = frame[(frame["role"] == role) & frame["evaluated"]].reset_index(drop=True)
    out = {}
    # WPM alone: its error is the label itself (the same for every seed); a continuous
    # recipe predicts per outage length (columns "R[continuous]/180s__seed42")
    name = "G" if model == "WPM" else model
    if not any(c.startswith(f"{name}__seed") for c in frame.columns):
        name = f"{model}/{outage_s}s"
    for col in [c for c in frame.columns if c.startswith(f"{name}__seed")]:
        seed = int(col.rsplit("__seed", 1)[1])
        e = frame["label_m"].to_numpy() - (0.0 if model == "WPM" else frame[col].to_numpy())
        start, _ = window_starts(frame["segment"].to_numpy(), outage_s)
        rows = start[:, None] + np.arange(outage_s)
        # R[continuous]/<L>s predicts only inside the L s windows: every window must be whole
        assert np.isfinite(e[rows]).all(), f"{run}: {col} has no prediction in a window"
        out[seed] = float(np.abs(e[rows]).sum(axis=1).mean())  # CRSE: sum of |e| per window
    return out


def r_model(ev: dict) -> str:
    """The chosen recipe's model name (a continuous recipe has no m)."""
    from rwhonet.contracts import CONTINUOUS_RECIPES

    if ev["recipe"] in CONTINUOUS_RECIPES:
        return f"R[{ev['recipe']}]"
    return f"R[{ev['recipe']}]@{ev['chosen_m']}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path, help="the baseline run (e.g. model.arch=whonet)")
    ap.add_argument("b", type=Path, help="the run compared with it")
    ap.add_argument("--outage", type=int, default=None, help="outage (s); default the longest")
    ap.add_argument("--role", default="target_test")
    ap.add_argument("--also", nargs="*", default=[], help="more models, e.g. 'R[paper]@50'")
    args = ap.parse_args()
    evs = [json.loads((r / "metrics" / "eval.json").read_text()) for r in (args.a, args.b)]
    outage = args.outage or max(int(k.removesuffix("s")) for k in evs[0]["overall"]["G"])
    rows = [("G", "G", "G"), ("S", "S", "S"), ("R", r_model(evs[0]), r_model(evs[1]))]
    for recipe_m in dict.fromkeys([r_model(evs[0]), r_model(evs[1])]):
        rows.append((recipe_m, recipe_m, recipe_m))
    rows += [(m, m, m) for m in args.also]
    rows.append(("WPM", "WPM", "WPM"))
    print(
        f"{args.a.name} (A) vs {args.b.name} (B): mean CRSE (m) of the {outage} s windows of "
        f"{args.role}, mean over seeds ± 95 % t half-width; B − A paired by seed and window set"
    )
    print(f"{'model':<22} {'A':>17} {'B':>17} {'B - A':>17}  {'B/A':>6}  A model / B model")
    for name, model_a, model_b in rows:
        got = []
        for run, model in ((args.a, model_a), (args.b, model_b)):
            got.append(per_seed_crse(run, model, outage, args.role))
        seeds = sorted(set(got[0]) & set(got[1]))
        a = np.array([got[0][s] for s in seeds])
        b = np.array([got[1][s] for s in seeds])
        (ma, ha), (mb, hb), (md, hd) = mean_ci95(a), mean_ci95(b), mean_ci95(b - a)
        print(
            f"{name:<22} {ma:8.2f} ± {ha:6.2f} {mb:8.2f} ± {hb:6.2f} {md:+8.2f} ± {hd:6.2f}  "
            f"{mb / ma:6.3f}  {model_a} / {model_b}"
        )
    for run, ev in zip((args.a, args.b), evs, strict=True):
        cells = ", ".join(
            f"{m} {ev['overall'][m][f'{outage}s']['crse_mean']:.2f}" for m in ("G", "S", "R", "WPM")
        )
        print(f"  {run.name} eval.json ({outage} s, target test): {cells}; R = {r_model(ev)}")


if __name__ == "__main__":
    main()
