"""A ROS 1 bag read record by record, without its index: a recording cut short.

``rosbag record`` writes a bag's index (its connections and where each chunk's messages
are) when it closes the file, and renames ``drive.bag.active`` to ``drive.bag``. A recorder
that lost power or was killed (the car switched off) leaves the ``.bag.active`` with no
index; ``rosbags`` refuses it ("not indexed"), and ROS's ``rosbag reindex`` rebuilds the
index by reading the records in order. :class:`ScannedBag` does that reading here, so that
:mod:`rwhonet.data.rosbag` reads such a bag as far as it goes: it offers what the reader
takes of ``rosbags``' ``AnyReader`` (``connections``, ``messages``, ``deserialize``,
``typestore``, ``message_count``, ``topics``), and ``rosbags`` deserialises the messages
by the definitions the bag's connection records carry.

**The format** (ROS's "Bag Format 2.0"): the line ``#ROSBAG V2.0``, then records, each a
header (its length, u4 little-endian, and fields ``name=value``, each with its length, u4)
and data (its length, u4, and bytes). The ``op`` field says the record: 0x03 the bag's
header, 0x05 a chunk (its data, ``compression`` none, bz2 or lz4, holds connection and
message records), 0x07 a connection (``conn``, ``topic``; its data a header of ``type``,
``md5sum``, ``message_definition``), 0x02 a message (``conn``, ``time``: u4 seconds and u4
nanoseconds; its data the serialised message), 0x04 and 0x06 the index (passed over).

**As far as it goes.** The records are read in order until one does not fit in the file
(a chunk the recorder was writing, cut where the file ends: its whole records are read;
one compressed, whose compression cannot end, is not); the note says how many messages
were read and where the file stopped.

**A damaged chunk passed over.** A whole chunk that does not unpack (a bz2 or lz4 chunk
with a byte changed: a disk's or a card's error) is passed over, as ``mcap recover``
passes over an MCAP file's, and the chunks after it are read. A closed bag that
``rosbags`` refuses for such damage is read so from its start
(:func:`rwhonet.data.rosbag.read_bag`), its index passed over. A ROS 1 chunk has no
checksum: a changed byte in an uncompressed chunk's message data cannot be told.

**A damaged record header passed over.** Where a chunk's records stop before its end (a
record header damaged: a field's length or name, the record's data length), or the
file's records stop before the file's end (a chunk record's header damaged), the read
goes on at the next place a record starts (:func:`_next_record`): a header whose fields,
each ``name=value`` with its length, fill it exactly, with an ``op`` of a record that
belongs there (in a chunk a message, with a 4-byte ``conn`` and an 8-byte ``time`` whose
nanoseconds are under 10^9, or a connection, with its ``conn`` and ``topic``; in the file
a chunk, with its ``compression`` and ``size``, or the index's records, not a connection:
the first chunk holds them) and data that fit. An uncompressed chunk whose own header is
damaged has its records read too, where what is left of its header says
``compression=none``.
Random bytes pass such a test about never (a 38-byte message header's lengths and names
must all fall right), and the records between are passed over, the notes saying which
bytes. Until stop 90 the rest of the chunk was lost (up to rosbag's 768 KiB: tens of
seconds of a car's topics), and the rest of the file where the damage was a chunk
record's own header.
"""

from __future__ import annotations

import bz2
import mmap
import re
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

MAGIC = b"#ROSBAG V2.0\n"
OP_MESSAGE, OP_HEADER, OP_INDEX, OP_CHUNK, OP_CHUNK_INFO, OP_CONNECTION = 2, 3, 4, 5, 6, 7
IN_CHUNK = (OP_MESSAGE, OP_CONNECTION)  # the records a chunk holds
# the records a read looks for after bytes that are no record in the file: a chunk and the
# index's (a connection record is passed over: one inside a chunk would match)
IN_FILE = (OP_INDEX, OP_CHUNK, OP_CHUNK_INFO)
MAX_HEADER = 4096  # a record header's bytes at most, where a read looks for the next one
_U32 = struct.Struct("<I")
_NAME = re.compile(rb"[a-z_]+")


