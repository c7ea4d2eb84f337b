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
  degrees true), the UTC date (``ddmmyy``), and from v2.3 a mode letter;
- ``GNS`` (v3.0+; the multi-constellation fix some receivers send in place of GGA): UTC
  time, latitude and longitude, a mode letter per constellation (``AN``: GPS autonomous,
  GLONASS none), the satellites used, the altitude above mean sea level in metres;
- ``GLL``: latitude and longitude, UTC time, status and, from v2.3, a mode letter;
- ``ZDA``: UTC time and date (day, month, four-digit year), no fix: its date dates the
  epoch of its time (a receiver set to GGA and ZDA, as survey and RTK receivers often
  are, gives no RMC), checked against the RMC dates where both come.
- ``VTG``: course over ground (degrees true), speed over ground in knots and in km/h,
  from v2.3 a mode letter; no time: it is the epoch's it is written with
  (:func:`_vtg_epochs`).
- ``GST``: UTC time, the range residuals' RMS, the error ellipse, then the standard
  deviations of the latitude and longitude errors (m) and of the altitude's; no fix: it
  gives the epoch of its time ``h_acc``, the root of the sum of the squares of the
  latitude's and longitude's (the DRMS, m), as ZDA dates it (empty: none stated; one
  of a time no fix has gives none).

- ``GSA``: the fix type (1 none, 2 2D, 3 3D) and the ids of the satellites used in the
  fix, up to 12 (a multi-GNSS receiver writes one for each constellation); no time: it is
  the epoch's it is written with (:func:`_gsa_epochs`), and gives the satellites of an
  epoch without a GGA or GNS (a receiver set to RMC and GSA) as the sum of its GSAs'.

Every other sentence (GSV, a receiver's proprietary ``$P...``) is passed over.
Sentences of one epoch (the same UTC time) are one fix: the position from GGA where the
epoch has one, else GNS, RMC, GLL; satellites and altitude from GGA, else GNS
(satellites else GSA); speed and course from RMC, else VTG; the stated accuracy from
GST. A sentence written again, or written late, joins its epoch wherever it is in the
log (the first of two of one kind is kept, the second counted); the epochs are in the
order they first appear, and out of time order where the log was, which the resampler's
rule puts right (:mod:`rwhonet.data.sampleorder`).

**A fix that is no fix**: GGA quality 0 (invalid), 6 (estimated: the receiver's own dead
reckoning), 7 (manual input) or 8 (simulation); RMC or GLL status ``V``; RMC or GLL mode
``E`` (estimated), ``N`` (not valid), ``M`` (manual) or ``S`` (simulator); a GNS whose
mode letters are all of these (GNS's last field, the navigational status, is left alone:
u-blox writes it ``V``, "not providing navigational status", beside every fix). An epoch
with any sentence so is no fix. Such an epoch is
kept, its latitude and longitude missing, as a CSV stream's empty cells are: the
receiver was there and had no fix. Receivers keep writing the last position in some of
these sentences; it is not a measurement, and a label must not take it as one.

**What a log holds besides sentences**: a sentence whose checksum (``*hh``) does not match
its characters is dropped (a byte lost on the serial line), so is a sentence cut short (a
logger that lost power) and one without a UTC time (a receiver still searching); blank
lines, ``#`` comments and bytes that are no text are passed over. The notes count each.

**The clock.** A sentence carries the receiver's UTC time of day, and RMC and ZDA its date. A line
may also begin with the logger's own stamp before the ``$`` (``1712345678.123 $GPGGA,...``,
``12.345,$GPRMC,...``): where every epoch has one, the stamps are its times on the
logger's clock, as a CSV stream's time column is. Otherwise the UTC times are placed on
the stream files' clock where that clock is UTC too (:func:`on_clock`). A receiver
started without the leap seconds gives UTC whole seconds ahead until it decodes them
from the navigation message, then steps back: the times before such a step are moved
back (:func:`_leap_step`, which tells it from a clock set back or a buffer sent twice).

