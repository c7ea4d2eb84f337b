"""A drive's clock: midnight rollover, and each row's slot on the sample grid.

Two things real loggers do to a time column that the per-second logic must not
mistake for bad data:

- **Midnight.** IO-VNBD time is seconds since the start of the day, so a drive
  across midnight steps from about 86399.9 back to about 0.
  :func:`unwrap_midnight` adds a day to every row after such a step, so the
  drive reads as one continuous clock (times after midnight then exceed
  86400 s; manual cuts and scenario intervals of such a drive are in that
  continuous clock).
- **The GPS week's end.** A time column in GPS time of week (a u-blox receiver's iTOW)
  steps from about 604799.9 back to about 0 each Sunday 00:00 GPS time; the same rule adds
  a week (:func:`unwrap_clock`).
- **Jitter.** A CAN logger stamps each row when it writes it, a few
  milliseconds off the nominal instant (still strictly increasing). A row
  stamped 4 ms before a whole second belongs to that second, one stamped 4 ms
  after it to the next, so plain rounding of the stamps fills seconds with 9 or
  11 rows. :func:`grid_slots` puts every row on the drive's own sample grid
  instead: its *slot* is the nearest grid instant, ``phase + j * period``, where
  the phase is the middle of the arc the stamps fill modulo the period, its 2 % at either
  end left out (stamps on whole tenths give phase 0, a few rows written 40 ms late among
  them too; a logger offset by 30 ms keeps its 30 ms). Jitter
  below half a period is removed as long as the stamps leave part of that circle
  empty: at up to 45 % of a period, a few hundred stamps always do (test_timebase).
  A dropped sample still leaves a slot empty (two slots between consecutive rows),
  so a real dropout is never hidden.
- **A logger restarted.** A logger that stops and starts again stamps the rows after its
  restart on a phase of their own (48 ms into each tenth where they were on whole
  tenths). Each run between steps longer than :data:`RUN_GAP_PERIODS` periods is placed on
  its own phase (:func:`nominal_times`, :func:`run_bounds`; :class:`StreamClock` for a
  drive read in blocks), as the label places each segment.
- **Jitter past half a period.** A logger whose stamps scatter wider (a busy phone or
  laptop logger: tens of ms at 10 Hz, the tails of a bell curve) puts now and then a row
  in its neighbour's slot, two rows in one, or a stamp before the one above it. The rows'
  order in the file is still the order the samples were taken, so where the nearest slots
  do not rise row by row, the rows around (:data:`REPAIR_ROWS` either side) are given the
  rising slots nearest their stamps (least squares: :func:`_rising_slots`). That is done
  only where every row so placed stays within a period of its stamp (within half a
  period, the nearest slot, where the stamps around are not jittered: :func:`jitter_reach`):
  two rows swapped whole periods apart, one row stamped far off on a drive stamped on its
  grid, a clock set back, a second recording are left as they are, and refused as
  before. The grid's phase is then the mean of the stamps' offsets from their slots,
  their arc being most of the circle (:func:`grid_phase`). Stamps on whole multiples are
  never moved. Measured (stop 67, V-Delta2's clock, stamps to the ms):
  a bell curve of 15, 20 and 25 ms puts 31, 475 and 1,594 of 35,927 rows nearest another
  row's slot; every row gets its own. At 30 ms and over the drive is refused.

The slots assume the sampling clock is the time column's clock, as on the
GPS-disciplined loggers of IO-VNBD; a logger whose rate differs from
``1 / period`` slips through the grid and its seconds come out partial where
it slips, as they did before.
"""

from __future__ import annotations

import itertools

import numpy as np

