"""CSV drives in any layout, read through a column map from ``params.yaml``.

``data.column_maps.<name>`` names, for each canonical quantity, the CSV column
that holds it and its unit (CUPAC, whose layout is not documented, is read this
way). With ``iovnbd.py`` this is the only module that knows file column names.
Columns are matched by name, without regard to case, spaces, punctuation and a unit
suffix (:func:`find_column`); the time continues across midnight. Besides the channels
(:data:`KEYS`), a map may name a date column (``date``: the ``t`` column then holds the
time of day), hemisphere letter columns (``lat_hemisphere``, ``lon_hemisphere``:
NMEA's N/S and E/W), which give the channels their day and their signs, and the
receiver's fix status (``fix``: :mod:`rwhonet.data.fixstatus`), by which a position it
says is no fix is taken as none, and in a file of many drives the column naming each
row's drive (``drive``: :mod:`rwhonet.data.fleetfile`).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.csvio import (
    RawDrive,
    csv_notes,
    first_cell,
    header_again_note,
    read_header,
    read_numeric_rows,
    read_text_column,
    without_rows,
)
from rwhonet.data.fixstatus import FIX_STATUS, is_text, refuse_bad_codes, screen, text_codes
from rwhonet.data.fixstatus import UNITS as FIX_STATUS_UNITS
from rwhonet.data.fixstatus import note as fix_status_note
from rwhonet.data.headers import header_key, map_unit_name, unit_name
from rwhonet.data.packed import (
    HHMMSS,
    VBOX_SATS,
    is_packed,
    signed_coordinates,
    unpack_or_refuse,
)
from rwhonet.data.texttime import (
    CLOCK,
    ISO8601,
    check_dates,
    date_note,
    date_problem,
    declared_text_unit,
    is_dated,
    is_pattern,
    parse_dates,
    pattern_problem,
    read_time_column,
    text_time_note,
)
from rwhonet.data.timebase import unwrap_clock
from rwhonet.data.wheelpulses import is_pulse_unit
from rwhonet.data.wheelunits import ANGULAR_WHEEL_UNITS, LINEAR_WHEEL_UNITS, wheel_factor
from rwhonet.errors import InputError, Problem

# A wheel speed: angular, or the wheel's circumferential speed (NaN: its factor needs the
# car's tyre radius, :func:`key_factor`; a reader that multiplied by it would give no values)
_WHEEL_UNITS = {**ANGULAR_WHEEL_UNITS, **dict.fromkeys(LINEAR_WHEEL_UNITS, math.nan)}
FIX = "fix"  # the receiver's fix status (rwhonet.data.fixstatus)
WHEEL_KEYS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")  # c.WHEELS' keys, in order

# Column-map key -> (canonical name, {unit: factor to SI}).
KEYS: dict[str, tuple[str, dict[str, float]]] = {
    # iso8601 and hh:mm:ss: a time written as text (rwhonet.data.texttime), parsed to seconds;
    # hhmmss: a time of day as the number hhmmss.ss (rwhonet.data.packed)
    "t": (
        c.T_S,
        {**c.TIME_UNITS, ISO8601: 1.0, CLOCK: 1.0, HHMMSS: math.nan},
    ),
    # minutes of arc (Racelogic VBOX logs), NMEA's ddmm.mmmm (rwhonet.data.packed), a
    # longitude positive west ("W"): c.LAT_UNITS
    "lat": (c.LAT_DEG, c.LAT_UNITS),
    "lon": (c.LON_DEG, c.LON_UNITS),
    "omega_fl": (c.OMEGA_FL, _WHEEL_UNITS),
    "omega_fr": (c.OMEGA_FR, _WHEEL_UNITS),
    "omega_rl": (c.OMEGA_RL, _WHEEL_UNITS),
    "omega_rr": (c.OMEGA_RR, _WHEEL_UNITS),
    # vbox: a Racelogic VBOX's count, its flags (64, 128) taken off (rwhonet.data.packed)
    "n_sats": (c.N_SATS, {"count": 1.0, VBOX_SATS: math.nan}),
    # the receiver's stated horizontal accuracy (c.H_ACC_M), screened by
    # validate.gnss.max_h_acc_m
    "h_acc": (c.H_ACC_M, c.ACCURACY_UNITS),
    # the navigation filter's gyro (validate checks its unit and sign against GNSS)
    "yaw_rate": (c.YAW_RATE_RAD_S, c.YAW_RATE_UNITS),
    # the receiver's fix status, its codes read by their unit (rwhonet.data.fixstatus): a
    # position it says is no fix is taken as none; no channel of the drive's
    FIX: (FIX_STATUS, dict.fromkeys(FIX_STATUS_UNITS, 1.0)),
}
REQUIRED_KEYS = tuple(k for k, (name, _) in KEYS.items() if name in c.REQUIRED)
# A date in a column of its own (rwhonet.data.texttime.parse_dates): no channel of its own,
# each row's midnight added to the time of day the ``t`` column then holds.
DATE = "date"
# A coordinate's hemisphere letter in a column of its own (NMEA's N/S and E/W fields): the
# key -> (the coordinate's key, the letters' unit); rwhonet.data.packed.signed_or_refuse.
HEMISPHERES = {"lat_hemisphere": ("lat", "N/S"), "lon_hemisphere": ("lon", "E/W")}
AUX_KEYS = (DATE, *HEMISPHERES)  # keys that name no channel of their own
# The column naming each row's drive, in a file of many drives (rwhonet.data.fleetfile):
# a column map's only; its unit "text" (an id, no quantity). The file is split into its
# drives before any is read; a drive's own file is read without it.
DRIVE, DRIVE_UNIT = "drive", "text"


def check_column_map(name: str, column_map: Mapping[str, ColumnSpec]) -> None:
    """Check a column map's keys and units before any file is read.

    Args:
        name: the map's name under ``data.column_maps``.
        column_map: canonical key -> column and unit.

    Raises:
        ConfigError: naming every unknown key, missing required key and unknown unit.
    """
    where = f"data.column_maps.{name}"
    issues = [
        f"{where}.{k}: unknown key; expected one of {[*KEYS, *AUX_KEYS, DRIVE]}"
        for k in column_map
        if k not in KEYS and k not in AUX_KEYS and k != DRIVE
    ]
    if DRIVE in column_map and column_map[DRIVE].unit != DRIVE_UNIT:
        issues.append(
            f"{where}.{DRIVE}.unit: expected {DRIVE_UNIT!r} (the column holds each row's "
            f"drive id), got {column_map[DRIVE].unit!r}"
        )
    issues += [f"{where}.{k}: missing" for k in REQUIRED_KEYS if k not in column_map]
    issues += [
        f"{where}.{k}.unit: expected one of {list(KEYS[k][1])}"
        + (" or a strptime pattern (%d.%m.%Y %H:%M:%S.%f)" if k == "t" else "")
        + f", got {spec.unit!r}"
        + (
            " (a pulse counter is differenced sample to sample, as the bus carried it: give "
            "the drive as streams, through a signal map)"
            if is_pulse_unit(spec.unit)
            else ""
        )
        for k, spec in column_map.items()
        if k in KEYS and spec.unit not in KEYS[k][1] and not (k == "t" and is_pattern(spec.unit))
    ]
    issues += [
        f"{where}.t.unit: expected {problem}"
        for k, spec in column_map.items()
        if k == "t" and is_pattern(spec.unit) and (problem := pattern_problem(spec.unit))
    ]
    issues += aux_key_issues(where, column_map)
    issues += scale_issues(where, column_map)
    if issues:
        raise ConfigError("\n".join(issues))


def scale_issues(where: str, spec_map: Mapping[str, ColumnSpec]) -> list[str]:
    """A map's ``scale`` and ``offset`` that cannot be applied (a column or signal map's).

    A number logged raw is read as ``raw * scale + offset`` in the key's unit
    (:func:`scaled`). Refused: a scale of 0 or not finite, an offset not finite; and either
    on a value that is no plain number: a time or date written as text, a packed unit
    (``ddmm``, ``hhmmss``, ``vbox``: its digits or bits are its meaning), a wheel's pulse
    counter (differenced as the bus counted it) and a hemisphere's letters.

    Args:
        where: how messages name the map (``data.column_maps.<name>``).
        spec_map: key -> column, unit, scale and offset.
    """
    issues = []
    for k, spec in spec_map.items():
        if not spec.scaled:
            continue
        if not math.isfinite(spec.scale) or spec.scale == 0.0:
            issues.append(
                f"{where}.{k}.scale: expected a finite number other than 0, got {spec.scale!r}"
            )
        if not math.isfinite(spec.offset):
            issues.append(f"{where}.{k}.offset: expected a finite number, got {spec.offset!r}")
        if why := _not_scalable(k, spec.unit):
            issues.append(
                f"{where}.{k}: expected no scale or offset on {why} (unit {spec.unit!r}), "
                f"got scale {spec.scale!r}, offset {spec.offset!r}"
            )
    return issues


def _not_scalable(key: str, unit: str) -> str | None:
    """Why a key's values in ``unit`` are no plain number a scale applies to, or None."""
    if key in AUX_KEYS:
        return "a column of letters or dates"
    if key == FIX:
        return "a fix status, whose codes are its meaning"
    if key == "t" and (unit in (ISO8601, CLOCK) or is_pattern(unit)):
        return "a time written as text"
    if is_packed(unit):
        return "a packed number, whose digits or bits are its meaning"
    if is_pulse_unit(unit):
        return "a pulse counter, differenced as the bus counted it"
    return None


