"""A Vector BLF log's CAN frames, parsed over the file's objects a batch at a time (numpy).

Vector's Binary Logging Format (CANoe, CANalyzer, Vector's loggers) is the bus tools'
most common log, and a whole bus for an hour is tens of millions of frames. python-can's
:class:`can.io.blf.BLFReader` builds a ``Message`` a frame at a time in Python (0.56 M
frames/s on this machine, 500,000 frames of 8 bytes); this reader gives the same frames,
bit for bit, from the file's objects found and read column by column (2.0 M frames/s):
:func:`blf_frames`. The containers are inflated and their objects parsed
:data:`BATCH_BYTES` (16 MB) at a time, each batch going on from where python-can's reader
would (the object it had not all of, or where the last one ended), so that a long log's
memory is a batch's and that of the frames kept (a :class:`rwhonet.data.keptframes.Kept`
leaves out, a batch at a time, the frames of messages the map does not name).

**The layout** (python-can's reader, which follows Toby Lorenz's Vector BLF library; no
official specification is published): a file header (``LOGG``, its size, the start as
a SYSTEMTIME), then objects (``LOBJ``, header size and version, object size and type),
each padded to 4 bytes. Top-level objects are log containers (type 10) of zlib-deflated
(or stored) inner objects; the inner objects run on from one container into the next,
each found within 4 bytes after the one before ends (python-can's ``index(b"LOBJ", pos,
pos + 8)``). An inner object's header (version 1 or 2) gives its flags and time stamp
(10 µs where the flags are 1, else 1 ns, from the file's start); the objects read:

- ``CAN_MESSAGE`` (1) and ``CAN_MESSAGE2`` (86): channel, flags (remote: 0x80), length
  code, identifier (extended: 0x80000000), 8 bytes; the data its first ``min(dlc, 8)``;
- ``CAN_FD_MESSAGE`` (100): as above with the valid bytes' count and 64 bytes;
- ``CAN_FD_MESSAGE_64`` (101): channel, length code, valid bytes, identifier, flags
  (remote: 0x10) and the data after the 40-byte message header;
- ``CAN_ERROR_EXT`` (73): an error frame (counted, as python-can yields it).

Every other object (bus statistics, markers, other buses) is passed over, as python-can
passes it over, and so is an inner object of a header version other than 1 or 2.

**Where python-can refuses, so does this** (:class:`BlfError`, with the frames read
before): a file that does not start ``LOGG``, a top-level object that is no ``LOBJ``, an
inner object not found where the one before ends, a container that zlib cannot inflate.
A log cut short (a logger that lost power) gives the frames it holds whole, as
python-can's reader does: the last container inflated as far as it goes, an object cut
at the end left out.

**The time stamps** are the header's start plus each object's stamp times its factor,
in python-can's floating-point operations. The start is a Windows SYSTEMTIME, a wall
time without a zone (python-can's writer writes the writing computer's local time).
python-can reads it on the *reading* computer's clock (``systemtime_to_timestamp``), so
one log read in Berlin and on a UTC server gave times an hour apart. Here it is read as
UTC, as python-can reads it on a UTC machine, wherever it is read; or, with the signal
map's ``local_zone``, in that zone (:func:`blf_start`; a start in the hour a change of
summer time repeats or skips is refused, :func:`rwhonet.data.texttime.local_to_unix`).
"""

from __future__ import annotations

import dataclasses
import mmap
import zlib
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from rwhonet.data.keptframes import ID_MASK, Kept
from rwhonet.data.texttime import local_to_unix

