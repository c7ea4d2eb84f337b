"""The per-second grid: row grouping, integration, features, scenario tags, input checks."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

from rwhonet.contracts import FEATURE_COLUMNS
from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.features.seconds import (
    anchor_rows,
    backwards_per_second,
    end_of_second,
    gnss_displacement_m,
    integrate_per_second,
    n_seconds,
    rows_of_seconds,
    scenario_per_second,
    segment_arrays,
    segment_seconds,
    span_s,
    wheel_features_rad_s,
)
from support.synthetic import build_drive, constant_speed, wavy_speed


@pytest.mark.parametrize(
    ("n_rows", "expected"), [(0, 0), (1, 0), (10, 0), (11, 1), (20, 1), (21, 2)]
)
def test_a_second_needs_eleven_rows(n_rows, expected):
    assert n_seconds(n_rows) == expected


def test_second_k_owns_rows_10k_plus_1_to_10k_plus_10():
    rows = np.arange(25)
    np.testing.assert_array_equal(rows_of_seconds(rows), [np.arange(1, 11), np.arange(11, 21)])
    np.testing.assert_array_equal(anchor_rows(2), [0, 10, 20])
    np.testing.assert_array_equal(end_of_second(rows), [10, 20])
    t = 100.05 + rows / 10.0  # segments start at any phase of the clock
    np.testing.assert_allclose(end_of_second(t), [101.05, 102.05])
    np.testing.assert_allclose(span_s(t), [1.0, 1.0])


def test_trapezoid_is_exact_for_linear_rates_even_with_jitter():
    rng = np.random.default_rng(0)
    t = np.arange(31) / 10.0 + np.concatenate([[0], rng.uniform(-0.03, 0.03, 29), [0]])
    rate = 3.0 + 2.0 * t
    exact = np.diff(3.0 * t[::10] + t[::10] ** 2)
    np.testing.assert_allclose(integrate_per_second(t, rate), exact, rtol=0, atol=1e-12)


def test_trapezoid_error_on_a_quadratic_is_h2_over_12_times_curvature():
    t = np.arange(11) / 10.0
    # Integral of t^2 over [0, 1] is 1/3; the trapezoid overshoots by (b - a) h^2 f'' / 12.
    assert integrate_per_second(t, t**2)[0] == pytest.approx(1 / 3 + 0.1**2 * 2 / 12, abs=1e-14)


def test_gnss_displacement_is_the_distance_driven_on_a_straight_road():
    profile = wavy_speed(20, 12.0, 4.0, 7.0)
    frame = build_drive(profile)
    disp = gnss_displacement_m(frame[c.LAT_DEG].to_numpy(), frame[c.LON_DEG].to_numpy())
    np.testing.assert_allclose(disp, np.diff(profile[1][::10]), rtol=0, atol=1e-6)


def test_features_are_wheel_major_rr_rl_fr_fl_oldest_first():
    n = 21
    rows = np.arange(n, dtype=float)
    wheels = [1000 + rows, 2000 + rows, 3000 + rows, 4000 + rows]  # RR, RL, FR, FL
    x = wheel_features_rad_s(wheels)
    assert x.shape == (2, 40) == (2, len(FEATURE_COLUMNS))
    np.testing.assert_array_equal(x[0, :10], 1000 + np.arange(1, 11))
    np.testing.assert_array_equal(x[1, 10:20], 2000 + np.arange(11, 21))
    np.testing.assert_array_equal(x[1, 30:], 4000 + np.arange(11, 21))


def test_segment_seconds_uses_the_canonical_wheel_columns():
    frame = build_drive(constant_speed(3, 10.0))
    for k, col in enumerate(c.FEATURE_WHEEL_ORDER):
        frame[col] = 100.0 * (k + 1)
    sec = segment_seconds(frame, "f")
    np.testing.assert_array_equal(sec.wheels_rad_s[:, ::10], [[100, 200, 300, 400]] * 3)
    assert len(sec) == 3 and sec.n_rows == 31


def test_scenario_is_the_sorted_union_of_the_rows_tags():
    tags = np.full(31, "", dtype=object)
    tags[3] = "wet"
    tags[5] = "roundabout;wet"
    tags[10] = "hard_brake"  # last row of second 0
    tags[11] = None  # missing counts as no tag
    tags[25] = "wet"
    merged = scenario_per_second(tags)
    assert merged.tolist() == ["hard_brake;roundabout;wet", "", "wet"]
    assert scenario_per_second(np.full(31, "")).tolist() == ["", "", ""]
    assert scenario_per_second(np.array(["a"] * 5)).tolist() == []


def test_tag_on_the_first_row_belongs_to_no_second():
    # Row 0 is only the starting fix of second 0; its tag is not in any second.
    tags = np.array(["tunnel"] + [""] * 10, dtype=object)
    assert scenario_per_second(tags).tolist() == [""]


def _frame(n: int = 31) -> pd.DataFrame:
    return build_drive(constant_speed((n - 1) / 10, 10.0))


def test_missing_column_is_reported_by_name():
    with pytest.raises(InputError) as err:
        segment_seconds(_frame().drop(columns=[c.OMEGA_RL]), "seg.parquet")
    (problem,) = err.value.problems
    assert (problem.file, problem.column, problem.found) == ("seg.parquet", c.OMEGA_RL, "missing")


def test_non_finite_values_and_time_reversals_are_reported_with_their_rows():
    frame = _frame()
    frame.loc[4, c.LAT_DEG] = np.nan
    frame.loc[7, c.T_S] = frame.loc[6, c.T_S]
    frame.loc[20, c.LAT_DEG] = -1.52  # lat/lon swapped: -1.52 is a valid latitude ...
    frame.loc[21, c.LAT_DEG] = 152.4  # ... this is not
    frame.loc[22, c.OMEGA_FL] = -np.inf
    with pytest.raises(InputError) as err:
        segment_seconds(frame, "seg.parquet")
    found = {(p.row, p.column) for p in err.value.problems}
    assert found == {(5, c.LAT_DEG), (8, c.T_S), (22, c.LAT_DEG), (23, c.OMEGA_FL)}  # 1-based


def test_data_that_is_not_10_hz_is_refused():
    frame = _frame()
    frame[c.T_S] = 1000.0 + np.arange(len(frame)) * 1.0  # 1 Hz
    with pytest.raises(InputError, match="10 Hz") as err:
        segment_seconds(frame, "seg.parquet")
    assert err.value.problems[0].row == 1


def test_short_segment_has_no_seconds():
    sec = segment_seconds(_frame(8), "f")
    assert len(sec) == 0 and sec.wheels_rad_s.shape == (0, 40) and len(sec.scenario) == 0


@pytest.mark.parametrize("as_series", [False, True])
def test_scenario_merge_matches_a_plain_per_second_union(as_series):
    rng = np.random.default_rng(5)
    vocabulary = np.array(["", "wet", "roundabout", "wet;roundabout", "tunnel", "hard_brake;wet"])
    tags = vocabulary[rng.integers(0, len(vocabulary), 1001)].astype(object)
    tags[rng.integers(0, 1001, 50)] = None
    expected = [
        ";".join(
            sorted({t for row in tags[10 * k + 1 : 10 * k + 11] if row for t in row.split(";")})
        )
        for k in range(100)
    ]
    values = pd.Series(tags, dtype="str") if as_series else tags
    assert scenario_per_second(values).tolist() == expected


@pytest.mark.parametrize("n_values", [6, 62, 63, 200])  # 63+: the sorted-combination path
@pytest.mark.parametrize("kind", ["numpy", "series", "arrow", "chunked", "dictionary"])
def test_scenario_merge_of_any_input_matches_a_plain_per_second_union(n_values, kind):
    rng = np.random.default_rng(n_values)
    vocabulary = np.array([""] + [f"t{k % 40};u{k}" for k in range(n_values - 1)], dtype=object)
    tags = vocabulary[rng.integers(0, n_values, 3001)]
    tags[rng.integers(0, 3001, 80)] = None
    expected = [
        ";".join(
            sorted({t for row in tags[10 * k + 1 : 10 * k + 11] if row for t in row.split(";")})
        )
        for k in range(300)
    ]
    values = {
        "numpy": tags,
        "series": pd.Series(tags, dtype="str"),
        "arrow": pa.array(tags, type=pa.string()),
        "chunked": pa.chunked_array([tags[:1234], tags[1234:]], type=pa.string()),
        # as read_segment reads it: one dictionary per row group, not the same for all
        "dictionary": pa.chunked_array(
            [pa.array(part, type=pa.string()).dictionary_encode() for part in (tags[:9], tags[9:])]
        ),
    }[kind]
    assert scenario_per_second(values).tolist() == expected


def test_gyro_yaw_is_the_rate_integrated_over_each_second_and_nan_without_a_channel():
    frame = _frame()
    t = frame[c.T_S].to_numpy()
    frame[c.YAW_RATE_RAD_S] = 0.05 + 0.01 * (t - t[0])  # a linear rate: the trapezoid is exact
    sec = segment_seconds(frame, "f")
    bounds = t[anchor_rows(len(sec))]
    expected = np.diff(0.05 * bounds + 0.005 * (bounds - t[0]) ** 2)
    np.testing.assert_allclose(sec.gyro_yaw_rad, expected, rtol=0, atol=1e-12)
    frame.loc[15, c.YAW_RATE_RAD_S] = np.nan  # a missing rate spoils its second only
    sec = segment_seconds(frame, "f")
    assert np.isnan(sec.gyro_yaw_rad[1]) and np.isfinite(np.delete(sec.gyro_yaw_rad, 1)).all()
    no_gyro = segment_seconds(frame.drop(columns=[c.YAW_RATE_RAD_S]), "f")
    assert len(no_gyro.gyro_yaw_rad) == len(sec) and np.isnan(no_gyro.gyro_yaw_rad).all()
    # the other per-second quantities do not depend on the channel
    np.testing.assert_array_equal(no_gyro.wheels_rad_s, sec.wheels_rad_s)


def test_a_logger_that_signs_its_wheel_speeds_says_which_seconds_went_backwards():
    frame = build_drive(constant_speed(6, 10.0))
    magnitudes = segment_seconds(frame, "f")
    assert not magnitudes.backwards.any()  # magnitudes never say
    signed = frame.copy()
    rows = slice(21, 41)  # the rows of seconds 2 and 3 (row 10k + 1 .. 10k + 10 is second k)
    for w in c.WHEELS:
        signed.loc[rows, w] = -signed.loc[rows, w]
    sec = segment_seconds(signed, "f")
    # each second by the sign of its net signed angle (the trapezoid's bounding rows are
    # shared with the neighbours: seconds 1 and 4 keep forwards)
    np.testing.assert_array_equal(sec.backwards, [False, False, True, True, False, False])
    # the distance stays a magnitude: every other per-second quantity is the same
    np.testing.assert_array_equal(sec.angle_rl_rad, magnitudes.angle_rl_rad)
    np.testing.assert_array_equal(sec.angle_rr_rad, magnitudes.angle_rr_rad)
    np.testing.assert_array_equal(sec.wheels_rad_s, magnitudes.wheels_rad_s)
    # the label stage's reader hands the signs on
    arrays = segment_arrays(pa.Table.from_pandas(signed, preserve_index=False))
    np.testing.assert_array_equal(segment_seconds(arrays, "f").backwards, sec.backwards)


def test_a_second_goes_backwards_by_its_rear_wheels_net_signed_angle():
    t = np.arange(11) * 0.1
    rl = np.r_[np.full(4, 1.0), np.full(7, -2.0)]  # 0.35 rad forwards, 0.6 back: net back
    assert backwards_per_second(t, rl, rl).tolist() == [True]
    assert backwards_per_second(t, np.abs(rl), np.abs(rl)).tolist() == [False]
    assert backwards_per_second(t, rl, np.full(11, 5.0)).tolist() == [False]  # the mean: forwards


# ------------------------------------------------------------ jittered stamps (issue 15)

JITTER_TOL = 1e-9  # m or rad per second: the jittered drive's seconds are the clean drive's


def _jittered(t: np.ndarray, max_s: float, seed: int = 0) -> np.ndarray:
    """The stamps a logger writes: each up to ``max_s`` off its instant, still increasing."""
    return t + np.random.default_rng(seed).uniform(-max_s, max_s, t.size)


@pytest.mark.parametrize("max_s", [0.004, 0.045])
def test_jittered_stamps_give_the_clean_drives_labels(max_s):
    """Rates are integrated over the rows' slots, not the stamps the logger wrote."""
    clean = build_drive(wavy_speed(120.0, 12.0, 5.0, 15.0, t0_s=45000.0))
    jittered = clean.assign(**{c.T_S: _jittered(clean[c.T_S].to_numpy(), max_s)})
    assert np.all(np.diff(jittered[c.T_S]) > 0)
    a, b = segment_seconds(clean), segment_seconds(jittered)
    for name in ("angle_rl_rad", "angle_rr_rad", "disp_gnss_m", "span_s", "t_s"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=0, atol=JITTER_TOL)
    # What integrating over the stamps did: every second's angle off by up to 2 jitters of
    # wheel speed (about 1.6 cm of distance at 4 ms and 12 m/s). The test can fail.
    t = jittered[c.T_S].to_numpy()
    stamped = integrate_per_second(t, jittered[c.OMEGA_RL].to_numpy())
    assert np.max(np.abs(stamped - a.angle_rl_rad)) > 100 * JITTER_TOL


