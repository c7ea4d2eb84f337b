"""Wheel-sensor and position plausibility: stuck or silent wheels, signs, coordinates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rwhonet.config import WheelPolicy
from rwhonet.data import canonical as c
from rwhonet.data import plausibility
from rwhonet.data.plausibility import (
    AXLE_EXCHANGED_GAIN,
    AXLE_MIN_TIGHT,
    AXLE_TIGHT_TERM,
    AXLE_WHEELBASE_M,
    DIAGONAL_MIN_GAIN,
    YAW_FLAT_SPAN_RAD,
    YAW_MIN_SECONDS,
    YAW_MIN_STEP_M,
    YawEstimate,
    axle_mistake,
    axle_order_gain,
    diagonal_gain,
    diagonal_mistake,
    implied_radius,
    latlon_swapped_by_range,
    minutes_radius,
    negative_wheel_rows,
    radians_radius,
    reversing_rows,
    side_mistake,
    stuck_wheel_runs,
    swapped_radius,
    wheel_gnss_runs,
    wheel_side_gains,
    yaw_gain,
    yaw_mistake,
)
from rwhonet.data.quality import Segment
from rwhonet.data.streams import DriveStreams, Stream, resample
from rwhonet.geo import latlon_from_offsets_deg
from support.corpus import TARGET_RADIUS_M, speed_profile_drive, weaving_drive
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


@pytest.mark.parametrize("azimuth_deg", [0.0, 90.0])
def test_degrees_read_as_minutes_imply_the_radius_once_multiplied_by_60(azimuth_deg):
    """A map's 'min' (or 'ddmm', NMEA's degrees-minutes) on a column of degrees divides
    the coordinates by 60: the radius found with them times 60 is the car's; the radians
    reading (x 57.3) comes within 5 % of it, by the heading (so validate names both where
    both fit); the drive as it is is 36-60 times short."""
    drive = straight_drive(40.0, azimuth_deg=azimuth_deg)
    as_minutes = drive.copy()
    as_minutes[[c.LAT_DEG, c.LON_DEG]] = drive[[c.LAT_DEG, c.LON_DEG]].to_numpy() / 60.0
    seg = _segment(drive)
    est = minutes_radius(as_minutes, seg, 1.0)
    assert est is not None and est.radius_m == pytest.approx(SOURCE_RADIUS_M, rel=1e-6)
    radians = radians_radius(as_minutes, seg, 1.0)
    assert radians is not None
    assert 3.0 / math.pi - 1e-3 < radians.radius_m / SOURCE_RADIUS_M < 1.01
    as_is = implied_radius(as_minutes, seg, 1.0).radius_m
    assert 1 / 62 < as_is / SOURCE_RADIUS_M < 1 / 36
    assert minutes_radius(drive, seg, 1.0) is None  # 52.4 deg x 60: no latitude


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


# ------------------------------------------------------------------------ the yaw rate


def _turning_drive(
    seconds: int = 300,
    speed_m_s: float = 10.0,
    fix_noise_m: float = 0.3,
    gyro_scale: float = 1.0,
    gyro_bias_rad_s: float = 0.005,
    lat0: float = 52.4,
    seed: int = 0,
    turn_rad_s: float = 0.2,
) -> dict[str, np.ndarray]:
    """A car weaving at 10 m/s (yaw rate ±0.2 rad/s), its fixes noisy, its gyro biased."""
    df = weaving_drive(
        seconds,
        speed_m_s,
        turn_rad_s,
        lat0,
        fix_noise_m=fix_noise_m,
        gyro_scale=gyro_scale,
        gyro_bias_rad_s=gyro_bias_rad_s,
        seed=seed,
    )
    return {k: df[k].to_numpy(copy=True) for k in (c.T_S, c.LAT_DEG, c.LON_DEG, c.YAW_RATE_RAD_S)}


def _whole(drive) -> list[Segment]:
    t = drive[c.T_S]
    return [Segment(0, t.size, start_s=float(t[0]), end_s=float(t[-1]))]


def test_a_right_yaw_rate_turns_as_the_gnss_course_turns():
    drive = _turning_drive()
    est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    assert est.seconds == 299  # every pair of consecutive seconds' chords (300 chords)
    assert est.gain == pytest.approx(1.0, abs=4 * est.gain_se) and est.gain_se < 0.04
    assert yaw_mistake(est, 0.25) == (True, None)
    # a 3 % scale error is a gyro's own, not a mistake; the bias is taken out by the intercept
    scaled = _turning_drive(gyro_scale=1.03, gyro_bias_rad_s=0.02)
    est = yaw_gain(scaled, _whole(scaled), YAW_MIN_STEP_M, 0.1)
    assert est.gain == pytest.approx(1 / 1.03, abs=4 * est.gain_se)
    assert yaw_mistake(est, 0.25) == (True, None)


def test_a_drifting_gyro_bias_does_not_pull_the_gain(monkeypatch):
    """Each block of YAW_BLOCK_S its own intercept: a bias that warms up (the gyro's own
    error term) is no turn, also on a drive that hardly turns (a motorway's ±0.02 rad/s)."""
    gentle = _turning_drive(seconds=900, turn_rad_s=0.02, fix_noise_m=0.05)
    steady = yaw_gain(gentle, _whole(gentle), YAW_MIN_STEP_M, 0.1)
    t = gentle[c.T_S] - gentle[c.T_S][0]
    warm = dict(gentle)
    warm[c.YAW_RATE_RAD_S] = gentle[c.YAW_RATE_RAD_S] + 0.03 * (1.0 - np.exp(-t / 600.0))
    drifting = yaw_gain(warm, _whole(warm), YAW_MIN_STEP_M, 0.1)
    assert steady.gain == pytest.approx(1.0, abs=4 * steady.gain_se)
    assert drifting.gain == pytest.approx(steady.gain, abs=0.03)
    assert yaw_mistake(drifting, 0.25) == (True, None)
    # one intercept for the whole drive: the warm-up pulls the gain down
    monkeypatch.setattr(plausibility, "YAW_BLOCK_S", 1e9)
    one = yaw_gain(warm, _whole(warm), YAW_MIN_STEP_M, 0.1)
    assert one.gain < steady.gain - 0.15


@pytest.mark.parametrize(
    "factor, what",
    [
        (-1.0, "positive turning right"),
        (180.0 / np.pi, "in deg/s where rad/s was declared"),
        (np.pi / 180.0, "in rad/s where deg/s was declared"),
        (-180.0 / np.pi, "in deg/s where rad/s was declared, and positive turning right"),
        (0.0, "never changes"),
    ],
)
def test_a_wrong_yaw_rate_is_named_by_its_gain(factor, what):
    drive = _turning_drive()
    drive[c.YAW_RATE_RAD_S] = drive[c.YAW_RATE_RAD_S] * factor
    est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    checked, mistake = yaw_mistake(est, 0.25)
    assert checked and what in mistake
    if factor:
        assert est.gain == pytest.approx(1.0 / factor, rel=0.1)


def test_a_yaw_rate_of_another_drive_does_not_follow_the_course():
    drive = _turning_drive()
    other = _turning_drive(seed=1)
    drive[c.YAW_RATE_RAD_S] = np.roll(other[c.YAW_RATE_RAD_S], 100)  # 10 s out of step
    est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    checked, mistake = yaw_mistake(est, 0.25)
    assert checked and "does not follow" in mistake


def test_a_straight_or_slow_drive_cannot_tell_and_says_so():
    # straight (the gyro reads its noise): the gain's ±4 standard errors cover the band
    drive = _turning_drive()
    rng = np.random.default_rng(5)
    t = drive[c.T_S]
    east, north = 10.0 * (t - t[0]) * np.sin(0.3), 10.0 * (t - t[0]) * np.cos(0.3)
    drive[c.LAT_DEG], drive[c.LON_DEG] = latlon_from_offsets_deg(
        52.4, -1.5, east + rng.normal(0, 0.5, t.size), north + rng.normal(0, 0.5, t.size)
    )
    for sign in (1.0, -1.0):
        drive[c.YAW_RATE_RAD_S] = sign * rng.normal(0.0, 0.002, t.size)
        est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
        assert est.seconds == 299 and yaw_mistake(est, 0.25) == (False, None)
    # slower than YAW_MIN_STEP_M a second: no chord has a course
    slow = _turning_drive(speed_m_s=4.0)
    est = yaw_gain(slow, _whole(slow), YAW_MIN_STEP_M, 0.1)
    assert est.seconds < YAW_MIN_SECONDS and yaw_mistake(est, 0.25) == (False, None)
    # zeros on a straight drive: a flat channel is refused only once the course turned
    drive[c.YAW_RATE_RAD_S] = np.zeros_like(t)
    est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    assert est.course_span_rad < YAW_FLAT_SPAN_RAD and yaw_mistake(est, 0.25) == (False, None)


def test_no_yaw_mistake_is_told_on_a_straight_stretch():
    """predict's first tries on the paper world's V-Delta1: over 104 pairs of seconds the
    course swung through 0.9 deg and the gain came out -1.47 ± 0.55, 4 standard errors
    from a right gyro's band; the gyro was right (1.005 ± 0.034 once the course swung 5
    deg). No mistake is told before the course swung through 10 deg; the same gain over a
    bend is told, and a right gain is told on any swing."""
    straight = YawEstimate(-1.47, 0.553, 104, math.radians(0.9))
    assert yaw_mistake(straight, 0.25) == (False, None)
    bend = YawEstimate(-1.47, 0.553, 104, math.radians(10.5))
    assert yaw_mistake(bend, 0.25) == (
        True,
        "does not follow the GNSS course (another signal, or another drive's?)",
    )
    assert yaw_mistake(YawEstimate(1.005, 0.034, 164, math.radians(0.9)), 0.25) == (True, None)
    flipped = YawEstimate(-1.0, 0.01, 300, math.radians(9.0))
    assert yaw_mistake(flipped, 0.25) == (False, None)
    turned = YawEstimate(-1.0, 0.01, 300, math.radians(11.0))
    assert yaw_mistake(turned, 0.25)[1].startswith("looks positive turning right")


def test_a_second_without_a_yaw_rate_drops_only_the_pairs_around_it():
    drive = _turning_drive()
    whole = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    drive[c.YAW_RATE_RAD_S][1000:1005] = np.nan  # half a second at t0 + 100 s
    est = yaw_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1)
    assert whole.seconds - 2 <= est.seconds < whole.seconds
    assert est.gain == pytest.approx(whole.gain, abs=0.01)


