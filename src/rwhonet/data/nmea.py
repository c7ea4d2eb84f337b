"""A GNSS receiver's NMEA 0183 log: its fixes as the receiver writes them, one stream.

Many loggers record the CAN bus in one place and the GNSS receiver's serial output in
another, as it comes: a text file of NMEA 0183 sentences (``gps.nmea``; ``gpspipe -r``,
a u-blox or a phone's NMEA logger). Such a file in a ``stream_csv`` drive's folder is
read here as the drive's GNSS stream (:func:`read_nmea`); :mod:`rwhonet.data.streamcsv`
puts it on the stream files' clock.

**Sentences read** (NMEA 0183 v4.10; any talker: ``GP``, ``GN``, ``GL``, ``GA``, ``BD``):

- ``GGA``: UTC time, latitude and longitude (``ddmm.mmmm`` with N/S, E/W), the fix
  quality, the satellites used, the altitude above mean sea level (``height``);
- ``RMC``: UTC time, status (``A`` valid, ``V`` void), latitude and longitude, speed over
  ground in knots (``speed_gnss``, 1 kn = 1852/3600 m/s), course over ground (``heading``,
  degrees true), the UTC date (``ddmmyy``), and from v2.3 a mode letter.

Every other sentence (GSV, GSA, VTG, a receiver's proprietary ``$P...``) is passed over.
Sentences of one epoch (the same UTC time) are one fix: the position, satellites and
altitude from GGA where the epoch has one, speed and course from RMC. A sentence written
again, or written late, joins its epoch wherever it is in the log (the first of two of
one kind is kept, the second counted); the epochs are in the order they first appear,
and out of time order where the log was, which the resampler's rule puts right
(:mod:`rwhonet.data.sampleorder`).

**A fix that is no fix**: GGA quality 0 (invalid), 6 (estimated: the receiver's own dead
reckoning), 7 (manual input) or 8 (simulation); RMC status ``V``; RMC mode ``E``
(estimated), ``N`` (not valid), ``M`` (manual) or ``S`` (simulator). Such an epoch is
kept, its latitude and longitude missing, as a CSV stream's empty cells are: the
receiver was there and had no fix. Receivers keep writing the last position in some of
these sentences; it is not a measurement, and a label must not take it as one.

**What a log holds besides sentences**: a sentence whose checksum (``*hh``) does not match
its characters is dropped (a byte lost on the serial line), so is a sentence cut short (a
logger that lost power) and one without a UTC time (a receiver still searching); blank
lines, ``#`` comments and bytes that are no text are passed over. The notes count each.

**The clock.** A sentence carries the receiver's UTC time of day, and RMC its date. A line
may also begin with the logger's own stamp before the ``$`` (``1712345678.123 $GPGGA,...``,
``12.345,$GPRMC,...``): where every epoch has one, the stamps are its times on the
logger's clock, as a CSV stream's time column is. Otherwise the UTC times are placed on
the stream files' clock where that clock is UTC too (:func:`on_clock`).

The sentences are parsed here, not by `pynmea2`: it parses one sentence at a time in
Python (with the conversions, 2.4 s for a two-hour 10 Hz log, 0.29 M input rows/s
through the resampler, under the stream readers' 1 M target), and it reads an empty
latitude as 0.0. Here every GGA and RMC sentence's checksum is computed at once and the
fields converted column by column: an empty field is missing, and a field that is no
number is refused with its line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import without_suffix
from rwhonet.data.packed import HHMMSS
from rwhonet.data.texttime import (
    CLOCK,
    DDMMYY,
    expected,
    is_dated,
    is_pattern,
    is_text_unit,
    parse_dates,
    parse_text_times,
)
from rwhonet.data.timebase import unwrap_clock
from rwhonet.errors import InputError, Problem

NMEA_SUFFIXES = (".nmea", ".nma")
KNOT_M_S = 1852.0 / 3600.0
# GGA fix quality (NMEA 0183 v4.10): 1 GPS, 2 DGPS, 3 PPS, 4 RTK fixed, 5 RTK float are
# measurements; 0 invalid, 6 estimated (dead reckoning), 7 manual input, 8 simulation not
GGA_FIXES = (b"1", b"2", b"3", b"4", b"5")
# RMC mode (v2.3+): A autonomous, D differential, P precise, R RTK, F float RTK; E
# estimated, N not valid, M manual, S simulator are none
RMC_FIXES = (b"A", b"D", b"P", b"R", b"F")
GGA_FIELDS = 9  # up to the altitude
RMC_FIELDS = 9  # up to the date
# a logger's stamp before the sentence: separated by spaces, a comma, a semicolon, a tab,
# or in brackets
_STAMP_STRIP = b" \t,;[]()"
_NEW_DAY_S = 12 * 3600.0  # a time of day this far back: the next day


def is_nmea_name(name: str) -> bool:
    """Whether a file's name is an NMEA log's, kept compressed or not (``gps.nmea``,
    ``gps.nmea.gz``)."""
    return without_suffix(name).lower().endswith(NMEA_SUFFIXES)


@dataclass(frozen=True)
class NmeaLog:
    """A receiver's fixes read from an NMEA log, one per epoch, in the log's order.

    Attributes:
        file: the log as messages name it.
        tod_s: each epoch's UTC time of day, s, made continuous across midnight (a day
            added where the time steps back from the day's last hour into the next's first).
        day_s: the first epoch's UTC date as s since 1970 (from RMC), or None (no valid
            RMC gave a date).
        stamps: each epoch's logger stamp as written (the first sentence's), or None
            where not every epoch has one.
        channels: signal-map key (``lat``, ``lon``, ``n_sats``, ``height``,
            ``speed_gnss``, ``heading``) -> values in SI units; only the keys the log
            gives, NaN where an epoch lacks it or has no fix.
        sources: key -> the sentence field it came from (``GGA latitude``).
        rows: each epoch's first sentence's line, 1-based.
        notes: what was passed over or dropped, and midnight.
        dropped: the sentences and lines passed over, counted (empty: none), which
            ``rwhonet predict`` says too.
    """

    file: str
    tod_s: np.ndarray
    day_s: float | None
    stamps: list[str] | None
    channels: dict[str, np.ndarray]
    sources: dict[str, str]
    rows: np.ndarray
    notes: list[str] = field(default_factory=list)
    dropped: str = ""

    @property
    def t_utc_s(self) -> np.ndarray | None:
        """Each epoch's UTC time as s since 1970, where the log gives its date."""
        return None if self.day_s is None else self.day_s + self.tod_s


