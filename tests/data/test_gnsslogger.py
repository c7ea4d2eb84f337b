"""A phone's GnssLogger log (``rwhonet.data.gnsslogger``): its Fix records of the GPS
provider, else its NMEA records, give the labels of the same fixes in gnss.csv; its
Status records the satellites used in each fix."""

from __future__ import annotations

import gzip

import numpy as np
import pandas as pd
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.gnsslogger import is_gnsslogger_log, read_gnsslogger
from rwhonet.data.streamcsv import log_kind
from rwhonet.errors import InputError
from support.gnsslogger import (
    HEADER_V1,
    HEADER_V3,
    fix_v1,
    fix_v3,
    gnsslogger_lines,
    status_epoch,
    write_gnsslogger,
)
from support.multirate import fixes_to_the_ms, receiver_drive, receiver_folder, receiver_labels
from support.nmea import gga, nmea_lines, rmc, write_nmea

DAY_S = 1_552_262_400.0  # 2019-03-11 00:00:00 UTC


def _no_sats():
    """The drives' map without the satellite count, which a phone's log does not give."""
    from rwhonet.sim.streams import signal_map

    return {k: v for k, v in signal_map().items() if k != "n_sats"}


def _reference(tmp_path, g):
    return receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()), _no_sats())[0]


@pytest.mark.parametrize("version", [3, 1])
def test_the_gps_provider_s_fix_records_give_the_labels_of_the_csv_fixes(tmp_path, version):
    """wheels.csv on the time of day, the fixes as a GnssLogger log's Fix records among its
    Raw, Status and UncalGyro records, each beside the fused (v3) or network (v1)
    provider's fix of the same time elsewhere: the labels of the same fixes in gnss.csv
    within 0.01 mm (the records' coordinates as Java writes a double, in full); the
    other providers' fixes and the other records passed over, counted."""
    g = fixes_to_the_ms()
    ref = _reference(tmp_path, g)
    wheels = receiver_folder(tmp_path / "log", g.iloc[:0])["wheels"]
    lines = gnsslogger_lines(g, DAY_S + g[c.T_S].to_numpy(), version=version)
    log_ = write_gnsslogger(tmp_path / "log" / "gnss_log_2019_03_11_12_30_00.txt", lines)
    assert log_kind(log_.name, log_) == "GnssLogger"
    got, streams = receiver_labels([wheels, log_], _no_sats())
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)
    said = " ".join(streams.notes)
    other = "FLP" if version == 3 else "network"
    assert f"a GnssLogger log: {len(g)} Fix records of the GPS provider read" in said
    assert f"{len(g)} Fix record(s) of the {other.lower()} provider (no receiver's fix)" in said
    assert f"its other records passed over: {2 * len(g)} Raw" in said
    gnss = next(s for s in streams.streams if s.name == log_.name)
    lat_name = "latitudedegrees" if version == 3 else "latitude"
    assert gnss.sources[c.LAT_DEG] == f"Fix {lat_name}"
    assert gnss.rows[0] == len(HEADER_V3 if version == 3 else lines[:9]) + 4  # after 2 Raw, 1 gyro


def test_speed_bearing_mock_and_a_time_twice(tmp_path):
    """Speed and bearing as the records give them; a record marked MockLocation and a second
    record of one time are passed over and said."""
    t0 = int((DAY_S + 45_000.0) * 1000)
    lines = [
        *HEADER_V3,
        fix_v3("GPS", 52.4, -1.5, 12.5, 271.25, t0),
        fix_v3("gps", 52.4001, -1.5, 13.0, 272.0, t0 + 1000),
        fix_v3("GPS", 52.9, -1.9, 13.0, 272.0, t0 + 1000),  # the same time again
        fix_v3("GPS", 40.0, 10.0, 0.0, 0.0, t0 + 2000, mock=1),  # an app's location
        fix_v3("GPS", 52.4002, -1.5, 13.5, 273.0, t0 + 3000),
    ]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "a.txt", lines), "a.txt")
    np.testing.assert_allclose(log.channels["lat"], [52.4, 52.4001, 52.4002])
    np.testing.assert_allclose(log.channels["speed_gnss"], [12.5, 13.0, 13.5])
    np.testing.assert_allclose(log.channels["heading"], [271.25, 272.0, 273.0])
    np.testing.assert_allclose(log.tod_s, [45_000.0, 45_001.0, 45_003.0])
    assert log.day_s == DAY_S and log.kind == "GnssLogger"
    assert log.dropped == "1 marked MockLocation; 1 of a time already given"
    np.testing.assert_array_equal(log.rows, [len(HEADER_V3) + k for k in (1, 2, 5)])


