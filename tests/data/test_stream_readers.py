"""MDF4 files (written with asammdf itself) and one CSV per stream, read through a signal map."""

from __future__ import annotations

import gc
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.signalmap import check_signal_map
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.drives import as_ddmm, as_hhmmss
from support.stream_fleet import (
    read_target_drive,
    role_drive,
    stream_params,
    tables_from_drive,
    write_drive,
)

R = 0.31
V = 14.0  # m/s, north


# four wheel-speed columns w0..w3 in rpm, as the NMEA stream tests write them
RPM_WHEELS = {f"omega_{w}": (f"w{k}", "rpm") for k, w in enumerate(("fl", "fr", "rl", "rr"))}


def _spec(**entries: tuple[str, str]) -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(*v) for k, v in entries.items()}


MDF_MAP = _spec(
    omega_fl=("WhlSpd_FL", "km/h"),
    omega_fr=("WhlSpd_FR", "km/h"),
    omega_rl=("WhlSpd_RL", "km/h"),
    omega_rr=("WhlSpd_RR", "km/h"),
    lat=("GPS_Lat", "deg"),
    lon=("GPS_Lon", "deg"),
    n_sats=("GPS_NumSV", "count"),
    yaw_rate=("YawRate", "deg/s cw"),
)


def _write_mdf(
    path,
    yaw_deg_s: float = 3.0,
    yaw_t0_s: float = 0.0,
    yaw_samples: int | None = None,
    nmea_lat: bool = False,
) -> None:
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    # Front and rear wheel speeds in two CAN messages (own time stamps), as many cars send them.
    t_f = np.arange(0.0, 40.0, 0.02) + 0.003
    t_r = np.arange(0.0, 40.0, 0.02) + 0.011
    kmh = V * 3.6
    mdf.append(
        [
            Signal(np.full(t_f.size, kmh), t_f, name=n, unit="km/h")
            for n in ("WhlSpd_FL", "WhlSpd_FR")
        ]
    )
    mdf.append(
        [
            Signal(np.full(t_r.size, kmh), t_r, name=n, unit="km/h")
            for n in ("WhlSpd_RL", "WhlSpd_RR")
        ]
    )
    t_g = np.arange(0.05, 40.0, 0.2)
    lat = 48.1 + V * t_g / 111_200.0
    if nmea_lat:  # NMEA's ddmm.mmmm, the unit left empty, as a receiver's raw field
        lat = 4800.0 + 60.0 * (lat - 48.0)
    mdf.append(
        [
            Signal(lat, t_g, name="GPS_Lat", unit="" if nmea_lat else "deg"),
            Signal(np.full(t_g.size, 11.5), t_g, name="GPS_Lon", unit="°"),
        ]
    )
    t_s = np.arange(0.0, 40.0, 1.0)  # satellites from the receiver's status message, 1 Hz
    mdf.append([Signal(np.full(t_s.size, 11, dtype=np.uint8), t_s, name="GPS_NumSV", unit="")])
    t_y = (np.arange(0.0, 40.0, 0.01) + yaw_t0_s)[:yaw_samples]
    mdf.append([Signal(np.full(t_y.size, yaw_deg_s), t_y, name="YawRate", unit="deg/s")])
    mdf.save(path, overwrite=True)
    mdf.close()


def test_an_mdf4_file_reads_through_its_signal_map(tmp_path):
    path = tmp_path / "log.mf4"
    _write_mdf(path)
    streams = read_mdf4(path, MDF_MAP, R)
    assert len(streams.wheels) == 2  # front and rear messages: two streams
    d = resample(streams, nominal_radius_m=R).drive.columns
    np.testing.assert_allclose(d[c.OMEGA_RL], V / R)
    np.testing.assert_allclose(d[c.OMEGA_FR], V / R)
    np.testing.assert_allclose(d[c.YAW_RATE_RAD_S], -math.radians(3.0))  # clockwise-positive
    np.testing.assert_array_equal(d[c.N_SATS], 11.0)
    np.testing.assert_allclose(d[c.LAT_DEG], 48.1 + V * d[c.T_S] / 111_200.0, atol=1e-12)
    assert d[c.T_S][0] == pytest.approx(0.1) and np.allclose(np.diff(d[c.T_S]), 0.1)


