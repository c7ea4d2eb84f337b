"""Rows a 10 Hz reader's callers drop: samples written twice, and samples without a wheel speed.

Two ordinary logger habits leave rows in a 10 Hz drive file (IO-VNBD, a column map) that
hold no usable sample, and the readers' callers (:func:`drop_rows`, in
:func:`rwhonet.data.drivefile.read_any`) drop both and say so in the drive's notes and in
the ingest manifest (the dropped rows, 1-based data rows of the file):

- ``repeated_rows``: a row that repeats an earlier row in every column the pipeline
  reads, the time included: the row before it (a logger that flushed a buffer twice, an
  export that wrote a block's boundary row again) or one further back (a block written
  again after a retry, two joined exports that overlap). The copy carries nothing the
  first does not. A row at an earlier row's time with *any* other value differing is not
  a copy: validate still refuses it (``time_not_repeated``, ``time_not_backwards``).
- ``wheelless_rows``: a row whose time is there but one of its four wheel speeds is empty
  (a CAN frame the logger missed, a logger that starts writing before the first wheel
  frame arrives). The sample is lost as a dropped row is lost: its slot of the 0.1 s grid
  is left empty, so validate cuts its second (``partial_second``) and splits the drive
  there, and ``rwhonet predict`` ends its run of seconds there, exactly as for a row the
  logger never wrote. Its fix goes with it: a second without the wheels' travel has no
  label. A wheel channel with no value in any row, and a file whose rows lack a wheel
  speed in a third of them or more (a channel at its own rate), are refused
  (:func:`drop_rows`).

A third kind is left out by the readers themselves: ``header_rows``, the header's line
again among the rows (:func:`rwhonet.data.csvio.header_again_rows`: a logger that wrote its
header each time it started, files of one drive joined); a fourth before the copies are
told: ``untimed_rows``, the rows of a second whose stamp, coarser than the rows, holds fewer
of them than a second has, so that which sample was lost the stamps cannot tell
(:func:`rwhonet.data.sampleorder.coarse_stamps_placed`); :func:`drop_rows` numbers the rows
it drops through both.

The canonical drive then lacks those rows, so its row ``k`` is no longer data row
``k + 1`` of the file; :class:`FileRows` gives the file's row for every message that
names one (validate's schema and drive checks, ``rwhonet recalibrate``'s).
``rwhonet predict``, which reads a drive in blocks as it arrives, drops them with
:class:`RowFilter`, which splits a block where it drops a row so that every block it
hands on is still rows ``first_row ..`` of the file, one after the other.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import replace
from typing import Any, overload

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.errors import InputError, Problem

# Dropped rows a note lists one by one (the manifest lists them all).
ROWS_NOTED = 5
# A drive that lacks a wheel speed in this share of its rows or more is refused rather
# than thinned. Dropping a share f of the rows, one here and one there, leaves f / (1 - f)
# of the kept steps skipping a slot: from f = 1/3 on, half of them or more, and validate
# would take the median step for the drive's sample rate (0.2 s: "5 Hz, not 10 Hz"). Such
# rows are not lost samples but a layout: wheel speeds written at their own rate.
WHEELLESS_MAX_SHARE = 1 / 3
# The kinds of rows a drive read from a 10 Hz file may lose, as the ingest manifest and
# reports/validation.json name them: copies, rows without a wheel speed, the header's line
# again (csvio.header_again_rows, left out by the reader), rows whose stamps to the second
# cannot tell their times (sampleorder.coarse_stamps_placed).
ROW_KINDS = ("repeated_rows", "wheelless_rows", "header_rows", "untimed_rows")
# The ingest manifest's key for a drive whose rows were put in time order
# (:func:`rwhonet.data.sampleorder.rows_in_time_order`): the file's data row of each row.
ROW_ORDER = "row_order"
# The key under which a stream of rows (``rwhonet predict``'s) carries each row's data row
# in the file with the rows: consecutive within a block, not across blocks once a copy
# was dropped.
FILE_ROW = "file_row"


def repeated_rows(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """The rows that repeat an earlier row in every column (NaN equal to NaN).

    A copy of the row just before (a sample written twice), of a block some rows back (a
    logger that wrote a buffer again after a retry), or of the rows two joined exports
    both hold (the second starting before the first ended): each repeats an earlier row,
    its time included.

    Args:
        columns: a drive's channels, one array per column, one element per row.

    Returns:
        0-based rows ``i >= 1`` whose every value equals some row ``j < i``'s, increasing.
    """
    arrays = [np.asarray(v) for v in columns.values()]
    if not arrays or arrays[0].size < 2:
        return np.zeros(0, dtype=np.int64)
    t = np.asarray(columns[c.T_S]) if c.T_S in columns else None
    if t is not None and t.dtype.kind == "f":
        with np.errstate(invalid="ignore"):
            if (t[1:] > t[:-1]).all():  # every row later than every one before it
                return np.zeros(0, dtype=np.int64)
    keys = row_keys(columns)
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return np.flatnonzero(first[inverse.ravel()] < np.arange(keys.size))


def row_keys(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """Each row's values as one opaque key: equal keys, equal rows (NaN equal to NaN, 0.0
    to -0.0), in the order of ``columns``' keys."""
    arrays = [np.asarray(v, dtype=np.float64) for v in columns.values()]
    table = np.column_stack(arrays) + 0.0  # -0.0 + 0.0 is 0.0
    table[np.isnan(table)] = np.nan  # one NaN, whatever its payload
    table = np.ascontiguousarray(table)
    return table.view(np.dtype((np.void, table.dtype.itemsize * table.shape[1]))).ravel()