def test_without_fix_records_its_nmea_records_are_read_as_the_nmea_log(tmp_path):
    """Location logging off: the NMEA records, each ``NMEA,`` before the sentence and the
    phone's time after its checksum, some split by the sentence's own line end (the time
    alone on the next line): the same fixes, rows and labels as the sentences in gps.nmea."""
    g = fixes_to_the_ms()
    t = DAY_S + g[c.T_S].to_numpy()
    sentences = nmea_lines(g, t, other=False)
    records = []
    for i, s in enumerate(sentences):
        ms = int(round(t[i // 2] * 1000.0)) + 12
        records += [f"NMEA,{s}\r", f",{ms}"] if i % 7 == 0 else [f"NMEA,{s},{ms}", "Raw,1,2,3"]
    log_ = write_gnsslogger(tmp_path / "log" / "gnss_log.txt", [*HEADER_V3, *records])
    want = write_nmea(tmp_path / "nmea" / "gps.nmea", sentences)
    wheels = receiver_folder(tmp_path / "log", g.iloc[:0])["wheels"]
    got, streams = receiver_labels([wheels, log_], _no_sats())
    ref, _ = receiver_labels([wheels, want], _no_sats())
    pd.testing.assert_frame_equal(got, ref)
    log = read_gnsslogger(log_, "gnss_log.txt")
    assert log.kind == "GnssLogger" and not log.dropped
    assert log.notes[0].startswith(
        "gnss_log.txt: a GnssLogger log without Fix records of the GPS provider: its NMEA "
        "records read; its other records passed over:"
    )
    assert log.rows[0] == len(HEADER_V3) + 1  # the file's own line


def test_what_is_no_gnsslogger_log_or_holds_no_fix_is_refused_or_passed_by(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("the drive to work, tyres at 2.3 bar\nFixed the logger's clock\n")
    assert not is_gnsslogger_log(notes) and log_kind(notes.name, notes) is None
    lines = gnsslogger_lines(fixes_to_the_ms().iloc[:5], DAY_S + 45_000.0 + np.arange(5))
    packed = tmp_path / "gnss_log.txt.gz"
    packed.write_bytes(gzip.compress(("\n".join(lines) + "\n").encode()))
    assert is_gnsslogger_log(packed) and log_kind(packed.name, packed) == "GnssLogger"
    assert not is_gnsslogger_log(tmp_path / "missing.txt")
    # only the fused provider's fixes and raw measurements: refused, naming what it holds
    fused = [x for x in lines if not x.startswith("Fix,GPS")]
    with pytest.raises(InputError) as err:
        read_gnsslogger(write_gnsslogger(tmp_path / "b.txt", fused), "b.txt")
    said = str(err.value)
    assert "GnssLogger's Fix records of the GPS provider, or its NMEA records" in said
    assert "records: 65 Status, 10 Raw, 5 UncalGyro, 5 Fix" in said
    assert "turn on Location (Fix) or NMEA logging" in said


def test_fix_records_without_their_header_or_with_a_bad_cell_are_refused_with_the_line(tmp_path):
    t0 = int((DAY_S + 45_000.0) * 1000)
    with pytest.raises(InputError) as err:
        read_gnsslogger(
            write_gnsslogger(tmp_path / "a.txt", [fix_v3("GPS", 52.4, -1.5, 1.0, 0.0, t0)]), "a.txt"
        )
    assert "row 1" in str(err.value) and "the header line naming the Fix records' columns" in str(
        err.value
    )
    bad = fix_v3("GPS", 52.4, -1.5, 1.0, 0.0, t0).replace("GPS,52.4,", "GPS,52,4O,")
    lines = [*HEADER_V3, fix_v3("GPS", 52.4, -1.5, 1.0, 0.0, t0 - 1000), bad]
    with pytest.raises(InputError) as err:
        read_gnsslogger(write_gnsslogger(tmp_path / "b.txt", lines), "b.txt")
    said = str(err.value)
    assert f"b.txt, row {len(HEADER_V3) + 2}" in said and "longitudedegrees" in said
    empty = fix_v3("GPS", 52.4, -1.5, 1.0, 0.0, t0).replace("GPS,52.4,", "GPS,,")
    with pytest.raises(InputError) as err:
        read_gnsslogger(write_gnsslogger(tmp_path / "e.txt", [*HEADER_V3, empty]), "e.txt")
    assert "latitudedegrees" in str(err.value) and "empty" in str(err.value)
    far = fix_v3("GPS", 52.4, -191.5, 1.0, 0.0, t0)
    with pytest.raises(InputError) as err:
        read_gnsslogger(write_gnsslogger(tmp_path / "c.txt", [*HEADER_V3, far]), "c.txt")
    assert "degrees within ±90, ±180" in str(err.value)


def test_an_nmea_log_beside_a_phone_s_log_is_the_receiver_s(tmp_path):
    """A receiver's gps.nmea and the phone's GnssLogger log in one folder: the NMEA log's
    fixes, the phone's left out and said; a GPX track beside the phone's log: the phone's
    records (in full precision), the track left out."""
    g = fixes_to_the_ms()
    t = DAY_S + g[c.T_S].to_numpy()
    folder = tmp_path / "d"
    wheels = receiver_folder(folder, g.iloc[:0])["wheels"]
    nmea = write_nmea(
        folder / "gps.nmea",
        [
            s
            for i in range(len(g))
            for s in (
                gga(t[i], g[c.LAT_DEG].iloc[i], g[c.LON_DEG].iloc[i], 9),
                rmc(t[i], g[c.LAT_DEG].iloc[i], g[c.LON_DEG].iloc[i], 10.0, 0.0),
            )
        ],
    )
    phone = write_gnsslogger(folder / "gnss_log.txt", gnsslogger_lines(g, t + 0.5))
    _, streams = receiver_labels([wheels, nmea, phone], _no_sats())
    assert any(
        "gnss_log.txt: GnssLogger log(s), left out: the fixes are the receiver's NMEA log's" in n
        for n in streams.notes
    )
    # a GPX track beside the phone's log: the phone's own records, the track left out
    from support.gpx import track, write_gpx

    gpx = write_gpx(folder / "track.gpx", track(g, t))
    _, streams = receiver_labels([wheels, gpx, phone], _no_sats())
    assert any(
        "track.gpx: GPX log(s), left out: the fixes are the receiver's GnssLogger log's" in n
        for n in streams.notes
    )


def test_a_drive_folder_s_gnsslogger_log_plain_or_compressed_through_ingest_s_reader(tmp_path):
    """Through ingest's reader (``read_any``), a folder's ``gnss_log.txt`` is found by what
    it holds, beside a ``notes.txt`` that is no log; kept compressed it gives the same
    grid, bit for bit; the fixes are the CSVs' within 1e-9 degrees."""
    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params
    from support.stream_fleet import signal_map_params

    g = fixes_to_the_ms()
    text = ("\n".join(gnsslogger_lines(g, DAY_S + g[c.T_S].to_numpy())) + "\n").encode()
    params = signal_map_params("stream_csv")
    params["signals"].pop("n_sats")
    data = make_params(tmp_path, **{"data.signal_maps": {"logger": params}}).data
    grids = {}
    for name in ("gnss_log.txt", "gnss_log.txt.gz", "csv"):
        folder = tmp_path / name.replace(".", "_")
        for k, written in receiver_folder(folder, g if name == "csv" else g.iloc[:0]).items():
            if k != "wheels" and name != "csv":  # the fixes are the log's
                written.unlink()
        if name != "csv":
            (folder / name).write_bytes(
                gzip.compress(text, mtime=0) if name.endswith(".gz") else text
            )
            (folder / "notes.txt").write_text("tyres at 2.3 bar\n")
        f = DriveFile(name, "target_test", "target", "logger", folder)
        grids[name] = read_any(f, data, lambda p: p.name, receiver_drive()[1], 0.1, 10.0)[0]
    assert np.isfinite(grids["gnss_log.txt"].columns[c.LAT_DEG]).sum() > 1000
    for k, v in grids["gnss_log.txt"].columns.items():
        np.testing.assert_array_equal(grids["gnss_log.txt.gz"].columns[k], v, err_msg=k)
    for k in (c.LAT_DEG, c.LON_DEG):
        np.testing.assert_allclose(
            grids["gnss_log.txt"].columns[k], grids["csv"].columns[k], rtol=0, atol=1e-9
        )


def test_the_stated_accuracy_is_the_fix_record_s_accuracymeters_as_given(tmp_path):
    """A GPS Fix record's AccuracyMeters (Android's Location.getAccuracy(), the 68 %
    radius, m) is h_acc as given: 3.9 and 12.25 m; empty, 0 (getAccuracy()'s "none") and a
    cell that is no number are NaN, and not refused; the fused provider's is not read.
    GnssLogger 1.x's column is Accuracy. A log none of whose GPS records states one has no
    h_acc."""
    t0 = int((DAY_S + 45_000.0) * 1000)
    accuracies = ["3.9", "", "0.0", "n/a", "12.25"]
    lines = [*HEADER_V3]
    for k, a in enumerate(accuracies):
        lines.append(fix_v3("GPS", 52.4 + 1e-5 * k, -1.5, 10.0, 0.0, t0 + 1000 * k, accuracy=a))
        lines.append(fix_v3("FLP", 52.4, -1.5, 10.0, 0.0, t0 + 1000 * k, accuracy="99.0"))
    log = read_gnsslogger(write_gnsslogger(tmp_path / "a.txt", lines), "a.txt")
    np.testing.assert_array_equal(log.channels["h_acc"], [3.9, np.nan, np.nan, np.nan, 12.25])
    assert log.channels["h_acc"].dtype == np.float64
    assert log.sources["h_acc"] == "Fix accuracymeters"
    v1 = [*HEADER_V1, *(fix_v1("gps", 52.4, -1.5, 10.0, t0 + 1000 * k, "4.5") for k in range(3))]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "v1.txt", v1), "v1.txt")
    np.testing.assert_array_equal(log.channels["h_acc"], [4.5, 4.5, 4.5])
    assert log.sources["h_acc"] == "Fix accuracy"
    none = [*HEADER_V3, *(fix_v3("GPS", 52.4, -1.5, 1.0, 0.0, t0 + k, accuracy="") for k in (0, 1))]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "n.txt", none), "n.txt")
    assert "h_acc" not in log.channels and "h_acc" not in log.sources


