"""Time columns written as text: ISO 8601 date-times, ``hh:mm:ss`` clock times, dates.

Many loggers and spreadsheet exports write each row's time as text rather than as
seconds: ``2019-03-11T14:22:05.123Z`` (ISO 8601, with or without a zone offset) or
``14:22:05.1`` (a time of day, or a time since the logger started). A column map's or
signal map's ``t`` declares such a column with the unit ``iso8601`` or ``hh:mm:ss``;
an IO-VNBD file whose time column holds such text is read as its first cell's form
(:func:`text_time_unit`). Every reader then parses it here into seconds:

- ``iso8601``: seconds since 1970-01-01 00:00 UTC. A zone offset (``Z``, ``+01:00``,
  ``+0100``, ``-05``) is applied, so a drive through a change of summer time stays
  continuous; without one, the times are taken as written (as UTC). A column that gives
  the offset in some rows and not in others is refused: their clocks would differ by the
  unknown offset. Date and time may be separated by ``T`` or a space; the fraction of a
  second by ``.`` or ``,`` (ISO 8601 allows both).
- ``hh:mm:ss``: ``h*3600 + m*60 + s``, any number of hours (``0:05:03.1`` since the
  logger started, ``23:59:59.9`` a time of day). A time of day then continues across
  midnight by the readers' rule, as a time of day in seconds does
  (:func:`rwhonet.data.timebase.unwrap_midnight`).

- a ``strptime`` pattern (any unit with a ``%``; Python's directives), for what the two
  forms do not cover: ``%d.%m.%Y %H:%M:%S.%f`` (11.03.2019 14:22:05.123),
  ``%m/%d/%Y %I:%M:%S.%f %p``. With a date (``%d``, ``%j``, ...) the times are seconds
  since 1970, UTC where ``%z`` gives the offset, as written otherwise; without one they
  are times of day (``h*3600 + m*60 + s``), continued past midnight. A ``,`` in the
  pattern or a cell is read as ``.`` (a decimal comma before ``%f``). It must hold ``%H``
  (or ``%I`` with ``%p``), ``%M`` and ``%S``, and round-trip a time (:func:`pattern_problem`).

**A date in a column of its own** (a column map's ``date`` key: NMEA's RMC sentence gives
the date apart from the time, and many loggers and spreadsheets write "Date" and "Time"
columns): its unit is ``ddmmyy`` (NMEA's six digits, 110319 for 11 March 2019, the leading
zero possibly dropped; years 80-99 are 1980-1999, 00-79 2000-2079) or a ``strptime`` pattern
of a date alone (``%d/%m/%Y``, ``%Y-%m-%d``); :func:`parse_dates` gives each row's
midnight in seconds since 1970, to which the readers add the ``t`` column's time of day
(which must then be one: ``s``, ``ms``, ``hhmmss``, ``hh:mm:ss`` or a pattern without a
date). The times are then as written (no zone is applied), and midnight is the date's.

An empty cell (or ``NaN``, ``NA``, ``null``) is a missing time (NaN), which validate
refuses as it refuses an empty number; any other text that is not of the declared form
is refused naming the file's row and column.

float64 holds seconds since 1970 to about 0.25 µs, well inside a 0.1 s grid.

**A start on a local clock** (an ASC log's date line, a PEAK TRC's ``$STARTTIME``, an
MDF4 bus log's start marked local) is put on UTC in the signal map's ``local_zone`` by
:func:`local_to_unix`: a wall time in the hour a change of summer time repeats is two
instants an hour apart, and one in the hour it skips is none, so either is refused
(:class:`LocalTimeUnclear`) rather than read as one of them.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, date, datetime, timedelta
from pathlib import Path

import numpy as np

from rwhonet.data.canonical import MISSING_CELLS
from rwhonet.data.problems import RowTally
from rwhonet.errors import InputError, Problem

ISO8601 = "iso8601"
CLOCK = "hh:mm:ss"
TEXT_TIME_UNITS = (ISO8601, CLOCK)
DDMMYY = "ddmmyy"  # a date as NMEA's RMC sentence writes it

_SECONDS = r"(\d{1,2}(?:[.,]\d*)?)"
_ISO = re.compile(
    r"\s*(\d{4})-(\d{2})-(\d{2})[Tt ](\d{2}):(\d{2}):" + _SECONDS + r"\s*"
    r"(?:(Z)|([+-])(\d{2})(?::?(\d{2}))?)?\s*$",
    re.IGNORECASE,
)
_CLOCK = re.compile(r"\s*(\d+):(\d{2}):" + _SECONDS + r"\s*$")


def expected(unit: str) -> str:
    """What a cell of a text time column in ``unit`` looks like, for messages."""
    if is_pattern(unit):
        return f"a time as the pattern {unit!r} writes it (Python's strptime)"
    return EXPECTED[unit]


EXPECTED = {
    ISO8601: "an ISO 8601 date and time, e.g. 2019-03-11T14:22:05.123 ('T' or a space; "
    "a zone offset such as Z or +01:00 optional, but in every row or in none)",
    CLOCK: "a time as hh:mm:ss, e.g. 14:22:05.123 (a time of day or since the logger started)",
}


_DATE_DIRECTIVES = ("%d", "%j", "%m", "%b", "%B", "%y", "%Y", "%U", "%W", "%a", "%A", "%c", "%x")
_NAIVE_EPOCH = datetime(1970, 1, 1)


def is_pattern(unit: str) -> bool:
    """Whether a time unit is a ``strptime`` pattern (it holds a ``%``)."""
    return "%" in unit


def is_text_unit(unit: str | None) -> bool:
    """Whether a time unit is text: ``iso8601``, ``hh:mm:ss`` or a ``strptime`` pattern."""
    return unit is not None and (unit in TEXT_TIME_UNITS or is_pattern(unit))


def pattern_problem(pattern: str) -> str | None:
    """Why a ``strptime`` pattern cannot be a time column's unit (None: it can)."""
    hours = "%H" in pattern or ("%I" in pattern and "%p" in pattern)
    if not (hours and "%M" in pattern and "%S" in pattern):
        return f"a strptime pattern with %H (or %I and %p), %M and %S; got {pattern!r}"
    when = datetime(2019, 3, 11, 14, 22, 5, 123000, tzinfo=UTC)
    try:
        back = datetime.strptime(when.strftime(pattern), pattern)
    except ValueError as err:
        return f"a strptime pattern that reads back what it writes; {pattern!r}: {err}"
    if (back.hour, back.minute, back.second) != (14, 22, 5):
        return f"a strptime pattern that reads back the time it writes; got {pattern!r}"
    return None


