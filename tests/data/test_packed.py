"""NMEA's ddmm.mmmm angles and hhmmss.ss times (rwhonet.data.packed): known values, edges."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rwhonet.data.canonical import DDMM, DDMM_W
from rwhonet.data.packed import (
    HHMMSS,
    VBOX_SATS,
    hemisphere_signs,
    signed_or_refuse,
    unpack,
    unpack_or_refuse,
)
from rwhonet.errors import InputError


def test_known_angles_as_nmea_writes_them() -> None:
    # NMEA 0183's own example ($GPGGA ... 4807.038,N,01131.000,E): 48 deg 7.038 min, 11 deg 31 min
    out, bad = unpack(np.array([4807.038, 1131.0, 5224.1234, -3352.0, -11819.5]), DDMM)
    assert bad.size == 0
    expected = [
        48 + 7.038 / 60,
        11 + 31 / 60,
        52 + 24.1234 / 60,
        -(33 + 52 / 60),
        -(118 + 19.5 / 60),
    ]
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


def test_a_longitude_positive_west_is_negated() -> None:
    out, _ = unpack(np.array([130.5, 12234.0]), DDMM_W)
    np.testing.assert_allclose(out, [-(1 + 30.5 / 60), -(122 + 34 / 60)], atol=1e-12)


def test_angles_under_a_degree_and_at_the_minute_s_edge() -> None:
    # 0 deg 59.9999999 min stays under one degree; 6.5 min west of Greenwich written -6.5
    out, bad = unpack(np.array([59.9999999, -6.5, 0.0, 9000.0, 18000.0]), DDMM)
    assert bad.size == 0
    np.testing.assert_allclose(out, [59.9999999 / 60, -6.5 / 60, 0.0, 90.0, 180.0], atol=1e-12)


def test_minutes_of_60_or_more_are_not_an_angle() -> None:
    out, bad = unpack(np.array([5261.0, 5224.0, 5299.9, -375.0, 5260.002]), DDMM)
    assert bad.tolist() == [0, 2, 3, 4]
    assert np.isnan(out[[0, 2, 3, 4]]).all()
    assert out[1] == pytest.approx(52.4)


def test_sixty_minutes_or_seconds_from_a_writer_s_rounding_are_the_next_degree_or_minute():
    # 52 deg 59.99996 min printed to four decimals; 12:34:59.996 printed to two
    out, bad = unpack(np.array([5260.0, -5260.0004]), DDMM)
    assert bad.size == 0
    np.testing.assert_allclose(out, [53.0, -(53.0 + 0.0004 / 60)], atol=1e-12)
    out, bad = unpack(np.array([123460.0]), HHMMSS)
    assert bad.size == 0 and out[0] == 12 * 3600 + 35 * 60


def test_a_missing_value_stays_missing_and_is_not_refused() -> None:
    out, bad = unpack(np.array([math.nan, 5224.0]), DDMM)
    assert bad.size == 0 and math.isnan(out[0])
    out, bad = unpack(np.array([math.nan, 120000.0]), HHMMSS)
    assert bad.size == 0 and math.isnan(out[0])


def test_known_times_with_and_without_leading_zeros() -> None:
    times = np.array([142205.1, 93005.5, 5.25, 235959.99, 0.0, 100.0])
    out, bad = unpack(times, HHMMSS)
    assert bad.size == 0
    expected = [14 * 3600 + 22 * 60 + 5.1, 9 * 3600 + 30 * 60 + 5.5, 5.25, 86399.99, 0.0, 60.0]
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-9)


def test_a_tenth_of_a_second_survives_the_unpacking() -> None:
    # every 10 Hz stamp of an hour across the top of the hour
    t = np.round(np.arange(0, 3600, 0.1), 1)
    h, rest = np.divmod(t + 13 * 3600 + 30 * 60, 3600)
    m, s = np.divmod(rest, 60)
    packed = h * 10_000 + m * 100 + s
    out, bad = unpack(packed, HHMMSS)
    assert bad.size == 0
    np.testing.assert_allclose(out, t + 13 * 3600 + 30 * 60, rtol=0, atol=1e-7)
    assert np.all(np.diff(out) > 0.09)


def test_impossible_times_are_named() -> None:
    out, bad = unpack(np.array([126000.0, 120061.0, 240000.0, -1.0, 125959.0]), HHMMSS)
    assert bad.tolist() == [0, 1, 2, 3]
    assert out[4] == 12 * 3600 + 59 * 60 + 59


def test_a_refused_cell_names_its_file_row_column_and_the_setting() -> None:
    with pytest.raises(InputError) as err:
        unpack_or_refuse(
            np.array([5224.0, 5275.5, 5224.1]),
            DDMM,
            "nmea.csv",
            "Lat",
            rows=np.array([1, 7, 9]),
            setting="data.column_maps.nmea.lat.unit",
        )
    (problem,) = err.value.problems
    assert (problem.file, problem.row, problem.column) == ("nmea.csv", 7, "Lat")
    assert "ddmm.mmmm" in problem.expected and problem.found == "5275.5"
    assert "data.column_maps.nmea.lat.unit declares 'ddmm'" in (problem.fix or "")


def test_many_refused_cells_are_listed_then_counted() -> None:
    with pytest.raises(InputError) as err:
        unpack_or_refuse(np.full(80, 1261.0), DDMM, "f.csv", "Lat")
    *listed, rest = err.value.problems
    assert [p.row for p in listed] == [1, 2, 3, 4, 5]
    assert rest.row is None and "75 more row(s)" in rest.found and "rows 6-80" in rest.found


def test_hemisphere_letters_give_the_signs_nmea_means() -> None:
    signs, bad = hemisphere_signs(["N", " s ", '"S"', "", None, "nan", "E", "north"], "N/S")
    np.testing.assert_array_equal(signs[:3], [1.0, -1.0, -1.0])
    assert np.isnan(signs[3:]).all()
    assert [i for i, _ in bad] == [6, 7]
    out = signed_or_refuse(
        np.array([48.1173, 11.5167, 0.0]), ["N", "S", "S"], "N/S", "f", ("a", "b")
    )
    np.testing.assert_array_equal(out, [48.1173, -11.5167, -0.0])


def test_a_sign_and_a_letter_both_and_a_letter_that_is_none_are_refused_with_rows() -> None:
    with pytest.raises(InputError) as err:
        signed_or_refuse(
            np.array([1.5, -2.0, 3.0, -4.0]),
            ["W", "W", "Q", ""],  # row 4: no letter, no fix: its sign does not matter
            "E/W",
            "gga.csv",
            ("Lon", "EW"),
            first_row=10,
            setting="data.column_maps.gga.lon_hemisphere",
        )
    rows = [(p.row, p.column) for p in err.value.problems]
    assert rows == [(12, "EW"), (11, "Lon")]
    assert "E or W" in err.value.problems[0].expected
    assert "data.column_maps.gga.lon_hemisphere" in (err.value.problems[1].fix or "")


def test_a_vbox_satellite_count_loses_its_flags() -> None:
    """64 (brake trigger) and 128 (DGPS) come off: 137 is 9 satellites with DGPS."""
    out, bad = unpack(np.array([9.0, 137.0, 73.0, 201.0, 0.0, np.nan, 12.0]), VBOX_SATS)
    np.testing.assert_array_equal(out[[0, 1, 2, 3, 4, 6]], [9, 9, 9, 9, 0, 12])
    assert np.isnan(out[5]) and bad.size == 0


def test_a_vbox_count_that_is_none_is_refused_with_its_row() -> None:
    with pytest.raises(InputError) as err:
        unpack_or_refuse(
            np.array([9.0, 256.0, -1.0, 9.5]),
            VBOX_SATS,
            "d.vbo",
            "sats",
            setting="data.column_maps.vbox.n_sats.unit",
        )
    assert [p.row for p in err.value.problems] == [2, 3, 4]
    assert "a plain count is declared 'count'" in err.value.problems[0].fix
