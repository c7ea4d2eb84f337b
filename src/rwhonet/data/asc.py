"""A Vector ASC log's CAN frames, parsed over the file's lines at once (numpy).

Vector's ASC (CANalyzer, CANoe, and most bus tools' text export) writes one event a line::

    date Fri Dec 5 10:15:30.123 am 2026
    base hex  timestamps absolute
    internal events logged
    Begin Triggerblock Fri Dec 5 10:15:30.123 am 2026
       0.000000 Start of measurement
       0.001234 1  1A0             Rx   d 8 00 11 22 33 44 55 66 77  Length = 0 BitCount = 0
       0.002100 CANFD   1 Rx        1a0  WheelSpeeds   1 0 d 12 00 11 22 33 ...

A whole bus for an hour is tens of millions of lines, and python-can's
:class:`can.io.asc.ASCReader` builds a ``Message`` a line at a time in Python (0.13 M
rows/s through the pipeline before this module). :func:`asc_frames` gives the same
messages, bit for bit, from the lines split into their whitespace-separated fields all
at once.

**A part at a time.** The file is read from disk (:func:`_blocks`) and never held
whole: its bytes are first looked over :data:`SCAN_BYTES` at a time for control bytes
and for their text encoding, then read as chunks of whole lines of about
:data:`CHUNK_BYTES` (:func:`_text_parts`, a CR LF cut between two blocks kept one line
end), each split into fields and parsed, its frames of messages a map does not need
left out (``kept``) before the next is read. A whole bus's hour of ASC (727 MB) is so
read within a third of a GB, where held whole it took 1.6 GB.

**Where it is exact by construction.** Each line after the header is put in one of three
kinds, field by field, with no Python per line:

- *no event python-can reads*: a first field that is no ``digits.digits`` stamp, or a
  second field neither digits (a classic frame's channel) nor starting ``CANFD``, or too
  few fields: python-can's event pattern (``ASC_MESSAGE_REGEX``) cannot match, and it
  passes the line over (comments, ``Start of measurement``, trigger blocks, statistics);
- *an event in the forms bus tools write*: a classic data frame (channel, identifier of
  1-8 hex digits and an optional ``x``, ``Rx``/``Tx``/``TxRq``, ``d``, a length code of 1-2 hex
  digits, bytes of 1-2 hex digits each), a classic remote frame (``r``), an error frame
  (``ErrorFrame``), a CAN FD frame (``CANFD``, channel, direction, identifier, a frame
  name or none, bit-rate switch, error state, length code, data length of 1-2 decimal
  digits, its bytes) or FD remote frame (data length 0), or an FD error frame. Each is
  read as python-can's ``_process_classic_can_frame`` and ``_process_fd_can_frame`` read
  it: the identifier's ``x`` its extended flag, the first ``min(8, dlc2len(dlc))`` byte
  fields of a classic frame (fewer where fewer are written), the first data-length fields
  of an FD frame, the channel the file's less one;
- *anything else* (a field these forms do not cover: an identifier python-can's
  ``int()`` reads otherwise, a byte of three digits, a missing field): the line goes
  through python-can's own code, the body of ``ASCReader.__iter__`` on that line alone
  (:func:`_one_line`), which yields what python-can yields or raises what it raises.

**The text encoding** (:func:`encoding_of`) is UTF-8 where the bytes are UTF-8, else
Windows' cp1252 (CANoe on a German installation writes ``Mär`` and umlauts in comments
and frame names so; python-can, which decodes with the locale's encoding, refused such a
log whole on a UTF-8 machine). A line with a byte outside ASCII is never read here:
python-can's code reads it, decoded (its ``strip`` and ``split`` take Unicode spaces for
white space).

The file itself goes to python-can whole (:func:`asc_frames` returns None, and
:func:`rwhonet.data.canlog._python_can` opens it in the same encoding) where the fields
would not be the ones python-can's text reading sees: a control character other than tab
and the line ends (``str.split`` splits at some of them, the event pattern does not), a
header whose ``base`` python-can refuses, ``base dec`` (rare; its fields are decimal),
and relative stamps with a byte outside ASCII (the summing pattern's Unicode digits and
spaces), whose sums reach 2**53 ns (104 days), or that have 10**9 s or more, or a first
field of over 24 characters (no bus tool writes these).

**The header** is read as ``ASCReader._extract_header`` reads it, and like it, takes
the line that ends the header as its own: the first line after the date, base and
comment lines and no ``internal events logged`` line is not read as an event (CANoe
writes the events line, so no frame is lost in its logs).

**Time stamps** are ``float()``'s: a stamp's digits read as one integer and divided once
by the power of ten its decimals give, both exact in float64 (below 2**53 and 10**22),
so the one division rounds as ``float()`` rounds; the few stamps beyond go through
``float()``. An ASC of relative stamps (``timestamps relative``: each event's time
since the event before) is read as :class:`rwhonet.data.canlog._SummedStamps` hands it
to python-can: every stamped line's stamp (the header's too) summed in integer
nanoseconds, its first 9 decimals, and each sum read as ``float()`` reads
``seconds.nnnnnnnnn``.

**Where python-can stops, so does this** (:class:`AscError`, with the data frames read
before): the first line whose fields python-can's code raises on (a byte field that is no
number, an FD line with too few fields).
"""

