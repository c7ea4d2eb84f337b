"""A PEAK TRC log's CAN frames (PCAN-View, PCAN-Explorer, PEAK-Converter), parsed over
the file's lines at once (numpy), in each version of PEAK's format, 1.0 to 2.1.

PEAK's "PEAK CAN TRC File Format" (PEAK-System Technik, 2010-2023) writes a header of
comment lines (``;``), three of them keys: ``;$FILEVERSION=2.1``, ``;$STARTTIME=45930.5``
(the measurement's start in days since 1899-12-30, an OLE Automation date, on the
logging computer's clock; python-can reads it as UTC, and
:func:`rwhonet.data.canlog._trc` puts it on UTC with the map's ``local_zone``) and,
from 2.0, ``;$COLUMNS=N,O,T,B,I,d,R,L,D``. Then one message a line, its columns
separated by spaces::

    1.0   1)  1841  0001  8  00 11 22 33 44 55 66 77      N) offset ID DLC bytes
    1.1   1)  1059.9  Rx  0300  7  00 00 00 00 04 00 00   N) offset type ID DLC bytes
    1.2   1)  1059.900  1  Rx  0300  7  00 ...            N) offset bus type ID DLC bytes
    1.3   1)  1059.900 1  Rx  0300 -  7  00 ...           N) offset bus type ID - DLC bytes
    2.x   1  1059.900 DT 1  0300 Rx -  7  00 ...          as $COLUMNS names them

The offset is in milliseconds since the start; an identifier of more than 4 hex digits
is extended (PEAK writes 4 for 11 bits, 8 for 29); the bus is the ``Bus`` (``B``)
column, else 1. In 2.x, ``T`` is the type: ``DT`` a CAN frame, ``FD``, ``FB`` (bit-rate
switch), ``FE`` (error state) and ``BI`` (both) CAN FD frames, whose ``L`` is the DLC
(9-15: 12-64 bytes) and ``l`` the bytes. A frame's time stamp is the start plus its
offset, ``float(offset) / 1000 + start``, as python-can computes it.

**Passed over, counted**: remote frames (``RTR`` in place of the bytes in 1.x, type
``RR`` in 2.x), error frames (``ERROR`` before the bytes in 1.0, type ``Error`` in
1.1-1.3, ``ER`` in 2.x), bus status and event lines (identifier ``FFFFFFFF`` in 1.0,
type ``Warng`` in 1.1-1.3, ``ST``, ``EC`` and ``EV`` in 2.x), lines of a type the
version has none of, and damaged lines (a field missing, an offset that is no number,
an identifier that is no hex, a byte that is not two hex digits, a length no frame has,
2.x bytes fewer or more than the length), the first of each named. A damaged line is
passed over as candump's are
(:func:`rwhonet.data.canlog._candump`): a log an hour long is not refused for one line
a power cut left.

**Against python-can's** :class:`can.io.trc.TRCReader`, which read every TRC here until
stop 80, a frame at a time: where it reads a log, the frames are its own, bit for bit
(time stamps, identifiers, extended flags, bytes, channels; the tests hold them to it).
It refused whole these logs, which PEAK's tools write and this reads:

- a 1.x log with a remote frame (PEAK's ``RTR``: ``int('RTR', 16)`` raises) or a 1.0 log
  with an error frame (``ERROR``);
- a 1.2 log (PCAN-Explorer 5's: python-can reads an unknown version as 1.0, and its
  ``Rx`` as the DLC), and a ``$STARTTIME`` with the trailing ``;`` PCAN-Explorer 5
  writes (``float()`` raises).

It reads a 1.0 log's offsets without the start; a 1.0 log with a ``$STARTTIME`` (which
PEAK's 1.0 has not) is put on it here. A version PEAK's format has not is refused,
naming it, where python-can read it as 1.0.

**Text.** The frames' lines are ASCII; a comment in a Windows code page (an umlaut in
PCAN-View's header on a German installation) is passed over as bytes, undecoded, and a
UTF-8 byte-order mark before the header (a log saved again by a Windows editor, where
python-can missed the header behind it) is dropped.
"""

from __future__ import annotations

import dataclasses
import mmap
import re
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

import numpy as np

from rwhonet.data.bytescan import DEC, Fields, small_hex
from rwhonet.errors import InputError, Problem

