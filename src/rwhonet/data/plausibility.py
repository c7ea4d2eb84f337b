"""Plausibility of wheel speeds, yaw rate, positions: units, sign, stuck sensors, swapped axes.

Wheel odometry gives a displacement ``x = ∫ ω r dt`` per second (paper Eq. 10). Over
many seconds, GNSS distance / wheel angle is therefore an effective rolling radius
(the calibration constant of the authors' code, in m/rad). A drive whose implied
radius is far from the vehicle's nominal one has wheel speeds in the wrong unit, and
the ratio says which: rpm gives 2π/60 of the radius, deg/s π/180, and a linear wheel
speed in km/h (m/s) gives a "radius" of 1/3.6 m (1 m) whatever the tyre. The same
radius, with latitude and longitude exchanged, tells swapped coordinate columns.

Wheel speeds are magnitudes, as ABS sensors give them (also when reversing): the WPM
integrates them into a distance and GNSS gives a distance, so a negated column would
make every label about twice the distance travelled. A logger that signs its speeds
shows reversing as all four wheels negative together for a short while; those rows are
taken as magnitudes (:func:`reversing_rows`). And the four wheels of a moving
car turn at nearly the same speed: a wheel reading zero while the others turn is a
broken sensor or channel, whose feature the network would learn from.

A yaw rate turns the car as the GNSS course turns (:func:`yaw_gain`): the gain of the
course's turn on the gyro's is about 1 for a yaw rate in the declared unit and sign,
-1 for a gyro positive clockwise (SAE J670's z down) read as ISO 8855's positive left,
π/180 for degrees read as radians and 180/π the other way round, and about 0 for a
channel that does not follow the car (zeros, another signal). Each axle's wheels turn it
too (:func:`wheel_side_gains`): the outer wheel runs faster, so the course turns with the
right wheel's speed less the left's, and a pair whose columns are exchanged turns it the
other way. And the front axle runs on a wider arc than the rear in a tight turn
(:func:`axle_order_gain`): its wheels turn faster, the rear ones where the front and rear
columns are exchanged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rwhonet.config import WheelPolicy
from rwhonet.data import canonical as c
from rwhonet.data.glitches import repaired_yaw_rate
from rwhonet.data.quality import Segment, second_index
from rwhonet.data.robust import cumulative_trapezoid
from rwhonet.geo import geodesic_distance_m, local_distance_m, local_step_distance_m
from rwhonet.geo.geodesic import wgs84


@dataclass(frozen=True)
class RadiusEstimate:
    """Effective rear-wheel radius implied by a drive's valid segments."""

    radius_m: float  # NaN when there was no moving second
    moving_s: int  # seconds that entered the estimate
    distance_m: float  # GNSS distance over those seconds
    angle_rad: float  # rear wheel angle over those seconds


def implied_radius(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    moving_wheel_speed_rad_s: float,
    sample_period_s: float | None = None,
) -> RadiusEstimate:
    """Sum of GNSS distance / sum of rear wheel angle over the moving seconds of the segments.

    Per whole second (the rows in ``(k - 1, k]``) the GNSS distance is the ellipsoidal
    distance between the last fixes of seconds ``k - 1`` and ``k``; the wheel angle is the
    trapezoidal integral of the mean |rear wheel speed| over the same interval. A second
    counts when its mean rear wheel speed exceeds ``moving_wheel_speed_rad_s`` and both
    seconds lie in the same segment.

    Args:
        drive: canonical columns of the drive (``t_s``, ``lat_deg``, ``lon_deg``, rear wheels).
        segments: the drive's valid segments.
        moving_wheel_speed_rad_s: wheel speed above which a second counts as moving.
        sample_period_s: the nominal sample period, to place jittered stamps in their
            seconds as :func:`rwhonet.data.quality.assess` does (None: the stamps as they are;
            the estimate is the same either way, since distance and angle are taken between
            the same rows, only the seconds' bounds move by a row).

    Returns:
        The estimate (``radius_m`` is NaN when no second counted).
    """
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    wheel = 0.5 * (np.abs(np.asarray(drive[c.OMEGA_RL])) + np.abs(np.asarray(drive[c.OMEGA_RR])))
    prev, this, _ = _second_chords(t, segments, sample_period_s)
    if prev.size == 0:
        return RadiusEstimate(float("nan"), 0, 0.0, 0.0)
    # Cumulative wheel angle, so the angle between any two rows is one subtraction.
    angle = cumulative_trapezoid(wheel, t)
    angle_s = angle[this] - angle[prev]
    moving = angle_s / (t[this] - t[prev]) > moving_wheel_speed_rad_s
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    dist = geodesic_distance_m(lat[prev], lon[prev], lat[this], lon[this])
    total_m, total_rad = float(dist[moving].sum()), float(angle_s[moving].sum())
    radius = total_m / total_rad if total_rad > 0 else float("nan")
    return RadiusEstimate(radius, int(moving.sum()), total_m, total_rad)