SECONDS_PER_DAY = 86400.0
# GPS time of week (a u-blox receiver's iTOW, many loggers' "GPS time") starts again at 0
# each Sunday 00:00 GPS time: the week's end is a rollover as midnight is a day's.
SECONDS_PER_WEEK = 7 * SECONDS_PER_DAY
# A step back from the last hour of a day into the first hour of the next is a midnight
# rollover (the true step across midnight is then shorter than an hour); any other
# backward step is left for validate to report.
MIDNIGHT_WINDOW_S = 3600.0
# Stamps whose grid phase lies within this fraction of a period of whole multiples of the
# period are on the whole grid: a few milliseconds of logger latency move no second boundary.
WHOLE_GRID_FRACTION = 0.1
PHASE_SAMPLE = 100_000  # stamps the phase is estimated from (evenly spread over the drive)
# Stamps whose widest empty arc modulo the period is narrower than this share of it spread
# over most of the circle (a bell curve's jitter, whose tails may pass half a period): their
# phase is the mean of their offsets from the slots of the arc's middle, taken twice
# (unbiased for any jitter symmetric about the slots); the arc's middle alone, exact for a
# tight jitter, rests on the tails there (200 stamps of 15 ms put it 9 ms off).
WIDE_ARC_SHARE = 0.5
# The stamps at either end of a narrower arc left out of its middle (:func:`grid_phase`):
# a logger's hiccups, a row written tens of ms late among stamps on their grid, whose
# farthest stamp would otherwise set the arc's end (of the 200 stamps a run's phase is
# taken from, the 4 farthest either way)
ARC_TRIM_SHARE = 0.02
# Rows either side of a place where the nearest slots do not rise that are placed again
# together (:func:`_rising_slots`): a row late by more than half a period and the row it
# crowds, and those beside them.
REPAIR_ROWS = 3
# How far from its stamp a row may be placed: less than a period where the stamps are
# jittered (their spread, 1.4826 MAD of their offsets from the nearest slots, at least this
# share of a period), half a period (the nearest slot) where they are on their grid: a
# drive stamped on its grid but for one row far off is no jitter, that row is left and
# refused. The spread is that of the rows around the place (:data:`SPREAD_ROWS` either side
# of the stretch placed together), not the drive's: a logger that gets busy an hour into a
# drive jitters from there on, and the rows one reader has at hand (predict's blocks, the
# label's segment) must give the same rows the same reach. Two values, not a multiple of
# the spread, so that a spread measured on a few dozen rows decides no more than which.
JITTERED_SPREAD = 0.02
MAX_REACH = 0.99
# Rows whose nearest slots do not rise and that no reach places (:func:`_written_late`)
# are taken for rows a logger wrote late where the stamps beside them spread by less than
# this share of a period (15 ms at 10 Hz: a row a period off is then more than six
# standard deviations out, no jitter's; under a bell curve of 20 ms and more, rows
# crowding may be its tails, and are left)
LATE_SPREAD = 0.15
SPREAD_ROWS = 16
# A step longer than this many periods (0.5 s at 10 Hz, validate.gnss.max_gap_s's default,
# where validate ends a segment): a logger that stopped and started again, its stamps on a
# phase of their own. Each run between such steps is placed on its own grid phase.
RUN_GAP_PERIODS = 5.0
TIME_EPS_S = 1e-6  # decimal time stamps stored as floats are within this of the true value
# A row beside a dropped sample (a slot left empty within a run) whose stamp lies more than
# this share of a period from its slot toward the empty one: its stamp may be off by more
# than half a period the other way, and the row the dropped sample's. Such a row is no
# fix a second may start or end on (:func:`leans_into_drop`; the label's ``drop_edge``
# rule, ``rwhonet predict``'s seconds). A quarter period: under a bell curve of 25 ms at
# 10 Hz, a row placed a slot off beside a drop leans further than that with a chance of
# 94 % (99 % at 20 ms; a normal's tails), and stamps within 25 ms of their slots (a
# logger's few ms) never do.
DROP_LEAN_SHARE = 0.25
# The column a drive read block by block carries each row's stamp less its placed time in
# (s; :func:`rwhonet.data.incremental.placed`), for ``rwhonet predict``'s seconds
STAMP_LEAN = "stamp_lean_s"
# Rows a run's grid phase is estimated from (a stream's before its first times are placed:
# with fewer, the stamps' arc may not yet show where the phase lies); a whole drive's runs
# take theirs from the same rows, so both place every row alike
STREAM_PHASE_ROWS = 200


def unwrap_midnight(
    t_s: np.ndarray, day_s: float = SECONDS_PER_DAY
) -> tuple[np.ndarray, np.ndarray]:
    """Make a time-of-day column continuous across midnight.

    A step from ``t >= day_s - MIDNIGHT_WINDOW_S`` to ``t' < MIDNIGHT_WINDOW_S`` whose true
    length ``t' + day_s - t`` is positive and at most ``MIDNIGHT_WINDOW_S`` is a rollover:
    ``day_s`` is added to every later row (twice after two midnights).

    Args:
        t_s: times, s (time of day; NaN allowed, never taken for a rollover).
        day_s: length of the day in the column's unit.

    Returns:
        ``(t_s continuous, rows)``: a new float64 array, and the 0-based rows that follow a
        rollover (empty when none; then the times are returned unchanged).
    """
    t = np.array(t_s, dtype=np.float64)
    if t.size < 2:
        return t, np.zeros(0, dtype=np.int64)
    before, after = t[:-1], t[1:]
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: no rollover, validate says
        true_step = after + day_s - before
    wrap = (
        (before >= day_s - MIDNIGHT_WINDOW_S)
        & (after < MIDNIGHT_WINDOW_S)
        & (true_step > 0)
        & (true_step <= MIDNIGHT_WINDOW_S)
    )
    rows = np.flatnonzero(wrap) + 1
    if rows.size:
        days = np.zeros(t.size)
        days[rows] = day_s
        t += np.cumsum(days)
    return t, rows


def unwrap_clock(t_s: np.ndarray, rows_named: str = "data row") -> tuple[np.ndarray, list[str]]:
    """A time column made continuous across midnight and across the GPS week's end
    (:func:`unwrap_midnight` with a day, then with a week), and what a reader says of it.

    Args:
        t_s: times, s (a time of day, or a GPS time of week).
        rows_named: what the notes call a row (``data row``; a stream file's ``row``).

    Returns:
        ``(t_s continuous, notes)``.
    """
    t, days = unwrap_midnight(t_s)
    t, weeks = unwrap_midnight(t, SECONDS_PER_WEEK)
    notes = []
    if days.size:
        notes.append(
            f"time of day passed midnight before {rows_named}(s) {_shown(days)}: a day added "
            "after each"
        )
    if weeks.size:
        notes.append(
            f"GPS time of week passed the week's end (604,800 s) before {rows_named}(s) "
            f"{_shown(weeks)}: a week added after each"
        )
    return t, notes


