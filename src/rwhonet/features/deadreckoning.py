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
    cum_d = np.cumsum(d)
    mid_d = cum_d - 0.5 * d  # start to the middle of each second
    # A stretch of `block_gap_s` seconds or more without a course (a stop, a manoeuvre)
    # starts a new block with its own heading: through it the wheels' yaw is not
    # checked by GNSS and may be wrong (wheel speeds are magnitudes, so a reversing
    # turn counts the wrong way round).
    idx = np.flatnonzero(known)
    block = np.zeros(d.size, np.int64)
    block[idx] = np.cumsum(np.r_[0, np.diff(idx) > block_gap_s])
    n_blocks = int(block[idx[-1]]) + 1
    prior = np.array([[1.0 / scale_sd, 0.0], [0.0, 1.0 / bias_sd_rad_per_m]])
    prior_target = np.array([1.0 / scale_sd, 0.0])
    first_known = idx[np.r_[0, np.flatnonzero(np.diff(block[idx])) + 1]]
    best: tuple[float, HeadingFit] | None = None
    for load in np.asarray(grid, np.float64):
        yc = y / (1.0 + load * d * d)
        cum_y = np.cumsum(yc)
        mid_y = cum_y - 0.5 * yc
        # Unwrap against this c's nominal model (s = 1, no bias), from each block's first
        # course: any amount of turning is fine.
        ref = (c + mid_y)[first_known][block]
        unwrapped = _wrap(c + mid_y - ref) - mid_y + ref
        keep = known.copy()
        for _ in range(3):
            # Each block's heading is a free intercept: fit s and β on the data less
            # their block means (exactly the least squares with one intercept per block).
            b = block[keep]
            n_b = np.bincount(b, minlength=n_blocks).astype(np.float64)
            cols = np.column_stack([unwrapped[keep], -mid_y[keep], -mid_d[keep]])
            means = (
                np.stack([np.bincount(b, cols[:, j], n_blocks) for j in range(3)], axis=1)
                / np.maximum(n_b, 1.0)[:, None]
            )
            dm = cols - means[b]
            scale, bias = np.linalg.lstsq(
                np.vstack([dm[:, 1:] / course_sd_rad, prior]),
                np.concatenate([dm[:, 0] / course_sd_rad, prior_target]),
                rcond=None,
            )[0]
            scale, bias = float(scale), float(bias)
            az0 = means[:, 0] - scale * means[:, 1] - bias * means[:, 2]
            resid = np.abs(unwrapped - (az0[block] - scale * mid_y - bias * mid_d))
            new_keep = known & (resid <= outlier_rad)
            if new_keep.sum() < 3 or np.array_equal(new_keep, keep):
                break
            keep = new_keep
        cost = float(
            np.sum(np.minimum(resid[known], outlier_rad) ** 2) / course_sd_rad**2
            + ((scale - 1.0) / scale_sd) ** 2
            + (bias / bias_sd_rad_per_m) ** 2
        )
        if best is None or cost < best[0]:
            last = int(block[np.flatnonzero(keep)[-1]])  # the latest block with a course kept
            fit = HeadingFit(
                scale,
                bias,
                float(az0[last]) - scale * cum_y[-1] - bias * cum_d[-1],
                int(keep.sum()),
                float(np.ptp(mid_y[known])),
                float(load),
            )
            best = (cost, fit)
    assert best is not None
    return best[1]


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
