"""Throughput of the navigation filter (``rwhonet.nav.filter.run``) and a digest of what it gives.

The filter steps every window of a batch through its seconds together (numpy over
the rows), so its cost per second is a fixed Python and numpy overhead plus a
part that grows with the rows. This prints, for each control and batch size, the
wall time per filtered second (per row and for the batch) on synthetic windows:
a car at 3-20 m/s turning at random, a gyro with a bias and noise, the rear
wheels' yaw with a scale error and noise, GNSS fixes with noise for the first
``--calibration`` seconds and none through the ``--outage`` after them.

The SHA-256 digest of every track's states, fix predictions and covariances is
printed too: a change to the filter's code that is meant to be only faster must
leave it unchanged (bit for bit), on the same machine.

Usage: python benchmarks/bench_nav_filter.py [--rows 1,40,300] [--repeat 3]
"""

from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

from rwhonet.nav import NavConfig
from rwhonet.nav.filter import CONTROLS, NavInputs, run


def synthetic_inputs(rows: int, calibration_s: int, outage_s: int, seed: int) -> NavInputs:
    """``rows`` windows of ``calibration_s + outage_s`` seconds of a car turning at random."""
    rng = np.random.default_rng(seed)
    n = calibration_s + outage_s
    speed = np.clip(8.0 + np.cumsum(rng.normal(0.0, 0.6, (rows, n)), axis=1), 3.0, 20.0)
    yaw = rng.normal(0.0, 0.03, (rows, n)) + 0.2 * np.sin(np.arange(n) / 17.0)[None, :] * (
        rng.random((rows, 1)) < 0.5
    )
    heading = rng.uniform(-np.pi, np.pi, (rows, 1)) - np.cumsum(yaw, axis=1)
    mid = heading + 0.5 * yaw
    east = np.concatenate([np.zeros((rows, 1)), np.cumsum(speed * np.sin(mid), axis=1)], axis=1)
    north = np.concatenate([np.zeros((rows, 1)), np.cumsum(speed * np.cos(mid), axis=1)], axis=1)
    fix_e = east + rng.normal(0.0, 1.5, east.shape)
    fix_n = north + rng.normal(0.0, 1.5, north.shape)
    fix_e[:, calibration_s + 1 :] = np.nan
    fix_n[:, calibration_s + 1 :] = np.nan
    return NavInputs(
        dist_m=speed * (1.0 + rng.normal(0.0, 0.01, (rows, 1)))
        + rng.normal(0.0, 0.05, speed.shape),
        dist_var_m2=np.full(speed.shape, 0.05**2),
        wheel_yaw_rad=1.01 * yaw + rng.normal(0.0, 0.004, yaw.shape),
        gyro_yaw_rad=yaw + np.radians(0.2) + rng.normal(0.0, 0.002, yaw.shape),
        fix_e_m=fix_e,
        fix_n_m=fix_n,
    )


def digest(track) -> str:
    h = hashlib.sha256()
    for a in (track.x, track.fix_pred, track.fix_cov, track.last_cov, track.fix_logpdf):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="1,40,300", help="batch sizes, comma-separated")
    ap.add_argument("--calibration", type=int, default=420, help="seconds with GNSS")
    ap.add_argument("--outage", type=int, default=180, help="seconds without")
    ap.add_argument("--repeat", type=int, default=3, help="runs per case (the fastest is shown)")
    args = ap.parse_args()
    cfg = NavConfig()
    n = args.calibration + args.outage
    print(f"{'control':8} {'rows':>5} {'s/run':>8} {'µs/second':>10} {'µs/row-second':>14}  digest")
    for rows in (int(r) for r in args.rows.split(",")):
        inputs = synthetic_inputs(rows, args.calibration, args.outage, seed=rows)
        for control in CONTROLS:
            best, track = np.inf, None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                track = run(inputs, cfg, control)
                best = min(best, time.perf_counter() - t0)
            print(
                f"{control:8} {rows:5d} {best:8.3f} {1e6 * best / n:10.0f} "
                f"{1e6 * best / (n * rows):14.1f}  {digest(track)}"
            )


if __name__ == "__main__":
    main()
