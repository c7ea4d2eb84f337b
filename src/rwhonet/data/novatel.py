"""A NovAtel receiver's logs, ASCII or binary: its best GNSS positions, one fix an epoch.

Research vehicles' reference receivers are often NovAtel's (OEM6, OEM7, the SPAN
GNSS/INS systems), and their logs are recorded as the receiver writes them: ASCII lines
such as::

    #BESTPOSA,COM1,0,83.5,FINESTEERING,2163,329760.000,02400000,b1f6,65535;SOL_COMPUTED,
    SINGLE,51.15043874397,-114.03066788586,1097.6822,-17.0000,WGS84,1.3648,1.1806,3.1112,
    "",0.000,0.000,18,18,18,0,00,02,11,01*c3194e35

(one line in the log). A file named ``*.gps`` (NovAtel Connect's), or a ``*.asc`` or
``*.log`` whose first lines are such logs (a CAN log's names too: told apart by what the
file holds), in a ``stream_csv`` drive's folder is read here as the drive's GNSS stream
(:func:`read_novatel`), kept compressed too, and :mod:`rwhonet.data.streamcsv` puts it on
the stream files' clock as it puts a UBX log: by its UTC times.

**The format** (NovAtel OEM7 Commands and Logs Reference Manual, "ASCII" and the logs
below): ``#``, the log's name ending in ``A``, the header's fields (port, sequence, idle
time, time status, GPS week, GPS seconds of the week, receiver status, two more), ``;``,
the log's fields, ``*`` and the CRC-32 of everything between ``#`` and ``*`` (polynomial
0xEDB88320, initial value 0, no final inversion: zlib's CRC-32 with its inversions undone;
checked against published BESTPOSA lines in the tests).

**Binary logs** (``BESTPOSB``, ...: NovAtel Connect's and Inertial Explorer's ``.gps``
files): sync ``0xAA 0x44 0x12``, a 28-byte header, the message (its fields in the ASCII
log's order) and the same CRC-32 over both (the manual's "Binary" section). A file that
holds any is read by its binary logs (:func:`_scan_binary`), each named by its number among
the file's binary logs; its fields are written as the ASCII log's, so the rest is one path.

**The logs read:**

- ``BESTGNSSPOS`` (the GNSS-only solution; a SPAN system's ``BESTPOS`` blends its INS), or
  where the log has none, ``BESTPOS``: ``lat``, ``lon`` (degrees), ``height`` (``hgt``,
  above mean sea level), ``n_sats`` (satellites used in the solution), ``h_acc``: the root
  of the sum of the squares of ``lat σ`` and ``lon σ`` (the latitude's and longitude's
  standard deviations, m), the DRMS, where its solution status is ``SOL_COMPUTED`` (the
  σ of a solution not computed, ``INSUFFICIENT_OBS`` and the like, state nothing; a log
  with no computed solution has no ``h_acc``). An epoch is a fix
  where the solution status is ``SOL_COMPUTED`` and the position type is not ``NONE``,
  ``FIXEDPOS`` (a position set by command: a base station's), ``PROPAGATED`` (the filter
  run on without new observations) or ``DOPPLER_VELOCITY``; otherwise it is kept without
  a position, as an NMEA epoch without a fix.
- ``BESTGNSSVEL`` or ``BESTVEL`` of the same epoch: ``speed_gnss`` (``hor_spd``, m/s),
  ``heading`` (``trk_gnd``, degrees from true north), where its solution is computed.
- ``TIME``: ``utc_offset``, GPS time less UTC's leap seconds (-18 s since 2017), where
  its UTC status is ``VALID``.

Every other log (RANGE, INSPVA, RXSTATUS, ...) is passed over and counted by name; a SPAN
system's INS solution (INSPVA) is not a GNSS fix.

**Abbreviated ASCII** (the manual's "Abbreviated ASCII": what a terminal shows for ``LOG
BESTPOS``, and what a capture of that session holds): a header line ``<BESTPOS COM1 0 72.0
FINESTEERING 2215 148248.000 02000020 cdba 32768`` (the ASCII header's fields spaced, the
name without its ``A``) and the log's fields spaced on the ``<`` line after it. These are
read as the ASCII logs are, each named by its header's line; they carry no CRC, so a log
whose fields line is missing or shorter than its kind's is passed over as cut, and the
notes say how many logs had no CRC to check. The receiver's prompt a capture holds before a
log (``[COM1]``) is no logger's stamp.

**The clock.** Where every epoch's log stands after the logger's stamp (``[12.345]
#BESTPOSA,...``), the stamps are the fixes' times, as an NMEA log's
(:func:`rwhonet.data.nmea.on_clock`). Otherwise each epoch's time is its header's GPS
week and seconds, put on UTC by the log's own ``TIME`` (``utc_offset``) or, without one,
by the leap seconds IERS announced (:data:`GPS_UTC_S`: 18 s since 2017-01-01, the last
announced when this was written; a later one would put the fixes a second off, which the
resampler's search for two clocks tells from the wheels:
:data:`rwhonet.data.fixlag.CLOCK_OFFSETS`, tested). The notes say which. An epoch whose
time status is ``UNKNOWN`` (a receiver that has not yet set its clock) has no time and
is passed over, counted.

**Damage**: a line whose CRC does not match, one cut short (no ``*`` and CRC: a logger
that lost power) and a position log of an epoch already given are passed over and
counted, with the first line of each. **Refused**, naming the file, line and field: a
field of a read log that is no number, a latitude or longitude out of range; a log
without BESTPOS or BESTGNSSPOS, naming the logs it holds.
"""

