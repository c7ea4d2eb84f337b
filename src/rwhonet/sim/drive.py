"""Simulate one drive: route -> motion -> wheels and sensors -> an IO-VNBD table.

The pipeline of one drive (all vectorised at the integration rate):

1. plan the speed along the route and sample the motion (:mod:`.motion`);
2. integrate the rear-axle pose and the GNSS antenna's path;
3. wheel loads, forces, slips, effective radii and angular speeds (:mod:`.vehicle`);
4. sample the sensors at the record rate (:mod:`.sensors`, :mod:`.channels`);
5. assemble the 29 IO-VNBD columns, drop the rows of GNSS gaps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from rwhonet.config import SimLeak, SimParams
from rwhonet.data.iovnbd import HEADERS
from rwhonet.sim.channels import can_channels
from rwhonet.sim.motion import (
    Motion,
    Pose,
    SpeedPlan,
    body_point_velocity,
    cg_acceleration,
    friction,
    integrate_pose,
    plan_speed,
    sample_motion,
)
from rwhonet.sim.roadgrid import Route
from rwhonet.sim.sensors import (
    Fault,
    GnssTrack,
    can_wheel_speeds,
    gnss_track,
    place_faults,
    yaw_rate_sensor,
)
from rwhonet.sim.vehicle import (
    WHEELS,
    Vehicle,
    WheelStates,
    effective_radius_m,
    per_wheel,
    tyre_pressure_psi,
    tyre_temperature_rise_k,
    wheel_states,
)

_START_RADIUS_M = 5000.0  # drives start within this distance of sim.start_*


@dataclass(frozen=True)
class SimOptions:
    """Physics and sensor effects that can be switched off for special drives.

    Attributes:
        slip: longitudinal tyre slip.
        radius_load: effective radius varies with the wheel load (load transfer).
        radius_speed: effective radius grows with speed.
        can_noise: CAN latency, noise, dead band and quantisation.
        gnss_noise: GNSS position/speed error.
        tyre_warmup: tyre air warms up while driving, raising the pressure (gas law).
        gyro_errors: yaw-rate sensor bias, drift, scale error, noise, quantisation, latency.
    """

    slip: bool = True
    radius_load: bool = True
    radius_speed: bool = True
    can_noise: bool = True
    gnss_noise: bool = True
    tyre_warmup: bool = True
    gyro_errors: bool = True

    @classmethod
    def ideal(cls) -> SimOptions:
        """Every effect off: no slip, static radius, perfect sensors, no warm-up."""
        return cls(**{f.name: False for f in fields(cls)})


@dataclass(frozen=True)
class DriveState:
    """Ground truth of a drive at the integration rate (what no sensor sees).

    Attributes:
        route: the route driven.
        plan: its speed plan.
        motion: the sampled motion.
        pose: rear-axle-centre pose in the local east/north frame.
        antenna_east_m: GNSS antenna east position.
        antenna_north_m: GNSS antenna north position.
        accel_x_cg_m_s2: body longitudinal acceleration of the centre of gravity.
        accel_y_cg_m_s2: body lateral acceleration of the centre of gravity.
        wheels: per-wheel truth (speeds, loads, forces, slips, radii).
        pressure_psi: inflation pressure of each tyre, (4, n) (warm-up, leaks).
        record_index: integration samples that are record rows (before gap removal).
        faults: degraded GNSS stretches (record rows).
    """

    route: Route
    plan: SpeedPlan
    motion: Motion
    pose: Pose
    antenna_east_m: np.ndarray
    antenna_north_m: np.ndarray
    accel_x_cg_m_s2: np.ndarray
    accel_y_cg_m_s2: np.ndarray
    wheels: WheelStates
    pressure_psi: np.ndarray
    record_index: np.ndarray
    faults: list[Fault]


class SimulatedDrive(NamedTuple):
    """A simulated drive: the IO-VNBD table, scenario intervals, truth and ground-truth state."""

    frame: pd.DataFrame
    scenarios: dict[str, Any]
    truth: dict[str, Any]
    state: DriveState


def seed_sequence(seed: int | np.random.SeedSequence) -> np.random.SeedSequence:
    """Return ``seed`` as a SeedSequence.

    Args:
        seed: an int or a SeedSequence (returned as is).

    Returns:
        The SeedSequence.
    """
    return seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)


def child_rng(seed: np.random.SeedSequence, k: int) -> np.random.Generator:
    """Generator of the k-th child stream of ``seed``, without mutating ``seed``.

    Equal to ``default_rng(seed.spawn(k + 1)[k])`` on a fresh SeedSequence, but
    stateless, so the same seed always gives the same streams.

    Args:
        seed: the parent seed.
        k: child index.

    Returns:
        A generator on the child stream.
    """
    child = np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, k))
    return np.random.default_rng(child)


# Times since the start (s) at which the truth sidecar records the tyre state.
_TIMELINE_S = (0.0, 300.0, 600.0, 1200.0, 1800.0, 2700.0, 3600.0, 5400.0, 7200.0, 9000.0)

# Child streams of a drive's seed: 0 route (fleet), then (a new sensor takes a new number,
# so every earlier stream, and the columns it fills, stays as it was):
_RNG_START, _RNG_FAULTS, _RNG_GNSS, _RNG_CAN, _RNG_CHANNELS, _RNG_GYRO = 1, 2, 3, 4, 5, 6

# Decimals written for each IO-VNBD column (the frame holds exactly these values).
_DECIMALS = {
    " Time": 2,
    " Lat": 9,
    " Long": 9,
    " Velocity kmh": 3,
    " Heading": 2,
    " Height": 6,
    " Vertical velocity kmh": 2,
    " Sample Period": 2,
    " Steering Angle (deg)": 1,
    " Yaw Rate (deg/sec)": 3,  # a CAN resolution of 0.005 deg/s fits
    " Indicated Vehicle Speed (km/h)": 2,
    " Indicated Longitudinal Acceleration (g)": 3,
    " Indicated Lateral Acceleration (g)": 3,
    " Engine Speed (rpm)": 0,
    " Coolant Temperature (degC)": 1,
    " Brake Pressure (psi)": 1,
    " Battery Voltage (V)": 2,
    " Air Temperature (degC)": 1,
    " Accelerator Pedal Position (%)": 1,
}
_WHEEL_HEADERS = {
    "fl": " Wheel Speed Front Left (rad/sec)",
    "fr": " Wheel Speed Front Right (rad/sec)",
    "rl": " Wheel Speed Rear Left (rad/sec)",
    "rr": " Wheel Speed Rear Right (rad/sec)",
}


def simulate_truth(
    vehicle: Vehicle,
    tyre_state: str,
    route: Route,
    sim: SimParams,
    seed: int | np.random.SeedSequence,
    options: SimOptions = SimOptions(),
    gnss_faults: list[str] | tuple[str, ...] = (),
    leaks: Sequence[SimLeak] = (),
) -> DriveState:
    """Ground truth of a drive: motion, pose, antenna path, tyre pressures and wheel states.

    Args:
        vehicle: the vehicle (with its payload, :meth:`Vehicle.with_payload`).
        tyre_state: its tyre state (key of ``tyre_states``): the cold pressures
            at the start and the treads.
        route: the route.
        sim: simulator settings.
        seed: the drive's seed.
        options: effects to switch off.
        gnss_faults: degraded GNSS stretches to place (their rows only).
        leaks: slow punctures during the drive.

    Returns:
        The ground-truth state.
    """
    ss = seed_sequence(seed)
    tyre = vehicle.tyre_state(tyre_state)
    hz, rec = sim.integration_hz, sim.record_hz
    ratio = hz // rec
    plan = plan_speed(route, vehicle, sim)
    duration = route.duration_s if route.duration_s is not None else plan.end_s
    n_rec = max(int(round(duration * rec)), 2)
    motion = sample_motion(route, plan, hz, (n_rec - 1) * ratio + 1)

    rng = child_rng(ss, _RNG_START)
    dist, az = _START_RADIUS_M * np.sqrt(rng.random()), rng.uniform(0.0, 2.0 * np.pi)
    pose = integrate_pose(
        route, motion, dist * np.sin(az), dist * np.cos(az), rng.uniform(0.0, 2.0 * np.pi)
    )
    p = vehicle.params
    ant_e, ant_n = pose.point(p.antenna_x_m, p.antenna_y_m)
    ax, ay = cg_acceleration(motion, hz, vehicle.cg_to_rear_m)
    mu = friction(route, sim)[motion.interval]
    stiffness = np.where(motion.wet, sim.wet_slip_stiffness_factor, 1.0)
    if options.tyre_warmup:
        rise = tyre_temperature_rise_k(vehicle, motion.speed_m_s, 1.0 / hz)
    else:
        rise = np.zeros(motion.t_s.size)
    pressure = tyre_pressure_psi(
        per_wheel(tyre.pressure_psi), motion.t_s, rise, _leak_psi_per_s(leaks)
    )
    wheels = wheel_states(
        vehicle,
        tyre,
        motion.speed_m_s,
        motion.accel_m_s2,
        motion.curvature_1_m,
        ax,
        ay,
        mu,
        stiffness,
        sim.air_density_kg_m3,
        slip=options.slip,
        radius_load=options.radius_load,
        radius_speed=options.radius_speed,
        pressure_psi=pressure,
    )
    record_index = np.arange(n_rec) * ratio
    faults = place_faults(
        list(gnss_faults), motion.speed_m_s[record_index], rec, child_rng(ss, _RNG_FAULTS)
    )
    return DriveState(
        route, plan, motion, pose, ant_e, ant_n, ax, ay, wheels, pressure, record_index, faults
    )


def _leak_psi_per_s(leaks: Sequence[SimLeak]) -> np.ndarray:
    """Cold pressure each wheel loses per second, (4,) in the order of WHEELS."""
    rate = np.zeros(len(WHEELS))
    for leak in leaks:
        rate[WHEELS.index(leak.wheel)] += leak.psi_per_h / 3600.0
    return rate


def simulate_drive(
    vehicle: Vehicle,
    tyre_state: str,
    route: Route,
    seed: int | np.random.SeedSequence,
    sim: SimParams,
    *,
    options: SimOptions = SimOptions(),
    gnss_faults: list[str] | tuple[str, ...] = (),
    name: str = "sim",
    start_s_of_day: float | None = None,
    leaks: Sequence[SimLeak] = (),
) -> SimulatedDrive:
    """Simulate one drive and return it in the IO-VNBD layout.

    Args:
        vehicle: the vehicle.
        tyre_state: its tyre state.
        route: the route (:func:`~rwhonet.sim.route.generate_route`,
            :func:`~rwhonet.sim.route.straight_route`, ...).
        seed: the drive's seed (int or SeedSequence); child streams drive the
            start point, faults, GNSS, CAN and filler channels independently,
            so switching one effect off leaves the others unchanged.
        sim: simulator settings.
        options: effects to switch off (``SimOptions.ideal()`` for perfect data).
        gnss_faults: degraded GNSS stretches (``low_sats``, ``frozen``, ``jump``, ``gap``).
        name: drive name (recorded in the truth).
        start_s_of_day: time of day of the first row, s; default: random in
            ``sim.day_start_s``.
        leaks: slow punctures during the drive (:class:`rwhonet.config.SimLeak`).

    Returns:
        ``(frame, scenarios, truth, state)``; the frame holds exactly the values
        the CSV writer writes.
    """
    ss = seed_sequence(seed)
    state = simulate_truth(vehicle, tyre_state, route, sim, ss, options, gnss_faults, leaks)
    rec = sim.record_hz
    motion, idx = state.motion, state.record_index
    t_true = motion.t_s
    t_rec = t_true[idx]
    ant_ve, ant_vn = body_point_velocity(
        motion, state.pose, vehicle.params.antenna_x_m, vehicle.params.antenna_y_m
    )
    gnss = gnss_track(
        state.antenna_east_m[idx],
        state.antenna_north_m[idx],
        ant_ve[idx],
        ant_vn[idx],
        (sim.start_lat_deg, sim.start_lon_deg, sim.start_height_m),
        vehicle.params.gnss,
        rec,
        child_rng(ss, _RNG_GNSS),
        state.faults,
        state.pose.heading_rad[idx],
        noise=options.gnss_noise,
    )
    omega_can = can_wheel_speeds(
        t_rec,
        t_true,
        state.wheels.omega_rad_s,
        vehicle.params.can,
        child_rng(ss, _RNG_CAN),
        noise=options.can_noise,
    )
    rng = child_rng(ss, _RNG_CHANNELS)
    if start_s_of_day is None:
        start_s_of_day = float(np.floor(rng.uniform(*sim.day_start_s)))
    channels = can_channels(
        vehicle,
        rec,
        motion.speed_m_s[idx],
        motion.accel_m_s2[idx],
        motion.direction[idx],
        motion.curvature_1_m[idx],
        state.accel_x_cg_m_s2[idx],
        state.accel_y_cg_m_s2[idx],
        state.wheels.omega_rad_s[:, idx],
        omega_can,
        sim.air_density_kg_m3,
        rng,
    )
    yaw = yaw_rate_sensor(
        t_rec,
        t_true,
        state.pose.heading_rad,
        vehicle.params.gyro,
        child_rng(ss, _RNG_GYRO),
        errors=options.gyro_errors,
    )
    channels["yaw_rate_deg_s"] = yaw.deg_s
    frame = _frame(start_s_of_day + t_rec, gnss, omega_can, channels, rec)
    keep = np.ones(idx.size, dtype=bool)
    for f in state.faults:
        if f.kind == "gap":
            keep[f.i0 : f.i1] = False
    frame = frame.loc[keep].reset_index(drop=True)
    scenarios = _scenarios(state, start_s_of_day, t_rec)
    truth = _truth(vehicle, tyre_state, state, ss, options, name, start_s_of_day, t_rec, leaks)
    truth["gyro"] = {
        "turn_on_bias_deg_s": round(yaw.turn_on_bias_deg_s, 6),
        "mean_bias_deg_s": round(float(yaw.bias_deg_s.mean()), 6),
        "end_bias_deg_s": round(float(yaw.bias_deg_s[-1]), 6),
        "temperature_rise_end_k": round(float(yaw.temperature_rise_k[-1]), 3),
        **asdict(vehicle.params.gyro),
    }
    truth["gnss_receiver"] = vehicle.receiver or "own"
    return SimulatedDrive(frame, scenarios, truth, state)


def _frame(
    time_s: np.ndarray,
    gnss: GnssTrack,
    omega: np.ndarray,
    ch: dict[str, np.ndarray],
    hz: int,
) -> pd.DataFrame:
    """The 29 IO-VNBD columns, rounded to what the file holds (header names exact)."""
    cols: dict[str, np.ndarray] = {
        "Sats": gnss.sats,
        " Time": time_s,
        " Lat": gnss.lat_deg,
        " Long": gnss.lon_deg,
        " Velocity kmh": gnss.speed_m_s * 3.6,
        " Heading": gnss.heading_deg,
        " Height": gnss.height_m / 1000.0,
        " Vertical velocity kmh": gnss.vertical_speed_m_s * 3.6,
        " Sample Period": np.full(time_s.size, 1.0 / hz),
        " Steering Angle (deg)": ch["steering_deg"],
        " Yaw Rate (deg/sec)": ch["yaw_rate_deg_s"],
        " Indicated Vehicle Speed (km/h)": ch["indicated_speed_kmh"],
        " Indicated Longitudinal Acceleration (g)": ch["acc_lon_g"],
        " Indicated Lateral Acceleration (g)": ch["acc_lat_g"],
        " Handbrake": ch["handbrake"],
        " Gear Requested": ch["gear"],
        " Gear": ch["gear"],
        " Engine Speed (rpm)": ch["engine_rpm"],
        " Coolant Temperature (degC)": ch["coolant_c"],
        " Clutch Position": ch["clutch"],
        " Brake Pressure (psi)": ch["brake_psi"],
        " Brake Position": ch["brake_on"],
        " Battery Voltage (V)": ch["battery_v"],
        " Air Temperature (degC)": ch["air_c"],
        " Accelerator Pedal Position (%)": ch["pedal_pct"],
    }
    for i, w in enumerate(WHEELS):
        cols[_WHEEL_HEADERS[w]] = omega[i]
    out = {}
    for header in HEADERS:
        values = cols[header]
        if header in _WHEEL_HEADERS.values():
            values = np.round(values, 2)
        elif header in _DECIMALS:
            # + 0.0 turns -0.0 into 0.0 so the file never shows "-0".
            values = np.round(values.astype(np.float64), _DECIMALS[header]) + 0.0
        out[header] = values
    return pd.DataFrame(out)


def _scenarios(state: DriveState, start_s: float, t_rec: np.ndarray) -> dict[str, Any]:
    """Scenario intervals in the file's time column (route tags and GNSS faults)."""
    route, plan = state.route, state.plan
    end = float(t_rec[-1])
    intervals = []
    for s0, s1, tag in route.tags:
        i0 = min(int(round(s0 / route.ds_m)), route.n - 1)
        i1 = min(int(round(s1 / route.ds_m)), route.n - 1)
        if i0 == i1:  # something that happens standing: the dwell
            a, b = plan.arrival_s[i0], plan.departure_s[i0]
        else:
            a, b = plan.departure_s[i0], plan.arrival_s[i1]
        a, b = max(float(a), 0.0), min(float(b), end)
        if b > a:
            intervals.append((a, b, tag))
    for f in state.faults:
        intervals.append((float(t_rec[f.i0]), float(t_rec[f.i1 - 1]), f"gnss_{f.kind}"))
    intervals.sort()
    return {
        "intervals": [
            {"start_s": round(start_s + a, 2), "end_s": round(start_s + b, 2), "tag": tag}
            for a, b, tag in intervals
        ]
    }


