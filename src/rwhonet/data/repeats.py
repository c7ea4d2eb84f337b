"""Rows a logger or an export wrote twice: found, dropped, and the file's row numbers kept.

A 10 Hz drive file (IO-VNBD, a column map) whose row repeats the row before it in every
column the pipeline reads, the time included, holds one sample twice: a logger that
flushed a buffer twice, an export that wrote a block's boundary row again. The copy
carries nothing the first does not, so the readers' callers (:func:`drop_repeated`, in
:func:`rwhonet.data.drivefile.read_any`) drop it and say so in the drive's notes and in
the ingest manifest (``repeated_rows``: the dropped rows, 1-based data rows of the
file). A row at the same time with *any* other value differing is not a copy: validate
still refuses it (``time_not_repeated``), as it refuses a clock going back.

The canonical drive then lacks those rows, so its row ``k`` is no longer data row
``k + 1`` of the file; :class:`FileRows` gives the file's row for every message that
names one (validate's schema and drive checks, ``rwhonet recalibrate``'s).
``rwhonet predict``, which reads a drive in blocks as it arrives, drops them with
:class:`CopyFilter`, which splits a block where it drops a row so that every block it
hands on is still rows ``first_row ..`` of the file, one after the other.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import replace
from typing import Any, overload

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive

# Dropped rows a note lists one by one (the manifest lists them all).
ROWS_NOTED = 5
# The key under which a stream of rows (``rwhonet predict``'s) carries each row's data row
# in the file with the rows: consecutive within a block, not across blocks once a copy
# was dropped.
FILE_ROW = "file_row"


def repeated_rows(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """The rows that repeat the row before them in every column (NaN equal to NaN).

    Args:
        columns: a drive's channels, one array per column, one element per row.

    Returns:
        0-based rows ``i >= 1`` whose every value equals row ``i - 1``'s, increasing.
    """
    arrays = [np.asarray(v) for v in columns.values()]
    if not arrays or arrays[0].size < 2:
        return np.zeros(0, dtype=np.int64)
    # the time first: almost every row differs from the one before there, and only the
    # rows that do not are compared further
    order = sorted(range(len(arrays)), key=lambda j: list(columns)[j] != c.T_S)
    same = np.ones(arrays[0].size - 1, dtype=bool)
    for j in order:
        a = arrays[j]
        rows = np.flatnonzero(same)
        if rows.size == 0:
            break
        now, before = a[rows + 1], a[rows]
        equal = now == before
        if a.dtype.kind == "f":
            equal |= np.isnan(now) & np.isnan(before)
        same[rows] = equal
    return np.flatnonzero(same) + 1


def drop_repeated(raw: RawDrive) -> RawDrive:
    """A drive read from a 10 Hz file without the rows that repeat the row before them.

    Args:
        raw: the drive as its reader read it (row ``i`` is data row ``i + 1`` of the file).

    Returns:
        ``raw`` itself when no row repeats; else a copy without them, whose
        ``repeated_rows`` lists them (1-based data rows of the file) and whose notes say so.
    """
    rows = repeated_rows(raw.columns)
    if rows.size == 0:
        return raw
    keep = np.ones(raw.n_rows, dtype=bool)
    keep[rows] = False
    return replace(
        raw,
        columns={name: values[keep] for name, values in raw.columns.items()},
        notes=(*raw.notes, dropped_note(rows + 1)),
        repeated_rows=rows + 1,
    )


def dropped_note(rows: Sequence[int] | np.ndarray) -> str:
    """What a reader says of the rows it dropped (the file's data rows, 1-based)."""
    shown = ", ".join(str(int(r)) for r in rows[:ROWS_NOTED])
    more = f" and {len(rows) - ROWS_NOTED} more" if len(rows) > ROWS_NOTED else ""
    return (
        f"{len(rows)} data row(s) repeat the row before them in every column read, the time "
        f"included (row(s) {shown}{more}): a sample written twice, dropped; rows named in "
        "messages are still the file's"
    )


class FileRows:
    """The file's data row of each row of a canonical drive that lost repeated rows.

    Args:
        dropped: the rows dropped (1-based data rows of the file, increasing); empty: row
            ``k`` is data row ``k + 1``.
    """

    def __init__(self, dropped: Sequence[int] | np.ndarray = ()) -> None:
        d = np.asarray(dropped, dtype=np.int64)
        # canonical row k is data row k + 1 + (the drops at or before it): drop j, the
        # (j+1)-th, sits after d[j] - 1 - j kept rows
        self._after = d - 1 - np.arange(d.size)

    @classmethod
    def of(cls, entry: Mapping[str, Any]) -> FileRows:
        """The numbering of a drive as the ingest manifest lists it (``repeated_rows``)."""
        return cls(entry.get("repeated_rows") or ())

    @property
    def identity(self) -> bool:
        """Whether no row was dropped (canonical row ``k`` is data row ``k + 1``)."""
        return self._after.size == 0

    @overload
    def __call__(self, k: int | np.integer) -> int: ...

    @overload
    def __call__(self, k: np.ndarray) -> np.ndarray: ...

    def __call__(self, k):
        """The 1-based data row of the file of canonical row(s) ``k`` (0-based)."""
        if isinstance(k, int | np.integer):
            return int(k) + 1 + int(np.searchsorted(self._after, int(k), side="right"))
        k = np.asarray(k, dtype=np.int64)
        return k + 1 + np.searchsorted(self._after, k, side="right")


class CopyFilter:
    """Drop the rows that repeat the row before them from blocks of rows as they arrive.

    The rows of ``rwhonet predict``'s drive come in blocks ``(first_row, columns)``: data
    rows ``first_row ..`` of the file. A block that holds copies is handed on split around
    them, so each block handed on is still consecutive rows of the file and every
    message downstream names the file's row; a copy of the previous block's last row is
    found too. ``dropped`` lists the rows dropped (the file's, 1-based).
    """

    def __init__(self) -> None:
        self.dropped: list[int] = []
        self._last: dict[str, np.ndarray] | None = None  # the last row handed in

    def blocks(
        self, blocks: Iterable[tuple[int, dict[str, np.ndarray]]]
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """The blocks without their copies (a block of copies only is left out)."""
        for first, columns in blocks:
            n = len(columns[c.T_S])
            if n == 0:
                yield first, columns
                continue
            last, self._last = self._last, {k: np.asarray(v)[-1:] for k, v in columns.items()}
            t = np.asarray(columns[c.T_S])
            if not (t[1:] == t[:-1]).any() and (last is None or last[c.T_S][0] != t[0]):
                yield first, columns  # no two rows at one time: no copy (almost every block)
                continue
            if last is not None and last.keys() == columns.keys():
                copies = repeated_rows({k: np.r_[last[k], columns[k]] for k in columns}) - 1
            else:
                copies = repeated_rows(columns)
            if copies.size == 0:
                yield first, columns
                continue
            self.dropped += [first + int(i) for i in copies]
            bounds = np.r_[-1, copies, n]
            for a, b in zip(bounds[:-1] + 1, bounds[1:], strict=True):
                if b > a:
                    yield first + int(a), {k: v[a:b] for k, v in columns.items()}

    def note(self, file: str) -> str | None:
        """What was dropped, for stderr (None: nothing)."""
        return f"{file}: {dropped_note(self.dropped)}" if self.dropped else None