LOGG, LOBJ = b"LOGG", b"LOBJ"
LOG_CONTAINER = 10
CAN_MESSAGE, CAN_MESSAGE2, CAN_ERROR_EXT = 1, 86, 73
CAN_FD_MESSAGE, CAN_FD_MESSAGE_64 = 100, 101
YIELDED = (CAN_MESSAGE, CAN_MESSAGE2, CAN_ERROR_EXT, CAN_FD_MESSAGE, CAN_FD_MESSAGE_64)
BASE_SIZE = 16  # signature, header size, header version, object size, object type
HEADER_SIZE = {1: 16, 2: 24}  # the rest of an inner object's header, by its version
CAN_MSG_EXT = 0x8000_0000
REMOTE_FLAG = 0x80  # CAN_MESSAGE's and CAN_FD_MESSAGE's flags
FD64_REMOTE = 0x0010  # CAN_FD_MESSAGE_64's flags
FD64_DATA_AT = 40  # CAN_FD_MESSAGE_64's message header before its data
NO_COMPRESSION, ZLIB_DEFLATE = 0, 2
Buffer = bytes | mmap.mmap


class BlfError(Exception):
    """A BLF log python-can's reader would not read to its end.

    Attributes:
        data_frames: the data frames among the messages python-can yields before the
            damage (None: the file is no BLF log).
    """

    def __init__(self, message: str, data_frames: int | None) -> None:
        super().__init__(message)
        self.data_frames = data_frames


@dataclass(frozen=True)
class BlfFrames:
    """The messages python-can's reader yields for a BLF log, as arrays, in its order.

    Attributes:
        t_s: each message's time stamp, s (the file's start plus the object's stamp).
        ids: its identifier as the object holds it (the extended flag 0x80000000 in it).
        remote: whether it is a remote frame.
        error: whether it is an error frame (``CAN_ERROR_EXT``).
        length: its data bytes.
        data: its bytes, zero after ``length`` (8 a row, or 64 where any frame has more).
        channel: its channel as python-can numbers it (the object's, less one).
    """

    t_s: np.ndarray
    ids: np.ndarray
    remote: np.ndarray
    error: np.ndarray
    length: np.ndarray
    data: np.ndarray
    channel: np.ndarray