@dataclass
class _Epoch:
    time: bytes
    row: int
    stamp: bytes | None
    gga: list[bytes] | None = None
    rmc: list[bytes] | None = None


def read_nmea(path: Path, file: str) -> NmeaLog:
    """Read a receiver's GGA and RMC sentences as one fix per epoch.

    The log is scanned line by line for GGA and RMC sentences; their checksums are
    computed over all of them at once (an XOR ``reduceat`` over the bytes) and their
    fields converted column by column (``benchmarks/bench_streams.py`` times a two-hour
    10 Hz log).

    Args:
        path: the NMEA log (text).
        file: how messages name it.

    Raises:
        InputError: no GGA or RMC sentence with a time; a field that is no number or
            outside its range (with its line); dates that contradict each other.
    """
    counts = {"checksum": 0, "cut": 0, "no time": 0, "again": 0, "not text": 0}
    first_bad: dict[str, int] = {}

    def passed(kind: str, row: int) -> None:
        counts[kind] += 1
        first_bad.setdefault(kind, row)

    rows, stamps, bodies, sums = [], [], [], []
    for row, line in enumerate(path.read_bytes().split(b"\n"), start=1):
        at = line.find(b"$")
        if at < 0:
            text = line.strip().strip(b"\x00")
            if text and not text.startswith(b"#"):
                passed("not text", row)
            continue
        kind = line[at + 3 : at + 6]
        if kind != b"GGA" and kind != b"RMC":
            continue
        sentence = line[at + 1 :].rstrip()
        star = sentence.rfind(b"*")
        rows.append(row)
        stamps.append(line[:at].strip(_STAMP_STRIP) or None)
        bodies.append(sentence if star < 0 else sentence[:star])
        sums.append(None if star < 0 else sentence[star + 1 :])
    ok = _checked(bodies, sums, rows, passed)
    epochs: list[_Epoch] = []
    # an epoch's sentences by their UTC time: a sentence written again or late (a logger's
    # buffer sent twice) joins its epoch, wherever it is in the log
    by_time: dict[bytes, _Epoch] = {}
    last: float | None = None
    for i in np.flatnonzero(ok):
        fields = bodies[i].split(b",")
        kind, row = fields[0][2:5], rows[i]
        if len(fields) <= (GGA_FIELDS if kind == b"GGA" else RMC_FIELDS):
            passed("cut", row)  # a line cut short
            continue
        time = fields[1].strip()
        if not time:
            passed("no time", row)
            continue
        epoch = by_time.get(time)
        if epoch is None:
            now = _quick_time_of_day(time)
            if now is not None and last is not None and last - now > _NEW_DAY_S:
                by_time.clear()  # past midnight: the day's times of day come again
            last = now if now is not None else last
            epoch = by_time[time] = _Epoch(time, row, stamps[i])
            epochs.append(epoch)
        slot = "gga" if kind == b"GGA" else "rmc"
        if getattr(epoch, slot) is not None:
            passed("again", row)  # the same epoch's sentence twice: the first kept
            continue
        setattr(epoch, slot, fields[1:])
    if not epochs:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "NMEA 0183 GGA or RMC sentences with a UTC time ($GPGGA, $GNRMC, ...)",
                    "none" + _passed_over(counts, first_bad),
                    "give the receiver's GGA or RMC output, or leave the file out of the drive",
                )
            ]
        )
    return _fixes(epochs, file, counts, first_bad)