def test_a_yaw_rate_on_another_time_base_is_refused_not_dropped(tmp_path):
    """The YawRate group stamped in UNIX time, the others from the measurement's start."""
    path = tmp_path / "log.mf4"
    _write_mdf(path, yaw_t0_s=1.7e9)
    with pytest.raises(InputError) as err:
        resample(read_mdf4(path, MDF_MAP, R, display="log.mf4"), nominal_radius_m=R)
    (p,) = err.value.problems
    assert (p.file, p.column) == ("log.mf4 [channel group 4]", "master time")
    assert "one clock" in p.expected and "no common stretch" in p.found
    assert "log.mf4 [channel group 4] 1.7e+09-1.7e+09 s" in p.found


def test_a_yaw_rate_with_one_sample_is_refused_by_its_name(tmp_path):
    path = tmp_path / "log.mf4"
    _write_mdf(path, yaw_samples=1)
    with pytest.raises(InputError) as err:
        resample(read_mdf4(path, MDF_MAP, R, display="log.mf4"), nominal_radius_m=R)
    (p,) = err.value.problems
    assert (p.file, p.column) == ("log.mf4 [channel group 4]", "YawRate")
    assert p.expected == "at least two samples" and p.found == "1 sample(s)"


def test_a_signal_in_two_groups_is_refused(tmp_path):
    from asammdf import MDF, Signal

    path = tmp_path / "twice.mf4"
    _write_mdf(path)
    mdf = MDF(path)
    t = np.arange(0.0, 1.0, 0.1)
    mdf.append([Signal(t, t, name="WhlSpd_FL", unit="km/h")])
    mdf.save(path, overwrite=True)
    mdf.close()
    with pytest.raises(InputError) as err:
        read_mdf4(path, MDF_MAP, R, display="twice.mf4")
    (p,) = err.value.problems
    assert (p.file, p.column) == ("twice.mf4", "WhlSpd_FL") and "channel groups" in p.found


def test_a_file_that_is_not_mdf_is_refused_with_the_decoder_s_error(tmp_path):
    path = tmp_path / "log.mf4"
    path.write_bytes(b"not an MDF file at all" * 10)
    with pytest.raises(InputError) as err:
        read_mdf4(path, MDF_MAP, R, display="log.mf4")
    (p,) = err.value.problems
    assert p.file == "log.mf4" and p.expected.startswith("an ASAM MDF file")
    assert p.found.split(":")[0].isidentifier() and "export the log as MDF4" in p.fix
    assert err.value.summary == "cannot decode log.mf4"


