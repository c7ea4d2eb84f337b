"""A NovAtel receiver's ASCII logs beside a drive's stream CSVs (rwhonet.data.novatel).

The logs are written by tests/support/novatel.py, whose CRC-32 is computed bit by bit as
NovAtel's reference code does, and three BESTPOSA lines published with their CRCs (by
NovAtel's decoder's tests and a ROS driver's) are read as printed."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.novatel import crc32, gps_utc_s, is_novatel_log, read_novatel
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.multirate import fixes_to_the_ms, receiver_drive, receiver_folder, receiver_labels
from support.novatel import (
    GPS_EPOCH_UNIX_S,
    binary_log,
    log,
    novatel_binary,
    novatel_lines,
    write_binary,
    write_novatel,
)

DAY_S = 1_552_262_400.0  # 2019-03-11 00:00:00 UTC
PUBLISHED = [
    # NovAtel EDIE's tests
    "#BESTPOSA,COM1,0,83.5,FINESTEERING,2163,329760.000,02400000,b1f6,65535;SOL_COMPUTED,"
    "SINGLE,51.15043874397,-114.03066788586,1097.6822,-17.0000,WGS84,1.3648,1.1806,3.1112,"
    '"",0.000,0.000,18,18,18,0,00,02,11,01*c3194e35',
    "#BESTPOSA,COM1,0,60.5,FINESTEERING,2166,327153.000,02000000,b1f6,16248;SOL_COMPUTED,WAAS,"
    "51.15043699323,-114.03067932462,1096.9772,-17.0000,WGS84,0.6074,0.5792,0.9564,"
    '"131",7.000,0.000,42,34,34,28,00,0b,1f,37*47bbdc4f',
    # swri-robotics' novatel_gps_driver's tests
    "#BESTPOSA,ICOM1,0,87.5,FINESTEERING,1956,157432.000,00000800,7145,6938;SOL_COMPUTED,"
    "SINGLE,29.44391220792,-98.61476921244,261.4344,-26.0000,WGS84,2.1382,3.1092,4.0429,"
    '"",0.000,0.000,8,8,8,8,0,06,00,03*ecf2202b',
]


def test_published_lines_are_read_as_printed(tmp_path):
    for line in PUBLISHED:
        body, crc = line[1:].split("*")
        assert crc32(body.encode()) == int(crc, 16)
    log_ = read_novatel(write_novatel(tmp_path / "a.gps", PUBLISHED), "a.gps")
    # in the log's order of GPS time: weeks 2163, 2166, 1956
    np.testing.assert_array_equal(
        log_.channels["lat"], [51.15043874397, 51.15043699323, 29.44391220792]
    )
    np.testing.assert_array_equal(log_.channels["n_sats"], [18, 34, 8])
    np.testing.assert_array_equal(log_.channels["height"], [1097.6822, 1096.9772, 261.4344])
    utc = log_.day_s + log_.tod_s
    assert utc[0] == GPS_EPOCH_UNIX_S + 2163 * 604800 + 329760.0 - 18
    assert "by the leap seconds to its date (18 s; no valid TIME log" in log_.notes[0]


def test_logger_stamps_give_the_labels_of_the_csv_fixes(tmp_path):
    """Each log after the logger's stamp (``[12.345] #BESTPOSA...``: its time on the
    wheels' clock, here the logger's own): the stamps are the fixes' times, and the labels
    are those of the same fixes in gnss.csv, within 0.01 mm. One epoch without a stamp:
    placed as unstamped, and refused beside the logger's own clock, naming its line."""
    g = fixes_to_the_ms()
    t = g[c.T_S].to_numpy()
    ref, _ = receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()))
    lines = novatel_lines(g, DAY_S + t, time_logs=False)
    stamped = [f"[{x:.3f}] {line}" for x, line in zip(t, lines, strict=True)]
    wheels = receiver_folder(tmp_path / "gps", g.iloc[:0])["wheels"]
    log_ = write_novatel(tmp_path / "gps" / "drive.gps", stamped)
    assert read_novatel(log_, "drive.gps").stamps[:2] == [f"{x:.3f}" for x in t[:2]]
    assert is_novatel_log(write_novatel(tmp_path / "stamped" / "drive.log", stamped))
    got, streams = receiver_labels([wheels, log_])
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)
    assert "logger stamp is its time on the stream files' clock" in " ".join(streams.notes)
    own = receiver_folder(tmp_path / "own", g.iloc[:0])["wheels"]
    df = pd.read_csv(own)
    df[df.columns[0]] -= 44_000.0  # the logger's clock from its start (1000 s on)
    df.to_csv(own, index=False, float_format="%.6f")
    own_stamps = [f"[{x - 44_000.0:.3f}] {line}" for x, line in zip(t, lines, strict=True)]
    own_stamps[5] = lines[5]  # the sixth epoch's log without its stamp
    log_ = write_novatel(tmp_path / "own" / "drive.gps", own_stamps)
    with pytest.raises(InputError) as err:
        receiver_labels([own, log_])
    said = str(err.value)
    assert "1 of 1199 epochs' sentences without a logger stamp (first at line 6)" in said


