"""Wheel speeds that change faster than any tyre can are found (and cut), ABS events are not."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.glitches import (
    WHEEL_GLITCH_G,
    glitch_mask,
    glitch_rows_mask,
    running_max,
    wheel_glitch_rows,
)
from rwhonet.data.iovnbd import LAYOUT
from rwhonet.data.quality import assess
from rwhonet.sim import generate_route, simulate_drive, vehicles_from_params
from rwhonet.sim.drive import child_rng
from support.corpus import speed_profile_drive

RADIUS_M = 0.3
T0 = 45000.0


def _drive(speed_m_s: float = 15.0, seconds: float = 60.0):
    return speed_profile_drive(np.full(round(seconds * 10) + 1, speed_m_s), RADIUS_M)


@pytest.mark.parametrize("speed_m_s", [2.0, 15.0, 40.0])
def test_a_one_row_tenfold_spike_is_found_at_its_row(speed_m_s):
    drive = _drive(speed_m_s)
    drive.loc[304, c.OMEGA_RL] *= 10.0
    assert {k: list(v) for k, v in wheel_glitch_rows(drive, RADIUS_M).items()} == {
        c.OMEGA_RL: [304]
    }


def test_a_spike_of_several_rows_is_flagged_until_it_ends():
    drive = _drive()
    drive.loc[200:202, c.OMEGA_FR] *= 3.0
    assert list(wheel_glitch_rows(drive, RADIUS_M)[c.OMEGA_FR]) == [200, 201, 202]


def test_the_glitched_second_is_cut_and_reported_with_its_row():
    drive = _drive(seconds=90.0)
    policy = load_params().validate.gnss
    drive.loc[304, c.OMEGA_RL] *= 10.0  # row 304 (data row 305) lies in second T0 + 31
    result = assess(drive, policy, 0.1, wheel_glitch=glitch_rows_mask(drive, RADIUS_M))
    glitch = [x for x in result.cuts if x.rule == "wheel_glitch"]
    assert [(x.start_s, x.end_s) for x in glitch] == [(T0 + 30, T0 + 31)]
    assert "row(s) 305" in glitch[0].detail
    assert [(s.start_s, s.end_s) for s in result.segments] == [
        (T0, T0 + 30),
        (T0 + 31, T0 + 90),
    ]


def test_a_glitch_on_a_seconds_last_row_also_spoils_the_next_seconds_start():
    drive = _drive()
    policy = load_params().validate.gnss
    drive.loc[310, c.OMEGA_RR] *= 10.0  # t = T0 + 31.0: the start fix of second T0 + 32
    result = assess(drive, policy, 0.1, wheel_glitch=glitch_rows_mask(drive, RADIUS_M))
    rules = [(x.start_s, x.end_s, x.rule) for x in result.cuts]
    assert (T0 + 30, T0 + 31, "wheel_glitch") in rules and (T0 + 31, T0 + 32, "start_fix") in rules


def test_abs_lockups_and_their_recovery_are_not_glitches():
    drive = _drive(25.0)
    # Hard braking with ABS: each wheel locks to 0 for 0.1-0.3 s and spins back up to the
    # road speed, at 10 Hz a fall and a rise of 83 rad/s (76 g) within one row; three wheels
    # locked in the same rows leave the fourth the only one at road speed.
    drive.loc[100:102, c.OMEGA_FL] = 0.0
    drive.loc[101, [c.OMEGA_FR, c.OMEGA_RL]] = 0.0
    drive.loc[101:102, c.OMEGA_RR] = 1.0
    drive.loc[300:301, [c.OMEGA_FL, c.OMEGA_FR, c.OMEGA_RL]] = 0.0
    assert wheel_glitch_rows(drive, RADIUS_M) == {}


def test_wheelspin_below_the_bound_passes_and_above_it_is_found():
    t = T0 + 0.1 * np.arange(200)
    road = np.full(t.size, 10.0 / RADIUS_M)
    wheels = np.stack([road, road, road, road])
    for g, flagged in ((0.8 * WHEEL_GLITCH_G, False), (1.2 * WHEEL_GLITCH_G, True)):
        w = wheels.copy()
        excess = np.clip(t - t[50], 0.0, 0.3) * g * c.G_M_S2 / RADIUS_M  # spins up for 0.3 s
        w[2] = road + excess
        assert glitch_mask(t, w, RADIUS_M)[2].any() == flagged, g


@pytest.fixture(scope="module")
def ci_drives():
    """Three drives of the sim's ci world with hard brakes, reversing, roundabouts and CAN noise."""
    params = load_params(overrides={"sim.profile": "ci"})
    cars = vehicles_from_params(params)
    drives = []
    for spec in params.sim.profiles["ci"].drives:
        if spec.name not in ("V-S1", "V-Charlie3", "V-Vta29"):
            continue
        ss = np.random.SeedSequence(11)
        vehicle = cars[spec.vehicle]
        route = generate_route(spec, params.sim, vehicle, child_rng(ss, 0))
        sim = simulate_drive(vehicle, spec.tyre, route, ss, params.sim)
        drives.append(
            (
                vehicle.nominal_radius_m,
                {
                    col.canonical: sim.frame[col.header].to_numpy(np.float64) * col.to_si
                    for col in LAYOUT
                    if col.canonical in c.REQUIRED
                },
            )
        )
    return drives


