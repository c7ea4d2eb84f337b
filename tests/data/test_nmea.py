"""A receiver's NMEA 0183 log beside a drive's stream CSVs (rwhonet.data.nmea)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.nmea import (
    DAY_TIME,
    KNOT_M_S,
    UTC_TIME,
    clock_kind,
    is_nmea_name,
    read_nmea,
)
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.multirate import receiver_drive, receiver_labels
from support.nmea import (
    gga,
    gll,
    gns,
    gsa,
    gst,
    hhmmss,
    nmea_lines,
    rmc,
    sentence,
    vtg,
    write_nmea,
    zda,
)

# 2019-03-11 00:00:00 UTC: the day of the drives below, as Unix seconds
DAY_S = 1_552_262_400.0


def _wheels(folder, shift_s: float = 0.0):
    """The drive's wheels.csv, its clock moved by ``shift_s``."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    moved = StreamTables(
        tables.wheels.assign(t_s=tables.wheels[c.T_S] + shift_s), tables.gnss.iloc[:0]
    )
    return write_stream_csvs(moved, folder)["wheels"]


def _reference(tmp_path, gnss=None):
    """The labels of the drive's fixes written as gnss.csv (``gnss``: other fixes)."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    if gnss is not None:
        tables = StreamTables(tables.wheels, gnss)
    files = write_stream_csvs(tables, tmp_path / "csv")
    return receiver_labels([files["wheels"], files["gnss"]])[0]


def _same(got, ref, atol_m):
    assert len(got) == len(ref) > 100
    np.testing.assert_allclose(got["t_s"], ref["t_s"], rtol=0, atol=1e-3)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=atol_m)


def test_names():
    assert is_nmea_name("gps.nmea") and is_nmea_name("GPS.NMEA.gz") and is_nmea_name("a.nma")
    assert not is_nmea_name("gps.csv") and not is_nmea_name("nmea.txt")


def test_clock_kinds():
    unix = [np.array([DAY_S + 45000.0])]
    own = [np.array([12.5])]
    assert clock_kind("s", False, unix) == UTC_TIME
    assert clock_kind("ms", False, own) is None
    assert clock_kind("s", True, own) == UTC_TIME  # a date column
    assert clock_kind("iso8601", False, own) == UTC_TIME
    assert clock_kind("%d.%m.%Y %H:%M:%S.%f", False, own) == UTC_TIME
    assert clock_kind("hhmmss", False, own) == DAY_TIME
    assert clock_kind("hh:mm:ss", False, own) == DAY_TIME
    assert clock_kind("%H:%M:%S", False, own) == DAY_TIME


def test_logger_stamps_give_the_labels_of_the_csv_fixes(tmp_path):
    """Each sentence after the logger's stamp (its time on the wheels' clock): the seconds
    and labels of the same fixes as gnss.csv, within the ddmm.mmmmmm rounding (2 mm)."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = g[c.T_S].to_numpy()
    log = write_nmea(tmp_path / "nmea" / "gps.nmea", nmea_lines(g, DAY_S + t, stamps=t))
    got, streams = receiver_labels([_wheels(tmp_path / "nmea"), log])
    _same(got, _reference(tmp_path), 0.002)
    said = " ".join(streams.notes)
    assert "logger stamp is its time" in said
    assert "1199 epochs (1199 GGA, 1199 RMC sentences), 1199 with a fix" in said
    gnss = next(s for s in streams.streams if s.name == "gps.nmea")
    assert gnss.sources[c.T_S] == "logger stamp" and gnss.rows[1] == 4  # line of epoch 2
    np.testing.assert_allclose(gnss.channels[c.N_SATS], g[c.N_SATS])


