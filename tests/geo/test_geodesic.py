"""Geodesic distances: agreement with GeographicLib, known values, metric properties."""

from __future__ import annotations

import numpy as np
import pytest
from geographiclib.geodesic import Geodesic

from rwhonet.geo import geodesic_distance_m, geodesic_distance_reference_m


@pytest.fixture(scope="module")
def pairs() -> tuple[np.ndarray, ...]:
    """2,000 point pairs 0-50 m apart (one second of driving) plus some long ones."""
    rng = np.random.default_rng(7)
    n = 2000
    lat1 = rng.uniform(-80, 80, n)
    lon1 = rng.uniform(-180, 180, n)
    az = rng.uniform(-180, 180, n)
    s = np.concatenate([rng.uniform(0, 50, n - 20), rng.uniform(1e5, 1.9e7, 20)])
    ends = [Geodesic.WGS84.Direct(a, b, c, d) for a, b, c, d in zip(lat1, lon1, az, s, strict=True)]
    lat2 = np.array([e["lat2"] for e in ends])
    lon2 = np.array([e["lon2"] for e in ends])
    return lat1, lon1, lat2, lon2, s


def test_vectorised_agrees_with_geographiclib_to_a_micrometre(pairs):
    lat1, lon1, lat2, lon2, _ = pairs
    fast = geodesic_distance_m(lat1, lon1, lat2, lon2)
    ref = geodesic_distance_reference_m(lat1, lon1, lat2, lon2)
    assert fast.shape == ref.shape == lat1.shape
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-6)


def test_direct_problem_round_trip(pairs):
    lat1, lon1, lat2, lon2, s = pairs
    # Long geodesics lose a few nm per 1000 km to round-off; 1e-6 m is still far below GNSS noise.
    np.testing.assert_allclose(geodesic_distance_m(lat1, lon1, lat2, lon2), s, rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    ("lat1", "lon1", "lat2", "lon2", "expected_m"),
    [
        # One degree of latitude at the equator on WGS84.
        (0.0, 0.0, 1.0, 0.0, 110574.388556),
        # One degree of longitude along the equator: a * pi / 180 with a = 6378137 m.
        (0.0, 10.0, 0.0, 11.0, 6378137.0 * np.pi / 180.0),
        # Pole to pole along a meridian: twice the WGS84 meridian quadrant 10001965.729 m.
        (90.0, 0.0, -90.0, 0.0, 2 * 10001965.729313),
    ],
)
def test_known_distances(lat1, lon1, lat2, lon2, expected_m):
    assert float(geodesic_distance_m(lat1, lon1, lat2, lon2)) == pytest.approx(expected_m, abs=1e-5)
    ref = float(geodesic_distance_reference_m(lat1, lon1, lat2, lon2))
    assert ref == pytest.approx(expected_m, abs=1e-5)


def test_symmetric_and_zero_for_equal_points(pairs):
    lat1, lon1, lat2, lon2, _ = pairs
    np.testing.assert_allclose(
        geodesic_distance_m(lat1, lon1, lat2, lon2),
        geodesic_distance_m(lat2, lon2, lat1, lon1),
        rtol=0,
        atol=1e-9,
    )
    np.testing.assert_array_equal(geodesic_distance_m(lat1, lon1, lat1, lon1), 0.0)


def test_broadcasts_and_propagates_nan():
    lat2 = np.array([[0.0, 1.0], [np.nan, 2.0]])
    d = geodesic_distance_m(0.0, 0.0, lat2, 0.0)
    assert d.shape == (2, 2)
    assert d[0, 0] == 0.0
    assert np.isnan(d[1, 0])
    assert d[1, 1] == pytest.approx(2 * 110574.388556, rel=1e-4)
    assert geodesic_distance_m(np.empty(0), np.empty(0), np.empty(0), np.empty(0)).shape == (0,)


def test_latitude_out_of_range_is_an_error_not_nan():
    # pyproj alone would return NaN for this (swapped lat/lon).
    with pytest.raises(ValueError, match="swapped"):
        geodesic_distance_m(np.array([52.4, 120.0]), -1.5, 52.4, -1.5)


def test_the_tangent_plane_distance_of_pairs_is_that_of_steps_and_near_the_geodesic():
    from rwhonet.geo import geodesic_distance_m, local_distance_m, local_step_distance_m

    rng = np.random.default_rng(5)
    lat = np.cumsum(rng.uniform(-1e-4, 1e-4, 500)) + rng.uniform(-80, 80)
    lon = np.cumsum(rng.uniform(-1e-4, 1e-4, 500)) + 179.99  # across the antimeridian
    lon = (lon + 180.0) % 360.0 - 180.0
    np.testing.assert_array_equal(
        local_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:]), local_step_distance_m(lat, lon)
    )
    k = 10  # pairs a second apart at 10 Hz
    far = local_distance_m(lat[:-k], lon[:-k], lat[k:], lon[k:])
    exact = geodesic_distance_m(lat[:-k], lon[:-k], lat[k:], lon[k:])
    np.testing.assert_allclose(far, exact, rtol=1e-6)


def test_the_tangent_plane_east_and_north_make_its_distance_and_the_geodesic_s_azimuth():
    from rwhonet.geo import local_distance_m, local_step_en_m
    from rwhonet.geo.geodesic import wgs84

    rng = np.random.default_rng(6)
    lat1 = rng.uniform(-80, 80, 300)
    lon1 = rng.uniform(-180, 180, 300)
    lat2 = lat1 + rng.uniform(-1e-3, 1e-3, 300)
    lon2 = (lon1 + rng.uniform(-1e-3, 1e-3, 300) + 180.0) % 360.0 - 180.0
    east, north = local_step_en_m(lat1, lon1, lat2, lon2)
    np.testing.assert_array_equal(np.hypot(north, east), local_distance_m(lat1, lon1, lat2, lon2))
    az, _, dist = wgs84().inv(lon1, lat1, lon2, lat2)
    np.testing.assert_allclose(east, dist * np.sin(np.radians(az)), rtol=0, atol=1e-3)
    np.testing.assert_allclose(north, dist * np.cos(np.radians(az)), rtol=0, atol=1e-3)
