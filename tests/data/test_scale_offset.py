"""A channel logged as raw numbers, read through a map's ``scale`` and ``offset``.

A CAN signal's raw value in a CSV export, ``ublox_msgs``' latitude in 1e-7 deg, a speed in
mm/s, a timer's ticks: a column or signal map gives ``scale`` and ``offset`` (a DBC's
factor and offset), and every reader of a map reads ``raw * scale + offset`` in the map's
unit (:func:`rwhonet.data.columnmap.scaled`). Each reader is checked against the same
drive written with those values themselves: the same channels bit for bit (ingest's
column-map reader, predict's, stream CSVs with a receiver's stamped NMEA log, MDF4, a ROS
bag of a u-blox receiver's NAV-PVT messages). A scale is refused where no number is
scaled (a time written as text, a packed unit, a pulse counter, letters), and where it
is 0 or not finite.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from rwhonet import paths
from rwhonet.config import ColumnSpec, ConfigError, parse_value
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import KEYS, check_column_map, read_columnmap
from rwhonet.data.incremental import read_rows
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.signalmap import check_signal_map
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from support.drives import TARGET_RADIUS_M, build_params, column_map_params, straight_drive
from support.multirate import receiver_drive, receiver_labels
from support.nmea import nmea_lines, write_nmea

R = TARGET_RADIUS_M
DAY_S = 1_552_262_400.0  # 2019-03-11 00:00 UTC
TICK_S = 1e-5  # a logger's timer of 10 us ticks

# key -> (column, unit, scale, offset): how an export of raw CAN values writes them
RAW = {
    "t": ("Time", "s", TICK_S, 0.0),
    "lat": ("Lat", "deg", 1e-7, 0.0),
    "lon": ("Lon", "deg", 1e-7, 0.0),
    **{f"omega_{w}": (f"WhlSpd_{w.upper()}", "km/h", 0.01, 0.0) for w in ("fl", "fr", "rl", "rr")},
    "n_sats": ("NumSV", "count", 1.0, 0.0),
    # a yaw rate's 16-bit raw value, 0.01 deg/s a bit, offset -327.68 deg/s (ESC signals so)
    "yaw_rate": ("YawRate", "deg/s", 0.01, -327.68),
}
CANONICAL = {k: KEYS[k][0] for k in RAW}  # the canonical column each key is read into


def _raw_numbers(key: str, si: np.ndarray) -> np.ndarray:
    """SI values as the logger's integers for ``RAW[key]``."""
    _, unit, scale, offset = RAW[key]
    in_unit = {
        "km/h": si * R * 3.6,
        "deg/s": np.degrees(si),
    }.get(unit, si)
    return np.round((in_unit - offset) / scale).astype(np.int64)


def _maps() -> tuple[dict[str, ColumnSpec], dict[str, ColumnSpec]]:
    """The raw file's map (scales and offsets) and the map of the same values written."""
    raw = {k: ColumnSpec(col, unit, scale, offset) for k, (col, unit, scale, offset) in RAW.items()}
    values = {k: ColumnSpec(col, unit) for k, (col, unit, _, _) in RAW.items()}
    return raw, values


def _drive_files(folder: Path) -> tuple[Path, Path]:
    """A 60 s drive turning gently, as raw integers and as the values they stand for."""
    df = straight_drive(60.0, radius_m=R, lat0_deg=-33.87, lon0_deg=151.2)
    t = df[c.T_S].to_numpy()
    df[c.YAW_RATE_RAD_S] = 0.05 * np.sin(2 * np.pi * t / 20.0)
    raw = pd.DataFrame(
        {col: _raw_numbers(k, df[CANONICAL[k]].to_numpy()) for k, (col, *_) in RAW.items()}
    )
    values = pd.DataFrame(
        {col: raw[col].to_numpy() * scale + offset for col, _, scale, offset in RAW.values()}
    )
    folder.mkdir(parents=True, exist_ok=True)
    raw.to_csv(folder / "raw.csv", index=False)
    values.to_csv(folder / "values.csv", index=False)  # shortest round-trip decimals
    return folder / "raw.csv", folder / "values.csv"