@dataclass(frozen=True)
class ScannedConnection:
    """A connection record: its number, topic, message type (ROS 2's form, as
    ``rosbags`` names it: ``sensor_msgs/msg/NavSatFix``) and definition."""

    id: int
    topic: str
    msgtype: str
    msgdef: Any  # rosbags' MessageDefinition (its format MSG: ROS 1's text)
    md5sum: str


class MappedFiles:
    """What a bag's files read record by record or page by page share
    (:class:`ScannedBag`, :class:`~rwhonet.data.mcapscan.ScannedMcap`,
    :class:`~rwhonet.data.db3scan.ScannedDb3`): the files mapped for reading and closed
    with it, their connections' topics, and ``rosbags`` deserialising a message by the
    files' types (CDR; ROS 1's own serialisation in :class:`ScannedBag`)."""

    connections: Sequence[ScannedConnection]
    typestore: Any

    def __init__(self) -> None:
        self._handles: list[tuple[Any, mmap.mmap]] = []

    def _map(self, path: Path, named: str | None = None) -> mmap.mmap:
        """``path`` mapped for reading, until :meth:`close`; ValueError where it is empty
        (naming it ``named``, else by its name)."""
        f = open(path, "rb")  # noqa: SIM115 - closed by close()
        try:
            buf = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except ValueError:  # an empty file
            f.close()
            raise ValueError(f"{named or path.name} is empty") from None
        self._handles.append((f, buf))
        return buf

    @property
    def topics(self) -> dict[str, int]:
        return {c.topic: c.id for c in self.connections}

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self.typestore.deserialize_cdr(raw, msgtype)

    def close(self) -> None:
        for f, buf in self._handles:
            buf.close()
            f.close()
        self._handles = []

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class NoWholeMessage(ValueError):
    """A bag or MCAP file read record by record holds no whole message of a connection
    (cut short before any, or the chunk of the connection records damaged)."""


@dataclass
class _Scan:
    connections: dict[int, ScannedConnection] = field(default_factory=dict)
    # each message: its connection, time (ns), chunk and place in the chunk's records
    messages: list[tuple[int, int, int, int, int]] = field(default_factory=list)
    chunks: list[tuple[int, int, str]] = field(default_factory=list)  # start, bytes, how
    stopped: str = ""
    # damaged whole chunks passed over (or their records from the damage on): where, why
    skipped: list[str] = field(default_factory=list)


def _fields(header: bytes | memoryview) -> dict[str, bytes]:
    out, pos, end = {}, 0, len(header)
    while pos + 4 <= end:
        (n,) = _U32.unpack_from(header, pos)
        pos += 4
        if n > end - pos:
            break
        item = bytes(header[pos : pos + n])
        pos += n
        name, sep, value = item.partition(b"=")
        if sep:
            out[name.decode("latin-1")] = value
    return out


def _records(
    buf: bytes | memoryview, pos: int, ends: list[int] | None = None
) -> Iterator[tuple[dict[str, bytes], int, int]]:
    """The records from ``pos``: their fields and their data's start and length (the last
    one's data may run past the buffer: a chunk cut short); ``ends`` is given where the
    records stopped."""
    end = len(buf)
    while True:
        if ends is not None:
            ends[:] = [pos]
        if pos + 8 > end:
            return
        (hlen,) = _U32.unpack_from(buf, pos)
        if hlen > end - pos - 8:
            return
        fields = _fields(buf[pos + 4 : pos + 4 + hlen])
        (dlen,) = _U32.unpack_from(buf, pos + 4 + hlen)
        start = pos + 8 + hlen
        if "op" not in fields:
            return  # no record: the file's bytes end here in substance
        yield fields, start, dlen
        pos = start + dlen


