"""Column-map reader: names from params, unit conversion to SI, config and input errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import check_column_map, read_columnmap
from rwhonet.errors import InputError
from support.drives import CUPAC_MAP, as_ddmm, as_hhmmss

FIXTURE = Path(__file__).parents[1] / "fixtures" / "cupac" / "C-T1.csv"


def cupac_map(**changes: tuple[str, str]) -> dict[str, ColumnSpec]:
    spec = CUPAC_MAP | changes
    return {k: ColumnSpec(col, unit) for k, (col, unit) in spec.items()}


def test_converts_ms_and_rpm_to_si():
    raw = read_columnmap(FIXTURE, cupac_map(), "cupac")
    assert raw.header_match == "column_map"
    np.testing.assert_allclose(raw.columns[c.T_S][:3], [1.0, 1.1, 1.2])  # 1000, 1100, 1200 ms
    assert raw.columns[c.OMEGA_FL][0] == pytest.approx(480.0 * 2 * math.pi / 60)  # 50.27 rad/s
    assert raw.columns[c.OMEGA_RL][0] == pytest.approx(477.5 * 2 * math.pi / 60)
    assert raw.columns[c.LAT_DEG][1] == pytest.approx(52.41001, abs=1e-9)
    assert raw.columns[c.N_SATS][0] == 11
    assert raw.source_columns[c.OMEGA_RR] == "WheelSpeedRR"
    assert "Notes" not in raw.source_columns.values()  # an unmapped text column is ignored


def test_deg_per_s_and_case_insensitive_names():
    cmap = cupac_map(omega_fl=("  wheelspeedfl ", "deg/s"), t=("TIME", "s"))
    raw = read_columnmap(FIXTURE, cmap, "cupac")
    assert raw.columns[c.OMEGA_FL][0] == pytest.approx(480.0 * math.pi / 180)
    assert raw.columns[c.T_S][0] == 1000.0


def test_optional_satellites_may_be_left_out():
    cmap = cupac_map()
    del cmap["n_sats"]
    assert c.N_SATS not in read_columnmap(FIXTURE, cmap, "cupac").columns


def test_missing_mapped_column_names_the_param(tmp_path):
    cmap = cupac_map(lat=("Lat_deg", "deg"))
    with pytest.raises(InputError) as err:
        read_columnmap(FIXTURE, cmap, "cupac")
    (problem,) = err.value.problems
    assert problem.column == "Lat_deg" and problem.row is None
    assert "data.column_maps.cupac.lat" in problem.expected
    assert "'Latitude'" in problem.found


def test_non_numeric_cell_in_mapped_column(tmp_path):
    lines = FIXTURE.read_text(encoding="utf-8").splitlines()
    lines[4] = lines[4].replace("477.5", "slip", 1)
    path = tmp_path / "C-X.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_columnmap(path, cupac_map(), "cupac")
    (problem,) = err.value.problems
    assert (problem.row, problem.column, problem.found) == (4, "WheelSpeedRL", "'slip'")


def test_check_column_map_lists_every_issue():
    cmap = cupac_map(t=("Time", "min"), omega_rr=("WheelSpeedRR", "kph"))
    del cmap["lon"]
    cmap["speed"] = ColumnSpec("Speed", "m/s")
    with pytest.raises(ConfigError) as err:
        check_column_map("cupac", cmap)
    text = str(err.value)
    assert "data.column_maps.cupac.speed: unknown key" in text
    assert "data.column_maps.cupac.lon: missing" in text
    units = (
        "['s', 'ms', 'us', 'ns', 'iso8601', 'hh:mm:ss', 'hhmmss'] "
        "or a strptime pattern (%d.%m.%Y %H:%M:%S.%f)"
    )
    assert f"data.column_maps.cupac.t.unit: expected one of {units}, got 'min'" in text
    assert "data.column_maps.cupac.omega_rr.unit" in text and "got 'kph'" in text


@pytest.mark.parametrize(
    ("header_unit", "declared", "refused"),
    [
        ("(rpm)", "rpm", False),
        ("(rpm)", "rad/s", True),
        (" [rad/s]", "rpm", True),
        ("", "rad/s", False),
    ],
)
def test_a_unit_the_header_names_must_be_the_one_the_map_declares(
    tmp_path, header_unit, declared, refused
):
    """'WheelSpeedRL (rpm)' mapped as rad/s: the map's unit was taken, the header's not read."""
    text = FIXTURE.read_text().replace("WheelSpeedRL", f"WheelSpeedRL{header_unit}", 1)
    path = tmp_path / "C-U.csv"
    path.write_text(text)
    cmap = cupac_map(omega_rl=("WheelSpeedRL", declared))
    if not refused:
        read_columnmap(path, cmap, "cupac")
        return
    with pytest.raises(InputError) as err:
        read_columnmap(path, cmap, "cupac")
    (problem,) = err.value.problems
    assert problem.column == f"WheelSpeedRL{header_unit}" and problem.row is None
    assert f"data.column_maps.cupac.omega_rl.unit declares, {declared!r}" in problem.expected
    assert "the header names the column's unit" in problem.found


def test_a_clockwise_gyro_s_declared_unit_matches_its_header_s():
    from rwhonet.data.columnmap import columnmap_positions

    header = ["t (s)", "lat", "lon", "fl", "fr", "rl", "rr", "Yaw Rate (deg/s)"]
    cmap = {"yaw_rate": ColumnSpec("Yaw Rate", "deg/s cw"), "lat": ColumnSpec("lat", "deg")}
    assert columnmap_positions(header, cmap, "m", "f.csv") == {"yaw_rate": 7, "lat": 1}


def test_coordinates_in_minutes_and_positive_west_convert_to_degrees(tmp_path):
    """A VBOX-like file (latitude and longitude in minutes of arc, longitude positive
    west) through a column map: the drive in degrees, in ingest's reader and predict's;
    a header naming degrees for a column mapped in minutes is refused."""
    import io

    import pandas as pd

    from rwhonet.data.incremental import read_rows
    from support.drives import write_columnmap
    from support.serving import wavy_drive

    df = wavy_drive(30.0)
    ref = read_columnmap(write_columnmap(df, tmp_path / "deg.csv"), cupac_map(), "cupac")
    frame = pd.read_csv(tmp_path / "deg.csv")
    frame["Latitude"] *= 60.0
    frame["Longitude"] *= -60.0  # minutes, positive west
    frame.to_csv(tmp_path / "vbox.csv", index=False)
    cmap = cupac_map(lat=("Latitude", "min"), lon=("Longitude", "min W"))
    got = read_columnmap(tmp_path / "vbox.csv", cmap, "cupac")
    np.testing.assert_allclose(got.columns[c.LAT_DEG], ref.columns[c.LAT_DEG], rtol=1e-14)
    np.testing.assert_allclose(got.columns[c.LON_DEG], ref.columns[c.LON_DEG], rtol=1e-14)
    _, blocks = read_rows(io.BytesIO((tmp_path / "vbox.csv").read_bytes()), "v", "cupac", cmap)
    streamed = np.concatenate([b[c.LON_DEG] for _, b in blocks])
    np.testing.assert_allclose(streamed, ref.columns[c.LON_DEG], rtol=1e-14)
    frame.rename(columns={"Latitude": "Latitude (deg)"}).to_csv(tmp_path / "x.csv", index=False)
    with pytest.raises(InputError, match="the header names the column's unit 'deg'"):
        read_columnmap(tmp_path / "x.csv", cmap, "cupac")
    with pytest.raises(
        ConfigError, match=r"cupac\.lat\.unit: expected one of \['deg', 'min', 'ddmm'\]"
    ):
        check_column_map("cupac", cupac_map(lat=("Latitude", "min W")))
    # a longitude positive west under a header naming degrees: the direction is no unit
    frame["Longitude"] /= 60.0
    frame.rename(columns={"Longitude": "Longitude (deg)"}).to_csv(tmp_path / "w.csv", index=False)
    west = read_columnmap(tmp_path / "w.csv", cupac_map(lon=("Longitude", "deg W")), "cupac")
    np.testing.assert_allclose(west.columns[c.LON_DEG], ref.columns[c.LON_DEG], rtol=1e-14)


def _both_readers_refuse(path, cmap) -> list[InputError]:
    """The refusals of ingest's reader and predict's (a stream read to its end) of a file."""
    import io

    from rwhonet.data.incremental import read_rows

    errors = []
    for read in (
        lambda: read_columnmap(path, cmap, "cupac"),
        lambda: list(read_rows(io.BytesIO(path.read_bytes()), path.name, "cupac", cmap)[1]),
    ):
        with pytest.raises(InputError) as err:
            read()
        errors.append(err.value)
    return errors


def test_nmea_coordinates_and_a_packed_time_of_day_across_midnight(tmp_path):
    """A logger that copies NMEA's fields: latitude and longitude as ddmm.mmmm (a minus
    sign for west), the UTC time of day as hhmmss.ss passing midnight. Read through a
    column map as the same drive in degrees and seconds, by ingest's reader and predict's;
    a minute of 60 or more is refused with its row, and a header naming its unit is held
    to the map's."""
    import io

    import pandas as pd

    from rwhonet.data.incremental import read_rows
    from support.drives import write_columnmap
    from support.serving import wavy_drive

    df = wavy_drive(30.0)
    ref = read_columnmap(write_columnmap(df, tmp_path / "deg.csv"), cupac_map(), "cupac")
    frame = pd.read_csv(tmp_path / "deg.csv")
    start = 23 * 3600 + 59 * 60 + 50.0  # 10 s before midnight
    t = ref.columns[c.T_S] - ref.columns[c.T_S][0] + start
    frame["Time"] = as_hhmmss(t)
    frame["Latitude"] = as_ddmm(frame["Latitude"].to_numpy())
    frame["Longitude"] = as_ddmm(-2.0 + frame["Longitude"].to_numpy())  # west of Greenwich
    frame.rename(columns={"Latitude": "Lat (ddmm.mmmm)"}).to_csv(tmp_path / "n.csv", index=False)
    cmap = cupac_map(t=("Time", "hhmmss"), lat=("Lat", "ddmm"), lon=("Longitude", "ddmm"))
    got = read_columnmap(tmp_path / "n.csv", cmap, "cupac")
    np.testing.assert_allclose(got.columns[c.T_S], t, rtol=0, atol=1e-6)
    assert got.columns[c.T_S][-1] > 86400.0  # continued past midnight
    assert any("midnight" in note for note in got.notes)
    np.testing.assert_allclose(got.columns[c.LAT_DEG], ref.columns[c.LAT_DEG], rtol=0, atol=1e-12)
    lon = ref.columns[c.LON_DEG] - 2.0
    np.testing.assert_allclose(got.columns[c.LON_DEG], lon, rtol=0, atol=1e-12)
    raw = (tmp_path / "n.csv").read_bytes()
    _, blocks = read_rows(io.BytesIO(raw), "n", "cupac", cmap)
    blocks = list(blocks)
    for name, want in ((c.LAT_DEG, ref.columns[c.LAT_DEG]), (c.LON_DEG, lon)):
        got_streamed = np.concatenate([b[name] for _, b in blocks])
        np.testing.assert_allclose(got_streamed, want, rtol=0, atol=1e-12)
    streamed_t = np.concatenate([b[c.T_S] for _, b in blocks])
    np.testing.assert_allclose(streamed_t % 86400.0, t % 86400.0, rtol=0, atol=1e-6)
    # row 7's latitude with 61 minutes: refused in both readers, naming row and setting
    frame.loc[6, "Lat (ddmm.mmmm)"] = 5261.0
    frame.to_csv(tmp_path / "bad.csv", index=False)
    for err in _both_readers_refuse(tmp_path / "bad.csv", cmap):
        (problem,) = err.problems
        assert (problem.row, problem.column) == (7, "Lat (ddmm.mmmm)")
        assert "ddmm.mmmm" in problem.expected and "data.column_maps.cupac.lat.unit" in problem.fix
    frame.rename(columns={"Lat (ddmm.mmmm)": "Lat (deg)"}).to_csv(tmp_path / "d.csv", index=False)
    with pytest.raises(InputError, match="the header names the column's unit 'deg'"):
        read_columnmap(tmp_path / "d.csv", cmap, "cupac")


