"""When each GNSS fix was taken: the receiver's epoch, or the logger's stamp.

A GNSS receiver computes its fixes on a regular grid of its own time: u-blox,
NovAtel and Septentrio receivers put their navigation epochs on whole multiples of
the configured period of GPS time (1, 2, 4, 5, 8, 10, 20 or 25 Hz). A logger that
records the receiver's messages stamps each one when it arrives, after the
receiver's processing and the serial or USB link: the stamp trails the epoch by a
latency that varies from fix to fix (9 ms standard deviation on comma2k19's
example segment, `docs/readers.md`). A fix placed at its stamp is then placed a few
milliseconds from where the car was: at 15 m/s, 5 ms is 7.5 cm, as large as the
per-second labels themselves, and it does not average out of a per-second
displacement (the two fixes at its ends are off independently). Measured on the
built-in fleet as 5 Hz streams with stamps off by up to ±5 ms (uniform,
``benchmarks/fleet_variants.py``): R-WhONet's mean 180 s CRSE 9.75 → 12.50 m.

Two ways to the epochs:

- **The log carries them** (comma2k19's UTC column; a signal map's ``gnss_time``):
  :func:`receiver_epochs` fits the device clock to the receiver's time, one robust
  straight line (an offset and a drift), and each fix goes to its epoch on the
  device clock.
- **The log does not** (:func:`fix_times`, what :func:`rwhonet.data.streams.resample`
  does with every stream drive's fixes): the stamps are fitted to a regular grid of
  a receiver's period, the same line with the epoch's count ``k`` in place of the
  receiver's time. Where the stamps scatter about that grid, two readings of the
  log remain: the fixes were taken at the grid's epochs and stamped late by a
  varying latency (a logger), or taken at their stamps (a receiver with its own
  irregular epochs, or streams resampled from another log at jittered times). The
  wheel speeds tell which: between two consecutive fixes the car rolled what the
  wheels say over the interval between the fixes' true times, so the distance
  between the fixes fits the wheels' distance over those times better, by the
  jitter's share. :func:`fix_times` compares the two (the wheels' distance scaled
  by the median ratio, moving pairs only) and keeps the times the wheels fit
  better (the robust spread of the differences, 1.4826 x their median absolute
  deviation, so a receiver's jumps do not decide); the drive's notes say which,
  with both spreads.

Stamps that already sit on a regular grid (scatter below :data:`MIN_SCATTER_S`), a
stream whose rate is no receiver's, or too few moving fix pairs to tell
(:data:`MIN_PAIRS`) keep their stamps, and so do stamps that fit no one grid
(a receiver restarted on another phase).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rwhonet.data.robust import mad_normal
from rwhonet.geo import local_step_distance_m

# Scatter (1.4826 MAD) of UTC - t around the fitted line above which the epochs are not
# used: well above a log's latency jitter (9 ms on comma2k19), below a 10 Hz fix interval.
MAX_EPOCH_SCATTER_S = 0.04
MIN_EPOCH_FIXES = 10
# Receivers' output periods (1, 2, 4, 5, 8, 10, 20, 25 Hz), and how close the stamps'
# median step must be to one of them (a logger clock's rate error is ppm, not per cent).
RECEIVER_PERIODS_S = (1.0, 0.5, 0.25, 0.2, 0.125, 0.1, 0.05, 0.04)
PERIOD_TOL = 0.02
# Stamps scattering more than this share of a period about the fitted grid are on no grid
# (or on two: a receiver restarted on another phase); the grid's phase is taken over
# PHASE_WINDOW fixes around each.
PHASE_TOL = 0.25
PHASE_WINDOW = 51
# Latency spikes put a few fixes that far (3 % of comma2k19's example at 10 Hz); a receiver
# restarted on another phase puts the fixes after it there.
MAX_FAR_SHARE = 0.1
# A logger's crystal runs within about 100 ppm of the receiver's time; a fitted drift beyond
# this is a line forced through two phases, not a clock.
MAX_DRIFT = 500e-6
# Fixes further apart than this (and than RUN_GAP_PERIODS periods) start a new run of the
# grid, with its own phase and offset.
RUN_GAP_S = 1.5
RUN_GAP_PERIODS = 2.5
# Stamps scattering less than this about the grid are taken as the epochs themselves.
MIN_SCATTER_S = 0.0005
MIN_RUN_FIXES = 20  # fixes a grid is fitted on
# Moving fix pairs (the fixes at least MIN_PAIR_SPEED_M_S apart per second) the wheels
# need to tell the two readings apart.
MIN_PAIRS = 50
MIN_PAIR_SPEED_M_S = 2.0


@dataclass(frozen=True)
class EpochFit:
    """The receiver's epochs on the device clock: ``t_fix = t`` where ``UTC - t = offset +
    drift (t - t_ref)``.

    Attributes:
        offset_s: UTC minus device time at ``t_ref_s``, s.
        drift: rate of the device clock against UTC (s/s).
        t_ref_s: the reference time (the drive's middle fix), device clock.
        scatter_s: 1.4826 x the median absolute residual (the log stamps' jitter), s.
        n_fixes: fixes fitted.
    """

    offset_s: float
    drift: float
    t_ref_s: float
    scatter_s: float
    n_fixes: int

    def on_device_clock(self, utc_s: np.ndarray) -> np.ndarray:
        """Epochs (UTC, s) as times of the device clock."""
        # utc = t + offset + drift (t - t_ref)  =>  t = (utc - offset + drift t_ref) / (1 + drift)
        return (np.asarray(utc_s, np.float64) - self.offset_s + self.drift * self.t_ref_s) / (
            1.0 + self.drift
        )


def receiver_epochs(
    t_s: np.ndarray, utc_ms: np.ndarray, max_scatter_s: float = MAX_EPOCH_SCATTER_S
) -> EpochFit | None:
    """Fit ``UTC - t`` over the fixes robustly: the device clock against the receiver's.

    Slope: the median of the slopes between fixes half the run apart; offset: the median
    of the residuals, so a fix is placed at its epoch plus the *median* latency of the
    log, a constant shift that the wheel speeds' own CAN latency shares in kind.

    Args:
        t_s: the fixes' device-clock stamps, s (increasing).
        utc_ms: their receiver epochs, UTC (or any receiver time) in ms.
        max_scatter_s: residual scatter above which the epochs are not used.

    Returns:
        The fit, or None when the epochs are unusable: not finite, not strictly increasing,
        fewer than ``MIN_EPOCH_FIXES``, or scattered by more than ``max_scatter_s``.
    """
    t = np.asarray(t_s, np.float64)
    utc = np.asarray(utc_ms, np.float64) / 1000.0
    n = t.size
    if n < MIN_EPOCH_FIXES or not np.all(np.isfinite(utc)) or np.any(np.diff(utc) <= 0):
        return None
    d = utc - t
    half = n // 2
    slopes = (d[half : 2 * half] - d[:half]) / (t[half : 2 * half] - t[:half])
    drift = float(np.median(slopes))
    t_ref = float(t[half])
    residual = d - drift * (t - t_ref)
    offset = float(np.median(residual))
    scatter = mad_normal(residual)
    if not scatter <= max_scatter_s:
        return None
    return EpochFit(offset, drift, t_ref, scatter, n)


def receiver_period_s(t_s: np.ndarray) -> float | None:
    """The receiver period the stamps' median step is (within :data:`PERIOD_TOL`), or None."""
    step = np.diff(np.asarray(t_s, np.float64))
    if step.size < MIN_RUN_FIXES:
        return None
    median = float(np.median(step))
    for period in RECEIVER_PERIODS_S:
        if abs(median - period) <= PERIOD_TOL * period:
            return period
    return None


def grid_epochs(t_s: np.ndarray, period_s: float) -> tuple[np.ndarray, float] | None:
    """The stamps fitted to a regular grid of ``period_s``: each fix's epoch on the clock.

    The fixes are split into runs at steps longer than :data:`RUN_GAP_S` and
    :data:`RUN_GAP_PERIODS` periods (a receiver
    that lost its fixes may come back on another phase, a logger that paused on another
    clock offset); in each run, each fix's epoch count ``k`` is its stamp's nearest grid
    instant, the grid's phase taken locally (the circular mean of the stamps' phases
    over :data:`PHASE_WINDOW` fixes around it, so a logger clock drifting against the
    receiver's keeps its count), and :func:`receiver_epochs` fits the line through
    ``k x period`` as the receiver's time, as it does a receiver's own epochs. A run
    of fewer than :data:`MIN_RUN_FIXES` fixes, or one that fits no grid (two fixes on
    one epoch, a drift beyond :data:`MAX_DRIFT`, a scatter above :data:`PHASE_TOL` of a
    period, or more than :data:`MAX_FAR_SHARE` of its fixes that far from their epochs:
    a receiver restarted on another phase, or no receiver's grid at all), keeps its
    stamps.

    Returns:
        ``(epochs, scatter_s)``: the times (a run not fitted keeps its stamps) and the
        median of the fitted runs' scatters, weighted by their fixes; None when no run
        was fitted.
    """
    t = np.asarray(t_s, np.float64)
    out = t.copy()
    fitted: list[tuple[float, int]] = []
    gap = max(RUN_GAP_S, RUN_GAP_PERIODS * period_s)
    for run in np.split(np.arange(t.size), np.flatnonzero(np.diff(t) > gap) + 1):
        epochs = _run_epochs(t[run], period_s)
        if epochs is not None:
            out[run], scatter = epochs
            fitted.append((scatter, run.size))
    if not fitted:
        return None
    scatters = np.repeat([f[0] for f in fitted], [f[1] for f in fitted])
    return out, float(np.median(scatters))


def _run_epochs(t: np.ndarray, period_s: float) -> tuple[np.ndarray, float] | None:
    """One run's epochs and scatter (:func:`grid_epochs`), or None."""
    if t.size < MIN_RUN_FIXES:
        return None
    x = (t - t[0]) / period_s
    z = np.concatenate([[0.0], np.cumsum(np.exp(2j * np.pi * x))])
    h = PHASE_WINDOW // 2
    lo = np.clip(np.arange(t.size) - h, 0, t.size)
    hi = np.clip(np.arange(t.size) + h + 1, 0, t.size)
    phase = np.unwrap(np.angle(z[hi] - z[lo]) / (2.0 * np.pi), period=1.0)
    k = np.rint(x - phase)
    if np.any(np.diff(k) < 1):
        return None
    fit = receiver_epochs(t, 1000.0 * period_s * k, max_scatter_s=PHASE_TOL * period_s)
    if fit is None or abs(fit.drift) > MAX_DRIFT:
        return None
    epochs = fit.on_device_clock(period_s * k)
    if np.mean(np.abs(t - epochs) > PHASE_TOL * period_s) > MAX_FAR_SHARE:
        return None
    return epochs, fit.scatter_s


@dataclass(frozen=True)
class FixTiming:
    """When the fixes were taken, as :func:`fix_times` decided.

    Attributes:
        t_s: the fixes' times on the drive's clock (the stamps, or the grid's epochs).
        at_epochs: whether the grid's epochs were taken.
        note: what was decided and why, for the drive's notes (None: nothing to say).
    """

    t_s: np.ndarray
    at_epochs: bool
    note: str | None


# How far the wheels rolled between two times: ``rolled(start, end) -> (angle, valid)``
# (:meth:`rwhonet.data.streams.TravelledPath.rolled`, the resampler's own integral of the speeds).
Rolled = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _spread_m(step_m: np.ndarray, wheel: np.ndarray) -> float:
    """How far the fix-to-fix distances stray from the wheels' over the same intervals
    (scaled by the median ratio): 1.4826 x the median absolute deviation, so a
    receiver's jumps and a few odd pairs do not decide."""
    ok = wheel > 0
    scale = float(np.median(step_m[ok] / wheel[ok])) if ok.any() else 1.0
    r = step_m - scale * wheel
    return mad_normal(r)


def fix_times(
    t_s: np.ndarray,
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    rolled: Rolled,
    where: str = "GNSS",
) -> FixTiming:
    """The fixes' times: their stamps, or the receiver grid's epochs where the wheels say so.

    Args:
        t_s: the fixes' stamps (strictly increasing), s.
        lat_deg: their latitudes, deg (real fixes only).
        lon_deg: their longitudes, deg.
        rolled: how far the wheels rolled between two times, rad, and whether the wheel
            speeds cover the interval (:data:`Rolled`); asked only when the stamps
            scatter about a grid.
        where: the stream, for the note.

    Returns:
        The times and what was decided (the module docstring).
    """
    t = np.asarray(t_s, np.float64)
    period = receiver_period_s(t)
    if period is None:
        return FixTiming(t, False, None)
    grid = grid_epochs(t, period)
    if grid is None:
        return FixTiming(t, False, None)
    epochs, scatter = grid
    if scatter < MIN_SCATTER_S:
        return FixTiming(t, False, None)
    step_m = local_step_distance_m(np.asarray(lat_deg), np.asarray(lon_deg))
    wheel_stamps, on_stamps_ok = rolled(t[:-1], t[1:])
    wheel_epochs, on_epochs_ok = rolled(epochs[:-1], epochs[1:])
    pairs = np.flatnonzero(
        on_stamps_ok
        & on_epochs_ok
        & (np.diff(t) <= 1.5 * period)
        & (step_m >= MIN_PAIR_SPEED_M_S * period)
        & np.isfinite(step_m)
    )
    rate = f"{1.0 / period:g} Hz"
    stamped = f"{where}: the fix stamps scatter {scatter * 1000:.1f} ms about a regular {rate} grid"
    if pairs.size < MIN_PAIRS:
        return FixTiming(
            t,
            False,
            f"{stamped}; too few moving fix pairs ({pairs.size} of {MIN_PAIRS}) for the wheel "
            "speeds to tell whether the fixes were taken at the grid's epochs: stamps kept",
        )
    on_stamps = _spread_m(step_m[pairs], wheel_stamps[pairs])
    on_epochs = _spread_m(step_m[pairs], wheel_epochs[pairs])
    fits = (
        f"the distance between consecutive fixes less the wheels' over the interval "
        f"scatters {on_epochs:.3f} m (1.4826 MAD) at the grid's epochs, {on_stamps:.3f} m "
        f"at the stamps, {pairs.size} moving pairs"
    )
    if on_epochs < on_stamps:
        return FixTiming(
            epochs,
            True,
            f"{stamped}; {fits}: fixes placed at the grid's epochs (a logger stamping fixes "
            "as they arrive), each moved by at most "
            f"{float(np.max(np.abs(epochs - t))) * 1000:.1f} ms",
        )
    return FixTiming(t, False, f"{stamped}; {fits}: stamps kept (the fixes' own times)")
