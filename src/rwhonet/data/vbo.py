"""Racelogic VBOX files (``.vbo``): their ``[data]`` section read as a column-mapped CSV.

A VBOX data logger writes a text file in sections: a first line ``File created on
11/03/2019 @ 14:22:05``, then ``[header]`` (one channel name per line), optionally
``[channel units]``, ``[comments]``, ``[laptiming]`` and others, ``[column names]`` (the
short names of the columns, separated by spaces) and ``[data]``: one sample per line,
the values separated by spaces, e.g.::

    [column names]
    sats time lat long velocity heading height Wheel_Speed_FL ...
    [data]
    009 142205.10 +03124.44123 +00090.60321 052.113 045.12 +00091.20 051.90 ...

Its conventions (Racelogic's VBO file format description): ``time`` is the UTC time of
day as ``hhmmss.ss``, ``lat`` minutes of arc positive north, ``long`` minutes of arc
positive **west**, ``velocity`` km/h, ``height`` m; channels from the car's CAN bus follow
under the names the user gave them. A column map reads such a file as it reads a CSV
(``t: {column: time, unit: hhmmss}``, ``lat: {column: lat, unit: min}``, ``lon: {column:
long, unit: min W}``, the wheel speeds under their CAN names): :class:`VboAsCsv` turns
the file into the CSV it stands for, a header line of the column names and each data
line's values separated by commas, so every reader, ingest's and ``rwhonet predict``'s,
reads it unchanged and names its rows as the data lines after ``[data]``.

``sats`` is the satellite count with flags added: 64 while the brake trigger input is on,
128 while a DGPS correction is used (``137``: 9 satellites with DGPS). A map declares it
``vbox`` (:data:`rwhonet.data.packed.VBOX_SATS`, the flags taken off); declared a plain
``count`` in a VBOX file, a count of 64 or more is refused (:func:`plain_counts_checked`),
as the flags would pass a fix with too few satellites.
"""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.packed import VBOX_SATS
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.errors import InputError, Problem

# How far into a file its [data] section may start: the sections before it are a few
# hundred lines at most (a long [comments] or [laptiming] section included).
PREAMBLE_MAX_BYTES = 1 << 20
_SPACES = re.compile(rb"[ \t]+")
_ENDS = re.compile(rb"(?m)^[ \t]+|[ \t\r]+$")
_SECTION = re.compile(rb"^\s*\[([^\]]+)\]\s*$")


def is_vbo(head: bytes) -> bool:
    """Whether a file's first bytes are a VBOX file's (``File created on ...``, ``[header]``)."""
    first = head.lstrip(b"\xef\xbb\xbf \t\r\n").split(b"\n", 1)[0].strip().lower()
    return first.startswith(b"file created") or first == b"[header]"


def file_is_vbo(path: Path) -> bool:
    """Whether the file at ``path`` is a VBOX file (by its first line; False if unreadable)."""
    try:
        with open(path, "rb") as f:
            return is_vbo(f.read(256))
    except OSError:
        return False


class VboAsCsv(io.RawIOBase):
    """A VBOX file's bytes as the CSV it stands for: the column names, then the data lines.

    Args:
        source: the VBOX file, opened in binary mode (a file or a pipe), nothing read yet.
        file: how the file is named in error reports.

    Raises:
        InputError: (on the first read) no ``[column names]`` or no ``[data]`` section in
            the first :data:`PREAMBLE_MAX_BYTES`, or column names that repeat.
    """

    def __init__(self, source: BinaryIO, file: str) -> None:
        super().__init__()
        self._source, self._file = source, file
        self._out = b""  # converted bytes not yet handed out
        self._carry = b""  # a data line not yet ended
        self._started = self._ended = False

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:  # type: ignore[no-untyped-def]
        if not self._started:
            self._out = self._header()
            self._started = True
        while not self._out and not self._ended:
            chunk = self._source.read(1 << 16)
            if not chunk:
                self._ended = True
                self._out = _as_csv(self._carry)
                self._carry = b""
                break
            data = self._carry + chunk
            end = data.rfind(b"\n") + 1
            self._carry = data[end:]
            self._out = _as_csv(data[:end])
        n = min(len(buffer), len(self._out))
        buffer[:n] = self._out[:n]
        self._out = self._out[n:]
        return n

    def _header(self) -> bytes:
        """Read the sections before ``[data]``; the CSV header line of the column names."""
        section, names, read = b"", None, 0
        while True:
            line = self._source.readline(PREAMBLE_MAX_BYTES + 1 - read)  # not a whole file
            read += len(line)
            if not line or read > PREAMBLE_MAX_BYTES:
                break
            found = _SECTION.match(line)
            if found:
                section = found.group(1).strip().lower()
                if section == b"data":
                    if names is None:
                        break
                    return b",".join(names) + b"\n"
                continue
            if section == b"column names" and line.strip():
                names = (names or []) + line.split()
        missing = "[column names]" if names is None else "[data]"
        raise InputError(
            [
                Problem(
                    self._file,
                    None,
                    None,
                    "a Racelogic VBOX file with a [column names] section and then a [data] "
                    f"section within its first {PREAMBLE_MAX_BYTES >> 20} MB",
                    f"no {missing} section",
                    "give the file as the VBOX logger wrote it (or export it as a CSV)",
                )
            ]
        )