def is_dated(unit: str) -> bool:
    """Whether a time unit gives the date as well (``iso8601``, a pattern with a date)."""
    return unit == ISO8601 or (is_pattern(unit) and any(d in unit for d in _DATE_DIRECTIVES))


_TIME_DIRECTIVES = ("%H", "%I", "%M", "%S", "%f", "%p", "%z", "%Z", "%X", "%c")


def date_problem(unit: str) -> str | None:
    """Why ``unit`` cannot be a date column's unit (None: it can)."""
    if unit == DDMMYY:
        return None
    wanted = f"{DDMMYY!r} or a strptime pattern of a date alone (%d/%m/%Y, %Y-%m-%d)"
    if not is_pattern(unit) or any(d in unit for d in _TIME_DIRECTIVES):
        return f"{wanted}; got {unit!r}"
    day = "%j" in unit or (
        ("%d" in unit or "%e" in unit) and any(m in unit for m in ("%m", "%b", "%B"))
    )
    if not (day and ("%Y" in unit or "%y" in unit)):
        return f"{wanted}, with a day, a month and a year; got {unit!r}"
    when = date(2019, 3, 11)
    try:
        back = datetime.strptime(when.strftime(unit), unit).date()
    except ValueError as err:
        return f"{wanted} that reads back what it writes; {unit!r}: {err}"
    if back != when:
        return f"{wanted} that reads back the date it writes; got {unit!r}"
    return None


def date_expected(unit: str) -> str:
    """What a cell of a date column in ``unit`` looks like, for messages."""
    if unit == DDMMYY:
        return "a date as ddmmyy (NMEA: 110319 is 11 March 2019)"
    return f"a date as the pattern {unit!r} writes it (Python's strptime)"


def parse_dates(cells: Sequence[str | None], unit: str) -> TextTimes:
    """A date column as each row's midnight in seconds since 1970 (the date as written).

    Args:
        cells: the column's cells in row order (None: an empty cell).
        unit: :data:`DDMMYY` or a date pattern (:func:`date_problem` None).

    Returns:
        The seconds (NaN for a missing or bad cell) and the bad cells with why.
    """
    out = np.full(len(cells), np.nan)
    bad: list[tuple[int, str]] = []
    seen: dict[str, float | str] = {}  # a drive's rows share a date or two: parse each once
    for i, cell in enumerate(cells):
        if cell is None or _bare(cell).lower() in MISSING_CELLS:
            continue
        text = _bare(cell)
        if text not in seen:
            seen[text] = _date_seconds(text, unit)
        got = seen[text]
        if isinstance(got, str):
            bad.append((i, f"{cell!r} ({got})"))
        else:
            out[i] = got
    return TextTimes(out, bad, None, None)