from __future__ import annotations

import codecs
import dataclasses
import io
import itertools
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from rwhonet.data.bytescan import DEC, Fields, small_hex
from rwhonet.data.keptframes import ID_MASK, Kept

Source = bytes | BinaryIO  # a log's bytes, or the log opened for reading bytes

CHUNK_BYTES = 1 << 22  # lines split into fields at once (4 MB of text; bounds the memory)
SCAN_BYTES = 1 << 23  # bytes looked over at once for their encoding and control bytes
EXACT = 2**53  # integers float64 holds exactly
POW10 = np.array([float(10**k) for k in range(23)])  # exact in float64
POW10_INT = 10 ** np.arange(18, dtype=np.int64)
# an ASC event line's time stamp: seconds, a point, its fraction (CANoe writes 6 or 9 digits)
STAMP = re.compile(r"(?P<lead>\s*)(?P<s>\d+)\.(?P<frac>\d+)(?P<rest>\s.*)", re.DOTALL)
# python-can's ASCReader._extract_header's patterns
_DATE = re.compile(r"date\s+\w+\s+(?P<datetime_string>.+)", re.IGNORECASE)
_BASE = re.compile(
    r"base\s+(?P<base>hex|dec)(?:\s+timestamps\s+(?P<timestamp_format>absolute|relative))?",
    re.IGNORECASE,
)
_COMMENT = re.compile(r"//.*")
_START = re.compile(r"^\d+\.\d+\s+Start of measurement")


class AscError(Exception):
    """An ASC log python-can's reader would not read to its end.

    Attributes:
        data_frames: the data frames among the messages python-can yields before it stops.
        cause: the exception python-can's code raises there.
    """

    def __init__(self, cause: Exception, data_frames: int) -> None:
        super().__init__(str(cause))
        self.cause = cause
        self.data_frames = data_frames


@dataclass(frozen=True)
class AscFrames:
    """The messages python-can's reader yields for an ASC log, as arrays, in its order.

    Attributes:
        t_s: each message's time stamp, s, as the log writes it (or the sums of its
            relative stamps).
        ids: its identifier, python-can's ``arbitration_id`` (0 for an error frame; int64,
            or Python's integers where a line python-can reads has one beyond).
        extended: whether the identifier is extended.
        remote: whether it is a remote frame.
        error: whether it is an error frame.
        length: its data bytes.
        data: its bytes, zero after ``length`` (8 a row, or 64 where any frame has more).
        channel: its channel as python-can numbers it (the log's, less one; as ``ids``).
    """

    t_s: np.ndarray
    ids: np.ndarray
    extended: np.ndarray
    remote: np.ndarray
    error: np.ndarray
    length: np.ndarray
    data: np.ndarray
    channel: np.ndarray


