"""Horizontal error at the end of 180 s outages: the heading fit and the navigation filter.

Simulates drives of the target car (the default profile's ``target``) for each case
below (``tests/support/navsim.py``: the simulator's drive cut into seconds, with a
yaw-rate gyro sampled from the true yaw), cuts non-overlapping 180 s outage
windows after ``--calibration`` seconds, and prints for each method the mean and
largest end-of-outage error (m), the error as a share of the distance driven in
the windows (sum over sum) and, for the filter, the share of windows inside its
predicted 68.27 % / 95.45 % ellipses (``rwhonet.nav.coverage``).

Methods: ``fit_heading`` is the pipeline's 2D dead reckoning
(``rwhonet.features.deadreckoning``: heading from the rear wheels fitted to the
GNSS course over every second before the window); ``wheels``, ``gyro``,
``fused`` are the filter's controls (``rwhonet.nav``), configured from the same
sensor figures the case simulates. Distances: ``gnss`` (each second's GNSS
distance: the error is the heading's alone) or ``wpm`` (the rear wheels' mean
travel with the nominal radius; the filter scales it by its ``s_d`` state).

Usage: python benchmarks/bench_positioning.py [--drives 6] [--cases baseline,leak]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the simulated drives of the test suite

from rwhonet.config import SimDrive, SimLeak, load_params  # noqa: E402
from rwhonet.features.deadreckoning import (  # noqa: E402
    course_rad,
    dead_reckon,
    fit_heading,
    wheel_yaw_rad,
)
from rwhonet.geo.local import latlon_from_offsets_deg  # noqa: E402
from rwhonet.nav import (  # noqa: E402
    SIGMA_CONTENT,
    GnssSpec,
    GyroSpec,
    NavConfig,
    WheelSpec,
    coverage_2d,
    run_outage,
    window_inputs,
)
from rwhonet.sim import vehicles_from_params  # noqa: E402
from support.navsim import Gyro, drive_seconds, with_sensors  # noqa: E402

OUTAGE_S = 180
TYRES = ("B", "C", "D", "A", "E", "B", "C", "D")
GYROS = {
    "mid": Gyro(),
    "good": Gyro(instability=np.radians(0.01), temp_drift_per_k=np.radians(0.002)),
    "poor": Gyro(
        bias=np.radians(0.5),
        instability=np.radians(0.05),
        noise_density=np.radians(0.05),
        lsb=np.radians(0.1),
        scale_error=0.03,
        temp_drift_per_k=np.radians(0.008),
    ),
}
# case: (gyro, CAN changes, GNSS changes, leaks)
CASES = {
    "baseline": ("mid", {}, {}, ()),
    "good gyro": ("good", {}, {}, ()),
    "poor gyro": ("poor", {}, {}, ()),
    "CAN 0.1 rad/s": ("mid", {"quantum_rad_s": 0.1}, {}, ()),
    "leak 4 psi/h": ("mid", {}, {}, (SimLeak("rl", 4.0),)),
    "consumer GNSS": ("mid", {}, {"white_m": 1.5}, ()),
}


def bench_drive(i: int, duration_s: float) -> SimDrive:
    """Drive ``i`` of every case (seeded 100 + i): urban and country, tyre state ``TYRES[i]``."""
    return SimDrive(
        name=f"B-{i}",
        role="target_test",
        vehicle="target",
        tyre=TYRES[i % len(TYRES)],
        duration_s=duration_s,
        roads={"urban": 0.5, "country": 0.5},
    )


def nav_config(car, gyro: Gyro) -> NavConfig:
    """The filter configured from the figures the simulated sensors are made of."""
    p = car.params
    return NavConfig(
        gyro=GyroSpec(
            noise_density=gyro.noise_density,
            lsb=gyro.lsb,
            bias_instability=gyro.instability,
            bias_tau_s=gyro.instability_tau_s,
            temp_drift_per_k=gyro.temp_drift_per_k,
            warm_rate_k_s=gyro.warm_k / gyro.warm_tau_s,
            warm_tau_s=gyro.warm_tau_s,
        ),
        wheels=WheelSpec(
            quantum_rad_s=p.can.quantum_rad_s,
            noise_rad_s=p.can.noise_rad_s,
            radius_m=car.nominal_radius_m,
            track_rear_m=p.track_rear_m,
        ),
        gnss=GnssSpec(
            sigma_m=p.gnss.sigma_m, tau_s=p.gnss.tau_s, white_m=max(p.gnss.white_m, 0.02)
        ),
        antenna_m=(p.antenna_x_m, p.antenna_y_m),
    )


def heading_fit_errors(ds, yaw, dist, starts, lat0, lon0):
    """End errors of the pipeline's heading fit (every second before the window)."""
    lat, lon = latlon_from_offsets_deg(
        lat0, lon0, np.r_[ds.start_e_m, ds.fix_e_m], np.r_[ds.start_n_m, ds.fix_n_m]
    )
    course = course_rad(lat, lon, 2.0)[1:]
    out = []
    for s in starts:
        fit = fit_heading(course[:s], yaw[:s], ds.disp_gnss_m[:s])
        rows = slice(s, s + OUTAGE_S)
        e, n = dead_reckon(
            fit.azimuth_end_rad,
            dist[rows],
            yaw[rows],
            fit.scale,
            fit.bias_rad_per_m,
            fit.load_s2_m2,
        )
        te, tn = (
            ds.fix_e_m[s + OUTAGE_S - 1] - ds.fix_e_m[s - 1],
            ds.fix_n_m[s + OUTAGE_S - 1] - (ds.fix_n_m[s - 1]),
        )
        out.append(np.hypot(e[-1] - te, n[-1] - tn))
    return np.array(out)


