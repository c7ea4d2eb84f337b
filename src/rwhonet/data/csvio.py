"""Numeric CSV reading shared by the drive readers, streamed block by block.

This module knows column *positions*, never column names: ``iovnbd.py`` and
``columnmap.py`` decide which position holds which quantity. The fast path is
one ``pyarrow.csv`` streaming pass converting straight to float64, a block of
``BLOCK_BYTES`` at a time, so memory holds the wanted columns (8 bytes per
cell) and one block of text, never the whole file. Only when it fails are the
columns re-read as bytes, again block by block and single-threaded, so that
every bad cell and every row with the wrong number of columns is reported with
its row number; only blocks with a bad cell are parsed cell by cell.

Row numbers are 1-based *data* rows: the header is not counted, and neither
are blank lines (pyarrow skips them). For a file without blank lines, data row
``r`` is line ``r + 1`` of the file (``r + 2`` under a row of units).

Lines before the header that start with ``#`` (a logger's comments) are skipped
(:func:`head_lines`), and so are a tool's preamble and blank lines (MoTeC i2's and AiM's
key and value lines): the header is then the line of names above the first rows of data
(:func:`find_header`). A row of units under the header (``s, deg, deg, rpm, ...``: a
second header line many loggers' and analysis tools' CSV exports write) is part of the
header: :func:`read_header` gives each column its unit as a header naming it would
(``Time (s)``), so the readers honour or check it as they do a unit the header names,
and the data rows start after it (:meth:`HeadLines.units`). Readers keep every data row, in
order, so row ``i`` (0-based) of a canonical drive is data row ``i + 1`` of its file;
``validate`` relies on this to point at the file's rows.

Rows that end in a comma the header does not are read with an unnamed empty last column
(:attr:`HeadLines.trailing_cell`), and the NUL bytes a file ends in (a logger that lost
power) are not read (:func:`nul_tail`), nor is a last row cut short there, with fewer cells
than a row and no line end (:func:`cut_last_row`). The header's line again among the rows (a logger
that wrote it each time it started; files joined) is told by :func:`header_again_rows`:
:func:`read_numeric_rows` reads those rows as NaN, and the readers leave them out
(:attr:`RawDrive.header_rows`; a stream CSV's samples keep their rows'
numbers: :attr:`rwhonet.data.signalmap.Group.rows`).

Whatever the bytes, a reader returns the columns or raises
:class:`~rwhonet.errors.InputError` (``tests/data/test_reader_fuzz.py``).
"""

from __future__ import annotations

import csv
import io
import itertools
import re
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from rwhonet.data import canonical as c
from rwhonet.data.columnar import MAGIC as TABLE_MAGIC
from rwhonet.data.compressed import MAGIC
from rwhonet.data.headers import header_key, unit_name
from rwhonet.data.problems import ROWS_LISTED, RowTally, no_data_rows, unreadable_file
from rwhonet.errors import InputError, Problem

# The cells pyarrow takes for a missing value: canonical.MISSING_CELLS in every case (pyarrow
# matches them as written), as predict's reader takes them.
NULL_VALUES = sorted(
    {
        "".join(x)
        for word in c.MISSING_CELLS
        for x in itertools.product(*({ch.lower(), ch.upper()} for ch in word))
    }
)

# Text parsed per step. A row longer than this cannot be read (no drive row comes close).
BLOCK_BYTES = 1 << 20
# Rows the columns are first allocated for: the file's size at the first block's bytes per
# row, times this (rows later in a file are rarely much shorter than its first ones).
CAPACITY_MARGIN = 1.2
# The header is read on its own: a first line longer than this is not a CSV header.
HEADER_MAX_BYTES = 1 << 20

EXPORT_CSV = (
    "export the drive as a CSV text file: UTF-8 (or ASCII), comma-separated, one header row "
    "then one row per sample"
)

# File signatures of things that are not CSV text (what spreadsheet tools produce by mistake).
_SIGNATURES: tuple[tuple[bytes, str], ...] = (
    (b"\xff\xfe", "UTF-16 text (byte-order mark FF FE), e.g. Excel's 'Unicode Text'"),
    (b"\xfe\xff", "UTF-16 text (byte-order mark FE FF)"),
    (b"PK\x03\x04", "a ZIP archive (an .xlsx workbook saved with a .csv name?)"),
    (b"\xd0\xcf\x11\xe0", "an OLE2 file (an .xls workbook saved with a .csv name?)"),
    # a compressed drive file is read by its path (rwhonet.data.compressed), not from a pipe
    *(
        (magic, f"{kind}-compressed data (give it as a file, or decompress it first)")
        for magic, kind, _ in MAGIC
        if kind != "zip"  # named above (a workbook is the likelier mistake)
    ),
    # a Parquet or Feather table is read by its path (rwhonet.data.columnar), not from a pipe
    *(
        (magic, f"a table file ({kind}): give its path, it is read as the CSV it holds")
        for magic, kind in TABLE_MAGIC
    ),
)


@dataclass(frozen=True)
class RawDrive:
    """The channels of one drive file, in canonical names and SI units.

    Attributes:
        columns: canonical name -> float64 array; element ``i`` is data row ``i + 1``
            (but see ``repeated_rows`` and ``wheelless_rows``).
        source_columns: canonical name -> the file's column name it was read from.
        header_match: how the columns were found: ``"name"``, ``"position"``,
            ``"column_map"``, or ``"streams"`` (resampled from timestamped streams,
            :mod:`rwhonet.data.streams`: element ``i`` is then row ``i`` of the 10 Hz grid).
        notes: what the reader did that the user should hear about (columns taken by
            position, the clock passing midnight, rows of the grid without data, rows
            written twice or without a wheel speed).
        repeated_rows: data rows of the file (1-based) left out because they repeat the
            row before them (:func:`rwhonet.data.droprows.drop_rows`).
        wheelless_rows: data rows of the file (1-based) left out because a wheel speed is
            empty in them (a lost sample, :func:`rwhonet.data.droprows.drop_rows`). Element
            ``i`` of ``columns`` is the file's row ``FileRows(both, merged)(i)``.
        held_fix_period_rows: the period, in rows, of a slower receiver whose fixes the
            file held and the reader placed along the path
            (:func:`rwhonet.data.heldfixes.place_held_fixes`); 0: the rows' own fixes.
        header_rows: data rows of the file (1-based) that are its header's line again
            (and its row of units), left out by the reader (:func:`header_again_rows`).
            Element ``i`` of ``columns`` is then the file's row ``FileRows(header_rows)(i)``
            (and through every kind of row dropped: ``FileRows`` of them all merged).
        row_order: where the rows were put in time order
            (:func:`rwhonet.data.sampleorder.rows_in_time_order`), the file's data row of
            each (1-based); None: the file's order.
        untimed_rows: data rows of the file (1-based) left out because their stamps,
            coarser than the rows, cannot tell their times (a second's stamp holding
            fewer rows than a second has: :func:`rwhonet.data.sampleorder.coarse_stamps_placed`).
    """

    columns: dict[str, np.ndarray]
    source_columns: dict[str, str]
    header_match: str
    notes: tuple[str, ...] = ()
    repeated_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    wheelless_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    held_fix_period_rows: int = 0
    header_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    row_order: np.ndarray | None = None
    untimed_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def n_rows(self) -> int:
        """Number of data rows."""
        return len(next(iter(self.columns.values()))) if self.columns else 0