def asc_frames(
    raw: Source, relative: bool, encoding: str | None = None, kept: Kept | None = None
) -> AscFrames | None:
    """The messages python-can's ASC reader yields for the log ``raw``, or None where the
    log is one for python-can to read itself (see the module's docstring).

    The log is read a chunk of whole lines at a time (:func:`_text_parts`): a file is
    never held whole, nor are its lines' fields.

    Args:
        raw: the log: its bytes, or the file opened for reading bytes (read from its start).
        relative: its stamps are each event's time since the one before (they are summed
            first, as :class:`rwhonet.data.canlog._SummedStamps` sums them).
        encoding: its text encoding (None: :func:`encoding_of` it).
        kept: the messages to keep (the data frames left out counted there, and dropped
            from each chunk as it is parsed); None: every message.

    Raises:
        AscError: python-can's reader stops at a line (with the data frames before it).
    """
    f = _file(raw)
    other_control, ascii_only = _scan(f)
    if other_control:  # a control byte besides tab and the line ends
        return None
    encoding = encoding or ("utf-8" if ascii_only else encoding_of(f))
    if relative and not ascii_only:  # _SummedStamps' pattern: Unicode digits, spaces
        return None
    parts = _text_parts(f)
    text, header = b"", (0, 0)  # an empty log: no header, no events
    for part in parts:  # the header's lines, and the events' after them in its chunk
        text += part
        header = _header(text, relative, encoding)
        if header is None or header[0] < len(text):
            break
    if header is None:
        return None
    at, carry = header
    chunks: list[AscFrames] = []
    data_frames = 0  # read so far, those left out included
    for chunk in itertools.chain([text[at:]], parts):
        if not chunk:
            continue
        part = _chunk(chunk, relative, carry, encoding)
        if part is None:
            return None
        got = part.frames
        data_frames += int((~got.error & ~got.remote).sum())
        if kept is not None:
            ids = np.asarray(got.ids & ID_MASK).astype(np.int64)
            taken = kept.part(ids, got.extended, got.channel, got.error | got.remote)
            got = got if taken.size == ids.size else _take(got, taken)
        chunks.append(got)
        carry = part.carry
        if part.failed is not None:
            raise AscError(part.failed, data_frames)
    return _joined(chunks)


def _file(raw: Source) -> BinaryIO:
    """The log as a file of bytes (bytes as one in memory, not copied)."""
    return io.BytesIO(raw) if isinstance(raw, bytes) else raw


def _blocks(f: BinaryIO, size: int) -> Iterator[bytes]:
    """The file's bytes from its start, ``size`` at a time."""
    f.seek(0)
    while block := f.read(size):
        yield block


def _scan(f: BinaryIO) -> tuple[bool, bool]:
    """Whether the log has a control byte other than tab, line feed and carriage return
    (python-can's ``str.split`` splits at some of them, its event pattern does not), and
    whether its bytes are all ASCII; read :data:`SCAN_BYTES` at a time."""
    other, ascii_only = False, True
    for block in _blocks(f, SCAN_BYTES):
        c = np.frombuffer(block, np.uint8)
        other = other or bool(((c < 32) & (c != 9) & (c != 10) & (c != 13)).any())
        ascii_only = ascii_only and block.isascii()
    return other, ascii_only


def _text_parts(f: BinaryIO) -> Iterator[bytes]:
    """The file as chunks of whole lines, read :data:`CHUNK_BYTES` at a time, their line
    ends made line feeds (``\\r\\n`` and a lone ``\\r``, as python-can's text reading
    takes them). A chunk ends after its block's last line end; a ``\\r`` that ends a block
    waits for the next one (it may be a ``\\r\\n`` cut in two): one after the other, the
    chunks are the whole file's text with its line ends replaced."""
    rest = b""
    for block in _blocks(f, CHUNK_BYTES):
        text = rest + block
        cut = max(text.rfind(b"\n", 0, len(text) - 1), text.rfind(b"\r", 0, len(text) - 1))
        if text.endswith(b"\n"):
            cut = len(text) - 1
        if cut < 0:
            rest = text
            continue
        rest = text[cut + 1 :]
        yield _line_feeds(text[: cut + 1])
    if rest:
        yield _line_feeds(rest)


def _line_feeds(text: bytes) -> bytes:
    """``text`` with its line ends (``\\r\\n``, a lone ``\\r``) made line feeds."""
    return text.replace(b"\r\n", b"\n").replace(b"\r", b"\n") if b"\r" in text else text