def _as_csv(lines: bytes) -> bytes:
    """Whole data lines with their values separated by commas, not spaces."""
    return _SPACES.sub(b",", _ENDS.sub(b"", lines))


def vbo_as_csv(path: Path, out: Path, file: str) -> None:
    """Write the CSV a VBOX file stands for (:class:`VboAsCsv`) to ``out``."""
    with open(path, "rb") as src, open(out, "wb") as dst:
        reader = io.BufferedReader(VboAsCsv(src, file), 1 << 16)
        while chunk := reader.read(1 << 20):
            dst.write(chunk)


def vbo_note() -> str:
    """What a reader says when it read a VBOX file."""
    return (
        "a Racelogic VBOX file: its [data] section read as comma-separated columns named "
        "by its [column names]"
    )


def vbo_needs_a_map(file: str, fmt: str) -> Problem:
    """The problem of a VBOX file given as an IO-VNBD drive: its columns need a map."""
    return Problem(
        file,
        None,
        None,
        "an IO-VNBD CSV (format iovnbd)",
        "a Racelogic VBOX file (its first line 'File created on ...')",
        f"read it through a column map (data.column_maps; format {fmt!r} names none): "
        "t: {column: time, unit: hhmmss}, lat: {column: lat, unit: min}, lon: {column: "
        "long, unit: min W}, n_sats: {column: sats, unit: vbox}, and the wheel speeds "
        "under their CAN channels' names "
        "(docs/readers.md, 'Racelogic VBOX files')",
    )


def plain_count_problems(
    counts: np.ndarray, file: str, column: str, setting: str, first_row: int = 1
) -> list[Problem]:
    """A VBOX file's satellite counts read as a plain ``count`` that carry its flags.

    Args:
        counts: the ``sats`` column as read (plain numbers).
        file: the file, as the user knows it.
        column: the file's column name (``sats``).
        setting: where the unit is declared (``data.column_maps.<map>.n_sats.unit``).
        first_row: the 1-based data row of ``counts[0]``.

    Returns:
        One problem per row (the first few; the rest counted) whose count is 64 or more.
    """
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(np.asarray(counts, dtype=np.float64) >= 64)
    if bad.size == 0:
        return []
    return row_problems(
        file,
        column,
        bad + first_row,
        [repr(float(counts[i])) for i in bad[:ROWS_LISTED]],
        "a satellite count below 64 (a VBOX adds 64 while its brake trigger is on and 128 "
        "while it uses DGPS)",
        fix=f"declare {setting} {VBOX_SATS!r}: the flags are taken off the count",
    )


def plain_counts_checked(
    blocks: Iterator[tuple[int, dict[str, np.ndarray]]], file: str, column: str, setting: str
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """``rwhonet predict``'s row blocks of a VBOX file, each refused (InputError) where
    its plain satellite count carries the VBOX's flags (:func:`plain_count_problems`)."""
    for first, columns in blocks:
        if c.N_SATS in columns:
            problems = plain_count_problems(columns[c.N_SATS], file, column, setting, first)
            if problems:
                raise InputError(problems, summary=f"VBOX flags in the satellite count of {file}")
        yield first, columns
