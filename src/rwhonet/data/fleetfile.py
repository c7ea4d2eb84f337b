"""One 10 Hz file holding many drives, told apart by a column: split into its drives.

A fleet's data is often handed on as one table of every drive: a database's or data
lake's export with a ``trip_id`` (``drive_id``, ``session``) column, written as one CSV
or one Parquet file rather than a file per drive or a folder per drive. Read as one
drive, its time goes back where the next drive starts (refused), or, on a Unix clock,
jumps on (two drives joined as one, of one car). A column map that names the column
(``data.column_maps.<name>.drive: {column: trip_id, unit: text}``) reads such a file as
its drives, each named by its value, as a table partitioned by that column
(``drive_id=C-B1/``, :mod:`rwhonet.data.columnar`) is read.

**How.** The file (a CSV; kept compressed, or a Parquet or Feather table, as the text it
holds) is read once, a line at a time (:func:`split_fleet`): the lines before its rows
(comments, a tool's preamble, the header, a row of units) are copied to each drive's own
CSV, and each data row to the CSV of the drive its cell in that column names. Each
drive's CSV is then read by the column map's reader with every rule of
docs/readers.md, as a file of that drive alone: its rows are those of the drive in the
file's order, however they lie in the file (one block, as an export sorted by drive
writes them, or among the other drives' rows, as a log of several cars sorted by time
does).

**Rows named in messages** are the drive's own, counted from its first (its row 1 is the
file's data row its notes give, and for a drive in one block its row ``k`` is the file's
``k`` plus that offset less one); the file is named ``fleet.csv (drive C-B1)``.

**Refused**, naming the file, row and column: the column not in the header; a row with no
drive id in it; an id that cannot name a drive's output files (``/``, ``\\``, a control
character, ``.`` or ``..``, over :data:`ID_MAX_CHARS` characters); a row too short to reach
the column. The file's last row cut short before its drive's cell (a logger that lost
power: no line end) is left out, said, as a drive's reader leaves out a last row cut
short; the header's line again among the rows (a logger's restart, files joined) is left
out of every drive, counted.
"""

from __future__ import annotations

import csv
import itertools
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from rwhonet.data.columnar import open_as_csv, table_kind
from rwhonet.data.compressed import compression_of, open_decompressed
from rwhonet.data.csvio import HeadLines, header_cells, line_key, read_head, text_lines
from rwhonet.errors import InputError, Problem

ID_MAX_CHARS = 128  # a drive id names output files (<drive>.arrow, <drive>_seg00)
FLUSH_BYTES = 32 << 20  # the drives' rows held, all together, before they are written
MAX_PROBLEMS = 20  # rows with a bad id listed


@dataclass(frozen=True)
class FleetPart:
    """One drive of a fleet file: its id, its rows, where they lie in the file, its CSV.

    Attributes:
        drive: the id, as its cells hold it (spaces around it aside).
        rows: its data rows.
        first_row: the file's data row of its first row (1-based, as the readers count).
        last_row: the file's data row of its last.
        runs: the blocks of consecutive file rows its rows lie in (1: one block).
        csv: its own CSV (None: the file was only listed).
    """

    drive: str
    rows: int
    first_row: int
    last_row: int
    runs: int
    csv: Path | None = None

    def note(self, file: str, column: str, total: int) -> str:
        """What the drive's notes say of where it came from."""
        where = (
            f"its data rows {self.first_row:,}-{self.last_row:,}"
            if self.runs == 1
            else f"in {self.runs:,} runs between its data rows {self.first_row:,} and "
            f"{self.last_row:,}"
        )
        return (
            f"drive {self.drive!r} of {file}, whose column {column!r} names each row's drive: "
            f"{self.rows:,} of its {total:,} data rows, {where}; rows named in messages are "
            f"the drive's own, counted from its first (the file's data row {self.first_row:,})"
        )


@dataclass(frozen=True)
class FleetSplit:
    """A fleet file's drives, in the order they first appear, and what was left out."""

    parts: tuple[FleetPart, ...]
    column: str  # the drive column as the header names it
    rows: int  # the file's data rows
    header_again: int  # the header's line again among the rows, left out
    cut_last: int | None = None  # the file's last row, cut short before its drive's cell

    def part(self, drive: str) -> FleetPart | None:
        """The part of a drive id (None: the file has none)."""
        return next((p for p in self.parts if p.drive == drive), None)


def shown(file: str, drive: str) -> str:
    """How messages name a drive of a fleet file: ``fleet.csv (drive C-B1)``."""
    return f"{file} (drive {drive})"


def id_problem(value: str) -> str | None:
    """Why a cell cannot be a drive id (None: it can)."""
    if not value:
        return "an empty cell"
    if value in (".", "..") or any(ch in value for ch in "/\\") or not value.isprintable():
        return f"{value!r}, which cannot name the drive's files"
    if len(value) > ID_MAX_CHARS:
        return f"an id of {len(value)} characters"
    return None


def _open_text(path: Path, file: str, stack: ExitStack) -> BinaryIO:
    """The file's text: as it is, decompressed as it is read, or a table's CSV."""
    if (table := table_kind(path)) is not None:
        return stack.enter_context(open_as_csv(path, table, file)[0])
    if (packed := compression_of(path)) is not None:
        return stack.enter_context(open_decompressed(path, packed, file))
    return stack.enter_context(open(path, "rb"))


