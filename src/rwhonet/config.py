"""Typed view of ``params.yaml``.

Each top-level section is a frozen dataclass. Loading is strict: an unknown
key, a missing key or a value of the wrong type raises :class:`ConfigError`
naming the dotted key, so a typo in ``dvc exp run -S`` never passes silently.
"""

from __future__ import annotations

import dataclasses
import posixpath
import re
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any, Literal

import yaml


class ConfigError(ValueError):
    """A params.yaml value is missing, unknown or of the wrong type."""


# --------------------------------------------------------------------------- paths in params
# Params may name where to read (data.root: anywhere) but never make a stage write outside
# the project's output folders: the names that become file names are plain names, and the
# one path a stage writes to (the tracking store) stays in mlruns/ unless it is absolute,
# i.e. a store shared on purpose (two clones logging to one store).

# A name that becomes a file name (a simulated drive's CSV): no folder, no '..', no hidden file.
FILE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
TRACKING_FOLDER = "mlruns"
_LOCAL_SCHEMES = ("sqlite", "file", "")


def inside_project_problem(path: str, folder: str | None = None) -> str | None:
    """Why a relative path from params would leave the project (or ``folder``), or None.

    Args:
        path: the path as written in params.yaml (relative to the project root).
        folder: the project folder it must stay in (None: anywhere in the project).

    Returns:
        What is wrong with it, or None when the path stays where it must.
    """
    where = f"{folder}/" if folder else "the project"
    if not path or PurePosixPath(path).is_absolute() or "\\" in path:
        return f"expected a path relative to the project root, inside {where}"
    norm = posixpath.normpath(path)
    parts = PurePosixPath(norm).parts
    if norm == "." or parts[0] == ".." or (folder and (parts[0] != folder or len(parts) < 2)):
        return f"expected a path inside {where}; it resolves to {norm!r}"
    return None


def tracking_uri_problem(uri: str) -> str | None:
    """Why a tracking URI from params would make a stage write outside ``mlruns/``, or None.

    ``sqlite:///<relative path>`` (and a ``file:`` or bare path) must lie inside
    ``mlruns/``; ``sqlite:////<absolute path>`` names a store shared on purpose and
    is taken as it is, as is a server (``http://``...).

    Args:
        uri: ``tracking.tracking_uri`` as written in params.yaml.

    A URI with a password in it (``https://user:pw@host``) is refused whatever its
    scheme: params.yaml is committed, logged as run params and copied into
    ``dvc.lock``. The message does not repeat the URI.

    Returns:
        The problem, naming the key, or None.
    """
    if _has_password(uri):
        return (
            "tracking.tracking_uri holds a password: params.yaml is committed and logged; "
            "remove user and password from the URI and set MLFLOW_TRACKING_USERNAME / "
            "MLFLOW_TRACKING_PASSWORD in the environment, or ~/.mlflow/credentials "
            "(docs/team.md)"
        )
    scheme, sep, rest = uri.partition(":")
    if not sep or len(scheme) == 1:  # a bare path (or a Windows drive letter)
        scheme, rest = "", uri
    if scheme.lower() not in _LOCAL_SCHEMES:
        return None
    if scheme.lower() == "sqlite":
        if rest in ("", "//"):  # in memory
            return None
        if not rest.startswith("///"):
            return f"tracking.tracking_uri={uri!r}: expected sqlite:///<path>"
        path = rest[3:]
    else:
        path = rest[2:] if rest.startswith("//") else rest
    if path.startswith("/"):
        return None  # absolute: a store shared on purpose
    problem = inside_project_problem(path, TRACKING_FOLDER)
    if problem is None:
        return None
    return (
        f"tracking.tracking_uri={uri!r}: a relative store path must stay in "
        f"{TRACKING_FOLDER}/ ({problem}); to share a store on purpose, give its absolute "
        "path (sqlite:////abs/path/mlflow.db)"
    )


def _has_password(uri: str) -> bool:
    """Whether a URI carries ``user:password@`` (``scheme://user:pw@host/...``)."""
    scheme, sep, rest = uri.partition("://")
    if not sep:
        return False
    netloc = re.split(r"[/?#]", rest, maxsplit=1)[0]
    userinfo, at, _ = netloc.rpartition("@")
    return bool(at) and ":" in userinfo


# --------------------------------------------------------------------------- sections


def _require_at_least(bound: int, names: str, *values: float) -> None:
    """Raise :class:`ConfigError` (``<names> must be >= <bound>, got <values>``) unless
    every value is at least ``bound``."""
    if any(v < bound for v in values):
        raise ConfigError(f"{names} must be >= {bound}, got {', '.join(f'{v}' for v in values)}")


# Manoeuvres the simulator can place on a road (rates in sim.roads.*.per_km, counts in
# sim.profiles.*.drives[*].events); docs/simulator.md describes each.
SIM_EVENTS = (
    "stop",
    "standstill",
    "traffic",
    "curve",
    "roundabout",
    "sharp_turn",
    "successive_turns",
    "hard_brake",
    "quick_acceleration",
    "reversing",
)


@dataclass(frozen=True)
class SimWheels:
    """One number per wheel (front/rear, left/right)."""

    fl: float
    fr: float
    rl: float
    rr: float


@dataclass(frozen=True)
class SimTyreState:
    """A tyre state (IO-VNBD letters A-E): inflation pressure and tread depth per wheel."""

    pressure_psi: SimWheels
    tread_mm: SimWheels


@dataclass(frozen=True)
class SimTyre:
    """Tyre model constants (docs/simulator.md, Section 3)."""

    reference_pressure_psi: float  # pressure at which vertical_stiffness_n_m holds
    vertical_stiffness_n_m: float  # C_z0 at the reference pressure
    stiffness_pressure_coeff: float  # p_Fz1: C_z = C_z0 (1 + p_Fz1 dp)
    new_tread_mm: float
    free_radius_offset_mm: float  # this car's tyres vs the size's design radius (brand spread)
    speed_growth_coeff: float  # q_V1: R_Omega = R_0 (1 + q_V1 (v / V_0)^2)
    speed_growth_ref_m_s: float  # V_0
    slip_stiffness_per_load: float  # C_Fkappa / F_z (per unit slip), dry road
    rolling_resistance: float  # f_rr
    warm_rise_k: float  # steady tyre-air temperature rise over ambient at warm_ref_speed_m_s
    warm_ref_speed_m_s: float
    warm_tau_s: float  # time constant of the tyre-air temperature


@dataclass(frozen=True)
class SimCan:
    """CAN wheel-speed signal."""

    quantum_rad_s: float
    noise_rad_s: float
    latency_s: float
    min_speed_rad_s: float  # below this the ABS sensor reads 0