def test_nmea_hemisphere_letters_in_columns_of_their_own_sign_the_coordinates(tmp_path):
    """A GGA sentence split into columns: magnitudes in ddmm.mmmm, the hemisphere in N/S and
    E/W columns. South and west read negative, by ingest's reader and predict's; an empty
    letter leaves the fix missing; a letter that is none, or a minus sign beside a letter,
    is refused with its row; a map that gives the sign twice is refused at once."""
    import io

    import pandas as pd

    from rwhonet.data.incremental import read_rows
    from support.drives import write_columnmap
    from support.serving import wavy_drive

    df = wavy_drive(30.0)
    ref = read_columnmap(write_columnmap(df, tmp_path / "deg.csv"), cupac_map(), "cupac")
    frame = pd.read_csv(tmp_path / "deg.csv")
    lat, lon = -frame["Latitude"].to_numpy(), frame["Longitude"].to_numpy() - 70.0
    frame["Latitude"], frame["Longitude"] = as_ddmm(np.abs(lat)), as_ddmm(np.abs(lon))
    frame.insert(frame.columns.get_loc("Latitude") + 1, "NS", np.where(lat < 0, "S", "N"))
    frame.insert(frame.columns.get_loc("Longitude") + 1, "EW", np.where(lon < 0, "w", "E"))
    frame.loc[5, ["NS"]] = ""
    frame.to_csv(tmp_path / "gga.csv", index=False)
    cmap = cupac_map(lat=("Latitude", "ddmm"), lon=("Longitude", "ddmm")) | {
        "lat_hemisphere": ColumnSpec("NS", "N/S"),
        "lon_hemisphere": ColumnSpec("EW", "E/W"),
    }
    got = read_columnmap(tmp_path / "gga.csv", cmap, "cupac")
    want_lat = -ref.columns[c.LAT_DEG]
    want_lat[5] = np.nan
    np.testing.assert_allclose(got.columns[c.LAT_DEG], want_lat, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.columns[c.LON_DEG], ref.columns[c.LON_DEG] - 70.0, atol=1e-12)
    assert set(got.source_columns.values()) >= {"Latitude", "Longitude"}
    assert not {"NS", "EW"} & set(got.source_columns.values())
    _, blocks = read_rows(io.BytesIO((tmp_path / "gga.csv").read_bytes()), "g", "cupac", cmap)
    streamed = list(blocks)
    for name, want in ((c.LAT_DEG, want_lat), (c.LON_DEG, ref.columns[c.LON_DEG] - 70.0)):
        values = np.concatenate([b[name] for _, b in streamed])
        np.testing.assert_allclose(values, want, rtol=0, atol=1e-12)
    frame.loc[8, "EW"] = "X"
    frame.loc[11, "Latitude"] *= -1
    frame.to_csv(tmp_path / "bad.csv", index=False)
    for err in _both_readers_refuse(tmp_path / "bad.csv", cmap):
        assert {(p.row, p.column) for p in err.problems} == {(9, "EW"), (12, "Latitude")}
    with pytest.raises(ConfigError) as err:
        check_column_map(
            "cupac",
            cupac_map(lon=("Longitude", "ddmm W"))
            | {"lon_hemisphere": ColumnSpec("EW", "E/W"), "lat_hemisphere": ColumnSpec("NS", "S")},
        )
    assert "cupac.lon.unit: expected a unit without ' W'" in str(err.value)
    assert "cupac.lat_hemisphere.unit: expected 'N/S', got 'S'" in str(err.value)


