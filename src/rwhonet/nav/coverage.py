"""Is the predicted uncertainty honest? Coverage and likelihood of predicted errors.

The issue's target "inside the predicted 1σ and 2σ: 68 ± 5 % and 95 ± 3 %" reads
as the probability content of ±1σ and ±2σ of a normal distribution, 68.27 %
and 95.45 %. For a scalar error (a window's CTE, its CRSE less the predicted
mean) that is ``|e| ≤ kσ`` (:func:`coverage_1d`). For a 2D position error the
same contents are the ellipses of the predicted covariance ``Σ`` whose
squared Mahalanobis radius ``eᵀ Σ⁻¹ e`` is at most the χ²(2) quantile
``−2 ln(1 − p)``: 2.296 for 68.27 % and 6.180 for 95.45 %
(:func:`coverage_2d`, ``probs=SIGMA_CONTENT``). The "1σ ellipse" in the strict
sense (Mahalanobis radius 1, resp. 2) holds only 39.35 % and 86.47 % of a 2D
normal; :data:`ELLIPSE_CONTENT` gives those to check against instead.

A filter's covariance is a normal's; the errors it predicts are not quite (a
window with reversing, a tyre that changes during the outage: heavy tails). The
evaluation calibrates it on training windows as a bivariate Student t with the
filter's covariance times a scale ``c`` as its scale matrix and ``ν`` degrees of
freedom (:func:`fit_t2`): the squared Mahalanobis radius holding ``p`` is then
``c ν ((1 − p)^(−2/ν) − 1)`` (:func:`t2_quantile`), which tends to the χ²(2)
quantile times ``c`` as ``ν → ∞``; ``c = 1, ν = ∞`` is the filter's own normal.
"""

from __future__ import annotations

import numpy as np

# Probability within ±1σ and ±2σ of a normal: erf(k / sqrt(2)).
SIGMA_CONTENT: tuple[float, float] = (0.6826894921370859, 0.9544997361036416)
# Probability inside the 2D ellipses of Mahalanobis radius 1 and 2: 1 − exp(−k² / 2).
ELLIPSE_CONTENT: tuple[float, float] = (1.0 - np.exp(-0.5), 1.0 - np.exp(-2.0))


def chi2_2dof_quantile(p: float | np.ndarray) -> np.ndarray:
    """The quantile of χ² with two degrees of freedom: ``−2 ln(1 − p)``.

    Args:
        p: probability in [0, 1).

    Returns:
        The squared Mahalanobis radius holding ``p`` of a 2D normal.
    """
    return -2.0 * np.log1p(-np.asarray(p, np.float64))


