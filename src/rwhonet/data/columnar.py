"""Drive files kept as columnar tables: Apache Parquet and Arrow IPC (Feather), told by their
first bytes, read as the CSV table they hold.

A fleet's drives are often kept in a data lake as Parquet (one file per drive or per
stream, written by Spark, pandas, Polars or DuckDB), or handed on as Feather (Arrow's IPC
file). Such a file has named, typed columns: everything a column map or a signal map names
is there as it is in a CSV. The 10 Hz readers (IO-VNBD, column maps), ``rwhonet predict``
and the stream-CSV reader read one through a scratch CSV of its table (:func:`csv_copy`),
as they read a compressed file through the text it holds (:mod:`rwhonet.data.compressed`),
so every reader's rules, notes and refusals apply unchanged. Row ``i`` of the table
(counted from 1) is data row ``i`` of that CSV, so a message names the table's own row.

**The cells** (the table's types, Apache Arrow's):

- numbers (integers, floating point, decimals) as numbers, every double as the shortest
  text that reads back to it (Arrow's CSV writer), so a value is read unchanged; a null is
  an empty cell (no value), a NaN ``nan`` (no value too);
- a **timestamp** as ISO 8601 text, ``2019-03-11 14:22:05.123000Z`` where the column has a
  zone (its instants on UTC: Arrow keeps them so; the zone only says how to show them),
  without ``Z`` where it has none (the time as written): a map's ``t`` in unit ``iso8601``
  reads either (:mod:`rwhonet.data.texttime`); a **date** as ``2019-03-11`` (a map's
  ``date`` in unit ``%Y-%m-%d``), a **time of day** as ``14:22:05.123000`` (``hh:mm:ss``),
  a **duration** as seconds (``s``);
- a **boolean** as ``true`` or ``false`` (a fix flag: the fix status unit ``bool``); a
  **dictionary-encoded** column (pandas' and Polars' categories) as its values; text as
  text (Polars' ``string_view`` too);
- a **struct**'s fields as columns of their own, named ``parent.field`` (a map names them
  so, or without the dot: columns are found without regard to punctuation);
- a column no CSV cell holds (a list, a map, binary data: a camera frame, a point cloud)
  is left out, and the notes name it.

**A folder of part files** (Spark's ``C-B1.parquet/part-00000-...snappy.parquet``, Dask's
``part.0.parquet``) is one table: its Parquet files in natural order of their names, the
writers' bookkeeping (``_SUCCESS``, ``_metadata``, ``.crc``: a leading ``_`` or ``.``) left
out, each part holding the first's columns (:func:`table_parts`): a 10 Hz drive, or a stream
folder's stream (``C-B1/wheels.parquet/``).

**Bounded** as a compressed file's text is: the CSV written may be at most
``data.max_file_mb`` MB (the file itself is too); the table is read and written a
record batch at a time, so memory holds one batch beside the scratch file.

**Refused**, naming the file: a file that is not whole (cut off, corrupted: its footer or a
page cannot be read; the notes say Arrow's own words), one of no columns, and a CSV past
the bound.
"""

from __future__ import annotations

import io
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pcsv

from rwhonet.data.compressed import copy_bounded, without_suffix
from rwhonet.errors import InputError, Problem

PARQUET, FEATHER = "Parquet", "Arrow IPC (Feather)"
# (first bytes, kind): Parquet's "PAR1" (it ends with it too), Arrow's IPC file "ARROW1"
# (Feather version 2 is that file; version 1, deprecated since 2020, is not read)
MAGIC: tuple[tuple[bytes, str], ...] = ((b"PAR1", PARQUET), (b"ARROW1", FEATHER))
# the names a stream folder's table files have (a file is told by its bytes; a folder's
# files are chosen by name, as its CSVs are)
TABLE_SUFFIXES = (".parquet", ".pq", ".feather", ".arrow", ".ipc")
BATCH_ROWS = 1 << 16  # rows read and written per step
COPY_BYTES = 1 << 20  # CSV text copied per step
_DURATION_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def table_kind(path: Path) -> str | None:
    """The kind of table a file's first bytes show (:data:`PARQUET`, :data:`FEATHER`), or
    :data:`PARQUET` for a folder of Parquet part files (:func:`table_parts`); None: neither,
    or the file cannot be read: its reader says why."""
    if path.is_dir():
        return PARQUET if table_parts(path) else None
    try:
        head = _head(path, 6)
    except OSError:
        return None
    return next((kind for magic, kind in MAGIC if head.startswith(magic)), None)