@pytest.mark.parametrize("unit", ["km/h", "m/s", "mph"])
def test_circumferential_wheel_speeds_are_divided_by_the_nominal_radius(tmp_path, unit):
    """CAN wheel speeds in km/h (the wheel's circumferential speed, as many cars put it on
    the bus): divided by the car's nominal radius, the same rad/s as the angular log, in
    ingest's reader and predict's; the note names the columns and the radius."""
    import io

    from rwhonet.data.incremental import read_rows
    from support.drives import write_columnmap
    from support.serving import wavy_drive

    df, radius = wavy_drive(30.0), 0.31
    ref = read_columnmap(write_columnmap(df, tmp_path / "rpm.csv"), cupac_map(), "cupac")
    wheels = {k: (f"WheelSpeed{k[-2:].upper()}", unit) for k in ("omega_rl", "omega_rr")}
    path = write_columnmap(df, tmp_path / "kmh.csv", CUPAC_MAP | wheels, radius_m=radius)
    cmap = cupac_map(**wheels)
    got = read_columnmap(path, cmap, "cupac", radius_m=radius)
    lay, blocks = read_rows(
        io.BytesIO(path.read_bytes()), "kmh.csv", "cupac", cmap, radius_m=radius
    )
    blocks = [b for _, b in blocks]
    streamed = {w: np.concatenate([b[w] for b in blocks]) for w in c.WHEELS}
    for w in c.WHEELS:
        np.testing.assert_allclose(got.columns[w], ref.columns[w], rtol=1e-12)
        np.testing.assert_allclose(streamed[w], ref.columns[w], rtol=1e-12)
    (note,) = [n for n in got.notes if "circumferential" in n]
    assert f"WheelSpeedRL ({unit}), WheelSpeedRR ({unit})" in note and "0.31 m" in note
    assert note in lay.notes


def test_circumferential_wheel_speeds_without_a_radius_are_refused_naming_the_setting(
    tmp_path,
):
    from support.drives import write_columnmap
    from support.serving import wavy_drive

    kmh = {"omega_rl": ("WheelSpeedRL", "km/h")}
    path = write_columnmap(wavy_drive(10.0), tmp_path / "kmh.csv", CUPAC_MAP | kmh, 0.3)
    with pytest.raises(InputError, match="tyre radius") as err:
        read_columnmap(path, cupac_map(**kmh), "cupac")
    assert err.value.problems[0].file == "data.column_maps.cupac.omega_rl.unit"
    assert "nominal_radius_m" in err.value.problems[0].fix
    check_column_map("cupac", cupac_map(**kmh))  # the unit itself is one a map may declare
    with pytest.raises(ConfigError, match="'rad/s', 'rpm', 'deg/s', 'm/s', 'km/h', 'mph'"):
        check_column_map("cupac", cupac_map(omega_rl=("WheelSpeedRL", "knots")))
