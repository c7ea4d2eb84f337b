"""Angles and times packed into one decimal number: NMEA's ``ddmm.mmmm``, ``hhmmss.ss``.

A GNSS receiver's NMEA 0183 sentences write the latitude as ``ddmm.mmmm`` and the
longitude as ``dddmm.mmmm``: degrees, then minutes and their decimals, run together
(``5224.1234`` is 52 deg 24.1234 min = 52.402057 deg). Loggers that copy those fields
into a CSV keep them so, often with a minus sign for south and west in place of NMEA's
N/S and E/W letters. The same sentences, Racelogic VBOX files and many receivers' CSV
exports write the UTC time of day as ``hhmmss.ss`` (``142205.10`` is 14:22:05.1, and a
CSV may drop the leading zeros: ``93005.5`` is 09:30:05.5).

NMEA gives the hemisphere as a letter in a field of its own (``N``/``S``, ``E``/``W``), and
a logger that splits a sentence into CSV columns keeps it so: a column map names that
column (keys ``lat_hemisphere``, unit ``N/S``; ``lon_hemisphere``, unit ``E/W``), and
:func:`signed_or_refuse` gives each coordinate the letter's sign. The coordinate beside a
letter must be a magnitude (a minus sign and a letter both are refused: which one is
meant cannot be told); an empty letter makes the coordinate missing (NMEA leaves both
fields empty without a fix).

A Racelogic VBOX packs flags into its satellite count: 64 is added while the brake
trigger input is on, 128 while the receiver uses a DGPS correction (Racelogic, "VBO File
Format": ``137`` is 9 satellites with DGPS). Read as a count, a 3-satellite fix with DGPS
would pass any minimum; the unit ``vbox`` takes the flags off (the count modulo 64).

A column or signal map declares such a column with the unit ``ddmm`` (``ddmm W``: a
longitude positive west) or ``hhmmss``; :func:`unpack` turns it into degrees or seconds of
the day (which the readers continue past midnight as any time of day). A cell that cannot
be such a number (minutes or seconds beyond 60, hours of 24 or more, a negative time; 60.000
itself is a writer's rounding of 59.9999..., read as the next degree or minute)
is refused naming its row (:func:`unpack_or_refuse`): read as a plain number it would put
the car a few kilometres off, or the second in the wrong minute, and nothing later could
tell. A column of plain degrees declared ``ddmm`` cannot be told from one near the equator
or the prime meridian; the map must be right.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from rwhonet.data.canonical import DDMM, DDMM_W, MISSING_CELLS
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.errors import InputError

HHMMSS = "hhmmss"
VBOX_SATS = "vbox"  # a VBOX's satellite count, 64 (brake trigger) and 128 (DGPS) added
PACKED_UNITS = (DDMM, DDMM_W, HHMMSS, VBOX_SATS)
# The flags a VBOX adds to its satellite count: the count is below the smallest.
VBOX_FLAGS = {64: "the brake trigger input on", 128: "a DGPS correction in use"}

EXPECTED = {
    DDMM: "degrees and minutes run together, ddmm.mmmm (NMEA: 5224.1234 is 52 deg 24.1234 "
    "min), the minutes below 60",
    HHMMSS: "a time of day as hhmmss.ss (142205.1 is 14:22:05.1), hours below 24, minutes "
    "and seconds below 60",
    VBOX_SATS: "a VBOX's satellite count: a whole number from 0 to 255, the count below 64 "
    "with 64 (brake trigger) and 128 (DGPS) added",
}
EXPECTED[DDMM_W] = EXPECTED[DDMM]
# A hundredth of a microsecond or of a micro-minute: what a float64 of such a number may
# be off by after the divisions below, so that 5259.9999999999 is not taken for 60 minutes.
_EPS = 1e-9
# Minutes or seconds from 60 up to this are a writer's rounding (59.99996 min printed to
# four decimals is 60.0000), read as the value they are (60 min: the next degree); beyond,
# the cell is not of the form.
_ROUNDED = 60.001


# A coordinate's hemisphere letters (positive, negative), as a column map declares them.
HEMISPHERE_UNITS = {"N/S": ("N", "S"), "E/W": ("E", "W")}


def is_packed(unit: str | None) -> bool:
    """Whether ``unit`` is one of this module's packed units."""
    return unit in PACKED_UNITS


