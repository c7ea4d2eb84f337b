"""One drive: the reader its format names, the size it may have, its canonical table.

The ``ingest`` stage reads every drive of the fleet with these, and
``rwhonet recalibrate`` / ``rwhonet predict`` a new car's drive (``cli/drive.py``),
so all of them refuse and convert a drive alike. Formats (``data.roles.<role>.format``):

- ``iovnbd`` and a column map's name (``data.column_maps``): one 10 Hz CSV file per
  drive, rows kept exactly as in the file, in order (row ``i`` is data row ``i + 1``
  of the source file), so ``validate`` can point at the file's rows; the file may be
  compressed (gzip, bzip2, xz, zstd, or zipped alone: :mod:`rwhonet.data.compressed`), and
  a table logged faster than the grid is resampled onto it (:mod:`rwhonet.data.fastfile`);
- ``comma2k19``: one folder per drive (a comma2k19 / openpilot segment, or a route of them);
- a signal map's name (``data.signal_maps``): one MDF4 file per drive (reader
  ``mdf4``) or one folder of stream CSVs per drive (reader ``stream_csv``).

A stream drive is resampled onto the grid (:func:`rwhonet.data.streams.resample`,
``validate.sample_period_s`` and ``validate.gnss.max_gap_s``): row ``i`` of its
canonical table is row ``i`` of that grid, and what the resampler found (the
streams, the rows whose wheel-speed mean used a glitched sample) travels with it
(:class:`StreamFacts`). Messages name a file as the caller's ``rel`` shows it (the
stage: relative to the project root).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from rwhonet.config import DataParams
from rwhonet.data import canonical as c
from rwhonet.data.canlog import is_can_log_name
from rwhonet.data.columnar import csv_copy, is_table_folder, is_table_name, table_kind
from rwhonet.data.columnmap import DRIVE, DRIVE_UNIT, read_columnmap
from rwhonet.data.compressed import (
    compressed_note,
    compression_of,
    decompressed_copy,
    drive_stem,
    is_csv_name,
    without_rotation,
    without_suffix,
)
from rwhonet.data.csvio import RawDrive
from rwhonet.data.droprows import drop_rows
from rwhonet.data.fastfile import as_streams, needs_resampling
from rwhonet.data.fleetfile import FleetPart, FleetSplit, shown, split_fleet
from rwhonet.data.heldfixes import place_held_fixes
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.problems import unreadable_file
from rwhonet.data.rosbag import is_rosbag2_folder, is_rosbag_name
from rwhonet.data.sampleorder import coarse_stamps_placed, rows_in_time_order
from rwhonet.data.scenarios import ScenarioInterval, read_scenarios, scenario_codes, sidecar_path
from rwhonet.data.streams import DriveStreams
from rwhonet.data.timebase import drive_label_times
from rwhonet.data.vbo import (
    file_is_vbo,
    plain_count_problems,
    vbo_as_csv,
    vbo_needs_a_map,
    vbo_note,
)
from rwhonet.errors import InputError, Problem
from rwhonet.io import scratch_dir

IOVNBD = "iovnbd"
COMMA2K19 = "comma2k19"
SPLIT_DRIVE = "split the drive into several files (one per trip)"
# Reader kinds (reader_kind): the two 10 Hz readers and the three stream readers.
COLUMN_MAP, MDF4, STREAM_CSV = "column_map", "mdf4", "stream_csv"
FOLDER_READERS = (COMMA2K19, STREAM_CSV)  # a drive is a folder, not a file
GLITCHES_LISTED = 50  # glitched samples the manifest lists one by one (all are counted)


def reader_kind(fmt: str, data: DataParams) -> str:
    """Which reader a format names: ``iovnbd``, ``column_map``, ``comma2k19``, ``mdf4``,
    ``stream_csv``.

    Raises:
        InputError: a format that names none (a built-in reader or a map of ``data``).
    """
    if fmt in (IOVNBD, COMMA2K19):
        return fmt
    if fmt in data.column_maps:
        return COLUMN_MAP
    if fmt in data.signal_maps:
        return data.signal_maps[fmt].reader
    raise InputError(
        [
            Problem(
                "--format",
                None,
                None,
                f"one of {', '.join(data.formats)} (the built-in readers, data.column_maps, "
                "data.signal_maps)",
                repr(fmt),
                "name the drive's format (for MDF4 files and stream CSVs, give the signal "
                "map: --signal-map, or data.signal_maps in params.yaml)",
            )
        ]
    )


def is_folder_format(fmt: str, data: DataParams) -> bool:
    """Whether a drive of this format is a folder (comma2k19, stream CSVs), not one file."""
    return reader_kind(fmt, data) in FOLDER_READERS


@dataclass(frozen=True)
class StreamFacts:
    """What resampling a stream drive found, for the manifest and validate.

    Attributes:
        clock: what the streams' time stamps are.
        n_input_rows: samples read over all streams.
        streams: per stream its name, file, samples and median step.
        glitch_rows: 0-based grid rows whose wheel-speed mean used a glitched sample.
        glitch_samples: the glitched samples, ``(stream, 1-based sample row, t_s, channel)``,
            the channel as the stream names it.
        glitch_wheels: per wheel (canonical name), the grid rows whose mean of that wheel
            used a glitched sample (:attr:`rwhonet.data.streams.Resampled.glitch_wheels`).
        lost: what the grid left out or changed, said on ``predict``'s stderr
            (:attr:`rwhonet.data.streams.Resampled.lost`; among the drive's notes too).
    """

    clock: str
    n_input_rows: int
    streams: list[dict[str, Any]]
    glitch_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    glitch_samples: list[tuple[str, int, float, str]] = field(default_factory=list)
    glitch_wheels: dict[str, np.ndarray] = field(default_factory=dict)
    lost: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The manifest's ``streams`` record (rows 0-based on the grid; samples 1-based)."""
        return {
            "clock": self.clock,
            "n_input_rows": self.n_input_rows,
            "streams": self.streams,
            "glitch_rows": [int(r) for r in self.glitch_rows],
            "n_glitch_samples": len(self.glitch_samples),
            "glitch_samples": [
                {"stream": s, "row": r, "t_s": t, "channel": w}
                for s, r, t, w in self.glitch_samples[:GLITCHES_LISTED]
            ],
        }


@dataclass(frozen=True)
class DriveFile:
    """One raw drive (a file, or a folder for comma2k19 and stream CSVs) and what params say
    about it."""

    drive: str  # drive id = file stem (a folder drive: the folder's name)
    role: str
    vehicle: str
    format: str  # "iovnbd", "comma2k19", a column map's or a signal map's name
    path: Path
    map_name: str | None = None  # how messages name its signal map (None: its params key)
    # a drive of a file of many drives (rwhonet.data.fleetfile): its id in the map's drive
    # column; and where ingest split the file already, its rows' own CSV and where they lay
    part: str | None = None
    split: tuple[Path, str] | None = None


def fleet_column(fmt: str, data: DataParams) -> str | None:
    """The column naming each row's drive where a format's column map has one (a file of
    many drives: :mod:`rwhonet.data.fleetfile`); None: a file is one drive."""
    spec = data.column_maps.get(fmt)
    return None if spec is None or DRIVE not in spec else spec[DRIVE].column


def source_name(f: DriveFile, rel: Callable[[Path], str]) -> str:
    """How messages name a drive's file: ``fleet.csv (drive C-B1)`` for a drive of a file
    of many, whose rows they count from its first."""
    return rel(f.path) if f.part is None else shown(rel(f.path), f.part)


def fleet_drives(
    f: DriveFile,
    data: DataParams,
    rel: Callable[[Path], str],
    dest: Path | None = None,
    keep: Callable[[str], bool] | None = None,
) -> list[DriveFile]:
    """The drives of a file of many (:func:`rwhonet.data.fleetfile.split_fleet`), in the
    order they first appear, each named by its id; with ``dest``, each one's rows written to
    a CSV of its own there, which :func:`read_any` then reads (with ``keep``, only the
    drives it keeps: a role's ``drives``).

    Raises:
        InputError: the file cannot be split (no such column, a row without an id).
    """
    column = fleet_column(f.format, data)
    assert column is not None, f.format
    file = rel(f.path)
    if reader_kind(f.format, data) == COLUMN_MAP and file_is_vbo(f.path):
        raise InputError([_vbo_not_fleet(file, f.format)])
    split = split_fleet(f.path, column, file, f"data.column_maps.{f.format}.{DRIVE}", dest, keep)
    return [
        dataclasses.replace(
            f,
            drive=p.drive,
            part=p.drive,
            split=None if p.csv is None else (p.csv, _part_note(p, split, file)),
        )
        for p in split.parts
    ]


def _part_note(part: FleetPart, split: FleetSplit, file: str) -> str:
    said = part.note(file, split.column, split.rows)
    if split.header_again:
        said += (
            f"; the header's line (or its units row) again in {split.header_again} of the "
            "file's rows, left out"
        )
    if split.cut_last is not None:
        said += (
            f"; the file's last row ({split.cut_last:,}) cut short before its drive's cell "
            "(a logger that lost power), left out: its sample lost"
        )
    return said


def _vbo_not_fleet(file: str, fmt: str) -> Problem:
    return Problem(
        file,
        None,
        None,
        f"a CSV or table of many drives (data.column_maps.{fmt}.{DRIVE})",
        "a Racelogic VBOX file, which holds one drive",
        f"leave the {DRIVE} key out of the map for VBOX files",
    )


def read_any(
    f: DriveFile,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool = True,
) -> tuple[RawDrive, StreamFacts | None]:
    """Read one drive with the reader its format names, if it is not too large.

    The reading part of :func:`read_canonical`, which gives the defaults.

    The readers stream a file, but the drive is then held in memory (by ingest and
    validate), so a drive above ``data.max_file_mb`` (a folder: its files together) is
    refused before it is read, and running out of memory while reading is reported as a
    problem of that drive. A raw CAN log is not counted there: it is read a part at a
    time, and what it may hold is its frames of the map's messages, bounded as they are
    kept (:func:`rwhonet.data.mdf4.can_log_groups`). A stream drive is resampled onto the
    grid.

    Args:
        f: the drive (a file, or a folder for comma2k19 and stream CSVs).
        data: the ``data`` section (for the maps and the size limit).
        rel: how messages name a file.
        radius_m: the car's nominal tyre radius: wheel speeds logged as the wheels'
            circumferential speeds (m/s, km/h, mph; any reader with a map) are divided by
            it; stream drives' sample-level glitch screen uses it too.
        period_s: the grid period (``validate.sample_period_s``).
        split_gap_s: holes in the grid are made longer than this (``validate.gnss.max_gap_s``).
        require_fix: a stream drive's grid rows need a fix (the pipeline); False keeps rows
            without one, their position NaN (``rwhonet predict``; :func:`resample`).

    Returns:
        The drive's channels, canonical names, SI units; and for a stream drive what the
        resampler found (None for a 10 Hz file).

    Raises:
        InputError: the drive is missing, too large, runs out of memory, or its reader
            (or the resampler) refuses it.
    """
    file = rel(f.path)
    kind = reader_kind(f.format, data)
    wrong = _wrong_kind(f, kind, file)
    if wrong is not None:
        raise InputError([wrong])
    if f.part is not None:  # a drive of a file of many: its rows alone, as a file of its own
        return _read_part(f, data, rel, radius_m, period_s, split_gap_s, require_fix)
    try:
        size_mb = (
            _size_bytes(
                f.path,
                kind in FOLDER_READERS or f.path.is_dir(),  # a ROS 2 bag's folder
                kind in (MDF4, STREAM_CSV),
                _bus_logs(f, data),
            )
            / 2**20
        )
    except OSError as err:  # gone since it was listed, or unreadable
        raise InputError([unreadable_file(file, err)]) from None
    if size_mb > data.max_file_mb:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"a drive file of at most {data.max_file_mb:g} MB (data.max_file_mb)",
                    _mb(size_mb),
                    f"{SPLIT_DRIVE}, or raise data.max_file_mb on a machine with the memory "
                    "(validate holds about 3x the file's size)",
                )
            ]
        )
    try:
        if kind in (IOVNBD, COLUMN_MAP, MDF4) and (packed := compression_of(f.path)) is not None:
            return _read_decompressed(
                f, packed, data, rel, radius_m, period_s, split_gap_s, require_fix
            )
        if kind in (IOVNBD, COLUMN_MAP) and (table := table_kind(f.path)) is not None:
            return _read_table(f, table, data, rel, radius_m, period_s, split_gap_s, require_fix)
        # a row written twice or without a wheel speed is dropped (rwhonet.data.droprows),
        # rows out of time order put in order where that is safe (.sampleorder), fixes held
        # from a slower receiver are placed along the path (.heldfixes); the drive says which
        if kind in (IOVNBD, COLUMN_MAP) and file_is_vbo(f.path):
            if kind == IOVNBD:
                raise InputError([vbo_needs_a_map(file, f.format)])
            raw = _read_vbo(f.path, data.column_maps[f.format], f.format, file, radius_m)
        elif kind == IOVNBD:
            raw = read_iovnbd(f.path, file)
        elif kind == COLUMN_MAP:
            raw = read_columnmap(f.path, data.column_maps[f.format], f.format, file, radius_m)
        else:
            return _read_streams(f, kind, data, rel, radius_m, period_s, split_gap_s, require_fix)
        raw = coarse_stamps_placed(raw, file, period_s)  # hh:mm:ss without its fraction
        raw = rows_in_time_order(drop_rows(raw, file), file, period_s)
        # a 20-100 Hz table, or one at a rate of the logger's own (9.98 Hz)
        if needs_resampling(raw.columns[c.T_S], period_s):
            return _resampled(
                as_streams(raw, file, period_s), data, radius_m, period_s, split_gap_s, require_fix
            )
        return place_held_fixes(raw, period_s), None
    except MemoryError:
        raise out_of_memory(f, rel) from None


