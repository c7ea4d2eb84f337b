"""Drive files kept compressed: gzip, bzip2, xz, zstd, or a ZIP archive of one drive file,
told by their first bytes.

A fleet's drives are often archived compressed (``V-S1.csv.gz``: a 10 Hz CSV shrinks
about five times), and pandas reads such a file as it reads the CSV. The 10 Hz readers
(IO-VNBD, column maps, a VBOX file) and the MDF4 reader read a compressed drive file
through a scratch copy of what it holds (:func:`decompressed_copy`, bounded by
``data.max_file_mb`` as the file itself is; a raw CAN log's, read a part at a time, by the
scratch disk's room), ``rwhonet predict`` a 10 Hz file block by block as it decompresses
it (:func:`open_decompressed`).
A drive's id is its file's name without the compression's suffix and the format's
(:func:`drive_stem`: ``V-S1.csv.gz`` is ``V-S1``), as the drive's uncompressed file names
it, so its scenario sidecar and every output keep the name.

The kind is told from the file's first bytes, not its name: a ``.csv`` that holds gzip
data is read, a ``.gz`` that holds text is read as text.
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import shutil
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from rwhonet.errors import InputError, Problem

# (first bytes, kind, the suffix a file of it has)
MAGIC: tuple[tuple[bytes, str, str], ...] = (
    (b"\x1f\x8b", "gzip", ".gz"),
    (b"BZh", "bzip2", ".bz2"),
    (b"\xfd7zXZ\x00", "xz", ".xz"),
    (b"\x28\xb5\x2f\xfd", "zstd", ".zst"),
    (b"\x28\xb5\x2f\xfd", "zstd", ".zstd"),  # rosbag2's file compression: drive_0.mcap.zstd
    (b"PK\x03\x04", "zip", ".zip"),  # a ZIP archive of one drive file
    (b"PK\x05\x06", "zip", ".zip"),  # ... or of none
)
SUFFIXES = tuple(suffix for _, _, suffix in MAGIC)
COPY_BYTES = 1 << 20  # decompressed per step
SCRATCH_RESERVE_MB = 1024  # what a raw CAN log's scratch copy leaves free on its disk


def compression_of(path: Path) -> str | None:
    """The compression a file's first bytes show (``gzip``, ``bzip2``, ``xz``, ``zstd``;
    None: none, or the file cannot be read: its reader says why)."""
    try:
        with open(path, "rb") as f:
            head = f.read(6)
    except OSError:
        return None
    return next((kind for magic, kind, _ in MAGIC if head.startswith(magic)), None)


def head_bytes(path: Path, name: str, size: int) -> bytes | None:
    """The first ``size`` bytes of a file, or of what it unpacks to where it is kept
    compressed (``drive.log.gz``: told by its magic); None where it cannot be read or
    unpacked. For a reader that tells its files by what they hold."""
    try:
        packing = compression_of(path)
        opened = open(path, "rb") if packing is None else open_decompressed(path, packing, name)
        with opened as f:
            return f.read(size)
    except (OSError, InputError, EOFError):
        return None


def open_decompressed(path: Path, kind: str, file: str) -> BinaryIO:
    """A compressed file's text as a binary stream, decompressed as it is read; data that
    cannot be decompressed (cut off, corrupted) raises :class:`InputError` naming ``file``
    where it is met."""
    if kind == "gzip":
        raw: Any = gzip.open(path, "rb")
    elif kind == "bzip2":
        raw = bz2.open(path, "rb")
    elif kind == "xz":
        raw = lzma.open(path, "rb")
    elif kind == "zip":
        archive, member = _one_member(path, file)
        return io.BufferedReader(_Checked(archive.open(member), kind, file, archive), COPY_BYTES)
    else:  # zstd: no module of Python's own reads it
        import pyarrow as pa

        raw = pa.CompressedInputStream(pa.OSFile(str(path)), "zstd")
    return io.BufferedReader(_Checked(raw, kind, file), COPY_BYTES)


def _one_member(path: Path, file: str) -> tuple[zipfile.ZipFile, zipfile.ZipInfo]:
    """A ZIP archive and the one file it holds (a drive zipped to be sent or kept).

    Raises:
        InputError: not a whole ZIP archive, an Excel workbook, or not one file in it.
    """
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, EOFError) as err:
        raise InputError([broken(file, "zip", err)]) from None
    members = [x for x in archive.infolist() if not x.is_dir()]
    names = [x.filename for x in members]
    workbook = any(n == "[Content_Types].xml" or n.startswith("xl/") for n in names)
    if len(members) == 1 and not workbook:
        return archive, members[0]
    archive.close()
    if workbook:
        found = "an Excel workbook (.xlsx: a ZIP archive of XML parts), not a CSV file"
        fix = "save the sheet as CSV (File > Save As > CSV UTF-8) and give that file"
    else:
        listed = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
        found = f"{len(names)} files: {listed}" if names else "no file"
        fix = "zip one drive per archive, or unzip it and give the drive files"
    raise InputError(
        [Problem(file, None, None, "a ZIP archive holding one drive file", found, fix)]
    )


class _Checked(io.RawIOBase):
    """A decompressing stream whose failures are the user's input problem, not a crash
    (``archive``: a ZIP archive the stream is one member of, closed with it)."""

    def __init__(self, stream: Any, kind: str, file: str, archive: Any = None) -> None:
        super().__init__()
        self._stream, self._kind, self._file, self._archive = stream, kind, file, archive

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        try:
            data = self._stream.read(len(buffer))
        except (
            OSError,
            EOFError,
            ValueError,
            lzma.LZMAError,
            zlib.error,
            zipfile.BadZipFile,
        ) as err:
            raise InputError([broken(self._file, self._kind, err)]) from None
        except Exception as err:  # pyarrow's own errors for a broken zstd frame
            if type(err).__module__.startswith("pyarrow"):
                raise InputError([broken(self._file, self._kind, err)]) from None
            raise
        buffer[: len(data)] = data
        return len(data)

    def close(self) -> None:
        self._stream.close()
        if self._archive is not None:
            self._archive.close()
        super().close()


def decompressed_copy(
    path: Path, kind: str, dest: Path, max_mb: float | None, file: str, what: str = "a CAN log"
) -> None:
    """Write what a compressed drive file holds (a CSV's text, an MDF4 log, a raw CAN log)
    to ``dest``, at most ``max_mb`` MB of it.

    ``max_mb`` None: a raw CAN log, whose reader takes a part of it at a time (its memory
    bounded by the frames it keeps, not by its size), or a ROS 2 bag's storage file
    (``what`` names it), so its copy is bounded by the scratch disk instead: it must leave
    :data:`SCRATCH_RESERVE_MB` free there.

    Raises:
        InputError: the text runs past ``max_mb`` (``data.max_file_mb``, which bounds a
            drive's text as it bounds a plain file) or past the scratch disk's room, or
            the file is not whole ``kind`` data (cut off, corrupted).
    """
    if max_mb is None:
        room = shutil.disk_usage(dest.parent).free / 2**20 - SCRATCH_RESERVE_MB
        expected = (
            f"{what} that fits the scratch disk once decompressed ({max(room, 0):,.0f} MB "
            f"there, leaving {SCRATCH_RESERVE_MB:,} MB free)"
        )
        fix = "free disk space where temporary files go (TMPDIR), or give the log decompressed"
        limit = int(max(room, 0) * 2**20)
    else:
        expected = f"a drive of at most {max_mb:g} MB once decompressed (data.max_file_mb)"
        fix = (
            "split the drive into several files (one per trip), or raise data.max_file_mb "
            "on a machine with the memory"
        )
        limit = int(max_mb * 2**20)
    found = f"more than that in this {kind} file"
    with open_decompressed(path, kind, file) as src:
        copy_bounded(src, dest, limit, lambda: Problem(file, None, None, expected, found, fix))


def copy_bounded(
    source: BinaryIO, dest: Path, limit: float, too_large: Callable[[], Problem]
) -> None:
    """Copy ``source`` to ``dest`` a step at a time, refusing with ``too_large()`` once
    more than ``limit`` bytes have come (a compressed file's content, a table's CSV text)."""
    written = 0
    with open(dest, "wb") as out:
        while chunk := source.read(COPY_BYTES):
            written += len(chunk)
            if written > limit:
                raise InputError([too_large()])
            out.write(chunk)


def broken(file: str, kind: str, err: BaseException) -> Problem:
    """The problem of a compressed file that cannot be decompressed to its end."""
    return Problem(
        file,
        None,
        None,
        f"whole {kind}-compressed data",
        f"{type(err).__name__}: {str(err)[:120] or 'cut off'}",
        "copy the file again (it is cut off or corrupted), or give its decompressed text",
    )


def compressed_note(kind: str, holds: str = "the text") -> str:
    """What a reader says of a drive file it decompressed (``holds``: what was in it)."""
    return f"a {kind}-compressed file, read as {holds} it holds"


def is_csv_name(name: str) -> bool:
    """Whether a file's name is a CSV's, kept compressed or not (``wheels.csv``,
    ``wheels.csv.gz``): a stream CSV of a folder drive."""
    lower = name.lower()
    return name.endswith(".csv") or any(lower.endswith(".csv" + s) for s in SUFFIXES)


def without_rotation(name: str) -> str:
    """A file's name without a log rotator's number (logrotate, ``RotatingFileHandler``:
    ``gps.nmea.1``, ``can0.log.2.gz`` -> ``gps.nmea``, ``can0.log.gz``): the name a stream
    folder's file is read by."""
    inner = without_suffix(name)
    stem, dot, number = inner.rpartition(".")
    if not dot or not stem or not number.isdigit() or "." not in stem:
        return name
    return stem + name[len(inner) :]


def without_suffix(name: str) -> str:
    """A file's name without a compression's suffix (``gps.nmea.gz`` -> ``gps.nmea``)."""
    for suffix in SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return name


def drive_stem(path: Path) -> str:
    """A drive file's id: its name without a compression's suffix and then its own
    (``V-S1.csv.gz`` -> ``V-S1``; ``V-S1.csv`` -> ``V-S1``)."""
    return Path(without_suffix(path.name)).stem
