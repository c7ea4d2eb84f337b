"""How late the fixes are stamped against the wheel speeds: a constant lag, from the wheels.

:mod:`rwhonet.data.fixtimes` puts each fix at its receiver epoch, or keeps its stamp; a
log whose stamps carry the receiver's *latency* keeps it either way. comma2k19's
reader places each fix at its epoch plus the log's median latency
(:func:`rwhonet.data.fixtimes.receiver_epochs`), and a logger that stamps fixes as they
arrive places them after the receiver's processing and the link; the wheel speeds'
CAN stamps carry a latency of their own. What matters to the
per-second labels is the difference, ``lag``: a fix stamped ``t`` was taken when the
wheels' clock read ``t - lag``. A per-second GNSS displacement then covers the wheels'
second shifted by the lag, and differs from the wheels' distance over their own second
by ``(v(t + 1) - v(t)) lag``: 8.5 cm at a change of 1 m/s with a lag of 85 ms, as
large as the labels themselves (a lag alone fits comma2k19's example minute best at
75-100 ms; with tyre slip told apart, below, one minute is too short to say:
``docs/readers.md``).

The wheels tell the lag. Over pairs of fixes about a second apart
(:data:`PAIR_SPAN_S`, consecutive at 1 Hz), the distance between the fixes is the
distance the car covered between their true times, and the wheels' path
(:class:`rwhonet.data.streams.TravelledPath`: the rolled angle, turned by the gyro where
the drive has one, so that a bend's chord is a chord on both sides) gives it up to one
scale between any two times. A lag makes the misfit grow with the speed change over
the pair.

Tyre slip does too, and must not be taken for a lag. A tyre carries a longitudinal force
by slipping in proportion to it (the slip stiffness, linear below ~10 % of the
friction: Pacejka, *Tyre and Vehicle Dynamics*, 2012, ch. 1; Gillespie, *Fundamentals of
Vehicle Dynamics*, 1992, ch. 2): driving wheels read ``kappa a`` more than the car
covers when speeding up, braked wheels less when slowing. Over a pair that is
``kappa a v T``, a lag of ``kappa v``: with the simulator's slip stiffness (25 per unit
load, a front-driven car: ~0.4 % per m/s^2 on the four wheels' mean) 40 ms at 10 m/s,
which a fit of the lag alone takes as one (measured: +40 to +45 ms on simulated drives
whose fixes and wheels share one clock). The two differ in form: a lag's misfit goes
with the speed change, slip's with the speed change times the speed. So the model is

    d = beta_0 w(lag) + beta_+ a_+ w(lag) + beta_- a_- w(lag)

with ``d`` the distance between the fixes, ``w(lag)`` the wheels' chord between their
times moved by ``lag`` (rad), ``a_+`` / ``a_-`` the wheels' mean angular acceleration
over the pair (from its two halves) when positive / negative: one scale and one slip
figure each way. Pairs whose wheels change speed by more than :data:`MAX_ACC_M_S2`
over the second are left out: beyond the tyres' linear slip range (a hard brake, a
launch) the slip is not the linear term's, and those pairs weigh most on the lag.
:func:`fix_lag` profiles the lag: for each lag of a grid (every
:data:`COARSE_STEP_S` over ``±``:data:`MAX_LAG_S`, then every :data:`GRID_STEP_S`
around the best), the three coefficients by Huber's M-estimate (iteratively reweighted
least squares, the residual scale held, so a receiver's jumps and a hard brake's
locked wheels count less); the lag is the vertex of the parabola through the best
three (the coarse search on every k-th pair of a long drive: it only places the fine
grid). Its standard error is the larger of two: the objective's curvature there (the
fixes' and wheels' noise, inflated by how many overlapping pairs share each second),
and a delete-a-block jackknife over :data:`JACKKNIFE_BLOCKS` stretches of the drive
(what the model leaves: a slip that changes along the drive, a wet stretch, a load),
each refit walking the fine grid downhill from the whole drive's best point.
Speed changes carry the information: a drive at a constant speed cannot tell a lag,
and its standard error says so.

What is done with it is the user's choice (``data.gnss_lag``, :func:`lagged_times`):
``report`` (the default) says the estimate in the drive's notes and moves nothing,
so a stream drive's labels are made as a 10 Hz file's are, and as the paper's authors
made theirs, with whatever lag the logger has; ``auto`` moves the fixes by the lag
where it is at least :data:`MIN_LAG_S` and :data:`LAG_SIGMAS` standard errors, found
inside the search over at least :data:`MIN_PAIRS` seconds of moving pairs; a number
moves them by that. Measured on simulated drives with known latencies
(``tests/data/test_fixlag.py``, ``docs/readers.md``, "A receiver's latency").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from rwhonet.data.robust import mad_normal
from rwhonet.errors import InputError, Problem
from rwhonet.geo import local_distance_m

# Fixes about this far apart are paired: long enough for a speed change to show, short
# enough that the chord between them is the path's (the wheels' path has the same chord).
PAIR_SPAN_S = 1.0
# The lags searched: a receiver's latency is tens to hundreds of ms; a second or more is
# two clocks, not a latency.
MAX_LAG_S = 1.0
# Two clocks are searched for over this much (coarsely, every WIDE_STEP_S) where the lag
# is not inside the latency's search: GNSS time scales differ from UTC and each other by
# whole seconds (CLOCK_OFFSETS), a logger's clock set by hand by any amount.
WIDE_LAG_S = 60.0
WIDE_STEP_S = 0.25
# The two-clock fit must explain the fixes this well: the correlation of the fixes'
# distances with the wheels' chords (0.9999 on simulated drives with a survey-grade
# receiver; about 0.93 where 1 Hz fixes scatter 1.5 m and the speed 5 m/s).
WIDE_MIN_CORR = 0.8
# ... and better than at the profile's every other peak by this factor on the misfit
# (1 - correlation): a speed that repeats itself (a test track's laps, stop-and-go) fits
# at several lags alike, and no clock is told.
WIDE_UNIQUE = 3.0
# Offsets between time scales (the IERS's leap seconds: TAI - UTC = 37 s since 1 Jan 2017;
# GPS time = TAI - 19 s; BeiDou time = GPS time - 14 s): offset -> what it is.
CLOCK_OFFSETS = {
    18.0: "GPS time runs 18 s ahead of UTC since 2017",
    14.0: "BeiDou time runs 14 s behind GPS time",
    4.0: "BeiDou time runs 4 s ahead of UTC since 2017",
    19.0: "TAI runs 19 s ahead of GPS time",
    37.0: "TAI runs 37 s ahead of UTC since 2017",
    1.0: "a leap second: UTC by a leap-second count one out of date",
}
COARSE_STEP_S = 0.05
GRID_STEP_S = 0.01
# Smaller lags are left alone: 10 ms changes a second's displacement by 1 cm per m/s of
# speed change, and the estimate is 1-3 ms off the truth on simulated drives.
MIN_LAG_S = 0.01
LAG_SIGMAS = 3.0
MAX_ACC_M_S2 = 3.0  # 0.3 g: the linear part of the tyres' slip curve (docs/readers.md)
JACKKNIFE_BLOCKS = 10
COARSE_PAIRS = 2000  # the coarse search's pairs at least (every k-th of a long drive's)
MAX_SE_S = 0.1  # a standard error beyond this: nothing to say about the lag
MIN_PAIRS = 30  # seconds of moving pairs
# The misfit's scale is taken as at least this (a receiver's centimetres, a wheel's
# resolution over a second): noise-free data must not make a flat misfit look certain.
MIN_SCATTER_M = 0.001
MIN_PAIR_SPEED_M_S = 2.0


class TravelledPathLike(Protocol):
    """What :func:`fix_lag` asks of the wheels' path
    (:class:`rwhonet.data.streams.TravelledPath`)."""

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def rolled(self, start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def sample(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class FixLag:
    """How late the fixes' stamps are against the wheels' clock, as :func:`fix_lag` found.

    Attributes:
        lag_s: the estimate, s: a fix stamped ``t`` was taken at ``t - lag_s`` of the
            wheels' clock (NaN: not estimated).
        se_s: its standard error, s (NaN: not estimated; inf: not determined).
        n_pairs: seconds of moving fix pairs the estimate rests on (pairs / overlap).
        clear: whether the lag is clear enough to move the fixes by (at least
            :data:`MIN_LAG_S` and :data:`LAG_SIGMAS` standard errors, inside the search).
        finding: what was found, for the drive's notes (None: too few moving pairs).
        two_clocks: the lag is beyond a receiver's latency (more than :data:`MAX_LAG_S`,
            found by :func:`_two_clocks`): the fixes and the wheel speeds are stamped by
            two clocks.
    """

    lag_s: float
    se_s: float
    n_pairs: int
    clear: bool
    finding: str | None
    two_clocks: bool = False


def _pairs(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Fix index pairs about :data:`PAIR_SPAN_S` apart (``stride`` fixes), one starting
    every ``max(1, stride // 2)`` fixes (at 10 Hz two overlapping pairs cover each
    second: more would repeat the same seconds' misfits), within runs without a missing
    fix; and how many pairs share a second (``stride / hop``)."""
    step = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    stride = max(1, int(round(PAIR_SPAN_S / step)))
    hop = max(1, stride // 2)
    i = np.arange(0, max(t.size - stride, 0), hop)
    j = i + stride
    span = t[j] - t[i]
    ok = (span > (stride - 0.5) * step) & (span < (stride + 0.5) * step)
    return i[ok], j[ok], stride / hop


HUBER_K = 1.345  # Huber's tuning constant: 95 % efficiency on normal residuals
IRLS_STEPS = 4


def _lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """numpy's least squares, refused before LAPACK sees a value that is not finite: LAPACK
    then prints "On entry to DLASCL parameter number 4 had an illegal value" to the
    process's stdout (where ``rwhonet predict`` may be writing its seconds) and numpy
    raises ``LinAlgError``; here only the error is raised."""
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise np.linalg.LinAlgError("values that are not finite")
    return np.linalg.lstsq(a, b, rcond=None)[0]


def _huber_fit(x: np.ndarray, d: np.ndarray, scale: float) -> tuple[np.ndarray, float]:
    """Huber's M-estimate of ``d ~ x beta`` with the residual scale held (iteratively
    reweighted least squares), and its objective ``sum rho(r / scale) scale^2``."""
    w = np.ones(d.size)
    beta, u = np.zeros(x.shape[1]), np.abs(d) / scale
    # The weighted normal equations, a 3 x 3 solve at a fraction of lstsq's time on the
    # rows; the columns scaled to unit norm first, so that a nearly empty one (the slip
    # terms at a steady speed) does not square the condition into noise.
    norm = np.linalg.norm(x, axis=0)
    xs = x / np.where(norm > 0, norm, 1.0)
    for _ in range(IRLS_STEPS):
        xw = xs * w[:, None]
        coef = _lstsq(xw.T @ xs, xw.T @ d)
        beta = coef / np.where(norm > 0, norm, 1.0)
        u = np.abs(d - xs @ coef) / scale
        w = np.where(u <= HUBER_K, 1.0, HUBER_K / np.maximum(u, 1e-12))
    rho = np.where(u <= HUBER_K, 0.5 * u**2, HUBER_K * u - 0.5 * HUBER_K**2)
    return beta, float(2.0 * rho.sum() * scale**2)


def _vertex(grid: np.ndarray, costs: np.ndarray) -> tuple[float, float]:
    """The vertex of the parabola through the grid's best three (kept within a step of the
    best), and the objective's curvature there (<= 0: none)."""
    best = int(np.clip(np.argmin(costs), 1, grid.size - 2))
    c_m, c_0, c_p = costs[best - 1 : best + 2]
    step = float(grid[1] - grid[0])
    curv = (c_m - 2.0 * c_0 + c_p) / step**2
    shift = 0.5 * (c_m - c_p) / (c_m - 2.0 * c_0 + c_p) if curv > 0 else 0.0
    return float(grid[best] + np.clip(shift, -1.0, 1.0) * step), float(curv)


def _descend(cost_at: Callable[[int], float], start: np.ndarray) -> np.ndarray:
    """A profile's costs along a grid, computed only from the grid's best point of
    ``start`` (another profile's costs on it) downhill to the nearest local minimum, with
    that minimum's two neighbours (inf where not computed): :func:`_vertex` of them is
    :func:`_vertex` of the whole profile wherever it has one minimum, at about a third
    of the fits when the minimum stays near ``start``'s."""
    costs = np.full(start.size, np.inf)
    i = int(np.clip(np.argmin(start), 1, start.size - 2))
    while True:
        for g in (i - 1, i, i + 1):
            if np.isinf(costs[g]):
                costs[g] = cost_at(g)
        step = int(np.argmin(costs[i - 1 : i + 2])) - 1
        if step == 0 or not 1 <= i + step <= start.size - 2:
            return costs
        i += step


def _two_clocks(
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    path: TravelledPathLike,
    ti: np.ndarray,
    tj: np.ndarray,
    d: np.ndarray,
    n: int,
    where: str,
) -> FixLag | None:
    """The lag of fixes stamped by another clock than the wheels' (None: none found).

    The coarse search: for each lag every :data:`WIDE_STEP_S` over ``±``:data:`WIDE_LAG_S`,
    the correlation of the pairs' distances ``d`` (fixes ``ti``, ``tj``) with the wheels'
    chords between the lagged times (pairs whose lagged stretch the wheels' path does not
    cover left out): the speed's changes line up only at the clocks' offset. Then
    :func:`fix_lag` on the fixes moved by the best lag, the latency's search around it.
    Found where the correlation there is at least :data:`WIDE_MIN_CORR`, its misfit is
    :data:`WIDE_UNIQUE` times smaller than at the profile's every other peak, and the best
    lag is at or beyond ``±``:data:`MAX_LAG_S` (the latency's search's edge: a leap
    second's offset is 1 s exactly); placed to within ms by the latency's search
    around it where that can (standard error at most :data:`MAX_SE_S`), else to within the
    coarse grid.
    """
    lags = np.arange(-WIDE_LAG_S, WIDE_LAG_S + 0.5 * WIDE_STEP_S, WIDE_STEP_S)
    corr = np.full(lags.size, -np.inf)
    for k, lag in enumerate(lags):
        z_a, p_a = path(ti - lag)
        z_b, p_b = path(tj - lag)
        ok = (p_a >= 0) & (p_a == p_b)
        if ok.sum() >= MIN_PAIRS:
            w = np.abs(z_b[ok] - z_a[ok])
            if np.std(w) > 0 and np.std(d[ok]) > 0:
                corr[k] = float(np.corrcoef(w, d[ok])[0, 1])
    best = int(np.argmax(corr))
    coarse = float(lags[best])
    inner = corr[1:-1]
    peaks = 1 + np.flatnonzero((inner >= corr[:-2]) & (inner >= corr[2:]) & np.isfinite(inner))
    others = corr[peaks[np.abs(lags[peaks] - coarse) > WIDE_STEP_S]]
    runner_up = float(others.max()) if others.size else -np.inf
    unique = 1.0 - runner_up >= WIDE_UNIQUE * (1.0 - corr[best])
    if not (corr[best] >= WIDE_MIN_CORR and unique and abs(coarse) >= MAX_LAG_S):
        return None
    # the correlation's peak to within its grid (the parabola's vertex), then to within
    # ms where the latency's search can place it about there (a noisy receiver's fixes
    # cannot: the peak's vertex stands, its standard error a quarter step)
    k = int(np.clip(best, 1, lags.size - 2))
    lag, curv = _vertex(lags[k - 1 : k + 2], -corr[k - 1 : k + 2])
    se = 0.25 * WIDE_STEP_S
    if not (np.isfinite(lag) and curv > 0):
        lag = coarse
    fine = fix_lag(t - lag, lat, lon, path, where, wide=False)
    if fine.finding is not None and fine.se_s <= MAX_SE_S and np.isfinite(fine.lag_s):
        lag, se, n = lag + fine.lag_s, fine.se_s, fine.n_pairs
    known = [why for offset, why in CLOCK_OFFSETS.items() if abs(abs(lag) - offset) <= 0.5]
    finding = (
        f"{where}: the distance between fixes fits the wheels' path best with the fixes "
        f"{abs(lag):.3f} ± {se:.3f} s {'earlier' if lag >= 0 else 'later'} than "
        f"stamped (correlation {corr[best]:.4f}; {n} s of moving pairs): far "
        f"beyond a receiver's latency, the fixes and the wheel speeds are stamped by two "
        f"clocks" + (f" ({known[0]}?)" if known else "")
    )
    return FixLag(lag, se, n, True, finding, two_clocks=True)


def fix_lag(
    t_s: np.ndarray,
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    path: TravelledPathLike,
    where: str = "GNSS",
    wide: bool = True,
) -> FixLag:
    """The fixes' lag against the wheel speeds (the module docstring), and whether to move them.

    A wheels' path that cannot be fitted (a wheel sample so large, 1e300 rad/s in a
    corrupt cell, that its squares overflow: the least squares do not converge) gives no
    estimate, and a finding that says so; the glitch screen and validate's range check
    deal with the sample itself.

    Args:
        t_s: the fixes' times (strictly increasing; after
            :func:`rwhonet.data.fixtimes.fix_times`), s.
        lat_deg: their latitudes, deg (real fixes only).
        lon_deg: their longitudes, deg.
        path: the wheels' path (:class:`rwhonet.data.streams.TravelledPath`).
        where: the stream, for the note.
        wide: where the best lag is at the edge of the latency's search, search for two
            clocks (:func:`_two_clocks`).

    Returns:
        The lag, its standard error and the decision.
    """
    try:
        with np.errstate(all="ignore"):
            return _fix_lag(t_s, lat_deg, lon_deg, path, where, wide)
    except np.linalg.LinAlgError:
        finding = (
            f"{where}: the fixes' lag against the wheel speeds not estimated: the wheels' "
            "path does not fit (a wheel speed too large for the arithmetic)"
        )
        return FixLag(float("nan"), float("nan"), 0, False, finding)


def _fix_lag(
    t_s: np.ndarray,
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    path: TravelledPathLike,
    where: str,
    wide: bool,
) -> FixLag:
    """:func:`fix_lag`'s estimate, without the guard against a path that does not fit."""
    t = np.asarray(t_s, np.float64)
    if t.size < MIN_PAIRS:
        return FixLag(float("nan"), float("nan"), 0, False, None)
    i, j, overlap = _pairs(t)
    # Pairs whose wheel path is unbroken however far the lag moves them.
    _, p_lo = path(t[i] - MAX_LAG_S)
    _, p_hi = path(t[j] + MAX_LAG_S)
    lat, lon = np.asarray(lat_deg, np.float64), np.asarray(lon_deg, np.float64)
    d = local_distance_m(lat[i], lon[i], lat[j], lon[j])  # as fix_times measures its steps
    keep = (p_lo >= 0) & (p_lo == p_hi) & np.isfinite(d) & (d >= MIN_PAIR_SPEED_M_S * (t[j] - t[i]))
    i, j, d = i[keep], j[keep], d[keep]
    n = int(i.size / overlap)  # seconds of pairs: overlapping pairs are not independent
    if n < MIN_PAIRS:
        return FixLag(float("nan"), float("nan"), n, False, None)
    ti, tj = t[i], t[j]
    tm, span = 0.5 * (ti + tj), tj - ti

    def design(lag: float, rows: slice = slice(None)) -> np.ndarray:
        """``[w, a+ w, a- w]`` of the pairs ``rows``: the wheels' chord over the lagged
        interval (rad), and it times the interval's mean angular acceleration (``4 (second
        half - first half) / T^2``, rad/s^2), split by sign: slip's share of the distance
        (the module docstring)."""
        a, m, b = ti[rows], tm[rows], tj[rows]
        z, cum = path.sample(np.concatenate([a, m, b]) - lag)  # one search for all three
        k = a.size
        w = np.abs(z[2 * k :] - z[:k])
        first, second = cum[k : 2 * k] - cum[:k], cum[2 * k :] - cum[k : 2 * k]
        acc = 4.0 * (second - first) / span[rows] ** 2
        return np.column_stack([w, np.maximum(acc, 0.0) * w, np.minimum(acc, 0.0) * w])

    # Pairs beyond the tyres' linear slip range left out (a hard brake, a launch).
    x0 = design(0.0)
    radius = float(_lstsq(x0[:, :1], d)[0])
    acc_m_s2 = radius * (x0[:, 1] + x0[:, 2]) / np.maximum(x0[:, 0], 1e-12)
    linear = np.abs(acc_m_s2) <= MAX_ACC_M_S2
    ti, tj, tm, span, d = ti[linear], tj[linear], tm[linear], span[linear], d[linear]
    n = int(ti.size / overlap)
    if n < MIN_PAIRS:
        return FixLag(float("nan"), float("nan"), n, False, None)
    x0 = x0[linear]
    beta0 = _lstsq(x0, d)
    scatter0 = mad_normal(d - x0 @ beta0)
    scale = max(scatter0, MIN_SCATTER_M)

    # Coarse to fine: every COARSE_STEP_S over the search, then every GRID_STEP_S around
    # the coarse best; the vertex of the parabola through the fine grid's best three.
    # The coarse search fits every k-th pair of a long drive (at least COARSE_PAIRS of
    # them): it only places the fine grid, which every pair is fitted on.
    thin = slice(None, None, max(1, d.size // COARSE_PAIRS))

    def cost(lag: float) -> float:
        return _huber_fit(design(lag, thin), d[thin], scale)[1]

    coarse = np.arange(-MAX_LAG_S, MAX_LAG_S + 0.5 * COARSE_STEP_S, COARSE_STEP_S)
    c_best = int(np.argmin([cost(float(g)) for g in coarse]))
    if c_best in (0, coarse.size - 1):
        clocks = _two_clocks(t, lat, lon, path, ti, tj, d, n, where) if wide else None
        if clocks is not None:
            return clocks
        edge = (
            f"{where}: the fixes fit the wheel speeds best at the edge of the ±{MAX_LAG_S:g} s "
            "searched, no lag a receiver has (are the GNSS and the wheel speeds on one clock?)"
        )
        return FixLag(float(coarse[c_best]), float("inf"), n, False, edge)
    grid = coarse[c_best] + np.arange(-COARSE_STEP_S, COARSE_STEP_S + 1e-9, GRID_STEP_S)
    designs = [design(float(g)) for g in grid]
    costs = np.array([_huber_fit(x, d, scale)[1] for x in designs])
    lag, curv = _vertex(grid, costs)
    x_lag = design(lag)
    beta, _ = _huber_fit(x_lag, d, scale)
    r = d - x_lag @ beta
    sigma = max(mad_normal(r), MIN_SCATTER_M)
    # The objective's curvature gives the standard error the noise makes: var = 2 sigma^2
    # / S'' for a least-squares objective S, inflated by the overlap (each second's misfit
    # counted that many times). What the model leaves (the slip changing along the drive:
    # a wet stretch, a load) it does not see; the delete-a-block jackknife does (Efron and
    # Tibshirani, An Introduction to the Bootstrap, 1993, ch. 11): the drive's pairs in
    # JACKKNIFE_BLOCKS stretches of time, the lag refitted without each, on the same grid
    # (from the whole drive's best point downhill to the nearest minimum: the grid's own
    # wherever the profile has one minimum there, as on 120 simulated drives of
    # 90-2,400 s, whose lags and standard errors are the full grid's to 2e-12 ms).
    se_noise = float(np.sqrt(2.0 * sigma**2 * overlap / curv)) if curv > 0 else float("inf")
    block = np.minimum((np.arange(d.size) * JACKKNIFE_BLOCKS) // d.size, JACKKNIFE_BLOCKS - 1)
    left_out = []
    for b in range(JACKKNIFE_BLOCKS):
        keep = block != b
        d_b = d[keep]
        c_b = _descend(lambda g, k=keep, y=d_b: _huber_fit(designs[g][k], y, scale)[1], costs)
        left_out.append(_vertex(grid, c_b)[0])
    spread = np.asarray(left_out) - np.mean(left_out)
    se_jack = float(np.sqrt((JACKKNIFE_BLOCKS - 1) / JACKKNIFE_BLOCKS * np.sum(spread**2)))
    se = max(se_noise, se_jack)
    if not se <= MAX_SE_S:
        # a lag the latency's search cannot place: two clocks far apart give that too
        clocks = _two_clocks(t, lat, lon, path, ti, tj, d, n, where) if wide else None
        if clocks is not None:
            return clocks
        vague = (
            f"{where}: the speed changes too little between fixes for the wheels to tell a "
            f"lag (its standard error {se:.2g} s over {n} s of moving pairs)"
        )
        return FixLag(lag, se, n, False, vague)
    k = float(beta[0])
    slip = [100.0 * -b / k**2 for b in beta[1:]]  # % of the distance per m/s^2
    found = (
        f"{where}: the distance between fixes {PAIR_SPAN_S:g} s apart fits the wheels' best "
        f"with the fixes {abs(lag) * 1000:.0f} ± {se * 1000:.0f} ms "
        f"{'earlier' if lag >= 0 else 'later'} than stamped (it scatters {sigma:.3f} m, "
        f"1.4826 MAD, against {scatter0:.3f} m at "
        f"the stamps; wheel slip {slip[0]:.2f} / {slip[1]:.2f} % per m/s^2 speeding up / "
        f"slowing; {n} s of moving pairs)"
    )
    clear = abs(lag) >= MIN_LAG_S and abs(lag) >= LAG_SIGMAS * se
    return FixLag(lag, se, n, clear, found)


class LaggedTimes(NamedTuple):
    """The fixes' times on the wheels' clock (:func:`lagged_times`).

    Attributes:
        t_s: the times, s.
        note: what was found and done (None: nothing to say).
        moved: whether the fixes were moved.
        two_clocks: moved by two clocks' offset (at least :data:`MAX_LAG_S`), not a
            receiver's latency: the fix times are then placed again on the wheels' clock.
    """

    t_s: np.ndarray
    note: str | None
    moved: bool
    two_clocks: bool = False


def lagged_times(
    t_s: np.ndarray,
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    path: TravelledPathLike,
    mode: str | float,
    where: str = "GNSS",
) -> LaggedTimes:
    """The fixes' times on the wheels' clock as ``mode`` (``data.gnss_lag``) says.

    Fixes stamped by another clock (:attr:`FixLag.two_clocks`) are moved by ``auto`` and
    by the user's figure, and refused by ``report``.

    Args:
        t_s, lat_deg, lon_deg, path, where: as :func:`fix_lag`.
        mode: ``"report"`` (estimate and say it, move nothing), ``"auto"`` (move the
            fixes by the estimate where it is clear) or a lag in seconds (move them by it).

    Returns:
        The times, what was found and done, whether the fixes were moved, and whether by
        two clocks' offset (:class:`LaggedTimes`).

    Raises:
        InputError: ``report`` of fixes stamped by another clock than the wheels'.
    """
    t = np.asarray(t_s, np.float64)
    if isinstance(mode, str) and mode not in ("report", "auto"):
        raise ValueError(f"gnss_lag must be 'report', 'auto' or seconds, got {mode!r}")
    lag = fix_lag(t, lat_deg, lon_deg, path, where)
    if not isinstance(mode, str):
        said = f"; the wheels' estimate: {lag.finding.split(': ', 1)[1]}" if lag.finding else ""
        return LaggedTimes(
            t - float(mode),
            f"{where}: fixes moved by {-float(mode) * 1000:+.0f} ms onto the wheels' clock "
            f"(data.gnss_lag = {float(mode):g} s){said}",
            True,
            lag.two_clocks or abs(float(mode)) >= MAX_LAG_S,  # as auto's, where it finds them
        )
    if lag.finding is None:
        return LaggedTimes(t, None, False)
    if lag.two_clocks:
        if mode == "auto":
            moved = f"{-lag.lag_s:+.2f} s onto the wheels' clock (data.gnss_lag = auto)"
            return LaggedTimes(t - lag.lag_s, f"{lag.finding}: fixes moved by {moved}", True, True)
        # per-second labels of fixes seconds off their wheels' seconds are no labels, and
        # validate would take the mismatch for wheels that stopped logging
        raise InputError(
            [
                Problem(
                    where,
                    None,
                    None,
                    "the fixes and the wheel speeds stamped by one clock (the fixes late by "
                    f"a receiver's latency at most, ±{MAX_LAG_S:g} s)",
                    lag.finding.split(": ", 1)[1],
                    f"set data.gnss_lag: {lag.lag_s:.3f} (the fixes moved onto the wheels' "
                    "clock) or auto, or stamp the streams by one clock",
                )
            ],
            summary=f"{where}: the fixes and the wheel speeds on two clocks",
        )
    moved = f"{-lag.lag_s * 1000:+.0f} ms onto the wheels' clock"
    if not lag.clear:
        rule = f"under {MIN_LAG_S * 1000:.0f} ms or {LAG_SIGMAS:g} standard errors"
        kept = "" if np.isinf(lag.se_s) else f" ({rule})"
        return LaggedTimes(t, f"{lag.finding}: stamps kept{kept}", False)
    if mode == "auto":
        note = f"{lag.finding}: fixes moved by {moved} (data.gnss_lag = auto)"
        return LaggedTimes(t - lag.lag_s, note, True)
    return LaggedTimes(
        t,
        f"{lag.finding}: stamps kept (data.gnss_lag = report; auto would move the fixes by "
        f"{moved})",
        False,
    )