# NovAtel EDIE's tests: a binary BESTPOS (104 bytes: its header, message and CRC)
PUBLISHED_BINARY = bytes.fromhex(
    "aa44121c2a00002048000000a3b4730898 74a81300000002f6b1ffff".replace(" ", "")
    + "000000001000000 0fcabe182419349 40ba32868af6815c c00010e5df712391 40".replace(" ", "")
    + "000088c13d0000002421a53ff18f8f3f43743c40000000000000000000000000"
    + "151515000002110155cec389"
)


def test_a_published_binary_log_is_read(tmp_path):
    """BESTPOSB: week 2163, 329807.000 s, SOL_COMPUTED SINGLE, 21 satellites, its CRC."""
    assert len(PUBLISHED_BINARY) == 104
    log_ = read_novatel(write_binary(tmp_path / "a.gps", [PUBLISHED_BINARY]), "a.gps")
    assert log_.channels["lat"][0] == pytest.approx(51.150436744872394, abs=1e-12)
    assert log_.channels["lon"][0] == pytest.approx(-114.03067267518318, abs=1e-12)
    assert log_.channels["n_sats"][0] == 21 and log_.sources["lat"] == "BESTPOSB lat"
    assert log_.day_s + log_.tod_s[0] == GPS_EPOCH_UNIX_S + 2163 * 604800 + 329807.0 - 18
    assert "a NovAtel log (binary): 1 epochs (BESTPOSB), 1 with a fix" in log_.notes[0]


def test_binary_logs_give_the_ascii_logs_labels(tmp_path):
    """The drive's fixes as binary TIMEB, BESTPOSB and BESTVELB logs (among other binary
    messages): the labels of the ASCII logs within 0.01 mm (the ASCII's 11 decimals); a
    CRC broken and the last log cut short: passed over, counted by log number. Named
    drive.log beside nothing else, it is told a NovAtel log by its bytes."""
    g = fixes_to_the_ms()
    t = DAY_S + g[c.T_S].to_numpy()
    wheels = receiver_folder(tmp_path / "a", g.iloc[:0])["wheels"]
    ascii_, _ = receiver_labels(
        [wheels, write_novatel(tmp_path / "a" / "drive.gps", novatel_lines(g, t))]
    )
    messages = novatel_binary(g, t)
    messages.insert(5, binary_log(43, t[1] - GPS_EPOCH_UNIX_S + 18, b"\0" * 40))  # a RANGEB
    broken = bytearray(messages[7])
    broken[40] ^= 1
    messages[7] = bytes(broken)
    messages.append(messages[-1][:50])
    log_ = write_binary(tmp_path / "b" / "drive.log", messages)
    assert is_novatel_log(log_)
    wheels = receiver_folder(tmp_path / "b", g.iloc[:0])["wheels"]
    got, streams = receiver_labels([wheels, log_])
    for q in ascii_.columns:
        np.testing.assert_allclose(got[q], ascii_[q], rtol=0, atol=1e-5, err_msg=q)
    said = " ".join(streams.notes)
    assert "besides them: message ID 43 (binary) 1" in said
    assert "1 log(s) whose CRC does not match (first at binary log 8)" in said
    assert "1 log(s) cut short (first at binary log " in said


def test_leap_seconds():
    assert gps_utc_s(DAY_S) == 18
    assert gps_utc_s(1_483_228_799) == 17 and gps_utc_s(1_483_228_800) == 18
    assert gps_utc_s(1_000_000_000) == 13  # 2001


