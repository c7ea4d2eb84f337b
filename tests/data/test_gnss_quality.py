"""GNSS-quality policy on synthetic drives: every rule cuts what it should, and says so."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geographiclib.geodesic import Geodesic

from rwhonet.config import CutSpec, GnssPolicy
from rwhonet.data import canonical as c
from rwhonet.data.fixes import no_fix_rows
from rwhonet.data.plausibility import implied_radius, unit_mistake
from rwhonet.data.quality import (
    assess,
    frozen_rows,
    implied_speed_m_s,
    local_step_distance_m,
    second_index,
)
from support.drives import straight_drive

POLICY = GnssPolicy(
    min_sats=4,
    max_speed_m_s=70.0,
    frozen_min_s=2.0,
    moving_wheel_speed_rad_s=1.0,
    max_gap_s=0.5,
    min_segment_s=5.0,
)
PERIOD_S = 0.1
T0 = 45000.0


def row(t_s: float) -> int:
    """Row index of time t_s in straight_drive() (first row at T0, 10 Hz)."""
    return round((t_s - T0) / PERIOD_S)


def spans(result):
    return [(s.start_s, s.end_s) for s in result.segments]


def cuts(result):
    return [(cut.start_s, cut.end_s, cut.rule) for cut in result.cuts]


def test_second_index_rounds_up_with_float_allowance():
    t = np.array([T0, T0 + 0.05, T0 + 0.1, T0 + 1.0 - 1e-10, T0 + 1.0 + 1e-10, T0 + 1.01])
    assert list(second_index(t) - int(T0)) == [0, 1, 1, 1, 1, 2]


def test_clean_drive_is_one_segment_with_its_start_fix():
    drive = straight_drive(duration_s=40.0)
    result = assess(drive, POLICY, PERIOD_S)
    assert spans(result) == [(T0, T0 + 40)]
    (seg,) = result.segments
    assert (seg.row_start, seg.row_stop, seg.n_rows, seg.n_seconds) == (0, 401, 401, 40)
    # The lone row at T0 is second T0's only row: cut as a partial second, used as start fix.
    assert cuts(result) == [(T0 - 1, T0, "partial_second")]
    assert result.rows_kept + sum(cut.n_rows for cut in result.cuts) == len(drive)


def test_drive_starting_on_a_second_boundary_loses_its_first_second_as_start_fix():
    drive = straight_drive(duration_s=20.0, first_row_at_t0=False)  # rows T0+0.1 .. T0+20
    result = assess(drive, POLICY, PERIOD_S)
    assert cuts(result) == [(T0, T0 + 1, "start_fix")]
    assert spans(result) == [(T0 + 1, T0 + 20)]


@pytest.mark.parametrize(("lean_s", "cut"), [(0.03, True), (0.02, False), (-0.03, False)])
def test_a_second_ending_on_a_row_leaning_into_a_dropped_sample_is_cut(lean_s, cut):
    """The sample at T0+30.1 dropped and the row at T0+30.0, second T0+30's end fix,
    stamped ``lean_s`` off its slot: 30 ms late (toward the dropped slot), it may be the
    dropped sample's and second T0+30 is cut as ``drop_edge``; 20 ms late, or 30 ms early,
    the second stays. Second T0+31, a row short, is cut either way. (Past the first 200
    rows, which give the grid's phase.)"""
    drive = straight_drive(duration_s=60.0)
    drive = drive.drop(index=row(T0 + 30.1)).reset_index(drop=True)
    drive.loc[row(T0 + 30.0), c.T_S] += lean_s
    result = assess(drive, POLICY, PERIOD_S)
    edge = [(T0 + 29, T0 + 30, "drop_edge")] if cut else []
    assert cuts(result) == [
        (T0 - 1, T0, "partial_second"),
        *edge,
        (T0 + 30, T0 + 31, "partial_second"),
    ]
    assert result.cut_seconds_by_rule["drop_edge"] == int(cut)
    if cut:
        assert "row(s) 301 (+30 ms)" in result.cuts[1].detail


@pytest.mark.parametrize(("lean_s", "cut"), [(-0.03, True), (-0.02, False)])
def test_a_stretch_starting_on_a_row_leaning_into_a_dropped_sample_loses_its_first_second(
    lean_s, cut
):
    """The sample at T0+29.9 dropped and the row at T0+30.0, the start fix of second
    T0+31, stamped 30 ms early (toward the dropped slot): it may be the dropped sample's,
    and second T0+31 is cut as ``drop_edge`` (20 ms early: the stretch starts there)."""
    drive = straight_drive(duration_s=60.0)
    drive = drive.drop(index=row(T0 + 29.9)).reset_index(drop=True)
    drive.loc[row(T0 + 29.9), c.T_S] += lean_s  # the row at T0 + 30.0, one row up now
    result = assess(drive, POLICY, PERIOD_S)
    assert spans(result)[-1] == ((T0 + 31, T0 + 60) if cut else (T0 + 30, T0 + 60))
    assert ((T0 + 30, T0 + 31, "drop_edge") in cuts(result)) == cut


def _move(drive, i, metres):
    g = Geodesic.WGS84.Direct(drive.loc[i, c.LAT_DEG], drive.loc[i, c.LON_DEG], 120.0, metres)
    drive.loc[i, [c.LAT_DEG, c.LON_DEG]] = [g["lat2"], g["lon2"]]


def test_jump_cuts_the_second_it_lands_in():
    drive = straight_drive(duration_s=40.0)
    _move(drive, row(T0 + 20.5), 100.0)  # 100 m off for one fix: ~1000 m/s in and out
    result = assess(drive, POLICY, PERIOD_S)
    assert spans(result) == [(T0, T0 + 20), (T0 + 21, T0 + 40)]
    jump = [cut for cut in result.cuts if cut.rule == "jump"]
    assert [(j.start_s, j.end_s, j.n_rows) for j in jump] == [(T0 + 20, T0 + 21, 10)]
    assert "m/s (> max_speed_m_s 70.0)" in jump[0].detail


def test_low_satellites_cut_and_missing_count_is_not_trusted():
    drive = straight_drive(duration_s=40.0)
    drive.loc[row(T0 + 10) : row(T0 + 12.9), c.N_SATS] = 3.0
    drive.loc[row(T0 + 30.5), c.N_SATS] = np.nan
    result = assess(drive, POLICY, PERIOD_S)
    low = [(cut.start_s, cut.end_s, cut.detail) for cut in result.cuts if cut.rule == "low_sats"]
    assert low == [
        (T0 + 9, T0 + 13, "3 satellites (min_sats 4)"),
        (T0 + 30, T0 + 31, "no count (min_sats 4)"),
    ]
    assert spans(result) == [(T0, T0 + 9), (T0 + 13, T0 + 30), (T0 + 31, T0 + 40)]


def test_no_satellite_column_means_no_satellite_rule():
    drive = straight_drive(duration_s=10.0).drop(columns=[c.N_SATS])
    assert spans(assess(drive, POLICY, PERIOD_S)) == [(T0, T0 + 10)]


def test_gap_splits_the_drive():
    drive = straight_drive(duration_s=40.0)
    drive = drive.drop(index=range(row(T0 + 15.0), row(T0 + 16.0))).reset_index(drop=True)
    result = assess(drive, POLICY, PERIOD_S)
    assert spans(result) == [(T0, T0 + 14), (T0 + 16, T0 + 40)]
    (gap,) = [cut for cut in result.cuts if cut.rule == "gap"]
    assert (gap.start_s, gap.end_s) == (T0 + 14, T0 + 16)
    assert gap.detail.startswith("time gap of up to 1.1 s")


def test_missing_whole_seconds_are_a_gap():
    drive = straight_drive(duration_s=40.0)
    drive = drive.drop(index=range(row(T0 + 10.1), row(T0 + 13.1))).reset_index(drop=True)
    result = assess(drive, POLICY, PERIOD_S)
    # Seconds T0+11..T0+13 hold no row; T0+14 is complete but its start fix is 3.1 s back.
    assert spans(result) == [(T0, T0 + 10), (T0 + 14, T0 + 40)]
    (gap,) = [cut for cut in result.cuts if cut.rule == "gap"]
    assert (gap.start_s, gap.end_s, gap.n_rows) == (T0 + 10, T0 + 14, 10)
    assert gap.detail.startswith("time gap of up to 3.1 s")


def test_short_valid_stretch_is_dropped_and_reported():
    drive = straight_drive(duration_s=40.0)
    drive = drive.drop(index=range(row(T0 + 4.0), row(T0 + 5.0))).reset_index(drop=True)
    result = assess(drive, POLICY, PERIOD_S)
    assert spans(result) == [(T0 + 5, T0 + 40)]
    assert (T0, T0 + 3, "short_segment") in cuts(result)
    (short,) = [cut for cut in result.cuts if cut.rule == "short_segment"]
    assert short.detail == "valid stretch of 3 s dropped (< min_segment_s 5.0 s)"
    assert result.cut_rows_by_rule["short_segment"] == 30


def test_manual_cut_by_interval():
    drive = straight_drive(duration_s=40.0)
    cut = CutSpec(drive="V-S1", start_s=T0 + 10.0, end_s=T0 + 12.0, reason="roadworks")
    result = assess(drive, POLICY, PERIOD_S, [cut])
    # Rows with t in [start_s, end_s] are cut; the row at end_s is no start fix either.
    assert cuts(result) == [
        (T0 - 1, T0, "partial_second"),
        (T0 + 9, T0 + 12, "manual"),
        (T0 + 12, T0 + 13, "start_fix"),
    ]
    assert result.cuts[1].detail == "manual cut: roadworks"
    assert spans(result) == [(T0, T0 + 9), (T0 + 13, T0 + 40)]


def test_frozen_fix_while_moving_is_cut():
    drive = straight_drive(duration_s=40.0)
    a, b = row(T0 + 10.0), row(T0 + 13.9)
    drive.loc[a:b, [c.LAT_DEG, c.LON_DEG]] = drive.loc[a, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    result = assess(drive, POLICY, PERIOD_S)
    assert (T0 + 9, T0 + 13, "frozen") in cuts(result)
    # The fix catches up by 60 m in 0.1 s: the second it lands in is a jump.
    assert (T0 + 13, T0 + 14, "jump") in cuts(result)
    assert result.segments[0].end_s == T0 + 9 and result.segments[-1].end_s == T0 + 40
    frozen = next(cut for cut in result.cuts if cut.rule == "frozen")
    assert "unchanged while the rear wheels turned" in frozen.detail


def test_frozen_rows_rules():
    n = 60
    lat = np.r_[np.linspace(52.0, 52.001, 10), np.full(40, 52.001), np.linspace(52.002, 52.003, 10)]
    lon = np.full(n, -1.5) + np.r_[np.zeros(10), np.zeros(40), np.ones(10)] * 1e-3
    moving = np.full(n, 50.0)
    flagged = frozen_rows(lat, lon, moving, 0.1, 2.0, 1.0)
    # The run of identical fixes is rows 9..49 (row 9 starts it): 41 moving rows = 4.1 s.
    assert np.flatnonzero(flagged).tolist() == list(range(9, 50))
    # Standing still with an unchanged fix is fine.
    assert not frozen_rows(lat, lon, np.zeros(n), 0.1, 2.0, 1.0).any()
    # Stopped first, then moving with the fix stuck: only the moving part is cut.
    wheels = moving.copy()
    wheels[9:30] = 0.0
    assert np.flatnonzero(frozen_rows(lat, lon, wheels, 0.1, 2.0, 1.0)).tolist() == list(
        range(30, 50)
    )
    # Moving for less than frozen_min_s with a stuck fix is tolerated.
    assert not frozen_rows(lat, lon, moving, 0.1, 5.0, 1.0).any()


def test_frozen_throughout_leaves_no_segment():
    drive = straight_drive(duration_s=20.0)
    drive[[c.LAT_DEG, c.LON_DEG]] = drive.loc[0, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    result = assess(drive, POLICY, PERIOD_S)
    assert result.segments == [] and result.cut_seconds_by_rule["frozen"] == 20


@pytest.mark.parametrize("radius_m", [0.298, 0.316])
def test_implied_radius_of_a_straight_drive_is_its_radius(radius_m):
    drive = straight_drive(duration_s=30.0, radius_m=radius_m)
    result = assess(drive, POLICY, PERIOD_S)
    est = implied_radius(drive, result.segments, POLICY.moving_wheel_speed_rad_s)
    assert est.moving_s == 30  # the start fix gives every second its earlier fix
    assert est.radius_m == pytest.approx(radius_m, rel=1e-9)
    assert est.distance_m == pytest.approx(15.0 * 30, rel=1e-9)


def test_standing_still_gives_no_radius():
    drive = straight_drive(duration_s=10.0, speed_m_s=0.0)
    result = assess(drive, POLICY, PERIOD_S)
    est = implied_radius(drive, result.segments, 1.0)
    assert est.moving_s == 0 and math.isnan(est.radius_m)


@pytest.mark.parametrize(
    ("factor", "unit"),
    [
        (60 / (2 * math.pi), "rpm"),  # wheel speed written in rpm
        (180 / math.pi, "deg/s"),
        (None, "km/h"),  # a linear wheel speed in km/h
        (0.5, None),  # something else: no unit fits
    ],
)
def test_unit_mistake_names_the_likely_unit(factor, unit):
    nominal, v = 0.298, 15.0
    omega_file = v * 3.6 if factor is None else v / nominal * factor
    message = unit_mistake(v / omega_file, nominal, 0.05)
    assert message is not None
    if unit is None:
        assert "unexpected unit" in message
    else:
        assert f"look like {unit}" in message


def test_plausible_radius_passes():
    assert unit_mistake(0.30, 0.298, 0.05) is None
    assert unit_mistake(0.298 * 1.06, 0.298, 0.05) is not None


def test_tangent_plane_step_distance_matches_the_geodesic():
    rng = np.random.default_rng(7)
    lat = rng.uniform(-75.0, 75.0, 300)
    lon = rng.uniform(-180.0, 180.0, 300)
    azimuth = rng.uniform(0.0, 360.0, 300)
    dist = 10 ** rng.uniform(-1.0, 3.3, 300)  # 0.1 m .. 2 km
    ends = [Geodesic.WGS84.Direct(*args) for args in zip(lat, lon, azimuth, dist, strict=True)]
    pairs_lat = np.ravel(np.column_stack([lat, [e["lat2"] for e in ends]]))
    pairs_lon = np.ravel(np.column_stack([lon, [e["lon2"] for e in ends]]))
    approx = local_step_distance_m(pairs_lat, pairs_lon)[0::2]
    np.testing.assert_allclose(approx, dist, rtol=1e-6)
    # Across the antimeridian the short way round is taken.
    across = local_step_distance_m(np.array([0.0, 0.0]), np.array([179.99995, -179.99995]))
    assert across[0] == pytest.approx(11.13, abs=0.01)


def test_implied_speed_is_exact_above_the_screening_threshold():
    drive = straight_drive(duration_s=3.0)
    _move(drive, 12, 30.0)
    t, lat, lon = (drive[k].to_numpy() for k in (c.T_S, c.LAT_DEG, c.LON_DEG))
    screened = implied_speed_m_s(t, lat, lon, exact_above_m_s=35.0)
    exact = implied_speed_m_s(t, lat, lon)
    assert screened[12] == exact[12] > 35.0  # the jump: geodesic, bit for bit
    np.testing.assert_allclose(screened, exact, rtol=1e-7)


def test_a_drive_without_rows_has_no_segment_and_no_cut():
    empty = {name: np.zeros(0) for name in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    result = assess(empty, POLICY, PERIOD_S)
    assert (result.segments, result.cuts, result.n_rows, result.n_seconds) == ([], [], 0, 0)


def test_a_fix_at_latitude_and_longitude_zero_is_no_fix_with_or_without_a_satellite_count():
    """A receiver without a fix writes zeros: a parked car's first 10 s at (0, 0) are cut
    (low_sats: no fix), not kept as seconds with no GNSS displacement."""
    for drop_sats in (False, True):
        drive = straight_drive(duration_s=40.0, speed_m_s=0.0)
        drive.loc[: row(T0 + 9.9), [c.LAT_DEG, c.LON_DEG]] = 0.0
        if drop_sats:
            drive = drive.drop(columns=[c.N_SATS])
        result = assess(drive, POLICY, PERIOD_S)
        assert all(s.start_s >= T0 + 10 for s in result.segments), spans(result)
        (low,) = [cut for cut in result.cuts if cut.rule == "low_sats"]
        assert (low.start_s, low.end_s) == (T0, T0 + 10)
        assert low.detail == "no fix (latitude = longitude = 0) (min_sats 4)"


def test_an_empty_fix_is_no_fix_and_the_cut_says_so():
    """A logger that leaves the fix's cells empty while the receiver has none: those
    seconds are cut (low_sats: no fix), the rest kept, whether one cell or both are empty."""
    drive = straight_drive(duration_s=200.0, speed_m_s=15.0)
    drive.loc[row(T0 + 40.05) : row(T0 + 49.9), [c.LAT_DEG, c.LON_DEG]] = np.nan
    drive.loc[row(T0 + 120.5), c.LON_DEG] = np.nan
    result = assess(drive, POLICY, PERIOD_S)
    low = [cut for cut in result.cuts if cut.rule == "low_sats"]
    assert [(x.start_s, x.end_s) for x in low] == [(T0 + 40, T0 + 50), (T0 + 120, T0 + 121)]
    assert all(x.detail == "no fix (latitude or longitude empty) (min_sats 4)" for x in low)
    assert {cut.rule for cut in result.cuts} == {"low_sats", "partial_second"}  # + first second
    assert result.seconds_kept == result.n_seconds - 11 - 1


def test_no_fix_rows_are_missing_zero_or_low_satellite_fixes():
    lat = np.array([52.0, 0.0, 0.0, np.nan, 52.0, 52.0, 52.0])
    lon = np.array([-1.0, 0.0, -1.0, -1.0, -1.0, -1.0, -1.0])
    sats = np.array([9.0, 9.0, 9.0, 9.0, 3.0, np.nan, 4.0])
    assert no_fix_rows(lat, lon).tolist() == [0, 1, 0, 1, 0, 0, 0]
    assert no_fix_rows(lat, lon, sats, 4).tolist() == [0, 1, 0, 1, 1, 1, 0]
