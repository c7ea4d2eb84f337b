"""Rear-radius calibration: the ratio-of-sums estimator and the authors' mean of ratios."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.features.calibration import (
    Calibration,
    calibration_from_dict,
    fit_radii_mean_of_ratios,
    fit_radii_ratio_of_sums,
)
from rwhonet.features.seconds import SegmentSeconds, segment_seconds
from support.synthetic import R_RL_M, R_RR_M, build_drive, piecewise_linear_speed

MIN_SPEED_M_S = 2.0


def fit_robust(sec: SegmentSeconds):
    return fit_radii_ratio_of_sums(
        sec.disp_gnss_m, sec.angle_rl_rad, sec.angle_rr_rad, sec.span_s, MIN_SPEED_M_S
    )


def fit_authors(sec: SegmentSeconds):
    return fit_radii_mean_of_ratios(sec.disp_gnss_m, sec.omega_end_rl_rad_s, sec.omega_end_rr_rad_s)


@pytest.fixture(scope="module")
def straight_drive() -> SegmentSeconds:
    """An hour at 15 m/s on a straight road, with a standstill at both ends (36,800 rows)."""
    profile = piecewise_linear_speed([0, 30, 40, 3640, 3650, 3680], [0, 0, 15, 15, 0, 0])
    frame = build_drive(profile, gnss_sigma_m=0.3, wheel_sigma_rad_s=0.05, seed=11)
    return segment_seconds(frame, "straight")


@pytest.fixture(scope="module")
def creeping_drive() -> SegmentSeconds:
    """Ten minutes of stop-and-go creeping at 0.4 m/s, then ten minutes at 15 m/s."""
    profile = piecewise_linear_speed([0, 1, 601, 611, 1211], [0.4, 0.4, 0.4, 15, 15])
    frame = build_drive(profile, gnss_sigma_m=0.3, seed=12)
    return segment_seconds(frame, "creeping")


def test_ratio_of_sums_recovers_the_true_radii_within_half_a_percent(straight_drive):
    fit = fit_robust(straight_drive)
    assert fit.r_rl_m == pytest.approx(R_RL_M, rel=0.005)
    assert fit.r_rr_m == pytest.approx(R_RR_M, rel=0.005)
    # What is left is known: along-track fix errors cancel in the sum of distances,
    # cross-track ones add Var / (2 d) per second (the distance is a norm), a
    # relative 2 sigma^2 / (2 d^2) = 0.3^2 / 15^2 = 4e-4 at 15 m/s.
    assert fit.r_rl_m / R_RL_M - 1 == pytest.approx(0.3**2 / 15**2, abs=1e-4)
    assert fit.r_rr_m / R_RR_M - 1 == pytest.approx(0.3**2 / 15**2, abs=1e-4)
    # Standstill and the slow parts of the ramps are left out: moving >= 2 m/s
    # covers 3600 s of cruise plus (15 - 2) / 15 of each 10 s ramp.
    assert fit.n_seconds == pytest.approx(3600 + 2 * 10 * 13 / 15, abs=2)


def test_authors_estimator_is_undefined_with_standstill(straight_drive):
    fit = fit_authors(straight_drive)
    assert not math.isfinite(fit.r_rl_m) and not math.isfinite(fit.r_rr_m)
    assert not fit.finite


def test_authors_estimator_is_biased_by_slow_seconds_where_ratio_of_sums_is_not(creeping_drive):
    authors = fit_authors(creeping_drive)
    robust = fit_robust(creeping_drive)
    assert authors.finite  # no standstill here: defined, but wrong
    # Slow seconds enter with full weight; their GNSS distance (a norm of a noisy
    # difference) is biased up, so the radius is inflated by tens of percent.
    assert authors.r_rl_m / R_RL_M > 1.2
    assert robust.r_rl_m == pytest.approx(R_RL_M, rel=0.005)
    assert robust.r_rr_m == pytest.approx(R_RR_M, rel=0.005)


def test_selection_is_by_wheel_speed_times_the_first_pass_radius():
    r = 0.3
    speed = np.array([0.0, 1.0, 1.9, 2.1, 5.0, 20.0])
    angle = speed / r
    gnss = speed.copy()
    gnss[3] = 1.5  # GNSS reads below the threshold, the wheels above: still used
    gnss[2] = 2.5  # GNSS above, wheels below: not used
    fit = fit_radii_ratio_of_sums(gnss, angle, angle, np.ones(6), MIN_SPEED_M_S)
    assert fit.n_seconds == 3
    assert fit.distance_m == pytest.approx(1.5 + 5.0 + 20.0)
    assert fit.r_rl_m == pytest.approx(26.5 / (27.1 / r))


def test_a_drive_that_never_moves_cannot_be_calibrated():
    with pytest.raises(ValueError, match="cannot calibrate"):
        fit_radii_ratio_of_sums(np.full(5, 0.5), np.full(5, 1.5), np.full(5, 1.5), np.ones(5), 2.0)


def _calibration() -> Calibration:
    return Calibration(
        r_rl_m=0.3011,
        r_rr_m=0.2968,
        estimator="ratio_of_sums",
        min_speed_m_s=2.0,
        n_seconds_used=3600,
        n_seconds_total=3680,
        distance_m=54000.0,
        role="source_calibration",
        drives=["V-cal"],
        segments=["V-cal__s0"],
        comparison={"mean_of_ratios": {"r_rl_m": None, "r_rr_m": None}},
    )


def test_calibration_round_trip_through_json():
    raw = json.loads(json.dumps(_calibration().to_dict()))
    assert raw["unit"] == "m/rad"
    assert calibration_from_dict(raw, "calibration.json") == _calibration()


def test_calibration_with_a_bad_radius_is_refused():
    raw = _calibration().to_dict()
    raw["r_rr_m"] = -0.3
    del raw["drives"]
    with pytest.raises(InputError) as err:
        calibration_from_dict(raw, "calibration.json")
    assert {p.column for p in err.value.problems} == {"r_rr_m", "drives"}