def scaled(values: np.ndarray, spec: ColumnSpec) -> np.ndarray:
    """A channel's logged numbers as ``values * scale + offset`` (``spec``'s), float64; the
    values themselves where the map sets neither."""
    if not spec.scaled:
        return values
    return np.asarray(values, dtype=np.float64) * spec.scale + spec.offset


def aux_key_issues(where: str, spec_map: Mapping[str, ColumnSpec]) -> list[str]:
    """What is wrong with a column or signal map's date and hemisphere keys (:data:`AUX_KEYS`).

    Args:
        where: how messages name the map (``data.column_maps.<name>``).
        spec_map: key -> column and unit.

    Returns:
        One line per problem: a date unit that is none, a dated time beside a date column,
        a hemisphere unit that is not its letters, a longitude ``... W`` beside letters.
    """
    issues = []
    if DATE in spec_map:
        if problem := date_problem(spec_map[DATE].unit):
            issues.append(f"{where}.date.unit: expected {problem}")
        if "t" in spec_map and is_dated(spec_map["t"].unit):
            issues.append(
                f"{where}.t.unit: expected a time of day beside a date column (s, ms, "
                f"hhmmss, hh:mm:ss, or a pattern without a date), got {spec_map['t'].unit!r}"
                ": the date would be given twice"
            )
    for key, (coordinate, unit) in HEMISPHERES.items():
        if key not in spec_map:
            continue
        if spec_map[key].unit != unit:
            issues.append(f"{where}.{key}.unit: expected {unit!r}, got {spec_map[key].unit!r}")
        if coordinate in spec_map and spec_map[coordinate].unit.endswith(" W"):
            issues.append(
                f"{where}.{coordinate}.unit: expected a unit without ' W' beside "
                f"{where}.{key} (the letters give the sign), got {spec_map[coordinate].unit!r}"
            )
    return issues