def _read_part(
    f: DriveFile,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool,
) -> tuple[RawDrive, StreamFacts | None]:
    """A drive of a file of many (:mod:`rwhonet.data.fleetfile`): its rows' own CSV (split
    by ingest, else here) read as the file, messages naming ``fleet.csv (drive C-B1)`` and
    counting its rows from its first."""
    file = rel(f.path)
    assert f.part is not None
    with scratch_dir("fleet") as scratch:
        if f.split is not None:
            plain, said = f.split
        else:
            column = fleet_column(f.format, data)
            if column is None:
                raise InputError([_not_a_fleet_map(file, f.format, f.part)])
            if file_is_vbo(f.path):
                raise InputError([_vbo_not_fleet(file, f.format)])
            setting = f"data.column_maps.{f.format}.{DRIVE}"
            wanted = f.part
            split = split_fleet(
                f.path, column, file, setting, Path(scratch), keep=lambda d: d == wanted
            )
            part = split.part(f.part)
            if part is None or part.csv is None:
                raise InputError([_no_such_drive(file, f.part, split)])
            plain, said = part.csv, _part_note(part, split, file)
        whole = dataclasses.replace(f, part=None, split=None)
        raw, facts = _read_as(
            whole,
            plain,
            data,
            rel,
            radius_m,
            period_s,
            split_gap_s,
            require_fix,
            shown(file, f.part),
        )
    return dataclasses.replace(raw, notes=(said, *raw.notes)), facts


