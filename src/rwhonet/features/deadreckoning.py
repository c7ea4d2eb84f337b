"""2D dead reckoning through a GNSS outage: heading from the rear wheels, distance from a model.

Beyond the paper, whose errors are distances travelled (1D). During an outage
the car's position advances by each second's displacement (the WPM's, or the
WPM corrected by a WhONet) along a heading carried forward from the last GNSS
course by the yaw the rear wheels measure:

- yaw per second (left turns positive): ``Δψ = (r_rr θ_rr − r_rl θ_rl) / b``,
  the difference of the rear wheels' travel over the rear track ``b``
  (``data.vehicles.<car>.track_rear_m``), the classic differential odometry of
  a rear axle with no steer;
- the effective track differs from the nominal one (tyre compliance, radius
  differences, slip), so the yaw's scale ``s`` is fitted against the GNSS
  course over the seconds before the outage, together with the heading the
  outage starts on and a yaw bias per metre (a left/right radius difference)
  (:func:`fit_heading`);
- in a turn, lateral load transfer (``m a_y h / t`` per axle) loads the outer
  wheel and unloads the inner one, and a tyre's effective rolling radius falls
  by about a third of its extra deflection (Pacejka 2012, as the simulator
  models it): the outer wheel turns faster than its travel, so the wheels
  overstate the yaw by a factor ``1 + c v^2`` (``a_y = v ψ'``: the radius
  difference grows with ``a_y``, its yaw error with ``v a_y``). ``c`` depends on
  the tyres' vertical stiffness, that is on their pressure, so it is fitted
  too: on a soft (14 psi) rear axle of a Fiesta it is about 0.003 s²/m², and
  the wheels then report 2.5 times the yaw of a 22 m/s bend;
- the GNSS course of second k is the azimuth of the chord from the fix ending
  second k−1 to the one ending second k: the heading at the middle of second k;
- position, in a local east/north frame at the fix before the outage
  (:mod:`rwhonet.geo.local`): per second, with azimuth ``az`` clockwise from
  north, ``az_mid = az − s Δψ / 2``, ``(east, north) += d (sin az_mid, cos az_mid)``,
  ``az −= s Δψ`` (midpoint rule).

With ideal wheels and a perfect receiver this ends within centimetres of the
GNSS position after minutes of driving (``tests/features/test_deadreckoning.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rwhonet.geo.geodesic import wgs84


def wheel_yaw_rad(
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    r_rl_m: float,
    r_rr_m: float,
    track_rear_m: float,
) -> np.ndarray:
    """Yaw per second from the rear wheels' travel difference (left turns positive), rad.

    Args:
        angle_rl_rad: rear-left wheel angle per second, rad.
        angle_rr_rad: rear-right wheel angle per second, rad.
        r_rl_m: rear-left rolling radius, m/rad.
        r_rr_m: rear-right rolling radius, m/rad.
        track_rear_m: rear track width, m.

    Returns:
        (n,) float64 rad.
    """
    rl = r_rl_m * np.asarray(angle_rl_rad, np.float64)
    rr = r_rr_m * np.asarray(angle_rr_rad, np.float64)
    return (rr - rl) / float(track_rear_m)


def course_rad(lat_deg: np.ndarray, lon_deg: np.ndarray, min_step_m: float) -> np.ndarray:
    """GNSS course of each second: the azimuth from the previous fix to this one, rad.

    Args:
        lat_deg: latitudes of the fixes ending consecutive seconds, degrees.
        lon_deg: their longitudes.
        min_step_m: a second that moved less has no course (NaN).

    Returns:
        (n,) azimuth clockwise from north in radians; element 0 (no previous fix)
        and slow seconds are NaN.
    """
    lat = np.asarray(lat_deg, np.float64)
    lon = np.asarray(lon_deg, np.float64)
    out = np.full(lat.shape, np.nan)
    if lat.size < 2:
        return out
    az, _, dist = wgs84().inv(lon[:-1], lat[:-1], lon[1:], lat[1:])
    az = np.radians(np.asarray(az, np.float64))
    out[1:] = np.where(np.asarray(dist) >= min_step_m, az, np.nan)
    return out


# A course this precise (rad, one standard deviation) anchors the unwrapping of the others.
_SURE_COURSE_RAD = 0.15


def _wrap(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class HeadingFit:
    """The heading track fitted to the GNSS course before an outage.

    Attributes:
        scale: multiplies the wheel yaw.
        bias_rad_per_m: yaw added per metre travelled (a left/right radius
            difference turns a straight drive into a wide circle), rad/m.
        azimuth_end_rad: the azimuth at the end of the last second, rad clockwise from north.
        n_courses: GNSS courses used.
        turned_rad: the wheel yaw's range over those seconds.
        load_s2_m2: the load-transfer coefficient ``c``: the wheels report
            ``1 + c v²`` times the yaw, v in m/s.
    """

    scale: float
    bias_rad_per_m: float
    azimuth_end_rad: float
    n_courses: int
    turned_rad: float
    load_s2_m2: float = 0.0


def fit_heading(
    course: np.ndarray,
    yaw: np.ndarray,
    disp_m: np.ndarray,
    *,
    course_sd_rad: float = 0.02,
    scale_sd: float = 0.05,
    bias_sd_rad_per_m: float = 0.003,
    outlier_rad: float = 0.2,
    max_yaw_rad: float = 0.05,
    load_grid_s2_m2: np.ndarray | None = None,
    block_gap_s: int = 5,
    fix_sd_m: float | None = None,
    memory_s: float | None = 600.0,
    yaw_noise_rad: float = 0.003,
) -> HeadingFit | None:
    """Fit the start azimuth, the yaw scale, a yaw bias and the load-transfer term to GNSS courses.

    The course of second k is the heading at its middle:
    ``az0 − s Y_k − β D_k``, with ``Y_k`` the wheel yaw divided by ``1 + c v²``
    (v: the second's distance over 1 s; module docstring) summed from the start
    to the middle of second k, and ``D_k`` the distance over the same stretch
    (the yaw is counter-clockwise, the azimuth clockwise). ``β`` absorbs a
    difference between the rear wheels' radii, which the nominal radii used for
    the yaw do not know. For each ``c`` of ``load_grid_s2_m2``: a weighted
    linear least-squares fit over every second with a course, with priors
    ``s = 1 ± scale_sd`` and ``β = 0 ± bias_sd_rad_per_m`` (a stretch with little
    turning, or turning in step with distance as on a roundabout at constant
    speed, then leaves them near their priors instead of trading one for the
    other), then again without courses more than ``outlier_rad`` off (GNSS
    jumps). The ``c`` whose fit has the least truncated squared residual (each
    course's capped at ``outlier_rad``, so fits dropping different courses
    compare) plus prior terms wins. Fitting the whole stretch, rather than
    course changes second by second, keeps the within-second approximation
    local instead of accumulating.

    What makes it hold on other cars' drives (docs/positioning.md measures each):

    - each course weighs by its own noise, ``course_sd² + 2 σ²/d²`` for fixes
      with white noise σ per axis (:func:`fix_noise_m` estimates σ from the
      data unless ``fix_sd_m`` is given): with a consumer receiver's metre of
      noise a slow second's chord points anywhere;
    - the courses are unwrapped course after course (against the nominal
      model, anchored on the precise ones), so any amount of drift between the
      wheels and the courses over a long stretch is followed;
    - a block splits only where courses are missing, not where a turn taken
      while braking was left out of the fit;
    - older seconds weigh less (``memory_s``), so a radius difference that
      grows (a tyre losing pressure) is fitted as it is now;
    - the heading the outage starts on is the fitted track's, re-anchored on
      the last block's latest courses (the wheels' noise makes the fitted
      track wander from the truth as a random walk of ``yaw_noise_rad`` per
      second).

    Args:
        course: (n,) GNSS course per second, rad (NaN where unknown).
        yaw: (n,) wheel yaw per second, rad.
        disp_m: (n,) distance per second, m.
        course_sd_rad: the courses' noise, rad (weights the data against the priors).
        scale_sd: prior spread of the yaw scale around 1.
        bias_sd_rad_per_m: prior spread of the bias around 0, rad/m (a 0.4 %
            radius difference on a 1.5 m track is 0.003 rad/m).
        outlier_rad: residual beyond which a course is dropped in the second pass.
        max_yaw_rad: a second gives a course only if its yaw times its relative
            change of speed is below this times 2 %: in a turn taken while
            speeding up or slowing down, a second's chord follows its
            distance-weighted mean heading, not the heading at its middle time,
            while between the other seconds the summed wheel yaw is exact.
        load_grid_s2_m2: the values of ``c`` tried, s²/m² (default 0 to 0.01 in
            steps of 0.00025: from stiff tyres to a very soft axle).
        block_gap_s: seconds without a course (stopped, crawling, a GNSS jump
            dropped) after which the heading is fitted afresh: the scale, bias and
            ``c`` are shared by the whole stretch, the heading only within a block.
        fix_sd_m: the fixes' white noise per axis, m (None: estimated, :func:`fix_noise_m`).
        memory_s: a course ``a`` seconds before the end weighs ``exp(−a / memory_s)``
            (in squared residuals); None: all alike.
        yaw_noise_rad: the wheels' yaw noise per second, rad (the random walk the
            heading anchor's memory is set against; 0.003 rad is a 0.03 rad/s CAN
            wheel-speed noise on a 1.46 m track).

    Returns:
        The fit, or None when fewer than 3 seconds have a course.
    """
    c = np.asarray(course, np.float64)
    y = np.asarray(yaw, np.float64)
    d = np.asarray(disp_m, np.float64)
    grid = np.linspace(0.0, 0.01, 41) if load_grid_s2_m2 is None else load_grid_s2_m2
    # relative change of speed around each second (its neighbours' distances)
    dd = (
        np.abs(np.r_[d[1:2], d[2:], d[-1:]] - np.r_[d[:1], d[:-2], d[-2:-1]])
        if d.size > 2
        else 0 * d
    )
    accel = dd / np.maximum(2.0 * d, 1e-6)
    known = np.isfinite(c) & (np.abs(y) * accel <= max_yaw_rad * 0.02)
    if known.sum() < 3:
        return None
    # Each course's own noise: a chord of d metres between two fixes with white noise
    # sigma_fix per axis points sqrt(2) sigma_fix / d off; on a receiver with metres of
    # fix noise a slow second's course is nearly random and must weigh (d / d_fast)^2 less.
    sigma_fix = fix_noise_m(c, y, d) if fix_sd_m is None else float(fix_sd_m)
    sd = np.sqrt(course_sd_rad**2 + 2.0 * sigma_fix**2 / np.maximum(d, 1e-3) ** 2)
    w = 1.0 / sd
    if memory_s is not None:
        w = w * np.exp(-0.5 * (d.size - 1 - np.arange(d.size)) / memory_s)
    limit = np.maximum(outlier_rad, 4.0 * sd)
    cum_d = np.cumsum(d)
    mid_d = cum_d - 0.5 * d  # start to the middle of each second
    # A stretch of `block_gap_s` seconds or more without a course (a stop, a manoeuvre)
    # starts a new block with its own heading: through it the wheels' yaw is not
    # checked by GNSS and may be wrong (wheel speeds are magnitudes, so a reversing
    # turn counts the wrong way round). Seconds that have a course but are left out
    # of the fit (a turn while the speed changes) do not split a block: the wheels'
    # yaw through them is good, and a split would leave the heading at the outage to
    # the few courses after the last such second.
    idx = np.flatnonzero(known)
    present = np.flatnonzero(np.isfinite(c))
    starts = present[np.r_[0, np.flatnonzero(np.diff(present) > block_gap_s) + 1]]
    raw = np.maximum(np.searchsorted(starts, np.arange(d.size), side="right") - 1, 0)
    kept_blocks = np.unique(raw[idx])  # blocks with at least one course fitted
    block = np.minimum(np.searchsorted(kept_blocks, raw), kept_blocks.size - 1)
    n_blocks = kept_blocks.size
    prior = np.array([[1.0 / scale_sd, 0.0], [0.0, 1.0 / bias_sd_rad_per_m]])
    prior_target = np.array([1.0 / scale_sd, 0.0])
    best: tuple[float, HeadingFit] | None = None
    for load in np.asarray(grid, np.float64):
        yc = y / (1.0 + load * d * d)
        cum_y = np.cumsum(yc)
        mid_y = cum_y - 0.5 * yc
        # Unwrap against this c's nominal model (s = 1, no bias) course after course, on
        # the courses that can be trusted to a fraction of a turn: consecutive ones differ
        # from the model by little, however far the model's error has drifted over the
        # stretch (a long drive, a left/right radius difference); the noisy ones take the
        # branch nearest to their trusted neighbours (one wild course in a sequential
        # unwrap would turn every course after it by 2 pi).
        level = c + mid_y
        sure = idx[sd[idx] < _SURE_COURSE_RAD]
        if sure.size >= 2:
            base = np.interp(idx, sure, np.unwrap(level[sure]))
        else:
            base = np.full(idx.size, level[idx[0]])
        unwrapped = np.full(d.size, np.nan)
        unwrapped[idx] = base + _wrap(level[idx] - base) - mid_y[idx]
        keep = known.copy()
        for _ in range(3):
            # Each block's heading is a free intercept: fit s and β on the data less
            # their block means (exactly the weighted least squares with one intercept
            # per block).
            b = block[keep]
            wk = w[keep] ** 2
            n_b = np.bincount(b, wk, minlength=n_blocks)
            cols = np.column_stack([unwrapped[keep], -mid_y[keep], -mid_d[keep]])
            means = (
                np.stack([np.bincount(b, wk * cols[:, j], n_blocks) for j in range(3)], axis=1)
                / np.maximum(n_b, 1e-300)[:, None]
            )
            dm = (cols - means[b]) * w[keep][:, None]
            scale, bias = np.linalg.lstsq(
                np.vstack([dm[:, 1:], prior]),
                np.concatenate([dm[:, 0], prior_target]),
                rcond=None,
            )[0]
            scale, bias = float(scale), float(bias)
            az0 = means[:, 0] - scale * means[:, 1] - bias * means[:, 2]
            model = az0[block] - scale * mid_y - bias * mid_d
            resid = np.abs(_wrap(unwrapped - model))
            unwrapped[idx] = model[idx] + _wrap(unwrapped - model)[idx]  # the fit's branch
            new_keep = known & (resid <= limit)
            if new_keep.sum() < 3 or np.array_equal(new_keep, keep):
                break
            keep = new_keep
        cost = float(
            np.sum(np.minimum(resid[known], limit[known]) ** 2 / sd[known] ** 2)
            + ((scale - 1.0) / scale_sd) ** 2
            + (bias / bias_sd_rad_per_m) ** 2
        )
        if best is None or cost < best[0]:
            last = int(block[np.flatnonzero(keep)[-1]])  # the latest block with a course kept
            # The heading the fitted track reaches carries every second's wheel noise since
            # the block began (a random walk of yaw_noise_rad per second); the latest courses
            # know better. Re-anchor on the last block's residuals, each weighted by its
            # precision and by how recent it is: a time constant sqrt(course var / walk var)
            # is where a course's noise equals the walk since it (a Kalman filter's memory).
            # Every course of the block counts, not only those the fitted track kept: where
            # the track has drifted off (a tyre losing air faster than the memory follows)
            # the latest courses are the ones it dropped. GNSS jumps are left out against
            # the latest courses' own median instead.
            ours = np.flatnonzero(known & (block == last))
            off = _wrap(unwrapped[ours] - model[ours])
            tau = np.sqrt(np.median(sd[ours] ** 2) / yaw_noise_rad**2)
            recent = d.size - 1 - ours <= 3.0 * tau
            centre = np.median(off[recent]) if recent.any() else np.median(off)
            gap = np.abs(_wrap(off - centre))
            near = gap <= limit[ours]
            if not near.any():  # none within its limit of the median (two courses apart)
                near = gap == gap.min()
            age = d.size - 1 - ours[near]
            wa = np.exp(-(age - age.min()) / tau) / sd[ours[near]] ** 2
            anchor = float(centre + np.sum(wa * _wrap(off[near] - centre)) / np.sum(wa))
            fit = HeadingFit(
                scale,
                bias,
                float(az0[last]) - scale * cum_y[-1] - bias * cum_d[-1] + anchor,
                int(keep.sum()),
                float(np.ptp(mid_y[known])),
                float(load),
            )
            best = (cost, fit)
    assert best is not None
    return best[1]


def fix_noise_m(course: np.ndarray, yaw: np.ndarray, disp_m: np.ndarray) -> float:
    """The GNSS fixes' white noise per axis, estimated from how consecutive courses scatter.

    Between the middles of seconds k−1 and k the car turns by about half of each
    second's wheel yaw, so ``r_k = course_k − course_(k−1) + (yaw_(k−1) + yaw_k) / 2``
    is noise: the two chords' errors (about ``sqrt(2) σ / d`` each, for fixes with
    white noise σ per axis), the wheels' noise and their scale and bias errors
    over one second. Where the chords' term dominates, ``r_k² / u_k`` with
    ``u_k = 2 / d_k² + 2 / d_(k−1)²`` estimates σ²; its median over every pair of
    consecutive courses, divided by 0.455 (the median of a χ² variable with one
    degree of freedom), is robust to GNSS jumps and to the seconds where the
    other terms dominate (they only make the estimate larger, and the fit's
    weights more cautious, on a receiver whose fixes are already smooth).

    Args:
        course: (n,) GNSS course per second, rad (NaN where unknown).
        yaw: (n,) wheel yaw per second, rad.
        disp_m: (n,) distance per second, m.

    Returns:
        σ, m (0 when fewer than 3 pairs of consecutive courses exist).
    """
    c = np.asarray(course, np.float64)
    y = np.asarray(yaw, np.float64)
    d = np.maximum(np.asarray(disp_m, np.float64), 1e-3)
    pair = np.isfinite(c[1:]) & np.isfinite(c[:-1])
    if pair.sum() < 3:
        return 0.0
    r = _wrap(c[1:] - c[:-1] + 0.5 * (y[1:] + y[:-1]))[pair]
    # the two chords share their middle fix: its noise turns them in opposite directions
    u = (1.0 / d[1:] ** 2 + 1.0 / d[:-1] ** 2 + (1.0 / d[1:] + 1.0 / d[:-1]) ** 2)[pair]
    return float(np.sqrt(np.median(r**2 / u) / 0.455))


def dead_reckon(
    azimuth0_rad: float,
    disp_m: np.ndarray,
    yaw_rad: np.ndarray,
    scale: float,
    bias_rad_per_m: float = 0.0,
    load_s2_m2: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Positions at the end of each second, from (0, 0) and an initial azimuth.

    Args:
        azimuth0_rad: azimuth at the start, clockwise from north, rad.
        disp_m: (n,) distance travelled in each second, m.
        yaw_rad: (n,) wheel yaw in each second (left turns positive), rad.
        scale: the yaw scale (:func:`fit_heading`).
        bias_rad_per_m: the yaw bias per metre (:func:`fit_heading`).
        load_s2_m2: the load-transfer coefficient (:func:`fit_heading`).

    Returns:
        ``(east_m, north_m)``, each (n,), cumulative.
    """
    d = np.asarray(disp_m, np.float64)
    turn = scale * np.asarray(yaw_rad, np.float64) / (1.0 + load_s2_m2 * d * d) + bias_rad_per_m * d
    az_end = azimuth0_rad - np.cumsum(turn)
    az_mid = az_end + 0.5 * turn
    chord = d * np.sinc(turn / (2.0 * np.pi))  # an arc of angle a: chord = arc sin(a/2)/(a/2)
    return np.cumsum(chord * np.sin(az_mid)), np.cumsum(chord * np.cos(az_mid))