def _exact_fields(header: bytes | memoryview) -> dict[str, bytes] | None:
    """A record header's fields where they fill it exactly, each ``name=value`` (a name of
    lower-case letters and ``_``), else None."""
    out, pos, end = {}, 0, len(header)
    while pos < end:
        if pos + 4 > end:
            return None
        (n,) = _U32.unpack_from(header, pos)
        pos += 4
        if n > end - pos:
            return None
        name, sep, value = bytes(header[pos : pos + n]).partition(b"=")
        if not sep or not _NAME.fullmatch(name):
            return None
        out[name.decode("ascii")] = value
        pos += n
    return out


def _fits(fields: dict[str, bytes], ops: Sequence[int]) -> bool:
    """Whether a header's fields are those of a record of ``ops``: its ``op`` one of them,
    a message's ``conn`` and ``time`` (nanoseconds under 10^9), a chunk's ``compression``
    and ``size``, a connection's ``conn`` and ``topic``."""
    op = fields.get("op", b"")
    if len(op) != 1 or op[0] not in ops:
        return False
    if op[0] == OP_MESSAGE:
        time = fields.get("time", b"")
        return (
            len(fields.get("conn", b"")) == 4
            and len(time) == 8
            and _U32.unpack_from(time, 4)[0] < 1_000_000_000
        )
    if op[0] == OP_CHUNK:
        return "compression" in fields and len(fields.get("size", b"")) == 4
    if op[0] == OP_CONNECTION:
        return len(fields.get("conn", b"")) == 4 and "topic" in fields
    return True


def _next_record(buf: bytes | memoryview, pos: int, ops: Sequence[int], end: int) -> int | None:
    """The first byte from ``pos`` where a record of ``ops`` starts whose header's fields
    fill it exactly (:func:`_exact_fields`, :func:`_fits`) and whose data end by ``end``;
    None where there is none. Found from its ``op`` field (``\\x04\\0\\0\\0op=`` and the
    op's byte), the header's start looked for in the bytes before it."""
    pattern = re.compile(rb"\x04\x00\x00\x00op=[" + re.escape(bytes(ops)) + rb"]")
    for hit in pattern.finditer(buf, pos, end):
        h = hit.start()
        for o in range(max(pos, h - 4 - MAX_HEADER), h - 3):
            (hlen,) = _U32.unpack_from(buf, o)
            if not h + 8 <= o + 4 + hlen <= end - 4:
                continue
            fields = _exact_fields(buf[o + 4 : o + 4 + hlen])
            if fields is None or not _fits(fields, ops):
                continue
            (dlen,) = _U32.unpack_from(buf, o + 4 + hlen)
            if o + 8 + hlen + dlen <= end:
                return o
    return None


def _connection(fields: dict[str, bytes], data: bytes | memoryview) -> ScannedConnection:
    from rosbags.interfaces import MessageDefinition, MessageDefinitionFormat
    from rosbags.typesys.msg import normalize_msgtype

    more = _fields(data)
    topic = fields["topic"].decode()
    return ScannedConnection(
        _U32.unpack(fields["conn"])[0],
        topic if topic.startswith("/") else f"/{topic}",
        normalize_msgtype(more.get("type", b"").decode()),
        MessageDefinition(
            MessageDefinitionFormat.MSG, more.get("message_definition", b"").decode()
        ),
        more.get("md5sum", b"").decode(),
    )


def _scan(buf: bytes | memoryview) -> _Scan:
    """Every whole connection and message record of the bag, chunk by chunk, in order
    (a compressed chunk unpacked to find its records, then let go)."""
    scan = _Scan()
    ends = [len(MAGIC)]
    while _file_records(scan, buf, ends):
        # bytes left that are no record (a chunk record's header damaged): on from the next
        at = ends[0]
        on = _next_record(buf, at + 1, IN_FILE, len(buf))
        stop = len(buf) if on is None else on
        before = len(scan.messages)
        # an uncompressed chunk's records after its damaged header: read (an lz4 chunk's
        # may stand in it as literals, their data not: the header must say "none")
        plain = b"compression=none" in buf[at : min(stop, at + MAX_HEADER)]
        first = _next_record(buf, at + 1, IN_CHUNK, stop) if plain else None
        if first is not None:
            scan.chunks.append((first, stop - first, "none"))
            _chunk_records(scan, buf[first:stop], len(scan.chunks) - 1, first, True)
        read = len(scan.messages) - before
        said = f", {read} messages read from the records in them" if read else ""
        if on is None:
            scan.stopped = f"at byte {at} of {len(buf)}, where no whole record starts{said}"
            break
        scan.skipped.append(f"bytes {at} to {on}, where no whole record starts{said}")
        ends[:] = [on]
    return scan


