"""IO-VNBD "V-" drive files (Onyekpe et al., IO-VNBD dataset description, Table 3).

The only module that knows the IO-VNBD header names. Real headers start with
a space (" Wheel Speed Front Left (rad/sec)"); columns are matched by
stripped, case-insensitive name and fall back to position.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import (
    RawDrive,
    csv_notes,
    first_cell,
    header_again_note,
    is_number,
    read_header,
    read_numeric_rows,
    without_rows,
)
from rwhonet.data.headers import header_key, unit_name
from rwhonet.data.packed import DDMM, HHMMSS, unpack_or_refuse
from rwhonet.data.texttime import read_time_column, text_time_note, text_time_unit
from rwhonet.data.timebase import unwrap_clock
from rwhonet.data.wheelunits import ANGULAR_WHEEL_UNITS, LINEAR_WHEEL_UNITS
from rwhonet.errors import InputError, Problem


class IovnbdColumn(NamedTuple):
    header: str  # as written in the file (leading space included)
    canonical: str | None  # canonical name, None when not carried downstream
    to_si: float  # factor converting the file's unit to the canonical SI unit


# Position (0-based) == index in this tuple.
LAYOUT: tuple[IovnbdColumn, ...] = (
    IovnbdColumn("Sats", c.N_SATS, 1.0),
    IovnbdColumn(" Time", c.T_S, 1.0),
    IovnbdColumn(" Lat", c.LAT_DEG, 1.0),
    IovnbdColumn(" Long", c.LON_DEG, 1.0),
    IovnbdColumn(" Velocity kmh", c.SPEED_GNSS_M_S, c.KMH_M_S),
    IovnbdColumn(" Heading", c.HEADING_DEG, 1.0),
    IovnbdColumn(" Height", c.HEIGHT_M, 1000.0),
    IovnbdColumn(" Vertical velocity kmh", None, c.KMH_M_S),
    IovnbdColumn(" Sample Period", None, 1.0),
    IovnbdColumn(" Steering Angle (deg)", None, 1.0),
    IovnbdColumn(" Wheel Speed Front Left (rad/sec)", c.OMEGA_FL, 1.0),
    IovnbdColumn(" Wheel Speed Front Right (rad/sec)", c.OMEGA_FR, 1.0),
    IovnbdColumn(" Wheel Speed Rear Left (rad/sec)", c.OMEGA_RL, 1.0),
    IovnbdColumn(" Wheel Speed Rear Right (rad/sec)", c.OMEGA_RR, 1.0),
    IovnbdColumn(" Yaw Rate (deg/sec)", c.YAW_RATE_RAD_S, math.pi / 180.0),
    IovnbdColumn(" Indicated Vehicle Speed (km/h)", c.SPEED_VEHICLE_M_S, c.KMH_M_S),
    IovnbdColumn(" Indicated Longitudinal Acceleration (g)", c.ACC_LON_M_S2, c.G_M_S2),
    IovnbdColumn(" Indicated Lateral Acceleration (g)", c.ACC_LAT_M_S2, c.G_M_S2),
    IovnbdColumn(" Handbrake", None, 1.0),
    IovnbdColumn(" Gear Requested", None, 1.0),
    IovnbdColumn(" Gear", None, 1.0),
    IovnbdColumn(" Engine Speed (rpm)", None, 1.0),
    IovnbdColumn(" Coolant Temperature (degC)", None, 1.0),
    IovnbdColumn(" Clutch Position", None, 1.0),
    IovnbdColumn(" Brake Pressure (psi)", None, 1.0),
    IovnbdColumn(" Brake Position", None, 1.0),
    IovnbdColumn(" Battery Voltage (V)", None, 1.0),
    IovnbdColumn(" Air Temperature (degC)", None, 1.0),
    IovnbdColumn(" Accelerator Pedal Position (%)", None, 1.0),
)

HEADERS: tuple[str, ...] = tuple(col.header for col in LAYOUT)
# The unit each carried channel has in the layout (the headers' own suffixes say the same).
_LAYOUT_UNIT: dict[str, str | None] = {
    c.T_S: "s",
    c.LAT_DEG: "deg",
    c.LON_DEG: "deg",
    c.N_SATS: None,
    c.SPEED_GNSS_M_S: "km/h",
    c.HEADING_DEG: "deg",
    c.HEIGHT_M: "km",
    **{w: "rad/s" for w in c.WHEELS},
    c.YAW_RATE_RAD_S: "deg/s",
    c.SPEED_VEHICLE_M_S: "km/h",
    c.ACC_LON_M_S2: "g",
    c.ACC_LAT_M_S2: "g",
}

# ---------------------------------------------------------------- header names and variants
#
# A header cell is matched by its *key*: lower case, letters and digits only, its unit
# suffix taken off (" Wheel Speed Front Left (rad/sec)", "wheel_speed_front_left",
# "WheelSpeedFrontLeft [rad/s]" all give "wheelspeedfrontleft"). Besides the IO-VNBD
# spellings, each carried channel has the common variants below. A declared unit is honoured
# when it is one of its quantity's units (a wheel speed "(rpm)" is converted from rpm) and
# refused when it is not; without one, the layout's unit is assumed.

# Quantity -> {unit: factor to the canonical SI unit}.
_UNITS: dict[str, dict[str, float]] = {
    "time": c.TIME_UNITS,
    "angle": {"deg": 1.0},
    "speed": {"km/h": c.KMH_M_S, "m/s": 1.0, "mph": 0.44704},
    "height": {"km": 1000.0, "m": 1.0},
    "wheel": ANGULAR_WHEEL_UNITS,
    "rate": {"deg/s": math.pi / 180.0, "rad/s": 1.0},
    "acc": {"g": c.G_M_S2, "m/s2": 1.0},
    "count": {"count": 1.0},
}
_KIND: dict[str, str] = {
    c.T_S: "time",
    c.LAT_DEG: "angle",
    c.LON_DEG: "angle",
    c.N_SATS: "count",
    c.SPEED_GNSS_M_S: "speed",
    c.HEADING_DEG: "angle",
    c.HEIGHT_M: "height",
    **{w: "wheel" for w in c.WHEELS},
    c.YAW_RATE_RAD_S: "rate",
    c.SPEED_VEHICLE_M_S: "speed",
    c.ACC_LON_M_S2: "acc",
    c.ACC_LAT_M_S2: "acc",
}
_WHEEL_POSITIONS = {
    c.OMEGA_FL: ("frontleft", "fl", "leftfront", "lf"),
    c.OMEGA_FR: ("frontright", "fr", "rightfront", "rf"),
    c.OMEGA_RL: ("rearleft", "rl", "leftrear", "lr"),
    c.OMEGA_RR: ("rearright", "rr", "rightrear", "rr"),
}
_VARIANTS: dict[str, tuple[str, ...]] = {
    c.T_S: ("time", "times", "timestamp", "timeofday"),
    c.LAT_DEG: ("lat", "latitude", "gpslat", "gpslatitude", "gnsslat", "gnsslatitude"),
    c.LON_DEG: (
        "long",
        "lon",
        "lng",
        "longitude",
        "gpslon",
        "gpslong",
        "gpslongitude",
        "gnsslon",
        "gnsslongitude",
    ),
    c.N_SATS: ("sats", "satellites", "nsats", "numsats", "numsat", "satcount", "numsv"),
    c.SPEED_GNSS_M_S: ("velocity", "gpsvelocity", "gpsspeed", "gnssspeed", "speedoverground"),
    c.HEADING_DEG: ("heading", "course", "gpsheading", "courseoverground"),
    c.HEIGHT_M: ("height", "altitude", "alt", "gpsheight", "gpsaltitude"),
    c.YAW_RATE_RAD_S: ("yawrate",),
    c.SPEED_VEHICLE_M_S: ("indicatedvehiclespeed", "vehiclespeed"),
    c.ACC_LON_M_S2: (
        "indicatedlongitudinalacceleration",
        "longitudinalacceleration",
        "acclon",
        "accellon",
    ),
    c.ACC_LAT_M_S2: (
        "indicatedlateralacceleration",
        "lateralacceleration",
        "acclat",
        "accellat",
    ),
    **{
        wheel: tuple(
            pattern.format(p)
            for p in positions
            for pattern in (
                "wheelspeed{}",
                "{}wheelspeed",
                "wheel{}",
                "ws{}",
                "omega{}",
                "{}wheel",
                "speed{}",  # "Speed_RL [rad/s]": a wheel's speed, by its position
                "{}speed",
                "whlspd{}",  # the CAN signal names of many DBCs ("WhlSpd_FL")
                "wheelspd{}",
                "wss{}",  # wheel speed sensor
            )
        )
        for wheel, positions in _WHEEL_POSITIONS.items()
    },
}


# Header key -> position in LAYOUT (every IO-VNBD column), and -> canonical channel (variants).
_KEY_TO_POSITION: dict[str, int] = {header_key(col.header)[0]: i for i, col in enumerate(LAYOUT)}
_KEY_TO_CHANNEL: dict[str, str] = {
    key: name for name, keys in _VARIANTS.items() for key in keys
} | {header_key(col.header)[0]: col.canonical for col in LAYOUT if col.canonical is not None}
_POSITION_OF: dict[str, int] = {col.canonical: i for i, col in enumerate(LAYOUT) if col.canonical}


class LayoutError(ValueError):
    """The IO-VNBD columns of a header cannot be located.

    Attributes:
        missing: canonical names of the required channels not found (empty for duplicates).
        why: why the columns could not be taken by name nor by position.
    """

    def __init__(self, missing: list[str], why: str) -> None:
        self.missing = missing
        self.why = why
        super().__init__(f"no column for {missing}: {why}" if missing else why)


def _key(header_cell: str) -> str:
    return header_key(header_cell)[0]


def locate_columns(header: Sequence[str]) -> tuple[dict[str, int], str]:
    """Find the file position of every canonical IO-VNBD channel.

    Columns are matched by name in any order, extra columns ignored: the header key
    (:func:`header_key`: case, spaces, punctuation and unit suffix do not matter) is looked
    up among the IO-VNBD names and the common variants. Only when a required channel is
    not found by name, the file has exactly the 29 IO-VNBD columns, and every header name
    that *is* recognised sits at its IO-VNBD position, the header is taken as unknown
    (renamed, translated) and columns are taken by position (the last resort; the reader
    says so in its ``header_match`` and notes).

    Args:
        header: the file's header cells.

    Returns:
        (canonical name -> 0-based file position, ``"name"`` or ``"position"``).

    Raises:
        LayoutError: the columns cannot be located, or two columns name one channel.
    """
    keys = [_key(h) for h in header]
    channel = [_KEY_TO_CHANNEL.get(k) for k in keys]
    seen: dict[str, list[str]] = {}
    for h, name in zip(header, channel, strict=True):
        if name is not None:
            seen.setdefault(name, []).append(h.strip())
    duplicated = sorted(names for names in seen.values() if len(names) > 1)
    plain = sorted({k for k in keys if k in _KEY_TO_POSITION and keys.count(k) > 1})
    if duplicated or plain:
        what = [" = ".join(repr(n) for n in names) for names in duplicated] or plain
        raise LayoutError([], f"header names appear more than once (one channel): {what}")
    by_name = {name: pos for pos, name in enumerate(channel) if name is not None}
    missing = [name for name in c.REQUIRED if name not in by_name]
    if not missing:
        return by_name, "name"
    # Known names at other positions mean a different column order: positions can't be trusted.
    moved = [
        h.strip()
        for pos, (h, k, name) in enumerate(zip(header, keys, channel, strict=True))
        if (_POSITION_OF.get(name, pos) if name else _KEY_TO_POSITION.get(k, pos)) != pos
    ]
    if len(header) == len(LAYOUT) and not moved:
        return {col.canonical: pos for pos, col in enumerate(LAYOUT) if col.canonical}, "position"
    if len(header) != len(LAYOUT):
        raise LayoutError(missing, f"{len(header)} columns, not the {len(LAYOUT)} of the layout")
    raise LayoutError(missing, f"known names at other positions than the layout's: {moved}")


# A time column's header suffix that names a form of text time or a zone, not a unit:
# 'Time (hh:mm:ss.sss)', 'Time [ISO 8601]', 'Time (UTC)' (rwhonet.data.texttime).
TEXT_TIME_SUFFIX = re.compile(r"h{1,2}:mm(:ss([.,][sfz]+)?)?|iso8601|utc|gmt|local(time)?")


# Units a header may name that are no factor: a number packed as NMEA writes it (a time of
# day as hhmmss.ss, a coordinate as ddmm.mmmm, the sign as written), unpacked by the readers
# (rwhonet.data.packed).
_PACKED: dict[str, tuple[str, ...]] = {c.T_S: (HHMMSS,), c.LAT_DEG: (DDMM,), c.LON_DEG: (DDMM,)}


def column_packed(header: Sequence[str], positions: dict[str, int]) -> dict[str, str]:
    """The located channels whose header names a packed unit (``Lat (ddmm.mmmm)``,
    ``Time (hhmmss.ss)``): canonical name -> the unit (:mod:`rwhonet.data.packed`)."""
    named = {name: unit_name(header_key(header[pos])[1]) for name, pos in positions.items()}
    return {
        name: unit
        for name, unit in named.items()
        if unit is not None and unit in _PACKED.get(name, ())
    }


def _unit_fix(name: str, cell: str) -> str:
    """What to do about a header's unit the layout does not take for the channel ``name``."""
    said = unit_name(header_key(cell)[1])
    if name in c.WHEELS and said in LINEAR_WHEEL_UNITS:
        # a wheel's circumferential speed: its conversion needs the car's tyre radius,
        # which an IO-VNBD file does not carry
        return (
            f"a wheel's circumferential speed in {said} is divided by the car's nominal "
            "tyre radius: read the file through a column map (data.column_maps, unit "
            f"{said!r} for each wheel; docs/readers.md), or write the column in rad/s"
        )
    return (
        "write the column in one of those units and name it in the header, e.g. "
        f"{LAYOUT[_POSITION_OF[name]].header.strip()!r}"
    )