def _not_text(file: str, found: str) -> InputError:
    return InputError(
        [Problem(file, None, None, "a CSV text file (UTF-8, comma-separated)", found, EXPORT_CSV)],
        summary=f"{file} is not a CSV text file",
    )


def read_header(path: Path, display: str | None = None) -> list[str]:
    """Return the header row of a CSV file, cells as written (spaces kept); under a row of
    units (:meth:`HeadLines.units`), each cell with its unit as a header names it (``Time (s)``).

    Args:
        path: the CSV file.
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The header cells.

    Raises:
        InputError: the file cannot be opened, is empty, is not CSV text (UTF-16, a
            workbook, compressed, binary), its first line is not a header of comma-separated
            names (no line break within ``HEADER_MAX_BYTES``, another separator); a units
            row naming another unit than the header does for a column.
    """
    file = display or str(path)
    try:
        head = head_lines(path)
    except OSError as err:
        raise InputError([unreadable_file(file, err)]) from None
    header = header_cells(head, file)
    units = head.units
    return header if units is None else with_units(header, units, file)


def header_cells(head: HeadLines, file: str) -> list[str]:
    """A header's cells as its rows hold them (:func:`parse_header`): with the empty cell
    the rows end in (:attr:`HeadLines.trailing_cell`), without the empty one the header
    ends in and its rows lack (:attr:`HeadLines.short_rows`)."""
    header = parse_header(head.header, file, head.comments)
    if head.trailing_cell:
        return [*header, ""]
    return header[:-1] if head.short_rows else header


# Lines before the header that start with '#' (a logger's or tool's comments: its version,
# the car, the settings) are skipped, at most this many.
COMMENT_MAX_LINES = 1000
# A tool's preamble before the header (MoTeC i2's and AiM Race Studio's CSV exports: key and
# value lines, "Format","MoTeC CSV File" / "Venue",... and blank lines): the header is looked
# for within this many lines and bytes, as the line of names above the first DATA_RUN rows
# of data of its width (find_header).
HEADER_SEARCH_LINES = 1000
HEADER_SEARCH_BYTES = 1 << 20
DATA_RUN = 3


@dataclass(frozen=True)
class HeadLines:
    """A CSV file's first lines: ``comments`` lines starting with '#' (skipped), then
    ``preamble`` lines of a tool's preamble or blank (skipped; ``preamble_first`` the first
    of them not blank),
    the header line, and the line after it (the header's line end and the second line's
    included)."""

    comments: int
    header: bytes
    second: bytes
    preamble: int = 0
    preamble_first: bytes = b""
    below: bytes = b""  # the first line not blank after the second (b"": none read)

    @property
    def delimiter(self) -> str:
        """The separator, told from the header line (:func:`delimiter_of`)."""
        return delimiter_of(self.header[: first_line_end(self.header)])

    @property
    def units(self) -> list[str] | None:
        """The second line's cells where it is a row of units (:func:`units_row_in`)."""
        return units_row_in(self.header, self.second, self.below)

    @property
    def trailing_cell(self) -> bool:
        """Whether the data rows end in a comma the header does not (a logger that writes
        each value and a comma after it): the first row of data has one cell more than
        the header, the last one empty. Readers read it as an unnamed last column."""
        first = self.below if self.units is not None or not self.second.strip() else self.second
        delimiter = self.delimiter
        width = len(_cells(self.header, delimiter))
        cells = _cells(first, delimiter)
        return (
            width >= 2
            and len(cells) == width + 1
            and not cells[-1].strip()
            and _is_data(cells, width)
        )

    @property
    def short_rows(self) -> bool:
        """Whether the header ends in an empty cell its data rows lack (a header written
        with a comma after each name, its rows without): the first row of data has one
        cell fewer than the header, whose last cell is empty. Readers read the header
        without it."""
        first = self.below if self.units is not None or not self.second.strip() else self.second
        delimiter = self.delimiter
        header = _cells(self.header, delimiter)
        cells = _cells(first, delimiter)
        return (
            len(header) >= 3
            and not header[-1].strip()
            and all(x.strip() for x in header[:-1])
            and len(cells) == len(header) - 1
            and _is_data(cells, len(cells))
        )

    @property
    def skipped(self) -> int:
        """Lines before the data rows: comments, a preamble, the header, a units row."""
        return self.comments + self.preamble + (1 if self.units is None else 2)

    def notes(self) -> tuple[str, ...]:
        """What a reader says of these lines: a separator not ',', a units row, comments,
        a preamble."""
        said = (
            delimiter_note(self.delimiter),
            None if self.units is None else units_row_note(),
            comment_lines_note(self.comments),
            preamble_note(self.preamble, self.preamble_first),
            trailing_cell_note() if self.trailing_cell else None,
            short_rows_note() if self.short_rows else None,
        )
        return tuple(note for note in said if note is not None)


def is_comment(line: bytes) -> bool:
    """Whether a line before the header is a comment: it starts with '#' (a byte-order mark
    and spaces before it aside)."""
    return line.lstrip(b"\xef\xbb\xbf \t").startswith(b"#")


def head_lines(path: Path) -> HeadLines:
    """The comments, preamble, header and second line of a CSV file (:class:`HeadLines`).

    Raises:
        OSError: the file cannot be read.
    """
    with open(path, "rb") as f:
        return read_head(text_lines(f))[0]