def test_the_yaw_check_is_the_same_near_a_pole():
    home = _turning_drive()
    pole = _turning_drive(lat0=89.95)  # 5.6 km from the North Pole
    a = yaw_gain(home, _whole(home), YAW_MIN_STEP_M, 0.1)
    b = yaw_gain(pole, _whole(pole), YAW_MIN_STEP_M, 0.1)
    assert b.seconds == a.seconds and b.gain == pytest.approx(a.gain, abs=1e-3)


@pytest.mark.parametrize(
    "factor, what",
    [
        (1.0, None),
        (-1.0, "positive turning right"),
        (180.0 / np.pi, "in deg/s where rad/s was declared"),
    ],
)
def test_a_wrong_gyro_bending_1_hz_positions_is_still_named(factor, what):
    """The resampler turns the path between fixes by the gyro (streams.travelled_path):
    a gyro of the wrong sign or unit bends the positions between 1 Hz fixes, yet the
    course between whole seconds still follows the fixes, so the yaw check names it."""
    drive = _turning_drive(fix_noise_m=0.05)
    t = drive[c.T_S]
    fix = np.flatnonzero(np.isclose((t * 10) % 10, 5.0))  # 1 Hz, half a second off
    omega = np.full(t.size, 10.0 / 0.3)
    streams = DriveStreams(
        (Stream("wheels", "w.csv", t, {w: omega for w in c.WHEELS}),),
        Stream(
            "gnss",
            "g.csv",
            t[fix],
            {c.LAT_DEG: drive[c.LAT_DEG][fix], c.LON_DEG: drive[c.LON_DEG][fix]},
        ),
        (Stream("gyro", "y.csv", t, {c.YAW_RATE_RAD_S: factor * drive[c.YAW_RATE_RAD_S]}),),
    )
    grid = resample(streams, max_fix_gap_s=1.5).drive.columns
    est = yaw_gain(grid, _whole(grid), YAW_MIN_STEP_M, 0.1)
    checked, mistake = yaw_mistake(est, 0.25)
    assert checked and (mistake is None if what is None else what in mistake)
    # the 57-fold gyro loops the path between fixes, and the course takes some of it (the
    # gain 0.054 against 1/57 = 0.017 measured): still far from 1, still named
    assert est.gain == pytest.approx(1.0 / factor, rel=0.1 if abs(factor) == 1 else 3.5)