def _date_seconds(text: str, unit: str) -> float | str:
    """One date's midnight in seconds since 1970, or why it is none."""
    try:
        if unit == DDMMYY:
            number = float(text)
            if not (number.is_integer() and 0 < number < 1_000_000):
                return "six digits ddmmyy"
            n = int(number)
            yy = n % 100
            when = date(1900 + yy if yy >= 80 else 2000 + yy, n // 100 % 100, n // 10_000)
        else:
            when = datetime.strptime(text, unit).date()
    except ValueError as err:
        return str(err)
    return float((when.toordinal() - _EPOCH_ORDINAL) * 86400)


def date_note(date_column: str, time_column: str, unit: str) -> str:
    """What a reader says when it added a date column's dates to the times of day."""
    return (
        f"dates of column {date_column.strip()!r} ({unit}) added to the times of day of "
        f"{time_column.strip()!r}: seconds since 1970 as written (no zone applied)"
    )


def text_time_unit(cell: str | None) -> str | None:
    """The text unit a time cell is written in (:data:`TEXT_TIME_UNITS`), or None."""
    if cell is None:
        return None
    if _ISO.match(_bare(cell)):
        return ISO8601
    if _CLOCK.match(_bare(cell)):
        return CLOCK
    return None


def _bare(cell: str) -> str:
    """A cell without the spaces and quotes around it."""
    return cell.strip().strip('"')


def text_time_note(column: str, unit: str) -> str:
    """What a reader says when it read the time column as text."""
    said = "seconds since 1970 (UTC)" if is_dated(unit) else "h*3600 + m*60 + s"
    return f"time column {column.strip()!r} written as text ({unit}): read as {said}"


@dataclass(frozen=True)
class TextTimes:
    """A text time column parsed (:func:`parse_text_times`).

    Attributes:
        seconds: float64 seconds (NaN for a missing time and for a bad cell).
        bad: the 0-based positions of the cells not of the unit's form, each with why.
        mixed: the 0-based position of the first ISO 8601 cell whose zone offset is given
            where the first time's is not, or the other way round (None: all agree).
        zoned: whether the first ISO 8601 time gave its offset (None: no such cell).
    """

    seconds: np.ndarray
    bad: list[tuple[int, str]]
    mixed: int | None
    zoned: bool | None


def parse_text_times(
    cells: Sequence[str | None], unit: str, zoned: bool | None = None
) -> TextTimes:
    """Text times as seconds.

    Args:
        cells: the column's cells in row order (None: an empty cell).
        unit: :data:`ISO8601` or :data:`CLOCK`.
        zoned: whether the column's first time, in an earlier block, gave its zone offset
            (None: it is in ``cells``).
    """
    if is_pattern(unit):
        return _parse_pattern(cells, unit)
    out = np.full(len(cells), np.nan)
    bad: list[tuple[int, str]] = []
    days: dict[tuple[str, str, str], int] = {}
    first_zoned: bool | None = zoned
    mixed: int | None = None
    pattern = _ISO if unit == ISO8601 else _CLOCK
    for i, cell in enumerate(cells):
        if cell is None or _bare(cell).lower() in MISSING_CELLS:
            continue
        m = pattern.match(_bare(cell))
        if m is None:
            bad.append((i, repr(cell)))
            continue
        if unit == CLOCK:
            h, mi, s = m.group(1), m.group(2), m.group(3)
            seconds = float(s.replace(",", "."))
            if int(mi) >= 60 or seconds >= 60.0:
                bad.append((i, f"{cell!r} (minutes and seconds are below 60)"))
                continue
            out[i] = int(h) * 3600 + int(mi) * 60 + seconds
            continue
        y, mo, d, h, mi, s, z, sign, oh, om = m.groups()
        key = (y, mo, d)
        if key not in days:
            try:
                days[key] = date(int(y), int(mo), int(d)).toordinal() - _EPOCH_ORDINAL
            except ValueError:
                bad.append((i, f"{cell!r} (no such date)"))
                continue
        seconds = float(s.replace(",", "."))
        if int(h) >= 24 or int(mi) >= 60 or seconds >= 61.0:  # 60.x: a leap second
            bad.append((i, f"{cell!r} (hours below 24, minutes and seconds below 60)"))
            continue
        offset = 0
        if sign is not None:
            if int(oh) >= 24 or int(om or 0) >= 60:
                bad.append((i, f"{cell!r} (a zone offset of at most 23:59)"))
                continue
            offset = (1 if sign == "+" else -1) * (int(oh) * 3600 + int(om or 0) * 60)
        zoned = z is not None or sign is not None
        if first_zoned is None:
            first_zoned = zoned
        elif zoned != first_zoned and mixed is None:
            mixed = i
        out[i] = days[key] * 86400 + int(h) * 3600 + int(mi) * 60 - offset + seconds
    return TextTimes(out, bad, mixed, first_zoned)


_EPOCH_ORDINAL = date(1970, 1, 1).toordinal()


def _parse_pattern(cells: Sequence[str | None], pattern: str) -> TextTimes:
    """Text times read by a ``strptime`` pattern (see the module's docstring)."""
    out = np.full(len(cells), np.nan)
    bad: list[tuple[int, str]] = []
    dated = any(d in pattern for d in _DATE_DIRECTIVES)
    fmt = pattern.replace(",", ".")
    for i, cell in enumerate(cells):
        if cell is None or _bare(cell).lower() in MISSING_CELLS:
            continue
        try:
            when = datetime.strptime(_bare(cell).replace(",", "."), fmt)
        except ValueError as err:
            bad.append((i, f"{cell!r} ({err})"))
            continue
        if not dated:
            seconds = when.hour * 3600 + when.minute * 60 + when.second
            out[i] = seconds + when.microsecond * 1e-6
        elif when.tzinfo is not None:
            out[i] = when.timestamp()
        else:
            out[i] = (when - _NAIVE_EPOCH).total_seconds()
    return TextTimes(out, bad, None, None)


def check_text_times(
    parsed: TextTimes,
    cells: Sequence[str | None],
    file: str,
    column: str,
    unit: str,
    first_row: int,
) -> None:
    """Refuse a text time column's bad cells, naming the file's rows.

    Args:
        parsed: :func:`parse_text_times` of ``cells``.
        cells: the column's cells.
        file: the file as the user knows it.
        column: the time column's name in the file.
        unit: the declared (or detected) text unit.
        first_row: the 1-based data row of the first cell.

    Raises:
        InputError: every cell not of ``unit``'s form, and the first whose zone differs.
    """
    problems: list[Problem] = []
    if parsed.bad:
        tally = RowTally(
            file,
            column,
            expected(unit),
            f"write every time in the form of the first rows ({unit}), or write the times "
            "as seconds",
        )
        tally.add([first_row + i for i, _ in parsed.bad], [why for _, why in parsed.bad])
        problems += tally.problems()
    if parsed.mixed is not None:
        cell = cells[parsed.mixed]
        problems.append(
            Problem(
                file,
                first_row + parsed.mixed,
                column,
                "a zone offset (Z, +01:00) in every row or in none",
                f"{cell!r}, where the first time " + ("has none" if _zoned(cell) else "has one"),
                "write the times in one zone (or every one with its offset)",
            )
        )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) reading {file}")


