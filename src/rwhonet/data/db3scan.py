"""A ROS 2 bag's sqlite3 files read page by page where SQLite cannot: cut short or damaged.

``ros2 bag record`` with sqlite3 storage (rosbag2's default through ROS 2 Humble) writes
each message as a row of the file's ``messages`` table. A file cut short (a copy that
stopped, a disk that filled, a recorder that lost power before SQLite wrote its last
pages) or with a damaged page is "malformed" to SQLite as soon as a query meets a page it
cannot read, and ``rosbags`` refuses the whole bag with it, however few pages are lost.
:class:`ScannedDb3` reads such files' pages one by one, as SQLite's own ``.recover``
does: every table leaf page whose cells parse gives its rows, whatever became of the
pages above it, so that :mod:`rwhonet.data.rosbag` reads the drive as far as its pages
go. It offers what the reader takes of ``rosbags``' ``AnyReader`` (``connections``,
``messages``, ``deserialize``, ``typestore``, ``message_count``, ``topics``).

**The format** (sqlite.org/fileformat2.html): a 100-byte header (``SQLite format 3``, the
page size, big-endian u16 at byte 16, 1 meaning 65536; the bytes reserved at each page's
end, byte 20), then pages of that size. A table's rows are the cells of its b-tree's leaf
pages (page type 13: the page's header at its start, at byte 100 on page 1; a cell
pointer array; each cell its payload's length and its rowid as varints, then the payload
as far as the page holds it and, where it is longer, the first of a chain of overflow
pages). A payload is a record: its header's length and each column's serial type as
varints, then the columns (NULL; big-endian integers of 1, 2, 3, 4, 6 or 8 bytes; the
integers 0 and 1; a float; a BLOB or text of the length the type says).

**Rows told by their shape.** A leaf page does not say which table it belongs to;
rosbag2's tables are told apart by their columns: ``messages`` (``id`` INTEGER PRIMARY
KEY, which SQLite keeps as the rowid and writes as NULL, ``topic_id``, ``timestamp``,
``data``: NULL, an integer, an integer, a BLOB), ``topics`` (``id``, ``name``, ``type``,
``serialization_format``, ...: NULL and texts, the name a topic's ``/...``) and, from ROS
2 Iron on, ``message_definitions`` (``id``, ``topic_type``, ``encoding``,
``encoded_message_definition``, ...: its encoding ``ros2msg``, ``ros2idl`` or ``unknown``).
A message is kept where its topic's row was read; one whose topic's row is lost is passed
over and counted. A row SQLite left on a page it freed is the same row as the one it
moved (rosbag2 never changes a row): a rowid given twice is read once. A cell whose
record does not parse, or whose overflow chain runs off the file, is damaged: passed over,
counted. Index pages (``timestamp_idx``) and interior pages are not read.

**A write-ahead log beside the file** (``drive_0.db3-wal``: rosbag2's ``resilient``
preset, a recorder stopped before SQLite moved its last pages into the file) is read as
SQLite reads it (:mod:`rwhonet.data.sqlitewal`): a page it commits is read from it, over
the file's own. ``rosbags`` opens the file ``immutable`` and never reads the log, so
:mod:`rwhonet.data.rosbag` reads such a bag page by page whether or not ``rosbags`` would
open it.

The messages are given in time order (their ``timestamp``, then their rowid), as
``rosbags`` gives a bag's; ``rosbags`` deserialises them, by the definitions the files
carry, else by ROS's own types of the latest LTS.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rwhonet.data.bagscan import MappedFiles, NoWholeMessage, ScannedConnection
from rwhonet.data.mcapscan import definitions_typestore, ros2_definition
from rwhonet.data.sqlitewal import SUFFIX, Committed, Overlaid, committed

MAGIC = b"SQLite format 3\x00"
TABLE_LEAF = 13  # a table b-tree's leaf page
DEFINITION_ENCODINGS = ("ros2msg", "ros2idl", "unknown")
_INT_BYTES = {1: 1, 2: 2, 3: 3, 4: 4, 5: 6, 6: 8}  # an integer's serial type: its bytes


class Damaged(ValueError):
    """A cell or record that does not parse."""


def _varint(buf: bytes | mmap.mmap, at: int, end: int) -> tuple[int, int]:
    """SQLite's varint at ``at`` (1 to 9 bytes, big-endian, 7 bits a byte but the ninth's
    8), and where it ends; :class:`Damaged` where it runs past ``end``."""
    value = 0
    for k in range(9):
        if at + k >= end:
            raise Damaged("a varint runs past its cell")
        b = buf[at + k]
        if k == 8:
            return (value << 8) | b, at + 9
        value = (value << 7) | (b & 0x7F)
        if b < 0x80:
            return value, at + k + 1
    raise AssertionError("unreachable")  # pragma: no cover


def _header(payload: bytes) -> tuple[int, list[int]]:
    """A record's header: its length and each column's serial type."""
    size, at = _varint(payload, 0, len(payload))
    if size > len(payload) or size < at:
        raise Damaged("a record's header longer than its payload")
    types: list[int] = []
    while at < size:
        t, at = _varint(payload, at, size)
        types.append(t)
    return size, types


def _columns(payload: bytes, body: int, types: Sequence[int]) -> tuple[list[Any], int]:
    """The columns of ``types`` from byte ``body`` on (None, int, float, bytes for a BLOB,
    str for a text), and the byte after them."""
    out: list[Any] = []
    for t in types:
        if t == 0:
            out.append(None)
        elif t in _INT_BYTES:
            n = _INT_BYTES[t]
            if body + n > len(payload):
                raise Damaged("a column past its record")
            out.append(int.from_bytes(payload[body : body + n], "big", signed=True))
            body += n
        elif t == 7:
            if body + 8 > len(payload):
                raise Damaged("a column past its record")
            out.append(struct.unpack(">d", payload[body : body + 8])[0])
            body += 8
        elif t in (8, 9):
            out.append(t - 8)
        elif t >= 12:
            n = (t - 12) // 2
            if body + n > len(payload):
                raise Damaged("a column past its record")
            raw = payload[body : body + n]
            body += n
            out.append(bytes(raw) if t % 2 == 0 else bytes(raw).decode("utf-8", "replace"))
        else:  # 10 and 11 are reserved
            raise Damaged(f"a reserved serial type {t}")
    return out, body


def _record(payload: bytes) -> list[Any]:
    """A record's columns, which must fill it."""
    size, types = _header(payload)
    out, body = _columns(payload, size, types)
    if body != len(payload):
        raise Damaged("a record's columns do not fill its payload")
    return out