def column_factors(header: Sequence[str], positions: dict[str, int]) -> dict[str, float]:
    """Each located channel's factor to SI: from the unit its header declares, else the layout's.

    Args:
        header: the file's header cells.
        positions: canonical name -> 0-based position (:func:`locate_columns`).

    Returns:
        Canonical name -> factor (NaN for a declared unit its quantity does not have:
        :func:`iovnbd_columns` refuses those).
    """
    out = {}
    for name, pos in positions.items():
        unit = header_key(header[pos])[1]
        alias = unit_name(unit)
        if name == c.T_S and unit is not None and TEXT_TIME_SUFFIX.fullmatch(unit):
            out[name] = 1.0  # 'Time (hh:mm:ss)', 'Time (UTC)': text, or seconds as written
        elif unit is None or alias == _LAYOUT_UNIT[name]:
            out[name] = TO_SI[name]
        elif alias in _PACKED.get(name, ()):
            out[name] = 1.0  # unpacked by the reader (column_packed)
        else:
            out[name] = _UNITS[_KIND[name]].get(alias or "", float("nan"))
    return out


def read_iovnbd(path: Path, display: str | None = None) -> RawDrive:
    """Read an IO-VNBD "V-" drive file into canonical SI channels.

    Args:
        path: the CSV file (header row first, 10 Hz rows).
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The drive's channels (every LAYOUT column with a canonical name that the file has),
        converted to SI with the unit each header declares, else the layout's
        (:func:`column_factors`); time of day continues across midnight
        (:func:`rwhonet.data.timebase.unwrap_midnight`). ``header_match`` says whether the
        columns were found by name or, for an unknown 29-column header, by position; the
        notes say so too, and where the clock passed midnight.

    Raises:
        InputError: empty file, missing required column, a declared unit the quantity does
            not have, non-numeric cell or a row with the wrong number of columns; every
            problem of the file is listed.
    """
    file = display or str(path)
    header = read_header(path, file)
    positions, match = iovnbd_columns(header, file)
    factors = column_factors(header, positions)
    # a time written as text (2019-03-11T14:22:05.1, 14:22:05.1): read as its first cell's form
    text_time = text_time_unit(first_cell(path, positions[c.T_S]))
    numeric = {pos for name, pos in positions.items() if not (name == c.T_S and text_time)}
    values, again = read_numeric_rows(
        path, len(header), {pos: header[pos] for pos in numeric}, file
    )
    if text_time:
        pos = positions[c.T_S]
        values[pos] = read_time_column(path, len(header), pos, header[pos], text_time, file, again)
        factors[c.T_S] = 1.0
    for name, pos in positions.items():
        # In place: the reader's arrays are ours, and a copy would hold a column twice.
        # A factor of 1 needs nothing (x * 1.0 == x, NaN and inf included).
        if factors[name] != 1.0:
            if not values[pos].flags.writeable:
                values[pos] = values[pos].copy()
            np.multiply(values[pos], factors[name], out=values[pos])
    for name, unit in column_packed(header, positions).items():
        if not (name == c.T_S and text_time):
            pos = positions[name]
            values[pos] = unpack_or_refuse(
                values[pos], unit, file, header[pos].strip(), setting=header_setting(header[pos])
            )
    columns = {name: values[pos] for name, pos in positions.items()}
    notes = []
    if match == "position":
        notes.append(position_note(header))
    if text_time:
        notes.append(text_time_note(header[positions[c.T_S]], text_time))
    notes += csv_notes(path, len(header), len(next(iter(values.values()))))
    if (again_said := header_again_note(again)) is not None:
        notes.append(again_said)
        columns = without_rows(columns, again)
    columns[c.T_S], said = unwrap_clock(columns[c.T_S])
    notes += said
    return RawDrive(
        columns=columns,
        source_columns={name: header[pos] for name, pos in positions.items()},
        header_match=match,
        notes=tuple(notes),
        header_rows=again,
    )