def _not_a_fleet_map(file: str, fmt: str, drive: str) -> Problem:
    return Problem(
        file,
        None,
        None,
        f"a format whose column map names each row's drive ({DRIVE}: {{column: ..., unit: "
        f"{DRIVE_UNIT}}}), to read drive {drive!r} of the file",
        f"format {fmt!r}, which reads the file as one drive",
        "give a column map with a drive key (--format), or leave out --drive-id",
    )


def _no_such_drive(file: str, drive: str, split: FleetSplit) -> Problem:
    ids = [p.drive for p in split.parts]
    shown_ids = ", ".join(ids[:10]) + (f" and {len(ids) - 10} more" if len(ids) > 10 else "")
    return Problem(
        file,
        None,
        split.column,
        f"drive {drive!r} among the ids of its column {split.column!r}",
        f"the drives {shown_ids}" if ids else "no row",
        "give one of the file's drives (--drive-id)",
    )


def _read_decompressed(
    f: DriveFile,
    packed: str,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool,
) -> tuple[RawDrive, StreamFacts | None]:
    """A compressed drive file (:mod:`rwhonet.data.compressed`: a 10 Hz CSV, an MDF4 log, a
    bus tool's CAN log): what it holds written to a scratch file (at most
    ``data.max_file_mb``) and read as the file, messages naming it."""
    file = rel(f.path)
    with scratch_dir("unpacked") as scratch:
        inner = ".mf4" if reader_kind(f.format, data) == MDF4 else ".csv"
        if inner == ".mf4" and (
            is_can_log_name(f.path.name) or is_rosbag_name(f.path.name)
        ):  # bus.log.gz, drive.bag.gz: read as a .log, a .bag
            inner = Path(without_suffix(f.path.name)).suffix.lower()
        plain = Path(scratch) / f"{drive_stem(f.path)}{inner}"
        parts = _read_in_parts(f.path.name, f.path, _bus_logs(f, data))
        bound = None if parts else data.max_file_mb
        decompressed_copy(f.path, packed, plain, bound, file)
        raw, facts = _read_as(f, plain, data, rel, radius_m, period_s, split_gap_s, require_fix)
    what = {
        ".csv": "the text",
        ".mf4": "the MDF4 log",
        ".bag": "the ROS bag",
        ".mcap": "the ROS bag",
        ".db3": "the ROS bag",
    }.get(inner, "the CAN log")
    said = compressed_note(packed, what)
    return dataclasses.replace(raw, notes=(said, *raw.notes)), facts