def test_the_novatel_log_gives_the_labels_of_the_csv_fixes(tmp_path):
    """wheels.csv on the time of day, the fixes as drive.gps (TIMEA and BESTPOSA an
    epoch; the table has no speed, so no BESTVELA): the labels of the same fixes in
    gnss.csv, within 0.01 mm (2.4 um measured: 1e-11 degrees and the CSV's digits)."""
    g = fixes_to_the_ms()
    ref, _ = receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()))
    files = [receiver_folder(tmp_path / "gps", g.iloc[:0])["wheels"]]
    files.append(write_novatel(tmp_path / "gps" / "drive.gps", novatel_lines(g, DAY_S + g[c.T_S])))
    got, streams = receiver_labels(files)
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)
    said = " ".join(streams.notes)
    assert "a NovAtel log: 1199 epochs (BESTPOSA), 1199 with a fix" in said
    assert "GPS time put on UTC by its TIME logs' utc_offset (-18 s)" in said
    gnss = next(s for s in streams.streams if s.name == "drive.gps")
    assert gnss.sources[c.LAT_DEG] == "BESTPOSA lat" and gnss.rows[1] == 4  # TIMEA, BESTPOSA


def test_a_leap_second_the_table_does_not_know_is_found_by_the_wheels(tmp_path):
    """A log without TIME, recorded after a leap second later than the reader's table
    (GPS time 19 s ahead of UTC, the table's 18): its fixes land a second late. The
    docstring's claim, checked: the resampler's search for two clocks finds the second
    (before stop 78 it stood at the latency search's edge and the fixes were kept a second
    off their wheels); report refuses the drive naming it, auto gives the labels of the
    drive's fixes on their true times."""
    g = fixes_to_the_ms()
    ref, _ = receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()))
    files = [receiver_folder(tmp_path / "gps", g.iloc[:0])["wheels"]]
    late = novatel_lines(g, DAY_S + g[c.T_S] + 1.0, time_logs=False)
    files.append(write_novatel(tmp_path / "gps" / "drive.gps", late))
    with pytest.raises(InputError) as err:
        receiver_labels(files)
    (problem,) = err.value.problems
    assert re.search(r"the fixes 1\.00\d ± 0\.00\d s earlier than stamped", problem.found)
    assert "(a leap second: UTC by a leap-second count one out of date?)" in problem.found
    assert re.match(r"set data\.gnss_lag: 1\.00\d ", problem.fix)
    # the user's 1 s gives the labels to 2.4 um; auto's estimate (1.005 s, the wheels'
    # slip terms' few ms) moves a second's displacement by up to 2.9 cm where it brakes
    for mode, atol in ((1.0, 1e-5), ("auto", 0.05)):
        got, streams = receiver_labels(files, gnss_lag=mode)
        assert "put on UTC by the leap seconds" in " ".join(streams.notes)
        assert len(got) == len(ref) > 100
        np.testing.assert_array_equal(got["t_s"], ref["t_s"])
        for q in ("disp_gnss_m", "label_m"):
            np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=atol, err_msg=q)


@pytest.mark.parametrize(
    ("status", "kind", "fix"),
    [
        ("SOL_COMPUTED", "SINGLE", True),
        ("SOL_COMPUTED", "NARROW_INT", True),
        ("SOL_COMPUTED", "INS_RTKFIXED", True),
        ("SOL_COMPUTED", "PROPAGATED", False),
        ("SOL_COMPUTED", "FIXEDPOS", False),
        ("INSUFFICIENT_OBS", "NONE", False),
        ("COLD_START", "SINGLE", False),
    ],
)
def test_what_is_a_fix(tmp_path, status, kind, fix):
    t = DAY_S - GPS_EPOCH_UNIX_S + 18 + 45000.0
    fields = [
        status,
        kind,
        "52.4",
        "-1.5",
        "112.0",
        "-17.0",
        "WGS84",
        "1",
        "1",
        "1",
        '""',
        "0",
        "0",
        "12",
        "10",
        "10",
        "0",
        "00",
        "02",
        "11",
        "01",
    ]
    vel = ["SOL_COMPUTED", "DOPPLER_VELOCITY", "0.15", "0", "10.5", "90.0", "0", "0"]
    lines = [log("BESTPOSA", t, fields), log("BESTVELA", t, vel)]
    got = read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    for key in ("lat", "lon", "speed_gnss", "heading"):
        assert np.isfinite(got.channels[key][0]) == fix, key
    assert got.channels["n_sats"][0] == 10