def _second_chords(
    t: np.ndarray, segments: Sequence[Segment], sample_period_s: float | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of the fixes that end consecutive seconds inside one valid segment.

    Returns:
        ``(prev, this, seconds)``: for each chord, the row of the fix ending the earlier
        second and of the one ending the later, and how many seconds apart they are
        (more than 1 where a second has no row).
    """
    segment = np.full(t.size, -1)
    for k, seg in enumerate(segments):  # per segment, not per sample
        segment[seg.row_start : seg.row_stop] = k
    sec = second_index(t, sample_period_s)
    # Last row of each second inside a segment: the per-second fix.
    last = np.flatnonzero(
        (segment >= 0) & (np.r_[sec[1:] != sec[:-1], True] | (segment != np.r_[segment[1:], -1]))
    )
    if last.size < 2:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, empty
    same = segment[last[1:]] == segment[last[:-1]]
    prev, this = last[:-1][same], last[1:][same]
    return prev, this, sec[this] - sec[prev]


@dataclass(frozen=True)
class YawEstimate:
    """How the GNSS course turned against the yaw rate (:func:`yaw_gain`)."""

    gain: float  # course turn per gyro turn (NaN: too few seconds, or a gyro that never varied)
    gain_se: float  # its standard error (inf when it cannot be told)
    seconds: int  # pairs of seconds that entered the fit
    # the span of the course's turns added up over them (max − min of their running sum:
    # a straight drive's noise stays near 0, since within a stretch the sum telescopes)
    course_span_rad: float


# A mistake is told only when the gain lies this many standard errors from every gain
# a right yaw rate could have. The standard error is least squares' for independent
# pairs; the course's noise is the difference of two chords' (consecutive pairs share a
# chord), which for a smooth yaw rate makes the true one smaller: it errs on the safe side.
YAW_EVIDENCE_SE = 4.0
YAW_MIN_SECONDS = 30  # pairs of seconds the fit needs before it may tell anything
YAW_MIN_STEP_M = 5.0  # a chord shorter than this (a second slower than 5 m/s) has no course
# The gyro's bias wanders and warms up (docs/simulator.md section 7): each block of this many
# seconds gets its own intercept, so that a drifting bias is no turn.
YAW_BLOCK_S = 120.0
YAW_FLAT_SPAN_RAD = math.pi / 2  # a flat yaw rate is refused once the course swung this far
# Any other mistake of a yaw rate is told only once the course swung this far (a bend's
# worth). Over a straight stretch the gyro's bias wandering within a block and the fixes'
# slowly drifting errors are all the gain is fitted on, and its standard error (white
# noise's) does not see them: `predict`'s first tries on the built-in V-Delta1 (the paper
# world's), 84-144 pairs of seconds over which the course swung 0.9 deg, gave -1.6 to -1.2
# ± 0.4-0.6 and refused a right gyro; 20 pairs later, the course 5 deg round, 1.005 ± 0.034.
# A wider standard error does not mend it: Newey-West's (Bartlett, 3-30 pairs of lags)
# gives 0.47-0.59 where white noise's gives 0.55 on those tries, and less than white
# noise's once the car turns (consecutive pairs share a chord; benchmarks/yaw_se.py). The
# pairs' residuals are not what is short of independence at up to 30 lags: what misleads
# the fit on a straight wanders more slowly (the gyro's bias, the fixes' smoothed error,
# over minutes), which no estimate from a few minutes of pairs can size. Only a course
# that turns puts a signal above it.
YAW_TELL_SPAN_RAD = math.radians(10.0)


@dataclass(frozen=True)
class CourseTurns:
    """The GNSS course's turns between the chords of consecutive seconds (:func:`course_turns`),
    which every yaw rate of a drive is fitted against (:func:`yaw_gain`)."""

    t: np.ndarray  # the drive's times
    a: np.ndarray  # per pair of chords, the first chord's middle time
    b: np.ndarray  # and the second's
    y: np.ndarray  # the course's yaw over the pair, rad, left positive (ISO 8855)
    block: np.ndarray  # the pair's block of YAW_BLOCK_S from the drive's start


@np.errstate(invalid="ignore", divide="ignore")
def course_turns(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    min_step_m: float,
    sample_period_s: float | None = None,
) -> CourseTurns | None:
    """The course's turns :func:`yaw_gain` fits a yaw rate against (its docstring says how);
    None where fewer than two chords lie in the segments."""
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    prev, this, gap = _second_chords(t, segments, sample_period_s)
    if prev.size < 2:
        return None
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    # Each chord's azimuth where it leaves and where it arrives (its back azimuth turned
    # round): two chords are compared at the fix they share, so the meridians' convergence
    # (a straight geodesic's azimuth changes along it, by degrees per second near a pole)
    # is no turn.
    leave, back, dist = wgs84().inv(lon[prev], lat[prev], lon[this], lat[this])
    leave = np.radians(np.asarray(leave, dtype=np.float64))
    arrive = np.radians(np.asarray(back, dtype=np.float64)) + math.pi
    chord = (gap == 1) & (np.asarray(dist) >= min_step_m)
    mid = 0.5 * (t[prev] + t[this])
    pair = chord[1:] & chord[:-1] & (this[:-1] == prev[1:])
    a, b = mid[:-1][pair], mid[1:][pair]
    y = -((leave[1:] - arrive[:-1] + math.pi) % (2.0 * math.pi) - math.pi)[pair]
    block = np.floor((a - t[0]) / YAW_BLOCK_S).astype(np.int64)
    return CourseTurns(t, a, b, y, block)


@np.errstate(invalid="ignore", divide="ignore")
def yaw_gain(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    min_step_m: float,
    sample_period_s: float | None = None,
    turns: CourseTurns | None = None,
) -> YawEstimate:
    """The gain of the GNSS course's turn on the yaw rate's, over the valid segments.

    Each whole second's fix (the last row of the second, as :func:`implied_radius`
    takes it) and the next give a chord, a geodesic; two chords of consecutive seconds,
    both at least ``min_step_m`` long, turn at the fix they share by ``Δcourse`` (the
    second's azimuth leaving it less the first's arriving, clockwise from north), the
    turn between their middle times, and the car's yaw (counter-clockwise, ISO
    8855) turned by ``−Δcourse`` over the same interval. The yaw rate's angle over it is
    the trapezoid integral of ``yaw_rate_rad_s``, read at the two middle times. The gain
    is the least-squares slope of the course's yaw on the gyro's with an intercept for
    each :data:`YAW_BLOCK_S` of the drive (a gyro's bias, and its drift as it warms up,
    would otherwise pull the slope of a mostly straight drive towards 0: a motorway
    drive's 0.98 fell to 0.88 with a 0.57 deg/s warm-up under one intercept, 0.99 with
    one per block); the course carries the GNSS's noise, the gyro almost none, so the
    slope is not diluted. A yaw rate in the declared unit and sign has a gain near 1.

    Args:
        drive: canonical columns (``t_s``, ``lat_deg``, ``lon_deg``, ``yaw_rate_rad_s``).
        segments: the drive's GNSS-valid segments.
        min_step_m: a chord shorter than this has no course worth the name.
        sample_period_s: the nominal sample period (as :func:`implied_radius`).
        turns: the course's turns over the segments (:func:`course_turns` of the same
            drive, segments, ``min_step_m`` and period), where several yaw rates are
            fitted on one drive; None: computed here.

    Returns:
        The estimate (``gain`` NaN with fewer than :data:`YAW_MIN_SECONDS` pairs, or a
        yaw rate that never changed over them).
    """
    if turns is None:
        turns = course_turns(drive, segments, min_step_m, sample_period_s)
    if turns is None:
        return YawEstimate(float("nan"), math.inf, 0, 0.0)
    x, keep = _pair_angles(turns, np.asarray(drive[c.YAW_RATE_RAD_S], dtype=np.float64))
    return _angles_gain(turns, x, keep)


def _angles_gain(turns: CourseTurns, x: np.ndarray, keep: np.ndarray) -> YawEstimate:
    """:func:`yaw_gain`'s fit of the course's turns on a yaw rate's angles over the pairs
    (:func:`_pair_angles`), over the pairs that have one."""
    fit = _slope_by_blocks(x[keep], turns.y[keep], turns.block[keep])
    span = float(np.ptp(np.r_[0.0, np.cumsum(fit.y)]))
    return YawEstimate(fit.gain, fit.gain_se, fit.n, span)


def _pair_angles(turns: CourseTurns, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A yaw rate's angle over each pair of :func:`course_turns` (the trapezoid integral
    between the pair's two middle times, a glitch beyond any car's yaw rate interpolated
    across, as the label integrates it), and which pairs have it (no row without one)."""
    t = turns.t
    rate, _ = repaired_yaw_rate(t, rate)
    # Cumulative angle: the angle between two times is one subtraction. A row without a
    # yaw rate makes every angle after it NaN in a cumsum, so its intervals are taken as
    # 0 and the pairs that span it dropped.
    step = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)
    finite = np.isfinite(step)
    a, b = turns.a, turns.b
    if finite.all():  # every row has one (a wheel yaw, most gyros): no pair to drop
        angle = np.r_[0.0, np.cumsum(step)]
        keep = np.ones(a.size, dtype=bool)
    else:
        angle = np.r_[0.0, np.cumsum(np.where(finite, step, 0.0))]
        missing = np.r_[0, np.cumsum(~finite)]
        keep = np.interp(b, t, missing) - np.interp(a, t, missing) == 0
    return np.interp(b, t, angle) - np.interp(a, t, angle), keep


@dataclass(frozen=True)
class _Slope:
    gain: float  # NaN: too few pairs, or a regressor that never varied
    gain_se: float  # inf when the gain cannot be told
    n: int  # pairs that entered the fit
    x: np.ndarray  # those pairs' regressor
    y: np.ndarray  # and response