def test_ordinary_simulated_drives_have_no_glitch(ci_drives):
    assert len(ci_drives) == 3
    for radius, drive in ci_drives:
        assert wheel_glitch_rows(drive, radius) == {}


# ------------------------------------------------ in validate's per-drive checks (issue 15)


def _checked(drive):
    from rwhonet.data.drivechecks import check_drive
    from rwhonet.data.schema import schema_problems
    from support.corpus import WHEEL_FL, WHEEL_FR, WHEEL_RL, WHEEL_RR
    from support.drives import make_params

    params = make_params(
        "raw", **{"data.vehicles.target": {"nominal_radius_m": RADIUS_M, "track_rear_m": 1.5}}
    )
    names = dict(zip(c.WHEELS, (WHEEL_FL, WHEEL_FR, WHEEL_RL, WHEEL_RR), strict=True))
    entry = {
        "drive": "V-G",
        "role": "target_train",
        "vehicle": "target",
        "source_file": "V-G.csv",
        "columns": names,
    }
    frame = drive.assign(**{c.SCENARIO: ""})
    found = schema_problems(frame, params.validate, "V-G.csv", names)
    return check_drive(params, entry, frame, found, [])


def test_validate_cuts_a_glitch_second_and_lists_its_row_and_column():
    drive = speed_profile_drive(15.0 + 2.0 * np.sin(np.arange(901) / 60.0), RADIUS_M)
    drive.loc[304, c.OMEGA_RL] *= 4.0  # data row 305, second T0 + 31 (within the schema)
    problems, result, _, glitches = _checked(drive)
    assert problems == []
    assert (T0 + 30, T0 + 31, "wheel_glitch") in [(x.start_s, x.end_s, x.rule) for x in result.cuts]
    assert glitches["rows"] == 1 and glitches["rows_are"] == "data rows of the file (1-based)"
    assert glitches["listed"] == [
        {"row": 305, "t_s": T0 + 30.4, "channel": " Wheel Speed Rear Left (rad/sec)"}
    ]


def test_a_glitch_beyond_the_wheel_speed_range_is_cut_not_the_drive_refused():
    # At 15 m/s a tenfold one-row spike is 500 rad/s, past validate.max_abs_wheel_speed_rad_s
    # (300) as well as past any tyre: the glitch screen flags that row, so its second is cut
    # and listed like any glitch, rather than the whole drive refused for one CAN row.
    drive = speed_profile_drive(15.0 + 2.0 * np.sin(np.arange(901) / 60.0), RADIUS_M)
    drive.loc[304, c.OMEGA_RL] *= 10.0
    problems, result, _, glitches = _checked(drive)
    assert problems == []
    assert (T0 + 30, T0 + 31, "wheel_glitch") in [(x.start_s, x.end_s, x.rule) for x in result.cuts]
    assert [g["row"] for g in glitches["listed"]] == [305]


def test_a_wheel_speed_out_of_range_that_is_no_glitch_is_still_refused():
    # The same value held for 4 s is no glitch (a glitch falls back within 1 s): the range
    # check still reports it.
    drive = speed_profile_drive(15.0 + 2.0 * np.sin(np.arange(901) / 60.0), RADIUS_M)
    drive.loc[300:339, c.OMEGA_RL] = 500.0
    problems, _, _, _ = _checked(drive)
    ranges = [p for p in problems if "max_abs_wheel_speed_rad_s" in p.expected]
    assert ranges and ranges[0].row == 301


def test_validate_refuses_a_drive_glitched_in_most_of_its_seconds():
    drive = speed_profile_drive(15.0 + 2.0 * np.sin(np.arange(901) / 60.0), RADIUS_M)
    drive.loc[np.arange(5, 900, 10), c.OMEGA_FR] *= 4.0  # one spike in every second
    problems, _, _, glitches = _checked(drive)
    (p,) = [p for p in problems if "g above the road speed" in p.expected]
    assert (p.row, p.column) == (6, " Wheel Speed Front Right (rad/sec)")
    assert "glitches in 90 of 91 s" in p.found and p.fix
    assert glitches["rows"] == 90