def wheelless_rows(columns: Mapping[str, np.ndarray]) -> np.ndarray:
    """The rows with one wheel speed or more empty (NaN), 0-based, increasing."""
    wheels = [np.asarray(columns[w]) for w in c.WHEELS if w in columns]
    if not wheels:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(np.any([np.isnan(w) for w in wheels], axis=0))


def drop_rows(raw: RawDrive, file: str) -> RawDrive:
    """A drive read from a 10 Hz file without its copies and its rows without a wheel speed.

    Both are found among the file's rows as written: a copy repeats the file's row before
    it. A copy of a row without a wheel speed is listed with the rows without one.

    Args:
        raw: the drive as its reader read it (row ``i`` is data row ``i + 1`` of the file).
        file: the file as the user knows it, for a refusal.

    Returns:
        ``raw`` itself when no row is dropped; else a copy without them, whose
        ``repeated_rows`` and ``wheelless_rows`` list them (1-based data rows of the file)
        and whose notes say so.

    Raises:
        InputError: a wheel speed column has no value in any row (a column map naming the
            wrong column, a channel the logger never had), or :data:`WHEELLESS_MAX_SHARE`
            (a third) of the rows or more lack a wheel speed (wheel speeds written at their
            own rate).
    """
    # the reader left out the header's lines again; coarse stamps, rows without a time
    file_row = FileRows(np.union1d(raw.header_rows, raw.untimed_rows))
    n_file_rows = raw.n_rows + len(raw.header_rows) + len(raw.untimed_rows)
    wheelless = wheelless_rows(raw.columns)
    if wheelless.size:
        empty = [w for w in c.WHEELS if w in raw.columns and np.isnan(raw.columns[w]).all()]
        problems = wheelless_problems(
            file, n_file_rows, file_row(wheelless), empty, raw.source_columns
        )
        if problems:
            raise InputError(problems)
    copies = np.setdiff1d(repeated_rows(raw.columns), wheelless)
    if copies.size == 0 and wheelless.size == 0:
        return raw
    keep = np.ones(raw.n_rows, dtype=bool)
    keep[copies] = False
    keep[wheelless] = False
    notes = [dropped_note(file_row(copies))] if copies.size else []
    if wheelless.size:
        notes.append(wheelless_note(file_row(wheelless), n_file_rows))
    return replace(
        raw,
        columns={name: values[keep] for name, values in raw.columns.items()},
        notes=(*raw.notes, *notes),
        repeated_rows=file_row(copies),
        wheelless_rows=file_row(wheelless),
    )