def key_factor(key: str, unit: str, radius_m: float | None, name: str) -> float:
    """The factor from a map key's unit to SI, as the readers multiply by it.

    Args:
        key: a channel key (:data:`KEYS`).
        unit: its unit (checked by :func:`check_column_map`).
        radius_m: the car's nominal tyre radius (a wheel's circumferential speed).
        name: the map's name, for messages.

    Returns:
        The factor; 1.0 for a packed unit (unpacked before) and a time's strptime pattern
        (parsed to seconds).

    Raises:
        InputError: a wheel speed in ``m/s``, ``km/h`` or ``mph`` without a radius.
    """
    if key in WHEEL_KEYS:
        return wheel_factor(unit, radius_m, f"data.column_maps.{name}.{key}.unit")
    if is_packed(unit):
        return 1.0
    return KEYS[key][1].get(unit, 1.0)


def linear_wheel_note(
    units: Mapping[str, str], names: Mapping[str, str], radius_m: float | None
) -> str | None:
    """How circumferential wheel speeds were read (None: every wheel angular).

    Args:
        units: key -> declared unit, for the map's keys.
        names: key -> the file's column name.
        radius_m: the radius they were divided by.
    """
    linear = [k for k in WHEEL_KEYS if units.get(k) in LINEAR_WHEEL_UNITS]
    if not linear:
        return None
    shown = ", ".join(f"{names[k].strip()} ({units[k]})" for k in linear)
    return (
        f"wheel speeds {shown} are the wheels' circumferential speeds: divided by the car's "
        f"nominal tyre radius, {radius_m:g} m, to rad/s"
    )


