"""What the rear wheels' yaw misses, regressed on candidate terms, on freshly simulated drives.

Simulates drives of the default profile's target car (``tests/support/navsim.py``;
seeds from ``--seed``, none of the pipeline's) for each tyre state given, with the
rear-left tyre losing ``--leak`` psi/h (0: no leak; the fleets' leaking drive,
V-Delta2, loses 4), takes the rear wheels' yaw of each second with the nominal radius
less the true yaw, and fits it by least squares (after the first ``--skip`` seconds,
the tyres warming up; seconds slower than 0.5 m/s left out, and residuals beyond 5
median absolute deviations of the fit on the filter's terms and the ramp, reversing and
slip) on the filter's terms (``beta d``, ``beta_v d v``, the scale ``s δ``, the load
term ``c δ v²``) and two candidates: a longitudinal-load term ``b_a d a`` (``a`` the
second's acceleration: two rear tyres of unequal pressure change their radii unequally
when braking moves load) and a ramp of the bias per metre ``b_t d t`` (``t`` s since the
start: a leaking tyre's radius shrinks with its pressure, so ``beta`` grows steadily,
where the filter lets it walk). Prints the coefficients; the residual's spread with the
filter's terms alone, with ``b_a``, with ``b_t``; how far the ``b_a`` term alone turns
the heading over the drive; and the RMS over 180 s windows (every 30 s) of the heading
the residual turns when ``beta`` is learnt on the 120 s before each window, as the
filter learns it with GNSS, without and with the ramp known.

Usage: python benchmarks/wheel_yaw_terms.py [--tyres C,B] [--drives 2] [--seed 200]
    [--leak 4]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the simulated drives of the test suite

from rwhonet.config import SimDrive, SimLeak, load_params  # noqa: E402
from rwhonet.features.deadreckoning import wheel_yaw_rad  # noqa: E402
from rwhonet.sim import vehicles_from_params  # noqa: E402
from support.navsim import drive_seconds  # noqa: E402

TERMS = ("beta d", "beta_v d v", "s yaw", "c yaw v^2", "b_a d a", "b_t d t")
OUTAGE_S, LEARN_S, EVERY_S = 180, 120, 30


def outage_heading(residual: np.ndarray, d: np.ndarray, ok: np.ndarray) -> float:
    """RMS over outage windows of the heading ``residual`` turns through them, rad, with
    its bias per metre learnt on the seconds before each (left-out seconds count 0)."""
    r, dd = np.where(ok, residual, 0.0), np.where(ok, d, 0.0)
    turned = []
    for s in range(LEARN_S, len(r) - OUTAGE_S, EVERY_S):
        if ok[s - LEARN_S : s].mean() < 1 / 3 or ok[s : s + OUTAGE_S].mean() < 0.5:
            continue
        beta = r[s - LEARN_S : s].sum() / max(dd[s - LEARN_S : s].sum(), 1.0)
        turned.append((r[s : s + OUTAGE_S] - beta * dd[s : s + OUTAGE_S]).sum())
    return float(np.sqrt(np.mean(np.square(turned)))) if turned else float("nan")


def fit(x: np.ndarray, res: np.ndarray, ok: np.ndarray, cols: list[int]):
    """Least squares of ``res`` on the columns ``cols`` of ``x`` over the seconds ``ok``:
    (coefficients, the residual left, 0 on the other seconds)."""
    c, *_ = np.linalg.lstsq(x[ok][:, cols], res[ok], rcond=None)
    return c, np.where(ok, res - x[:, cols] @ c, 0.0)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tyres", default="C,B", help="tyre states, comma-separated")
    ap.add_argument("--drives", type=int, default=2)
    ap.add_argument("--seed", type=int, default=200)
    ap.add_argument("--duration", type=float, default=1800.0, help="s per drive")
    ap.add_argument("--skip", type=int, default=600, help="warm-up seconds left out")
    ap.add_argument("--leak", type=float, default=0.0, help="rear-left leak, psi/h")
    args = ap.parse_args(argv)
    params = load_params(ROOT / "params.yaml")
    car = vehicles_from_params(params)["target"]
    r = car.nominal_radius_m
    leaks = (SimLeak("rl", args.leak),) if args.leak > 0 else ()
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
            ds = drive_seconds(params, car, spec, args.seed + i, leaks=leaks)
            yaw = wheel_yaw_rad(ds.angle_rl_rad, ds.angle_rr_rad, r, r, car.params.track_rear_m)
            d, true = ds.odo_true_m, ds.yaw_true_rad
            a, t = np.gradient(d), np.arange(len(d), dtype=np.float64)
            x = np.column_stack([d, d * d, true, true * d * d, d * a, d * t])
            res = yaw - true
            ok = np.isfinite(res) & (d > 0.5) & (np.arange(len(d)) >= args.skip)
            # outliers judged after the filter's terms and the ramp, not on the raw residual,
            # whose beta d (large on a leaking drive) would decide what is left out
            kept = [0, 1, 2, 3, 5]
            pre, *_ = np.linalg.lstsq(x[ok][:, kept], res[ok], rcond=None)
            dev = np.abs(res - x[:, kept] @ pre)
            ok &= dev <= 5.0 * 1.4826 * np.median(dev[ok])
            full, _ = fit(x, res, ok, list(range(len(TERMS))))
            _, left = fit(x, res, ok, [0, 1, 2, 3])
            _, left_a = fit(x, res, ok, [0, 1, 2, 3, 4])
            ramp, left_t = fit(x, res, ok, [0, 1, 2, 3, 5])
            turn = np.cumsum(full[4] * (d * a)[ok])
            coefs = " ".join(f"{n}: {c:+.2e}" for n, c in zip(TERMS, full, strict=True))
            print(
                f"tyre {tyre}, leak {args.leak:g} psi/h, seed {args.seed + i}: {coefs} | "
                f"residual sd {left[ok].std():.5f} rad, {left_a[ok].std():.5f} with b_a, "
                f"{left_t[ok].std():.5f} with b_t | b_a's heading wander {np.std(turn):.4f} rad | "
                f"180 s outages, beta learnt on the {LEARN_S} s before: heading "
                f"{outage_heading(left_t + ramp[4] * d * t, d, ok):.4f} rad RMS, "
                f"{outage_heading(left_t, d, ok):.4f} with the ramp known",
                flush=True,
            )


if __name__ == "__main__":
    main()
