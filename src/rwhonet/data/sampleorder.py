"""A stream's samples written twice or out of time order, put right where that is safe.

The 10 Hz readers drop a row written again (:mod:`rwhonet.data.droprows`); a stream
(one CSV file per message, an MDF4 channel group: :mod:`rwhonet.data.signalmap`; a
comma2k19 segment's channel: :mod:`rwhonet.data.comma2k19`) was
refused for it, and for samples written out of their time order, which loggers do too:
a buffer flushed twice after a retry, a logger that merges its receive buffers (two
FIFOs, two interfaces) in arrival order rather than by time stamp. Here, per stream:

1. **Copies.** A sample equal to an earlier one in its time and every channel (NaN equal
   to NaN) holds nothing new; it is dropped, as the 10 Hz readers drop a row written
   again (:func:`rwhonet.data.droprows.repeated_rows`).
2. **Out of order.** The samples left are put in time order where the order is all that
   is wrong: sorted, no samples may crowd closer than the stream has them, and no step
   may open longer than 1.5 of its median that the file's forward steps lacked. Samples
   written late, a file shuffled, a stream's files joined out of order: each sample fills
   the slot the stream's rate left for it, and sorting closes the steps the disorder
   opened. A clock that went back (a restart, a clock set back by NTP or by the
   receiver's time after boot) makes two recordings overlap in time, and sorting would
   crowd them into one at twice the rate, or, set back further than it had run, leaves
   a gap between them that neither had; a sample stamped wrongly lands beside another's
   slot and leaves its own empty. Each is left as written, and refused by the stream
   checks (:func:`rwhonet.data.streams.check_streams`), naming the file's row. (A table's
   rows, wheels and fixes in each, tell more: where the fixes show the car going on
   through a step back, its clock is put right, :func:`clock_set_back`.)
   *Crowding* is judged by short steps (under 0.6 of the median) for a regularly stamped
   stream, by density (samples per 4 median steps) for a jittered one, whose own short
   steps a reordering breaks up (:func:`_crowded`): in a jittered stream a clock set back
   by less than three periods, or one sample stamped wrongly, can be sorted in.
3. **A time twice with other values** (a clock that stuck) is no copy and has no order:
   refused as before.

Every message after it still names the source's row: the stream carries each sample's
row (:attr:`rwhonet.data.streams.Stream.rows`). A stream already in order costs one
comparison of its times.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.droprows import FileRows, manifest_rows, repeated_rows
from rwhonet.data.timebase import coarse_places, run_slots
from rwhonet.geo.geodesic import geodesic_distance_m, local_step_distance_m

# Sorting may not bring two samples closer than this share of the stream's median step
# unless the file already had them so close. A clock set back by anything but a whole
# number of periods puts each sample of the overlap at most half a period from another's
# (a whole number: at the same times, refused as a time twice); samples written late
# fill their own slots, a period from the next (jitter of a few % aside).
CROWDED_SHARE = 0.6
# Nor open a step longer than this share of it that the file's forward steps did not have
# (two recordings one before the other leave a gap between them; a sample stamped far off
# leaves its slot empty; samples written late leave none once sorted).
GAP_SHARE = 1.5
# A stream whose steps within runs in order are this regular (their interquartile range
# at most this share of their median, none short) is judged by its short steps; a
# jittered one (or one with too few such steps to tell) by the density of its samples.
REGULAR_SPREAD = 0.1
REGULAR_MIN_STEPS = 20
WINDOW_STEPS = 4
ROWS_NOTED = 5
# A clock set back during a drive (:func:`clock_set_back`): the rows after each step back
# must run on in order for this many rows (a row or a few stamped wrongly are no clock
# set back); the fixes either side of it, each within STEP_FIX_ROWS rows of it, must lie
# within STEP_REACH times the farthest the fixes around moved a row, over the rows
# between them, and STEP_FIX_M (a receiver's noise); the rows after it are put this far
# after the rows before, a gap that ends a run of seconds (timebase.RUN_GAP_PERIODS) and
# validate's segment (validate.gnss.max_gap_s, 0.5 s by default)
STEP_RUN_ROWS = 20
STEP_FIX_ROWS = 10
STEP_NEAR_ROWS = 20
STEP_REACH = 1.5
STEP_FIX_M = 5.0
STEP_GAP_S = 1.0
# A jitter beside a step may have it found this many rows off the row where the clock
# went back (its fixes are judged beyond them)
STEP_SLACK_ROWS = 2


@dataclass(frozen=True)
class Order:
    """What :func:`time_order` did to a stream.

    Attributes:
        index: the samples kept, in time order (0-based positions in the stream as read);
            None where the stream is left as it is.
        notes: what the reader says (copies dropped, samples put in order).
    """

    index: np.ndarray | None
    notes: tuple[str, ...] = ()


def time_order(
    t_s: np.ndarray,
    channels: Mapping[str, np.ndarray],
    rows: np.ndarray | None,
    where: str,
) -> Order:
    """A stream's copies dropped and its samples put in time order, where safe.

    Args:
        t_s: the sample times as read.
        channels: the values, one array per channel, one element per sample.
        rows: each sample's row in its source, 1-based (None: sample ``i`` is row ``i + 1``).
        where: the stream as messages name it.

    Returns:
        The order to take the samples in, or None where the stream stays as it is (in
        order already; a time that is not finite or repeats with other values, or an
        order sorting would crowd: the stream checks refuse those).
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.size < 2 or not np.isfinite(t).all():
        return Order(None)
    if (t[1:] > t[:-1]).all():
        return Order(None)
    row = np.arange(1, t.size + 1) if rows is None else np.asarray(rows)
    copies = repeated_rows({"t_s": t, **channels})
    keep = np.ones(t.size, dtype=bool)
    keep[copies] = False
    index = np.flatnonzero(keep)
    notes = []
    if copies.size:
        notes.append(
            f"{where}: {copies.size} sample(s) repeat an earlier sample in every channel, "
            f"the time included ({_listed(row[copies])}): written again, dropped"
        )
    kept = t[index]
    if (kept[1:] > kept[:-1]).all():
        return Order(index, tuple(notes))
    order = np.argsort(kept, kind="stable")
    ordered = kept[order]
    step = np.diff(ordered)
    if not (step > 0).all():  # a time twice with other values: refused as it is
        return Order(index if copies.size else None, tuple(notes))
    before = np.maximum.accumulate(kept)
    late = np.flatnonzero(np.r_[False, kept[1:] < before[:-1]])
    by = float(np.max(before[late - 1] - kept[late]))
    median = float(np.median(step))
    if _crowded(kept, ordered, step, median) or _opened(kept, step, median):
        return Order(index if copies.size else None, tuple(notes))
    notes.append(
        f"{where}: {late.size} sample(s) written after a later one (up to {by:.3g} s "
        f"late: {_listed(row[index[late]])}) put in time order (sorted, no samples crowd "
        "closer than the stream's own and no gap opens that the file's order did not "
        "have: a reordering, not a clock gone back)"
    )
    return Order(index[order], tuple(notes))


