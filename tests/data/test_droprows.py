"""Rows written twice or without a wheel speed (rwhonet.data.droprows): found, dropped, and
the file's rows kept."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.cli.drive import load_drive
from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.droprows import FileRows, RowFilter, drop_rows, repeated_rows, wheelless_rows
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import validate
from support.corpus import DRIVE, good_target, rows, write_good_fleet, write_target
from support.drives import (
    make_params,
    target_drive_args,
    write_iovnbd,
    written_again,
    written_twice,
)


def test_only_rows_equal_in_every_column_repeat():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.2, 0.3, 0.3, 0.3])
    a = np.array([1.0, 2.0, 2.0, 3.0, 3.5, np.nan, np.nan, np.nan])
    b = np.array([5.0, 6.0, 6.0, 7.0, 7.0, 8.0, 8.0, 8.0])
    # row 2 repeats row 1; row 4 shares row 3's time only; rows 6 and 7 repeat NaN and all
    assert repeated_rows({c.T_S: t, "a": a, "b": b}).tolist() == [2, 6, 7]
    assert repeated_rows({"a": a, c.T_S: t}).tolist() == [2, 6, 7]  # column order is free
    assert repeated_rows({c.T_S: t[:1]}).size == 0 and repeated_rows({}).size == 0


def test_a_block_written_again_and_an_overlap_repeat_earlier_rows():
    """A B C D A B C E: the second A B C repeat rows further back; a row at an earlier
    time with one value its own is no copy (validate refuses its time going back)."""
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.0, 0.1, 0.2, 0.4, 0.1])
    a = np.array([1.0, 2.0, 3.0, 4.0, 1.0, 2.0, 3.0, 5.0, 2.5])
    assert repeated_rows({c.T_S: t, "a": a}).tolist() == [4, 5, 6]  # row 8: 0.1 s, a 2.5
    nan = np.array([1.0, np.nan, 3.0, -0.0, 1.0, np.nan, 3.0, 0.0, 2.5])
    assert repeated_rows({c.T_S: t, "a": nan}).tolist() == [4, 5, 6]  # NaN = NaN, -0 = 0
    assert repeated_rows({c.T_S: np.arange(6) * 0.1, "a": np.zeros(6)}).size == 0


@settings(max_examples=200, deadline=None)
@given(
    st.integers(2, 40),
    st.lists(st.tuples(st.integers(0, 39), st.integers(0, 39), st.integers(1, 15)), max_size=3),
    st.lists(st.integers(1, 9), max_size=12),
)
def test_blocks_written_again_are_dropped_by_the_file_reader_and_the_row_filter(n, replays, sizes):
    """A drive of ``n`` rows with blocks of it written again anywhere later (``(at, from,
    length)``): both lose exactly the rows written again, under any blocking, named alike."""
    t = np.arange(n) * 0.1
    cols = {c.T_S: t, **{w: 10.0 + np.arange(n) + j for j, w in enumerate(c.WHEELS)}}
    order = list(range(n))
    for at, start, length in replays:
        at, start = at % (len(order) + 1), start % n
        block = list(range(start, min(start + length, n)))
        seen = set(order[:at])
        if not set(block) <= seen:  # written again: only rows already written
            continue
        order[at:at] = block
    file_cols = {k: v[order] for k, v in cols.items()}
    whole = drop_rows(RawDrive(file_cols, {}, "name"), "f")
    np.testing.assert_array_equal(whole.columns[c.T_S], t)
    expected = [i + 1 for i, row in enumerate(order) if row in order[:i]]
    assert whole.repeated_rows.tolist() == expected
    f, blocks, i = RowFilter(), [], 0
    for size in [*sizes, len(order)]:
        if i < len(order):
            blocks.append((i + 1, {k: v[i : i + size] for k, v in file_cols.items()}))
        i += size
    kept = list(f.blocks(blocks))
    assert f.dropped == expected
    np.testing.assert_array_equal(np.concatenate([b[c.T_S] for _, b in kept]), t)
    for first, b in kept:  # every block handed on is consecutive rows of the file
        np.testing.assert_array_equal(
            file_cols[c.T_S][first - 1 : first - 1 + len(b[c.T_S])], b[c.T_S]
        )


def test_a_drive_without_repeats_is_returned_as_it_is():
    raw = RawDrive({c.T_S: np.arange(5) * 0.1, "a": np.arange(5.0)}, {}, "name")
    assert drop_rows(raw, "V-T.csv") is raw


def test_dropped_rows_are_named_in_the_file_s_numbering():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.3, 0.3])
    raw = RawDrive({c.T_S: t, "a": np.array([1.0, 2, 2, 3, 4, 4])}, {}, "name", ("earlier",))
    out = drop_rows(raw, "V-T.csv")
    assert out.columns[c.T_S].tolist() == [0.0, 0.1, 0.2, 0.3]
    assert out.repeated_rows.tolist() == [3, 6]  # data rows of the file, 1-based
    assert out.notes[0] == "earlier" and "2 data row(s)" in out.notes[1]
    assert "row(s) 3, 6)" in out.notes[1]
    assert FileRows(out.repeated_rows)(np.arange(4)).tolist() == [1, 2, 4, 5]


def _wheels(n: int, t: np.ndarray | None = None) -> dict[str, np.ndarray]:
    t = np.arange(n) * 0.1 if t is None else t
    return {c.T_S: t, **{w: np.full(t.size, 10.0) + np.arange(t.size) for w in c.WHEELS}}


def test_rows_without_a_wheel_speed_are_dropped_and_listed():
    t = np.r_[0.0, 0.1, 0.2, 0.2, 0.3, 0.4, 0.5, 0.5, 0.6 + 0.1 * np.arange(6)]
    cols = _wheels(t.size, t)
    cols[c.OMEGA_RL][[1, 5]] = np.nan
    cols[c.OMEGA_FR][5] = np.nan
    for w in c.WHEELS:  # row 3 copies row 2; row 7 copies row 6
        cols[w][3], cols[w][7] = cols[w][2], cols[w][6]
    cols[c.OMEGA_FL][6] = cols[c.OMEGA_FL][7] = np.nan  # ... and row 7 lacks a wheel, as row 6
    assert wheelless_rows(cols).tolist() == [1, 5, 6, 7]
    raw = RawDrive(cols, {w: w.upper() for w in c.WHEELS}, "name")
    out = drop_rows(raw, "V-T.csv")
    assert out.columns[c.T_S][:4].tolist() == [0.0, 0.2, 0.3, 0.6] and out.n_rows == 9
    # a copy of a row without a wheel speed is listed with those rows, once
    assert out.repeated_rows.tolist() == [4] and out.wheelless_rows.tolist() == [2, 6, 7, 8]
    assert (
        "4 of 14 (29 %) data row(s) have an empty wheel speed (row(s) 2, 6, 7, 8)" in out.notes[1]
    )
    entry = {"repeated_rows": [4], "wheelless_rows": [2, 6, 7, 8]}
    assert FileRows.of(entry)(np.arange(4)).tolist() == [1, 3, 5, 9]


def test_a_wheel_channel_without_any_value_is_refused():
    cols = _wheels(20)
    cols[c.OMEGA_RR][:] = np.nan
    with pytest.raises(InputError) as err:
        drop_rows(RawDrive(cols, {c.OMEGA_RR: "WhlSpd_RR"}, "name"), "V-T.csv")
    (problem,) = err.value.problems
    assert (problem.file, problem.row, problem.column) == ("V-T.csv", None, "WhlSpd_RR")
    assert problem.found == "no value in any of the 20 data rows"
    cols = _wheels(20)  # each wheel in other rows: no row has the four
    for j, w in enumerate(c.WHEELS):
        cols[w][np.arange(20) % 4 != j] = np.nan
    with pytest.raises(InputError, match=r"20 of the 20 data rows \(100 %\)") as err:
        drop_rows(RawDrive(cols, {}, "name"), "V-T.csv")
    assert "stream_csv" in str(err.value) and err.value.problems[0].row == 1
    cols = _wheels(20)  # the four in every other row: half the rows without them
    cols[c.OMEGA_RL][1::2] = np.nan
    with pytest.raises(InputError, match=r"10 of the 20 data rows \(50 %\)") as err:
        drop_rows(RawDrive(cols, {}, "name"), "V-T.csv")
    assert err.value.problems[0].row == 2
    cols[c.OMEGA_RL][[1, 3, 5, 7]] = 3.0  # 6 of 20: thinned, not refused
    assert drop_rows(RawDrive(cols, {}, "name"), "V-T.csv").n_rows == 14
    cols[c.OMEGA_RL][1] = np.nan  # 7 of 20, more than a third: refused
    with pytest.raises(InputError, match=r"7 of the 20 data rows \(35 %\)"):
        drop_rows(RawDrive(cols, {}, "name"), "V-T.csv")


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(0, 5), min_size=1, max_size=40), st.lists(st.integers(1, 9), max_size=12)
)
def test_the_row_filter_drops_what_drop_rows_drops(kinds, sizes):
    """Rows streamed in any blocks lose the rows the whole-file reader loses, named alike.

    ``kinds``: per row, 0-2 a new row, 3 a copy of the row before, 4 a row without a
    front-right wheel speed, 5 a copy of the row before without that wheel."""
    t, fr = [], []
    for i, k in enumerate(kinds):
        if k in (3, 5) and t:
            t.append(t[-1])
            fr.append(np.nan if k == 5 else fr[-1])
        else:
            t.append(0.1 * i)
            fr.append(np.nan if k in (4, 5) else float(i))
    cols = {c.T_S: np.array(t), **{w: np.arange(len(t), dtype=float) for w in c.WHEELS}}
    cols[c.OMEGA_FR] = np.array(fr)
    for w in (c.OMEGA_FL, c.OMEGA_RL, c.OMEGA_RR):  # a copy copies every column
        cols[w] = np.where(np.r_[False, np.diff(cols[c.T_S]) == 0], np.r_[0, cols[w][:-1]], cols[w])
    raw = RawDrive(cols, {}, "name")
    if np.isnan(cols[c.OMEGA_FR]).sum() >= len(t) / 3:
        return  # refused by drop_rows (tested above); the filter drops them as they come
    whole = drop_rows(raw, "f")
    f, blocks, i = RowFilter(), [], 0
    for n in [*sizes, len(t)]:
        if i < len(t):
            blocks.append((i + 1, {k: v[i : i + n] for k, v in cols.items()}))
        i += n
    kept = list(f.blocks(blocks))
    assert f.dropped == whole.repeated_rows.tolist()
    assert f.wheelless == whole.wheelless_rows.tolist()
    got_rows = [first + j for first, b in kept for j in range(len(b[c.T_S]))]
    assert (
        got_rows
        == FileRows.of({"repeated_rows": f.dropped, "wheelless_rows": f.wheelless})(
            np.arange(whole.n_rows)
        ).tolist()
    )
    np.testing.assert_array_equal(
        np.concatenate([b[c.T_S] for _, b in kept]) if kept else np.zeros(0), whole.columns[c.T_S]
    )


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


def _good_drive_report(tmp_path):
    """validate's report of the corpus's good target drive, written once."""
    once = tmp_path / "once"
    write_good_fleet(once)
    write_target(once, good_target())
    p_once = make_params(once)
    ingest(p_once, tmp_path / "d1", tmp_path / "f1.json")
    ref = validate(p_once, tmp_path / "d1", tmp_path / "s1", tmp_path / "v1.json")
    (good,) = [d for d in ref["drives"] if d["drive"] == DRIVE]
    return good


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
    good = _good_drive_report(tmp_path)
    assert (drive["seconds_kept"], drive["segments"]) == (good["seconds_kept"], good["segments"])
    assert "repeated_rows" not in good
    assert json.loads((tmp_path / "v.json").read_text())["drives"] == report["drives"]


def test_a_block_written_again_is_dropped_and_the_drive_is_the_one_written_once(tmp_path):
    """Rows 301-350 written again after row 400 (a logger's retry), and rows 1001-1100
    again after row 1100 (two exports joined that overlap by 10 s): ingest drops the 150
    copies and validate keeps the seconds of the drive written once; before, validate
    refused the time going back."""
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = written_again(written_again(good_target(), 400, 301, 350), 1150, 1051, 1150)
    write_target(raw, df)
    params = make_params(raw)
    manifest = ingest(params, tmp_path / "drives", tmp_path / "failed.json")
    (entry,) = [d for d in manifest["drives"] if d["drive"] == DRIVE]
    assert entry["repeated_rows"] == [*range(401, 451), *range(1151, 1251)]
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    good = _good_drive_report(tmp_path)
    assert (drive["seconds_kept"], drive["segments"]) == (good["seconds_kept"], good["segments"])
    # one value of the block written again differs: not a copy, and refused as before
    bad = written_again(good_target(), 400, 301, 350)
    bad.loc[410, c.OMEGA_RL] += 0.01  # data row 411, a copy of row 310 but for this
    write_target(raw, bad)
    ingest(params, tmp_path / "drives2", tmp_path / "failed2.json")
    with pytest.raises(InputError) as err:
        validate(params, tmp_path / "drives2", tmp_path / "seg2", tmp_path / "v2.json")
    assert any(p.row == 411 and p.column == " Time" for p in err.value.problems), err.value


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
    args = target_drive_args()
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
    copies = RowFilter()
    out = list(copies.blocks(blocks))
    got_t = np.concatenate([cols[c.T_S] for _, cols in out])
    np.testing.assert_array_equal(got_t, t_once)
    for first, cols in out:
        rows_in_file = first - 1 + np.arange(cols[c.T_S].size)
        np.testing.assert_array_equal(t_file[rows_in_file], cols[c.T_S])
    kept = np.ones(t_file.size, dtype=bool)
    kept[np.array(copies.dropped, dtype=np.int64) - 1] = False
    np.testing.assert_array_equal(t_file[kept], t_once)


def test_ingest_drops_rows_without_a_wheel_speed_and_validate_cuts_their_seconds(tmp_path):
    """The manifest and the report list them by the file's rows (after a copy too), and
    validate cuts the second each leaves short, as for a row the logger never wrote."""
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = written_twice(good_target(), 100)  # data row 101 a copy
    df.loc[rows(df, 800, 800), c.OMEGA_RL] = np.nan
    df.loc[rows(df, 1200, 1201), c.OMEGA_FR] = np.nan
    write_target(raw, df)
    params = make_params(raw)
    manifest = ingest(params, tmp_path / "drives", tmp_path / "failed.json")
    (entry,) = [d for d in manifest["drives"] if d["drive"] == DRIVE]
    assert entry["repeated_rows"] == [101] and entry["wheelless_rows"] == [800, 1200, 1201]
    assert entry["n_rows"] == len(df) - 4
    assert any(
        "3 of" in n and "empty wheel speed (row(s) 800, 1200, 1201)" in n for n in entry["notes"]
    )
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "v.json")
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    assert drive["wheelless_rows"] == {"rows": 3, "listed": [800, 1200, 1201]}
    assert drive["repeated_rows"] == {"rows": 1, "listed": [101]}
    # the drive without those rows, written once: the same seconds and cuts
    alone = tmp_path / "alone"
    write_good_fleet(alone)
    write_target(alone, good_target().drop(index=[799 - 1, 1199 - 1, 1200 - 1]))
    p_alone = make_params(alone)
    ingest(p_alone, tmp_path / "d1", tmp_path / "f1.json")
    ref = validate(p_alone, tmp_path / "d1", tmp_path / "s1", tmp_path / "v1.json")
    (good,) = [d for d in ref["drives"] if d["drive"] == DRIVE]
    assert drive["cut_seconds_by_rule"] == good["cut_seconds_by_rule"]
    assert drive["cut_seconds_by_rule"]["partial_second"] >= 2
    assert (drive["seconds_kept"], drive["segments"]) == (good["seconds_kept"], good["segments"])
