"""A leak-rate state, and the choice per outage between the filter with it and without it.

Simulates ``bench_positioning.py``'s drives (``bench_positioning.bench_drive``: its tyre states,
seeds 100 + i, urban and country, its mid gyro) for ``--duration`` s, without and with
the rear-left tyre losing ``--leak`` psi/h, and cuts 180 s outage windows every 180 s
from ``--first`` s on: the same windows for every history length. For each
``--history`` H, the filter (``rwhonet.nav``) starts H s before each window, with
GNSS until the outage, in two configurations: as shipped (``beta`` walks) and with the
leak-rate state (``NavConfig.leak_per_h``, ``beta`` ramps by ``bd_w`` each second).
Per window, the state is chosen where its log score over the H s exceeds the shipped
filter's by ``--margin`` nats: fused, the rear-wheel yaw's under its prediction with the
gyro (``NavTrack.wheel_logpdf``) plus the fixes' (``NavTrack.fix_logpdf``); wheels
alone, the fixes' (the wheels' yaw has nothing to be predicted from). The margin is
the log of the prior odds against a leak (3 nats: about 1 in 20).

Prints, per history length, drive set and control, the end-of-outage error as a share
of the distance driven (sum over sum) without the state, with it, and chosen, with the
share of windows where the state was chosen and the median score gain.

Usage: python benchmarks/leak_models.py [--drives 6] [--duration 3600] [--first 1800]
    [--history 600,1200,1800] [--leak-per-h 0.002] [--margin 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))  # the simulated drives of the test suite

from bench_positioning import GYROS, OUTAGE_S, bench_drive, nav_config  # noqa: E402
from rwhonet.config import SimLeak, load_params  # noqa: E402
from rwhonet.features.deadreckoning import wheel_yaw_rad  # noqa: E402
from rwhonet.nav import window_inputs  # noqa: E402
from rwhonet.nav.filter import run  # noqa: E402
from rwhonet.sim import vehicles_from_params  # noqa: E402
from support.navsim import drive_seconds  # noqa: E402


def per_second(ds, car):
    """The filter's per-second inputs of a simulated drive, and its fixes."""
    r = car.nominal_radius_m
    wpm = 0.5 * r * (ds.angle_rl_rad + ds.angle_rr_rad)
    per = {
        "dist_m": wpm,
        "dist_var_m2": (0.01 * wpm) ** 2 + 0.05**2,
        "wheel_yaw_rad": wheel_yaw_rad(
            ds.angle_rl_rad, ds.angle_rr_rad, r, r, car.params.track_rear_m
        ),
        "gyro_yaw_rad": ds.gyro_rad,
    }
    return per, (np.r_[ds.start_e_m, ds.fix_e_m], np.r_[ds.start_n_m, ds.fix_n_m])


def outage_ends(inputs, history_s: int, cfg, control: str):
    """Each window's end error (m), distance (m) and the log scores over its history."""
    fe, fn = inputs.fix_e_m.copy(), inputs.fix_n_m.copy()
    truth = np.stack([fe[:, -1], fn[:, -1]], axis=1)
    seg_e, seg_n = fe[:, history_s:], fn[:, history_s:]
    dist = np.nansum(np.hypot(np.diff(seg_e, axis=1), np.diff(seg_n, axis=1)), axis=1)
    fe[:, history_s + 1 :] = np.nan
    fn[:, history_s + 1 :] = np.nan
    track = run(replace(inputs, fix_e_m=fe, fix_n_m=fn), cfg, control)
    err = np.hypot(*(track.fix_pred[:, -1] - truth).T)
    fixes = track.fix_logpdf[:, :history_s].sum(axis=1)
    wheels = track.wheel_logpdf[:, :history_s].sum(axis=1)
    return err, dist, fixes + wheels if control == "fused" else fixes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drives", type=int, default=6)
    ap.add_argument("--duration", type=float, default=3600.0)
    ap.add_argument("--first", type=int, default=1800, help="the first window's start, s")
    ap.add_argument("--history", default="600,1200,1800")
    ap.add_argument("--leak", type=float, default=4.0, help="psi/h, rear left")
    ap.add_argument("--leak-per-h", type=float, default=0.002)
    ap.add_argument("--margin", type=float, default=3.0)
    args = ap.parse_args()
    histories = [int(h) for h in args.history.split(",")]
    if min(histories) < 1 or max(histories) > args.first or args.first + OUTAGE_S > args.duration:
        ap.error("each --history must be in [1, --first], and --first + 180 s ≤ --duration")
    params = load_params()
    car = vehicles_from_params(params)["target"]
    gyro = GYROS["mid"]
    shipped = nav_config(car, gyro)
    with_state = replace(shipped, leak_per_h=args.leak_per_h)
    t0 = time.perf_counter()
    sets = {"no leak": [], "leak": []}
    for i in range(args.drives):
        spec = bench_drive(i, args.duration)
        for name, leaks in (("no leak", ()), ("leak", (SimLeak("rl", args.leak),))):
            ds = drive_seconds(params, car, spec, 100 + i, gyro=gyro, leaks=leaks)
            sets[name].append(per_second(ds, car))
    print(
        f"{args.drives} drives of {args.duration:.0f} s; windows of {OUTAGE_S} s every "
        f"{OUTAGE_S} s from {args.first} s; leak {args.leak} psi/h (rear left); state prior "
        f"{100 * args.leak_per_h:.2f} %/h; margin {args.margin} nats"
    )
    print(
        "| history | drives | control | without the state | with it | chosen "
        "| state chosen | median score gain |\n|---|---|---|---:|---:|---:|---:|---:|"
    )
    for history in histories:
        for name, drives in sets.items():
            for control in ("wheels", "gyro", "fused"):
                parts = {"off": [], "on": [], "chosen": []}
                dists, picked, gains = [], [], []
                for per, fixes in drives:
                    n = len(per["dist_m"])
                    starts = np.arange(args.first, n - OUTAGE_S + 1, OUTAGE_S)
                    inputs = window_inputs(per, *fixes, starts, history, OUTAGE_S)
                    e0, dist, s0 = outage_ends(inputs, history, shipped, control)
                    e1, _, s1 = outage_ends(inputs, history, with_state, control)
                    pick = s1 - s0 > args.margin
                    parts["off"].append(e0)
                    parts["on"].append(e1)
                    parts["chosen"].append(np.where(pick, e1, e0))
                    dists.append(dist)
                    picked.append(pick)
                    gains.append(s1 - s0)
                total = np.concatenate(dists).sum()
                pct = {k: 100 * np.nansum(np.concatenate(v)) / total for k, v in parts.items()}
                print(
                    f"| {history} s | {name} | {control} | {pct['off']:.2f} % | {pct['on']:.2f} % "
                    f"| {pct['chosen']:.2f} % | {100 * np.concatenate(picked).mean():.0f} % "
                    f"| {np.median(np.concatenate(gains)):+.1f} |",
                    flush=True,
                )
    print(f"<!-- {time.perf_counter() - t0:.0f} s -->")


if __name__ == "__main__":
    main()
