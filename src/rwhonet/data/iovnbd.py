"""IO-VNBD "V-" drive files (Onyekpe et al., IO-VNBD dataset description, Table 3).

The only module that knows the IO-VNBD header names. Real headers start with
a space (" Wheel Speed Front Left (rad/sec)"); columns are matched by
stripped, case-insensitive name and fall back to position.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive, read_header, read_numeric
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

# Stripped, case-insensitive header name -> position in LAYOUT.
_KEY_TO_POSITION: dict[str, int] = {col.header.strip().lower(): i for i, col in enumerate(LAYOUT)}


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
    return header_cell.strip().lower()


def locate_columns(header: Sequence[str]) -> tuple[dict[str, int], str]:
    """Find the file position of every canonical IO-VNBD channel.

    Columns are matched by stripped, case-insensitive header name. When a required
    channel is not found by name, the file has exactly the 29 IO-VNBD columns, and
    every header name that *is* recognised sits at its IO-VNBD position, the header
    is taken as unknown (renamed, translated) and columns are taken by position.

    Args:
        header: the file's header cells.

    Returns:
        (canonical name -> 0-based file position, ``"name"`` or ``"position"``).

    Raises:
        LayoutError: the columns cannot be located.
    """
    keys = [_key(h) for h in header]
    duplicated = sorted({k for k in keys if k in _KEY_TO_POSITION and keys.count(k) > 1})
    if duplicated:
        raise LayoutError([], f"header names appear more than once: {duplicated}")
    by_name = {
        LAYOUT[_KEY_TO_POSITION[k]].canonical: pos
        for pos, k in enumerate(keys)
        if k in _KEY_TO_POSITION and LAYOUT[_KEY_TO_POSITION[k]].canonical is not None
    }
    missing = [name for name in c.REQUIRED if name not in by_name]
    if not missing:
        return by_name, "name"
    # Known names at other positions mean a different column order: positions can't be trusted.
    moved = [h.strip() for pos, h in enumerate(header) if _KEY_TO_POSITION.get(_key(h), pos) != pos]
    if len(header) == len(LAYOUT) and not moved:
        return {col.canonical: pos for pos, col in enumerate(LAYOUT) if col.canonical}, "position"
    if len(header) != len(LAYOUT):
        raise LayoutError(missing, f"{len(header)} columns, not the {len(LAYOUT)} of the layout")
    raise LayoutError(missing, f"known names at other positions than the layout's: {moved}")


def read_iovnbd(path: Path, display: str | None = None) -> RawDrive:
    """Read an IO-VNBD "V-" drive file into canonical SI channels.

    Args:
        path: the CSV file (header row first, 10 Hz rows).
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The drive's channels (every LAYOUT column with a canonical name that the file has),
        converted with ``LAYOUT[i].to_si``; ``header_match`` says whether the columns were
        found by name or, for an unknown 29-column header, by position.

    Raises:
        InputError: empty file, missing required column, non-numeric cell or a row with the
            wrong number of columns; every problem of the file is listed.
    """
    file = display or str(path)
    header = read_header(path, file)
    positions, match = iovnbd_columns(header, file)
    values = read_numeric(path, len(header), {pos: header[pos] for pos in positions.values()}, file)
    for name, pos in positions.items():
        # In place: the reader's arrays are ours, and a copy would hold a column twice.
        # A factor of 1 needs nothing (x * 1.0 == x, NaN and inf included).
        if TO_SI[name] != 1.0:
            if not values[pos].flags.writeable:
                values[pos] = values[pos].copy()
            np.multiply(values[pos], TO_SI[name], out=values[pos])
    return RawDrive(
        columns={name: values[pos] for name, pos in positions.items()},
        source_columns={name: header[pos] for name, pos in positions.items()},
        header_match=match,
    )


TO_SI: dict[str, float] = {col.canonical: col.to_si for col in LAYOUT if col.canonical}


def iovnbd_columns(header: Sequence[str], file: str) -> tuple[dict[str, int], str]:
    """Locate the IO-VNBD channels of a header, or report why not (as :func:`read_iovnbd`).

    Args:
        header: the file's header cells.
        file: how the file is named in error reports.

    Returns:
        (canonical name -> 0-based file position, ``"name"`` or ``"position"``); each
        channel's factor to SI units is :data:`TO_SI`.

    Raises:
        InputError: the columns cannot be located, or the first line is a data row.
    """
    try:
        positions, match = locate_columns(header)
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
                f"a column named {col.header.strip()!r} (IO-VNBD layout), or all "
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
    if match == "position" and all(_is_number(h) for h in header):
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


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True