def wheelless_problems(
    file: str,
    n_rows: int,
    rows: Sequence[int] | np.ndarray,
    empty: Sequence[str],
    names: Mapping[str, str],
) -> list[Problem]:
    """Why a drive's rows without a wheel speed are not lost samples (none: they are).

    Args:
        file: the file as the user knows it.
        n_rows: the file's data rows.
        rows: the data rows (1-based) without a wheel speed, increasing.
        empty: the wheel channels (canonical names) with no value in any row.
        names: canonical name -> the file's column name.

    Returns:
        A problem per wheel column with no value in any row; else one problem when
        :data:`WHEELLESS_MAX_SHARE` of the rows or more lack a wheel speed; else none.
    """
    if not n_rows or len(rows) < WHEELLESS_MAX_SHARE * n_rows:
        return []
    return [
        Problem(
            file,
            None,
            names.get(w, w),
            "a wheel speed in the rows (a row without one is dropped as a lost sample)",
            f"no value in any of the {n_rows} data rows",
            "check that the column holds this wheel's speed (a column map naming another "
            "column, a channel the logger did not record)",
        )
        for w in empty
    ] or [
        Problem(
            file,
            int(rows[0]),
            None,
            "the four wheel speeds in most rows (a row without one is dropped as a lost sample)",
            f"{len(rows)} of the {n_rows} data rows ({100 * len(rows) / n_rows:.3g} %) without "
            f"all four, the first {_listed(rows[:ROWS_NOTED])}",
            "the wheel speeds are written in other rows than the rest (a CAN channel at its "
            "own rate in a 10 Hz file): give each stream with its own times as stream CSVs "
            "(format stream_csv), or fill the wheel speeds onto the 10 Hz rows before "
            "writing the file",
        )
    ]


def manifest_rows(raw: RawDrive) -> dict[str, Any]:
    """The rows a drive lost, as the ingest manifest lists them (only the kinds it lost):
    ``repeated_rows``, ``wheelless_rows``, ``header_rows`` (the header's line again) and
    ``untimed_rows`` (stamps to the second that cannot tell them), the file's data rows,
    every one; and ``held_fix_period_rows`` where its fixes were held
    (:mod:`rwhonet.data.heldfixes`)."""
    lists = {
        "repeated_rows": raw.repeated_rows,
        "wheelless_rows": raw.wheelless_rows,
        "header_rows": raw.header_rows,
        "untimed_rows": raw.untimed_rows,
    }
    out: dict[str, Any] = {key: [int(r) for r in rows] for key, rows in lists.items() if rows.size}
    if raw.held_fix_period_rows:  # fixes held from a slower receiver, placed (heldfixes)
        out["held_fix_period_rows"] = raw.held_fix_period_rows
    if raw.row_order is not None:  # rows put in time order: each row's file row
        out[ROW_ORDER] = [int(r) for r in raw.row_order]
    return out


def report_rows(entry: Mapping[str, Any], listed: int = 50) -> dict[str, Any]:
    """The rows a drive lost, as ``reports/validation.json`` gives them per drive: for each
    kind, the count and the first ``listed`` rows."""
    out: dict[str, Any] = {
        key: {"rows": len(entry[key]), "listed": list(entry[key][:listed])}
        for key in ROW_KINDS
        if entry.get(key)
    }
    if entry.get("held_fix_period_rows"):
        out["held_fix_period_rows"] = entry["held_fix_period_rows"]
    return out


def _listed(rows: Sequence[int] | np.ndarray) -> str:
    shown = ", ".join(str(int(r)) for r in rows[:ROWS_NOTED])
    more = f" and {len(rows) - ROWS_NOTED} more" if len(rows) > ROWS_NOTED else ""
    return f"row(s) {shown}{more}"


def dropped_note(rows: Sequence[int] | np.ndarray) -> str:
    """What a reader says of the copies it dropped (the file's data rows, 1-based)."""
    return (
        f"{len(rows)} data row(s) repeat an earlier row in every column read, the time "
        f"included ({_listed(rows)}): samples written again, dropped; rows named in "
        "messages are still the file's"
    )


