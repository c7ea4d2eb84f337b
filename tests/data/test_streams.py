"""Streams in, one grid out: the time-weighted means, the fix interpolation and its gap rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.data import canonical as c
from rwhonet.data.streams import (
    DriveStreams,
    Stream,
    grid_times,
    interpolate_fixes,
    resample,
    travelled_path,
    window_means,
)
from rwhonet.errors import InputError
from rwhonet.geo import latlon_from_offsets_deg, offsets_m

R = 0.3


def _wheels(t, v_m_s, name="wheels", **extra):
    return Stream(name, "wheels.csv", t, {w: v_m_s / R for w in c.WHEELS} | extra)


def _gnss(t, lat, lon, name="gnss"):
    return Stream(name, "gnss.csv", t, {c.LAT_DEG: lat, c.LON_DEG: lon})


def _moving(t_w, t_g, v=10.0, lat0=52.0, lon0=-1.5):
    """A drive north at v m/s: wheel speeds and fixes (small enough for a linear model)."""
    lat = lat0 + v * t_g / 111_250.0
    return DriveStreams(
        (_wheels(t_w, np.full(t_w.size, v)),), _gnss(t_g, lat, np.full(t_g.size, lon0))
    )


def test_grid_rows_are_whole_tenths_of_the_clock():
    g = grid_times(46408.655, 46408.99)
    assert list(g) == [46408.7, 46408.8, 46408.9]  # the doubles nearest each tenth


@settings(max_examples=50, deadline=None)
@given(
    a=st.floats(-5, 5),
    b=st.floats(-5, 5),
    q=st.floats(-1, 1),
    seed=st.integers(0, 1000),
)
def test_window_mean_is_exact_for_piecewise_linear_signals(a, b, q, seed):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.02, 400))
    v = a + b * t + q * np.sin(t)  # sampled: the mean is that of the linear interpolant
    lo = np.sort(rng.uniform(t[0], t[-1] - 0.1, 30))
    hi = lo + 0.1
    means, ok = window_means(t, v[None, :], lo, hi, max_gap_s=1.0)
    dense = np.linspace(0, 1, 20001)
    for k in range(lo.size):
        x = lo[k] + dense * 0.1
        want = np.trapezoid(np.interp(x, t, v), x) / 0.1
        assert means[0, k] == pytest.approx(want, abs=1e-7)
    assert ok.all()


def test_a_ramp_averages_to_its_value_at_the_window_centre():
    t = np.arange(0.0, 10.0, 0.01)
    means, ok = window_means(t, (3.0 + 2.0 * t)[None, :], np.array([4.95]), np.array([5.05]), 0.2)
    assert ok[0] and means[0, 0] == pytest.approx(13.0, abs=1e-12)  # no half-period lag


def test_windows_beyond_the_samples_or_over_a_gap_are_invalid():
    t = np.r_[np.arange(0.0, 5.0, 0.01), np.arange(5.5, 10.0, 0.01)]  # 0.51 s hole
    lo = np.array([-0.01, 2.0, 4.95, 5.2, 9.95])
    _, ok = window_means(t, np.ones((1, t.size)), lo, lo + 0.1, 0.2)
    assert list(ok) == [False, True, False, False, False]


def test_fixes_are_interpolated_only_between_close_fixes_and_never_extrapolated():
    t = np.array([0.0, 1.0, 2.0, 5.0, 6.0])
    lat = np.array([0.0, 1.0, 2.0, 5.0, 6.0])
    at = np.array([-0.1, 0.0, 0.5, 2.0, 3.0, 5.5, 6.0, 6.1])
    out, ok = interpolate_fixes(t, {c.LAT_DEG: lat, c.LON_DEG: lat}, at, max_gap_s=1.5)
    assert list(ok) == [False, True, True, True, False, True, True, False]
    np.testing.assert_allclose(out[c.LAT_DEG][ok], [0.0, 0.5, 2.0, 5.5, 6.0])


def test_fixes_across_the_antimeridian_interpolate_the_short_way():
    t = np.array([0.0, 1.0])
    lon = np.array([179.9999, -179.9999])
    out, ok = interpolate_fixes(
        t, {c.LAT_DEG: np.zeros(2), c.LON_DEG: lon}, np.array([0.25, 0.5]), 1.5
    )
    assert ok.all()
    np.testing.assert_allclose(out[c.LON_DEG], [179.99995, -180.0], atol=1e-9)


def _circle(t, radius_m=40.0, v=12.0, lat0=-33.9, lon0=151.2):
    """A car on a circle (counter-clockwise, starting east-bound at the origin): lat, lon."""
    a = v * t / radius_m
    east, north = radius_m * np.sin(a), radius_m * (1.0 - np.cos(a))
    return latlon_from_offsets_deg(lat0, lon0, east, north)


def _placed_m(out, truth_lat, truth_lon, lat0=-33.9, lon0=151.2):
    e, n = offsets_m(lat0, lon0, out[c.LAT_DEG], out[c.LON_DEG])
    te, tn = offsets_m(lat0, lon0, truth_lat, truth_lon)
    return np.hypot(e - te, n - tn)


def test_between_1_hz_fixes_the_wheels_and_gyro_place_a_position_on_the_arc_not_the_chord():
    # 12 m/s round a 40 m circle, fixes each second half a second off the rows: the chord's
    # middle lies a sagitta, r (1 - cos(v T / 2r)), ~0.45 m, inside the arc.
    t_w = np.arange(0.0, 20.0, 0.01)
    omega = np.full(t_w.size, 12.0 / R)
    t_g = np.arange(0.5, 20.0, 1.0)
    lat, lon = _circle(t_g)
    at = np.arange(1.0, 19.0, 0.1)
    truth = _circle(at)
    fixes = {c.LAT_DEG: lat, c.LON_DEG: lon}
    linear, ok = interpolate_fixes(t_g, fixes, at, 1.5)
    sagitta = 40.0 * (1.0 - np.cos(12.0 / 80.0))
    assert ok.all() and _placed_m(linear, *truth).max() == pytest.approx(sagitta, rel=0.02)
    # the wheels alone: the chord, walked by the distance rolled (the same, at a constant speed)
    straight = interpolate_fixes(t_g, fixes, at, 1.5, travelled_path(t_w, omega))[0]
    np.testing.assert_allclose(_placed_m(straight, *truth), _placed_m(linear, *truth), atol=1e-3)
    # turned by the gyro: on the arc, whatever the tyre radius
    yaw = np.full(t_w.size, 12.0 / 40.0)
    on_arc = interpolate_fixes(
        t_g, fixes, at, 1.5, travelled_path(t_w, 1.07 * omega, 0.2, t_w, yaw)
    )
    assert _placed_m(on_arc[0], *truth).max() < 1e-5  # 2 µm: the 0.01 s steps of the sum
    # a gyro bias b bends the L = 12 m between fixes T = 1 s apart by L b T / 8: 2.6 cm at 1 deg/s
    biased = travelled_path(t_w, omega, 0.2, t_w, yaw + np.radians(1.0))
    bent = _placed_m(interpolate_fixes(t_g, fixes, at, 1.5, biased)[0], *truth).max()
    assert bent == pytest.approx(12.0 * np.radians(1.0) / 8.0, rel=0.02)


def test_along_the_path_an_accelerating_car_is_placed_where_its_wheels_say():
    # From rest at 2 m/s^2 north, fixes at 1 Hz: in time the middle is a T^2 / 8 = 0.25 m
    # ahead; along the wheels' distance, exact.
    t_w = np.arange(0.0, 10.0, 0.01)
    t_g = np.arange(0.5, 10.0, 1.0)
    lat, lon = latlon_from_offsets_deg(52.0, -1.5, 0.0 * t_g, t_g**2)
    at = np.arange(1.0, 9.0, 0.1)
    truth = latlon_from_offsets_deg(52.0, -1.5, 0.0 * at, at**2)
    fixes = {c.LAT_DEG: lat, c.LON_DEG: lon}
    linear = interpolate_fixes(t_g, fixes, at, 1.5)[0]
    along = interpolate_fixes(t_g, fixes, at, 1.5, travelled_path(t_w, 2.0 * t_w / R))[0]
    err = lambda o: _placed_m(o, *truth, 52.0, -1.5)  # noqa: E731
    assert err(linear).max() == pytest.approx(0.25, rel=0.01)
    assert err(along).max() < 1e-4


def test_without_an_unbroken_path_or_with_the_car_at_rest_positions_go_linearly_in_time():
    t_g = np.arange(0.5, 10.0, 1.0)
    lat, lon = latlon_from_offsets_deg(52.0, -1.5, 0.0 * t_g, t_g**2)
    fixes = {c.LAT_DEG: lat, c.LON_DEG: lon}
    at = np.arange(1.0, 9.0, 0.1)
    linear = interpolate_fixes(t_g, fixes, at, 1.5)[0]
    t_w = np.arange(0.0, 10.0, 0.01)
    # the wheels pause 0.5 s within 4.5-5.5 s: that second goes in time, the others along
    gap = (t_w < 4.8) | (t_w > 5.3)
    broken = interpolate_fixes(t_g, fixes, at, 1.5, travelled_path(t_w[gap], 2.0 * t_w[gap] / R))
    inside = (at > 4.5) & (at < 5.5)
    np.testing.assert_array_equal(broken[0][c.LAT_DEG][inside], linear[c.LAT_DEG][inside])
    assert np.abs(broken[0][c.LAT_DEG][~inside] - linear[c.LAT_DEG][~inside]).max() > 1e-7
    # wheels that hardly turn (0.5 rad a second) say nothing of where the car is
    still = interpolate_fixes(t_g, fixes, at, 1.5, travelled_path(t_w, np.full(t_w.size, 0.5)))
    np.testing.assert_array_equal(still[0][c.LAT_DEG], linear[c.LAT_DEG])
    # nor do wheel speeds that end before the fixes do
    short = interpolate_fixes(t_g, fixes, at, 1.5, travelled_path(t_w[:300], 2.0 * t_w[:300] / R))
    np.testing.assert_array_equal(short[0][c.LAT_DEG][at > 3.5], linear[c.LAT_DEG][at > 3.5])


def test_along_the_path_across_the_antimeridian():
    t_w = np.arange(0.0, 4.0, 0.01)
    t_g = np.array([0.5, 1.5, 2.5, 3.5])
    lat, lon = latlon_from_offsets_deg(-17.0, 179.99995, 12.0 * t_g - 18.0, 0.0 * t_g)
    assert lon[0] > 179.0 and lon[-1] < -179.0
    at = np.arange(1.0, 3.5, 0.1)
    out, ok = interpolate_fixes(
        t_g, {c.LAT_DEG: lat, c.LON_DEG: lon}, at, 1.5, travelled_path(t_w, np.full(400, 40.0))
    )
    truth = latlon_from_offsets_deg(-17.0, 179.99995, 12.0 * at - 18.0, 0.0 * at)
    assert ok.all() and _placed_m(out, *truth, -17.0, 179.99995).max() < 1e-4


def test_a_path_sampled_once_gives_its_points_and_rolled_angles():
    """``TravelledPath.sample`` (one search for both) is the path's point as calling it
    gives, and differences of its rolled angle are ``rolled``'s, inside the samples, at
    them, and held beyond either end."""
    rng = np.random.default_rng(3)
    t_w = np.cumsum(rng.uniform(0.008, 0.012, 3000))
    omega = 30.0 + 5.0 * np.sin(t_w)
    path = travelled_path(t_w, omega, 0.2, t_w, 0.2 * np.cos(0.3 * t_w))
    x = np.concatenate([rng.uniform(t_w[0] - 1.0, t_w[-1] + 1.0, 500), t_w[[0, 7, -1]]])
    z, cum = path.sample(x)
    np.testing.assert_allclose(z, path(x)[0], rtol=0, atol=1e-12)
    a, b = x[:250], x[250:500]
    np.testing.assert_allclose(cum[250:500] - cum[:250], path.rolled(a, b)[0], atol=1e-9)


def test_resample_places_1_hz_fixes_along_the_gyro_s_turn():
    t_w = np.arange(0.0, 30.0, 0.01) + 0.003
    t_g = np.arange(0.5, 30.0, 1.0)
    lat, lon = _circle(t_g)
    drive = DriveStreams(
        (_wheels(t_w, np.full(t_w.size, 12.0)),),
        _gnss(t_g, lat, lon),
        (Stream("gyro", "gyro.csv", t_w, {c.YAW_RATE_RAD_S: np.full(t_w.size, 0.3)}),),
    )
    d = resample(drive, max_fix_gap_s=1.5).drive.columns
    truth = _circle(d[c.T_S])
    assert _placed_m(d, *truth).max() < 1e-4
    plain = resample(DriveStreams(drive.wheels, drive.gnss), max_fix_gap_s=1.5).drive.columns
    assert _placed_m(plain, *truth).max() > 0.4


def test_resample_gives_the_canonical_drive_on_whole_tenths():
    t_w = np.arange(0.0, 30.0, 0.01) + 0.003
    t_g = np.arange(0.05, 30.0, 0.2)
    res = resample(_moving(t_w, t_g))
    d = res.drive
    assert d.header_match == "streams" and set(c.REQUIRED) <= set(d.columns)
    t = d.columns[c.T_S]
    assert t[0] == pytest.approx(0.1) and t[-1] == pytest.approx(29.8)  # last fix 29.85 s
    np.testing.assert_allclose(np.diff(t), 0.1, atol=1e-9)
    np.testing.assert_allclose(np.round(t * 10), t * 10, atol=1e-6)
    np.testing.assert_allclose(d.columns[c.OMEGA_RL], 10.0 / R)
    np.testing.assert_allclose(d.columns[c.LAT_DEG], 52.0 + 10.0 * t / 111_250.0, atol=1e-12)
    assert res.n_input_rows == t_w.size + t_g.size


def test_a_fix_gap_leaves_a_hole_longer_than_validates_gap():
    t_w = np.arange(0.0, 40.0, 0.01)
    t_g = np.r_[np.arange(0.0, 10.0, 0.1), np.arange(10.6, 40.0, 0.1)]  # 0.7 s without a fix
    t = resample(_moving(t_w, t_g), max_fix_gap_s=0.25).drive.columns[c.T_S]
    steps = np.round(np.diff(t), 6)
    assert set(steps) == {0.1, steps.max()} and steps.max() > 0.5
    hole = np.flatnonzero(steps > 0.1)[0]
    assert t[hole] <= 9.9 and t[hole + 1] >= 10.6  # no row inside the fix gap


def test_a_short_wheel_gap_is_widened_so_validate_cuts_it_as_a_gap():
    t_w = np.r_[np.arange(0.0, 10.0, 0.01), np.arange(10.25, 40.0, 0.01)]  # 0.26 s hole
    t_g = np.arange(0.0, 40.0, 0.1)
    t = resample(_moving(t_w, t_g), max_wheel_gap_s=0.2, split_gap_s=0.5).drive.columns[c.T_S]
    steps = np.diff(t)
    assert steps.max() > 0.5 and np.all((np.abs(steps - 0.1) < 1e-6) | (steps > 0.5))


def test_optional_channels_are_averaged_and_nan_where_missing():
    t_w = np.arange(0.0, 30.0, 0.01)
    t_y = np.arange(5.0, 20.0, 0.01)
    streams = _moving(t_w, np.arange(0.0, 30.0, 0.1))
    yaw = Stream("gyro", "imu.csv", t_y, {c.YAW_RATE_RAD_S: np.full(t_y.size, 0.2)})
    d = resample(DriveStreams(streams.wheels, streams.gnss, (yaw,))).drive.columns
    t, yaw_rate = d[c.T_S], d[c.YAW_RATE_RAD_S]
    inside = (t >= 5.1) & (t <= 19.9)
    np.testing.assert_allclose(yaw_rate[inside], 0.2)
    assert np.isnan(yaw_rate[~inside]).all() and len(t) > inside.sum()


def test_missing_values_are_left_out_and_said():
    t_w = np.arange(0.0, 30.0, 0.01)
    streams = _moving(t_w, np.arange(0.0, 30.0, 0.1))
    streams.gnss.channels[c.LAT_DEG][50] = np.nan
    res = resample(streams)
    assert any("1 sample(s) without a value" in n for n in res.drive.notes)


def test_streams_on_different_clocks_are_refused():
    t_w = np.arange(0.0, 30.0, 0.01)
    t_g = np.arange(1.5e9, 1.5e9 + 30, 0.1)  # GNSS in UNIX time, wheels on a boot clock
    streams = DriveStreams(
        (_wheels(t_w, np.full(t_w.size, 10.0)),), _gnss(t_g, t_g * 0 + 52.0, t_g * 0)
    )
    with pytest.raises(InputError) as err:
        resample(streams)
    (p,) = err.value.problems
    assert "no common stretch" in p.found and "one clock" in p.expected


def test_bad_streams_are_refused_with_file_stream_channel_row_and_time():
    t_w = np.arange(0.0, 30.0, 0.01)
    t_w[100] = t_w[99]  # a repeated stamp
    t_g = np.arange(0.0, 30.0, 0.1)
    lat = np.full(t_g.size, 52.0)
    lat[7] = 95.0
    streams = DriveStreams((_wheels(t_w, np.full(t_w.size, 10.0)),), _gnss(t_g, lat, lat * 0))
    with pytest.raises(InputError) as err:
        resample(streams)
    found = {(p.file, p.row, p.column) for p in err.value.problems}
    assert ("wheels.csv [wheels]", 101, "time") in found  # a stream without a time name
    assert ("gnss.csv [gnss]", 8, c.LAT_DEG) in found
    text = str(err.value)
    assert "step +0 s" in text and "95.0 at t = 0.7" in text


def test_a_wheel_missing_or_twice_is_refused():
    t = np.arange(0.0, 10.0, 0.01)
    front = Stream("front", "f.csv", t, {c.OMEGA_FL: t, c.OMEGA_FR: t})
    rear = Stream("rear", "r.csv", t, {c.OMEGA_RL: t, c.OMEGA_FR: t})
    gnss = _gnss(t, t * 0 + 52, t * 0)
    with pytest.raises(InputError) as err:
        resample(DriveStreams((front, rear), gnss))
    assert "in two streams" in str(err.value) or "missing" in str(err.value)


def test_a_raw_sample_glitch_flags_the_rows_that_used_it():
    t_w = np.arange(0.0, 40.0, 0.01)
    streams = _moving(t_w, np.arange(0.0, 40.0, 0.1))
    streams.wheels[0].channels[c.OMEGA_RR][2000] *= 10.0  # t = 20.00 s, one 100 Hz sample
    res = resample(streams, nominal_radius_m=R)
    t = res.drive.columns[c.T_S]
    # Only the row whose window overlaps the steps 19.99-20.01 s used that sample.
    assert list(np.round(t[res.glitch], 1)) == [20.0]
    assert res.glitch_samples == [("wheels.csv [wheels]", 2001, 20.0, c.OMEGA_RR)]
    # per wheel: only the glitched wheel's mean used it (what predict repairs)
    assert res.glitch_wheels[c.OMEGA_RR].tolist() == res.glitch.tolist()
    assert not any(res.glitch_wheels[w].any() for w in c.WHEELS if w != c.OMEGA_RR)


def test_a_wheel_stream_without_values_is_refused():
    t_w = np.arange(0.0, 30.0, 0.01)
    streams = _moving(t_w, np.arange(0.0, 30.0, 0.1))
    streams.wheels[0].channels[c.OMEGA_FL][:] = np.nan
    with pytest.raises(InputError) as err:
        resample(streams)
    (p,) = err.value.problems
    assert p.file == "wheels.csv [wheels]" and p.column == c.OMEGA_FL
    assert p.found == f"0 of {t_w.size}; blank or NaN cells: '{c.OMEGA_FL}' in {t_w.size}"


@pytest.mark.parametrize(
    ("t_w", "steps"),
    [
        (np.arange(0.0, 60.0, 0.25), "steps of 0.25 s"),  # wheels logged at 4 Hz
        (np.arange(0.0, 60.0, 0.2) + np.resize([0.0, 0.02, -0.02], 300), "steps of 0.16-0.22 s"),
        (np.arange(0.0, 60_000.0, 20.0), "steps of 20 s"),  # 50 Hz stamped in ms, read as s
    ],
)
def test_a_wheel_stream_too_slow_for_the_grid_is_refused_naming_its_steps(t_w, steps):
    """Every row would span a step longer than max_wheel_gap_s: refused (not an empty or
    nearly empty grid), naming the stream, its wheel channels and its steps."""
    t_g = np.arange(0.0, t_w[-1], 0.2 if t_w[-1] < 100 else 200.0)
    with pytest.raises(InputError) as err:
        resample(_moving(t_w, t_g))
    (p,) = err.value.problems
    assert p.file == "wheels.csv [wheels]" and p.column == ", ".join(c.WHEELS)
    assert "max_wheel_gap_s" in p.expected and steps in p.found
    assert "10 Hz or faster" in p.fix and "ms read as s" in p.fix


def test_a_wheel_stream_with_one_long_pause_is_resampled_with_a_gap():
    """A stream that stops for a minute (the logger paused) is no slow stream."""
    t_w = np.r_[np.arange(0.0, 60.0, 0.01), np.arange(120.0, 180.0, 0.01)]
    t = resample(_moving(t_w, np.arange(0.0, 180.0, 0.1))).drive.columns[c.T_S]
    assert t[0] < 1.0 and t[-1] > 179.0 and np.diff(t).max() > 60.0


def test_streams_without_a_common_row_are_refused():
    """Wheels and fixes overlap in time, but no row has both within their gap limits."""
    t_w = np.arange(0.0, 30.0, 0.01)
    t_g = np.arange(0.0, 30.0, 5.0)
    with pytest.raises(InputError) as err:
        resample(_moving(t_w, t_g), max_fix_gap_s=1.0)
    (p,) = err.value.problems
    assert "wheels.csv" in p.file and "gnss.csv" in p.file and p.found.startswith("none of")


def test_a_gyro_on_another_clock_is_refused_naming_both_spans():
    """The imu's time in ms while the wheels and fixes are in s: not dropped in silence.
    Where the two clocks still overlap (both from 0), no row spans short steps of it."""
    t_w = 5000.0 + np.arange(0.0, 30.0, 0.01)
    streams = _moving(t_w, 5000.0 + np.arange(0.0, 30.0, 0.1))
    t_y = (5000.0 + np.arange(0.0, 30.0, 0.01)) * 1000.0
    yaw = Stream("gyro", "imu.csv", t_y, {c.YAW_RATE_RAD_S: np.full(t_y.size, 0.2)})
    with pytest.raises(InputError) as err:
        resample(DriveStreams(streams.wheels, streams.gnss, (yaw,)))
    (p,) = err.value.problems
    assert (p.file, p.column) == ("imu.csv [gyro]", "time") and "one clock" in p.expected
    assert "imu.csv [gyro] 5e+06-5.02999e+06 s" in p.found
    assert "wheels.csv [wheels] 5000-5029.99 s" in p.found
    streams = _moving(t_w - 5000.0, np.arange(0.0, 30.0, 0.1))
    yaw = Stream("gyro", "imu.csv", t_y - 5e6, {c.YAW_RATE_RAD_S: np.full(t_y.size, 0.2)})
    with pytest.raises(InputError) as err:
        resample(DriveStreams(streams.wheels, streams.gnss, (yaw,)))
    (p,) = err.value.problems
    assert (p.file, p.column) == ("imu.csv [gyro]", c.YAW_RATE_RAD_S)
    assert "steps of 10 s" in p.found and "ms read as s" in p.fix


def test_without_require_fix_rows_in_a_fix_gap_are_kept_without_a_position():
    """predict's resampling: a GNSS outage of 10 s keeps its wheel rows, lat/lon NaN there;
    the pipeline's (the default) leaves them out for validate to cut as a gap."""
    t_w = np.arange(0.0, 40.0, 0.01)
    t_g = np.r_[np.arange(0.0, 15.0, 0.1), np.arange(25.0, 40.0, 0.1)]
    kept = resample(_moving(t_w, t_g), require_fix=False)
    d = kept.drive.columns
    np.testing.assert_allclose(np.diff(d[c.T_S]), 0.1, atol=1e-9)  # no row left out
    gap = (d[c.T_S] > 14.95) & (d[c.T_S] < 25.0)
    assert np.isnan(d[c.LAT_DEG][gap]).all() and np.isnan(d[c.LON_DEG][gap]).all()
    assert np.isfinite(d[c.LAT_DEG][~gap]).all() and np.isfinite(d[c.OMEGA_RL]).all()
    assert kept.lost == (
        f"gnss.csv [gnss]: {gap.sum()} of {gap.size} grid rows have the wheel speeds but no "
        "fix (no two fixes at most 0.25 s apart around them): kept without a position",
    )
    pipeline = resample(_moving(t_w, t_g)).drive.columns
    assert np.isfinite(pipeline[c.LAT_DEG]).all() and pipeline[c.T_S].size < d[c.T_S].size