def encoding_of(raw: Source) -> str:
    """The text encoding an ASC (or TRC) log is read in: UTF-8 where its bytes are UTF-8 (what
    python-can reads on a machine whose locale is UTF-8), else Windows' Western code page
    cp1252 (what CANoe's own machine writes and python-can reads there: a German
    installation's ``Mär`` in a date line, an umlaut in a comment), else Latin-1 (any
    bytes). A file is read :data:`SCAN_BYTES` at a time, not held whole, and decoded by an
    incremental decoder: a character cut between two blocks is read whole."""
    f = _file(raw)
    if all(block.isascii() for block in _blocks(f, SCAN_BYTES)):  # the usual log
        return "utf-8"
    for encoding in ("utf-8", "cp1252"):
        decoder = codecs.getincrementaldecoder(encoding)()
        try:
            for block in _blocks(f, SCAN_BYTES):
                decoder.decode(block)
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            continue
        return encoding
    return "latin-1"


def _header(text: bytes, relative: bool, encoding: str) -> tuple[int, int] | None:
    """Where the events start (after the line ``_extract_header`` ends on, which it takes)
    and the relative stamps' sum over the header's lines, ns; None where python-can's
    header reading refuses the base, or the base is decimal."""
    at, carry, base = 0, 0, "hex"
    while at < len(text):
        end = text.find(b"\n", at)
        end = len(text) if end < 0 else end + 1
        line = text[at:end].decode(encoding)
        at = end
        if relative and (match := STAMP.fullmatch(line)) is not None:
            carry += stamp_ns(match)
        line = line.strip()
        if _DATE.match(line):
            continue
        if (match := _BASE.match(line)) is not None:
            base = match.group("base")
            if base not in ("hex", "dec"):
                return None  # python-can raises ValueError: for it to say
            continue
        if _COMMENT.match(line):
            continue
        break  # the events line or the first other line: taken as the header's
    return (at, carry) if base == "hex" else None


def stamp_ns(match: re.Match[str]) -> int:
    """A matched stamp in integer nanoseconds (its first 9 decimals)."""
    return int(match["s"]) * 1_000_000_000 + int(match["frac"][:9].ljust(9, "0"))


@dataclass(frozen=True)
class _Part:
    """A chunk's messages, the relative stamps' sum at its end, and what python-can's code
    raised at a line of it (None: nothing; the messages are those before the line)."""

    frames: AscFrames
    carry: int
    failed: Exception | None


STAMP_WIDTH = 24  # the longest stamp read here (float() reads the rest)


def _stamps(f: Fields, s: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, ...]:
    """Which first fields are ``digits.digits`` stamps of at most :data:`STAMP_WIDTH`
    characters, and their seconds, decimals (as an integer) and count of decimals."""
    n = e - s
    width = int(np.clip(n.max(initial=0), 3, STAMP_WIDTH))  # as far as the longest goes
    m, inside = f.chars(s, e, width)
    d = DEC[m].astype(np.int64)
    dot = (m == 46) & inside
    point = np.argmax(dot, axis=1)
    j = np.arange(width)
    stamp = (
        (n >= 3)
        & (n <= width)
        & (dot.sum(axis=1) == 1)
        & ((d >= 0) | dot | ~inside).all(axis=1)
        & (point > 0)
        & (point < n - 1)
    )
    whole_n, frac_n = point, n - point - 1
    before = j < point[:, None]
    after = (j > point[:, None]) & inside
    digits = np.where(before | after, d, 0)
    # seconds and decimals of up to 18 digits each (longer ones: float() and none here)
    exact = stamp & (whole_n <= 18) & (frac_n <= 18)
    e_whole = np.clip(point[:, None] - 1 - j, 0, 18)
    e_frac = np.clip(n[:, None] - 1 - j, 0, 18)
    seconds = (np.where(before, digits, 0) * np.where(before, 10**e_whole, 0)).sum(axis=1)
    frac = (np.where(after, digits, 0) * np.where(after, 10**e_frac, 0)).sum(axis=1)
    seconds, frac = np.where(exact, seconds, 0), np.where(exact, frac, 0)
    return stamp, exact, seconds, frac, whole_n, frac_n