The sentences are parsed here, not by `pynmea2`: it parses one sentence at a time in
Python (with the conversions, 2.4 s for a two-hour 10 Hz log, 0.29 M input rows/s
through the resampler, under the stream readers' 1 M target), and it reads an empty
latitude as 0.0. Here the log's lines are found and every fix sentence's checksum
computed over its bytes at once, and the fields converted column by column (0.91 M rows/s;
``benchmarks/bench_streams.py``): an empty field is missing, and a field that is no
number is refused with its line.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from rwhonet.config import ColumnSpec
from rwhonet.data.bytescan import HEX, CommaFields, after, before, floats_or_nan
from rwhonet.data.columnmap import scaled
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
from rwhonet.geo import local_distance_m, local_step_en_m

NMEA_SUFFIXES = (".nmea", ".nma")
KNOT_M_S = 1852.0 / 3600.0
# GGA fix quality (NMEA 0183 v4.10): 1 GPS, 2 DGPS, 3 PPS, 4 RTK fixed, 5 RTK float are
# measurements, and 9, which NovAtel receivers write for a WAAS (SBAS) fix by default
# (NovAtel's "Which NovAtel position types correspond to the GGA quality indicator?");
# 0 invalid, 6 estimated (dead reckoning), 7 manual input, 8 simulation are not
GGA_FIXES = (b"1", b"2", b"3", b"4", b"5", b"9")
# the mode of RMC and GLL (v2.3+) and each of GNS's, one a constellation: A autonomous,
# D differential, P precise, R RTK, F float RTK; E estimated, N not valid, M manual, S
# simulator are none
RMC_FIXES = (b"A", b"D", b"P", b"R", b"F")
# the sentences read, by their code in the scan
KINDS = (b"GGA", b"RMC", b"GNS", b"GLL", b"ZDA", b"VTG", b"GST", b"GSA")
GGA, RMC, GNS, GLL, ZDA, VTG, GST, GSA = range(len(KINDS))
# the sentences that make an epoch (ZDA only dates one, GST only states its accuracy)
FIX_KINDS = (GGA, RMC, GNS, GLL)
# fields a sentence needs (its talker and type the first): up to GGA's and GNS's
# altitude, RMC's date, GLL's status, ZDA's year, VTG's km/h letter, GST's longitude error,
# GSA's VDOP (its fields: mode, fix type, 12 satellites' ids, PDOP, HDOP, VDOP)
FIELDS_NEEDED = np.array([10, 10, 10, 7, 5, 9, 8, 18])
# where each gives the UTC time (GLL after its position; VTG and GSA none)
TIME_FIELD = np.array([1, 1, 1, 5, 1, -1, 1, -1])
# GSA's fix type (1 no fix, 2 2D, 3 3D) and its fields of the satellites used in the fix
GSA_FIX_TYPE = 2
GSA_SATELLITES = range(3, 15)
# GST's standard deviations of the latitude and longitude errors (m), the fields after
# its time, RMS and error ellipse (semi-major, semi-minor, orientation)
GST_ERRORS = (6, 7)
ZDA_DATE = "%d,%m,%Y"  # ZDA's day, month and year fields, as the sentence writes them
# which sentence's position an epoch takes where it has several
POSITION_ORDER = (GGA, GNS, RMC, GLL)
# each kind's first position field: latitude, its letter, longitude, its letter
POSITION_FIELD = {GGA: 2, RMC: 3, GNS: 2, GLL: 1}
# a logger's stamp before the sentence: separated by spaces, a comma, a semicolon, a tab,
# or in brackets
STAMP_STRIP = b" \t\r\n\x0b\x0c,;[]()"  # a serial line's LF CR leaves a CR before the "$"
_NEW_DAY_S = 12 * 3600.0  # a time of day this far back: the next day


def is_nmea_name(name: str) -> bool:
    """Whether a file's name is an NMEA log's, kept compressed or not (``gps.nmea``,
    ``gps.nmea.gz``)."""
    return without_suffix(name).lower().endswith(NMEA_SUFFIXES)


@dataclass(frozen=True)
class ReceiverRates:
    """A receiver's own stream beside its fixes, at its own times: a u-blox dead-reckoning
    receiver's yaw rate (UBX-ESF-INS).

    Attributes:
        tod_s: each sample's UTC time of day, s, on the fixes' day (:attr:`FixLog.day_s`).
        channels: signal-map key (``yaw_rate``) -> values in SI units.
        sources: key -> the message field it came from.
        rows: each sample's message number in the log, 1-based.
        name: the stream as messages name it (``ESF-INS``).
    """

    tod_s: np.ndarray
    channels: dict[str, np.ndarray]
    sources: dict[str, str]
    rows: np.ndarray
    name: str


@dataclass(frozen=True)
class FixLog:
    """A receiver's fixes read from an NMEA log (or a u-blox UBX log:
    :func:`rwhonet.data.ubx.read_ubx`; a GPX track: :func:`rwhonet.data.gpx.read_gpx`), one
    per epoch, in the log's order.

    Attributes:
        file: the log as messages name it.
        tod_s: each epoch's UTC time of day, s, made continuous across midnight (a day
            added where the time steps back from the day's last hour into the next's first).
        day_s: the first epoch's UTC date as s since 1970 (from RMC or ZDA), or None (no
            valid RMC and no ZDA gave a date).
        stamps: each epoch's logger stamp as written (the first sentence's), or None
            where not every epoch has one.
        channels: signal-map key (``lat``, ``lon``, ``n_sats``, ``h_acc``, ``height``,
            ``speed_gnss``, ``heading``) -> values in SI units; only the keys the log
            gives, NaN where an epoch lacks it or has no fix.
        sources: key -> the sentence field it came from (``GGA latitude``).
        rows: each epoch's first sentence's line, 1-based (a UBX log: its NAV-PVT's or
            NAV-POSLLH's number among the log's messages).
        notes: what was passed over or dropped, and midnight.
        dropped: the sentences and lines passed over, counted (empty: none), which
            ``rwhonet predict`` says too.
        unstamped: the lines of the epochs without a logger stamp, where others have one.
        dated_by: what gave the date (``RMC dates``, ``ZDA dates``; a UBX log's ``NAV-PVT dates``,
            ``NAV-TIMEUTC dates``, ``NAV-TIMEGPS weeks``).
        kind: ``NMEA``, ``UBX`` (a binary log: no logger stamps), or ``GPX`` (a track:
            :func:`rwhonet.data.gpx.read_gpx`; UTC times, no logger stamps).
        rates: the receiver's yaw rate where its log gives one (a UBX log's ESF-INS).
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
    unstamped: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dated_by: str = "RMC dates"
    kind: str = "NMEA"
    rates: ReceiverRates | None = None

    @classmethod
    def on_utc(
        cls,
        file: str,
        utc_s: np.ndarray,
        channels: dict[str, np.ndarray],
        sources: dict[str, str],
        rows: np.ndarray,
        notes: list[str],
        dropped: str,
        *,
        dated_by: str,
        kind: str,
        stamps: list[str] | None = None,
        unstamped: np.ndarray | None = None,
    ) -> FixLog:
        """A log whose epochs' times are UTC (s since 1970, a GPX track's, a binary
        receiver log's once on UTC): their times of day on the first epoch's UTC date."""
        day_s = float(np.floor(utc_s[0] / 86400.0) * 86400.0)
        return cls(
            file,
            utc_s - day_s,
            day_s,
            stamps,
            channels,
            sources,
            rows,
            notes,
            dropped,
            np.zeros(0, np.int64) if unstamped is None else unstamped,
            dated_by,
            kind,
        )

    @property
    def t_utc_s(self) -> np.ndarray | None:
        """Each epoch's UTC time as s since 1970, where the log gives its date."""
        return None if self.day_s is None else self.day_s + self.tod_s


def read_nmea(path: Path | bytes, file: str) -> FixLog:
    """Read a receiver's GGA, RMC, GNS and GLL sentences as one fix per epoch.

    The fix sentences are found and checked over the log's bytes at once
    (:func:`_scan`), gathered into epochs by their UTC time, and their fields converted
    column by column (:class:`CommaFields`).

    Args:
        path: the NMEA log (text), or its bytes (a UBX log's without its binary messages:
            :mod:`rwhonet.data.ubx`).
        file: how messages name it.

    Raises:
        InputError: no fix sentence with a time; a field that is no number or
            outside its range (with its line); dates that contradict each other.
    """
    counts = {
        "checksum": 0,
        "long": 0,
        "cut": 0,
        "no time": 0,
        "again": 0,
        "no epoch": 0,
        "not text": 0,
    }
    first_bad: dict[str, int] = {}

    def passed(kind: str, rows: Sequence[int]) -> None:
        if len(rows):
            counts[kind] += len(rows)
            first_bad[kind] = min(first_bad.get(kind, rows[0]), int(np.min(rows)))

    data = path if isinstance(path, bytes) else path.read_bytes()
    if b"\n" not in data:  # line ends of CR alone (a classic Mac's, some serial loggers')
        data = data.replace(b"\r", b"\n")
    found = _scan(data)
    passed("not text", found.not_text)
    for kind, at in found.passed.items():
        passed(kind, at)
    kept = np.flatnonzero(found.ok)
    rows, kinds = found.rows, found.kind[kept]
    spans = list(zip(found.body[0][kept].tolist(), found.body[1][kept].tolist(), strict=True))
    bodies = [data[a:b] for a, b in spans]
    head_start, head_end = found.head[0][kept].tolist(), found.head[1][kept].tolist()

    def stamp(i: int) -> bytes | None:  # what stands before sentence i's "$", if anything
        return data[head_start[i] : head_end[i]].strip(STAMP_STRIP) or None

    row_of = rows[kept]
    fields = CommaFields(bodies)
    gll = kinds == GLL
    vtg = kinds == VTG  # no time: it joins an epoch by its place in the log (_vtg_epochs)
    gsa = kinds == GSA  # no time either (_gsa_epochs)
    time = fields.column(1)
    if gll.any():
        time = np.where(gll, fields.column(TIME_FIELD[GLL]), time)
    enough = fields.count >= FIELDS_NEEDED[kinds]
    passed("cut", row_of[~enough])  # a line cut short
    passed("no time", row_of[enough & ~vtg & ~gsa & (time == b"")])
    use = np.flatnonzero(enough & ~vtg & ~gsa & (time != b""))
    if not np.isin(kinds[use], FIX_KINDS).any():  # no fix sentence (ZDA alone dates none)
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "NMEA 0183 GGA, RMC, GNS or GLL sentences with a UTC time ($GPGGA, "
                    "$GNRMC, ...)",
                    "none" + _passed_over(counts, first_bad),
                    "give the receiver's GGA, RMC, GNS or GLL output, or leave the file out "
                    "of the drive",
                )
            ]
        )
    return _fixes(
        fields,
        use,
        time[use],
        row_of,
        kinds,
        stamp,
        file,
        counts,
        first_bad,
        passed,
        np.flatnonzero(enough & vtg),
        np.flatnonzero(enough & gsa),
    )


@dataclass(frozen=True)
class _Found:
    """The fix sentences of a log (:func:`_scan`), in the log's order.

    Attributes:
        rows: each sentence's line, 1-based.
        kind: what it is, an index into :data:`KINDS`.
        head: (start, end) of what stands before its ``$`` (a logger's stamp).
        body: (start, end) of its characters between ``$`` and ``*`` (or the line's end).
        ok: whether it is text of a sentence's length whose checksum, where it has one,
            matches.
        passed: kind -> the lines of the sentences that are not ``ok``, and why.
        not_text: lines that are no sentence (no ``$``, not blank, no ``#`` comment).
    """

    rows: np.ndarray
    kind: np.ndarray
    head: tuple[np.ndarray, np.ndarray]
    body: tuple[np.ndarray, np.ndarray]
    ok: np.ndarray
    passed: dict[str, np.ndarray]
    not_text: np.ndarray