@pytest.mark.parametrize("n", [1, 2, 7, 50, 1001])
@pytest.mark.parametrize("size", [1, 3, 5, 11, 101])
def test_running_max_is_scipy_s_maximum_filter_with_the_ends_held(n, size):
    from scipy.ndimage import maximum_filter1d

    x = np.random.default_rng(n * size).normal(size=n)
    np.testing.assert_array_equal(running_max(x, size), maximum_filter1d(x, size, mode="nearest"))


def test_running_max_skips_nan_unless_the_whole_window_is_nan():
    x = np.array([1.0, np.nan, 3.0, np.nan, np.nan, np.nan, 0.5])
    np.testing.assert_array_equal(running_max(x, 3), [1.0, 3.0, 3.0, 3.0, np.nan, 0.5, 0.5])
    assert running_max(np.zeros(0), 5).size == 0


# ------------------------------------------------ the yaw rate's glitches (issue 17)


def test_a_yaw_rate_beyond_any_car_s_is_interpolated_across_and_a_missing_one_stays():
    from rwhonet.data.glitches import YAW_RATE_LIMIT_RAD_S, repaired_yaw_rate

    t = np.arange(8) * 0.1
    rate = np.array([0.1, 0.2, np.radians(327.67), 0.4, np.nan, 0.6, -5.0, 0.7])
    fixed, mask = repaired_yaw_rate(t, rate)  # two of seven beyond: more than 1 %, left
    assert not mask.any() and np.array_equal(fixed, rate, equal_nan=True)
    fixed, mask = repaired_yaw_rate(t, rate, max_share=0.5)
    assert mask.tolist() == [False, False, True, False, False, False, True, False]
    np.testing.assert_allclose(fixed[[2, 6]], [0.3, 0.65])  # in time between the good ones
    assert np.isnan(fixed[4]) and fixed[0] == 0.1
    assert YAW_RATE_LIMIT_RAD_S == pytest.approx(2.0)
    lone = repaired_yaw_rate(t[:2], np.array([9.0, np.nan]), max_share=1.0)[0]
    assert np.isnan(lone).all()  # nothing good to take it from: missing


def test_a_channel_beyond_the_limit_throughout_is_left_for_the_unit_check():
    from rwhonet.data.glitches import repaired_yaw_rate

    t = np.arange(1000) * 0.1
    deg_as_rad = 20.0 * np.sin(t / 5.0)  # deg/s values declared rad/s: most beyond 2
    fixed, mask = repaired_yaw_rate(t, deg_as_rad)
    assert not mask.any() and np.array_equal(fixed, deg_as_rad)


def test_the_label_s_gyro_yaw_ignores_a_one_row_invalid_code():
    from rwhonet.features.seconds import gyro_yaw_rad

    t = 45000.0 + np.arange(601) * 0.1
    rate = 0.2 * np.sin(2 * np.pi * (t - t[0]) / 40.0)
    spiked = rate.copy()
    spiked[305] = np.radians(327.67)  # int16 full scale at 0.01 deg/s per bit
    clean, got = gyro_yaw_rad(t, rate), gyro_yaw_rad(t, spiked)
    assert np.abs(got - clean).max() < 1e-4  # rad: was 0.55 (32 deg) in that second


def test_validate_lists_a_yaw_rate_glitch_and_still_checks_the_channel():
    from rwhonet.data.drivechecks import yaw_problems
    from rwhonet.data.quality import assess
    from support.corpus import weaving_target

    params = load_params()
    drive = {k: np.asarray(v) for k, v in weaving_target(300.0).items()}
    drive[c.YAW_RATE_RAD_S] = drive[c.YAW_RATE_RAD_S].copy()
    drive[c.YAW_RATE_RAD_S][1204] = np.radians(327.67)
    segments = assess(drive, params.validate.gnss, params.validate.sample_period_s).segments
    entry = {"source_file": "V-T.csv", "columns": {}}
    problems, record = yaw_problems(entry, drive, segments, params.validate)
    assert problems == [] and record["checked"] and abs(record["gain"] - 1.0) < 0.02
    assert record["glitches"]["rows"] == 1
    assert record["glitches"]["listed"][0]["row"] == 1205
    assert record["glitches"]["listed"][0]["rad_s"] == pytest.approx(np.radians(327.67))
