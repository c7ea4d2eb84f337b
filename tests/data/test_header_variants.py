"""Named columns as real exports write them: any order, extra columns, spellings, unit suffixes."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import find_column, read_columnmap
from rwhonet.data.headers import header_key, unit_name
from rwhonet.data.iovnbd import HEADERS, LayoutError, locate_columns, read_iovnbd
from rwhonet.errors import InputError
from support.drives import straight_drive, write_iovnbd

VARIANTS = {
    c.T_S: "time_s",
    c.LAT_DEG: "Latitude [deg]",
    c.LON_DEG: "LONGITUDE",
    c.N_SATS: "Satellites",
    c.OMEGA_FL: "WheelSpeed_FL (rad/s)",
    c.OMEGA_FR: "wheel speed front right",
    c.OMEGA_RL: "ws_rl",
    c.OMEGA_RR: "Wheel Speed Rear Right (rad/sec)",
}


def _write(df: pd.DataFrame, names: dict[str, str], path, extra: bool = True):
    out = {names[k]: df[k].to_numpy() for k in reversed(list(names))}  # reversed order
    if extra:
        out = {"Comment": np.zeros(len(df)), **out, "GPS Time UTC": np.arange(len(df))}
    pd.DataFrame(out).to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    ("cell", "key", "unit"),
    [
        (" Wheel Speed Front Left (rad/sec)", "wheelspeedfrontleft", "rad/sec"),
        ("wheel_speed_front_left", "wheelspeedfrontleft", None),
        ("WheelSpeedFrontLeft [rad/s]", "wheelspeedfrontleft", "rad/s"),
        (" Velocity kmh", "velocity", "kmh"),
        ("lat_deg", "lat", "deg"),
        ("Time (s)", "time", "s"),
        (" Sats", "sats", None),
        ("wheel_speed_fl_rad_s", "wheelspeedfl", "rad/s"),  # a unit in snake case
        ("acc_lon_m_s2", "acclon", "m/s2"),
        ("vehicle_speed_km_h", "vehiclespeed", "km/h"),
        ("yaw_rate_deg_s", "yawrate", "deg/s"),
        ("gps_time_ms", "gpstime", "ms"),
        ("timestamp_us", "timestamp", "us"),
        ("Time [µs]", "time", "µs"),
        ("stamp_ns", "stamp", "ns"),
        ("speed_m_s_s", "speed", "m/s/s"),
    ],
)
def test_header_key_ignores_case_spaces_punctuation_and_unit(cell, key, unit):
    assert header_key(cell) == (key, unit)


def test_variant_names_in_any_order_with_extra_columns_read_as_the_layout(tmp_path):
    df = straight_drive(duration_s=5.0)
    raw = read_iovnbd(_write(df, VARIANTS, tmp_path / "V-V.csv"))
    assert raw.header_match == "name" and raw.notes == ()
    for name in VARIANTS:
        np.testing.assert_allclose(raw.columns[name], df[name].to_numpy(), rtol=0, atol=1e-12)
    assert raw.source_columns[c.OMEGA_RL] == "ws_rl"


@pytest.mark.parametrize(
    "spelling",
    [
        "wheel_speed_{}_rad_s",
        "Speed_{} [rad/s]",
        "WhlSpd_{}",
        "WHEEL_SPEED_{} [rad/s]",
        "wss_{}_rpm",
    ],
)
def test_common_wheel_speed_spellings_are_found_by_name(tmp_path, spelling):
    # Names real exports and DBCs give the four wheel speeds, with extra columns around them
    # (so the layout's positions cannot rescue them): each is found by name, in its unit.
    df = straight_drive(duration_s=5.0)
    pos = {c.OMEGA_FL: "FL", c.OMEGA_FR: "FR", c.OMEGA_RL: "RL", c.OMEGA_RR: "RR"}
    names = {**VARIANTS, **{w: spelling.format(p) for w, p in pos.items()}}
    scale = 60.0 / (2.0 * math.pi) if spelling.endswith("rpm") else 1.0
    logged = df.assign(**{w: df[w] * scale for w in pos})
    raw = read_iovnbd(_write(logged, names, tmp_path / "V-W.csv"))
    assert raw.header_match == "name"
    for w in pos:
        np.testing.assert_allclose(raw.columns[w], df[w].to_numpy(), rtol=1e-12, atol=1e-12)


def test_a_declared_unit_is_honoured(tmp_path):
    df = straight_drive(duration_s=5.0)
    names = {**VARIANTS, c.OMEGA_RL: "Wheel Speed Rear Left (rpm)"}
    in_rpm = df.assign(**{c.OMEGA_RL: df[c.OMEGA_RL] * 60.0 / (2.0 * math.pi)})
    raw = read_iovnbd(_write(in_rpm, names, tmp_path / "V-R.csv"))
    np.testing.assert_allclose(raw.columns[c.OMEGA_RL], df[c.OMEGA_RL], rtol=1e-12)


@pytest.mark.parametrize(
    ("name", "scale"), [("time_ms", 1e3), ("Time (us)", 1e6), ("Time [µs]", 1e6), ("time_ns", 1e9)]
)
def test_a_time_in_ms_us_or_ns_is_read_in_seconds(tmp_path, name, scale):
    """A microcontroller's micros(), a ROS or CAN tool's nanoseconds since the epoch (1.7e18:
    float64 keeps them to 256 ns), by the IO-VNBD reader and a column map."""
    df = straight_drive(duration_s=5.0)
    df[c.T_S] += 1.7e9  # seconds since the epoch
    raw = read_iovnbd(
        _write(
            df.assign(**{c.T_S: df[c.T_S] * scale}), {**VARIANTS, c.T_S: name}, tmp_path / "V-T.csv"
        )
    )
    np.testing.assert_allclose(raw.columns[c.T_S], df[c.T_S], rtol=0, atol=1e-6)
    unit = unit_name(header_key(name)[1])  # a map spells it as the readers name it: us
    spec = {k: ColumnSpec(VARIANTS[n], "deg") for k, n in (("lat", c.LAT_DEG), ("lon", c.LON_DEG))}
    spec |= {
        k: ColumnSpec(VARIANTS[w], "rad/s")
        for k, w in zip(("omega_fl", "omega_fr", "omega_rl", "omega_rr"), c.WHEELS, strict=True)
    }
    spec["t"] = ColumnSpec(name, unit)
    got = read_columnmap(tmp_path / "V-T.csv", spec, "mine")
    np.testing.assert_allclose(got.columns[c.T_S], df[c.T_S], rtol=0, atol=1e-6)


def test_a_unit_the_quantity_has_not_is_refused(tmp_path):
    df = straight_drive(duration_s=5.0)
    names = {**VARIANTS, c.LAT_DEG: "Latitude (m/s)"}
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(df, names, tmp_path / "V-U.csv"))
    (p,) = err.value.problems
    assert (p.file, p.column) == (str(tmp_path / "V-U.csv"), "Latitude (m/s)")
    assert "a unit of angle (deg, ddmm)" in p.expected and "'m/s'" in p.found


def test_a_wheel_s_circumferential_speed_is_sent_to_a_column_map(tmp_path):
    """'Wheel Speed RL (km/h)': converting it needs the car's tyre radius, which an IO-VNBD
    file does not carry; the fix says to read the file through a column map."""
    df = straight_drive(duration_s=5.0)
    names = {**VARIANTS, c.OMEGA_RL: "Wheel Speed RL (kph)"}
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(df, names, tmp_path / "V-K.csv"))
    (p,) = err.value.problems
    assert (
        p.column == "Wheel Speed RL (kph)" and "a unit of wheel (rad/s, rpm, deg/s)" in p.expected
    )
    assert "circumferential speed in km/h" in p.fix and "unit 'km/h'" in p.fix
    assert "data.column_maps" in p.fix


def test_two_columns_naming_one_channel_are_refused(tmp_path):
    header = [*HEADERS, "Latitude"]
    with pytest.raises(LayoutError, match="more than once"):
        locate_columns(header)


def test_unknown_names_fall_back_to_position_and_say_so(tmp_path):
    df = straight_drive(duration_s=5.0)
    path = write_iovnbd(df, tmp_path / "V-P.csv", tuple(f"Kanal {i}" for i in range(29)))
    raw = read_iovnbd(path)
    assert raw.header_match == "position"
    assert any("by position (the last resort)" in note for note in raw.notes)


def test_a_column_map_finds_its_columns_whatever_their_spelling(tmp_path):
    df = straight_drive(duration_s=5.0)
    path = tmp_path / "cupac.csv"
    pd.DataFrame(
        {
            "Extra": 1.0,
            "Wheel Speed RL (rad/s)": df[c.OMEGA_RL],
            "wheel_speed_rr": df[c.OMEGA_RR],
            "WHEEL SPEED FL": df[c.OMEGA_FL],
            "WheelSpeedFR": df[c.OMEGA_FR],
            " Latitude ": df[c.LAT_DEG],
            "longitude": df[c.LON_DEG],
            "Time [s]": df[c.T_S],
        }
    ).to_csv(path, index=False)
    cmap = {
        "t": ColumnSpec("Time", "s"),
        "lat": ColumnSpec("Latitude", "deg"),
        "lon": ColumnSpec("Longitude", "deg"),
        **{f"omega_{w}": ColumnSpec(f"WheelSpeed{w.upper()}", "rad/s") for w in ("fl", "fr")},
        **{f"omega_{w}": ColumnSpec(f"WheelSpeed{w.upper()}", "rad/s") for w in ("rl", "rr")},
    }
    raw = read_columnmap(path, cmap, "cupac")
    for name in c.REQUIRED:
        np.testing.assert_allclose(raw.columns[name], df[name].to_numpy())


def test_find_column_prefers_the_exact_name_and_refuses_ambiguity():
    assert find_column(["ws_fl", "WS FL"], "ws_fl") == 0
    assert find_column(["WS-FL", "ws fl"], "wsfl") is None  # two columns share the key
    assert find_column(["a", "b"], "c") is None