def test_a_column_map_reads_raw_numbers_as_their_values(tmp_path):
    """Ingest's column-map reader: the raw file gives the values file's channels bit for bit
    (time ticks, 1e-7 deg, 0.01 km/h wheels, a yaw rate's offset), and they are the drive's
    within the raw numbers' resolution."""
    raw_csv, values_csv = _drive_files(tmp_path)
    raw_map, values_map = _maps()
    got = read_columnmap(raw_csv, raw_map, "raw", radius_m=R).columns
    want = read_columnmap(values_csv, values_map, "values", radius_m=R).columns
    assert set(got) == set(want) == set(CANONICAL.values())
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    df = straight_drive(60.0, radius_m=R, lat0_deg=-33.87, lon0_deg=151.2)
    np.testing.assert_allclose(got[c.T_S], df[c.T_S], rtol=0, atol=TICK_S)
    np.testing.assert_allclose(got[c.LAT_DEG], df[c.LAT_DEG], rtol=0, atol=1e-7)
    np.testing.assert_allclose(got[c.LON_DEG], df[c.LON_DEG], rtol=0, atol=1e-7)
    np.testing.assert_allclose(got[c.OMEGA_FL], df[c.OMEGA_FL], rtol=0, atol=0.01 / 3.6 / R)
    yaw = 0.05 * np.sin(2 * np.pi * df[c.T_S].to_numpy() / 20.0)
    np.testing.assert_allclose(got[c.YAW_RATE_RAD_S], yaw, rtol=0, atol=math.radians(0.005))


def _predict_rows(path: Path, fmt: str, column_map) -> dict[str, np.ndarray]:
    layout, blocks = read_rows(
        io.BytesIO(path.read_bytes()), path.name, fmt, column_map, block_bytes=4096, radius_m=R
    )
    parts = [block for _, block in blocks]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def test_predict_reads_raw_numbers_as_ingest_does(tmp_path):
    """``rwhonet predict``'s reader (the file in blocks): the raw file's channels are the
    values file's bit for bit, and its wheels, fixes and yaw rate ingest's."""
    raw_csv, values_csv = _drive_files(tmp_path)
    raw_map, values_map = _maps()
    got = _predict_rows(raw_csv, "raw", raw_map)
    want = _predict_rows(values_csv, "values", values_map)
    assert set(got) == set(want) and c.YAW_RATE_RAD_S in got
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    ingest = read_columnmap(raw_csv, raw_map, "raw", radius_m=R).columns
    for name in (c.LAT_DEG, c.LON_DEG, *c.WHEELS, c.YAW_RATE_RAD_S):
        np.testing.assert_array_equal(got[name], ingest[name], err_msg=name)


