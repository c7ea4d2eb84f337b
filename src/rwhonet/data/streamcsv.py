"""One CSV file per sensor stream, read through a signal map.

A logger that exports each message or sensor to its own CSV (wheel speeds in
one, GNSS fixes in another, perhaps the IMU in a third), each with its own time
column, is read here: one signal map (:mod:`rwhonet.data.signalmap`, key ``t``
required) names the time column every file has and where each other quantity
is; each quantity must be in exactly one of the files. Columns are found by
name without regard to case, spaces, punctuation and a unit suffix
(:func:`rwhonet.data.columnmap.find_column`); extra columns are ignored. The
files are parsed by the same streaming CSV reader as the 10 Hz files
(:mod:`rwhonet.data.csvio`), so every bad cell is reported with its file, row
and column. The clock is the files' common time column.

A GNSS receiver's NMEA 0183 log among the files (``gps.nmea``), a u-blox receiver's
binary log (``gps.ubx``) or a GPS track in GPX (``track.gpx``: a phone's or handheld's
logger) gives the fixes where no CSV holds the map's latitude and longitude:
:mod:`rwhonet.data.nmea`, :mod:`rwhonet.data.ubx` and :mod:`rwhonet.data.gpx` read them,
and the first places them on the files' clock (``_receiver_groups``). Where a folder holds
several kinds, the first of UBX (its positions to 1e-7 degrees), NovAtel, Septentrio's
SBF (:mod:`rwhonet.data.sbf`), NMEA (the receiver's own sentences), a phone's GnssLogger
log, gpsd's JSON reports (:mod:`rwhonet.data.gpsdjson`), GPX (a track written from them) is
read and the others left out, said. With the
map's CAN databases (``dbc``), a bus tool's raw CAN log among them (``can0.log`` from
``candump -l``, ASC, BLF, TRC: :mod:`rwhonet.data.canlog`; or an MDF4 bus log, a CANedge's
split files, on each file's start time) is decoded as the MDF4 reader decodes a bus log,
and each of its messages holding a mapped signal is a stream, the signal found by name as
a column. Files of one stream a logger split in time (``wheels_000.csv``,
``wheels_001.csv``; NMEA, UBX or GPX logs; raw CAN logs) are joined by
:mod:`rwhonet.data.fileparts`.

Midnight: a time of day (seconds since the start of the day, as IO-VNBD's) that
passes midnight continues into the next day, by the rule of the 10 Hz readers
(:func:`rwhonet.data.timebase.unwrap_midnight`: a step back from the day's last
hour into the next day's first hour, shorter than an hour in truth, adds a day),
applied to each file's time column; a file whose first sample already lies past
midnight while another file starts in the day's last hour is put on the next day
as a whole. Any other step back stays a problem the resampler reports.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from rwhonet.config import ColumnSpec
from rwhonet.data.canlog import is_can_log_name
from rwhonet.data.columnmap import (
    AUX_KEYS,
    DATE,
    FIX,
    HEMISPHERES,
    column_matches,
    column_not_found,
    find_column,
    scaled,
)
from rwhonet.data.csvio import (
    cut_last_row,
    cut_last_row_note,
    first_cell,
    header_again_note,
    read_header,
    read_numeric_rows,
    read_text_column,
    without_rows,
)
from rwhonet.data.fileparts import join_parts
from rwhonet.data.fixstatus import is_text, text_codes
from rwhonet.data.gnsslogger import is_gnsslogger_log, read_gnsslogger
from rwhonet.data.gpsdjson import is_gpsd_log, read_gpsd
from rwhonet.data.gpx import is_gpx_name, read_gpx
from rwhonet.data.headers import header_key, unit_name
from rwhonet.data.mdf4 import CanLogGroups, Databases, can_log_groups, is_mdf_name
from rwhonet.data.nmea import FixLog, is_nmea_name, on_clock, read_nmea
from rwhonet.data.novatel import is_novatel_log, is_novatel_name, read_novatel
from rwhonet.data.packed import signed_coordinates
from rwhonet.data.sbf import is_sbf_name, read_sbf
from rwhonet.data.signalmap import (
    FIX_KEYS,
    Group,
    build_streams,
    check_signal_map,
    fix_status_unit,
    mapped_unit_name,
    pulse_units,
    to_si,
)
from rwhonet.data.streams import DriveStreams
from rwhonet.data.texttime import (
    check_dates,
    date_note,
    declared_text_unit,
    is_text_unit,
    parse_dates,
    read_time_column,
)
from rwhonet.data.timebase import (
    MIDNIGHT_WINDOW_S,
    SECONDS_PER_DAY,
    SECONDS_PER_WEEK,
    unwrap_clock,
)
from rwhonet.data.ubx import is_ubx_name, read_ubx
from rwhonet.errors import InputError, Problem

CLOCK = "the stream files' time column"


def read_stream_csvs(
    paths: Sequence[Path],
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str = "the signal map",
    display: Mapping[Path, str] | None = None,
    dbc: Databases = (),
    local_zone: str | None = None,
    max_mb: float | None = None,
) -> DriveStreams:
    """Read a drive given as one CSV per sensor stream.

    Args:
        paths: the drive's stream files (each with a header row and the time column).
        signal_map: key -> column name and unit (:func:`check_signal_map`, with ``t``).
        radius_m: the car's nominal tyre radius, for wheel speeds logged in m/s or km/h.
        name: how messages name the map (``data.signal_maps.<name>.signals``, a map file).
        display: how each file is named in error reports (default: the path as given).
        dbc: the CAN databases that decode a bus tool's raw CAN log among the files
            (``can0.log``, ``drive.blf``: :mod:`rwhonet.data.canlog`); its messages are
            streams as a CSV is, their signals found by the map's names. Empty: such
            files are not the drive's.
        local_zone: the loggers' time zone (:attr:`SignalMapSpec.local_zone`): a raw CAN
            log's local clock (an ASC log's date line) put on UTC, as the CSVs' and a
            receiver's times are.
        max_mb: the memory a raw CAN log among the files may take (``data.max_file_mb``;
            None: no bound; :func:`rwhonet.data.mdf4.can_log_groups`).

    Returns:
        The drive's streams: one per file that holds a mapped quantity.

    Raises:
        ConfigError: the signal map is invalid.
        InputError: a file without the time column, a quantity found in no file or in
            several, a cell that is not a number, a row with the wrong number of columns;
            every problem of every file is listed.
    """
    check_signal_map(name, signal_map, with_time=True, where=name)
    every = [(Path(p), (display or {}).get(Path(p), str(p))) for p in paths]
    # a receiver's logs: NMEA, u-blox's UBX, a GPX track
    logs = [(p, f) for p, f in every if log_kind(p.name, p)]
    # raw CAN logs: a bus tool's, or MDF4 bus logs (a CANedge's split files)
    buses = [
        (p, f)
        for p, f in every
        if dbc and (p, f) not in logs and (is_can_log_name(p.name) or is_mdf_name(p.name))
    ]
    files = [(p, f) for p, f in every if (p, f) not in logs and (p, f) not in buses]
    problems: list[Problem] = []
    decoded: dict[str, CanLogGroups] = {}
    for path, file in buses:
        not_csv = {k: v for k, v in signal_map.items() if k not in ("t", DATE, *HEMISPHERES)}
        try:
            decoded[file] = can_log_groups(
                path, not_csv, radius_m, name, file, dbc, True, local_zone, max_mb
            )
        except InputError as err:
            problems += err.problems
    undecoded = len(decoded) < len(buses)  # a CAN log refused: its keys' absence is said
    if not files and not buses:
        raise InputError(
            [
                Problem(
                    "the drive",
                    None,
                    None,
                    "one CSV file per sensor stream",
                    "no file",
                    "give the drive's stream files",
                )
            ]
        )
    headers: dict[str, list[str]] = {}
    unreadable: list[str] = []
    for path, file in files:
        try:
            headers[file] = read_header(path, file)
        except InputError as err:
            problems += err.problems
            unreadable.append(file)
    time_spec = signal_map["t"]
    found: dict[str, list[tuple[str, int]]] = {}
    time_at: dict[str, int] = {}
    # a logger's other CSVs (its settings, an event list): no time column, nothing mapped;
    # left out, unless no file has either (the map names none of the drive's columns)
    left_out = [
        file
        for file, header in headers.items()
        if not any(column_matches(header, spec.column) for spec in signal_map.values())
    ]
    if len(left_out) < len(headers):
        headers = {f: h for f, h in headers.items() if f not in left_out}
    else:
        left_out = []
    for file, header in headers.items():
        pos = find_column(header, time_spec.column, time_spec.unit)
        if pos is None:
            several = len(column_matches(header, time_spec.column)) > 1
            problems.append(
                column_not_found(header, time_spec.column, f"{name}.t", file)
                if several
                else Problem(
                    file,
                    None,
                    time_spec.column,
                    f"the time column {time_spec.column!r} ({name}.t) in every stream file",
                    f"no such name in the header {[h.strip() for h in header]}",
                    "give every stream file its time column (one clock for all of them)",
                )
            )
            continue
        time_at[file] = pos
        problems += _unit_problems(file, header[pos], "t", time_spec, name)
        for key, spec in signal_map.items():
            if key == "t":
                continue
            at = find_column(header, spec.column, spec.unit)
            if at is not None:
                found.setdefault(key, []).append((file, at))
                problems += _unit_problems(file, header[at], key, spec, name)
    for file, log in decoded.items():  # a raw CAN log's decoded signals, as a CSV's columns
        for key in {k for g in log.groups for k in g.channels}:
            found.setdefault(key, []).append((file, -1))
    found_fix = "lat" in found or "lon" in found  # the fixes in a CSV: an NMEA log unused
    problems += _fix_source_problems(signal_map, logs, found_fix, name, [*headers, *decoded])
    for key, spec in signal_map.items():
        if key == "t":
            continue
        where = found.get(key, [])
        if key == DATE:  # beside the time, in every file
            problems += [
                Problem(
                    file,
                    None,
                    spec.column,
                    f"the date column {spec.column!r} ({name}.date) in every stream file, "
                    "as the time",
                    f"no such name in the header {[h.strip() for h in header]}",
                    "give every stream file its date column, or drop date from the map and "
                    "write the times with their dates",
                )
                for file, header in headers.items()
                if file not in {f for f, _ in where}
            ]
            continue
        if key in HEMISPHERES and len(where) == 1:
            coordinate = HEMISPHERES[key][0]
            files_of = {f for f, _ in found.get(coordinate, [])}
            if files_of and where[0][0] not in files_of:
                problems.append(
                    Problem(
                        where[0][0],
                        None,
                        spec.column,
                        f"the hemisphere letters ({name}.{key}) in the file of their "
                        f"coordinate ({name}.{coordinate})",
                        f"the coordinate in {', '.join(sorted(files_of))}",
                        "give the letters and their coordinate in one file",
                    )
                )
        from_log = key in FIX_KEYS or key in HEMISPHERES
        from_log |= key == "yaw_rate" and any(is_ubx_name(p.name) for p, _ in logs)
        if not where and logs and from_log and not found_fix:
            continue  # the receiver's log gives it (checked when it is read)
        if not where and undecoded:
            continue  # the refused CAN log's problems say why its signals are missing
        if not where and unreadable:
            continue  # so do the problems of a stream file whose header could not be read
        if len(where) > 1 and _split_stream(where, found):
            continue  # one stream in several files: joined (fileparts) once read
        if len(where) != 1 and len(time_at) == len(headers):
            problems.append(
                Problem(
                    ", ".join([*headers, *decoded])
                    if not where
                    else ", ".join(f for f, _ in where),
                    None,
                    spec.column,
                    f"a column named {spec.column!r} ({name}.{key}) in exactly one stream file"
                    + (" or CAN log" if decoded else "")
                    + (
                        ", or in each file of one stream a logger split in time (files with "
                        "the same mapped columns)"
                        if where
                        else ""
                    ),
                    "in none of them"
                    if not where
                    else f"in {len(where)} files: "
                    + "; ".join(f"{f} ({', '.join(sorted(_keys_in(f, found)))})" for f, _ in where),
                    f"name the column in {name}.{key}.column"
                    + (
                        "; give each file of a split stream the same columns, and leave out "
                        "a file that is not the drive's"
                        if where
                        else ""
                    ),
                )
            )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in the stream files")
    groups = []
    notes: list[str] = [
        f"{file}: neither the time column {time_spec.column!r} nor any other column of "
        f"{name} in it: not one of the drive's streams, left out"
        for file in left_out
    ]
    changed: list[str] = []  # what the reader changed of the samples (DriveStreams.changed)
    for log in decoded.values():  # its messages' groups, on the log's own clock
        groups += log.groups
        notes += log.notes
        changed += log.changed
    paths_of = {file: path for path, file in files}
    for file, header in headers.items():
        keys = {k: at for k, places in found.items() for f, at in places if f == file}
        aux = {k: keys.pop(k) for k in AUX_KEYS if k in keys}
        if not keys:
            continue
        at_t = time_at[file]
        text = is_text_unit(time_spec.unit)
        # a fix status written as letters or words: read as text, as the hemispheres are
        text_fix = keys.get(FIX) if FIX in keys and is_text(signal_map[FIX].unit) else None
        wanted = {at: header[at] for k, at in keys.items() if k != FIX or text_fix is None}
        if not text:
            wanted[at_t] = header[at_t]
        try:
            where = f"{name}.t.unit"
            cell = first_cell(paths_of[file], at_t)
            declared_text_unit(time_spec.unit, cell, header[at_t], where, file)
            values, again = read_numeric_rows(paths_of[file], len(header), wanted, file)
            n_rows = len(values[next(iter(wanted))])
            cut = cut_last_row_note(n_rows + 1, cut_last_row(paths_of[file], len(header)))
            if cut is not None:  # a logger that lost power: said by predict too
                changed.append(f"{file}: {cut}")
            if text:
                values[at_t] = read_time_column(
                    paths_of[file], len(header), at_t, header[at_t], time_spec.unit, file, again
                )
        except InputError as err:
            problems += err.problems
            continue
        try:
            t = to_si(
                "t",
                scaled(values[at_t], time_spec),
                time_spec.unit,
                None,
                file,
                (file, header[at_t]),
            )
            channels = {
                k: to_si(
                    k,
                    scaled(values[at], signal_map[k]),
                    signal_map[k].unit,
                    radius_m,
                    f"{file} {header[at]!r}",
                    (file, header[at]),
                )
                for k, at in keys.items()
                if not (k == FIX and text_fix is not None)
            }
            if text_fix is not None:
                cells = read_text_column(
                    paths_of[file], len(header), text_fix, file, again, nulls=False
                )
                unit, column = signal_map[FIX].unit, header[text_fix].strip()
                channels[FIX] = text_codes(cells, unit, file, column, None, f"{name}.fix")
            lettered = {}  # both coordinates' letters checked, their problems in one report
            for key, at in aux.items():
                cells = read_text_column(paths_of[file], len(header), at, file, again)
                if key == DATE:
                    unit = signal_map[DATE].unit
                    dates = parse_dates(cells, unit)
                    check_dates(dates, file, header[at].strip(), unit, 1, f"{name}.date")
                    t = t + dates.seconds
                    notes.append(f"{file}: " + date_note(header[at], header[at_t], unit))
                    continue
                coordinate, unit = HEMISPHERES[key]
                if coordinate in keys:
                    columns = (header[keys[coordinate]].strip(), header[at].strip())
                    setting = f"{name}.{key}"
                    lettered[coordinate] = (channels[coordinate], cells, unit, columns, setting)
            channels |= signed_coordinates(lettered, file)
        except InputError as err:
            problems += err.problems
            continue
        rows = None  # the header's line again: its rows dropped, the others keep their numbers
        if (again_said := header_again_note(again)) is not None:
            changed.append(f"{file}: {again_said}")  # said by predict too, as a 10 Hz file's
            read = without_rows({"t": t, **channels}, again)
            t, channels = read.pop("t"), read
            rows = np.setdiff1d(np.arange(1, t.size + again.size + 1), again)
        t, said = unwrap_clock(t, "row")
        notes += [f"{file}: {note}" for note in said]
        groups += _per_message(
            Group(
                Path(file).name,
                file,
                np.ascontiguousarray(t),
                channels,
                {"t": header[time_at[file]].strip()}
                | {k: header[at].strip() for k, at in keys.items()},
                rows,
            ),
            notes,
        )
    if logs and not found_fix and not problems:
        try:
            groups += _receiver_groups(logs, signal_map, groups, set(found), name, notes, changed)
        except InputError as err:
            problems += _local_clock_hint(err.problems, decoded, name)
    elif logs and found_fix:
        notes.append(
            f"{', '.join(f for _, f in logs)}: receiver log(s), left out: the fixes are {name}'s "
            "columns in "
            + ", ".join(sorted({f for k in ("lat", "lon") for f, _ in found.get(k, [])}))
        )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in the stream files")
    groups = _next_day_starts(join_parts(groups, notes, changed), notes)
    streams = build_streams(groups, CLOCK, pulse_units(signal_map), fix_status_unit(signal_map))
    return dataclasses.replace(
        streams, notes=(*streams.notes, *notes), changed=(*changed, *streams.changed)
    )


def _keys_in(file: str, found: Mapping[str, list[tuple[str, int]]]) -> set[str]:
    return {k for k, places in found.items() if any(f == file for f, _ in places)}


def _split_stream(
    where: Sequence[tuple[str, int]], found: Mapping[str, list[tuple[str, int]]]
) -> bool:
    """Whether a key's files are one stream a logger split in time: CSVs with the same mapped
    columns, or raw CAN logs (whose messages :mod:`rwhonet.data.fileparts` matches)."""
    if all(at < 0 for _, at in where):
        return True
    if any(at < 0 for _, at in where):
        return False
    first = _keys_in(where[0][0], found)
    return all(_keys_in(f, found) == first for f, _ in where[1:])


def _per_message(g: Group, notes: list[str]) -> list[Group]:
    """A "wide" file split into one group per set of columns logged together.

    A logger that writes several messages into one file (the wheel speeds at 50 Hz and
    the yaw rate at 100 Hz, each row one message's samples) leaves the other messages'
    cells blank: no row has a value in every column. Such a file is read as one stream
    per set of columns whose cells are filled in the same rows, each with those rows'
    times. A file with rows that hold every column is one stream, as it was (its blank
    cells are samples without a value).
    """
    if len(g.channels) < 2:
        return [g]
    filled = {k: np.isfinite(v) for k, v in g.channels.items()}
    if np.logical_and.reduce(list(filled.values())).sum() >= 2:
        return [g]
    sets: dict[bytes, list[str]] = {}
    for k, mask in filled.items():
        sets.setdefault(np.packbits(mask).tobytes(), []).append(k)
    if len(sets) < 2 or any(filled[keys[0]].sum() < 2 for keys in sets.values()):
        return [g]  # one set, or a column without values: refused, naming it
    out = []
    for keys in sets.values():
        rows = filled[keys[0]]
        names = ", ".join(g.sources[k] for k in keys)
        out.append(
            Group(
                f"{g.name}: {names}",
                g.file,
                np.ascontiguousarray(g.t_s[rows]),
                {k: np.ascontiguousarray(g.channels[k][rows]) for k in keys},
                {"t": g.sources["t"]} | {k: g.sources[k] for k in keys},
                np.flatnonzero(rows) + 1 if g.rows is None else np.asarray(g.rows)[rows],
            )
        )
    shown = "; ".join(f"[{o.name.split(': ', 1)[1]}] {o.t_s.size} rows" for o in out)
    notes.append(
        f"{g.file}: no row has a value in every column (several messages in one file): "
        f"read as one stream per set of columns filled together: {shown}"
    )
    return out


def _unit_problems(file: str, cell: str, key: str, spec: ColumnSpec, name: str) -> list[Problem]:
    """A header cell whose unit suffix contradicts the map's unit (``Time [ms]`` mapped as s).

    As for an MDF4 signal's own unit: only units both spell (:func:`unit_name`) are
    compared; a header without a unit suffix says nothing.
    """
    declared = unit_name(header_key(cell)[1])
    mapped = mapped_unit_name(spec.unit)
    if declared is None or mapped is None or declared == mapped:
        return []
    return [
        Problem(
            file,
            None,
            cell.strip(),
            f"the unit {spec.unit!r} ({name}.{key})",
            f"the header says {declared!r}",
            f"set {name}.{key}.unit to the file's unit",
        )
    ]


def _next_day_starts(groups: list[Group], notes: list[str]) -> list[Group]:
    """Files that start past midnight put on the next day when another starts before it.

    A drive whose files start on both sides of midnight (the wheels at 23:59:59.9, the
    first fix at 00:00:00.1) has one file in the day's last hour and another in the
    next day's first hour: the latter gets a day added, as its first step would have
    been given had it been in the same file.
    """
    starts = [float(g.t_s[0]) for g in groups if g.t_s.size and np.isfinite(g.t_s[0])]
    if not starts or max(starts) < SECONDS_PER_DAY - MIDNIGHT_WINDOW_S:
        return groups
    # a GPS time of week: files on both sides of the week's end (a time of day never
    # reaches the week's last hour)
    week = max(starts) >= SECONDS_PER_WEEK - MIDNIGHT_WINDOW_S
    period, what = (
        (SECONDS_PER_WEEK, "the GPS week's end") if week else (SECONDS_PER_DAY, "midnight")
    )
    out = []
    for g in groups:
        if g.t_s.size and g.t_s[0] < MIDNIGHT_WINDOW_S:
            g = dataclasses.replace(g, t_s=g.t_s + period)
            added = "a week" if week else "a day"
            notes.append(f"{g.file}: starts past {what}, after the other files: {added} added")
        out.append(g)
    return out


def _fix_source_problems(
    signal_map: Mapping[str, ColumnSpec],
    logs: Sequence[tuple[Path, str]],
    found_fix: bool,
    name: str,
    files: Sequence[str],
) -> list[Problem]:
    """Where the fixes come from: a CSV's columns or a receiver's logs, not neither."""
    missing = [k for k in ("lat", "lon") if k not in signal_map]
    if missing and not logs:
        return [
            Problem(
                ", ".join(files) or "the drive",
                None,
                None,
                f"the fixes: {name}.lat and {name}.lon naming a stream file's columns, or a "
                "receiver's log among the drive's files (NMEA, *.nmea; u-blox UBX, *.ubx; "
                "NovAtel ASCII, *.gps; Septentrio SBF, *.sbf; a GPX track, *.gpx)",
                f"{' and '.join(missing)} not in {name}, and no receiver log",
                f"name the fixes' columns in {name}, or give the drive its receiver's log",
            )
        ]
    return []


def _local_clock_hint(
    problems: list[Problem], decoded: Mapping[str, CanLogGroups], name: str
) -> list[Problem]:
    """The receiver's log refused on the stream files' clock, where a raw CAN log among them
    keeps a local clock (an ASC log's seconds from its measurement's start, a TRC's start
    as PEAK's tools write it, an MDF4 bus log marked local time) and the map gives no
    ``local_zone``: each fix says how to put it on UTC."""
    local = [f for f, g in decoded.items() if g.local_clock]
    if not local:
        return problems
    where = name.removesuffix(".signals")
    hint = (
        f"; {', '.join(local)} keeps the logging computer's local clock: give the signal map "
        f"({where}) local_zone, that computer's time zone (Europe/Berlin), which puts the "
        "log's start (an ASC log's date line, a TRC's $STARTTIME, an MDF4 file's start) on UTC"
    )
    return [dataclasses.replace(p, fix=(p.fix or "") + hint) for p in problems]


# a receiver's logs, the most precise kind first -> why: where a folder holds several
# kinds, the first is read and the others left out
LOG_KINDS = {
    "UBX": "its positions to 1e-7 degrees",
    "NovAtel": "its GNSS solution to 1e-11 degrees",
    "SBF": "its positions in radians as 8-byte floats",
    "NMEA": "the receiver's own sentences",
    "GnssLogger": "a phone's fixes as Android gives them",
    "gpsd": "gpsd's reports of the receiver's fixes",
    "GPX": "a track written from them",
}
LOG_NAMES = {
    "UBX": is_ubx_name,
    "NovAtel": is_novatel_name,
    "SBF": is_sbf_name,
    "NMEA": is_nmea_name,
    "GPX": is_gpx_name,
}
LOG_READERS = {
    "UBX": read_ubx,
    "NovAtel": read_novatel,
    "SBF": read_sbf,
    "NMEA": read_nmea,
    "GnssLogger": read_gnsslogger,
    "gpsd": read_gpsd,
    "GPX": read_gpx,
}


def log_kind(name: str, path: Path | None = None) -> str | None:
    """A receiver's log's kind by its name (``gps.ubx``, ``gps.nmea.gz``, ``track.gpx``,
    ``drive.gps``), or, given its ``path``, a ``*.asc`` or ``*.log`` that holds a NovAtel
    receiver's logs (:func:`rwhonet.data.novatel.is_novatel_log`), a ``*.txt`` that is
    a phone's GnssLogger log (:func:`rwhonet.data.gnsslogger.is_gnsslogger_log`) or a
    ``*.json`` (``*.log``, ``*.txt``) of gpsd's reports
    (:func:`rwhonet.data.gpsdjson.is_gpsd_log`); None: no receiver log."""
    kind = next((k for k, named in LOG_NAMES.items() if named(name)), None)
    if kind is None and path is not None and is_novatel_log(path, name):
        return "NovAtel"
    if kind is None and path is not None and is_gnsslogger_log(path, name):
        return "GnssLogger"
    if kind is None and path is not None and is_gpsd_log(path, name):
        return "gpsd"
    return kind


def _receiver_groups(
    logs: Sequence[tuple[Path, str]],
    signal_map: Mapping[str, ColumnSpec],
    groups: Sequence[Group],
    in_csv: set[str],
    name: str,
    notes: list[str],
    changed: list[str],
) -> list[Group]:
    """The receiver's UBX, NovAtel, SBF, NMEA, GnssLogger, gpsd or GPX logs as the drive's GNSS
    stream, each on the stream files' clock (those of the first kind of :data:`LOG_KINDS`
    alone where there are several, the others left out, said).

    They give the fixes and every GNSS key no stream file's column gives; a key the map
    names that a log does not give is refused, naming the log. Several logs are one
    receiver's log a logger rotated (joined by :mod:`rwhonet.data.fileparts`): each gives
    the keys all of them give. Sentences passed over (a checksum that does not match, a
    line cut short, ...) are said in ``changed`` too, so predict says them.
    """
    kinds = {p: log_kind(p.name, p) for p, _ in logs}
    first = next(k for k in LOG_KINDS if k in kinds.values())
    kept = [(p, f) for p, f in logs if kinds[p] == first]
    for kind in LOG_KINDS:
        if kind != first and (out := [f for p, f in logs if kinds[p] == kind]):
            notes.append(
                f"{', '.join(out)}: {kind} log(s), left out: the fixes are the receiver's "
                f"{first} log's ({', '.join(f for _, f in kept)}), {LOG_KINDS[first]}"
            )
    logs = kept
    read, problems = [], []
    for path, file in logs:  # every log's problems in one report
        try:
            read.append(LOG_READERS[first](path, file))
        except InputError as err:
            problems += err.problems
    if problems:
        raise InputError(problems)
    common = set.intersection(*(set(log.channels) for log in read))
    out = []
    for log in read:
        if log.dropped:
            changed.append(f"{log.file}: passed over: {log.dropped}")
        keys = [k for k in FIX_KEYS if k in common and k not in in_csv]
        lacking = [
            k for k in FIX_KEYS if k in signal_map and k not in in_csv and k not in log.channels
        ]
        if lacking:
            problems.append(
                Problem(
                    log.file,
                    None,
                    ", ".join(signal_map[k].column for k in lacking),
                    f"{', '.join(f'{name}.{k}' for k in lacking)} in a stream file or in the "
                    "receiver log's messages",
                    "in neither (the log's: "
                    + ", ".join(log.sources[k] for k in log.channels)
                    + ")",
                    f"name the column in {name}, or drop the key: the log gives "
                    + ", ".join(log.channels),
                )
            )
            continue
        if len(read) > 1 and (only := [k for k in log.channels if k not in common]):
            notes.append(
                f"{log.file}: {', '.join(only)} left out: not in every one of the drive's "
                "receiver logs"
            )
        named = [k for k in ("lat", "lon") if k in signal_map]
        if named:
            notes.append(
                f"{log.file}: the fixes are the receiver log's ("
                + ", ".join(repr(signal_map[k].column) for k in named)
                + f", named in {name}, in no stream file)"
            )
        time_spec = signal_map["t"]
        t, clock, said = on_clock(
            log,
            time_spec.unit,
            DATE in signal_map,
            [g.t_s for g in groups],
            name,
            read,
            time_spec,
        )
        notes += [*log.notes, said]
        out.append(
            Group(
                Path(log.file).name,
                log.file,
                np.ascontiguousarray(t),
                {k: log.channels[k] for k in keys},
                {"t": clock} | {k: log.sources[k] for k in keys},
                log.rows,
            )
        )
        rates = log.rates
        if "yaw_rate" in signal_map and "yaw_rate" not in in_csv and rates is not None:
            # on the fixes' clock: the receiver's times of day, moved as the fixes' were
            moved = rates.tod_s + (float(t[0]) - float(log.tod_s[0]))
            out.append(
                Group(
                    rates.name,
                    log.file,
                    np.ascontiguousarray(moved),
                    dict(rates.channels),
                    {"t": clock, **rates.sources},
                    rates.rows,
                )
            )
    if "yaw_rate" in signal_map and "yaw_rate" not in in_csv:
        problems += _no_yaw_rate(read, signal_map["yaw_rate"], name)
    if problems:
        raise InputError(problems)
    return out


def _no_yaw_rate(read: Sequence[FixLog], spec: ColumnSpec, name: str) -> list[Problem]:
    """The map's yaw rate found in no stream file: a problem where no receiver log (a UBX
    log's ESF-INS) gives it either."""
    if any(log.rates is not None and "yaw_rate" in log.rates.channels for log in read):
        return []
    return [
        Problem(
            ", ".join(log.file for log in read),
            None,
            spec.column,
            f"{name}.yaw_rate in a stream file, or a u-blox dead-reckoning receiver's "
            "UBX-ESF-INS z angular rate in its UBX log",
            "in neither",
            f"name the yaw rate's column in {name}, enable ESF-INS on the receiver, or drop "
            "yaw_rate from the map",
        )
    ]