def _without_lone_pairs(
    x: np.ndarray, y: np.ndarray, block: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of blocks with two or more (a block's only pair would be all its intercept
    takes), and their blocks numbered from 0."""
    _, block, per_block = np.unique(block, return_inverse=True, return_counts=True)
    alone = per_block[block] < 2
    x, y = x[~alone], y[~alone]
    return x, y, np.unique(block[~alone], return_inverse=True)[1]


def _slope_by_blocks(x: np.ndarray, y: np.ndarray, block: np.ndarray) -> _Slope:
    """The least-squares slope of ``y`` on ``x`` with an intercept for each block, and its
    standard error; a block's only pair is left out (its intercept would take it all)."""
    x, y, block = _without_lone_pairs(x, y, block)
    n = x.size
    if n < YAW_MIN_SECONDS or np.ptp(x) < 1e-9:  # too few, or one value (to the sum's rounding)
        return _Slope(float("nan"), math.inf, n, x, y)
    count = np.bincount(block)
    xc = x - (np.bincount(block, x) / count)[block]
    yc = y - (np.bincount(block, y) / count)[block]
    sxx = float(xc @ xc)
    if not sxx > 0.0:  # one value in each block: nothing to regress on
        return _Slope(float("nan"), math.inf, n, x, y)
    gain = float(xc @ yc) / sxx
    resid = yc - gain * xc
    dof = n - count.size - 1  # a slope, and an intercept per block
    se = math.sqrt(float(resid @ resid) / max(dof, 1) / sxx)
    return _Slope(gain, se, n, x, y)


@dataclass(frozen=True)
class _Slopes:
    gain: np.ndarray  # per regressor (NaN: too few pairs, or regressors not told apart)
    gain_se: np.ndarray  # their standard errors (inf when they cannot be told)
    n: int  # pairs that entered the fit


def _slopes_by_blocks(x: np.ndarray, y: np.ndarray, block: np.ndarray) -> _Slopes:
    """As :func:`_slope_by_blocks`, with several regressors (the columns of ``x``) fitted
    at once."""
    x, y, block = _without_lone_pairs(x, y, block)
    n, k = x.shape
    nan = _Slopes(np.full(k, np.nan), np.full(k, np.inf), n)
    if n < YAW_MIN_SECONDS:
        return nan
    count = np.bincount(block)
    xc = x - (np.stack([np.bincount(block, col) for col in x.T], axis=1) / count[:, None])[block]
    yc = y - (np.bincount(block, y) / count)[block]
    sxx = xc.T @ xc
    if not np.all(np.isfinite(sxx)) or np.linalg.cond(sxx) > 1e12:  # one value, or collinear
        return nan
    inv = np.linalg.inv(sxx)
    gain = inv @ (xc.T @ yc)
    resid = yc - xc @ gain
    dof = n - count.size - k  # the slopes, and an intercept per block
    se = np.sqrt(np.diag(inv) * float(resid @ resid) / max(dof, 1))
    return _Slopes(gain, se, n)


# Each axle's two wheels, left then right, for :func:`wheel_side_gains`.
AXLES: dict[str, tuple[str, str]] = {
    "rear": (c.OMEGA_RL, c.OMEGA_RR),
    "front": (c.OMEGA_FL, c.OMEGA_FR),
}


@dataclass(frozen=True)
class SideYaws:
    """Each axle's wheel yaw, ``(ω_right − ω_left) r / track``, integrated over each pair of
    seconds of the course's turns (:func:`side_yaws`): what :func:`wheel_side_gains` and
    :func:`diagonal_gain` both fit, integrated once where a drive goes through both."""

    turns: CourseTurns
    angle: dict[str, np.ndarray]  # per axle (AXLES), its yaw over each pair, rad
    keep: dict[str, np.ndarray]  # per axle, the pairs that have it (no row without)


def side_yaws(
    drive: Mapping[str, np.ndarray], turns: CourseTurns, radius_m: float, track_m: float
) -> SideYaws:
    """Each axle's wheel yaw over the pairs of ``turns`` (:class:`SideYaws`), integrated as
    :func:`yaw_gain` integrates a yaw rate."""
    angle, keep = {}, {}
    for axle, (left, right) in AXLES.items():
        yaw = (np.asarray(drive[right], np.float64) - np.asarray(drive[left], np.float64)) * (
            radius_m / track_m
        )
        angle[axle], keep[axle] = _pair_angles(turns, yaw)
    return SideYaws(turns, angle, keep)


@np.errstate(invalid="ignore", divide="ignore")
def wheel_side_gains(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    min_step_m: float,
    sample_period_s: float | None,
    radius_m: float,
    track_m: float,
    turns: CourseTurns | None = None,
    sides: SideYaws | None = None,
) -> dict[str, YawEstimate]:
    """The gain of the GNSS course's turn on each axle's wheel yaw, over the valid segments.

    In a turn the outer wheels roll a longer arc: an axle's yaw rate is about
    ``(ω_right − ω_left) r / track`` (the rear axle's is what 2D dead reckoning turns
    by without a gyro). :func:`yaw_gain` of that yaw rate is positive for wheels in their
    columns and negative for a left and a right column exchanged. Its size is not 1: a
    turn's load transfer shrinks the outer tyres' rolling radii and their slip adds to
    it, so the wheels overstate a turn, more the faster it is taken (the built-in
    drives' rear axles give 0.42-0.92: docs/readers.md); only its sign tells anything.

    Args:
        drive: canonical columns (``t_s``, ``lat_deg``, ``lon_deg``, the wheel speeds).
        segments: the drive's GNSS-valid segments.
        min_step_m: a chord shorter than this has no course (:func:`yaw_gain`).
        sample_period_s: the nominal sample period.
        radius_m: the car's nominal tyre radius.
        track_m: its track width (the rear's serves both axles: only the sign is told).
        turns: the course's turns (:func:`course_turns`), where already computed.
        sides: the axles' yaws over those turns (:func:`side_yaws` of the same drive,
            turns, radius and track), where already computed; None: computed here.

    Returns:
        Per axle (``rear``, ``front``) its estimate (``gain`` NaN with fewer than
        :data:`YAW_MIN_SECONDS` pairs).
    """
    if sides is None:
        if turns is None:
            turns = course_turns(drive, segments, min_step_m, sample_period_s)
        if turns is None:
            return {axle: YawEstimate(float("nan"), math.inf, 0, 0.0) for axle in AXLES}
        sides = side_yaws(drive, turns, radius_m, track_m)
    return {axle: _angles_gain(sides.turns, sides.angle[axle], sides.keep[axle]) for axle in AXLES}


# One diagonal pair of wheel columns exchanged (:func:`diagonal_gain`): told where the
# gain's size lies YAW_EVIDENCE_SE standard errors beyond this. An exchange gives about the
# wheels' own side gain (1 for ideal rolling; the built-in drives' 0.42-0.93, the real
# RAV4 minute's 0.76); wheels in their columns leave a few tenths at most (the built-in
# drives' -0.18..0.11 over a whole drive; on fewer pairs, as `predict` tries them, up to
# -0.23 ± 0.07 on the paper world's V-Vta21, where a fit without the fourth term of
# diagonal_gain gave -0.35 ± 0.07 at 61 pairs: what the turns' load transfer puts in the
# front wheels' speeds over the rear's that the sides' yaws do not take).
DIAGONAL_MIN_GAIN = 0.25


@dataclass(frozen=True)
class DiagonalEstimate:
    """How the course turns with the front columns' speeds over the rear columns'
    (:func:`diagonal_gain`)."""

    gain: float  # NaN: too few pairs, or regressors that cannot be told apart
    gain_se: float  # inf when it cannot be told
    seconds: int  # pairs of seconds that entered the fit


@np.errstate(invalid="ignore", divide="ignore")
def diagonal_gain(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    min_step_m: float,
    sample_period_s: float | None,
    radius_m: float,
    track_m: float,
    turns: CourseTurns | None = None,
    sides: SideYaws | None = None,
) -> DiagonalEstimate:
    """Whether one diagonal pair of wheel columns holds each other's speeds.

    The front left wheel's speed written to the rear right's column and the rear right's
    to the front left's (or the front right's and the rear left's) leaves each axle's two
    columns holding two wheels of one side: their difference carries no turn (the sides'
    gains of :func:`wheel_side_gains` scatter either side of 0), and the front columns'
    speeds less the rear columns' carry the whole of it, since the front columns then
    hold both right wheels (or both left ones). So the course's turn over each pair of
    seconds of :func:`course_turns` is fitted by least squares on four terms at once,
    with an intercept for each :data:`YAW_BLOCK_S`: three yaws, each integrated over the
    pair as :func:`yaw_gain` integrates a yaw rate, the front columns' right less left, the
    rear columns' right less left (each times ``radius_m / track_m``) and the front
    columns' mean speed less the rear columns' (times the same: for a diagonal pair
    exchanged, the sides' yaw); and the sides' mean yaw times its size (the wheels
    overstate a turn the more the harder it is taken, as load transfer shrinks the outer
    tyres: a course that is not the sides' yaw times one gain). The gain is the third
    term's coefficient: with the wheels in their columns the sides take the turn and it
    stays near 0; with the front left and rear right exchanged it is the sides' gain, with
    the front right and rear left its negative. Exchanges within an axle or of the axles
    leave it near 0 (the first leaves the front less the rear as it is, the second negates
    it). The front wheels' speed over the rear's grows in the harder turns whichever way
    they go (load transfer, the front axle's wider arc), so over a drive whose turns are
    not balanced it follows the course a little: fitted alone it told gains of ±2.7 on a
    quarter of the built-in drives; with the sides' yaws, -0.28..0.11 over whole drives;
    with the fourth term too, -0.18..0.11.

    Args:
        as :func:`wheel_side_gains` (``sides``: the axles' yaws, where already integrated).

    Returns:
        The estimate (``gain`` NaN with fewer than :data:`YAW_MIN_SECONDS` pairs).
    """
    if sides is None:
        if turns is None:
            turns = course_turns(drive, segments, min_step_m, sample_period_s)
        if turns is None:
            return DiagonalEstimate(float("nan"), math.inf, 0)
        sides = side_yaws(drive, turns, radius_m, track_m)
    turns = sides.turns
    w = {k: np.asarray(drive[k], np.float64) for k in (*AXLES["front"], *AXLES["rear"])}
    (fl, fr), (rl, rr) = AXLES["front"], AXLES["rear"]
    ahead = 0.5 * (radius_m / track_m) * ((w[fl] + w[fr]) - (w[rl] + w[rr]))
    front_less_rear, ahead_keep = _pair_angles(turns, ahead)
    angles = (sides.angle["front"], sides.angle["rear"], front_less_rear)
    kept = sides.keep["front"] & sides.keep["rear"] & ahead_keep
    x = np.stack([angle[kept] for angle in angles], axis=1)
    sides = 0.5 * (x[:, 0] + x[:, 1])
    x = np.c_[x, sides * np.abs(sides)]  # the wheels overstating the harder turns more
    fit = _slopes_by_blocks(x, turns.y[kept], turns.block[kept])
    return DiagonalEstimate(float(fit.gain[2]), float(fit.gain_se[2]), fit.n)


def diagonal_mistake(est: DiagonalEstimate) -> tuple[str, str] | None:
    """The two wheel columns :func:`diagonal_gain` tells exchanged, or None: told where the
    gain's size lies :data:`YAW_EVIDENCE_SE` standard errors beyond
    :data:`DIAGONAL_MIN_GAIN`, over at least :data:`YAW_MIN_SECONDS` pairs of seconds;
    positive, the front left and the rear right (the front columns then hold the right
    wheels, faster in a left turn); negative, the front right and the rear left.
    """
    if est.seconds < YAW_MIN_SECONDS or not math.isfinite(est.gain):
        return None
    if abs(est.gain) - YAW_EVIDENCE_SE * est.gain_se <= DIAGONAL_MIN_GAIN:
        return None
    (fl, fr), (rl, rr) = AXLES["front"], AXLES["rear"]
    return (fl, rr) if est.gain > 0.0 else (fr, rl)


def side_mistake(est: YawEstimate) -> tuple[bool, bool]:
    """Whether an axle's wheel-yaw gain (:func:`wheel_side_gains`) tells its sides, and
    whether they are exchanged: told where the gain lies :data:`YAW_EVIDENCE_SE` standard
    errors from 0, over at least :data:`YAW_MIN_SECONDS` pairs of seconds.

    Returns:
        ``(checked, exchanged)``.
    """
    if est.seconds < YAW_MIN_SECONDS or not math.isfinite(est.gain):
        return False, False
    told = abs(est.gain) > YAW_EVIDENCE_SE * est.gain_se
    return told, told and est.gain < 0.0


# The front and rear axles (:func:`axle_order_gain`): an ordinary car's wheelbase (the
# gain's scale, (wheelbase / this) squared; only its sign is told), and how tight a turn
# must be to count: (wheelbase x curvature)^2 / 2 of at least this (a turn radius under
# 27 m at this wheelbase: a junction's, where the front axle runs 0.5 % or more faster),
# in at least so many pairs of seconds.
AXLE_WHEELBASE_M = 2.7
AXLE_TIGHT_TERM = 0.005
AXLE_MIN_TIGHT = 10
# An exchange gives about -(wheelbase / AXLE_WHEELBASE_M)^2: -0.73 for a city car's 2.3 m,
# diluted to about three quarters of that by noisy fixes (their course's noise adds to
# the turn's term). A gain told negative but above this is no exchange's: the front axle's
# brakes or the rear's drive slipping more in the turns than the arc adds; not told.
AXLE_EXCHANGED_GAIN = -0.25


@dataclass(frozen=True)
class AxleEstimate:
    """How the front wheels' speed over the rear's grows with the turn (:func:`axle_order_gain`)."""

    gain: float  # per unit of the turn's term (NaN: too few pairs, or no turn)
    gain_se: float  # its standard error (inf when it cannot be told)
    seconds: int  # pairs of seconds that entered the fit
    tight: int  # of which turned at least AXLE_TIGHT_TERM


@np.errstate(invalid="ignore", divide="ignore")
def axle_order_gain(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    min_step_m: float,
    sample_period_s: float | None,
    radius_m: float,
    turns: CourseTurns | None = None,
) -> AxleEstimate:
    """How much faster the front wheels turn than the rear ones as the car turns.

    In a turn the front axle runs on a wider arc than the rear: a car turning about a
    centre level with its rear axle at radius ``R`` (low speed, no slip: the kinematic
    bicycle model, Rajamani, *Vehicle Dynamics and Control*, 2nd ed., sec. 2.2) moves its
    front axle on ``sqrt(R^2 + L^2)``, so the front wheels' mean speed over the rear's is
    ``sqrt(1 + (L k)^2) ~ 1 + (L k)^2 / 2`` for curvature ``k``, whichever way it turns.
    Over each pair of seconds of :func:`course_turns` the curvature is the course's turn
    over the rear wheels' distance (their angle times ``radius_m``), and the fit is the
    least-squares slope of ``front / rear - 1`` on ``(L k)^2 / 2`` (``L`` =
    :data:`AXLE_WHEELBASE_M`) with an intercept for each :data:`YAW_BLOCK_S` (the two axles'
    tyres differ, and warm, by as much). Wheels in their columns give a gain near
    ``(wheelbase / L)^2``, about 1 (0.70-1.10 on the built-in drives); the front and rear
    columns exchanged, its negative. At speed the rear tyres' slip moves the turn's centre
    forward and shrinks the gain, but the tight turns, which weigh most, are slow.

    Returns:
        The estimate (``gain`` NaN with fewer than :data:`YAW_MIN_SECONDS` pairs, or with
        axles that never differed).
    """
    if turns is None:
        turns = course_turns(drive, segments, min_step_m, sample_period_s)
    if turns is None:
        return AxleEstimate(float("nan"), math.inf, 0, 0)
    t = turns.t

    def angle(left: str, right: str) -> np.ndarray:
        wheel = 0.5 * (np.abs(np.asarray(drive[left])) + np.abs(np.asarray(drive[right])))
        whole = cumulative_trapezoid(wheel, t)
        return np.interp(turns.b, t, whole) - np.interp(turns.a, t, whole)

    front, rear = angle(*AXLES["front"]), angle(*AXLES["rear"])
    term = 0.5 * (AXLE_WHEELBASE_M * turns.y / (rear * radius_m)) ** 2
    ratio = front / rear - 1.0
    keep = np.isfinite(term) & np.isfinite(ratio) & (rear > 0)
    fit = _slope_by_blocks(term[keep], ratio[keep], turns.block[keep])
    tight = int(np.count_nonzero(fit.x >= AXLE_TIGHT_TERM))
    if fit.y.size and np.ptp(fit.y) < 1e-12:  # the axles never differed: nothing to tell
        return AxleEstimate(float("nan"), math.inf, fit.n, tight)
    return AxleEstimate(fit.gain, fit.gain_se, fit.n, tight)


def axle_mistake(est: AxleEstimate) -> tuple[bool, bool]:
    """Whether the front and rear wheels are told apart (:func:`axle_order_gain`), and
    whether their columns are exchanged: told where the gain lies :data:`YAW_EVIDENCE_SE`
    standard errors from 0 over at least :data:`AXLE_MIN_TIGHT` tight turns (a drive
    without them can still fit a gain far from 0: the axles' speed ratio drifts with
    speed, and a straight drive's small curvatures grow as its speed falls), and either
    positive or below :data:`AXLE_EXCHANGED_GAIN` (exchanged).

    Returns:
        ``(checked, exchanged)``.
    """
    if est.tight < AXLE_MIN_TIGHT or not math.isfinite(est.gain):
        return False, False
    told = abs(est.gain) > YAW_EVIDENCE_SE * est.gain_se
    exchanged = told and est.gain < AXLE_EXCHANGED_GAIN
    return told and (est.gain > 0.0 or exchanged), exchanged


# (what the yaw rate really is, the gain of the course's turn on it)
_YAW_MISTAKES: tuple[tuple[str, float], ...] = (
    ("positive turning right (a gyro positive clockwise, z down as in SAE J670)", -1.0),
    ("in deg/s where rad/s was declared", math.pi / 180.0),
    ("in rad/s where deg/s was declared", 180.0 / math.pi),
    ("in deg/s where rad/s was declared, and positive turning right", -math.pi / 180.0),
    ("in rad/s where deg/s was declared, and positive turning right", -180.0 / math.pi),
)


def yaw_mistake(est: YawEstimate, tolerance: float) -> tuple[bool, str | None]:
    """Whether a yaw estimate tells anything, and what is wrong when something is.

    A right yaw rate has a gain within ``[1 / (1 + tolerance), 1 + tolerance]`` (a gyro's
    scale error is a few percent; the built-in drives give 0.92-1.01). The yaw rate is
    told wrong only when its gain lies :data:`YAW_EVIDENCE_SE` standard errors outside
    that band; then the mistake is named (a gain within the same band around -1, π/180,
    180/π or their negatives, and told from 0), or the channel does not follow the car.
    A channel that holds one value while the course swung through
    :data:`YAW_FLAT_SPAN_RAD` or more is no yaw rate (zeros where a log had none?). No
    mistake is told before the course swung through :data:`YAW_TELL_SPAN_RAD` (a right
    yaw rate can be told on less).

    Args:
        est: :func:`yaw_gain`'s estimate.
        tolerance: ``validate.yaw_gain_tolerance``.

    Returns:
        ``(checked, mistake)``: ``checked`` False when the seconds were too few, or the
        drive turned too little, to tell (the gain's ±4 standard errors wider than the
        band); ``mistake`` None when nothing is wrong.
    """
    if est.seconds < YAW_MIN_SECONDS:
        return False, None
    if math.isnan(est.gain):  # the yaw rate never changed over the fit's seconds
        if est.course_span_rad >= YAW_FLAT_SPAN_RAD:
            return True, "never changes: one value while the course turned"
        return False, None
    low, high = 1.0 / (1.0 + tolerance), 1.0 + tolerance
    margin = YAW_EVIDENCE_SE * est.gain_se
    if est.gain + margin >= low and est.gain - margin <= high:
        return 2.0 * margin <= high - low, None
    if est.course_span_rad < YAW_TELL_SPAN_RAD:  # no mistake told on a straight
        return False, None
    if abs(est.gain) > margin:  # the channel follows the course, in some unit and sign
        for what, gain in _YAW_MISTAKES:
            lo, hi = sorted((gain * low, gain * high))
            if est.gain + margin >= lo and est.gain - margin <= hi:
                return True, f"looks {what}"
    return True, "does not follow the GNSS course (another signal, or another drive's?)"


# (unit the wheel speeds are really in, the sign of it, implied radius / nominal radius if
# it scales with the tyre, else the implied radius itself in m)
_UNIT_MISTAKES: tuple[tuple[str, str, float | None, float | None], ...] = (
    ("rpm", "ratio ≈ 2π/60", 2.0 * math.pi / 60.0, None),
    ("deg/s", "ratio ≈ π/180", math.pi / 180.0, None),
    ("km/h (a linear wheel speed)", "radius ≈ 1/3.6 m", None, 1.0 / 3.6),
    ("m/s (a linear wheel speed)", "radius ≈ 1 m", None, 1.0),
)


def unit_mistake(radius_m: float, nominal_m: float, tolerance: float) -> str | None:
    """Say which unit mistake an implied radius suggests, if it is not plausible.

    Args:
        radius_m: implied effective radius, m.
        nominal_m: the vehicle's nominal radius, m (``data.vehicles.<v>.nominal_radius_m``).
        tolerance: allowed relative deviation (``validate.radius_tolerance``).

    Returns:
        None when ``|radius / nominal - 1| <= tolerance``; otherwise an explanation naming
        the likely unit (rpm: ratio ≈ 2π/60, deg/s: π/180, km/h: radius ≈ 1/3.6 m, m/s: 1 m)
        or, when none fits, what else to check.
    """
    ratio = radius_m / nominal_m
    if abs(ratio - 1.0) <= tolerance:
        return None
    fits = []
    for unit, sign, ratio_if, radius_if in _UNIT_MISTAKES:
        expected = ratio_if * nominal_m if ratio_if is not None else radius_if
        miss = abs(math.log(radius_m / expected)) if radius_m > 0 else math.inf
        if miss <= math.log1p(tolerance):
            fits.append((miss, unit, sign))
    head = f"implied radius {radius_m:.4g} m, ratio {ratio:.4g} to the nominal {nominal_m} m"
    if fits:
        _, unit, sign = min(fits)
        return (
            f"{head}; {sign}: the wheel speeds look like {unit}, not rad/s; convert them "
            "(or declare the unit in a column map)"
        )
    return (
        f"{head}: wheel speeds in an unexpected unit or scale, a wrong "
        "data.vehicles nominal_radius_m, or GNSS and wheel data from different drives"
    )


# --------------------------------------------------------------------------- wheel sensors


@dataclass(frozen=True)
class StuckRun:
    """Rows ``row_start:row_stop`` where one wheel read far below the others while moving."""

    wheel: str  # canonical name
    row_start: int  # 0-based, first row of the run
    row_stop: int  # exclusive
    reading_max_rad_s: float  # the stuck wheel's largest |reading| in the run
    others_median_rad_s: float  # median over the run of the four wheels' median


def stuck_wheel_runs(
    drive: Mapping[str, np.ndarray],
    policy: WheelPolicy,
    sample_period_s: float,
    ignore: np.ndarray | None = None,
) -> list[StuckRun]:
    """Find wheels that read (near) zero while the vehicle moves: a stuck or unplugged sensor.

    The vehicle's wheel speed is the median of the four |wheel speeds| (the mean of the
    middle two: one faulty wheel, or one spinning, does not move it). A wheel is stuck in a
    row when that median exceeds ``stuck_moving_rad_s`` and the wheel reads below
    ``stuck_ratio`` times it; a run of such rows lasting ``stuck_min_s`` or more is
    reported. Cornering never comes close: the inner rear wheel of the tightest turn a car
    can make still turns at about 0.7 times the median.

    Args:
        drive: canonical columns (the four wheel speeds).
        policy: ``validate.wheels``.
        sample_period_s: nominal sample period (a run's duration is its rows x this).
        ignore: rows to leave out (manual cuts), or None.

    Returns:
        The runs, wheel by wheel (FL, FR, RL, RR) and in row order.
    """
    w = np.abs(np.stack([np.asarray(drive[name], dtype=np.float64) for name in c.WHEELS]))
    ref = median_wheel_rad_s(drive)
    candidate = ref > policy.stuck_moving_rad_s
    if ignore is not None:
        candidate &= ~ignore
    runs = []
    for k, name in enumerate(c.WHEELS):
        start, stop = _runs(candidate & (w[k] < policy.stuck_ratio * ref))
        long = (stop - start) * sample_period_s >= policy.stuck_min_s - 1e-9
        runs += [
            StuckRun(
                name,
                int(a),
                int(b),
                float(w[k, a:b].max()),
                float(np.median(ref[a:b])),
            )
            for a, b in zip(start[long], stop[long], strict=True)
        ]
    return runs


@dataclass(frozen=True)
class SilentRun:
    """Rows ``row_start:row_stop`` where every wheel read far below the GNSS speed."""

    row_start: int
    row_stop: int
    wheels_max_rad_s: float  # the largest median of the four |wheel speeds| in the run
    gnss_max_m_s: float  # the largest GNSS speed in the run
    gnss_m: float  # GNSS distance over the run


def wheel_gnss_runs(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    nominal_radius_m: float,
    policy: WheelPolicy,
    sample_period_s: float,
    ignore: np.ndarray | None = None,
) -> tuple[list[SilentRun], list[StaleRun]]:
    """The two checks of the wheels against GNSS: silent wheels and stale wheel data.

    Both compare the four wheels' median with the GNSS speed inside the valid segments,
    so both are computed from one pass over those (:func:`_silent_runs`,
    :func:`_stale_runs`).

    Args:
        drive: canonical columns.
        segments: the drive's valid segments (the GNSS policy's).
        nominal_radius_m: the vehicle's nominal tyre radius, m.
        policy: ``validate.wheels``.
        sample_period_s: nominal sample period.
        ignore: rows to leave out (manual cuts), or None.

    Returns:
        ``(silent, stale)``: the runs of each, in row order.
    """
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    k = max(round(1.0 / sample_period_s), 1)
    if t.size <= k:
        return [], []
    _, trusted = _gnss_speed(drive, segments, k, speed=False)
    median = median_wheel_rad_s(drive)
    check = WheelCheck(drive, t, k, trusted, median, nominal_radius_m, policy, sample_period_s)
    return _silent_runs(check, ignore), _stale_runs(check, ignore)


@dataclass(frozen=True)
class WheelCheck:
    """What both wheel-against-GNSS checks read (:func:`wheel_gnss_runs`)."""

    drive: Mapping[str, np.ndarray]
    t: np.ndarray  # times, s
    k: int  # rows per second
    trusted: np.ndarray  # rows whose last second lies inside one valid segment
    median: np.ndarray  # the four wheels' median speed, rad/s
    nominal_radius_m: float
    policy: WheelPolicy
    sample_period_s: float


def _silent_runs(check: WheelCheck, ignore: np.ndarray | None) -> list[SilentRun]:
    """Find stretches where all four wheels read (near) zero while GNSS moves: no wheel data.

    The median wheel cannot tell a stuck wheel when all of them stop (a CAN channel that
    stopped logging, wheel columns left empty as zeros). Inside the valid segments (GNSS
    trusted), the GNSS speed over the last second, divided by the nominal radius, is the
    wheel speed to expect; a run of ``stuck_min_s`` or more where it exceeds
    ``stuck_moving_rad_s`` and the median of the four wheels stays below ``stuck_ratio``
    times it is reported. The runs come in row order.
    """
    drive, t, k, same, wheels = check.drive, check.t, check.k, check.trusted, check.median
    nominal_radius_m, policy, sample_period_s = (
        check.nominal_radius_m,
        check.policy,
        check.sample_period_s,
    )
    n = t.size
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    moving_m_s = policy.stuck_moving_rad_s * nominal_radius_m
    with np.errstate(invalid="ignore", divide="ignore"):
        wheel_m_s = wheels * nominal_radius_m / policy.stuck_ratio
        # Only rows whose speed could exceed both thresholds (by a bound with no trigonometry
        # per row) get the tangent-plane speed; while the wheels turn with GNSS, none does.
        bound = _speed_bound(lat, lon, t, k)
        maybe = same & (bound > moving_m_s * (1 - _NEAR)) & (bound > wheel_m_s * (1 - _NEAR))
    speed = np.zeros(n)
    rows = np.flatnonzero(maybe)
    speed[rows] = local_distance_m(lat[rows - k], lon[rows - k], lat[rows], lon[rows]) / (
        t[rows] - t[rows - k]
    )
    # The tangent-plane speed is within 1e-6 of the geodesic's: only a row within 1e-5 of a
    # threshold could be decided otherwise, and those are decided on the geodesic.
    for threshold in (moving_m_s, wheel_m_s):
        near = maybe & (np.abs(speed - threshold) <= _NEAR * np.abs(threshold))
        if near.any():
            speed[near] = _exact_speed(drive, np.flatnonzero(near), k)
    expected = speed / nominal_radius_m
    silent = (
        same & (expected > policy.stuck_moving_rad_s) & (wheels < policy.stuck_ratio * expected)
    )
    if ignore is not None:
        silent &= ~ignore
    start, stop = _runs(silent)
    long = (stop - start) * sample_period_s >= policy.stuck_min_s - 1e-9
    return [
        SilentRun(
            int(a),
            int(b),
            float(wheels[a:b].max()),
            float(_exact_speed(drive, np.arange(a, b), k).max()),
            float(local_step_distance_m(lat[a:b], lon[a:b]).sum()),
        )
        for a, b in zip(start[long], stop[long], strict=True)
    ]


@dataclass(frozen=True)
class StaleRun:
    """Rows ``row_start:row_stop`` where all four wheel speeds repeat while GNSS speed changes."""

    row_start: int
    row_stop: int
    wheels_rad_s: float  # the repeated median wheel speed
    gnss_min_m_s: float  # the GNSS speed range over the run
    gnss_max_m_s: float


def _stale_runs(check: WheelCheck, ignore: np.ndarray | None) -> list[StaleRun]:
    """Find stretches where all four wheel speeds repeat one value while the car changes speed.

    A logger that lost the CAN bus may repeat the last value it had: the wheels then
    read a plausible, moving speed, bit for bit the same from row to row, while the
    GNSS speed (over the last second, inside the valid segments) changes. Real wheel
    speeds carry sensor noise and never repeat all four for seconds while the car
    speeds up or slows down. Reported: runs of ``stuck_min_s`` or more of repeated
    values above ``stuck_moving_rad_s`` during which the GNSS speed (from the run's
    second second on) spans more than ``stuck_moving_rad_s`` x the nominal radius.

    The runs come in row order.
    """
    drive, k, median, policy = check.drive, check.k, check.median, check.policy
    n = check.t.size
    w = np.stack([np.asarray(drive[name], dtype=np.float64) for name in c.WHEELS])
    repeated = np.zeros(n, dtype=bool)
    repeated[1:] = (w[:, 1:] == w[:, :-1]).all(axis=0)
    repeated &= median > policy.stuck_moving_rad_s
    if ignore is not None:
        repeated &= ~ignore
    start, stop = _runs(repeated)
    long = (stop - start) * check.sample_period_s >= policy.stuck_min_s - 1e-9
    valid = check.trusted
    out = []
    for a, b in zip(start[long], stop[long], strict=True):  # per stretch, a handful
        # From one second into the run on, so that the GNSS window lies inside it: right
        # after a change of speed the window still averages the speed before it.
        rows = np.arange(a + k, b)[valid[a + k : b]]
        v = _exact_speed(drive, rows, k)
        if v.size and v.max() - v.min() > policy.stuck_moving_rad_s * check.nominal_radius_m:
            out.append(StaleRun(int(a), int(b), float(median[a]), float(v.min()), float(v.max())))
    return out


# Relative margin around a threshold within which a tangent-plane speed (1e-6 of the
# geodesic's) is replaced by the geodesic's before deciding.
_NEAR = 1e-5


def median_wheel_rad_s(drive: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per row, the median of the four |wheel speeds|: the mean of the middle two.

    Exactly ``np.median`` of the four (the middle two's sum halved; NaN anywhere gives
    NaN), without sorting: from the two pairs' minima and maxima.
    """
    a, b, c3, d = (np.abs(np.asarray(drive[w], dtype=np.float64)) for w in c.WHEELS)
    lo = np.maximum(np.minimum(a, b), np.minimum(c3, d))  # the second smallest
    hi = np.minimum(np.maximum(a, b), np.maximum(c3, d))  # the second largest
    return (lo + hi) / 2.0


def _gnss_speed(
    drive: Mapping[str, np.ndarray], segments: Sequence[Segment], k: int, speed: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """GNSS speed over the last ``k`` rows on the tangent plane (within 1e-6 relative of the
    geodesic's, :func:`rwhonet.geo.local_distance_m`), and where it is trusted (inside one
    segment). ``speed`` False: only where it is trusted (the speeds are zeros)."""
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    n = t.size
    segment = np.full(n, -1)
    for j, seg in enumerate(segments):  # per segment, not per sample
        segment[seg.row_start : seg.row_stop] = j
    out = np.zeros(n)
    valid = np.zeros(n, dtype=bool)
    if n > k:
        valid[k:] = (segment[k:] >= 0) & (segment[k:] == segment[:-k])
        if speed:
            lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
            lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
            out[k:] = local_distance_m(lat[:-k], lon[:-k], lat[k:], lon[k:]) / (t[k:] - t[:-k])
    return out, valid


def _speed_bound(lat: np.ndarray, lon: np.ndarray, t: np.ndarray, k: int) -> np.ndarray:
    """An upper bound of the tangent-plane speed over the last ``k`` rows (0 for the first k).

    The radii of curvature at the drive's largest |latitude| (both grow towards the poles)
    and the cosine at its smallest bound those at any step's mid latitude.
    """
    n = t.size
    out = np.zeros(n)
    lat_r, lon_r = np.radians(lat), np.radians(lon)
    finite = np.isfinite(lat_r)
    if n <= k or not finite.any():
        out[k:] = np.inf
        return out
    abs_lat = np.abs(lat_r[finite])
    w2 = 1.0 - _WGS84_E2 * np.sin(abs_lat.max()) ** 2
    r_n = _WGS84_A_M / np.sqrt(w2)
    r_m = r_n * (1.0 - _WGS84_E2) / w2
    lo = abs_lat.min()
    cos_max = 1.0 if lo <= 0.0 else float(np.cos(lo))
    d_lon = (lon_r[k:] - lon_r[:-k] + np.pi) % (2.0 * np.pi) - np.pi
    out[k:] = np.hypot(r_m * (lat_r[k:] - lat_r[:-k]), r_n * cos_max * d_lon) / (t[k:] - t[:-k])
    out[k:] *= 1.0 + 1e-9  # the bound's own rounding
    out[k:][~np.isfinite(out[k:])] = np.inf
    return out


# WGS84 semi-major axis (m) and first eccentricity squared (rwhonet.geo.geodesic's).
_WGS84_A_M = 6378137.0
_WGS84_E2 = 6.69437999014e-3


def _exact_speed(drive: Mapping[str, np.ndarray], rows: np.ndarray, k: int) -> np.ndarray:
    """The geodesic speed over the ``k`` rows before each of ``rows`` (0 for a row < k)."""
    rows = np.asarray(rows, dtype=np.int64)
    out = np.zeros(rows.size)
    ok = rows >= k
    r = rows[ok]
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    out[ok] = geodesic_distance_m(lat[r - k], lon[r - k], lat[r], lon[r]) / (t[r] - t[r - k])
    return out


def negative_wheel_rows(
    drive: Mapping[str, np.ndarray], tol_rad_s: float, ignore: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Rows where a wheel speed is negative: speeds are magnitudes, as ABS sensors give them.

    Args:
        drive: canonical columns (the four wheel speeds).
        tol_rad_s: values down to ``-tol_rad_s`` pass (noise around a standstill).
        ignore: rows to leave out (manual cuts), or None.

    Returns:
        Wheel (canonical name) -> 0-based rows below ``-tol_rad_s``, for wheels that have any.
    """
    out = {}
    for name in c.WHEELS:
        bad = np.asarray(drive[name], dtype=np.float64) < -tol_rad_s
        if ignore is not None:
            bad &= ~ignore
        if bad.any():
            out[name] = np.flatnonzero(bad)
    return out


def reversing_rows(drive: Mapping[str, np.ndarray], tol_rad_s: float) -> np.ndarray:
    """Rows a logger that signs its wheel speeds records as reversing.

    All four wheels are at most ``+tol_rad_s`` and at least one is below ``-tol_rad_s``:
    the car rolls backwards as one body. A lone negative wheel while the others turn
    forwards is no reversing, and stays a sign error.

    Args:
        drive: canonical columns (the four wheel speeds).
        tol_rad_s: the noise band around zero (``validate.wheels.negative_tol_rad_s``).

    Returns:
        A boolean mask over the rows.
    """
    speeds = np.stack([np.asarray(drive[name], dtype=np.float64) for name in c.WHEELS])
    return (speeds <= tol_rad_s).all(axis=0) & (speeds < -tol_rad_s).any(axis=0)


def gnss_path_m(drive: Mapping[str, np.ndarray], rows: np.ndarray) -> float:
    """GNSS distance travelled over the steps into the given rows (evidence of motion), m."""
    rows = np.asarray(rows)
    rows = rows[rows > 0]
    if rows.size == 0:
        return 0.0
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    step = local_step_distance_m(lat, lon)  # step i: row i -> i + 1
    return float(np.nansum(step[rows - 1]))


@dataclass(frozen=True)
class SignTally:
    """What validate's sign check knows of one wheel over the rows seen: the whole drive,
    or a stream's rows so far, tallied block by block (:meth:`add`) without keeping them.

    Rows are 0-based over the drive; ``first_row`` is -1 while there is no negative row.
    """

    negative: int = 0  # rows below -tol (outside the manual cuts)
    first_row: int = -1  # the first of them
    first_value: float = math.nan  # its wheel speed, rad/s
    last_row: int = -1  # the last of them
    reversing: bool = True  # every one of them a row where all four roll backwards together
    gnss_m: float = 0.0  # GNSS distance over the steps into them, m
    moving: int = 0  # rows where this wheel turns faster than the moving threshold

    @property
    def share(self) -> float:
        """The negative rows' share of the moving rows."""
        return self.negative / max(self.moving, 1)

    def add(self, later: SignTally) -> SignTally:
        """This tally and the one of the rows that follow them."""
        first = self.negative > 0
        return SignTally(
            self.negative + later.negative,
            self.first_row if first else later.first_row,
            self.first_value if first else later.first_value,
            later.last_row if later.negative else self.last_row,
            self.reversing and later.reversing,
            self.gnss_m + later.gnss_m,
            self.moving + later.moving,
        )


def sign_tallies(
    drive: Mapping[str, np.ndarray],
    tol_rad_s: float,
    moving_rad_s: float,
    ignore: np.ndarray | None = None,
    row0: int = 0,
    lead: int = 0,
) -> dict[str, SignTally]:
    """Each wheel's :class:`SignTally` over ``drive``'s rows from ``lead`` on.

    Args:
        drive: canonical columns (the four wheel speeds, latitude, longitude).
        tol_rad_s: ``validate.wheels.negative_tol_rad_s`` (:func:`negative_wheel_rows`).
        moving_rad_s: ``validate.gnss.moving_wheel_speed_rad_s``.
        ignore: rows to leave out of the negative ones (manual cuts), or None.
        row0: the drive's rows before ``drive``'s row ``lead`` (the tally's row numbers).
        lead: rows at the start that only lead in (a stream's last row of the block
            before: the GNSS step into the first row tallied).

    Returns:
        Wheel (canonical name) -> its tally, for every wheel.
    """
    negative = negative_wheel_rows(drive, tol_rad_s, ignore)
    reversing = reversing_rows(drive, tol_rad_s) if negative else None
    out = {}
    for name in c.WHEELS:
        values = np.asarray(drive[name], dtype=np.float64)[lead:]
        moving = int((np.abs(values) > moving_rad_s).sum())
        rows = negative.get(name, np.empty(0, dtype=np.int64))
        rows = rows[rows >= lead]
        if rows.size == 0:
            out[name] = SignTally(moving=moving)
            continue
        out[name] = SignTally(
            int(rows.size),
            row0 + int(rows[0]) - lead,
            float(values[rows[0] - lead]),
            row0 + int(rows[-1]) - lead,
            bool(reversing[rows].all()),
            gnss_path_m(drive, rows),
            moving,
        )
    return out


# --------------------------------------------------------------------------- positions


def latlon_swapped_by_range(lat_deg: np.ndarray, lon_deg: np.ndarray) -> bool:
    """Whether latitude and longitude look swapped: most "latitudes" beyond ±90 deg, every
    "longitude" within ±90 deg and every "latitude" a valid longitude.

    Args:
        lat_deg: the latitude column.
        lon_deg: the longitude column.

    Returns:
        True when the columns fit the other's range and not their own.
    """
    lat = np.asarray(lat_deg, dtype=np.float64)
    lon = np.asarray(lon_deg, dtype=np.float64)
    lat, lon = lat[~np.isnan(lat)], lon[~np.isnan(lon)]
    if lat.size == 0 or lon.size == 0:
        return False
    return bool(
        np.mean(np.abs(lat) > 90.0) > 0.5
        and np.all(np.abs(lat) <= 180.0)
        and np.all(np.abs(lon) <= 90.0)
    )


def swapped_radius(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    moving_wheel_speed_rad_s: float,
) -> RadiusEstimate:
    """The effective radius the drive implies if its latitude and longitude are swapped.

    Near Europe's meridians a swapped pair stays within range, but a degree of the
    "latitude" then spans a degree of longitude's distance: every GNSS displacement is
    off by a factor that depends on the heading. When the swapped radius is plausible
    and the drive's own is not, the columns are swapped.

    A longitude beyond ±90 deg cannot be a latitude: for such a drive (most of the
    world's roads: the Americas, most of Asia, Oceania) the hypothesis is impossible,
    and it is rejected without computing a single distance (the geodesic would be asked
    for latitudes beyond ±90 deg and refuse).

    Args:
        drive: canonical columns.
        segments: the drive's valid segments.
        moving_wheel_speed_rad_s: as in :func:`implied_radius`.

    Returns:
        The estimate with ``lat_deg`` and ``lon_deg`` exchanged; ``radius_m`` NaN (no
        moving second) when some longitude of the segments lies beyond ±90 deg.
    """
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    used = np.zeros(lon.size, dtype=bool)
    for seg in segments:  # per segment, not per sample
        used[seg.row_start : seg.row_stop] = True
    if np.any(np.abs(lon[used]) > 90.0):
        return RadiusEstimate(float("nan"), 0, 0.0, 0.0)
    swapped = dict(drive)
    swapped[c.LAT_DEG], swapped[c.LON_DEG] = drive[c.LON_DEG], drive[c.LAT_DEG]
    return implied_radius(swapped, segments, moving_wheel_speed_rad_s)


def radians_radius(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    moving_wheel_speed_rad_s: float,
) -> RadiusEstimate | None:
    """The effective radius the drive implies if its coordinates are radians, not degrees.

    Args:
        drive: canonical columns.
        segments: the drive's valid segments.
        moving_wheel_speed_rad_s: as in :func:`implied_radius`.

    Returns:
        The estimate with both coordinates converted from radians, or None when some
        latitude lies beyond ±π/2 or longitude beyond ±π (they cannot be radians).
    """
    return _rescaled_radius(drive, segments, moving_wheel_speed_rad_s, 180.0 / math.pi)


def minutes_radius(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    moving_wheel_speed_rad_s: float,
) -> RadiusEstimate | None:
    """The effective radius the drive implies if its coordinates are degrees that were read
    as minutes of arc (a map's ``min``, or ``ddmm`` on a column of degrees below 60).

    Such a drive lies within a degree or so of (0, 0) and every GNSS displacement is about
    60 times too short (between 37 and 60 times, by the heading, far from the equator). A
    radians reading (x 57.3) may fit it too; validate then names both.

    Args:
        drive: canonical columns.
        segments: the drive's valid segments.
        moving_wheel_speed_rad_s: as in :func:`implied_radius`.

    Returns:
        The estimate with both coordinates multiplied by 60, or None when that puts some
        latitude beyond ±90 deg or longitude beyond ±180 deg.
    """
    return _rescaled_radius(drive, segments, moving_wheel_speed_rad_s, 60.0)


def _rescaled_radius(
    drive: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    moving_wheel_speed_rad_s: float,
    factor: float,
) -> RadiusEstimate | None:
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64) * factor
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64) * factor
    if np.nanmax(np.abs(lat)) > 90.0 or np.nanmax(np.abs(lon)) > 180.0:
        return None
    converted = dict(drive)
    converted[c.LAT_DEG], converted[c.LON_DEG] = lat, lon
    return implied_radius(converted, segments, moving_wheel_speed_rad_s)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the runs of True in a boolean array."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return edges[0::2], edges[1::2]
