"""A drive's clock: midnight rollover, and each row's slot on the sample grid.

Two things real loggers do to a time column that the per-second logic must not
mistake for bad data:

- **Midnight.** IO-VNBD time is seconds since the start of the day, so a drive
  across midnight steps from about 86399.9 back to about 0.
  :func:`unwrap_midnight` adds a day to every row after such a step, so the
  drive reads as one continuous clock (times after midnight then exceed
  86400 s; manual cuts and scenario intervals of such a drive are in that
  continuous clock).
- **Jitter.** A CAN logger stamps each row when it writes it, a few
  milliseconds off the nominal instant (still strictly increasing). A row
  stamped 4 ms before a whole second belongs to that second, one stamped 4 ms
  after it to the next, so plain rounding of the stamps fills seconds with 9 or
  11 rows. :func:`grid_slots` puts every row on the drive's own sample grid
  instead: its *slot* is the nearest grid instant, ``phase + j * period``, where
  the phase is the middle of the arc the stamps fill modulo the period (stamps on
  whole tenths give phase 0; a logger offset by 30 ms keeps its 30 ms). Jitter
  below half a period is removed as long as the stamps leave part of that circle
  empty: at up to 45 % of a period, a few hundred stamps always do (test_timebase).
  A dropped sample still leaves a slot empty (two slots between consecutive rows),
  so a real dropout is never hidden.

The slots assume the sampling clock is the time column's clock, as on the
GPS-disciplined loggers of IO-VNBD; a logger whose rate differs from
``1 / period`` slips through the grid and its seconds come out partial where
it slips, as they did before.
"""

from __future__ import annotations

import numpy as np

SECONDS_PER_DAY = 86400.0
# A step back from the last hour of a day into the first hour of the next is a midnight
# rollover (the true step across midnight is then shorter than an hour); any other
# backward step is left for validate to report.
MIDNIGHT_WINDOW_S = 3600.0
# Stamps whose grid phase lies within this fraction of a period of whole multiples of the
# period are on the whole grid: a few milliseconds of logger latency move no second boundary.
WHOLE_GRID_FRACTION = 0.1
PHASE_SAMPLE = 100_000  # stamps the phase is estimated from (evenly spread over the drive)
TIME_EPS_S = 1e-6  # decimal time stamps stored as floats are within this of the true value


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


def grid_phase(t_s: np.ndarray, period_s: float) -> float:
    """The phase of a drive's stamps on its sample grid, s, in ``(-period/2, period/2]``.

    The stamps modulo the period fill an arc of the circle ``[0, period)``, narrower than
    the circle when their jitter is below half a period; the phase is that arc's middle
    (opposite the widest empty arc; unlike a circular mean, exact for jitter up to half a
    period). Within ``WHOLE_GRID_FRACTION`` of a period of zero it is zero (stamps on whole
    multiples). Non-finite stamps are left out.

    Args:
        t_s: times, s.
        period_s: the nominal sample period, s.

    Returns:
        The phase, s (0 for a drive without finite stamps).
    """
    t = np.asarray(t_s, dtype=np.float64)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return 0.0
    if t.size > PHASE_SAMPLE:  # every k-th stamp: the empty arc stays as wide
        t = t[:: -(-t.size // PHASE_SAMPLE)]
    v = np.sort(np.remainder(t, period_s))
    gaps = np.diff(np.r_[v, v[0] + period_s])
    k = int(np.argmax(gaps))
    # The stamps fill an arc of the circle [0, period); its middle is opposite the empty one.
    phase = (v[k] + 0.5 * gaps[k] + 0.5 * period_s) % period_s
    if phase > 0.5 * period_s:
        phase -= period_s
    return 0.0 if abs(phase) <= WHOLE_GRID_FRACTION * period_s else float(phase)


def grid_slots(
    t_s: np.ndarray, period_s: float, phase_s: float | None = None
) -> tuple[np.ndarray, float]:
    """Each row's slot on the drive's sample grid: the nearest ``phase + j * period``.

    Args:
        t_s: times, s (finite).
        period_s: the nominal sample period, s.
        phase_s: the grid's phase (default: :func:`grid_phase` of ``t_s``).

    Returns:
        ``(j, phase)``: the int64 slot numbers and the phase used.
    """
    t = np.asarray(t_s, dtype=np.float64)
    phase = grid_phase(t, period_s) if phase_s is None else phase_s
    return np.rint((t - phase) / period_s).astype(np.int64), phase


def nominal_times(t_s: np.ndarray, period_s: float) -> np.ndarray:
    """Each row's time with its jitter removed: its slot's instant on the drive's grid.

    Args:
        t_s: times, s (finite, increasing).
        period_s: the nominal sample period, s.

    Returns:
        float64 times ``phase + j * period``.
    """
    slots, phase = grid_slots(t_s, period_s)
    return phase + slots * period_s