@dataclass(frozen=True)
class SimGnss:
    """GNSS receiver: a slow Gauss-Markov drift seen through the navigation filter, + white noise.

    The horizontal position error per axis is a first-order Gauss-Markov drift
    (correlation time ``tau_s``) low-passed by the receiver's navigation filter
    (time constant ``filter_tau_s``), scaled to the stationary std ``sigma_m``;
    docs/simulator.md Section 5 derives the per-second displacement noise.
    """

    sigma_m: float  # stationary std of the horizontal position error, per axis
    tau_s: float  # correlation time of the drift (atmosphere, orbits, clocks)
    filter_tau_s: float  # time constant of the navigation filter (first-order low-pass)
    white_m: float  # white noise per fix and axis (position resolution, jitter)
    vertical_factor: float  # vertical error = vertical_factor * horizontal
    speed_noise_m_s: float  # white noise on the Doppler speed
    sats: list[int]  # [min, max] satellites in open sky
    multipath_sigma_m: float  # low_sats stretches: extra Gauss-Markov error per axis
    multipath_tau_s: float  # ... and its correlation time


@dataclass(frozen=True)
class SimGyro:
    """The ESC yaw-rate sensor as the car's CAN bus carries it (docs/simulator.md, Section 7).

    ``measured = (1 + scale_error_pct / 100) true + b0 + b_GM(t) + tco dT(t) + noise``,
    each value the mean over its record period, ``latency_s`` late, quantised to
    ``quantum_deg_s``. ``b0`` is drawn per drive (turn-on bias), ``b_GM`` is a
    first-order Gauss-Markov bias instability and ``dT`` the sensor's warm-up
    ``warmup_k (1 - exp(-t / warmup_tau_s))`` from a cold start.
    """

    bias_sigma_deg_s: float  # turn-on bias b0 ~ N(0, sigma^2), drawn per drive
    instability_sigma_deg_s: float  # in-run bias: stationary std of the Gauss-Markov term
    instability_tau_s: float  # ... and its correlation time
    temp_coeff_deg_s_k: float  # this unit's bias change per K of sensor temperature (signed)
    warmup_k: float  # sensor temperature rise over a drive from a cold start
    warmup_tau_s: float  # ... its time constant
    scale_error_pct: float  # this unit's scale-factor error, %
    noise_density_deg_s_rthz: float  # rate noise density
    quantum_deg_s: float  # the CAN signal's resolution (LSB); 0: not quantised
    latency_s: float  # sensor filter + CAN + logger delay


@dataclass(frozen=True)
class SimDriver:
    """How the car's driver drives (relative to the road types' settings)."""

    speed_factor: float  # multiplies the cruise speed of every leg
    accel_factor: float  # multiplies the roads' comfortable acceleration
    decel_factor: float  # multiplies the roads' comfortable deceleration
    lat_acc_max_g: float  # slows down before curves to stay below this


@dataclass(frozen=True)
class SimVehicle:
    """A simulated vehicle (one car: its body, tyres, sensors and driver)."""

    nominal_radius_m: float  # spec-sheet effective rolling radius (docs/simulator.md, Section 2)
    drive: Literal["fwd", "rwd"]
    mass_kg: float  # car + driver + logger, no payload
    wheelbase_m: float
    track_front_m: float
    track_rear_m: float
    front_load_fraction: float
    cg_height_m: float
    drag_area_m2: float
    brake_front_share: float
    steering_ratio: float
    gear_ratios: list[float]
    final_drive: float
    idle_rpm: float
    antenna_x_m: float  # GNSS antenna ahead of the rear-axle centre
    antenna_y_m: float  # ... and to its left
    tyre: SimTyre
    can: SimCan
    gnss: SimGnss
    gyro: SimGyro
    driver: SimDriver
    tyre_states: dict[str, SimTyreState]


@dataclass(frozen=True)
class SimRoad:
    """How a road type is driven and how often each event happens on it."""

    speed_m_s: list[float]  # [min, max] cruise speed of a leg
    accel_m_s2: float
    decel_m_s2: float
    leg_s: list[float]  # [min, max] duration of a leg
    curve_radius_m: list[float]
    curve_angle_deg: list[float]
    per_km: dict[str, float]  # event rates, events per km


@dataclass(frozen=True)
class SimLeak:
    """A slow puncture: one tyre loses air at a constant rate during the drive."""

    wheel: Literal["fl", "fr", "rl", "rr"]
    psi_per_h: float


@dataclass(frozen=True)
class SimDrive:
    """One drive of a fleet profile."""

    name: str
    role: Literal[
        "source_train", "source_calibration", "source_test", "target_train", "target_test"
    ]
    vehicle: str  # the pipeline's vehicle name (source | target), mapped by the profile
    tyre: str
    duration_s: float
    roads: dict[str, float]  # share of driving time per road type
    events: dict[str, int] = field(default_factory=dict)  # counts replacing the road rates
    event_scale: float = 1.0  # multiplies every road rate (0.1: a calm drive)
    wet_fraction: float = 0.0
    gnss_faults: list[Literal["low_sats", "frozen", "jump", "gap"]] = field(default_factory=list)
    payload_kg: float = 0.0  # passengers and luggage besides the driver
    payload_x_m: float = 0.0  # their centre of mass ahead of the rear axle (boot: negative)
    leaks: list[SimLeak] = field(default_factory=list)