CHUNK_BYTES = 1 << 23  # lines split into fields at once (8 MB of text; bounds the memory)
VERSIONS = ("1.0", "1.1", "1.2", "1.3", "2.0", "2.1")
# the 1.x columns (0-based, the message number first): offset, bus, type, ID, DLC; the
# bytes follow the DLC
# a CAN FD frame's bytes by its DLC (ISO 11898-1), and the most a frame has
FD_LENGTHS = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64])
MAX_BYTES = 64
LAYOUT_1 = {
    "1.0": (1, None, None, 2, 3),
    "1.1": (1, None, 2, 3, 4),
    "1.2": (1, 2, 3, 4, 5),
    "1.3": (1, 2, 3, 4, 6),
}
FD_TYPES = (b"FD", b"FB", b"FE", b"BI")
STATUS_TYPES = (b"ST", b"EC", b"EV")
OFFSET_DIGITS = 18  # an offset's digits read as one exact integer (longer: float())
MAX_OFFSET = 40  # characters of an offset (a longer field is a damaged line's)
_KEY = re.compile(rb"\s*;\$(?P<key>\w+)\s*=\s*(?P<value>.*?)\s*$")
_OLE_EPOCH = datetime(1899, 12, 30)
UTF8_BOM = b"\xef\xbb\xbf"
ID_MASK = 0x1FFF_FFFF  # an extended identifier's 29 bits
Buffer = bytes | mmap.mmap
Keep = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (ids, extended) -> which to keep
# python-can's TRCWriter writes its start in UTC, and says so in its header
_PYTHON_CAN = b"Generated by python-can TRCWriter"
PASSED = (
    "error frames",
    "remote frames",
    "bus status and event lines",
)


@dataclass(frozen=True)
class TrcFrames:
    """A TRC log's data frames, in the log's order.

    Attributes:
        t_s: each frame's time stamp, s: the start (Unix time; 0 where the log gives none)
            plus its offset.
        ids: its identifier (int64, as the log writes it).
        extended: whether the identifier has more than 4 hex digits.
        length: its data bytes.
        data: its bytes, zero after ``length`` (8 a row, or 64 where any has more).
        bus: its bus as the log numbers it (1 where the version has no bus column).
        rows: its line in the log, 1-based.
        passed: what was passed over (see the module's docstring) -> how many.
        version: the log's TRC version.
        start_s: the measurement's start, Unix time (None: the log gives none), its
            ``$STARTTIME`` read as UTC, as python-can reads it.
        offset_s: each frame's offset from the start, s (``t_s`` less the start).
        start_wall: the ``$STARTTIME`` as the date and time it writes, without a zone.
        start_utc: whether the header says its start is UTC: python-can's writer's
            (``Generated by python-can TRCWriter``); PEAK's tools write the logging
            computer's local clock.
        dropped: the data frames ``keep`` left out.
        seen: where ``keep`` was given, every data frame's bus, identifier (29 bits) and
            whether it is extended, once each: ``bus << 40 | extended << 32 | id``.
        bus_order: where ``keep`` was given, the buses in the order first seen among
            every data frame.
    """

    t_s: np.ndarray
    ids: np.ndarray
    extended: np.ndarray
    length: np.ndarray
    data: np.ndarray
    bus: np.ndarray
    rows: np.ndarray
    passed: dict[str, int]
    version: str
    start_s: float | None
    offset_s: np.ndarray
    start_wall: datetime | None
    start_utc: bool
    dropped: int = 0
    seen: np.ndarray | None = None
    bus_order: np.ndarray | None = None


@dataclass(frozen=True)
class _Layout:
    """Where a version's message lines hold each column (0-based; None: none)."""

    offset: int
    bus: int | None
    type: int | None
    ident: int
    dlc: int
    data: int
    dlc_is_length: bool  # 2.x's ``l``: the bytes, not the DLC
    bytes_last: bool  # 2.x: the bytes end the line, as many as the length says


