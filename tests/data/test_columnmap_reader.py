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
from support.drives import CUPAC_MAP

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
    cmap = cupac_map(t=("Time", "min"), omega_rr=("WheelSpeedRR", "km/h"))
    del cmap["lon"]
    cmap["speed"] = ColumnSpec("Speed", "m/s")
    with pytest.raises(ConfigError) as err:
        check_column_map("cupac", cmap)
    text = str(err.value)
    assert "data.column_maps.cupac.speed: unknown key" in text
    assert "data.column_maps.cupac.lon: missing" in text
    units = "['s', 'ms', 'iso8601', 'hh:mm:ss'] or a strptime pattern (%d.%m.%Y %H:%M:%S.%f)"
    assert f"data.column_maps.cupac.t.unit: expected one of {units}, got 'min'" in text
    assert "data.column_maps.cupac.omega_rr.unit" in text and "'km/h'" in text


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
    with pytest.raises(ConfigError, match=r"cupac\.lat\.unit: expected one of \['deg', 'min'\]"):
        check_column_map("cupac", cupac_map(lat=("Latitude", "min W")))