def table_parts(folder: Path) -> list[Path]:
    """A folder's Parquet part files, in their write's order: the files whose first bytes
    are Parquet's, those named as Hadoop's and Spark's bookkeeping (``_SUCCESS``,
    ``_metadata``, ``.part-00000.crc``: a leading ``_`` or ``.``) left out, in natural order
    of their names (Spark's ``part-00000-<uuid>.snappy.parquet``, Dask's and Arrow's
    ``part.0.parquet`` ... ``part.10.parquet``, ``part-0.parquet``). Empty where the folder
    has none (or cannot be listed)."""
    try:
        files = [p for p in folder.iterdir() if p.is_file() and p.name[:1] not in ("_", ".")]
    except OSError:
        return []
    parts = []
    for p in files:
        try:
            if _head(p, 4) == b"PAR1":
                parts.append(p)
        except OSError:
            continue
    return sorted(parts, key=lambda p: _natural(p.name))


def is_table_folder(path: Path) -> bool:
    """Whether ``path`` is a folder of Parquet part files: one table (a drive Spark, Dask or
    Arrow's dataset writer wrote as a folder)."""
    return path.is_dir() and bool(table_parts(path))


def folder_id(folder: Path) -> str:
    """A folder drive's id: its name, without a table's suffix where it is a table's
    (Spark's ``C-B1.parquet/`` is drive ``C-B1``, as the file ``C-B1.parquet`` is); a
    partition's folder of a table written partitioned by a column, ``key=value`` (Spark's
    ``partitionBy``, pandas' ``partition_cols``: ``drive_id=C-B1/``), is drive ``value``,
    as written (Hive's escapes, ``%2F`` for ``/``, kept: an id names output files)."""
    name = folder.name
    key, eq, value = name.partition("=")
    if eq and key and value and is_table_folder(folder):
        return value
    for suffix in TABLE_SUFFIXES:
        if name.lower().endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


def _natural(name: str) -> list:
    """A name's natural sort key: its runs of digits as numbers (``part.2`` before
    ``part.10``)."""
    return [(0, int(x), "") if x.isdigit() else (1, 0, x) for x in re.split(r"(\d+)", name) if x]


def is_table_name(name: str) -> bool:
    """Whether a file's name is a table file's (``wheels.parquet``, ``gps.feather``, kept
    compressed too: ``wheels.parquet.gz``): a stream of a folder drive, as a CSV is."""
    return without_suffix(name).lower().endswith(TABLE_SUFFIXES)


@dataclass(frozen=True)
class TableRead:
    """What a table file held, for the notes: its kind, rows and the columns left out."""

    kind: str
    rows: int
    left_out: tuple[str, ...]
    parts: int = 0  # a folder's part files (0: one file)

    @property
    def brief(self) -> str:
        """``Parquet, 6,000 rows; frame left out`` (a stream folder's note, per file; ``Parquet,
        3 part file(s), 6,000 rows`` for a folder of part files)."""
        parts = f"{self.parts} part file(s), " if self.parts else ""
        said = f"{self.kind}, {parts}{self.rows:,} rows"
        return said + (f"; {', '.join(self.left_out)} left out" if self.left_out else "")

    @property
    def note(self) -> str:
        """The note of a drive read from a table file."""
        what = (
            f"a folder of {self.parts} {self.kind} part file(s), read in their names' order"
            if self.parts
            else f"a table file ({self.kind})"
        )
        said = f"{what}, read as CSV: {self.rows:,} rows"
        if self.left_out:
            said += f"; column(s) no CSV cell holds left out: {', '.join(self.left_out)}"
        return said