# ------------------------------------------------------------------------ the wheels' sides


def _wheels_turning(**kw) -> dict[str, np.ndarray]:
    """A car weaving at 10 m/s (±0.2 rad/s), each side's wheels at their own speed (a
    1.5 m track), its fixes noisy."""
    df = weaving_drive(300, 10.0, fix_noise_m=0.3, track_m=1.5, **kw)
    return {k: df[k].to_numpy(copy=True) for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}


def _sides(drive, track_m: float = 1.5):
    return wheel_side_gains(drive, _whole(drive), YAW_MIN_STEP_M, 0.1, 0.3, track_m)


def test_each_axle_s_wheels_turn_as_the_course_turns():
    """Ideal rolling (no load transfer, no slip): each axle's gain is 1 on the car's track
    and scales with the track given (only its sign is told)."""
    drive = _wheels_turning()
    for axle, est in _sides(drive).items():
        assert est.seconds == 299
        assert est.gain == pytest.approx(1.0, abs=4 * est.gain_se) and est.gain_se < 0.04, axle
        assert side_mistake(est) == (True, False)
    wide = _sides(drive, track_m=3.0)["rear"]
    assert wide.gain == pytest.approx(2.0 * _sides(drive)["rear"].gain, rel=1e-9)


@pytest.mark.parametrize(
    "exchanged, told",
    [
        ((c.OMEGA_RL, c.OMEGA_RR), {"rear": True, "front": False}),
        ((c.OMEGA_FL, c.OMEGA_FR), {"rear": False, "front": True}),
    ],
)
def test_an_axle_s_left_and_right_exchanged_turn_against_the_course(exchanged, told):
    drive = _wheels_turning()
    left, right = exchanged
    drive[left], drive[right] = drive[right].copy(), drive[left].copy()
    for axle, est in _sides(drive).items():
        assert side_mistake(est) == (True, told[axle]), axle
        if told[axle]:
            assert est.gain == pytest.approx(-1.0, abs=4 * est.gain_se)


