"""A gpsd client's log (``gpspipe -w``'s JSON reports) beside a drive's stream CSVs
(rwhonet.data.gpsdjson).

The main log was written by gpsd 3.22 itself, played a simulated receiver's NMEA log by
gpsfake (tests/fixtures/gpsd/write_gpsd.py): its TPV reports are held to the NMEA log
gpsd was given. The small logs of the other tests are written here, report by report."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data.gpsdjson import is_gpsd_log, read_gpsd
from rwhonet.data.nmea import read_nmea
from rwhonet.data.streamcsv import log_kind
from rwhonet.errors import InputError
from support.multirate import receiver_drive, receiver_folder, receiver_labels

FIXTURE = Path(__file__).parents[1] / "fixtures" / "gpsd"
HEAD = [
    {"class": "VERSION", "release": "3.22", "rev": "3.22", "proto_major": 3, "proto_minor": 14},
    {"class": "WATCH", "enable": True, "json": True},
]


def _unpacked(tmp_path: Path, name: str) -> Path:
    out = tmp_path / name.removesuffix(".gz")
    out.write_bytes(gzip.decompress((FIXTURE / name).read_bytes()))
    return out


def _tpv(t: str, lat=52.4, lon=-1.5, mode=3, **more) -> dict:
    return (
        {"class": "TPV", "device": "/dev/ttyACM0", "mode": mode, "time": t}
        | ({"lat": lat, "lon": lon} if mode not in (0, 1) else {})
        | more
    )


def _log(tmp_path: Path, reports: list, name: str = "gps.json") -> Path:
    path = tmp_path / name
    lines = [r if isinstance(r, str) else json.dumps(r) for r in [*HEAD, *reports]]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_gpsd_s_own_reports_are_the_nmea_log_it_was_given(tmp_path):
    """Every epoch gpsd dated, its position within 1e-9 degrees (gpsd prints 9 decimals),
    speed within its 3 decimals, course, satellites (its SKY reports from GSA) and fix
    (GGA quality 0 and 6 no fix: TPV mode 1, and mode 3 with status 5) as the NMEA
    reader reads the sentences."""
    log = read_gpsd(_unpacked(tmp_path, "gpsd.json.gz"), "gpsd.json")
    nmea = read_nmea(_unpacked(tmp_path, "gps.nmea.gz"), "gps.nmea")
    at = np.searchsorted(nmea.tod_s, log.tod_s - 1e-6)
    np.testing.assert_allclose(nmea.tod_s[at], log.tod_s, rtol=0, atol=1e-6)
    # gpsd dates no report of the first epoch without a fix (nor its first report, of the
    # first GGA, before any RMC gave the date: the epoch's RMC report is kept)
    assert sorted(set(range(nmea.tod_s.size)) - set(at)) == [300] and log.day_s == nmea.day_s
    tol = {"lat": 1e-9, "lon": 1e-9, "speed_gnss": 5e-4, "heading": 0.0}
    for key, atol in tol.items():
        want = nmea.channels[key][at]
        np.testing.assert_allclose(log.channels[key], want, atol=atol, err_msg=key)
    fix = np.isfinite(log.channels["lat"])  # satellites used in a fix (GGA's in any epoch)
    np.testing.assert_array_equal(log.channels["n_sats"][fix], nmea.channels["n_sats"][at][fix])
    assert np.isnan(log.channels["n_sats"][~fix]).all()
    assert np.isnan(log.channels["lat"]).sum() == 49  # 29 dated without a fix, 20 dead reckoning
    (said,) = log.notes
    assert said.startswith("gpsd.json: gpsd's reports: 1198 TPV epochs, 1149 with a fix; ")
    assert "without one: 20 at status 5 (dead reckoning only)" in said
    assert "; 2 TPV report(s) without a time (no fix yet, or its date not yet known)" in said
    assert log.dropped == ""  # gpsd's way, not damage: predict does not say it


def test_the_gpsd_log_gives_the_labels_of_the_nmea_log(tmp_path):
    """wheels.csv and gpsd's reports against wheels.csv and the NMEA log gpsd was given:
    the same seconds, their GNSS displacement within 0.1 mm."""
    nmea = receiver_folder(tmp_path / "nmea", receiver_drive()[0].gnss.iloc[:0])
    gpsd = receiver_folder(tmp_path / "gpsd", receiver_drive()[0].gnss.iloc[:0])
    packed = shutil.copy(FIXTURE / "gpsd.json.gz", tmp_path / "gps.json.gz")
    assert log_kind("gps.json.gz", Path(packed)) == "gpsd"  # told inside its compression
    ref, _ = receiver_labels([nmea["wheels"], _unpacked(tmp_path / "nmea", "gps.nmea.gz")])
    logged = _unpacked(tmp_path / "gpsd", "gpsd.json.gz")
    got, streams = receiver_labels([gpsd["wheels"], logged])
    assert len(got) == len(ref) == 81  # the seconds without a fix or dead-reckoned cut
    for q in ("t_s", "disp_wpm_m"):
        np.testing.assert_array_equal(got[q], ref[q], err_msg=q)
    for q in ("disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-4, err_msg=q)
    assert "gpsd.json: gpsd's reports: 1198 TPV epochs" in " ".join(streams.notes)


@pytest.mark.parametrize(
    ("name", "text", "is_log"),
    [
        ("gps.json", json.dumps(HEAD[0]), True),
        ("gpsd.log", json.dumps(_tpv("2019-03-11T12:00:00.000Z")), True),
        ("track.jsonl", "\n\n" + json.dumps(HEAD[1]), True),
        ("gps.json", '0.5,"lon":-1.5}\n' + json.dumps(HEAD[1]), True),  # cut by a rotation
        ("gps.json", '{"lat": 52.4, "lon": -1.5}', False),  # no class of gpsd's
        ("can0.log", "(1552305600.000000) can0 0AA#0102030405060708", False),
        ("gps.csv", json.dumps(HEAD[0]), False),  # not a name a gpsd log has
        ("gnss_log.txt", "# Version: v3.0.6.0\n# Fix,Provider", False),
    ],
)
def test_a_gpsd_log_is_told_by_its_name_and_its_first_report(tmp_path, name, text, is_log):
    path = tmp_path / name
    path.write_text(text + "\n")
    assert is_gpsd_log(path, name) is is_log


def test_what_is_a_fix_and_what_is_read(tmp_path):
    """mode 2 and 3 are fixes, mode 1 and status 5, 7, 8 not; status 6 (GNSS with dead
    reckoning) is; altMSL before alt; uSat before counting the used satellites."""
    reports = [
        {"class": "SKY", "satellites": [{"PRN": 5, "used": True}, {"PRN": 9, "used": False}]},
        _tpv("2019-03-11T12:00:00.0Z", altMSL=12.5, alt=99.0, speed=3.25, track=91.5),
        _tpv("2019-03-11T12:00:00.1Z", mode=2),
        {"class": "SKY", "uSat": 11, "satellites": []},
        _tpv("2019-03-11T12:00:00.2Z", mode=1),
        _tpv("2019-03-11T12:00:00.3Z", status=5),
        _tpv("2019-03-11T12:00:00.4Z", status=6),
        _tpv("2019-03-11T12:00:00.5Z", status=7),
        _tpv("2019-03-11T12:00:00.6Z", status=8),
        _tpv("2019-03-11T12:00:00.7Z", status=2),
    ]
    log = read_gpsd(_log(tmp_path, reports), "gps.json")
    assert np.isfinite(log.channels["lat"]).tolist() == [1, 1, 0, 0, 1, 0, 0, 1]
    assert log.channels["n_sats"][[0, 1, 4, 7]].tolist() == [1, 1, 11, 11]
    assert log.channels["height"][0] == 12.5 and log.channels["speed_gnss"][0] == 3.25
    assert log.channels["heading"][0] == 91.5 and np.isnan(log.channels["heading"][1])
    assert log.t_utc_s[1] - log.t_utc_s[0] == pytest.approx(0.1, abs=1e-6)
    assert "2 at status 5 (dead reckoning only)" not in log.notes[0]  # one of each
    assert "1 at status 5 (dead reckoning only), 1 at status 7 (time only)" in log.notes[0]


def test_damage_is_passed_over_and_counted_and_the_old_protocol_read(tmp_path):
    """A line no JSON (a serial line's noise), gpspipe -r's sentences among the reports,
    gpspipe -t's stamp before a report, a time as seconds since 1970 (gpsd before 3.10),
    a report written twice for one epoch (the later kept), the last line cut short."""
    reports = [
        _tpv(1552305600.0, lat=52.0),
        "$GPGGA,120000.10,5224.000,N,00130.000,W,1,09,0.9,112.4,M,47.0,M,,*4C",
        'garbled {"class": TPV',
        "2019-03-11 13:00:00: " + json.dumps(_tpv(1552305600.1, lat=52.1)),
        json.dumps(_tpv(1552305600.2, lat=52.15)),
        json.dumps(_tpv(1552305600.2, lat=52.2, speed=1.0)),
        '{"class": ["TPV"], "mode": 3}',  # a class no text: a damaged report
        '{"class":"TPV","device":"/dev/ttyACM0","mode":3,"time":155230',
    ]
    log = read_gpsd(_log(tmp_path, reports), "gps.json")
    np.testing.assert_allclose(log.channels["lat"], [52.0, 52.1, 52.2])
    assert log.rows.tolist() == [3, 6, 8]
    assert log.dropped == "3 line(s) that are no gpsd report (first at line 5)"
    said = log.notes[0]
    assert "1 report(s) of an epoch a later report of it completes" in said
    assert "1 NMEA sentence(s) among them passed over" in said


def test_several_receivers_the_one_with_the_most_fixes_is_read(tmp_path):
    other = {"device": "/dev/ttyUSB1"}
    reports = [
        _tpv("2019-03-11T11:59:59Z", mode=1, device={"path": 1}),  # a device no text: none
        _tpv("2019-03-11T12:00:00Z", lat=10.0, **other),  # the first report: not the reader's
        _tpv("2019-03-11T12:00:00Z"),
        _tpv("2019-03-11T12:00:01Z", lat=52.41),
        {"class": "SKY", "device": "/dev/ttyACM0", "uSat": 12},
        {"class": "SKY", "device": "/dev/ttyUSB1", "uSat": 3},
        _tpv("2019-03-11T12:00:02Z", lat=52.42),
    ]
    log = read_gpsd(_log(tmp_path, reports), "gps.json")
    np.testing.assert_allclose(log.channels["lat"], [52.4, 52.41, 52.42])
    # no SKY before the first two: no count; the third: its own receiver's SKY
    np.testing.assert_array_equal(log.channels["n_sats"], [np.nan, np.nan, 12.0])
    assert log.notes[1] == (
        "gps.json: several receivers on one gpsd: the fixes are /dev/ttyACM0's, left out: "
        "no device (1 TPV), /dev/ttyUSB1 (1 TPV)"
    )


@pytest.mark.parametrize(
    ("report", "field", "found"),
    [
        (_tpv("2019-03-11T12:00:00Z", lat=91.0), "lat", "91.0"),
        (_tpv("2019-03-11T12:00:00Z", lon="1.5"), "lon", "'1.5'"),
        (_tpv("2019-03-11 noon"), "time", None),
        (_tpv("2019-03-11T12:00:00Z", mode="3"), "mode", "'3'"),
        (_tpv("2019-03-11T12:00:00Z", status=2.5), "status", "2.5"),
        (_tpv("2019-03-11T12:00:00Z", speed=True), "speed", "True"),
    ],
)
def test_a_value_that_is_none_is_refused_naming_its_line_and_field(tmp_path, report, field, found):
    with pytest.raises(InputError) as err:
        read_gpsd(_log(tmp_path, [_tpv("2019-03-11T11:59:59Z"), report]), "gps.json")
    (p,) = err.value.problems
    assert (p.file, p.row, p.column) == ("gps.json", 4, field)
    if found is not None:
        assert p.found == found


def test_a_log_without_a_dated_tpv_is_refused_naming_what_it_holds(tmp_path):
    path = _log(tmp_path, [{"class": "DEVICE", "path": "/dev/ttyACM0"}, _tpv(None, mode=1)])
    with pytest.raises(InputError) as err:
        read_gpsd(path, "gps.json")
    (p,) = err.value.problems
    assert p.found == "1 TPV report(s), none with a time (1 DEVICE, 1 VERSION, 1 WATCH)"


def test_beside_the_receiver_s_nmea_log_the_nmea_log_is_read(tmp_path):
    folder = receiver_folder(tmp_path / "both", receiver_drive()[0].gnss.iloc[:0])
    nmea = _unpacked(tmp_path / "both", "gps.nmea.gz")
    gpsd = _unpacked(tmp_path / "both", "gpsd.json.gz")
    got, streams = receiver_labels([folder["wheels"], nmea, gpsd])
    alone, _ = receiver_labels([folder["wheels"], nmea])
    np.testing.assert_array_equal(got["disp_gnss_m"], alone["disp_gnss_m"])
    said = " ".join(streams.notes)
    assert "gpsd.json: gpsd log(s), left out: the fixes are the receiver's NMEA log's" in said


def test_the_reports_as_the_benchmark_writes_them_give_the_csv_fixes_labels(tmp_path):
    """tests/support/gpsd.py's layout (two TPV an epoch, the first without speed and
    course; a SKY a second): the labels of the same fixes in gnss.csv within 0.1 mm (gpsd
    prints 9 decimals, its times to the millisecond)."""
    from support.gpsd import gpsd_lines, write_gpsd
    from support.multirate import fixes_to_the_ms

    g = fixes_to_the_ms()
    csv = receiver_folder(tmp_path / "csv", g)
    ref, _ = receiver_labels(list(csv.values()))
    folder = receiver_folder(tmp_path / "gpsd", g.iloc[:0])
    log = write_gpsd(tmp_path / "gpsd" / "gps.json", gpsd_lines(g, 1_552_262_400.0 + g["t_s"]))
    got, streams = receiver_labels([folder["wheels"], log])
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-4, err_msg=q)
    said = " ".join(streams.notes)
    assert "1199 TPV epochs, 1199 with a fix; 1199 report(s) of an epoch a later" in said