def check_dates(
    parsed: TextTimes, file: str, column: str, unit: str, first_row: int, setting: str
) -> None:
    """Refuse a date column's bad cells (:func:`parse_dates`), naming the file's rows.

    Args:
        parsed: the parsed column.
        file: the file as the user knows it.
        column: the date column's name in the file.
        unit: its unit.
        first_row: the 1-based data row of the first cell.
        setting: where the unit is declared (``data.column_maps.<name>.date.unit``).

    Raises:
        InputError: every cell that is no date of ``unit``'s form.
    """
    if not parsed.bad:
        return
    tally = RowTally(
        file,
        column,
        date_expected(unit),
        f"write every date in the form {setting} declares ({unit}), or correct it",
    )
    tally.add([first_row + i for i, _ in parsed.bad], [why for _, why in parsed.bad])
    raise InputError(tally.problems(), summary=f"dates in {file} not of the form {unit!r}")


def _zoned(cell: str | None) -> bool:
    m = _ISO.match(_bare(cell or ""))
    return bool(m and (m.group(7) is not None or m.group(8) is not None))


def read_time_column(
    path: Path,
    n_columns: int,
    pos: int,
    column: str,
    unit: str,
    file: str,
    blank_rows: np.ndarray | None = None,
) -> np.ndarray:
    """A CSV file's text time column as seconds (after the numeric columns were read).

    Args:
        path: the CSV file (header row first).
        n_columns: columns of its header.
        pos: the time column's 0-based position.
        column: its name in the file (for messages).
        unit: :data:`ISO8601` or :data:`CLOCK`.
        file: how the file is named in error reports.
        blank_rows: data rows (1-based) read as empty: the header's line again
            (:func:`rwhonet.data.csvio.read_numeric_rows`).

    Returns:
        float64 seconds, one per data row (NaN for an empty cell).

    Raises:
        InputError: every cell not of ``unit``'s form, and a zone given in some rows only.
    """
    from rwhonet.data.csvio import read_text_column

    if blank_rows is None:
        cells = read_text_column(path, n_columns, pos, file)
    else:
        cells = read_text_column(path, n_columns, pos, file, blank_rows)
    parsed = parse_text_times(cells, unit)
    check_text_times(parsed, cells, file, column, unit, 1)
    return parsed.seconds


