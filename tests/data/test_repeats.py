"""Rows written twice (rwhonet.data.repeats): found, dropped, and the file's rows kept."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.cli.drive import calibration_of, load_drive
from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.repeats import CopyFilter, FileRows, drop_repeated, repeated_rows
from rwhonet.errors import InputError
from rwhonet.features.scaling import MinMaxScaler
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import validate
from support.corpus import DRIVE, good_target, rows, write_good_fleet, write_target
from support.drives import TARGET_RADIUS_M, make_params, write_iovnbd, written_twice


def test_only_rows_equal_in_every_column_repeat():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.2, 0.3, 0.3, 0.3])
    a = np.array([1.0, 2.0, 2.0, 3.0, 3.5, np.nan, np.nan, np.nan])
    b = np.array([5.0, 6.0, 6.0, 7.0, 7.0, 8.0, 8.0, 8.0])
    # row 2 repeats row 1; row 4 shares row 3's time only; rows 6 and 7 repeat NaN and all
    assert repeated_rows({c.T_S: t, "a": a, "b": b}).tolist() == [2, 6, 7]
    assert repeated_rows({"a": a, c.T_S: t}).tolist() == [2, 6, 7]  # column order is free
    assert repeated_rows({c.T_S: t[:1]}).size == 0 and repeated_rows({}).size == 0


def test_a_drive_without_repeats_is_returned_as_it_is():
    raw = RawDrive({c.T_S: np.arange(5) * 0.1, "a": np.arange(5.0)}, {}, "name")
    assert drop_repeated(raw) is raw


def test_dropped_rows_are_named_in_the_file_s_numbering():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.3, 0.3])
    raw = RawDrive({c.T_S: t, "a": np.array([1.0, 2, 2, 3, 4, 4])}, {}, "name", ("earlier",))
    out = drop_repeated(raw)
    assert out.columns[c.T_S].tolist() == [0.0, 0.1, 0.2, 0.3]
    assert out.repeated_rows.tolist() == [3, 6]  # data rows of the file, 1-based
    assert out.notes[0] == "earlier" and "2 data row(s)" in out.notes[1]
    assert "row(s) 3, 6)" in out.notes[1]
    assert FileRows(out.repeated_rows)(np.arange(4)).tolist() == [1, 2, 4, 5]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60))
def test_file_rows_are_the_kept_rows_of_the_file(dropped_mask):
    """Canonical row k is the k-th kept row of the file, whatever was dropped."""
    dropped_mask[0] = False  # the first row never repeats a row before it
    n = len(dropped_mask)
    dropped = np.flatnonzero(dropped_mask) + 1
    kept = np.delete(np.arange(1, n + 1), dropped - 1)
    numbering = FileRows(dropped)
    assert numbering(np.arange(kept.size)).tolist() == kept.tolist()
    assert [numbering(int(k)) for k in range(kept.size)] == kept.tolist()
    assert numbering.identity == (dropped.size == 0)


def test_ingest_drops_them_and_validate_reports_them(tmp_path, capsys):
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = written_twice(good_target(), 200, 700, 701)  # a row twice, and a row three times
    write_target(raw, df)
    params = make_params(raw)
    manifest = ingest(params, tmp_path / "drives", tmp_path / "failed.json")
    (entry,) = [d for d in manifest["drives"] if d["drive"] == DRIVE]
    assert entry["repeated_rows"] == [201, 701, 702]
    assert entry["n_rows"] == len(df) - 3
    assert any("3 data row(s) repeat" in n for n in entry["notes"])
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    assert drive["repeated_rows"] == {"rows": 3, "listed": [201, 701, 702]}
    assert drive["rows"] == len(df) - 3
    # what is kept is the drive as written once: the same seconds as the good drive
    once = tmp_path / "once"
    write_good_fleet(once)
    write_target(once, good_target())
    p_once = make_params(once)
    ingest(p_once, tmp_path / "d1", tmp_path / "f1.json")
    ref = validate(p_once, tmp_path / "d1", tmp_path / "s1", tmp_path / "v1.json")
    (good,) = [d for d in ref["drives"] if d["drive"] == DRIVE]
    assert (drive["seconds_kept"], drive["segments"]) == (good["seconds_kept"], good["segments"])
    assert "repeated_rows" not in good
    assert json.loads((tmp_path / "v.json").read_text())["drives"] == report["drives"]


def test_validate_names_the_file_s_row_after_a_dropped_copy(tmp_path):
    """A bad cell after dropped copies is named by the file's row (not the drive's)."""
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = written_twice(good_target(), 50, 60)
    df.loc[rows(df, 400, 400), c.LAT_DEG] = np.inf
    t = df[c.T_S].to_numpy().copy()
    t[899] = t[898]  # row 900 at row 899's time, its values its own
    df[c.T_S] = t
    write_target(raw, df)
    params = make_params(raw)
    ingest(params, tmp_path / "drives", tmp_path / "failed.json")
    with pytest.raises(InputError) as err:
        validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    found = {(p.row, p.column): p.found for p in err.value.problems}
    assert (400, " Lat") in found
    assert found[(900, " Time")] == f"t = {float(t[898])!r} s again (as in row 899)"


def test_recalibrate_reads_a_drive_as_ingest_does(tmp_path):
    """``rwhonet recalibrate``'s reader drops the copies, says so, and names the file's rows."""
    path = tmp_path / "V-T.csv"
    clean = good_target()
    args = dict(
        params=load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of((TARGET_RADIUS_M, TARGET_RADIUS_M), "t"),
        scaler=MinMaxScaler("global", (0.0,) * 4, (60.0,) * 4, (), 0),
        wpm_mode="integrated",
        seq_len=1,
    )
    write_iovnbd(clean, path)
    once = load_drive(path, **args)
    write_iovnbd(written_twice(clean, 300), path)
    twice = load_drive(path, **args)
    assert any("1 data row(s) repeat" in n and "row(s) 301)" in n for n in twice.notes)
    assert twice.samples.frame.equals(once.samples.frame)
    assert np.array_equal(twice.samples.x, once.samples.x)
    assert np.array_equal(twice.samples.y, once.samples.y)
    bad = written_twice(clean, 300)
    bad.loc[rows(bad, 500, 500), c.LON_DEG] = np.inf
    write_iovnbd(bad, path)
    with pytest.raises(InputError) as err:
        load_drive(path, **args)
    assert {(p.row, p.column) for p in err.value.problems} >= {(500, " Long")}


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(0, 3), min_size=1, max_size=40),  # times each row is written
    st.lists(st.integers(1, 7), min_size=1, max_size=10),  # block sizes, cycled
)
def test_copy_filter_hands_on_the_rows_once_each_with_their_file_rows(times, sizes):
    """Whatever the blocks, the rows handed on are the drive written once, and each row
    handed on is the file's row its block's first_row says (blocks stay consecutive)."""
    times = [max(n, 1) for n in times]
    t_once = np.arange(len(times)) * 0.1
    a_once = np.arange(len(times), dtype=np.float64) ** 2
    t_file = np.repeat(t_once, times)
    a_file = np.repeat(a_once, times)
    bounds, k = [0], 0
    while bounds[-1] < t_file.size:
        bounds.append(min(bounds[-1] + sizes[k % len(sizes)], t_file.size))
        k += 1
    blocks = [
        (a + 1, {c.T_S: t_file[a:b], "a": a_file[a:b]})
        for a, b in zip(bounds[:-1], bounds[1:], strict=True)
    ]
    copies = CopyFilter()
    out = list(copies.blocks(blocks))
    got_t = np.concatenate([cols[c.T_S] for _, cols in out])
    np.testing.assert_array_equal(got_t, t_once)
    for first, cols in out:
        rows_in_file = first - 1 + np.arange(cols[c.T_S].size)
        np.testing.assert_array_equal(t_file[rows_in_file], cols[c.T_S])
    kept = np.ones(t_file.size, dtype=bool)
    kept[np.array(copies.dropped, dtype=np.int64) - 1] = False
    np.testing.assert_array_equal(t_file[kept], t_once)