from __future__ import annotations

import math
import re
import struct
import zlib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import head_bytes, without_suffix
from rwhonet.data.csvio import is_number
from rwhonet.data.nmea import STAMP_STRIP, FixLog
from rwhonet.errors import InputError, Problem

NOVATEL_SUFFIXES = (".gps",)
SNIFFED_SUFFIXES = (".asc", ".log")  # a CAN log's names too: told apart by the content
SNIFF_BYTES = 4096
# a log's header at a line's start, or after a logger's stamp: ASCII's, or abbreviated
# ASCII's (``<BESTPOS COM1 0 72.0 FINESTEERING 2215 148248.000 ...``)
_HEADER = re.compile(
    rb"(?m)^[^#<\r\n]{0,40}(?:#[A-Z][A-Z0-9_]*A,[^,;]*,\d+,[\d.]+,[A-Z_]+,\d+,[\d.]+,"
    rb"|<[A-Z][A-Z0-9_]* +[A-Z0-9_]+ +\d+ +[\d.]+ +[A-Z_]+ +\d+ +[\d.]+ )"
)
# a log after a logger's stamp on its line (``12.345 #BESTPOSA,...``); an abbreviated
# log's header (``<BESTPOS COM1``) or its fields' line (``<     SOL_COMPUTED``)
_AFTER_STAMP = re.compile(rb"[#%<][A-Z][A-Z0-9_]*,|<[A-Z][A-Z0-9_]* |<\s")
# the receiver's prompt a terminal's capture holds before a log (``[COM1]``): no stamp
_PROMPT = re.compile(rb"[A-Z]+\d*")
GPS_EPOCH_UNIX_S = 315_964_800  # 1980-01-06 00:00:00 UTC
SECONDS_PER_WEEK = 604_800
# GPS time less UTC (s), from each date (UTC, Unix s) on: the leap seconds since 1980
# (IERS Bulletin C; the last on 2017-01-01)
GPS_UTC_S = (
    (362_793_600, 1),  # 1981-07-01
    (394_329_600, 2),  # 1982-07-01
    (425_865_600, 3),  # 1983-07-01
    (489_024_000, 4),  # 1985-07-01
    (567_993_600, 5),  # 1988-01-01
    (631_152_000, 6),  # 1990-01-01
    (662_688_000, 7),  # 1991-01-01
    (709_948_800, 8),  # 1992-07-01
    (741_484_800, 9),  # 1993-07-01
    (773_020_800, 10),  # 1994-07-01
    (820_454_400, 11),  # 1996-01-01
    (867_715_200, 12),  # 1997-07-01
    (915_148_800, 13),  # 1999-01-01
    (1_136_073_600, 14),  # 2006-01-01
    (1_230_768_000, 15),  # 2009-01-01
    (1_341_100_800, 16),  # 2012-07-01
    (1_435_708_800, 17),  # 2015-07-01
    (1_483_228_800, 18),  # 2017-01-01
)
POSITIONS = ("BESTGNSSPOSA", "BESTPOSA")  # the first the log has gives the epochs
VELOCITIES = ("BESTGNSSVELA", "BESTVELA")
NO_FIX_TYPES = ("NONE", "FIXEDPOS", "PROPAGATED", "DOPPLER_VELOCITY")
LISTED = 20