def open_as_csv(path: Path, kind: str, file: str) -> tuple[BinaryIO, TableRead]:
    """A table file's rows as the text of a CSV with a header, made a record batch at a
    time as it is read, and what it held (the kind, the rows, any columns left out).

    Raises:
        InputError: naming ``file``: the table's footer or schema cannot be read, or it has
            no column a CSV cell holds; met while reading, a record batch that cannot be.
    """
    left_out: list[str] = []
    parts = table_parts(path) if path.is_dir() else [path]
    if not parts:  # a folder emptied since it was told a table's
        raise InputError([_no_columns(file, kind, left_out)])
    named = {part: file if part == path else f"{file}/{part.name}" for part in parts}
    rows = 0
    for i, part in enumerate(parts):
        try:
            n, schema = _shape(part, kind)
            if i == 0:
                first = schema
                header = _as_cells(schema.empty_table(), left_out)  # a name damaged: not UTF-8
        except (pa.ArrowException, OSError, ValueError) as err:
            raise InputError([broken(named[part], kind, err)]) from None
        if not schema.equals(first):  # pandas' metadata per part aside
            raise InputError([_other_schema(named[part], parts[0].name, schema, first)])
        rows += n
    if header.num_columns == 0:
        raise InputError([_no_columns(file, kind, left_out)])
    text = _Text(_parts_batches(parts, kind, named), header, kind)
    held = TableRead(kind, rows, tuple(left_out), len(parts) if path.is_dir() else 0)
    return io.BufferedReader(text, COPY_BYTES), held


def csv_copy(path: Path, kind: str, dest: Path, max_mb: float | None, file: str) -> TableRead:
    """Write a table file's rows to ``dest`` as a CSV with a header (:func:`open_as_csv`),
    at most ``max_mb`` MB of it (``data.max_file_mb``, which bounds a drive's text as it
    bounds a plain file's); returns what it held.

    Raises:
        InputError: naming ``file``: as :func:`open_as_csv`, or the CSV runs past
            ``max_mb``.
    """
    source, held = open_as_csv(path, kind, file)
    limit = math.inf if max_mb is None else max_mb * 2**20
    with source:
        copy_bounded(source, dest, limit, lambda: _too_large(file, kind, max_mb))
    return held


class _Text(io.RawIOBase):
    """The CSV text of a table's record batches: the header, then each batch's rows as it
    is read; a batch that cannot be read is the user's input problem, not a crash."""

    def __init__(
        self, batches: Iterator[tuple[pa.RecordBatch, str]], header: pa.Table, kind: str
    ) -> None:
        super().__init__()
        self._batches, self._kind, self._file = batches, kind, ""
        self._pending = _csv(header, True)
        self._at = 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        while self._at == len(self._pending):
            try:
                got = next(self._batches, None)
                if got is None:
                    return 0
                batch, self._file = got
                cells = _as_cells(batch, [])
            except (pa.ArrowException, OSError, ValueError) as err:
                raise InputError([broken(self._file, self._kind, err)]) from None
            self._pending, self._at = _csv(cells, False), 0
        n = min(len(buffer), len(self._pending) - self._at)
        buffer[:n] = self._pending[self._at : self._at + n]
        self._at += n
        return n

    def close(self) -> None:
        close = getattr(self._batches, "close", None)
        if close is not None:
            close()  # the generator's file
        super().close()


def _csv(cells: pa.Table, header: bool) -> bytes:
    """A table's rows (and its header) as CSV text."""
    out = io.BytesIO()
    pcsv.write_csv(cells, out, pcsv.WriteOptions(include_header=header))
    return out.getvalue()


def _shape(path: Path, kind: str) -> tuple[int, pa.Schema]:
    """A table file's rows and schema, from its footer."""
    if kind == PARQUET:
        import pyarrow.parquet as pq

        with pq.ParquetFile(path) as table:
            return table.metadata.num_rows, table.schema_arrow
    with pa.memory_map(str(path)) as source:
        reader = pa.ipc.open_file(source)
        rows = sum(reader.get_batch(i).num_rows for i in range(reader.num_record_batches))
        return rows, reader.schema


def _batches(path: Path, kind: str) -> Iterator[pa.RecordBatch]:
    """The table's record batches, at most :data:`BATCH_ROWS` rows each."""
    if kind == PARQUET:
        import pyarrow.parquet as pq

        with pq.ParquetFile(path) as table:
            yield from table.iter_batches(batch_size=BATCH_ROWS)
        return
    with pa.memory_map(str(path)) as source:
        reader = pa.ipc.open_file(source)
        for i in range(reader.num_record_batches):
            yield from pa.Table.from_batches([reader.get_batch(i)]).to_batches(BATCH_ROWS)