@dataclass(frozen=True)
class SimProfile:
    """A fleet: which simulated car plays each pipeline vehicle, and the drives.

    ``drives_from`` reuses another profile's drive list (same names, roles,
    tyre-state letters, payloads and seeds) instead of repeating it.
    """

    vehicles: dict[str, str]  # pipeline vehicle name -> sim.vehicles key
    drives: list[SimDrive] = field(default_factory=list)
    drives_from: str | None = None
    # pipeline vehicle name -> sim.receivers key: that car's receiver replaced by this grade
    receivers: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class SimParams:
    """Simulator settings; the fleet profiles are documented in docs/simulator.md."""

    profile: str
    integration_hz: int
    record_hz: int
    start_lat_deg: float
    start_lon_deg: float
    start_height_m: float
    day_start_s: list[float]  # [earliest, latest] start of a drive, s since midnight
    friction_dry: float
    friction_wet: float
    wet_slip_stiffness_factor: float
    air_density_kg_m3: float
    roads: dict[str, SimRoad]
    vehicles: dict[str, SimVehicle]
    profiles: dict[str, SimProfile]
    seed: int = 42  # the simulated world's seed (drive i: SeedSequence(seed, spawn_key=(i,)))
    # Named GNSS receiver grades a profile fits to a car in place of its own (profiles.*.receivers)
    receivers: dict[str, SimGnss] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.profile not in self.profiles:
            raise ConfigError(
                f"sim.profile={self.profile!r} is not in sim.profiles {sorted(self.profiles)}"
            )
        if self.integration_hz % self.record_hz:
            raise ConfigError(
                f"sim.integration_hz={self.integration_hz} must be a multiple of "
                f"sim.record_hz={self.record_hz}"
            )
        pairs = {"sim.day_start_s": self.day_start_s}
        for name, road in self.roads.items():
            for key in ("speed_m_s", "leg_s", "curve_radius_m", "curve_angle_deg"):
                pairs[f"sim.roads.{name}.{key}"] = getattr(road, key)
        receivers = {f"sim.vehicles.{n}.gnss": v.gnss for n, v in self.vehicles.items()}
        receivers.update({f"sim.receivers.{n}": g for n, g in self.receivers.items()})
        for where, gnss in receivers.items():
            pairs[f"{where}.sats"] = gnss.sats
        for key, pair in pairs.items():
            if len(pair) != 2 or pair[0] > pair[1]:
                raise ConfigError(f"{key}: expected [min, max], got {pair}")
        for where, gnss in receivers.items():
            for key in ("sigma_m", "tau_s", "filter_tau_s", "multipath_tau_s"):
                if not getattr(gnss, key) > 0:
                    raise ConfigError(f"{where}.{key} must be > 0, got {getattr(gnss, key)}")
        for name, veh in self.vehicles.items():
            gyro = veh.gyro
            non_negative = {
                "bias_sigma_deg_s": gyro.bias_sigma_deg_s,
                "instability_sigma_deg_s": gyro.instability_sigma_deg_s,
                "warmup_k": gyro.warmup_k,
                "noise_density_deg_s_rthz": gyro.noise_density_deg_s_rthz,
                "quantum_deg_s": gyro.quantum_deg_s,
                "latency_s": gyro.latency_s,
            }
            for key, value in non_negative.items():
                if not value >= 0:
                    raise ConfigError(f"sim.vehicles.{name}.gyro.{key} must be >= 0, got {value}")
            positive = {
                "nominal_radius_m": veh.nominal_radius_m,
                "gyro.instability_tau_s": gyro.instability_tau_s,
                "gyro.warmup_tau_s": gyro.warmup_tau_s,
                "tyre.warm_ref_speed_m_s": veh.tyre.warm_ref_speed_m_s,
                "tyre.warm_tau_s": veh.tyre.warm_tau_s,
                "driver.speed_factor": veh.driver.speed_factor,
                "driver.accel_factor": veh.driver.accel_factor,
                "driver.decel_factor": veh.driver.decel_factor,
                "driver.lat_acc_max_g": veh.driver.lat_acc_max_g,
            }
            for key, value in positive.items():
                if not value > 0:
                    raise ConfigError(f"sim.vehicles.{name}.{key} must be > 0, got {value}")
        self._resolve_drives_from()
        for pname, prof in self.profiles.items():
            for role, sim_name in prof.vehicles.items():
                if sim_name not in self.vehicles:
                    raise ConfigError(
                        f"sim.profiles.{pname}.vehicles.{role}={sim_name!r} is not in "
                        f"sim.vehicles {sorted(self.vehicles)}"
                    )
            for role, grade in prof.receivers.items():
                if role not in prof.vehicles:
                    raise ConfigError(
                        f"sim.profiles.{pname}.receivers.{role}: {role!r} is not in "
                        f"sim.profiles.{pname}.vehicles {sorted(prof.vehicles)}"
                    )
                if grade not in self.receivers:
                    raise ConfigError(
                        f"sim.profiles.{pname}.receivers.{role}={grade!r} is not in "
                        f"sim.receivers {sorted(self.receivers)}"
                    )
            names = [d.name for d in prof.drives]
            if len(set(names)) != len(names):
                raise ConfigError(f"sim.profiles.{pname}: drive names must be unique")
            for i, d in enumerate(prof.drives):
                where = f"sim.profiles.{pname}.drives[{i}] ({d.name})"
                if not FILE_NAME.fullmatch(d.name):
                    raise ConfigError(
                        f"{where}: name {d.name!r} becomes a file name: expected letters, "
                        "digits, '.', '_' or '-' (no folder), starting with a letter or digit"
                    )
                if d.vehicle not in prof.vehicles:
                    raise ConfigError(
                        f"{where}: vehicle {d.vehicle!r} not in sim.profiles.{pname}.vehicles "
                        f"{sorted(prof.vehicles)}"
                    )
                sim_name = prof.vehicles[d.vehicle]
                if d.tyre not in self.vehicles[sim_name].tyre_states:
                    raise ConfigError(
                        f"{where}: tyre {d.tyre!r} not in sim.vehicles.{sim_name}.tyre_states"
                    )
                unknown = sorted(set(d.roads) - set(self.roads))
                if unknown or not d.roads or min(d.roads.values()) < 0:
                    raise ConfigError(
                        f"{where}: roads {d.roads} must be shares of {sorted(self.roads)}"
                    )
                if set(d.events) - set(SIM_EVENTS):
                    raise ConfigError(f"{where}: events {d.events} must be among {SIM_EVENTS}")
                if d.payload_kg < 0 or any(leak.psi_per_h < 0 for leak in d.leaks):
                    raise ConfigError(f"{where}: payload_kg and leaks[*].psi_per_h must be >= 0")
        for name, road in self.roads.items():
            if set(road.per_km) - set(SIM_EVENTS):
                raise ConfigError(
                    f"sim.roads.{name}.per_km {sorted(road.per_km)} must be among {SIM_EVENTS}"
                )

    def _resolve_drives_from(self) -> None:
        """Give every ``drives_from`` profile the drive list it names (one level deep)."""
        for pname, prof in self.profiles.items():
            if prof.drives_from is None:
                if not prof.drives:
                    raise ConfigError(f"sim.profiles.{pname}: give drives or drives_from")
                continue
            base = self.profiles.get(prof.drives_from)
            if prof.drives:
                raise ConfigError(f"sim.profiles.{pname}: give drives or drives_from, not both")
            if base is None or base.drives_from is not None:
                raise ConfigError(
                    f"sim.profiles.{pname}.drives_from={prof.drives_from!r} must name a "
                    f"profile with its own drives"
                )
            # Frozen dataclass: the resolved list is set once, at load time.
            object.__setattr__(prof, "drives", list(base.drives))


# Formats with a reader of their own (no map): the IO-VNBD "V-" layout, comma2k19 folders.
BUILTIN_FORMATS = ("iovnbd", "comma2k19")


