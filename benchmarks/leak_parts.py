"""What a leaking rear tyre costs the filter through an outage: beta's lag before it, or
the ramp through it.

Simulates ``bench_positioning.py``'s drives (its tyre states, seeds 100 + i, urban and
country, its mid gyro) twice each, without and with the rear-left tyre losing
``--leak`` psi/h, and takes the leak's effect on each second's rear-wheel yaw (nominal
radius) as the difference of the two (the simulator draws the same route, speeds and
sensor noise for both; the leak changes only the tyre). That effect is fitted as a ramp
of the filter's bias per metre, ``-b_t d t`` (``d`` the second's true travel, ``t`` s
since the start; ``tests/support/navsim.py``, ``rwhonet.sim.vehicle.tyre_pressure_psi``).
Then, with the outage windows of ``bench_positioning.py`` (``--calibration`` s of GNSS,
then 180 s without; the rear wheels' mean travel as the distance), the filter
(``rwhonet.nav``) is run on five versions of each window's wheel yaw, ``t0`` its outage's
first second:

- ``no leak``: the drive without the leak;
- ``leak``: as simulated;
- ``ramp only``: before ``t0`` the leak's ``beta`` held at its value at ``t0``, through
  the outage as simulated (what the ramp through the outage costs once ``beta`` is
  known);
- ``lag only``: before ``t0`` as simulated, through the outage held at its ``t0`` value
  (what learning a moving ``beta`` late costs);
- ``constant``: held at its ``t0`` value throughout (an offset the filter has to learn).

The held versions keep what the ramp fit leaves of the leak's effect. Prints, per
control, the end-of-outage error as a share of the distance driven (sum over sum), and
the filter's lag: how far its ``beta`` after the outage's first second trails the held
version's, in seconds of the ramp (median over windows; wheels alone and fused).
``--bias-walk`` runs it all again for each random walk of ``beta`` given (the filter's
``wheel_bias_walk``, rad/m per √s); ``--leak-per-h`` gives the filter its leak-rate
state (``NavConfig.leak_per_h``). ``--drive V-Delta2`` takes that drive of the
project's profile (``params.yaml``'s ``sim.profile``: its route, tyre state, load and the
fleet's seed, so the drive the pipeline simulates) instead, with its own leaks replaced
by ``--leak``; the filter stays configured for the benchmark's target car and gyro.

Usage: python benchmarks/leak_parts.py [--drives 6] [--leak 4] [--bias-walk 2e-6,6e-6]
    [--leak-per-h 0.002] [--drive V-Delta2]
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
from rwhonet.config import SimDrive, SimLeak, load_params  # noqa: E402
from rwhonet.features.deadreckoning import wheel_yaw_rad  # noqa: E402
from rwhonet.nav import run_outage, window_inputs  # noqa: E402
from rwhonet.nav.filter import BW  # noqa: E402
from rwhonet.sim import vehicles_from_params  # noqa: E402
from rwhonet.sim.fleet import drive_seed  # noqa: E402
from support.navsim import drive_seconds  # noqa: E402

_CUT = ("dist_m", "dist_var_m2", "wheel_yaw_rad", "gyro_yaw_rad", "fix_e_m", "fix_n_m")


def _cut(inputs, key: str, calibration_s: int) -> np.ndarray:
    """A window's array up to the outage's first second (fixes: one more column)."""
    extra = 2 if key.startswith("fix") else 1
    return getattr(inputs, key)[:, : calibration_s + extra]


VARIANTS = ("no leak", "leak", "ramp only", "lag only", "constant")
CONTROLS = ("wheels", "gyro", "fused")


def windows_of(params, car, spec: SimDrive, seed, leak_psi_h: float, calibration_s: int):
    """A drive's outage windows (leak drive's inputs), its wheel-yaw versions and ramp."""
    spec = replace(spec, leaks=())
    r, track = car.nominal_radius_m, car.params.track_rear_m
    gyro = GYROS["mid"]
    none = drive_seconds(params, car, spec, seed, gyro=gyro)
    leak = drive_seconds(params, car, spec, seed, gyro=gyro, leaks=(SimLeak("rl", leak_psi_h),))
    if not np.allclose(none.odo_true_m, leak.odo_true_m):
        raise RuntimeError(f"{spec.name}: the leak changed the route, so the difference is not its")
    yaw_none = wheel_yaw_rad(none.angle_rl_rad, none.angle_rr_rad, r, r, track)
    yaw_leak = wheel_yaw_rad(leak.angle_rl_rad, leak.angle_rr_rad, r, r, track)
    d = leak.odo_true_m
    t = np.arange(len(d), dtype=np.float64)
    moving = d > 0.5
    effect = yaw_leak - yaw_none
    slope = np.linalg.lstsq((d * t)[moving, None], effect[moving], rcond=None)[0][0]
    b_t = -slope  # wheel yaw = true yaw - beta d: the ramp of beta, rad/m per s

    wpm = 0.5 * r * (leak.angle_rl_rad + leak.angle_rr_rad)
    starts = np.arange(calibration_s, len(d) - OUTAGE_S + 1, OUTAGE_S)
    fixes = (np.r_[leak.start_e_m, leak.fix_e_m], np.r_[leak.start_n_m, leak.fix_n_m])
    per = {
        "dist_m": wpm,
        "dist_var_m2": (0.01 * wpm) ** 2 + 0.05**2,
        "wheel_yaw_rad": yaw_leak,
        "gyro_yaw_rad": leak.gyro_rad,
    }
    inputs = window_inputs(per, *fixes, starts, calibration_s, OUTAGE_S)
    rows = starts[:, None] - calibration_s + np.arange(calibration_s + OUTAGE_S)
    dw, tw, t0 = d[rows], t[rows], starts[:, None].astype(np.float64)
    before = np.arange(calibration_s + OUTAGE_S)[None, :] < calibration_s
    ramp, held = -b_t * dw * tw, -b_t * dw * t0
    rest = effect[rows] - ramp  # what the ramp does not describe, kept in every version
    base = yaw_none[rows] + rest
    yaws = {
        "no leak": yaw_none[rows],
        "leak": inputs.wheel_yaw_rad,
        "ramp only": base + np.where(before, held, ramp),
        "lag only": base + np.where(before, ramp, held),
        "constant": base + held,
    }
    fit_sd = float(np.std(effect[moving] - slope * (d * t)[moving]))
    return b_t, fit_sd, float(np.std(effect[moving])), inputs, yaws


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drives", type=int, default=6)
    ap.add_argument("--duration", type=float, default=2400.0)
    ap.add_argument("--calibration", type=int, default=600)
    ap.add_argument("--leak", type=float, default=4.0, help="psi/h, rear left")
    ap.add_argument("--bias-walk", default="", help="comma-separated wheel_bias_walk values")
    ap.add_argument(
        "--leak-per-h",
        type=float,
        default=0.0,
        help="the filter's leak-rate state (NavConfig.leak_per_h; 0: none, as shipped)",
    )
    ap.add_argument(
        "--drive",
        default="",
        help="a drive of the project's profile (its route, tyres, load and fleet seed) "
        "instead of the benchmark's; its own leaks left out, --leak put in",
    )
    args = ap.parse_args()
    if args.drives < 1 or args.leak <= 0:
        ap.error("--drives must be ≥ 1 and --leak > 0")
    params = load_params()
    target = vehicles_from_params(params)["target"]
    cfg0 = replace(nav_config(target, GYROS["mid"]), leak_per_h=args.leak_per_h)
    walks = [float(w) for w in args.bias_walk.split(",") if w] or [cfg0.wheel_bias_walk]
    if args.drive:
        profile = params.sim.profiles[params.sim.profile].drives
        names = [d.name for d in profile]
        if args.drive not in names:
            ap.error(f"--drive: {args.drive!r} is not in profile {params.sim.profile!r}: {names}")
        i = names.index(args.drive)
        spec = profile[i]
        car = vehicles_from_params(params)[spec.vehicle].with_payload(
            spec.payload_kg, spec.payload_x_m
        )
        chosen = [(spec, drive_seed(params.sim.seed, i), car)]
    else:
        chosen = [(bench_drive(i, args.duration), 100 + i, target) for i in range(args.drives)]
    t_start = time.perf_counter()
    drives = []
    for spec, seed, car in chosen:
        b_t, fit_sd, eff_sd, inputs, yaws = windows_of(
            params, car, spec, seed, args.leak, args.calibration
        )
        drives.append((inputs, yaws, b_t))
        print(
            f"{spec.name} (tyre state {spec.tyre}, {spec.duration_s:.0f} s, "
            f"{inputs.dist_m.shape[0]} windows): beta ramps {b_t:+.2e} rad/m per s; the leak's "
            f"effect on a second's wheel yaw {eff_sd * 1e3:.2f} mrad sd, "
            f"{fit_sd * 1e3:.2f} mrad left by the ramp",
            flush=True,
        )
    print(f"<!-- simulated in {time.perf_counter() - t_start:.0f} s -->")
    print(
        f"| wheel_bias_walk | control | {' | '.join(VARIANTS)} |\n"
        f"|---|---|{'---:|' * len(VARIANTS)}"
    )
    for walk in walks:
        cfg = replace(cfg0, wheel_bias_walk=walk)
        lags = []
        for control in CONTROLS:
            cells = []
            for name in VARIANTS:
                if control == "gyro" and name != "no leak":
                    cells.append("same")  # the gyro alone never reads the wheel yaw
                    continue
                err, dist = [], []
                for inputs, yaws, b_t in drives:
                    case = replace(inputs, wheel_yaw_rad=yaws[name])
                    out = run_outage(case, args.calibration, cfg, control)
                    err.append(out.horizontal_m)
                    dist.append(out.distance_m)
                    if control != "gyro" and name in ("lag only", "constant"):
                        # the filter's beta after the outage's first second
                        first = replace(case, **{k: _cut(case, k, args.calibration) for k in _CUT})
                        at_t0 = run_outage(first, args.calibration, cfg, control)
                        lags.append((control, name, at_t0.state[:, BW] / b_t))
                h, dd = np.concatenate(err), np.concatenate(dist)
                cells.append(f"{100 * np.nansum(h) / dd[np.isfinite(h)].sum():.2f} %")
            print(f"| {walk:.1e} | {control} | {' | '.join(cells)} |", flush=True)
        for control in ("wheels", "fused"):
            late = np.concatenate(
                [v for c, k, v in lags if c == control and k == "constant"]
            ) - np.concatenate([v for c, k, v in lags if c == control and k == "lag only"])
            print(
                f"<!-- wheel_bias_walk {walk:.1e}, {control}: at the outage's start beta trails "
                f"the held one by {np.nanmedian(late):.0f} s of the ramp (median; quartiles "
                f"{np.nanpercentile(late, 25):.0f}-{np.nanpercentile(late, 75):.0f} s, "
                f"{np.isfinite(late).sum()} windows) -->",
                flush=True,
            )
    print(f"<!-- {time.perf_counter() - t_start:.0f} s -->")


if __name__ == "__main__":
    main()