def wheelless_note(rows: Sequence[int] | np.ndarray, n_rows: int | None = None) -> str:
    """What a reader says of the rows without a wheel speed it dropped (1-based data rows);
    ``n_rows``: the file's data rows, for the share (None: a stream, not said)."""
    share = f" of {n_rows} ({100 * len(rows) / n_rows:.2g} %)" if n_rows else ""
    return (
        f"{len(rows)}{share} data row(s) have an empty wheel speed ({_listed(rows)}): each "
        "is dropped as a lost sample, and the second it leaves short is cut "
        "(partial_second) and ends a stretch; rows named in messages are still the file's"
    )


class FileRows:
    """The file's data row of each row of a canonical drive that lost rows (:func:`drop_rows`).

    Args:
        dropped: the rows dropped (1-based data rows of the file, increasing); empty: row
            ``k`` is data row ``k + 1``.
    """

    def __init__(
        self,
        dropped: Sequence[int] | np.ndarray = (),
        headers: Sequence[int] | np.ndarray = (),
        order: Sequence[int] | np.ndarray | None = None,
    ) -> None:
        d = np.asarray(dropped, dtype=np.int64)
        # canonical row k is data row k + 1 + (the drops at or before it): drop j, the
        # (j+1)-th, sits after d[j] - 1 - j kept rows
        self._after = d - 1 - np.arange(d.size)
        self.headers = np.asarray(headers, dtype=np.int64)  # of them, the header's line again
        # rows put in time order: each canonical row's file row, given
        self._order = None if order is None else np.asarray(order, dtype=np.int64)

    @classmethod
    def of(cls, entry: Mapping[str, Any]) -> FileRows:
        """The numbering of a drive as the ingest manifest lists it (:data:`ROW_KINDS`, and
        :data:`ROW_ORDER` where its rows were put in time order)."""
        dropped = sorted(r for key in ROW_KINDS for r in entry.get(key) or ())
        return cls(dropped, entry.get("header_rows") or (), entry.get(ROW_ORDER))

    def header_between(self, k: int | np.integer) -> int | None:
        """The file's row of the header's line again between canonical rows ``k - 1`` and
        ``k`` (None: none; the last of them where several)."""
        if not self.headers.size:
            return None
        lo, hi = self(int(k) - 1), self(int(k))
        inside = self.headers[(self.headers > lo) & (self.headers < hi)]
        return int(inside[-1]) if inside.size else None

    @property
    def identity(self) -> bool:
        """Whether no row was dropped or moved (canonical row ``k`` is data row ``k + 1``)."""
        return self._after.size == 0 and self._order is None

    @overload
    def __call__(self, k: int | np.integer) -> int: ...

    @overload
    def __call__(self, k: np.ndarray) -> np.ndarray: ...

    def __call__(self, k):
        """The 1-based data row of the file of canonical row(s) ``k`` (0-based)."""
        if self._order is not None:
            return int(self._order[k]) if isinstance(k, int | np.integer) else self._order[k]
        if isinstance(k, int | np.integer):
            return int(k) + 1 + int(np.searchsorted(self._after, int(k), side="right"))
        k = np.asarray(k, dtype=np.int64)
        return k + 1 + np.searchsorted(self._after, k, side="right")