@dataclass(frozen=True)
class RoleSpec:
    """Where the drives of one role live and how to read them.

    ``drives``: the role takes only the drives its glob finds whose id matches one of these
    patterns (shell-style, case-sensitive: ``T-04*``, ``RAV4-0[0-4]``, an id itself); None:
    every one. A file of many drives (a column map's ``drive`` key) is how several roles
    share one file, each taking its own drives of it; each pattern must match a drive.
    """

    glob: str
    format: str
    vehicle: str
    required: bool = True
    drives: list[str] | None = None


@dataclass(frozen=True)
class ColumnSpec:
    """One canonical quantity in a column-mapped CSV: its column name and unit.

    ``scale`` and ``offset``: a channel logged as raw numbers (a CAN signal's raw value in
    a CSV export, ``ublox_msgs``' latitude in 1e-7 deg, a speed in mm/s) is read as
    ``raw * scale + offset`` in ``unit``, a DBC's ``(factor, offset)``, before the unit is
    converted to SI (:func:`rwhonet.data.columnmap.scale_issues` says where they may be set).
    """

    column: str  # the column (or logged channel) that holds it
    unit: str  # as the file writes it (after scale and offset); readers convert to SI
    scale: float = 1.0
    offset: float = 0.0

    @property
    def scaled(self) -> bool:
        """Whether the map scales or offsets the logged values."""
        return self.scale != 1.0 or self.offset != 0.0


@dataclass(frozen=True)
class SignalMapSpec:
    """A drive logged as timestamped streams: its reader, and where each quantity is.

    ``reader``: ``mdf4`` (one ASAM MDF4 file per drive, :mod:`rwhonet.data.mdf4`, or one
    bus tool's log of raw CAN frames: candump, ASC, BLF, TRC, :mod:`rwhonet.data.canlog`, or
    one ROS bag, a ROS 2 bag's folder too, its signals ``/topic.field``:
    :mod:`rwhonet.data.rosbag`) or
    ``stream_csv`` (one folder per drive holding one CSV per sensor stream,
    :mod:`rwhonet.data.streamcsv`; ``t`` names their common time column). ``signals``:
    key -> the logged channel and its unit (:mod:`rwhonet.data.signalmap`). ``source``:
    the file the map was read from (``rwhonet ... --signal-map FILE``), so messages name
    it; None for a map in params.yaml (messages name its key). ``dbc``: the CAN databases
    (DBC, or ARXML) that decode a log of raw CAN frames (an MDF4 bus log: a CANedge's, a
    Vector logger's; a candump, ASC, BLF or TRC log, alone or, for ``stream_csv``, among
    the folder's CSVs and NMEA log) before its signals are read; paths relative to the
    project root (a map file's: to its folder). One file or a list decodes every bus; a
    mapping from a bus to its file(s) (``{can0: chassis.dbc, can1: [pt.dbc]}``) decodes
    each bus by its own, the bus named as the log names it (a candump interface, ASC/BLF's
    channel number; an MDF4 bus log's bus channel number). Empty: the file holds decoded
    signals. ``local_zone``: the time zone (IANA, ``Europe/Berlin``) of a logger whose clock
    is local time without a zone, so its times can be put on UTC beside a receiver's: an ASC
    log's date line (the logging computer's clock at the measurement's start), a PEAK TRC's
    ``$STARTTIME`` (the same, as PCAN-View writes it), an MDF4 file whose start is marked
    local time; None: such times are kept as the log gives them.
    """

    reader: Literal["mdf4", "stream_csv"]
    signals: dict[str, ColumnSpec]
    source: str | None = None
    dbc: list[str] | str | dict[str, list[str] | str] = field(default_factory=list)
    local_zone: str | None = None

    def __post_init__(self) -> None:
        if self.local_zone is not None:
            from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

            try:
                ZoneInfo(self.local_zone)
            except (ZoneInfoNotFoundError, ValueError):
                where = self.source or "the signal map"
                raise ConfigError(
                    f"{where}: local_zone {self.local_zone!r} is no time zone the IANA "
                    "database names (Europe/Berlin, America/Detroit, Asia/Tokyo, UTC)"
                ) from None

    @property
    def dbc_buses(self) -> tuple[tuple[str, str | None], ...]:
        """Each CAN database with the bus it decodes (None: every bus), relative paths from
        the project root."""
        from rwhonet import paths

        def files(v: list[str] | str) -> tuple[str, ...]:
            return (v,) if isinstance(v, str) else tuple(v)

        if isinstance(self.dbc, dict):
            pairs = [(f, str(bus)) for bus, v in self.dbc.items() for f in files(v)]
        else:
            pairs = [(f, None) for f in files(self.dbc)]
        return tuple((str(paths.resolve(f)), bus) for f, bus in pairs)

    @property
    def dbc_files(self) -> tuple[str, ...]:
        """The CAN databases (one, a list or per bus, as written), relative ones from the
        project root."""
        return tuple(dict.fromkeys(f for f, _ in self.dbc_buses))


@dataclass(frozen=True)
class VehicleSpec:
    """What the pipeline knows about a vehicle before seeing its drives."""

    nominal_radius_m: float
    track_rear_m: float  # rear track width: the wheel yaw of 2D dead reckoning


@dataclass(frozen=True)
class DataParams:
    source: Literal["sim", "files"]
    root: str
    roles: dict[str, RoleSpec]
    vehicles: dict[str, VehicleSpec]
    column_maps: dict[str, dict[str, ColumnSpec]] = field(default_factory=dict)
    # Drives logged as timestamped streams (MDF4 files, folders of stream CSVs).
    signal_maps: dict[str, SignalMapSpec] = field(default_factory=dict)
    # A larger drive file is refused before it is read: validate holds a drive in memory.
    max_file_mb: float = 512.0
    # Stream drives' fixes against their wheel speeds' clock (rwhonet.data.fixlag):
    # "report" estimates the lag and says it, "auto" also moves the fixes where it is
    # clear, a number (s, within +-60) moves them by that (a fix stamped t taken at t - lag).
    # Fixes stamped by another clock (a lag beyond +-1 s) are refused by report.
    gnss_lag: Literal["report", "auto"] | float = "report"
    # A drive ingest or validate refuses: "stop" fails the stage with every problem (nothing
    # written); "leave_out" goes on without it, named in every manifest and report and in
    # the tables (rwhonet.data.leftout); a required role left without a drive still fails.
    refused_drives: Literal["stop", "leave_out"] = "stop"

    def __post_init__(self) -> None:
        if not self.max_file_mb > 0:
            raise ConfigError(f"data.max_file_mb must be > 0, got {self.max_file_mb}")
        for role, spec in self.roles.items():
            if spec.drives is not None and not (spec.drives and all(d for d in spec.drives)):
                raise ConfigError(
                    f"data.roles.{role}.drives: expected a list of drive ids or patterns "
                    f"(T-04*), none empty; got {spec.drives!r}"
                )
        # ±61 s: what the search for two clocks can find (its ±60 s and the latency's
        # ±1 s about it: rwhonet.data.fixlag), so that the setting a refusal names loads
        if isinstance(self.gnss_lag, float) and not abs(self.gnss_lag) <= 61.0:
            raise ConfigError(
                f"data.gnss_lag must be report, auto or a lag in seconds within ±61 (a "
                f"receiver's latency, or two clocks' offset), got {self.gnss_lag}"
            )
        clash = sorted(
            (set(self.column_maps) & set(self.signal_maps))
            | ((set(self.column_maps) | set(self.signal_maps)) & set(BUILTIN_FORMATS))
        )
        if clash:
            raise ConfigError(
                f"data.column_maps / data.signal_maps: the name(s) {clash} are taken (a format "
                f"names one reader: the built-in {list(BUILTIN_FORMATS)}, a column map or a "
                "signal map); rename the map"
            )

    @property
    def formats(self) -> list[str]:
        """Every format a role may name: the built-in readers, column maps, signal maps."""
        return [*BUILTIN_FORMATS, *sorted(self.column_maps), *sorted(self.signal_maps)]


