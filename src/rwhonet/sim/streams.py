"""Simulated drives written as a real logger writes them: separate streams at their own rates.

To measure what resampling costs (:mod:`rwhonet.data.streams`), one ground truth
is sampled twice: once as the pipeline's native 10 Hz drive (the wheel speeds
and fix *at* every 0.1 s, as :func:`rwhonet.sim.simulate_drive` records them)
and once as streams (CAN wheel speeds at 50 or 100 Hz with jittered time
stamps, GNSS fixes at 1, 5 or 10 Hz at a random phase of the second). The
simulator integrates at ``sim.integration_hz`` (50 Hz), which is coarser than a
100 Hz stream; here the same physics is integrated at ``truth_hz`` (1 kHz by
default: :func:`rwhonet.sim.simulate_truth` with ``integration_hz`` raised, the
same route, plan, seed and vehicle) and every sensor, 10 Hz or stream, samples
that truth by linear interpolation (off by at most ``h^2 / 8`` times the
signal's curvature at ``h`` = 1 ms: nothing). Both samplings come from one
truth, so their label difference is the resampling's alone.

Sensors are ideal by default (the wheel speeds and the antenna path themselves),
so the comparison isolates the resampling; ``can_noise=True`` adds the
simulator's CAN model (latency, white noise, dead band, quantisation,
:func:`rwhonet.sim.sensors.can_wheel_speeds`) to both, drawn independently at
each rate, as real sensors would.

:func:`write_stream_csvs` and :func:`write_stream_mdf4` write the streams the way
loggers export them (one CSV per stream; one MDF4 file with one channel group per
stream), with the signal map that reads them back; :func:`write_comma2k19` the way
comma's openpilot logs them (:func:`write_comma2k19_route`: a route of one-minute segments).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.config import SimParams
from rwhonet.data import canonical as c
from rwhonet.geo import latlon_from_offsets_deg
from rwhonet.sim.drive import DriveState, SimOptions, child_rng, seed_sequence, simulate_truth
from rwhonet.sim.roadgrid import Route
from rwhonet.sim.sensors import can_wheel_speeds
from rwhonet.sim.vehicle import Vehicle

TRUTH_HZ = 1000
_RNG_STREAMS = 101  # child stream of the drive's seed for stream times (far from drive.py's)


@dataclass(frozen=True)
class StreamSpec:
    """How a logger samples the drive.

    Attributes:
        wheel_hz: CAN wheel-speed rate.
        gnss_hz: GNSS fix rate.
        wheel_jitter: each CAN stamp is off its nominal instant by up to this fraction of
            the CAN period (uniform), as bus arbitration and logger buffering shift them.
        gnss_jitter_s: each fix's stamp is off by up to this (uniform).
        gyro_hz: the yaw-rate stream's rate (its stamps jittered as the wheels'), or 0
            for none.
    """

    wheel_hz: float
    gnss_hz: float
    wheel_jitter: float = 0.25
    gnss_jitter_s: float = 0.005
    gyro_hz: float = 0.0

    @property
    def name(self) -> str:
        """``wheels 100 Hz, GNSS 1 Hz`` (``, gyro 50 Hz`` with one)."""
        gyro = f", gyro {self.gyro_hz:g} Hz" if self.gyro_hz else ""
        return f"wheels {self.wheel_hz:g} Hz, GNSS {self.gnss_hz:g} Hz{gyro}"


@dataclass(frozen=True)
class StreamTables:
    """One drive as streams: the wheel speeds (rad/s), the fixes and optionally the yaw
    rate (rad/s, ISO 8855), each with its times."""

    wheels: pd.DataFrame  # t_s, omega_fl_rad_s, omega_fr_rad_s, omega_rl_rad_s, omega_rr_rad_s
    gnss: pd.DataFrame  # t_s, lat_deg, lon_deg, n_sats
    gyro: pd.DataFrame | None = None  # t_s, yaw_rate_rad_s

    @property
    def n_rows(self) -> int:
        """Samples over every stream."""
        return len(self.wheels) + len(self.gnss) + (0 if self.gyro is None else len(self.gyro))


def fine_truth(
    vehicle: Vehicle,
    tyre_state: str,
    route: Route,
    seed: int | np.random.SeedSequence,
    sim: SimParams,
    truth_hz: int = TRUTH_HZ,
    options: SimOptions | None = None,
) -> DriveState:
    """The drive's ground truth integrated at ``truth_hz`` (same route, plan and seed).

    Args:
        vehicle: the vehicle.
        tyre_state: its tyre state.
        route: the route.
        seed: the drive's seed.
        sim: simulator settings (``integration_hz`` replaced by ``truth_hz``).
        truth_hz: the integration rate, a multiple of ``sim.record_hz``.
        options: physics effects (default: all on; sensor options do not apply here).

    Returns:
        The ground truth (no GNSS faults: the comparison wants every second valid).
    """
    if truth_hz % sim.record_hz:
        raise ValueError(f"truth_hz={truth_hz} must be a multiple of sim.record_hz")
    # A shallow copy with the rate changed: dataclasses.replace would re-run the params'
    # checks on its fleet profiles, which were resolved when the params were loaded.
    fine = copy.copy(sim)
    object.__setattr__(fine, "integration_hz", int(truth_hz))
    return simulate_truth(
        vehicle, tyre_state, route, fine, seed_sequence(seed), options or SimOptions()
    )


def _antenna(state: DriveState, t: np.ndarray, sim: SimParams) -> tuple[np.ndarray, np.ndarray]:
    truth_t = state.motion.t_s
    east = np.interp(t, truth_t, state.antenna_east_m)
    north = np.interp(t, truth_t, state.antenna_north_m)
    return latlon_from_offsets_deg(sim.start_lat_deg, sim.start_lon_deg, east, north)


def _wheels(
    state: DriveState,
    t: np.ndarray,
    vehicle: Vehicle,
    rng: np.random.Generator,
    can_noise: bool,
) -> np.ndarray:
    return can_wheel_speeds(
        t, state.motion.t_s, state.wheels.omega_rad_s, vehicle.params.can, rng, noise=can_noise
    )


def native_drive(
    state: DriveState,
    vehicle: Vehicle,
    sim: SimParams,
    seed: int | np.random.SeedSequence,
    start_s: float = 0.0,
    can_noise: bool = False,
) -> pd.DataFrame:
    """The drive as the pipeline's native 10 Hz rows, in canonical columns.

    Args:
        state: the fine ground truth (:func:`fine_truth`).
        vehicle: the vehicle (its CAN model when ``can_noise``).
        sim: simulator settings (``record_hz``, the GNSS origin).
        seed: the drive's seed (CAN noise draws).
        start_s: the clock's time at the drive's start (rows at ``start_s + k / 10``).
        can_noise: the simulator's CAN model on the wheel speeds.

    Returns:
        ``t_s, lat_deg, lon_deg``, the four wheel speeds and ``n_sats`` (9), one row per
        0.1 s from the start to the end of the truth.
    """
    truth_t = state.motion.t_s
    k = np.arange(int(np.floor(truth_t[-1] * sim.record_hz + 1e-9)) + 1)
    t = k / sim.record_hz
    lat, lon = _antenna(state, t, sim)
    omega = _wheels(state, t, vehicle, child_rng(seed_sequence(seed), _RNG_STREAMS), can_noise)
    return pd.DataFrame(
        {
            c.T_S: (round(start_s * sim.record_hz) + k) / sim.record_hz,
            c.LAT_DEG: lat,
            c.LON_DEG: lon,
            **{w: omega[i] for i, w in enumerate(c.WHEELS)},
            c.N_SATS: np.full(t.size, 9.0),
        }
    )


def stream_tables(
    state: DriveState,
    vehicle: Vehicle,
    sim: SimParams,
    seed: int | np.random.SeedSequence,
    spec: StreamSpec,
    start_s: float = 0.0,
    can_noise: bool = False,
) -> StreamTables:
    """The drive as a logger's streams: jittered CAN wheel speeds, fixes at a random phase,
    and the ideal yaw rate at jittered stamps where ``spec.gyro_hz``.

    Args:
        state: the fine ground truth (:func:`fine_truth`).
        vehicle: the vehicle.
        sim: simulator settings.
        seed: the drive's seed (stream times and CAN noise draw from its child streams).
        spec: the rates and jitter.
        start_s: the clock's time at the drive's start.
        can_noise: the simulator's CAN model on the wheel speeds.

    Returns:
        The streams, times on the same clock as :func:`native_drive`.
    """
    truth_t = state.motion.t_s
    end = float(truth_t[-1])
    ss = seed_sequence(seed)
    # One child stream per use, so the CAN noise never shifts the stream times and the
    # GNSS phase of a rate pair is the same with and without it.
    key = _RNG_STREAMS + 1 + 4 * (round(spec.wheel_hz) * 1000 + round(spec.gnss_hz))
    rng_can, rng_noise, rng_gnss = (child_rng(ss, key + i) for i in range(3))
    t_w = _can_clock(spec.wheel_hz, spec.wheel_jitter, end, rng_can)
    omega = _wheels(state, t_w, vehicle, rng_noise, can_noise)
    fix_period = 1.0 / spec.gnss_hz
    rng = rng_gnss
    phase = rng.uniform(0.0, fix_period)
    nominal_g = phase + np.arange(int((end - phase) / fix_period) + 1) * fix_period
    t_g = nominal_g + rng.uniform(-spec.gnss_jitter_s, spec.gnss_jitter_s, nominal_g.size)
    t_g = np.sort(t_g[(t_g >= 0.0) & (t_g <= end)])
    lat, lon = _antenna(state, t_g, sim)
    wheels = pd.DataFrame({c.T_S: start_s + t_w, **{w: omega[i] for i, w in enumerate(c.WHEELS)}})
    gnss = pd.DataFrame(
        {c.T_S: start_s + t_g, c.LAT_DEG: lat, c.LON_DEG: lon, c.N_SATS: np.full(t_g.size, 9.0)}
    )
    gyro = None
    if spec.gyro_hz:
        t_y = _can_clock(spec.gyro_hz, spec.wheel_jitter, end, child_rng(ss, key + 3))
        gyro = pd.DataFrame(
            {
                c.T_S: start_s + t_y,
                c.YAW_RATE_RAD_S: np.interp(t_y, truth_t, state.motion.yaw_rate_rad_s),
            }
        )
    return StreamTables(wheels, gnss, gyro)


def _can_clock(hz: float, jitter: float, end_s: float, rng: np.random.Generator) -> np.ndarray:
    """A CAN message's stamps from 0 to ``end_s``: every ``1 / hz``, each off its nominal
    instant by up to ``jitter`` periods (uniform), sorted, those outside the drive dropped."""
    period = 1.0 / hz
    nominal = np.arange(int(end_s / period) + 1) * period
    t = nominal + rng.uniform(-jitter, jitter, nominal.size) * period
    return np.sort(t[(t >= 0.0) & (t <= end_s)])


# How the stream files name their columns (a logger's own names), and the map that reads them.
WHEEL_COLUMNS = {
    c.OMEGA_FL: "WheelSpeed_FL",
    c.OMEGA_FR: "WheelSpeed_FR",
    c.OMEGA_RL: "WheelSpeed_RL",
    c.OMEGA_RR: "WheelSpeed_RR",
}
GNSS_COLUMNS = {c.LAT_DEG: "Latitude", c.LON_DEG: "Longitude", c.N_SATS: "NumSV"}
GYRO_COLUMNS = {c.YAW_RATE_RAD_S: "YawRate"}
SIGNAL_MAP: dict[str, tuple[str, str]] = {
    "t": ("Time", "s"),
    "omega_fl": ("WheelSpeed_FL", "rad/s"),
    "omega_fr": ("WheelSpeed_FR", "rad/s"),
    "omega_rl": ("WheelSpeed_RL", "rad/s"),
    "omega_rr": ("WheelSpeed_RR", "rad/s"),
    "lat": ("Latitude", "deg"),
    "lon": ("Longitude", "deg"),
    "n_sats": ("NumSV", "count"),
}


def write_stream_csvs(tables: StreamTables, folder: Path) -> dict[str, Path]:
    """Write the streams as one CSV each (``wheels.csv``, ``gnss.csv``, and ``gyro.csv``
    with a yaw rate) under ``folder``.

    Args:
        tables: the streams.
        folder: where to write them (created).

    Returns:
        Stream name -> file. :func:`signal_map` reads them back (``gyro=True`` with a yaw
        rate).
    """
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    written = [("wheels", tables.wheels, WHEEL_COLUMNS), ("gnss", tables.gnss, GNSS_COLUMNS)]
    if tables.gyro is not None:
        written.append(("gyro", tables.gyro, GYRO_COLUMNS))
    for name, frame, columns in written:
        names = {c.T_S: "Time", **columns}
        table = pa.table({names[k]: pa.array(frame[k].to_numpy(np.float64)) for k in names})
        path = folder / f"{name}.csv"
        # pyarrow writes the shortest decimal that round-trips; the header without quotes.
        with open(path, "wb") as f:
            f.write((",".join(table.column_names) + "\n").encode("utf-8"))
            pa_csv.write_csv(table, f, pa_csv.WriteOptions(include_header=False))
        out[name] = path
    return out


def write_stream_mdf4(tables: StreamTables, path: Path) -> Path:
    """Write the streams as one MDF4 file, one channel group per stream (``asammdf``).

    Args:
        tables: the streams (times from 0 at the measurement start).
        path: the ``.mf4`` file.

    Returns:
        The path. :data:`SIGNAL_MAP` (without ``t``) reads it back.
    """
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    t_w = tables.wheels[c.T_S].to_numpy(np.float64)
    mdf.append(
        [
            Signal(tables.wheels[k].to_numpy(np.float64), t_w, name=n, unit="rad/s")
            for k, n in WHEEL_COLUMNS.items()
        ],
        comment="CAN wheel speeds",
    )
    t_g = tables.gnss[c.T_S].to_numpy(np.float64)
    units = {c.LAT_DEG: "deg", c.LON_DEG: "deg", c.N_SATS: ""}
    mdf.append(
        [
            Signal(tables.gnss[k].to_numpy(np.float64), t_g, name=n, unit=units[k])
            for k, n in GNSS_COLUMNS.items()
        ],
        comment="GNSS fixes",
    )
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    mdf.save(path, overwrite=True)
    mdf.close()
    return Path(path)


def write_comma2k19(tables: StreamTables, folder: Path, radius_m: float) -> Path:
    """Write the streams as a comma2k19 ``processed_log`` folder (NumPy arrays, no extension).

    Args:
        tables: the streams.
        folder: the segment folder; ``processed_log/CAN/wheel_speed`` (m/s: rad/s x
            ``radius_m``, as the car scales them) and ``processed_log/GNSS/live_gnss_ublox``
            (latitude, longitude, speed 0, UTC 0, altitude 0, bearing 0) go under it.
        radius_m: the radius the car's CAN turns wheel speeds into m/s with.

    Returns:
        The ``processed_log`` folder.
    """
    log = Path(folder) / "processed_log"
    wheels = np.stack([tables.wheels[w].to_numpy(np.float64) for w in c.WHEELS], axis=1)
    gnss = np.zeros((len(tables.gnss), 6))
    gnss[:, 0] = tables.gnss[c.LAT_DEG].to_numpy(np.float64)
    gnss[:, 1] = tables.gnss[c.LON_DEG].to_numpy(np.float64)
    for sub, t, value in (
        ("CAN/wheel_speed", tables.wheels[c.T_S], wheels * radius_m),
        ("GNSS/live_gnss_ublox", tables.gnss[c.T_S], gnss),
    ):
        (log / sub).mkdir(parents=True, exist_ok=True)
        for name, array in (("t", np.asarray(t, np.float64)), ("value", value)):
            with open(log / sub / name, "wb") as f:  # np.save on a path would add ".npy"
                np.save(f, array)
    return log


def write_comma2k19_route(
    tables: StreamTables,
    folder: Path,
    radius_m: float,
    segment_s: float = 60.0,
    first: int = 0,
    leave_out: tuple[int, ...] = (),
) -> list[Path]:
    """Write the streams as a comma2k19 route: one segment folder per ``segment_s`` of it.

    openpilot's logger cuts a drive (a route, ``dongle_id|start time``) into one-minute
    segments, numbered from 0, each a folder of its own ``processed_log`` on the one boot
    clock of the device (the comma2k19 dataset's layout, ``commaai/comma2k19`` README).

    Args:
        tables: the streams.
        folder: the route folder; segment ``n`` goes to ``folder / str(n)``
            (:func:`write_comma2k19`).
        radius_m: as for :func:`write_comma2k19`.
        segment_s: each segment's span, s, from the first sample.
        first: the first segment's number.
        leave_out: segment numbers not written (a route the dataset keeps in part).

    Returns:
        The ``processed_log`` folders written, in segment order.
    """
    t0 = min(float(tables.wheels[c.T_S].iloc[0]), float(tables.gnss[c.T_S].iloc[0]))
    end = max(float(tables.wheels[c.T_S].iloc[-1]), float(tables.gnss[c.T_S].iloc[-1]))
    written = []
    for k in range(int((end - t0) // segment_s) + 1):
        lo, hi = t0 + k * segment_s, t0 + (k + 1) * segment_s
        if first + k in leave_out:
            continue

        def part(table: pd.DataFrame, lo: float = lo, hi: float = hi) -> pd.DataFrame:
            t = table[c.T_S].to_numpy(np.float64)
            return table[(t >= lo) & (t < hi)].reset_index(drop=True)

        segment = StreamTables(part(tables.wheels), part(tables.gnss))
        written.append(write_comma2k19(segment, Path(folder) / str(first + k), radius_m))
    return written


def signal_map(with_time: bool = True, gyro: bool = False) -> Mapping[str, object]:
    """:data:`SIGNAL_MAP` as ``ColumnSpec`` entries (without ``t`` for MDF4; with the yaw
    rate of ``gyro.csv`` where ``gyro``)."""
    from rwhonet.config import ColumnSpec

    signals = {**SIGNAL_MAP, **({"yaw_rate": ("YawRate", "rad/s")} if gyro else {})}
    return {k: ColumnSpec(col, unit) for k, (col, unit) in signals.items() if with_time or k != "t"}