def test_a_truncated_mdf4_file_is_refused_with_nothing_but_the_report(tmp_path, monkeypatch):
    # asammdf gives up half way through a cut-off log and leaves a half-built reader whose
    # destructor fails: Python would print that as "Exception ignored ... Traceback" after
    # the report. Every unraisable error is recorded here; none may reach the user.
    whole = tmp_path / "whole.mf4"
    _write_mdf(whole)
    path = tmp_path / "cut.mf4"
    path.write_bytes(whole.read_bytes()[: whole.stat().st_size // 3])
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    with pytest.raises(InputError) as err:
        read_mdf4(path, MDF_MAP, R, display="cut.mf4")
    gc.collect()
    (p,) = err.value.problems
    assert p.file == "cut.mf4" and p.expected.startswith("an ASAM MDF file")
    assert unraisable == []
    assert sys.unraisablehook == unraisable.append  # the user's hook is back


def test_signal_maps_are_checked_before_reading():
    with pytest.raises(ConfigError) as err:
        check_signal_map("log", _spec(omega_fl=("a", "furlong/s"), lat=("b", "deg")))
    text = str(err.value)
    assert "omega_fl.unit" in text and "data.signal_maps.log.signals.lon: missing" in text
    with pytest.raises(ConfigError, match="t: missing"):
        check_signal_map("log", MDF_MAP, with_time=True)


def test_one_csv_per_stream_reads_through_its_signal_map(tmp_path):
    t_w = np.arange(0.0, 30.0, 0.0125) + 5000.0
    t_g = np.arange(0.0, 30.0, 1.0) + 5000.3  # a 1 Hz receiver
    t_i = np.arange(0.0, 30.0, 0.01) + 5000.0
    pd.DataFrame(
        {
            "Time [ms]": t_w * 1000.0,
            "Wheel Speed FL (rpm)": V / R * 60 / (2 * math.pi),
            "Wheel Speed FR (rpm)": V / R * 60 / (2 * math.pi),
            "wheel_speed_rl": V / R * 60 / (2 * math.pi),
            "WHEEL SPEED RR": V / R * 60 / (2 * math.pi),
            "Brake": 0,
        }
    ).to_csv(tmp_path / "can.csv", index=False)
    pd.DataFrame(
        {"time": t_g * 1000.0, "lat": -33.9 + V * (t_g - 5000.0) / 110_900.0, "lon": 151.2}
    ).to_csv(tmp_path / "gps.csv", index=False)
    pd.DataFrame({"TIME": t_i * 1000.0, "gyro_z": 0.05}).to_csv(tmp_path / "imu.csv", index=False)
    smap = _spec(
        t=("Time", "ms"),
        omega_fl=("WheelSpeedFL", "rpm"),
        omega_fr=("WheelSpeedFR", "rpm"),
        omega_rl=("WheelSpeedRL", "rpm"),
        omega_rr=("WheelSpeedRR", "rpm"),
        lat=("Lat", "deg"),
        lon=("Lon", "deg"),
        yaw_rate=("gyro_z", "rad/s"),
    )
    files = sorted(tmp_path.glob("*.csv"))
    streams = read_stream_csvs(files, smap, R)
    assert [s.name for s in streams.streams] == ["can.csv", "gps.csv", "imu.csv"]
    d = resample(streams, max_fix_gap_s=1.5).drive.columns
    np.testing.assert_allclose(d[c.OMEGA_FL], V / R)
    np.testing.assert_allclose(d[c.YAW_RATE_RAD_S], 0.05)
    assert d[c.T_S][0] == pytest.approx(5000.3) and d[c.T_S][-1] == pytest.approx(5029.3)
    np.testing.assert_allclose(d[c.LAT_DEG], -33.9 + V * (d[c.T_S] - 5000.0) / 110_900.0)


@pytest.mark.parametrize("period", [86400.0, 604800.0])
@pytest.mark.parametrize(("gnss_hz", "before_s"), [(10.0, 60.0), (1.0, 1.0)])
def test_stream_csvs_across_midnight_give_the_labels_of_the_drive_by_day(
    tmp_path, gnss_hz, before_s, period
):
    """Each file's time of day continues past midnight, as the 10 Hz file's does: the same
    drive starting ``before_s`` before midnight gives the seconds and labels it gives by day
    (within 1e-6 m: only the clock's floating-point rounding differs). With a 1 Hz receiver
    whose first fix comes 1.5 s in, 1 s before midnight, the fixes' file starts past
    midnight, after the wheels' file. A GPS time of week across the week's end likewise."""
    from rwhonet.sim.streams import (
        StreamTables,
        signal_map,
        write_stream_csvs,
    )
    from support.multirate import START_S, per_second, simulated_streams

    tables, radius = simulated_streams(120.0, 100.0, gnss_hz)
    late = tables.gnss[tables.gnss[c.T_S] >= START_S + 1.5] if before_s < 1.5 else tables.gnss
    tables = StreamTables(tables.wheels, late.reset_index(drop=True))
    shift = period - before_s - START_S  # whole seconds: the same seconds

    def read(t: StreamTables, folder):
        files = write_stream_csvs(t, folder)
        streams = read_stream_csvs(list(files.values()), signal_map(), radius)
        return per_second(resample(streams, nominal_radius_m=radius).drive.columns, radius), streams

    day, _ = read(tables, tmp_path / "day")
    night_tables = StreamTables(
        *(d.assign(t_s=(d[c.T_S] + shift) % period) for d in (tables.wheels, tables.gnss))
    )
    night, streams = read(night_tables, tmp_path / "night")
    said = " ".join(streams.notes)
    end = "midnight" if period == 86400.0 else "the GPS week's end"
    assert ("passed midnight" if period == 86400.0 else "passed the week's end") in said
    assert (f"starts past {end}" in said) == (before_s < 1.5)
    assert len(night) == len(day) > 90
    np.testing.assert_allclose(night["t_s"], day["t_s"] + shift, rtol=0, atol=1e-3)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(night[q], day[q], rtol=0, atol=1e-6)


def test_nmea_fields_in_stream_csvs_and_an_mdf4_signal_read_as_degrees_and_seconds(tmp_path):
    """A receiver's file with NMEA's ddmm.mmmm coordinates (south and west as a minus sign)
    and every file's time of day as hhmmss.ss: the same drive as in degrees and seconds.
    A minute of 60 or more is refused naming the file, its row and column; an MDF4 signal
    in ddmm.mmmm reads as degrees, and one whose own unit is degrees is held to it."""
    t_w = np.arange(0.0, 30.0, 0.0125) + 9 * 3600.0 + 59 * 60.0 + 45.0  # 09:59:45 on
    t_g = np.arange(0.0, 30.0, 1.0) + t_w[0] + 0.3
    omega = V / R * 60 / (2 * math.pi)
    lat = -33.9 - V * (t_g - t_w[0]) / 110_900.0
    wheels = {f"w{k}": omega for k in range(4)}

    def write(folder, packed: bool):
        folder.mkdir()
        time = (lambda t: as_hhmmss(t, decimals=4)) if packed else (lambda t: t)
        angle = as_ddmm if packed else (lambda a: a)
        pd.DataFrame({"Time": time(t_w), **wheels}).to_csv(folder / "can.csv", index=False)
        gps = {"Time": time(t_g), "lat": angle(lat), "lon": angle(np.full(t_g.size, -58.4))}
        pd.DataFrame(gps).to_csv(folder / "gps.csv", index=False)
        return sorted(folder.glob("*.csv"))

    plain = _spec(t=("Time", "s"), lat=("lat", "deg"), lon=("lon", "deg"), **RPM_WHEELS)
    nmea = _spec(t=("Time", "hhmmss"), lat=("lat", "ddmm"), lon=("lon", "ddmm"), **RPM_WHEELS)
    want = resample(read_stream_csvs(write(tmp_path / "s", False), plain, R)).drive.columns
    got = resample(read_stream_csvs(write(tmp_path / "p", True), nmea, R)).drive.columns
    for name in (c.T_S, c.LAT_DEG, c.LON_DEG, c.OMEGA_RL):
        np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-6)
    gps = pd.read_csv(tmp_path / "p" / "gps.csv")
    gps.loc[4, "lat"] = -3375.0
    gps.to_csv(tmp_path / "p" / "gps.csv", index=False)
    with pytest.raises(InputError) as err:
        read_stream_csvs(sorted((tmp_path / "p").glob("*.csv")), nmea, R)
    (problem,) = err.value.problems
    assert problem.file.endswith("gps.csv") and (problem.row, problem.column) == (5, "lat")
    assert problem.found == "-3375.0"

    path = tmp_path / "log.mf4"
    _write_mdf(path, nmea_lat=True)
    smap = MDF_MAP | _spec(lat=("GPS_Lat", "ddmm"))
    d = resample(read_mdf4(path, smap, R), max_fix_gap_s=1.5).drive.columns
    np.testing.assert_allclose(d[c.LAT_DEG], 48.1 + V * d[c.T_S] / 111_200.0, atol=1e-9)
    with pytest.raises(InputError, match="the file says '°'"):
        read_mdf4(path, MDF_MAP | _spec(lon=("GPS_Lon", "ddmm")), R)


def test_a_date_in_every_stream_file_and_hemisphere_letters_beside_their_coordinates(tmp_path):
    """A receiver's file as a split RMC sentence (date ddmmyy, time hhmmss.ss, unsigned
    ddmm.mmmm with S and W letters) and a CAN file with the same date and time columns,
    through midnight: the drive read from seconds since 1970 in degrees. A file without
    the date column, and letters in another file than their coordinate, are refused."""
    from datetime import UTC, datetime

    day_s = datetime(2019, 3, 11, tzinfo=UTC).timestamp()
    t_w = np.arange(0.0, 30.0, 0.0125) + 86400.0 - 15.0  # 23:59:45 on
    t_g = np.arange(0.0, 30.0, 1.0) + t_w[0] + 0.3
    omega = V / R * 60 / (2 * math.pi)
    lat = -33.9 - V * (t_g - t_w[0]) / 110_900.0
    wheels = {f"w{k}": omega for k in range(4)}

    def rmc(t: np.ndarray) -> dict:
        day = np.where(t >= 86400.0, "120319", "110319")
        return {"Date": day, "UTC": as_hhmmss(t, decimals=4)}

    folder = tmp_path / "nmea"
    folder.mkdir()
    pd.DataFrame({**rmc(t_w), **wheels}).to_csv(folder / "can.csv", index=False)
    gps = {
        **rmc(t_g),
        "lat": as_ddmm(np.abs(lat)),
        "NS": "S",
        "lon": 5824.0,  # 58 deg 24 min
        "EW": "W",
    }
    pd.DataFrame(gps).to_csv(folder / "gps.csv", index=False)
    nmea = _spec(
        date=("Date", "ddmmyy"),
        t=("UTC", "hhmmss"),
        lat=("lat", "ddmm"),
        lat_hemisphere=("NS", "N/S"),
        lon=("lon", "ddmm"),
        lon_hemisphere=("EW", "E/W"),
        **RPM_WHEELS,
    )
    streams = read_stream_csvs(sorted(folder.glob("*.csv")), nmea, R)
    assert any("dates of column 'Date'" in note for note in streams.notes)
    got = resample(streams).drive.columns
    plain = tmp_path / "plain"
    plain.mkdir()
    pd.DataFrame({"t": day_s + t_w, **wheels}).to_csv(plain / "can.csv", index=False)
    pd.DataFrame({"t": day_s + t_g, "lat": lat, "lon": -58.4}).to_csv(
        plain / "gps.csv", index=False
    )
    smap = _spec(t=("t", "s"), lat=("lat", "deg"), lon=("lon", "deg"), **RPM_WHEELS)
    want = resample(read_stream_csvs(sorted(plain.glob("*.csv")), smap, R)).drive.columns
    for name in (c.T_S, c.LAT_DEG, c.LON_DEG, c.OMEGA_RL):
        np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-6)
    pd.DataFrame({"UTC": rmc(t_w)["UTC"], **wheels, "EW": "W"}).to_csv(
        folder / "can.csv", index=False
    )
    gps.pop("EW")
    pd.DataFrame(gps).to_csv(folder / "gps.csv", index=False)
    with pytest.raises(InputError) as err:
        read_stream_csvs(sorted(folder.glob("*.csv")), nmea, R)
    said = {(Path(p.file).name, p.column, p.expected.split(" (")[0]) for p in err.value.problems}
    assert ("can.csv", "Date", "the date column 'Date'") in said
    assert ("can.csv", "EW", "the hemisphere letters") in said
    with pytest.raises(ConfigError, match="stream CSVs only"):
        check_signal_map("log", MDF_MAP | _spec(date=("Date", "ddmmyy")))


