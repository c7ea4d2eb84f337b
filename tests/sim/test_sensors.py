"""Sensor models: the GNSS receiver's error, CAN wheel speeds, the yaw-rate gyro, GNSS faults."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rwhonet.config import SimCan, SimGnss, SimGyro
from rwhonet.geo import geodesic_distance_m, offsets_m
from rwhonet.sim.sensors import (
    can_wheel_speeds,
    filtered_gauss_markov,
    gauss_markov,
    gnss_error_autocorrelation,
    gnss_increment_std_m,
    place_faults,
    sensor_warmup_k,
    yaw_rate_sensor,
)

# A gyro with every error off; each test switches on the one it checks.
PERFECT = SimGyro(
    bias_sigma_deg_s=0.0,
    instability_sigma_deg_s=0.0,
    instability_tau_s=300.0,
    temp_coeff_deg_s_k=0.0,
    warmup_k=0.0,
    warmup_tau_s=600.0,
    scale_error_pct=0.0,
    noise_density_deg_s_rthz=0.0,
    quantum_deg_s=0.0,
    latency_s=0.0,
)
T_TRUE = np.arange(0.0, 600.0 + 1e-9, 0.02)  # 50 Hz truth
T_REC = T_TRUE[::5]  # 10 Hz rows


def wandering_heading(t: np.ndarray) -> np.ndarray:
    """An unwrapped heading that turns both ways, several full turns (rad)."""
    return 0.3 * t / 10.0 + 2.0 * np.sin(t / 7.0) + 0.5 * np.sin(t / 1.3)


def autocorrelation(x: np.ndarray, lag: int) -> float:
    """Mean lag-``lag`` autocorrelation over the rows of ``x`` (known zero mean)."""
    return float((x[:, :-lag] * x[:, lag:]).mean() / (x * x).mean())


def test_gauss_markov_has_the_configured_sigma_and_correlation_time():
    sigma, tau, dt = 1.2, 60.0, 0.1
    x = gauss_markov(36_000, dt, sigma, tau, np.random.default_rng(0), rows=40)  # 40 h
    assert x.std() == pytest.approx(sigma, rel=0.03)
    assert x[:, 0].std() == pytest.approx(sigma, rel=0.25)  # stationary from the first sample
    for lag_s in (6.0, 30.0, 60.0, 120.0):
        expected = np.exp(-lag_s / tau)
        assert autocorrelation(x, int(lag_s / dt)) == pytest.approx(expected, abs=0.04)
    # The correlation time, fitted from the decay between lags of 10 and 60 s.
    r10, r60 = autocorrelation(x, 100), autocorrelation(x, 600)
    assert 50.0 / np.log(r10 / r60) == pytest.approx(tau, rel=0.15)


def test_filtered_gauss_markov_matches_its_analytic_statistics():
    # The receiver's error: a 120 s drift through a 15 s navigation filter, 40 h at 10 Hz.
    sigma, tau, filt, dt = 1.1, 120.0, 15.0, 0.1
    e, rate = filtered_gauss_markov(36_000, dt, sigma, tau, filt, np.random.default_rng(0), rows=40)
    assert e.std() == pytest.approx(sigma, rel=0.05)
    assert e[:, 0].std() == pytest.approx(sigma, rel=0.25)  # stationary from the first sample
    for lag_s in (1.0, 10.0, 30.0, 120.0):
        expected = float(gnss_error_autocorrelation(lag_s, tau, filt))
        assert autocorrelation(e, int(lag_s / dt)) == pytest.approx(expected, abs=0.04)
    # Smooth, not random-walk-like: the change over 1 s is what the analytic
    # formula says (~ sigma / sqrt(tau * filter) = 2.6 cm), and over 0.1 s ten
    # times less (a random walk would give sqrt(10) times less).
    gnss = SimGnss(sigma, tau, filt, 0.0, 1.5, 0.0, [8, 13], 3.0, 2.0)
    d1 = (e[:, 10:] - e[:, :-10]).std()
    assert d1 == pytest.approx(gnss_increment_std_m(gnss, 1.0), rel=0.05)
    assert d1 == pytest.approx(sigma / np.sqrt(tau * filt), rel=0.05)
    assert d1 / (e[:, 1:] - e[:, :-1]).std() == pytest.approx(10.0, rel=0.05)
    # The rate the filter reports (the receiver's velocity error) is the path's derivative.
    slope = (e[:, 1:] - e[:, :-1]) / dt
    assert np.std(slope - rate[:, 1:]) < 0.01 * rate.std()


def test_gnss_autocorrelation_is_one_at_zero_and_flat_there():
    for tau, filt in ((120.0, 15.0), (60.0, 60.0)):
        rho = gnss_error_autocorrelation(np.array([0.0, 1e-3, 1.0, 1e4]), tau, filt)
        assert rho[0] == pytest.approx(1.0)
        assert 1.0 - rho[1] < 1e-7  # zero slope at lag 0: a differentiable path
        assert 0.0 < rho[3] < 1e-10 and rho[2] < 1.0


def test_can_wheel_speed_is_late_noisy_and_quantised():
    t_true = np.arange(0.0, 20.0, 0.02)
    omega = np.vstack([np.linspace(0.0, 50.0, t_true.size)] * 4)  # constant angular acceleration
    t_rec = np.arange(0.0, 19.9, 0.1)
    can = SimCan(quantum_rad_s=0.01, noise_rad_s=0.0, latency_s=0.1, min_speed_rad_s=0.5)
    got = can_wheel_speeds(t_rec, t_true, omega, can, np.random.default_rng(0))
    np.testing.assert_allclose(got * 100, np.round(got * 100), atol=1e-9)  # 0.01 rad/s steps
    expected = np.interp(np.maximum(t_rec - 0.1, 0.0), t_true, omega[0])
    moving = expected >= 0.5
    np.testing.assert_allclose(got[0, moving], expected[moving], atol=0.005 + 1e-9)
    assert np.all(got[:, ~moving] == 0.0)  # dead band: too few pulses at crawl speed
    noisy = SimCan(quantum_rad_s=0.01, noise_rad_s=0.05, latency_s=0.1, min_speed_rad_s=0.5)
    got = can_wheel_speeds(t_rec, t_true, omega, noisy, np.random.default_rng(1))
    assert np.std(got[:, moving] - expected[moving]) == pytest.approx(0.05, rel=0.2)


def test_faults_avoid_each_other_the_ends_and_freeze_only_while_moving():
    hz = 10
    speed = np.where((np.arange(6000) // 600) % 2 == 0, 0.0, 12.0)  # 60 s stopped, 60 s moving
    faults = place_faults(
        ["frozen", "gap", "jump", "low_sats"], speed, hz, np.random.default_rng(0)
    )
    assert sorted(f.kind for f in faults) == ["frozen", "gap", "jump", "low_sats"]
    for f in faults:
        assert f.i0 >= 30 * hz and f.i1 <= speed.size - 30 * hz
    for a, b in zip(faults, faults[1:], strict=False):
        assert b.i0 - a.i1 >= 30 * hz
    frozen = next(f for f in faults if f.kind == "frozen")
    assert np.all(speed[frozen.i0 : frozen.i1] > 3.0)
    with pytest.raises(ValueError, match="unknown GNSS fault"):
        place_faults(["solar_flare"], speed, hz, np.random.default_rng(0))


def test_drive_faults_are_what_validate_must_cut(urban_drive, params):
    frame, scenarios, truth, state = urban_drive
    policy = params.validate.gnss
    t = frame[" Time"].to_numpy()
    lat, lon = frame[" Lat"].to_numpy(), frame[" Long"].to_numpy()
    sats = frame["Sats"].to_numpy()
    wheels = frame[[c for c in frame.columns if "Wheel Speed" in c]].to_numpy()
    windows = {f["kind"]: (f["start_s"], f["end_s"]) for f in truth["gnss_faults"]}
    assert set(windows) == {"low_sats", "frozen", "jump", "gap"}

    def inside(kind, times, pad=0.15):
        a, b = windows[kind]
        return (times >= a - pad) & (times <= b + pad)

    # gap: the only time steps longer than max_gap_s
    dt = np.diff(t)
    big = dt > policy.max_gap_s
    assert big.sum() == 1 and inside("gap", t[1:][big]).all()
    # low_sats: the only rows below min_sats
    few = sats < policy.min_sats
    assert few.any() and np.array_equal(few, inside("low_sats", t, pad=0.0))
    # jump: fix-to-fix speeds above max_speed_m_s. Only inside degraded stretches
    # (a 3 m noisy fix with few satellites, the catch-up after a frozen fix, the jump).
    speed = geodesic_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:]) / dt
    fast = t[1:][(speed > policy.max_speed_m_s) & ~big]
    assert inside("jump", fast).sum() >= 2  # away and back
    assert (inside("jump", fast) | inside("low_sats", fast) | inside("frozen", fast)).all()
    # frozen: the only run of identical fixes >= frozen_min_s while the wheels turn
    same = (np.diff(lat) == 0) & (np.diff(lon) == 0) & (wheels[1:].max(axis=1) > 1.0)
    frozen_rows = t[1:][same]
    assert frozen_rows.size >= policy.frozen_min_s * 10
    assert inside("frozen", frozen_rows).all()
    tags = {i["tag"] for i in scenarios["intervals"]}
    assert {"gnss_low_sats", "gnss_frozen", "gnss_jump", "gnss_gap"} <= tags


def test_gnss_error_statistics_in_a_drive(urban_drive, params, source):
    frame, _, truth, state = urban_drive
    gnss = source.params.gnss
    keep = np.ones(state.record_index.size, dtype=bool)
    for f in state.faults:
        keep[f.i0 : f.i1] = False
    e, n = offsets_m(
        params.sim.start_lat_deg, params.sim.start_lon_deg, frame[" Lat"], frame[" Long"]
    )
    gap = next(f for f in state.faults if f.kind == "gap")
    rows = np.delete(np.arange(state.record_index.size), np.arange(gap.i0, gap.i1))
    ok = keep[rows]
    idx = state.record_index[rows][ok]
    err = np.stack([e[ok] - state.antenna_east_m[idx], n[ok] - state.antenna_north_m[idx]])
    # 10 minutes is a few correlation times, so only a loose check of the size...
    assert 0.3 * gnss.sigma_m < err.std() < 2.0 * gnss.sigma_m
    # ...and of the time correlation: 1 s apart, errors are almost the same.
    err = err - err.mean(axis=1, keepdims=True)
    assert autocorrelation(err, 10) > 0.99


def test_a_stationary_gyro_averages_to_its_bias_plus_the_temperature_term(params):
    # The fiesta's sensor, with a strong temperature coefficient so that the warm-up shows.
    gyro = dataclasses.replace(params.sim.vehicles["fiesta"].gyro, temp_coeff_deg_s_k=0.02)
    t_true = np.arange(0.0, 7200.0 + 1e-9, 0.02)
    t_rec = t_true[::5]
    still = np.full(t_true.size, 0.7)  # parked, any heading
    yaw = yaw_rate_sensor(t_rec, t_true, still, gyro, np.random.default_rng(3))
    rise = sensor_warmup_k(t_rec, gyro)
    np.testing.assert_allclose(yaw.temperature_rise_k, rise)
    assert rise[0] == 0.0 and rise[-1] == pytest.approx(gyro.warmup_k, rel=1e-4)
    # Whole drive: the turn-on bias plus the mean temperature term. The mean of the
    # Gauss-Markov instability over 2 h has std sigma sqrt(2 tau / 7200 s) ~ 0.0007 deg/s.
    expected = yaw.turn_on_bias_deg_s + gyro.temp_coeff_deg_s_k * rise.mean()
    assert yaw.deg_s.mean() == pytest.approx(expected, abs=0.004)
    # The last 20 minutes against the first 10: the bias moved by tco times the warm-up.
    early, late = t_rec < 600.0, t_rec > 6000.0
    shift = gyro.temp_coeff_deg_s_k * (rise[late].mean() - rise[early].mean())
    assert shift > 0.15  # 30 times the tolerance below
    assert yaw.deg_s[late].mean() - yaw.deg_s[early].mean() == pytest.approx(shift, abs=0.006)
    # Turn-on biases over many drives spread like the configured sigma.
    draws = [
        yaw_rate_sensor(T_REC, T_TRUE, still[: T_TRUE.size], gyro, np.random.default_rng(k))
        for k in range(400)
    ]
    spread = np.std([d.turn_on_bias_deg_s for d in draws])
    assert spread == pytest.approx(gyro.bias_sigma_deg_s, rel=0.1)


def test_a_perfect_gyro_integrates_to_the_true_heading_change():
    heading = wandering_heading(T_TRUE)
    for errors, gyro in ((False, dataclasses.replace(PERFECT, latency_s=0.03)), (True, PERFECT)):
        yaw = yaw_rate_sensor(T_REC, T_TRUE, heading, gyro, np.random.default_rng(0), errors)
        # Each row is the mean rate over its record period: the sum over rows is the heading
        # change from one period before the first row (still the start heading) to the last.
        integrated = np.radians(np.cumsum(yaw.deg_s) * 0.1)
        np.testing.assert_allclose(integrated, heading[::5] - heading[0], rtol=0, atol=1e-10)
        assert np.abs(yaw.bias_deg_s).max() == 0.0


def test_gyro_latency_delays_the_rate():
    heading = wandering_heading(T_TRUE)
    late = dataclasses.replace(PERFECT, latency_s=0.2)
    got = yaw_rate_sensor(T_REC, T_TRUE, heading, late, np.random.default_rng(0)).deg_s
    now = yaw_rate_sensor(T_REC, T_TRUE, heading, PERFECT, np.random.default_rng(0)).deg_s
    np.testing.assert_allclose(got[2:], now[:-2], atol=1e-9)  # two rows of 0.1 s later


def test_gyro_quantisation_steps_equal_the_lsb():
    lsb = 0.05
    gyro = dataclasses.replace(PERFECT, quantum_deg_s=lsb, noise_density_deg_s_rthz=0.002)
    ramp = np.radians(0.5 * (T_TRUE / 600.0) * T_TRUE)  # the rate ramps 0 -> 1 deg/s
    got = yaw_rate_sensor(T_REC, T_TRUE, ramp, gyro, np.random.default_rng(0)).deg_s
    steps = np.round(got / lsb)
    np.testing.assert_allclose(got, steps * lsb, atol=1e-12)  # every value on the LSB grid
    jumps = np.abs(np.diff(steps))
    assert jumps.max() == 1.0  # a slowly varying rate moves one LSB at a time...
    assert 15 <= (jumps == 1).sum()  # ...through each of the 20 levels, noise dithering
    true = yaw_rate_sensor(T_REC, T_TRUE, ramp, PERFECT, np.random.default_rng(0)).deg_s
    assert np.abs(got - true).max() <= lsb / 2 + 4 * 0.002 / np.sqrt(0.2)


@pytest.mark.parametrize("scale_pct", [-1.1, 0.8, 3.0])
def test_gyro_scale_factor_multiplies_the_true_rate(scale_pct):
    heading = wandering_heading(T_TRUE)
    gyro = dataclasses.replace(PERFECT, scale_error_pct=scale_pct)
    got = yaw_rate_sensor(T_REC, T_TRUE, heading, gyro, np.random.default_rng(0)).deg_s
    true = yaw_rate_sensor(T_REC, T_TRUE, heading, PERFECT, np.random.default_rng(0)).deg_s
    assert np.abs(true).max() > 10.0
    np.testing.assert_allclose(got, (1.0 + scale_pct / 100.0) * true, rtol=1e-12, atol=1e-12)


def test_gyro_noise_follows_the_noise_density_over_the_record_period():
    gyro = dataclasses.replace(PERFECT, noise_density_deg_s_rthz=0.015)
    t_true = np.arange(0.0, 3600.0 + 1e-9, 0.02)
    still = np.zeros(t_true.size)
    got = yaw_rate_sensor(t_true[::5], t_true, still, gyro, np.random.default_rng(0)).deg_s
    # The mean over a 0.1 s period: noise-equivalent bandwidth 1 / (2 T) = 5 Hz.
    assert got.std() == pytest.approx(0.015 * np.sqrt(5.0), rel=0.03)
    assert abs(np.corrcoef(got[:-1], got[1:])[0, 1]) < 0.03  # white from row to row
