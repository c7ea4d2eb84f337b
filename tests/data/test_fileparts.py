"""A stream a logger split across files in time, joined (rwhonet.data.fileparts) in a stream
folder (rwhonet.data.streamcsv): the drive reads as the one-file drive, every refusal names
the file and row a user opens."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.fileparts import files_label, join_parts
from rwhonet.data.signalmap import Group
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.errors import InputError


def _split(path: Path, cuts: list[int], names: list[str], repeat: bool = False) -> list[Path]:
    """A CSV's data rows cut before rows ``cuts`` (0-based data rows) into files ``names``,
    each with the header; ``repeat``: each file after the first starts with the row before
    its cut again (a logger writing the rotation's sample into both files)."""
    header, *rows = path.read_text().splitlines()
    bounds = [0, *cuts, len(rows)]
    out = []
    for k, name in enumerate(names):
        lo = bounds[k] - (1 if repeat and k else 0)
        part = path.parent / name
        part.write_text("\n".join([header, *rows[lo : bounds[k + 1]]]) + "\n")
        out.append(part)
    path.unlink()
    return out


def _columns(streams):
    return resample(streams).drive.columns


def _assert_same(got, want):
    assert set(got) == set(want)
    for k in want:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


def test_a_stream_split_across_files_reads_as_the_one_file(tmp_path):
    """The wheel speeds in three files and the fixes in two, cut at arbitrary rows, one
    rotation's sample written into both files, the files named so that their names' order
    is not their time order, and given in no order: the grid's every column is the one-file
    drive's, bit for bit; the notes say which files were joined and the copy dropped."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs
    from support.stream_corpus import good_tables

    tables = good_tables()
    one = write_stream_csvs(tables, tmp_path / "one")
    want = _columns(read_stream_csvs(list(one.values()), signal_map(), 0.3))
    split = write_stream_csvs(tables, tmp_path / "split")
    n = len(tables.wheels)
    wheels = _split(split["wheels"], [n // 3, n // 3 + 17], ["w_c.csv", "w_a.csv", "w_b.csv"], True)
    gnss = _split(split["gnss"], [len(tables.gnss) // 2], ["gps_2.csv", "gps_1.csv"])
    streams = read_stream_csvs(
        [wheels[1], gnss[0], wheels[2], gnss[1], wheels[0]], signal_map(), 0.3
    )
    _assert_same(_columns(streams), want)
    (w,) = streams.wheels
    assert [Path(f).name for f, _ in w.parts] == ["w_c.csv", "w_a.csv", "w_b.csv"]
    assert w.name == "w_c.csv + w_a.csv + w_b.csv"
    assert [Path(f).name for f, _ in streams.gnss.parts] == ["gps_2.csv", "gps_1.csv"]
    said = " ".join(streams.notes)
    assert "w_c.csv + " in said and "one stream split across 3 files, joined in time order" in said
    changed = " ".join(streams.changed)
    assert (
        changed.count("(the samples at the files' rotation, written into both): taken as one") == 2
    )


@pytest.mark.parametrize("period", [86400.0, 604800.0])
def test_a_split_stream_across_midnight_gives_the_labels_of_the_drive_by_day(tmp_path, period):
    """Hourly files on a time of day: the wheel speeds in three files, the second across
    midnight, the third after it; the fixes in two, the second starting past midnight.
    Each file's clock is put on the one before's (a day added to the files past midnight),
    and the seconds and labels are those of the same drive by day (within 1e-6 m, the
    clock's rounding). A GPS time of week across the week's end likewise."""
    from rwhonet.sim.streams import (
        StreamTables,
        signal_map,
        write_stream_csvs,
    )
    from support.multirate import START_S, per_second, simulated_streams

    tables, radius = simulated_streams(120.0, 100.0, 10.0)
    shift = period - 60.0 - START_S  # the drive starts a minute before midnight

    def read(files):
        streams = read_stream_csvs(files, signal_map(), radius)
        return per_second(resample(streams, nominal_radius_m=radius).drive.columns, radius), streams

    day, _ = read(list(write_stream_csvs(tables, tmp_path / "day").values()))
    night = StreamTables(
        *(d.assign(t_s=(d[c.T_S] + shift) % period) for d in (tables.wheels, tables.gnss))
    )
    files = write_stream_csvs(night, tmp_path / "night")
    wt = night.wheels[c.T_S].to_numpy()
    gt = night.gnss[c.T_S].to_numpy()
    cuts = [int(np.argmax(wt > period - 30.0)), int(np.argmax((wt > 30.0) & (wt < 3600.0)))]
    wheels = _split(files["wheels"], cuts, ["wheels_22h.csv", "wheels_23h.csv", "wheels_00h.csv"])
    gnss = _split(files["gnss"], [int(np.argmax(gt < 3600.0))], ["gnss_1.csv", "gnss_2.csv"])
    got, streams = read([*wheels, *gnss])
    end = "midnight" if period == 86400.0 else "the week's end"
    said = " ".join(streams.notes)
    assert f"wheels_00h.csv: starts past {end}, after the stream's other files" in said
    assert f"gnss_2.csv: starts past {end}, after the stream's other files" in said
    assert len(got) == len(day) > 90
    np.testing.assert_allclose(got["t_s"], day["t_s"] + shift, rtol=0, atol=1e-3)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], day[q], rtol=0, atol=1e-6)


def test_a_refusal_in_a_later_file_names_that_file_and_its_own_row(tmp_path):
    """A time going back in the second file's 7th data row, a latitude out of range in the
    first file's 4th: each problem names its own file and the row in it (not the row in
    the files laid end to end)."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs
    from support.stream_corpus import good_tables

    files = write_stream_csvs(good_tables(), tmp_path)
    n = len(good_tables().wheels)
    wheels = _split(files["wheels"], [n // 2], ["wheels_1.csv", "wheels_2.csv"])
    header, *rows = wheels[1].read_text().splitlines()
    rows[6] = ",".join(["0.5", *rows[6].split(",")[1:]])  # far before its neighbours
    wheels[1].write_text("\n".join([header, *rows]) + "\n")
    gnss = _split(files["gnss"], [len(good_tables().gnss) // 2], ["gnss_1.csv", "gnss_2.csv"])
    header, *rows = gnss[0].read_text().splitlines()
    cells = rows[3].split(",")
    lat = header.split(",").index("Latitude")
    cells[lat] = "152.5"
    rows[3] = ",".join(cells)
    gnss[0].write_text("\n".join([header, *rows]) + "\n")
    with pytest.raises(InputError) as err:
        _columns(read_stream_csvs([*wheels, *gnss], signal_map(), 0.3))
    places = {(Path(p.file.split(" [")[0]).name, p.row, p.column) for p in err.value.problems}
    assert ("wheels_2.csv", 7, "Time") in places, places
    assert ("gnss_1.csv", 4, "Latitude") in places, places


def test_files_of_one_stream_that_overlap_with_other_values_are_refused(tmp_path):
    """The second file starting 5 rows before the first ends, with other values (a second
    logger on the same bus): refused, naming the second file, its first overlapping row and
    both files' times. The same file given twice under two names is a copy: left out, and
    said."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs
    from support.stream_corpus import good_tables

    files = write_stream_csvs(good_tables(), tmp_path)
    header, *rows = files["wheels"].read_text().splitlines()
    half = len(rows) // 2
    (tmp_path / "wheels_1.csv").write_text("\n".join([header, *rows[:half]]) + "\n")
    moved = [
        ",".join([r.split(",")[0], *(f"{float(x) + 0.5!r}" for x in r.split(",")[1:])])
        for r in rows[half - 5 :]
    ]
    (tmp_path / "wheels_2.csv").write_text("\n".join([header, *moved]) + "\n")
    files["wheels"].unlink()
    paths = [files["gnss"], tmp_path / "wheels_1.csv", tmp_path / "wheels_2.csv"]
    with pytest.raises(InputError) as err:
        read_stream_csvs(paths, signal_map(), 0.3)
    (problem,) = err.value.problems
    assert Path(problem.file.split(" [")[0]).name == "wheels_2.csv"
    assert problem.row == 1 and problem.column == "Time"
    assert "wheels_1.csv" in problem.expected and "the files overlap by" in problem.found
    assert "leave one out" in problem.fix
    (tmp_path / "wheels_2.csv").write_text("\n".join([header, *rows[:half]]) + "\n")
    streams = read_stream_csvs(paths, signal_map(), 0.3)  # a copy: left out, and said
    assert streams.wheels[0].n_rows == half
    assert "wheels_2.csv [wheels_2.csv]: a copy of " in " ".join(streams.changed)


def test_files_with_a_column_in_common_but_not_all_are_refused_naming_each(tmp_path):
    """A key in two files whose mapped columns differ (the first also holds the yaw rate):
    no one stream split in time; refused, naming each file with its mapped keys."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs
    from support.stream_corpus import good_tables

    files = write_stream_csvs(good_tables(), tmp_path)
    header, *rows = files["wheels"].read_text().splitlines()
    half = len(rows) // 2
    (tmp_path / "wheels_1.csv").write_text(
        "\n".join([header + ",YawRate", *(r + ",0.01" for r in rows[:half])]) + "\n"
    )
    (tmp_path / "wheels_2.csv").write_text("\n".join([header, *rows[half:]]) + "\n")
    files["wheels"].unlink()
    paths = [files["gnss"], tmp_path / "wheels_1.csv", tmp_path / "wheels_2.csv"]
    smap = signal_map() | {"yaw_rate": ColumnSpec("YawRate", "rad/s")}
    with pytest.raises(InputError) as err:
        read_stream_csvs(paths, smap, 0.3)
    problem = next(p for p in err.value.problems if p.column == "WheelSpeed_FL")
    assert problem.found.startswith("in 2 files: ") and "yaw_rate" in problem.found
    assert "each file of one stream a logger split in time" in problem.expected


def _can_drive(tmp_path):
    """A simulated minute's streams as raw CAN frames (``(stamps, ids, data)`` on a Unix
    clock), the car's radius, the map, the DBC beside them, and the frames' streams read
    from one candump log (one/can0.log)."""
    from support.canlog import DBC, SIGNALS, stream_frames, write_candump
    from support.multirate import simulated_streams

    tables, radius = simulated_streams(60.0, 50.0, 5.0)
    frames = stream_frames(tables, radius, 1_700_000_000.0)
    (tmp_path / "bus.dbc").write_text(DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    smap = {"t": ColumnSpec("t", "s")} | {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    (tmp_path / "one").mkdir()
    one = write_candump(*frames, tmp_path / "one" / "can0.log")
    return (
        frames,
        radius,
        smap,
        dbc,
        read_stream_csvs([one], smap, radius, "m", {one: "can0.log"}, dbc),
    )


def test_a_can_log_split_across_files_reads_as_the_one_log(tmp_path):
    """``candump -l`` under a log rotator: can0.log.1 ... as can0_1.log, can0_2.log beside
    the DBC: each message's frames joined across the logs; the wheel speeds and fixes are
    the one log's, bit for bit."""
    from support.canlog import write_candump

    (stamps, ids, data), radius, smap, dbc, want = _can_drive(tmp_path)
    cut = len(stamps) // 3
    (tmp_path / "split").mkdir()
    logs = [
        write_candump(stamps[cut:], ids[cut:], data[cut:], tmp_path / "split" / "can0_2.log"),
        write_candump(stamps[:cut], ids[:cut], data[:cut], tmp_path / "split" / "can0_1.log"),
    ]
    got = read_stream_csvs(logs, smap, radius, "m", {p: p.name for p in logs}, dbc)
    _assert_same(_columns(got), _columns(want))
    (w,) = got.wheels
    assert [f for f, _ in w.parts] == ["can0_1.log", "can0_2.log"]
    assert w.where() == "can0_1.log + can0_2.log [WheelSpeeds 0x1A0]"


def test_a_canedge_drive_of_split_mf4_files_reads_as_its_frames_in_one_log(tmp_path):
    """A CANedge splits its MDF4 bus log into files, each with its own start time and a
    master time counting from it: three such files (given in no order) beside the DBC read
    as the same frames in one candump log (each file put on its start; the grid's times
    within 1 µs, its wheel speeds within 1e-5 rad/s: candump writes its stamps to the µs,
    which moves a frame near a grid row's edge to the other side)."""
    from support.canlog import write_mdf_bus_log

    (stamps, ids, data), radius, smap, dbc, one = _can_drive(tmp_path)
    want = _columns(one)
    cuts = np.searchsorted(stamps, stamps[0] + np.array([20.0, 41.0]))
    files = [
        write_mdf_bus_log(stamps[i], ids[i], data[i], tmp_path / "LOG" / f"0000000{k + 1}.MF4")
        for k, i in enumerate(np.split(np.arange(stamps.size), cuts))
    ]
    got_streams = read_stream_csvs(files[::-1], smap, radius, "m", {p: p.name for p in files}, dbc)
    got = _columns(got_streams)
    assert got.keys() == want.keys()
    np.testing.assert_allclose(got[c.T_S], want[c.T_S], rtol=0, atol=1e-6)
    for k in c.WHEELS:
        np.testing.assert_allclose(got[k], want[k], rtol=0, atol=1e-5)
    np.testing.assert_allclose(got[c.LAT_DEG], want[c.LAT_DEG], rtol=0, atol=1e-9)
    (w,) = got_streams.wheels
    assert [f for f, _ in w.parts] == ["00000001.MF4", "00000002.MF4", "00000003.MF4"]
    said = " ".join(got_streams.notes)
    start = "(2023-11-15T10:43:40.038663+00:00) plus its master time: Unix time"
    assert f"00000002.MF4: its times are its start {start}" in said
    # a file whose start is marked local time: read as it is, and the note says so
    from asammdf import MDF

    with MDF(files[0]) as mdf:
        mdf.header.time_flags = 1  # MDF4's local-time flag
        mdf.save(tmp_path / "local.mf4", overwrite=True)
    local = tmp_path / "local.mf4"
    streams = read_stream_csvs([local], smap, radius, "m", {local: "local.mf4"}, dbc)
    assert "plus its master time: a local time (the file marks its start as local" in " ".join(
        streams.notes
    )
    # with the map's local_zone, that local start is put on UTC: Tokyo's 9 h ahead of it
    zoned = read_stream_csvs(
        [local], smap, radius, "m", {local: "local.mf4"}, dbc, local_zone="Asia/Tokyo"
    )
    (w0,), (w1,) = streams.wheels, zoned.wheels
    np.testing.assert_allclose(w1.t_s, w0.t_s - 9 * 3600.0, rtol=0, atol=1e-6)
    assert "local time; in Asia/Tokyo, the map's local_zone" in " ".join(zoned.notes)
    # the flag a receiver's UTC log beside it reads, to name local_zone in its refusal: a
    # local start without the zone (a start on UTC, or put on it, is no local clock)
    from rwhonet.data.mdf4 import can_log_groups

    flagged = {
        zone: can_log_groups(local, smap, radius, "m", "local.mf4", dbc, True, zone).local_clock
        for zone in (None, "Asia/Tokyo")
    }
    utc = can_log_groups(files[0], smap, radius, "m", "f.mf4", dbc, True).local_clock
    assert flagged == {None: True, "Asia/Tokyo": False} and not utc


def test_a_glitch_in_a_later_file_is_placed_in_that_file():
    """The resampler's glitched samples of a joined stream name each sample's own file and
    row (what validate lists)."""
    t = np.arange(0.0, 20.0, 0.01)
    w = np.full(t.size, 40.0)
    fl = w.copy()
    fl[1507] = 400.0  # the front left wheel at a speed no tyre reaches in 10 ms
    parts = []
    for k, (lo, hi) in enumerate(((0, 1000), (1000, t.size))):
        chans = {f"omega_{x}": w[lo:hi].copy() for x in ("fr", "rl", "rr")}
        chans["omega_fl"] = fl[lo:hi].copy()
        parts.append(Group(f"w{k + 1}.csv", f"w{k + 1}.csv", t[lo:hi], chans, {"t": "Time"}))
    tg = np.arange(0.0, 20.0, 0.1)
    fixes = {"lat": 52.4 + 1e-5 * tg, "lon": np.full(tg.size, -1.5)}
    notes, changed = [], []
    groups = join_parts([*parts, Group("g.csv", "g.csv", tg, fixes, {"t": "Time"})], notes, changed)
    from rwhonet.data.signalmap import build_streams

    res = resample(build_streams(groups, "test clock"), nominal_radius_m=0.3)
    assert {(where, row) for where, row, _, _ in res.glitch_samples} == {("w2.csv", 508)}


def test_files_label():
    assert files_label(["a.csv", "b.csv"]) == "a.csv + b.csv"
    assert files_label([f"w{k}.csv" for k in range(5)]) == "w0.csv + ... + w4.csv (5 files)"


def test_an_mdf4_bus_log_s_local_start_in_the_hour_the_clocks_went_back_is_refused(tmp_path):
    """A CANedge's file whose start is marked local time, 02:30 on the night Berlin's
    clocks went back: with local_zone Europe/Berlin it is two instants, refused naming the
    file and both offsets; with the fixed zone the logger kept, read an hour apart."""
    from datetime import UTC, datetime

    from asammdf import MDF

    from support.canlog import write_mdf_bus_log

    (stamps, ids, data), radius, smap, dbc, _ = _can_drive(tmp_path)
    plain = write_mdf_bus_log(stamps, ids, data, tmp_path / "LOG" / "00000001.MF4")
    with MDF(plain) as mdf:
        mdf.header.start_time = datetime(2024, 10, 27, 2, 30)
        mdf.header.time_flags = 1  # MDF4's local-time flag
        mdf.save(tmp_path / "local.mf4", overwrite=True)
    local = tmp_path / "local.mf4"
    with pytest.raises(InputError) as err:
        read_stream_csvs([local], smap, radius, "m", {local: "local.mf4"}, dbc, "Europe/Berlin")
    said = str(err.value)
    assert "local.mf4, column 'start time'" in said
    assert "in the hour its clocks went back: UTC+2 or UTC+1" in said
    first, second = (
        read_stream_csvs([local], smap, radius, "m", {local: "local.mf4"}, dbc, z).wheels[0].t_s
        for z in ("Etc/GMT-2", "Etc/GMT-1")
    )
    np.testing.assert_allclose(second - first, 3600.0, rtol=0, atol=1e-6)
    at = datetime(2024, 10, 27, 0, 30, tzinfo=UTC).timestamp()  # 02:30 at UTC+2
    assert at <= first[0] < at + 60.0
