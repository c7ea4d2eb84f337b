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
    """

    scale: float
    bias_rad_per_m: float
    azimuth_end_rad: float
    n_courses: int
    turned_rad: float


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
) -> HeadingFit | None:
    """Fit the start azimuth, the yaw scale and a yaw bias to the GNSS courses of a stretch.

    The course of second k is the heading at its middle:
    ``az0 − s Y_k − β D_k``, with ``Y_k`` the wheel yaw and ``D_k`` the distance
    from the start to the middle of second k (the yaw is counter-clockwise, the
    azimuth clockwise). ``β`` absorbs a difference between the rear wheels'
    radii, which the nominal radii used for the yaw do not know. A weighted
    linear least-squares fit over every second with a course, with priors
    ``s = 1 ± scale_sd`` and ``β = 0 ± bias_sd_rad_per_m``: a stretch with little
    turning (or turning in step with distance, as on a roundabout at constant
    speed) then leaves them near their priors instead of trading one for the
    other. Then again without courses more than ``outlier_rad`` off (GNSS
    jumps). Fitting the whole stretch, rather than course changes second by
    second, keeps the within-second approximation local instead of accumulating.

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

    Returns:
        The fit, or None when fewer than 3 seconds have a course.
    """
    c = np.asarray(course, np.float64)
    y = np.asarray(yaw, np.float64)
    d = np.asarray(disp_m, np.float64)
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
    cum_y, cum_d = np.cumsum(y), np.cumsum(d)
    mid_y, mid_d = cum_y - 0.5 * y, cum_d - 0.5 * d  # start to the middle of each second
    # Unwrap against the nominal model (s = 1, no bias) so any amount of turning is fine.
    ref = c[known][0] + mid_y[known][0]
    unwrapped = _wrap(c + mid_y - ref) - mid_y + ref
    keep = known.copy()
    prior = np.array([[0.0, 1.0 / scale_sd, 0.0], [0.0, 0.0, 1.0 / bias_sd_rad_per_m]])
    prior_target = np.array([1.0 / scale_sd, 0.0])
    for _ in range(3):
        a = np.column_stack([np.ones(keep.sum()), -mid_y[keep], -mid_d[keep]]) / course_sd_rad
        coef = np.linalg.lstsq(
            np.vstack([a, prior]),
            np.concatenate([unwrapped[keep] / course_sd_rad, prior_target]),
            rcond=None,
        )[0]
        az0, scale, bias = (float(v) for v in coef)
        resid = np.abs(unwrapped - (az0 - scale * mid_y - bias * mid_d))
        new_keep = known & (resid <= outlier_rad)
        if new_keep.sum() < 3 or np.array_equal(new_keep, keep):
            break
        keep = new_keep
    return HeadingFit(
        scale, bias, az0 - scale * cum_y[-1] - bias * cum_d[-1], int(keep.sum()),
        float(np.ptp(mid_y[known])),
    )  # fmt: skip


def dead_reckon(
    azimuth0_rad: float,
    disp_m: np.ndarray,
    yaw_rad: np.ndarray,
    scale: float,
    bias_rad_per_m: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Positions at the end of each second, from (0, 0) and an initial azimuth.

    Args:
        azimuth0_rad: azimuth at the start, clockwise from north, rad.
        disp_m: (n,) distance travelled in each second, m.
        yaw_rad: (n,) wheel yaw in each second (left turns positive), rad.
        scale: the yaw scale (:func:`fit_heading`).
        bias_rad_per_m: the yaw bias per metre (:func:`fit_heading`).

    Returns:
        ``(east_m, north_m)``, each (n,), cumulative.
    """
    d = np.asarray(disp_m, np.float64)
    turn = scale * np.asarray(yaw_rad, np.float64) + bias_rad_per_m * d
    az_end = azimuth0_rad - np.cumsum(turn)
    az_mid = az_end + 0.5 * turn
    chord = d * np.sinc(turn / (2.0 * np.pi))  # an arc of angle a: chord = arc sin(a/2)/(a/2)
    return np.cumsum(chord * np.sin(az_mid)), np.cumsum(chord * np.cos(az_mid))
