"""A receiver's fix status in a column of its own: the logged positions that are no fix.

A receiver writes a position even when it has no GNSS fix: its own dead reckoning
(NMEA GGA quality 6, u-blox ``fixType`` 1), a manual or simulated position, or the last
fix held. The native readers screen these by the message's own status
(:mod:`~rwhonet.data.nmea`, :mod:`~rwhonet.data.ubx`, :mod:`~rwhonet.data.rosbag`); a
column or signal map names such a status with its ``fix`` key, and a unit that says how
to read its codes (:data:`UNITS`):

==========  ==================================================  =========================
unit        fixes                                                no fix
==========  ==================================================  =========================
``gga``     NMEA 0183 GGA quality 1 GPS, 2 DGPS, 3 PPS, 4 RTK     0 invalid, 6 estimated
            fixed, 5 RTK float; 9 (NovAtel's SBAS)               (dead reckoning), 7
                                                                 manual input, 8 simulation
``ubx``     u-blox NAV-PVT ``fixType`` 2 2D, 3 3D, 4 GNSS with   0 none, 1 dead reckoning
            dead reckoning                                       only, 5 time only
``navsat``  ``sensor_msgs/NavSatStatus`` ``status`` 0 and above   below 0 (-1 ``NO_FIX``,
            (FIX, SBAS, GBAS; gps_common's DGPS 18, WAAS 33)     -2 ``UNKNOWN``)
``sbf``     Septentrio PVT ``Mode`` (bits 0-3; bit 7, 2D, and   0 no PVT, 3 a fixed
            bit 6 aside) 1 stand-alone, 2 DGPS, 4 RTK fixed, 5   location (set by command),
            RTK float, 6 SBAS, 7 and 8 moving-base RTK, 10 PPP   9 and 11-15 (none defined)
``gpsd``    gpsd's TPV ``mode`` 2 (2D), 3 (3D)                   0 unknown, 1 no fix
``flag``    1                                                    0
``rmc``     as text: NMEA's RMC status and RMC/GNS/GLL mode      ``V`` void, ``N`` not
            letters ``A`` (valid; autonomous), ``D``             valid, ``E`` estimated
            differential, ``F`` float RTK, ``P`` precise, ``R``  (dead reckoning), ``M``
            RTK                                                  manual, ``S`` simulator
``gpx``     as text: GPX's ``fix`` words ``2d``, ``3d``,         ``none``
            ``dgps``, ``pps`` (GPSBabel's unicsv ``Fix``)
``bool``    as text: ``true`` (any case: pandas' ``True``,       ``false``
            Excel's ``TRUE``; Polars' and Arrow's ``true``)
==========  ==================================================  =========================

A status written as text (``rmc``, ``gpx``; case and spaces aside) is read in a CSV (a
column map's file, a stream CSV), as hemisphere letters are; a logger's MDF4 signal or
bag field is a number, so a signal map for those takes a code unit.

A position whose status says no fix keeps its time and loses its fix: every GNSS channel
of that row (:data:`rwhonet.data.canonical.FIX_CHANNELS`) becomes a missing value, as if
the receiver had written none, and validate and ``rwhonet predict`` take the row as one
without a fix. A position whose status cell is empty is not vouched for and is taken the
same way. A code the unit does not have (a GGA quality of 12, a flag of 2, 1.5) is
refused, naming its row: it says the column or its unit is not what the map says.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.errors import InputError

# The status column's name among a reader's channels while it is read (a map's ``fix`` key):
# taken off (:func:`screen`) before the channels are a drive's.
FIX_STATUS = "fix_status"
GGA, UBX, NAVSAT, SBF, GPSD, FLAG = "gga", "ubx", "navsat", "sbf", "gpsd", "flag"
RMC, GPX, BOOL = "rmc", "gpx", "bool"  # written as text
# :func:`screen`'s counts: every row with a position; the positions with an empty status
POSITIONS, NO_STATUS = "positions", "no status"
UNITS = (GGA, UBX, NAVSAT, SBF, GPSD, FLAG, RMC, GPX, BOOL)
# a status written as text: its words, each read as its place in the tuple (its code here);
# RMC's status A/V and the modes of RMC, GNS and GLL (NMEA 0183 v2.3 on), as the NMEA
# reader takes them (rwhonet.data.nmea.RMC_FIXES); GPX 1.1's fixType, as the GPX reader
TEXT_UNITS = {
    RMC: ("V", "N", "E", "M", "S", "A", "D", "F", "P", "R"),
    GPX: ("none", "2d", "3d", "dgps", "pps"),
    BOOL: ("false", "true"),  # a boolean column as pandas, Excel, Polars, Arrow write it
}
# the bits of a unit's code that say whether it is a fix (Septentrio's Mode: its bits 0-3)
_MASKS = {SBF: 0x0F}

# unit -> (the codes that are fixes, the codes it has (None: any integer), the names of
# the codes that are no fix); GGA as rwhonet.data.nmea.GGA_FIXES, u-blox's as ubx.PVT_FIXES,
# Septentrio's as sbf.FIX_MODES (its codes: Mode's bits 0-3)
_FIXES: dict[str, tuple[frozenset[int] | None, frozenset[int] | None, dict[int, str]]] = {
    GGA: (
        frozenset({1, 2, 3, 4, 5, 9}),
        frozenset(range(10)),
        {0: "invalid", 6: "estimated (dead reckoning)", 7: "manual input", 8: "simulation"},
    ),
    UBX: (
        frozenset({2, 3, 4}),
        frozenset(range(6)),
        {0: "no fix", 1: "dead reckoning only", 5: "time only"},
    ),
    NAVSAT: (None, None, {-1: "NO_FIX", -2: "UNKNOWN"}),  # fixes: 0 and above
    SBF: (
        frozenset({1, 2, 4, 5, 6, 7, 8, 10}),
        frozenset(range(256)),  # a u1, its 2D and fixed-position bits with it
        {0: "no PVT", 3: "a fixed location"},
    ),
    GPSD: (frozenset({2, 3}), frozenset(range(4)), {0: "unknown", 1: "no fix"}),
    RMC: (
        frozenset(range(5, 10)),
        frozenset(range(10)),
        {0: "void", 1: "not valid", 2: "estimated (dead reckoning)", 3: "manual", 4: "simulator"},
    ),
    GPX: (frozenset({1, 2, 3, 4}), frozenset(range(5)), {0: "no fix"}),
    FLAG: (frozenset({1}), frozenset({0, 1}), {0: "no fix"}),
    BOOL: (frozenset({1}), frozenset({0, 1}), {0: "no fix"}),
}
_EXPECTED = {
    GGA: "a GGA fix quality, an integer 0-9",
    UBX: "a u-blox fixType, an integer 0-5",
    NAVSAT: "a NavSatStatus status, an integer",
    SBF: "a Septentrio PVT Mode, an integer 0-255",
    GPSD: "a gpsd TPV mode, an integer 0-3",
    FLAG: "a fix flag, 1 (fix) or 0 (no fix)",
    RMC: "an NMEA status or mode letter, one of " + ", ".join(TEXT_UNITS[RMC]),
    GPX: "a GPX fix, one of " + ", ".join(TEXT_UNITS[GPX]),
    BOOL: "a fix flag written as text, true or false",
}


def is_text(unit: str | None) -> bool:
    """Whether a fix status unit is written as text (:data:`TEXT_UNITS`)."""
    return unit in TEXT_UNITS


def text_codes(
    cells: Sequence[str | None],
    unit: str,
    file: str,
    column: str,
    rows: np.ndarray | None = None,
    setting: str | None = None,
) -> np.ndarray:
    """A status column written as text (:data:`TEXT_UNITS`) as its codes.

    Args:
        cells: the cells (None or a missing value's text: no status).
        unit: ``rmc`` or ``gpx``.
        file: the file, as the user knows it.
        column: the file's column name.
        rows: each cell's 1-based row (default: ``1, 2, ...``).
        setting: where the unit was declared, for the fix.

    Returns:
        Each word's place in the unit's words, float64; NaN for an empty cell.

    Raises:
        InputError: each cell that is none of the unit's words, with its row.
    """
    lookup = {w.lower(): float(i) for i, w in enumerate(TEXT_UNITS[unit])}
    out = np.full(len(cells), np.nan)
    bad = []
    for i, cell in enumerate(cells):
        word = (cell or "").strip().strip('"').strip().lower()
        code = lookup.get(word)  # first: GPX's "none" is a word, not a missing value
        if code is not None:
            out[i] = code
        elif word not in c.MISSING_CELLS:
            bad.append(i)
    if bad:
        found = [repr(cells[i]) for i in bad[:ROWS_LISTED]]
        raise _refusal(np.asarray(bad), found, unit, file, column, rows, setting)
    return out


def refuse_bad_codes(
    codes: np.ndarray,
    unit: str,
    file: str,
    column: str,
    rows: np.ndarray | None = None,
    setting: str | None = None,
) -> None:
    """Refuse a status column holding a code its unit does not have (empty cells pass).

    Args:
        codes: the statuses as logged (NaN: an empty cell).
        unit: one of :data:`UNITS`.
        file: the file, as the user knows it.
        column: the file's column (or the logger's channel) name.
        rows: each value's 1-based row (default: ``1, 2, ...``).
        setting: where the unit was declared (``data.column_maps.X.fix``), for the fix.

    Raises:
        InputError: each cell that is no code of the unit, with its row.
    """
    x = np.asarray(codes, dtype=np.float64)
    known = _FIXES[unit][1]
    whole = np.isfinite(x) & (x == np.round(x))
    ok = np.isnan(x)  # an empty cell: no status
    if known is None:
        ok |= whole
    else:
        ok |= whole & np.isin(x, sorted(known))
    bad = np.flatnonzero(~ok)
    if bad.size:
        found = [repr(float(v)) for v in x[bad[:ROWS_LISTED]]]
        raise _refusal(bad, found, unit, file, column, rows, setting)


def _refusal(
    bad: np.ndarray,
    found: list[str],
    unit: str,
    file: str,
    column: str,
    rows: np.ndarray | None,
    setting: str | None,
) -> InputError:
    """The cells at indices ``bad`` (``found``: the first few as written) that are no
    status of ``unit``, each named by its row (``rows``; default: index + 1)."""
    at = np.asarray(rows)[bad] if rows is not None else bad + 1
    declared = f"{setting} declares {unit!r}" if setting else f"the unit is {unit!r}"
    fix = (
        f"check that the column is the receiver's fix status and its unit ({declared}: one "
        f"of {list(UNITS)}); otherwise correct or delete the rows named"
    )
    problems = row_problems(file, column, at, found, _EXPECTED[unit], fix=fix)
    return InputError(
        problems, summary=f"{bad.size} cell(s) in {file} that are no {unit!r} fix status"
    )


def is_fix(codes: np.ndarray, unit: str) -> np.ndarray:
    """Which statuses are a fix (False for an empty cell)."""
    return _fixes(_codes(codes, unit), unit)


def _fixes(x: np.ndarray, unit: str) -> np.ndarray:
    """:func:`is_fix` of codes already read by :func:`_codes`."""
    fixes = _FIXES[unit][0]
    if fixes is None:
        with np.errstate(invalid="ignore"):
            return x >= 0.0
    return np.isin(x, sorted(fixes))


def _codes(codes: np.ndarray, unit: str) -> np.ndarray:
    """The codes as float64, only the bits that say a fix where the unit has others
    (:data:`_MASKS`; NaN kept)."""
    x = np.asarray(codes, dtype=np.float64)
    if unit not in _MASKS:
        return x
    whole = np.where(np.isfinite(x), x, 0.0).astype(np.int64)
    return np.where(np.isfinite(x), (whole & _MASKS[unit]).astype(np.float64), x)


def screen(
    columns: Mapping[str, np.ndarray], unit: str, counts: Counter | None = None
) -> dict[str, np.ndarray]:
    """Channels with the positions their status says are no fix taken out.

    Args:
        columns: canonical name -> values, with the status under :data:`FIX_STATUS` (its
            codes checked by :func:`refuse_bad_codes`).
        unit: the status's unit.
        counts: where the positions taken out are counted, by code (:data:`NO_STATUS`: an
            empty cell) and :data:`POSITIONS` for every row with a position; added to,
            across blocks.

    Returns:
        The channels without :data:`FIX_STATUS`, each of
        :data:`rwhonet.data.canonical.FIX_CHANNELS` missing (NaN) where a row's position
        has no fix by its status.
    """
    out = {k: v for k, v in columns.items() if k != FIX_STATUS}
    codes = np.asarray(columns[FIX_STATUS], dtype=np.float64)
    kept = _codes(codes, unit)  # as the unit reads them: Septentrio's Mode's bits 0-3
    has = np.isfinite(out[c.LAT_DEG]) & np.isfinite(out[c.LON_DEG])
    none = has & ~_fixes(kept, unit)
    if counts is not None:
        counts[POSITIONS] += int(has.sum())
        counts[NO_STATUS] += int(np.isnan(codes[none]).sum())
        values, n = np.unique(kept[none & ~np.isnan(codes)], return_counts=True)
        for v, k in zip(values, n, strict=True):
            counts[int(v)] += int(k)
    if not none.any():
        return out
    for name in c.FIX_CHANNELS:
        if name in out:
            out[name] = np.where(none, np.nan, np.asarray(out[name], dtype=np.float64))
    return out


def note(counts: Counter, unit: str, where: str, column: str) -> str | None:
    """What :func:`screen` took out, for the drive's notes (None: nothing).

    Args:
        counts: :func:`screen`'s counts.
        unit: the status's unit.
        where: the file (or the logger's group) as messages name it.
        column: the status column's name.
    """
    codes = sorted(k for k, n in counts.items() if isinstance(k, int) and n)
    empty = counts[NO_STATUS]
    if not codes and not empty:
        return None
    names = _FIXES[unit][2]
    words = TEXT_UNITS.get(unit)
    listed = [
        f"{counts[k]} at {words[k] if words else k} ({names.get(k, 'no fix')})" for k in codes
    ]
    listed += [f"{empty} with no status"] if empty else []
    total = sum(counts[k] for k in codes) + empty
    return (
        f"{where}: {total} of {counts[POSITIONS]} position(s) whose fix status "
        f"({column.strip()}, {unit}) says no fix, taken as rows without a fix: " + "; ".join(listed)
    )
