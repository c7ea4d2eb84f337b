"""Drive rows read incrementally from a byte stream (a file or stdin), a few blocks at a time.

``rwhonet predict`` reads a drive as it arrives: the header is located by the
same code as the ingest readers (:func:`rwhonet.data.csvio.parse_header`,
:func:`rwhonet.data.iovnbd.iovnbd_columns`, :func:`rwhonet.data.columnmap.columnmap_positions`),
then every block of whole lines that the stream has ready is parsed into the
canonical channels in SI units (``t_s``, ``lat_deg``, ``lon_deg``, ``omega_*``, and
``yaw_rate_rad_s`` where the layout has it).
Rows are numbered as the readers number them (1-based data rows, blank lines not
counted), so a bad cell is reported with its row and the file's column name.
Missing values (empty, ``NaN``, ``NA``, ``null``) become NaN: the caller decides
what a missing fix or wheel speed means. The time column reads as the ingest
readers and the label stage read it (:class:`rwhonet.data.timebase.StreamClock`):
a time of day that passes midnight continues into the next day, and stamps
jittered off the drive's sample grid are replaced by their slots' instants, so
``predict`` cuts and integrates the seconds ``label`` does.
"""

from __future__ import annotations

import csv
import functools
import io
import itertools
import math
import os
import select
import stat
from collections import Counter
from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import BinaryIO

import numpy as np

from rwhonet.config import ColumnSpec, GnssPolicy
from rwhonet.data import canonical as c
from rwhonet.data.packed import is_packed, signed_coordinates, unpack_or_refuse
from rwhonet.data.problems import no_data_rows
from rwhonet.data.texttime import check_dates, date_note, parse_dates
from rwhonet.data.timebase import STAMP_LEAN, STREAM_PHASE_ROWS, StreamClock
from rwhonet.errors import InputError, Problem

BLOCK_BYTES = 1 << 16  # at most this much text is parsed per step (about 15 s of 10 Hz rows)
# A pipe's reader wakes this often while it waits for data, so that a signal another thread
# of the process took (numpy's and ONNX Runtime's threads can take a process's SIGTERM) is
# handled: Python runs handlers on the main thread only, and a read() the signal did not
# interrupt would wait for the next row, forever on a live stream that has paused.
PIPE_WAKE_S = 0.2
CHANNELS = c.REQUIRED  # what a second needs: time, fix, four wheel speeds
# Read too where the layout has them: the yaw rate (predict's navigation filter), the
# satellite count and the receiver's stated accuracy (a fix validate's GNSS policy would
# not use is no fix: FixScreen).
OPTIONAL_CHANNELS = (c.YAW_RATE_RAD_S, c.N_SATS, c.H_ACC_M)


def carried_channels(available: Collection[str]) -> tuple[str, ...]:
    """What predict reads of a drive: :data:`CHANNELS`, and each optional one it has."""
    return (*CHANNELS, *(name for name in OPTIONAL_CHANNELS if name in available))


@dataclass(frozen=True)
class Layout:
    """Where the canonical channels are in a file's rows, and their factors to SI.

    Attributes:
        n_columns: columns of the header (and the empty one every row ends in, where
            ``trailing_cell``: csvio.HeadLines.trailing_cell; without the empty one the
            header ends in, where ``short_rows``: csvio.HeadLines.short_rows).
        positions: canonical name -> 0-based column position.
        factors: canonical name -> factor from the file's unit to SI.
        linear: canonical name -> a column map's entry whose ``scale`` and ``offset`` make
            the file's raw numbers values in its unit before the factor
            (:func:`rwhonet.data.columnmap.scaled`); none where the map sets neither.
        names: canonical name -> the file's column name (for messages).
        time_unit: the time column's unit as a column map declares it (``s``, ``ms``,
            ``iso8601``, ``hh:mm:ss``); None for an IO-VNBD file, whose time is read in the
            form its first row shows (seconds, or text: :mod:`rwhonet.data.texttime`).
        time_setting: where a column map declares it (for messages).
        packed: canonical name -> a packed unit a column map declares for it (``ddmm``,
            ``hhmmss``: :mod:`rwhonet.data.packed`) and where it is declared; unpacked
            after the factors (whose entry is 1.0).
        date: a column map's date column (``date`` key): its position, unit, name and
            setting; each row's date is added to its time of day (None: no such column).
        hemispheres: canonical name -> a column map's hemisphere letter column for it
            (``lat_hemisphere``, ``lon_hemisphere``): its position, unit (``N/S``,
            ``E/W``), name and setting; the letters give the coordinates their signs.
        fix_status: a column map's fix status column (``fix`` key): its unit, setting,
            name, and position where it is written as text (None: a code, read among the
            channels as :data:`rwhonet.data.fixstatus.FIX_STATUS`); a position it says is no
            fix is taken as none (None: no such column).
        fix_counts: the positions the status took out so far, by code
            (:func:`rwhonet.data.fixstatus.screen`).
        header: every header cell as written (without a units row's units), to tell a
            header line of other columns among the rows (a logger that restarted with
            another configuration).
    """

    n_columns: int
    positions: dict[str, int]
    factors: dict[str, float]
    names: dict[str, str]
    linear: dict[str, ColumnSpec] = field(default_factory=dict)
    trailing_cell: bool = False  # the last column: the empty cell every row ends in
    short_rows: bool = False  # the header's empty last cell, which its rows lack, not read
    time_unit: str | None = None
    time_setting: str = ""
    packed: dict[str, tuple[str, str]] = field(default_factory=dict)
    date: tuple[int, str, str, str] | None = None
    hemispheres: dict[str, tuple[int, str, str, str]] = field(default_factory=dict)
    fix_status: tuple[str, str, str, int | None] | None = None
    header: tuple[str, ...] = ()
    # how the rows were read where a reader would note it (a time written as text, a file
    # separated by ';'), filled as the first rows arrive
    notes: list[str] = field(default_factory=list)
    fix_counts: Counter = field(default_factory=Counter)

    def fix_status_note(self, file: str) -> str | None:
        """What the fix status column took out of the rows read so far (None: nothing)."""
        if self.fix_status is None:
            return None
        from rwhonet.data.fixstatus import note

        return note(self.fix_counts, self.fix_status[0], file, self.fix_status[2])


