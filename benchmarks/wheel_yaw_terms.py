"""What the rear wheels' yaw misses, regressed on candidate terms, on freshly simulated drives.

Simulates drives of the default profile's target car (``tests/support/navsim.py``;
seeds from ``--seed``, none of the pipeline's) for each tyre state given, takes
the rear wheels' yaw of each second with the nominal radius less the true yaw,
and fits it by least squares (after the first ``--skip`` seconds, the tyres
warming up; seconds slower than 0.5 m/s and residuals beyond 5 median absolute
deviations, reversing and slip, left out) on the filter's terms (``beta d``,
``beta_v d v``, the scale ``s δ``, the load term ``c δ v²``) and a
longitudinal-load term ``b_a d a`` (``a`` the second's acceleration: two rear
tyres of unequal pressure change their radii unequally when braking moves load).
Prints the coefficients, the residual's spread with and without ``b_a``, and how
far the ``b_a`` term alone would turn the heading over the drive.

Usage: python benchmarks/wheel_yaw_terms.py [--tyres C,B] [--drives 2] [--seed 200]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the simulated drives of the test suite

from rwhonet.config import SimDrive, load_params  # noqa: E402
from rwhonet.features.deadreckoning import wheel_yaw_rad  # noqa: E402
from rwhonet.sim import vehicles_from_params  # noqa: E402
from support.navsim import drive_seconds  # noqa: E402

TERMS = ("beta d", "beta_v d v", "s yaw", "c yaw v^2", "b_a d a")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tyres", default="C,B", help="tyre states, comma-separated")
    ap.add_argument("--drives", type=int, default=2)
    ap.add_argument("--seed", type=int, default=200)
    ap.add_argument("--duration", type=float, default=1800.0, help="s per drive")
    ap.add_argument("--skip", type=int, default=600, help="warm-up seconds left out")
    args = ap.parse_args(argv)
    params = load_params(ROOT / "params.yaml")
    car = vehicles_from_params(params)["target"]
    r = car.nominal_radius_m
    for tyre in args.tyres.split(","):
        for i in range(args.drives):
            spec = SimDrive(
                name=f"W-{i}",
                role="target_test",
                vehicle="target",
                tyre=tyre,
                duration_s=args.duration,
                roads={"urban": 0.7, "country": 0.3},
            )
            ds = drive_seconds(params, car, spec, args.seed + i)
            yaw = wheel_yaw_rad(ds.angle_rl_rad, ds.angle_rr_rad, r, r, car.params.track_rear_m)
            d, true = ds.odo_true_m, ds.yaw_true_rad
            a = np.gradient(d)
            x = np.column_stack([d, d * d, true, true * d * d, d * a])
            res = yaw - true
            ok = np.isfinite(res) & (d > 0.5) & (np.arange(len(d)) >= args.skip)
            dev = np.abs(res - np.median(res[ok]))
            ok &= dev <= 5.0 * 1.4826 * np.median(dev[ok])
            full, *_ = np.linalg.lstsq(x[ok], res[ok], rcond=None)
            base, *_ = np.linalg.lstsq(x[ok][:, :4], res[ok], rcond=None)
            sd_full = np.std(res[ok] - x[ok] @ full)
            sd_base = np.std(res[ok] - x[ok][:, :4] @ base)
            turn = np.cumsum(full[4] * (d * a)[ok])
            coefs = " ".join(f"{t}: {c:+.2e}" for t, c in zip(TERMS, full, strict=True))
            print(
                f"tyre {tyre} seed {args.seed + i}: {coefs} | residual sd {sd_base:.5f} rad "
                f"without b_a, {sd_full:.5f} with | b_a's heading wander {np.std(turn):.4f} rad",
                flush=True,
            )


if __name__ == "__main__":
    main()
