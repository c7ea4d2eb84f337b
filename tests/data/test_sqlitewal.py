"""An SQLite file's write-ahead log read as SQLite reads it (rwhonet.data.sqlitewal).

The logs here are SQLite's own, written by Python's ``sqlite3`` in WAL mode and copied as a
killed writer leaves them, then cut, damaged or left with frames from before a
checkpoint; what SQLite itself reads of each (a copy opened, its log recovered and
checkpointed into the file) is the truth the module's pages are held to, byte for byte.
"""

from __future__ import annotations

import random
import sqlite3
import struct
from pathlib import Path

import pytest

from rwhonet.data.sqlitewal import (
    FRAME_HEADER,
    HEADER,
    MAGICS,
    Committed,
    Overlaid,
    checksum,
    committed,
)
from support.sqlitewal import killed_copy, sqlite_reads


def _killed(
    tmp_path: Path, rows: int, checkpoint: int = 1000, every: int = 7, cache: int = 2000
) -> Path:
    """A table of ``rows`` random 300-byte blobs written in WAL mode, a commit every
    ``every`` rows (the rows after the last commit left uncommitted), SQLite checkpointing
    every ``checkpoint`` pages, its cache ``cache`` pages (a transaction larger spills its
    pages into the log before it commits); the files as a writer killed then leaves
    them."""
    live = tmp_path / "live" / "a.db3"
    live.parent.mkdir()
    db = sqlite3.connect(live)
    rng = random.Random(rows)
    try:
        db.execute("PRAGMA journal_mode = WAL")
        db.execute(f"PRAGMA wal_autocheckpoint = {checkpoint}")
        db.execute(f"PRAGMA cache_size = {cache}")
        db.execute("CREATE TABLE t(id INTEGER PRIMARY KEY, x BLOB)")
        db.commit()
        for i in range(rows):
            db.execute("INSERT INTO t(x) VALUES (?)", (rng.randbytes(300),))
            if i % every == every - 1:
                db.commit()
        return killed_copy(live, tmp_path / "killed" / "a.db3")
    finally:
        db.close()


def _overlaid(path: Path) -> bytes | None:
    """The file's bytes through its log (None: the log commits nothing)."""
    log = path.with_name(path.name + "-wal").read_bytes()
    wal = committed(log)
    if wal is None:
        return None
    over = Overlaid(path.read_bytes(), log, wal)
    return b"".join(over[k * wal.page : (k + 1) * wal.page] for k in range(wal.pages))


def _same_as_sqlite(path: Path, scratch: Path) -> bytes:
    want = sqlite_reads(path, scratch)
    got = _overlaid(path)
    assert (path.read_bytes() if got is None else got) == want
    return want


def test_the_checksum_is_sqlite_s_on_its_own_log(tmp_path):
    """A log SQLite wrote: its header's checksums are the module's of the header's first 24
    bytes, and its first frame's run on from them over the frame's header and page."""
    log = _killed(tmp_path, 40).with_name("a.db3-wal").read_bytes()
    magic, _, page = struct.unpack(">3I", log[:12])
    order = MAGICS[magic]
    s = checksum(log[:24], order, 0, 0)
    assert s == struct.unpack(">2I", log[24:32])
    frame = log[HEADER : HEADER + FRAME_HEADER + page]
    s = checksum(frame[:8], order, *s)
    s = checksum(frame[FRAME_HEADER:], order, *s)
    assert s == struct.unpack(">2I", frame[16:24])


def test_known_values_of_the_checksum():
    """By hand: words (1, 2) from (0, 0) give s0 = 0+1+0 = 1, s1 = 0+2+1 = 3; then (3, 4)
    give s0 = 1+3+3 = 7, s1 = 3+4+7 = 14; sums wrap at 2^32; little-endian words under one
    magic, big-endian under the other."""
    data = struct.pack("<4I", 1, 2, 3, 4)
    assert checksum(data, "<", 0, 0) == (7, 14)
    assert checksum(data[:8], "<", 0, 0) == (1, 3)
    assert checksum(struct.pack(">4I", 1, 2, 3, 4), ">", 0, 0) == (7, 14)
    assert checksum(struct.pack("<2I", 0xFFFFFFFF, 0), "<", 1, 0) == (0, 0)