def read_columnmap(
    path: Path,
    column_map: Mapping[str, ColumnSpec],
    name: str,
    display: str | None = None,
    radius_m: float | None = None,
) -> RawDrive:
    """Read a CSV drive through a column map, converting every quantity to SI.

    Args:
        path: the CSV file (header row first).
        display: how the file is named in error reports (default: ``path`` as given).
        column_map: canonical key (``t``, ``lat``, ``omega_rl``, ...) -> column and unit;
            checked with :func:`check_column_map`.
        name: the map's name, for messages.
        radius_m: the car's nominal tyre radius, by which wheel speeds in ``m/s``,
            ``km/h`` or ``mph`` (the wheels' circumferential speeds) are divided.

    Returns:
        The mapped channels in canonical names and SI units (``header_match="column_map"``).

    Raises:
        InputError: empty file, a mapped column missing from the header, non-numeric cell or
            a row with the wrong number of columns; every problem of the file is listed.
        ConfigError: the column map itself is invalid.
    """
    check_column_map(name, column_map)
    # a fleet file's drive column: the file was split into its drives (fleetfile), each
    # read alone
    column_map = {k: spec for k, spec in column_map.items() if k != DRIVE}
    file = display or str(path)
    header = read_header(path, file)
    positions = columnmap_positions(header, column_map, name, file)
    factors = {
        key: key_factor(key, spec.unit, radius_m, name)
        for key, spec in column_map.items()
        if key not in AUX_KEYS
    }
    text_time = None
    if "t" in positions:
        where = f"data.column_maps.{name}.t.unit"
        spec, at = column_map["t"], positions["t"]
        cell = first_cell(path, at)
        text_time = declared_text_unit(spec.unit, cell, header[at], where, file)
    numeric = {
        pos
        for key, pos in positions.items()
        if not (key == "t" and text_time)
        and key not in AUX_KEYS
        and not (key == FIX and is_text(column_map[FIX].unit))  # letters or words
    }
    values, again = read_numeric_rows(
        path, len(header), {pos: header[pos] for pos in numeric}, file
    )
    if text_time:
        pos = positions["t"]
        values[pos] = read_time_column(path, len(header), pos, header[pos], text_time, file, again)
    columns = {}
    shared = {pos for pos in positions.values() if list(positions.values()).count(pos) > 1}
    for key, spec in column_map.items():
        if key in AUX_KEYS:
            continue
        if key == FIX and is_text(spec.unit):
            pos = positions[key]
            cells = read_text_column(path, len(header), pos, file, again, nulls=False)
            where = f"data.column_maps.{name}.fix"
            columns[FIX_STATUS] = text_codes(
                cells, spec.unit, file, header[pos].strip(), None, where
            )
            continue
        canonical, pos, factor = KEYS[key][0], positions[key], factors[key]
        if is_packed(spec.unit):
            where = f"data.column_maps.{name}.{key}.unit"
            columns[canonical] = unpack_or_refuse(
                values[pos], spec.unit, file, header[pos], setting=where
            )
        elif spec.scaled:  # raw numbers: in the unit once scaled and offset
            columns[canonical] = scaled(values[pos], spec) * factor
        elif pos in shared or not values[pos].flags.writeable:  # two keys read one column
            columns[canonical] = values[pos] * factor
        else:  # in place: the reader's arrays are ours, and a copy would hold a column twice
            columns[canonical] = np.multiply(values[pos], factor, out=values[pos])
    notes: tuple[str, ...] = ()
    if text_time:
        notes = (text_time_note(header[positions["t"]], text_time),)
    notes += csv_notes(path, len(header), len(next(iter(values.values()))))
    units = {key: spec.unit for key, spec in column_map.items()}
    if said := linear_wheel_note(units, {k: header[p] for k, p in positions.items()}, radius_m):
        notes += (said,)
    columns |= signed_coordinates(
        {
            KEYS[coordinate][0]: (
                columns[KEYS[coordinate][0]],
                read_text_column(path, len(header), positions[key], file, again),
                unit,
                (header[positions[coordinate]].strip(), header[positions[key]].strip()),
                f"data.column_maps.{name}.{key}",
            )
            for key, (coordinate, unit) in HEMISPHERES.items()
            if key in positions
        },
        file,
    )
    if FIX in positions:
        columns, said = screened_by_status(
            columns, column_map[FIX].unit, file, header[positions[FIX]], f"data.column_maps.{name}"
        )
        notes += (said,) if said else ()
    if DATE in positions:
        pos, unit = positions[DATE], column_map[DATE].unit
        dates = parse_dates(read_text_column(path, len(header), pos, file, again), unit)
        check_dates(dates, file, header[pos].strip(), unit, 1, f"data.column_maps.{name}.date")
        columns[c.T_S] = columns[c.T_S] + dates.seconds
        notes += (date_note(header[pos], header[positions["t"]], unit),)
    if (again_said := header_again_note(again)) is not None:
        notes += (again_said,)
        columns = without_rows(columns, again)
    if c.T_S in columns:
        columns[c.T_S], said = unwrap_clock(columns[c.T_S])
        notes += tuple(said)
    return RawDrive(
        columns=columns,
        source_columns={
            KEYS[k][0]: header[pos]
            for k, pos in positions.items()
            if k not in AUX_KEYS and k != FIX
        },
        header_match="column_map",
        notes=notes,
        header_rows=again,
    )