def _read_table(
    f: DriveFile,
    table: str,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool,
) -> tuple[RawDrive, StreamFacts | None]:
    """A 10 Hz drive kept as a table file (:mod:`rwhonet.data.columnar`: Parquet, Feather):
    its rows written to a scratch CSV (at most ``data.max_file_mb``) and read as the file,
    messages naming it."""
    file = rel(f.path)
    with scratch_dir("table") as scratch:
        plain = Path(scratch) / f"{drive_stem(f.path)}.csv"
        held = csv_copy(f.path, table, plain, data.max_file_mb, file)
        raw, facts = _read_as(f, plain, data, rel, radius_m, period_s, split_gap_s, require_fix)
    return dataclasses.replace(raw, notes=(held.note, *raw.notes)), facts


def _read_as(
    f: DriveFile,
    plain: Path,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool,
    name: str | None = None,
) -> tuple[RawDrive, StreamFacts | None]:
    """The drive ``f`` read from ``plain``, its scratch copy in a form the readers read (a
    compressed file's content, a table's CSV, a drive's rows of a file of many), messages
    naming ``f``'s file (or ``name``)."""
    file = rel(f.path) if name is None else name

    def shown(path: Path) -> str:
        return file if path == plain else rel(path)

    return read_any(
        dataclasses.replace(f, path=plain),
        data,
        shown,
        radius_m,
        period_s,
        split_gap_s,
        require_fix,
    )


