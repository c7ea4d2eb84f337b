"""Choosing the leak-rate state per outage on a built world's test windows.

Run in a built world's folder (the workspace, or ``build/worlds/<name>``): runs the
evaluate stage's study in memory (``calibration_by_spread.run_the_study``), keeps the
arguments of its test-window filter (``position.filter_windows``: the test drives, the
runs, the fitted filter settings) and the 2D calibrations it fitted on the training
windows, and filters the control model's runs (every control) again with the
leak-rate state (``NavConfig.leak_per_h``, ``--leak-per-h``). Per window, the state is
chosen where its log score over the segment before the outage beats the shipped
filter's by ``--margin`` nats (fused: the fixes' and the rear-wheel yaw's,
``NavTrack.fix_logpdf`` + ``wheel_logpdf``; wheels alone: the fixes'; the gyro alone
never reads the wheels), as ``benchmarks/leak_models.py`` measures on fresh drives.
Nothing is refitted: the receiver, geometry and gyro figures and the calibrations are
the study's, made without the state.

Prints per control and outage length the error as a share of the distance (sum over
sum, mean over seeds) and the calibrated 1σ / 2σ coverage, without the state, with
it, and chosen (with the share of windows where it was chosen); then per test drive
at the longest outage, fused: the error without, with, chosen, where the state was
chosen, and the gyro alone's error.

Usage (in a world's folder): python <repo>/benchmarks/leak_choice.py [--leak-per-h 0.002]
    [--margin 3]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
import pandas as pd

import rwhonet.evaluation.study as study
from calibration_by_spread import run_the_study
from rwhonet.evaluation.position import (
    filter_windows,
    nav_segments,
    position_per_seed,
    segment_pass,
    target_windows,
)

KEYS = ["model", "seed", "control", "outage_s", "window"]


def the_study() -> dict:
    """The evaluate stage's study, run in memory: its test filter's arguments, its 2D
    calibrations and its plan."""
    kept: dict = {}
    calibrate, windows = study.calibrate_on_training, study.filter_windows

    def keep_calibrations(*args, **kwargs):
        out = calibrate(*args, **kwargs)
        kept["calibrations"] = out[0]
        return out

    def keep_windows(*args, **kwargs):
        kept["test_args"] = (args, kwargs)
        return windows(*args, **kwargs)

    study.calibrate_on_training, study.filter_windows = keep_calibrations, keep_windows
    try:
        result = run_the_study()
    finally:
        study.calibrate_on_training, study.filter_windows = calibrate, windows
    kept["plan"] = result.position_plan
    return kept


def score_gains(frame, params, runs, outages, shipped, with_state) -> pd.DataFrame:
    """Each window's log-score gain of the state over the segment before its outage."""
    segs = nav_segments(frame, params)
    n_seg = len(segs.first_row)
    out = []
    for control in dict.fromkeys(r.control for r in runs):
        if control == "gyro":
            continue
        mine = [r for r in runs if r.control == control]
        tracks = [segment_pass(segs, mine, cfg) for cfg in (shipped, with_state)]
        scores = [t.fix_logpdf + (t.wheel_logpdf if control == "fused" else 0.0) for t in tracks]
        before = np.cumsum(scores[1] - scores[0], axis=1)  # through each second
        for L in outages:
            rows = target_windows(frame, params, L)
            g = segs.segment_of[rows[:, 0]]
            s = rows[:, 0] - segs.first_row[g]
            for i, r in enumerate(mine):
                gain = np.where(s > 0, before[i * n_seg + g, np.maximum(s - 1, 0)], 0.0)
                out.append(
                    pd.DataFrame(
                        {
                            "model": r.model,
                            "seed": r.seed,
                            "control": control,
                            "outage_s": L,
                            "window": np.arange(len(g)),
                            "gain": gain,
                        }
                    )
                )
    return pd.concat(out, ignore_index=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--leak-per-h", type=float, default=0.002)
    ap.add_argument("--margin", type=float, default=3.0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    kept = the_study()
    (frame, params, runs, outages, shipped), _ = kept["test_args"]
    plan, calibrations = kept["plan"], kept["calibrations"]
    mine = [r for r in runs if r.model == plan["control_model"]]
    with_state = replace(shipped, leak_per_h=args.leak_per_h)
    print(
        f"control model {plan['control_model']}; controls {sorted({r.control for r in mine})}; "
        f"state prior {100 * args.leak_per_h:.2f} %/h; margin {args.margin} nats "
        f"(study in {time.perf_counter() - t0:.0f} s)",
        flush=True,
    )
    off = filter_windows(frame, params, mine, outages, shipped)
    on = filter_windows(frame, params, mine, outages, with_state)
    gains = score_gains(frame, params, mine, outages, shipped, with_state)
    if not off[KEYS].equals(on[KEYS]):
        raise RuntimeError("the two filters' windows are not in the same order")
    on = on.merge(gains, on=KEYS, how="left")
    pick = (on["gain"] > args.margin).to_numpy()
    chosen = off.copy()
    for column in off.columns:
        chosen[column] = np.where(pick, on[column].to_numpy(), off[column].to_numpy())
    seeds = params.seeds
    tables = {
        name: position_per_seed(w, seeds, calibrations)
        .groupby(["control", "outage_s"])
        .mean(numeric_only=True)
        for name, w in (("off", off), ("on", on.drop(columns="gain")), ("chosen", chosen))
    }
    share = on.assign(pick=pick).groupby(["control", "outage_s"])["pick"].mean()
    print(
        "| control | outage | without the state | with it | chosen | state chosen |\n"
        "|---|---:|---|---|---|---:|"
    )
    for key in tables["off"].index:

        def cell(name, key=key):
            t = tables[name].loc[key]
            return (
                f"{t['pos_pct']:.2f} % ({100 * t['cover_1sigma']:.0f} / "
                f"{100 * t['cover_2sigma']:.0f})"
            )

        print(
            f"| {key[0]} | {key[1]} s | {cell('off')} | {cell('on')} | {cell('chosen')} "
            f"| {100 * share.get(key, 0.0):.0f} % |"
        )
    longest = max(outages)
    print(f"\nfused, {longest} s, per test drive (share of distance, mean over seeds):")
    for name, w in (("off", off), ("on", on.drop(columns="gain")), ("chosen", chosen)):
        sel = w[(w["control"] == "fused") & (w["outage_s"] == longest)]
        per = position_per_seed(sel, seeds, calibrations, by=("drive",))
        txt = ", ".join(f"{d} {v:.2f} %" for d, v in per.groupby("drive")["pos_pct"].mean().items())
        print(f"  {name}: {txt}")
    fused_long = (on["control"] == "fused") & (on["outage_s"] == longest)
    picked = on.assign(pick=pick)[fused_long].groupby("drive")["pick"].mean()
    print("  state chosen: " + ", ".join(f"{d} {100 * v:.0f} %" for d, v in picked.items()))
    gyro = position_per_seed(
        off[(off["control"] == "gyro") & (off["outage_s"] == longest)],
        seeds,
        calibrations,
        by=("drive",),
    )
    txt = ", ".join(f"{d} {v:.2f} %" for d, v in gyro.groupby("drive")["pos_pct"].mean().items())
    print(f"  gyro alone: {txt}")
    print(f"<!-- {time.perf_counter() - t0:.0f} s -->")


if __name__ == "__main__":
    main()