@dataclass(frozen=True)
class _Layout:
    page: int  # bytes a page
    usable: int  # a page's bytes less those reserved at its end
    pages: int  # whole pages in the file


@dataclass
class _Db3:
    """What a file's pages give: the rows of each table by rowid, and what was lost."""

    path: Path
    messages: dict[int, tuple[int, int, int]]  # rowid: topic id, timestamp, its cell's byte
    topics: dict[int, tuple[str, str]]  # id: name, type
    definitions: dict[str, tuple[str, str]]  # type: encoding, definition
    layout: _Layout
    damaged: int  # cells that did not parse
    tail: int  # bytes after the last whole page
    wal: Committed | None = None  # the write-ahead log read over the file's pages


def _scan(buf: mmap.mmap | Overlaid, path: Path) -> _Db3:
    """Every table leaf page of a sqlite3 file, its cells told by their shape: a message's
    topic, time and cell kept (its data read when it is wanted), the others' rows."""
    if buf[: len(MAGIC)] != MAGIC:
        raise ValueError(f"{path.name} does not start as an SQLite database")
    size = int.from_bytes(buf[16:18], "big")
    page = 65536 if size == 1 else size
    if page < 512 or page & (page - 1):
        raise ValueError(f"{path.name}: its header's page size {size} is none SQLite writes")
    layout = _Layout(page, page - buf[20], len(buf) // page)
    wal = buf.wal if isinstance(buf, Overlaid) else None
    out = _Db3(path, {}, {}, {}, layout, 0, len(buf) - layout.pages * page, wal)
    for p in range(1, layout.pages + 1):
        start = (p - 1) * page
        head = start + (100 if p == 1 else 0)
        if buf[head] != TABLE_LEAF:
            continue
        cells = int.from_bytes(buf[head + 3 : head + 5], "big")
        end = start + layout.usable
        pointers = buf[head + 8 : min(head + 8 + 2 * cells, end)]  # read at once
        out.damaged += cells - len(pointers) // 2  # an array running off its page
        for k in range(len(pointers) // 2):
            cell = start + int.from_bytes(pointers[2 * k : 2 * k + 2], "big")
            try:
                _shelve(out, buf, cell, end, layout)
            except Damaged:
                out.damaged += 1
    return out


def _shelve(out: _Db3, buf: mmap.mmap | Overlaid, cell: int, end: int, layout: _Layout) -> None:
    """A table leaf cell kept by its shape (see the module's docstring): a message by its
    record's header and first columns, on the page; another row whole."""
    rowid, length, local, _ = _cell_head(buf, cell, end, layout.usable)
    try:
        size, types = _header(local)
    except Damaged:  # not all on the page (or damaged): the cell read whole
        size, types = 0, []
    if (
        len(types) == 4
        and types[0] == 0
        and all(t in _INT_BYTES or t in (8, 9) for t in types[1:3])
        and types[3] >= 12
        and types[3] % 2 == 0
    ):
        widths = [_INT_BYTES.get(t, 0) for t in types[1:3]]
        if size + sum(widths) + (types[3] - 12) // 2 != length:
            raise Damaged("a message's columns do not fill its payload")
        (topic, t_ns), _ = _columns(local, size, types[1:3])
        out.messages.setdefault(rowid, (topic, t_ns, cell))
        return
    _, row = _cell(buf, cell, end, layout)
    _keep(out, rowid, row)


def _cell_head(
    buf: mmap.mmap | Overlaid, at: int, end: int, usable: int
) -> tuple[int, int, bytes, int]:
    """A table leaf cell's rowid, its payload's length, the payload's part on the page and
    its first overflow page (0: none)."""
    if not at < end:
        raise Damaged("a cell outside its page")
    head = buf[at : min(at + 18, end)]  # its two varints, read at once
    length, k = _varint(head, 0, len(head))
    rowid, k = _varint(head, k, len(head))
    at += k
    # the payload's part on the page (sqlite.org/fileformat2.html, "Cell Payload Overflow")
    most = usable - 35
    if length <= most:
        local = length
    else:
        least = (usable - 12) * 32 // 255 - 23
        local = least + (length - least) % (usable - 4)
        local = local if local <= most else least
    if at + local + (4 if local < length else 0) > end:
        raise Damaged("a cell past its page")
    first = int.from_bytes(buf[at + local : at + local + 4], "big") if local < length else 0
    return rowid, length, bytes(buf[at : at + local]), first


def _cell(buf: mmap.mmap | Overlaid, at: int, end: int, layout: _Layout) -> tuple[int, list[Any]]:
    """A table leaf cell's rowid and record, its overflow chain followed."""
    rowid, length, local, next_page = _cell_head(buf, at, end, layout.usable)
    payload = bytearray(local)
    seen = 0
    while len(payload) < length:
        if not 1 <= next_page <= layout.pages or seen > layout.pages:
            raise Damaged("an overflow chain off the file")
        start = (next_page - 1) * layout.page
        take = min(length - len(payload), layout.usable - 4)
        payload += buf[start + 4 : start + 4 + take]
        next_page = int.from_bytes(buf[start : start + 4], "big")
        seen += 1
    return rowid, _record(bytes(payload))


def _keep(out: _Db3, rowid: int, row: list[Any]) -> None:
    """A topic's or a definition's row kept, told by its shape."""
    if len(row) >= 4 and row[0] is None and all(isinstance(x, str) for x in row[1:4]):
        if row[1].startswith("/") and "/" in row[2]:
            out.topics.setdefault(rowid, (row[1], row[2]))
        elif row[2] in DEFINITION_ENCODINGS and "/" in row[1]:
            out.definitions.setdefault(row[1], (row[2], row[3]))


def _log_of(path: Path) -> Path | None:
    """The write-ahead log beside a sqlite3 file (``drive_0.db3-wal``), where one holds
    bytes."""
    log = path.with_name(path.name + SUFFIX)
    return log if log.is_file() and log.stat().st_size else None


def wal_beside(path: Path) -> Path | None:
    """The write-ahead log beside a sqlite3 file where it commits a page
    (:func:`rwhonet.data.sqlitewal.committed`)."""
    if (log := _log_of(path)) is None:
        return None
    with open(log, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        return log if committed(buf) is not None else None


class ScannedDb3(MappedFiles):
    """A ROS 2 bag's sqlite3 files (in order) read page by page (what ``rosbags``'
    ``AnyReader`` offers the reader: :mod:`rwhonet.data.rosbag`).

    Raises:
        ValueError: a file that is no SQLite database.
        NoWholeMessage: no message of a topic whose row was read.
    """

    how = "its sqlite3 pages one by one, rosbags deserialising"  # as the reader's notes say
    # a message that does not deserialise is damaged: passed over (rwhonet.data.rosbag)
    scanned = True

    def __init__(self, paths: Sequence[Path], refused: str | None) -> None:
        """Scan ``paths``, each with its write-ahead log where one beside it commits a page
        (:func:`wal_beside`); ``refused``: why ``rosbags`` (SQLite) refused them (None:
        read so for their logs)."""
        super().__init__()
        files: list[_Db3] = []
        self._bufs: list[mmap.mmap | Overlaid] = []
        try:
            for path in paths:
                buf = self._mapped(path)
                self._bufs.append(buf)
                files.append(_scan(buf, path))
        except Exception:
            self.close()
            raise
        # one topic table for the bag: rosbag2 writes the same rows in each of its files
        topics: dict[int, tuple[str, str]] = {}
        definitions: dict[str, tuple[str, str]] = {}
        for f in files:
            for k, v in f.topics.items():
                topics.setdefault(k, v)
            for name, d in f.definitions.items():
                definitions.setdefault(name, d)
        self.connections = [
            ScannedConnection(
                k, name, msgtype, ros2_definition(*definitions.get(msgtype, ("", ""))), ""
            )
            for k, (name, msgtype) in sorted(topics.items())
        ]
        by_id = {c.id: c for c in self.connections}
        rows = [
            (t, k, rowid, topic, cell)
            for k, f in enumerate(files)
            for rowid, (topic, t, cell) in f.messages.items()
        ]
        self.orphans = sum(1 for r in rows if r[3] not in by_id)
        # in time order, then the files' and rows' order, as rosbags gives a bag's
        self._messages = [(by_id[r[3]], r[0], r[1], r[4]) for r in sorted(rows) if r[3] in by_id]
        damaged = sum(f.damaged for f in files)
        pages = sum(f.layout.pages for f in files)
        self._layouts = [f.layout for f in files]
        if not self._messages:
            self.close()
            raise NoWholeMessage(
                f"no whole message: {len(rows)} message row(s), {len(topics)} topic row(s) "
                f"and {damaged} damaged cell(s) among {pages} pages"
            )
        self.typestore = definitions_typestore(self.connections)
        lost = [f"{f.path.name} ends {f.tail} byte(s) into a page" for f in files if f.tail]
        logs = [_wal_said(f.path, f.wal) for f in files if f.wal is not None]
        self.said = (
            (
                f"rosbags refused {'the file' if len(files) == 1 else 'its files'} ({refused}): "
                if refused is not None
                else ""
            )
            + f"read page by page, {len(self._messages)} messages from {pages} pages"
            + (f"; {'; '.join(logs)}" if logs else "")
            + (f"; {damaged} damaged cell(s) passed over" if damaged else "")
            + (
                f"; {self.orphans} message(s) of a topic whose row is lost passed over"
                if self.orphans
                else ""
            )
            + (f"; {'; '.join(lost)}" if lost else "")
        )

    @property
    def message_count(self) -> int:
        return len(self._messages)

    def messages(
        self, connections: Sequence[ScannedConnection] = ()
    ) -> Iterator[tuple[ScannedConnection, int, bytes]]:
        """The messages of ``connections`` (all where none), in time order. A message whose
        data cannot be read from its pages (its overflow chain damaged) is given empty:
        ``rosbags`` cannot deserialise it, and the reader passes it over as damaged."""
        wanted = {c.id for c in (connections or self.connections)}
        for c, t, k, cell in self._messages:
            if c.id not in wanted:
                continue
            buf, layout = self._bufs[k], self._layouts[k]
            page_end = (cell // layout.page) * layout.page + layout.usable
            try:
                data = _cell(buf, cell, page_end, layout)[1][3]
            except (Damaged, IndexError):
                data = b""
            yield c, t, data

    def _mapped(self, path: Path) -> mmap.mmap | Overlaid:
        """A file's bytes, read through its write-ahead log where one commits a page (the
        log read once: :func:`wal_beside` reads it so too)."""
        if (log := _log_of(path)) is None:
            return self._map(path)
        wal_buf = self._map(log)
        wal = committed(wal_buf)
        if wal is None:  # it commits nothing: the file alone
            return self._map(path)
        # a file SQLite had not yet written to: its pages all in the log
        file = self._map(path) if path.stat().st_size else b""
        return Overlaid(file, wal_buf, wal)

    def close(self) -> None:
        self._messages = []
        self._bufs = []
        super().close()


def _wal_said(path: Path, wal: Committed) -> str:
    """What the notes say of a file's write-ahead log."""
    return (
        f"{path.name}{SUFFIX} (a recorder stopped before SQLite moved its pages into the "
        f"file; rosbags reads the file without it) read over the file: {len(wal.at)} "
        f"page(s) of {wal.frames} committed frame(s)"
        + (
            f", {wal.passed_over} frame(s) after the last commit passed over (never "
            "committed, or left from before a checkpoint)"
            if wal.passed_over
            else ""
        )
    )