def trc_frames(raw: Buffer, file: str, keep: Keep | None = None) -> TrcFrames:
    """The data frames of the TRC log ``raw`` (see the module's docstring).

    Args:
        raw: the log's bytes (or the file mapped in memory: read a chunk at a time).
        file: how messages name it.
        keep: which frames to keep, by their identifiers (29 bits) and whether each is
            extended; each chunk's others are counted (``dropped``), their bus and
            identifier noted (``seen``), and left out as it is read.

    Raises:
        InputError: a ``$FILEVERSION`` PEAK's format has not, a ``$STARTTIME`` that is no
            number of days, a 2.x log without the ``$COLUMNS`` a frame needs (each named
            with its line).
    """
    if raw.find(b"\n") < 0:  # line ends of CR alone
        raw = bytes(raw).replace(b"\r", b"\n")
    # a log saved again by a Windows editor as UTF-8 starts with a byte-order mark
    body, keys = _header(raw, len(UTF8_BOM) if raw[: len(UTF8_BOM)] == UTF8_BOM else 0)
    version, wall, layout = _read_keys(keys, file)
    parts: list[_Part] = []
    seen: list[np.ndarray] = []
    order: list[int] = []
    dropped = 0
    at, line = body, raw[:body].count(b"\n") + 1
    while at < len(raw):
        end = raw.find(b"\n", min(at + CHUNK_BYTES, len(raw)) - 1)
        end = len(raw) if end < 0 else end + 1
        chunk = raw[at:end]
        part = _chunk(chunk, layout, line, version)
        if keep is not None:
            _, ids, extended, _, _, bus, _ = part.frames
            ids, bus = ids.astype(np.int64) & ID_MASK, bus.astype(np.int64)
            seen.append(np.unique((bus << 40) | (extended.astype(np.int64) << 32) | ids))
            values, first = np.unique(bus, return_index=True)
            order += [b for b in values[np.argsort(first)].tolist() if b not in order]
            kept = np.flatnonzero(keep(ids, extended.astype(bool)))
            dropped += ids.size - kept.size
            part = _Part(tuple(x[kept] for x in part.frames), part.passed)
        parts.append(part)
        line += chunk.count(b"\n")
        at = end
    utc = _PYTHON_CAN in raw[:body]
    frames = _joined(parts, version, wall, utc)
    if keep is None:
        return frames
    return dataclasses.replace(
        frames,
        dropped=dropped,
        seen=np.unique(np.concatenate([*seen, np.zeros(0, np.int64)])),
        bus_order=np.array(order, np.int64),
    )


def _header(raw: Buffer, at: int = 0) -> tuple[int, dict[bytes, tuple[int, bytes]]]:
    """Where the messages start (the first line from ``at`` neither blank nor a ``;``
    comment), and the header's keys: name -> (line, value)."""
    keys: dict[bytes, tuple[int, bytes]] = {}
    line = 1
    while at < len(raw):
        end = raw.find(b"\n", at)
        end = len(raw) if end < 0 else end + 1
        text = raw[at:end].strip()
        if text and not text.startswith(b";"):
            break
        if (match := _KEY.match(raw[at:end])) is not None:
            keys[match["key"].upper()] = (line, match["value"])  # the last, as python-can
        at, line = end, line + 1
    return at, keys


def _read_keys(
    keys: dict[bytes, tuple[int, bytes]], file: str
) -> tuple[str, datetime | None, _Layout]:
    """The log's version, start (the date and time its ``$STARTTIME`` writes) and column
    layout, from its header's keys."""
    problems: list[Problem] = []
    version = "1.0"
    if b"FILEVERSION" in keys:
        row, value = keys[b"FILEVERSION"]
        version = value.decode("latin-1")
        if version not in VERSIONS:
            problems.append(
                Problem(
                    file,
                    row,
                    "$FILEVERSION",
                    "a version of PEAK's TRC format: " + ", ".join(VERSIONS),
                    repr(version),
                    "export the log again as TRC 2.1 (PCAN-View, PEAK-Converter)",
                )
            )
    wall = None
    if b"STARTTIME" in keys:
        row, value = keys[b"STARTTIME"]
        text = value.rstrip(b"; \t").decode("latin-1")  # PCAN-Explorer 5 ends it with ";"
        try:
            days = float(text)
            # python-can's reading: a timedelta (to the microsecond) after 1899-12-30 UTC
            wall = _OLE_EPOCH + timedelta(days=days)  # to the microsecond, as python-can
        except (ValueError, OverflowError):
            problems.append(
                Problem(
                    file,
                    row,
                    "$STARTTIME",
                    "the measurement's start in days since 1899-12-30 (45930.5)",
                    repr(text),
                )
            )
    layout = None
    if version in LAYOUT_1:
        o, b, t, i, d = LAYOUT_1[version]
        layout = _Layout(o, b, t, i, d, d + 1, False, False)
    elif version in VERSIONS:
        layout = _columns(keys, file, problems)
    if problems or layout is None:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    return version, wall, layout