@dataclass(frozen=True)
class GnssPolicy:
    min_sats: int
    max_speed_m_s: float
    frozen_min_s: float
    moving_wheel_speed_rad_s: float
    max_gap_s: float
    min_segment_s: float
    # A fix whose receiver states a horizontal accuracy worse than this (m, the drive's
    # h_acc_m), or states none in a drive that has the column, is no fix; None: not screened.
    max_h_acc_m: float | None = None

    def __post_init__(self) -> None:
        if self.max_h_acc_m is not None and not self.max_h_acc_m > 0.0:
            raise ConfigError(
                f"validate.gnss.max_h_acc_m must be > 0 m (or null: accuracy not screened), "
                f"got {self.max_h_acc_m}"
            )


@dataclass(frozen=True)
class CutSpec:
    drive: str
    start_s: float
    end_s: float
    reason: str


@dataclass(frozen=True)
class WheelPolicy:
    """Wheel-speed sensor checks; a drive that fails one is refused (validate.wheels)."""

    # A wheel reading below stuck_ratio x the median of the four wheels, while that median
    # is above stuck_moving_rad_s, for stuck_min_s or longer, has a stuck sensor.
    stuck_ratio: float
    stuck_moving_rad_s: float
    stuck_min_s: float
    # Wheel speeds are magnitudes (ABS sensors); a value below -negative_tol_rad_s is a
    # sign error, unless all four wheels are negative together (a logger that signs its
    # speeds, reversing) on at most signed_max_share of the moving rows: then the
    # magnitudes are taken and the report says so.
    negative_tol_rad_s: float
    signed_max_share: float

    def __post_init__(self) -> None:
        if not 0.0 < self.stuck_ratio < 1.0:
            raise ConfigError(
                f"validate.wheels.stuck_ratio must be in (0, 1), got {self.stuck_ratio}"
            )
        if self.stuck_min_s <= 0 or self.stuck_moving_rad_s < 0 or self.negative_tol_rad_s < 0:
            raise ConfigError(
                "validate.wheels: stuck_min_s must be > 0, stuck_moving_rad_s and "
                f"negative_tol_rad_s >= 0; got {self.stuck_min_s}, {self.stuck_moving_rad_s}, "
                f"{self.negative_tol_rad_s}"
            )
        if not 0.0 <= self.signed_max_share < 1.0:
            raise ConfigError(
                f"validate.wheels.signed_max_share must be in [0, 1), got {self.signed_max_share}"
            )


@dataclass(frozen=True)
class ValidateParams:
    sample_period_s: float
    sample_period_tol_s: float
    max_abs_wheel_speed_rad_s: float
    radius_tolerance: float
    radius_min_moving_s: float
    gnss: GnssPolicy
    wheels: WheelPolicy
    cuts: list[CutSpec] = field(default_factory=list)
    # the GNSS course's turn over the yaw rate's within 1 ± this (a wrong unit or sign is
    # refused: rwhonet.data.plausibility.yaw_mistake)
    yaw_gain_tolerance: float = 0.25

    def __post_init__(self) -> None:
        if not self.yaw_gain_tolerance > 0.0:
            raise ConfigError(
                f"validate.yaw_gain_tolerance must be > 0, got {self.yaw_gain_tolerance}"
            )


@dataclass(frozen=True)
class LabelParams:
    wpm_mode: Literal["integrated", "reference"]
    calibration_min_speed_m_s: float
    scaler: Literal["global", "per_wheel"]


@dataclass(frozen=True)
class ModelParams:
    hidden: int
    layers: int
    dropout: float
    seq_len: int
    # the network (rwhonet.models.network): the paper's WhONet, or one with temporal context
    arch: Literal["whonet", "gru", "tcn"] = "whonet"
    channels: int = 16  # tcn: context features per level

    def __post_init__(self) -> None:
        _require_at_least(1, "model.seq_len and model.channels", self.seq_len, self.channels)


@dataclass(frozen=True)
class TrainerParams:
    """Where and how Lightning runs G's and S's training (docs/scaling.md).

    The defaults (one CPU process, 32-bit) are the paper's single-process run.
    ``train.batch_size`` is per process: with ``ddp`` the effective batch is
    ``batch_size * devices * num_nodes``.
    """

    accelerator: Literal["cpu", "gpu", "cuda", "auto"] = "cpu"
    devices: int = 1  # processes (CPU) or GPUs per node
    strategy: Literal["auto", "ddp"] = "auto"  # auto: one process; ddp: one process per device
    num_nodes: int = 1
    precision: Literal["32-true", "bf16-mixed", "16-mixed"] = "32-true"

    def __post_init__(self) -> None:
        _require_at_least(1, "train.trainer.devices and num_nodes", self.devices, self.num_nodes)
        if self.strategy == "auto" and self.devices * self.num_nodes > 1:
            raise ConfigError(
                f"train.trainer: {self.devices} device(s) on {self.num_nodes} node(s) need "
                "strategy: ddp (auto runs one process)"
            )

    @property
    def world_size(self) -> int:
        """Training processes in all (one per device)."""
        return self.devices * self.num_nodes


@dataclass(frozen=True)
class TrainParams:
    epochs: int
    batch_size: int
    lr: float
    val_fraction: float
    num_threads: int
    trainer: TrainerParams = field(default_factory=TrainerParams)


@dataclass(frozen=True)
class StepsParams:
    """The ``steps`` recipe: a step budget and early stopping on a held-back tail."""

    max_steps: int
    holdout_fraction: float  # the last part of the m seconds, never trained on
    patience: int  # steps without a better held-back MAE before stopping