def _file_records(scan: _Scan, buf: bytes | memoryview, ends: list[int]) -> bool:
    """The file's records from byte ``ends[0]`` into ``scan``, until the file ends (False)
    or bytes that are no record are left (True; ``ends[0]``: where)."""
    for fields, start, dlen in _records(buf, ends[0], ends):
        op = fields["op"][0] if fields["op"] else -1
        end = start + dlen
        if op == OP_CHUNK:
            how = fields.get("compression", b"none").decode("latin-1")
            k = len(scan.chunks)
            scan.chunks.append((start, min(end, len(buf)) - start, how))
            try:
                chunk = _chunk(buf, scan.chunks[k])
            except Exception as err:  # a compressed chunk cut short, or damaged
                if end > len(buf):
                    scan.stopped = f"inside a {how} chunk at byte {start}, which cannot be unpacked"
                    return False
                scan.skipped.append(f"a {how} chunk at byte {start}: {_why(err)}")
                continue
            _chunk_records(scan, chunk, k, start, end <= len(buf))
            del chunk
        elif op == OP_CONNECTION and end <= len(buf):
            c = _connection(fields, buf[start:end])
            scan.connections.setdefault(c.id, c)
        if end > len(buf):
            what = "chunk" if op == OP_CHUNK else "record"
            scan.stopped = f"inside a {what} at byte {start} (its whole records read)"
            return False
    return ends[0] + 8 <= len(buf)


def _why(err: BaseException) -> str:
    return f"{type(err).__name__}: {str(err)[:80]}"


def _chunk_records(scan: _Scan, chunk: bytes | memoryview, k: int, start: int, whole: bool) -> None:
    """The connection and message records of chunk ``k`` (at byte ``start``) into ``scan``:
    its whole records, those from a damaged one to the next place a record starts
    (:func:`_next_record`) passed over (a chunk cut short: up to its end)."""
    ends = [0]
    while True:
        damage = ""
        for inner, at, n in _records(chunk, ends[0], ends):
            if at + n > len(chunk):  # a record running past the chunk: not whole
                break
            try:
                if inner["op"][:1] == bytes([OP_CONNECTION]):
                    c = _connection(inner, chunk[at : at + n])
                    scan.connections.setdefault(c.id, c)
                elif inner["op"][:1] == bytes([OP_MESSAGE]):
                    sec, nsec = struct.unpack("<II", inner["time"])
                    (conn,) = _U32.unpack(inner["conn"])
                    scan.messages.append((conn, sec * 1_000_000_000 + nsec, k, at, n))
            except Exception as err:  # a field damaged: no record of its kind
                damage = _why(err)
                break
        stop = ends[0]
        if not whole or not (damage or stop < len(chunk)):
            return
        why = f" ({damage})" if damage else " (a record damaged)"
        on = _next_record(chunk, stop + 1, IN_CHUNK, len(chunk))
        if on is None:
            where = f"a chunk at byte {start}: its records stop at byte {stop} of {len(chunk)}"
            scan.skipped.append(where + why)
            return
        scan.skipped.append(
            f"a chunk at byte {start}: its bytes {stop} to {on} of {len(chunk)} passed over{why}"
        )
        ends[:] = [on]


def _chunk(buf: bytes | memoryview, where: tuple[int, int, str]) -> bytes | memoryview:
    """A chunk's records (unpacked where compressed)."""
    start, n, how = where
    raw = buf[start : start + n]
    return raw if how == "none" else _decompressed(how, bytes(raw))


def _decompressed(how: str, data: bytes) -> bytes:
    if how == "bz2":
        return bz2.decompress(data)
    if how == "lz4":
        from lz4.frame import decompress

        return decompress(data)  # type: ignore[no-any-return]
    raise ValueError(f"compression {how!r}")