def _crowded(kept: np.ndarray, ordered: np.ndarray, step: np.ndarray, median: float) -> bool:
    """Whether sorting crowds samples closer than the stream has them.

    A stream whose steps within its runs in order are regular (their interquartile range
    at most :data:`REGULAR_SPREAD` of their median, none under :data:`CROWDED_SHARE` of
    it: a logger that stamps in hardware) may have no more such short steps sorted than
    forward in the file's order. A jittered stream (a phone's or a simulator's CAN
    stamps, steps from a small fraction of the period to twice it) has short steps of its
    own, which a reordering breaks up in the file's order; for it the test is density: no
    window of :data:`WINDOW_STEPS` median steps may hold more samples sorted than any
    such window of a run in the file's order holds (or ``WINDOW_STEPS + 2``: a stream of
    that rate with any jitter under half a period has at most ``WINDOW_STEPS + 1`` in a
    window of ``WINDOW_STEPS`` periods, and its median step may be a little longer than
    its period). Two stretches overlapping (a clock set back by three periods or more)
    hold about twice as many.
    """
    short = CROWDED_SHARE * median
    run = np.r_[0, np.cumsum(kept[1:] <= kept[:-1])]  # a new run at each step back
    forward = np.diff(kept)
    in_run = forward[run[1:] == run[:-1]]
    if in_run.size >= REGULAR_MIN_STEPS:
        q1, mid, q3 = np.percentile(in_run, [25, 50, 75])
        if q3 - q1 <= REGULAR_SPREAD * mid and not (in_run < short).any():
            return int((step < short).sum()) > int(((forward > 0) & (forward < short)).sum())
    width = WINDOW_STEPS * median
    sorted_count = np.searchsorted(ordered, ordered + width, side="left") - np.arange(ordered.size)
    # the same count within each run: runs laid end to end on one axis, apart by more
    # than a window, so no window reaches from one into the next
    span = float(ordered[-1] - ordered[0]) + 2.0 * width + 1.0
    axis = run * span + (kept - ordered[0])
    run_count = np.searchsorted(axis, axis + width, side="left") - np.arange(axis.size)
    bound = max(WINDOW_STEPS + 2, int(run_count.max()))
    return int(sorted_count.max()) > bound


