"""Local east/north offsets: exact distances from the reference and a lossless round trip."""

from __future__ import annotations

import numpy as np
import pytest
from geographiclib.geodesic import Geodesic

from rwhonet.geo import (
    destination_deg,
    geodesic_distance_m,
    latlon_from_offsets_deg,
    offsets_m,
)

LAT0, LON0 = 52.4068, -1.5197  # Coventry


def test_offsets_round_trip():
    rng = np.random.default_rng(3)
    east = rng.uniform(-5000, 5000, 500)
    north = rng.uniform(-5000, 5000, 500)
    lat, lon = latlon_from_offsets_deg(LAT0, LON0, east, north)
    e2, n2 = offsets_m(LAT0, LON0, lat, lon)
    np.testing.assert_allclose(e2, east, rtol=0, atol=1e-6)
    np.testing.assert_allclose(n2, north, rtol=0, atol=1e-6)


def test_distance_from_reference_is_exact():
    east = np.array([0.0, 100.0, 0.0, -300.0, 2000.0])
    north = np.array([0.0, 0.0, 250.0, -400.0, 2000.0])
    lat, lon = latlon_from_offsets_deg(LAT0, LON0, east, north)
    np.testing.assert_allclose(
        geodesic_distance_m(LAT0, LON0, lat, lon), np.hypot(east, north), rtol=0, atol=1e-6
    )
    # Pure north stays on the meridian; pure east moves east.
    assert lon[2] == pytest.approx(LON0, abs=1e-12)
    assert lat[2] > LAT0
    assert lon[1] > LON0


def test_destination_moves_the_requested_distance_and_back():
    lat, lon = destination_deg(LAT0, LON0, 37.0, np.array([10.0, 1000.0]))
    np.testing.assert_allclose(geodesic_distance_m(LAT0, LON0, lat, lon), [10.0, 1000.0], atol=1e-6)
    # Walking back (negative distance) along the geodesic's azimuth at the far end returns home.
    azi2 = Geodesic.WGS84.Inverse(LAT0, LON0, lat[1], lon[1])["azi2"]
    lat_b, lon_b = destination_deg(lat[1], lon[1], azi2, -1000.0)
    assert float(geodesic_distance_m(LAT0, LON0, lat_b, lon_b)) == pytest.approx(0.0, abs=1e-6)