def _read_vbo(
    path: Path, column_map: Mapping, fmt: str, file: str, radius_m: float | None
) -> RawDrive:
    """A VBOX file through its column map: its CSV written to a scratch file and read."""
    with scratch_dir("vbo") as scratch:
        csv = Path(scratch) / "drive.csv"
        vbo_as_csv(path, csv, file)
        raw = read_columnmap(csv, column_map, fmt, file, radius_m)
    sats = column_map.get("n_sats")
    if sats is not None and sats.unit == "count":  # a VBOX's flags would pass any fix
        setting = f"data.column_maps.{fmt}.n_sats.unit"
        column = raw.source_columns[c.N_SATS]
        if problems := plain_count_problems(raw.columns[c.N_SATS], file, column, setting):
            raise InputError(problems, summary=f"VBOX flags in the satellite count of {file}")
    return dataclasses.replace(raw, notes=(vbo_note(), *raw.notes))


def _size_bytes(
    path: Path, folder: bool, can_logs_apart: bool = False, bus_logs: bool = False
) -> int:
    """A drive file's size, or a folder drive's files together (OSError: not there);
    with ``can_logs_apart``, raw CAN logs' files (``bus.log``, ``can0.log.1.gz``; with
    ``bus_logs``, MDF4 files too) not counted: their frames are bounded as they are kept.
    A NovAtel receiver's ``.log`` or ``.asc``, read whole, is."""
    files = [p for p in path.rglob("*") if p.is_file()] if folder else [path]
    return sum(
        p.stat().st_size
        for p in files
        if not (can_logs_apart and _read_in_parts(without_rotation(p.name), p, bus_logs))
    )


def _read_in_parts(name: str, path: Path, bus_logs: bool = False) -> bool:
    """Whether a drive's file, read by ``name``, is a raw CAN log: read a part at a time,
    bounded by the frames it keeps, not by its size (a NovAtel receiver's ``.log`` or
    ``.asc`` is read whole). With ``bus_logs`` (its signal map has a ``dbc``, which only
    an MDF4 file of raw CAN frames takes), an MDF4 file is: a bus log
    (:mod:`rwhonet.data.mdfframes`)."""
    from rwhonet.data.mdf4 import is_mdf_name
    from rwhonet.data.streamcsv import log_kind

    if bus_logs and is_mdf_name(name):
        return True
    return is_can_log_name(name) and log_kind(name, path) is None