def test_wheels_that_cannot_tell_their_sides_pass():
    """Every wheel at the car's speed (an axle's mean speed written to both), a drive
    that hardly turns, or one too slow for a course: no side is told, none is exchanged."""
    same = weaving_drive(300, 10.0, fix_noise_m=0.3)  # no track: every wheel alike
    same = {k: same[k].to_numpy() for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    gentle = _wheels_turning(turn_rad_s=0.0005)
    slow = weaving_drive(300, 4.0, fix_noise_m=0.3, track_m=1.5)
    slow = {k: slow[k].to_numpy() for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    for drive in (same, gentle, slow):
        for est in _sides(drive).values():
            assert side_mistake(est) == (False, False)
    assert all(est.seconds < YAW_MIN_SECONDS for est in _sides(slow).values())


# ------------------------------------------------------------------ the front and rear axles


def _axles_turning(**kw) -> dict[str, np.ndarray]:
    """A car weaving at 8 m/s through tight turns (±0.6 rad/s: a radius down to 13 m),
    its front wheels on the front axle's wider arc (``wheelbase_m``), its fixes noisy
    (0.3 m, white: every fix's own)."""
    kw = {"wheelbase_m": AXLE_WHEELBASE_M, "turn_rad_s": 0.6, "fix_noise_m": 0.3} | kw
    df = weaving_drive(300, kw.pop("speed_m_s", 8.0), track_m=1.5, **kw)
    return {k: df[k].to_numpy(copy=True) for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}


def _axles(drive):
    return axle_order_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1, TARGET_RADIUS_M)


def _exchanged(drive) -> dict[str, np.ndarray]:
    out = dict(drive)
    for front, rear in ((c.OMEGA_FL, c.OMEGA_RL), (c.OMEGA_FR, c.OMEGA_RR)):
        out[front], out[rear] = drive[rear], drive[front]
    return out


def test_the_front_wheels_run_faster_in_a_turn_by_the_wheelbase_squared():
    """The front axle on sqrt(R^2 + L^2): with exact fixes the gain is 1 on the wheelbase
    the fit assumes (0.99: sqrt(1 + u) is 1 + u / 2 less u^2 / 8) and (L /
    AXLE_WHEELBASE_M)^2 on another. Noisy fixes dilute it (their course's noise squared
    adds to the turn's term: 0.74 with 0.3 m white fix noise), only its sign is told: in
    their columns the axles are told, not exchanged."""
    exact = _axles(_axles_turning(fix_noise_m=0.0))
    assert exact.seconds == 299 and exact.tight >= AXLE_MIN_TIGHT
    assert exact.gain == pytest.approx(0.99, abs=0.005) and exact.gain_se < 0.001
    long = _axles(_axles_turning(fix_noise_m=0.0, wheelbase_m=AXLE_WHEELBASE_M * math.sqrt(2)))
    assert long.gain == pytest.approx(2.0 * exact.gain, rel=0.01)
    noisy = _axles(_axles_turning())
    assert 0.5 < noisy.gain < exact.gain and noisy.gain > 20 * noisy.gain_se
    assert axle_mistake(noisy) == (True, False)


def test_the_front_and_rear_columns_exchanged_run_slower_in_the_turns():
    assert _axles(_exchanged(_axles_turning(fix_noise_m=0.0))).gain == pytest.approx(-1, abs=0.02)
    est = _axles(_exchanged(_axles_turning()))
    assert est.gain < -20 * est.gain_se
    assert axle_mistake(est) == (True, True)


def test_axles_that_cannot_be_told_apart_pass():
    """Every wheel at the rear axle's speed (no wheelbase), turns too wide to count, or a
    car too slow for a course: the axles are not told, nor exchanged."""
    alike = _axles(_axles_turning(wheelbase_m=0.0))
    assert math.isnan(alike.gain) and axle_mistake(alike) == (False, False)
    wide = _axles(_axles_turning(turn_rad_s=0.1, speed_m_s=15.0))  # radius 150 m and more
    assert wide.tight == 0 and axle_mistake(wide) == (False, False)
    assert axle_mistake(_axles(_exchanged(_axles_turning(turn_rad_s=0.1, speed_m_s=15.0)))) == (
        False,
        False,
    )
    slow = _axles(_axles_turning(speed_m_s=4.0))
    assert slow.seconds < YAW_MIN_SECONDS and axle_mistake(slow) == (False, False)


def test_a_drift_of_the_axles_ratio_over_wide_turns_is_no_evidence():
    """Wide turns (their term under AXLE_TIGHT_TERM), with the front axle's speed over the
    rear's falling 300 times the term (a drift with speed, as a straight built-in drive
    showed): the gain lies far below 0 by its standard error, yet too few tight turns tell
    nothing."""
    drive = _axles_turning(turn_rad_s=0.05, speed_m_s=15.0, wheelbase_m=0.0, fix_noise_m=0.02)
    term = 0.5 * (AXLE_WHEELBASE_M * 0.05 / 15.0) ** 2
    assert 300 * term < 0.05 and term < AXLE_TIGHT_TERM
    t = drive[c.T_S]
    rate = 0.05 * np.sin(2.0 * np.pi * (t - t[0]) / 40.0)
    slower = 1.0 - 300.0 * 0.5 * (AXLE_WHEELBASE_M * rate / 15.0) ** 2
    for w in (c.OMEGA_FL, c.OMEGA_FR):
        drive[w] = drive[w] * slower
    est = _axles(drive)
    assert est.gain < -4 * est.gain_se and est.tight == 0
    assert axle_mistake(est) == (False, False)


def test_front_wheels_a_little_slower_in_the_turns_are_no_exchange():
    """Front wheels that run slower in the tight turns by a tenth of the arc's excess (its
    brakes, or the rear's drive, slipping more there than the arc adds): the gain is told
    negative, but an exchange would make it about -1: neither told nor refused."""
    drive = _axles_turning(wheelbase_m=0.0, fix_noise_m=0.02)
    t = drive[c.T_S]
    rate = 0.6 * np.sin(2.0 * np.pi * (t - t[0]) / 40.0)
    for w in (c.OMEGA_FL, c.OMEGA_FR):
        drive[w] = drive[w] * (1.0 - 0.1 * 0.5 * (AXLE_WHEELBASE_M * rate / 8.0) ** 2)
    est = _axles(drive)
    assert AXLE_EXCHANGED_GAIN < est.gain < -4 * est.gain_se and est.tight >= AXLE_MIN_TIGHT
    assert axle_mistake(est) == (False, False)


def test_both_diagonal_pairs_exchanged_are_three_exchanges_told():
    """The four columns turned round (front left holding the rear right's speed, and so
    on): each axle's sides are told exchanged and the axles too, so the three fixes the
    refusals give, made together, put every wheel back."""
    drive = _axles_turning()
    turned = dict(drive)
    for a, b in ((c.OMEGA_FL, c.OMEGA_RR), (c.OMEGA_FR, c.OMEGA_RL)):
        turned[a], turned[b] = drive[b], drive[a]
    assert axle_mistake(_axles(turned)) == (True, True)
    for est in wheel_side_gains(turned, _whole(turned), YAW_MIN_STEP_M, 0.1, 0.3, 1.5).values():
        assert side_mistake(est) == (True, True)


# ------------------------------------------------------------------ one diagonal pair


def _diagonal(drive):
    return diagonal_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1, TARGET_RADIUS_M, 1.5)