def _opened(kept: np.ndarray, step: np.ndarray, median: float) -> bool:
    """Whether sorting opens more steps longer than :data:`GAP_SHARE` of the median than the
    file's forward steps have (two stretches one before the other leave a gap between
    them; a sample stamped far off leaves its slot empty)."""
    long = GAP_SHARE * median
    forward = np.diff(kept)
    return int((step > long).sum()) > int((forward > long).sum())


def _listed(rows: np.ndarray) -> str:
    shown = ", ".join(str(int(r)) for r in rows[:ROWS_NOTED])
    more = f" and {rows.size - ROWS_NOTED} more" if rows.size > ROWS_NOTED else ""
    return f"row(s) {shown}{more}"


def rows_in_time_order(raw: RawDrive, file: str, period_s: float) -> RawDrive:
    """A 10 Hz file's rows put in time order where that is all that is wrong, as a
    stream's samples are (:func:`time_order`): exports of a drive joined in the wrong
    order, a table sorted by another column, a logger writing two buffers in turn.

    Rows whose stamps a jitter turned back are not out of order: the slots the rows' order
    gives them rise (:func:`rwhonet.data.timebase.run_slots`), and they stay as written.

    Args:
        raw: the drive as its reader read it, its copies and rows without a wheel speed
            dropped (:func:`rwhonet.data.droprows.drop_rows`), its clock continuous.
        file: the file as the user knows it, for the notes.
        period_s: the sample period.

    Where sorting is not safe, a clock set back during the drive is put right where the
    rows went on as the car did (:func:`clock_set_back`).

    Returns:
        ``raw`` itself where its rows are in order, or neither sorting nor a clock set
        back puts them right (a second recording, a row stamped wrongly: validate
        refuses it, naming the rows); else the drive in time order, ``row_order`` giving
        each row's file row, the notes saying so.
    """
    t = raw.columns[c.T_S]
    if not out_of_order(t, period_s):
        return raw
    file_row = FileRows.of(manifest_rows(raw))(np.arange(raw.n_rows))
    order = time_order(t, raw.columns, file_row, file)
    if order.index is None or order.index.size != t.size:
        return clock_set_back(raw, file_row, file, period_s)
    return replace(
        raw,
        columns={k: v[order.index] for k, v in raw.columns.items()},
        notes=(*raw.notes, *order.notes),
        row_order=file_row[order.index],
    )