def test_a_stream_running_on_beyond_the_others_is_said():
    """Wheel speeds that stop 20 s before the fixes: the drive is cut to their common
    stretch, and a note says so (the manifest's, and predict's stderr)."""
    res = resample(_moving(np.arange(0.0, 40.0, 0.01), np.arange(0.0, 60.0, 0.1)))
    assert res.drive.columns[c.T_S][-1] == pytest.approx(39.9)
    (note,) = res.lost
    assert note == (
        "the drive is cut to 0-39.99 s, where the wheel speeds and the fixes all have samples; "
        "beyond it: gnss.csv [gnss] 0-59.9 s"
    )
    assert note in res.drive.notes


@settings(max_examples=300, deadline=None)
@given(
    keep=st.lists(st.booleans(), min_size=1, max_size=80),
    split_gap_s=st.floats(0.05, 2.5),
)
def test_holes_widen_as_a_maximum_filter_over_them_would(keep, split_gap_s):
    # _widen_holes takes glitches.running_max of the holes where it used scipy.ndimage's
    # maximum_filter1d, whose import cost predict 0.3 s: the same rows either way
    import math

    from scipy.ndimage import maximum_filter1d

    from rwhonet.data.streams import _widen_holes

    k = np.array(keep)
    need = math.floor(split_gap_s / 0.1 + 1e-9)
    d = max(math.ceil((need - 1) / 2), 0)
    if d == 0 or k.all():
        expected = k
    else:
        hole = maximum_filter1d((~k).astype(np.uint8), size=2 * d + 1, mode="constant")
        expected = ~hole.astype(bool)
    np.testing.assert_array_equal(_widen_holes(k, split_gap_s, 0.1), expected)


def test_a_glitched_sample_is_named_by_its_row_after_samples_without_a_value():
    """Samples without a value are left out before the glitch screen; the glitched sample
    is still named by its own row (it was named by its place among the samples left)."""
    t_w = np.arange(0.0, 40.0, 0.01)
    streams = _moving(t_w, np.arange(0.0, 40.0, 0.1))
    streams.wheels[0].channels[c.OMEGA_FL][[500, 900]] = np.nan  # two CAN frames missed
    streams.wheels[0].channels[c.OMEGA_RR][2000] *= 10.0
    res = resample(streams, nominal_radius_m=R)
    assert res.glitch_samples == [("wheels.csv [wheels]", 2001, 20.0, c.OMEGA_RR)]