def read_head(lines: Iterator[bytes]) -> tuple[HeadLines, list[bytes]]:
    """The lines before a CSV file's data (:class:`HeadLines`) from its lines as they come,
    and the lines read after the header (the second line first) to tell where it is."""
    comments, line = 0, next(lines, b"")
    while is_comment(line) and comments < COMMENT_MAX_LINES:
        comments, line = comments + 1, next(lines, b"")
    if any(line.startswith(signature) for signature, _ in _SIGNATURES) or b"\x00" in line:
        return HeadLines(comments, line, b""), []  # not text: parse_header says what it is
    seen, ended, size = [line], not line, len(line)
    while (at := find_header(seen, ended or size > HEADER_SEARCH_BYTES)) is None:
        line = next(lines, b"")
        ended, size = not line, size + len(line)
        if line:
            seen.append(line)
    after, said = seen[at + 1 :], next((x for x in seen[:at] if x.strip()), b"")
    second, below = after[0] if after else b"", next((x for x in after[1:] if x.strip()), b"")
    return HeadLines(comments, seen[at], second, at, said, below), after


def find_header(lines: list[bytes], ended: bool) -> int | None:
    """Where the header is among a CSV file's first lines (comments skipped), or None where
    more lines are needed to tell (``ended``: there are no more).

    The first line is the header where the first line after it (after a row of units
    under it) is a row of data as wide; else a tool's preamble is looked for: the header is
    the first line of names (every cell filled, one at most aside, none a number) above
    ``DATA_RUN`` rows of data of its width (a row of units between them allowed), its
    delimiter theirs. Where none is found, or the line above the one found is a line of
    names as wide (a second header line: which is the header cannot be told), the first
    line is the header, as it always was, and its reader says what is wrong.
    """
    first = _data_after(lines, 0, 1)
    if first or (first is None and not ended):
        return 0 if first else None
    run, width = 0, -1  # rows of data in a row, of one width, under no header found
    for i in range(1, min(len(lines), HEADER_SEARCH_LINES)):
        if not lines[i].strip():
            continue
        found = _data_after(lines, i, DATA_RUN) if _is_names(lines[i]) else False
        if found is None and not ended:
            return None
        if found:
            above = next((x for x in reversed(lines[:i]) if x.strip()), b"")
            return 0 if _is_names(above) and _width(above) == _width(lines[i]) else i
        cells = _cells(lines[i], delimiter_of(lines[0]))
        if _is_data(cells, width):
            run += 1
        else:
            run, width = int(_is_data(cells, len(cells))), len(cells)
        if run >= DATA_RUN:  # in the data: no preamble above it
            return 0
    return 0 if ended or len(lines) >= HEADER_SEARCH_LINES else None


def _cells(line: bytes, delimiter: str) -> list[str]:
    """A line's cells, read with ``delimiter`` as its readers read it."""
    text = as_comma_separated(line[: first_line_end(line)], delimiter)
    return next(csv.reader([text.decode("utf-8-sig", errors="replace")]), [])


def _width(line: bytes) -> int:
    return len(_cells(line, delimiter_of(line)))


def _is_names(line: bytes) -> bool:
    """Whether a line could be a header: two cells or more, all filled but one at most,
    none a number."""
    cells = [x.strip() for x in _cells(line, delimiter_of(line))]
    filled = [x for x in cells if x]
    return len(cells) >= 2 and len(filled) >= len(cells) - 1 and not any(map(is_number, filled))


def _is_data(cells: list[str], width: int) -> bool:
    """Whether cells are a row of data ``width`` wide (an empty cell more at its end
    allowed: :attr:`HeadLines.trailing_cell`): half of its filled cells numbers."""
    if len(cells) == width + 1 and not cells[-1].strip():
        cells = cells[:-1]
    filled = [x for x in cells if x.strip()]
    return len(cells) == width and bool(filled) and 2 * sum(map(is_number, filled)) >= len(filled)


def _data_after(lines: list[bytes], at: int, rows: int) -> bool | None:
    """Whether the first ``rows`` non-blank lines after line ``at`` (and a row of units
    right under it) are rows of data as wide as it, read with its delimiter (None: not
    enough lines yet)."""
    delimiter = delimiter_of(lines[at][: first_line_end(lines[at])])
    width = len(_cells(lines[at], delimiter))
    after = lines[at + 1 :]
    if after:
        below = next((x for x in after[1:] if x.strip()), None)
        if below is None and is_units_row(_cells(after[0], delimiter), data_below=True):
            return None  # a row of units perhaps, told by the line under it
        if units_row_in(lines[at], after[0], below or b"") is not None:
            after = after[1:]
    data = [x for x in after if x.strip()][:rows]
    if not all(_is_data(_cells(x, delimiter), width) for x in data):
        return False
    return True if len(data) == rows else None


def text_lines(f: Any) -> Iterator[bytes]:
    """A file's lines of at most ``HEADER_MAX_BYTES`` each, each with its line end: LF, CR
    LF, or a lone CR (classic Mac), which ``readline`` does not split at."""
    while True:
        data = f.readline(HEADER_MAX_BYTES + 1)
        if not data:
            return
        while data:
            end = first_line_end(data)
            if data[end : end + 1] == b"\r" and data[end + 1 : end + 2] != b"\n":
                line, data = data[: end + 1], data[end + 1 :]
            else:
                line, data = data, b""
            yield line


# A cell of a units row: a unit's spelling ("s", "km/h", "m/s^2", "[deg]", "°C", "%"), no
# number; and half of a row's filled cells at least must be units the readers know.
_UNIT_LIKE = re.compile(r"[\[(]?(?:1/)?[A-Za-z°%µ][A-Za-z0-9°%µ/^*·. \-]{0,15}[\])]?")


def is_units_row(cells: Iterable[str], data_below: bool = False) -> bool:
    """Whether a CSV line's cells are the columns' units, not a row of data: every filled
    cell spells a unit (letters first, no number) and half of them at least are units the
    readers know (:data:`rwhonet.data.headers.UNIT_ALIASES`), or one at least where a row
    of data as wide as the header is under the line (``data_below``: a tool's export of
    many channels whose units the readers do not use, ``C``, ``kPa``, ``V``)."""
    filled = [x.strip() for x in cells if x.strip()]
    if not filled or not all(_UNIT_LIKE.fullmatch(x) and not is_number(x) for x in filled):
        return False
    known = sum(unit_name(x.strip("[]()")) is not None for x in filled)
    return 2 * known >= len(filled) or (data_below and known >= 1)