def test_damage_is_passed_over_and_counted(tmp_path):
    """A CRC that does not match, a line cut short, an epoch given twice, a time status
    UNKNOWN: passed over, counted with their first lines; the rest read."""
    g = fixes_to_the_ms().iloc[:20]
    lines = novatel_lines(g, DAY_S + g[c.T_S], velocity=None, time_logs=False)
    lines[3] = lines[3].replace("52.", "53.", 1)  # the CRC no longer matches
    lines[5] = lines[5][:60]  # cut short
    lines.insert(8, lines[7])  # written twice
    t_gps = DAY_S + float(g[c.T_S].iloc[10]) - GPS_EPOCH_UNIX_S + 18
    lines[11] = log("BESTPOSA", t_gps, lines[11].split(";")[1].split("*")[0].split(","), "UNKNOWN")
    got = read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    assert got.rows.size == 17
    assert got.dropped == (
        "1 log(s) whose CRC does not match (first at line 4); 1 log(s) cut short (first at "
        "line 6); 1 BESTPOSA log(s) of the time status UNKNOWN (first at line 12); 1 BESTPOSA "
        "log(s) of an epoch already given (first at line 9)"
    )


def test_bestgnsspos_is_read_before_bestpos(tmp_path):
    """A SPAN system logs BESTPOS blended with its INS and BESTGNSSPOS from the GNSS alone:
    the GNSS's are the fixes."""
    g = fixes_to_the_ms().iloc[:30]
    t = DAY_S + g[c.T_S]
    moved = g.assign(**{c.LAT_DEG: g[c.LAT_DEG] + 0.001})
    lines = novatel_lines(moved, t, "BESTPOSA") + novatel_lines(
        g, t, "BESTGNSSPOSA", time_logs=False
    )
    got = read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    np.testing.assert_array_equal(got.channels["lat"], np.round(g[c.LAT_DEG].to_numpy(), 11))
    assert "left out: BESTPOSA 30 (the GNSS-only solution read)" in got.notes[0]


def test_a_log_without_a_position_log_is_refused_naming_what_it_holds(tmp_path):
    t = 2_000_000_000.0
    lines = [log("RANGEA", t + k, ["0"]) for k in range(3)] + [log("RXSTATUSA", t, ["0"])]
    with pytest.raises(InputError) as err:
        read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    said = str(err.value)
    assert "expected a NovAtel receiver's BESTPOSA or BESTGNSSPOSA logs" in said
    assert "other logs (RANGEA 3, RXSTATUSA 1)" in said


def test_bad_fields_are_refused_at_their_line(tmp_path):
    g = fixes_to_the_ms().iloc[:5]
    lines = novatel_lines(g, DAY_S + g[c.T_S], velocity=None, time_logs=False)
    fields = lines[2].split(";")[1].split("*")[0].split(",")
    t_gps = DAY_S + float(g[c.T_S].iloc[2]) - GPS_EPOCH_UNIX_S + 18
    lines[2] = log("BESTPOSA", t_gps, fields[:2] + ["95.0", "x"] + fields[4:])
    with pytest.raises(InputError) as err:
        read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    said = str(err.value)
    assert "a.gps, row 3, column 'lon': expected a number; found 'x'" in said
    assert "a.gps, row 3, column 'lat': expected a lat in [-90, 90] degrees" in said


def test_a_novatel_asc_or_log_beside_a_candump_log_is_told_by_what_it_holds(tmp_path):
    """A NovAtel log named drive.log (or .asc, as NovAtel's converter writes) among a Linux
    logger's can0.log with the map's DBC: read as the fixes, the candump log as the bus;
    the same labels as the NovAtel log named drive.gps."""
    from rwhonet.config import ColumnSpec
    from rwhonet.sim.streams import StreamTables
    from support.canlog import DBC, stream_frames, write_candump

    tables, radius = receiver_drive()
    g = fixes_to_the_ms()
    wheels_only = StreamTables(tables.wheels, tables.gnss.iloc[:0])
    frames = stream_frames(wheels_only, radius, DAY_S)
    signals = {"t": ColumnSpec("t", "s")} | {
        f"omega_{w}": ColumnSpec(f"WhlSpd_{w.upper()}", "km/h") for w in ("fl", "fr", "rl", "rr")
    }
    (tmp_path / "bus.dbc").write_text(DBC)
    got = {}
    for name in ("drive.gps", "drive.log", "drive.asc"):
        folder = tmp_path / name.replace(".", "_")
        folder.mkdir()
        can = write_candump(*frames, folder / "can0.log")
        gps = write_novatel(folder / name, novatel_lines(g, DAY_S + g[c.T_S]))
        assert is_novatel_log(gps) and not is_novatel_log(can)
        streams = read_stream_csvs(
            [can, gps], signals, radius, "map", None, [str(tmp_path / "bus.dbc")]
        )
        got[name] = resample(streams, nominal_radius_m=radius).drive.columns
    for name in ("drive.log", "drive.asc"):
        for k, v in got["drive.gps"].items():
            np.testing.assert_array_equal(got[name][k], v, err_msg=f"{name} {k}")