def test_time_going_back_in_a_stream_csv_outside_midnight_is_still_refused(tmp_path):
    t = np.arange(0.0, 20.0, 0.01) + 86000.0  # in the day's last hour, but no midnight
    t[500:] -= 30.0
    omega = np.full(t.size, V / R)
    pd.DataFrame({"Time": t, **{f"w{k}": omega for k in range(4)}}).to_csv(
        tmp_path / "can.csv", index=False
    )
    tg = np.arange(0.0, 20.0, 0.1) + 86000.0
    pd.DataFrame({"Time": tg, "lat": 52.0 + V * (tg - 86000.0) / 111_000.0, "lon": -1.5}).to_csv(
        tmp_path / "gps.csv", index=False
    )
    smap = _spec(
        t=("Time", "s"),
        omega_fl=("w0", "rad/s"),
        omega_fr=("w1", "rad/s"),
        omega_rl=("w2", "rad/s"),
        omega_rr=("w3", "rad/s"),
        lat=("lat", "deg"),
        lon=("lon", "deg"),
    )
    streams = read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, R)
    with pytest.raises(InputError, match="strictly increasing"):
        resample(streams, nominal_radius_m=R)


def test_a_wide_csv_of_several_messages_reads_as_one_stream_per_message(tmp_path):
    """Wheel speeds at 50 Hz and the yaw rate at 100 Hz in one file, each row one
    message's samples and the other cells blank: read as two streams, the drive the two
    files give. A column blank throughout is refused, named."""
    t_w = np.arange(0.0, 30.0, 0.02) + 5000.0
    t_y = np.arange(0.0, 30.0, 0.01) + 5000.003
    wheels = pd.DataFrame({"Time": t_w, **{f"W{k}": V / R for k in ("FL", "FR", "RL", "RR")}})
    yaw = pd.DataFrame({"Time": t_y, "Yaw": 0.05 + 0.01 * np.sin(t_y)})
    t_g = np.arange(0.0, 30.0, 0.1) + 5000.05
    gps = pd.DataFrame({"Time": t_g, "Lat": 48.1 + V * (t_g - 5000.0) / 111_200.0, "Lon": 11.5})
    smap = _spec(
        t=("Time", "s"),
        **{f"omega_{k.lower()}": (f"W{k}", "rad/s") for k in ("FL", "FR", "RL", "RR")},
        lat=("Lat", "deg"),
        lon=("Lon", "deg"),
        yaw_rate=("Yaw", "rad/s"),
    )
    apart, wide = tmp_path / "apart", tmp_path / "wide"
    for folder in (apart, wide):
        folder.mkdir()
        gps.to_csv(folder / "gps.csv", index=False)
    wheels.to_csv(apart / "can.csv", index=False)
    yaw.to_csv(apart / "imu.csv", index=False)
    pd.concat([wheels, yaw]).sort_values("Time").to_csv(wide / "can.csv", index=False)
    d = {
        f.name: resample(read_stream_csvs(sorted(f.glob("*.csv")), smap, R)) for f in (apart, wide)
    }
    for name in (*c.WHEELS, c.YAW_RATE_RAD_S, c.LAT_DEG):
        np.testing.assert_allclose(d["wide"].drive.columns[name], d["apart"].drive.columns[name])
    assert any("several messages in one file" in n for n in d["wide"].drive.notes)
    blank = wheels.assign(WFL=np.nan)
    blank.to_csv(wide / "can.csv", index=False)
    with pytest.raises(InputError) as err:
        no_yaw = {k: v for k, v in smap.items() if k != "yaw_rate"}
        resample(read_stream_csvs([wide / "can.csv", wide / "gps.csv"], no_yaw, R))
    (p,) = err.value.problems
    assert p.column == "WFL" and "'WFL' in 1500" in p.found and "one file per message" in p.fix