def _parts_batches(
    parts: list[Path], kind: str, shown: dict[Path, str]
) -> Iterator[tuple[pa.RecordBatch, str]]:
    """Each part's record batches in turn, each with how messages name its part; a part
    that cannot be read to its end refused, named."""
    for part in parts:
        batches = _batches(part, kind)
        while True:
            try:
                batch = next(batches, None)
            except (pa.ArrowException, OSError, ValueError) as err:
                raise InputError([broken(shown[part], kind, err)]) from None
            if batch is None:
                break
            yield batch, shown[part]


def _head(path: Path, size: int) -> bytes:
    with open(path, "rb") as f:
        return f.read(size)


def _as_cells(batch: pa.RecordBatch | pa.Table, left_out: list[str]) -> pa.Table:
    """A batch whose every column a CSV cell holds as the readers read it (the module's
    list), the columns none can hold named in ``left_out``."""
    table = pa.Table.from_batches([batch]) if isinstance(batch, pa.RecordBatch) else batch
    while any(pa.types.is_struct(t) for t in table.schema.types):
        table = table.flatten()  # parent.field
    names, arrays = [], []
    for name, column in zip(table.column_names, table.columns, strict=True):
        cells = _cells(column.combine_chunks())
        if cells is None:
            left_out.append(name)
            continue
        names.append(name)
        arrays.append(cells)
    return pa.table(arrays, names=names)


def _cells(array: pa.Array) -> pa.Array | None:
    """One column as CSV cells the readers read (None: none holds it)."""
    kind = array.type
    if pa.types.is_dictionary(kind):  # its values' own rules, then each row's value
        values = _cells(array.dictionary)
        return None if values is None else _cells(pc.take(values, array.indices))
    if pa.types.is_string_view(kind):  # Polars' text in an IPC file
        return pc.cast(array, pa.string())
    if pa.types.is_duration(kind):
        seconds = pc.cast(pc.cast(array, pa.int64()), pa.float64())
        return pc.multiply(seconds, _DURATION_S[kind.unit])
    if pa.types.is_timestamp(kind) and kind.tz is not None:
        return pc.cast(array, pa.timestamp(kind.unit, "UTC"))  # written with Z
    if (
        pa.types.is_integer(kind)
        or pa.types.is_floating(kind)  # half floats too
        or pa.types.is_decimal(kind)
        or pa.types.is_timestamp(kind)
        or pa.types.is_date(kind)
        or pa.types.is_time(kind)
        or pa.types.is_string(kind)
        or pa.types.is_large_string(kind)
        or pa.types.is_boolean(kind)  # true, false: the fix status unit bool
        or pa.types.is_null(kind)
    ):
        return array
    return None  # lists, maps, binary, unions


def broken(file: str, kind: str, err: BaseException) -> Problem:
    """The problem of a table file that cannot be read to its end."""
    return Problem(
        file,
        None,
        None,
        f"a whole {kind} file",
        f"{type(err).__name__}: {str(err)[:160] or 'cut off'}",
        "copy the file again (it is cut off or corrupted), or write the table again",
    )


def _other_schema(file: str, first: str, schema: pa.Schema, want: pa.Schema) -> Problem:
    """A part file whose columns are not the first part's."""
    names, wanted = schema.names, want.names
    if names != wanted:
        found = f"columns {', '.join(names[:8])}" + (" ..." if len(names) > 8 else "")
    else:
        kinds = [
            f"{n}: {a} (not {b})"
            for n, a, b in zip(names, schema.types, want.types, strict=True)
            if a != b
        ]
        found = "column types " + "; ".join(kinds[:4])
    return Problem(
        file,
        None,
        None,
        f"the columns of the folder's first part file, {first}",
        found,
        "give the folder the part files of one write of one drive",
    )


def _no_columns(file: str, kind: str, left_out: list[str]) -> Problem:
    found = f"only columns no CSV cell holds: {', '.join(left_out)}" if left_out else "no column"
    return Problem(
        file,
        None,
        None,
        f"a table file ({kind}) with the drive's columns (numbers, text, times)",
        found,
        "write the drive's channels as columns of their own",
    )


def _too_large(file: str, kind: str, max_mb: float | None) -> Problem:
    return Problem(
        file,
        None,
        None,
        f"a drive of at most {max_mb:g} MB as CSV text (data.max_file_mb)",
        f"more than that in this {kind} table",
        "split the drive into several files (one per trip), or raise data.max_file_mb on a "
        "machine with the memory",
    )