def layout(
    header: list[str],
    fmt: str,
    column_map: Mapping | None,
    file: str,
    radius_m: float | None = None,
) -> Layout:
    """Locate the channels of ``header`` as the ingest reader of ``fmt`` does.

    Args:
        header: the header cells.
        fmt: ``iovnbd`` or a column map's name.
        column_map: that column map (``data.column_maps[fmt]``), for a column-mapped file.
        file: how the file is named in error reports.
        radius_m: the car's nominal tyre radius, for a column map's circumferential wheel
            speeds (``km/h``, ``m/s``, ``mph``).

    Raises:
        InputError: the channels cannot be located; a circumferential wheel speed without
            a radius.
    """
    date: tuple[int, str, str, str] | None = None
    hemispheres: dict[str, tuple[int, str, str, str]] = {}
    fix_status: tuple[str, str, str, int | None] | None = None
    wheel_note = None
    if fmt == "iovnbd":
        from rwhonet.data.iovnbd import (
            column_factors,
            column_packed,
            header_setting,
            iovnbd_columns,
        )

        positions, _ = iovnbd_columns(header, file)
        factors = column_factors(header, positions)
        linear: dict[str, ColumnSpec] = {}
        packed = {
            name: (unit, header_setting(header[positions[name]]))
            for name, unit in column_packed(header, positions).items()
        }
    else:
        from rwhonet.data.columnmap import (
            DATE,
            FIX,
            HEMISPHERES,
            KEYS,
            check_column_map,
            columnmap_positions,
            key_factor,
            linear_wheel_note,
        )

        check_column_map(fmt, column_map or {})
        by_key = columnmap_positions(header, column_map or {}, fmt, file)
        if DATE in by_key:
            at = by_key.pop(DATE)
            date = (at, (column_map or {})[DATE].unit, header[at], f"data.column_maps.{fmt}.date")
        for key, (coordinate, unit) in HEMISPHERES.items():
            if key in by_key:
                at = by_key.pop(key)
                setting = f"data.column_maps.{fmt}.{key}"
                hemispheres[KEYS[coordinate][0]] = (at, unit, header[at], setting)
        if FIX in by_key:
            from rwhonet.data.fixstatus import is_text

            unit, at = (column_map or {})[FIX].unit, by_key[FIX]
            text_at = by_key.pop(FIX) if is_text(unit) else None  # read as text, not a number
            fix_status = (unit, f"data.column_maps.{fmt}.{FIX}", header[at], text_at)
        positions = {KEYS[key][0]: pos for key, pos in by_key.items()}
        # a strptime pattern for the time is text, read as seconds: factor 1; a packed unit
        # is unpacked (factor 1 before); a circumferential wheel speed by the radius
        units = {key: (column_map or {})[key].unit for key in by_key}
        factors = {
            KEYS[key][0]: key_factor(key, unit, radius_m, fmt) for key, unit in units.items()
        }
        # raw numbers (scale, offset: checked above): (raw * scale + offset) * factor
        specs = {KEYS[key][0]: (column_map or {})[key] for key in by_key}
        linear = {name: spec for name, spec in specs.items() if spec.scaled}
        wheel_note = linear_wheel_note(units, {k: header[p] for k, p in by_key.items()}, radius_m)
        packed = {
            KEYS[key][0]: (unit, f"data.column_maps.{fmt}.{key}.unit")
            for key, unit in units.items()
            if is_packed(unit)
        }
    wanted = carried_channels(positions)
    if fix_status is not None and fix_status[3] is None:  # a code: read with the channels
        from rwhonet.data.fixstatus import FIX_STATUS

        wanted = (*wanted, FIX_STATUS)
    positions = {name: positions[name] for name in wanted}
    declared = None if fmt == "iovnbd" else (column_map or {})["t"].unit
    return Layout(
        n_columns=len(header),
        positions=positions,
        factors={name: factors[name] for name in wanted},
        names={name: header[pos] for name, pos in positions.items()},
        linear={name: linear[name] for name in wanted if name in linear},
        time_unit=declared,
        time_setting=f"data.column_maps.{fmt}.t.unit",
        packed={name: how for name, how in packed.items() if name in wanted},
        date=date,
        hemispheres=hemispheres,
        fix_status=fix_status,
        header=tuple(header),
        notes=[
            *([] if date is None else [date_note(date[2], header[positions[c.T_S]], date[1])]),
            *([] if wheel_note is None else [wheel_note]),
        ],
    )


@dataclass
class _TimeForm:
    """How a stream's time column is written, decided from its first data row.

    Attributes:
        text: the text unit (:func:`rwhonet.data.texttime.is_text_unit`), None: numbers.
        zoned: whether the first ISO 8601 time gave its zone offset (None: not yet seen).
    """

    text: str | None = None
    zoned: bool | None = None

    @classmethod
    def of(cls, lines: str, lay: Layout, file: str) -> _TimeForm:
        """The form of the first data row's time cell, checked against a declared unit.

        Raises:
            InputError: a column map declares numbers (s, ms) and the time is text.
        """
        from rwhonet.data.csvio import first_cell_in
        from rwhonet.data.texttime import declared_text_unit

        cell = first_cell_in(lines.splitlines(), lay.positions[c.T_S])
        return cls(
            declared_text_unit(lay.time_unit, cell, lay.names[c.T_S], lay.time_setting, file)
        )


