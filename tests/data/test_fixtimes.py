"""When each GNSS fix was taken (rwhonet.data.fixtimes): the receiver's grid or the stamps."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data.fixtimes import (
    MIN_PAIRS,
    fix_times,
    grid_epochs,
    receiver_epochs,
    receiver_period_s,
)
from rwhonet.data.streams import travelled_path
from rwhonet.geo import latlon_from_offsets_deg

RADIUS_M = 0.3


def speed(t: np.ndarray) -> np.ndarray:
    """A car speeding up and slowing down between 4 and 24 m/s every 20 s."""
    return 14.0 + 10.0 * np.sin(2.0 * np.pi * t / 20.0)


def distance(t: np.ndarray) -> np.ndarray:
    """Its distance from t = 0, m (the integral of :func:`speed`)."""
    return 14.0 * t - 10.0 * 20.0 / (2.0 * np.pi) * (np.cos(2.0 * np.pi * t / 20.0) - 1.0)


def fixes_at(t: np.ndarray, noise_m: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Where the car is at ``t`` on a road north-east from Coventry (white noise added)."""
    rng = np.random.default_rng(seed)
    s = distance(t) + rng.normal(0.0, noise_m, t.size)
    return latlon_from_offsets_deg(52.4, -1.5, s * np.sin(0.7), s * np.cos(0.7))


def wheels(duration_s: float):
    """How far a 100 Hz wheel-speed stream of the car says it rolled (the path's ``rolled``)."""
    t = np.arange(0.0, duration_s, 0.01)
    return travelled_path(t, speed(t) / RADIUS_M).rolled


def arrival_stamps(epochs: np.ndarray, seed: int = 1) -> np.ndarray:
    """A logger's stamps: 40 ms of latency, ±8 ms of jitter, a clock 30 ppm fast."""
    rng = np.random.default_rng(seed)
    return (epochs + 0.040 + rng.uniform(-0.008, 0.008, epochs.size)) * (1.0 + 30e-6)


@pytest.mark.parametrize("hz", [1.0, 5.0, 10.0])
def test_the_grid_s_epochs_come_back_from_arrival_stamps(hz):
    epochs = 1000.0 + np.arange(round(600 * hz)) / hz  # 10 min
    stamps = arrival_stamps(epochs)
    assert receiver_period_s(stamps) == pytest.approx(1.0 / hz)
    found, scatter = grid_epochs(stamps, 1.0 / hz)
    # Each fix at its epoch plus the median latency (on the logger's clock): a constant.
    # Each fix at its epoch plus the median latency (on the logger's clock): a constant, up
    # to a drift the fit leaves of a few tenths of a ppm.
    shift = found - epochs * (1.0 + 30e-6)
    assert np.abs(np.diff(shift)).max() < 1e-5 * max(1.0, 10.0 / hz)
    assert np.ptp(shift) < 3e-3
    assert shift.mean() == pytest.approx(0.040, abs=1e-3)
    assert scatter == pytest.approx(1.4826 * 0.004, rel=0.15)  # uniform ±8 ms: MAD 4 ms


def test_dropped_epochs_and_an_hour_of_clock_drift_keep_the_count():
    epochs = np.arange(36000) / 10.0  # 10 Hz for an hour
    keep = np.random.default_rng(2).random(epochs.size) > 0.05  # 5 % of the epochs dropped
    stamps = arrival_stamps(epochs[keep]) * (1.0 + 70e-6)  # 100 ppm: 0.36 s over the hour
    found, _ = grid_epochs(stamps, 0.1)
    shift = found - epochs[keep] * (1.0 + 30e-6) * (1.0 + 70e-6)
    assert np.abs(np.diff(shift)).max() < 1e-5 and np.ptp(shift) < 1e-3


def test_stamps_on_no_one_grid_are_no_grid():
    t = 100.0 + np.arange(400) * 0.2
    restarted = np.concatenate([t[:200], t[200:] + 0.09])  # a phase 0.45 period later
    assert grid_epochs(restarted, 0.2) is None
    irregular = np.cumsum(np.random.default_rng(3).uniform(0.15, 0.25, 400))
    assert grid_epochs(irregular, 0.2) is None


def test_receiver_epochs_refuse_a_scatter_beyond_the_limit():
    t = np.arange(100) * 0.2
    assert receiver_epochs(t, t * 1000.0) is not None
    jittered = t + np.random.default_rng(4).uniform(-0.05, 0.05, t.size)
    assert receiver_epochs(jittered, t * 1000.0, max_scatter_s=0.01) is None