@dataclass(frozen=True)
class ContinuousParams:
    """The ``continuous`` recipe: recalibrate before every outage window."""

    inner: Literal["ridge_head", "radius+G", "shrink+ridge_head"]  # run before each window
    window_s: int  # GNSS-valid seconds before the window it fits on; 0: all of the drive so far


@dataclass(frozen=True)
class ShrinkParams:
    """The ``shrink`` recipes' evidence (rwhonet.models.adapt.ShrinkEvidence)."""

    # τ's part for a car no evidence drive is of (the source car's drives only):
    # the spread of relative rear radius between cars on tyres of one nominal size
    unknown_car_sd: float
    min_rest_s: int  # an evidence drive counts at k while this many seconds follow k


Recipe = Literal[
    "paper", "head", "ridge_head", "radius+G", "steps", "continuous", "shrink", "continuous_shrink"
]
AUTO = "auto"  # adapt.recipe / adapt.chosen_m: the selection rule picks (evaluation.selection)


@dataclass(frozen=True)
class FallbackParams:
    """What ``auto`` reports as R-WhONet when the selection rule has no candidate."""

    recipe: Recipe  # one of adapt.recipes
    m: int  # seconds of target drive, one of adapt.m_grid


@dataclass(frozen=True)
class AdaptParams:
    m_grid: list[int]
    chosen_m: int | Literal["auto"]
    recipe: Recipe | Literal["auto"]  # reported as R-WhONet (R, R@m)
    recipes: list[Recipe]  # every recipe the adapt stages run
    epochs: int
    batch_size: int
    lr: float
    ridge_penalty: float
    ridge_penalty_grid: list[float]  # candidates scored on held-out source drives only
    steps: StepsParams
    continuous: ContinuousParams
    shrink: ShrinkParams
    fallback: FallbackParams

    @property
    def auto(self) -> bool:
        """Whether R-WhONet's recipe and m are left to the selection rule."""
        return self.recipe == AUTO

    def __post_init__(self) -> None:
        if (self.recipe == AUTO) != (self.chosen_m == AUTO):
            raise ConfigError(
                "adapt.recipe and adapt.chosen_m are chosen together: set both to auto or "
                f"neither, got recipe={self.recipe!r}, chosen_m={self.chosen_m!r}"
            )
        for key, recipe in (("recipe", self.recipe), ("fallback.recipe", self.fallback.recipe)):
            if recipe != AUTO and recipe not in self.recipes:
                raise ConfigError(f"adapt.{key}={recipe!r} is not in adapt.recipes {self.recipes}")
        if self.recipe == AUTO and self.fallback.m not in self.m_grid:
            raise ConfigError(
                f"adapt.fallback.m={self.fallback.m} is not in adapt.m_grid={self.m_grid}"
            )
        if len(set(self.recipes)) != len(self.recipes):
            raise ConfigError(f"adapt.recipes must not repeat a recipe, got {self.recipes}")
        if self.ridge_penalty < 0:
            raise ConfigError(f"adapt.ridge_penalty must be >= 0, got {self.ridge_penalty}")
        if not 0.0 < self.steps.holdout_fraction < 1.0 or self.steps.max_steps < 1:
            raise ConfigError(
                "adapt.steps: holdout_fraction must be in (0, 1) and max_steps >= 1, got "
                f"{self.steps.holdout_fraction}, {self.steps.max_steps}"
            )
        if self.continuous.window_s < 0:
            raise ConfigError(
                f"adapt.continuous.window_s must be >= 0, got {self.continuous.window_s}"
            )
        if self.shrink.unknown_car_sd < 0 or self.shrink.min_rest_s < 1:
            raise ConfigError(
                "adapt.shrink: unknown_car_sd must be >= 0 and min_rest_s >= 1, got "
                f"{self.shrink.unknown_car_sd}, {self.shrink.min_rest_s}"
            )


@dataclass(frozen=True)
class DeadReckoningParams:
    """2D dead reckoning through each outage window (rwhonet.features.deadreckoning)."""

    calibration_s: int  # GNSS seconds before the window the heading is fitted on (0: all)
    min_step_m: float  # a second that moved less gives no GNSS course


@dataclass(frozen=True)
class NavGyroParams:
    """The yaw-rate sensor the navigation filter assumes (rwhonet.nav.sensors.GyroSpec)."""

    noise_density_deg_s_rthz: float
    lsb_deg_s: float  # the CAN signal's resolution
    bias_sd_deg_s: float  # turn-on bias spread (the filter's prior)
    instability_deg_s: float  # Gauss-Markov bias wander
    instability_tau_s: float
    temp_drift_deg_s_k: float  # bias change per kelvin
    warm_rate_k_s: float  # the sensor's warm-up rate at power-on
    warm_tau_s: float  # the warm-up's time constant
    scale_sd: float  # scale-factor error spread (fraction)
    # how late the channel reads the turn against the fixes, s (the starting point of its
    # fit on the target training drives: NavigationParams.fit_geometry)
    latency_s: float = 0.0
    # instability_deg_s fitted with the receiver's drift on the target training drives
    # (rwhonet.evaluation.position.fit_noise), the configured one its starting point
    fit_instability: bool = True


@dataclass(frozen=True)
class NavWheelParams:
    """The rear wheels' CAN speeds (rwhonet.nav.sensors.WheelSpec)."""

    quantum_rad_s: float  # the CAN signal's resolution
    noise_rad_s: float  # white noise of each sample


@dataclass(frozen=True)
class NavGnssParams:
    """The receiver's error (rwhonet.nav.sensors.GnssSpec), per axis."""

    sigma_m: float  # Gauss-Markov drift
    tau_s: float
    white_m: float  # white noise per fix
    # sigma_m fitted on the target training drives (rwhonet.evaluation.position.fit_noise)
    fit_sigma: bool = True