def read_rows(
    stream: BinaryIO,
    file: str,
    fmt: str = "iovnbd",
    column_map: Mapping | None = None,
    block_bytes: int = BLOCK_BYTES,
    period_s: float = 0.1,
    radius_m: float | None = None,
    split_gap_s: float = 0.5,
    gnss_lag: str | float = "report",
) -> tuple[Layout, Iterator[tuple[int, dict[str, np.ndarray]]]]:
    """Read the header now; return the layout and the drive's row blocks as they arrive.

    A Racelogic VBOX file (told by its first line, from a file or a pipe) is read through
    its column map as the CSV it stands for (:func:`_vbo_rows`).

    Args:
        stream: the drive, opened in binary mode (``sys.stdin.buffer`` for a pipe).
        file: how the drive is named in error reports (``<stdin>``).
        fmt: ``iovnbd`` or a column map's name.
        column_map: the column map of ``fmt``.
        block_bytes: at most this many bytes are read per step; a pipe yields what it has.
        period_s: the nominal sample period (``validate.sample_period_s``), for the clock.
        radius_m: the car's nominal tyre radius (a column map's wheel speeds in ``km/h``,
            ``m/s``, ``mph``).
        split_gap_s: a table logged faster than the grid is resampled (read whole first:
            :func:`_placed_or_resampled`), its holes in the grid made longer than this
            (``validate.gnss.max_gap_s``).
        gnss_lag: such a table's fixes against its wheels' clock (``data.gnss_lag``, as
            ingest resamples it: :func:`rwhonet.data.streams.resample`).

    Returns:
        ``(layout, blocks)``: ``blocks`` yields ``(first_row, columns)``, the 1-based data
        row of the block's first row and each canonical channel as float64 in SI units,
        the time on the drive's continuous clock with jitter removed (the first block
        holds at least ``STREAM_PHASE_ROWS`` rows, from which the grid's phase is taken).

    Raises:
        InputError: a header the reader refuses (now), a row with another number of columns
            than the header or a cell that is not a number (while iterating).
    """
    from rwhonet.data.csvio import (
        HEADER_MAX_BYTES,
        HEADER_SEARCH_LINES,
        as_comma_separated,
        comment_lines_note,
        delimiter_of,
        first_line_end,
        header_cells,
        line_key,
        preamble_note,
        read_head,
        short_rows_note,
        trailing_cell_note,
        units_row_note,
        with_units,
    )
    from rwhonet.data.vbo import is_vbo

    pipe = _pipe_reader(stream)
    line, rest = _header_line(pipe or stream, HEADER_MAX_BYTES + 1, pipe)
    blank: list[bytes] = []  # blank lines first: a VBOX file is told by its first line after
    while line and not line.strip() and len(blank) < HEADER_SEARCH_LINES:
        blank.append(line)
        line, rest = _next_line(pipe or stream, pipe, rest)
    if is_vbo(line):  # a Racelogic VBOX file, from a file or a pipe
        head = line + (rest or b"")
        return _vbo_rows(
            head,
            pipe or stream,
            file,
            fmt,
            column_map,
            block_bytes,
            period_s,
            radius_m,
            split_gap_s,
            gnss_lag,
        )
    # comment lines and a tool's preamble before the header, a row of units under it
    # (csvio.read_head), read as ingest reads them; the lines read after the header to find
    # it (rows of data: the first ones) go to the blocks first
    more = _MoreLines(pipe or stream, pipe, rest)
    head, after = read_head(itertools.chain(blank, [line], more))
    rest, line, second = more.rest, head.header, head.second
    whole = second.endswith((b"\n", b"\r"))  # a pipe's lone-CR file: one byte, no line
    units = head.units if whole else None
    header = written = header_cells(head, file)
    if units is not None:
        header, after = with_units(header, units, file), after[1:]
    lay = replace(
        layout(header, fmt, column_map, file, radius_m),
        trailing_cell=head.trailing_cell,
        short_rows=head.short_rows,
        header=tuple(written),  # as a restarted logger would write it again
    )
    if units is not None:
        lay.notes.append(units_row_note())
    said = (
        comment_lines_note(head.comments),
        preamble_note(head.preamble, head.preamble_first),
        trailing_cell_note() if head.trailing_cell else None,
        short_rows_note() if head.short_rows else None,
    )
    lay.notes.extend(note for note in said if note is not None)
    # rest is None: lines end in LF (or CR LF); else the bytes read after a header that
    # ended in a lone CR (classic Mac line ends), whose rows are read with CR as LF
    # a file separated by ';' or tabs (decimal commas): its rows read as comma-separated
    delimiter = delimiter_of(line[: first_line_end(line)])
    # the header's line again among the rows (csvio.header_again_rows), as the rows are read
    keys = tuple(
        as_comma_separated(line_key(x), delimiter) if x is not None else None
        for x in (line, second if units is not None else None)
    )
    blocks = _blocks(stream, lay, file, block_bytes, pipe, rest, delimiter, b"".join(after), keys)
    # a table faster than the grid: resampled whole, as ingest resamples it
    whole = functools.partial(
        _resampled,
        lay=lay,
        file=file,
        period_s=period_s,
        radius_m=radius_m,
        split_gap_s=split_gap_s,
        gnss_lag=gnss_lag,
    )
    # a file (not a pipe) read whole, so that rows out of time order are put in order as
    # ingest puts them (rwhonet.data.sampleorder.rows_in_time_order)
    ordered = None
    if pipe is None:
        ordered = functools.partial(_in_time_order, lay=lay, file=file, period_s=period_s)
    return lay, _placed_or_resampled(blocks, period_s, whole, ordered)


Whole = Callable[
    [list[tuple[int, dict[str, np.ndarray]]]], Iterator[tuple[int, dict[str, np.ndarray]]]
]


