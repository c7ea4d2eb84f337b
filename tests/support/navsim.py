"""Simulated drives cut into seconds for the positioning tests and benchmarks.

One drive of the simulator (:mod:`rwhonet.sim`) with every GNSS fault off, taken
from the IO-VNBD frame it produces (exactly what its CSV would hold) and cut
into whole seconds as the pipeline cuts a segment (:mod:`rwhonet.features.seconds`),
plus what no sensor sees: the rear-axle pose at the end of every second and the
true yaw of every second. A yaw-rate gyro of the kind an ESC carries is sampled
here from the true yaw rate (:class:`Gyro`), independently of the simulator's own
yaw-rate channel, so the tests control every error term of it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from rwhonet.config import Params, SimDrive, SimLeak
from rwhonet.data.iovnbd import LAYOUT
from rwhonet.features.seconds import integrate_per_second, segment_seconds
from rwhonet.geo.local import offsets_m
from rwhonet.sim import SimOptions, Vehicle, generate_route, simulate_drive
from rwhonet.sim.drive import child_rng, seed_sequence


@dataclass(frozen=True)
class Gyro:
    """An automotive yaw-rate sensor (the ESC's), as the error terms of its data sheet.

    The measured rate is ``(1 + scale_error) r(t - latency) + b(t) + n``, rounded to
    ``lsb``: ``b`` a constant turn-on bias plus a first-order Gauss-Markov bias
    instability (``instability``, ``instability_tau_s``) plus a temperature ramp
    (``temp_drift`` per degree, the sensor warming by ``warm_k`` with time constant
    ``warm_tau_s``); ``n`` white with the noise density ``noise_density`` (a
    sample at ``hz`` has standard deviation ``noise_density sqrt(hz)``, so one
    second integrates to an angle random walk of ``noise_density`` rad per
    square-root second).

    Attributes are in rad/s (noise density in rad/s/sqrt(Hz)); the defaults are
    the middle of the ranges the brief for issue 17 names (bias 0.1-0.5 deg/s,
    0.01-0.05 deg/s/sqrt(Hz), LSB 0.01-0.1 deg/s, scale 1-3 %).
    """

    bias: float = np.radians(0.3)
    instability: float = np.radians(0.03)
    instability_tau_s: float = 300.0
    temp_drift_per_k: float = np.radians(0.004)
    warm_k: float = 15.0
    warm_tau_s: float = 600.0
    scale_error: float = 0.02
    noise_density: float = np.radians(0.03)
    lsb: float = np.radians(0.05)
    latency_s: float = 0.03

    def sample(self, t_s: np.ndarray, rate_rad_s: np.ndarray, rng: np.random.Generator):
        """The sensor's output at times ``t_s`` (10 Hz rows) for the true yaw rate there.

        Args:
            t_s: (n,) sample times, s (uniform).
            rate_rad_s: (n,) true yaw rate at those times, rad/s (left positive).
            rng: random generator.

        Returns:
            ``(measured, bias)``: (n,) the measured yaw rate and the bias in it, rad/s.
        """
        dt = float(t_s[1] - t_s[0])
        true = np.interp(t_s - self.latency_s, t_s, rate_rad_s)
        phi = np.exp(-dt / self.instability_tau_s)
        w = rng.standard_normal(t_s.size) * self.instability * np.sqrt(1.0 - phi**2)
        w[0] = rng.standard_normal() * self.instability
        gm = lfilter([1.0], [1.0, -phi], w)  # x_k = phi x_(k-1) + w_k
        t = t_s - t_s[0]
        warm = self.temp_drift_per_k * self.warm_k * (1.0 - np.exp(-t / self.warm_tau_s))
        white = rng.standard_normal(t_s.size) * self.noise_density / np.sqrt(dt)
        bias = self.bias + gm + warm
        out = (1.0 + self.scale_error) * true + bias + white
        return (np.round(out / self.lsb) * self.lsb if self.lsb > 0 else out), bias


@dataclass(frozen=True)
class DriveSeconds:
    """One simulated drive, per whole second (index k: the second ending at fix k+1).

    Attributes:
        t_s: end of each second, s.
        fix_e_m: GNSS fix ending each second, east of the simulator's origin, m.
        fix_n_m: its north offset, m.
        start_e_m: the fix starting the first second, east, m (then ``fix_e_m[:-1]``).
        start_n_m: its north offset, m.
        disp_gnss_m: GNSS displacement of each second, m.
        angle_rl_rad: rear-left wheel angle of each second, rad.
        angle_rr_rad: rear-right wheel angle, rad.
        gyro_rad: the gyro's yaw rate integrated over each second (left positive), rad.
        gyro_bias_rad: the gyro's bias integrated over each second, rad.
        yaw_true_rad: the true yaw of each second (left positive), rad.
        odo_true_m: the rear-axle centre's true travel in each second, m.
        truth_e_m: the rear-axle centre at the end of each second, east, m.
        truth_n_m: north, m.
        truth_azimuth_rad: the body's azimuth at the end of each second, rad.
        antenna_m: the antenna ahead of and left of the rear-axle centre, m.
        radius_m: the true static rear radii ``(rl, rr)`` at the start, m.
        track_rear_m: the car's rear track, m.
    """

    t_s: np.ndarray
    fix_e_m: np.ndarray
    fix_n_m: np.ndarray
    start_e_m: float
    start_n_m: float
    disp_gnss_m: np.ndarray
    angle_rl_rad: np.ndarray
    angle_rr_rad: np.ndarray
    gyro_rad: np.ndarray
    gyro_bias_rad: np.ndarray
    yaw_true_rad: np.ndarray
    odo_true_m: np.ndarray
    truth_e_m: np.ndarray
    truth_n_m: np.ndarray
    truth_azimuth_rad: np.ndarray
    antenna_m: tuple[float, float]
    radius_m: tuple[float, float]
    track_rear_m: float

    def __len__(self) -> int:
        return len(self.t_s)


def with_sensors(vehicle: Vehicle, **changes) -> Vehicle:
    """The same car with its CAN (``can=dict(...)``) or GNSS (``gnss=dict(...)``) changed."""
    p = vehicle.params
    new = {}
    for key, value in changes.items():
        new[key] = (
            dataclasses.replace(getattr(p, key), **value) if isinstance(value, dict) else value
        )
    return dataclasses.replace(vehicle, params=dataclasses.replace(p, **new))


def drive_seconds(
    params: Params,
    vehicle: Vehicle,
    spec: SimDrive,
    seed: int | np.random.SeedSequence,
    *,
    gyro: Gyro = Gyro(),
    options: SimOptions | None = None,
    leaks: tuple[SimLeak, ...] = (),
) -> DriveSeconds:
    """Simulate ``spec`` on ``vehicle`` (no GNSS faults) and cut it into seconds.

    Args:
        params: the project's params (``sim`` settings).
        vehicle: the car (its sensors included).
        spec: the drive (its ``gnss_faults`` are ignored: every row stays).
        seed: the drive's seed (child 0 lays out the route, as the fleet does;
            ``rwhonet.sim.fleet.drive_seed`` gives a profile's drive its fleet's).
        gyro: the yaw-rate sensor sampled from the true yaw rate.
        options: simulator effects to switch off.
        leaks: slow punctures during the drive.

    Returns:
        The drive's seconds.
    """
    seq = seed_sequence(seed)
    route = generate_route(spec, params.sim, vehicle, child_rng(seq, 0))
    drive = simulate_drive(
        vehicle,
        spec.tyre,
        route,
        seq,
        params.sim,
        options=options or SimOptions(),
        leaks=leaks,
    )
    frame = {
        col.canonical: drive.frame[col.header].to_numpy(np.float64) * col.to_si
        for col in LAYOUT
        if col.canonical is not None
    }
    sec = segment_seconds(frame, spec.name)
    state = drive.state
    idx = state.record_index
    anchors = idx[::10][: len(sec) + 1]
    lat0, lon0 = params.sim.start_lat_deg, params.sim.start_lon_deg
    e, n = offsets_m(lat0, lon0, frame["lat_deg"][::10], frame["lon_deg"][::10])
    rate = state.motion.yaw_rate_rad_s[idx]
    g_rng = child_rng(seq, 99)
    measured, bias = gyro.sample(frame["t_s"], rate, g_rng)
    heading = state.pose.heading_rad[anchors]
    s = state.motion.s_m[anchors]
    r = drive.truth["radius_static_m"]
    return DriveSeconds(
        t_s=sec.t_s,
        fix_e_m=e[1 : len(sec) + 1],
        fix_n_m=n[1 : len(sec) + 1],
        start_e_m=float(e[0]),
        start_n_m=float(n[0]),
        disp_gnss_m=sec.disp_gnss_m,
        angle_rl_rad=sec.angle_rl_rad,
        angle_rr_rad=sec.angle_rr_rad,
        gyro_rad=integrate_per_second(frame["t_s"], measured),
        gyro_bias_rad=integrate_per_second(frame["t_s"], bias),
        yaw_true_rad=np.diff(heading),
        odo_true_m=np.diff(s),
        truth_e_m=state.pose.east_m[anchors[1:]],
        truth_n_m=state.pose.north_m[anchors[1:]],
        truth_azimuth_rad=np.pi / 2 - heading[1:],
        antenna_m=(vehicle.params.antenna_x_m, vehicle.params.antenna_y_m),
        radius_m=(r["rl"], r["rr"]),
        track_rear_m=vehicle.params.track_rear_m,
    )