def unpack(values: np.ndarray, unit: str) -> tuple[np.ndarray, np.ndarray]:
    """Unpack a column of ``ddmm.mmmm`` angles, ``hhmmss.ss`` times or VBOX satellite counts.

    Args:
        values: the numbers as written (NaN: a missing value, kept NaN).
        unit: ``ddmm``, ``ddmm W`` (the result negated: positive west), ``hhmmss`` or
            ``vbox``.

    Returns:
        ``(unpacked, bad)``: degrees (the sign as written), seconds since midnight or the
        satellite count without its flags, as float64; and the indices of the cells that
        are not of the unit's form (their unpacked value is NaN).
    """
    x = np.asarray(values, dtype=np.float64)
    if unit == HHMMSS:
        hours = np.floor(x / 10_000.0 + _EPS)
        rest = x - 10_000.0 * hours
        minutes = np.floor(rest / 100.0 + _EPS)
        seconds = np.maximum(rest - 100.0 * minutes, 0.0)
        out = 3600.0 * hours + 60.0 * minutes + seconds
        with np.errstate(invalid="ignore"):
            bad = (x < 0) | (hours >= 24) | (minutes >= 60) | (seconds >= _ROUNDED)
    elif unit == VBOX_SATS:
        with np.errstate(invalid="ignore"):
            bad = (x < 0) | (x > 255) | (np.abs(x - np.round(x)) > _EPS)
            out = np.round(x) % 64.0
    elif unit in (DDMM, DDMM_W):
        a = np.abs(x)
        degrees = np.floor(a / 100.0 + _EPS)
        minutes = np.maximum(a - 100.0 * degrees, 0.0)
        out = np.copysign(degrees + minutes / 60.0, x)
        if unit == DDMM_W:
            out = -out
        with np.errstate(invalid="ignore"):
            bad = minutes >= _ROUNDED
    else:
        raise ValueError(f"not a packed unit: {unit!r}")
    where_bad = np.flatnonzero(bad)
    out[where_bad] = np.nan
    return out, where_bad


def unpack_or_refuse(
    values: np.ndarray,
    unit: str,
    file: str,
    column: str,
    rows: np.ndarray | None = None,
    setting: str | None = None,
) -> np.ndarray:
    """:func:`unpack`, refusing a column with any cell not of the unit's form.

    Args:
        values: the numbers as written.
        unit: the packed unit.
        file: the file, as the user knows it.
        column: the file's column (or the logger's channel) name.
        rows: each value's 1-based data row in the file (default: ``1, 2, ...``).
        setting: where the unit was declared (``data.column_maps.X.lat.unit``, ``its header
            'Lat (ddmm.mmmm)'``), for the fix.

    Raises:
        InputError: the cells that are not of the form, each with its row (the first few
            listed, the rest counted: :func:`rwhonet.data.problems.row_problems`).
    """
    out, bad = unpack(values, unit)
    if bad.size == 0:
        return out
    x = np.asarray(values, dtype=np.float64)
    declared = f" ({setting} declares {unit!r})" if setting else ""
    plain = (
        "a plain count is declared 'count'"
        if unit == VBOX_SATS
        else ("a column of plain degrees or seconds is declared 'deg' or 's'")
    )
    fix = f"check the column's unit{declared}: {plain}; otherwise correct or delete the rows named"
    at = np.asarray(rows)[bad] if rows is not None else bad + 1
    found = [repr(float(v)) for v in x[bad[:ROWS_LISTED]]]
    problems = row_problems(file, column, at, found, EXPECTED[unit], fix=fix)
    raise InputError(problems, summary=f"{bad.size} cell(s) in {file} not in the unit {unit!r}")