def _checked(bodies: list[bytes], sums: list[bytes | None], rows: list[int], passed) -> np.ndarray:
    """Which sentences pass: text (no byte above 127) whose checksum, where it has one, is
    the XOR of its characters between ``$`` and ``*``."""
    n = len(bodies)
    if not n:
        return np.zeros(0, bool)
    lengths = np.fromiter(map(len, bodies), np.int64, n)  # >= 5: the talker and "GGA"
    blob = np.frombuffer(b"".join(bodies), np.uint8)
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    xor = np.bitwise_xor.reduceat(blob, starts)
    text = np.maximum.reduceat(blob, starts) < 128
    ok = np.ones(n, bool)
    for i in range(n):
        given = sums[i]
        if not text[i]:
            ok[i] = False
            passed("cut", rows[i])  # bytes that are no text: a line damaged or cut
        elif given is not None:
            try:
                valid = len(given) == 2 and int(given, 16) == xor[i]
            except ValueError:
                valid = False
            if not valid:
                ok[i] = False
                passed("checksum" if len(given) == 2 else "cut", rows[i])
    return ok


def _quick_time_of_day(text: bytes) -> float | None:
    """``hhmmss.ss`` as seconds, or None (checked with its line later)."""
    try:
        return int(text[0:2]) * 3600.0 + int(text[2:4]) * 60.0 + float(text[4:])
    except ValueError:
        return None


def _passed_over(counts: dict[str, int], first: dict[str, int]) -> str:
    said = {
        "checksum": "with a checksum that does not match",
        "cut": "cut short",
        "no time": "without a UTC time",
        "again": "of an epoch already given",
        "not text": "lines that are no sentence",
    }
    parts = [
        f"{n} {said[k]} (first at line {first[k]})"
        if k == "not text"
        else f"{n} sentence(s) {said[k]} (first at line {first[k]})"
        for k, n in counts.items()
        if n
    ]
    return f" ({'; '.join(parts)})" if parts else ""


MAX_PROBLEMS = 20  # cells of one column listed in a report


def _table(sentences: list[list[bytes]], width: int) -> np.ndarray:
    """The sentences' first ``width`` fields as one array (``b""`` where a sentence is
    shorter), stripped: column ``j`` is field ``j``."""
    padded = [f[:width] if len(f) >= width else f + [b""] * (width - len(f)) for f in sentences]
    return np.char.strip(np.array(padded, dtype=np.bytes_))