def _with(drive, *pairs: tuple[str, str]) -> dict[str, np.ndarray]:
    out = dict(drive)
    for a, b in pairs:
        out[a], out[b] = out[b], out[a]
    return out


FL_RR, FR_RL = (c.OMEGA_FL, c.OMEGA_RR), (c.OMEGA_FR, c.OMEGA_RL)


def test_one_diagonal_pair_exchanged_turns_the_front_less_the_rear_with_the_course():
    """Ideal rolling through tight turns, exact fixes: in their columns the sides take the
    turn and the diagonal gain is 0 (the front axle's wider arc turns with neither sign);
    the front left and rear right exchanged, the front columns hold both right wheels and
    it is the sides' gain, 1; the front right and rear left, -1. Noisy fixes (0.3 m, white)
    leave it told."""
    exact = _axles_turning(fix_noise_m=0.0)
    est = _diagonal(exact)
    assert est.seconds == 299 and abs(est.gain) < 0.01 and diagonal_mistake(est) is None
    flrr, frrl = _diagonal(_with(exact, FL_RR)), _diagonal(_with(exact, FR_RL))
    assert flrr.gain == pytest.approx(1.0, abs=0.01) and diagonal_mistake(flrr) == FL_RR
    assert frrl.gain == pytest.approx(-1.0, abs=0.01) and diagonal_mistake(frrl) == FR_RL
    noisy = _axles_turning()
    assert diagonal_mistake(_diagonal(noisy)) is None
    told = _diagonal(_with(noisy, FL_RR))
    assert told.gain > 20 * told.gain_se and diagonal_mistake(told) == FL_RR


