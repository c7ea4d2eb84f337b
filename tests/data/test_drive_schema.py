"""Pandera schema of a canonical drive: each bad input gives a problem in the file's terms."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.schema import drive_schema, schema_problems, schema_problems_batch
from support.drives import straight_drive

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
    drive.loc[5, c.OMEGA_RL] = np.nan
    (p,) = problems(drive, vp)
    assert (p.file, p.row, p.column) == (FILE, 6, " Wheel Speed Rear Left (rad/sec)")
    assert "required" in p.expected and "NaN" in p.found


def test_an_empty_fix_is_no_fix_not_a_schema_failure(drive, vp):
    """An empty latitude or longitude is a row without a fix, which the GNSS policy cuts
    (rwhonet.data.fixes.no_fix_rows), as rwhonet predict takes it; not a refusal."""
    drive.loc[5, c.LAT_DEG] = np.nan
    drive.loc[[7, 8], c.LON_DEG] = np.nan
    assert problems(drive, vp) == []


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


@pytest.mark.parametrize(("scale", "unit"), [(1e3, "ms"), (1e6, "us"), (1e9, "ns")])
def test_time_in_ms_is_recognised(drive, vp, scale, unit):
    drive[c.T_S] = drive[c.T_S] * scale
    (p,) = [p for p in problems(drive, vp) if "median" in p.expected]
    assert p.row is None and f"time in {unit} instead of s" in p.found


def test_a_step_too_short_for_the_grid_is_reported_but_dropped_samples_and_gaps_pass(drive, vp):
    short = drive.copy()
    short.loc[13:, c.T_S] -= 0.07  # a 0.03 s step: a sample off the logger's clock
    (p,) = problems(short, vp)
    assert p.row == 14 and "step +0.03 s" in p.found and "dropped sample" in p.expected
    # two samples lost (a 0.3 s step): the GNSS policy cuts their second (partial_second)
    dropped = drive.drop(index=[12, 13]).reset_index(drop=True)
    assert problems(dropped, vp) == []
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


def test_stacked_drives_are_reported_as_if_validated_alone(vp):
    clean = straight_drive(duration_s=5.0).assign(**{c.SCENARIO: ""})
    backwards = clean.copy()
    backwards.loc[10, c.T_S] = backwards.loc[8, c.T_S] - 0.05
    in_ms = clean.assign(**{c.T_S: clean[c.T_S] * 1000.0})
    bad_lat = clean.copy()
    bad_lat.loc[[0, 30], c.LAT_DEG] = [95.0, -91.0]
    # The next drive starts 10 h earlier: no time step is taken across a drive boundary.
    later = straight_drive(duration_s=3.0, t0_s=9000.0).assign(**{c.SCENARIO: ""})
    # pandera hands a check the column without its NaN rows: rows are then not positions.
    gaps = clean.copy()
    gaps.loc[[0, 20], c.T_S] = np.nan
    gaps.loc[33, c.T_S] = gaps.loc[32, c.T_S]
    drives = [backwards, in_ms, clean, bad_lat, later, gaps, later]
    files = [f"raw/V-{k}.csv" for k in range(len(drives))]
    sources = [SOURCE, {}, SOURCE, SOURCE, {c.T_S: "Time"}, SOURCE, SOURCE]
    stacked = pd.concat(drives, ignore_index=True)
    starts = np.cumsum([0] + [len(d) for d in drives[:-1]])

    batch = schema_problems_batch(stacked, starts, vp, files, sources)

    alone = [schema_problems(d, vp, f, s) for d, f, s in zip(drives, files, sources, strict=True)]
    assert batch == alone
    # backwards: a step back (the 0.35 s step after it is a dropped sample: cut, not refused);
    # gaps: two NaN and a repeat (its two 0.2 s steps are dropped samples too).
    assert [len(p) for p in batch] == [1, 1, 0, 2, 0, 3, 0]
    assert [p.row for p in batch[5]] == [1, 21, 34]
    (ms,) = batch[1]
    assert ms.row is None and ms.file == files[1] and "ms instead of s" in ms.found
    assert [(p.row, p.column) for p in batch[3]] == [(1, " Lat"), (31, " Lat")]


def test_stacked_drives_share_a_missing_column(vp):
    drives = [straight_drive(duration_s=2.0).drop(columns=[c.OMEGA_RL]) for _ in range(2)]
    stacked = pd.concat(drives, ignore_index=True).assign(**{c.SCENARIO: ""})
    batch = schema_problems_batch(stacked, [0, len(drives[0])], vp, ["a.csv", "b.csv"], [{}, {}])
    assert [[(p.file, p.column, p.found) for p in found] for found in batch] == [
        [("a.csv", c.OMEGA_RL, "no such column")],
        [("b.csv", c.OMEGA_RL, "no such column")],
    ]


def test_time_in_ms_is_recognised_when_the_first_time_is_missing(drive, vp):
    drive[c.T_S] = drive[c.T_S] * 1000.0
    drive.loc[0, c.T_S] = np.nan  # the row the median verdict is attached to
    found = [(p.row, p.expected) for p in problems(drive, vp)]
    assert (1, "a value (this channel is required)") in found
    assert (None, "a median step of 0.1 ± 0.05 s (validate.sample_period_s)") in found