_SPACE = np.zeros(256, bool)  # what bytes.rstrip() strips
_SPACE[np.frombuffer(b" \t\r\x0b\x0c", np.uint8)] = True
_BLANK_BYTES = b" \t\r\x0b\x0c\x00"  # what a blank line may hold: spaces, a lost power's NULs


def _scan(data: bytes) -> _Found:
    """Find the fix sentences of a log, and check them, all lines at once.

    A line's sentence begins at its first ``$``; it is one of :data:`KINDS` where the
    three characters after the talker say so. Its checksum is the XOR of its characters
    between ``$`` and the last ``*`` (an ``reduceat`` over the log's bytes), compared with
    the two hex digits after the ``*``; trailing spaces and CR are not the sentence's.
    """
    buf = np.frombuffer(data + b"\n", np.uint8)  # a last line without its line end
    size = buf.size
    ends = np.flatnonzero(buf == ord("\n"))
    starts = np.concatenate([[0], ends[:-1] + 1])
    dollar = after(np.flatnonzero(buf == ord("$")), starts, size)
    sentence = dollar < ends
    not_text = [  # lines without a sentence (few): not blank, no "#" comment
        i + 1
        for i in np.flatnonzero(~sentence).tolist()
        if (text := data[starts[i] : ends[i]].strip(_BLANK_BYTES)) and not text.startswith(b"#")
    ]
    line = np.flatnonzero(sentence)
    at = dollar[line]

    def char(offset: int) -> np.ndarray:
        return buf[np.minimum(at + offset, size - 1)]

    # a talker's two letters, then the type; "$P..." is a maker's own sentence, whatever
    # follows (Garmin's $PGRMC is its sensor configuration, no RMC)
    long_enough = (at + 6 <= ends[line]) & (char(1) != ord("P"))
    kind = np.full(line.size, -1)
    third, fourth, fifth = char(3), char(4), char(5)
    for code, name in enumerate(KINDS):
        kind[long_enough & (third == name[0]) & (fourth == name[1]) & (fifth == name[2])] = code
    keep = kind >= 0
    line, at, kind = line[keep], at[keep], kind[keep]
    end = ends[line]  # without the trailing spaces and CR (bytes.rstrip's)
    while (step := _SPACE[buf[end - 1]] & (end > at + 6)).any():
        end = end - step
    star = before(np.flatnonzero(buf == ord("*")), end)
    starred = star > at
    body_end = np.where(starred, star, end)
    rows = line + 1
    n = line.size
    if n:
        edges = np.column_stack([at + 1, body_end]).ravel()
        xor = np.bitwise_xor.reduceat(buf, edges)[::2]
        text = np.maximum.reduceat(buf, edges)[::2] < 128
    else:
        xor, text = np.zeros(0, np.uint8), np.ones(0, bool)
    digits = end - star - 1
    hi = HEX[buf[np.minimum(star + 1, size - 1)]]
    lo = HEX[buf[np.minimum(star + 2, size - 1)]]
    two = starred & (digits == 2) & (hi >= 0) & (lo >= 0)
    long = body_end - at - 1 > MAX_SENTENCE
    bad_text = ~long & ~text
    cut = ~long & text & starred & ~two
    wrong = ~long & text & two & (hi * 16 + lo != xor)
    return _Found(
        rows,
        kind,
        (starts[line], at),
        (at + 1, body_end),
        ~(long | bad_text | cut | wrong),
        {
            "long": rows[long],
            "cut": rows[bad_text | cut],  # bytes that are no text; a checksum cut short
            "checksum": rows[wrong],
        },
        np.asarray(not_text, np.int64),
    )


