"""Sensor models: the GNSS receiver's error, CAN wheel speeds, degraded GNSS stretches."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import SimCan, SimGnss
from rwhonet.geo import geodesic_distance_m, offsets_m
from rwhonet.sim.sensors import (
    can_wheel_speeds,
    filtered_gauss_markov,
    gauss_markov,
    gnss_error_autocorrelation,
    gnss_increment_std_m,
    place_faults,
)


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
