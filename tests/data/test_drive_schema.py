"""Pandera schema of a canonical drive: each bad input gives a problem in the file's terms."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.schema import drive_schema, schema_problems

from .drives import straight_drive

FILE = "raw/source_train/V-S1.csv"
SOURCE = {c.T_S: " Time", c.LAT_DEG: " Lat", c.OMEGA_RL: " Wheel Speed Rear Left (rad/sec)"}


@pytest.fixture(scope="module")
def vp():
    return load_params().validate


@pytest.fixture
def drive():
    df = straight_drive(duration_s=5.0)
    df[c.SCENARIO] = ""
    return df


def problems(df, vp):
    return schema_problems(df, vp, FILE, SOURCE)


def test_clean_drive_passes(drive, vp):
    assert problems(drive, vp) == []
    drive_schema(vp).validate(drive)


def test_nan_in_a_required_channel(drive, vp):
    drive.loc[5, c.LAT_DEG] = np.nan
    (p,) = problems(drive, vp)
    assert (p.file, p.row, p.column) == (FILE, 6, " Lat")
    assert "required" in p.expected and "NaN" in p.found


def test_time_going_backwards(drive, vp):
    drive.loc[10, c.T_S] = drive.loc[8, c.T_S] - 0.05  # row 11 earlier than row 10
    found = {(p.row, p.expected.split(" (")[0]) for p in problems(drive, vp)}
    assert (11, "a time after the previous row's") in found
    (p,) = [p for p in problems(drive, vp) if "backwards" in p.found]
    assert p.column == " Time" and "after t = 45000.9 s in row 10" in p.found


def test_duplicated_timestamp(drive, vp):
    drive.loc[20, c.T_S] = drive.loc[19, c.T_S]
    dup = [p for p in problems(drive, vp) if "again" in p.found]
    assert [(p.row, p.column) for p in dup] == [(21, " Time")]
    assert "strictly increasing" in dup[0].expected


def test_latitude_out_of_range(drive, vp):
    drive.loc[[3, 30], c.LAT_DEG] = [95.0, -90.5]
    found = [(p.row, p.column, p.found) for p in problems(drive, vp)]
    assert found == [(4, " Lat", "95.0"), (31, " Lat", "-90.5")]


def test_wheel_speed_out_of_range_uses_canonical_name_without_source_map(drive, vp):
    drive.loc[7, c.OMEGA_FR] = 1e4
    (p,) = problems(drive, vp)
    assert (p.row, p.column) == (8, c.OMEGA_FR)
    assert "max_abs_wheel_speed_rad_s" in p.expected


def test_time_in_ms_is_recognised(drive, vp):
    drive[c.T_S] = drive[c.T_S] * 1000.0
    (p,) = [p for p in problems(drive, vp) if "median" in p.expected]
    assert p.row is None and "ms instead of s" in p.found


def test_irregular_step_is_reported_but_gaps_are_allowed(drive, vp):
    irregular = drive.drop(index=[12, 13])  # a 0.3 s step: neither regular nor a gap
    irregular = irregular.reset_index(drop=True)
    (p,) = problems(irregular, vp)
    assert p.row == 13 and "step +0.3 s" in p.found and "max_gap_s" in p.expected
    gap = drive.drop(index=range(12, 20)).reset_index(drop=True)  # a 0.9 s gap
    assert problems(gap, vp) == []


def test_many_failures_are_capped(drive, vp):
    drive.loc[:, c.LAT_DEG] = 100.0
    listed = problems(drive, vp)
    assert [p.row for p in listed] == [1, 2, 3, 4, 5, None]
    assert "46 more row(s)" in listed[-1].found  # 51 rows in all


def test_unknown_and_missing_columns(drive, vp):
    bad = drive.drop(columns=[c.OMEGA_RL]).assign(speed_kmh=1.0)
    found = {(p.column, p.found) for p in problems(bad, vp)}
    assert (" Wheel Speed Rear Left (rad/sec)", "no such column") in found
    assert ("speed_kmh", "column 'speed_kmh'") in found


def test_rows_are_positions_whatever_the_index(drive, vp):
    drive.index = drive.index + 1000
    drive.loc[1004, c.LAT_DEG] = 91.0  # fifth row
    (p,) = problems(drive, vp)
    assert p.row == 5
