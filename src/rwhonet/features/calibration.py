"""Effective rolling radius of each rear wheel, fitted on the source vehicle.

The WPM (paper Eqs. 8-10) needs the constant ``r`` that maps wheel angle to
distance. It is fitted per rear wheel on the calibration drive(s) against the
GNSS displacement.

Estimator used (``ratio_of_sums``): over the *moving* seconds,
``r = sum(disp_gnss_m) / sum(wheel angle)``. This is the least-squares slope
through the origin weighted by 1/angle, i.e. total distance over total angle.
It weights each second by its distance, so slow seconds (where GNSS noise is
large relative to the motion and the distance, a norm, is biased upwards by
``~ sigma^2 / d``) barely count; standstill contributes 0 / 0 to neither sum.

Which seconds are "moving" is decided in two passes. A first radius is fitted
on the seconds whose GNSS speed is at least ``min_speed_m_s``; the final
selection then uses the *wheel* speed times that radius. Selecting on the
regressor (wheel angle) rather than the response (GNSS distance) keeps the
ratio unbiased: choosing seconds by their GNSS distance would prefer seconds
whose GNSS noise happened to be positive near the threshold.

Alternative kept for comparison (``mean_of_ratios``, the authors' code): the
mean over all seconds of ``disp_gnss_m / (omega * 1 s)`` with ``omega`` one
wheel-speed sample per second. It divides by zero at standstill (the result is
inf or NaN) and every slow second enters with full weight, its upward-biased
GNSS distance divided by a small angle, which inflates the radius.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from rwhonet.errors import InputError, Problem

ESTIMATORS: tuple[str, ...] = ("ratio_of_sums", "mean_of_ratios")


@dataclass(frozen=True)
class RadiusFit:
    """Rear-wheel radii from one estimator.

    Attributes:
        r_rl_m: rear-left effective rolling radius, m/rad (inf/NaN when undefined).
        r_rr_m: rear-right effective rolling radius, m/rad.
        estimator: ``ratio_of_sums`` or ``mean_of_ratios``.
        n_seconds: seconds that entered the fit.
        distance_m: GNSS distance over those seconds, metres.
    """

    r_rl_m: float
    r_rr_m: float
    estimator: str
    n_seconds: int
    distance_m: float

    @property
    def finite(self) -> bool:
        """Whether both radii are finite numbers."""
        return math.isfinite(self.r_rl_m) and math.isfinite(self.r_rr_m)


def fit_radii_ratio_of_sums(
    disp_gnss_m: np.ndarray,
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    span_s: np.ndarray,
    min_speed_m_s: float,
    explained_m: np.ndarray | None = None,
) -> RadiusFit:
    """Fit the rear radii as total GNSS distance over total wheel angle on moving seconds.

    Args:
        disp_gnss_m: GNSS displacement per second, metres.
        angle_rl_rad: integrated rear-left wheel angle per second, rad.
        angle_rr_rad: integrated rear-right wheel angle per second, rad.
        span_s: duration of each second, seconds.
        min_speed_m_s: seconds slower than this are left out (``label.calibration_min_speed_m_s``).
        explained_m: per second, what a model added on top of the WPM already explains
            (metres); the radii then fit the rest, ``Σ (GNSS − explained) / Σ angle``, so
            that WPM + model adds up to the GNSS distance. None: nothing.

    Returns:
        The fitted radii and how many seconds and metres they rest on.

    Raises:
        ValueError: if no second reaches ``min_speed_m_s`` or the wheels do not turn forwards.
    """
    d = np.asarray(disp_gnss_m, np.float64)
    th_rl = np.asarray(angle_rl_rad, np.float64)
    th_rr = np.asarray(angle_rr_rad, np.float64)
    dt = np.asarray(span_s, np.float64)
    explained = None if explained_m is None else np.asarray(explained_m, np.float64)

    def ratio(sel: np.ndarray) -> tuple[float, float]:
        den_rl, den_rr = th_rl[sel].sum(), th_rr[sel].sum()
        if not sel.any() or den_rl <= 0 or den_rr <= 0:
            raise ValueError(
                f"no seconds at >= {min_speed_m_s} m/s with forward-turning rear wheels "
                f"among {len(d)} seconds; cannot calibrate the wheel radii"
            )
        total = d[sel].sum() - (explained[sel].sum() if explained is not None else 0.0)
        return float(total / den_rl), float(total / den_rr)

    # Pass 1 selects on GNSS speed; pass 2 re-selects on wheel speed (module docstring).
    r0_rl, r0_rr = ratio(d / dt >= min_speed_m_s)
    moving = 0.5 * (r0_rl * th_rl + r0_rr * th_rr) / dt >= min_speed_m_s
    r_rl, r_rr = ratio(moving)
    return RadiusFit(r_rl, r_rr, "ratio_of_sums", int(moving.sum()), float(d[moving].sum()))


def refit(
    disp_gnss_m: np.ndarray,
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    min_speed_m_s: float,
    explained_m: np.ndarray | None = None,
) -> RadiusFit | None:
    """Rear radii refitted on a stretch of one drive, with the seconds and metres they rest on.

    The calibration's estimator (total GNSS distance over total wheel angle on
    the moving seconds) applied to, e.g., a target drive's first m seconds.
    Seconds are one second long (the samples' grid).

    Args:
        disp_gnss_m: GNSS displacement per second, metres.
        angle_rl_rad: rear-left wheel angle per second, rad (the WPM's mode).
        angle_rr_rad: rear-right wheel angle per second, rad.
        min_speed_m_s: seconds slower than this are left out.
        explained_m: per second, what a network on top of the WPM predicts (metres):
            the radii fit what it leaves (:func:`fit_radii_ratio_of_sums`). None: nothing.

    Returns:
        The fit, or None when no second moves fast enough.
    """
    d = np.asarray(disp_gnss_m, np.float64)
    try:
        return fit_radii_ratio_of_sums(
            d, angle_rl_rad, angle_rr_rad, np.ones_like(d), min_speed_m_s, explained_m
        )
    except ValueError:
        return None


def refit_radii(
    disp_gnss_m: np.ndarray,
    angle_rl_rad: np.ndarray,
    angle_rr_rad: np.ndarray,
    min_speed_m_s: float,
    explained_m: np.ndarray | None = None,
) -> tuple[float, float] | None:
    """Rear radii refitted on a stretch of one drive: the one-parameter control of R-WhONet.

    :func:`refit`'s radii alone (the same arguments).

    Returns:
        ``(r_rl_m, r_rr_m)``, or None when no second moves fast enough.
    """
    fit = refit(disp_gnss_m, angle_rl_rad, angle_rr_rad, min_speed_m_s, explained_m)
    return None if fit is None else (fit.r_rl_m, fit.r_rr_m)


def fit_radii_mean_of_ratios(
    disp_gnss_m: np.ndarray,
    omega_rl_rad_s: np.ndarray,
    omega_rr_rad_s: np.ndarray,
    step_s: float = 1.0,
) -> RadiusFit:
    """Fit the rear radii the authors' way: the mean of per-second distance / (speed * step).

    Kept to show why it is not used: at standstill it divides by zero and
    returns inf or NaN, and slow seconds bias it upwards (module docstring).

    Args:
        disp_gnss_m: GNSS displacement per second, metres.
        omega_rl_rad_s: rear-left wheel speed sampled once per second, rad/s.
        omega_rr_rad_s: rear-right wheel speed sampled once per second, rad/s.
        step_s: time step the sample is multiplied by (the authors use 1 s).

    Returns:
        The radii (possibly inf/NaN), with every second counted.
    """
    d = np.asarray(disp_gnss_m, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        r_rl = np.mean(d / (np.asarray(omega_rl_rad_s, np.float64) * step_s))
        r_rr = np.mean(d / (np.asarray(omega_rr_rad_s, np.float64) * step_s))
    return RadiusFit(float(r_rl), float(r_rr), "mean_of_ratios", len(d), float(d.sum()))


@dataclass(frozen=True)
class Calibration:
    """What ``calibration.json`` holds: the radii the WPM uses and how they were fitted.

    Attributes:
        r_rl_m: rear-left effective rolling radius, m/rad.
        r_rr_m: rear-right effective rolling radius, m/rad.
        estimator: the estimator that produced them (``ratio_of_sums``).
        min_speed_m_s: the moving-second threshold.
        n_seconds_used: seconds in the fit.
        n_seconds_total: seconds of the calibration segments.
        distance_m: GNSS distance of the seconds used, metres.
        role: role of the calibration drives: ``source_calibration``, or the
            fallback ``source_train``.
        drives: calibration drive ids.
        segments: calibration segment ids.
        comparison: other estimators' radii on the same data (JSON null where undefined).
    """

    r_rl_m: float
    r_rr_m: float
    estimator: str
    min_speed_m_s: float
    n_seconds_used: int
    n_seconds_total: int
    distance_m: float
    role: str
    drives: list[str]
    segments: list[str]
    comparison: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return plain JSON-ready data (``unit`` added for the reader)."""
        return {"unit": "m/rad", **asdict(self)}


def fit_summary(fit: RadiusFit) -> dict[str, Any]:
    """Return a fit as JSON-ready data, with ``None`` for undefined radii.

    Args:
        fit: a radius fit.

    Returns:
        ``{"r_rl_m", "r_rr_m", "n_seconds", "distance_m"}``.
    """

    def num(x: float) -> float | None:
        return x if math.isfinite(x) else None

    return {
        "r_rl_m": num(fit.r_rl_m),
        "r_rr_m": num(fit.r_rr_m),
        "n_seconds": fit.n_seconds,
        "distance_m": fit.distance_m,
    }


def calibration_from_dict(raw: Any, source: str) -> Calibration:
    """Rebuild a :class:`Calibration` from what :meth:`Calibration.to_dict` gave.

    Args:
        raw: the parsed ``calibration.json`` (anything but an object has no fields).
        source: where it came from, for error reports.

    Returns:
        The calibration.

    Raises:
        InputError: when a field is missing or a radius is not a positive number.
    """
    raw = raw if isinstance(raw, dict) else {}
    names = [f for f in Calibration.__dataclass_fields__ if f != "comparison"]
    problems = [
        Problem(source, None, name, "a calibration field", "missing")
        for name in names
        if name not in raw
    ]
    for name in ("r_rl_m", "r_rr_m"):
        value = raw.get(name)
        if name in raw and not (isinstance(value, int | float) and value > 0):
            problems.append(Problem(source, None, name, "a positive radius in m/rad", repr(value)))
    if problems:
        raise InputError(problems, f"{source} is not a valid calibration file")
    return Calibration(**{k: raw[k] for k in names}, comparison=raw.get("comparison", {}))