@dataclass(frozen=True)
class NavigationParams:
    """2D navigation through each outage (rwhonet.evaluation.position, rwhonet.nav)."""

    control_model: str  # whose distances the wheels / gyro / fused controls run on (R: R-WhONet)
    min_calibration_s: int  # seconds the filter must have run on GNSS before an outage
    antenna_m: list[float]  # the antenna ahead of and left of the rear-axle centre, m
    gyro: NavGyroParams
    wheels: NavWheelParams
    gnss: NavGnssParams
    # the antenna's place and the gyro's latency fitted on the target training drives by how
    # well the filter predicts their fixes (rwhonet.evaluation.position.fit_geometry); the
    # configured ones are the starting point
    fit_geometry: bool = True

    def __post_init__(self) -> None:
        if len(self.antenna_m) != 2:
            raise ConfigError(
                f"evaluate.navigation.antenna_m: expected [ahead, left] in m, got {self.antenna_m}"
            )
        if self.min_calibration_s < 0:
            raise ConfigError(
                f"evaluate.navigation.min_calibration_s must be >= 0, got {self.min_calibration_s}"
            )
        figures = {
            **{f"gyro.{k}": v for k, v in dataclasses.asdict(self.gyro).items()},
            **{f"wheels.{k}": v for k, v in dataclasses.asdict(self.wheels).items()},
            **{f"gnss.{k}": v for k, v in dataclasses.asdict(self.gnss).items()},
        }
        late = figures.pop("gyro.latency_s")
        # the switches (gnss.fit_sigma, gyro.fit_instability) are not figures: false is fine
        figures = {k: v for k, v in figures.items() if not k.split(".")[1].startswith("fit_")}
        bad = [f"evaluate.navigation.{k} = {v}" for k, v in figures.items() if not v > 0]
        if bad:
            raise ConfigError("sensor figures must be > 0: " + ", ".join(bad))
        if not late >= 0:
            raise ConfigError(f"evaluate.navigation.gyro.latency_s must be >= 0 s, got {late}")


@dataclass(frozen=True)
class EvaluateParams:
    outages_s: list[int]
    dead_reckoning: DeadReckoningParams
    navigation: NavigationParams
    scenario_outage_s: int  # the outage over each tagged event (rwhonet.evaluation.scenarios)

    def __post_init__(self) -> None:
        if self.scenario_outage_s < 1:
            raise ConfigError(
                f"evaluate.scenario_outage_s must be at least 1 s, got {self.scenario_outage_s}"
            )


@dataclass(frozen=True)
class TrackingParams:
    experiment: str
    tracking_uri: str

    def __post_init__(self) -> None:
        problem = tracking_uri_problem(self.tracking_uri)
        if problem:
            raise ConfigError(problem)
        if not self.experiment.strip():
            raise ConfigError("tracking.experiment: expected a name, got ''")


@dataclass(frozen=True)
class GateParams:
    baseline: str  # a file committed with the project
    rel_tol: float
    abs_tol_m: float

    def __post_init__(self) -> None:
        problem = inside_project_problem(self.baseline)
        if problem:
            raise ConfigError(f"gate.baseline={self.baseline!r}: {problem}")
        _require_at_least(0, "gate.rel_tol and gate.abs_tol_m", self.rel_tol, self.abs_tol_m)


@dataclass(frozen=True)
class Params:
    seeds: list[int]
    sim: SimParams
    data: DataParams
    validate: ValidateParams
    label: LabelParams
    model: ModelParams
    train: TrainParams
    adapt: AdaptParams
    evaluate: EvaluateParams
    tracking: TrackingParams
    gate: GateParams

    def __post_init__(self) -> None:
        if not self.seeds or len(set(self.seeds)) != len(self.seeds):
            raise ConfigError(f"seeds must be a non-empty list of distinct seeds, got {self.seeds}")
        if any(not 0 <= s < 2**32 for s in self.seeds):
            raise ConfigError(f"seeds must lie in [0, 2**32), got {self.seeds}")
        if self.adapt.chosen_m != AUTO and self.adapt.chosen_m not in self.adapt.m_grid:
            raise ConfigError(
                f"adapt.chosen_m={self.adapt.chosen_m} is not in adapt.m_grid={self.adapt.m_grid}"
            )
        if any(m <= 0 for m in self.adapt.m_grid):
            raise ConfigError(f"adapt.m_grid must hold positive seconds, got {self.adapt.m_grid}")
        if any(o <= 0 for o in self.evaluate.outages_s):
            raise ConfigError(f"evaluate.outages_s must be positive, got {self.evaluate.outages_s}")
        if not 0.0 <= self.train.val_fraction < 1.0:
            raise ConfigError(
                f"train.val_fraction must be in [0, 1), got {self.train.val_fraction}"
            )
        for role, spec in self.data.roles.items():
            if spec.format not in self.data.formats:
                raise ConfigError(
                    f"data.roles.{role}.format={spec.format!r}: expected one of "
                    f"{list(BUILTIN_FORMATS)}, a column map (data.column_maps "
                    f"{sorted(self.data.column_maps)}) or a signal map (data.signal_maps "
                    f"{sorted(self.data.signal_maps)})"
                )
            if spec.vehicle not in self.data.vehicles:
                raise ConfigError(
                    f"data.roles.{role}.vehicle={spec.vehicle!r} is not in data.vehicles "
                    f"{sorted(self.data.vehicles)}"
                )

    def nominal_radius_m(self, vehicle: str) -> float:
        """The nominal effective tyre radius the pipeline assumes for a vehicle.

        Simulated drives (``data.source == "sim"``) come from the car the
        selected profile maps ``vehicle`` to, so its spec-sheet radius
        (``sim.vehicles.<car>.nominal_radius_m``) applies; real drives use
        ``data.vehicles.<vehicle>.nominal_radius_m``.

        Args:
            vehicle: the pipeline's vehicle name (``source``, ``target``).

        Returns:
            The nominal radius, m.

        Raises:
            ConfigError: if the vehicle is unknown to the profile or to ``data.vehicles``.
        """
        return self._vehicle_spec(vehicle).nominal_radius_m

    def track_rear_m(self, vehicle: str) -> float:
        """The rear track width the pipeline assumes for a vehicle, m.

        As :meth:`nominal_radius_m`: the profile's car for simulated drives
        (``sim.vehicles.<car>.track_rear_m``), ``data.vehicles.<vehicle>.track_rear_m``
        for real ones.

        Raises:
            ConfigError: if the vehicle is unknown to the profile or to ``data.vehicles``.
        """
        return self._vehicle_spec(vehicle).track_rear_m

    def _vehicle_spec(self, vehicle: str) -> SimVehicle | VehicleSpec:
        """Where a vehicle's assumed numbers come from: for simulated drives
        (``data.source == "sim"``) the car the selected profile maps ``vehicle`` to
        (``sim.vehicles.<car>``), for real ones ``data.vehicles.<vehicle>``.

        Raises:
            ConfigError: if the vehicle is unknown to the profile or to ``data.vehicles``.
        """
        if self.data.source == "sim":
            mapping = self.sim.profiles[self.sim.profile].vehicles
            if vehicle not in mapping:
                raise ConfigError(
                    f"vehicle {vehicle!r} is not in sim.profiles.{self.sim.profile}.vehicles "
                    f"{sorted(mapping)}"
                )
            return self.sim.vehicles[mapping[vehicle]]
        if vehicle not in self.data.vehicles:
            raise ConfigError(
                f"vehicle {vehicle!r} is not in data.vehicles {sorted(self.data.vehicles)}"
            )
        return self.data.vehicles[vehicle]

    def section(self, name: str) -> dict[str, Any]:
        """Return one section as plain data (for MLflow params and saved configs)."""
        return _to_plain(getattr(self, name))

    def to_dict(self) -> dict[str, Any]:
        return _to_plain(self)