def is_number(cell: str | bytes) -> bool:
    """Whether a cell reads as a number (``float`` takes it: ``NaN`` and ``inf`` too)."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


def units_row_in(header_line: bytes, second: bytes, below: bytes = b"") -> list[str] | None:
    """The cells of the line after a CSV header (``second``) where they are a row of units
    (:func:`is_units_row`, ``below`` the first line not blank under it; None: they are
    not)."""
    delimiter = delimiter_of(header_line[: first_line_end(header_line)])
    cells = _cells(second, delimiter)
    width = len(_cells(header_line, delimiter))
    data_below = bool(below.strip()) and _is_data(_cells(below, delimiter), width)
    return cells if is_units_row(cells, data_below) else None


def with_units(header: list[str], units: list[str], file: str) -> list[str]:
    """Header cells with the units of a units row, as a header names them (``Time (s)``).

    A cell that names its own unit keeps it; a units row naming another for it is refused.

    Raises:
        InputError: the header and the units row name two units for a column.
    """
    out, problems = [], []
    for i, cell in enumerate(header):
        unit = units[i].strip().strip("[]()").strip() if i < len(units) else ""
        said = header_key(cell)[1]
        if unit and said is None:
            out.append(f"{cell} ({unit})")
            continue
        named = (unit_name(said), unit_name(unit))
        # two units the readers do not know (degC, %) are compared as written
        if unit and (named[0] != named[1] or named[0] is None and said != unit.lower()):
            problems.append(
                Problem(
                    file,
                    None,
                    cell.strip(),
                    f"the unit the header names, {said!r}, in the row of units too",
                    f"{unit!r} in the row of units under the header",
                    "correct the header or the row of units",
                )
            )
        out.append(cell)
    if problems:
        raise InputError(problems, summary=f"a header and its row of units disagree in {file}")
    return out


def _head_or_plain(path: Path) -> HeadLines:
    """:func:`head_lines`, or a plain file's where it cannot be read (its reader says why)."""
    try:
        return head_lines(path)
    except OSError:
        return HeadLines(0, b"", b"")


def csv_notes(path: Path, n_columns: int, n_rows: int) -> tuple[str, ...]:
    """What a reader says of the lines before a CSV file's data (:meth:`HeadLines.notes`),
    of NUL bytes it ends in (:func:`nul_tail`) and of a last row cut short after its
    ``n_rows`` data rows of ``n_columns`` cells (:func:`cut_last_row`)."""
    said = (
        nul_tail_note(nul_tail(path)),
        cut_last_row_note(n_rows + 1, cut_last_row(path, n_columns)),
    )
    return _head_or_plain(path).notes() + tuple(x for x in said if x is not None)


def comment_lines_note(n: int) -> str | None:
    """What a reader says of ``n`` comment lines skipped before the header (None: none)."""
    return f"{n} comment line(s) starting with '#' before the header skipped" if n else None


def preamble_note(n: int, first: bytes) -> str | None:
    """What a reader says of ``n`` lines of a tool's preamble skipped before the header,
    ``first`` the first of them not blank (None: none)."""
    if not n:
        return None
    if not first.strip():
        return f"{n} blank line(s) before the header skipped"
    start = ", ".join(x.strip() for x in _cells(first, delimiter_of(first)) if x.strip())
    return (
        f"{n} line(s) before the header skipped, from {start[:60]!r}: a tool's preamble "
        "(the header taken as the line of names above the first rows of data)"
    )


def columns_expected(n_columns: int, trailing_cell: bool, short_rows: bool = False) -> str:
    """What a reader expects of every row's cells (``trailing_cell``: the header's and the
    empty one its rows end in, :attr:`HeadLines.trailing_cell`; ``short_rows``: the
    header's without the empty one it ends in, :attr:`HeadLines.short_rows`)."""
    if short_rows:
        return (
            f"{n_columns} comma-separated columns: the header's {n_columns + 1} without its "
            "empty last one, as the first rows hold them"
        )
    if trailing_cell:
        return (
            f"{n_columns} comma-separated columns: the header's {n_columns - 1} and the "
            "empty one the first rows end in"
        )
    return f"{n_columns} comma-separated columns, as in the header"


def short_rows_note() -> str:
    """What a reader says of a header that ends in a comma its data rows do not."""
    return "the header ends in a comma its rows do not: its empty last cell not read"


def trailing_cell_note() -> str:
    """What a reader says of data rows that end in a comma the header does not."""
    return "every row of data ends in a comma the header does not: an empty last column"


def units_row_note() -> str:
    """What a reader says when a row of units was read under the header."""
    return "a row of units under the header: each column's unit read from it"


def first_cell(path: Path, pos: int, limit: int = 1 << 16) -> str | None:
    """The first non-empty cell of column ``pos`` in a CSV file's first data rows (None: none
    in the first ``limit`` bytes after the header, or the file cannot be read: its reader
    says why). For telling a time written as text before the numbers are read."""
    try:
        with open(path, "rb") as f:
            data = f.read(limit)
    except OSError:
        return None
    head = _head_or_plain(path)
    skip = head.skipped
    data = as_comma_separated(data, head.delimiter)
    lines = data.decode("utf-8", errors="replace").splitlines()  # LF, CR LF or a lone CR
    return first_cell_in(lines[skip:-1] if len(data) == limit else lines[skip:], pos)


def first_cell_in(lines: Iterable[str], pos: int) -> str | None:
    """The first non-empty cell of column ``pos`` in comma-separated data lines (blank
    lines skipped; None: none)."""
    for cells in csv.reader(line for line in lines if line.strip()):
        if pos < len(cells) and cells[pos].strip():
            return cells[pos]
    return None


def first_line_end(data: bytes) -> int:
    """Where the first line of ``data`` ends: its first CR or LF (``len(data)``: neither)."""
    ends = [i for i in (data.find(b"\r"), data.find(b"\n")) if i >= 0]
    return min(ends) if ends else len(data)


def parse_header(line: bytes, file: str, comments: int = 0) -> list[str]:
    """Return the cells of a CSV file's first line (see :func:`read_header`).

    Args:
        line: the first line as read, at most ``HEADER_MAX_BYTES + 1`` bytes.
        file: how the file is named in error reports.
        comments: the comment lines before it (a file of nothing else is said so).

    Returns:
        The header cells.

    Raises:
        InputError: as :func:`read_header`.
    """
    for signature, what in _SIGNATURES:
        if line.startswith(signature):
            raise _not_text(file, what)
    # A file saved with classic Mac line ends (a lone CR: Excel's "CSV (Macintosh)") has
    # no LF: its first line ends at the first CR, as the readers' CSV parsers take it.
    read, line = line, line[: first_line_end(line)]
    if b"\x00" in line:
        raise _not_text(file, "binary data (NUL bytes) in the first line")
    if len(line) > HEADER_MAX_BYTES:
        raise _not_text(file, f"no line break in the first {HEADER_MAX_BYTES >> 20} MB")
    # utf-8-sig drops a byte-order mark that spreadsheet exports often add in front of the
    # first header name; undecodable bytes are replaced so a bad header still gets reported.
    text = line.decode("utf-8-sig", errors="replace")
    header = next(csv.reader(io.StringIO(text, newline="")), None)
    if not header or all(not cell.strip() for cell in header):
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a header row followed by data rows",
                    "an empty first line"
                    if read
                    else f"{comments} comment line(s) starting with '#' and nothing after"
                    if comments
                    else "an empty file",
                    "put the column names in the first line (the IO-VNBD names, or the names "
                    "data.column_maps gives)",
                )
            ]
        )
    delimiter = delimiter_of(line)
    if delimiter != ",":  # a spreadsheet's locale: ';' or tabs, and perhaps decimal commas
        header = next(csv.reader(io.StringIO(text, newline=""), delimiter=delimiter))
    return header


