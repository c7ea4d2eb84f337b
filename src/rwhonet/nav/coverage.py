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
    error: np.ndarray, cov: np.ndarray, probs: tuple[float, ...] = SIGMA_CONTENT
) -> dict[float, float]:
    """Share of windows whose 2D error lies inside the predicted ellipse of each content.

    Args:
        error: (W, 2) error vectors (estimate − truth), m.
        cov: (W, 2, 2) predicted covariances, m².
        probs: probability contents of the ellipses (default: those of ±1σ, ±2σ).

    Returns:
        ``{p: share}``; NaN shares when there are no windows.
    """
    d2 = mahalanobis_sq(error, cov)
    return {
        float(p): float(np.mean(d2 <= chi2_2dof_quantile(p))) if d2.size else float("nan")
        for p in probs
    }


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


def nll_2d(error: np.ndarray, cov: np.ndarray) -> float:
    """Mean negative log-likelihood of 2D errors under their predicted normals, nats.

    ``½ (eᵀ Σ⁻¹ e + ln det Σ) + ln 2π`` per window, averaged.
    """
    c = np.asarray(cov, np.float64)
    _, logdet = np.linalg.slogdet(c)
    return float(np.mean(0.5 * (mahalanobis_sq(error, c) + logdet) + np.log(2.0 * np.pi)))


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