def test_the_phone_s_stated_accuracy_reaches_the_drive(tmp_path):
    """gnss_log.txt beside wheels.csv, each GPS Fix record's AccuracyMeters 3.9: the GNSS
    stream's h_acc_m, and every row of the resampled drive with a fix has it."""
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample

    g = fixes_to_the_ms()
    _, radius = receiver_drive()
    wheels = receiver_folder(tmp_path / "log", g.iloc[:0])["wheels"]
    lines = gnsslogger_lines(g, DAY_S + g[c.T_S].to_numpy())
    log_ = write_gnsslogger(tmp_path / "log" / "gnss_log.txt", lines)
    streams = read_stream_csvs([wheels, log_], _no_sats(), radius)
    np.testing.assert_array_equal(streams.gnss.channels[c.H_ACC_M], 3.9)
    assert streams.gnss.sources[c.H_ACC_M] == "Fix accuracymeters"
    drive = resample(streams, nominal_radius_m=radius).drive.columns
    fixed = np.isfinite(drive[c.LAT_DEG])
    assert fixed.sum() > 1000
    np.testing.assert_array_equal(drive[c.H_ACC_M][fixed], 3.9)


def _fixes_with_status(tmp_path, epochs, name="s.txt"):
    """A v3 log of GPS Fix records one a second and, between them, what ``epochs`` says:
    for each fix a list of Status epochs (each a list of lines) written before it, or
    after it (``("after", lines)``); read."""
    t0 = int((DAY_S + 45_000.0) * 1000)
    lines = [*HEADER_V3]
    for k, around in enumerate(epochs):
        before = [x for e in around if e[0] != "after" for x in e]
        after = [x for e in around if e[0] == "after" for x in e[1]]
        lines += before
        lines.append(fix_v3("GPS", 52.4 + 1e-5 * k, -1.5, 10.0, 0.0, t0 + 1000 * k))
        lines += after
    return read_gnsslogger(write_gnsslogger(tmp_path / name, lines), name)