def _numbers(
    cells: np.ndarray, rows: np.ndarray, what: str, file: str, problems: list[Problem]
) -> np.ndarray:
    """Cells as numbers: NaN where empty; a problem for each that is no finite number."""
    empty = cells == b""
    filled = np.where(empty, b"nan", cells)
    try:
        values = filled.astype(np.float64)
    except ValueError:
        values = np.array([_float(x) for x in filled], np.float64)
    bad = np.flatnonzero(~empty & ~np.isfinite(values))
    problems += [
        Problem(file, int(rows[i]), what, "a number", repr(cells[i].decode("ascii")))
        for i in bad[:MAX_PROBLEMS]
    ]
    values[bad] = np.nan
    return values


def _float(cell: bytes) -> float:
    try:
        return float(cell)
    except ValueError:
        return math.nan


def _coordinates(
    values: np.ndarray,
    letters: np.ndarray,
    rows: np.ndarray,
    what: str,
    kind: str,
    file: str,
    problems: list[Problem],
) -> np.ndarray:
    """Unsigned ``ddmm.mmmm`` with their hemisphere letters as signed degrees."""
    x = _numbers(values, rows, f"{kind} {what}", file, problems)
    degrees = np.floor(x / 100.0)
    minutes = x - 100.0 * degrees
    limit = 90 if what == "latitude" else 180
    signs = (b"N", b"S") if what == "latitude" else (b"E", b"W")
    upper = np.char.upper(letters)
    sign = np.where(upper == signs[0], 1.0, np.where(upper == signs[1], -1.0, np.nan))
    with np.errstate(invalid="ignore"):
        bad = np.isfinite(x) & (
            (x < 0) | (minutes >= 60.0) | (degrees + minutes / 60.0 > limit) | np.isnan(sign)
        )
    problems += [
        Problem(
            file,
            int(rows[i]),
            f"{kind} {what}",
            f"an unsigned ddmm.mmmm below {limit} degrees, minutes below 60, and its letter "
            f"({'/'.join(s.decode() for s in signs)})",
            f"{values[i].decode('ascii')!r} {letters[i].decode('ascii')!r}",
        )
        for i in np.flatnonzero(bad)[:MAX_PROBLEMS]
    ]
    out = sign * (degrees + minutes / 60.0)
    out[bad] = np.nan
    return out