def _passed_over(counts: dict[str, int], first: dict[str, int]) -> str:
    said = {
        "checksum": "with a checksum that does not match",
        "long": "longer than a sentence can be (two run together)",
        "cut": "cut short",
        "no time": "without a UTC time",
        "again": "of an epoch already given",
        "no epoch": "(VTG, GSA) whose epoch the log does not hold (at its start or end)",
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
# NMEA 0183 allows 82 characters a sentence; high-precision receivers write a few more. A
# longer one is two run together (a lost line end), or no sentence
MAX_SENTENCE = 120


def _numbers(
    cells: np.ndarray, rows: np.ndarray, what: str, file: str, problems: list[Problem]
) -> np.ndarray:
    """Cells as numbers: NaN where empty; a problem for each that is no finite number."""
    empty = cells == b""
    filled = np.where(empty, b"nan", cells)
    values = floats_or_nan(filled)
    bad = np.flatnonzero(~empty & ~np.isfinite(values))
    problems += [
        Problem(file, int(rows[i]), what, "a number", repr(cells[i].decode("ascii")))
        for i in bad[:MAX_PROBLEMS]
    ]
    values[bad] = np.nan
    return values


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
    fields: CommaFields,
    use: np.ndarray,
    times: np.ndarray,
    rows: np.ndarray,
    kinds: np.ndarray,
    stamp: Callable[[int], bytes | None],
    file: str,
    counts: dict[str, int],
    first: dict[str, int],
    passed,
    vtg: np.ndarray,
    gsa: np.ndarray,
) -> FixLog:
    """The sentences ``use`` (their UTC time cells ``times``) gathered into epochs by UTC
    time, their fields converted column by column: one fix an epoch; a ZDA dates the
    epoch of its time, a GST states its accuracy; a VTG (``vtg``) gives the speed and
    course of the epoch it is written with (:func:`_vtg_epochs`) where that epoch has no
    RMC; the GSAs (``gsa``) the satellites used in the fix of the epoch they are written
    with (:func:`_gsa_epochs`) where that epoch has no GGA or GNS."""
    problems: list[Problem] = []
    tod_s = _times_of_day(times, rows[use], file, problems)
    timed = np.isfinite(tod_s)  # a time that is no time: refused below, with the rest
    use, tod_s = use[timed], tod_s[timed]
    tod_s, leap_said = _leap_step(tod_s, use, kinds, fields, rows, file)
    if not np.isin(kinds[use], FIX_KINDS).any():
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    # an epoch's sentences by their UTC time: a sentence written again or late (a logger's
    # buffer sent twice) joins its epoch wherever it is in the log; a time of day far
    # back from the sentence before is the next day's
    day = np.concatenate([[0], np.cumsum(np.diff(tod_s) < -_NEW_DAY_S)])
    key = day * 86_400_000 + np.round(tod_s * 1000.0).astype(np.int64)
    # no fix: a ZDA dates the epoch of its time, a GST states its accuracy, if there is one
    zda, gst = kinds[use] == ZDA, kinds[use] == GST
    zda_sent, zda_key = use[zda], key[zda]
    gst_sent, gst_key = use[gst], key[gst]
    aside = zda | gst
    use, tod_s, key = use[~aside], tod_s[~aside], key[~aside]
    _, first_at, inverse = np.unique(key, return_index=True, return_inverse=True)
    order = np.argsort(first_at, kind="stable")  # epochs as they first appear
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    epoch_of = rank[inverse.ravel()]
    lead = use[first_at[order]]  # each epoch's first sentence
    n = order.size
    epoch_rows = rows[lead]
    tod = tod_s[first_at[order]]

    def firsts(kind: int) -> tuple[np.ndarray, np.ndarray]:
        """Each epoch's first sentence of a kind: (epochs, sentences)."""
        at = np.flatnonzero(kinds[use] == kind)
        epochs, once = np.unique(epoch_of[at], return_index=True)
        again = np.setdiff1d(np.arange(at.size), once)
        passed("again", rows[use[at[again]]])  # the same epoch's sentence twice
        return epochs, use[at[once]]

    of = {kind: firsts(kind) for kind in FIX_KINDS}
    lat, lon = np.full(n, np.nan), np.full(n, np.nan)
    sats, height = np.full(n, np.nan), np.full(n, np.nan)
    speed, course = np.full(n, np.nan), np.full(n, np.nan)
    valid = np.ones(n, bool)
    placed = np.zeros(n, bool)  # a position from a sentence of an earlier kind
    counted = np.zeros(n, bool)  # satellites and altitude from GGA
    for kind in POSITION_ORDER:
        epochs, sent = of[kind]
        if not epochs.size:
            continue
        name = KINDS[kind].decode()
        kind_rows = rows[sent]
        valid[epochs] &= _valid(kind, fields, sent)
        alone = ~placed[epochs]
        if alone.any():
            j = POSITION_FIELD[kind]
            cells = [fields.column(j + i, sent[alone]) for i in range(4)]
            at = epochs[alone]
            lat[at] = _coordinates(
                cells[0], cells[1], kind_rows[alone], "latitude", name, file, problems
            )
            lon[at] = _coordinates(
                cells[2], cells[3], kind_rows[alone], "longitude", name, file, problems
            )
            placed[at] = True
        if kind in (GGA, GNS):  # satellites and altitude: GGA's, else GNS's
            empty = ~counted[epochs]
            at = epochs[empty]
            counted[at] = True
            sats[at] = _numbers(
                fields.column(7, sent[empty]),
                kind_rows[empty],
                f"{name} satellites",
                file,
                problems,
            )
            alt = _numbers(
                fields.column(9, sent[empty]), kind_rows[empty], f"{name} altitude", file, problems
            )
            if kind == GGA:  # GGA names the altitude's unit; GNS's is metres
                alt[~np.isin(np.char.upper(fields.column(10, sent[empty])), [b"M", b""])] = np.nan
            height[at] = alt
    dated: list[_Dates] = []
    r_at, r_sent = of[RMC]
    if r_at.size:
        r_rows = rows[r_sent]
        r_valid = _valid(RMC, fields, r_sent)
        knots = _numbers(fields.column(7, r_sent), r_rows, "RMC speed", file, problems)
        cog = _numbers(fields.column(8, r_sent), r_rows, "RMC course", file, problems)
        speed[r_at] = np.where(r_valid, knots * KNOT_M_S, np.nan)
        course[r_at] = np.where(r_valid, cog, np.nan)
        dates = fields.column(9, r_sent)
        has = r_valid & (dates != b"")
        dated.append(_Dates("RMC", r_at[has], dates[has], DDMMYY, r_rows[has]))
    if zda_sent.size:
        dated.append(_zda_dates(fields, zda_sent, zda_key, key[first_at[order]], rows))
    vtg_speed, vtg_course = _vtg_velocity(fields, vtg, rows[vtg], file, problems)
    gst_epoch = _epochs_of_keys(gst_key, key[first_at[order]])
    h_acc = _gst_accuracy(fields, gst_sent, gst_epoch, n, rows, file, problems, passed)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    lat[~valid] = np.nan
    lon[~valid] = np.nan
    tod, said = unwrap_clock(tod, "epoch")
    notes = [f"{file}: {s}" for s in said] + ([f"{file}: {leap_said}"] if leap_said else [])
    by_vtg = np.zeros(n, bool)  # speed and course from a VTG: an epoch without an RMC
    if counted.all():  # every epoch's satellites are its GGA's or GNS's: its GSAs unused
        gsa = gsa[:0]
    if vtg.size or gsa.size:
        # each timed sentence's epoch, in the log's order: a ZDA's is that of its time
        zda_epoch = _epochs_of_keys(zda_key, key[first_at[order]])
        timed = np.concatenate([use, zda_sent[zda_epoch >= 0], gst_sent[gst_epoch >= 0]])
        timed_epoch = np.concatenate(
            [epoch_of, zda_epoch[zda_epoch >= 0], gst_epoch[gst_epoch >= 0]]
        )
        sort = np.argsort(timed, kind="stable")
        timed, timed_epoch = timed[sort], timed_epoch[sort]
    if vtg.size:
        v_epoch, v_said = _vtg_epochs(
            vtg,
            timed,
            timed_epoch,
            _Track(lat, lon, tod),
            vtg_speed,
            vtg_course,
        )
        notes += [f"{file}: {v_said}"] if v_said else []
        passed("no epoch", rows[vtg[v_epoch < 0]])
        at = np.flatnonzero(v_epoch >= 0)
        epochs, once = np.unique(v_epoch[at], return_index=True)
        passed("again", rows[vtg[np.setdiff1d(at, at[once])]])
        fill = ~np.isin(epochs, r_at)
        epochs, one = epochs[fill], at[once][fill]
        by_vtg[epochs] = True
        speed[epochs] = np.where(valid[epochs], vtg_speed[one], np.nan)
        course[epochs] = np.where(valid[epochs], vtg_course[one], np.nan)
    by_gsa = np.zeros(n, bool)  # satellites from the GSAs: an epoch without a GGA or GNS
    if gsa.size:
        fixed = valid & np.isfinite(lat)
        g_epoch, g_said = _gsa_epochs(gsa, timed, timed_epoch, fields, fixed)
        notes += [f"{file}: {g_said}"] if g_said else []
        passed("no epoch", rows[gsa[g_epoch < 0]])
        g_sats, again = _gsa_satellites(fields, gsa, g_epoch, n)
        passed("again", rows[gsa[again]])
        by_gsa = ~counted & np.isfinite(g_sats)
        sats[by_gsa] = g_sats[by_gsa]
    first_day, dated_by = _first_day(dated, tod, file)
    channels = {
        "lat": lat,
        "lon": lon,
        "n_sats": sats,
        "h_acc": h_acc,
        "height": height,
        "speed_gnss": speed,
        "heading": course,
    }
    given_by = [KINDS[k].decode() for k in POSITION_ORDER if of[k][0].size]
    sats_kinds = [k for k in (GGA, GNS) if of[k][0].size] or [GGA]
    height_by = KINDS[sats_kinds[0]].decode()
    sats_by = f"{height_by} satellites" + (
        " (GSA's where an epoch has none)" if by_gsa.any() else ""
    )
    if by_gsa.all():
        sats_by = "GSA satellites"
    velocity_by = (
        ("RMC {} (VTG's where an epoch has no RMC)" if r_at.size else "VTG {}")
        if by_vtg.any()
        else "RMC {}"
    )
    sources = {
        "lat": f"{given_by[0]} latitude",
        "lon": f"{given_by[0]} longitude",
        "n_sats": sats_by,
        "h_acc": "GST lat/lon error",
        "height": f"{height_by} altitude",
        "speed_gnss": velocity_by.format("speed"),
        "heading": velocity_by.format("course"),
    }
    given = {k: v for k, v in channels.items() if np.isfinite(v).any() or k in ("lat", "lon")}
    stamps = [stamp(i) for i in lead.tolist()]  # each epoch's first sentence's
    notes.append(
        f"{file}: an NMEA log: {n} epochs ("
        + ", ".join(f"{of[k][0].size} {KINDS[k].decode()}" for k in of if of[k][0].size)
        + (f", {vtg.size} VTG" if vtg.size else "")
        + (f", {gsa.size} GSA" if gsa.size else "")
        + f" sentences), {int(np.isfinite(lat).sum())} with a fix"
        + _zda_said(dated, zda_sent.size)
        + _gst_said(h_acc, gst_sent.size)
        + _passed_over(counts, first).replace(" (", ", passed over: (", 1)
    )
    return FixLog(
        file,
        tod,
        first_day,
        None if any(x is None for x in stamps) else [x.decode("ascii", "replace") for x in stamps],
        {k: np.ascontiguousarray(v) for k, v in given.items()},
        {k: sources[k] for k in given},
        epoch_rows,
        notes,
        _passed_over(counts, first)[2:-1],  # " (...)" without its brackets
        epoch_rows[[x is None for x in stamps]] if any(stamps) else np.zeros(0, np.int64),
        dated_by,
    )


@dataclass(frozen=True)
class _Track:
    """The epochs' positions (degrees, NaN without a fix) and UTC times of day."""

    lat: np.ndarray
    lon: np.ndarray
    tod: np.ndarray