def test_both_coordinates_bad_letters_are_named_in_one_report(tmp_path):
    """A stream file whose latitude and longitude letters are both wrong (a minus sign
    beside S, an 'X' for E/W): one report names both rows, as the 10 Hz readers do."""
    t_w = np.arange(0.0, 30.0, 0.0125)
    t_g = np.arange(0.0, 30.0, 1.0) + 0.3
    folder = tmp_path / "nmea"
    folder.mkdir()
    omega = V / R * 60 / (2 * math.pi)
    pd.DataFrame({"t": t_w, **{f"w{k}": omega for k in range(4)}}).to_csv(
        folder / "can.csv", index=False
    )
    lat = np.full(t_g.size, 3354.0)
    lat[4] = -3354.0  # a sign beside its letter
    ew = np.full(t_g.size, "W")
    ew[7] = "X"
    gps = {"t": t_g, "lat": lat, "NS": "S", "lon": 5824.0, "EW": ew}
    pd.DataFrame(gps).to_csv(folder / "gps.csv", index=False)
    spec = _spec(
        t=("t", "s"),
        lat=("lat", "ddmm"),
        lat_hemisphere=("NS", "N/S"),
        lon=("lon", "ddmm"),
        lon_hemisphere=("EW", "E/W"),
        **RPM_WHEELS,
    )
    with pytest.raises(InputError) as err:
        read_stream_csvs(sorted(folder.glob("*.csv")), spec, R)
    rows = {(p.column, p.row) for p in err.value.problems}
    assert ("lat", 5) in rows or ("NS", 5) in rows, rows
    assert ("EW", 8) in rows, rows