def _fixes(
    epochs: list[_Epoch], file: str, counts: dict[str, int], first: dict[str, int]
) -> NmeaLog:
    """The epochs' fields as channels, converted column by column."""
    n = len(epochs)
    problems: list[Problem] = []
    rows = np.array([e.row for e in epochs], dtype=np.int64)
    tod = np.array([_time_of_day(e.time, e.row, file, problems) for e in epochs])
    lat, lon = np.full(n, np.nan), np.full(n, np.nan)
    sats, height = np.full(n, np.nan), np.full(n, np.nan)
    speed, course = np.full(n, np.nan), np.full(n, np.nan)
    valid = np.ones(n, bool)
    g_at = np.array([i for i, e in enumerate(epochs) if e.gga is not None], np.int64)
    r_at = np.array([i for i, e in enumerate(epochs) if e.rmc is not None], np.int64)
    if g_at.size:
        g = _table([epochs[i].gga for i in g_at], 10).T
        g_rows = rows[g_at]
        valid[g_at] &= np.isin(g[5], GGA_FIXES)
        lat[g_at] = _coordinates(g[1], g[2], g_rows, "latitude", "GGA", file, problems)
        lon[g_at] = _coordinates(g[3], g[4], g_rows, "longitude", "GGA", file, problems)
        sats[g_at] = _numbers(g[6], g_rows, "GGA satellites", file, problems)
        metres = np.isin(np.char.upper(g[9]), [b"M", b""])
        alt = _numbers(g[8], g_rows, "GGA altitude", file, problems)
        height[g_at] = np.where(metres, alt, np.nan)
    date_cells: list[str | None] = [None] * n
    if r_at.size:
        r = _table([epochs[i].rmc for i in r_at], 12).T
        r_rows = rows[r_at]
        mode = np.char.upper(r[11])
        r_valid = (np.char.upper(r[1]) == b"A") & ((mode == b"") | np.isin(mode, RMC_FIXES))
        valid[r_at] &= r_valid
        alone = np.array([epochs[i].gga is None for i in r_at], bool)
        if alone.any():
            rows_alone, at = r_rows[alone], r_at[alone]
            lat[at] = _coordinates(
                r[2][alone],
                r[3][alone],
                rows_alone,
                "latitude",
                "RMC",
                file,
                problems,
            )
            lon[at] = _coordinates(
                r[4][alone],
                r[5][alone],
                rows_alone,
                "longitude",
                "RMC",
                file,
                problems,
            )
        knots = _numbers(r[6], r_rows, "RMC speed", file, problems)
        cog = _numbers(r[7], r_rows, "RMC course", file, problems)
        speed[r_at] = np.where(r_valid, knots * KNOT_M_S, np.nan)
        course[r_at] = np.where(r_valid, cog, np.nan)
        dates = r[8]
        for i, d, ok in zip(r_at, dates, r_valid, strict=True):
            if ok and d:
                date_cells[i] = d.decode("ascii")
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    lat[~valid] = np.nan
    lon[~valid] = np.nan
    tod, said = unwrap_clock(tod, "epoch")
    notes = [f"{file}: {s}" for s in said]
    day = _first_day(date_cells, tod, rows, file)
    channels = {
        "lat": lat,
        "lon": lon,
        "n_sats": sats,
        "height": height,
        "speed_gnss": speed,
        "heading": course,
    }
    sources = {
        "lat": "GGA latitude",
        "lon": "GGA longitude",
        "n_sats": "GGA satellites",
        "height": "GGA altitude",
        "speed_gnss": "RMC speed",
        "heading": "RMC course",
    }
    if not g_at.size:
        sources |= {"lat": "RMC latitude", "lon": "RMC longitude"}
    given = {k: v for k, v in channels.items() if np.isfinite(v).any() or k in ("lat", "lon")}
    stamps = [e.stamp for e in epochs]
    notes.append(
        f"{file}: an NMEA log: {n} epochs ({g_at.size} GGA, {r_at.size} RMC "
        f"sentences), {int(np.isfinite(lat).sum())} with a fix"
        + _passed_over(counts, first).replace(" (", ", passed over: (", 1)
    )
    return NmeaLog(
        file,
        tod,
        day,
        None if any(x is None for x in stamps) else [x.decode("ascii", "replace") for x in stamps],
        {k: np.ascontiguousarray(v) for k, v in given.items()},
        {k: sources[k] for k in given},
        rows,
        notes,
        _passed_over(counts, first)[2:-1],  # " (...)" without its brackets
    )


def _time_of_day(text: bytes, row: int, file: str, problems: list[Problem]) -> float:
    """``hhmmss.ss`` as seconds since midnight (NaN and a problem where it is none)."""
    t = text.strip()
    try:
        h, m, s = int(t[0:2]), int(t[2:4]), float(t[4:])
        ok = len(t) >= 6 and t[:4].isdigit() and h < 24 and m < 60 and 0 <= s < 61
    except ValueError:
        ok = False
    if not ok:
        shown = repr(t.decode("ascii", "replace"))
        problems.append(Problem(file, row, "UTC time", "a time of day as hhmmss.ss", shown))
        return math.nan
    return h * 3600.0 + m * 60.0 + s


def _first_day(
    cells: list[str | None], tod: np.ndarray, rows: np.ndarray, file: str
) -> float | None:
    """The first epoch's UTC date (s since 1970) from the valid RMC dates, checked to agree.

    Each dated epoch gives the date of the log's first day (its date less the days the
    time of day was carried across midnight); they must all give one.
    """
    at = [i for i, c in enumerate(cells) if c is not None]
    if not at:
        return None
    dates = parse_dates([cells[i] for i in at], DDMMYY)
    if dates.bad:
        i, why = dates.bad[0]
        raise InputError([Problem(file, int(rows[at[i]]), "RMC date", "a date as ddmmyy", why)])
    days_in = np.floor(tod[at] / 86400.0) * 86400.0
    first = dates.seconds - days_in
    wrong = np.flatnonzero(first != first[0])
    if wrong.size:
        i = int(wrong[0])
        raise InputError(
            [
                Problem(
                    file,
                    int(rows[at[i]]),
                    "RMC date",
                    f"the date of the log's earlier sentences ({cells[at[0]]}, line "
                    f"{int(rows[at[0]])}) carried on by its UTC times",
                    repr(cells[at[i]]),
                    "give the drive one receiver's log, in the order it was written",
                )
            ]
        )
    return float(first[0])


