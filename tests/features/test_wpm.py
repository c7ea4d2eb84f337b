"""The WPM (paper Eqs. 6-10) and the label (Eq. 11, GNSS - WPM) on drives with known truth."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.features.seconds import segment_seconds
from rwhonet.features.wpm import (
    label_m,
    radius_corrected,
    wheel_angle_rad,
    wpm_displacement_m,
)
from support.synthetic import (
    R_RL_M,
    R_RR_M,
    build_drive,
    constant_acceleration,
    constant_speed,
    wavy_speed,
)


def labels(frame, r_rl_m=R_RL_M, r_rr_m=R_RR_M, mode="integrated"):
    """Return (label_m, disp_gnss_m, disp_wpm_m) per second of a segment."""
    sec = segment_seconds(frame, "synthetic")
    wpm = wpm_displacement_m(
        wheel_angle_rad(sec.angle_rl_rad, sec.omega_end_rl_rad_s, mode),
        wheel_angle_rad(sec.angle_rr_rad, sec.omega_end_rr_rad_s, mode),
        r_rl_m,
        r_rr_m,
    )
    return label_m(sec.disp_gnss_m, wpm), sec.disp_gnss_m, wpm


def test_zero_slip_true_radius_noise_free_gnss_leaves_only_the_integration_error():
    profile = wavy_speed(60, 12.0, 4.0, 7.0)
    y, _, _ = labels(build_drive(profile))
    assert np.abs(y).max() < 3e-3
    # That residual is the trapezoid's leading error term: -h^2/12 times the change
    # of acceleration over the second (Euler-Maclaurin), h = 0.1 s.
    t, _, v = profile
    acc = np.gradient(v, t, edge_order=2)
    predicted = -(0.1**2) / 12 * np.diff(acc[::10])
    np.testing.assert_allclose(y, predicted, rtol=0, atol=2e-5)


def test_zero_slip_true_radius_white_gnss_noise_gives_zero_mean_noise_labels():
    sigma_m = 0.3
    y, _, _ = labels(build_drive(constant_speed(2000, 15.0), gnss_sigma_m=sigma_m, seed=1))
    # Each label is the along-track difference of two independent fix errors, so
    # it has mean ~0 (the sum telescopes; the distance's rectification adds only
    # ~sigma^2 / d = 6 mm), std sqrt(2) sigma and lag-1 autocorrelation -1/2.
    assert abs(y.mean()) < 0.015
    assert y.std() == pytest.approx(np.sqrt(2) * sigma_m, rel=0.06)
    assert np.corrcoef(y[1:], y[:-1])[0, 1] == pytest.approx(-0.5, abs=0.06)


@pytest.mark.parametrize(("radius_factor", "expected_fraction"), [(0.98, +0.02), (1.02, -0.02)])
def test_radius_error_sign(radius_factor, expected_fraction):
    """A radius 2 % too small makes WPM under-read: label = +2 % of the distance (GNSS - WPM).

    The "-2 %" of the same situation is Eq. 11's WPM - GNSS sign; with the sign the
    code and tables use, -2 % belongs to a radius 2 % too large (WPM over-reads).
    """
    y, gnss, wpm = labels(
        build_drive(constant_speed(100, 15.0)),
        r_rl_m=radius_factor * R_RL_M,
        r_rr_m=radius_factor * R_RR_M,
    )
    np.testing.assert_allclose(y / gnss, expected_fraction, rtol=0, atol=1e-9)
    paper_eq11_sign = wpm - gnss
    np.testing.assert_allclose(paper_eq11_sign / gnss, -expected_fraction, rtol=0, atol=1e-9)


def test_reference_and_integrated_modes_agree_at_constant_speed():
    frame = build_drive(constant_speed(60, 13.0))
    y_int, _, wpm_int = labels(frame, mode="integrated")
    y_ref, _, wpm_ref = labels(frame, mode="reference")
    np.testing.assert_allclose(wpm_ref, wpm_int, rtol=1e-12)
    np.testing.assert_allclose(y_int, 0.0, atol=1e-6)


def test_under_acceleration_reference_mode_overshoots_by_half_the_acceleration():
    a_m_s2 = 2.0
    frame = build_drive(constant_acceleration(10, 5.0, a_m_s2))
    y_int, _, wpm_int = labels(frame, mode="integrated")
    y_ref, _, wpm_ref = labels(frame, mode="reference")
    # The end-of-second sample is v(t) = v(t-1) + a; the second's distance is v(t-1) + a/2.
    np.testing.assert_allclose(wpm_ref - wpm_int, a_m_s2 / 2, rtol=0, atol=1e-9)
    np.testing.assert_allclose(y_int, 0.0, atol=1e-6)  # trapezoid: exact for linear speed
    np.testing.assert_allclose(y_ref, -a_m_s2 / 2, atol=1e-6)


def test_rear_axle_averages_the_two_wheels_rolled_distances():
    # Eq. 6 averages the rear wheels; with a radius per wheel the distances are averaged.
    out = wpm_displacement_m(np.array([10.0]), np.array([20.0]), 0.3, 0.25)
    assert out[0] == pytest.approx((10.0 * 0.3 + 20.0 * 0.25) / 2)
    assert label_m(np.array([5.0]), out)[0] == pytest.approx(5.0 - 4.0)


def test_unknown_mode_is_an_error():
    with pytest.raises(ValueError, match="wpm mode"):
        wheel_angle_rad(np.ones(2), np.ones(2), "simpson")


def test_radius_corrected_adds_the_difference_of_the_two_wpms():
    rng = np.random.default_rng(3)
    pred, a_rl, a_rr = rng.normal(size=50), rng.uniform(0, 40, 50), rng.uniform(0, 40, 50)
    own, source = (0.301, 0.297), (0.294, 0.2945)
    # the formula every caller had written out: pred + WPM(own) - WPM(source), in that order
    old = pred.copy()
    old += wpm_displacement_m(a_rl, a_rr, *own)
    old -= wpm_displacement_m(a_rl, a_rr, *source)
    assert np.array_equal(radius_corrected(pred, a_rl, a_rr, own, source), old)
    # what it means: the source WPM plus the restated label is the own WPM plus the prediction
    np.testing.assert_allclose(
        wpm_displacement_m(a_rl, a_rr, *source) + radius_corrected(pred, a_rl, a_rr, own, source),
        wpm_displacement_m(a_rl, a_rr, *own) + pred,
        rtol=0,
        atol=1e-12,
    )