def _u(buf: np.ndarray, at: np.ndarray, width: int) -> np.ndarray:
    """Little-endian unsigned integers of ``width`` bytes (1, 2, 4 or 8) at offsets ``at``
    (each within the buffer): gathered from the buffer viewed as such integers at each of
    its ``width`` alignments, an item a read."""
    if width == 1:
        return buf[at].astype(np.int64)
    out = np.empty(at.size, np.uint64 if width == 8 else np.int64)
    shift = at % width
    for r in range(width):
        sel = shift == r
        if not sel.any():
            continue
        items = (buf.size - r) // width
        view = buf[r : r + items * width].view(f"<u{width}")
        out[sel] = view[(at[sel] - r) // width]
    return out


def blf_start(systemtime: tuple[int, ...], zone: str | None = None) -> float:
    """A BLF header's start (its SYSTEMTIME's eight fields) in Unix seconds: as UTC, or
    in ``zone`` (IANA); 0 where the fields are no date, as python-can reads them.

    Raises:
        LocalTimeUnclear: the start is in the hour ``zone``'s clocks went back or skipped.
    """
    from datetime import UTC, datetime

    try:
        year, month, _, day, hour, minute, second, ms = systemtime
        wall = datetime(year, month, day, hour, minute, second, ms * 1000)
    except ValueError:
        return 0.0
    if zone is None:
        return wall.replace(tzinfo=UTC).timestamp()
    return local_to_unix(wall, zone)


def _containers(
    raw: Buffer, cut: list[str] | None = None, zone: str | None = None
) -> tuple[float, Iterator[bytes], list[str]]:
    """The file's start time, its containers' inner bytes (inflated, one after the other,
    up to any damage), and the damage python-can's reader would stop at after reading them
    (appended to the list once the containers run out; none: it reads to the end).
    ``cut``: where the file ends inside an object (a logger that lost power), said;
    ``zone``: the start's (:func:`blf_start`)."""
    import struct

    from can.io.blf import FILE_HEADER_STRUCT, LOG_CONTAINER_STRUCT

    if raw[:4] != LOGG or len(raw) < FILE_HEADER_STRUCT.size:
        raise BlfError("the file does not start with a BLF header (LOGG)", None)
    header = FILE_HEADER_STRUCT.unpack_from(raw)
    start = blf_start(header[14:22], zone)
    rest = header[1] - FILE_HEADER_STRUCT.size  # python-can reads this much more of it
    if rest < -1:
        raise BlfError(f"a file header of {header[1]} bytes, less than its fields", None)
    damage: list[str] = []

    def inflated() -> Iterator[bytes]:
        pos = len(raw) if rest == -1 else FILE_HEADER_STRUCT.size + rest
        while pos < len(raw):
            if len(raw) - pos < BASE_SIZE:
                damage.append("an object header cut short")
                return
            signature, _, _, size, kind = struct.unpack_from("<4sHHLL", raw, pos)
            if signature != LOBJ:
                damage.append(f"no object at byte {pos}")
                return
            if size == BASE_SIZE - 1:  # python-can reads the rest of the file as its body
                body, pos = raw[pos + BASE_SIZE :], len(raw)
            elif size < BASE_SIZE:
                damage.append(f"an object of {size} bytes, less than its header")
                return
            else:
                body = raw[pos + BASE_SIZE : pos + size]
                if pos + size > len(raw) and cut is not None:
                    cut.append(
                        f"the log cut short: it ends in an object of {size:,} bytes at byte "
                        f"{pos:,}, {len(raw) - pos:,} of them there (read as far as it goes)"
                    )
                pos += size + size % 4
            if kind != LOG_CONTAINER:
                continue
            if len(body) < LOG_CONTAINER_STRUCT.size:
                damage.append("a log container cut short")
                return
            method, _ = LOG_CONTAINER_STRUCT.unpack_from(body)
            data = body[LOG_CONTAINER_STRUCT.size :]
            if method == ZLIB_DEFLATE:
                try:
                    data = zlib.decompressobj().decompress(data)
                except zlib.error as err:
                    damage.append(f"a log container zlib cannot inflate ({err})")
                    return
            elif method != NO_COMPRESSION:
                continue  # python-can warns and passes the container over
            yield data

    return start, inflated(), damage


def _chain(buf: np.ndarray, first: bool = True) -> tuple[np.ndarray, str | None, int | None]:
    """The inner objects' offsets as python-can's reader walks them, why it stops with an
    error (None: it reads to the stream's end), and where it would go on reading were
    more of the stream there (the object it has not all of, or where the last ends; None
    after an error). ``first``: ``buf`` starts the stream (else it starts where the
    object before it ended).

    Each object is the first ``LOBJ`` within 4 bytes after the one before ends (its offset
    plus its size). Every ``LOBJ`` in the stream is a candidate; where each one's successor
    is the next (no ``LOBJ`` among an object's bytes, as in every log a tool writes), the
    candidates are the chain, found at once; otherwise the chain is walked from candidate
    to successor."""
    n = buf.size
    none = np.zeros(0, np.int64)
    if n < 4:
        return none, None, 0
    # the signature as a 4-byte integer, looked for in the stream viewed as such integers
    # at each of its 4 alignments (a pass a quarter of the stream's size each)
    sig = int.from_bytes(LOBJ, "little")
    found = []
    for r in range(4):
        items = (n - r) // 4
        found.append(np.flatnonzero(buf[r : r + 4 * items].view("<u4") == sig) * 4 + r)
    cand = np.sort(np.concatenate(found)).astype(np.int64)
    if not cand.size or cand[0] > 4:  # python-can's first search: LOBJ within [0, 4]
        if n < 8:
            return none, None, 0
        where = "the inner stream starts" if first else "the one before ends"
        return none, f"no object where {where}", None
    whole = cand[cand + BASE_SIZE <= n]  # those with a header to read
    if not whole.size or whole[0] != cand[0]:
        return none, None, 0  # the first object's header cut: nothing read
    size = _u(buf, whole + 8, 4)
    end = whole + size
    at = np.searchsorted(cand, end)
    succ = cand[np.minimum(at, cand.size - 1)]
    ok = (at < cand.size) & (succ <= end + 4)
    if np.all(size > 0) and np.all(ok[:-1]) and np.array_equal(succ[:-1], whole[1:]):
        chain, last = whole, whole.size - 1
    else:
        index = {int(p): i for i, p in enumerate(whole)}
        walked, i = [], 0
        while True:
            walked.append(i)
            if size[i] == 0:  # python-can's reader would find this object for ever
                return whole[walked[:-1]], "an object of size 0", None
            j = index.get(int(succ[i])) if ok[i] else None
            if j is None:
                break
            i = j
        chain, last = whole[walked], i
    stop = int(end[last])
    if stop > n:  # the last object runs past the stream's end: cut, not read
        return chain[:-1], None, int(chain[-1])
    after = cand[(cand >= stop) & (cand <= stop + 4)]
    if after.size or stop + 8 > n:
        return chain, None, stop  # the next object's header cut, or the stream's end
    return chain, "no object where the one before ends", None


BATCH_BYTES = 1 << 24  # inner objects parsed at once (16 MB inflated; bounds the memory)


def blf_frames(
    raw: Buffer, kept: Kept | None = None, cut: list[str] | None = None, zone: str | None = None
) -> BlfFrames:
    """The messages python-can's BLF reader yields for the log's bytes ``raw`` (module
    docstring): its containers inflated and their objects parsed :data:`BATCH_BYTES` at a
    time, each batch from where the objects before it end.

    Args:
        raw: the log's bytes (or the file mapped in memory).
        kept: the messages to keep (the data frames left out counted there, and dropped
            from each batch as it is parsed); None: every message.
        cut: where the log ends inside an object is appended to it (a logger that lost
            power: read as far as it goes, as python-can reads it, and said).
        zone: the logging computer's time zone, which puts the header's start on UTC
            (None: it is read as UTC; :func:`blf_start`).

    Raises:
        BlfError: where python-can's reader raises, with the messages it yielded before.
    """
    start, containers, damage = _containers(raw, cut, zone)
    parts: list[BlfFrames] = []
    carry, batch, size, data_frames = b"", [], 0, 0
    first = True
    for inner in containers:
        batch.append(inner)
        size += len(inner)
        if size < BATCH_BYTES:
            continue
        buf = carry + b"".join(batch)
        got, stop, resume = _objects(np.frombuffer(buf, np.uint8), start, first)
        carry, batch, size = buf[resume:] if resume is not None else b"", [], 0
        first = first and resume == 0
        data_frames += _kept_part(got, kept, parts)
        if stop is not None:
            raise BlfError(stop, data_frames)
    buf = carry + b"".join(batch)
    got, stop, _ = _objects(np.frombuffer(buf, np.uint8), start, first)
    data_frames += _kept_part(got, kept, parts)
    if stop is not None or damage:
        raise BlfError(stop or damage[0], data_frames)
    return _joined(parts)


def _kept_part(got: BlfFrames, kept: Kept | None, parts: list[BlfFrames]) -> int:
    """Add a batch's messages to ``parts`` (those ``kept`` keeps); its data frames, those
    left out included."""
    data_frames = int(np.sum(~got.error & ~got.remote))
    if kept is not None:
        ids = (got.ids & ID_MASK).astype(np.int64)
        at = kept.part(ids, (got.ids & CAN_MSG_EXT) != 0, got.channel, got.error | got.remote)
        if at.size < got.t_s.size:
            got = BlfFrames(*(getattr(got, f.name)[at] for f in dataclasses.fields(BlfFrames)))
    parts.append(got)
    return data_frames


def _joined(parts: list[BlfFrames]) -> BlfFrames:
    """Batches' messages one after the other (their data as wide as the widest's)."""
    if len(parts) == 1:
        return parts[0]
    width = max((p.data.shape[1] for p in parts), default=8)
    return BlfFrames(
        *(
            np.concatenate([np.pad(p.data, ((0, 0), (0, width - p.data.shape[1]))) for p in parts])
            if f.name == "data"
            else np.concatenate([getattr(p, f.name) for p in parts])
            for f in dataclasses.fields(BlfFrames)
        )
    )


def _objects(
    buf: np.ndarray, start: float, first: bool
) -> tuple[BlfFrames, str | None, int | None]:
    """The messages of the inner objects in ``buf`` (the stream's first bytes where
    ``first``), why python-can's reader stops with an error in it (None: it does not),
    and where it goes on reading in the next batch, if there is one (None: it stops)."""
    n = buf.size
    chain, stop, resume = _chain(buf, first)
    version = _u(buf, chain + 6, 2)
    kind = _u(buf, chain + 12, 4)
    read = np.isin(version, (1, 2))
    body = chain + BASE_SIZE + np.where(version == 2, HEADER_SIZE[2], HEADER_SIZE[1])
    msg_size = np.select(
        [
            np.isin(kind, (CAN_MESSAGE, CAN_MESSAGE2)),
            kind == CAN_FD_MESSAGE,
            kind == CAN_FD_MESSAGE_64,
            kind == CAN_ERROR_EXT,
        ],
        [16, 84, FD64_DATA_AT, 32],
        0,
    )
    # an object whose header or message runs past the stream's end: python-can waits for
    # the next container (in the next batch, or none: the reading ends)
    past = read & (body + msg_size > n)
    if past.any():
        keep = int(np.argmax(past))
        resume = int(chain[keep])
        chain, version, kind, read, body = (x[:keep] for x in (chain, version, kind, read, body))
        stop = None
    yielded = read & np.isin(kind, YIELDED)
    at, kind, obj = body[yielded], kind[yielded], chain[yielded]
    flags = _u(buf, obj + BASE_SIZE, 4)
    t_s = _u(buf, obj + 24, 8).astype(np.float64) * np.where(flags == 1, 1e-5, 1e-9) + start
    m = at.size
    channel, ids = np.zeros(m, np.int64), np.zeros(m, np.int64)
    remote, length, data_at = np.zeros(m, bool), np.zeros(m, np.int64), np.zeros(m, np.int64)
    # (kinds, channel bytes, flags at, remote bit, length at, its cap, identifier at, data at)
    layouts = (
        ((CAN_MESSAGE, CAN_MESSAGE2), 2, 2, REMOTE_FLAG, 3, 8, 4, 8),
        ((CAN_FD_MESSAGE,), 2, 2, REMOTE_FLAG, 14, 64, 4, 20),
        ((CAN_FD_MESSAGE_64,), 1, 12, FD64_REMOTE, 2, 64, 4, FD64_DATA_AT),
        ((CAN_ERROR_EXT,), 2, None, 0, 10, 8, 16, 24),
    )
    for kinds, ch_bytes, flags_at, bit, len_at, cap, id_at, data_off in layouts:
        sel = np.isin(kind, kinds)
        if not sel.any():
            continue
        a = at[sel]
        channel[sel] = _u(buf, a, ch_bytes)
        ids[sel] = _u(buf, a + id_at, 4)
        if flags_at is not None:
            width = 4 if flags_at == 12 else 1
            remote[sel] = (_u(buf, a + flags_at, width) & bit) != 0
        length[sel] = np.minimum(_u(buf, a + len_at, 1), cap)
        data_at[sel] = a + data_off
    length = np.minimum(length, np.maximum(n - data_at, 0))  # FD 64's data cut at the end
    width = 8 if length.max(initial=0) <= 8 else 64
    cols = np.arange(width)
    idx = np.minimum(data_at[:, None] + cols, max(n - 1, 0))
    data = np.where(cols < length[:, None], buf[idx] if n else 0, 0).astype(np.uint8)
    error = kind == CAN_ERROR_EXT
    return BlfFrames(t_s, ids, remote, error, length, data, channel - 1), stop, resume