def _columns(
    keys: dict[bytes, tuple[int, bytes]], file: str, problems: list[Problem]
) -> _Layout | None:
    """A 2.x log's layout, from its ``$COLUMNS``."""
    row, value = keys.get(b"COLUMNS", (None, b""))
    names = [x.strip() for x in value.decode("latin-1").split(",")]
    length = "l" if "l" in names else "L"
    needed = ("O", "T", "I", length, "D")
    if not all(x in names for x in needed) or names[-1] != "D" or len(set(names)) < len(names):
        problems.append(
            Problem(
                file,
                row,
                "$COLUMNS",
                "PEAK's 2.x columns, with O (offset), T (type), I (ID), L (DLC) or l "
                "(length) and D (data) last: N,O,T,B,I,d,R,L,D",
                repr(value.decode("latin-1")) if row is not None else "no $COLUMNS line",
            )
        )
        return None
    bus = names.index("B") if "B" in names else None
    return _Layout(
        names.index("O"),
        bus,
        names.index("T"),
        names.index("I"),
        names.index(length),
        names.index("D"),
        length == "l",
        True,
    )


@dataclass(frozen=True)
class _Part:
    """A chunk's frames, and the lines of each kind passed over."""

    frames: tuple[np.ndarray, ...]  # t (ms), ids, extended, length, data, bus, rows
    passed: dict[str, np.ndarray]


def _chunk(chunk: bytes, layout: _Layout, first_line: int, version: str) -> _Part:
    """One chunk of whole lines' frames (see the module's docstring)."""
    f = Fields(np.frombuffer(chunk, np.uint8))
    lines = np.arange(f.lines)
    has0, s0, _ = f.field(0, lines)
    message = has0 & (f.byte(s0) != ord(";"))
    rows = lines[message]
    kind = _kinds(f, rows, layout, version)
    frame = kind >= 0
    fr = rows[frame]
    fd = kind[frame] == 1
    ok, offset = _offset(f, *f.field(layout.offset, fr))
    id_has, s, e = f.field(layout.ident, fr)
    id_ok, ids = f.number(s, e, 8, 16)
    ok &= id_has & id_ok
    extended = (e - s) > 4
    bus = np.ones(fr.size, np.int64)
    if layout.bus is not None:
        bus_has, s, e = f.field(layout.bus, fr)
        bus_ok, bus = f.number(s, e, 3, 10)
        ok &= bus_has & bus_ok
    dlc_has, s, e = f.field(layout.dlc, fr)
    dlc_ok, dlc = f.number(s, e, 2, 10)
    ok &= dlc_has & dlc_ok
    if layout.dlc_is_length:
        length = dlc
        ok &= np.where(fd, np.isin(dlc, FD_LENGTHS), dlc <= 8)
    else:
        length = np.where(fd, FD_LENGTHS[np.minimum(dlc, 15)], dlc)
        ok &= np.where(fd, dlc <= 15, dlc <= 8)
    if layout.bytes_last:
        ok &= f.count[fr] == layout.data + length
    length = np.where(ok, length, 0)
    width = MAX_BYTES if length.max(initial=0) > 8 else 8
    data = np.zeros((fr.size, width), np.uint8)
    for j in range(int(length.max(initial=0))):
        inside = j < length
        has, s, e = f.field(layout.data + j, fr)
        hexes, values = small_hex(f, has, s, e)
        ok &= ~inside | (hexes & (e - s == 2))  # two hex digits, as PEAK writes a byte
        data[:, j] = np.where(inside, values, 0)
    rows_1 = first_line + fr
    passed = {
        name: first_line + rows[kind == code]
        for code, name in ((-1, PASSED[0]), (-2, PASSED[1]), (-3, PASSED[2]))
    }
    passed["other"] = first_line + rows[kind == -4]
    passed["damaged"] = rows_1[~ok]
    return _Part(
        (offset[ok], ids[ok], extended[ok], length[ok], data[ok], bus[ok], rows_1[ok]),
        passed,
    )