@pytest.mark.parametrize(
    "pairs",
    [
        [(c.OMEGA_RL, c.OMEGA_RR)],
        [(c.OMEGA_FL, c.OMEGA_FR), (c.OMEGA_RL, c.OMEGA_RR)],
        [(c.OMEGA_FL, c.OMEGA_RL), (c.OMEGA_FR, c.OMEGA_RR)],
        [FL_RR, FR_RL],
    ],
    ids=["rear_sides", "both_sides", "axles", "both_diagonals"],
)
def test_other_exchanges_are_no_diagonal_pair(pairs):
    """An axle's sides exchanged leave the front less the rear as it is, the axles
    exchanged negate it, both diagonals do both: no turn in it, none told a diagonal (the
    sides and axles checks tell those)."""
    est = _diagonal(_with(_axles_turning(), *pairs))
    assert abs(est.gain) < DIAGONAL_MIN_GAIN and diagonal_mistake(est) is None


def test_the_load_transfer_in_the_front_less_the_rear_is_no_diagonal_pair():
    """Front wheels that run faster than the rear in every turn, more the harder it is taken
    (a tenth of the wheel yaw's size, whichever way it turns: what load transfer and the
    front's wider arc put there), through turns mostly one way (the course's turn then
    follows the size of the turn too): fitted alone, the front less the rear would take a
    share of the turn (told); fitted with the sides, nothing told."""
    drive = _wheels_turning()
    t = drive[c.T_S]
    rate = 0.2 * np.sin(2.0 * np.pi * (t - t[0]) / 40.0)
    one_way = np.where(rate > 0, 1.0, 0.3)  # left turns taken three times as hard
    for w in (c.OMEGA_FL, c.OMEGA_FR):
        drive[w] = drive[w] * (1.0 + 0.1 * np.abs(rate) * one_way)
    alone = yaw_gain(
        {
            c.T_S: t,
            c.YAW_RATE_RAD_S: 0.5
            * (0.3 / 1.5)
            * ((drive[c.OMEGA_FL] + drive[c.OMEGA_FR]) - (drive[c.OMEGA_RL] + drive[c.OMEGA_RR])),
            c.LAT_DEG: drive[c.LAT_DEG],
            c.LON_DEG: drive[c.LON_DEG],
        },
        _whole(drive),
        YAW_MIN_STEP_M,
        0.1,
    )
    assert alone.gain > 4 * alone.gain_se, alone
    est = diagonal_gain(drive, _whole(drive), YAW_MIN_STEP_M, 0.1, 0.3, 1.5)
    assert abs(est.gain) < 4 * est.gain_se and diagonal_mistake(est) is None


def test_a_drive_too_short_or_straight_tells_no_diagonal_pair():
    slow = weaving_drive(300, 4.0, fix_noise_m=0.3, track_m=1.5)
    slow = {k: slow[k].to_numpy() for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    est = _diagonal(_with(slow, FL_RR))
    assert est.seconds < YAW_MIN_SECONDS and diagonal_mistake(est) is None
    gentle = _wheels_turning(turn_rad_s=0.0005)
    assert diagonal_mistake(_diagonal(_with(gentle, FL_RR))) is None