def header_setting(cell: str) -> str:
    """Where an IO-VNBD file declares a column's unit, for messages: its header."""
    return f"its header {cell.strip()!r}"


def position_note(header: Sequence[str]) -> str:
    """What a reader says when it took the IO-VNBD columns by position."""
    return (
        "columns taken by position (the last resort): the header names no time, latitude, "
        f"longitude and four wheel speeds that the reader knows ({[h.strip() for h in header]})"
    )


TO_SI: dict[str, float] = {col.canonical: col.to_si for col in LAYOUT if col.canonical}


def iovnbd_columns(header: Sequence[str], file: str) -> tuple[dict[str, int], str]:
    """Locate the IO-VNBD channels of a header, or report why not (as :func:`read_iovnbd`).

    Args:
        header: the file's header cells.
        file: how the file is named in error reports.

    Returns:
        (canonical name -> 0-based file position, ``"name"`` or ``"position"``); each
        channel's factor to SI units is :func:`column_factors`'s.

    Raises:
        InputError: the columns cannot be located, a header declares a unit its quantity
            does not have, or the first line is a data row.
    """
    try:
        positions, match = locate_columns(header)
        factors = column_factors(header, positions)
    except LayoutError as err:
        shown = [h.strip() for h in header]
        fix = (
            "give the file the IO-VNBD header (rwhonet.data.iovnbd.HEADERS) or all 29 "
            "columns in the IO-VNBD order; a CSV in another layout needs a column map "
            "(data.column_maps) and the role's format set to its name"
        )
        problems = [
            Problem(
                file,
                None,
                col.header.strip(),
                f"a column named {col.header.strip()!r} (IO-VNBD layout; case, spaces and "
                "unit suffix do not matter, common variants are known), or all "
                f"{len(LAYOUT)} IO-VNBD columns in their order",
                f"no such name among the {len(header)} header names; no position fallback: "
                f"{err.why}",
                fix,
            )
            for col in LAYOUT
            if col.canonical in err.missing
        ] or [
            Problem(
                file,
                None,
                None,
                "each IO-VNBD column name once",
                err.why,
                "rename or delete the repeated columns",
            )
        ]
        raise InputError(
            problems, summary=f"cannot locate the columns of {file} (header: {shown})"
        ) from None
    bad_units = [
        Problem(
            file,
            None,
            header[pos].strip(),
            f"a unit of {_KIND[name]} "
            f"({', '.join([*_UNITS[_KIND[name]], *_PACKED.get(name, ())]) or 'none'})",
            f"unit {header_key(header[pos])[1]!r} in the header",
            _unit_fix(name, header[pos]),
        )
        for name, pos in positions.items()
        if math.isnan(factors[name])
    ]
    if bad_units:
        raise InputError(bad_units, summary=f"unknown units in the header of {file}")
    if match == "position" and all(is_number(h) for h in header):
        # A file without its header row: taking the first data row as the header would
        # drop it silently.
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a header row first (IO-VNBD files start with one)",
                    f"a row of {len(header)} numbers: {','.join(header)[:60]!r}",
                    "add the IO-VNBD header line (rwhonet.data.iovnbd.HEADERS) at the top",
                )
            ]
        )
    return positions, match