def _kinds(f: Fields, rows: np.ndarray, layout: _Layout, version: str) -> np.ndarray:
    """Each message line's kind: 0 a CAN frame, 1 a CAN FD frame; -1 an error frame, -2 a
    remote frame, -3 a bus status or event line, -4 a type the version has none of."""
    kind = np.full(rows.size, -4, np.int64)
    if version in LAYOUT_1:
        if layout.type is None:  # 1.0: the identifier and the bytes say what a line is
            kind[:] = 0
            _, s, e = f.field(layout.ident, rows)
            kind[f.is_(s, e, b"FFFFFFFF")] = -3
        else:
            _, s, e = f.field(layout.type, rows)
            kind[f.is_(s, e, b"Rx") | f.is_(s, e, b"Tx")] = 0
            kind[f.is_(s, e, b"Error")] = -1
            kind[f.is_(s, e, b"Warng")] = -3
        _, s, e = f.field(layout.data, rows)  # the first byte's place
        frame = kind == 0
        if layout.type is None:
            kind[frame & f.is_(s, e, b"ERROR")] = -1
        kind[frame & f.is_(s, e, b"RTR")] = -2
        return kind
    _, s, e = f.field(layout.type, rows)
    kind[f.is_(s, e, b"DT")] = 0
    for word in FD_TYPES:
        kind[f.is_(s, e, word)] = 1
    kind[f.is_(s, e, b"ER")] = -1
    kind[f.is_(s, e, b"RR")] = -2
    for word in STATUS_TYPES:
        kind[f.is_(s, e, word)] = -3
    return kind


def _offset(f: Fields, has: np.ndarray, s: np.ndarray, e: np.ndarray) -> tuple:
    """Whether each field is an offset (digits, at most one ``.`` among them), and its
    value as ``float()`` reads it: the digits as one integer divided once by the power of
    ten its decimals give (both exact in float64, so the one division rounds as
    ``float()`` rounds); one of more than :data:`OFFSET_DIGITS` digits by ``float()``."""
    n = e - s
    width = min(int(n.max(initial=0)), MAX_OFFSET)
    digits = np.zeros(n.size, np.int64)
    whole = np.zeros(n.size, np.int64)
    dots = np.zeros(n.size, np.int64)
    decimals = np.zeros(n.size, np.int64)
    ok = has & (n >= 1) & (n <= MAX_OFFSET)
    for j in range(width):
        inside = j < n
        b = f.byte(s + j)
        d = DEC[b]
        dot = inside & (b == ord("."))
        digit = inside & (d >= 0)
        ok &= ~inside | digit | dot
        decimals += digit & (dots > 0)
        dots += dot
        digits += digit
        whole = np.where(digit & (digits <= OFFSET_DIGITS), whole * 10 + d, whole)
    ok &= (dots <= 1) & (digits >= 1)
    value = whole / 10.0 ** np.minimum(decimals, 22)
    for i in np.flatnonzero(ok & (digits > OFFSET_DIGITS)):  # float() reads these
        value[i] = float(bytes(f.c[s[i] : e[i]]))
    return ok, np.where(ok, value, np.nan)


def _joined(parts: list[_Part], version: str, wall: datetime | None, utc: bool) -> TrcFrames:
    """The chunks' frames as one log's (its start ``wall``, UTC as python-can reads it)."""
    start_s = None if wall is None else wall.replace(tzinfo=UTC).timestamp()
    columns = [np.concatenate(x) for x in zip(*(p.frames for p in parts), strict=True)]
    if not parts:
        columns = [np.zeros(0)] * 4 + [np.zeros((0, 8), np.uint8)] + [np.zeros(0)] * 2
    offset, ids, extended, length, _, bus, rows = columns
    width = max((p.frames[4].shape[1] for p in parts), default=8)
    data = np.zeros((offset.size, width), np.uint8)
    at = 0
    for p in parts:
        chunk = p.frames[4]
        data[at : at + chunk.shape[0], : chunk.shape[1]] = chunk
        at += chunk.shape[0]
    passed: dict[str, int] = {}
    for name in (*PASSED, "other", "damaged"):
        found = np.concatenate([p.passed[name] for p in parts]) if parts else np.zeros(0)
        if not found.size:
            continue
        if name == "other":
            name = f"lines of a type TRC {version} has none of (first at line {int(found[0])})"
        elif name == "damaged":
            name = f"lines damaged (first at line {int(found[0])})"
        passed[name] = int(found.size)
    offset_s = offset.astype(np.float64) / 1000.0
    return TrcFrames(
        offset_s + (start_s or 0.0),
        ids.astype(np.int64),
        extended.astype(bool),
        length.astype(np.int64),
        data,
        bus.astype(np.int64),
        rows.astype(np.int64),
        passed,
        version,
        start_s,
        offset_s,
        wall,
        utc,
    )
