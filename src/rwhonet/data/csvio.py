"""Fast numeric CSV reading shared by the drive readers.

This module knows column *positions*, never column names: ``iovnbd.py`` and
``columnmap.py`` decide which position holds which quantity. The fast path is
one multithreaded ``pyarrow.csv`` pass converting straight to float64; only
when it fails are the columns re-read as text, single-threaded, so that every
bad cell and every row with the wrong number of columns is reported with its
row number.

Row numbers are 1-based *data* rows: the header is not counted, and neither
are blank lines (pyarrow skips them). For a file without blank lines, data row
``r`` is line ``r + 1`` of the file. Readers keep every data row, in order, so
row ``i`` (0-based) of a canonical drive is data row ``i + 1`` of its file;
``validate`` relies on this to point at the file's rows.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv

from rwhonet.data.problems import row_problems
from rwhonet.errors import InputError, Problem


@dataclass(frozen=True)
class RawDrive:
    """The channels of one drive file, in canonical names and SI units.

    Attributes:
        columns: canonical name -> float64 array; element ``i`` is data row ``i + 1``.
        source_columns: canonical name -> the file's column name it was read from.
        header_match: how the columns were found: ``"name"``, ``"position"`` or ``"column_map"``.
    """

    columns: dict[str, np.ndarray]
    source_columns: dict[str, str]
    header_match: str

    @property
    def n_rows(self) -> int:
        """Number of data rows."""
        return len(next(iter(self.columns.values()))) if self.columns else 0


def read_header(path: Path, display: str | None = None) -> list[str]:
    """Return the header row of a CSV file, cells as written (spaces kept).

    Args:
        path: the CSV file.
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The header cells.

    Raises:
        InputError: the file is empty.
    """
    # utf-8-sig drops a byte-order mark that spreadsheet exports often add in front of the
    # first header name; undecodable bytes are replaced so a bad header still gets reported.
    with open(path, encoding="utf-8-sig", errors="replace", newline="") as f:
        header = next(csv.reader(f), None)
    if not header or all(not cell.strip() for cell in header):
        raise InputError(
            [
                Problem(
                    display or str(path),
                    None,
                    None,
                    "a header row followed by data rows",
                    "an empty file",
                )
            ]
        )
    return header


def read_numeric(
    path: Path, n_columns: int, wanted: Mapping[int, str], display: str | None = None
) -> dict[int, np.ndarray]:
    """Read some columns of a CSV file (header row first) as float64.

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
            cell in a wanted column, or a file without data rows.
    """
    names = [f"c{i}" for i in range(n_columns)]
    include = [names[i] for i in wanted]
    invalid_rows: list[object] = []

    def on_invalid_row(row: object) -> str:
        invalid_rows.append(row)
        return "skip"

    try:
        table = pacsv.read_csv(
            path,
            read_options=pacsv.ReadOptions(skip_rows=1, column_names=names, use_threads=True),
            parse_options=pacsv.ParseOptions(invalid_row_handler=on_invalid_row),
            convert_options=pacsv.ConvertOptions(
                include_columns=include, column_types={n: pa.float64() for n in include}
            ),
        )
    except pa.ArrowInvalid:
        table = None  # a cell that is not a number: find all of them on the slow path
    if table is None or invalid_rows:
        return _read_numeric_slow(path, n_columns, wanted, display)
    if table.num_rows == 0:
        raise InputError(
            [
                Problem(
                    display or str(path),
                    None,
                    None,
                    "at least one data row after the header",
                    "none",
                )
            ]
        )
    return {pos: table.column(names[pos]).to_numpy() for pos in wanted}


def _read_numeric_slow(
    path: Path, n_columns: int, wanted: Mapping[int, str], display: str | None
) -> dict[int, np.ndarray]:
    """Failure path of :func:`read_numeric`: read as text and locate every problem."""
    file = display or str(path)
    names = [f"c{i}" for i in range(n_columns)]
    include = [names[i] for i in wanted]
    bad_rows: list[tuple[int, int, str]] = []  # (data row, columns found, text)

    def on_invalid_row(row: pacsv.InvalidRow) -> str:
        # Single-threaded, pyarrow knows the row number; it counts the header line.
        bad_rows.append((row.number - 1, row.actual_columns, row.text))
        return "skip"

    table = pacsv.read_csv(
        path,
        read_options=pacsv.ReadOptions(skip_rows=1, column_names=names, use_threads=False),
        parse_options=pacsv.ParseOptions(invalid_row_handler=on_invalid_row),
        convert_options=pacsv.ConvertOptions(
            include_columns=include,
            column_types={n: pa.string() for n in include},
            strings_can_be_null=True,
        ),
    )
    problems: list[Problem] = []
    if bad_rows:
        problems += row_problems(
            file,
            None,
            [r for r, _, _ in bad_rows],
            [f"{k} column(s): {text[:60]!r}" for _, k, text in bad_rows],
            f"{n_columns} comma-separated columns, as in the header",
        )
    # Data row of each row pyarrow kept (it dropped the ones with the wrong column count).
    n_total = table.num_rows + len(bad_rows)
    kept_rows = np.setdiff1d(np.arange(1, n_total + 1), [r for r, _, _ in bad_rows])

    out: dict[int, np.ndarray] = {}
    for pos, column_name in wanted.items():
        text = pd.Series(table.column(names[pos]).to_numpy(zero_copy_only=False), dtype=object)
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=np.float64)
        bad = np.flatnonzero(np.isnan(values) & text.notna().to_numpy())
        if bad.size:
            problems += row_problems(
                file, column_name, kept_rows[bad], [repr(s) for s in text.iloc[bad]], "a number"
            )
        out[pos] = values
    if not problems and n_total == 0:
        problems.append(Problem(file, None, None, "at least one data row after the header", "none"))
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) reading {file}")
    # pandas parsed what pyarrow would not (nothing was reported): keep its values.
    return out