def is_novatel_name(name: str) -> bool:
    """Whether a file's name is a NovAtel log's by its name alone (``drive.gps``,
    ``drive.gps.gz``)."""
    return without_suffix(name).lower().endswith(NOVATEL_SUFFIXES)


def is_novatel_log(path: Path, name: str | None = None) -> bool:
    """Whether a file is a NovAtel ASCII log: named so (``*.gps``), or a ``*.asc`` or
    ``*.log`` whose first :data:`SNIFF_BYTES` hold a NovAtel log's header; one kept
    compressed (``drive.log.gz``) by the first bytes it unpacks to. A file that cannot be
    read or unpacked is not (read as a CAN log, its reader says what is wrong)."""
    name = name or path.name
    if is_novatel_name(name):
        return True
    if Path(without_suffix(name)).suffix.lower() not in SNIFFED_SUFFIXES:
        return False
    head = head_bytes(path, name, SNIFF_BYTES)
    return head is not None and (BINARY_SYNC in head or _HEADER.search(head) is not None)


def gps_utc_s(unix_s: float) -> int:
    """GPS time less UTC at a UTC time (s since 1970), by :data:`GPS_UTC_S`."""
    return next((s for at, s in reversed(GPS_UTC_S) if unix_s >= at), 0)


def crc32(body: bytes) -> int:
    """NovAtel's CRC-32 of a log's bytes between ``#`` and ``*``."""
    return zlib.crc32(body, 0xFFFFFFFF) ^ 0xFFFFFFFF


@dataclass
class _Logs:
    """A file's NovAtel logs of the kinds read, each ``(line, header, fields)``."""

    logs: dict[str, list[tuple[int, list[bytes], list[bytes]]]] = field(default_factory=dict)
    others: Counter = field(default_factory=Counter)
    bad_crc: list[int] = field(default_factory=list)
    cut: list[int] = field(default_factory=list)
    stamps: dict[int, bytes] = field(default_factory=dict)  # line -> the logger's stamp
    binary: bool = False  # whether the logs read are binary (named by number, not line)
    abbreviated: int = 0  # logs of the kinds read in abbreviated ASCII (no CRC to check)


READ = (*POSITIONS, *VELOCITIES, "TIMEA")