def _stream_folders(tmp_path: Path) -> tuple[list[Path], list[Path], dict, dict]:
    """The receiver drive's wheels (100 Hz) as a stream CSV on a timer of 10 us ticks, its
    fixes in an NMEA log whose lines follow the logger's stamps in the same ticks: raw
    (wheel speeds in 0.001 rad/s, offset -0.5 rad/s) and as the values they stand for."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    t0 = float(tables.wheels[c.T_S].iloc[0])
    ticks = np.round((tables.wheels[c.T_S].to_numpy() - t0) / TICK_S).astype(np.int64)
    g = tables.gnss
    stamps = np.round((g[c.T_S].to_numpy() - t0) / TICK_S).astype(np.int64)
    utc = DAY_S + g[c.T_S].to_numpy()
    wheel_cols = {f"omega_{w}": f"WheelSpeed_{w.upper()}" for w in ("fl", "fr", "rl", "rr")}
    canonical = dict(zip(wheel_cols.values(), c.WHEELS, strict=True))
    raw_w = {
        col: np.round((tables.wheels[name].to_numpy() + 0.5) / 0.001).astype(np.int64)
        for col, name in canonical.items()
    }
    out = []
    for kind in ("raw", "values"):
        folder = tmp_path / kind
        files = write_stream_csvs(StreamTables(tables.wheels, g.iloc[:0]), folder)
        if kind == "raw":
            frame = pd.DataFrame({"Time": ticks} | raw_w)
            lines = nmea_lines(g, utc, stamps=stamps, stamp_format="{:d},")
        else:
            frame = pd.DataFrame(
                {"Time": ticks * TICK_S} | {k: v * 0.001 - 0.5 for k, v in raw_w.items()}
            )
            lines = nmea_lines(g, utc, stamps=stamps * TICK_S, stamp_format="{},")
        frame.to_csv(files["wheels"], index=False)
        for name, path in files.items():
            if name != "wheels":
                path.unlink()
        out.append([files["wheels"], write_nmea(folder / "gps.nmea", lines)])
    raw_map = {"t": ColumnSpec("Time", "s", TICK_S)} | {
        k: ColumnSpec(col, "rad/s", 0.001, -0.5) for k, col in wheel_cols.items()
    }
    values_map = {"t": ColumnSpec("Time", "s")} | {
        k: ColumnSpec(col, "rad/s") for k, col in wheel_cols.items()
    }
    return out[0], out[1], raw_map, values_map


def test_stream_csvs_and_a_stamped_nmea_log_read_raw_numbers_as_their_values(tmp_path):
    """Stream CSVs on a timer's ticks, wheel speeds raw with an offset, and the receiver's
    NMEA sentences after the logger's stamps in the same ticks (the map's ``t`` scale
    applies to them too): the streams, the 10 Hz grid and the labels are the values
    folder's bit for bit."""
    raw_files, value_files, raw_map, values_map = _stream_folders(tmp_path)
    _, radius = receiver_drive()
    got = read_stream_csvs(raw_files, raw_map, radius)
    want = read_stream_csvs(value_files, values_map, radius)
    for a, b in zip(got.streams, want.streams, strict=True):
        for name in b.channels:
            np.testing.assert_array_equal(a.channels[name], b.channels[name], err_msg=name)
        np.testing.assert_array_equal(a.t_s, b.t_s)
    assert any("logger stamp is its time" in n for n in got.notes)
    grid_a = resample(got, nominal_radius_m=radius).drive.columns
    grid_b = resample(want, nominal_radius_m=radius).drive.columns
    for name in grid_b:
        np.testing.assert_array_equal(grid_a[name], grid_b[name], err_msg=name)
    labels, _ = receiver_labels(raw_files, raw_map)
    ref, _ = receiver_labels(value_files, values_map)
    assert len(labels) > 100
    pd.testing.assert_frame_equal(labels, ref)


def _write_mdf(path: Path, raw: bool) -> None:
    """Wheel speeds (100 Hz) and fixes (10 Hz) of a straight drive, as raw integers of
    0.01 km/h and 1e-7 deg, or as those values."""
    from asammdf import MDF, Signal

    df = straight_drive(40.0, radius_m=R)
    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    t_w = np.arange(0.0, 40.0, 0.01) + 0.003
    kmh = np.round(np.interp(t_w, t, df[c.OMEGA_FL]) * R * 3.6 / 0.01).astype(np.int32)
    lat = np.round(df[c.LAT_DEG].to_numpy() * 1e7).astype(np.int32)
    lon = np.round(df[c.LON_DEG].to_numpy() * 1e7).astype(np.int32)
    mdf = MDF(version="4.10")
    wheel = kmh if raw else kmh * 0.01
    mdf.append([Signal(wheel, t_w, name=f"WhlSpd_{w}") for w in ("FL", "FR", "RL", "RR")])
    fix_lat, fix_lon = (lat, lon) if raw else (lat * 1e-7, lon * 1e-7)
    mdf.append([Signal(fix_lat, t, name="GPS_Lat"), Signal(fix_lon, t, name="GPS_Lon")])
    mdf.save(path, overwrite=True)


def test_an_mdf4_file_s_raw_integers_read_as_their_values(tmp_path):
    """An MDF4 file whose channels are stored raw (int32, no conversion of their own): with
    the map's scales, the streams and the 10 Hz grid of the file of the values themselves."""
    _write_mdf(tmp_path / "raw.mf4", raw=True)
    _write_mdf(tmp_path / "values.mf4", raw=False)
    wheels = {f"omega_{w}": f"WhlSpd_{w.upper()}" for w in ("fl", "fr", "rl", "rr")}
    raw_map = {k: ColumnSpec(col, "km/h", 0.01) for k, col in wheels.items()} | {
        "lat": ColumnSpec("GPS_Lat", "deg", 1e-7),
        "lon": ColumnSpec("GPS_Lon", "deg", 1e-7),
    }
    values_map = {k: ColumnSpec(s.column, s.unit) for k, s in raw_map.items()}
    got = read_mdf4(tmp_path / "raw.mf4", raw_map, R)
    want = read_mdf4(tmp_path / "values.mf4", values_map, R)
    grid_a = resample(got, nominal_radius_m=R).drive.columns
    grid_b = resample(want, nominal_radius_m=R).drive.columns
    assert len(grid_b[c.T_S]) > 390
    for name in grid_b:
        np.testing.assert_array_equal(grid_a[name], grid_b[name], err_msg=name)
    df = straight_drive(40.0, radius_m=R)
    assert np.nanmax(np.abs(grid_a[c.OMEGA_RL] - df[c.OMEGA_RL].iloc[0])) < 0.01 / 3.6 / R