def out_of_order(t_s: np.ndarray, period_s: float) -> bool:
    """Whether a 10 Hz drive's finite times are out of order beyond a jitter the rows'
    order places: not rising, nor their slots on the grid
    (:func:`rwhonet.data.timebase.run_slots`)."""
    t = np.asarray(t_s, dtype=np.float64)
    if t.size < 2 or not np.isfinite(t).all() or (np.diff(t) > 0).all():
        return False
    return not (np.diff(run_slots(t, period_s)[0]) > 0).all()


def clock_set_back(raw: RawDrive, file_row: np.ndarray, file: str, period_s: float) -> RawDrive:
    """A 10 Hz drive whose clock was set back while it logged, put on one clock.

    A logger's clock is stepped back by NTP or by a GNSS receiver's time (``ntpd`` steps
    any offset over 128 ms), or by summer time ending where it logs local time: the rows
    go on as the car did, and their stamps go back. Sorting would crowd the two stretches
    into one (:func:`time_order`), and validate refused the drive ("time goes
    backwards"). Here each step back (a row whose slot on the grid is not after the slot
    of the row before: :func:`rwhonet.data.timebase.run_slots`; where a jitter leaves a
    row or two beside it so too, the steepest step back among them) is taken for a clock
    set back where

    - the rows after it run on in time order for at least :data:`STEP_RUN_ROWS` rows,
      as the rows before it do, and the :data:`STEP_RUN_ROWS` rows either side of it
      each a period after the one before (a row or a few stamped wrongly, whose clock
      then goes on as it was, and a clock that stuck, whose next row is two periods on,
      are no clock set back);
    - the car went on: the last fix before it and the first after it (each within
      :data:`STEP_FIX_ROWS` rows) lie within :data:`STEP_REACH` times the farthest the
      fixes around (:data:`STEP_NEAR_ROWS` rows either side) moved in a row, over the rows
      between them, plus :data:`STEP_FIX_M`. A second recording appended to the first
      (another place, another time) is not.

    The rows after each such step are then put on by whole seconds, the fewest that leave
    at least :data:`STEP_GAP_S` after the last row before it: a gap that ends a run of
    seconds and validate's segment there, so the seconds around the step, whose true
    length the stamps no longer tell, are cut, and each side keeps its own rows, in the
    file's order, and its seconds as its clock counts them (whole seconds keep where
    each second begins). The notes say where, by how much the clock went back, and how
    far on the later rows were put (their times are the logger's plus that).

    Args:
        raw: the drive, its copies dropped (by :func:`rows_in_time_order`'s caller).
        file_row: each row's data row in the file (1-based).
        file: the file as the user knows it, for the notes.
        period_s: the sample period.

    Returns:
        ``raw`` itself where any step back is not so (validate refuses it, naming the
        row), else the drive on one clock, ``row_order`` its file rows, the notes saying
        so.
    """
    t = np.asarray(raw.columns[c.T_S], dtype=np.float64)
    nan = np.full(t.size, np.nan)
    lat = np.asarray(raw.columns.get(c.LAT_DEG, nan), dtype=np.float64)
    lon = np.asarray(raw.columns.get(c.LON_DEG, nan), dtype=np.float64)
    got = clock_steps(t, lat, lon, file_row, period_s)
    if got is None:
        return raw
    new, said = got
    return replace(
        raw,
        columns={**raw.columns, c.T_S: new},
        notes=(*raw.notes, f"{file}: {said}"),
        row_order=np.asarray(file_row, dtype=np.int64),
    )


