"""A ROS 2 bag's MCAP files read record by record, without their summary: a recording cut short.

``ros2 bag record`` with MCAP storage (the default since ROS 2 Iron) writes each file's
summary (its schemas, channels, chunk index and statistics) and footer when it closes it,
and the folder's ``metadata.yaml`` after that. A recorder that lost power or was killed
(the car switched off) leaves a file that ends without them, often inside the chunk it was
writing; ``rosbags`` refuses it ("File end magic is invalid"), and so does ``ros2 bag
reindex``. :class:`ScannedMcap` reads such files from their start, as ``mcap recover``
(Foxglove's tool) does, so that :mod:`rwhonet.data.rosbag` reads the drive as far as it
goes: it offers what the reader takes of ``rosbags``' ``AnyReader`` (``connections``,
``messages``, ``deserialize``, ``typestore``, ``message_count``, ``topics``), and
``rosbags`` deserialises the messages by the definitions the files' schema records carry.
Closed files ``rosbags`` refuses (a chunk that fails its CRC, a damaged summary or
footer) are read so too (:func:`rwhonet.data.rosbag.read_bag`).

**The format** (MCAP, mcap.dev/spec): the magic ``\\x89MCAP0\\r\\n``, then records, each an
opcode (u8), a length (u64 little-endian) and that many bytes: 0x01 the header (its
profile ``ros2``), 0x03 a schema (id u16, name, encoding, data: the message definition),
0x04 a channel (id u16, schema id u16, topic, message encoding, metadata), 0x05 a message
(channel id u16, sequence u32, log time u64, publish time u64, the serialised message),
0x06 a chunk (message start and end times u64, uncompressed size u64, CRC-32 u32,
compression string, its records' bytes: schemas, channels and messages), 0x0F the end of
the data section; the rest (message and chunk indexes, statistics, metadata, attachments)
is passed over. Strings are a u32 length and UTF-8 bytes. A message's time is its log
time, as ``rosbags`` takes it (rosbag2's receipt time).

**As far as it goes.** The records are read in order until one does not fit in the file
(the record being written when the recorder stopped): an uncompressed chunk cut so gives
its whole records (rosbag2's default preset writes chunks uncompressed), and so does a zstd
or lz4 one (its ``zstd_fast`` and ``zstd_small`` presets), decompressed as far as its
frame's whole blocks go (zstd's and lz4's streaming decompressors give them; no CRC can be
checked on part of a chunk); another compression gives nothing. A whole chunk is
decompressed and its CRC checked by ``rosbags``. A damaged record ends the read there, as
the file's end would, with one exception: a whole chunk whose data is damaged (its CRC
fails, it does not decompress, a record inside it is shorter than its fields) is passed
over from the damage on (a chunk that fails its CRC or does not decompress: all of it; one
without a CRC: its whole records before the damaged one are read, as those of a chunk cut
short are), and the records after it are read on, as ``mcap recover`` passes over an
invalid chunk. Its length, outside its data, says where the next record begins; that record
must start with an opcode of the format, or the read ends at the chunk after all (a length
damaged too). The notes say how many messages were read, which chunks were passed over, and
where each file stopped.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rwhonet.data.bagscan import MappedFiles, NoWholeMessage, ScannedConnection

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_DATA_END = 1, 3, 4, 5, 6, 0x0F
# every opcode of the format (mcap.dev/spec: 0x01 header .. 0x0F data end)
OPCODES = frozenset(range(0x01, 0x10))
_NAMES = {OP_HEADER: "header", OP_SCHEMA: "schema", OP_CHANNEL: "channel", OP_MESSAGE: "message"}
_NAMES |= {OP_CHUNK: "chunk", 7: "message index", 8: "chunk index", 0x0C: "metadata"}
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_RECORD = struct.Struct("<BQ")  # opcode, length
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_CHUNK = struct.Struct("<QQQI")  # start, end, uncompressed size, CRC


def is_finished(path: Path) -> bool:
    """Whether an MCAP file ends as a closed one does (its footer's closing magic). True for
    a file that is no MCAP file, which ``rosbags`` then refuses, saying so."""
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            return True
        size = f.seek(0, 2)
        if size < 2 * len(MAGIC) + 9:
            return False
        f.seek(size - len(MAGIC))
        return f.read(len(MAGIC)) == MAGIC


class _Damaged(Exception):
    """A record that cannot be what its opcode says (a write the recorder left damaged)."""


def _string(buf: Any, pos: int) -> tuple[str, int]:
    (n,) = _U32.unpack_from(buf, pos)
    if pos + 4 + n > len(buf):
        raise _Damaged(f"a string of {n} bytes past the data's end")
    return bytes(buf[pos + 4 : pos + 4 + n]).decode("utf-8"), pos + 4 + n


@dataclass
class _File:
    """One file's records: where its chunks are, and its messages."""

    path: Path
    size: int = 0
    # each chunk: its records' start and length in the file, compression, sizes and CRC
    chunks: list[tuple[int, int, str, int, int]] = field(default_factory=list)
    # each message: its channel, log time (ns), chunk (-1: the file itself), start, length
    messages: list[tuple[int, int, int, int, int]] = field(default_factory=list)
    stopped: str = ""
    # the chunk it stops in is compressed and none of it was read
    unread_cut: bool = False
    # damaged whole chunks passed over: where each is, and why
    skipped: list[str] = field(default_factory=list)


@dataclass
class _Meta:
    schemas: dict[tuple[int, int], tuple[str, str, str]] = field(default_factory=dict)
    channels: dict[tuple[int, int], tuple[str, int]] = field(default_factory=dict)


class ScannedMcap(MappedFiles):
    """A ROS 2 bag's MCAP files (in order) read record by record, as far as each goes (what
    ``rosbags``' ``AnyReader`` offers the reader: :mod:`rwhonet.data.rosbag`).

    Raises:
        ValueError: a file that is no MCAP file of the ``ros2`` profile.
        NoWholeMessage: no whole message.
    """

    how = "its MCAP records one by one, rosbags deserialising"  # as the reader's notes say
    # a message that does not deserialise is damaged: passed over (rwhonet.data.rosbag)
    scanned = True

    def __init__(self, paths: Sequence[Path], refused: str | None = None) -> None:
        """Scan ``paths``; ``refused``: why ``rosbags`` refused the closed files (read here
        for that reason: a damaged chunk or summary), or None for files cut short."""
        super().__init__()
        self._files: list[_File] = []
        meta = _Meta()
        try:
            for k, path in enumerate(paths):
                buf = self._open(path)
                self._files.append(_scan(buf, k, path, meta))
        except Exception:
            self.close()
            raise
        # a message whose channel has no channel record (its id damaged): passed over
        self.orphans = 0
        for k, f in enumerate(self._files):
            kept = [m for m in f.messages if (k, m[0]) in meta.channels]
            self.orphans += len(f.messages) - len(kept)
            f.messages = kept
        if not any(f.messages for f in self._files):
            stops = "; ".join(f"{f.stopped}" for f in self._files if f.stopped)
            skipped = [x for f in self._files for x in f.skipped]
            self.close()
            if skipped:  # the cause first: a refusal's text is kept short
                raise NoWholeMessage(
                    f"no whole message: {len(skipped)} damaged chunk(s) passed over "
                    f"({'; '.join(skipped)}), {self.orphans} message(s) of no channel record "
                    "after" + (f"; cut short {stops}" if stops else "")
                )
            raise NoWholeMessage(f"no whole message: cut short {stops or 'before any'}")
        self._ids: dict[tuple[int, int], int] = {}
        connections = []
        for key, (topic, schema_id) in sorted(meta.channels.items()):
            name, encoding, data = meta.schemas.get((key[0], schema_id), ("", "", ""))
            self._ids[key] = len(connections) + 1
            connections.append(
                ScannedConnection(
                    len(connections) + 1, topic, name, ros2_definition(encoding, data), ""
                )
            )
        self.connections: list[ScannedConnection] = connections
        self.typestore = definitions_typestore(connections)
        stops = [f"{f.path.name} stops {f.stopped}" for f in self._files if f.stopped]
        stops += [
            f"{f.path.name}: {len(f.skipped)} damaged chunk(s) passed over ({'; '.join(f.skipped)})"
            for f in self._files
            if f.skipped
        ]
        # what was read: the messages, and where each file stopped
        files = "the file" if len(self._files) == 1 else "its files"
        why = (
            f"{'the file has' if len(self._files) == 1 else 'its files have'} no summary (a "
            "recording cut short: ros2 bag record writes it as it closes a file)"
            if refused is None
            else f"rosbags refused {files} ({refused}), closed as they are"
        )
        self.said = (
            f"{why}: read record by record, {self.message_count} whole messages"
            + (f"; {'; '.join(stops)}" if stops else "")
            + (
                f"; {self.orphans} message(s) of no channel record passed over"
                if self.orphans
                else ""
            )
            + (
                ""
                if not any(f.unread_cut for f in self._files)
                else " (a compressed chunk cut short: none of its messages read)"
            )
        )

    def _open(self, path: Path) -> mmap.mmap:
        buf = self._map(path)
        if buf[: len(MAGIC)] != MAGIC:
            raise ValueError(f"{path.name} does not start as an MCAP file")
        return buf

    @property
    def message_count(self) -> int:
        return sum(len(f.messages) for f in self._files)

    def messages(
        self, connections: Sequence[ScannedConnection] = ()
    ) -> Iterator[tuple[ScannedConnection, int, bytes]]:
        """The messages of ``connections`` (all where none), in the files' order."""
        wanted = {c.id: c for c in (connections or self.connections)}
        for k, (f, (_, buf)) in enumerate(zip(self._files, self._handles, strict=True)):
            at_chunk, chunk = -1, b""
            for channel, t, j, at, n in f.messages:
                c = wanted.get(self._ids[(k, channel)])
                if c is None:
                    continue
                if j < 0:
                    yield c, t, buf[at : at + n]
                    continue
                if j != at_chunk:
                    at_chunk, chunk = j, _records_of(buf, f.chunks[j])
                yield c, t, chunk[at : at + n]

    def close(self) -> None:
        self._files = []
        super().close()


# The compressions of a chunk cut short that decompress as far as they go (their streaming
# decompressors give the frame's whole blocks), and how a chunk so cut is marked.
PARTIAL = ("zstd", "lz4")
CUT = " (cut short)"


def _partly(compression: str, data: bytes) -> bytes:
    """What a compressed chunk cut short decompresses to, as far as its whole blocks go."""
    try:
        if compression == "zstd":
            from backports.zstd import ZstdDecompressor

            return ZstdDecompressor().decompress(data)  # type: ignore[no-any-return]
        from lz4.frame import LZ4FrameDecompressor

        return LZ4FrameDecompressor().decompress(data)  # type: ignore[no-any-return]
    except Exception as err:  # the decompressor's own: data damaged before the cut
        raise _Damaged(f"{compression} data: {err}") from None


def _records_of(buf: mmap.mmap, chunk: tuple[int, int, str, int, int]) -> bytes:
    """A chunk's records, decompressed where the chunk is compressed, their CRC checked
    where it has one (a copy: no view of the map is left open to stop its closing); a
    compressed chunk cut short, as far as it decompresses."""
    start, n, compression, size, crc = chunk
    data = buf[start : start + n]
    if not compression and not crc:  # a chunk cut short (its whole records), or no CRC
        return data
    if compression.endswith(CUT):
        return _partly(compression.removesuffix(CUT), data)
    from rosbags.rosbag2.storage_mcap import decompress

    try:
        return decompress(data, compression, size, crc)
    except Exception as err:  # rosbags' (size, CRC) or the decompressor's own
        raise _Damaged(f"{compression or 'uncompressed'} data: {err}") from None


def _scan(buf: mmap.mmap, k: int, path: Path, meta: _Meta) -> _File:
    """One file's records, as far as they go; schemas and channels into ``meta``."""
    out = _File(path, len(buf))
    pos, size = len(MAGIC), len(buf)
    while pos < size:
        if pos + _RECORD.size > size:
            out.stopped = f"{size - pos} byte(s) into a record's opcode and length, at byte {pos}"
            break
        op, n = _RECORD.unpack_from(buf, pos)
        body, end = pos + _RECORD.size, pos + _RECORD.size + n
        if op == OP_DATA_END:
            break
        if op == OP_HEADER:
            profile, _ = _string(buf, body)
            if profile != "ros2":
                raise ValueError(f"{path.name}: the MCAP profile is {profile!r}, not ros2")
        if end > size:
            what = _NAMES.get(op, f"0x{op:02x}")
            out.stopped = f"inside a {what} record at byte {pos} of {size}"
            if op == OP_CHUNK:
                try:
                    compression, read = _partial_chunk(buf, body, size, k, out, meta)
                    if compression:
                        out.stopped = (
                            f"inside a {compression}-compressed chunk at byte {pos} of {size}"
                        )
                        if read:
                            out.stopped += ", its whole records read as far as it decompresses"
                        out.unread_cut = not read
                except _Damaged as err:  # its records up to the damage kept
                    out.stopped += f", damaged in it ({err})"
            break
        try:
            if op == OP_CHUNK:
                _chunk(buf, body, end, k, out, meta)
            else:
                _record(buf, op, body, end, k, -1, out, meta)
        except _Damaged as err:  # read as far as it goes: up to the damage
            what = _NAMES.get(op, f"0x{op:02x}")
            if op == OP_CHUNK and _record_starts(buf, end):  # passed over, as mcap recover
                out.skipped.append(f"byte {pos}: {err}")
                pos = end
                continue
            out.stopped = f"at a damaged {what} record at byte {pos} of {size} ({err})"
            break
        pos = end
    return out


def _record_starts(buf: mmap.mmap, pos: int) -> bool:
    """Whether a record of the format (or the file's end) begins at ``pos``: where a damaged
    chunk's length says the next record is."""
    return pos >= len(buf) or buf[pos] in OPCODES


def _chunk(buf: mmap.mmap, body: int, end: int, k: int, out: _File, meta: _Meta) -> None:
    """A whole chunk: its records read (decompressed, CRC checked).

    Raises:
        _Damaged: fields past the chunk's end, a compression that is no UTF-8 text, data
            that fails its CRC or does not decompress, a record inside shorter than its
            fields.
    """
    try:
        _, _, size, crc = _CHUNK.unpack_from(buf, body)
        compression, at = _string(buf, body + _CHUNK.size)
        (n,) = _U64.unpack_from(buf, at)
    except (struct.error, UnicodeDecodeError) as err:
        raise _Damaged(str(err)) from None
    if at + 8 + n > end:
        raise _Damaged(f"records of {n} bytes past the chunk's end")
    out.chunks.append((at + 8, n, compression, size, crc))
    records = _records_of(buf, out.chunks[-1])
    _records(records, len(out.chunks) - 1, k, out, meta)


def _partial_chunk(
    buf: mmap.mmap, body: int, size: int, k: int, out: _File, meta: _Meta
) -> tuple[str, bool]:
    """A chunk cut where the file ends: its whole records, where it is not compressed or
    is zstd or lz4 (as far as it decompresses); none where it is another compression.

    Returns:
        Its compression ("": none, or its header cut) and whether any message was read.
    """
    if body + _CHUNK.size + 4 > size:
        return "", False
    compression, at = _string(buf, body + _CHUNK.size)
    if (compression and compression not in PARTIAL) or at + 8 > size:
        return compression, False
    start = at + 8
    out.chunks.append((start, size - start, compression + CUT if compression else "", 0, 0))
    before = len(out.messages)
    _records(_records_of(buf, out.chunks[-1]), len(out.chunks) - 1, k, out, meta)
    return compression, len(out.messages) > before


def _records(data: bytes, j: int, k: int, out: _File, meta: _Meta) -> None:
    """The whole records of a chunk's bytes (those past its end, cut short, passed over)."""
    pos, size = 0, len(data)
    while pos + _RECORD.size <= size:
        op, n = _RECORD.unpack_from(data, pos)
        body, end = pos + _RECORD.size, pos + _RECORD.size + n
        if end > size:
            return
        _record(data, op, body, end, k, j, out, meta)
        pos = end


def _record(
    buf: Any, op: int, body: int, end: int, k: int, j: int, out: _File, meta: _Meta
) -> None:
    """A schema, channel or message record (anything else passed over).

    Raises:
        _Damaged: a record shorter than its fields, or a name that is no UTF-8 text.
    """
    try:
        _fields(buf, op, body, end, k, j, out, meta)
    except (struct.error, UnicodeDecodeError) as err:
        raise _Damaged(str(err)) from None


def _fields(
    buf: Any, op: int, body: int, end: int, k: int, j: int, out: _File, meta: _Meta
) -> None:
    if op == OP_MESSAGE:
        if end - body < _MESSAGE.size:
            raise _Damaged(f"{end - body} bytes, fewer than a message's header")
        channel, _, log_time, _ = _MESSAGE.unpack_from(buf, body)
        start = body + _MESSAGE.size
        out.messages.append((channel, log_time, j, start, end - start))
    elif op == OP_SCHEMA:
        (sid,) = _U16.unpack_from(buf, body)
        name, at = _string(buf, body + 2)
        encoding, at = _string(buf, at)
        (n,) = _U32.unpack_from(buf, at)
        meta.schemas[(k, sid)] = (name, encoding, bytes(buf[at + 4 : at + 4 + n]).decode())
    elif op == OP_CHANNEL:
        cid, sid = struct.unpack_from("<HH", buf, body)
        topic, _ = _string(buf, body + 4)
        meta.channels[(k, cid)] = (topic, sid)


def ros2_definition(encoding: str, data: str) -> Any:
    """A schema's definition as ``rosbags`` holds it."""
    from rosbags.interfaces import MessageDefinition, MessageDefinitionFormat

    if encoding == "ros2msg" and data:
        return MessageDefinition(MessageDefinitionFormat.MSG, data)
    if encoding in ("ros2idl", "omgidl") and data:
        return MessageDefinition(MessageDefinitionFormat.IDL, data)
    return MessageDefinition(MessageDefinitionFormat.NONE, "")


def definitions_typestore(connections: Sequence[ScannedConnection]) -> Any:
    """The types of the files' definitions, as ``AnyReader`` registers them; where they carry
    none, ROS's own types of the latest LTS (as :func:`rwhonet.data.rosbag.opened_bag`)."""
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    types: dict[str, Any] = {}
    defined = [c for c in connections if c.msgdef.format != MessageDefinitionFormat.NONE]
    for c in defined:
        if c.msgdef.format == MessageDefinitionFormat.MSG:
            types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
            continue
        sep = "=" * 80 + "\n"
        if c.msgdef.data.startswith(f"{sep}IDL: "):
            for part in c.msgdef.data.split(sep)[1:]:
                types.update(get_types_from_idl(part.split("\n", 1)[1]))
        else:
            types.update(get_types_from_idl(c.msgdef.data))
    if not defined:
        types.update(get_typestore(Stores.LATEST).fielddefs)
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store