# Files separated by ';' or tabs (what spreadsheets write in locales whose decimal mark is
# ','): each is read as the comma-separated file it stands for, every byte of it through
# this table, the separator becoming ',' and a ',' (a decimal comma there) becoming '.'.
DELIMITERS = {";": "semicolons", "\t": "tabs"}
_TABLES = {sep: bytes.maketrans(sep.encode() + b",", b",.") for sep in DELIMITERS}


def delimiter_of(line: bytes) -> str:
    """A CSV file's separator from its first line: ``;`` or a tab where the line has one
    and no comma (a spreadsheet in a locale whose decimal mark is ','), else ``,``."""
    if b"," in line:
        return ","
    for sep in DELIMITERS:
        if sep.encode() in line:
            return sep
    return ","


def as_comma_separated(data: bytes, delimiter: str) -> bytes:
    """Bytes of a file separated by ``delimiter`` as those of the comma-separated file it
    stands for (``;`` -> ``,``, a decimal ``,`` -> ``.``); unchanged for ``,``."""
    return data if delimiter == "," else data.translate(_TABLES[delimiter])


def delimiter_note(delimiter: str) -> str | None:
    """What a reader says of a file not separated by commas (None: it is)."""
    if delimiter == ",":
        return None
    return (
        f"separated by {DELIMITERS[delimiter]}, a ',' taken for a decimal mark (a "
        "spreadsheet's locale); cells quoted in messages are shown with '.'"
    )


def nul_tail(path: Path) -> int:
    """The NUL bytes a file ends in (0: none, or the file cannot be read: its reader says
    why): what a logger that lost power leaves where its last data were never written
    (the file's length already counting a cluster its data never reached)."""
    n, size = 0, 4096  # the last 4 KB first (a file of whole rows: its last byte a line end)
    try:
        with open(path, "rb") as f:
            end = f.seek(0, io.SEEK_END)
            while end > 0:
                step = min(size, end)
                f.seek(end - step)
                kept = len(f.read(step).rstrip(b"\x00"))
                n, end, size = n + step - kept, end - step, min(2 * size, BLOCK_BYTES)
                if kept:
                    break
    except OSError:
        return 0
    return n


def nul_tail_note(n: int) -> str | None:
    """What a reader says of a file's ``n`` NUL bytes at its end, not read (None: none)."""
    if not n:
        return None
    return (
        f"{n} NUL byte(s) at the end of the file not read: what a logger that lost power "
        "leaves where its last data were never written"
    )


def cut_last_row(
    path: Path, n_columns: int, head: HeadLines | None = None, nul: int | None = None
) -> int:
    """The bytes of a last data row cut short (0: none): what a logger that lost power while
    writing a row leaves, or a copy stopped part way.

    The row is the text after the file's last line end (before the NUL bytes it ends in,
    :func:`nul_tail`) that :func:`is_cut_short` says is cut short. A last row without its
    line end that holds every cell is read as it stands: many exporters end their last row
    so, and a cell cut short in it cannot be told from a shorter number.

    Args:
        path: the CSV file.
        n_columns: the cells every data row holds.
        head: the file's first lines (:func:`head_lines`), where the caller has them.
        nul: the NUL bytes it ends in (:func:`nul_tail`), where the caller has them.

    Returns:
        The row's length in bytes (0 also where the file cannot be read: its reader says why).
    """
    head = _head_or_plain(path) if head is None else head
    try:
        with open(path, "rb") as f:
            end = f.seek(0, io.SEEK_END) - (nul_tail(path) if nul is None else nul)
            start = max(end - BLOCK_BYTES, 0)
            f.seek(start)
            text = f.read(end - start)
    except OSError:
        return 0
    if not text or text.endswith((b"\n", b"\r")):
        return 0
    at = max(text.rfind(b"\n"), text.rfind(b"\r"))
    row = text[at + 1 :]
    # the header's lines are never a row cut short (nor are a tool's comments)
    if at < 0 or line_key(row) in (line_key(head.header), line_key(head.second)):
        return 0
    return len(row) if not is_comment(row) and is_cut_short(row, head.delimiter, n_columns) else 0


def is_cut_short(row: bytes, delimiter: str, n_columns: int) -> bool:
    """Whether a last row without its line end is cut short: not blank, no quote (a quoted
    cell may hold a separator), fewer than ``n_columns`` cells between ``delimiter``s."""
    if not row.strip() or b'"' in row:
        return False
    return row.count(delimiter.encode()) + 1 < n_columns


def cut_last_row_note(row: int, n_bytes: int) -> str | None:
    """What a reader says of a last data row ``row`` cut short (:func:`cut_last_row`: its
    ``n_bytes``; 0: none, None said), not read."""
    if not n_bytes:
        return None
    return (
        f"the last row ({row}) cut short, not read: {n_bytes} byte(s) with fewer cells than "
        "the header's and no line end, where a logger that lost power stopped writing (its "
        "sample lost as a dropped one)"
    )


def cut_by_nul_tail(file: str, row: int, n: int) -> Problem:
    """The problem of a last data row cut off where a file's ``n`` NUL bytes begin."""
    return Problem(
        file,
        row,
        None,
        "the last row whole before the NUL bytes the file ends in",
        f"row {row} cut off, then {n} NUL byte(s) to the end of the file: a logger that lost "
        "power while writing it",
        f"delete row {row} (the rows before it are read; the NUL bytes after it are not)",
    )


class _Source(io.RawIOBase):
    """A CSV file's first ``end`` bytes, a file separated by ';' or tabs read as the
    comma-separated file it stands for."""

    def __init__(self, path: Path, delimiter: str, end: int) -> None:
        self._file = open(path, "rb")  # noqa: SIM115 -- closed by close(), as a file is
        self._delimiter, self._left = delimiter, end

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        data = self._file.read(min(len(buffer), self._left))
        self._left -= len(data)
        data = as_comma_separated(data, self._delimiter)
        buffer[: len(data)] = data
        return len(data)

    def close(self) -> None:
        self._file.close()
        super().close()