@pytest.mark.parametrize("checkpoint", [1000, 20])
def test_the_pages_are_those_sqlite_reads_through_the_log(tmp_path, checkpoint):
    """A writer killed mid-transaction, with SQLite checkpointing at its default (every
    page still in the log) and every 20 pages (the file holds the pages of the checkpoints,
    the log restarted over its start with new salts, frames from before left after the
    new ones): the file read through the log is, byte for byte, the file SQLite writes as
    it recovers and checkpoints the log; the rows after the last commit are not in it."""
    path = _killed(tmp_path, 300, checkpoint)
    want = _same_as_sqlite(path, tmp_path / "sqlite")
    wal = committed(path.with_name("a.db3-wal").read_bytes())
    assert wal is not None and wal.pages * wal.page == len(want)
    if checkpoint == 20:
        assert wal.passed_over > 0 and len(path.read_bytes()) > wal.page  # stale frames
    else:
        assert len(path.read_bytes()) == wal.page  # only the header page in the file
    copy = tmp_path / "rows" / "a.db3"
    copy.parent.mkdir()
    copy.write_bytes(want)
    with sqlite3.connect(copy) as db:
        assert db.execute("SELECT count(*) FROM t").fetchone() == (294,)  # 42 commits of 7
    db.close()


@pytest.mark.parametrize("cut", [1, 100, 2000, 4096 + 23])
def test_a_log_cut_short_commits_what_sqlite_recovers(tmp_path, cut):
    """The log cut ``cut`` bytes short (the last frame torn, or its header): the frames
    before it up to the last commit hold, as SQLite reads them."""
    path = _killed(tmp_path, 120)
    log = path.with_name("a.db3-wal")
    data = log.read_bytes()
    whole = committed(data)
    log.write_bytes(data[:-cut])
    _same_as_sqlite(path, tmp_path / "sqlite")
    cut_wal = committed(log.read_bytes())
    assert cut_wal is not None and whole is not None and cut_wal.frames <= whole.frames


def test_damaged_bytes_anywhere_read_as_sqlite_reads_them(tmp_path):
    """40 copies of a killed writer's log, 1 to 3 random bytes of each changed (a frame's
    page, its header, the log's header): each read through the log is what SQLite reads,
    byte for byte, whether SQLite keeps the frames before the damage or the whole log is
    void."""
    path = _killed(tmp_path, 150, checkpoint=15)
    log = path.with_name("a.db3-wal")
    data = log.read_bytes()
    rng = random.Random(7)
    void = 0
    for k in range(40):
        bad = bytearray(data)
        for _ in range(rng.randint(1, 3)):
            at = rng.randrange(len(bad)) if k % 4 else rng.randrange(HEADER)
            bad[at] ^= rng.randint(1, 255)
        log.write_bytes(bad)
        _same_as_sqlite(path, tmp_path / f"sqlite{k}")
        void += committed(bytes(bad)) is None
    assert 0 < void < 40  # a damaged header voids the log; others keep a part


def _rewritten(data: bytearray) -> bytes:
    """A log's header and frames' checksums written again for what it now holds (in the
    byte order its magic says)."""
    order = MAGICS[struct.unpack(">I", data[:4])[0]]
    page = struct.unpack(">I", data[8:12])[0]
    s = checksum(bytes(data[:24]), order, 0, 0)
    data[24:32] = struct.pack(">2I", *s)
    for start in range(HEADER, len(data) - FRAME_HEADER - page + 1, FRAME_HEADER + page):
        s = checksum(bytes(data[start : start + 8]), order, *s)
        s = checksum(bytes(data[start + FRAME_HEADER : start + FRAME_HEADER + page]), order, *s)
        data[start + 16 : start + 24] = struct.pack(">2I", *s)
    return bytes(data)


def test_a_log_whose_checksums_are_big_endian_is_read(tmp_path):
    """The other magic (``0x377f0683``: a big-endian writer's log) with every checksum
    written big-endian: SQLite reads it, and the same pages are read."""
    path = _killed(tmp_path, 60)
    log = path.with_name("a.db3-wal")
    data = bytearray(log.read_bytes())
    data[:4] = struct.pack(">I", 0x377F0683)
    log.write_bytes(_rewritten(data))
    want = _same_as_sqlite(path, tmp_path / "sqlite")
    page = struct.unpack(">I", data[8:12])[0]
    assert _overlaid(path) == want and len(want) > page


def test_a_frame_whose_salts_are_not_the_header_s_ends_the_log(tmp_path):
    """A frame's salts are not in its checksums: a frame (the 8th) whose salt differs from
    the header's, its checksums holding, ends the log there, as SQLite ends it."""
    path = _killed(tmp_path, 120)
    log = path.with_name("a.db3-wal")
    data = bytearray(log.read_bytes())
    whole = committed(bytes(data))
    page = struct.unpack(">I", data[8:12])[0]
    salt = HEADER + 7 * (FRAME_HEADER + page) + 8
    data[salt] ^= 0x01
    log.write_bytes(bytes(data))
    _same_as_sqlite(path, tmp_path / "sqlite")
    cut = committed(bytes(data))
    assert whole is not None and cut is not None and cut.frames < 8 <= whole.frames
    # so does a frame of page 0 (none), its checksums written again for it
    data[salt] ^= 0x01
    data[salt - 8 : salt - 4] = bytes(4)
    log.write_bytes(_rewritten(data))
    _same_as_sqlite(path, tmp_path / "sqlite2")
    assert committed(bytes(data)) == cut