def _bus_logs(f: DriveFile, data: DataParams) -> bool:
    """Whether the drive's signal map decodes raw CAN frames (has a ``dbc``)."""
    spec = data.signal_maps.get(f.format)
    return spec is not None and bool(spec.dbc_files)


def _wrong_kind(f: DriveFile, kind: str, file: str) -> Problem | None:
    """A folder given where the format reads a file, or the other way round."""
    folder = kind in FOLDER_READERS
    if not f.path.exists() or f.path.is_dir() == folder:
        return None
    if kind == MDF4 and is_rosbag2_folder(f.path):  # a ROS 2 bag: one folder a drive
        return None
    if kind in (IOVNBD, COLUMN_MAP) and is_table_folder(f.path):  # Spark's part files
        return None
    what = {
        COMMA2K19: "a comma2k19 segment folder (holding processed_log, or CAN and GNSS), or a "
        "route folder of numbered segment folders",
        STREAM_CSV: "a folder holding the drive's stream CSV files",
        MDF4: "an MDF4 file (.mf4), a CAN log (.log, .asc, .blf, .trc), a ROS 1 bag (.bag) "
        "or a ROS 2 bag's folder (holding metadata.yaml)",
    }.get(kind, "a drive file (CSV, or a Parquet or Feather table; a folder of Parquet part files)")
    return Problem(
        file,
        None,
        None,
        f"{what} (format {f.format!r})",
        "a folder" if f.path.is_dir() else "a file",
        "give the drive in the format's form, or name its format (the role's format, --format)",
    )


def _map_name(f: DriveFile) -> str:
    """How messages name a drive's signal map: its params key, or the file it came from."""
    return f.map_name or f"data.signal_maps.{f.format}.signals"


def _read_streams(
    f: DriveFile,
    kind: str,
    data: DataParams,
    rel: Callable[[Path], str],
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool = True,
) -> tuple[RawDrive, StreamFacts]:
    """Read a stream drive with its reader and resample it onto the grid."""
    file = rel(f.path)
    if kind == COMMA2K19:
        from rwhonet.data.comma2k19 import read_comma2k19

        streams = read_comma2k19(f.path, radius_m, display=file)
    elif kind == MDF4:
        from rwhonet.data.mdf4 import read_mdf4

        spec = data.signal_maps[f.format]
        streams = read_mdf4(
            f.path,
            spec.signals,
            radius_m,
            _map_name(f),
            file,
            spec.dbc_buses,
            spec.local_zone,
            data.max_file_mb,
        )
    else:
        from rwhonet.data.mdf4 import canedge_packed, canedge_packed_problem, is_mdf_name
        from rwhonet.data.streamcsv import log_kind, read_stream_csvs

        # a hidden file is none of the drive's (macOS's ._wheels.csv beside wheels.csv on
        # a logger's FAT card: binary metadata), as discover leaves hidden drives out
        # a receiver's NMEA, UBX, NovAtel or GPX log beside them (gps.nmea, gps.ubx,
        # drive.gps, track.gpx) is read as the GNSS stream, and a bus tool's raw CAN log
        # (can0.log) as its messages' streams where the map has a dbc;
        # a log rotator's files (gps.nmea.1, wheels.csv.2.gz) by their names without its number
        spec = data.signal_maps[f.format]
        # a stream Spark or Dask wrote as a folder of part files (wheels.parquet/) is a
        # table, as the file wheels.parquet is
        every = sorted(
            p
            for p in f.path.glob("*")
            if (p.is_file() or is_table_folder(p))
            and (
                is_csv_name(name := without_rotation(p.name))
                or is_table_name(name)
                or log_kind(name, p)
                or (
                    spec.dbc_files
                    and (is_can_log_name(name) or is_mdf_name(name) or canedge_packed(name))
                )
            )
        )
        files = [p for p in every if not p.name.startswith(".")]
        if packed_logs := [(p, how) for p in files if (how := canedge_packed(p.name))]:
            raise InputError([canedge_packed_problem(rel(p), how) for p, how in packed_logs])
        signals = spec.signals
        with scratch_dir("unpacked") as scratch:
            plain, shown, packed, tables = [], {}, [], []
            for i, p in enumerate(files):  # a file kept compressed: read as its text
                q, packing = p, compression_of(p)
                name = without_suffix(without_rotation(p.name))
                if packing is not None:
                    q = Path(scratch) / str(i) / name
                    q.parent.mkdir()
                    parts = _read_in_parts(name, p, bool(spec.dbc_files))
                    bound = None if parts else data.max_file_mb
                    decompressed_copy(p, packing, q, bound, rel(p))
                    packed.append(f"{p.name} ({packing})")
                elif name != p.name:  # a rotated file: read under its name without the number
                    q = Path(scratch) / str(i) / name
                    q.parent.mkdir()
                    q.symlink_to(p.resolve())
                if (table := table_kind(q)) is not None:  # wheels.parquet: read as its CSV
                    csv = Path(scratch) / f"{i}-table" / f"{Path(name).stem}.csv"
                    csv.parent.mkdir()
                    held = csv_copy(q, table, csv, data.max_file_mb, rel(p))
                    tables.append(f"{p.name} ({held.brief})")
                    q = csv
                shown[q] = rel(p)
                plain.append(q)
            streams = read_stream_csvs(
                plain,
                signals,
                radius_m,
                _map_name(f),
                shown,
                spec.dbc_buses,
                spec.local_zone,
                data.max_file_mb,
            )
        if hidden := [p.name for p in every if p.name.startswith(".")]:
            said = f"hidden files left out (none of the drive's streams): {', '.join(hidden)}"
            streams = dataclasses.replace(streams, notes=(*streams.notes, said))
        if packed:
            said = f"stream files kept compressed, read as the text they hold: {', '.join(packed)}"
            streams = dataclasses.replace(streams, notes=(*streams.notes, said))
        if tables:
            said = f"stream files kept as tables, read as the CSV they hold: {'; '.join(tables)}"
            streams = dataclasses.replace(streams, notes=(*streams.notes, said))
    return _resampled(streams, data, radius_m, period_s, split_gap_s, require_fix)


