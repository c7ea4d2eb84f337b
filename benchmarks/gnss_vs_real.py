"""Per-second GNSS distance against scaled wheel distance: the real u-blox drive vs the simulator.

The one real recording these machines reach (``../shared/real/comma2k19-example1``:
a Toyota RAV4, one minute of highway at 10-20 m/s, a u-blox receiver) gives, after
one scale factor, a per-second difference between the GNSS distance and the rear
wheels' distance of about 0.13 m mean absolute. This script computes that same
statistic

    r_k = d_gnss,k - c d_wheel,k,   c = sum(d_gnss) / sum(d_wheel)   (one factor per minute)

on the real recording, two ways (the fixes interpolated at whole seconds of the
logging device's clock, as the recording's README does, and the fixes at whole
seconds of the receiver's own UTC epochs), and on simulated one-minute windows of
highway driving at 10-20 m/s for each receiver grade of params.yaml: the two
logger-grade receivers (``fiesta``, ``fiesta_cupac``) and the consumer grade
(``sim.receivers``). The simulator's receivers are set from sources
(docs/simulator.md, Section 5), never from this recording: the script reports
agreement or disagreement, it fits nothing.

Usage: python benchmarks/gnss_vs_real.py [--real DIR] [--drives N] [--minutes M]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from rwhonet.config import SimDrive, load_params
from rwhonet.geo import geodesic_distance_m
from rwhonet.sim import SimOptions, generate_route, simulate_drive, vehicles_from_params
from rwhonet.sim.sensors import gnss_increment_std_m

REAL = Path(__file__).resolve().parents[1] / ".." / "shared" / "real" / "comma2k19-example1"
MIN_SPEED_M_S = 7.8  # the slowest second of the real minute


def statistic(d_gnss: np.ndarray, d_wheel: np.ndarray) -> tuple[float, float, float]:
    """Mean |r|, std of r and lag-1 autocorrelation of r, after one scale factor."""
    r = d_gnss - d_gnss.sum() / d_wheel.sum() * d_wheel
    return float(np.abs(r).mean()), float(r.std()), float(np.corrcoef(r[:-1], r[1:])[0, 1])


def real_statistics(folder: Path) -> tuple[dict[str, tuple[float, float, float]], np.ndarray]:
    """The statistic on the real recording, timed by the log's clock and by the receiver's.

    Returns:
        The statistic by timing, and each fix's log-clock time minus its receiver
        epoch (after the median offset), s: the logging chain's time-tag jitter.
    """
    log = folder / "processed_log"
    tg, fix = np.load(log / "GNSS/live_gnss_ublox/t"), np.load(log / "GNSS/live_gnss_ublox/value")
    tw, wheel = np.load(log / "CAN/wheel_speed/t"), np.load(log / "CAN/wheel_speed/value")
    rear = wheel[:, 2:].mean(axis=1)  # m/s, the car's own scaling
    travelled = np.concatenate([[0.0], np.cumsum(np.diff(tw) * 0.5 * (rear[1:] + rear[:-1]))])
    out = {}
    # (a) whole seconds of the logging device's clock, fixes interpolated (the README's way).
    t = np.arange(np.ceil(max(tg[0], tw[0])), np.floor(min(tg[-1], tw[-1])) + 0.5)
    lat, lon = np.interp(t, tg, fix[:, 0]), np.interp(t, tg, fix[:, 1])
    d_gnss = geodesic_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:])
    out["log clock"] = statistic(d_gnss, np.diff(np.interp(t, tw, travelled)))
    # (b) the fixes at whole seconds of the receiver's UTC epochs; the wheels at the same
    # instants on the log clock (one constant offset between the two clocks).
    utc_s = fix[:, 3] / 1000.0
    whole = np.flatnonzero(np.abs(utc_s - np.round(utc_s)) < 0.002)
    t_fix = utc_s[whole] + np.median(tg - utc_s)
    inside = (t_fix >= tw[0]) & (t_fix <= tw[-1])
    whole, t_fix = whole[inside], t_fix[inside]
    d_gnss = geodesic_distance_m(
        fix[whole[:-1], 0], fix[whole[:-1], 1], fix[whole[1:], 0], fix[whole[1:], 1]
    )
    out["receiver epochs"] = statistic(d_gnss, np.diff(np.interp(t_fix, tw, travelled)))
    return out, tg - utc_s - np.median(tg - utc_s)


def simulated_windows(params, car, drives: int, minutes: int, seed0: int = 100) -> dict:
    """One-minute windows of simulated highway driving: the statistic for each window."""
    spec = SimDrive(
        name="H",
        role="target_test",
        vehicle="target",
        tyre="E",
        duration_s=60.0 * (minutes + 1),
        roads={"country": 1.0},
        event_scale=0.0,
    )
    rows = {"true distance": [], "CAN wheels": []}
    hz = params.sim.record_hz
    for k in range(drives):
        seed = np.random.SeedSequence(seed0 + k)
        rng = np.random.default_rng(np.random.SeedSequence(seed0 + k, spawn_key=(0,)))
        route = generate_route(spec, params.sim, car, rng)
        drive = simulate_drive(car, spec.tyre, route, seed, params.sim, options=SimOptions())
        frame, state = drive.frame, drive.state
        lat, lon = frame[" Lat"].to_numpy()[::hz], frame[" Long"].to_numpy()[::hz]
        d_gnss = geodesic_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:])
        s = state.motion.s_m[state.record_index][::hz]
        d_true = np.diff(s)
        t = frame[" Time"].to_numpy()
        rear = frame[[" Wheel Speed Rear Left (rad/sec)", " Wheel Speed Rear Right (rad/sec)"]]
        omega = rear.to_numpy().mean(axis=1) * car.nominal_radius_m
        travelled = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (omega[1:] + omega[:-1]))])
        d_can = np.diff(travelled[::hz])
        speed = np.diff(s)  # m per second
        for w in range(1, minutes + 1):  # the first minute pulls away
            sl = slice(60 * w, 60 * (w + 1) - 1)  # 59 seconds, like the real minute
            if speed[sl].min() < MIN_SPEED_M_S or speed[sl].size < 59:
                continue
            rows["true distance"].append(statistic(d_gnss[sl], d_true[sl]))
            rows["CAN wheels"].append(statistic(d_gnss[sl], d_can[sl]))
    return {k: np.array(v) for k, v in rows.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, default=REAL)
    parser.add_argument("--drives", type=int, default=20)
    parser.add_argument("--minutes", type=int, default=10)
    args = parser.parse_args()

    print("Per-second GNSS distance - c x wheel distance, one scale factor c per minute")
    print(f"{'':44s} {'mean |r|':>9s} {'std r':>7s} {'lag-1':>6s}")
    if (args.real / "processed_log").is_dir():
        stats, jitter = real_statistics(args.real)
        for how, (mae, std, rho) in stats.items():
            print(f"{'real u-blox, RAV4, ' + how:44s} {mae:9.3f} {std:7.3f} {rho:6.2f}")
        p1, p99 = np.percentile(jitter, [1, 99]) * 1000
        std_ms = jitter.std() * 1000
        print(
            f"  (a fix's log-clock time - its receiver epoch: std {std_ms:.1f} ms, 1-99 %", end=""
        )
        print(f" {p1:.0f} to {p99:.0f} ms)")
    else:
        print(f"(no real recording at {args.real})")
    # Highway at 10-20 m/s: the country road type, its leg speeds set to the real drive's range.
    params = load_params(overrides={"sim.roads.country.speed_m_s": [10.0, 20.0]})
    cars = vehicles_from_params(params, "paper")
    grades = {"fiesta (VBOX)": cars["source"], "fiesta_cupac (CUPAC)": cars["target"]}
    for name, gnss in params.sim.receivers.items():
        target = cars["target"]
        spec = dataclasses.replace(target.params, gnss=gnss)
        grades[f"{name} on fiesta_cupac"] = dataclasses.replace(target, params=spec, receiver=name)
    for name, car in grades.items():
        analytic = gnss_increment_std_m(car.params.gnss)
        windows = simulated_windows(params, car, args.drives, args.minutes)
        for wheels, stats in windows.items():
            mae, std, rho = np.median(stats, axis=0)
            lo, hi = np.percentile(stats[:, 0], [10, 90])
            label = f"sim {name}, {wheels}"
            print(
                f"{label:44s} {mae:9.3f} {std:7.3f} {rho:6.2f}   "
                f"(median of {len(stats)} minutes; mean |r| 10-90 %: {lo:.3f}-{hi:.3f}; "
                f"analytic 1 s noise std {analytic:.3f} m)"
            )


if __name__ == "__main__":
    main()