def _shown(rows: np.ndarray) -> str:
    return ", ".join(str(int(r) + 1) for r in rows[:5]) + (" ..." if rows.size > 5 else "")


def grid_phase(t_s: np.ndarray, period_s: float, whole: bool = True) -> float:
    """The phase of a drive's stamps on its sample grid, s, in ``(-period/2, period/2]``.

    The stamps modulo the period fill an arc of the circle ``[0, period)``, narrower than
    the circle when their jitter is below half a period; the phase is that arc's middle
    (opposite the widest empty arc; unlike a circular mean, exact for jitter up to half a
    period), the :data:`ARC_TRIM_SHARE` of stamps at either end of the arc left out (a
    logger's hiccups, rows written tens of ms late, set no end). Where the arc is wider
    than :data:`WIDE_ARC_SHARE` of the circle (a bell curve's jitter, its tails near or
    past half a period), the phase is the mean of the
    stamps' offsets from their nearest slots about it, taken twice. With ``whole``, a
    phase within ``WHOLE_GRID_FRACTION`` of a period of zero is zero (stamps on whole
    multiples) where every stamp stays within half a period of its slot, or, the arc that
    wide, where the phase is that near zero by two standard errors of its mean. Non-finite
    stamps are left out.

    Args:
        t_s: times, s.
        period_s: the nominal sample period, s.
        whole: snap a phase near zero to zero (seconds are counted on whole multiples).

    Returns:
        The phase, s (0 for a drive without finite stamps).
    """
    t = np.asarray(t_s, dtype=np.float64)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return 0.0
    if whole and _on_whole_multiples(t, period_s):  # the usual case, in one pass
        return 0.0
    if t.size > PHASE_SAMPLE:  # every k-th stamp: the empty arc stays as wide
        t = t[:: -(-t.size // PHASE_SAMPLE)]
    v = np.sort(np.remainder(t, period_s))
    gaps = np.diff(np.r_[v, v[0] + period_s])
    k = int(np.argmax(gaps))
    if gaps[k] < WIDE_ARC_SHARE * period_s:  # spread wide: the mean of the stamps about it
        # the arc's middle (opposite the empty arc), then each stamp's offset from its
        # nearest slot, the slots moved
        phase = (v[k] + 0.5 * gaps[k] + 0.5 * period_s) % period_s
        if phase > 0.5 * period_s:
            phase -= period_s
        for _ in range(2):
            off = np.remainder(v - phase + 0.5 * period_s, period_s) - 0.5 * period_s
            phase += float(np.mean(off))
        phase = (phase + 0.5 * period_s) % period_s - 0.5 * period_s
        # whole tenths where the phase is near them by more than two standard errors
        near = abs(phase) + 2.0 * float(np.std(off)) / np.sqrt(v.size)
        return 0.0 if whole and near <= WHOLE_GRID_FRACTION * period_s else float(phase)
    # The stamps fill an arc of the circle [0, period), from v[k + 1] round to v[k]; its
    # middle is opposite the empty arc between them. The ARC_TRIM_SHARE of stamps at
    # either end of the arc are left out first: a logger's hiccup (a row written 40 ms
    # late among stamps within 2 ms of their grid) would move the middle, and every slot
    # of the run, by half the hiccup.
    m = int(ARC_TRIM_SHARE * v.size)
    end, start = (k - m) % v.size, (k + 1 + m) % v.size  # the trimmed arc's two ends
    empty = (v[start] + (period_s if start <= end else 0.0)) - v[end]
    phase = (v[end] + 0.5 * empty + 0.5 * period_s) % period_s
    if phase > 0.5 * period_s:
        phase -= period_s
    # Snap to the whole grid only where every stamp then still lies within half a period
    # of its slot: a wide jitter keeps its phase.
    off = np.remainder(v - phase + 0.5 * period_s, period_s) - 0.5 * period_s
    snaps = (
        abs(phase) <= WHOLE_GRID_FRACTION * period_s
        and float(np.max(off)) + phase < 0.5 * period_s
        and float(np.min(off)) + phase > -0.5 * period_s
    )
    return 0.0 if whole and snaps else float(phase)


def grid_slots(
    t_s: np.ndarray, period_s: float, phase_s: float | None = None
) -> tuple[np.ndarray, float]:
    """Each row's slot on the drive's sample grid: the nearest ``phase + j * period``.

    Args:
        t_s: times, s (finite).
        period_s: the nominal sample period, s.
        phase_s: the grid's phase (default: :func:`grid_phase` of ``t_s``).

    Where the nearest slots do not rise row by row (jitter past half a period), the rows
    around get the rising slots nearest their stamps, each within a period of its stamp
    (:func:`_rising_slots`); elsewhere, and where that cannot be, the nearest.

    Returns:
        ``(j, phase)``: the int64 slot numbers and the phase used.
    """
    t = np.asarray(t_s, dtype=np.float64)
    phase = grid_phase(t, period_s) if phase_s is None else phase_s
    u = (t - phase) / period_s
    nearest = np.rint(u).astype(np.int64)
    if (np.diff(nearest) > 0).all():
        return nearest, phase
    return _rising_slots(u, nearest), phase


def jitter_reach(u: np.ndarray) -> float:
    """How far (in periods) from its stamp :func:`_rising_slots` may place a row:
    :data:`MAX_REACH` where the stamps are jittered (their spread about their nearest
    slots at least :data:`JITTERED_SPREAD`), else half a period. ``u``: stamps in
    periods from the grid's phase (the rows around a place, :data:`SPREAD_ROWS` either
    side)."""
    if not u.size:
        return 0.5
    return MAX_REACH if _spread(u) >= JITTERED_SPREAD else 0.5


def _spread(u: np.ndarray) -> float:
    """The stamps' spread about their nearest slots, in periods: 1.4826 MAD of their
    offsets (of every k-th stamp, :data:`PHASE_SAMPLE` of them at most). ``u``: stamps in
    periods from the grid's phase (non-empty)."""
    sample = u[:: -(-u.size // PHASE_SAMPLE)]
    off = sample - np.rint(sample)
    return 1.4826 * _median(np.abs(off - _median(off)))


def _median(x: np.ndarray) -> float:
    """``np.median`` of a non-empty array, by partition (a tenth of its cost on the few
    dozen values of a place's rows, where it runs once per place)."""
    k = x.size // 2
    if x.size % 2:
        return float(np.partition(x, k)[k])
    low, high = np.partition(x, (k - 1, k))[k - 1 : k + 1]
    return 0.5 * (float(low) + float(high))


def _rising_slots(
    u: np.ndarray,
    nearest: np.ndarray,
    floor: int | None = None,
    history: np.ndarray | None = None,
) -> np.ndarray:
    """Slots that rise row by row, each the nearest to its stamp where the nearest rise.

    Around each place where the nearest slots ``nearest`` do not rise (:data:`REPAIR_ROWS`
    rows either side, overlapping stretches joined), the rows are given the rising slots
    of least squared distance to their stamps ``u`` (in periods): ``j_k - k`` is the
    isotonic least-squares fit of ``u_k - k``, rounded (pool adjacent violators). A
    stretch whose rows would move farther than its reach from their stamps
    (:func:`jitter_reach` of the stretch and :data:`SPREAD_ROWS` rows either side), or fall
    at or before the slot before it, keeps its nearest slots (the checks downstream refuse
    them).

    Args:
        u: stamps in periods from the grid's phase (finite).
        nearest: ``rint(u)``.
        floor: a slot every row must lie after (the slot of the row before ``u[0]``,
            placed already; None: none).
        history: the stamps (in periods, on the same phase) of the rows before ``u[0]``,
            placed already, the last :data:`SPREAD_ROWS` of them at most (None: none).

    Returns:
        int64 slots.
    """
    first = nearest[:1] if floor is None else np.r_[floor, nearest[:1]]
    if (np.diff(nearest) > 0).all() and (first.size < 2 or first[1] > first[0]):
        return nearest
    bad = np.flatnonzero(np.diff(nearest) <= 0)
    starts = np.maximum(bad - REPAIR_ROWS, 0)
    ends = np.minimum(bad + 2 + REPAIR_ROWS, u.size)
    if floor is not None and nearest.size and nearest[0] <= floor:
        starts, ends = np.r_[0, starts], np.r_[min(1 + REPAIR_ROWS, u.size), ends]
    out = nearest.copy()
    a, b = int(starts[0]), int(ends[0])
    for lo, hi in [*zip(starts[1:].tolist(), ends[1:].tolist(), strict=True), (u.size + 1, 0)]:
        if lo <= b:  # overlapping: one stretch
            b = max(b, hi)
            continue
        k = np.arange(a, b)
        slots = k + np.rint(_isotonic(u[a:b] - k)).astype(np.int64)
        # between the slots placed before and after the stretch (a stamp half way between
        # two slots rounds either way)
        before = floor if a == 0 else int(out[a - 1])
        if before is not None:
            slots = np.maximum(slots, before + 1 + np.arange(b - a))
        if b < u.size:
            slots = np.minimum(slots, int(nearest[b]) - (b - a) + np.arange(b - a))
        reach = jitter_reach(_around(u, a, b, history))
        fits = np.all(np.abs(u[a:b] - slots) <= reach) and (np.diff(slots) > 0).all()
        if not fits and _spread(_beside(u, a, b, history)) < LATE_SPREAD:
            # a logger whose stamps keep near their grid around: rows written late?
            late = _written_late(
                u[a:b], nearest[a:b], before, int(nearest[b]) if b < u.size else None
            )
            if late is not None:
                slots, fits = late, True
        if fits and (before is None or slots[0] > before):
            out[a:b] = slots
        a, b = lo, hi
    return out


def _beside(u: np.ndarray, a: int, b: int, history: np.ndarray | None) -> np.ndarray:
    """The stamps of the :data:`SPREAD_ROWS` rows either side of rows ``a:b`` (those before
    ``u[0]`` from ``history``), without rows ``a:b``; the stretch's own stamps where there
    are none."""
    before = u[max(a - SPREAD_ROWS, 0) : a]
    short = SPREAD_ROWS - a
    if history is not None and short > 0 and history.size:
        before = np.r_[history[-short:], before]
    got = np.r_[before, u[b : b + SPREAD_ROWS]]
    return got if got.size else u[a:b]


def _around(u: np.ndarray, a: int, b: int, history: np.ndarray | None) -> np.ndarray:
    """The stamps of rows ``a:b`` and :data:`SPREAD_ROWS` rows either side (those before
    ``u[0]`` from ``history``)."""
    here = u[max(a - SPREAD_ROWS, 0) : b + SPREAD_ROWS]
    short = SPREAD_ROWS - a
    if history is None or short <= 0 or not history.size:
        return here
    return np.concatenate([history[-short:], here])


def _written_late(
    u: np.ndarray, nearest: np.ndarray, before: int | None, after: int | None
) -> np.ndarray | None:
    """The slots of rows a logger on its grid wrote late, or None.

    A logger that stamps a row when it writes it, not when the sample was taken, stamps
    rows late and never early: after a stall (a garbage collection, a flush to the card)
    it writes the rows it held back at once, their stamps crowding after slots left
    empty. Each row is then given the latest slot at or before its nearest that leaves
    room for the rows after it (before ``after``, the next row's nearest slot): the empty
    slots are filled in the rows' order. None where a row would so be placed more than
    :data:`RUN_GAP_PERIODS` periods before its stamp (a stall that long splits the run),
    or where a slot is left empty just before a row placed so (a sample lost as well:
    whether before the held rows or among them, the stamps cannot tell).

    Args:
        u: the stretch's stamps, in periods from the grid's phase.
        nearest: ``rint(u)``.
        before: the slot of the row before the stretch (None: none).
        after: the slot the rows must lie before (None: none).

    Returns:
        int64 slots, rising, each at most its nearest; or None.
    """
    k = np.arange(nearest.size)
    top = nearest - k
    if after is not None:
        top = np.minimum(top, after - nearest.size)
    slots = k + np.minimum.accumulate(top[::-1])[::-1]
    if np.max(u - slots) > RUN_GAP_PERIODS:
        return None
    moved = u - slots > 0.5
    previous = np.r_[slots[0] - 2 if before is None else before, slots[:-1]]
    if (moved & (slots - previous > 1)).any():
        return None
    return slots


def _isotonic(y: np.ndarray) -> np.ndarray:
    """The non-decreasing sequence nearest ``y`` in least squares (pool adjacent
    violators); ``y`` is a short stretch of rows."""
    means: list[float] = []
    sizes: list[int] = []
    for value in y.tolist():
        means.append(value)
        sizes.append(1)
        while len(means) > 1 and means[-2] > means[-1]:
            n = sizes[-2] + sizes[-1]
            means[-2:] = [(means[-2] * sizes[-2] + means[-1] * sizes[-1]) / n]
            sizes[-2:] = [n]
    return np.repeat(means, sizes)


def nominal_times(t_s: np.ndarray, period_s: float) -> np.ndarray:
    """Each row's time with its jitter removed: its slot's instant on the drive's grid.

    Each run of rows between steps longer than :data:`RUN_GAP_PERIODS` periods (a logger
    that stopped and started again) is placed on its own grid phase (:func:`grid_slots`).

    Args:
        t_s: times, s (finite, increasing).
        period_s: the nominal sample period, s.

    Returns:
        float64 times ``phase + j * period``.
    """
    slots, phases = run_slots(t_s, period_s)
    return phases + slots * period_s


def run_slots(t_s: np.ndarray, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Each row's slot (:func:`grid_slots`) and its run's grid phase, each run between
    steps longer than :data:`RUN_GAP_PERIODS` periods on its own phase, taken from the
    run's first :data:`STREAM_PHASE_ROWS` rows as ``rwhonet predict`` takes it
    (:class:`StreamClock`: on a jittered run's wide arc the mean of the whole run's
    offsets lies a millisecond or so from theirs, and the seconds' times with it)
    (int64 slots, each counting periods from its run's phase; float64 phases, s)."""
    t = np.asarray(t_s, dtype=np.float64)
    slots = np.empty(t.size, dtype=np.int64)
    phases = np.empty(t.size)
    for a, b in run_bounds(t, period_s):
        phase = grid_phase(t[a : min(b, a + STREAM_PHASE_ROWS)], period_s)
        slots[a:b], phases[a:b] = grid_slots(t[a:b], period_s, phase)
    return slots, phases


def run_bounds(t_s: np.ndarray, period_s: float) -> list[tuple[int, int]]:
    """``(first, stop)`` rows of each run between steps longer than
    :data:`RUN_GAP_PERIODS` periods (one run for a drive without such a step)."""
    cuts = np.flatnonzero(np.diff(t_s) > RUN_GAP_PERIODS * period_s) + 1
    return list(itertools.pairwise([0, *cuts.tolist(), int(np.size(t_s))]))


def _on_whole_multiples(t: np.ndarray, period_s: float) -> bool:
    """Whether every stamp lies within ``TIME_EPS_S`` of a whole multiple of the period
    (decimal stamps on the grid: their phase is 0 whatever the arc says)."""
    per_s = round(1.0 / period_s)
    if t.size == 0 or abs(per_s * period_s - 1.0) > 1e-12:
        return False
    return bool(np.max(np.abs(t - np.rint(t * per_s) / per_s)) <= TIME_EPS_S)


# Stamps coarser than the rows (:func:`coarse_places`): at least this share of the steps
# between rows are none (the rows of one stamp)
COARSE_SHARE = 0.5


def coarse_places(t_s: np.ndarray, period_s: float) -> tuple[np.ndarray, float, np.ndarray] | None:
    """Times for rows whose stamps are coarser than their rate, the stamps' step, and the
    rows whose times they cannot tell.

    A spreadsheet that shows a time as ``hh:mm:ss`` saves it so in a CSV, dropping the
    fraction; a logger that prints ``%H:%M:%S``, or writes the GNSS receiver's once-a-second
    time in every row, does the same: the ten rows of each second share one stamp. Such
    stamps are told by every step between rows being none or a whole number of one
    step ``q`` (a second) that holds a whole number ``n >= 2`` of periods, at least
    :data:`COARSE_SHARE` of them none, no stamp holding more than ``n`` rows and most
    holding ``n`` (none more, but for a sample a software logger's jitter stamped across
    a second's edge: an inner stamp with ``n + 1`` rows beside one with ``n - 1``, a
    second apart, whose ``2n`` rows are placed in turn from the first's). Each stamp's
    rows are then placed a period apart after it, in the
    file's order (``stamp + (k + 1) * period``: the second ``(stamp, stamp + q]``, the
    grid's second ending at the next stamp). The first stamp's rows take its last slots
    (the logger started during that second), the last stamp's its first (it stopped).
    Any other stamp with fewer rows lost a sample, and which the stamps no longer tell:
    placed in its first slots, its last row would stand a period early as the start of
    the next second (a label 0.1 s of travel off, 1.7 m at 17 m/s); its rows are
    *untimed*, for the caller to leave out (a gap: its second and the next are cut).

    Returns:
        ``(times, q, untimed)`` (``untimed`` a bool mask), or None where the stamps are
        not so (the rows as stamped).
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.size < 3 or not np.isfinite(t).all():
        return None
    step = np.diff(t)
    if (step < 0).any() or (step == 0).mean() < COARSE_SHARE or not (step > 0).any():
        return None
    q = float(step[step > 0].min())
    n = round(q / period_s)
    quanta = step[step > 0] / q
    if n < 2 or abs(q / period_s - n) > 1e-6 * n or np.abs(quanta - np.round(quanta)).max() > 1e-6:
        return None
    starts = np.r_[0, np.flatnonzero(step > 0) + 1]
    rows = np.diff(np.r_[starts, t.size])
    if float(np.median(rows)) != n:
        return None
    # a sample a logger's jitter stamped across a second's edge: an inner stamp with one
    # row more than a second has beside one with one fewer, a second apart; their 2n rows
    # are placed in turn from the first's
    stamp = t[starts]
    follow = np.zeros(rows.size, dtype=bool)
    g = 1
    while g < rows.size - 2:
        if abs(stamp[g + 1] - stamp[g] - q) <= 1e-6 * q and {rows[g], rows[g + 1]} == {
            n - 1,
            n + 1,
        }:
            follow[g + 1] = True
            g += 2
        else:
            g += 1
    paired = follow | np.r_[follow[1:], False]
    if (rows[~paired] > n).any():
        return None
    origin = np.arange(rows.size) - follow  # the stamp each stamp's rows count from
    within = np.arange(t.size) - np.repeat(starts[origin], rows)
    within[: rows[0]] += n - rows[0]  # the logger started in the first stamp's second
    short = (rows < n) & ~paired
    short[[0, -1]] = False
    return np.repeat(stamp[origin], rows) + (within + 1) * period_s, q, np.repeat(short, rows)


def label_times(t_s: np.ndarray, period_s: float) -> np.ndarray:
    """The times a drive's rates are integrated over: the stamps, or their slots' instants.

    A jittered stamp says when the logger wrote the row, not when the sample was taken
    (:func:`grid_slots`): integrating a wheel speed over stamps 4 ms off moves a second's
    wheel angle by up to 8 ms of wheel speed. When every stamp lies within
    ``TIME_EPS_S`` of its slot's instant (a clean drive: the decimal time stamps as
    floats), the stamps are returned as they are, so a clean drive's labels do not move
    by a bit; otherwise every row gets its slot's instant ``phase + j * period``
    (:func:`nominal_times`: on whole multiples when the stamps are near them).

    Args:
        t_s: times, s (finite, strictly increasing).
        period_s: the nominal sample period, s.

    Returns:
        float64 times: ``t_s`` itself, or the slot instants.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.size == 0:
        return t
    if _on_whole_multiples(t, period_s):  # the usual case, in one pass
        return t
    # On the arc's own middle first, not snapped to whole multiples: a logger offset by a
    # few ms without jitter keeps its stamps.
    slots, phase = grid_slots(t, period_s, grid_phase(t, period_s, whole=False))
    if np.max(np.abs(t - (phase + slots * period_s))) <= TIME_EPS_S:
        return t
    return nominal_times(t, period_s)


def drive_label_times(t_s: np.ndarray, period_s: float) -> np.ndarray:
    """A whole drive's :func:`label_times`, each stamp within ``TIME_EPS_S`` of the time
    given it kept as it is: the times validate writes into the drive's segments.

    Placing a segment's rows alone would give its edge rows a neighbour on one side only:
    under a jitter past half a period, the last row of a segment ended by a logger's
    restart or a lost sample (or its first) could then take the slot beside its own, which
    the drive's rows after it had ruled out, and its second be labelled a row's travel
    off. The whole drive's slots are the ones validate's seconds and ``rwhonet predict``
    (:class:`StreamClock`) take. Keeping the stamps on their slots leaves a clean drive's
    rows, and the rows of a drive jittered only in places, bit for bit as logged; the
    segment's times are then all on the grid, and :func:`label_times` keeps them.

    Args:
        t_s: a drive's times, s (finite, strictly increasing).
        period_s: the nominal sample period, s.

    Returns:
        float64 times: ``t_s`` itself where :func:`label_times` keeps it, else the slot
        instants with the stamps on them kept.
    """
    t = np.asarray(t_s, dtype=np.float64)
    placed = label_times(t, period_s)
    if placed is t:
        return t
    return np.where(np.abs(placed - t) <= TIME_EPS_S, t, placed)


def lean_limit_s(period_s: float) -> float:
    """How far a stamp may lie from its placed time toward a dropped sample beside it and
    its row still be a fix a second starts or ends on, s (:data:`DROP_LEAN_SHARE` of a
    period, and the decimal stamps' allowance)."""
    return DROP_LEAN_SHARE * period_s + TIME_EPS_S


def leans_into_drop(
    lean_s: np.ndarray, step_s: np.ndarray, period_s: float, max_gap_s: float
) -> np.ndarray:
    """Rows beside a dropped sample whose stamps lean toward it: none of them is a fix
    a second may start or end on.

    A step of more than one and a half periods between placed rows, and no longer than
    ``max_gap_s`` (a longer one ends the run), leaves a slot empty: a sample dropped, or
    a row beside it placed a slot off, its stamp off by more than half a period. Which of
    the two the stamps cannot tell; the row beside the empty slot whose stamp leans
    toward it by more than :data:`DROP_LEAN_SHARE` of a period (a row before it stamped
    late, a row after it early) may be the one placed off. Stamps within a quarter period
    of their slots (a clean logger's) never lean so.

    Args:
        lean_s: each row's stamp less its placed time, s (the stamp on the drive's
            continuous clock).
        step_s: the placed times' steps, s (``np.diff`` of the placed times; one fewer).
        period_s: the nominal sample period, s.
        max_gap_s: a step longer than this ends the run (``validate.gnss.max_gap_s``).

    Returns:
        Boolean per row.
    """
    lean = np.asarray(lean_s, dtype=np.float64)
    step = np.asarray(step_s, dtype=np.float64)
    drop = (step > 1.5 * period_s) & (step <= max_gap_s)
    far = lean_limit_s(period_s)
    before_drop = np.r_[drop, False] & (lean > far)
    after_drop = np.r_[False, drop] & (lean < -far)
    return before_drop | after_drop


class StreamClock:
    """Midnight and jitter for a drive read block by block (``rwhonet predict``).

    The same clock :mod:`rwhonet.data.iovnbd` and :func:`label_times` give a whole
    drive, kept across blocks: a step back from the last hour of a day into the first
    hour of the next adds a day to that and every later row (:func:`unwrap_midnight`),
    and stamps farther than ``TIME_EPS_S`` from their slot are replaced by the slot's
    instant, on a grid phase taken from the first ``STREAM_PHASE_ROWS`` rows (the
    caller hands over at least that many first, or the whole drive when it is shorter).
    After a step longer than :data:`RUN_GAP_PERIODS` periods (a logger that stopped and
    started again, placed on a phase of its own by :func:`nominal_times` and the label) the
    phase is taken again, from that run's first ``STREAM_PHASE_ROWS`` rows: a run shorter
    than that at a block's end is held back until they are at hand.
    Where jitter past half a period has the rows around a place given rising slots
    (:func:`grid_slots`), the rows that later rows could still move are held back
    (:meth:`place`), so a drive read in blocks gets the slots it gets read whole.

    Args:
        period_s: the nominal sample period, s.
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self.day_s = 0.0  # added to the rows of the current day
        self.last: float | None = None  # the previous blocks' last finite time, as logged
        self.last_run_t: float | None = None  # ... on the continuous clock, not placed
        self.phase: float | None = None  # the grid's phase (near-zero snapped to zero)
        self.raw_phase = 0.0  # the stamps' own arc middle
        self.midnights: list[int] = []  # 0-based rows after a rollover
        self.slot: int | None = None  # the slot of the last row placed (jittered stamps)
        # the stamps (periods from the phase) of the last SPREAD_ROWS rows placed: the rows
        # before a block's first that tell the reach of a place beside them (_rising_slots)
        self.history = np.zeros(0)
        # the rows last placed: each stamp (on the continuous clock) less its placed time, s
        # (:func:`leans_into_drop`)
        self.lean_s = np.zeros(0)

    def place(self, t_s: np.ndarray, first_row: int = 0, final: bool = True) -> np.ndarray:
        """The block's times on the drive's continuous clock, jitter removed.

        Args:
            t_s: the block's times of day as logged, s.
            first_row: 0-based row of the block's first row in the drive (for the notes).
            final: place every row. Otherwise, on stamps off their grid, the rows whose
                slots (or whose reach, :func:`jitter_reach`) the rows after them could
                still change (the last ``SPREAD_ROWS``, and
                those placed together with them: :func:`_settled`) are left unplaced:
                the caller gives them again, first, with the next block.

        Returns:
            float64 times of the block's first rows (all of them where ``final``); each
            one's stamp less its time is :attr:`lean_s`.
        """
        t = np.asarray(t_s, dtype=np.float64)
        if t.size == 0:
            self.lean_s = np.zeros(0)
            return t.copy()
        stamps = self._continuous(t)[0]
        out = stamps
        finite = np.isfinite(t)
        n = t.size
        if finite.all():  # else the checks downstream report the missing times
            out, n = self._runs(out, final)
        elif self.phase is None:
            self._new_run(out[finite])
        self._advance(t[:n], first_row)
        with np.errstate(invalid="ignore"):  # inf - inf: NaN, no lean (the checks tell)
            self.lean_s = stamps[:n] - out[:n]
        return out[:n]

    def _runs(self, out: np.ndarray, final: bool) -> tuple[np.ndarray, int]:
        """A block's finite times placed run by run (a new phase after each step longer
        than :data:`RUN_GAP_PERIODS` periods), and how many of them are settled."""
        before = out[0] if self.last_run_t is None else self.last_run_t
        starts = np.flatnonzero(np.diff(np.r_[before, out]) > RUN_GAP_PERIODS * self.period_s)
        if self.phase is None and (not starts.size or starts[0] != 0):
            starts = np.r_[0, starts]
        placed = out.copy()
        bounds = [*starts.tolist(), out.size]
        if bounds[0] != 0:  # the run the blocks before began goes on
            bounds = [0, *bounds]
        for a, b in itertools.pairwise(bounds):
            if a in starts:
                if b == out.size and b - a < STREAM_PHASE_ROWS and not final:
                    return placed, a  # the run's first rows are not all at hand yet
                self._new_run(out[a : min(b, a + STREAM_PHASE_ROWS)])
            got, k = self._on_grid(out[a:b], final or b < out.size)
            placed[a : a + k] = got[:k]
            self.last_run_t = float(out[a + k - 1]) if k else self.last_run_t
            if k < b - a:
                return placed, a + k
        return placed, out.size

    def _new_run(self, t: np.ndarray) -> None:
        """The grid's phase taken from a run's first stamps ``t``; the slots and stamps of
        the run before forgotten."""
        self.raw_phase = grid_phase(t, self.period_s, whole=False)
        self.phase = grid_phase(t, self.period_s)
        self.slot = None
        self.history = np.zeros(0)

    def _continuous(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times on the continuous clock after the rows placed so far, and the rows (of
        ``t``, 0-based, the row before first) after a midnight and a week's end."""
        prev = np.zeros(0) if self.last is None else np.array([self.last])
        joined, rows = unwrap_midnight(np.concatenate([prev, t]))
        joined, weeks = unwrap_midnight(joined, SECONDS_PER_WEEK)  # a GPS time of week's end
        return joined[prev.size :] + self.day_s, rows - prev.size, weeks - prev.size

    def _advance(self, t: np.ndarray, first_row: int) -> None:
        """The clock's state moved past the rows ``t`` (placed)."""
        if not t.size:
            return
        _, rows, weeks = self._continuous(t)
        finite = np.isfinite(t)
        if finite.any():
            self.last = float(t[finite][-1])
        self.midnights += [first_row + int(r) for r in np.union1d(rows, weeks)]
        self.day_s += SECONDS_PER_DAY * rows.size + SECONDS_PER_WEEK * weeks.size

    def _on_grid(self, out: np.ndarray, final: bool) -> tuple[np.ndarray, int]:
        """Finite times on the grid, and how many of them are settled."""
        period, phase = self.period_s, float(self.phase or 0.0)
        u = (out - phase) / period
        nearest = np.rint(u).astype(np.int64)
        exact = np.rint((out - self.raw_phase) / period)
        if np.max(np.abs(out - (self.raw_phase + exact * period))) <= TIME_EPS_S:
            # on the grid already (a logger's own offset kept): no row moved, none held
            placed, slots, n = out, nearest, out.size
        else:
            slots = _rising_slots(u, nearest, self.slot, self.history)
            placed = phase + slots * period
            n = out.size if final else _settled(nearest, self.slot)
        if n:
            self.slot = int(slots[n - 1])
            self.history = np.concatenate([self.history, u[:n]])[-SPREAD_ROWS:]
        return placed, n


def _settled(nearest: np.ndarray, floor: int | None) -> int:
    """How many of a block's first rows no later row can give another slot: those before
    the last ``SPREAD_ROWS`` (a later row may start a stretch ``REPAIR_ROWS + 1`` rows back,
    and a stretch's reach takes ``SPREAD_ROWS`` rows after it), and not in a stretch
    :func:`_rising_slots` places together with rows after them."""
    n = nearest.size - max(REPAIR_ROWS + 2, SPREAD_ROWS)
    if n <= 0:
        return 0
    bad = np.flatnonzero(np.diff(nearest) <= 0)
    if floor is not None and nearest[0] <= floor:
        bad = np.r_[-1, bad]
    covered = np.zeros(nearest.size + 1, dtype=bool)
    for b in bad.tolist():
        covered[max(b - REPAIR_ROWS, 0) : b + 2 + REPAIR_ROWS] = True
    while n > 0 and covered[n - 1] and covered[n]:
        n -= 1
    return n