@contextmanager
def _quiet_undecodable_rows() -> Iterator[None]:
    """Keep pyarrow's noise about rows that are not UTF-8 off the user's terminal.

    pyarrow decodes a malformed row's text for the invalid-row handler; when the row is
    not UTF-8 that raises inside pyarrow, which prints "Exception ignored ..." with a
    traceback and then fails the read with ``ArrowInvalid`` naming the row, which the
    reader reports. Only that UnicodeDecodeError is silenced, only while reading.
    """
    previous = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        if unraisable.exc_type is not UnicodeDecodeError:
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous


def read_numeric_rows(
    path: Path, n_columns: int, wanted: Mapping[int, str], display: str | None = None
) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """Read some columns of a CSV drive file (a 10 Hz file, a stream CSV) as float64, block
    by block, and the lines that repeat its header (:func:`header_again_rows`: a logger
    that wrote its header again each time it started, appending to one file; exports of
    one drive joined).

    Returns:
        (column position -> float64 array, one element per data row, NaN in the rows that
        repeat the header; those rows, 1-based data rows, increasing): a reader keeps
        ``row i is data row i + 1`` while it reads the file's other columns, then drops
        them (:attr:`RawDrive.header_rows`).

    Raises:
        InputError: a row with another number of columns than the header, a cell that is
            not a number (the header's lines again aside): every such row, by the slow path
            (:func:`_read_numeric_slow`).
    """
    return _read_numeric(path, n_columns, wanted, display)


@_quiet_undecodable_rows()
def _read_numeric(
    path: Path,
    n_columns: int,
    wanted: Mapping[int, str],
    display: str | None,
) -> tuple[dict[int, np.ndarray], np.ndarray]:
    """Read some columns of a CSV file (header row first) as float64, block by block.

    Empty cells and the usual missing-value spellings (``NaN``, ``NA``, ``null``) become NaN,
    left for ``validate`` to report; any other text in a number column is an error here.

    Args:
        path: the CSV file.
        n_columns: number of columns of the header; every data row must have as many.
        wanted: 0-based column position -> the file's column name (used in messages).
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        Column position -> float64 array, one element per data row.

    Raises:
        InputError: listing every row with the wrong number of columns, every non-numeric
            cell in a wanted column, text that is not CSV, or a file without data rows.
    """
    file = display or str(path)
    names = [f"c{i}" for i in range(n_columns)]
    invalid_rows = 0

    def on_invalid_row(row: object) -> str:
        nonlocal invalid_rows
        invalid_rows += 1
        return "skip"

    # The columns are allocated once, for the rows the file's size allows at the first
    # block's bytes per row (with a margin), and filled block by block: no list of blocks to
    # join at the end, which would hold every value twice. Rows shorter than the first
    # block's (the margin exhausted) grow them by half again.
    try:
        size = Path(path).stat().st_size
    except OSError:
        size = 0  # unreadable: the slow path says so
    out: dict[int, np.ndarray] = {}
    capacity = n = 0
    try:
        reader = _open_columns(path, names, wanted, pa.float64(), on_invalid_row)
        for batch in reader:
            if invalid_rows:
                break
            if n + batch.num_rows > capacity:
                if not out:  # the first block: BLOCK_BYTES of text (or the whole file)
                    per_row = BLOCK_BYTES / max(batch.num_rows, 1)
                    capacity = batch.num_rows + int(CAPACITY_MARGIN * size / per_row) + 1024
                else:
                    capacity = max(int(1.5 * capacity), n + batch.num_rows)
                out = {pos: _grown(out.get(pos), n, capacity) for pos in wanted}
            for pos in wanted:
                out[pos][n : n + batch.num_rows] = batch.column(names[pos]).to_numpy(
                    zero_copy_only=False
                )
            n += batch.num_rows
    except (pa.ArrowInvalid, OSError):
        invalid_rows = -1  # a cell that is not a number, or not CSV: find every problem
    if invalid_rows:
        del out
        again = header_again_rows(path)
        return _read_numeric_slow(path, n_columns, wanted, file, again), again
    if n == 0:
        raise InputError([no_data_rows(file)])
    return {pos: values[:n] for pos, values in out.items()}, _NO_ROWS


_NO_ROWS = np.zeros(0, dtype=np.int64)
_NO_ROWS.flags.writeable = False


def header_again_rows(path: Path) -> np.ndarray:
    """The data rows (1-based) of a CSV file that are its header line again, each with the
    row of units under it where the file has one under its header.

    A logger that writes its header each time it starts, appending to one file (a
    microcontroller's ``setup()``; a logger that restarts after losing power), and exports
    of one drive joined with ``cat``, leave the header's line among the rows. Such a line
    is the header's to the byte (spaces and a byte-order mark around it aside);
    the rows after it are read as the file's rows, whatever their time does (a gap, or a
    clock that went back, which validate refuses). Rows are numbered as the readers number
    them: lines after the header (and its units row), blank lines not counted.

    Returns:
        The rows, increasing (none: the file cannot be read, its reader says why).
    """
    head = _head_or_plain(path)
    header = line_key(head.header)
    units = line_key(head.second) if head.units is not None else None
    if not header:
        return _NO_ROWS
    rows: list[int] = []
    try:
        with open(path, "rb") as f:
            lines = text_lines(f)
            for _ in itertools.islice(lines, head.skipped):
                pass
            row, after_header = 0, False
            for line in lines:
                if not line.rstrip(b"\r\n"):
                    continue  # a blank line: not a row
                row += 1
                key = line_key(line)
                if key == header or (after_header and key == units):
                    rows.append(row)
                    after_header = key == header
                else:
                    after_header = False
    except OSError:
        return _NO_ROWS
    return np.asarray(rows, dtype=np.int64)


def without_rows(columns: dict[str, np.ndarray], rows: np.ndarray) -> dict[str, np.ndarray]:
    """A reader's columns without some data rows (1-based): the header's line again."""
    if not len(rows):
        return columns
    keep = np.ones(len(next(iter(columns.values()))), dtype=bool)
    keep[np.asarray(rows) - 1] = False
    return {name: values[keep] for name, values in columns.items()}


def line_key(line: bytes) -> bytes:
    """A line as the readers compare it with the header's (:func:`header_again_rows`):
    without its line end, spaces around it and a byte-order mark."""
    return line.strip().removeprefix(b"\xef\xbb\xbf").strip()