# ublox_msgs/NavPVT's fields the map reads, with their types, in the message's order (the
# message has more: a subset, as a bag's own definition of it would read)
NAV_PVT = "ublox_msgs/msg/NavPVT"
NAV_PVT_DEF = (
    "uint32 iTOW\nuint8 fixType\nuint8 flags\nuint8 numSV\n"
    "int32 lon\nint32 lat\nint32 height\nint32 gSpeed\nint32 heading\n"
)


def test_a_bag_s_ublox_nav_pvt_integers_read_as_a_navsatfix_s_degrees(tmp_path):
    """A ROS bag of a u-blox driver's NAV-PVT messages (latitude and longitude int32 in
    1e-7 deg, ground speed in mm/s, no header: the bag's record times): with the map's
    scales, the 10 Hz grid of a NavSatFix of the same degrees bit for bit, and the
    ground speed in m/s; its messages without a fix (fixType 0: latitude and longitude 0)
    are no fixes, as the NavSatFix's whose status says so."""
    from rwhonet.sim.streams import StreamTables
    from support.rosbag import bag_map, tables_bag, typestore

    tables, radius = receiver_drive()
    g = tables.gnss
    lat = np.round(g[c.LAT_DEG].to_numpy() * 1e7).astype(np.int32)
    lon = np.round(g[c.LON_DEG].to_numpy() * 1e7).astype(np.int32)
    as_fix = g.assign(**{c.LAT_DEG: lat * 1e-7, c.LON_DEG: lon * 1e-7})
    lost = np.zeros(lat.size, dtype=bool)
    lost[300:320] = True  # 2 s without a fix: NAV-PVT's fixType 0 at (0, 0), 0 satellites
    status = np.where(lost, -1, 0)  # the NavSatFix's: STATUS_NO_FIX
    navsatfix = tables_bag(tmp_path / "fix.bag", StreamTables(tables.wheels, as_fix), status=status)
    lat[lost], lon[lost] = 0, 0
    sats = np.where(lost, 0, 12)
    fix_type = np.where(lost, 0, 3)

    from rosbags.typesys import get_types_from_msg

    ts = typestore()
    ts.register(get_types_from_msg(NAV_PVT_DEF, NAV_PVT))
    cls = ts.types[NAV_PVT]
    t_ns = np.round(g[c.T_S].to_numpy() * 1e9).astype(np.int64)
    messages = [
        (
            int(t_ns[i]),
            cls(0, int(fix_type[i]), 1, int(sats[i]), int(lon[i]), int(lat[i]), 0, 15_000, 0),
        )
        for i in range(lat.size)
    ]
    pvt = tables_bag(
        tmp_path / "pvt.bag",
        StreamTables(tables.wheels, g.iloc[:0]),
        extra=[("/ublox/navpvt", NAV_PVT, messages)],
        msgdefs={NAV_PVT: NAV_PVT_DEF},
    )
    pvt_map = {k: s for k, s in bag_map().items() if k not in ("lat", "lon")} | {
        "lat": ColumnSpec("/ublox/navpvt.lat", "deg", 1e-7),
        "lon": ColumnSpec("/ublox/navpvt.lon", "deg", 1e-7),
        "n_sats": ColumnSpec("/ublox/navpvt.numSV", "count"),
        "speed_gnss": ColumnSpec("/ublox/navpvt.gSpeed", "m/s", 0.001),
    }
    got = read_mdf4(pvt, pvt_map, radius)
    want = read_mdf4(navsatfix, bag_map(), radius)
    fixes = next(s for s in got.streams if c.LAT_DEG in s.channels)
    np.testing.assert_array_equal(fixes.channels[c.SPEED_GNSS_M_S], np.full(lat.size, 15.0))
    np.testing.assert_array_equal(fixes.channels[c.N_SATS], sats)
    assert any("/ublox/navpvt" in n and "recorded" in n for n in got.notes)
    grid_a = resample(got, nominal_radius_m=radius).drive.columns
    grid_b = resample(want, nominal_radius_m=radius).drive.columns
    assert len(grid_b[c.T_S]) > 1000 and np.nanmin(np.abs(grid_a[c.LAT_DEG])) > 1.0
    for name in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS):
        np.testing.assert_array_equal(grid_a[name], grid_b[name], err_msg=name)