def test_a_loggers_other_files_in_a_stream_folder_are_left_out(tmp_path):
    """macOS's ._wheels.csv (binary metadata beside each file on a logger's FAT card) and
    a CSV of the logger's own (an event list: no time column, nothing the map names) are
    left out with a note; the drive reads as without them. A CSV the map names a column of
    but without the time column is still refused."""

    tables = tables_from_drive(role_drive("target_test", 60.0))
    plain = write_drive("stream_csv", tables, tmp_path / "plain", "C-B1", 0.3)
    other = write_drive("stream_csv", tables, tmp_path / "other", "C-B1", 0.3)
    (other / "._wheels.csv").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X        ")
    (other / "events.csv").write_text("Event,Note\nstart,logger v2.1\nstop,card full\n")
    params = stream_params(tmp_path, "stream_csv")
    want, got = read_target_drive(params, plain), read_target_drive(params, other)
    for name in want.raw.columns:
        np.testing.assert_array_equal(got.raw.columns[name], want.raw.columns[name])
    said = " ".join(got.raw.notes)
    assert "hidden files left out (none of the drive's streams): ._wheels.csv" in said
    assert "events.csv: neither the time column" in said and "left out" in said
    (other / "events.csv").write_text("Event,NumSV\nstart,9\n")  # a mapped column, no time
    with pytest.raises(InputError) as err:
        read_target_drive(params, other)
    assert any(p.file.endswith("events.csv") for p in err.value.problems)