@pytest.mark.parametrize("sigma_s", [0.015, 0.02])
def test_stamps_jittered_past_half_a_period_give_the_clean_drives_labels(sigma_s):
    """A bell curve's jitter: rows nearest another's slot, stamps going back; each row is
    still integrated at its own slot (rwhonet.data.timebase.grid_slots)."""
    clean = build_drive(wavy_speed(300.0, 12.0, 5.0, 15.0, t0_s=45000.0))
    t = clean[c.T_S].to_numpy()
    stamps = np.round(t + np.random.default_rng(2).normal(0.0, sigma_s, t.size), 3)
    assert (np.diff(np.rint(stamps / 0.1)) <= 0).any()  # some rows nearest another's slot
    jittered = clean.assign(**{c.T_S: stamps})
    a, b = segment_seconds(clean), segment_seconds(jittered)
    for name in ("angle_rl_rad", "angle_rr_rad", "disp_gnss_m", "span_s", "t_s"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=0, atol=JITTER_TOL)


def test_a_clean_drives_stamps_are_integrated_as_they_are():
    """Decimal stamps (and a logger's constant offset) are kept bit for bit."""
    for t0 in (45000.0, 45000.03):
        clean = build_drive(wavy_speed(30.0, 12.0, 5.0, 15.0, t0_s=t0))
        t = clean[c.T_S].to_numpy()
        sec = segment_seconds(clean)
        np.testing.assert_array_equal(sec.t_s, t[10::10])
        np.testing.assert_array_equal(
            sec.angle_rl_rad, integrate_per_second(t, clean[c.OMEGA_RL].to_numpy())
        )
