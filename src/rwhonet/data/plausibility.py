"""Plausibility of wheel speeds: the effective radius they imply, and unit mistakes it reveals.

Wheel odometry gives a displacement ``x = ∫ ω r dt`` per second (paper Eq. 10). Over
many seconds, GNSS distance / wheel angle is therefore an effective rolling radius
(the calibration constant of the authors' code, in m/rad). A drive whose implied
radius is far from the vehicle's nominal one has wheel speeds in the wrong unit, and
the ratio says which: rpm gives 2π/60 of the radius, deg/s π/180, and a linear wheel
speed in km/h (m/s) gives a "radius" of 1/3.6 m (1 m) whatever the tyre.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.quality import Segment, second_index
from rwhonet.geo import geodesic_distance_m


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

    Returns:
        The estimate (``radius_m`` is NaN when no second counted).
    """
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    wheel = 0.5 * (np.abs(np.asarray(drive[c.OMEGA_RL])) + np.abs(np.asarray(drive[c.OMEGA_RR])))
    segment = np.full(t.size, -1)
    for k, seg in enumerate(segments):  # per segment, not per sample
        segment[seg.row_start : seg.row_stop] = k
    sec = second_index(t)
    # Last row of each second inside a segment: the per-second fix.
    last = np.flatnonzero(
        (segment >= 0) & (np.r_[sec[1:] != sec[:-1], True] | (segment != np.r_[segment[1:], -1]))
    )
    if last.size < 2:
        return RadiusEstimate(float("nan"), 0, 0.0, 0.0)
    same = segment[last[1:]] == segment[last[:-1]]
    prev, this = last[:-1][same], last[1:][same]
    # Cumulative wheel angle, so the angle between any two rows is one subtraction.
    angle = np.r_[0.0, np.cumsum(0.5 * (wheel[1:] + wheel[:-1]) * np.diff(t))]
    angle_s = angle[this] - angle[prev]
    moving = angle_s / (t[this] - t[prev]) > moving_wheel_speed_rad_s
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    dist = geodesic_distance_m(lat[prev], lon[prev], lat[this], lon[this])
    total_m, total_rad = float(dist[moving].sum()), float(angle_s[moving].sum())
    radius = total_m / total_rad if total_rad > 0 else float("nan")
    return RadiusEstimate(radius, int(moving.sum()), total_m, total_rad)


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
