"""An SQLite file's write-ahead log read as SQLite reads it: the pages it committed over the
file's own.

``ros2 bag record --storage-preset-profile resilient`` (rosbag2's sqlite3 storage, for a
recording that must survive a crash) sets ``journal_mode = WAL``: SQLite appends each
transaction's pages to ``<file>-wal`` beside the file and moves them into the file only at
a checkpoint (after 1,000 pages, about 4 MB, by default) or as the last connection closes.
A recorder that is killed, or loses power, leaves the pages written since the last
checkpoint in the ``-wal`` file alone: SQLite reads them from there as it next opens the
file, but ``rosbags`` opens it ``immutable`` and never looks at the log. The last minutes
of the drive are lost without a word, and a drive shorter than a checkpoint is refused:
its tables are in the log alone ("no such table: messages").

**The format** (sqlite.org/fileformat2.html, "The Write-Ahead Log"; the recovery is
``walIndexRecover`` of SQLite's ``wal.c``): a 32-byte header (big-endian: magic
``0x377f0682`` or ``0x377f0683``, format version 3007000, page size, checkpoint sequence,
two salts, two checksums of the header's first 24 bytes), then frames: a 24-byte header
(the page's number; for a transaction's last frame, its commit, the database's size in
pages after it, else 0; the header's two salts; two checksums) and the page. A frame's
checksums run on from the frame before it (from the header's for the first) over its
header's first 8 bytes and its page: 32-bit words, little-endian under magic ``...82`` and
big-endian under ``...83``, two at a time: ``s0 += x[i] + s1; s1 += x[i+1] + s0``.

**What counts** is what SQLite counts: frames from the first on while each carries the
header's salts and its checksums hold (a checkpoint that restarts the log writes new
salts over its start, so a frame left from before is told apart; a frame torn by the
crash fails its checksums), up to the last commit among them. A page's content is its
last such frame's; the database has the last commit's number of pages. Frames after the
last commit are a transaction SQLite never finished: passed over and counted, as
SQLite drops them. A log whose header does not hold (its magic, version, page size or
checksum) holds nothing.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

MAGICS = {0x377F0682: "<", 0x377F0683: ">"}  # the checksum's byte order
VERSION = 3007000
HEADER = 32  # the log's header
FRAME_HEADER = 24
SUFFIX = "-wal"  # the log beside its file: drive_0.db3-wal
_MASK = 0xFFFFFFFF


@dataclass(frozen=True)
class Committed:
    """What a write-ahead log commits: each page's last committed frame and the
    database's size after the last commit."""

    page: int  # bytes a page
    at: dict[int, int]  # page number: the byte its content starts at in the log
    pages: int  # the database's pages after the last commit
    frames: int  # frames up to the last commit
    passed_over: int  # whole frames after it (not committed, torn, or left from before)


def checksum(data: bytes | memoryview, order: str, s0: int, s1: int) -> tuple[int, int]:
    """SQLite's WAL checksum of ``data`` (a multiple of 8 bytes) run on from ``s0, s1``."""
    words = struct.unpack(f"{order}{len(data) // 4}I", data)
    for i in range(0, len(words), 2):
        s0 = (s0 + words[i] + s1) & _MASK
        s1 = (s1 + words[i + 1] + s0) & _MASK
    return s0, s1


def committed(log: Sequence[int] | bytes) -> Committed | None:
    """The pages a write-ahead log's bytes commit (see the module's docstring); None where
    its header does not hold or no frame is committed."""
    with memoryview(log) as buf:
        return _committed(buf)


def _committed(buf: memoryview) -> Committed | None:
    """:func:`committed` of the log's bytes."""
    if len(buf) < HEADER:
        return None
    magic, version, page, _, salt1, salt2, c0, c1 = struct.unpack(">8I", buf[:HEADER])
    order = MAGICS.get(magic)
    if (
        order is None
        or version != VERSION
        or not 512 <= page <= 65536
        or page & (page - 1)
        or checksum(buf[:24], order, 0, 0) != (c0, c1)
    ):
        return None
    s = (c0, c1)
    at: dict[int, int] = {}
    pending: dict[int, int] = {}  # the frames of a transaction not yet committed
    frames = pages = read = 0
    step = FRAME_HEADER + page
    start = HEADER
    while start + step <= len(buf):
        number, size, f1, f2, k0, k1 = struct.unpack(">6I", buf[start : start + FRAME_HEADER])
        if number == 0 or (f1, f2) != (salt1, salt2):
            break
        s = checksum(buf[start : start + 8], order, *s)
        s = checksum(buf[start + FRAME_HEADER : start + step], order, *s)
        if s != (k0, k1):
            break
        read += 1
        pending[number] = start + FRAME_HEADER
        if size:  # a commit: the transaction's pages hold
            at.update(pending)
            pending.clear()
            frames, pages = read, size
        start += step
    whole = (len(buf) - HEADER) // step
    if not frames:
        return None
    return Committed(page, at, pages, frames, whole - frames)


class Overlaid:
    """A database file's bytes as SQLite reads them with its write-ahead log: a page the
    log commits from its last committed frame, any other from the file, zeros past the
    file's end, to the last commit's number of pages. Indexed by byte, or sliced within
    one page, as :mod:`rwhonet.data.db3scan` reads a file."""

    def __init__(self, file: Sequence[int] | bytes, log: Sequence[int] | bytes, wal: Committed):
        self.file, self.log, self.wal = file, log, wal
        self.page = wal.page
        self._zeros = bytes(wal.page)

    def __len__(self) -> int:
        return self.wal.pages * self.page

    def _source(self, offset: int) -> tuple[Sequence[int] | bytes, int]:
        """Where the byte at ``offset`` is read, and the byte its page starts at there."""
        number, _ = divmod(offset, self.page)
        if number >= self.wal.pages:
            raise IndexError("past the database's last page")
        at = self.wal.at.get(number + 1)
        if at is not None:
            return self.log, at
        start = number * self.page
        if start + self.page <= len(self.file):
            return self.file, start
        return self._zeros, 0

    def __getitem__(self, key: int | slice) -> int | bytes:
        if isinstance(key, slice):
            first = key.start or 0
            stop = len(self) if key.stop is None else min(key.stop, len(self))
            if stop <= first:
                return b""
            src, base = self._source(first)
            within = first % self.page
            if within + stop - first > self.page:
                raise IndexError("a slice across pages")
            return bytes(src[base + within : base + within + stop - first])
        src, base = self._source(key)
        return src[base + key % self.page]