def _placed_or_resampled(
    blocks: Iterator[tuple[int, dict[str, np.ndarray]]],
    period_s: float,
    resampled: Whole,
    ordered: Whole | None = None,
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """The row blocks placed on the drive's clock (:func:`placed`), or, where the rows
    come faster than the grid (a 20-100 Hz table) or at a rate of the logger's own
    (:func:`rwhonet.data.fastfile.needs_resampling`), the whole drive read and given to
    ``resampled`` (:func:`_resampled`, its other arguments bound), and its grid rows
    handed on. With ``ordered`` (a file, not a pipe), the whole drive is read first and
    judged whole, in time order, as ingest judges it; where its rows are out of time order
    they are given to ``ordered`` (:func:`_in_time_order`). From a pipe, the first
    ``STREAM_PHASE_ROWS`` rows are judged."""
    from rwhonet.data.fastfile import needs_resampling
    from rwhonet.data.sampleorder import out_of_order
    from rwhonet.data.timebase import coarse_places, unwrap_clock

    head: list[tuple[int, dict[str, np.ndarray]]] = []
    n = 0
    for block in blocks:
        head.append(block)
        n += len(block[1][c.T_S])
        if n >= STREAM_PHASE_ROWS and ordered is None:
            break
    t = np.concatenate([cols[c.T_S] for _, cols in head]) if head else np.zeros(0)
    if ordered is not None:  # the whole drive, on its continuous clock (midnight unwrapped)
        t = unwrap_clock(t)[0]
        # stamps to the second (placed), or out of order beyond a jitter the rows' order
        # places (coarse stamps first: to out_of_order each second is a run of its own)
        if head and (coarse_places(t, period_s) is not None or out_of_order(t, period_s)):
            head = list(ordered(head))
            t = unwrap_clock(np.concatenate([cols[c.T_S] for _, cols in head]))[0]
    # judged in time order, as ingest judges it after putting the rows in order
    if needs_resampling(t, period_s):
        yield from placed(resampled([*head, *blocks]), StreamClock(period_s))
        return
    rows = iter(head) if ordered is not None else itertools.chain(head, blocks)
    yield from placed(rows, StreamClock(period_s))


def _in_time_order(
    blocks: list[tuple[int, dict[str, np.ndarray]]], lay: Layout, file: str, period_s: float
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """A drive's rows (the whole drive) put in time order as ingest puts them: its copies
    and rows without a wheel speed dropped, then sorted where that is safe
    (:func:`rwhonet.data.sampleorder.rows_in_time_order`; else as they are, for the checks
    downstream to refuse), handed on in runs of consecutive rows of the file; the notes
    say so."""
    from rwhonet.data.csvio import RawDrive
    from rwhonet.data.droprows import FileRows, drop_rows, manifest_rows
    from rwhonet.data.sampleorder import coarse_stamps_placed, rows_in_time_order
    from rwhonet.data.timebase import unwrap_clock

    file_rows = np.concatenate([f + np.arange(len(cols[c.T_S])) for f, cols in blocks])
    names = list(blocks[0][1])
    columns = {k: np.concatenate([cols[k] for _, cols in blocks]) for k in names}
    logged = columns[c.T_S]
    columns[c.T_S] = unwrap_clock(logged)[0]  # sorted on the continuous clock
    raw = RawDrive(
        columns | {"logged_t": logged, "unwrapped_t": columns[c.T_S]},
        dict(lay.names),
        "name",
        header_rows=np.setdiff1d(np.arange(1, int(file_rows[-1]) + 1), file_rows),
    )
    raw = coarse_stamps_placed(raw, file, period_s)  # hh:mm:ss without its fraction
    raw = rows_in_time_order(drop_rows(raw, file), file, period_s)
    moved = raw.columns[c.T_S] - raw.columns["unwrapped_t"]  # coarse stamps, a clock set back
    if raw.row_order is None and not moved.any():  # in order, or not safe to sort: as read
        yield from blocks
        return
    lay.notes.extend(note.removeprefix(f"{file}: ") for note in raw.notes)
    order = raw.row_order
    if order is None:  # in the file's order, but copies and rows without a wheel dropped
        order = FileRows.of(manifest_rows(raw))(np.arange(raw.n_rows))
    kept = {k: v for k, v in raw.columns.items() if k not in ("logged_t", "unwrapped_t")}
    kept[c.T_S] = raw.columns["logged_t"] + moved  # the clock as the file has it, moved
    cuts = np.r_[0, np.flatnonzero(np.diff(order) != 1) + 1, order.size]
    for a, b in itertools.pairwise(cuts.tolist()):
        yield int(order[a]), {k: v[a:b] for k, v in kept.items()}


def _resampled(
    blocks: list[tuple[int, dict[str, np.ndarray]]],
    lay: Layout,
    file: str,
    period_s: float,
    radius_m: float | None,
    split_gap_s: float,
    gnss_lag: str | float = "report",
    rows_per_block: int = 600,
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """A faster table's rows (the whole drive) on the grid, in blocks of grid rows: its
    copies and rows without a wheel speed dropped, then read as streams and resampled
    (:func:`rwhonet.data.fastfile.as_streams`, :func:`rwhonet.data.streams.resample`,
    grid rows without a fix kept with NaN positions), as ingest reads it; the notes say so."""
    from rwhonet.data.csvio import RawDrive
    from rwhonet.data.droprows import drop_rows
    from rwhonet.data.fastfile import as_streams
    from rwhonet.data.streams import resample

    file_rows = np.concatenate([f + np.arange(len(cols[c.T_S])) for f, cols in blocks])
    names = list(blocks[0][1])
    raw = RawDrive(
        {k: np.concatenate([cols[k] for _, cols in blocks]) for k in names},
        dict(lay.names),
        "name",
        # rows the reader did not hand on (the header's line again) keep the file's numbers
        header_rows=np.setdiff1d(np.arange(1, int(file_rows[-1]) + 1), file_rows),
    )
    blocks.clear()
    res = resample(
        as_streams(drop_rows(raw, file), file, period_s),
        period_s=period_s,
        split_gap_s=split_gap_s,
        nominal_radius_m=radius_m,
        require_fix=False,
        gnss_lag=gnss_lag,
    )
    lay.notes.extend(res.drive.notes)
    # the rows whose mean of a wheel used a glitched sample, for predict to repair, as a
    # stream drive's (rwhonet.cli.drive.canonical_blocks)
    grid = res.drive.columns | {c.GLITCH_FLAG + w: rows for w, rows in res.glitch_wheels.items()}
    carried = [k for k in names if k in grid] + [k for k in grid if k.startswith(c.GLITCH_FLAG)]
    for a in range(0, grid[c.T_S].size, rows_per_block):
        yield a + 1, {k: grid[k][a : a + rows_per_block] for k in carried}


class _Replay(io.RawIOBase):
    """``head`` (bytes already read from ``source``), then the rest of ``source``."""

    def __init__(self, head: bytes, source: BinaryIO | io.FileIO) -> None:
        super().__init__()
        self._head, self._source = head, source

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:  # type: ignore[no-untyped-def]
        if self._head:
            n = min(len(buffer), len(self._head))
            buffer[:n], self._head = self._head[:n], self._head[n:]
            return n
        data = self._source.read(len(buffer))
        buffer[: len(data)] = data
        return len(data)


def _vbo_rows(
    head: bytes,
    source: BinaryIO | io.FileIO,
    file: str,
    fmt: str,
    column_map: Mapping | None,
    block_bytes: int,
    period_s: float,
    radius_m: float | None,
    split_gap_s: float = 0.5,
    gnss_lag: str | float = "report",
) -> tuple[Layout, Iterator[tuple[int, dict[str, np.ndarray]]]]:
    """:func:`read_rows` of a VBOX file (``head``: its first line, read already) through its
    column map, as the CSV it stands for (:class:`rwhonet.data.vbo.VboAsCsv`); a satellite
    count mapped as a plain ``count`` is refused where it carries the VBOX's flags.

    Raises:
        InputError: ``fmt`` is ``iovnbd`` (a VBOX file needs a map), or as :func:`read_rows`.
    """
    from rwhonet.data.vbo import VboAsCsv, plain_counts_checked, vbo_needs_a_map, vbo_note

    if fmt == "iovnbd":
        raise InputError([vbo_needs_a_map(file, fmt)])
    raw = io.BufferedReader(_Replay(head, source), 1 << 16)
    csv_rows = io.BufferedReader(VboAsCsv(raw, file), 1 << 16)  # type: ignore[arg-type]
    lay, blocks = read_rows(
        csv_rows, file, fmt, column_map, block_bytes, period_s, radius_m, split_gap_s, gnss_lag
    )
    lay.notes.insert(0, vbo_note())
    sats = (column_map or {}).get("n_sats")
    if sats is not None and sats.unit == "count" and c.N_SATS in lay.names:
        setting = f"data.column_maps.{fmt}.n_sats.unit"
        blocks = plain_counts_checked(blocks, file, lay.names[c.N_SATS].strip(), setting)
    return lay, blocks


class _MoreLines:
    """The lines after the first, read as :func:`_next_line` reads them; ``rest``: the
    bytes read after the last line given (see :func:`_next_line`)."""

    def __init__(
        self, source: BinaryIO | io.FileIO, pipe: io.FileIO | None, rest: bytes | None
    ) -> None:
        self.source, self.pipe, self.rest = source, pipe, rest

    def __iter__(self) -> Iterator[bytes]:
        return self

    def __next__(self) -> bytes:
        line, self.rest = _next_line(self.source, self.pipe, self.rest)
        if not line:
            raise StopIteration
        return line


def _next_line(
    source: BinaryIO | io.FileIO, pipe: io.FileIO | None, rest: bytes | None
) -> tuple[bytes, bytes | None]:
    """The next line before the data rows, and the bytes read after it: read from
    ``source`` as :func:`_header_line` reads (``rest`` None), else taken from ``rest``, the
    bytes read after a line that ended in a lone CR, the line's end read on where ``rest``
    holds only its start (a pipe's one byte)."""
    from rwhonet.data.csvio import HEADER_MAX_BYTES, first_line_end

    if rest is None:
        return _header_line(source, HEADER_MAX_BYTES + 1, pipe)
    end = first_line_end(rest)
    if end < len(rest):
        return rest[: end + 1], rest[end + 1 :]
    more, after = _header_line(source, HEADER_MAX_BYTES + 1 - len(rest), pipe)
    return rest + more, after


def _pipe_reader(stream: BinaryIO) -> io.FileIO | None:
    """An unbuffered reader of ``stream``'s file descriptor where it is a pipe, FIFO,
    terminal or socket (None for a regular file or an in-memory stream), so that
    :func:`_wait_readable` sees whether data waits (a buffer could hold rows select()
    does not see); nothing must have been read from ``stream`` yet, and ``stream`` must
    stay open while the reader is used (it owns the descriptor)."""
    try:
        fd = stream.fileno()
        mode = os.fstat(fd).st_mode
    except (AttributeError, OSError, ValueError):  # io.BytesIO and the like
        return None
    if stat.S_ISREG(mode) or stat.S_ISBLK(mode) or os.name == "nt":  # select(): sockets only there
        return None
    return io.FileIO(fd, "rb", closefd=False)


def _wait_readable(stream: io.FileIO) -> None:
    """Return when the pipe has data (or has ended), waking every :data:`PIPE_WAKE_S`.

    Raises:
        rwhonet.libraries.Interrupted: a signal of ``interruptible`` came, also one whose
            exception a C library lost (:func:`rwhonet.libraries.raise_if_interrupted`).
    """
    from rwhonet.libraries import raise_if_interrupted

    fd = stream.fileno()
    raise_if_interrupted()
    while not select.select([fd], [], [], PIPE_WAKE_S)[0]:
        raise_if_interrupted()  # back in Python between waits: a pending handler runs here


def _header_line(
    stream: BinaryIO, limit: int, pipe: io.FileIO | None
) -> tuple[bytes, bytes | None]:
    """The first line (at most ``limit`` bytes) and, where it ends in a lone CR (classic
    Mac line ends, no LF in the file), the bytes read after it (else None).

    A pipe's line is read a byte at a time, as its data arrives, so that no row after it
    is read ahead (after a CR, one byte more: whether an LF follows).
    """
    from rwhonet.data.csvio import first_line_end

    if pipe is None:
        line = stream.readline(limit)
        end = first_line_end(line)
        if line[end : end + 1] == b"\r" and line[end + 1 : end + 2] != b"\n":
            return line[: end + 1], line[end + 1 :]
        return line, None
    line = bytearray()
    while len(line) < limit:
        _wait_readable(pipe)
        byte = pipe.read(1)
        if not byte:
            break
        line += byte
        if byte == b"\r":
            _wait_readable(pipe)
            after = pipe.read(1)
            if after != b"\n":
                return bytes(line), after
            line += after
        if line.endswith(b"\n"):
            break
    return bytes(line), None


def placed(
    blocks: Iterator[tuple[int, dict[str, np.ndarray]]], clock: StreamClock
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """Row blocks with their times placed on ``clock`` (midnight and jitter).

    The first blocks are held back until they hold ``STREAM_PHASE_ROWS`` rows (or the
    drive ends), so the grid's phase is taken from that many stamps. A block's last rows
    whose slots the next rows could still change (:meth:`StreamClock.place`) go on with
    the next block, where it follows them in the file; so every block handed on is still
    rows ``first ..`` of the file, one after the other. Each block carries each row's
    stamp less its placed time (:data:`rwhonet.data.timebase.STAMP_LEAN`, s), which
    ``predict``'s seconds read beside a dropped sample as the label's do
    (:func:`rwhonet.data.timebase.leans_into_drop`).
    """
    held: list[tuple[int, dict[str, np.ndarray]]] = []
    carry: tuple[int, dict[str, np.ndarray]] | None = None
    for block in blocks:
        if clock.phase is None:
            held.append(block)
            if sum(len(cols[c.T_S]) for _, cols in held) < STREAM_PHASE_ROWS:
                continue
            if not _consecutive(held):
                yield from _placed_held(held, clock)
                held = []
                continue
            block, held = _joined(held), []
        if carry is not None:
            if carry[0] + len(carry[1][c.T_S]) == block[0]:
                block = _joined([carry, block])
            else:  # the header's line again between them: the rows before placed whole
                yield from _place(carry, clock, final=True)[0]
        done, carry = _place(block, clock, final=False)
        yield from done
    if held:  # a drive shorter than STREAM_PHASE_ROWS rows
        yield from _placed_held(held, clock)
    if carry is not None:
        yield from _place(carry, clock, final=True)[0]


def _consecutive(blocks: list[tuple[int, dict[str, np.ndarray]]]) -> bool:
    """Whether row blocks are consecutive rows of the file."""
    return all(a + len(x[c.T_S]) == b for (a, x), (b, _) in itertools.pairwise(blocks))


def _placed_held(
    held: list[tuple[int, dict[str, np.ndarray]]], clock: StreamClock
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """The first blocks placed on ``clock`` together, all of them (its phase taken from all
    their stamps): one block where they are consecutive rows of the file, else each apart
    (rows the reader did not read between them: the header's line again)."""
    first, columns = _joined(held)
    columns[c.T_S] = clock.place(columns[c.T_S], first - 1)
    columns[STAMP_LEAN] = clock.lean_s
    if _consecutive(held):
        yield first, columns
        return
    at = 0
    for first, cols in held:
        n = len(cols[c.T_S])
        yield first, {name: values[at : at + n] for name, values in columns.items()}
        at += n


def _place(
    block: tuple[int, dict[str, np.ndarray]], clock: StreamClock, final: bool
) -> tuple[list[tuple[int, dict[str, np.ndarray]]], tuple[int, dict[str, np.ndarray]] | None]:
    """A block's settled rows placed (a list of none or one block), and the rows left."""
    first, columns = block
    t = clock.place(columns[c.T_S], first - 1, final)
    n, size = t.size, len(columns[c.T_S])
    done = []
    if n:
        done.append(
            (first, {k: v[:n] for k, v in columns.items()} | {c.T_S: t, STAMP_LEAN: clock.lean_s})
        )
    left = (first + n, {k: v[n:] for k, v in columns.items()}) if n < size else None
    return done, left


@dataclass
class FixScreen:
    """Rows whose fix validate's GNSS policy would not use, made rows without a fix.

    :func:`rwhonet.data.fixes.no_fix_rows` decides, as it does for validate's
    ``low_sats`` rule: latitude = longitude = 0 (a receiver without a fix writes zeros)
    and, where the drive counts satellites, fewer than ``min_sats`` (or no count); where
    the drive has its receiver's stated accuracy and ``policy`` sets ``max_h_acc_m``, an
    accuracy worse than that (or none stated). With
    ``policy`` (``validate.gnss``) validate's ``jump`` and ``frozen`` rules too
    (:mod:`rwhonet.data.quality`): a fix implying more than ``max_speed_m_s`` from the row
    before it (the last block's last row for a block's first; a row the satellite rule took
    out has no fix to compare, where validate compares the zeros), and a fix unchanged while
    the rear wheels turned faster than ``moving_wheel_speed_rad_s`` for ``frozen_min_s``
    in all, from the row where that time is reached to the end of the run of identical
    fixes (validate also takes out the run's moving rows before it, which a stream has
    passed on already). Such a row's latitude and longitude become NaN, as a missing fix
    is, so ``predict`` never measures a GNSS displacement or updates its filter with it.

    Attributes:
        min_sats: ``validate.gnss.min_sats``.
        policy: ``validate.gnss`` (None: the satellite rule alone).
        sample_period_s: ``validate.sample_period_s`` (a row's share of a run's time).
        zeros: rows taken out so far at latitude = longitude = 0.
        low_sats: rows taken out so far for their satellite count.
        poor_accuracy: rows taken out so far for their stated accuracy alone.
        jumps: rows taken out so far as jumps.
        frozen: rows taken out so far as frozen.
    """

    min_sats: float
    policy: GnssPolicy | None = None
    sample_period_s: float = 0.1
    zeros: int = 0
    low_sats: int = 0
    poor_accuracy: int = 0
    jumps: int = 0
    frozen: int = 0
    _last: tuple[float, float, float] | None = None  # the last row's time and fix
    _run_moving_s: float = 0.0  # moving time of the run of identical fixes it ends

    def blocks(
        self, blocks: Iterator[tuple[int, dict[str, np.ndarray]]]
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """The row blocks with every unusable fix taken out."""
        for first, columns in blocks:
            yield first, self.screen(columns)

    def screen(self, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """One block's columns with its unusable fixes taken out (counted)."""
        from rwhonet.data.fixes import no_fix_rows

        lat, lon = columns[c.LAT_DEG], columns[c.LON_DEG]
        has = np.isfinite(lat) & np.isfinite(lon)  # a missing fix is not taken out again
        bad = no_fix_rows(lat, lon, columns.get(c.N_SATS), self.min_sats) & has
        max_h_acc_m = getattr(self.policy, "max_h_acc_m", None)
        poor = np.zeros_like(bad)
        if max_h_acc_m is not None and c.H_ACC_M in columns:
            poor = ~bad & has & ~(columns[c.H_ACC_M] <= max_h_acc_m)  # NaN: none stated
            bad = bad | poor
        if self.policy is not None and len(lat):
            usable = {c.LAT_DEG: np.where(bad, np.nan, lat), c.LON_DEG: np.where(bad, np.nan, lon)}
            jump, frozen = self._jumps_and_frozen(columns | usable)
            jump &= has & ~bad
            frozen &= has & ~bad & ~jump
            self.jumps += int(jump.sum())
            self.frozen += int(frozen.sum())
            screened = bad | jump | frozen
        else:
            screened = bad
        if not screened.any():
            return columns
        zero = bad & (lat == 0.0) & (lon == 0.0)
        self.zeros += int(zero.sum())
        self.low_sats += int((bad & ~zero & ~poor).sum())
        self.poor_accuracy += int(poor.sum())
        return columns | {
            c.LAT_DEG: np.where(screened, np.nan, lat),
            c.LON_DEG: np.where(screened, np.nan, lon),
        }

    def _jumps_and_frozen(self, columns: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        from rwhonet.data.quality import implied_speed_m_s
        from rwhonet.data.timebase import TIME_EPS_S

        policy = self.policy
        assert policy is not None
        t, lat, lon = columns[c.T_S], columns[c.LAT_DEG], columns[c.LON_DEG]
        before = self._last or (math.nan, math.nan, math.nan)
        te, la, lo = (np.r_[before[k], x] for k, x in enumerate((t, lat, lon)))
        with np.errstate(divide="ignore", invalid="ignore"):  # two rows in one slot: a jump
            # a fix off the globe is the stream's to refuse (SecondStream), not a jump
            on_earth = (np.abs(la) <= 90.0) & (np.abs(lo) <= 360.0)
            speed = implied_speed_m_s(
                te,
                np.where(on_earth, la, np.nan),
                np.where(on_earth, lo, np.nan),
                exact_above_m_s=0.5 * policy.max_speed_m_s,
            )
            jump = speed[1:] > policy.max_speed_m_s
        wheel = 0.5 * (np.abs(columns[c.OMEGA_RL]) + np.abs(columns[c.OMEGA_RR]))
        same = (la[1:] == la[:-1]) & (lo[1:] == lo[:-1])  # each row's fix as the row before's
        run = np.cumsum(~same)  # 0: the run the last block ended in
        moved = (wheel > policy.moving_wheel_speed_rad_s) * self.sample_period_s
        total = np.cumsum(moved)
        starts = np.flatnonzero(~same)
        before_run = np.zeros(int(run[-1]) + 1)
        before_run[0] = -self._run_moving_s
        before_run[run[starts]] = total[starts] - moved[starts]
        moving_s = total - before_run[run]
        frozen = moving_s >= policy.frozen_min_s - TIME_EPS_S
        self._last = (float(t[-1]), float(lat[-1]), float(lon[-1]))
        self._run_moving_s = float(moving_s[-1])
        return jump, frozen

    def note(self, file: str) -> str | None:
        """What was taken out, for stderr (None: nothing)."""
        counts = (
            ("zeros", self.zeros),
            ("low_sats", self.low_sats),
            ("poor_accuracy", self.poor_accuracy),
            ("jump", self.jumps),
            ("frozen", self.frozen),
        )
        if not any(n for _, n in counts):
            return None
        policy = self.policy
        said = {
            "zeros": "at latitude = longitude = 0 (what a receiver without a fix writes)",
            "low_sats": f"with fewer than validate.gnss.min_sats {self.min_sats:g} satellites "
            "or no count",
            "poor_accuracy": "whose receiver states a horizontal accuracy worse than "
            f"validate.gnss.max_h_acc_m {getattr(policy, 'max_h_acc_m', None) or math.nan:g} m "
            "or none",
            "jump": "implying more than validate.gnss.max_speed_m_s "
            f"{getattr(policy, 'max_speed_m_s', math.nan):g} m/s from the row before (a jump)",
            "frozen": "unchanged while the wheels turned for validate.gnss.frozen_min_s "
            f"{getattr(policy, 'frozen_min_s', math.nan):g} s (a frozen receiver)",
        }
        total = sum(n for _, n in counts)
        listed = "; ".join(f"{n} {said[k]}" for k, n in counts if n)
        head = f"{file}: {total} row(s) taken as without a GNSS fix, as validate cuts them"
        return f"{head}: {listed}"


def _joined(
    blocks: list[tuple[int, dict[str, np.ndarray]]],
) -> tuple[int, dict[str, np.ndarray]]:
    """Consecutive row blocks as one."""
    if len(blocks) == 1:
        return blocks[0]
    names = blocks[0][1].keys()
    return blocks[0][0], {n: np.concatenate([cols[n] for _, cols in blocks]) for n in names}


def _blocks(
    stream: BinaryIO,
    lay: Layout,
    file: str,
    block_bytes: int,
    pipe: io.FileIO | None = None,
    cr_rest: bytes | None = None,
    delimiter: str = ",",
    head: bytes = b"",
    keys: tuple[bytes | None, ...] = (None, None),
) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """The row blocks of ``stream`` after its header: ``head`` (a line read already) first,
    then ``cr_rest`` (bytes read after a header that ended in a lone CR), then the rest.
    A line that is the header again (``keys``: the header's line and its units row's, as
    :func:`rwhonet.data.csvio.line_key` gives them) is a row not read, as ingest drops it
    (:func:`rwhonet.data.csvio.header_again_rows`): a block is split around it."""
    from rwhonet.data.csvio import (
        as_comma_separated,
        cut_by_nul_tail,
        cut_last_row_note,
        delimiter_note,
        header_again_note,
        is_cut_short,
        nul_tail_note,
    )
    from rwhonet.data.texttime import text_time_note

    if (said := delimiter_note(delimiter)) is not None:
        lay.notes.append(said)

    # read1: what a buffered file has, without waiting; a raw pipe's read() returns what
    # the pipe has (the generator holds ``stream``, which owns the pipe's descriptor)
    read = pipe.read if pipe is not None else getattr(stream, "read1", stream.read)
    cr = cr_rest is not None  # lines end in a lone CR: read as LF (blank lines are skipped)
    first = (head + (cr_rest or b"")).replace(b"\r", b"\n") if cr else head
    row, pending = 1, as_comma_separated(first, delimiter)
    form: _TimeForm | None = None  # decided on the first whole line
    cut = _HeaderAgain(*keys)
    while True:
        if pipe is not None:
            _wait_readable(pipe)
        chunk = read(block_bytes)
        if not chunk:
            break
        chunk = as_comma_separated(chunk, delimiter)
        pending += chunk.replace(b"\r", b"\n") if cr else chunk
        end = pending.rfind(b"\n")
        if end < 0:
            continue
        lines, pending = pending[: end + 1], pending[end + 1 :]
        if form is None and lines.strip():
            form = _TimeForm.of(lines.decode("utf-8", errors="replace"), lay, file)
            if form.text is not None:
                lay.notes.append(text_time_note(lay.names[c.T_S], form.text))
        for at, part in cut.parts(lines, row):
            columns = parse_lines(part, lay, at, file, form)
            if len(columns[c.T_S]):
                yield at, columns
            row = at + len(columns[c.T_S])
        row = cut.next_row or row
    # NUL bytes the stream ends in (a logger that lost power): not read, as ingest does
    tail = len(pending) - len(pending.rstrip(b"\x00"))
    if (said := nul_tail_note(tail)) is not None:
        pending = pending[:-tail]
        lay.notes.append(said)
    # a last row cut short (no line end, fewer cells than a row's): not read, as ingest does
    if is_cut_short(pending, ",", lay.n_columns):
        lay.notes.append(cut_last_row_note(row, len(pending)))
        pending = b""
    if pending.strip():
        if form is None:
            form = _TimeForm.of(pending.decode("utf-8", errors="replace"), lay, file)
            if form.text is not None:
                lay.notes.append(text_time_note(lay.names[c.T_S], form.text))
        for at, part in cut.parts(pending, row):
            try:
                columns = parse_lines(part, lay, at, file, form)
            except InputError as err:  # the last row, cut off where the NUL bytes begin
                if not tail:
                    raise
                raise InputError([*err.problems, cut_by_nul_tail(file, at, tail)]) from None
            if len(columns[c.T_S]):
                yield at, columns
            row = at + len(columns[c.T_S])
        row = cut.next_row or row
    if (said := header_again_note(np.asarray(cut.rows, dtype=np.int64))) is not None:
        lay.notes.append(said)
    if (said := lay.fix_status_note(file)) is not None:
        lay.notes.append(said)
    if row - 1 <= len(cut.rows):  # no row, or the header's line again only
        raise InputError([no_data_rows(file)])


class _HeaderAgain:
    """Whole lines of a stream split around the lines that repeat its header (and the
    units row under one, where the header has one), counting rows as :func:`parse_lines`
    does (blank lines are not rows).

    Attributes:
        rows: the data rows (1-based) that repeat the header, so far.
        next_row: the data row of the line after the last lines split (None: they hold no
            such line and are one part, whose rows the caller counts as it parses them).
    """

    def __init__(self, header: bytes | None, units: bytes | None) -> None:
        self._header, self._units = header, units
        self._after = False  # the last row was the header again: a units row may follow
        self.rows: list[int] = []
        self.next_row: int | None = None

    def parts(self, lines: bytes, row: int) -> list[tuple[int, bytes]]:
        """``lines`` (from data row ``row`` on) as ``(first_row, lines)`` parts without the
        header's lines again; :attr:`next_row` is the row after them."""
        from rwhonet.data.csvio import line_key

        if not self._header or (self._header not in lines and not self._after):
            self.next_row = None  # the rows parse_lines reads from them: the caller counts
            return [(row, lines)]
        parts: list[tuple[int, bytes]] = []
        part: list[bytes] = []
        start = row
        for line in lines.splitlines(keepends=True):
            if not line.strip():
                part.append(line)
                continue
            key = line_key(line)
            if key == self._header or (self._after and key == self._units):
                if part:
                    parts.append((start, b"".join(part)))
                self.rows.append(row)
                self._after, part, row = key == self._header, [], row + 1
                start = row
                continue
            self._after = False
            part.append(line)
            row += 1
        if part:
            parts.append((start, b"".join(part)))
        self.next_row = row
        return parts


def parse_lines(
    lines: bytes, lay: Layout, first_row: int, file: str, form: _TimeForm | None = None
) -> dict[str, np.ndarray]:
    """Parse whole CSV lines into the layout's channels (blank lines skipped).

    The fast path is numpy's C parser on the wanted columns; a block it refuses
    (a missing value, a stray cell, a short row) is parsed line by line, which
    names every problem's row and column. A time written as text (``form``) is parsed
    by :mod:`rwhonet.data.texttime` once the numbers are read.
    """
    text = lines.decode("utf-8", errors="replace")
    text_time = form is not None and form.text is not None
    names = [n for n in lay.positions if not (text_time and n == c.T_S)]
    cols = [lay.positions[n] for n in names]
    commas = {line.count(",") for line in _nonblank(text)}
    try:
        if not commas:
            values = np.zeros((0, len(cols)))
        elif commas != {lay.n_columns - 1}:
            raise ValueError("rows with another number of columns than the header")
        else:
            values = np.loadtxt(
                io.StringIO(text),
                delimiter=",",
                usecols=cols,
                ndmin=2,
                comments=None,
                quotechar='"',  # cells written quoted ("0.000"), as MoTeC i2 exports them
                dtype=np.float64,
            )
    except ValueError:
        values = _parse_slow(text, lay, cols, first_row, file)
    for i, name in enumerate(names):
        if name in lay.linear:  # raw numbers: in the file's unit first, as ingest reads them
            from rwhonet.data.columnmap import scaled

            values[:, i] = scaled(values[:, i], lay.linear[name])
    out = {
        name: values[:, i] * lay.factors[name] if lay.factors[name] != 1.0 else values[:, i]
        for i, name in enumerate(names)
    }
    for name, (unit, setting) in lay.packed.items():
        if name in out:
            rows = first_row + np.arange(len(out[name]))
            out[name] = unpack_or_refuse(out[name], unit, file, lay.names[name], rows, setting)
    out |= signed_coordinates(
        {
            name: (
                out[name],
                _column_cells(text, pos),
                unit,
                (lay.names[name].strip(), column.strip()),
                setting,
            )
            for name, (pos, unit, column, setting) in lay.hemispheres.items()
            if name in out
        },
        file,
        first_row,
    )
    if lay.fix_status is not None:
        from rwhonet.data.fixstatus import FIX_STATUS, refuse_bad_codes, screen, text_codes

        unit, setting, column, text_at = lay.fix_status
        rows = first_row + np.arange(len(out[c.LAT_DEG]))
        if text_at is not None:  # letters or words: read from the lines' cells
            cells = _column_cells(text, text_at)
            out[FIX_STATUS] = text_codes(cells, unit, file, column.strip(), rows, setting)
        refuse_bad_codes(out[FIX_STATUS], unit, file, column.strip(), rows, setting)
        out = screen(out, unit, lay.fix_counts)
    if text_time:
        assert form is not None and form.text is not None
        out[c.T_S] = _text_times(text, lay, first_row, file, form)
    if lay.date is not None and len(out[c.T_S]):
        pos, unit, column, setting = lay.date
        dates = parse_dates(_column_cells(text, pos), unit)
        check_dates(dates, file, column.strip(), unit, first_row, setting)
        out[c.T_S] = out[c.T_S] + dates.seconds
    return out


def _text_times(text: str, lay: Layout, first_row: int, file: str, form: _TimeForm) -> np.ndarray:
    """The time column of whole lines (their columns already checked) written as text."""
    from rwhonet.data.texttime import check_text_times, parse_text_times

    cells = _column_cells(text, lay.positions[c.T_S])
    assert form.text is not None
    parsed = parse_text_times(cells, form.text, form.zoned)
    check_text_times(parsed, cells, file, lay.names[c.T_S], form.text, first_row)
    form.zoned = parsed.zoned
    return parsed.seconds


def _column_cells(text: str, pos: int) -> list[str]:
    """One column's cells of whole lines (their columns already checked), as text."""
    if '"' in text:  # quoted cells (a decimal comma in one): the csv module splits them
        return [cells[pos] for cells in csv.reader(_nonblank(text))]
    return [line.split(",")[pos] for line in _nonblank(text)]


def _nonblank(text: str) -> Iterator[str]:
    return (line for line in text.splitlines() if line.strip())


def _parse_slow(text: str, lay: Layout, cols: list[int], first_row: int, file: str) -> np.ndarray:
    """Line by line: missing values as NaN, every other problem named with its row."""
    from rwhonet.data.csvio import cell_names, columns_expected, is_header_like, restarted_problem

    out, problems = [], []
    names = cell_names(",".join(lay.header))
    for i, cells in enumerate(csv.reader(_nonblank(text))):
        row = first_row + i
        if is_header_like(cells, names) and [x.strip().lower() for x in cells] != names:
            # the header again with other columns or another order, as ingest says it
            problems.append(restarted_problem(file, row, ",".join(cells)))
            continue
        if len(cells) != lay.n_columns:
            problems.append(
                Problem(
                    file,
                    row,
                    None,
                    columns_expected(lay.n_columns, lay.trailing_cell, lay.short_rows),
                    f"{len(cells)} column(s): {','.join(cells)[:60]!r}",
                    "give every row the header's columns (a cut-off last row, a stray comma, or a "
                    "decimal comma?)",
                )
            )
            continue
        values = []
        for pos in cols:
            cell = cells[pos].strip()
            if cell.lower() in c.MISSING_CELLS:
                values.append(np.nan)
                continue
            try:
                values.append(float(cell))
            except ValueError:
                name = next(n for n, p in lay.positions.items() if p == pos)
                problems.append(
                    Problem(
                        file,
                        row,
                        lay.names[name],
                        "a number",
                        repr(cells[pos]),
                        "replace the text by a number ('.' as the decimal mark), or leave the cell "
                        "empty for a missing value",
                    )
                )
                values.append(np.nan)
        out.append(values)
        if len(problems) >= 20:
            break
    if problems:
        raise InputError(problems, f"{len(problems)} problem(s) reading {file}")
    return np.asarray(out, dtype=np.float64).reshape(len(out), len(cols))