def _chunk(chunk: bytes, relative: bool, carry: int, encoding: str) -> _Part | None:
    """One chunk of whole lines' messages (see the module's docstring)."""
    f = Fields(np.frombuffer(chunk, np.uint8))
    rows = np.arange(f.lines)
    # a line with a byte outside ASCII is never read here (str.strip and str.split take a
    # Unicode space for white space): python-can's code reads it
    ascii_line = np.ones(f.lines, bool)
    high = np.flatnonzero(f.c >= 128)
    if high.size:
        ascii_line[np.searchsorted(f.newlines, high)] = False
    has0, s0, e0 = f.field(0, rows)
    stamp, exact, seconds, frac, whole_n, frac_n = _stamps(f, s0, e0)
    stamp &= has0
    # a first field too long to read here that may be a stamp: python-can's code decides
    long0 = has0 & (e0 - s0 > STAMP_WIDTH) & (DEC[f.byte(s0)] >= 0) & (DEC[f.byte(e0 - 1)] >= 0)
    t = np.full(f.lines, np.nan)
    sums = None  # the relative stamps' sums, ns
    if relative:
        # a stamped line's stamp is followed by white space (its line end counts); a stamp
        # alone on the file's last line without one is not summed by _SummedStamps, but
        # no line comes after it for the sum to change
        stamped = stamp
        if (stamped & ~exact).any() or (seconds[stamped] >= 10**9).any() or long0.any():
            return None
        taken = np.minimum(frac_n, 9)
        frac9 = np.where(frac_n > 9, frac // 10 ** np.clip(frac_n - 9, 0, 18), frac)
        ns = seconds * 1_000_000_000 + frac9 * 10 ** np.clip(9 - taken, 0, 9)
        sums = carry + np.cumsum(np.where(stamped, ns, 0))
        if sums.size and int(sums[-1]) >= EXACT:
            return None
        carry = int(sums[-1]) if sums.size else carry
        t = sums / 1e9  # float("s.nnnnnnnnn"): the one division, correctly rounded
    else:
        exact &= whole_n + frac_n <= 17  # the digits' integer below 10**17
        whole = seconds * POW10_INT[np.clip(frac_n, 0, 17)] + frac
        exact &= whole < EXACT
        t = np.where(exact, whole / POW10[np.clip(frac_n, 0, 22)], np.nan)
        for i in np.flatnonzero(stamp & ~exact).tolist():
            t[i] = float(chunk[s0[i] : e0[i]])

    has1, s1, e1 = f.field(1, rows)
    digits1, chan1 = f.number(s1, e1, 9, 10)
    long1 = (
        has1 & (e1 - s1 > 9) & (DEC[f.byte(s1)] >= 0)
    )  # digits, maybe: python-can's code decides
    may = stamp & ((digits1 & (f.count >= 3)) | long1 | f.is_(s1, e1, b"canfd", fold=True))
    candidate = np.flatnonzero(may & ascii_line)
    may |= long0 | ~ascii_line  # str.strip() takes Unicode spaces too: its code decides
    fast = np.zeros(f.lines, bool)
    kind = np.zeros(f.lines, np.int8)  # 0 data, 1 remote, 2 error
    chan = np.where(digits1, chan1 - 1, 0)
    ident = np.zeros(f.lines, np.int64)
    ext = np.zeros(f.lines, bool)
    nbytes = np.zeros(f.lines, np.int64)
    first_byte = np.zeros(f.lines, np.int64)  # the field of the first data byte

    # classic frames: channel, identifier, direction, d|r, length code, bytes
    rc = candidate[digits1[candidate]]
    has2, s2, e2 = f.field(2, rc)
    error = has2 & f.is_(s2, e2, b"errorframe", fold=True)
    fast[rc[error]], kind[rc[error]] = True, 2
    idok, idv, idx = _identifier(f, has2, s2, e2)
    _, s3, e3 = f.field(3, rc)
    # python-can's pattern wants a direction starting Rx or Tx (CANoe's TxRq too), any case
    direction = f.is_(s3, e3, b"rx", fold=True) | f.is_(s3, e3, b"tx", fold=True)
    has4, s4, e4 = f.field(4, rc)
    framed = ~error & idok & direction & has4
    remote = framed & ((f.byte(s4) | 32) == ord("r"))
    data = framed & f.is_(s4, e4, b"d") & (f.count[rc] >= 6)
    dlc_ok, dlc = small_hex(f, *f.field(5, rc))
    data &= dlc_ok
    n = np.minimum(8, dlc)  # python-can's min(8, dlc2len(dlc)): the same for every code
    n = np.minimum(n, f.count[rc] - 6)
    fast[rc[remote | data]] = True
    kind[rc[remote]] = 1
    ident[rc[framed]], ext[rc[framed]] = idv[framed], idx[framed]
    nbytes[rc[data]], first_byte[rc[data]] = n[data], 6

    # CAN FD frames: CANFD, channel, direction, identifier, [name], brs, esi, dlc, length
    rf = candidate[f.is_(s1[candidate], e1[candidate], b"CANFD")]
    has2, s2, e2 = f.field(2, rf)
    fd, chan2 = f.number(s2, e2, 9, 10)
    fd &= has2 & (f.count[rf] >= 5)
    chan[rf] = chan2 - 1
    has4, s4, e4 = f.field(4, rf)
    error = fd & f.is_(s4, e4, b"errorframe", fold=True)
    fast[rf[error]], kind[rf[error]] = True, 2
    idok, idv, idx = _identifier(f, has4, s4, e4)
    has5, s5, e5 = f.field(5, rf)
    brs, _ = f.number(s5, e5, 9, 10)
    brs &= has5
    # a fifth field of over 9 characters that starts with a digit (a long bit-rate switch,
    # or a frame name python-can takes for one?): python-can's code decides
    plain = ~(has5 & (e5 - s5 > 9) & (DEC[f.byte(s5)] >= 0))
    at = np.where(brs, 7, 8)  # the length code's field; the data length's after it
    dlc_ok, _ = small_hex(f, *f.field(at, rf))
    has_l, sl, el = f.field(at + 1, rf)
    len_ok, length = f.number(sl, el, 2, 10)
    len_ok &= has_l
    framed = fd & ~error & plain & idok & dlc_ok & len_ok & (length <= 64)
    framed &= f.count[rf] >= at + 3  # python-can splits the data off the fields before
    fast[rf[framed]] = True
    kind[rf[framed & (length == 0)]] = 1
    ident[rf[framed]], ext[rf[framed]] = idv[framed], idx[framed]
    avail = f.count[rf] - (at + 2)
    nbytes[rf[framed]] = np.minimum(length, avail)[framed]
    first_byte[rf[framed]] = (at + 2)[framed]

    # the data bytes of the frames read here: 1-2 hex digits each, else python-can's code
    got = np.flatnonzero(fast & (kind == 0))
    most = int(nbytes[got].max(initial=0))
    payload = np.zeros((got.size, 8 if most <= 8 else 64), np.uint8)
    good = np.ones(got.size, bool)
    if most:
        # every field of the chunk as a byte (1-2 hex digits) at once, then each frame's
        every = np.arange(f.start.size)
        hexes, values = small_hex(f, every >= 0, f.start, f.end)
        at = f.first[got] + first_byte[got]
        for j in range(most):
            inside = nbytes[got] > j
            field = np.minimum(at + j, max(f.start.size - 1, 0))
            ok = hexes[field]
            good &= ~inside | ok
            payload[:, j] = np.where(inside & ok, values[field], 0)
    fast[got[~good]] = False
    nbytes[got[~good]] = 0
    rows = np.flatnonzero(fast)
    data = np.zeros((rows.size, payload.shape[1]), np.uint8)
    data[np.searchsorted(rows, got[good])] = payload[good]
    error = kind[rows] == 2
    read = AscFrames(
        t[rows],
        np.where(error, 0, ident[rows]),  # an error frame's Message: python-can's defaults,
        ext[rows] | error,  # identifier 0, extended
        kind[rows] == 1,
        error,
        nbytes[rows],
        data,
        chan[rows],
    )
    slow = np.flatnonzero(may & ~fast)
    frames, failed = _with_python_can(chunk, f, sums, rows, read, slow, encoding)
    return _Part(frames, carry, failed)


def _identifier(f: Fields, has: np.ndarray, s: np.ndarray, e: np.ndarray) -> tuple:
    """Whether each field is an identifier of 1-8 hex digits and an optional ``x``
    (python-can: extended), its value and whether it is extended."""
    last = f.byte(e - 1) | 32
    ext = has & (e - s >= 2) & (last == ord("x"))
    ok, value = f.number(s, e - ext, 8, 16)
    return has & ok, value, ext & ok


def _with_python_can(
    chunk: bytes,
    f: Fields,
    sums: np.ndarray | None,
    rows: np.ndarray,
    read: AscFrames,
    slow: np.ndarray,
    encoding: str,
) -> tuple[AscFrames, Exception | None]:
    """The chunk's messages in line order: those ``read`` here (at lines ``rows``), and
    python-can's for the ``slow`` lines (:func:`_one_line`), up to the first line its code
    raises on, and what it raised (None: none)."""
    if not slow.size:
        return read, None
    from can.io.asc import ASCReader

    reader = ASCReader(io.StringIO(""))
    failed, at, messages = None, [], []
    for i in slow.tolist():
        first = f.first[i]
        end = int(f.newlines[i]) if i < f.newlines.size else len(chunk)
        line = chunk[int(f.start[first]) : end].decode(encoding)
        if sums is not None:  # python-can reads the stamp as the sum
            seconds, ns = divmod(int(sums[i]), 1_000_000_000)
            line = f"{seconds}.{ns:09d}" + line[int(f.end[first] - f.start[first]) :]
        try:
            msg = _one_line(reader, line)
        except Exception as err:  # whatever python-can's code raises there
            failed = err
            read = _take(read, np.flatnonzero(rows < i))
            rows = rows[rows < i]
            break
        if msg is not None:
            at.append(i)
            messages.append(msg)
    both = _joined([read, _of_messages(messages)])
    return _take(both, np.argsort(np.concatenate([rows, at]), kind="stable")), failed


def _one_line(reader, line: str):  # type: ignore[no-untyped-def]
    """What python-can's ``ASCReader.__iter__`` yields for one line after the header (its
    loop's body, its start time 0 as ``can.LogReader`` opens it): a message or None."""
    from can.io.asc import ASC_MESSAGE_REGEX, ASC_TRIGGER_REGEX

    line = line.strip()
    if ASC_TRIGGER_REGEX.match(line) or _START.match(line):
        return None
    if not ASC_MESSAGE_REGEX.match(line):
        return None
    kwargs: dict[str, object] = {}
    try:
        stamp, channel, rest = line.split(None, 2)
        kwargs["timestamp"] = float(stamp) + reader.start_time
        if channel == "CANFD":
            kwargs["is_fd"] = True
        elif channel.isdigit():
            kwargs["channel"] = int(channel) - 1
        else:
            return None
    except ValueError:
        return None
    if "is_fd" not in kwargs:
        return reader._process_classic_can_frame(rest, kwargs)
    return reader._process_fd_can_frame(rest, kwargs)


def _of_messages(messages: list) -> AscFrames:  # type: ignore[type-arg]
    """python-can's messages as arrays."""
    lengths = np.array([len(m.data) for m in messages], np.int64)
    data = np.zeros((len(messages), 8 if lengths.max(initial=0) <= 8 else 64), np.uint8)
    for k, m in enumerate(messages):
        data[k, : lengths[k]] = np.frombuffer(bytes(m.data), np.uint8)
    return AscFrames(
        np.array([m.timestamp for m in messages], np.float64),
        _ints([m.arbitration_id for m in messages]),
        np.array([m.is_extended_id for m in messages], bool),
        np.array([m.is_remote_frame for m in messages], bool),
        np.array([m.is_error_frame for m in messages], bool),
        lengths,
        data,
        _ints([m.channel for m in messages]),
    )


def _ints(values: list[int]) -> np.ndarray:
    """Integers as int64, or as Python's where one is beyond (python-can reads a field of
    any length: an identifier or channel of 20 digits in a damaged line)."""
    try:
        return np.array(values, np.int64)
    except OverflowError:
        return np.array(values, object)


def _take(frames: AscFrames, index: np.ndarray) -> AscFrames:
    """The messages ``index`` of ``frames``, in its order."""
    return AscFrames(*(getattr(frames, k.name)[index] for k in dataclasses.fields(AscFrames)))


def _joined(parts: list[AscFrames]) -> AscFrames:
    """Messages one after the other (their data as wide as the widest's)."""
    if not parts:
        return _of_messages([])
    width = max(p.data.shape[1] for p in parts)
    joined = {
        k.name: np.concatenate([getattr(p, k.name) for p in parts])
        for k in dataclasses.fields(AscFrames)
        if k.name != "data"
    }
    data = [np.pad(p.data, ((0, 0), (0, width - p.data.shape[1]))) for p in parts]
    return AscFrames(**joined, data=np.concatenate(data))