def screened_by_status(
    columns: dict[str, np.ndarray], unit: str, file: str, column: str, where: str
) -> tuple[dict[str, np.ndarray], str | None]:
    """A column-mapped file's channels with the positions its fix status column says are no
    fix taken out (:func:`rwhonet.data.fixstatus.screen`), and the note saying how many.

    Args:
        columns: the channels, the status's codes under ``fix_status`` (row ``i + 1`` at
            index ``i``).
        unit: the status's unit.
        file: the file, as the user knows it.
        column: the status column's name.
        where: the map (``data.column_maps.<name>``).

    Raises:
        InputError: a status that is no code of its unit, with its row.
    """
    refuse_bad_codes(columns[FIX_STATUS], unit, file, column.strip(), setting=f"{where}.fix")
    counts: Counter = Counter()
    out = screen(columns, unit, counts)
    return out, fix_status_note(counts, unit, file, column)


def columnmap_positions(
    header: list[str], column_map: Mapping[str, ColumnSpec], name: str, file: str
) -> dict[str, int]:
    """Locate a column map's columns in a header (matched stripped, case-insensitive).

    Args:
        header: the file's header cells.
        column_map: canonical key -> column and unit (checked).
        name: the map's name, for messages.
        file: how the file is named in error reports.

    Returns:
        Column-map key -> 0-based file position; key ``k``'s canonical name and unit
        factor are ``KEYS[k][0]`` and ``KEYS[k][1][column_map[k].unit]``.

    Raises:
        InputError: a mapped column is missing from the header.
    """
    found = {key: find_column(header, spec.column, spec.unit) for key, spec in column_map.items()}
    problems = [
        column_not_found(header, spec.column, f"data.column_maps.{name}.{key}", file)
        for key, spec in column_map.items()
        if found[key] is None
    ]
    if problems:
        raise InputError(problems, summary=f"missing column(s) in {file}")
    # A header that names its unit ("Wheel Speed RL (rpm)") against a map that declares
    # another: one of the two is wrong, and a factor of 9.5 or 57 goes unseen otherwise
    for key, pos in found.items():
        if key in AUX_KEYS or key == FIX:  # a date's form, a letter, a code: no unit
            continue
        said = unit_name(header_key(header[pos])[1])
        declared = column_map[key].unit
        if said is not None and said != map_unit_name(declared):
            problems.append(
                Problem(
                    file,
                    None,
                    header[pos],
                    f"the unit data.column_maps.{name}.{key}.unit declares, {declared!r}",
                    f"the header names the column's unit {said!r}",
                    f"set data.column_maps.{name}.{key}.unit to the column's unit (one of "
                    f"{sorted(KEYS[key][1])}), or correct the header",
                )
            )
    if problems:
        raise InputError(problems, summary=f"units in {file} that the column map contradicts")
    return {key: pos for key, pos in found.items() if pos is not None}