def test_the_real_minute_s_fixes_as_a_novatel_log(tmp_path):
    """The RAV4's wheel speeds in wheels.csv on the receiver's UTC, its recorded u-blox
    fixes written as BESTPOSA and BESTVELA logs (with TIMEA) in place of GGA and RMC: the
    NMEA log's 59 seconds, times and wheel travel identical, the GNSS displacement within
    2 mm (the NMEA log's ddmm.mmmmmm against 1e-11 degrees)."""
    from support.realminute import minute_seconds, write_minute_nmea

    ref, _ = minute_seconds(tmp_path / "nmea", write_minute_nmea)
    got, said = minute_seconds(
        tmp_path / "novatel",
        lambda d, f, t: write_novatel(d / "drive.gps", novatel_lines(f, t)),
    )
    assert "GPS weeks, on the stream files' UTC" in said
    assert len(got) == len(ref) == 59
    for q in ("t_s", "disp_wpm_m"):
        np.testing.assert_array_equal(got[q], ref[q], err_msg=q)
    for q in ("disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=2e-3, err_msg=q)


@pytest.mark.parametrize("name", ["drive.log.gz", "drive.asc.zst"])
@pytest.mark.parametrize("dbc", [False, True])
def test_a_novatel_asc_or_log_kept_compressed_is_told_by_what_it_holds(tmp_path, name, dbc):
    """A NovAtel log named drive.log.gz (or .asc.zst) in a stream folder is told from a CAN
    log by the text it unpacks to, as drive.log is: read as the fixes (before, without a
    map's dbc the folder left it out, and with one it was taken for a raw CAN log, its
    unpacked copy unbounded by data.max_file_mb and its size not counted); the labels of
    the same log as drive.gps."""
    import gzip

    import pyarrow as pa

    from rwhonet.data.compressed import without_suffix
    from rwhonet.data.drivefile import DriveFile, _read_in_parts, read_any
    from support.canlog import DBC
    from support.drives import make_params
    from support.stream_fleet import signal_map_params

    g = fixes_to_the_ms()
    text = "\n".join(novatel_lines(g, DAY_S + g[c.T_S])).encode() + b"\n"
    packed = (
        gzip.compress(text, mtime=0)
        if name.endswith(".gz")
        else pa.compress(text, codec="zstd", asbytes=True)
    )
    smap = signal_map_params("stream_csv")
    if dbc:
        (tmp_path / "bus.dbc").write_text(DBC)
        smap["dbc"] = str(tmp_path / "bus.dbc")
    got = {}
    for kept in ("drive.gps", name):
        folder = tmp_path / kept.replace(".", "_")
        for k, written in receiver_folder(folder, g.iloc[:0]).items():
            if k != "wheels":  # the fixes are the log's
                written.unlink()
        if kept == name:
            (folder / kept).write_bytes(packed)
            assert is_novatel_log(folder / kept)
            # a receiver's log, read whole: counted in the drive's size, unpacked under it
            assert not _read_in_parts(without_suffix(name), folder / kept)
        else:
            write_novatel(folder / kept, novatel_lines(g, DAY_S + g[c.T_S]))
        data = make_params(tmp_path, **{"data.signal_maps": {"logger": smap}}).data
        f = DriveFile(kept, "target_test", "target", "logger", folder)
        drive, facts = read_any(f, data, lambda p: p.name, receiver_drive()[1], 0.1, 10.0)
        got[kept] = drive
    for k, v in got["drive.gps"].columns.items():
        np.testing.assert_array_equal(got[name].columns[k], v, err_msg=k)


# NovAtel EDIE's tests: a BESTPOS in abbreviated ASCII as a terminal shows it, the
# receiver's prompt after it
ABBREVIATED = [
    "<BESTPOS COM1 0 72.0 FINESTEERING 2215 148248.000 02000020 cdba 32768",
    "<     SOL_COMPUTED SINGLE 51.15043711386 -114.03067767000 1097.2099 -17.0000 WGS84 "
    '0.9038 0.8534 1.7480 "" 0.000 0.000 35 30 30 30 00 06 39 33',
    "[COM1]",
]


def _abbreviate(line: str) -> list[str]:
    """An ASCII log (``#BESTPOSA,...;...*crc``) as abbreviated ASCII writes it: the
    header spaced without the name's ``A``, the fields spaced on a line of their own."""
    head, body = line[1 : line.rindex("*")].split(";")
    name, *rest = head.split(",")
    return [" ".join([f"<{name[:-1]}", *rest]), "<     " + " ".join(body.split(","))]


def test_a_published_abbreviated_log_is_read_as_printed(tmp_path):
    log_ = read_novatel(write_novatel(tmp_path / "a.gps", ABBREVIATED), "a.gps")
    np.testing.assert_array_equal(log_.channels["lat"], [51.15043711386])
    np.testing.assert_array_equal(log_.channels["lon"], [-114.03067767])
    np.testing.assert_array_equal(log_.channels["height"], [1097.2099])
    np.testing.assert_array_equal(log_.channels["n_sats"], [30])
    assert log_.day_s + log_.tod_s[0] == GPS_EPOCH_UNIX_S + 2215 * 604800 + 148248.0 - 18
    assert log_.rows.tolist() == [1] and log_.stamps is None
    assert "(1 logs in abbreviated ASCII: no CRC to check)" in log_.notes[0]
    assert is_novatel_log(write_novatel(tmp_path / "drive.log", ABBREVIATED))


def test_an_abbreviated_log_gives_the_labels_of_the_ascii_log(tmp_path):
    """The drive's fixes logged from a terminal (``LOG BESTPOS ONTIME 0.1``, ``LOG
    BESTVEL``, ``LOG TIME``: abbreviated ASCII, the receiver's prompt ``[COM1]`` before
    each log): the labels of the same logs in ASCII, bit for bit. A header whose fields
    line is lost, a fields line cut short and a header the log ends after are passed over
    as cut, with their lines."""
    g = fixes_to_the_ms()
    lines = novatel_lines(g, DAY_S + g[c.T_S])
    wheels = receiver_folder(tmp_path / "ascii", g.iloc[:0])["wheels"]
    ascii_log = write_novatel(tmp_path / "ascii" / "drive.gps", lines)
    short = [f"[COM1]{x}" if i % 2 == 0 else x for y in lines for i, x in enumerate(_abbreviate(y))]
    abbreviated = write_novatel(tmp_path / "ascii" / "drive.log", short)
    ref, _ = receiver_labels([wheels, ascii_log])
    got, streams = receiver_labels([wheels, abbreviated])
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(got[q], ref[q], err_msg=q)
    assert "abbreviated ASCII: no CRC to check" in " ".join(streams.notes)
    position = [i for i, x in enumerate(short) if x.startswith("[COM1]<BESTPOS ")]
    damaged = list(short)
    damaged[position[3] + 1] = ""  # the fourth position's fields lost
    damaged[position[5] + 1] = damaged[position[5] + 1][:40]  # the sixth's cut
    damaged = damaged[: position[-1] + 1]  # the log ends at the last position's header
    log_ = read_novatel(write_novatel(tmp_path / "damaged.log", damaged), "damaged.log")
    assert log_.rows.size == len(position) - 3
    assert f"3 log(s) cut short (first at line {position[3] + 1})" in log_.notes[0]


def test_the_stated_accuracy_is_the_root_of_lat_and_lon_sigma_squared(tmp_path):
    """BESTPOSA's lat σ and lon σ (m, one sigma) give h_acc, the DRMS: 0.6 and 0.8 make
    1.0 m; an epoch whose solution is not computed (INSUFFICIENT_OBS, its σ zeros) states
    none; a σ that is no number is none, not refused. The published lines' and the
    abbreviated log's are their σ's root sum of squares."""
    g = fixes_to_the_ms().iloc[:4].copy()
    g.loc[g.index[2], c.LAT_DEG] = np.nan  # no solution
    t = DAY_S + g[c.T_S].to_numpy()
    lines = novatel_lines(g, t, velocity=None, time_logs=False, sigma_m=(0.6, 0.8))
    fields = lines[3][lines[3].index(";") + 1 : lines[3].index("*")].split(",")
    fields[7] = "x"  # lat σ
    lines[3] = log("BESTPOSA", t[3] - GPS_EPOCH_UNIX_S + 18, fields)
    fields = lines[1][lines[1].index(";") + 1 : lines[1].index("*")].split(",")
    fields[8] = "-0.8"  # lon σ below 0: no standard deviation, none stated
    lines[1] = log("BESTPOSA", t[1] - GPS_EPOCH_UNIX_S + 18, fields)
    got = read_novatel(write_novatel(tmp_path / "a.gps", lines), "a.gps")
    np.testing.assert_allclose(got.channels["h_acc"], [1.0, np.nan, np.nan, np.nan], atol=1e-12)
    assert got.channels["h_acc"].dtype == np.float64
    assert got.sources["h_acc"] == "BESTPOSA lat σ, lon σ"
    published = read_novatel(write_novatel(tmp_path / "p.gps", PUBLISHED), "p.gps")
    np.testing.assert_array_equal(
        published.channels["h_acc"],
        [np.hypot(1.3648, 1.1806), np.hypot(0.6074, 0.5792), np.hypot(2.1382, 3.1092)],
    )
    short = read_novatel(write_novatel(tmp_path / "s.gps", ABBREVIATED), "s.gps")
    np.testing.assert_array_equal(short.channels["h_acc"], [np.hypot(0.9038, 0.8534)])


def test_a_binary_log_s_stated_accuracy(tmp_path):
    """BESTPOSB's lat σ and lon σ (float32): 3 and 4 m make 5 m, named BESTPOSB's; the
    published binary log's (1.29007387, 1.12158024) their root sum of squares."""
    g = fixes_to_the_ms().iloc[:3]
    t = DAY_S + g[c.T_S].to_numpy()
    got = read_novatel(
        write_binary(tmp_path / "b.gps", novatel_binary(g, t, sigma_m=(3.0, 4.0))), "b"
    )
    np.testing.assert_array_equal(got.channels["h_acc"], [5.0, 5.0, 5.0])
    assert got.sources["h_acc"] == "BESTPOSB lat σ, lon σ"
    published = read_novatel(write_binary(tmp_path / "p.gps", [PUBLISHED_BINARY]), "p.gps")
    assert published.channels["h_acc"][0] == pytest.approx(1.7094539584187551, abs=1e-12)


def test_a_log_without_a_computed_solution_states_no_accuracy(tmp_path):
    """Every BESTPOSA of INSUFFICIENT_OBS: no h_acc channel, as before it was read."""
    g = fixes_to_the_ms().iloc[:5].assign(**{c.LAT_DEG: np.nan, c.LON_DEG: np.nan})
    lines = novatel_lines(g, DAY_S + g[c.T_S].to_numpy(), velocity=None)
    got = read_novatel(write_novatel(tmp_path / "n.gps", lines), "n.gps")
    assert "h_acc" not in got.channels and "h_acc" not in got.sources
    assert not np.isfinite(got.channels["lat"]).any()


def test_the_novatel_log_s_stated_accuracy_reaches_the_drive(tmp_path):
    """drive.gps beside wheels.csv, each BESTPOSA's σ 0.6 and 0.8 m: the GNSS stream's
    h_acc_m is 1.0 m (BESTPOSA lat σ, lon σ), and so is every row of the resampled drive's
    h_acc_m with a fix."""
    from rwhonet.sim.streams import signal_map

    g = fixes_to_the_ms()
    _, radius = receiver_drive()
    wheels = receiver_folder(tmp_path / "gps", g.iloc[:0])["wheels"]
    lines = novatel_lines(g, DAY_S + g[c.T_S].to_numpy(), sigma_m=(0.6, 0.8))
    streams = read_stream_csvs(
        [wheels, write_novatel(tmp_path / "gps" / "drive.gps", lines)], signal_map(), radius
    )
    np.testing.assert_allclose(streams.gnss.channels[c.H_ACC_M], 1.0, atol=1e-12)
    drive = resample(streams, nominal_radius_m=radius).drive.columns
    fixed = np.isfinite(drive[c.LAT_DEG])
    assert fixed.sum() > 1000
    np.testing.assert_allclose(drive[c.H_ACC_M][fixed], 1.0, atol=1e-12)
