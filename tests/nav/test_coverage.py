"""Coverage of predicted uncertainty: hand-computed cases and the normal distribution's contents."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.nav import (
    ELLIPSE_CONTENT,
    SIGMA_CONTENT,
    coverage_1d,
    coverage_2d,
    crse_coverage,
    crse_prediction,
    fit_t2,
    fit_t2_scale,
    mahalanobis_sq,
    nll_2d,
    t2_quantile,
    t2_radius_nll,
)
from rwhonet.nav.coverage import chi2_2dof_quantile


def test_the_contents_of_one_and_two_sigma():
    assert SIGMA_CONTENT == pytest.approx((0.682689, 0.954500), abs=1e-6)
    assert ELLIPSE_CONTENT == pytest.approx((0.393469, 0.864665), abs=1e-6)
    # the ellipses holding 68.27 % and 95.45 % of a 2D normal, and those of radius 1 and 2
    assert chi2_2dof_quantile(np.array(SIGMA_CONTENT)) == pytest.approx([2.2957, 6.1801], abs=1e-4)
    assert chi2_2dof_quantile(np.array(ELLIPSE_CONTENT)) == pytest.approx([1.0, 4.0])


def test_coverage_of_a_hand_computed_case():
    # Four windows. Predicted covariances: the unit circle for the first three, an ellipse
    # 2 m east by 0.5 m north for the fourth. Squared Mahalanobis distances by hand:
    #   (1, 0) / I          -> 1.00   inside 68.27 % (<= 2.2957) and 95.45 % (<= 6.1801)
    #   (0, 1.6) / I        -> 2.56   outside 68.27 %, inside 95.45 %
    #   (2, 2) / I          -> 8.00   outside both
    #   (2, 0.5) / diag(4, 0.25) -> 1 + 1 = 2.00   inside both
    error = np.array([[1.0, 0.0], [0.0, 1.6], [2.0, 2.0], [2.0, 0.5]])
    cov = np.array([np.eye(2), np.eye(2), np.eye(2), np.diag([4.0, 0.25])])
    assert mahalanobis_sq(error, cov) == pytest.approx([1.0, 2.56, 8.0, 2.0])
    assert coverage_2d(error, cov) == {SIGMA_CONTENT[0]: 0.5, SIGMA_CONTENT[1]: 0.75}
    # the strict ellipses of Mahalanobis radius 1 and 2 (contents 39.3 % and 86.5 %)
    strict = coverage_2d(error, cov, ELLIPSE_CONTENT)
    assert list(strict.values()) == [0.25, 0.75]
    # scalar errors: |e| <= k sd
    assert coverage_1d([0.5, -1.5, 2.5, -0.9], [1.0, 1.0, 1.0, 1.0]) == {1.0: 0.5, 2.0: 0.75}
    # negative log-likelihood of the first window alone: 0.5 (1 + ln 1) + ln 2 pi
    assert nll_2d(error[:1], cov[:1]) == pytest.approx(0.5 + np.log(2 * np.pi))


def test_coverage_of_normal_errors_matches_the_contents():
    rng = np.random.default_rng(0)
    w = 20000
    a = rng.normal(size=(w, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(2)
    error = np.einsum("wij,wj->wi", np.linalg.cholesky(cov), rng.normal(size=(w, 2)))
    got = coverage_2d(error, cov)
    for p in SIGMA_CONTENT:
        assert got[p] == pytest.approx(p, abs=0.01)
    sd = rng.uniform(0.5, 3.0, w)
    got1 = coverage_1d(rng.normal(size=w) * sd, sd)
    assert [got1[1.0], got1[2.0]] == pytest.approx(SIGMA_CONTENT, abs=0.01)
    # a covariance half as wide as the truth covers too little
    assert coverage_2d(error, cov / 4.0)[SIGMA_CONTENT[0]] < 0.4


def test_crse_of_independent_normal_seconds():
    # 180 seconds of N(0, 0.2^2) errors: CRSE = sum |e_t| has mean 180 * 0.2 * sqrt(2/pi)
    mean, sd = crse_prediction(np.full((1, 180), 0.2))
    assert mean[0] == pytest.approx(180 * 0.2 * np.sqrt(2 / np.pi))
    assert sd[0] == pytest.approx(np.sqrt(180 * 0.04 * (1 - 2 / np.pi)))
    rng = np.random.default_rng(1)
    sigma = rng.uniform(0.05, 0.5, (4000, 1)) * np.ones((1, 180))
    crse = np.abs(rng.normal(size=sigma.shape) * sigma).sum(axis=1)
    got = crse_coverage(crse, sigma)
    assert [got[1.0], got[2.0]] == pytest.approx(SIGMA_CONTENT, abs=0.02)


def _t2_errors(rng, n: int, scale: float, dof: float, cov: np.ndarray) -> np.ndarray:
    """Bivariate t errors with scale matrix ``scale * cov`` and ``dof`` degrees of freedom."""
    z = np.einsum("wij,wj->wi", np.linalg.cholesky(cov), rng.normal(size=(n, 2)))
    w = rng.chisquare(dof, n) / dof
    return np.sqrt(scale) * z / np.sqrt(w)[:, None]


def test_the_t_quantile_by_hand_and_its_normal_limit():
    # nu = 2: r = 2 ((1 - p)^-1 - 1); p = 0.5 -> 2, p = 0.75 -> 6; times c
    assert t2_quantile(0.5, 1.0, 2.0) == pytest.approx(2.0)
    assert t2_quantile(0.75, 3.0, 2.0) == pytest.approx(18.0)
    # nu -> inf: the chi-square(2) quantile; nu = inf is exactly it
    p = np.array(SIGMA_CONTENT)
    assert t2_quantile(p, 1.0, 1e7) == pytest.approx(chi2_2dof_quantile(p), rel=1e-5)
    assert t2_quantile(p, 2.0, np.inf) == pytest.approx(2.0 * chi2_2dof_quantile(p))
    # heavier tails hold the same content farther out
    assert t2_quantile(0.9545, 1.0, 3.0) > t2_quantile(0.9545, 1.0, 30.0) > 6.18


def test_fit_t2_recovers_scale_and_tails_and_its_coverage_matches_the_contents():
    rng = np.random.default_rng(1)
    n = 20000
    a = rng.normal(size=(n, 2, 2))
    cov = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(2)
    error = _t2_errors(rng, n, 2.5, 4.0, cov)
    c, nu, used = fit_t2(mahalanobis_sq(error, cov))
    assert used == n and c == pytest.approx(2.5, rel=0.05) and nu == pytest.approx(4.0, rel=0.1)
    got = coverage_2d(error, cov, scale=c, dof=nu)
    for p in SIGMA_CONTENT:
        assert got[p] == pytest.approx(p, abs=0.01)
    # the filter's own normal would cover too little at 2 sigma (heavy tails)
    assert coverage_2d(error, cov)[SIGMA_CONTENT[1]] < 0.9
    # and the t is the likelier description of these errors
    assert nll_2d(error, cov, c, nu) < nll_2d(error, cov, c, np.inf) < nll_2d(error, cov)


def test_fit_t2_of_normal_errors_is_a_normal_and_of_few_windows_no_calibration():
    rng = np.random.default_rng(2)
    n = 20000
    error = rng.normal(size=(n, 2)) * np.sqrt(0.5)
    c, nu, _ = fit_t2(mahalanobis_sq(error, np.broadcast_to(np.eye(2), (n, 2, 2))))
    assert c == pytest.approx(0.5, rel=0.05)
    assert nu == np.inf or nu > 100  # normal errors: no heavy tails found
    assert fit_t2(np.array([1.0, 2.0, np.nan]), min_windows=3) == (1.0, np.inf, 2)


def test_the_t_likelihood_by_hand():
    # d2 = 2, det = 1, c = 1, nu = 2: ln 2 pi + 2 ln(1 + 2 / 2) = ln 2 pi + 2 ln 2
    error, cov = np.array([[1.0, 1.0]]), np.eye(2)[None]
    assert nll_2d(error, cov, 1.0, 2.0) == pytest.approx(np.log(2 * np.pi) + 2 * np.log(2.0))
    # the normal with a scale c: ln 2 pi + ln c + d2 / (2c)
    assert nll_2d(error, cov, 2.0) == pytest.approx(np.log(2 * np.pi) + np.log(2.0) + 0.5)


def test_fit_t2_scale_with_the_tails_held_recovers_the_scale():
    rng = np.random.default_rng(11)
    n = 20000
    z = rng.normal(size=(n, 2)) * np.sqrt(2.5) / np.sqrt(rng.chisquare(4.0, n) / 4.0)[:, None]
    d2 = (z**2).sum(axis=1)
    assert fit_t2_scale(d2, 4.0) == pytest.approx(2.5, rel=0.05)
    # a normal: the mean radius over its two dimensions, in closed form
    assert fit_t2_scale(np.array([1.0, 3.0, 5.0]), np.inf, min_windows=3) == 1.5
    assert fit_t2_scale(np.array([1.0, np.nan]), 4.0, min_windows=2) is None


def test_t2_quantile_takes_one_dof_per_element_and_t2_radius_nll_the_normal():
    p = np.array([0.6827, 0.9545])
    got = t2_quantile(p, 2.0, np.array([5.0, np.inf]))
    np.testing.assert_allclose(got, [t2_quantile(p[0], 2.0, 5.0), 2.0 * chi2_2dof_quantile(p[1])])
    r = np.array([0.5, 2.0, np.nan])  # NaN left out, as the fits leave it
    assert t2_radius_nll(r, 2.0, np.inf) == pytest.approx(np.mean(np.log(2.0) + r[:2] / 4.0))
    assert t2_radius_nll(r, 2.0, 1e9) == pytest.approx(t2_radius_nll(r, 2.0, np.inf), rel=1e-6)