def column_not_found(header: list[str], column: str, setting: str, file: str) -> Problem:
    """The problem of a map's column the header has not, or has more than once."""
    matches = column_matches(header, column)
    if len(matches) > 1:
        return Problem(
            file,
            None,
            column,
            f"one column named {column!r} ({setting})",
            f"{len(matches)}: {[header[i].strip() for i in matches]}, the unit {setting}.unit "
            "declares named by none or by several of them",
            f"set {setting}.unit to the unit of the one meant (as its header or row of units "
            "names it), or rename the others in the file",
        )
    return Problem(
        file,
        None,
        column,
        f"a column named {column!r} ({setting})",
        f"no such name in the header {[h.strip() for h in header]}",
        f"name the file's column in {setting}.column (matched without regard to case, "
        "spaces, punctuation and a unit suffix), or give the file that column",
    )


def find_column(header: list[str], column: str, unit: str | None = None) -> int | None:
    """Position of a named column: its stripped, case-insensitive name, else its header key.

    The header key (:func:`rwhonet.data.headers.header_key`) leaves case, spaces,
    punctuation and a unit suffix aside: ``"WheelSpeedRL"`` finds ``"Wheel Speed RL (rpm)"``.
    A name that several columns share (:func:`column_matches`: a tool's export with a
    ``Time`` in s and a lap ``Time`` in min) is the one whose header, or row of units,
    names ``unit`` (the map's); else it matches none of them (ambiguous).

    Args:
        header: the file's header cells (a units row's units in them: ``Time (s)``).
        column: the name to find.
        unit: the unit a map declares for it (None: not told apart by unit).

    Returns:
        The 0-based position, or None.
    """
    matches = column_matches(header, column)
    if len(matches) == 1:
        return matches[0]
    if unit is not None and len(matches) > 1:
        named = [i for i in matches if unit_name(header_key(header[i])[1]) == map_unit_name(unit)]
        if len(named) == 1:
            return named[0]
    return None


def column_matches(header: list[str], column: str) -> list[int]:
    """The columns a name finds: those of its stripped, case-insensitive name, else those
    of its header key (:func:`find_column`)."""
    exact = [i for i, h in enumerate(header) if h.strip().lower() == column.strip().lower()]
    if exact:
        return exact
    key = header_key(column)[0]
    return [i for i, h in enumerate(header) if header_key(h)[0] == key] if key else []