def declared_text_unit(
    unit: str | None, cell: str | None, column: str, where: str, file: str
) -> str | None:
    """The text unit of a CSV time column, None for numbers.

    Args:
        unit: the unit a map declares for it (None: no map, an IO-VNBD file: the form
            ``cell`` shows).
        cell: the column's first non-empty cell (:func:`rwhonet.data.csvio.first_cell`).
        column: the column's name in the file.
        where: the map's setting, for messages (``data.column_maps.<name>.t.unit``).
        file: how the file is named in error reports.

    Raises:
        InputError: the map declares a number unit (s, ms) and ``cell`` is text of a known
            form; the message says which unit to declare.
    """
    if is_text_unit(unit):
        return unit
    found = text_time_unit(cell)
    if found is None or unit is None:
        return found
    raise InputError(
        [
            Problem(
                file,
                None,
                column.strip(),
                f"times in {unit} ({where})",
                f"times written as text: {cell!r}",
                f"set {where} to {found!r}",
            )
        ]
    )


class LocalTimeUnclear(ValueError):
    """A local wall time a zone's change of summer time makes two instants or none.

    Attributes:
        found: what the time is (``2024-10-27T02:30:00 in Europe/Berlin, in the hour its
            clocks went back: UTC+2 or UTC+1``).
        fix: how to say which offset the clock kept.
    """

    def __init__(self, found: str, fix: str) -> None:
        super().__init__(found)
        self.found, self.fix = found, fix


def local_to_unix(wall: datetime, zone: str) -> float:
    """A wall time (naive) on a clock kept in the IANA ``zone``, as Unix seconds.

    Raises:
        LocalTimeUnclear: ``wall`` is in the hour ``zone``'s clocks went back (two
            instants) or skipped (none).
    """
    from zoneinfo import ZoneInfo

    tz = ZoneInfo(zone)
    first, second = (wall.replace(tzinfo=tz, fold=k) for k in (0, 1))
    if first.utcoffset() == second.utcoffset():
        return first.timestamp()
    offsets = [_utc_offset(t.utcoffset()) for t in (first, second)]
    fixed = [z for z in (_fixed_zone(t.utcoffset()) for t in (first, second)) if z]
    say = f"{wall.isoformat()} in {zone}"
    if datetime.fromtimestamp(first.timestamp(), tz).replace(tzinfo=None) == wall:
        found = f"{say}, in the hour its clocks went back: {offsets[0]} or {offsets[1]}"
    else:
        found = f"{say}, in the hour its clocks skipped: no such time there"
    fix = (
        "give local_zone as the fixed offset the logger's clock kept then: "
        + " or ".join(f"{z} ({o})" for z, o in zip(fixed, offsets, strict=True))
        if len(fixed) == 2
        else "give the log with its start on UTC"
    )
    raise LocalTimeUnclear(found, fix)


def unclear_start(file: str, row: int | None, column: str | None, err: LocalTimeUnclear) -> Problem:
    """The problem of a log whose start on a local clock :func:`local_to_unix` refused."""
    return Problem(
        file,
        row,
        column,
        "a start the signal map's local_zone puts on one instant of UTC",
        err.found,
        err.fix,
    )


def _utc_offset(offset: timedelta | None) -> str:
    """``UTC+2``, ``UTC+5:30``, ``UTC-3``."""
    minutes = int((offset or timedelta(0)).total_seconds() // 60)
    hours, rest = divmod(abs(minutes), 60)
    return f"UTC{'-' if minutes < 0 else '+'}{hours}" + (f":{rest:02d}" if rest else "")


def _fixed_zone(offset: timedelta | None) -> str | None:
    """The IANA zone of a whole-hour offset from UTC (``Etc/GMT-2`` is UTC+2: POSIX's sign),
    None for another offset."""
    minutes = int((offset or timedelta(0)).total_seconds() // 60)
    if minutes % 60:
        return None
    hours = minutes // 60
    return "Etc/UTC" if hours == 0 else f"Etc/GMT{-hours:+d}"