def _vtg_velocity(
    fields: CommaFields, sent: np.ndarray, rows: np.ndarray, file: str, problems: list[Problem]
) -> tuple[np.ndarray, np.ndarray]:
    """The VTG sentences ``sent`` as speed over ground (m/s) and course (degrees true).

    VTG (NMEA 0183 v4.10): course true, ``T``; course magnetic, ``M``; speed in knots,
    ``N``; speed in km/h, ``K``; from v2.3 a mode letter. The speed is the knots' where
    they are given, else the km/h's; a value whose letter is not its unit's is none (as
    GGA's altitude in another unit). A mode ``E``, ``N``, ``M`` or ``S`` is no fix: no speed
    and no course, as RMC's.
    """
    if not sent.size:
        return np.zeros(0), np.zeros(0)

    def letter(j: int, want: bytes) -> np.ndarray:
        return np.char.upper(fields.column(j, sent)) == want

    cog = _numbers(fields.column(1, sent), rows, "VTG course", file, problems)
    knots = _numbers(fields.column(5, sent), rows, "VTG speed (knots)", file, problems)
    kmh = _numbers(fields.column(7, sent), rows, "VTG speed (km/h)", file, problems)
    knots[~letter(6, b"N")] = np.nan
    kmh[~letter(8, b"K")] = np.nan
    speed = np.where(np.isfinite(knots), knots * KNOT_M_S, kmh / 3.6)
    course = np.where(letter(2, b"T"), cog, np.nan)
    modes = np.char.upper(fields.column(9, sent))
    fix = (modes == b"") | np.isin(modes, RMC_FIXES)
    return np.where(fix, speed, np.nan), np.where(fix, course, np.nan)


def _epochs_of_keys(keys: np.ndarray, epoch_keys: np.ndarray) -> np.ndarray:
    """The epoch (an index into ``epoch_keys``) of each key; -1 where no epoch has it."""
    order = np.argsort(epoch_keys)
    at = np.minimum(np.searchsorted(epoch_keys[order], keys), max(order.size - 1, 0))
    hit = epoch_keys[order][at] == keys if order.size else np.zeros(keys.size, bool)
    return np.where(hit, order[at] if order.size else -1, -1)


# the fixes' velocity at an epoch: from the epochs either side, at most this far apart
VELOCITY_SPAN_S = 5.0


def _vtg_epochs(
    vtg: np.ndarray,
    timed: np.ndarray,
    timed_epoch: np.ndarray,
    track: _Track,
    speed: np.ndarray,
    course: np.ndarray,
) -> tuple[np.ndarray, str]:
    """The epoch each VTG sentence is written with (-1: one the log does not hold), and
    a note where the log's order had to tell.

    A VTG carries no time: it belongs to the epoch whose sentences the receiver wrote it
    among. Between two sentences of one epoch (a GGA, VTG, ZDA burst) it is that epoch's.
    Between the last sentence of one epoch and the first of the next (a GGA and VTG
    receiver's; a u-blox's with RMC off begins each epoch with VTG), the order alone
    cannot say which: a receiver writes its epoch's sentences in a fixed order, so every
    such VTG of the log is taken the same way, the one its velocity fits. Its speed and
    course are compared with the fixes' velocity at the epoch before and at the epoch
    after (the central difference of the positions either side), the sum of squared
    differences over the log; the smaller wins, the epoch before where they are equal or
    cannot be compared (a car standing still or driving straight at one speed: there
    the two are alike).

    Args:
        vtg: the VTG sentences (indices into the log's sentences, in its order).
        timed: the sentences with an epoch, in the log's order.
        timed_epoch: each one's epoch.
        track: the epochs' positions and times.
        speed: each VTG's speed, m/s (NaN: none).
        course: each VTG's course, degrees (NaN: none).
    """
    before, after, edge = _epochs_either_side(vtg, timed, timed_epoch)
    if not edge.any():
        return before, ""
    heading = np.radians(course)
    v_east, v_north = speed * np.sin(heading), speed * np.cos(heading)
    both = edge & (before >= 0) & (after >= 0)
    misfit = [_misfit(track, e[both], v_east[both], v_north[both]) for e in (before, after)]
    compared = np.isfinite(misfit[0]) & np.isfinite(misfit[1])
    sums = [float(m[compared].sum()) for m in misfit]
    later = bool(compared.any()) and sums[1] < sums[0]
    chosen = np.where(edge, after if later else before, before)
    n = int(compared.sum())
    said = (
        f"{int(edge.sum())} of its {vtg.size} VTG sentences (no time of their own) stand "
        f"between one epoch's sentences and the next's; each is taken as the epoch "
        f"{'after' if later else 'before'} it"
    )
    if n:
        rms = [math.sqrt(x / n) for x in sums]
        first, other = (rms[1], rms[0]) if later else (rms[0], rms[1])
        said += (
            f", whose fixes' velocity its speed and course fit ({first:.2f} m/s RMS, "
            f"{other:.2f} m/s the other way, over {n})"
        )
    else:
        said += " (no epoch's velocity from its fixes to compare its speed and course with)"
    return chosen, said