def test_each_fix_s_satellites_are_those_its_status_epoch_used_once_each(tmp_path):
    """A Status epoch (GPS satellites used, two of them on L5 too; Galileo satellites seen,
    not used) written after each Fix record gives that fix the satellites used, a
    satellite once however many of its signals: 9, 5, 2, 0; the note says it."""
    log = _fixes_with_status(
        tmp_path, [[("after", status_epoch(n, unused=3))] for n in (9, 5, 2, 0)]
    )
    np.testing.assert_array_equal(log.channels["n_sats"], [9.0, 5.0, 2.0, 0.0])
    assert log.sources["n_sats"] == "Status UsedInFix satellites"
    said = " ".join(log.notes)
    assert "4 whole epoch(s) of 4" not in said  # records, not epochs, after "of"
    records = sum(len(status_epoch(n, unused=3)) for n in (9, 5, 2, 0))
    assert f"4 whole epoch(s) of {records} Status records; 4 of 4 fixes by the epoch after" in said
    assert "Status" not in log.notes[0]  # read, not passed over


def test_a_fix_takes_the_epoch_after_it_else_the_last_before_it(tmp_path):
    """Epochs written before the fixes (the log's order the other way round): each fix takes
    the next fix's epoch, the one after it, and the last fix, with none after it, the last
    before it. Status at half the fixes' rate: a fix with no epoch after it before the next
    fix takes the last before it. A fix with no epoch either side has no count."""
    log = _fixes_with_status(tmp_path, [[status_epoch(n)] for n in (9, 5, 2, 7)])
    np.testing.assert_array_equal(log.channels["n_sats"], [5.0, 2.0, 7.0, 7.0])
    half = [[("after", status_epoch(8))], [], [("after", status_epoch(6))], []]
    log = _fixes_with_status(tmp_path, half, "half.txt")
    np.testing.assert_array_equal(log.channels["n_sats"], [8.0, 8.0, 6.0, 6.0])
    assert "2 of 4 fixes by the epoch after them" in " ".join(log.notes)
    t0 = int((DAY_S + 45_000.0) * 1000)
    lines = [*HEADER_V3, fix_v3("GPS", 52.4, -1.5, 10.0, 0.0, t0)]
    lines += [fix_v3("GPS", 52.4, -1.5, 10.0, 0.0, t0 + 1000), *status_epoch(6)]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "first.txt", lines), "first.txt")
    np.testing.assert_array_equal(log.channels["n_sats"], [np.nan, 6.0])
    assert "1 fix(es) without a count (1 with no epoch, 0 by an epoch not whole)" in log.notes[1]