def _truth(
    vehicle: Vehicle,
    tyre_state: str,
    state: DriveState,
    ss: np.random.SeedSequence,
    options: SimOptions,
    name: str,
    start_s: float,
    t_rec: np.ndarray,
    leaks: Sequence[SimLeak],
) -> dict[str, Any]:
    """Ground truth a test (never the pipeline) may compare against."""
    tyre = vehicle.tyre_state(tyre_state)
    w = state.wheels
    t = state.motion.t_s
    # The tyre state over the drive, compactly: at fixed times since the start and the end.
    marks = np.array([t_ for t_ in _TIMELINE_S if t_ < t[-1]] + [t[-1]])
    at = np.searchsorted(t, marks - 1e-9)
    # At the static load (with payload) and walking speed: the radius an ideal
    # (SimOptions.ideal()) drive rolls on; radius_static_m is its value at the start.
    static_radius = effective_radius_m(
        vehicle,
        state.pressure_psi[:, at],
        per_wheel(tyre.tread_mm)[:, None],
        vehicle.static_wheel_load_n[:, None],
        0.0,
    )
    # Distance-weighted means: what an odometer calibrated on this drive would see.
    weight = w.ground_speed_m_s.sum(axis=1)
    safe = np.where(weight > 0, weight, 1.0)
    mean_radius = (w.radius_m * w.ground_speed_m_s).sum(axis=1) / safe
    mean_slip = (w.slip * w.ground_speed_m_s).sum(axis=1) / safe

    def wheels(a: np.ndarray) -> dict[str, float]:
        return {k: round(float(v), 7) for k, v in zip(WHEELS, a, strict=True)}

    def series(a: np.ndarray, digits: int) -> dict[str, list[float]]:
        return {k: [round(float(x), digits) for x in row] for k, row in zip(WHEELS, a, strict=True)}

    return {
        "drive": name,
        "vehicle": vehicle.name,
        "tyre_state": tyre_state,
        "nominal_radius_m": vehicle.nominal_radius_m,
        "pressure_psi": asdict(tyre.pressure_psi),
        "tread_mm": asdict(tyre.tread_mm),
        "radius_static_m": wheels(static_radius[:, 0]),
        "radius_mean_m": wheels(mean_radius),
        "slip_mean": wheels(mean_slip),
        "payload_kg": vehicle.payload_kg,
        "payload_x_m": vehicle.payload_x_m,
        "leaks": [asdict(leak) for leak in leaks],
        "tyre_timeline": {
            "t_s": [round(float(x), 2) for x in t[at]],
            "pressure_psi": series(state.pressure_psi[:, at], 3),
            "radius_static_m": series(static_radius, 7),
        },
        "antenna_body_m": [vehicle.params.antenna_x_m, vehicle.params.antenna_y_m],
        "distance_m": round(float(state.motion.s_m[-1]), 3),
        "duration_s": round(float(t_rec.size * (t_rec[1] - t_rec[0])), 2),
        "start_s_of_day": start_s,
        "gnss_faults": [
            {
                "kind": f.kind,
                "start_s": round(start_s + float(t_rec[f.i0]), 2),
                "end_s": round(start_s + float(t_rec[f.i1 - 1]), 2),
            }
            for f in state.faults
        ],
        "options": {f.name: getattr(options, f.name) for f in fields(options)},
        "seed": {"entropy": int(ss.entropy), "spawn_key": [int(k) for k in ss.spawn_key]},
    }