def header_again_note(rows: np.ndarray) -> str | None:
    """What a reader says of the lines that repeat the header, dropped (None: none)."""
    if not len(rows):
        return None
    shown = ", ".join(str(int(r)) for r in rows[:5]) + (
        f" and {len(rows) - 5} more" if len(rows) > 5 else ""
    )
    return (
        f"the header line again in {len(rows)} data row(s) ({shown}): a logger that wrote "
        "its header each time it started, or files joined; those lines dropped, the rows "
        "after them read as the drive's (rows named in messages are still the file's)"
    )


def read_text_column(
    path: Path,
    n_columns: int,
    pos: int,
    display: str,
    blank_rows: np.ndarray = _NO_ROWS,
    nulls: bool = True,
) -> list[str | None]:
    """One column of a CSV file (header row first) as text, one cell per data row.

    For a column that is not numbers (a time written as text: :mod:`rwhonet.data.texttime`).
    Call it after :func:`read_numeric_rows` read the file's other columns: that refuses rows with
    another number of columns, so the rows here are the same.

    Args:
        path: the CSV file.
        n_columns: number of columns of the header.
        pos: the column's 0-based position.
        display: how the file is named in error reports.
        blank_rows: data rows (1-based) read as empty: the header's line again
            (:func:`read_numeric_rows`).
        nulls: whether a cell that says "no value" (``NaN``, ``null``, ``none``) is None;
            False: every cell as written (a word that is a value: GPX's fix ``none``).

    Returns:
        The cells, None for an empty one (with ``nulls``) and the header's line again.

    Raises:
        InputError: the file cannot be read as CSV text.
    """
    names = [f"c{i}" for i in range(n_columns)]
    cells: list[str | None] = []
    skipped, narrow = _head_or_plain(path).skipped, []

    def on_invalid_row(row: pacsv.InvalidRow) -> str:
        # only the header's line again is left to skip (read_numeric_rows refused any other row
        # of another width), where the rows end in a cell it lacks: kept as an empty cell
        narrow.append(-1 if row.number is None else row.number - skipped)
        return "skip"

    try:
        reader = _open_columns(path, names, {pos: names[pos]}, pa.string(), on_invalid_row, nulls)
        for batch in reader:
            cells += batch.column(names[pos]).to_pylist()
        for row in sorted(narrow):
            cells.insert(max(row - 1, 0), None)
    except (pa.ArrowInvalid, OSError) as err:
        message = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise InputError(
            [Problem(display, None, None, "CSV text", f"unreadable: {message[:160]}", EXPORT_CSV)]
        ) from None
    for row in blank_rows:
        if row <= len(cells):
            cells[row - 1] = None
    return cells


def _grown(values: np.ndarray | None, n: int, capacity: int) -> np.ndarray:
    """A column of ``capacity`` rows holding the first ``n`` of ``values``."""
    out = np.empty(capacity)
    if values is not None and n:
        out[:n] = values[:n]
    return out


def _open_columns(
    path: Path,
    names: list[str],
    wanted: Mapping[int, str],
    column_type: pa.DataType,
    on_invalid_row: Callable[[Any], str],
    strings_can_be_null: bool = False,
) -> pacsv.CSVStreamingReader:
    """A block reader of the ``wanted`` columns (as ``column_type``) of a CSV after its header.

    Single-threaded, so pyarrow numbers the rows it hands to ``on_invalid_row`` and the
    blocks come in file order; ``BLOCK_BYTES`` of text per block.
    """
    head = _head_or_plain(path)
    delimiter, tail = head.delimiter, nul_tail(path)
    tail += cut_last_row(path, len(names), head, tail)  # a last row cut short is not read
    # pyarrow's own reader, unless the bytes must be changed or cut; opened here, as pyarrow
    # would take a name ending in .gz or .bz2 for compressed data (rwhonet.data.compressed
    # tells that from the bytes, and hands the readers the text)
    if delimiter != "," or tail:  # a NUL tail (nul_tail) is not read
        end = path.stat().st_size - tail
        source: Any = io.BufferedReader(_Source(path, delimiter, end), BLOCK_BYTES)
    else:
        source = pa.OSFile(str(path))
    return pacsv.open_csv(
        source,
        read_options=pacsv.ReadOptions(
            skip_rows=head.skipped,
            column_names=names,
            use_threads=False,
            block_size=BLOCK_BYTES,
        ),
        parse_options=pacsv.ParseOptions(invalid_row_handler=on_invalid_row),
        convert_options=pacsv.ConvertOptions(
            include_columns=[names[i] for i in wanted],
            column_types={names[i]: column_type for i in wanted},
            null_values=NULL_VALUES,
            strings_can_be_null=strings_can_be_null,
        ),
    )


def _kept_rows(start: int, n: int, bad: np.ndarray) -> np.ndarray:
    """Data rows of the next ``n`` rows pyarrow kept: rows from ``start`` on, not in ``bad``."""
    bad = bad[bad >= start]
    candidates = np.arange(start, start + n + bad.size, dtype=np.int64)
    return candidates[~np.isin(candidates, bad)][:n]


def _parse_block(
    column: pa.Array, blank: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """One block of a column, as bytes -> float64, the positions that are not numbers, and
    them; positions where ``blank`` is set (the header's line again) NaN, never a problem."""
    if blank is not None and blank.any():
        column = pc.if_else(pa.array(blank), pa.scalar(None, column.type), column)
    try:
        return pc.cast(column, pa.float64()).to_numpy(zero_copy_only=False), np.zeros(0, int), []
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        pass
    import pandas as pd  # only here, on a failure path: `rwhonet predict` starts without it

    cells = [None if b is None else b.decode("utf-8", errors="replace") for b in column.to_pylist()]
    text = pd.Series(cells, dtype=object)
    values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=np.float64)
    bad = np.flatnonzero(np.isnan(values) & text.notna().to_numpy())
    return values, bad, [cells[i] for i in bad[:50]]


def cell_names(line: bytes | str) -> list[str]:
    """A header line's column names as a restarted header is compared with them: each
    cell without spaces around it, in lower case."""
    text = line.decode("utf-8", "replace") if isinstance(line, bytes) else line
    return [x.strip().lower() for x in text.strip().removeprefix("\ufeff").split(",")]


def is_header_like(cells: Sequence[str], names: Sequence[str]) -> bool:
    """Whether a row's cells are a header line's (a logger that restarted with another
    configuration): none a number, and at least half of them names of the file's header."""
    cells = [x.strip().lower() for x in cells]
    if not any(cells) or any(is_number(x) for x in cells if x):
        return False
    known = set(names)
    return 2 * sum(x in known for x in cells) >= len(cells)