def test_fixes_stamped_on_arrival_go_to_the_grid_s_epochs():
    """Positions of the epochs, stamped late and jittered: the wheels fit the epochs."""
    epochs = 0.2 * np.arange(1500)  # 5 Hz, 300 s
    lat, lon = fixes_at(epochs, noise_m=0.01)
    stamps = epochs + 0.03 + np.random.default_rng(5).uniform(-0.005, 0.005, epochs.size)
    timing = fix_times(stamps, lat, lon, wheels(300.0), where="gnss.csv")
    assert timing.at_epochs
    np.testing.assert_allclose(timing.t_s - epochs, 0.03, atol=5e-4)
    assert "gnss.csv: the fix stamps scatter" in timing.note
    assert "5 Hz grid" in timing.note and "placed at the grid's epochs" in timing.note


def test_fixes_taken_at_their_stamps_keep_them():
    """Positions of the (jittered) stamps themselves: the wheels fit the stamps."""
    nominal = 0.2 * np.arange(1500)
    stamps = nominal + 0.03 + np.random.default_rng(6).uniform(-0.005, 0.005, nominal.size)
    lat, lon = fixes_at(stamps, noise_m=0.01)
    timing = fix_times(stamps, lat, lon, wheels(300.0))
    assert not timing.at_epochs
    assert timing.t_s is stamps or np.array_equal(timing.t_s, stamps)
    assert "stamps kept (the fixes' own times)" in timing.note


def test_stamps_on_the_grid_are_left_alone_without_a_word():
    stamps = 0.03 + 0.2 * np.arange(1500)
    lat, lon = fixes_at(stamps)
    timing = fix_times(stamps, lat, lon, wheels(300.0))
    assert np.array_equal(timing.t_s, stamps) and not timing.at_epochs and timing.note is None


def test_a_car_that_hardly_moves_keeps_its_stamps_and_says_why():
    epochs = 0.2 * np.arange(1500)
    lat, lon = latlon_from_offsets_deg(52.4, -1.5, np.zeros(epochs.size), 0.1 * epochs / 300.0)
    stamps = epochs + np.random.default_rng(7).uniform(-0.005, 0.005, epochs.size)
    t_w = np.arange(0.0, 300.0, 0.01)
    timing = fix_times(stamps, lat, lon, travelled_path(t_w, np.full(t_w.size, 0.001)).rolled)
    assert not timing.at_epochs and np.array_equal(timing.t_s, stamps)
    assert f"too few moving fix pairs (0 of {MIN_PAIRS})" in timing.note


def test_a_rate_no_receiver_has_keeps_its_stamps():
    stamps = np.arange(900) / 3.0 + np.random.default_rng(8).uniform(-0.005, 0.005, 900)
    assert receiver_period_s(stamps) is None
    lat, lon = fixes_at(stamps)
    timing = fix_times(stamps, lat, lon, wheels(300.0))
    assert np.array_equal(timing.t_s, stamps) and timing.note is None


def test_a_receiver_back_on_another_phase_after_a_gap_is_fitted_run_by_run():
    """Fixes lost for 3 s come back 100 ms off the old phase: each run keeps its own grid."""
    first = 0.2 * np.arange(750)  # 150 s at 5 Hz
    second = 153.1 + 0.2 * np.arange(750)
    epochs = np.concatenate([first, second])
    stamps = epochs + 0.03 + np.random.default_rng(9).uniform(-0.005, 0.005, epochs.size)
    found, _ = grid_epochs(stamps, 0.2)
    np.testing.assert_allclose(found - epochs, 0.03, atol=5e-4)
    lat, lon = fixes_at(epochs, noise_m=0.01)
    timing = fix_times(stamps, lat, lon, wheels(310.0))
    assert timing.at_epochs
    np.testing.assert_allclose(timing.t_s - epochs, 0.03, atol=5e-4)


def test_a_receiver_s_jumps_do_not_decide():
    """A few fixes 5 m off (multipath) swamp an RMS; the robust spread still sees the grid."""
    epochs = 0.2 * np.arange(1500)
    lat, lon = fixes_at(epochs, noise_m=0.01)
    jumped = np.random.default_rng(10).choice(epochs.size, 30, replace=False)
    lat[jumped] += 5.0 / 111_000.0
    stamps = epochs + 0.03 + np.random.default_rng(11).uniform(-0.005, 0.005, epochs.size)
    assert fix_times(stamps, lat, lon, wheels(300.0)).at_epochs