@pytest.mark.parametrize(
    "sentences",
    [("GGA", "RMC"), ("GGA",), ("RMC",), ("GNS", "RMC"), ("GNS",), ("GLL",), ("GGA", "ZDA")],
)
def test_utc_times_on_a_unix_clock(tmp_path, sentences):
    """No stamps: the wheels' clock in Unix seconds, the receiver's UTC times placed on it
    with RMC's or ZDA's date, or (GGA alone) the day nearest the wheels' start: the labels of the
    same fixes in gnss.csv, within the ddmm.mmmmmm rounding (2 mm). The fixes' times are
    written to 0.01 s, as receivers write them, in both."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = np.round(g[c.T_S].to_numpy(), 2)
    exact = g.assign(t_s=t)
    write_nmea(tmp_path / "utc" / "gps.nmea", nmea_lines(exact, DAY_S + t, sentences))
    files = [_wheels(tmp_path / "utc", DAY_S), tmp_path / "utc" / "gps.nmea"]
    from rwhonet.sim.streams import signal_map

    counts = "GGA" in sentences or "GNS" in sentences
    smap = {k: v for k, v in signal_map().items() if k != "n_sats" or counts}
    got, streams = receiver_labels(files, smap)
    _same(got.assign(t_s=got["t_s"] - DAY_S), _reference(tmp_path, exact), 0.002)
    said = " ".join(streams.notes)
    assert ("RMC dates" in said) == ("RMC" in sentences)
    assert ("ZDA dates" in said) == ("ZDA" in sentences)
    assert ("no RMC or ZDA date" in said) == ("RMC" not in sentences and "ZDA" not in sentences)
    read = [k for k in ("GGA", "RMC", "GNS", "GLL") if k in sentences]  # as the note counts
    if "ZDA" in sentences:  # no fix: it dates the epoch of its time
        assert "; 1199 ZDA sentences, 1199 dating an epoch of their time" in said
    assert f"({', '.join(f'1199 {k}' for k in read)} sentences), 1199 with a fix" in said
    gnss = next(s for s in streams.streams if s.name == "gps.nmea")
    assert (c.SPEED_GNSS_M_S in gnss.channels) == ("RMC" in sentences)
    assert (c.N_SATS in gnss.channels) == counts
    if counts:
        np.testing.assert_allclose(gnss.channels[c.N_SATS], g[c.N_SATS])
    assert gnss.sources[c.LAT_DEG] == f"{sentences[0]} latitude"


@pytest.mark.parametrize("sentences", [("GGA", "RMC"), ("GGA", "ZDA")])
def test_dates_a_gps_week_rollover_early_are_moved_onto_the_wheels_clock(tmp_path, sentences):
    """A receiver whose firmware does not carry GPS's 10-bit week past a rollover dates its
    fixes 1024 weeks early (2019-03-11 as 1999-07-26), the time of day right: placed 1024
    weeks later, the labels of the fixes dated right (before stop 78: refused as fixes
    that share no time with the wheels). Fixes dated 1024 weeks late are no rollover:
    refused as before."""
    from rwhonet.data.nmea import GPS_ROLLOVER_S

    tables, _ = receiver_drive()
    t = np.round(tables.gnss[c.T_S].to_numpy(), 2)
    exact = tables.gnss.assign(t_s=t)
    early = nmea_lines(exact, DAY_S - GPS_ROLLOVER_S + t, sentences)
    assert any(",260799," in x or ",26,07,1999," in x for x in early)
    write_nmea(tmp_path / "early" / "gps.nmea", early)
    files = [_wheels(tmp_path / "early", DAY_S), tmp_path / "early" / "gps.nmea"]
    got, streams = receiver_labels(files)
    _same(got.assign(t_s=got["t_s"] - DAY_S), _reference(tmp_path, exact), 0.002)
    assert (
        "gps.nmea: the receiver's dates (1999-07-26 on) 1024 weeks before the stream files' "
        "times: a GPS week-number rollover the receiver's firmware does not carry (its week "
        "modulo 1024), the fixes moved 1024 weeks later"
    ) in " ".join(streams.notes)
    late = nmea_lines(exact, DAY_S + GPS_ROLLOVER_S + t, sentences)
    write_nmea(tmp_path / "late" / "gps.nmea", late)
    files = [_wheels(tmp_path / "late", DAY_S), tmp_path / "late" / "gps.nmea"]
    with pytest.raises(InputError, match="fixes during the stream files' times"):
        receiver_labels(files)


def test_a_logger_clock_in_local_time_is_refused_with_its_offset(tmp_path):
    tables, _ = receiver_drive()
    g = tables.gnss
    t = g[c.T_S].to_numpy()
    write_nmea(tmp_path / "d" / "gps.nmea", nmea_lines(g, DAY_S + t))
    files = [_wheels(tmp_path / "d", DAY_S + 3600.0), tmp_path / "d" / "gps.nmea"]
    with pytest.raises(InputError) as err:
        receiver_labels(files)
    said = str(err.value)
    assert "gps.nmea" in said and "fixes during the stream files' times" in said
    assert "1.00 h ahead of the receiver's UTC: a local time?" in said


def test_a_logger_clock_on_gps_time_is_found_by_the_wheels_and_refused_as_two_clocks(tmp_path):
    """A logger whose clock runs on GPS time (18 s ahead of UTC) beside unstamped sentences:
    their UTC times alone cannot tell it, but the fixes' distances fit the wheels' path
    only 18 s later (the resampler's wide search, rwhonet.data.fixlag). Refused with the
    setting that moves them; with it set, the labels of the drive logged on UTC, exactly,
    18 s later on the logger's clock."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = np.round(g[c.T_S].to_numpy(), 2)
    exact = g.assign(t_s=t)
    for name, shift in (("utc", 0.0), ("gps", 18.0)):
        write_nmea(tmp_path / name / "gps.nmea", nmea_lines(exact, DAY_S + t))
        _wheels(tmp_path / name, DAY_S + shift)
    gps = [tmp_path / "gps" / "wheels.csv", tmp_path / "gps" / "gps.nmea"]
    with pytest.raises(InputError) as err:
        receiver_labels(gps)
    said = str(err.value)
    assert "the fixes and the wheel speeds on two clocks" in said
    assert "(GPS time runs 18 s ahead of UTC since 2017?)" in said
    assert "set data.gnss_lag: -17.9" in said or "set data.gnss_lag: -18.0" in said
    ref = receiver_labels([tmp_path / "utc" / "wheels.csv", tmp_path / "utc" / "gps.nmea"])[0]
    got = receiver_labels(gps, gnss_lag=-18.0)[0]
    _same(got.assign(t_s=got["t_s"] - 18.0), ref, 1e-9)


def test_unstamped_sentences_on_a_logger_s_own_clock_are_refused(tmp_path):
    tables, _ = receiver_drive()
    g = tables.gnss
    write_nmea(tmp_path / "d" / "gps.nmea", nmea_lines(g, DAY_S + g[c.T_S].to_numpy()))
    files = [_wheels(tmp_path / "d", -44_000.0), tmp_path / "d" / "gps.nmea"]  # from 1000 s
    with pytest.raises(InputError) as err:
        receiver_labels(files)
    said = str(err.value)
    assert "sentences without stamps" in said and "counting from the logger's start" in said
    assert "have the logger stamp each sentence" in said


@pytest.mark.parametrize("kind", ["nmea", "ubx"])
def test_a_receiver_that_stopped_early_beside_seconds_of_the_day_is_refused_saying_why(
    tmp_path, kind
):
    """wheels.csv in seconds of the day (IO-VNBD's clock), the receiver's log holding only
    the first 40 % of the drive's fixes (it stopped early): the seconds are not taken as
    UTC seconds of the day, and the refusal says why (the share the fixes cover, not
    "counting from the logger's start" alone) and what reads it. With 60 %: placed."""
    from support.ubx import ubx_messages, write_ubx

    tables, _ = receiver_drive()
    g = tables.gnss
    for share, placed in ((0.4, False), (0.6, True)):
        part = g.iloc[: int(share * len(g))]
        folder = tmp_path / f"{kind}{share}"
        utc = DAY_S + part[c.T_S].to_numpy()
        if kind == "nmea":
            log_ = write_nmea(folder / "gps.nmea", nmea_lines(part, utc))
        else:
            log_ = write_ubx(folder / "gps.ubx", ubx_messages(part, utc))
        files = [_wheels(folder), log_]
        if placed:
            assert len(receiver_labels(files)[0]) > 60
            continue
        with pytest.raises(InputError) as err:
            receiver_labels(files)
        said = " ".join(str(err.value).split())
        assert "taken as counting from the logger's start: below two days" in said
        assert "had the receiver's UTC times of day (45000.0-45047." in said
        assert "covered at least half of its span (45000.0-45119.9 s); they cover 40 %" in said
        assert "UTC seconds of the day written as hh:mm:ss are read so" in said


def test_one_stamp_gone_to_0_on_a_unix_clock_is_refused_where_it_is(tmp_path):
    """The wheels on Unix seconds, one sample's stamp written as 0 (a logger's glitch): the
    clock is still UTC, so the receiver's log is placed, and the stamp is refused at its row
    (not the whole drive as on "a clock counting from the logger's start")."""
    import pandas as pd

    tables, _ = receiver_drive()
    g = tables.gnss
    write_nmea(tmp_path / "d" / "gps.nmea", nmea_lines(g, DAY_S + g[c.T_S].to_numpy()))
    wheels = _wheels(tmp_path / "d", DAY_S)
    df = pd.read_csv(wheels)
    df.loc[46, df.columns[0]] = 0.0
    df.to_csv(wheels, index=False, float_format="%.6f")
    with pytest.raises(InputError) as err:
        receiver_labels([wheels, tmp_path / "d" / "gps.nmea"])
    said = str(err.value)
    assert "wheels.csv], row 47, column 'Time'" in said and "logger's start" not in said


def _log(tmp_path, lines, name="gps.nmea"):
    return read_nmea(write_nmea(tmp_path / name, lines), name)


def test_no_fix_sentences_keep_their_epoch_without_a_position(tmp_path):
    """GGA quality 0 and 6 (the receiver's dead reckoning), RMC status V: the epoch is
    there, its position missing, though the receiver wrote the last one again."""
    t0 = DAY_S + 45000.0
    lines = [
        gga(t0, 52.4, -1.5, 9),
        rmc(t0, 52.4, -1.5, 10.0, 90.0),
        gga(t0 + 1, 52.4, -1.5, 9, quality=6),  # estimated
        rmc(t0 + 1, 52.4, -1.5, 10.0, 90.0),
        gga(t0 + 2, 52.4, -1.5, 3, quality=0),
        gga(t0 + 3, 52.41, -1.49, 8),
        rmc(t0 + 3, 52.41, -1.49, 10.0, 90.0, status="V"),
        gga(t0 + 4, -33.9, 151.2, 12),
        gga(t0 + 5, -33.9, 151.2, 12, quality=9),  # NovAtel's SBAS fix
    ]
    log = _log(tmp_path, lines)
    lat = log.channels["lat"]
    assert np.isnan(lat[1:4]).all() and lat[0] == pytest.approx(52.4, abs=1e-8)
    assert log.channels["lon"][4] == pytest.approx(151.2, abs=1e-8)
    assert log.channels["lat"][4] == pytest.approx(-33.9, abs=1e-8)
    assert log.channels["speed_gnss"][0] == pytest.approx(10.0, abs=1e-3)
    assert np.isnan(log.channels["speed_gnss"][3])  # RMC void
    np.testing.assert_allclose(log.tod_s, 45000.0 + np.arange(6))
    assert log.day_s == DAY_S
    assert "6 epochs (6 GGA, 3 RMC sentences), 3 with a fix" in log.notes[-1]


def test_gns_and_gll_say_when_they_have_no_fix(tmp_path):
    """GNS: a fix where any constellation's mode letter is one (``NA``: GLONASS
    autonomous), none where all are ``N``/``E``; its navigational status ``V`` is no
    verdict on the fix (u-blox writes it beside every fix). GLL: status ``V`` or mode
    ``N`` is no fix. An epoch's GGA gives the position, satellites and altitude before
    its GNS."""
    t0 = DAY_S + 45000.0
    lines = [
        gns(t0, 52.4, -1.5, 9),
        gns(t0 + 1, 52.4, -1.5, 4, mode="NA"),
        gns(t0 + 2, 52.4, -1.5, 0, mode="NN"),
        gns(t0 + 3, 52.4, -1.5, 3, mode="EN"),  # the receiver's dead reckoning
        gll(t0 + 4, 52.5, -1.4),
        gll(t0 + 5, 52.5, -1.4, status="V", mode="N"),
        gll(t0 + 6, 52.5, -1.4, mode="N"),
        gga(t0 + 7, -33.9, 151.2, 12),
        gns(t0 + 7, -33.8, 151.1, 20),
        gll(t0 + 7, -33.7, 151.0),
    ]
    log = _log(tmp_path, lines)
    lat, lon = log.channels["lat"], log.channels["lon"]
    assert np.isfinite(lat).tolist() == [True, True, False, False, True, False, False, True]
    assert lat[4] == pytest.approx(52.5, abs=1e-8) and lon[4] == pytest.approx(-1.4, abs=1e-8)
    assert lat[7] == pytest.approx(-33.9, abs=1e-8) and lon[7] == pytest.approx(151.2, abs=1e-8)
    np.testing.assert_array_equal(log.channels["n_sats"], [9, 4, 0, 3, np.nan, np.nan, np.nan, 12])
    assert log.channels["height"][0] == 112.4 and log.channels["height"][7] == 112.4
    assert log.sources["lat"] == "GGA latitude" and log.sources["n_sats"] == "GGA satellites"
    np.testing.assert_allclose(log.tod_s, 45000.0 + np.arange(8))
    assert log.day_s is None  # no RMC, no date
    assert "8 epochs (1 GGA, 5 GNS, 4 GLL sentences), 4 with a fix" in log.notes[-1]


def test_a_maker_s_own_sentences_are_passed_over_whatever_their_letters(tmp_path):
    """Garmin's $PGRMC (its sensor configuration) ends in the letters of RMC, and $PGRME
    and u-blox's $PUBX sit beside the fixes: passed over, not read as fixes (before stop
    64, $PGRMC was read as an RMC sentence and refused as a time that is no hhmmss)."""
    t0 = DAY_S + 45000.0
    lines = [
        sentence("PGRMC,A,218.8,100,,,,,,A,3,1,1,4,30"),
        gga(t0, 52.4, -1.5, 9),
        sentence("PGRME,15.0,M,45.0,M,25.0,M"),
        rmc(t0, 52.4, -1.5, 10.0, 90.0),
        sentence("PUBX,00,081350.00,4717.113210,N,00833.915187,E,546.589,G3,2.1,2.0"),
        gga(t0 + 1, 52.41, -1.5, 9),
    ]
    log = _log(tmp_path, lines)
    np.testing.assert_allclose(log.tod_s, [45000.0, 45001.0])
    assert "2 epochs (2 GGA, 1 RMC sentences), 2 with a fix" in log.notes[-1]
    assert not log.dropped


def test_documented_gll_sentences_read_as_their_positions(tmp_path):
    """GLL as gpsd's NMEA notes (v2.2, no mode) and u-blox's M8 protocol manual (v4.10)
    print it, their checksums as printed."""
    log = _log(
        tmp_path,
        [
            "$GPGLL,4916.45,N,12311.12,W,225444,A,*1D",
            "$GPGLL,4717.11364,N,00833.91565,E,092321.00,A,A*60",
        ],
    )
    assert log.channels["lat"][0] == pytest.approx(49 + 16.45 / 60, abs=1e-12)
    assert log.channels["lon"][0] == pytest.approx(-(123 + 11.12 / 60), abs=1e-12)
    assert log.channels["lat"][1] == pytest.approx(47 + 17.11364 / 60, abs=1e-12)
    assert log.channels["lon"][1] == pytest.approx(8 + 33.91565 / 60, abs=1e-12)
    np.testing.assert_allclose(log.tod_s, [22 * 3600 + 54 * 60 + 44, 9 * 3600 + 23 * 60 + 21])
    assert not log.dropped


def test_damaged_lines_are_passed_over_and_counted(tmp_path):
    t0 = DAY_S + 45000.0
    good = [gga(t0 + i, 52.4 + i * 1e-4, -1.5, 9) for i in range(6)]
    bad_sum = good[1][:-2] + ("00" if not good[1].endswith("00") else "01")
    lines = [
        "# logger v1.2",
        good[0],
        bad_sum,  # a byte lost on the line
        good[2][:25],  # cut short
        "\x00\x00\x00garbage",
        "",
        sentence("GPGGA,,,,,,0,00,99.99,,,,,,"),  # no time yet
        "$PUBX,00,foo*00",
        good[3],
        good[3],  # twice
        good[4],
        good[5],
    ]
    log = _log(tmp_path, lines)
    np.testing.assert_allclose(log.tod_s, 45000.0 + np.array([0, 3, 4, 5]))
    np.testing.assert_array_equal(log.rows, [2, 9, 11, 12])
    said = log.notes[-1]
    assert "1 sentence(s) with a checksum that does not match (first at line 3)" in said
    assert "1 sentence(s) cut short (first at line 4)" in said
    assert "1 lines that are no sentence (first at line 5)" in said
    assert "1 sentence(s) without a UTC time (first at line 7)" in said
    assert "1 sentence(s) of an epoch already given (first at line 10)" in said
    assert log.dropped.startswith("1 sentence(s) with a checksum")  # predict says it
    assert log.dropped.endswith("1 lines that are no sentence (first at line 5)")


@pytest.mark.parametrize(
    ("first", "bad", "said"),
    [
        (  # GGA: a latitude, a hemisphere letter, a time that are no numbers
            "gga",
            [
                "GPGGA,123001.00,52x4.000,N,00130.000,W,1,09,0.9,112.4,M,47.0,M,,",
                "GPGGA,123002.00,5224.000,N,00130.000,X,1,09,0.9,112.4,M,47.0,M,,",
                "GPGGA,126002.00,5224.000,N,00130.000,W,1,09,0.9,112.4,M,47.0,M,,",
            ],
            [
                "gps.nmea, row 2, column 'GGA latitude': expected a number; found '52x4.000'",
                "row 3, column 'GGA longitude'",
                "'00130.000' 'X'",
                "row 4, column 'UTC time'",
            ],
        ),
        (  # GNS's satellites, GLL's hemisphere letter and time
            "gns",
            [
                "GNGNS,123001.00,5224.000,N,00130.000,W,AA,x9,0.9,112.4,47.0,,,V",
                "GPGLL,5224.000,N,00130.000,Q,123002.00,A,A",
                "GPGLL,5224.000,N,00130.000,W,12x003.00,A,A",
            ],
            [
                "gps.nmea, row 2, column 'GNS satellites': expected a number; found 'x9'",
                "row 3, column 'GLL longitude'",
                "'00130.000' 'Q'",
                "row 4, column 'UTC time'",
                "'12x003.00'",
            ],
        ),
    ],
)
def test_a_field_that_is_no_number_is_refused_with_its_line(tmp_path, first, bad, said):
    t0 = DAY_S + 45000.0
    lines = [{"gga": gga, "gns": gns}[first](t0, 52.4, -1.5, 9), *map(sentence, bad)]
    with pytest.raises(InputError) as err:
        _log(tmp_path, lines)
    for part in said:
        assert part in str(err.value)


def test_a_log_across_midnight_is_continuous_and_contradicting_dates_are_refused(tmp_path):
    t0 = DAY_S + 86400.0 - 1.5
    lines = [
        s for i in range(4) for s in (gga(t0 + i, 52.4, -1.5, 9), rmc(t0 + i, 52.4, -1.5, 1, 0))
    ]
    log = _log(tmp_path, lines)
    np.testing.assert_allclose(log.t_utc_s, t0 + np.arange(4))
    assert "passed midnight" in " ".join(log.notes)
    wrong = [*lines, rmc(t0 + 4 + 86400.0, 52.4, -1.5, 1, 0)]  # a day later than its time
    with pytest.raises(InputError) as err:
        _log(tmp_path, wrong, "b.nmea")
    assert "b.nmea, row 9, column 'RMC date'" in str(err.value)


def test_zda_dates_the_epoch_of_its_time_and_is_checked_against_rmc(tmp_path):
    """A receiver set to GGA and ZDA (no RMC): ZDA's day, month and year date the epoch of
    its time, across midnight as RMC's do. A ZDA at a time no fix has dates nothing, makes
    no epoch; ZDA alone is no fix. A ZDA that contradicts the RMC dates, or holds no date,
    is refused naming its line and the ZDA date."""
    t0 = DAY_S + 86400.0 - 1.5  # 23:59:58.5 on 11 March 2019
    lines = [s for i in range(4) for s in (gga(t0 + i, 52.4, -1.5, 9), zda(t0 + i))]
    log = _log(tmp_path, [zda(t0 - 0.5), *lines])  # the first at a time of no fix
    assert log.tod_s.size == 4 and log.dated_by == "ZDA dates"
    np.testing.assert_allclose(log.t_utc_s, t0 + np.arange(4))
    assert "; 5 ZDA sentences, 4 dating an epoch of their time" in " ".join(log.notes)
    both = [
        s for i in range(4) for s in (gga(t0 + i, 52.4, -1.5, 9), rmc(t0 + i, 52.4, -1.5, 1, 0))
    ]
    log = _log(tmp_path, [*both, zda(t0 + 3)], "both.nmea")
    assert log.dated_by == "RMC and ZDA dates" and log.day_s == DAY_S
    with pytest.raises(InputError) as err:  # a day later than its time
        _log(tmp_path, [*both, zda(t0 + 3 + 86400.0)], "late.nmea")
    (p,) = err.value.problems
    assert (p.file, p.row, p.column) == ("late.nmea", 9, "ZDA date")
    assert p.expected.startswith("the date of the log's earlier sentences (RMC 110319, line 2)")
    with pytest.raises(InputError) as err:
        _log(tmp_path, [*lines[:2], sentence("GPZDA,235958.50,32,03,2019,,")], "bad.nmea")
    (p,) = err.value.problems
    assert (p.file, p.row, p.column) == ("bad.nmea", 3, "ZDA date")
    assert p.expected.startswith("a date in ZDA's day, month and year fields")
    assert p.found.startswith("'32,03,2019'")
    with pytest.raises(InputError) as err:
        _log(tmp_path, [zda(t0), zda(t0 + 1)], "alone.nmea")
    assert "expected NMEA 0183 GGA, RMC, GNS or GLL sentences" in str(err.value)


def test_a_file_without_gga_or_rmc_is_refused(tmp_path):
    with pytest.raises(InputError) as err:
        _log(tmp_path, ["$GPGSV,1,1,01,05,40,083,46*7A", sentence("GPGGA,,,,,,0,00,,,,,,,")])
    said = str(err.value)
    assert "expected NMEA 0183 GGA, RMC, GNS or GLL sentences with a UTC time" in said
    assert "1 sentence(s) without a UTC time (first at line 2)" in said
    # an empty log, a text file named .nmea, a log of satellites in view alone
    for text in ("", "no sentence here\n", "$GPGSV,1,1,01,05,40,083,46*7A\n"):
        path = tmp_path / "empty.nmea"
        path.write_text(text)
        with pytest.raises(InputError) as err:  # before stop 64: IndexError (no "$" at all)
            read_nmea(path, "empty.nmea")
        assert "empty.nmea: expected NMEA 0183 GGA, RMC, GNS or GLL sentences" in str(err.value)
    # two such logs of one drive: both named in one report
    (tmp_path / "gps_1.nmea").write_text("")
    (tmp_path / "gps_2.nmea").write_text("no sentence here\n")
    files = [_wheels(tmp_path / "w"), tmp_path / "gps_1.nmea", tmp_path / "gps_2.nmea"]
    with pytest.raises(InputError) as err:
        receiver_labels(files)
    assert {Path(p.file).name for p in err.value.problems} == {"gps_1.nmea", "gps_2.nmea"}


def _stream_folder(tmp_path, with_nmea=True, with_gnss_csv=False, two=False):
    from rwhonet.sim.streams import write_stream_csvs

    tables, _ = receiver_drive()
    files = write_stream_csvs(tables, tmp_path / "d")
    paths = [files["wheels"]]
    if with_gnss_csv:
        paths.append(files["gnss"])
    if with_nmea:
        t = tables.gnss[c.T_S].to_numpy()
        for name in ("gps.nmea", "gps2.nmea")[: 2 if two else 1]:
            lines = nmea_lines(tables.gnss, DAY_S + t, stamps=t)
            paths.append(write_nmea(tmp_path / "d" / name, lines))
    return paths


def test_where_the_fixes_come_from(tmp_path):
    from rwhonet.sim.streams import signal_map

    smap = dict(signal_map())
    no_fix_keys = {k: v for k, v in smap.items() if k not in ("lat", "lon", "n_sats")}
    # the map's fixes in gnss.csv: the NMEA log left out, said so
    _, streams = receiver_labels(_stream_folder(tmp_path / "a", with_gnss_csv=True))
    assert any("receiver log(s), left out: the fixes are" in n for n in streams.notes)
    # no fix keys in the map: the log gives them all
    _, streams = receiver_labels(_stream_folder(tmp_path / "b"), no_fix_keys)
    gnss = next(s for s in streams.streams if s.name == "gps.nmea")
    assert {c.LAT_DEG, c.LON_DEG, c.N_SATS, c.SPEED_GNSS_M_S, c.HEADING_DEG} <= set(gnss.channels)
    # a map written for another drive's gps.csv, with hemisphere letters: the log's fixes
    lettered = smap | {
        "lat": ColumnSpec("Lat", "ddmm"),
        "lon": ColumnSpec("Lon", "ddmm"),
        "lat_hemisphere": ColumnSpec("NS", "N/S"),
        "lon_hemisphere": ColumnSpec("EW", "E/W"),
    }
    _, streams = receiver_labels(_stream_folder(tmp_path / "f"), lettered)
    assert any("the fixes are the receiver log's ('Lat', 'Lon'" in n for n in streams.notes)
    # neither
    with pytest.raises(InputError) as err:
        receiver_labels(_stream_folder(tmp_path / "c", with_nmea=False), no_fix_keys)
    assert "lat and lon not in the signal map, and no receiver log" in str(err.value)
    # the same log twice (gps.nmea, gps2.nmea): a copy, left out, and said
    got, streams = receiver_labels(_stream_folder(tmp_path / "e", two=True), no_fix_keys)
    one, _ = receiver_labels(_stream_folder(tmp_path / "b"), no_fix_keys)
    pd.testing.assert_frame_equal(got, one)
    assert "gps2.nmea [gps2.nmea]: a copy of " in " ".join(streams.changed)


@pytest.mark.parametrize("clock", ["stamp", "unix", "day"])
def test_a_log_a_logger_rotated_reads_as_the_one_log(tmp_path, clock):
    """The receiver's log rotated into three files by size, one cut between an epoch's GGA
    and its RMC: the fixes are the one log's (that epoch's position, satellites and speed
    taken from both files), the labels the one log's exactly; with the logger's stamps,
    with the receiver's UTC times on a Unix clock, and on seconds of the day (IO-VNBD's
    clock: each file alone covers less than half of the wheels' span, the three do)."""
    stamped = clock == "stamp"
    tables, _ = receiver_drive()
    t = np.round(tables.gnss[c.T_S].to_numpy(), 2)
    exact = tables.gnss.assign(t_s=t)
    lines = nmea_lines(exact, DAY_S + t, stamps=DAY_S + t if stamped else None)
    assert lines[701].split("$")[1].startswith("GPRMC")  # the cut at 701: an epoch split
    one = write_nmea(tmp_path / "one" / "gps.nmea", lines)
    wheels = _wheels(tmp_path / "wheels", 0.0 if clock == "day" else DAY_S)
    want, _ = receiver_labels([wheels, one])
    rotated = [
        write_nmea(tmp_path / "rotated" / name, part)
        for name, part in (
            ("gps_c.nmea", lines[:701]),
            ("gps_a.nmea", lines[701:1500]),
            ("gps_b.nmea", lines[1500:]),
        )
    ]
    got, streams = receiver_labels([wheels, *rotated])
    pd.testing.assert_frame_equal(got, want)
    (gnss,) = [s for s in streams.streams if s.parts]
    assert [Path(f).name for f, _ in gnss.parts] == ["gps_c.nmea", "gps_a.nmea", "gps_b.nmea"]
    assert "gps_a.nmea]: its first 1 sample(s) at the times of the last" in " ".join(
        streams.changed
    )


def test_a_mapped_gnss_key_neither_file_gives_is_refused(tmp_path):
    tables, _ = receiver_drive()
    t = tables.gnss[c.T_S].to_numpy()
    lines = nmea_lines(tables.gnss, DAY_S + t, ("RMC",), stamps=t)
    files = [_wheels(tmp_path / "d"), write_nmea(tmp_path / "d" / "gps.nmea", lines)]
    with pytest.raises(InputError) as err:
        receiver_labels(files)  # the map names NumSV: RMC has no satellites
    said = str(err.value)
    assert "the signal map.n_sats in a stream file or in the receiver log's messages" in said
    assert "RMC latitude" in said


def test_course_and_speed_units(tmp_path):
    t0 = DAY_S + 45000.0
    log = _log(tmp_path, [rmc(t0, 52.4, -1.5, 20.0 * KNOT_M_S, 271.5)])
    assert log.channels["speed_gnss"][0] == pytest.approx(20.0 * KNOT_M_S, abs=1e-6)
    assert log.channels["heading"][0] == pytest.approx(271.5)
    assert math.isnan(log.channels["n_sats"][0]) if "n_sats" in log.channels else True


def test_the_real_minute_s_fixes_as_nmea_sentences_give_the_comma2k19_reader_s_labels(tmp_path):
    """The real RAV4 minute as a CAN logger and an NMEA logger would have written it: the
    wheel speeds as wheels.csv on the phone's boot clock, the u-blox fixes as GGA and RMC
    sentences with the receiver's own UTC times. Each line after the boot-clock stamp:
    the labels of the comma2k19 reader (measured: 2e-6 m). Without stamps, the wheels'
    clock put on UTC by the receiver's own clock fit: the UTC times are placed by their
    dates; the seconds then start 0.354 s later in the drive, so the 59 seconds cover a
    slightly other stretch (measured: 1003.05 m against 1001.81 m, mean |label| 0.160
    against 0.158 m). GGA and ZDA sentences, without stamps, give those seconds too."""
    from rwhonet.data.fixtimes import receiver_epochs
    from support.multirate import per_second
    from support.realminute import RAV4_RADIUS_M, real_minute, reference_seconds

    minute = real_minute()
    ref = reference_seconds()
    tw, vw, tg, vg = minute.t_wheels, minute.wheels, minute.t_gnss, minute.gnss
    fit = receiver_epochs(tg, vg[:, 3])
    smap = {"t": ColumnSpec("t", "s")} | {
        f"omega_{w}": ColumnSpec(w, "m/s") for w in ("fl", "fr", "rl", "rr")
    }
    got, said = {}, {}
    for case in ("stamped", "utc", "zda"):
        folder = tmp_path / case
        folder.mkdir()
        t = tw if case == "stamped" else tw + fit.offset_s + fit.drift * (tw - fit.t_ref_s)
        wheels = {"t": t} | {w: vw[:, k] for k, w in enumerate(("fl", "fr", "rl", "rr"))}
        pd.DataFrame(wheels).to_csv(folder / "wheels.csv", index=False, float_format="%.6f")
        lines = []
        for i in range(tg.size):
            utc = vg[i, 3] / 1000.0
            dated = zda(utc) if case == "zda" else rmc(utc, *vg[i, [0, 1, 2, 5]])
            for s in (gga(utc, vg[i, 0], vg[i, 1], 9), dated):
                lines.append(f"{tg[i]:.6f} {s}" if case == "stamped" else s)
        write_nmea(folder / "gps.nmea", lines)
        streams = read_stream_csvs(
            [folder / "wheels.csv", folder / "gps.nmea"], smap, RAV4_RADIUS_M
        )
        drive = resample(streams, nominal_radius_m=RAV4_RADIUS_M).drive.columns
        got[case] = per_second(drive, RAV4_RADIUS_M)
        said[case] = " ".join(streams.notes)
    stamped, utc = got["stamped"], got["utc"]
    assert len(stamped) == len(utc) == len(ref) == 59
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(stamped[q], ref[q], rtol=0, atol=1e-5)
    np.testing.assert_allclose(utc["t_s"] - fit.offset_s, ref["t_s"] + 0.354, atol=1e-3)
    assert utc["disp_gnss_m"].sum() == pytest.approx(ref["disp_gnss_m"].sum(), abs=2.0)
    assert utc["label_m"].abs().mean() == pytest.approx(ref["label_m"].abs().mean(), abs=0.005)
    # a receiver set to GGA and ZDA: the same seconds, dated by ZDA
    pd.testing.assert_frame_equal(got["zda"], utc)
    assert "UTC times and RMC dates" in said["utc"] and "UTC times and ZDA dates" in said["zda"]


def test_two_sentences_run_together_are_passed_over(tmp_path):
    """A lost line end joins two sentences into one line longer than NMEA's 82 characters
    (the first's checksum inside, the second's at the end): passed over, not read as one."""
    t0 = DAY_S + 45000.0
    good = [gga(t0 + i, 52.4 + i * 1e-4, -1.5, 9) for i in range(4)]
    log = _log(tmp_path, [good[0], good[1] + good[2], good[3]])
    np.testing.assert_allclose(log.tod_s, 45000.0 + np.array([0, 3]))
    assert "1 sentence(s) longer than a sentence can be (two run together) (first at line 2)" in (
        log.dropped
    )


@pytest.mark.parametrize("ending", ["\n\r", "\r"])
def test_a_serial_line_s_lf_cr_or_cr_alone_is_a_line_end(tmp_path, ending):
    """A logger writing the serial line's LF CR leaves a CR before each "$" (no stamp; a
    capture that starts just after a line end has one before its first sentence too); a
    log of CR line ends alone is read line by line too."""
    t0 = DAY_S + 45000.0
    lines = [gga(t0 + i, 52.4 + i * 1e-4, -1.5, 9) for i in range(3)]
    path = tmp_path / "gps.nmea"
    path.write_bytes((ending + ending.join(lines) + ending).encode())
    log = read_nmea(path, "gps.nmea")
    np.testing.assert_allclose(log.tod_s, 45000.0 + np.arange(3))
    assert log.stamps is None and log.dropped == ""


def test_a_log_stamped_in_part_on_a_logger_s_own_clock_is_refused_saying_so(tmp_path):
    tables, _ = receiver_drive()
    g = tables.gnss
    t = g[c.T_S].to_numpy() - 44_000.0  # the wheels' clock from 1000 s
    lines = nmea_lines(g, DAY_S + g[c.T_S].to_numpy(), stamps=t)
    lines[30] = lines[30].split(",", 1)[1]  # epoch 11's GGA without its stamp
    files = [_wheels(tmp_path / "d", -44_000.0), write_nmea(tmp_path / "d" / "gps.nmea", lines)]
    with pytest.raises(InputError) as err:
        receiver_labels(files)
    said = str(err.value)
    assert "1 of 1199 epochs' sentences without a logger stamp (first at line 31)" in said


def _leap_log(
    tmp_path,
    leap_s: float,
    stamped: bool = False,
    after_s: float = 60.0,
    moved=None,
    sentences=("GGA", "RMC"),
):
    """The drive's fixes on the receiver's 10 Hz grid, its UTC ``leap_s`` ahead for the first
    ``after_s`` seconds (a receiver started without the leap seconds, before it decoded
    them), then right; ``moved``: degrees added to the positions after the step."""
    tables, _ = receiver_drive()
    g = tables.gnss
    t = np.round(g[c.T_S].to_numpy(), 1)  # a receiver's epochs: its 10 Hz grid
    exact = g.assign(t_s=t)
    before = t < t[0] + after_s
    utc = DAY_S + t + np.where(before, leap_s, 0.0)
    shown = (
        exact if moved is None else exact.assign(lat_deg=g[c.LAT_DEG] + np.where(before, 0, moved))
    )
    lines = nmea_lines(shown, utc, sentences, stamps=t if stamped else None)
    folder = tmp_path / ("stamped" if stamped else "utc")
    log = write_nmea(folder / "gps.nmea", lines)
    return exact, log, _wheels(folder, 0.0 if stamped else DAY_S)


@pytest.mark.parametrize(
    ("leap_s", "stamped", "sentences"),
    [
        (2.0, False, ("GGA", "RMC")),
        (1.0, False, ("GGA", "RMC")),
        (3.0, True, ("GGA", "RMC")),
        (2.0, False, ("GGA", "ZDA")),
    ],
)
def test_a_receiver_s_step_onto_the_leap_seconds_is_undone(tmp_path, leap_s, stamped, sentences):
    """A receiver started without the leap seconds gives UTC some whole seconds ahead until
    it decodes them from the navigation message (up to 12.5 min), then steps back: the
    fixes before the step are moved back, and the labels are those of the fixes dated
    right (within the ddmm.mmmmmm rounding, 2 mm). Before stop 80 the fixes after the step
    fell on the times of those before (each "of an epoch already given", dropped), the
    ones before it stayed ahead, and the drive was refused as two clocks or misplaced."""
    exact, log, wheels = _leap_log(tmp_path, leap_s, stamped, sentences=sentences)
    from rwhonet.sim.streams import signal_map

    smap = {k: v for k, v in signal_map().items() if k not in ("speed_gnss", "heading")}
    got, streams = receiver_labels([wheels, log], smap)
    ref = _reference(tmp_path, exact)
    _same(got.assign(t_s=got["t_s"] - (0.0 if stamped else DAY_S)), ref, 0.002)
    said = " ".join(streams.notes)
    assert f"the receiver's UTC stepped back {leap_s:.0f} s at line 1801, 60 s into the log" in said
    assert "the 1200 sentences before it moved" in said  # 600 epochs' GGA and RMC (or ZDA)
    assert "already given" not in said
    if "ZDA" in sentences:  # each dates its own epoch, the one after its epoch's GGA too
        assert "1199 ZDA sentences, 1199 dating an epoch of their time" in said


def test_a_step_back_that_is_no_leap_second_step_is_left_alone(tmp_path, monkeypatch):
    """A step back of a second and a half, one after the first 15 min, one where the car's
    position jumps, and a block of lines sent twice are no receiver learning its leap
    seconds: the times are left as they are."""
    from rwhonet.data import nmea

    def note(log) -> str:
        return " ".join(read_nmea(log, log.name).notes)

    assert "stepped back" in note(_leap_log(tmp_path / "a", 2.0)[1])
    assert "stepped back" not in note(_leap_log(tmp_path / "b", 1.5)[1])
    assert "stepped back" not in note(_leap_log(tmp_path / "c", 2.0, moved=0.01)[1])
    monkeypatch.setattr(nmea, "LEAP_WITHIN_S", 30.0)
    assert "stepped back" not in note(_leap_log(tmp_path / "d", 2.0)[1])
    monkeypatch.undo()
    log = _leap_log(tmp_path / "e", 0.0)[1]
    lines = log.read_text().splitlines()
    resent = lines[:1800] + lines[1770:1800] + lines[1800:]  # 10 epochs sent again
    log.write_text("\n".join(resent) + "\n")
    said = note(log)
    assert "stepped back" not in said and "20 sentence(s) of an epoch already given" in said


def _velocity_1hz():
    """:func:`receiver_drive`'s fixes a second apart (every tenth), and each one's velocity
    from its 10 Hz neighbours (0.1 s either side): speed, m/s, and course, degrees."""
    from rwhonet.geo import local_step_en_m

    g = receiver_drive()[0].gnss
    lat, lon, t = (g[k].to_numpy() for k in (c.LAT_DEG, c.LON_DEG, c.T_S))
    east, north = local_step_en_m(lat[:-2], lon[:-2], lat[2:], lon[2:])
    at = np.arange(10, len(g) - 10, 10)
    dt = t[at + 1] - t[at - 1]
    speed = np.hypot(east[at - 1], north[at - 1]) / dt
    course = np.degrees(np.arctan2(east[at - 1], north[at - 1])) % 360.0
    return g.iloc[at].reset_index(drop=True), np.round(speed, 2), np.round(course, 2)


@pytest.mark.parametrize(
    "burst",
    [
        ("GGA", "VTG", "ZDA"),  # a survey receiver's: the VTG between its epoch's sentences
        ("GGA", "VTG"),  # the VTG after its epoch's GGA
        ("VTG", "GGA", "GSA", "GLL"),  # a u-blox's with RMC off: each epoch begins with VTG
    ],
)
def test_vtg_gives_the_speed_and_course_of_the_epoch_it_is_written_with(tmp_path, burst):
    """A receiver set to GGA and VTG (and ZDA) writes no RMC: the speed and course are
    VTG's. A VTG has no time: it is its epoch's by its place among the epoch's sentences,
    or, between two epochs' sentences, the way its velocity fits the fixes'. Each epoch
    gets its own VTG's speed and course exactly: taken the other way they would be a
    second late or early (up to 7 m/s and 110 degrees apart on this drive)."""
    fixes, speed, course = _velocity_1hz()
    t = DAY_S + np.round(fixes[c.T_S].to_numpy(), 2)
    lines = []
    for i in range(len(fixes)):
        lat, lon = fixes[c.LAT_DEG][i], fixes[c.LON_DEG][i]
        written = {
            "GGA": gga(t[i], lat, lon, 9),
            "VTG": vtg(speed[i], course[i]),
            "ZDA": zda(t[i]),
            "GSA": sentence("GPGSA,A,3,05,13,15,18,,,,,,,,,1.9,0.9,1.7"),
            "GLL": gll(t[i], lat, lon),
        }
        lines += [written[k] for k in burst]
    log = _log(tmp_path, lines)
    assert log.tod_s.size == len(fixes)
    np.testing.assert_allclose(log.channels["speed_gnss"], speed, rtol=0, atol=2e-3)
    np.testing.assert_allclose(log.channels["heading"], course, rtol=0, atol=1e-9)
    assert log.sources["speed_gnss"] == "VTG speed"
    assert log.sources["heading"] == "VTG course"
    assert f"{len(fixes)} GGA sentences" not in log.notes[-1]  # with the VTG count
    assert f", {len(fixes)} VTG sentences)" in log.notes[-1]  # GGA's satellites: no GSA read
    assert not log.dropped
    said = " ".join(log.notes)
    if burst[-1] == "ZDA":
        assert "stand between" not in said
    else:
        way = "after" if burst[0] == "VTG" else "before"
        assert f"each is taken as the epoch {way} it, whose fixes' velocity" in said
    # a second later or earlier: the data tell which (the wrong way fits much worse)
    assert np.nanmax(np.abs(np.diff(speed))) > 5.0
    assert np.nanmax(np.abs((np.diff(course) + 180.0) % 360.0 - 180.0)) > 90.0


def test_vtg_beside_rmc_fills_only_the_epochs_without_one(tmp_path):
    """RMC's speed and course where the epoch has an RMC, the VTG's where it has none; a
    VTG of a mode that is no fix, or of an epoch without a fix, gives none; the speed
    from km/h where the knots are empty; a value whose letter is not its unit's is none;
    a VTG before the log's first epoch (the epoch before it, cut off) is counted."""
    t0 = DAY_S + 45000.0
    lines = [
        vtg(4.0, 10.0),  # the last epoch's before the log began: trailing VTGs below
        gga(t0, 52.4, -1.5, 9),
        rmc(t0, 52.4, -1.5, 10.0, 90.0),
        vtg(11.0, 95.0),  # RMC's are kept
        gga(t0 + 1, 52.4001, -1.5, 9),
        vtg(12.0, 100.0),
        gga(t0 + 2, 52.4002, -1.5, 9),
        vtg(13.0, 105.0, mode="N"),
        gga(t0 + 3, 52.4003, -1.5, 9, quality=0),
        vtg(14.0, 110.0),
        gga(t0 + 4, 52.4004, -1.5, 9),
        vtg(15.0, 115.0, knots=False),
        gga(t0 + 5, 52.4005, -1.5, 9),
        sentence("GPVTG,120.00,M,,M,32.0,K,59.3,K,A"),  # course not true, knots not knots
        gga(t0 + 6, 52.4006, -1.5, 9),
        sentence("GPVTG,,T,,M,,N,3.2,N,A"),  # no course (standing), km/h not km/h
    ]
    log = _log(tmp_path, lines)
    np.testing.assert_allclose(
        log.channels["speed_gnss"],
        [10.0, 12.0, np.nan, np.nan, 15.0, 59.3 / 3.6, np.nan],
        rtol=0,
        atol=2e-3,
    )
    np.testing.assert_allclose(
        log.channels["heading"],
        [90.0, 100.0, np.nan, np.nan, 115.0, np.nan, np.nan],
        rtol=0,
        atol=1e-9,
    )
    assert log.sources["heading"] == "RMC course (VTG's where an epoch has no RMC)"
    assert "1 sentence(s) (VTG, GSA) whose epoch the log does not hold" in log.dropped
    assert "(first at line 1)" in log.dropped
    assert "without a UTC time" not in log.dropped  # a VTG has none, and needs none


def test_the_fixes_velocity_is_taken_only_from_epochs_close_either_side():
    """The velocity a VTG is compared with is the fixes' at its epoch: from the epochs
    either side, none where they are more than 5 s apart (a gap in the fixes), none at
    the log's ends and without a fix."""
    from rwhonet.data.nmea import _misfit, _Track
    from rwhonet.geo import latlon_from_offsets_deg

    # east at 10 m/s, one epoch a second, a gap of 9 s after the fourth, one without a fix
    t = np.array([0.0, 1.0, 2.0, 3.0, 12.0, 13.0, 14.0, 15.0])
    lat, lon = latlon_from_offsets_deg(52.4, -1.5, 10.0 * t, np.zeros(t.size))
    lat[6] = lon[6] = np.nan
    got = _misfit(_Track(lat, lon, t), np.arange(8), np.full(8, 10.0), np.zeros(8))
    np.testing.assert_allclose(got[[1, 2]], 0.0, atol=1e-6)  # (1e-3 m/s)^2
    assert np.isnan(got[[0, 3, 4, 5, 7]]).all()  # ends, a gap either side, no fix beside


def test_a_vtg_field_that_is_no_number_is_refused_with_its_line(tmp_path):
    t0 = DAY_S + 45000.0
    lines = [gga(t0, 52.4, -1.5, 9), sentence("GPVTG,1O.5,T,,M,3.0,N,5.6,K,A")]
    with pytest.raises(InputError) as err:
        _log(tmp_path, lines)
    said = str(err.value)
    assert "row 2" in said and "VTG course" in said and "'1O.5'" in said


def test_a_gga_and_vtg_log_gives_the_drive_its_course_as_an_rmc_log_does(tmp_path):
    """Through a stream folder: the receiver's GGA and VTG give the drive the speed and
    course an RMC log of the same fixes gives, and the same labels."""
    from rwhonet.sim.streams import signal_map

    fixes, speed, course = _velocity_1hz()
    t = np.round(fixes[c.T_S].to_numpy(), 2)
    lat, lon = fixes[c.LAT_DEG].to_numpy(), fixes[c.LON_DEG].to_numpy()
    wheels = _wheels(tmp_path / "w", DAY_S)
    with_rmc = [
        s
        for i in range(len(t))
        for s in (
            gga(DAY_S + t[i], lat[i], lon[i], 9),
            rmc(DAY_S + t[i], lat[i], lon[i], speed[i], course[i]),
        )
    ]
    with_vtg = [
        s
        for i in range(len(t))
        for s in (gga(DAY_S + t[i], lat[i], lon[i], 9), vtg(speed[i], course[i]))
    ]
    smap = {k: v for k, v in signal_map().items() if k not in ("lat", "lon", "n_sats")}
    one = receiver_labels([wheels, write_nmea(tmp_path / "r" / "gps.nmea", with_rmc)], smap)
    two = receiver_labels([wheels, write_nmea(tmp_path / "v" / "gps.nmea", with_vtg)], smap)
    pd.testing.assert_frame_equal(one[0], two[0])
    (a,) = [s for s in one[1].streams if s.name == "gps.nmea"]
    (b,) = [s for s in two[1].streams if s.name == "gps.nmea"]
    for key in (c.SPEED_GNSS_M_S, c.HEADING_DEG):
        np.testing.assert_allclose(b.channels[key], a.channels[key], rtol=0, atol=2e-3)
        assert np.isfinite(b.channels[key]).sum() > 100


def _rmc_and_gsa(t0: float, sats: list[int], order: str, again: int = -1) -> list[str]:
    """An RMC and GSA receiver's log, 1 Hz: each epoch's RMC (void where it has no
    satellites) and its two GSAs (GPS and GLONASS, ``sats`` satellites between them; fix
    type 1 and none listed without a fix), written after its RMC (u-blox's, MediaTek's,
    Garmin's order) or before it (SiRF's); a fix of 3 satellites 2D (fix type 2); up to
    12 satellites in the GPS GSA, the rest in the GLONASS one; epoch ``again``'s GPS GSA
    written twice."""
    lines = []
    for i, n in enumerate(sats):
        kind = 1 if not n else 2 if n == 3 else 3
        gps, glo = list(range(1, min(n, 12) + 1)), list(range(65, 65 + max(n - 12, 0)))
        said = [gsa(gps, kind, system=1), gsa(glo, kind, system=2)]
        said += said[:1] if i == again else []
        fix = rmc(t0 + i, 52.4 + 1e-4 * i, -1.5, 10.0, 0.0, status="A" if n else "V")
        lines += [fix, *said] if order == "after" else [*said, fix]
    return lines


SATS = [9, 9, 8, 3, 0, 0, 5, 11, 14, 12, 10, 0, 7, 7, 6]


@pytest.mark.parametrize(("order", "way"), [("after", "before"), ("before", "after")])
def test_gsa_gives_the_satellites_of_an_rmc_log_by_the_epoch_its_fix_agrees_with(
    tmp_path, order, way
):
    """A receiver set to RMC and GSA writes no GGA: an epoch's satellites are the ids its
    GSAs list (one a constellation), summed. A GSA has no time: between one epoch's RMC
    and the next it is the epoch whose fix its fix type agrees with, u-blox's after its
    RMC, SiRF's before; each epoch gets its own count exactly (taken the other way, every
    count would be a second late or early). A GSA written twice in its epoch counts
    once."""
    t0 = DAY_S + 45000.0
    log = _log(tmp_path, _rmc_and_gsa(t0, SATS, order, again=8))
    np.testing.assert_array_equal(log.channels["n_sats"], SATS)
    assert log.sources["n_sats"] == "GSA satellites"
    np.testing.assert_array_equal(np.isfinite(log.channels["lat"]), np.array(SATS) > 0)
    said = " ".join(log.notes)
    assert (
        f"GSA sentences (no time of their own) stand between one epoch's sentences and the "
        f"next's; each is taken as the epoch {way} it, whose fix its fix type agrees with "
        f"(0 contradicting, 8 the other way, over 29)" in said
    )
    assert "15 epochs (15 RMC, 31 GSA sentences), 12 with a fix" in log.notes[-1]
    assert "1 sentence(s) of an epoch already given" in log.notes[-1]


def test_gsa_satellites_only_where_an_epoch_has_no_gga_and_a_tie_takes_the_epoch_before(
    tmp_path,
):
    """GGA's satellites are kept where an epoch has a GGA, the GSAs' only fill those
    without. A log whose fixes never come and go cannot tell a GSA before its RMC from
    one after: each is taken as the epoch before, said so (the counts a second late)."""
    t0 = DAY_S + 45000.0
    lines = _rmc_and_gsa(t0, [8, 9, 10, 11], "after")
    lines.insert(0, gga(t0, 52.4, -1.5, 6))
    log = _log(tmp_path / "a", lines)
    np.testing.assert_array_equal(log.channels["n_sats"], [6, 9, 10, 11])
    assert log.sources["n_sats"] == "GGA satellites (GSA's where an epoch has none)"
    assert log.sources["height"] == "GGA altitude"
    log = _log(tmp_path / "b", _rmc_and_gsa(t0, [8, 9, 10, 11], "before"))
    np.testing.assert_array_equal(log.channels["n_sats"], [9, 10, 11, np.nan])
    assert (
        "taken as the epoch before it (its fix type agrees as well either way, 0 of 6 "
        "contradicting: the log's order cannot tell, and the counts may be an epoch late)"
    ) in " ".join(log.notes)
    # the first epoch's GSAs, before any sentence with a time, have no epoch before them
    assert "2 sentence(s) (VTG, GSA) whose epoch the log does not hold" in log.notes[-1]


def test_an_rmc_and_gsa_log_gives_the_drive_the_satellites_a_gga_log_does(tmp_path):
    """Through a stream folder: the drive's fixes as RMC and GSA sentences give the labels
    and the satellites of the same fixes as GGA and RMC sentences."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs

    tables, _ = receiver_drive()
    g = tables.gnss
    t = DAY_S + g[c.T_S].to_numpy()
    sats = g[c.N_SATS].to_numpy().astype(int)
    wheels = write_stream_csvs(tables, tmp_path / "w")["wheels"]
    stamps = g[c.T_S].to_numpy()
    plain = nmea_lines(g, t, stamps=stamps)
    only_rmc = nmea_lines(g, t, ("RMC",), stamps=stamps, other=False)
    with_gsa = [x for i, r in enumerate(only_rmc) for x in (r, gsa(range(1, sats[i] + 1)))]
    smap = {k: v for k, v in signal_map().items() if k not in ("lat", "lon", "n_sats")}
    one = receiver_labels([wheels, write_nmea(tmp_path / "g" / "gps.nmea", plain)], smap)
    two = receiver_labels([wheels, write_nmea(tmp_path / "s" / "gps.nmea", with_gsa)], smap)
    pd.testing.assert_frame_equal(one[0], two[0])
    (a,) = [s for s in one[1].streams if s.name == "gps.nmea"]
    (b,) = [s for s in two[1].streams if s.name == "gps.nmea"]
    np.testing.assert_array_equal(b.channels[c.N_SATS], a.channels[c.N_SATS])
    assert np.isfinite(b.channels[c.N_SATS]).all()


def test_gst_states_the_accuracy_of_the_epoch_of_its_time(tmp_path):
    """GST's latitude and longitude errors (m, one sigma) give the epoch of its time h_acc,
    their root sum of squares: 0.6 and 0.8 make 1.0 m, 3 and 4 make 5 m, wherever in the
    log the GST stands. A GST with the errors empty, an epoch without a GST: NaN. A second
    GST of an epoch is passed over, counted; one at a time no fix has makes no epoch. A
    log without GST has no h_acc, nor one whose GSTs state nothing."""
    t0 = DAY_S + 45000.0
    lines = [
        gst(t0 - 1.0, 0.6, 0.8),  # a time no fix has
        gga(t0, 52.4, -1.5, 9),
        rmc(t0, 52.4, -1.5, 1.0, 0.0),
        gst(t0, 0.6, 0.8),
        gst(t0 + 1.0, 3.0, 4.0),  # before its epoch's GGA
        gga(t0 + 1.0, 52.4, -1.5, 9),
        gga(t0 + 2.0, 52.4, -1.5, 9),
        gst(t0 + 2.0, math.nan, math.nan),
        gga(t0 + 3.0, 52.4, -1.5, 9),
        gst(t0, 9.0, 9.0),  # the first epoch's again
        gga(t0 + 4.0, 52.4, -1.5, 9),
        gst(t0 + 4.0, 0.6, -0.8),  # a standard deviation below 0: none stated
    ]
    log = _log(tmp_path, lines)
    np.testing.assert_array_equal(log.tod_s, 45000.0 + np.arange(5))
    np.testing.assert_allclose(
        log.channels["h_acc"], [1.0, 5.0, np.nan, np.nan, np.nan], atol=1e-12
    )
    assert log.channels["h_acc"].dtype == np.float64
    assert log.sources["h_acc"] == "GST lat/lon error"
    said = " ".join(log.notes)
    assert "; 6 GST sentences, 2 stating an epoch's accuracy" in said
    assert "1 sentence(s) of an epoch already given (first at line 10)" in log.dropped
    plain = _log(tmp_path, [x for x in lines if "GST" not in x], "plain.nmea")
    assert "h_acc" not in plain.channels and "h_acc" not in plain.sources
    for key in plain.channels:
        np.testing.assert_array_equal(log.channels[key], plain.channels[key], err_msg=key)
    empty = [gga(t0, 52.4, -1.5, 9), gst(t0, math.nan, math.nan)]
    assert "h_acc" not in _log(tmp_path, empty, "empty.nmea").channels


def test_gst_alone_is_no_fix_and_a_gst_error_that_is_no_number_is_refused(tmp_path):
    t0 = DAY_S + 45000.0
    with pytest.raises(InputError) as err:
        _log(tmp_path, [gst(t0, 0.6, 0.8), gst(t0 + 1.0, 0.6, 0.8)], "alone.nmea")
    assert "expected NMEA 0183 GGA, RMC, GNS or GLL sentences" in str(err.value)
    lines = [gga(t0, 52.4, -1.5, 9), sentence(f"GPGST,{hhmmss(t0)},1.8,,,,O.6,0.8,2.2")]
    with pytest.raises(InputError) as err:
        _log(tmp_path, lines, "bad.nmea")
    said = str(err.value)
    assert "row 2" in said and "GST latitude error" in said and "'O.6'" in said


def test_a_gst_log_gives_the_drive_its_stated_accuracy_and_the_same_labels(tmp_path):
    """Through a stream folder: GGA, RMC and GST, the GST's errors 0.6 and 0.8 times a
    stated accuracy: the GNSS stream's h_acc_m is it (to GST's mm), the drive has the
    column, and the labels are those of the same log without GST, bit for bit."""
    tables, _ = receiver_drive()
    g = tables.gnss
    g = g.assign(**{c.H_ACC_M: 0.5 + 0.01 * (np.arange(len(g)) % 40)})
    t = DAY_S + g[c.T_S].to_numpy()
    wheels = _wheels(tmp_path / "w")
    with_gst = write_nmea(tmp_path / "a" / "gps.nmea", nmea_lines(g, t, ("GGA", "RMC", "GST")))
    plain = write_nmea(tmp_path / "b" / "gps.nmea", nmea_lines(g, t))
    got, streams = receiver_labels([wheels, with_gst])
    want, _ = receiver_labels([wheels, plain])
    pd.testing.assert_frame_equal(got, want)
    np.testing.assert_allclose(streams.gnss.channels[c.H_ACC_M], g[c.H_ACC_M], atol=1e-3)
    assert streams.gnss.sources[c.H_ACC_M] == "GST lat/lon error"
    _, radius = receiver_drive()
    drive = resample(streams, nominal_radius_m=radius).drive.columns
    assert np.isfinite(drive[c.H_ACC_M]).sum() > 1000
