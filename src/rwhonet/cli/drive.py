"""One drive -> labelled samples, through the domain code the pipeline's stages call.

``rwhonet recalibrate`` reads a new car's drive exactly as the DVC stages read
the fleet's: the reader of its format (a 10 Hz CSV, a comma2k19 folder, an MDF4
file or a folder of stream CSVs, resampled onto the grid) with the size limit and
the scenario sidecar (:func:`rwhonet.data.drivefile.read_canonical`, as ``ingest``), the
schema and the per-drive checks (:func:`rwhonet.data.schema.schema_problems`,
:func:`rwhonet.data.drivechecks.check_drive`: GNSS quality, wheel sensors,
plausibility, as ``validate``), the per-second grid and samples of each valid
segment (:func:`rwhonet.features.seconds.segment_seconds`,
:func:`rwhonet.features.labels.sample_table`, as ``label``) with the base
model's scaler and source radii; the samples are stacked as the model stages
stack theirs (:func:`rwhonet.features.samples.stack_segments`). Bad input stops
with the same report (file, row, column, expected, found, what to do).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rwhonet import contracts, paths
from rwhonet.config import (
    ColumnSpec,
    ConfigError,
    Params,
    SignalMapSpec,
    VehicleSpec,
    parse_value,
)
from rwhonet.data.columnmap import check_column_map
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import Calibration
from rwhonet.features.scaling import MinMaxScaler

if TYPE_CHECKING:  # annotations only: `rwhonet predict` starts without pandas
    from rwhonet.data.quality import Assessment
    from rwhonet.features.samples import SampleSet

ROLE = "recalibration"  # not a pipeline role: validate's role-specific checks do not apply


@dataclass
class DriveSamples:
    """A drive's labelled samples and what validation kept.

    Attributes:
        samples: the samples, in time order (``frame["k"]``: rank of the second in the drive).
        file: the drive file as the user named it.
        assessment: validate's GNSS-quality assessment (segments, cuts).
        notes: what the resampler left out or changed of a stream drive (its fixes moved
            to the receiver's epochs, ...), said on stderr as ``predict`` says it; for a
            10 Hz file what its reader did (rows written twice and dropped, ...).
    """

    samples: SampleSet
    file: str
    assessment: Assessment
    notes: tuple[str, ...] = ()

    def kept_summary(self) -> str:
        """``"540 valid s of 560 s (cut: low_sats 20 s)"``."""
        a = self.assessment
        cut = ", ".join(f"{r} {n} s" for r, n in a.cut_seconds_by_rule.items() if n)
        return f"{a.seconds_kept} valid s of {a.n_seconds} s" + (f" (cut: {cut})" if cut else "")


# The car whose rear track a new car borrows when none is given (only 2D dead reckoning
# uses it; recalibrate and predict's displacements do not).
TRACK_FROM = "target"
PREDICT_CAR = "car"  # predict's name for the car of --nominal-radius / --vehicle-file
STREAM_READERS = ("mdf4", "stream_csv")  # --format names of the signal-map readers


def with_vehicle(
    params: Params,
    vehicle: str,
    nominal_radius_m: float,
    track_rear_m: float | None = None,
) -> Params:
    """``params`` that know ``vehicle``: as they are, or with it added to ``data.vehicles``.

    A vehicle the params do not name (a new car) is checked against ``nominal_radius_m``
    (``--nominal-radius``, or the base model's source calibration) as a real drive's
    vehicle; its rear track is ``track_rear_m``, else that of ``data.vehicles.target``.
    """
    try:
        params.nominal_radius_m(vehicle)
        return params
    except ConfigError:
        return set_vehicle(params, vehicle, nominal_radius_m, track_rear_m)


def set_vehicle(
    params: Params, vehicle: str, nominal_radius_m: float, track_rear_m: float | None = None
) -> Params:
    """``params`` with ``vehicle``'s nominal radius (and rear track) set, read as real drives.

    Raises:
        ConfigError: a radius or track that is not a positive number.
    """
    if track_rear_m is None:
        from rwhonet.data.drivechecks import DEFAULT_TRACK_M

        known = params.data.vehicles
        spec = known.get(vehicle) or known.get(TRACK_FROM) or next(iter(known.values()), None)
        track_rear_m = spec.track_rear_m if spec is not None else DEFAULT_TRACK_M
    for what, value in (("--nominal-radius", nominal_radius_m), ("--track-rear", track_rear_m)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ConfigError(f"{what}: expected a length in metres > 0, got {value!r}")
    data = dataclasses.replace(
        params.data,
        source="files",
        vehicles={
            **params.data.vehicles,
            vehicle: VehicleSpec(float(nominal_radius_m), float(track_rear_m)),
        },
    )
    return dataclasses.replace(params, data=data)


def read_yaml(path: str, what: str) -> Any:
    """A YAML file the command line was given (``--vehicle-file``, ``--signal-map``).

    Raises:
        InputError: the file is missing or not YAML.
    """
    import yaml

    try:
        text = Path(path).read_text(encoding="utf-8")
        return yaml.safe_load(text)
    except (OSError, UnicodeDecodeError) as err:
        found = f"{type(err).__name__}: {getattr(err, 'strerror', None) or err}"
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        said = text.splitlines()[line - 1] if line and line <= len(text.splitlines()) else ""
        # a ROS bag's channel with an index inside {...}: YAML reads [2] as a list
        fix = (
            'quote a channel with an index in {...}: {column: "/joint_states.velocity[2]", ...}'
            if "{" in said and "[" in said
            else None
        )
        raise InputError(
            [Problem(path, line, None, f"{what} in YAML", f"not YAML: {str(err)[:160]}", fix)]
        ) from None
    raise InputError([Problem(path, None, None, f"{what} in YAML", found)])


def vehicle_from_file(path: str) -> VehicleSpec:
    """A car from a YAML file: ``nominal_radius_m`` and ``track_rear_m`` (as data.vehicles).

    Raises:
        InputError: the file cannot be read; ConfigError: a key missing, unknown or mistyped.
    """
    raw = read_yaml(path, "a vehicle: nominal_radius_m and track_rear_m (m)")
    spec = parse_value(VehicleSpec, raw, f"--vehicle-file {path}")
    for key in ("nominal_radius_m", "track_rear_m"):
        value = getattr(spec, key)
        if not (math.isfinite(value) and value > 0):
            raise ConfigError(f"--vehicle-file {path}: {key}: expected > 0, got {value!r}")
    return spec


def with_car(
    params: Params,
    vehicle: str,
    nominal_radius_m: float | None = None,
    track_rear_m: float | None = None,
    vehicle_file: str | None = None,
) -> Params:
    """``params`` with the car the command line names (``--vehicle-file``, ``--nominal-radius``).

    Neither given: the params as they are (a vehicle they do not know then takes the base
    model's radius, :func:`with_vehicle`).

    Raises:
        ConfigError: both given, or a bad value; InputError: a vehicle file that cannot be read.
    """
    if vehicle_file is not None:
        if nominal_radius_m is not None or track_rear_m is not None:
            raise ConfigError(
                "--vehicle-file and --nominal-radius/--track-rear: give the car one way"
            )
        spec = vehicle_from_file(vehicle_file)
        return set_vehicle(params, vehicle, spec.nominal_radius_m, spec.track_rear_m)
    if nominal_radius_m is not None:
        return set_vehicle(params, vehicle, nominal_radius_m, track_rear_m)
    if track_rear_m is not None:
        raise ConfigError("--track-rear: give the car's --nominal-radius with it")
    return params


# a --signal-map file's keys where it has more than its signals: a signal map's own
# settings (SignalMapSpec), less the reader (--format names it) and the source (the file)
MAP_FILE_KEYS = tuple(
    f.name for f in dataclasses.fields(SignalMapSpec) if f.name not in ("reader", "source")
)


def with_format(params: Params, fmt: str, signal_map: str | None = None) -> Params:
    """``params`` that can read ``--format``: a known format, or a reader with a map file.

    ``--format mdf4`` or ``stream_csv`` with ``--signal-map FILE`` adds the file's map as
    that format (a YAML mapping key -> {column, unit}, optionally under ``signals:``).

    Raises:
        InputError: an unknown format, or a reader that needs a map without one;
            ConfigError: a map with unknown keys or units.
    """
    data = params.data
    if signal_map is None:
        if fmt in data.formats:
            return params
        need = (
            f"; --format {fmt} reads through a signal map: give it with --signal-map FILE"
            if fmt in STREAM_READERS
            else ""
        )
        raise InputError(
            [
                Problem(
                    "--format",
                    None,
                    None,
                    f"one of {', '.join(data.formats)}, or {' / '.join(STREAM_READERS)} with "
                    "--signal-map",
                    repr(fmt) + need,
                    "name the drive's format: iovnbd (IO-VNBD CSV), comma2k19 (an openpilot "
                    "segment or route folder), a column map or signal map of params.yaml, or "
                    "mdf4 / stream_csv with --signal-map",
                )
            ],
            "unknown --format",
        )
    if fmt not in STREAM_READERS:
        raise InputError(
            [
                Problem(
                    "--signal-map",
                    None,
                    None,
                    f"--format {' or '.join(STREAM_READERS)} with a signal map",
                    f"--format {fmt}",
                    "give --format mdf4 (an MDF4 file, a CAN log, a ROS bag) or stream_csv (a "
                    "folder of stream CSVs)",
                )
            ]
        )
    from rwhonet.data.signalmap import check_signal_map  # the stream readers: a map needs them

    raw = read_yaml(signal_map, "a signal map: key -> {column, unit}")
    dbc: list[str] | str | dict[str, list[str] | str] = []
    zone: str | None = None
    if isinstance(raw, dict) and "signals" in raw:
        # beside signals: the CAN databases of a log of raw frames (one, a list, or per
        # bus), relative to the map file; the loggers' time zone where a clock is local
        unknown = sorted(str(k) for k in raw if k not in MAP_FILE_KEYS)
        if unknown:  # a misspelt key (local_zon) would otherwise be dropped in silence
            raise ConfigError(
                f"--signal-map {signal_map}: unknown key(s) {', '.join(map(repr, unknown))} "
                f"beside signals; expected {', '.join(MAP_FILE_KEYS)}"
            )
        kind = list[str] | str | dict[str, list[str] | str]
        dbc = parse_value(kind, raw.get("dbc", []), f"--signal-map {signal_map} dbc")
        zone = parse_value(
            str | None, raw.get("local_zone"), f"--signal-map {signal_map} local_zone"
        )
        raw = raw["signals"]
    signals = parse_value(dict[str, ColumnSpec], raw, f"--signal-map {signal_map}")
    check_signal_map(fmt, signals, with_time=fmt == "stream_csv", where=signal_map)
    folder = Path(signal_map).parent

    def resolved(v: list[str] | str) -> list[str]:
        return [str((folder / f).resolve()) for f in ([v] if isinstance(v, str) else v)]

    files = {b: resolved(v) for b, v in dbc.items()} if isinstance(dbc, dict) else resolved(dbc)
    spec = SignalMapSpec(fmt, signals, source=signal_map, dbc=files, local_zone=zone)
    maps = {**data.signal_maps, fmt: spec}
    return dataclasses.replace(params, data=dataclasses.replace(data, signal_maps=maps))


def load_drive(
    path: Path,
    params: Params,
    *,
    vehicle: str,
    fmt: str,
    calibration: Calibration,
    scaler: MinMaxScaler,
    wpm_mode: str,
    seq_len: int,
    part: str | None = None,
) -> DriveSamples:
    """Read, validate and label one drive file.

    Args:
        path: the drive (an IO-VNBD or column-mapped CSV, a comma2k19 folder, an MDF4 file,
            a folder of stream CSVs).
        params: the project parameters (``data``, ``validate``).
        vehicle: the car (``data.vehicles``; an unknown name is checked against the
            calibration's radius).
        fmt: a format of ``params.data`` (:func:`with_format`).
        calibration: the WPM's source radii.
        scaler: the input scaler.
        wpm_mode: ``label.wpm_mode`` of the model.
        seq_len: the model's time steps.
        part: in a file of many drives, the drive (``--drive-id``; None: the file's one
            drive, :func:`resolved_part`).

    Returns:
        The samples of every GNSS-valid second.

    Raises:
        InputError: every problem of the file, as the ingest and validate stages report them.
    """
    from rwhonet.data.drivefile import with_label_times
    from rwhonet.data.quality import segment_name
    from rwhonet.features.labels import sample_table
    from rwhonet.features.samples import stack_segments
    from rwhonet.features.seconds import segment_arrays, segment_seconds

    path = Path(path)
    nominal = 0.5 * (calibration.r_rl_m + calibration.r_rr_m)
    params = with_vehicle(params, vehicle, nominal)
    part = resolved_part(path, params, fmt, part)
    checked = check_drive_file(path, params, vehicle, fmt, part)
    file, result = checked.file, checked.assessment
    segments = []
    table = with_label_times(checked.table, params.validate.sample_period_s)  # as validate
    drive = part or drive_id(path)
    for j, seg in enumerate(result.segments):
        name = segment_name(drive, j)
        sec = segment_seconds(segment_arrays(table.slice(seg.row_start, seg.n_rows)), name)
        samples = sample_table(sec, calibration, scaler, wpm_mode).to_pandas()
        segments.append(({"drive": drive, "segment": name, "role": ROLE}, samples))
    return DriveSamples(stack_segments(segments, seq_len), file, result, checked.notes)


@dataclass(frozen=True)
class CheckedDrive:
    """A drive read and checked as ingest and validate would (:func:`check_drive_file`).

    Attributes:
        file: the drive as messages name it.
        table: the canonical drive (a pyarrow table; a stream drive on its 10 Hz grid).
        assessment: validate's GNSS-quality assessment (segments, cuts).
        checks: validate's records of the drive's checks as ``validation.json`` has them:
            ``radius``, ``yaw_rate``, ``wheel_sides``, ``wheel_axles``.
        columns: canonical name -> the drive's own column or channel.
        notes: what the reader or resampler did (:class:`DriveSamples`' notes).
        reader_notes: everything the reader said (the ingest manifest's ``notes``: for a
            stream drive also where its fixes were placed and their lag estimated).
    """

    file: str
    table: Any
    assessment: Assessment
    checks: dict[str, Any]
    columns: dict[str, str]
    notes: tuple[str, ...]
    reader_notes: tuple[str, ...] = ()


def check_drive_file(
    path: Path,
    params: Params,
    vehicle: str,
    fmt: str,
    part: str | None = None,
    split: tuple[Path, str] | None = None,
) -> CheckedDrive:
    """Read one drive and run validate's checks on it (its schema, the GNSS policy, the
    wheel sensors, the tyre radius, the yaw rate, the wheels' columns); ``part``: in a file
    of many drives, the drive (None: the file's one drive), ``split`` its rows' own CSV
    where the file was split already (:func:`fleet_parts`).

    Raises:
        InputError: every problem of the drive, as the ingest and validate stages report
            them.
    """
    from rwhonet.data.drivechecks import check_drive
    from rwhonet.data.droprows import FileRows, manifest_rows
    from rwhonet.data.fleetfile import shown
    from rwhonet.data.schema import schema_problems

    path = Path(path)
    part = resolved_part(path, params, fmt, part)
    file = paths.rel(path) if part is None else shown(paths.rel(path), part)
    drive = read_drive_file(path, params, vehicle, fmt, part=part, split=split)
    raw, table = drive.raw, drive.table()
    df = table.to_pandas(split_blocks=True)
    entry: dict[str, Any] = {
        "drive": part or drive_id(path),
        "role": ROLE,
        "vehicle": vehicle,
        "source_file": file,
        "columns": raw.source_columns,
    }
    if drive.streams is not None:  # the grid rows whose mean used a glitched sample
        entry["streams"] = drive.streams.to_dict()
    # rows written twice or without a wheel speed, dropped: messages name the file's rows
    entry.update(manifest_rows(raw))
    cuts = [cut for cut in params.validate.cuts if cut.drive == (part or drive_id(path))]
    rows = FileRows.of(entry)
    found = schema_problems(df, params.validate, file, raw.source_columns, rows)
    problems, result, checks, _ = check_drive(params, entry, df, found, cuts)
    if problems:
        raise InputError(problems, f"{file}: {len(problems)} problem(s) (validate)")
    assert result is not None and checks is not None  # no problem: the GNSS policy ran
    # a stream drive: what the resampler lost; a 10 Hz file: what its reader did (rows
    # written twice and dropped, the clock passing midnight, columns taken by position)
    notes = tuple(drive.streams.lost) if drive.streams is not None else tuple(raw.notes)
    columns = dict(raw.source_columns)
    return CheckedDrive(file, table, result, checks, columns, notes, tuple(raw.notes))


def drive_sha256(path: Path) -> str:
    """The SHA-256 of a drive: a file's bytes, or a folder drive's files (each relative path
    and its own digest, sorted by path), hex."""
    import hashlib

    from rwhonet.serve.bundle import file_digests, sha256_file

    path = Path(path)
    if not path.is_dir():
        return sha256_file(path)
    listing = "".join(f"{name}\t{digest}\n" for name, digest in file_digests(path).items())
    return hashlib.sha256(listing.encode("utf-8")).hexdigest()


def drive_id(path: Path) -> str:
    """A drive's id: a file's stem (a compressed file's without its compression's suffix:
    :func:`rwhonet.data.compressed.drive_stem`), a folder's name (a table's without its
    suffix: :func:`rwhonet.data.columnar.folder_id`)."""
    from rwhonet.data.columnar import folder_id
    from rwhonet.data.compressed import drive_stem

    return folder_id(path) if path.is_dir() else drive_stem(path)


def fleet_parts(path: Path, params: Params, fmt: str, dest: Path | None = None) -> list | None:
    """The drives of a file of many (its format's column map names each row's drive:
    :mod:`rwhonet.data.fleetfile`), each a :class:`~rwhonet.data.drivefile.DriveFile`, in
    the order they first appear; with ``dest`` each one's rows split into a CSV there (its
    ``split``: the file read once for them all). None: the format reads a file as one drive.

    Raises:
        InputError: the file cannot be split into its drives.
    """
    from rwhonet.data.drivefile import DriveFile, fleet_column, fleet_drives

    if fleet_column(fmt, params.data) is None:
        return None
    f = DriveFile(drive_id(path), ROLE, "", fmt, Path(path))
    return fleet_drives(f, params.data, paths.rel, dest)


def fleet_ids(path: Path, params: Params, fmt: str) -> list[str] | None:
    """The ids of :func:`fleet_parts` (the file listed, nothing written)."""
    parts = fleet_parts(path, params, fmt)
    return None if parts is None else [d.drive for d in parts]


def resolved_part(path: Path, params: Params, fmt: str, part: str | None) -> str | None:
    """The drive to read of a file of many: ``part`` (``--drive-id``), else the file's only
    one; None for a file of one drive.

    Raises:
        InputError: a file of several drives and no ``part``, naming them.
    """
    if part is not None or not Path(path).exists():  # no such drive: its reader says so
        return part
    ids = fleet_ids(path, params, fmt)
    if ids is None or len(ids) == 1:
        return None if ids is None else ids[0]
    shown_ids = ", ".join(ids[:10]) + (f" and {len(ids) - 10} more" if len(ids) > 10 else "")
    raise InputError(
        [
            Problem(
                paths.rel(Path(path)),
                None,
                None,
                f"one drive, or --drive-id naming the one to read (the format {fmt!r} reads "
                "each row's drive from its column)",
                f"{len(ids)} drives: {shown_ids}",
                "give --drive-id",
            )
        ]
    )


def read_drive_file(
    path: Path,
    params: Params,
    vehicle: str,
    fmt: str,
    require_fix: bool = True,
    part: str | None = None,
    split: tuple[Path, str] | None = None,
) -> Any:
    """Read a drive the command line names, as ingest reads it (:func:`read_canonical`).

    Stream formats are resampled onto ``validate.sample_period_s`` with the vehicle's
    nominal radius (linear wheel speeds, the glitch screen); ``require_fix`` False keeps
    the grid rows without a fix (``predict``), their position NaN. ``part``: in a file of
    many drives, the drive (:func:`resolved_part`), ``split`` its rows' own CSV where the
    file was split already.

    Raises:
        InputError: no such drive, or its reader's problems.
    """
    from rwhonet.data.drivefile import DriveFile, read_canonical, reader_kind

    path = Path(path)
    file = paths.rel(path)
    kind = reader_kind(fmt, params.data)
    if not path.exists():
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"a drive {'folder' if kind in ('comma2k19', 'stream_csv') else 'file'} "
                    f"({fmt}: {_FORM.get(kind, 'a CSV file')})",
                    "no such file or folder",
                    "give the path of the car's drive (--drive) and its --format",
                )
            ],
        )
    if kind == "column_map":
        check_column_map(fmt, params.data.column_maps[fmt])
    try:
        radius = params.nominal_radius_m(vehicle)
    except ConfigError:
        radius = None
    spec = params.data.signal_maps.get(fmt)
    part = resolved_part(path, params, fmt, part)
    f = DriveFile(
        part or drive_id(path), ROLE, vehicle, fmt, path, spec.source if spec else None, part, split
    )
    vp = params.validate
    return read_canonical(
        f, params.data, paths.rel, radius, vp.sample_period_s, vp.gnss.max_gap_s, require_fix
    )


_FORM = {
    "iovnbd": "an IO-VNBD CSV file",
    "column_map": "a CSV file",
    "comma2k19": "a segment folder, or a route folder of segments",
    "mdf4": "an MDF4 file, a CAN log, a ROS 1 bag or a ROS 2 bag's folder",
    "stream_csv": "a folder of stream CSVs",
}


@dataclass(frozen=True)
class DriveBlocks:
    """A drive read whole, to be streamed: what :func:`canonical_blocks` returns.

    Attributes:
        names: canonical name -> the source's channel.
        blocks: ``(first_row, columns)`` blocks (1-based rows of the drive or its grid).
        glitch_samples: the glitched samples the resampler found (``(stream, 1-based
            sample row, t_s, channel)``; empty for a 10 Hz drive).
        notes: what the resampler left out or changed, for stderr (empty for a 10 Hz drive).
    """

    names: dict[str, str]
    blocks: Iterator[tuple[int, dict[str, np.ndarray]]]
    glitch_samples: list[tuple[str, int, float, str]]
    notes: tuple[str, ...] = ()


def canonical_blocks(
    path: Path, params: Params, vehicle: str, fmt: str, rows: int = 600, part: str | None = None
) -> DriveBlocks:
    """A drive read whole (a stream format: resampled), handed on in blocks of grid rows.

    What ``rwhonet predict`` streams for a format that cannot be read as it arrives
    (a folder, an MDF4 file): the canonical channels of :func:`read_drive_file` (grid rows
    without a fix kept, their position NaN, as a 10 Hz file's empty fix cells), with the
    time placed as ``predict`` places a CSV's (:class:`rwhonet.data.timebase.StreamClock`),
    and for a resampled drive the resampler's glitch flags: per wheel, the grid rows whose
    mean used a glitched sample (:data:`rwhonet.data.canonical.GLITCH_FLAG` + the wheel's
    canonical name, booleans), for ``predict`` to repair as it repairs a 10 Hz glitch.

    Returns:
        The channels' names, blocks of ``rows`` rows, the glitched samples and what the
        resampler left out (:class:`DriveBlocks`).
    """
    from rwhonet.data import canonical as c
    from rwhonet.data.canonical import GLITCH_FLAG
    from rwhonet.data.incremental import carried_channels, placed
    from rwhonet.data.timebase import StreamClock

    drive = read_drive_file(path, params, vehicle, fmt, require_fix=False, part=part)
    raw, facts = drive.raw, drive.streams
    carried = carried_channels(raw.columns)  # as a 10 Hz file's: the yaw rate where it has one
    columns = {name: raw.columns[name] for name in carried}
    n = columns[c.T_S].size
    samples = []
    if facts is not None and facts.glitch_samples:
        columns |= {GLITCH_FLAG + w: rows for w, rows in facts.glitch_wheels.items()}
        samples = list(facts.glitch_samples)

    def blocks() -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        for a in range(0, n, rows):
            yield a + 1, {k: v[a : a + rows] for k, v in columns.items()}

    clock = StreamClock(params.validate.sample_period_s)
    names = {name: raw.source_columns.get(name, name) for name in carried}
    # a drive of a file of many: what its reader said (where its rows lay in the file)
    lost = facts.lost if facts is not None else tuple(raw.notes) if part is not None else ()
    return DriveBlocks(names, placed(blocks(), clock), samples, lost)


def calibration_of(radii: tuple[float, float], source: str) -> Calibration:
    """A :class:`Calibration` holding the source radii a served model carries."""
    return Calibration(
        r_rl_m=radii[0],
        r_rr_m=radii[1],
        estimator="ratio_of_sums",
        min_speed_m_s=0.0,
        n_seconds_used=0,
        n_seconds_total=0,
        distance_m=0.0,
        role=contracts.SOURCE_CALIBRATION,
        drives=[],
        segments=[],
        comparison={"note": f"the source radii of {source}"},
    )