# The binary form (NovAtel OEM7 manual, "Binary"): sync 0xAA 0x44 0x12, a 28-byte header
# (little-endian: header length, message ID, message type, port, message length,
# sequence, idle time, time status, GPS week, GPS milliseconds of the week, receiver
# status, reserved, software version), the message, and the CRC-32 of both.
BINARY_SYNC = b"\xaa\x44\x12\x1c"
_BINARY_HEADER = struct.Struct("<3sBHBBHHBBHIIHH")
# message ID -> its ASCII name, and its fields as the ASCII log orders them
BINARY_LOGS = {
    42: ("BESTPOSA", struct.Struct("<IIdddfIfff4sffBBBBBBBB")),
    1429: ("BESTGNSSPOSA", struct.Struct("<IIdddfIfff4sffBBBBBBBB")),
    99: ("BESTVELA", struct.Struct("<IIffdddf")),
    1430: ("BESTGNSSVELA", struct.Struct("<IIffdddf")),
    101: ("TIMEA", struct.Struct("<IdddIBBBBII")),
}
TIME_STATUS_UNKNOWN = 20
# the enumerations' values the reader tells apart (the rest are named by number)
SOLUTION_STATUS = {0: "SOL_COMPUTED"}
POSITION_TYPE = {
    0: "NONE",
    1: "FIXEDPOS",
    2: "FIXEDHEIGHT",
    8: "DOPPLER_VELOCITY",
    16: "SINGLE",
    19: "PROPAGATED",
}
UTC_STATUS = {0: "INVALID", 1: "VALID", 2: "WARNING"}


def _binary_tokens(name: str, values: tuple) -> list[bytes]:
    """A binary log's fields as its ASCII twin writes them (the enumerations by name)."""
    out = [repr(v).encode() if isinstance(v, float) else str(v).encode() for v in values]
    if name.startswith("BEST"):
        out[0] = SOLUTION_STATUS.get(values[0], f"STATUS_{values[0]}").encode()
        out[1] = POSITION_TYPE.get(values[1], f"TYPE_{values[1]}").encode()
    else:  # TIME: its UTC status last
        out[10] = UTC_STATUS.get(values[10], f"STATUS_{values[10]}").encode()
    return out


def _scan_binary(data: bytes, out: _Logs) -> None:
    """Every binary log in ``data`` of the kinds read, its CRC checked, into ``out``; each
    named by its number among the file's binary logs (as a line is an ASCII log's)."""
    out.binary = True
    number = 0
    for m in re.finditer(re.escape(BINARY_SYNC), data):
        at = m.start()
        if at + 28 > len(data):
            continue
        head = _BINARY_HEADER.unpack_from(data, at)
        msg_id, msg_type, length = head[2], head[3], head[5]
        if msg_type & 0x60:  # not binary (ASCII or NMEA in binary framing)
            continue
        number += 1
        end = at + 28 + length
        if end + 4 > len(data):
            out.cut.append(number)
            continue
        if int.from_bytes(data[end : end + 4], "little") != crc32(data[at:end]):
            out.bad_crc.append(number)
            continue
        known = BINARY_LOGS.get(msg_id)
        if known is None:
            out.others[f"message ID {msg_id} (binary)"] += 1
            continue
        name, layout = known
        if length < layout.size:
            out.cut.append(number)
            continue
        week, ms = head[9], head[10]
        status = b"UNKNOWN" if head[8] == TIME_STATUS_UNKNOWN else str(head[8]).encode()
        header = [
            name.encode(),
            b"",
            b"",
            b"",
            status,
            str(week).encode(),
            repr(ms / 1000.0).encode(),
        ]
        fields = _binary_tokens(name, layout.unpack_from(data, at + 28))
        out.logs.setdefault(name, []).append((number, header, fields))


def _scan(data: bytes) -> _Logs:
    """Every ``#`` line's log, its CRC checked, and every abbreviated ASCII log (a ``<``
    header line, its fields on the ``<`` line after it, spaced: :func:`_abbreviated`);
    what stands before a line's ``#`` or ``<`` is the logger's stamp (as before an NMEA
    sentence's ``$``), but for the receiver's prompt (``[COM1]``)."""
    out = _Logs()
    header: tuple[int, str, list[bytes]] | None = None  # an abbreviated log's, waiting
    for number, line in enumerate(data.splitlines(), 1):
        line = line.strip()
        if not line.startswith((b"#", b"%", b"<")):
            at = _AFTER_STAMP.search(line)
            if at is None:
                continue
            stamp = line[: at.start()].strip(STAMP_STRIP)
            if stamp and not _PROMPT.fullmatch(stamp):
                out.stamps[number] = stamp
            line = line[at.start() :]
        if line.startswith(b"<"):
            header = _abbreviated(out, number, line, header)
            continue
        name = line[1:].split(b",", 1)[0].decode("ascii", "replace")
        if not line.startswith(b"#") or name not in READ:
            out.others[name if line.startswith(b"#") else f"{line[:1].decode()}{name}"] += 1
            continue
        star = line.rfind(b"*")
        if star < 0 or len(line) - star - 1 != 8:
            out.cut.append(number)
            continue
        try:
            ok = int(line[star + 1 :], 16) == crc32(line[1:star])
        except ValueError:
            ok = False
        if not ok:
            out.bad_crc.append(number)
            continue
        head, _, body = line[1:star].partition(b";")
        out.logs.setdefault(name, []).append((number, head.split(b","), body.split(b",")))
    if header is not None and header[1] in READ:  # the last header, its fields not there
        out.cut.append(header[0])
    return out


