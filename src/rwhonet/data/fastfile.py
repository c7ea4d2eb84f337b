"""A 10 Hz file's layout logged faster (a VBOX at 20 Hz, a CAN logger's export at 50 or
100 Hz): its rows read as streams and resampled onto the grid.

The 10 Hz readers (IO-VNBD, column maps, VBOX files) take one row per sample of the grid
(``validate.sample_period_s``, 0.1 s). Many loggers write the same columns faster: a
Racelogic VBOX logs at 20 Hz as readily as at 10 Hz, and a CAN logger's export of one
table samples every signal at the fastest message's rate. Before, validate refused such
a drive ("the drive is sampled at 20 Hz, not 10 Hz") and the user resampled it by hand.
Now a file whose rows come at least :data:`FAST_FACTOR` times as often as the grid's
(median step) is read as the streams it stands for (:func:`as_streams`) and put on the
grid by the stream resampler (:func:`rwhonet.data.streams.resample`): the wheel speeds
and the gyro as rates (the mean of each row's window), the fixes placed along the path.
Fixes a slower receiver held over several rows (a 10 Hz receiver in a 50 Hz table) are
its fixes where they changed (:func:`rwhonet.data.heldfixes.held_fixes`), as for a 10 Hz
file. The drive is then a drive on the grid (``header_match="streams"``, its rows the
grid's, not the file's), and its notes say so.

**A logger at its own rate** (since stop 68). A logger that reads its sensors, writes the
row and then sleeps a period (a Python or Arduino loop: ``time.sleep(0.1)``) takes a
little longer each time: 9.98 Hz, 9.9 Hz, its stamps right. On the grid each row's slot
slips a little further from its stamp until a slot is skipped (every 500 rows at 9.98 Hz,
every 100 at 9.9 Hz), taken for a dropped sample and its second cut; and the rows'
wheel speeds, integrated over their slots' 0.1 s, cover 0.2 % (1 %) less time than the
fixes around them: a label off by 2 cm a second at 9.4 m/s, a third of its RMS. A drive
whose stamps run at another rate than the grid's by :data:`OFF_RATE` or more
(:func:`rate_ratio`, beyond :data:`OFF_RATE_SE` standard errors) is read as streams and
resampled as a faster table is: measured on V-Delta2's first 1,565 s sampled at 9.98 and
9.9 Hz, the labels of the 10 Hz drive (mean -0.0261 against -0.0259 m, 1,564 seconds
kept), where the grid lost 56 seconds and moved the mean label by 1.9 cm at 9.98 Hz, and
refused the drive at 9.9 Hz (a second cut every 10 s).
"""

from __future__ import annotations

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.droprows import FileRows, manifest_rows
from rwhonet.data.heldfixes import held_fixes
from rwhonet.data.sampleorder import clock_steps, time_order
from rwhonet.data.streams import GRID_PERIOD_S, RATE_CHANNELS, DriveStreams, Stream

# Rows this many times as frequent as the grid's or more (median step at most the grid's
# period over it): a faster table, resampled. A 10 Hz file's jittered or dropped rows keep
# its median step near the period; 15 Hz is the slowest rate taken as faster.
FAST_FACTOR = 1.5
# ... but no faster than this step: a table of these channels at more than 1 kHz is no
# logger's (CAN messages come at 100 Hz at most, a VBOX at 100 Hz), but a time column in
# another unit than it says; it is read as a 10 Hz file, and validate names its rate.
MIN_STEP_S = 0.001
# A 10 Hz table whose stamps run at another rate than the grid's by this share or more
# (its rows' period over the grid's, less 1: 3e-4 moves a label by 3 mm a second at 10 m/s
# and skips a slot every 3,300 rows), and by this many standard errors of the estimate
# (a jittered drive's): resampled. A logger's clock drift against GNSS time (50 ppm) is
# in its stamps and its sampling alike, and below it.
OFF_RATE = 3e-4
OFF_RATE_SE = 4.0
# ... judged on steps within this share of a period of one period, and only where those
# steps spread by at most REGULAR_SPREAD of a period (1.4826 MAD): a logger stamping to the
# ms beside its own loop. A jittered drive's dropped sample (a step of two periods less
# the jitter) would otherwise pass for an even step now and then and pull the slope up
# (measured: 235 of 3,000 simulated 10 Hz drives with up to 30 ms of jitter and 10 % of
# samples dropped taken for a logger of its own rate); such a drive keeps the grid.
EVEN_BAND = 0.25
REGULAR_SPREAD = 0.1


