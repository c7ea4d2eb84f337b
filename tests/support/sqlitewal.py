"""SQLite files in write-ahead-log mode as a recorder killed mid-recording leaves them, and
what SQLite itself reads of them (the ground truth :mod:`rwhonet.data.sqlitewal` is
held to)."""

from __future__ import annotations

import shutil
import sqlite3
from collections.abc import Sequence
from pathlib import Path

TABLES = ("schema", "topics", "message_definitions")  # what rosbag2 writes as it starts


def killed_copy(live: Path, out: Path) -> Path:
    """``live`` (open in another connection) and its ``-wal`` copied to ``out`` as they
    lie on disk: what a recorder killed now leaves."""
    out.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(live, out)
    wal = live.with_name(live.name + "-wal")
    if wal.exists():
        shutil.copyfile(wal, out.with_name(out.name + "-wal"))
    return out


def resilient_recording(
    db3: Path, out: Path, share: float, checkpoint: int = 1000, batch: int = 50
) -> Path:
    """``db3``'s (a whole ROS 2 bag's sqlite3 file) rows recorded again as rosbag2's
    ``resilient`` preset writes them (``journal_mode = WAL``, ``synchronous = NORMAL``;
    SQLite's checkpoint every ``checkpoint`` pages, 1,000 its default; a transaction a
    batch of messages) and the files as a recorder killed after ``share`` of the messages
    leaves them in ``out`` (a bag folder without its metadata.yaml)."""
    live = out.parent / f"{out.name}-live" / db3.name
    live.parent.mkdir(parents=True)
    src = sqlite3.connect(db3)
    db = sqlite3.connect(live, isolation_level=None)
    try:
        db.execute("PRAGMA journal_mode = WAL")
        db.execute("PRAGMA synchronous = NORMAL")
        db.execute(f"PRAGMA wal_autocheckpoint = {checkpoint}")
        for (sql,) in src.execute("SELECT sql FROM sqlite_master WHERE sql IS NOT NULL"):
            db.execute(sql)
        for table in TABLES:
            rows = src.execute(f"SELECT * FROM {table}").fetchall()  # noqa: S608
            if rows:
                marks = ",".join("?" * len(rows[0]))
                db.executemany(f"INSERT INTO {table} VALUES ({marks})", rows)  # noqa: S608
        # as a recorder receives them: in time order, each given the next id
        rows = src.execute("SELECT * FROM messages ORDER BY timestamp, id").fetchall()
        rows = [(k + 1, *row[1:]) for k, row in enumerate(rows)]
        rows = rows[: int(share * len(rows))]
        for k in range(0, len(rows), batch):
            db.execute("BEGIN")
            db.executemany("INSERT INTO messages VALUES (?,?,?,?)", rows[k : k + batch])
            db.execute("COMMIT")
        return killed_copy(live, out / db3.name)
    finally:
        db.close()
        src.close()


def sqlite_reads(path: Path, scratch: Path) -> bytes:
    """The database's bytes as SQLite reads them: a copy of the file and its ``-wal``
    opened (SQLite recovers the log) and checkpointed into the file."""
    scratch.mkdir(parents=True, exist_ok=True)
    copy = killed_copy(path, scratch / path.name)
    db = sqlite3.connect(copy)
    try:
        db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    finally:
        db.close()
    return copy.read_bytes()


def sqlite_rows(path: Path, scratch: Path, sql: str) -> Sequence[tuple]:
    """``sql``'s rows from a copy of the file and its ``-wal``, as SQLite reads them."""
    scratch.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(killed_copy(path, scratch / path.name))
    try:
        return db.execute(sql).fetchall()
    finally:
        db.close()