def _abbreviated(
    out: _Logs, number: int, line: bytes, header: tuple[int, str, list[bytes]] | None
) -> tuple[int, str, list[bytes]] | None:
    """One line of abbreviated ASCII, what a terminal shows for ``LOG BESTPOS``: a header
    line (``<BESTPOS COM1 0 72.0 FINESTEERING 2215 148248.000 02000020 cdba 32768``: the
    ASCII header's fields, spaced, the name without its ``A``), then the log's fields on
    the next ``<`` line (``<     SOL_COMPUTED SINGLE 51.15043711386 ...``; a list's on
    several). A header line is returned to wait for its fields; a fields line after a
    header of a kind read gives that log (named by its header's line, its stamp the
    header's), after any other is passed over. There is no CRC: a log whose fields are
    fewer than its kind's is taken as cut short where it is read."""
    fields = line[1:].split()
    if not fields or line[1:2].isspace():  # the fields of the header before it
        if header is not None and header[1] in READ:
            out.logs.setdefault(header[1], []).append((header[0], header[2], fields))
            out.abbreviated += 1
        return None
    if header is not None and header[1] in READ:  # the header before it had no fields
        out.cut.append(header[0])
    raw = fields[0].decode("ascii", "replace")
    name = raw if raw.endswith("A") and raw in READ else f"{raw}A"
    if name not in READ:
        out.others[f"<{raw}"] += 1
    return number, name, [name.encode(), *fields[1:]]


def _number(cell: bytes, file: str, line: int, what: str, problems: list[Problem]) -> float:
    try:
        return float(cell)
    except ValueError:
        if len(problems) < LISTED:
            problems.append(
                Problem(file, line, what, "a number", repr(cell.decode("ascii", "replace")))
            )
        return float("nan")


def _drms(lat_sigma: bytes, lon_sigma: bytes) -> float:
    """A position log's ``lat σ`` and ``lon σ`` (m, one sigma) as the DRMS, the root of the
    sum of their squares; NaN where either is no finite number, or negative. Not refused
    as the position's fields are: a log read before the accuracy was is read still."""
    try:
        a, b = float(lat_sigma), float(lon_sigma)
    except ValueError:
        return float("nan")
    ok = math.isfinite(a) and math.isfinite(b) and a >= 0.0 and b >= 0.0
    return math.hypot(a, b) if ok else float("nan")