def median_step(t_s: np.ndarray) -> float:
    """The median step between a drive's finite times that move forward (NaN: none)."""
    t = t_s[np.isfinite(t_s)]
    steps = np.diff(t)
    steps = steps[steps > 0]
    return float(np.median(steps)) if steps.size else float("nan")


def is_faster_than_grid(t_s: np.ndarray, period_s: float) -> bool:
    """Whether a 10 Hz layout's rows come :data:`FAST_FACTOR` times as often as the grid's
    or more (its median step), and no faster than a logger writes (:data:`MIN_STEP_S`)."""
    step = median_step(t_s)
    return bool(np.isfinite(step) and MIN_STEP_S <= step and step * FAST_FACTOR <= period_s)


def rate_ratio(t_s: np.ndarray, period_s: float) -> tuple[float, float]:
    """How much the stamps' own period differs from the grid's (their period over the
    grid's, less 1), and the standard error of that.

    The least-squares slope of stamp against row number, pooled over stretches of rows
    whose steps all lie within :data:`EVEN_BAND` of a period of one period (a dropped
    sample, a gap, a jittered step past that end a stretch; each stretch its own
    intercept). A jitter moves it by nothing on average; its standard error says by how
    much.

    Args:
        t_s: the drive's times, s, in time order (non-finite ones left out).
        period_s: the grid's period, s.

    Returns:
        ``(ratio - 1, standard error)``; ``(0, inf)`` with fewer than 3 rows in stretches.
    """
    t = np.asarray(t_s, dtype=np.float64)
    t = t[np.isfinite(t)]
    if t.size < 3:
        return 0.0, float("inf")
    return _rate_ratio(t, _even(np.diff(t), period_s), period_s)


def _rate_ratio(t: np.ndarray, even: np.ndarray, period_s: float) -> tuple[float, float]:
    """:func:`rate_ratio` of finite times ``t`` (3 or more) whose even steps are told."""
    starts = np.r_[0, np.flatnonzero(~even) + 1]
    size = np.diff(np.r_[starts, t.size])
    stretch = np.repeat(np.arange(starts.size), size)
    keep = size[stretch] >= 3
    n_stretches = int((size >= 3).sum())
    if keep.sum() - n_stretches < 2:
        return 0.0, float("inf")
    row = np.arange(t.size, dtype=np.float64)
    di = (row - (np.bincount(stretch, row) / size)[stretch])[keep]
    dt = (t - (np.bincount(stretch, t) / size)[stretch])[keep]
    sxx = float(np.sum(di * di))  # not BLAS: its threads would fight the readers'
    slope = float(np.sum(di * dt)) / sxx
    resid = dt - slope * di
    s2 = float(np.sum(resid * resid)) / (keep.sum() - n_stretches - 1)
    return slope / period_s - 1.0, float(np.sqrt(s2 / sxx)) / period_s


def _even(steps: np.ndarray, period_s: float) -> np.ndarray:
    """Steps within :data:`EVEN_BAND` of a period of one period, the band's edges left out
    by a microsecond both sides alike: stamps to the ms put many steps on an edge, and a
    difference of floats lands either side of it by chance, more often on one side (it
    pulled the slope of a 20 ms bell curve's stamps to the ms up by 1e-3)."""
    return np.abs(steps - period_s) < EVEN_BAND * period_s - 1e-6


def is_off_the_grid_rate(t_s: np.ndarray, period_s: float) -> bool:
    """Whether a 10 Hz layout's stamps, regular (their even steps spread by at most
    :data:`REGULAR_SPREAD` of a period), run at another rate than the grid's by
    :data:`OFF_RATE` or more, and by :data:`OFF_RATE_SE` standard errors
    (:func:`rate_ratio`)."""
    t = np.asarray(t_s, dtype=np.float64)
    t = t[np.isfinite(t)]
    steps = np.diff(t)
    even = _even(steps, period_s)
    steps = steps[even]
    if steps.size < 2:
        return False
    spread = 1.4826 * float(np.median(np.abs(steps - np.median(steps))))
    if spread > REGULAR_SPREAD * period_s:
        return False
    off, se = _rate_ratio(t, even, period_s)
    return abs(off) >= OFF_RATE and abs(off) >= OFF_RATE_SE * se


def needs_resampling(t_s: np.ndarray, period_s: float) -> bool:
    """Whether a 10 Hz layout's rows are read as streams and resampled onto the grid:
    logged faster (:func:`is_faster_than_grid`), or at a rate of the logger's own
    (:func:`is_off_the_grid_rate`)."""
    return is_faster_than_grid(t_s, period_s) or is_off_the_grid_rate(t_s, period_s)