# --------------------------------------------------------------------------- loading


def load_params(
    path: Path | str | None = None,
    overrides: dict[str, Any] | None = None,
    *,
    only: list[str] | None = None,
    reader: str = "this code",
) -> Params:
    """Load and type-check ``params.yaml``.

    Args:
        path: the YAML file; defaults to the project's ``params.yaml`` (``rwhonet.paths``).
        overrides: dotted keys to replace after loading (``{"sim.profile": "ci"}``).
        only: dotted keys (``"adapt"``, ``"adapt.m_grid"``) the caller may read; any
            other read raises :class:`ConfigError` naming the key and ``reader``.
            None: everything. A DVC stage gets exactly its ``dvc.yaml`` params, so a
            value it reads without declaring it can never leave a stale output.
        reader: who reads, for that error (``"stage train"``).

    Returns:
        The typed parameters (the whole file is checked either way).

    Raises:
        ConfigError: on unknown, missing or mistyped keys.
    """
    if path is None:
        from rwhonet import paths

        path = paths.PARAMS
    with open(path, encoding="utf-8") as f:
        # libyaml's safe loader where PyYAML has it: the same documents, parsed in C (the
        # pure-Python loader was most of `rwhonet predict`'s start-up inside a project)
        raw = yaml.load(f, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)) or {}
    for dotted, value in (overrides or {}).items():
        node = raw
        *parents, leaf = dotted.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    params = _build(Params, raw, "")
    return params if only is None else Guarded(params, "", tuple(only), reader)  # type: ignore[return-value]


class Guarded:
    """A read-only view of a params section that lets through only the declared keys.

    Attribute reads of dataclass fields are checked against the declared dotted
    keys: a declared key (or a parent of it) gives the value itself, a section
    holding declared keys gives another view, anything else raises
    :class:`ConfigError`. Methods of the section run on the view, so they are
    checked the same way.
    """

    __slots__ = ("_obj", "_prefix", "_allowed", "_reader")

    def __init__(self, obj: Any, prefix: str, allowed: tuple[str, ...], reader: str) -> None:
        object.__setattr__(self, "_obj", obj)
        object.__setattr__(self, "_prefix", prefix)
        object.__setattr__(self, "_allowed", allowed)
        object.__setattr__(self, "_reader", reader)

    def __getattr__(self, name: str) -> Any:
        obj, prefix, allowed = self._obj, self._prefix, self._allowed
        if name not in {f.name for f in dataclasses.fields(obj)}:
            attr = getattr(type(obj), name)  # methods and properties see the guarded view
            return attr.__get__(self) if hasattr(attr, "__get__") else attr
        key = prefix + name
        if any(key == a or key.startswith(a + ".") for a in allowed):
            return getattr(obj, name)
        if any(a.startswith(key + ".") for a in allowed):
            return Guarded(getattr(obj, name), key + ".", allowed, self._reader)
        raise ConfigError(
            f"{self._reader} reads params '{key}' but does not declare it; declared: "
            f"{list(allowed)}. Add '{key}' (or its section) to the stage's params in dvc.yaml."
        )

    def __setattr__(self, name: str, value: Any) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        # A stage's jobs carry its view to their worker processes (rwhonet.stages.cores).
        return (Guarded, (self._obj, self._prefix, self._allowed, self._reader))

    def __repr__(self) -> str:
        return f"Guarded({type(self._obj).__name__}, allowed={list(self._allowed)})"


def parse_value(tp: Any, value: Any, where: str) -> Any:
    """Build a typed value (a params section's dataclass, a mapping of them) from plain data,
    with ``load_params``' checks: for files the command line reads (a vehicle, a signal map).

    Raises:
        ConfigError: unknown, missing or mistyped keys, named under ``where``.
    """
    return _build(tp, value, where)


def flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Flatten nested dicts to dotted keys (MLflow params)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _to_plain(obj: Any) -> Any:
    if isinstance(obj, Guarded):
        return {f.name: _to_plain(getattr(obj, f.name)) for f in dataclasses.fields(obj._obj)}
    if dataclasses.is_dataclass(obj):
        return {f.name: _to_plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {k: _to_plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_to_plain(v) for v in obj]
    return obj


# A number in exponent form as YAML 1.2 (and DVC, and a DBC) writes it, which PyYAML's
# YAML 1.1 resolver reads as a string (it wants a dot and a signed exponent: 1.0e-7).
_EXPONENT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+")


def _build(tp: Any, value: Any, where: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    label = where or "<root>"
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(f"{label}: expected a mapping, got {value!r}")
        hints = typing.get_type_hints(tp)
        fields = {f.name: f for f in dataclasses.fields(tp)}
        unknown = sorted(set(value) - set(fields))
        if unknown:
            raise ConfigError(
                f"{label}: unknown key(s) {unknown}; expected some of {sorted(fields)}"
            )
        kwargs = {}
        for name, f in fields.items():
            key = f"{where}.{name}" if where else name
            if name in value:
                kwargs[name] = _build(hints[name], value[name], key)
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                raise ConfigError(f"{key}: missing")
        return tp(**kwargs)
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"{label}: expected one of {list(args)}, got {value!r}")
        return value
    if origin in (types.UnionType, typing.Union):
        if value is None and type(None) in args:
            return None
        errors = []
        for inner in (a for a in args if a is not type(None)):
            try:
                return _build(inner, value, where)
            except ConfigError as e:
                errors.append(str(e).removeprefix(f"{label}: "))
        raise ConfigError(f"{label}: {' or '.join(errors)}")
    if origin is list:
        if not isinstance(value, list):
            raise ConfigError(f"{label}: expected a list, got {value!r}")
        return [_build(args[0], v, f"{where}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{label}: expected a mapping, got {value!r}")
        return {str(k): _build(args[1], v, f"{where}.{k}") for k, v in value.items()}
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{label}: expected true/false, got {value!r}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{label}: expected an integer, got {value!r}")
        return value
    if tp is float:
        if isinstance(value, str) and _EXPONENT.fullmatch(value.strip()):
            return float(value)  # YAML 1.2's 1e-7, a string to PyYAML (YAML 1.1)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{label}: expected a number, got {value!r}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{label}: expected a string, got {value!r}")
        return value
    if tp is Any:
        return value
    raise TypeError(f"config type {tp!r} at {label} is not supported")