def _epochs_either_side(
    untimed: np.ndarray, timed: np.ndarray, timed_epoch: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For sentences without a time (indices into the log's sentences, in its order): the
    epoch of the timed sentence before each and after it (-1: none), and where they differ
    (a sentence between one epoch's last sentence and the next one's first)."""
    i = np.searchsorted(timed, untimed)
    last = max(timed.size - 1, 0)
    before = np.where(i > 0, timed_epoch[np.maximum(i - 1, 0)], -1)
    after = np.where(i < timed.size, timed_epoch[np.minimum(i, last)], -1)
    return before, after, before != after


def _misfit(track: _Track, epoch: np.ndarray, east: np.ndarray, north: np.ndarray) -> np.ndarray:
    """The squared difference, (m/s)^2, between each velocity (east, north) and the fixes'
    at its epoch: the positions of the epochs either side over their time apart; NaN
    where there is none."""
    n = track.lat.size
    ok = (epoch >= 1) & (epoch < n - 1)
    a, b = np.where(ok, epoch - 1, 0), np.where(ok, epoch + 1, 0)
    dt = track.tod[b] - track.tod[a]
    ok &= (dt > 0) & (dt <= VELOCITY_SPAN_S)
    de, dn = local_step_en_m(track.lat[a], track.lon[a], track.lat[b], track.lon[b])
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (de / dt - east) ** 2 + (dn / dt - north) ** 2
    return np.where(ok, out, np.nan)


def _gsa_epochs(
    gsa: np.ndarray,
    timed: np.ndarray,
    timed_epoch: np.ndarray,
    fields: CommaFields,
    fixed: np.ndarray,
) -> tuple[np.ndarray, str]:
    """The epoch each GSA sentence is written with (-1: one the log does not hold), and a
    note where the log's order had to tell.

    A GSA carries no time, as a VTG: between two sentences of one epoch it is that
    epoch's; between one epoch's last sentence and the next one's first the order alone
    cannot say (u-blox, MediaTek, Garmin and Quectel write it after their epoch's RMC,
    SiRF before), so every such GSA of the log is taken the same way: the one whose fix
    type (1 no fix, 2 or 3 a fix) agrees with the epochs' fixes (``fixed``) in more of
    them, the epoch before where they tie (a log whose fixes never come and go: there the
    two ways give the counts of epochs next to each other).
    """
    before, after, edge = _epochs_either_side(gsa, timed, timed_epoch)
    if not edge.any():
        return before, ""
    kind = fields.column(GSA_FIX_TYPE, gsa)
    known = edge & (before >= 0) & (after >= 0) & np.isin(kind, [b"1", b"2", b"3"])
    says_fix = kind != b"1"
    disagree = [int((says_fix[known] != fixed[e[known]]).sum()) for e in (before, after)]
    later = disagree[1] < disagree[0]
    chosen = np.where(edge, after if later else before, before)
    first, other = (disagree[1], disagree[0]) if later else disagree
    said = (
        f"{int(edge.sum())} of its {gsa.size} GSA sentences (no time of their own) stand "
        f"between one epoch's sentences and the next's; each is taken as the epoch "
        f"{'after' if later else 'before'} it"
    )
    if first == other:  # a tie: the fixes never came and went beside them
        return chosen, said + (
            f" (its fix type agrees as well either way, {first} of {int(known.sum())} "
            "contradicting: the log's order cannot tell, and the counts may be an epoch "
            "late)"
        )
    return chosen, said + (
        f", whose fix its fix type agrees with ({first} contradicting, {other} the other "
        f"way, over {int(known.sum())})"
    )


def _gsa_satellites(
    fields: CommaFields, gsa: np.ndarray, epoch: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The satellites used in each epoch's fix by its GSAs (NaN: an epoch without one), and
    the GSAs written again (indices into ``gsa``).

    A GSA lists the ids of the satellites used in the fix (up to 12); a multi-GNSS receiver
    writes one an epoch for each constellation (``GNGSA``, NMEA 4.10's system id last), so
    an epoch's count is the sum of its GSAs'. A GSA the same as one before it in its epoch
    (a buffer sent twice) counts once.
    """
    cells = [fields.column(j, gsa) for j in GSA_SATELLITES]
    used = np.sum([c != b"" for c in cells], axis=0)
    whole = [fields.column(j, gsa) for j in range(1, FIELDS_NEEDED[GSA] + 1)]
    keys = [b",".join(row) for row in zip(*whole, strict=True)] if gsa.size else []
    seen: set[tuple[int, bytes]] = set()
    again = []
    total = np.full(n, np.nan)
    for k, (e, row) in enumerate(zip(epoch.tolist(), keys, strict=True)):
        if e < 0:
            continue
        if (e, row) in seen:
            again.append(k)
            continue
        seen.add((e, row))
        total[e] = (0.0 if np.isnan(total[e]) else total[e]) + used[k]
    return total, np.asarray(again, np.int64)


@dataclass(frozen=True)
class _Dates:
    """The dates one kind of sentence gives its epochs (:func:`_first_day`)."""

    kind: str  # RMC, ZDA
    at: np.ndarray  # the epochs dated
    cells: np.ndarray  # each one's date as the sentence writes it (ZDA's three fields)
    unit: str  # how to read it: DDMMYY, ZDA_DATE
    rows: np.ndarray  # the dating sentences' lines


def _zda_dates(
    fields: CommaFields,
    sent: np.ndarray,
    keys: np.ndarray,
    epoch_keys: np.ndarray,
    rows: np.ndarray,
) -> _Dates:
    """The ZDA sentences ``sent`` (their epochs' ``keys``) as the dates of the epochs of
    the same UTC time (``epoch_keys``); a ZDA at a time no fix has, or without its date,
    dates none."""
    day, month, year = (fields.column(i, sent) for i in (2, 3, 4))
    epoch = _epochs_of_keys(keys, epoch_keys)
    hit = (epoch >= 0) & (day != b"") & (month != b"") & (year != b"")
    cells = np.char.add(np.char.add(np.char.add(np.char.add(day, b","), month), b","), year)
    return _Dates("ZDA", epoch[hit], cells[hit], ZDA_DATE, rows[sent[hit]])


def _zda_said(dated: Sequence[_Dates], n: int) -> str:
    """The log note's words on its ZDA sentences (none: nothing)."""
    if not n:
        return ""
    used = sum(d.at.size for d in dated if d.kind == "ZDA")
    return f"; {n} ZDA sentences, {used} dating an epoch of their time"


def _gst_accuracy(
    fields: CommaFields,
    sent: np.ndarray,
    epoch: np.ndarray,
    n: int,
    rows: np.ndarray,
    file: str,
    problems: list[Problem],
    passed: Callable[[str, Sequence[int]], None],
) -> np.ndarray:
    """Each of the ``n`` epochs' stated horizontal accuracy (m; NaN: none) from the GST
    sentences ``sent`` of their times (``epoch``: each one's, -1 where no epoch has its
    time): the root of the sum of the squares of the standard deviations of its latitude
    and longitude errors, the DRMS. An empty one, or one below 0, states none; the first
    GST of an epoch is kept, another counted as given again."""
    out = np.full(n, np.nan)
    hit = np.flatnonzero(epoch >= 0)
    epochs, once = np.unique(epoch[hit], return_index=True)
    passed("again", rows[sent[np.setdiff1d(hit, hit[once])]])
    one = sent[hit[once]]
    if not one.size:
        return out
    lat_err, lon_err = (
        _numbers(fields.column(j, one), rows[one], f"GST {what} error", file, problems)
        for j, what in zip(GST_ERRORS, ("latitude", "longitude"), strict=True)
    )
    with np.errstate(invalid="ignore"):
        stated = (lat_err >= 0.0) & (lon_err >= 0.0)  # NaN: empty
    out[epochs] = np.where(stated, np.hypot(lat_err, lon_err), np.nan)
    return out


def _gst_said(h_acc: np.ndarray, n: int) -> str:
    """The log note's words on its GST sentences (none: nothing)."""
    if not n:
        return ""
    return f"; {n} GST sentences, {int(np.isfinite(h_acc).sum())} stating an epoch's accuracy"


def _valid(kind: int, fields: CommaFields, sent: np.ndarray) -> np.ndarray:
    """Whether each of the sentences ``sent`` of a kind says its position is a fix."""
    if kind == GGA:
        return np.isin(fields.column(6, sent), GGA_FIXES)
    if kind == GNS:  # a mode letter a constellation: a fix where any is one
        modes = np.char.upper(fields.column(6, sent))
        return np.logical_or.reduce([np.char.find(modes, m) >= 0 for m in RMC_FIXES])
    status, mode = (2, 12) if kind == RMC else (6, 7)
    modes = np.char.upper(fields.column(mode, sent))
    return (np.char.upper(fields.column(status, sent)) == b"A") & (
        (modes == b"") | np.isin(modes, RMC_FIXES)
    )


# GPS's UTC parameters (the leap seconds, GPS less UTC) come in subframe 4, page 18, of
# the navigation message, every 12.5 min (IS-GPS-200, 20.3.3.5.1.6 and 20.3.3.5.2.4)
UTC_PARAMETERS_EVERY_S = 750.0
LEAP_WITHIN_S = UTC_PARAMETERS_EVERY_S + 150.0  # of the log's first fix: 15 min
MAX_LEAP_S = 18  # GPS less UTC since 2017 (GPS_UTC_S): no receiver's step is larger
LEAP_TOLERANCE_S = 0.05  # a step's distance from whole seconds
MAX_SPEED_M_S = 70.0  # a car's, between the fixes either side of a step


def _leap_step(
    tod_s: np.ndarray,
    use: np.ndarray,
    kinds: np.ndarray,
    fields: CommaFields,
    rows: np.ndarray,
    file: str,
) -> tuple[np.ndarray, str | None]:
    """The sentences' UTC times of day (``tod_s``, of the sentences ``use``, in the log's
    order) with a receiver's step onto the leap seconds undone, and a note saying so.

    A receiver without the leap seconds stored (a cold start, a module without its backup
    battery) gives UTC as GPS time less the value its firmware holds until it decodes the
    navigation message's UTC parameters (up to 12.5 min), then steps its UTC by the
    difference: whole seconds, back where the held value was short. Such a step puts the
    fixes before it that many seconds ahead, and the ones after it on the times of those
    before, each an "epoch already given". It is told here from a clock set back or a
    buffer sent twice by all of: the only step back in the log but a new day's; within 15
    min of the log's first fix; the times' step back within 0.05 s of whole seconds less
    the epoch period, 1 to 18 s; and the positions either side of it no farther apart than
    a car goes in two epochs, and the sentence after it not the same, field for field, as
    one before it of its kind and time (a buffer sent twice repeats its sentences). The
    sentences before it are moved back by the whole seconds; the note names the line.
    Otherwise the times are left as they are (a step back is refused as a clock set back).
    """
    fix = np.flatnonzero(np.isin(kinds[use], FIX_KINDS))
    if fix.size < 3:
        return tod_s, None
    t = tod_s[fix]
    d = np.diff(t)
    ahead = d[d > 1e-6]
    back = np.flatnonzero((d < -0.5) & (d > -_NEW_DAY_S))
    if back.size != 1 or not ahead.size:
        return tod_s, None
    j = int(back[0])
    period = float(np.median(ahead))
    leap = period - float(d[j])
    k = round(leap)
    if not (1 <= k <= MAX_LEAP_S and abs(leap - k) <= LEAP_TOLERANCE_S):
        return tod_s, None
    if t[j] - t[0] > LEAP_WITHIN_S:
        return tod_s, None
    either = use[fix[[j, j + 1]]]
    after_step = int(either[1])
    # a sentence of its kind and time before the step, the same field for field: a buffer
    # sent twice, no step
    earlier = fix[: j + 1]
    alike = (kinds[use[earlier]] == kinds[after_step]) & (np.abs(t[: j + 1] - t[j + 1]) < 5e-4)
    same = earlier[alike]
    if same.size and _same_fields(fields, int(use[same[0]]), after_step):
        return tod_s, None
    where = []
    for i in either.tolist():
        col = POSITION_FIELD[int(kinds[i])]
        cells = [fields.column(col + c, np.array([i])) for c in range(4)]
        ignored: list[Problem] = []
        lat = _coordinates(cells[0], cells[1], rows[[i]], "latitude", "", file, ignored)
        lon = _coordinates(cells[2], cells[3], rows[[i]], "longitude", "", file, ignored)
        where.append((float(lat[0]), float(lon[0])))
    (lat0, lon0), (lat1, lon1) = where
    apart = local_distance_m(*(np.array([x]) for x in (lat0, lon0, lat1, lon1)))[0]
    if not apart <= MAX_SPEED_M_S * 2.0 * max(period, 0.1):  # NaN: no fix
        return tod_s, None
    # every sentence before the step's last fix sentence, and those between it and the
    # next fix sentence that are not of the next one's time (a ZDA after its epoch's GGA)
    between = np.arange(fix[j] + 1, fix[j + 1])
    before = np.r_[np.arange(fix[j] + 1), between[np.abs(tod_s[between] - t[j + 1]) > 0.5]]
    moved = tod_s.copy()
    moved[before] -= k
    line = int(rows[either[1]])
    said = (
        f"the receiver's UTC stepped back {k} s at line {line}, {t[j] - t[0]:.0f} s into the "
        f"log: the leap seconds it decoded from the navigation message after a start without "
        f"them (GPS's UTC parameters come every 12.5 min); the {before.size} sentences before "
        f"it moved {k} s back"
    )
    return moved, said


def _same_fields(fields: CommaFields, a: int, b: int) -> bool:
    """Whether sentences ``a`` and ``b`` have the same fields."""
    n = int(fields.count[a])
    pair = np.array([a, b])
    return n == int(fields.count[b]) and all(
        (col := fields.column(j, pair))[0] == col[1] for j in range(n)
    )


def _times_of_day(
    cells: np.ndarray, rows: np.ndarray, file: str, problems: list[Problem]
) -> np.ndarray:
    """``hhmmss.ss`` cells as seconds since midnight (a problem for each that is none)."""
    width = cells.dtype.itemsize
    chars = np.ascontiguousarray(cells).view(np.uint8).reshape(-1, width)
    length = np.char.str_len(cells)
    ok = length >= 6
    seconds = np.full(cells.size, np.nan)
    if width >= 6:
        digits = chars[:, :4].astype(np.int64) - ord("0")
        ok &= ((digits >= 0) & (digits <= 9)).all(axis=1)
        hours = digits[:, 0] * 10 + digits[:, 1]
        minutes = digits[:, 2] * 10 + digits[:, 3]
        rest = np.ascontiguousarray(chars[:, 4:]).view(f"S{width - 4}").ravel()
        sec = floats_or_nan(rest)
        with np.errstate(invalid="ignore"):
            ok &= (hours < 24) & (minutes < 60) & (sec >= 0) & (sec < 61)
        seconds = np.where(ok, hours * 3600.0 + minutes * 60.0 + sec, np.nan)
    problems += [
        Problem(
            file,
            int(rows[i]),
            "UTC time",
            "a time of day as hhmmss.ss",
            repr(cells[i].decode("ascii", "replace")),
        )
        for i in np.flatnonzero(~ok)[:MAX_PROBLEMS]
    ]
    return seconds


def _first_day(dated: Sequence[_Dates], tod: np.ndarray, file: str) -> tuple[float | None, str]:
    """The first epoch's UTC date (s since 1970) from the valid RMC and ZDA dates, checked
    to agree, and what gave it (``RMC dates``, ``ZDA dates``, ``RMC and ZDA dates``).

    Each dated epoch (its date as its sentence writes it) gives the date of the log's
    first day (its date less the days the time of day was carried across midnight); they
    must all give one.
    """
    firsts, given = [], []
    for d in dated:
        if not d.at.size:
            continue
        # a log holds a date or two: each parsed once
        texts, inverse = np.unique(d.cells, return_inverse=True)
        inverse = inverse.ravel()
        dates = parse_dates([x.decode("ascii", "replace") for x in texts], d.unit)
        if dates.bad:
            i = int(np.flatnonzero(inverse == dates.bad[0][0])[0])
            raise InputError(
                [
                    Problem(
                        file,
                        int(d.rows[i]),
                        f"{d.kind} date",
                        "a date in ZDA's day, month and year fields (11,03,2019)"
                        if d.kind == "ZDA"
                        else "a date as ddmmyy",
                        dates.bad[0][1],
                    )
                ]
            )
        firsts.append(dates.seconds[inverse] - np.floor(tod[d.at] / 86400.0) * 86400.0)
        given.append(d)
    if not firsts:
        return None, "RMC dates"
    first, lines = np.concatenate(firsts), np.concatenate([d.rows for d in given])
    ref = int(np.argmin(lines))  # the log's first dated sentence
    wrong = np.flatnonzero(first != first[ref])
    if wrong.size:
        (d0, j0), (d, j) = _nth(given, ref), _nth(given, int(wrong[np.argmin(lines[wrong])]))
        raise InputError(
            [
                Problem(
                    file,
                    int(d.rows[j]),
                    f"{d.kind} date",
                    f"the date of the log's earlier sentences ({d0.kind} "
                    f"{d0.cells[j0].decode('ascii', 'replace')}, line {int(d0.rows[j0])}) "
                    "carried on by its UTC times",
                    repr(d.cells[j].decode("ascii", "replace")),
                    "give the drive one receiver's log, in the order it was written",
                )
            ]
        )
    return float(first[ref]), " and ".join(d.kind for d in given) + " dates"


def _nth(dated: Sequence[_Dates], i: int) -> tuple[_Dates, int]:
    """The ``i``-th dated epoch of the sources taken in turn: its source and place there."""
    for d in dated:
        if i < d.at.size:
            return d, i
        i -= d.at.size
    raise IndexError(i)


UNIX_FROM_S = 946_684_800.0  # 2000-01-01 UTC: a stream clock in s from here on is Unix time
UNIX_TO_S = 4_102_444_800.0  # 2100-01-01 UTC
UTC_TIME = "utc"  # the stream files' clock: s since 1970, UTC
DAY_TIME = "day"  # a time of day (s since a midnight)
_HOUR_S = 3600.0
# GPS's week number is 10 bits in the navigation message: a receiver whose firmware does
# not carry it past a rollover (1999-08-22, 2019-04-07, next 2038-11-21) dates its fixes
# 1024 weeks early (IS-GPS-200, 20.3.3.3.1.1: the week number modulo 1024).
GPS_ROLLOVER_S = 1024 * 7 * 86400.0


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
    # each file's median, not its first: one stamp gone to 0 is no clock of its own
    typical = [float(np.nanmedian(t)) for t in t_s if np.isfinite(t).any()]
    if typical and all(UNIX_FROM_S <= f < UNIX_TO_S for f in typical):
        return UTC_TIME
    return None


def on_clock(
    log: FixLog,
    unit: str,
    dated: bool,
    t_s: Sequence[np.ndarray],
    name: str,
    parts: Sequence[FixLog] = (),
    time: ColumnSpec | None = None,
) -> tuple[np.ndarray, str, str]:
    """A log's epochs on the stream files' clock.

    Where every epoch has the logger's stamp (and the map has no ``date`` column, which a
    stamp lacks), the stamps are the times, read in the map's ``t`` unit as a time
    column's cells. Otherwise the receiver's UTC times are placed: on a UTC clock with
    the RMC or ZDA date (a log without one takes the day that puts its first fix nearest the
    stream files' start), on a time-of-day clock as they are, and on seconds below two
    days (IO-VNBD's time of day) where the receiver's times of day cover at least half of
    the stream files' span.

    Args:
        log: the receiver's fixes.
        unit: the signal map's ``t`` unit.
        dated: whether the map has a ``date`` column.
        t_s: the stream files' times, s.
        name: how messages name the map.
        parts: the logs of the receiver's one log a logger rotated, ``log`` among them (none:
            ``log`` is the whole): whether their times of day cover half of the stream
            files' span is told of them together.
        time: the map's ``t`` entry, whose scale and offset a logger stamp's number takes as
            a time column's does (:func:`rwhonet.data.columnmap.scaled`); None: neither.

    Returns:
        ``(times, what the times are, a note)``.

    Raises:
        InputError: a stamp not in the unit; a clock of the logger's own with unstamped
            sentences; fixes that share no time with the stream files.
    """
    if log.stamps is not None and not dated:
        t = _stamps(log, unit, name, time)
        t, said = unwrap_clock(t, "epoch")
        note = f"{log.file}: each sentence's logger stamp is its time on the stream files' clock"
        return _shared(log, t, t_s, "stamp")[0], "logger stamp", "; ".join([note, *said])
    kind = clock_kind(unit, dated, t_s)
    whole = [p.tod_s for p in parts] or [log.tod_s]
    if kind is None and _seconds_of_a_day(np.concatenate(whole), t_s):
        note = (
            f"{log.file}: the stream files' times, below a day, read as UTC seconds of the "
            "day (as IO-VNBD's): the receiver's UTC times fall within them"
        )
        return log.tod_s, "UTC time", note
    utc_clock = (
        "the stream files' times in UTC (a time of day as hhmmss, hh:mm:ss; iso8601; a date "
        "column; Unix seconds)"
    )
    too_little = _too_little_of_a_day(np.concatenate(whole), t_s) if kind is None else ""
    own_clock = (
        f"the stream files' time in {unit!r}, taken as counting from the logger's start: "
        + too_little
        if too_little
        else f"the stream files' time in {unit!r} counting from the logger's start"
    )
    if kind is None and log.kind != "NMEA" and not log.unstamped.size:
        # UBX, GPX, a NovAtel log without stamps: no logger stamp before an epoch
        raise InputError(
            [
                Problem(
                    log.file,
                    None,
                    None,
                    f"a clock the receiver's UTC times can be placed on: {utc_clock}",
                    f"a {log.kind} log (no logger stamps in it), and {own_clock}",
                    f"log {name}.t in UTC, or give the receiver's NMEA log with the logger's "
                    "stamp before each sentence",
                )
            ]
        )
    if kind is None:
        raise InputError(
            [
                Problem(
                    log.file,
                    None,
                    None,
                    "a clock the receiver's UTC times can be placed on: the logger's stamp "
                    f"before each sentence, or {utc_clock}",
                    (
                        f"{log.unstamped.size} of {log.rows.size} epochs' sentences without a "
                        f"logger stamp (first at line {int(log.unstamped[0])})"
                        if log.unstamped.size
                        else "sentences without stamps"
                    )
                    + f", and {own_clock}",
                    f"have the logger stamp each sentence, or log {name}.t in UTC",
                )
            ]
        )
    if kind == DAY_TIME:
        note = f"{log.file}: the receiver's UTC times of day, on the stream files' time of day"
        return _shared(log, log.tod_s, t_s, "utc")[0], "UTC time", note
    if log.day_s is not None:
        note = f"{log.file}: the receiver's UTC times and {log.dated_by}, on the stream files' UTC"
        t, rolled = _shared(log, log.day_s + log.tod_s, t_s, "utc", dated=True)
        return t, "UTC time", "; ".join([note, *rolled])
    start = min(float(np.nanmin(t)) for t in t_s if np.isfinite(t).any())
    day = round((start - log.tod_s[0]) / 86400.0) * 86400.0
    note = (
        f"{log.file}: the receiver's UTC times, on the stream files' UTC; no RMC or ZDA date, so "
        "the day is the one that puts the first fix nearest the stream files' start"
    )
    return _shared(log, day + log.tod_s, t_s, "utc")[0], "UTC time", note


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


def _too_little_of_a_day(tod: np.ndarray, t_s: Sequence[np.ndarray]) -> str:
    """Where the stream files' times in s could be seconds of the day but the receiver's
    times of day cover less than half of their span (:func:`_seconds_of_a_day`), how much
    they cover, said; else nothing. A receiver that stopped early (or a log cut short)
    beside seconds of the day is refused so, and a user should see why."""
    spans = [(float(np.nanmin(x)), float(np.nanmax(x))) for x in t_s if np.isfinite(x).any()]
    if not spans or not np.isfinite(tod).any():
        return ""
    c, d = min(a for a, _ in spans), max(b for _, b in spans)
    if c < 0 or d >= 2 * 86400.0 or d <= c:
        return ""
    a, b = float(np.nanmin(tod)), float(np.nanmax(tod))
    shared = max(0.0, min(d, b) - max(c, a))
    return (
        f"below two days, it would be taken as UTC seconds of the day had the receiver's UTC "
        f"times of day ({a:.1f}-{b:.1f} s) covered at least half of its span ({c:.1f}-"
        f"{d:.1f} s); they cover {100.0 * shared / (d - c):.0f} % (a receiver that stopped "
        f"early, or a log cut short? UTC seconds of the day written as hh:mm:ss are read so "
        f"however much the fixes cover)"
    )


def _stamps(log: FixLog, unit: str, name: str, time: ColumnSpec | None = None) -> np.ndarray:
    """The logger's stamps in s, read in the map's ``t`` unit (numbers: scaled and offset
    first, as ``time`` says)."""
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

    if time is not None:
        t = scaled(t, time)
    return to_si("t", t, unit, None, log.file, (log.file, "logger stamp"))


def _shared(
    log: FixLog, t: np.ndarray, t_s: Sequence[np.ndarray], how: str, dated: bool = False
) -> tuple[np.ndarray, list[str]]:
    """The log's times, refused where they share no time with the stream files'; and a
    note where they were dated a whole number of GPS week rollovers early (``dated``: the
    receiver's own dates) and moved onto the stream files' span by that."""
    spans = [(float(np.nanmin(x)), float(np.nanmax(x))) for x in t_s if np.isfinite(x).any()]
    if not spans or not np.isfinite(t).any():
        return t, []
    a, b = float(np.nanmin(t)), float(np.nanmax(t))
    c, d = min(s for s, _ in spans), max(e for _, e in spans)
    if a <= d and c <= b:
        return t, []
    offset = a - c
    rollovers = round(-offset / GPS_ROLLOVER_S)
    moved = rollovers * GPS_ROLLOVER_S
    if dated and rollovers > 0 and a + moved <= d and c <= b + moved:
        first = datetime.fromtimestamp(a, UTC).date().isoformat()
        return t + moved, [
            f"{log.file}: the receiver's dates ({first} on) {rollovers * 1024} weeks before "
            f"the stream files' times: a GPS week-number rollover the receiver's firmware "
            f"does not carry (its week modulo 1024), the fixes moved {rollovers * 1024} "
            "weeks later"
        ]
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
