"""Wheel-sensor and position plausibility: stuck or silent wheels, signs, coordinates."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import WheelPolicy
from rwhonet.data import canonical as c
from rwhonet.data.plausibility import (
    implied_radius,
    latlon_swapped_by_range,
    negative_wheel_rows,
    radians_radius,
    reversing_rows,
    stuck_wheel_runs,
    swapped_radius,
    wheel_gnss_runs,
)
from rwhonet.data.quality import Segment
from support.corpus import speed_profile_drive
from support.drives import SOURCE_RADIUS_M, straight_drive

POLICY = WheelPolicy(
    stuck_ratio=0.5,
    stuck_moving_rad_s=3.0,
    stuck_min_s=3.0,
    negative_tol_rad_s=0.5,
    signed_max_share=0.5,
)


def test_a_clean_drive_has_no_stuck_or_negative_wheel():
    drive = straight_drive(20.0)
    assert stuck_wheel_runs(drive, POLICY, 0.1) == []
    assert negative_wheel_rows(drive, POLICY.negative_tol_rad_s) == {}


def test_reversing_rows_need_all_four_wheels_backwards_together():
    drive = straight_drive(20.0)  # 201 rows at 51 rad/s
    drive.loc[50:59, list(c.WHEELS)] *= -1.0  # a signing logger, reversing
    drive.loc[60:64, list(c.WHEELS)] = 0.2  # standstill noise: no reversing
    drive.loc[100:109, c.OMEGA_FL] *= -1.0  # one wheel negative, three turning forwards
    rev = reversing_rows(drive, POLICY.negative_tol_rad_s)
    assert np.array_equal(np.flatnonzero(rev), np.arange(50, 60))


def test_the_tightest_turn_is_not_a_stuck_wheel():
    # Rear axle on a 4.5 m radius (a small car's full lock), track 1.46 m: the inner rear
    # wheel rolls 0.72 x the outer one, the fronts (on a longer radius) faster still.
    drive = straight_drive(20.0)
    v = drive[c.OMEGA_RL].to_numpy()
    drive[c.OMEGA_RL] = v * (4.5 - 0.73) / 4.5
    drive[c.OMEGA_RR] = v * (4.5 + 0.73) / 4.5
    drive[c.OMEGA_FL] = v * 1.05
    drive[c.OMEGA_FR] = v * 1.25
    assert stuck_wheel_runs(drive, POLICY, 0.1) == []


def test_stuck_wheel_runs_name_the_wheel_rows_and_speeds():
    drive = straight_drive(20.0)  # 201 rows at 51 rad/s
    drive.loc[50:89, c.OMEGA_FR] = 0.0  # 4 s
    drive.loc[120:139, c.OMEGA_FR] = 0.0  # 2 s: shorter than stuck_min_s
    (run,) = stuck_wheel_runs(drive, POLICY, 0.1)
    assert (run.wheel, run.row_start, run.row_stop) == (c.OMEGA_FR, 50, 90)
    assert run.reading_max_rad_s == 0.0
    assert run.others_median_rad_s == pytest.approx(15.0 / SOURCE_RADIUS_M)
    ignore = np.zeros(len(drive), dtype=bool)
    ignore[40:100] = True  # a manual cut over the stretch
    assert stuck_wheel_runs(drive, POLICY, 0.1, ignore) == []


def test_one_spinning_wheel_does_not_make_the_others_stuck():
    drive = straight_drive(20.0)
    for w in (c.OMEGA_FL, c.OMEGA_RL, c.OMEGA_RR):
        drive[w] = 0.0
    drive[c.OMEGA_FR] = 40.0  # a driven wheel spinning on ice, the car standing
    assert stuck_wheel_runs(drive, POLICY, 0.1) == []


def test_negative_rows_beyond_the_noise_tolerance():
    drive = straight_drive(5.0)
    drive.loc[3, c.OMEGA_RL] = -0.3  # noise around a standstill: passes
    drive.loc[10:14, c.OMEGA_RR] = -5.0
    found = negative_wheel_rows(drive, 0.5)
    assert list(found) == [c.OMEGA_RR] and list(found[c.OMEGA_RR]) == [10, 11, 12, 13, 14]


def test_swapped_coordinates_by_range():
    lat, lon = np.full(10, 121.5), np.full(10, 31.2)  # Shanghai, swapped
    assert latlon_swapped_by_range(lat, lon)
    assert not latlon_swapped_by_range(lon, lat)
    lat_glitch = np.r_[np.full(9, 52.4), 95.0]  # one corrupt latitude is not a swap
    assert not latlon_swapped_by_range(lat_glitch, np.full(10, -1.5))


@pytest.mark.parametrize("azimuth_deg", [30.0, 80.0])
def test_swapped_coordinates_by_the_radius_they_imply(azimuth_deg):
    drive = straight_drive(40.0, azimuth_deg=azimuth_deg)
    seg = [Segment(0, len(drive), start_s=45000.0, end_s=45040.0)]
    swapped = drive.copy()
    swapped[[c.LAT_DEG, c.LON_DEG]] = drive[[c.LON_DEG, c.LAT_DEG]].to_numpy()
    as_is = implied_radius(swapped, seg, 1.0).radius_m
    assert abs(as_is / SOURCE_RADIUS_M - 1.0) > 0.1  # off by the heading's scale factor
    assert swapped_radius(swapped, seg, 1.0).radius_m == pytest.approx(SOURCE_RADIUS_M, rel=1e-6)


def _segment(drive) -> list[Segment]:
    t = drive[c.T_S]
    return [Segment(0, len(drive), start_s=float(t.iloc[0]), end_s=float(t.iloc[-1]))]


def test_wheels_silent_while_gnss_moves_but_not_at_a_hard_stop():
    # 15 m/s, a hard stop (7.5 m/s^2: the one-second GNSS window lags it), 20 s standing.
    v = np.r_[np.full(100, 15.0), np.linspace(15.0, 0.0, 21), np.zeros(200), np.full(100, 15.0)]
    drive = speed_profile_drive(v, SOURCE_RADIUS_M)
    assert wheel_gnss_runs(drive, _segment(drive), SOURCE_RADIUS_M, POLICY, 0.1)[0] == []
    drive.loc[330:380, list(c.WHEELS)] = 0.0  # 5 s without wheel data while driving
    (run,) = wheel_gnss_runs(drive, _segment(drive), SOURCE_RADIUS_M, POLICY, 0.1)[0]
    assert (run.row_start, run.row_stop) == (330, 381)
    assert run.gnss_max_m_s == pytest.approx(15.0, rel=1e-3) and run.gnss_m > 70.0


def test_coordinates_in_radians_imply_the_radius_once_converted():
    drive = straight_drive(40.0)
    in_radians = drive.copy()
    in_radians[[c.LAT_DEG, c.LON_DEG]] = np.radians(drive[[c.LAT_DEG, c.LON_DEG]].to_numpy())
    est = radians_radius(in_radians, _segment(drive), 1.0)
    assert est is not None and est.radius_m == pytest.approx(SOURCE_RADIUS_M, rel=1e-6)
    assert radians_radius(drive, _segment(drive), 1.0) is None  # 52.4 deg: not radians


def test_stale_wheel_values_while_the_car_changes_speed():
    v = np.r_[np.full(100, 5.0), np.linspace(5.0, 15.0, 101), np.full(100, 15.0)]
    drive = speed_profile_drive(v, SOURCE_RADIUS_M)
    seg = _segment(drive)
    # Exactly constant readings at a constant speed are not stale...
    assert wheel_gnss_runs(drive, seg, SOURCE_RADIUS_M, POLICY, 0.1)[1] == []
    # ...and real sensors are noisy: bit-identical readings while speeding up are.
    noise = np.random.default_rng(3).normal(0.0, 0.02, (len(drive), 4))
    drive[list(c.WHEELS)] = drive[list(c.WHEELS)].to_numpy() + noise
    drive.loc[100:180, list(c.WHEELS)] = drive.loc[99, list(c.WHEELS)].to_numpy()
    (run,) = wheel_gnss_runs(drive, seg, SOURCE_RADIUS_M, POLICY, 0.1)[1]
    assert (run.row_start, run.row_stop) == (100, 181)
    assert run.gnss_max_m_s - run.gnss_min_m_s > 5.0