def _resampled(
    streams: DriveStreams,
    data: DataParams,
    radius_m: float | None,
    period_s: float,
    split_gap_s: float,
    require_fix: bool,
) -> tuple[RawDrive, StreamFacts]:
    """A drive's streams on the grid (:func:`rwhonet.data.streams.resample`), and what the
    resampler found."""
    from rwhonet.data.streams import resample

    res = resample(
        streams,
        period_s=period_s,
        split_gap_s=split_gap_s,
        nominal_radius_m=radius_m,
        require_fix=require_fix,
        gnss_lag=data.gnss_lag,
    )
    sources = {where: s.sources for s in streams.streams for where in s.wheres()}
    facts = StreamFacts(
        clock=streams.clock,
        n_input_rows=res.n_input_rows,
        streams=[
            {
                "stream": s.name,
                "file": s.file,
                "rows": s.n_rows,
                "median_step_s": float(np.median(np.diff(s.t_s))),
                "channels": {k: s.sources.get(k, k) for k in s.channels},
            }
            for s in streams.streams
        ],
        glitch_rows=np.flatnonzero(res.glitch),
        # each glitched sample's wheel as its stream names it
        glitch_samples=[
            (where, row, t, sources.get(where, {}).get(wheel, wheel))
            for where, row, t, wheel in res.glitch_samples
        ],
        glitch_wheels=res.glitch_wheels,
        lost=res.lost,
    )
    return res.drive, facts


def _mb(size_mb: float) -> str:
    return f"{size_mb:,.0f} MB" if size_mb >= 10 else f"{size_mb:.3g} MB"


def out_of_memory(f: DriveFile, rel: Callable[[Path], str] = str) -> InputError:
    """The report of a drive that did not fit in memory (reading it, or writing its table)."""
    size_mb = _size_bytes(f.path, f.path.is_dir()) / 2**20 if f.path.exists() else float("nan")
    return InputError(
        [
            Problem(
                rel(f.path),
                None,
                None,
                "a drive that fits in this machine's memory",
                f"out of memory on its {_mb(size_mb)}",
                f"{SPLIT_DRIVE}, or run on a machine with more memory (ingest holds about "
                "1.5x the file's size, validate about 3x), and lower data.max_file_mb to what "
                "fits",
            )
        ]
    )