def clock_steps(
    t_s: np.ndarray, lat: np.ndarray, lon: np.ndarray, file_row: np.ndarray, period_s: float
) -> tuple[np.ndarray, str] | None:
    """The times of rows whose clock was set back put on one clock, and what to say, by
    the rule of :func:`clock_set_back`; None where a step back is not so.

    Args:
        t_s: the rows' times, s, in the file's order.
        lat, lon: their fixes, deg (NaN: none).
        file_row: each row's data row in the file (1-based), for the note.
        period_s: the rows' period (the grid's; a faster table's own:
            :func:`rwhonet.data.fastfile.as_streams`).
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.size < 2 * STEP_RUN_ROWS or not np.isfinite(t).all():
        return None
    # where the rows' slots do not rise; a jitter beside a step may add a row or two
    # there, so each cluster's step is its steepest step back
    back = np.flatnonzero(np.diff(run_slots(t, period_s)[0]) <= 0) + 1
    if not back.size:
        return None
    cluster = np.r_[0, np.cumsum(np.diff(back) >= STEP_RUN_ROWS)]
    dt = np.diff(t)
    steps = []
    for k in range(int(cluster[-1]) + 1):
        near = back[cluster == k]
        i = int(near[0]) + int(np.argmin(dt[near[0] - 1 : near[-1]]))
        # a clock set back: the time goes back, or on by under half a period (0.13 s back
        # under 20 ms of jitter), and the rows after it stay back
        if dt[i - 1] < 0.5 * period_s and _stayed_back(t, i, period_s):
            steps.append(i)
        # else rows the whole drive's slots could not place beside a real step (their
        # phase between the stretches'): each stretch's own slots judge them below
    if not steps:
        return None
    bounds = np.r_[0, steps, t.size]
    if np.diff(bounds).min() < STEP_RUN_ROWS:
        return None
    for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
        # each stretch in order, its rows nearest a step each a slot after the one before
        rise = np.diff(run_slots(t[a:b], period_s)[0])
        after = rise[: STEP_RUN_ROWS - 1] if a > 0 else rise[:0]
        before = rise[-(STEP_RUN_ROWS - 1) :] if b < t.size else rise[:0]
        if (rise <= 0).any() or (after != 1).any() or (before != 1).any():
            return None
    if not all(_went_on(lat, lon, i) for i in steps):
        return None
    new = t.copy()
    said = []
    for i, stop in zip(steps, bounds[2:].tolist(), strict=True):
        shift = float(math.ceil(round(float(new[i - 1] - t[i]) + STEP_GAP_S, 6)))
        new[i:stop] = t[i:stop] + shift
        said.append(
            f"row {int(file_row[i])} ({round(float(t[i - 1] - t[i]) + period_s, 3):g} s back, "
            f"its rows {shift:.6g} s later)"
        )
    if out_of_order(new, period_s):  # rising, or slots a jitter's rows' order gives
        return None
    return new, (
        f"the clock set back during the drive at {len(said)} row(s), the rows on either "
        f"side going on as the car did (an NTP step, summer time ending): "
        f"{'; '.join(said)}: each step's rows put on by whole seconds, at least "
        f"{STEP_GAP_S:g} s after the rows before it, the seconds around it cut"
    )


def _stayed_back(t: np.ndarray, i: int, period_s: float) -> bool:
    """Whether the rows from row ``i`` on run at least half a period behind the clock of
    the rows before it: the median of each side's stamps less their rows' periods
    (:data:`STEP_RUN_ROWS` rows a side). A jitter's one short step (under a bell curve
    of 20 ms, 4 % of rows step under half a period) leaves the two alike: their
    medians differ by 8 ms (one standard deviation) at 20 ms."""
    lo, hi = max(i - STEP_RUN_ROWS, 0), min(i + STEP_RUN_ROWS, t.size)
    off = t[lo:hi] - t[lo] - period_s * np.arange(hi - lo)
    return bool(np.median(off[i - lo :]) <= np.median(off[: i - lo]) - 0.5 * period_s)


def _went_on(lat: np.ndarray, lon: np.ndarray, i: int) -> bool:
    """Whether the fixes either side of row ``i`` (the first row after a step back) show
    the car going on, not a second recording (:func:`clock_set_back`). A jitter may have
    the step found up to :data:`STEP_SLACK_ROWS` rows off the row where the clock went
    back: the fixes are taken that far beyond it either side, and so are the rows whose
    moves say how far the car goes in a row."""
    ok = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90.0)
    end, start = max(i - STEP_SLACK_ROWS, 0), min(i + STEP_SLACK_ROWS, lat.size)
    before = np.flatnonzero(ok[max(end - STEP_FIX_ROWS, 0) : end])
    after = np.flatnonzero(ok[start : start + STEP_FIX_ROWS])
    if not before.size or not after.size:
        return False
    a = max(end - STEP_FIX_ROWS, 0) + int(before[-1])
    b = start + int(after[0])
    moved = 0.0  # the farthest the fixes around moved a row, each side apart
    for lo, hi in (
        (max(end - STEP_NEAR_ROWS, 0), end),
        (start, min(start + STEP_NEAR_ROWS, lat.size)),
    ):
        rows = lo + np.flatnonzero(ok[lo:hi])
        if rows.size >= 2:
            d = local_step_distance_m(lat[rows], lon[rows])
            moved = max(moved, float(np.max(d / np.diff(rows))))
    gap = float(geodesic_distance_m(lat[a], lon[a], lat[b], lon[b]))
    return gap <= STEP_REACH * moved * (b - a) + STEP_FIX_M


def coarse_stamps_placed(raw: RawDrive, file: str, period_s: float) -> RawDrive:
    """A 10 Hz file whose stamps are coarser than its rows (``hh:mm:ss`` without the
    fraction: the ten rows of a second share one stamp) placed a period apart after each
    stamp, in the file's order (:func:`rwhonet.data.timebase.coarse_places`), before its
    copies are told (rows at a standstill that share a stamp are no copies); the rows of
    a second whose stamp holds fewer (a sample lost: which, the stamps do not tell) left
    out as ``untimed_rows``; the note says so. Else ``raw`` itself (validate refuses a
    time twice, naming the row): also where most rows that share a stamp repeat the row
    before them in every column, rows written twice (a 5 Hz drive so written is no 10 Hz
    drive stamped to 0.2 s: its copies are dropped, and validate names its rate)."""
    got = coarse_places(raw.columns[c.T_S], period_s)
    if got is None or _mostly_copies(raw.columns):
        return raw
    placed, q, untimed = got
    n = round(q / period_s)
    note = (
        f"{file}: time stamps to {q:g} s, coarser than its rows ({n} a stamp, one every "
        f"{period_s:g} s): each stamp's rows placed {period_s:g} s apart after it, in the "
        f"file's order (the second up to the next stamp; the first stamp's rows in its "
        "last slots). Stamps rounded to the nearest "
        f"{q:g} s (a spreadsheet's) rather than cut put the seconds up to {q / 2:g} s late"
    )
    columns = {**raw.columns, c.T_S: placed}
    rows = np.zeros(0, dtype=np.int64)
    if untimed.any():
        at = np.flatnonzero(untimed)
        rows = FileRows(raw.header_rows)(at)
        stamps = np.unique(raw.columns[c.T_S][at]).size
        columns = {k: v[~untimed] for k, v in columns.items()}
        note += (
            f"; {rows.size} row(s) of {stamps} stamp(s) holding fewer than {n} "
            f"({_listed(rows)}): samples lost, which the "
            "stamps do not tell, so their times are unknown: left out, their seconds and the "
            "next cut"
        )
    return replace(raw, columns=columns, notes=(*raw.notes, note), untimed_rows=rows)


def _mostly_copies(columns: Mapping[str, np.ndarray]) -> bool:
    """Whether most rows at the time of the row before them repeat an earlier row in every
    column, the time included (:func:`rwhonet.data.droprows.repeated_rows`): rows written
    twice, not the rows of a stamp to the second."""
    t = columns[c.T_S]
    same = int(np.count_nonzero(t[1:] == t[:-1]))
    return bool(same and repeated_rows(columns).size * 2 > same)