class RowFilter:
    """Drop copies and rows without a wheel speed from blocks of rows as they arrive.

    The rows of ``rwhonet predict``'s drive come in blocks ``(first_row, columns)``: data
    rows ``first_row ..`` of the file. A block that holds such rows is handed on split
    around them, so each block handed on is still consecutive rows of the file and every
    message downstream names the file's row. A copy is a row that repeats any earlier row
    of the drive (:func:`repeated_rows`), in an earlier block too: every row is kept (72
    bytes a row for the nine channels predict reads, 26 MB for ten hours at 10 Hz), and
    rows are compared only where a block's time does not run past every earlier row's.
    ``dropped`` lists the copies dropped and ``wheelless`` the rows without a wheel speed
    (the file's, 1-based), as :func:`drop_rows` lists them.
    """

    def __init__(self) -> None:
        self.dropped: list[int] = []
        self.wheelless: list[int] = []
        self.n_rows = 0  # the rows handed in
        self._valued: set[str] = set()  # the wheel channels seen with a value
        self._names: tuple[str, ...] | None = None  # the channels of the first block
        self._keyed: list[np.ndarray] = []  # the keys (row_keys) of the first rows
        self._n_keyed = 0  # how many
        self._last_key = np.zeros(0, dtype="V1")  # the last keyed row's
        self._pending: list[dict[str, np.ndarray]] = []  # the blocks after them, not keyed
        self._t_max = -np.inf  # the latest time handed in

    def blocks(
        self, blocks: Iterable[tuple[int, dict[str, np.ndarray]]]
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """The blocks without those rows (a block of such rows only is left out)."""
        for first, columns in blocks:
            n = len(columns[c.T_S])
            if n == 0:
                yield first, columns
                continue
            self.n_rows = first + n - 1
            t = np.asarray(columns[c.T_S])
            wheelless = wheelless_rows(columns)
            self._valued |= {w for w in c.WHEELS if w in columns and not np.isnan(columns[w]).all()}
            copies = self._copies(columns, t)
            copies = np.setdiff1d(copies, wheelless)
            if copies.size == 0 and wheelless.size == 0:
                yield first, columns  # no copy and every wheel: as it is
                continue

            self.dropped += [first + int(i) for i in copies]
            self.wheelless += [first + int(i) for i in wheelless]
            bounds = np.r_[-1, np.union1d(copies, wheelless), n]
            for a, b in zip(bounds[:-1] + 1, bounds[1:], strict=True):
                if b > a:
                    yield first + int(a), {k: v[a:b] for k, v in columns.items()}

    def _copies(self, columns: dict[str, np.ndarray], t: np.ndarray) -> np.ndarray:
        """The block's rows (0-based) that repeat an earlier row of the drive; keeps them."""
        if self._names is None:
            self._names = tuple(columns)
        if tuple(columns) != self._names:  # another layout: not comparable, none is a copy
            return np.zeros(0, dtype=np.int64)
        self._pending.append(columns)
        with np.errstate(invalid="ignore"):
            if t[0] > self._t_max and (t[1:] > t[:-1]).all():
                # every row later than every row before it: no copy (keyed when needed)
                self._t_max = float(t[-1])
                return np.zeros(0, dtype=np.int64)
        latest = np.fmax.accumulate(np.r_[self._t_max, t])  # a NaN time passes nothing
        self._t_max = float(latest[-1])
        new = row_keys({k: np.concatenate([b[k] for b in self._pending]) for k in self._names})
        self._pending = []
        before = self._n_keyed + new.size - t.size  # the rows before the block
        self._keyed.append(new)
        self._n_keyed += new.size
        keys = new[new.size - t.size :]
        # a copy of the row just before (the common case) is told from that row; only a row
        # at or before an earlier row's time that is not is looked up among them all
        previous = new[-t.size - 1 : -t.size] if new.size > t.size else self._last_key
        if previous.size:
            consecutive = np.r_[previous, keys[:-1]] == keys
        else:
            consecutive = np.r_[False, keys[1:] == keys[:-1]]
        self._last_key = keys[-1:]
        with np.errstate(invalid="ignore"):
            back = ~(t > latest[:-1]) & ~consecutive  # a NaN time: looked up
        if not back.any():
            return np.flatnonzero(consecutive)
        every = np.concatenate(self._keyed)
        self._keyed = [every]  # one array: the next look-up joins only what came after
        _, first, inverse = np.unique(every, return_index=True, return_inverse=True)
        copied = first[inverse.ravel()][before:] < np.arange(before, before + t.size)
        return np.flatnonzero(consecutive | (back & copied))

    def problems(self, file: str, names: Mapping[str, str]) -> list[Problem]:
        """Once every row is in: why its rows without a wheel speed are not lost samples,
        as :func:`drop_rows` says it (none: they are)."""
        if not self.wheelless:
            return []
        empty = [w for w in c.WHEELS if w not in self._valued]
        return wheelless_problems(file, self.n_rows, self.wheelless, empty, names)

    def notes(self, file: str) -> list[str]:
        """What was dropped, for stderr (none: nothing)."""
        return [
            *([f"{file}: {dropped_note(self.dropped)}"] if self.dropped else []),
            *([f"{file}: {wheelless_note(self.wheelless)}"] if self.wheelless else []),
        ]