@dataclass
class CanonicalDrive:
    """A drive file read, with the scenario tags of its sidecar.

    Attributes:
        raw: the channels, canonical names, SI units.
        intervals: the tagged intervals of ``<drive>.scenarios.json`` (none without one).
        sidecar: that sidecar, when the drive has one.
        streams: what resampling found, for a stream drive (None for a 10 Hz file).
    """

    raw: RawDrive
    intervals: list[ScenarioInterval]
    sidecar: Path | None
    streams: StreamFacts | None = None

    def table(self) -> pa.Table:
        """The canonical drive table (:func:`canonical_table`) with its ``scenario`` column."""
        return canonical_table(self.raw, scenario_array(self.raw.columns[c.T_S], self.intervals))


def read_canonical(
    f: DriveFile,
    data: DataParams,
    rel: Callable[[Path], str] = str,
    radius_m: float | None = None,
    period_s: float = 0.1,
    split_gap_s: float = 0.5,
    require_fix: bool = True,
) -> CanonicalDrive:
    """Read one drive (:func:`read_any`) and its optional scenario sidecar.

    Args: as :func:`read_any`.

    Returns:
        The drive, its scenario intervals, and what resampling found.

    Raises:
        InputError: the problems of the drive or of its sidecar.
    """
    raw, streams = read_any(f, data, rel, radius_m, period_s, split_gap_s, require_fix)
    # a drive of a file of many: <drive>.scenarios.json beside the file
    sidecar = sidecar_path(f.path if f.part is None else f.path.with_name(f"{f.part}.csv"))
    if not sidecar.is_file():
        return CanonicalDrive(raw, [], None, streams)
    return CanonicalDrive(raw, read_scenarios(sidecar, rel(sidecar)), sidecar, streams)


def canonical_table(raw: RawDrive, scenario: np.ndarray | pa.Array) -> pa.Table:
    """Assemble the canonical drive table: required, then optional channels, then ``scenario``.

    Every column is declared non-nullable: channels are float64 with missing values as NaN
    (never Arrow nulls), and a row without tags has ``""``. Parquet then stores no
    definition levels, which halves the time to write and to read the channels.

    Args:
        raw: the channels read from the file.
        scenario: per-row scenario labels (strings, or an Arrow string array).

    Returns:
        An Arrow table with float64 channels and a string ``scenario`` column.
    """
    order = [name for name in (*c.REQUIRED, *c.OPTIONAL) if name in raw.columns]
    arrays = [pa.array(raw.columns[name], type=pa.float64()) for name in order]
    arrays.append(scenario if isinstance(scenario, pa.Array) else pa.array(scenario, pa.string()))
    schema = pa.schema(
        [pa.field(name, pa.float64(), nullable=False) for name in order]
        + [pa.field(c.SCENARIO, pa.string(), nullable=False)]
    )
    return pa.Table.from_arrays(arrays, schema=schema)


def with_label_times(table: pa.Table, period_s: float) -> pa.Table:
    """A canonical drive table with its times as the label takes them, placed on the
    whole drive (:func:`rwhonet.data.timebase.drive_label_times`): the table itself where
    every stamp is on its slot, or a time is not finite (validate refuses such a drive).

    Its segments are sliced from it: a segment's rows placed alone would give its edge
    rows a neighbour on one side only, and under a jitter past half a period a slot the
    drive's rows beyond the edge had ruled out.
    """
    i = table.schema.get_field_index(c.T_S)
    t = table.column(i).to_numpy()
    if not np.isfinite(t).all():
        return table
    placed = drive_label_times(t, period_s)
    if placed is t or np.array_equal(placed, t):
        return table
    return table.set_column(i, table.schema.field(i), pa.array(placed, type=pa.float64()))


def scenario_array(t_s: np.ndarray, intervals: list[ScenarioInterval]) -> pa.Array:
    """Return a drive's ``scenario`` column as an Arrow string array.

    Args:
        t_s: row times, s.
        intervals: the drive's tagged intervals (:func:`rwhonet.data.scenarios.read_scenarios`).

    Returns:
        One ';'-joined tag string per row (:func:`rwhonet.data.scenarios.scenario_column`).
    """
    labels, codes = scenario_codes(t_s, intervals)
    # Arrow copies the few distinct labels per row in C++, rather than building one
    # Python string per row and converting them.
    return pa.array(labels, type=pa.string()).take(pa.array(codes))