def has_index(path: Path) -> bool:
    """Whether a ROS 1 bag's header points to an index inside the file (``index_pos``:
    0 while it is recorded; past the end where a copy was cut short). True for a file that
    is no bag, which ``rosbags`` then refuses, saying so."""
    with open(path, "rb") as f:
        head = f.read(len(MAGIC) + 8 + 4096)
        size = f.seek(0, 2)
    if not head.startswith(MAGIC):
        return True
    for fields, _, _ in _records(head, len(MAGIC)):
        if fields["op"][0] == OP_HEADER and len(fields.get("index_pos", b"")) == 8:
            (at,) = struct.unpack("<Q", fields["index_pos"])
            return 0 < at < size
        break
    return True


class ScannedBag(MappedFiles):
    """A ROS 1 bag without its index, read record by record (what ``rosbags``'
    ``AnyReader`` offers the reader: :mod:`rwhonet.data.rosbag`)."""

    how = "record by record, rosbags deserialising"  # how the reader's notes say it was read
    # a message that does not deserialise is damaged: passed over (rwhonet.data.rosbag)
    scanned = True

    def __init__(self, path: Path, refused: str | None = None) -> None:
        """Scan the bag at ``path``; ``refused``: why ``rosbags`` refused it closed (read
        here for that reason: a damaged chunk), or None for a bag without its index.

        Raises:
            ValueError: a file that is empty or no ROS 1 bag.
            NoWholeMessage: no whole message.
        """
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        super().__init__()
        self._refused = refused
        self._buf = self._map(path, "the file")
        if self._buf[: len(MAGIC)] != MAGIC:
            self.close()
            raise ValueError("the file does not start as a ROS 1 bag (#ROSBAG V2.0)")
        self._scan = scan = _scan(self._buf)
        if not scan.messages:
            stopped = scan.stopped or "where the file ends"
            skipped = "; ".join(scan.skipped)
            self.close()
            if skipped:  # the cause first: a refusal's text is kept short
                raise NoWholeMessage(
                    f"no whole message: {len(scan.skipped)} damaged stretch(es) passed over "
                    f"({skipped}); it stops {stopped}"
                )
            raise NoWholeMessage(
                f"no whole message: the recording was cut short inside its first chunk ({stopped})"
            )
        self.connections: list[ScannedConnection] = [c for _, c in sorted(scan.connections.items())]
        self.typestore = get_typestore(Stores.EMPTY)
        types: dict[str, Any] = {}
        for c in self.connections:
            if c.msgdef.data:
                types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
        self.typestore.register(types)

    @property
    def message_count(self) -> int:
        return len(self._scan.messages)

    @property
    def said(self) -> str:
        """What was read: the messages, and where the file stopped."""
        end = f"; it stops {self._scan.stopped}" if self._scan.stopped else ""
        if skipped := self._scan.skipped:
            end += f"; {len(skipped)} damaged stretch(es) passed over ({'; '.join(skipped)})"
        why = (
            "the bag has no index (a recording cut short: rosbag record leaves drive.bag.active so)"
            if self._refused is None
            else f"rosbags refused the bag ({self._refused}), closed as it is"
        )
        return f"{why}: read record by record, {self.message_count} whole messages{end}"

    def messages(
        self, connections: Sequence[ScannedConnection] = ()
    ) -> Iterator[tuple[ScannedConnection, int, bytes]]:
        """The messages of ``connections`` (all where none), in the bag's order."""
        by_id = {c.id: c for c in (connections or self.connections)}
        at_chunk, chunk = -1, b""
        for conn, t, k, at, n in self._scan.messages:
            c = by_id.get(conn)
            if c is None:
                continue
            if k != at_chunk:
                at_chunk, chunk = k, _chunk(self._buf, self._scan.chunks[k])
            yield c, t, bytes(chunk[at : at + n])

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self.typestore.deserialize_ros1(raw, msgtype)

    def close(self) -> None:
        self._scan = _Scan()
        super().close()