def read_novatel(path: Path, file: str) -> FixLog:
    """Read a NovAtel receiver's BESTGNSSPOS (or BESTPOS) logs as one fix an epoch, with
    the speed and course of its BESTGNSSVEL (BESTVEL) logs, on UTC.

    Args:
        path: the log (text; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: no BESTPOS or BESTGNSSPOS log; a field that is no number; a latitude
            or longitude out of range.
    """
    data = path.read_bytes()
    found = _scan(data) if BINARY_SYNC not in data else _Logs()
    if BINARY_SYNC in data:
        _scan_binary(data, found)
    kind = next((k for k in POSITIONS if k in found.logs), None)
    if kind is None:
        held = ", ".join(f"{k} {v}" for k, v in found.others.most_common(6)) or "none"
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a NovAtel receiver's BESTPOSA or BESTGNSSPOSA logs (ASCII, with a CRC)",
                    f"other logs ({held})"
                    + (f"; {len(found.bad_crc)} whose CRC does not match" if found.bad_crc else ""),
                    "log BESTPOSA (LOG BESTPOSA ONTIME 0.1) with the drive, or give the "
                    "receiver's NMEA output (GPGGA, GPRMC)",
                )
            ]
        )
    problems: list[Problem] = []
    rows, gps_s, fix, lat, lon, hgt, sats, h_acc = [], [], [], [], [], [], [], []
    unknown, again, seen = [], [], set()
    for line, head, body in found.logs[kind]:
        if len(head) < 7 or len(body) < 15:
            found.cut.append(line)
            continue
        if head[4] == b"UNKNOWN":
            unknown.append(line)
            continue
        t = _number(head[5], file, line, "GPS week", problems) * SECONDS_PER_WEEK + _number(
            head[6], file, line, "GPS seconds", problems
        )
        if t in seen:
            again.append(line)
            continue
        seen.add(t)
        rows.append(line)
        gps_s.append(t)
        fix.append(
            body[0] == b"SOL_COMPUTED" and body[1].decode("ascii", "replace") not in NO_FIX_TYPES
        )
        lat.append(_number(body[2], file, line, "lat", problems))
        lon.append(_number(body[3], file, line, "lon", problems))
        hgt.append(_number(body[4], file, line, "hgt", problems))
        sats.append(_number(body[14], file, line, "#solnSVs", problems))
        h_acc.append(_drms(body[7], body[8]) if body[0] == b"SOL_COMPUTED" else np.nan)
    lat_a, lon_a = np.array(lat), np.array(lon)
    for what, values, limit in (("lat", lat_a, 90), ("lon", lon_a, 180)):
        problems += [
            Problem(
                file,
                rows[i],
                what,
                f"a {what} in [-{limit}, {limit}] degrees",
                f"{float(values[i])!r}",
            )
            for i in np.flatnonzero(np.abs(values) > limit)[:LISTED]
        ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    if not rows:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    kind[:-1],
                    f"{kind} logs with a GPS time",
                    f"{len(unknown)} with the time status UNKNOWN, none with a time",
                    "log the drive once the receiver has set its clock",
                )
            ]
        )
    gps = np.array(gps_s)
    fixed = np.array(fix, dtype=bool)
    stamped = [found.stamps.get(r) for r in rows]
    stamps = None if None in stamped else [x.decode("ascii", "replace") for x in stamped]
    some = stamps is None and any(x is not None for x in stamped)
    unstamped = np.array(
        [r for r, x in zip(rows, stamped, strict=True) if x is None] if some else [],
        dtype=np.int64,
    )
    offset_s, how = _utc_offset(found, gps, file)
    utc = GPS_EPOCH_UNIX_S + gps + offset_s
    channels = {
        "lat": np.where(fixed, lat_a, np.nan),
        "lon": np.where(fixed, lon_a, np.nan),
        "height": np.array(hgt),
        "n_sats": np.array(sats),
    }
    shown = {k: k[:-1] + ("B" if found.binary else "A") for k in READ}  # BESTPOSB: binary
    sources = {
        "lat": f"{shown[kind]} lat",
        "lon": f"{shown[kind]} lon",
        "height": f"{shown[kind]} hgt",
        "n_sats": f"{shown[kind]} #solnSVs",
    }
    if np.isfinite(h_acc).any():  # a log none of whose solutions is computed states none
        channels["h_acc"] = np.array(h_acc, np.float64)
        sources["h_acc"] = f"{shown[kind]} lat σ, lon σ"
    vel = next((k for k in VELOCITIES if k in found.logs), None)
    if vel is not None:
        speed, course = _velocities(found.logs[vel], gps, file)
        channels["speed_gnss"] = np.where(fixed, speed, np.nan)
        channels["heading"] = np.where(fixed, course, np.nan)
        sources |= {"speed_gnss": f"{shown[vel]} hor_spd", "heading": f"{shown[vel]} trk_gnd"}
    at = "binary log" if found.binary else "line"
    dropped = "; ".join(
        part
        for part in (
            f"{len(found.bad_crc)} log(s) whose CRC does not match (first at {at} "
            f"{found.bad_crc[0]})"
            if found.bad_crc
            else "",
            f"{len(found.cut)} log(s) cut short (first at {at} {found.cut[0]})"
            if found.cut
            else "",
            f"{len(unknown)} {shown[kind]} log(s) of the time status UNKNOWN (first at {at} "
            f"{unknown[0]})"
            if unknown
            else "",
            f"{len(again)} {shown[kind]} log(s) of an epoch already given (first at {at} "
            f"{again[0]})"
            if again
            else "",
        )
        if part
    )
    besides = ", ".join(f"{k} {v}" for k, v in found.others.most_common(6))
    unused = [k for k in (*POSITIONS, *VELOCITIES) if k in found.logs and k not in (kind, vel)]
    left = ", ".join(f"{shown[k]} {len(found.logs[k])}" for k in unused)
    notes = [
        f"{file}: a NovAtel log{' (binary)' if found.binary else ''}"
        + (
            f" ({found.abbreviated} logs in abbreviated ASCII: no CRC to check)"
            if found.abbreviated
            else ""
        )
        + f": {gps.size} epochs "
        f"({shown[kind]}"
        + (f", {shown[vel]}" if vel else "")
        + f"), {int(fixed.sum())} with a fix; {how}"
        + (f"; left out: {left} (the GNSS-only solution read)" if left else "")
        + (f"; besides them: {besides}" if besides else "")
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    return FixLog.on_utc(
        file,
        utc,
        channels,
        sources,
        np.array(rows),
        notes,
        dropped,
        dated_by="GPS weeks",
        kind="NovAtel",
        stamps=stamps,
        unstamped=unstamped,
    )


def _utc_offset(found: _Logs, gps: np.ndarray, file: str) -> tuple[float, str]:
    """UTC less GPS time (s): the log's valid TIME logs' ``utc_offset`` (their median), or
    the leap-second table's at the first epoch."""
    valid = [
        float(body[3])
        for _, _, body in found.logs.get("TIMEA", [])
        if len(body) >= 11 and body[10] == b"VALID" and is_number(body[3])
    ]
    if valid:
        offset = float(np.median(valid))
        return offset, f"GPS time put on UTC by its TIME logs' utc_offset ({offset:g} s)"
    leap = gps_utc_s(GPS_EPOCH_UNIX_S + float(gps[0]))
    return -float(leap), (
        f"GPS time put on UTC by the leap seconds to its date ({leap} s; no valid TIME log "
        "in the file)"
    )


def _velocities(
    logs: list[tuple[int, list[bytes], list[bytes]]], gps: np.ndarray, file: str
) -> tuple[np.ndarray, np.ndarray]:
    """Each epoch's horizontal speed and course over ground from the velocity logs of its
    GPS time (NaN: none, or its solution not computed)."""
    speed = np.full(gps.size, np.nan)
    course = np.full(gps.size, np.nan)
    at = {t: i for i, t in enumerate(gps.tolist())}
    problems: list[Problem] = []
    for line, head, body in logs:
        if len(head) < 7 or len(body) < 6 or body[0] != b"SOL_COMPUTED":
            continue
        if not (is_number(head[5]) and is_number(head[6])):
            continue
        i = at.get(float(head[5]) * SECONDS_PER_WEEK + float(head[6]))
        if i is None or np.isfinite(speed[i]):
            continue
        speed[i] = _number(body[4], file, line, "hor_spd", problems)
        course[i] = _number(body[5], file, line, "trk_gnd", problems)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    return speed, course