def test_a_header_whose_checksum_fails_voids_the_log(tmp_path):
    """The header's checkpoint sequence (bytes 12-15, read by nothing else) changed: its
    checksum fails, and SQLite reads the file without the log; so does the module."""
    path = _killed(tmp_path, 60)
    log = path.with_name("a.db3-wal")
    data = bytearray(log.read_bytes())
    data[15] ^= 0x01
    log.write_bytes(bytes(data))
    assert sqlite_reads(path, tmp_path / "sqlite") == path.read_bytes()
    assert committed(bytes(data)) is None


def test_the_database_has_the_last_commit_s_pages(tmp_path):
    """With ``auto_vacuum = FULL`` a commit that deletes rows shrinks the database: its
    size is the last commit's, not the largest, as SQLite reads it."""
    live = tmp_path / "live" / "a.db3"
    live.parent.mkdir()
    db = sqlite3.connect(live)
    try:
        db.execute("PRAGMA auto_vacuum = FULL")
        db.execute("PRAGMA journal_mode = WAL")
        db.execute("CREATE TABLE t(id INTEGER PRIMARY KEY, x BLOB)")
        db.executemany("INSERT INTO t(x) VALUES (?)", [(bytes(900),)] * 100)
        db.commit()
        db.execute("DELETE FROM t WHERE id > 10")
        db.commit()
        path = killed_copy(live, tmp_path / "killed" / "a.db3")
    finally:
        db.close()
    want = _same_as_sqlite(path, tmp_path / "sqlite")
    wal = committed(path.with_name("a.db3-wal").read_bytes())
    assert wal is not None and wal.pages * wal.page == len(want) < max(wal.at) * wal.page


def test_frames_of_a_transaction_never_committed_are_passed_over(tmp_path):
    """A transaction larger than SQLite's cache spills its pages into the log before it
    commits; killed before the commit, its frames are passed over (counted), as SQLite
    passes them over: the table is there, empty."""
    path = _killed(tmp_path, 200, every=1000, cache=5)
    want = _same_as_sqlite(path, tmp_path / "sqlite")
    wal = committed(path.with_name("a.db3-wal").read_bytes())
    assert wal is not None and wal.passed_over >= 10
    copy = tmp_path / "rows" / "a.db3"
    copy.parent.mkdir()
    copy.write_bytes(want)
    with sqlite3.connect(copy) as db:
        assert db.execute("SELECT count(*) FROM t").fetchone() == (0,)
    db.close()


def test_a_log_that_commits_nothing_is_none(tmp_path):
    """An empty log, one of its header alone, one whose only frame is not a commit, one of
    another format version: nothing committed."""
    assert committed(b"") is None
    path = _killed(tmp_path, 6)
    data = path.with_name("a.db3-wal").read_bytes()
    wal = committed(data)
    assert wal is not None and wal.at == {1: 56, 2: 56 + FRAME_HEADER + wal.page}  # the table
    assert committed(data[:HEADER]) is None
    assert committed(data[: HEADER + FRAME_HEADER + wal.page]) is None  # page 1, no commit
    version = bytearray(data)
    version[4:8] = struct.pack(">I", 3007001)  # its checksums written again for it
    assert committed(_rewritten(version)) is None
    assert committed(_rewritten(bytearray(data))) == wal  # what the rewriting leaves


def test_overlaid_reads_by_byte_and_within_a_page_only():
    """A page the log commits from the log, another from the file, zeros past the file's
    end; past the last commit's pages an IndexError; a slice across two pages refused."""
    page = 512
    file = bytes([1]) * page + bytes([2]) * page  # pages 1 and 2
    log = bytes(HEADER + FRAME_HEADER) + bytes([9]) * page
    over = Overlaid(file, log, Committed(page, {2: HEADER + FRAME_HEADER}, 3, 1, 0))
    assert len(over) == 3 * page
    assert over[0] == 1 and over[page] == 9 and over[2 * page] == 0
    assert over[page + 10 : page + 20] == bytes([9]) * 10
    assert over[3 * page - 4 : 3 * page] == bytes(4)
    with pytest.raises(IndexError):
        over[3 * page]
    with pytest.raises(IndexError):
        over[page - 2 : page + 2]