UNIX_FROM_S = 946_684_800.0  # 2000-01-01 UTC: a stream clock in s from here on is Unix time
UNIX_TO_S = 4_102_444_800.0  # 2100-01-01 UTC
UTC_TIME = "utc"  # the stream files' clock: s since 1970, UTC
DAY_TIME = "day"  # a time of day (s since a midnight)
_HOUR_S = 3600.0


def clock_kind(unit: str, dated: bool, t_s: Sequence[np.ndarray]) -> str | None:
    """What the stream files' clock is, against UTC.

    Args:
        unit: the signal map's ``t`` unit.
        dated: whether the map has a ``date`` column beside the time.
        t_s: the stream files' times, s (as read, after the date).

    Returns:
        :data:`UTC_TIME`: a date and time (ISO 8601 text, a ``strptime`` pattern with a
        date, a ``date`` column, or seconds between 2000 and 2100, Unix time);
        :data:`DAY_TIME`: a time of day (``hhmmss``, ``hh:mm:ss``, a pattern without a
        date); None: a clock of the logger's own (seconds since it started).
    """
    if dated or is_dated(unit):
        return UTC_TIME
    if unit in (HHMMSS, CLOCK) or is_pattern(unit):
        return DAY_TIME
    firsts = [float(np.nanmin(t)) for t in t_s if np.isfinite(t).any()]
    if firsts and all(UNIX_FROM_S <= f < UNIX_TO_S for f in firsts):
        return UTC_TIME
    return None


def on_clock(
    log: NmeaLog, unit: str, dated: bool, t_s: Sequence[np.ndarray], name: str
) -> tuple[np.ndarray, str, str]:
    """A log's epochs on the stream files' clock.

    Where every epoch has the logger's stamp (and the map has no ``date`` column, which a
    stamp lacks), the stamps are the times, read in the map's ``t`` unit as a time
    column's cells. Otherwise the receiver's UTC times are placed: on a UTC clock with
    the RMC date (a log without one takes the day that puts its first fix nearest the
    stream files' start), on a time-of-day clock as they are, and on seconds below two
    days (IO-VNBD's time of day) where the receiver's times of day cover at least half of
    the stream files' span.

    Args:
        log: the receiver's fixes.
        unit: the signal map's ``t`` unit.
        dated: whether the map has a ``date`` column.
        t_s: the stream files' times, s.
        name: how messages name the map.

    Returns:
        ``(times, what the times are, a note)``.

    Raises:
        InputError: a stamp not in the unit; a clock of the logger's own with unstamped
            sentences; fixes that share no time with the stream files.
    """
    if log.stamps is not None and not dated:
        t = _stamps(log, unit, name)
        t, said = unwrap_clock(t, "epoch")
        note = f"{log.file}: each sentence's logger stamp is its time on the stream files' clock"
        return _shared(log, t, t_s, "stamp"), "logger stamp", "; ".join([note, *said])
    kind = clock_kind(unit, dated, t_s)
    if kind is None and _seconds_of_a_day(log.tod_s, t_s):
        note = (
            f"{log.file}: the stream files' times, below a day, read as UTC seconds of the "
            "day (as IO-VNBD's): the receiver's UTC times fall within them"
        )
        return log.tod_s, "UTC time", note
    if kind is None:
        raise InputError(
            [
                Problem(
                    log.file,
                    None,
                    None,
                    "a clock the receiver's UTC times can be placed on: the logger's stamp "
                    "before each sentence, or the stream files' times in UTC (a time of day "
                    "as hhmmss, hh:mm:ss; iso8601; a date column; Unix seconds)",
                    f"sentences without stamps, and the stream files' time in {unit!r} "
                    "counting from the logger's start",
                    f"have the logger stamp each sentence, or log {name}.t in UTC",
                )
            ]
        )
    if kind == DAY_TIME:
        note = f"{log.file}: the receiver's UTC times of day, on the stream files' time of day"
        return _shared(log, log.tod_s, t_s, "utc"), "UTC time", note
    if log.day_s is not None:
        note = f"{log.file}: the receiver's UTC times and RMC dates, on the stream files' UTC"
        return _shared(log, log.day_s + log.tod_s, t_s, "utc"), "UTC time", note
    start = min(float(np.nanmin(t)) for t in t_s if np.isfinite(t).any())
    day = round((start - log.tod_s[0]) / 86400.0) * 86400.0
    note = (
        f"{log.file}: the receiver's UTC times, on the stream files' UTC; no RMC date, so the "
        "day is the one that puts the first fix nearest the stream files' start"
    )
    return _shared(log, day + log.tod_s, t_s, "utc"), "UTC time", note