@pytest.mark.parametrize(
    ("key", "spec", "said"),
    [
        ("lat", ColumnSpec("Lat", "deg", 0.0), "lat.scale: expected a finite number other than 0"),
        ("lat", ColumnSpec("Lat", "deg", math.inf), "lat.scale: expected a finite number"),
        ("lat", ColumnSpec("Lat", "deg", 1.0, math.nan), "lat.offset: expected a finite number"),
        ("lat", ColumnSpec("Lat", "ddmm", 1e-4), "no scale or offset on a packed number"),
        ("t", ColumnSpec("Time", "iso8601", 2.0), "no scale or offset on a time written as text"),
        ("t", ColumnSpec("Time", "%H:%M:%S", 2.0), "on a time written as text"),
        ("t", ColumnSpec("Time", "hhmmss", 1.0, 1.0), "on a packed number"),
        ("n_sats", ColumnSpec("Sats", "vbox", 2.0), "on a packed number"),
        ("lat_hemisphere", ColumnSpec("NS", "N/S", 2.0), "on a column of letters or dates"),
    ],
)
def test_a_scale_where_no_number_is_scaled_is_refused(key, spec, said):
    _, values_map = _maps()
    cmap = values_map | {key: spec}
    if key == "lat_hemisphere":
        cmap["lat"] = ColumnSpec("Lat", "deg")
    with pytest.raises(ConfigError) as err:
        check_column_map("raw", cmap)
    assert f"data.column_maps.raw.{key}" in str(err.value) and said in str(err.value)
    with pytest.raises(ConfigError) as err:
        check_signal_map("raw", cmap, with_time=True)
    assert f"data.signal_maps.raw.signals.{key}" in str(err.value) and said in str(err.value)


def test_a_pulse_counter_takes_no_scale():
    smap = {k: ColumnSpec(col, unit) for k, (col, unit, _, _) in RAW.items()}
    smap["omega_fl"] = ColumnSpec("Pulses_FL", "pulses/96 mod 1024", 0.5)
    with pytest.raises(ConfigError, match="omega_fl: expected no scale or offset on a pulse"):
        check_signal_map("raw", smap, with_time=True)


def test_a_map_without_scale_or_offset_is_read_as_logged():
    spec = ColumnSpec("Lat", "deg")
    assert (spec.scale, spec.offset, spec.scaled) == (1.0, 0.0, False)
    assert ColumnSpec("Lat", "deg", 1.0, -1.0).scaled and ColumnSpec("Lat", "deg", 2.0).scaled
    check_column_map("plain", _maps()[1])
    check_column_map("raw", _maps()[0])


@pytest.mark.parametrize(
    ("text", "value"),
    [("1e-7", 1e-7), ("1.0e-7", 1e-7), ("1.0e+7", 1e7), ("1E3", 1000.0), ("-.5e1", -5.0)],
)
def test_a_scale_in_exponent_form_is_a_number(text, value):
    """PyYAML (YAML 1.1) reads ``1e-7`` and ``1.0e-7`` as strings; a map file and
    params.yaml take them as the numbers YAML 1.2 (and DVC) reads."""
    raw = yaml.safe_load(f"lat: {{column: /ublox/navpvt.lat, unit: deg, scale: {text}}}")
    got = parse_value(dict[str, ColumnSpec], raw, "map.yaml")
    assert got["lat"].scale == value
    project = yaml.safe_load(paths.PARAMS.read_text(encoding="utf-8"))
    project["data"]["column_maps"]["raw"] = column_map_params() | {"lat": raw["lat"]}
    params = build_params(project)
    assert params.data.column_maps["raw"]["lat"].scale == value


def test_a_scale_that_is_no_number_is_refused():
    with pytest.raises(ConfigError, match=r"map.yaml.lat.scale: expected a number, got 'e-7'"):
        parse_value(
            dict[str, ColumnSpec],
            {"lat": {"column": "x", "unit": "deg", "scale": "e-7"}},
            "map.yaml",
        )
