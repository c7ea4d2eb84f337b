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
    mahalanobis_sq,
    nll_2d,
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