def test_an_epoch_between_other_records_counts_and_one_not_whole_gives_no_count(tmp_path):
    """An epoch's records with Raw and gyro records between them count as one epoch, and
    so does one whose UsedInFix is written ``true`` / ``False``. An epoch with a record
    missing, a damaged cell (UsedInFix ``x``, Svid empty, ConstellationType 1.5), a
    SignalCount that is not its records' or a SignalIndex out of turn gives its fix no
    count (validate cuts it as low_sats), said; the fixes around keep theirs."""
    whole = status_epoch(6)
    mixed = [
        whole[0],
        "Raw,1,2,18,0.0,-1,3,30",
        *whole[1:4],
        "UncalGyro,1,2,0,0,0,0,0,0",
        *whole[4:],
    ]
    missing = whole[:3] + whole[4:]
    used_x = [*whole[:2], whole[2].replace(",1,1,1,29.0", ",x,1,1,29.0"), *whole[3:]]
    no_svid = [whole[0], whole[1].replace(",1,2,1575420030,", ",1,,1575420030,"), *whole[2:]]
    recount = [x.replace(f"Status,,{len(whole)},", f"Status,,{len(whole) + 1},") for x in whole]
    out_of_turn = [
        *whole[:3],
        whole[3].replace(f",{len(whole)},3,", f",{len(whole)},2,"),
        *whole[4:],
    ]
    half_system = [whole[0], whole[1].replace(",1,2,1575420030,", ",1.5,2,1575420030,"), *whole[2:]]
    words = [_used_as_word(x) for x in whole]  # UsedInFix written true / false
    epochs = [whole, mixed, missing, used_x, no_svid, recount, out_of_turn, half_system, words]
    log = _fixes_with_status(tmp_path, [[("after", e)] for e in [*epochs, status_epoch(4)]])
    np.testing.assert_array_equal(log.channels["n_sats"], [6.0, 6.0, *[np.nan] * 6, 6.0, 4.0])
    said = log.notes[1]
    assert (
        "4 whole epoch(s)" in said and "6 epoch(s) not whole (a record missing or damaged)" in said
    )
    assert "6 fix(es) without a count (0 with no epoch, 6 by an epoch not whole)" in said
    # a log that starts inside an epoch: its records before the first SignalIndex 0 are no
    # epoch, and the first fix, whose epoch they are, has none either side
    log = _fixes_with_status(tmp_path, [[("after", whole[3:])], [("after", whole)]], "cut.txt")
    np.testing.assert_array_equal(log.channels["n_sats"], [np.nan, 6.0])


