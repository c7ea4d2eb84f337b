"""What a bundle carries of the evaluation's navigation filter; how predict sizes its regions."""

import numpy as np
import pytest

from rwhonet.nav import SIGMA_CONTENT, NavConfig, t2_quantile
from rwhonet.nav.coverage import chi2_2dof_quantile
from rwhonet.serve.navigation import PositionCalibration


def test_without_a_calibration_the_regions_are_the_filter_s_own_normal():
    cal = PositionCalibration.from_meta(None)
    assert not cal.calibrated and cal.nav_config(NavConfig()) == NavConfig()
    cov = np.array([[[4.0, 0.0], [0.0, 1.0]]])  # major axis east, 2 m
    for p in SIGMA_CONTENT:
        want = np.sqrt(4.0 * chi2_2dof_quantile(p))
        assert cal.semi_axis(cov, np.array([60.0]), p)[0] == pytest.approx(want)
    assert np.isnan(cal.semi_axis(np.full((1, 2, 2), np.nan), np.array([1.0]), 0.5))[0]


def test_the_scale_between_evaluated_lengths_is_interpolated_in_ln_l_and_held_outside():
    cal = PositionCalibration({30: 1.0, 120: 4.0})
    got = cal.scale_at(np.array([10.0, 30.0, 60.0, 120.0, 600.0]))
    np.testing.assert_allclose(got, [1.0, 1.0, 2.0, 4.0, 4.0])  # 60 s: halfway in ln L


def test_dof_between_evaluated_lengths_is_interpolated_as_1_over_nu_in_ln_l():
    cal = PositionCalibration.from_meta(
        {"calibration": {"scales": {"30": 1.0, "120": 1.0}, "dofs": {"30": 4.0, "120": None}}}
    )
    got = cal.dof_at(np.array([10.0, 30.0, 60.0, 120.0, 600.0]))
    np.testing.assert_allclose(got, [4.0, 4.0, 8.0, np.inf, np.inf])  # 60 s: 1/ν halfway
    cov = np.broadcast_to(np.eye(2), (2, 2, 2))
    r = cal.semi_axis(cov, np.array([30.0, 120.0]), SIGMA_CONTENT[1])
    np.testing.assert_allclose(
        r**2, [t2_quantile(SIGMA_CONTENT[1], 1.0, 4.0), chi2_2dof_quantile(SIGMA_CONTENT[1])]
    )
    # a bundle from before ν per length: one ν for every length
    old = PositionCalibration.from_meta({"calibration": {"scales": {"30": 1.0}, "dof": 6.0}})
    np.testing.assert_allclose(old.dof_at(np.array([5.0, 500.0])), [6.0, 6.0])


def test_a_calibrated_region_holds_its_content_of_t_distributed_ends():
    rng = np.random.default_rng(11)
    c, nu, n = 0.7, 6.0, 200_000
    cal = PositionCalibration.from_meta(
        {"calibration": {"scales": {"180": c}, "dof": nu}, "receiver_sigma_m": 2.7}
    )
    assert cal.calibrated and cal.dof == nu
    cov = np.broadcast_to(np.eye(2) * 9.0, (n, 2, 2))  # isotropic: the region is a circle
    z = rng.normal(size=(n, 2)) * np.sqrt(c * 9.0) / np.sqrt(rng.chisquare(nu, n) / nu)[:, None]
    for p in SIGMA_CONTENT:
        r = cal.semi_axis(cov[:1], np.array([180.0]), p)[0]
        assert r == pytest.approx(np.sqrt(9.0 * t2_quantile(p, c, nu)))
        assert np.mean(np.hypot(z[:, 0], z[:, 1]) <= r) == pytest.approx(p, abs=0.005)


def test_the_fitted_receiver_drift_goes_into_the_filter():
    cal = PositionCalibration.from_meta({"receiver_sigma_m": 2.7, "receiver_tau_s": 100.0})
    cfg = cal.nav_config(NavConfig())
    assert cfg.gnss.sigma_m == 2.7 and cfg.gnss.tau_s == 100.0
    assert cfg.gyro == NavConfig().gyro and cfg.gnss.white_m == NavConfig().gnss.white_m
    assert cfg.antenna_m == NavConfig().antenna_m


def test_the_fitted_antenna_and_gyro_figures_go_into_the_filter():
    cal = PositionCalibration.from_meta(
        {"antenna_m": [0.95, -0.2], "gyro_latency_s": 0.11, "gyro_instability_deg_s": 0.004}
    )
    cfg = cal.nav_config(NavConfig())
    assert cfg.antenna_m == (0.95, -0.2) and cfg.gyro.latency_s == 0.11
    assert cfg.gyro.bias_instability == pytest.approx(np.radians(0.004))
    # a bundle registered before the instability was fitted: the filter's own figure
    old = PositionCalibration.from_meta({"gyro_latency_s": 0.11}).nav_config(NavConfig())
    assert old.gyro.bias_instability == NavConfig().gyro.bias_instability
    assert cfg.gnss == NavConfig().gnss
    assert cfg.gyro.noise_density == NavConfig().gyro.noise_density


def _lasting(scales):
    return PositionCalibration.from_meta({"outage_scale": {str(k): v for k, v in scales.items()}})


def test_inside_an_outage_the_distance_variance_grows_as_the_evaluation_measured():
    rng = np.random.default_rng(3)
    var = rng.uniform(0.001, 0.01, 400)
    withheld = np.zeros(400, bool)
    withheld[50:230] = withheld[300:360] = True  # outages of 180 and 60 s
    # nothing carried: the seconds as they are
    same, _ = PositionCalibration().outage_variance(var, withheld)
    np.testing.assert_array_equal(same, var)
    # one factor for every length: each outage second's variance times it
    flat, _ = _lasting({30: 4.0, 180: 4.0}).outage_variance(var, withheld)
    np.testing.assert_allclose(flat[withheld], 4.0 * var[withheld])
    np.testing.assert_array_equal(flat[~withheld], var[~withheld])
    # growing with the length: t seconds into an outage, its summed variance is
    # gamma(t) times the seconds' own, the evaluation's for an outage of t s
    cal = _lasting({30: 8.0, 60: 9.0, 120: 15.0, 180: 18.0})
    grown, carried = cal.outage_variance(var, withheld)
    for start, end in ((50, 230), (300, 360)):
        t = np.arange(1, end - start + 1)
        np.testing.assert_allclose(
            np.cumsum(grown[start:end]), cal.outage_scale_at(t) * np.cumsum(var[start:end])
        )
    assert (grown > 0).all() and carried == (0, 0.0)
    # block by block as the stream goes, the same
    parts, state = [], (0, 0.0)
    # (a block of one second; a block that starts as an outage has just ended)
    for a, b in ((0, 100), (100, 229), (229, 230), (230, 330), (330, 400)):
        v, state = cal.outage_variance(var[a:b], withheld[a:b], state)
        parts.append(v)
    np.testing.assert_allclose(np.concatenate(parts), grown)