def hemisphere_signs(
    cells: Sequence[str | None], unit: str
) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """The sign each row's hemisphere letter gives (``N``/``E``: +1, ``S``/``W``: -1).

    Args:
        cells: the letter column's cells (None: empty).
        unit: ``N/S`` or ``E/W`` (:data:`HEMISPHERE_UNITS`).

    Returns:
        The signs (NaN for an empty cell, and for one that is no such letter) and the
        0-based positions of the cells that are no such letter, each as written.
    """
    plus, minus = HEMISPHERE_UNITS[unit]
    out = np.full(len(cells), np.nan)
    bad: list[tuple[int, str]] = []
    for i, cell in enumerate(cells):
        letter = (cell or "").strip().strip('"').strip().upper()
        if letter == plus:
            out[i] = 1.0
        elif letter == minus:
            out[i] = -1.0
        elif letter.lower() not in MISSING_CELLS:
            bad.append((i, repr(cell)))
    return out, bad


def signed_or_refuse(
    values: np.ndarray,
    cells: Sequence[str | None],
    unit: str,
    file: str,
    columns: tuple[str, str],
    first_row: int = 1,
    setting: str | None = None,
) -> np.ndarray:
    """Coordinates given the sign of their hemisphere letters.

    Args:
        values: the coordinates as magnitudes (degrees, after any unpacking).
        cells: the letter column's cells, row for row.
        unit: ``N/S`` or ``E/W``.
        file: the file, as the user knows it.
        columns: the coordinate's and the letter's column names.
        first_row: the 1-based data row of the first value.
        setting: where the letter column is declared, for the fix.

    Returns:
        The signed coordinates (NaN where the letter is empty).

    Raises:
        InputError: a letter that is not one of ``unit``'s, and a coordinate written with a
            minus sign beside a letter, each with its row.
    """
    values = np.asarray(values, dtype=np.float64)
    signs, bad = hemisphere_signs(cells, unit)
    with np.errstate(invalid="ignore"):
        negative = np.flatnonzero((values < 0) & np.isfinite(signs))
    if not bad and not negative.size:
        return values * signs
    coordinate, letter = columns
    problems = row_problems(
        file,
        letter,
        [first_row + i for i, _ in bad],
        [why for _, why in bad[:ROWS_LISTED]],
        f"a hemisphere letter, {' or '.join(HEMISPHERE_UNITS[unit])} ({setting or unit})",
        fix="write one of the two letters in every row with a fix, or leave it empty",
    ) + row_problems(
        file,
        coordinate,
        first_row + negative,
        [repr(float(v)) for v in values[negative[:ROWS_LISTED]]],
        f"a coordinate without a sign beside its hemisphere letter in {letter!r}",
        fix=(
            "write the coordinate as NMEA does, without a sign, or take the letter column "
            f"out of the map{f' ({setting})' if setting else ''} and keep the sign"
        ),
    )
    raise InputError(problems, summary=f"hemispheres in {file} that cannot be read")


# A coordinate to sign (:func:`signed_coordinates`): its values, its letters' cells, their
# unit (N/S, E/W), the coordinate's and the letters' column names, and where declared.
Lettered = tuple[np.ndarray, Sequence[str | None], str, tuple[str, str], str]


def signed_coordinates(
    coordinates: Mapping[str, Lettered], file: str, first_row: int = 1
) -> dict[str, np.ndarray]:
    """:func:`signed_or_refuse` for each coordinate, every problem of both in one report.

    Args:
        coordinates: canonical name -> what :data:`Lettered` holds.
        file: the file, as the user knows it.
        first_row: the 1-based data row of the first value.

    Returns:
        Canonical name -> the signed coordinates.

    Raises:
        InputError: the problems of every coordinate.
    """
    out, problems = {}, []
    for name, (values, cells, unit, columns, setting) in coordinates.items():
        try:
            out[name] = signed_or_refuse(values, cells, unit, file, columns, first_row, setting)
        except InputError as err:
            problems += err.problems
    if problems:
        raise InputError(problems, summary=f"hemispheres in {file} that cannot be read")
    return out