def _seconds_of_a_day(tod: np.ndarray, t_s: Sequence[np.ndarray]) -> bool:
    """Whether stream files' times in s are seconds of the day: all below two days (a
    drive across midnight), and the receiver's times of day cover at least half of their
    span (a logger's own clock from its start almost never falls so)."""
    spans = [(float(np.nanmin(x)), float(np.nanmax(x))) for x in t_s if np.isfinite(x).any()]
    if not spans or not np.isfinite(tod).any():
        return False
    c, d = min(a for a, _ in spans), max(b for _, b in spans)
    if c < 0 or d >= 2 * 86400.0 or d <= c:
        return False
    shared = min(d, float(np.nanmax(tod))) - max(c, float(np.nanmin(tod)))
    return shared >= 0.5 * (d - c)


def _stamps(log: NmeaLog, unit: str, name: str) -> np.ndarray:
    """The logger's stamps in s, read in the map's ``t`` unit."""
    cells = log.stamps or []
    problems = []
    if is_text_unit(unit):
        parsed = parse_text_times(cells, unit)
        t = parsed.seconds
        problems = [
            Problem(log.file, int(log.rows[i]), "logger stamp", expected(unit), why)
            for i, why in parsed.bad[:20]
        ]
    else:
        t = np.full(len(cells), np.nan)
        for i, cell in enumerate(cells):
            try:
                t[i] = float(cell)
            except ValueError:
                if len(problems) < 20:
                    problems.append(
                        Problem(
                            log.file,
                            int(log.rows[i]),
                            "logger stamp",
                            f"a time in {unit!r} ({name}.t.unit), as the stream files' times",
                            repr(cell),
                        )
                    )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {log.file}")
    if is_text_unit(unit):
        return t
    from rwhonet.data.signalmap import to_si  # signalmap reads stream files; it imports us

    return to_si("t", t, unit, None, log.file, (log.file, "logger stamp"))


def _shared(log: NmeaLog, t: np.ndarray, t_s: Sequence[np.ndarray], how: str) -> np.ndarray:
    """The log's times, refused where they share no time with the stream files'."""
    spans = [(float(np.nanmin(x)), float(np.nanmax(x))) for x in t_s if np.isfinite(x).any()]
    if not spans or not np.isfinite(t).any():
        return t
    a, b = float(np.nanmin(t)), float(np.nanmax(t))
    c, d = min(s for s, _ in spans), max(e for _, e in spans)
    if a <= d and c <= b:
        return t
    offset = a - c
    hours = offset / _HOUR_S
    zone = (
        abs(offset) <= 14 * _HOUR_S
        and abs(offset - round(offset / 900.0) * 900.0) <= 60.0
        and round(offset / 900.0) != 0
    )
    hint = (
        f"; the stream files' clock starts {abs(hours):.2f} h "
        f"{'behind' if offset > 0 else 'ahead of'} the receiver's UTC: a local time?"
        if zone and how == "utc"
        else ""
    )
    raise InputError(
        [
            Problem(
                log.file,
                None,
                None,
                f"fixes during the stream files' times ({c:.3f} to {d:.3f} s)",
                f"fixes from {a:.3f} to {b:.3f} s ({'logger stamps' if how == 'stamp' else 'UTC'})"
                + hint,
                "log the stream files' times in UTC, or stamp each sentence with the logger's clock"
                if how == "utc"
                else "give the drive the receiver's log of the same drive",
            )
        ]
    )