def mahalanobis_sq(error: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``eᵀ Σ⁻¹ e`` per window.

    Args:
        error: (W, 2) error vectors.
        cov: (W, 2, 2) predicted covariances.

    Returns:
        (W,) squared Mahalanobis distances.
    """
    e = np.asarray(error, np.float64)
    return np.einsum(
        "wi,wi->w", e, np.linalg.solve(np.asarray(cov, np.float64), e[..., None])[..., 0]
    )


def coverage_2d(
    error: np.ndarray,
    cov: np.ndarray,
    probs: tuple[float, ...] = SIGMA_CONTENT,
    scale: float = 1.0,
    dof: float = np.inf,
) -> dict[float, float]:
    """Share of windows whose 2D error lies inside the predicted ellipse of each content.

    Args:
        error: (W, 2) error vectors (estimate − truth), m.
        cov: (W, 2, 2) predicted covariances, m².
        probs: probability contents of the ellipses (default: those of ±1σ, ±2σ).
        scale: ``c``, the calibration's scale of the covariance (:func:`fit_t2`).
        dof: ``ν``, its degrees of freedom (``inf``: the normal).

    Returns:
        ``{p: share}``; NaN shares when there are no windows.
    """
    d2 = mahalanobis_sq(error, cov)
    return {
        float(p): float(np.mean(d2 <= t2_quantile(p, scale, dof))) if d2.size else float("nan")
        for p in probs
    }


def t2_quantile(
    p: float | np.ndarray, scale: float = 1.0, dof: float | np.ndarray = np.inf
) -> np.ndarray:
    """The squared Mahalanobis radius (in the filter's covariance) holding ``p``.

    For the bivariate t with scale matrix ``c Σ`` and ``ν`` degrees of freedom,
    ``d² / c`` has the distribution function ``1 − (1 + r / ν)^(−ν / 2)`` (half of it
    follows F(2, ν)); its quantile is ``ν ((1 − p)^(−2/ν) − 1)``, the χ²(2) one as
    ``ν → ∞``.

    Args:
        p: probability in [0, 1).
        scale: ``c``.
        dof: ``ν`` (``inf``: the normal), or one per element (broadcast with ``p``).
    """
    p = np.asarray(p, np.float64)
    nu = np.asarray(dof, np.float64)
    if not np.isfinite(nu).any():
        return scale * chi2_2dof_quantile(p)
    finite = np.where(np.isfinite(nu), nu, 1.0)
    t = finite * np.expm1(-2.0 / finite * np.log1p(-p))
    return scale * np.where(np.isfinite(nu), t, chi2_2dof_quantile(p))


def t2_nll(d2: np.ndarray, logdet: np.ndarray, scale: float = 1.0, dof: float = np.inf):
    """Each window's negative log-likelihood under the bivariate t, nats.

    ``ln 2π + ln c + ½ ln det Σ + (ν/2 + 1) ln(1 + d² / (c ν))``; the normal's
    ``ln 2π + ln c + ½ ln det Σ + d² / (2c)`` for ``ν = ∞``.

    Args:
        d2: (W,) squared Mahalanobis radii in the filter's covariance ``Σ``.
        logdet: (W,) ``ln det Σ``.
        scale: ``c``.
        dof: ``ν``.
    """
    d2 = np.asarray(d2, np.float64)
    base = np.log(2.0 * np.pi) + np.log(scale) + 0.5 * np.asarray(logdet, np.float64)
    if not np.isfinite(dof):
        return base + 0.5 * d2 / scale
    return base + (0.5 * dof + 1.0) * np.log1p(d2 / (scale * dof))


MIN_T2_WINDOWS = 20  # fewer training windows: no calibration (the filter's normal)
T2_DOF_BOUNDS = (1.0, 1000.0)  # ν: a finite mean radius at the low end; normal at the top


def _radius_nll(r: np.ndarray, c: float, nu: float) -> float:
    """:func:`t2_nll`'s mean without its terms that depend on neither ``c`` nor ``ν``
    (``ln 2π``, ``½ ln det Σ``): what the fits below minimise."""
    return float(np.mean(np.log(c) + (0.5 * nu + 1.0) * np.log1p(r / (c * nu))))


def t2_radius_nll(d2: np.ndarray, scale: float, dof: float) -> float:
    """Mean negative log-likelihood of squared radii under the bivariate t (``c``, ``ν``),
    less the terms no calibration changes (``ln 2π``, ``½ ln det Σ``), nats.

    What :func:`fit_t2` and :func:`fit_t2_scale` minimise, so two calibrations of the
    same windows compare by it (``ν = ∞``: the normal's ``ln c + d² / 2c``). Non-finite
    radii are left out, as the fits leave them.
    """
    r = np.asarray(d2, np.float64)
    r = np.maximum(r[np.isfinite(r)], 1e-12)
    if not np.isfinite(dof):
        return float(np.mean(np.log(scale) + 0.5 * r / scale))
    return _radius_nll(r, scale, dof)


def fit_t2(d2: np.ndarray, min_windows: int = MIN_T2_WINDOWS) -> tuple[float, float, int]:
    """``c`` and ``ν`` of the bivariate t that fits squared Mahalanobis radii best.

    Maximum likelihood over the windows' ``d²`` in the filter's covariance (the
    ``ln det Σ`` terms do not depend on ``c`` or ``ν``), over ``ln c`` and ``ln ν``
    within :data:`T2_DOF_BOUNDS` (L-BFGS-B). Fewer than ``min_windows`` finite
    radii: ``(1, inf)``, the filter's own normal.

    Args:
        d2: (W,) squared Mahalanobis radii of training windows.
        min_windows: the fewest windows to fit on.

    Returns:
        ``(c, ν, n)``: scale, degrees of freedom (``inf`` when not fitted or at the
        upper bound) and the windows fitted on.
    """
    r = np.asarray(d2, np.float64)
    r = r[np.isfinite(r)]
    if len(r) < min_windows:
        return 1.0, float("inf"), int(len(r))
    r = np.maximum(r, 1e-12)

    def nll(theta: np.ndarray) -> float:
        c, nu = np.exp(theta)
        return _radius_nll(r, c, nu)

    lo, hi = np.log(T2_DOF_BOUNDS)
    start = np.array([np.log(max(np.mean(r) / 2.0, 1e-9)), np.log(10.0)])
    from scipy.optimize import minimize  # here: rwhonet predict imports nav, never fits

    res = minimize(nll, start, method="L-BFGS-B", bounds=[(-30.0, 30.0), (lo, hi)])
    c, nu = np.exp(res.x)
    if res.x[1] >= hi - 1e-6:  # as heavy-tailed as a normal: take the normal's scale
        return float(np.mean(r) / 2.0), float("inf"), int(len(r))
    return float(c), float(nu), int(len(r))


def fit_t2_scale(d2: np.ndarray, dof: float, min_windows: int = MIN_T2_WINDOWS) -> float | None:
    """``c`` of the bivariate t with ``ν`` given that fits squared Mahalanobis radii best.

    Maximum likelihood over ``ln c`` alone (one outage length's windows, the tails
    taken from a fit over every length, :func:`fit_t2`); a normal (``ν = ∞``):
    ``mean(d²) / 2``. Fewer than ``min_windows`` finite radii: None.
    """
    r = np.asarray(d2, np.float64)
    r = np.maximum(r[np.isfinite(r)], 1e-12)
    if len(r) < min_windows:
        return None
    if not np.isfinite(dof):
        return float(np.mean(r) / 2.0)

    def nll(theta: np.ndarray) -> float:
        return _radius_nll(r, np.exp(theta[0]), dof)

    start = np.array([np.log(max(np.mean(r) / 2.0, 1e-9))])
    from scipy.optimize import minimize

    res = minimize(nll, start, method="L-BFGS-B", bounds=[(-30.0, 30.0)])
    return float(np.exp(res.x[0]))


def coverage_1d(error: np.ndarray, sd: np.ndarray, ks: tuple[float, ...] = (1.0, 2.0)) -> dict:
    """Share of windows whose scalar error lies within ``k`` predicted standard deviations.

    Args:
        error: (W,) errors.
        sd: (W,) predicted standard deviations.
        ks: the multiples.

    Returns:
        ``{k: share}``; NaN shares when there are no windows.
    """
    e = np.abs(np.asarray(error, np.float64))
    s = np.asarray(sd, np.float64)
    return {float(k): float(np.mean(e <= k * s)) if e.size else float("nan") for k in ks}


def nll_2d(error: np.ndarray, cov: np.ndarray, scale: float = 1.0, dof: float = np.inf) -> float:
    """Mean negative log-likelihood of 2D errors under their predicted distributions, nats.

    ``½ (eᵀ Σ⁻¹ e + ln det Σ) + ln 2π`` per window, averaged, for the filter's normal;
    with a calibration (``scale``, ``dof``) the bivariate t's (:func:`t2_nll`).
    """
    c = np.asarray(cov, np.float64)
    _, logdet = np.linalg.slogdet(c)
    return float(np.mean(t2_nll(mahalanobis_sq(error, c), logdet, scale, dof)))


def crse_prediction(sd_per_second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of a window's CRSE predicted from per-second spreads.

    CRSE is ``Σ_t |e_t|`` (paper Eq. 16). With independent ``e_t ~ N(0, σ_t²)``
    each ``|e_t|`` is half-normal: mean ``σ_t sqrt(2/π)``, variance
    ``σ_t² (1 − 2/π)``; the sums follow.

    Args:
        sd_per_second: (W, L) predicted standard deviation of each second's
            distance error, m.

    Returns:
        ``(mean, sd)``, each (W,), m.
    """
    s = np.asarray(sd_per_second, np.float64)
    mean = np.sqrt(2.0 / np.pi) * s.sum(axis=-1)
    sd = np.sqrt((1.0 - 2.0 / np.pi) * (s * s).sum(axis=-1))
    return mean, sd


def crse_coverage(
    crse_m: np.ndarray, sd_per_second: np.ndarray, ks: tuple[float, ...] = (1.0, 2.0)
) -> dict[float, float]:
    """Share of windows whose CRSE lies within ``k`` predicted sd of its predicted mean.

    Args:
        crse_m: (W,) each window's CRSE, m.
        sd_per_second: (W, L) the predicted sd of each of its seconds' errors, m.
        ks: the multiples.

    Returns:
        ``{k: share}`` (:func:`crse_prediction` gives the mean and sd).
    """
    mean, sd = crse_prediction(sd_per_second)
    return coverage_1d(np.asarray(crse_m, np.float64) - mean, sd, ks)