def run_case(params, car0, name, n_drives, calibration_s, duration_s):
    gyro_name, can, gnss, leaks = CASES[name]
    car = car0
    if can:
        car = with_sensors(car, can=can)
    if gnss:
        car = with_sensors(car, gnss=gnss)
    gyro = GYROS[gyro_name]
    cfg = nav_config(car, gyro)
    r = car.nominal_radius_m
    rows: dict[tuple[str, str], list] = {}
    for i in range(n_drives):
        spec = bench_drive(i, duration_s)
        ds = drive_seconds(params, car, spec, 100 + i, gyro=gyro, leaks=leaks)
        yaw = wheel_yaw_rad(ds.angle_rl_rad, ds.angle_rr_rad, r, r, car.params.track_rear_m)
        wpm = 0.5 * r * (ds.angle_rl_rad + ds.angle_rr_rad)
        starts = np.arange(calibration_s, len(ds) - OUTAGE_S + 1, OUTAGE_S)
        dist_driven = np.array([ds.disp_gnss_m[s : s + OUTAGE_S].sum() for s in starts])
        fixes = (np.r_[ds.start_e_m, ds.fix_e_m], np.r_[ds.start_n_m, ds.fix_n_m])
        for dname, dist, var in (
            # a GNSS distance carries both fixes' white noise
            ("gnss", ds.disp_gnss_m, np.full(len(ds), 0.05**2 + 2 * car.params.gnss.white_m**2)),
            ("wpm", wpm, (0.01 * wpm) ** 2 + 0.05**2),
        ):
            err = heading_fit_errors(
                ds, yaw, dist, starts, params.sim.start_lat_deg, params.sim.start_lon_deg
            )
            rows.setdefault(("fit_heading", dname), []).append((err, dist_driven, None, None))
            per = {
                "dist_m": dist,
                "dist_var_m2": var,
                "wheel_yaw_rad": yaw,
                "gyro_yaw_rad": ds.gyro_rad,
            }
            inputs = window_inputs(per, *fixes, starts, calibration_s, OUTAGE_S)
            for control in ("wheels", "gyro", "fused"):
                out = run_outage(inputs, calibration_s, cfg, control)
                rows.setdefault((control, dname), []).append(
                    (out.horizontal_m, out.distance_m, out.error_m, out.cov_m2)
                )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drives", type=int, default=6)
    ap.add_argument("--duration", type=float, default=2400.0)
    ap.add_argument("--calibration", type=int, default=600)
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args()
    unknown = [c for c in args.cases.split(",") if c not in CASES]
    if unknown:
        ap.error(f"--cases: unknown {', '.join(map(repr, unknown))}; known: {', '.join(CASES)}")
    params = load_params()
    car = vehicles_from_params(params)["target"]
    print(
        f"target car {car.name}; {args.drives} drives of {args.duration:.0f} s per case "
        f"(urban/country, tyre states {', '.join(TYRES[: args.drives])}); {OUTAGE_S} s outages "
        f"after {args.calibration} s; gyros: "
        + "; ".join(
            f"{k}: bias {np.degrees(g.bias):.2f} deg/s, instability {np.degrees(g.instability):.3f}"
            f" deg/s (tau {g.instability_tau_s:.0f} s), noise {np.degrees(g.noise_density):.3f}"
            f" deg/s/rtHz, LSB {np.degrees(g.lsb):.2f} deg/s, scale {100 * g.scale_error:.0f} %"
            for k, g in GYROS.items()
        )
    )
    print(
        "| case | distance | method | windows | mean (m) | max (m) | % of distance "
        "| in 68.27 % / 95.45 % ellipse |"
    )
    print("|---|---|---|---:|---:|---:|---:|---|")
    for name in args.cases.split(","):
        t0 = time.perf_counter()
        rows = run_case(params, car, name, args.drives, args.calibration, args.duration)
        for (method, dname), parts in rows.items():
            h = np.concatenate([p[0] for p in parts])
            dist = np.concatenate([p[1] for p in parts])
            cov_txt = ""
            if parts[0][2] is not None:
                err = np.concatenate([p[2] for p in parts])
                cov = np.concatenate([p[3] for p in parts])
                ok = np.isfinite(h)
                c = coverage_2d(err[ok], cov[ok])
                cov_txt = f"{100 * c[SIGMA_CONTENT[0]]:.0f} % / {100 * c[SIGMA_CONTENT[1]]:.0f} %"
            print(
                f"| {name} | {dname} | {method} | {np.isfinite(h).sum()} | {np.nanmean(h):.1f} "
                f"| {np.nanmax(h):.1f} | {100 * np.nansum(h) / dist[np.isfinite(h)].sum():.2f} "
                f"| {cov_txt} |"
            )
        print(f"<!-- {name}: {time.perf_counter() - t0:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
