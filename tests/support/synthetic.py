"""Synthetic 10 Hz drives with known truth, built independently of the code under test.

Fixes come from GeographicLib's direct problem along one geodesic (a straight
road), wheel speeds from ``omega = v / r`` with the true radii, so every label
component is known: zero slip and the true radius leave only GNSS noise and the
WPM's integration error.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from geographiclib.geodesic import Geodesic

from rwhonet.data import canonical as c

LAT0, LON0, AZIMUTH_DEG = 52.4068, -1.5197, 63.0
R_RL_M, R_RR_M, R_FRONT_M = 0.301, 0.297, 0.299
T0_S = 1000.0
_A, _F = 6378137.0, 1 / 298.257223563
_E2 = _F * (2 - _F)

Profile = tuple[np.ndarray, np.ndarray, np.ndarray]  # (t_s, s_m, v_m_s) per row


def build_drive(
    profile: Profile,
    *,
    r_rl_m: float = R_RL_M,
    r_rr_m: float = R_RR_M,
    r_front_m: float = R_FRONT_M,
    gnss_sigma_m: float = 0.0,
    wheel_sigma_rad_s: float = 0.0,
    scenario: np.ndarray | None = None,
    seed: int = 0,
) -> pd.DataFrame:
    """Return a canonical segment that drives ``s_m(t)`` metres along a straight geodesic.

    Args:
        profile: ``(t_s, s_m, v_m_s)``: row times, true distance travelled, true speed.
        r_rl_m: true rear-left rolling radius (the wheel speed is ``v / r``).
        r_rr_m: true rear-right rolling radius.
        r_front_m: true front rolling radius.
        gnss_sigma_m: white horizontal GNSS noise per axis, metres.
        wheel_sigma_rad_s: white wheel-speed noise, rad/s.
        scenario: optional per-row tags.
        seed: noise seed.
    """
    t_s, s_m, v_m_s = profile
    rng = np.random.default_rng(seed)
    line = Geodesic.WGS84.Line(LAT0, LON0, AZIMUTH_DEG)
    fixes = [line.Position(float(s)) for s in s_m]  # the direct problem along one geodesic
    lat = np.array([f["lat2"] for f in fixes])
    lon = np.array([f["lon2"] for f in fixes])
    if gnss_sigma_m > 0:
        east, north = rng.normal(0.0, gnss_sigma_m, (2, len(t_s)))
        # Meridian (M) and prime-vertical (N) radii of curvature turn metres into
        # degrees; exact to first order, far below the noise itself.
        w = np.sqrt(1 - _E2 * np.sin(np.radians(lat)) ** 2)
        lat_new = lat + np.degrees(north * w**3 / (_A * (1 - _E2)))
        lon = lon + np.degrees(east * w / (_A * np.cos(np.radians(lat))))
        lat = lat_new

    def wheel(r: float) -> np.ndarray:
        omega = v_m_s / r
        if wheel_sigma_rad_s > 0:
            # A wheel-speed sensor counts pulses: a wheel at rest reads exactly 0.
            noise = rng.normal(0.0, wheel_sigma_rad_s, len(t_s))
            omega = omega + np.where(v_m_s == 0, 0.0, noise)
        return omega

    return pd.DataFrame(
        {
            c.T_S: t_s,
            c.LAT_DEG: lat,
            c.LON_DEG: lon,
            c.OMEGA_FL: wheel(r_front_m),
            c.OMEGA_FR: wheel(r_front_m),
            c.OMEGA_RL: wheel(r_rl_m),
            c.OMEGA_RR: wheel(r_rr_m),
            c.SCENARIO: scenario if scenario is not None else np.full(len(t_s), ""),
        }
    )


def _grid(duration_s: float, t0_s: float) -> tuple[np.ndarray, np.ndarray]:
    tau = np.arange(int(round(duration_s * 10)) + 1) / 10.0
    return t0_s + tau, tau


def constant_speed(duration_s: float, v_m_s: float, t0_s: float = T0_S) -> Profile:
    """Constant speed for ``duration_s`` seconds (``10 duration_s + 1`` rows)."""
    t, tau = _grid(duration_s, t0_s)
    return t, v_m_s * tau, np.full(len(t), float(v_m_s))


def constant_acceleration(
    duration_s: float, v0_m_s: float, a_m_s2: float, t0_s: float = T0_S
) -> Profile:
    """Constant acceleration ``a`` from speed ``v0``."""
    t, tau = _grid(duration_s, t0_s)
    return t, v0_m_s * tau + 0.5 * a_m_s2 * tau**2, v0_m_s + a_m_s2 * tau


def wavy_speed(
    duration_s: float, v0_m_s: float, amp_m_s: float, period_s: float, t0_s: float = T0_S
) -> Profile:
    """Speed ``v0 + amp sin(2 pi tau / period)``, with the exact distance integral."""
    t, tau = _grid(duration_s, t0_s)
    w = 2 * np.pi / period_s
    return (
        t,
        v0_m_s * tau + amp_m_s / w * (1 - np.cos(w * tau)),
        v0_m_s + amp_m_s * np.sin(w * tau),
    )


def piecewise_linear_speed(
    knots_s: list[float], knots_v_m_s: list[float], t0_s: float = T0_S
) -> Profile:
    """Speed linear between knots (knot times on the 0.1 s grid), with the exact distance.

    Between two samples the speed is linear, so the cumulative trapezoid is the
    exact integral.
    """
    t, tau = _grid(knots_s[-1], t0_s)
    v = np.interp(tau, knots_s, knots_v_m_s)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(tau))])
    return t, s, v