def as_streams(raw: RawDrive, file: str, period_s: float = GRID_PERIOD_S) -> DriveStreams:
    """A faster table's rows as the streams it stands for: the four wheel speeds in one
    (the rows with all four), the fixes in another (each row's, or a slower receiver's
    where the table held them), the other rates (the gyro, ...) each in its own.

    Args:
        raw: the drive as its 10 Hz reader read it (copies and rows without a wheel speed
            dropped).
        file: the file as the user knows it, for messages.
    """
    cols = raw.columns
    source = raw.source_columns
    # each row's data row in the file (rows dropped before as copies or without a wheel
    # speed), so that messages name the file's rows
    file_row = FileRows.of(manifest_rows(raw))(np.arange(raw.n_rows))
    # rows written out of time order (a logger's buffers merged as they arrived): put in
    # order where that is all that is wrong, as a stream's samples are; a clock set back
    # put on one clock where the car drove on (sampleorder.clock_steps); else left, refused
    order = time_order(cols[c.T_S], cols, file_row, file)
    notes = raw.notes
    if order.index is not None:
        cols = {k: v[order.index] for k, v in cols.items()}
        file_row = file_row[order.index]
        notes = (*notes, *order.notes)
    elif np.isfinite(own := median_step(cols[c.T_S])) and (
        moved := clock_steps(cols[c.T_S], cols[c.LAT_DEG], cols[c.LON_DEG], file_row, own)
    ):  # its clock set back while the car drove on (judged at the table's own rate)
        cols = {**cols, c.T_S: moved[0]}
        notes = (*notes, f"{file}: {moved[1]}")
    t = cols[c.T_S]

    def stream(name: str, rows: np.ndarray, names: tuple[str, ...]) -> Stream:
        return Stream(
            name,
            file,
            t[rows],
            {k: cols[k][rows] for k in names},
            {k: source.get(k, k) for k in (c.T_S, *names)},
            file_row[rows],
        )

    finite_t = np.isfinite(t)
    wheels = finite_t & np.all([np.isfinite(cols[w]) for w in c.WHEELS], axis=0)
    held = held_fixes(cols)
    has_fix = finite_t & np.isfinite(cols[c.LAT_DEG]) & np.isfinite(cols[c.LON_DEG])
    fixes = has_fix if held is None else np.isin(np.arange(t.size), held.fresh) & has_fix
    gnss = tuple(k for k in c.FIX_CHANNELS if k in cols)
    extra = []
    for name in RATE_CHANNELS:
        if name in c.WHEELS or name not in cols:
            continue
        rows = finite_t & np.isfinite(cols[name])
        if rows.sum() >= 2:
            extra.append(
                stream(f"rows with {source.get(name, name)}", np.flatnonzero(rows), (name,))
            )
    held_rows = held.period_rows if held is not None else 0
    if (step := median_step(t)) * FAST_FACTOR <= period_s:
        note = fast_note(step, held_rows)
    else:
        note = off_rate_note(rate_ratio(t, period_s)[0], period_s, held_rows)
    return DriveStreams(
        wheels=(stream("rows with the wheel speeds", np.flatnonzero(wheels), c.WHEELS),),
        gnss=stream("rows with a fix", np.flatnonzero(fixes), gnss),
        extra=tuple(extra),
        clock="the file's time column",
        notes=(*notes, note),
    )


def fast_note(step_s: float, held_rows: int) -> str:
    """What a reader says of a table logged faster than the grid, resampled."""
    return (
        f"rows every {step_s:.3g} s ({1.0 / step_s:.3g} Hz), faster than the grid: "
        + _resampled_note(held_rows)
    )


def off_rate_note(off: float, period_s: float, held_rows: int) -> str:
    """What a reader says of a table whose stamps run at a rate of the logger's own."""
    rate = 1.0 / (period_s * (1.0 + off))
    return (
        f"rows at {rate:.5g} Hz by their stamps, {abs(off):.2%} "
        f"{'slower' if off > 0 else 'faster'} than the grid's {1.0 / period_s:g} Hz (a "
        "logger that keeps its own rate, not the grid's: on the grid its rows would slip "
        "out of their slots and their seconds cover another time than their fixes): "
        + _resampled_note(held_rows)
    )


def _resampled_note(held_rows: int) -> str:
    held = (
        f"; the fixes held over {held_rows} rows (a slower receiver) taken where they change"
        if held_rows
        else ""
    )
    return (
        "read as streams and resampled onto it (the wheel speeds and the gyro as each "
        f"row's window mean, the fixes along the path){held}; rows named in messages are "
        "the grid's"
    )
