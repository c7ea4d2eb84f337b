"""The fixes' lag against the wheel speeds (rwhonet.data.fixlag): found from the wheels,
told from tyre slip, and applied only as ``data.gnss_lag`` says."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rwhonet.config import ConfigError, load_params
from rwhonet.data import canonical as c
from rwhonet.data import fixlag
from rwhonet.data.fixlag import MIN_PAIRS, fix_lag, lagged_times
from rwhonet.data.streams import travelled_path
from rwhonet.errors import InputError
from rwhonet.geo import latlon_from_offsets_deg

RADIUS_M = 0.3
LAT0, LON0 = 52.4, -1.5


def _drive(
    lag_s: float,
    duration_s: float = 600.0,
    fix_hz: float = 10.0,
    slip_per_m_s2: tuple[float, float] = (0.0, 0.0),
    speed=None,
    wet_after_s: float | None = None,
    origin: tuple[float, float] = (LAT0, LON0),
):
    """A straight drive north-east: speed ``10 + 4 sin(2 pi t / 20) + 2 sin(2 pi t / 7)``
    m/s (or ``speed(t)``), wheels at 100 Hz that over-read by ``slip x a`` (the first
    figure speeding up, the second slowing), fixes every ``1 / fix_hz`` s stamped
    ``lag_s`` late; from ``wet_after_s`` on, the slip doubled (a wet road); starting at
    ``origin`` (lat, lon). Returns
    ``(stamps, lat, lon, path)``."""
    t = np.arange(0.0, duration_s + 1e-9, 0.001)
    v = (
        10.0 + 4.0 * np.sin(2 * np.pi * t / 20.0) + 2.0 * np.sin(2 * np.pi * t / 7.0)
        if speed is None
        else speed(t)
    )
    a = np.gradient(v, t)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    up, down = slip_per_m_s2
    slip = np.where(a > 0, up * a, down * a)  # the wheel reads v (1 + slip)
    if wet_after_s is not None:
        slip = np.where(t >= wet_after_s, 2.0 * slip, slip)
    t_w = np.arange(0.0, duration_s + 1e-9, 0.01)
    omega = np.interp(t_w, t, v * (1.0 + slip)) / RADIUS_M
    path = travelled_path(t_w, [omega] * 4)
    true = np.arange(0.5, duration_s - 0.5, 1.0 / fix_hz)
    dist = np.interp(true, t, x)
    lat, lon = latlon_from_offsets_deg(*origin, dist / np.sqrt(2), dist / np.sqrt(2))
    return true + lag_s, lat, lon, path


@pytest.mark.parametrize("lag_s", [0.085, -0.04, 0.25])
@pytest.mark.parametrize("fix_hz", [1.0, 10.0])
def test_a_known_lag_is_found_from_the_wheels(lag_s, fix_hz):
    stamps, lat, lon, path = _drive(lag_s, fix_hz=fix_hz)
    found = fix_lag(stamps, lat, lon, path, "gnss.csv")
    assert found.lag_s == pytest.approx(lag_s, abs=0.002)
    assert found.se_s < 0.002 and found.clear
    assert found.finding.startswith("gnss.csv: the distance between fixes 1 s apart")
    assert f"{abs(lag_s) * 1000:.0f} ± " in found.finding


@pytest.mark.parametrize("centre", [-0.033, 0.0, 0.0271, 0.044, 0.049])
@pytest.mark.parametrize("start", [0, 5, 10])
def test_the_jackknife_s_descent_finds_the_whole_profile_s_vertex(centre, start):
    """``_descend`` computes a profile only downhill from another's best point, and its
    vertex is the whole grid's wherever the profile has one minimum, at the grid's edge
    too; each point computed once."""
    grid = np.arange(-0.05, 0.05 + 1e-9, 0.01)
    profile = 1e4 * (grid - centre) ** 2 + 3.0
    other = np.full(grid.size, 10.0)
    other[start] = 0.0
    asked: list[int] = []

    def cost_at(g: int) -> float:
        asked.append(g)
        return float(profile[g])

    costs = fixlag._descend(cost_at, other)
    assert fixlag._vertex(grid, costs) == fixlag._vertex(grid, profile)
    assert len(asked) == len(set(asked)) and len(asked) <= grid.size


def test_a_long_drive_s_coarse_search_on_every_kth_pair_gives_the_full_search_s_lag(
    monkeypatch,
):
    """The coarse search only places the fine grid: thinned (a long drive's) or not, the
    lag and its standard error are the same."""
    stamps, lat, lon, path = _drive(0.085)  # 1,196 pairs: every 5th in the coarse search
    monkeypatch.setattr(fixlag, "COARSE_PAIRS", 200)
    thinned = fix_lag(stamps, lat, lon, path)
    monkeypatch.setattr(fixlag, "COARSE_PAIRS", 10**9)  # every pair
    full = fix_lag(stamps, lat, lon, path)
    assert thinned.lag_s == pytest.approx(full.lag_s, abs=1e-12)
    assert thinned.se_s == pytest.approx(full.se_s, abs=1e-12)


def test_the_lag_is_the_same_anywhere_on_earth():
    """The pairs' distances are each pair's own (no plane about the first fix): a drive
    across the antimeridian, or at 69.6 N, gives Coventry's lag."""
    here = fix_lag(*_drive(0.085))
    for origin in ((-16.43, 179.97), (69.65, 18.96)):
        stamps, lat, lon, path = _drive(0.085, origin=origin)
        assert origin[1] < 100 or ((lon > 0).any() and (lon < 0).any())  # crosses 180
        assert fix_lag(stamps, lat, lon, path).lag_s == pytest.approx(here.lag_s, abs=1e-5)


def test_tyre_slip_is_not_taken_for_a_lag():
    """Wheels over-reading by 0.4 % per m/s^2 speeding up and under-reading by 0.3 % per
    m/s^2 slowing (a front-driven car on dry asphalt, the simulator's slip stiffness)
    shift the distance like a lag of ``slip x v``, 40 ms at 10 m/s; the fit's slip terms
    take it, and the lag stays at the stamps."""
    stamps, lat, lon, path = _drive(0.0, slip_per_m_s2=(0.004, 0.003))
    found = fix_lag(stamps, lat, lon, path)
    assert abs(found.lag_s) < 0.002 and not found.clear
    up, down = re.search(r"wheel slip (\S+) / (\S+) % per m/s\^2", found.finding).groups()
    assert float(up) == pytest.approx(0.40, abs=0.03)
    assert float(down) == pytest.approx(0.30, abs=0.03)
    stamps, lat, lon, path = _drive(0.06, slip_per_m_s2=(0.004, 0.003))
    assert fix_lag(stamps, lat, lon, path).lag_s == pytest.approx(0.06, abs=0.002)


def test_slip_that_changes_along_the_drive_widens_the_standard_error():
    """One slip figure each way cannot fit a drive whose second half is wet (its slip
    doubled): the misfit left biases the lag, which the noise alone would call certain;
    the jackknife over stretches of the drive sees the halves disagree."""
    stamps, lat, lon, path = _drive(0.0, slip_per_m_s2=(0.004, 0.003), wet_after_s=300.0)
    found = fix_lag(stamps, lat, lon, path)
    assert abs(found.lag_s) > 0.002  # biased
    assert abs(found.lag_s) < 2.0 * found.se_s and not found.clear


def test_a_steady_speed_tells_no_lag():
    stamps, lat, lon, path = _drive(0.1, speed=lambda t: np.full(t.size, 12.0))
    found = fix_lag(stamps, lat, lon, path, "gnss.csv")
    assert not found.clear and found.se_s > 0.1
    assert found.finding.startswith("gnss.csv: the speed changes too little between fixes")
    times, note, moved, _ = lagged_times(stamps, lat, lon, path, "auto", "gnss.csv")
    assert not moved and np.array_equal(times, stamps) and "stamps kept" in note


def test_too_few_moving_seconds_say_nothing():
    stamps, lat, lon, path = _drive(0.1, duration_s=MIN_PAIRS - 5.0)
    found = fix_lag(stamps, lat, lon, path)
    assert found.finding is None and not found.clear
    assert lagged_times(stamps, lat, lon, path, "auto")[1:] == (None, False, False)


@pytest.mark.parametrize(
    ("offset_s", "known"),
    [
        (3.0, None),
        # a leap second: 1 s, the latency search's edge (before stop 78 said there and kept)
        (1.0, "a leap second: UTC by a leap-second count one out of date"),
        (-1.0, "a leap second: UTC by a leap-second count one out of date"),
        (0.98, "a leap second: UTC by a leap-second count one out of date"),
        (18.0, "GPS time runs 18 s ahead of UTC since 2017"),
        (-14.0, "BeiDou time runs 14 s behind GPS time"),
        (37.0, "TAI runs 37 s ahead of UTC since 2017"),
    ],
)
def test_fixes_stamped_by_another_clock_are_found_refused_or_moved(offset_s, known):
    """Seconds off the wheels' clock (GPS time against UTC, a logger's clock set by hand):
    found by the wide search to a few ms; report refuses the drive with the setting that
    moves them, auto and the user's figure move them."""
    stamps, lat, lon, path = _drive(offset_s)
    found = fix_lag(stamps, lat, lon, path, "gnss.csv")
    assert found.two_clocks and found.clear
    assert found.lag_s == pytest.approx(offset_s, abs=0.005) and found.se_s < 0.01
    assert "stamped by two clocks" in found.finding
    assert (known in found.finding) if known else "?)" not in found.finding
    with pytest.raises(InputError) as err:
        lagged_times(stamps, lat, lon, path, "report", "gnss.csv")
    (problem,) = err.value.problems
    assert problem.file == "gnss.csv" and "stamped by one clock" in problem.expected
    assert f"set data.gnss_lag: {offset_s:.2f}" in problem.fix  # to the ms: 18.00x
    times, note, moved, two_clocks = lagged_times(stamps, lat, lon, path, "auto", "gnss.csv")
    assert moved and two_clocks and np.allclose(times, stamps - offset_s, atol=0.005)
    assert note.endswith("onto the wheels' clock (data.gnss_lag = auto)")
    times, _, moved, two_clocks = lagged_times(stamps, lat, lon, path, offset_s, "gnss.csv")
    assert moved and two_clocks and np.array_equal(times, stamps - offset_s)


def test_a_lag_beyond_the_wide_search_is_a_clock_problem_not_moved():
    stamps, lat, lon, path = _drive(75.0, duration_s=900.0)
    found = fix_lag(stamps, lat, lon, path, "gnss.csv")
    assert not found.clear and not found.two_clocks
    assert "edge of the ±1 s searched" in found.finding
    times, note, moved, _ = lagged_times(stamps, lat, lon, path, "auto", "gnss.csv")
    assert not moved and np.array_equal(times, stamps)
    assert "one clock?" in note and note.endswith("stamps kept")


def test_a_steady_drive_on_one_clock_is_not_taken_for_two():
    """The wide search runs where the latency's cannot place a lag (a steady speed): it
    finds no two clocks in a drive on one."""
    stamps, lat, lon, path = _drive(0.0, speed=lambda t: np.full(t.size, 12.0))
    found = fix_lag(stamps, lat, lon, path)
    assert not found.two_clocks and not found.clear


def test_the_modes_report_move_or_take_the_users_figure():
    stamps, lat, lon, path = _drive(0.085)
    times, note, moved, _ = lagged_times(stamps, lat, lon, path, "report", "gnss.csv")
    assert not moved and np.array_equal(times, stamps)
    assert "stamps kept (data.gnss_lag = report; auto would move the fixes by -85 ms" in note
    times, note, moved, two_clocks = lagged_times(stamps, lat, lon, path, "auto", "gnss.csv")
    assert moved and not two_clocks and np.allclose(times, stamps - 0.085, atol=0.002)
    assert note.endswith("fixes moved by -85 ms onto the wheels' clock (data.gnss_lag = auto)")
    times, note, moved, two_clocks = lagged_times(stamps, lat, lon, path, 0.1, "gnss.csv")
    assert moved and not two_clocks and np.array_equal(times, stamps - 0.1)
    assert note.startswith("gnss.csv: fixes moved by -100 ms onto the wheels' clock ")
    assert "the wheels' estimate: the distance between fixes" in note
    with pytest.raises(ValueError, match="gnss_lag"):
        lagged_times(stamps, lat, lon, path, "sometimes")


def test_the_setting_is_checked():
    assert load_params().data.gnss_lag == "report"
    assert load_params(overrides={"data.gnss_lag": "auto"}).data.gnss_lag == "auto"
    assert load_params(overrides={"data.gnss_lag": 0.12}).data.gnss_lag == 0.12
    assert load_params(overrides={"data.gnss_lag": 18.0}).data.gnss_lag == 18.0
    with pytest.raises(ConfigError, match="data.gnss_lag"):
        load_params(overrides={"data.gnss_lag": 61.5})


def test_the_setting_a_refusal_names_at_the_wide_search_s_edge_loads():
    """Fixes 60.1 s off, beyond the wide search's ±60 s grid, are found (its edge's peak
    and the latency's search about it); the setting the refusal names loads (until stop 78
    the setting was refused beyond ±60 s)."""
    stamps, lat, lon, path = _drive(60.1, duration_s=900.0)
    with pytest.raises(InputError) as err:
        lagged_times(stamps, lat, lon, path, "report", "gnss.csv")
    (problem,) = err.value.problems
    setting = float(re.search(r"set data\.gnss_lag: (\S+) ", problem.fix).group(1))
    assert setting == pytest.approx(60.1, abs=0.005)
    assert load_params(overrides={"data.gnss_lag": setting}).data.gnss_lag == setting
    with pytest.raises(ConfigError, match="data.gnss_lag"):
        load_params(overrides={"data.gnss_lag": "sometimes"})


def test_the_simulated_cars_can_latency_is_found_and_moved_by_resample(tmp_path):
    """The simulator's CAN wheel speeds are 50 ms late (``sim.vehicles.target.can`` of
    the ci profile); its fixes are the antenna's at their stamps. The wheels say so, at
    1, 5 and 10 Hz, and ``auto`` moves the fixes 50 ms later onto the wheels' clock."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from rwhonet.sim.streams import StreamSpec, signal_map, stream_tables, write_stream_csvs
    from support.multirate import START_S, simulated_drive

    state, vehicle, sim, ss, _ = simulated_drive(300.0, seed=6, can_noise=True)
    assert vehicle.params.can.latency_s == pytest.approx(0.05)
    for hz in (1.0, 5.0, 10.0):
        tables = stream_tables(state, vehicle, sim, ss, StreamSpec(100.0, hz), START_S, True)
        files = write_stream_csvs(tables, tmp_path / f"{hz:g}")
        streams = read_stream_csvs(list(files.values()), signal_map(), vehicle.nominal_radius_m)
        path = travelled_path(
            streams.wheels[0].t_s, [streams.wheels[0].channels[w] for w in c.WHEELS]
        )
        g = streams.gnss
        found = fix_lag(g.t_s, g.channels[c.LAT_DEG], g.channels[c.LON_DEG], path)
        # Measured 47.7-48.0 ms on this 300 s drive, standard error 1.3-2.5 ms: what the
        # slip's linear terms leave (48.0-50.8 ms on 600 s drives, docs/readers.md).
        assert found.lag_s == pytest.approx(-0.05, abs=0.004) and found.clear, found
        res = resample(streams, nominal_radius_m=vehicle.nominal_radius_m, gnss_lag="auto")
        assert any("fixes moved by +" in n and "(data.gnss_lag = auto)" in n for n in res.lost)
        kept = resample(streams, nominal_radius_m=vehicle.nominal_radius_m)
        assert not any("fixes moved" in n for n in kept.lost)
        assert any("auto would move the fixes by +" in n for n in kept.drive.notes)


@pytest.mark.parametrize(
    ("offset_s", "known"),
    [
        (18.0, "GPS time runs 18 s ahead of UTC since 2017"),
        (1.0, "a leap second: UTC by a leap-second count one out of date"),
    ],
)
def test_fixes_in_gps_time_beside_wheels_in_utc_are_refused_or_moved_by_resample(
    tmp_path, offset_s, known
):
    """A GNSS stream exported in GPS time beside CAN wheel speeds in UTC: 18 s apart (or
    a leap second apart: 1 s, a NovAtel log without TIME after a leap second the reader's
    table does not know). Before, the drive went through the reader with a note ("are the
    GNSS and the wheel speeds on one clock?") and validate refused it as wheels that
    stopped logging (1 s: until stop 78, kept with that note, labels a second off their
    wheels); now resample refuses it naming the offset and the setting, and with that
    setting (or auto) the drive is the one logged on one clock."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from rwhonet.sim.streams import StreamSpec, signal_map, stream_tables, write_stream_csvs
    from support.multirate import START_S, simulated_drive

    state, vehicle, sim, ss, _ = simulated_drive(300.0, seed=6)
    tables = stream_tables(state, vehicle, sim, ss, StreamSpec(100.0, 5.0), START_S)
    one = read_stream_csvs(
        list(write_stream_csvs(tables, tmp_path / "one").values()), signal_map(), None
    )
    tables.gnss[c.T_S] += offset_s
    two = read_stream_csvs(
        list(write_stream_csvs(tables, tmp_path / "two").values()), signal_map(), None
    )
    radius = vehicle.nominal_radius_m
    with pytest.raises(InputError) as err:
        resample(two, nominal_radius_m=radius)
    (problem,) = err.value.problems
    assert f"stamped by two clocks ({known}?)" in problem.found
    assert re.search(rf"set data\.gnss_lag: {offset_s:.0f}\.0\d\d \(the fixes moved", problem.fix)
    ref = resample(one, nominal_radius_m=radius, gnss_lag=0.0).drive.columns
    # the grid spans what the wheels and the moved fixes cover (before: the raw stamps',
    # 18 s short); auto's estimate is a few ms off 18 s: positions within 20 cm
    for mode, atol in ((offset_s, 1e-9), ("auto", 3e-6)):
        got = resample(two, nominal_radius_m=radius, gnss_lag=mode).drive.columns
        np.testing.assert_array_equal(got[c.T_S], ref[c.T_S])
        for name in (c.LAT_DEG, c.LON_DEG, c.OMEGA_RL):
            np.testing.assert_allclose(got[name], ref[name], rtol=0, atol=atol)


def test_a_wheel_sample_too_large_for_the_arithmetic_gives_no_estimate_not_a_crash(capfd):
    """A corrupt cell's 1e300 rad/s (found by the stream fuzz test): the least squares
    overflow and do not converge; the lag is then not estimated, and the finding says so.
    LAPACK never sees the values: it would print "On entry to DLASCL ..." on the process's
    stdout, where ``rwhonet predict`` writes its seconds (found by the MDF4 fuzz test)."""
    capfd.readouterr()
    stamps, lat, lon, _ = _drive(0.085, duration_s=120.0)
    t_w = np.arange(0.0, 120.0 + 1e-9, 0.01)
    omega = np.full(t_w.size, 12.0 / RADIUS_M)
    omega[3000] = 1e300
    found = fix_lag(stamps, lat, lon, travelled_path(t_w, [omega] * 4), "gnss.csv")
    assert np.isnan(found.lag_s) and not found.clear
    assert found.finding.startswith("gnss.csv: the fixes' lag against the wheel speeds not ")
    times, note, moved, _ = lagged_times(stamps, lat, lon, travelled_path(t_w, [omega] * 4), "auto")
    assert not moved and np.array_equal(times, stamps) and "not estimated" in note
    assert capfd.readouterr().out == ""