def _used_as_word(record: str) -> str:
    """A Status record with its UsedInFix (the tenth field after the kind) as a word."""
    cells = record.split(",")
    cells[10] = {"1": "true", "0": "False"}[cells[10]]
    return ",".join(cells)


def test_status_records_without_their_header_or_none_give_no_count(tmp_path):
    """Status records without the ``# Status`` header line, or with one that lacks
    UsedInFix, give no count, said; so does a log whose epochs are none of them whole. A
    log without Status records (Status logging off) has no n_sats, and says nothing of it."""
    t0 = int((DAY_S + 45_000.0) * 1000)
    fixes = [fix_v3("GPS", 52.4, -1.5, 10.0, 0.0, t0 + 1000 * k) for k in range(3)]
    no_status_header = [x for x in HEADER_V3 if not x.startswith("# Status")]
    lines = [*no_status_header, *(y for f in fixes for y in (f, *status_epoch(5)))]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "a.txt", lines), "a.txt")
    assert "n_sats" not in log.channels
    n = 3 * len(status_epoch(5))
    assert f"{n} Status records give no satellite count: no header line naming" in log.notes[1]
    assert "signalcount, signalindex, constellationtype, svid, usedinfix column" in log.notes[1]
    assert f"passed over: {n} Status" in log.notes[0]  # passed over, counted
    cut = [x.replace(",UsedInFix", ",Used") for x in HEADER_V3]
    lines = [*cut, *(y for f in fixes for y in (f, *status_epoch(5)))]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "b.txt", lines), "b.txt")
    assert "n_sats" not in log.channels and "their usedinfix column(s)" in log.notes[1]
    broken = [*HEADER_V3, *(y for f in fixes for y in (f, *status_epoch(5)[1:]))]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "c.txt", broken), "c.txt")
    assert "n_sats" not in log.channels and "no whole epoch among them" in log.notes[1]
    log = read_gnsslogger(write_gnsslogger(tmp_path / "d.txt", [*HEADER_V3, *fixes]), "d.txt")
    assert "n_sats" not in log.channels and len(log.notes) == 1


def test_the_drives_own_map_with_its_satellite_count_reads_a_phone_s_log(tmp_path):
    """With the drives' signal map as it is (n_sats named, which a stream CSV's NumSV
    gives), gnss_log.txt's Status records give it: the labels of the same fixes in
    gnss.csv, every fix's count the CSV's. A fix whose epoch used 3 satellites is cut by
    validate's GNSS checks (min_sats 4) as the CSV's count of 3 is."""
    from rwhonet.data.quality import assess
    from support.drives import make_params

    g = fixes_to_the_ms().copy()
    low = (g[c.T_S] > 45_060.0) & (g[c.T_S] < 45_070.0)
    g.loc[low, c.N_SATS] = 3.0
    ref, ref_streams = receiver_labels(list(receiver_folder(tmp_path / "csv", g).values()))
    wheels = receiver_folder(tmp_path / "log", g.iloc[:0])["wheels"]
    log_ = write_gnsslogger(
        tmp_path / "log" / "gnss_log.txt", gnsslogger_lines(g, DAY_S + g[c.T_S].to_numpy())
    )
    got, streams = receiver_labels([wheels, log_])
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)
    np.testing.assert_array_equal(streams.gnss.channels[c.N_SATS], g[c.N_SATS].to_numpy())
    assert streams.gnss.sources[c.N_SATS] == "Status UsedInFix satellites"
    _, radius = receiver_drive()
    from rwhonet.data.streams import resample

    vp = make_params(tmp_path).validate
    said = {}
    for name, s in (("log", streams), ("csv", ref_streams)):
        drive = resample(s, nominal_radius_m=radius).drive.columns
        said[name] = assess(drive, vp.gnss, vp.sample_period_s).cut_seconds_by_rule
    assert 10 <= said["log"]["low_sats"] <= 12  # the 10 s of 3 satellites
    assert said["log"] == said["csv"]