def split_fleet(
    path: Path,
    column: str,
    file: str,
    setting: str,
    dest: Path | None = None,
    keep: Callable[[str], bool] | None = None,
) -> FleetSplit:
    """Read a fleet file once: its drives, and with ``dest`` each one's own CSV written.

    Args:
        path: the file (a CSV, kept compressed, or a Parquet or Feather table).
        column: the drive column, as the map names it (found as a map's columns are:
            :func:`rwhonet.data.columnmap.find_column`).
        file: how messages name the file.
        setting: the map's key, for messages (``data.column_maps.fleet.drive``).
        dest: a folder for the drives' CSVs (``<k>.csv``, the k-th drive's); None: listed
            only.
        keep: which drives' CSVs to write (the others listed; None: every one).

    Raises:
        InputError: the file cannot be read, has no such column, or a row has no drive id
            or one that cannot name a drive.
        OSError: ``dest`` cannot be written.
    """
    from rwhonet.data.columnmap import column_not_found, find_column

    with ExitStack() as stack:
        try:
            lines = text_lines(_open_text(path, file, stack))
            head, after = read_head(lines)
        except OSError as err:
            from rwhonet.data.problems import unreadable_file

            raise InputError([unreadable_file(file, err)]) from None
        header = header_cells(head, file)
        pos = find_column(header, column)
        if pos is None:
            raise InputError([column_not_found(header, column, setting, file)])
        name = header[pos].strip()
        delimiter = head.delimiter
        sep = delimiter.encode()
        head_bytes = b"".join(_head_lines(head, after))
        header_key = line_key(head.header)
        units_key = line_key(head.second) if head.units is not None else None
        # the lines read to find the header, after it (the units row among them), then the rest
        rest = itertools.chain(after[1 if head.units is not None else 0 :], lines)
        drives: dict[str, _Open] = {}
        problems: list[Problem] = []
        row = header_again = size = 0
        cut_last: int | None = None
        after_header = False
        for line in rest:
            if not line.rstrip(b"\r\n"):
                continue  # a blank line: no row
            row += 1
            key = line_key(line)
            if key == header_key or (after_header and key == units_key):
                header_again += 1
                after_header = key == header_key
                continue
            after_header = False
            cell = _cell(line, sep, delimiter, pos)
            if cell is None:  # too short to reach the column
                if not line.endswith((b"\n", b"\r")):  # the last row, cut short: no sample
                    cut_last = row
                elif len(problems) < MAX_PROBLEMS:
                    problems.append(_no_id(file, row, name, "a row too short to hold it"))
                continue
            said = id_problem(cell)
            if said is not None:
                if len(problems) < MAX_PROBLEMS:
                    problems.append(_no_id(file, row, name, said))
                continue
            drive = cell
            held = drives.get(drive)
            if held is None:
                out = None
                if dest is not None and (keep is None or keep(drive)):
                    out = dest / f"{len(drives)}.csv"
                held = drives[drive] = _Open(out, head_bytes, row)
            held.add(line, row)
            size += len(line)
            if size >= FLUSH_BYTES:  # one drive's rows after another's, or all interleaved
                for each in drives.values():
                    each.flush()
                size = 0
        if problems:
            raise InputError(problems, summary=f"{file}: rows without a drive id in {name!r}")
        parts = tuple(held.close(d) for d, held in drives.items())
    return FleetSplit(parts, name, row, header_again, cut_last)


def _head_lines(head: HeadLines, after: list[bytes]) -> Iterator[bytes]:
    """The lines before the rows, as the file writes them: a header with its units row."""
    # read_head keeps the comments and preamble only as counts: a drive's CSV starts at its
    # header (the reader skips comments and a preamble, and says so: not needed here)
    yield head.header
    if head.units is not None:
        yield after[0]


def _cell(line: bytes, sep: bytes, delimiter: str, pos: int) -> str | None:
    """A row's cell at ``pos`` (spaces around it aside; None: the row has no such cell)."""
    if b'"' in line:
        text = line.decode("utf-8", "replace").rstrip("\r\n")
        cells = next(csv.reader([text], delimiter=delimiter), [])
        return cells[pos].strip() if pos < len(cells) else None
    cells = line.rstrip(b"\r\n").split(sep)
    if pos >= len(cells):
        return None
    return cells[pos].strip().decode("utf-8", "replace")


def _no_id(file: str, row: int, column: str, found: str) -> Problem:
    return Problem(
        file,
        row,
        column,
        "a drive id in the drive column (the map's drive key): a name of its files, not "
        f"empty, no '/' or '\\', at most {ID_MAX_CHARS} characters",
        found,
        "give every row its drive's id, or leave the drive key out of the map where the "
        "file holds one drive",
    )


class _Open:
    """One drive's rows as they come: counted, and written to its CSV where it has one."""

    def __init__(self, out: Path | None, head: bytes, row: int) -> None:
        self.out, self.held = out, [head] if out is not None else []
        self.first = self.last = row
        self.rows, self.runs, self.started = 0, 0, False

    def add(self, line: bytes, row: int) -> None:
        self.runs += self.rows == 0 or row != self.last + 1
        self.rows, self.last = self.rows + 1, row
        if self.out is not None:  # the file's last line, without a line end, is its last too
            self.held.append(line)

    def flush(self) -> None:
        if self.out is None or not self.held:
            return
        with open(self.out, "ab" if self.started else "wb") as f:
            f.writelines(self.held)
        self.held, self.started = [], True

    def close(self, drive: str) -> FleetPart:
        self.flush()
        return FleetPart(drive, self.rows, self.first, self.last, self.runs, self.out)