def _headers_in_another_order(
    parsed: Mapping[int, tuple[np.ndarray, np.ndarray, list[str]]],
    rows: np.ndarray,
    wanted: Mapping[int, str],
    names: Sequence[str],
) -> list[tuple[int, str]]:
    """The rows of a block whose wanted cells are all names of the file's header, not each
    its own column's: the header line again with its columns in another order (or
    renamed), whose rows after it a reader by the first header would put in the wrong
    columns. Returns each such row with its cells, as the row shows them."""
    cells: dict[int, dict[int, str]] = {}
    for pos, (_, bad, found) in parsed.items():
        for r, x in zip(rows[bad].tolist(), found, strict=False):
            cells.setdefault(r, {})[pos] = x
    out = []
    for r, by_pos in cells.items():
        if len(by_pos) < len(wanted):
            continue
        own = all(by_pos[pos].strip().lower() == wanted[pos].strip().lower() for pos in wanted)
        if not own and is_header_like(list(by_pos.values()), names):
            out.append((r, ",".join(by_pos[pos] for pos in sorted(by_pos))))
    return out


def restarted_problem(file: str, row: int, text: str) -> Problem:
    """A header line again with other columns (:func:`is_header_like`)."""
    return Problem(
        file,
        row,
        None,
        "the header's columns, in its order, in every row",
        f"a header line again with other columns or another order: {text[:80]!r} (a "
        "logger that restarted with another configuration, or files of two configurations "
        "joined); the rows after it cannot be read by the first header",
        "split the file at this row, each part under its own header: a stream folder reads "
        "a stream's parts (wheels_1.csv, wheels_2.csv) as one stream; a 10 Hz drive file's "
        "parts are two drives",
    )


def _read_numeric_slow(
    path: Path,
    n_columns: int,
    wanted: Mapping[int, str],
    file: str,
    again: np.ndarray = _NO_ROWS,
) -> dict[int, np.ndarray]:
    """Failure path of :func:`read_numeric_rows`: read as bytes and locate every problem; the
    rows ``again`` (the header's line again: :func:`header_again_rows`) are NaN, none of
    their cells a problem."""
    names = [f"c{i}" for i in range(n_columns)]
    bad_rows: list[int] = []  # data rows with the wrong column count, in file order
    head = _head_or_plain(path)
    rows_tally = RowTally(
        file,
        None,
        columns_expected(n_columns, head.trailing_cell, head.short_rows),
        "give every row the header's columns (a cut-off last row, a stray comma, or a "
        "decimal comma?); delete or repair these rows",
    )

    skipped = head.skipped
    again_set = set(again.tolist())
    skipped_again: list[int] = []
    header_names = cell_names(head.header)
    restarted: list[tuple[int, str]] = []  # a header line again, with other columns

    def on_invalid_row(row: pacsv.InvalidRow) -> str:
        # Single-threaded, pyarrow knows the row number; it counts the header's lines.
        r = -1 if row.number is None else row.number - skipped
        bad_rows.append(r)
        if r in again_set:  # the header's line again, narrower than the rows (a trailing
            skipped_again.append(r)  # cell): a NaN row put back for it at the end
            return "skip"
        if is_header_like(row.text.split(","), header_names):
            restarted.append((r, row.text))
            return "skip"
        rows_tally.add([r], [f"{row.actual_columns} column(s): {row.text[:60]!r}"])
        return "skip"

    cells_tally = {
        pos: RowTally(
            file,
            name,
            "a number",
            "replace the text by a number ('.' as the decimal mark, times in seconds, not "
            "hh:mm:ss), or leave the cell empty for a missing value; a second header row "
            "means two files were joined: split them into one drive each",
        )
        for pos, name in wanted.items()
    }
    chunks: dict[int, list[np.ndarray]] = {pos: [] for pos in wanted}
    next_row = 1
    unreadable: Problem | None = None
    try:
        reader = _open_columns(
            path, names, wanted, pa.binary(), on_invalid_row, strings_can_be_null=True
        )
        for batch in reader:
            rows = _kept_rows(next_row, batch.num_rows, np.asarray(bad_rows, dtype=np.int64))
            if rows.size:
                next_row = int(rows[-1]) + 1
            repeated = np.isin(rows, again) if again_set else None
            parsed = {pos: _parse_block(batch.column(names[pos]), repeated) for pos in wanted}
            moved = _headers_in_another_order(parsed, rows, wanted, header_names)
            restarted += moved
            for pos, (values, bad, found) in parsed.items():
                header = wanted[pos].strip().lower()
                keep = ~np.isin(rows[bad], [r for r, _ in moved])
                cells_tally[pos].add(
                    rows[bad][keep],
                    [
                        repr(x) + (" (the header again)" if x.strip().lower() == header else "")
                        for x, k in zip(found, keep, strict=False)
                        if k
                    ],
                )
                chunks[pos].append(values)
    except (pa.ArrowInvalid, OSError) as err:
        message = str(err).splitlines()[0] if str(err) else type(err).__name__
        # pyarrow numbers the lines it parses, header included ("Row #3: Expected 29 ...").
        at = re.search(r"Row #(\d+)", message)
        unreadable = Problem(
            file,
            int(at.group(1)) - skipped if at else None,
            None,
            f"{n_columns} comma-separated columns of UTF-8 text in every row",
            (
                f"a row that cannot be read: {message[:160]}"
                if at
                else f"text that cannot be read as CSV from about data row {next_row} on: "
                f"{message[:160]}"
            ),
            EXPORT_CSV,
        )
    problems = [restarted_problem(file, r, text) for r, text in sorted(restarted)[:ROWS_LISTED]]
    problems += rows_tally.problems()
    for tally in cells_tally.values():
        problems += tally.problems()
    if unreadable is not None:
        problems.append(unreadable)
    n_total = next_row - 1
    if bad_rows:
        n_total = max(n_total, max(bad_rows))
    if (tail := nul_tail(path)) and bad_rows and max(bad_rows) == n_total:
        problems.append(cut_by_nul_tail(file, n_total, tail))
    if not problems and n_total <= len(again_set):  # none, or the header's line again only
        problems.append(no_data_rows(file))
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) reading {file}")
    # pandas parsed what pyarrow would not (nothing was reported): keep its values.
    out = {pos: np.concatenate(chunks[pos]) if chunks[pos] else np.zeros(0) for pos in wanted}
    if skipped_again:  # row r is element r - 1 again
        at = np.asarray(skipped_again) - 1 - np.arange(len(skipped_again))
        out = {pos: np.insert(values, at, np.nan) for pos, values in out.items()}
    return out
