"""Geodesic distances on the WGS84 ellipsoid.

The paper (Sec. 2.2, text after Eq. 11) takes the vehicle's true displacement
x_GNSS as Vincenty's ellipsoidal distance between consecutive fixes. We solve
the same inverse geodesic problem with Karney's algorithm (GeographicLib):
it agrees with Vincenty wherever Vincenty converges, is accurate to round-off
(nanometres), and never fails to converge (Vincenty does for near-antipodal
points). Two implementations are kept:

- :func:`geodesic_distance_m`: vectorised through ``pyproj.Geod.inv`` (which
  wraps GeographicLib's C code); ``benchmarks/bench_geo.py`` prints its speed.
- :func:`geodesic_distance_reference_m`: GeographicLib's pure-Python
  ``Geodesic.WGS84.Inverse`` in a loop, the independent reference the tests
  hold the fast one to.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from geographiclib.geodesic import Geodesic
from numpy.typing import ArrayLike
from pyproj import Geod


@cache
def wgs84() -> Geod:
    """Return the shared ``pyproj.Geod`` on the WGS84 ellipsoid (built on first use)."""
    return Geod(ellps="WGS84")


def as_float64_arrays(*coords: ArrayLike) -> list[np.ndarray]:
    """Broadcast coordinates to one shape as contiguous float64 arrays.

    Args:
        *coords: scalars or arrays that broadcast against each other.

    Returns:
        One contiguous float64 array per input (a copy), all of the broadcast shape.
    """
    arrays = np.broadcast_arrays(*(np.asarray(c, dtype=np.float64) for c in coords))
    # np.array copies: broadcast views are read-only and may repeat memory (zero strides).
    return [np.array(a) for a in arrays]


def check_latitudes(*lat_deg: np.ndarray) -> None:
    """Raise ``ValueError`` if a finite latitude lies outside [-90, 90] degrees.

    pyproj silently returns NaN for such input; a latitude out of range nearly
    always means latitude and longitude were swapped, which we want to hear about.

    Args:
        *lat_deg: latitude arrays in degrees (NaN is allowed and passes).
    """
    for lat in lat_deg:
        bad = np.abs(lat) > 90.0  # NaN compares False: NaN passes here, propagates later
        if np.any(bad):
            first = np.flatnonzero(np.ravel(bad))[0]
            raise ValueError(
                f"latitude must lie in [-90, 90] deg; found {np.ravel(lat)[first]!r} at "
                f"flat index {first} (are latitude and longitude swapped?)"
            )


def geodesic_distance_m(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Return the WGS84 geodesic distance between point pairs (vectorised).

    Args:
        lat1_deg: latitude of the first points, degrees.
        lon1_deg: longitude of the first points, degrees.
        lat2_deg: latitude of the second points, degrees.
        lon2_deg: longitude of the second points, degrees.
            All four broadcast against each other.

    Returns:
        Distances in metres, float64, with the broadcast shape (0-d for scalars).
        A NaN coordinate gives a NaN distance.

    Raises:
        ValueError: if a latitude is outside [-90, 90] degrees.
    """
    lat1, lon1, lat2, lon2 = as_float64_arrays(lat1_deg, lon1_deg, lat2_deg, lon2_deg)
    check_latitudes(lat1, lat2)
    if lat1.size == 0:
        return np.zeros(lat1.shape)
    # pyproj takes (lon, lat) order and returns (azimuth12, azimuth21, distance).
    _, _, dist_m = wgs84().inv(lon1.ravel(), lat1.ravel(), lon2.ravel(), lat2.ravel())
    return np.asarray(dist_m, dtype=np.float64).reshape(lat1.shape)


def geodesic_distance_reference_m(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> np.ndarray:
    """Return the same distances as :func:`geodesic_distance_m` with pure-Python GeographicLib.

    Much slower; it exists as an independent reference for tests and
    benchmarks, so it deliberately loops over ``Geodesic.WGS84.Inverse``.

    Args:
        lat1_deg, lon1_deg, lat2_deg, lon2_deg: as for :func:`geodesic_distance_m`.

    Returns:
        Distances in metres, float64, with the broadcast shape.

    Raises:
        ValueError: if a latitude is outside [-90, 90] degrees.
    """
    lat1, lon1, lat2, lon2 = as_float64_arrays(lat1_deg, lon1_deg, lat2_deg, lon2_deg)
    check_latitudes(lat1, lat2)
    inverse = Geodesic.WGS84.Inverse
    dist_m = [
        inverse(a, b, c, d, Geodesic.DISTANCE)["s12"]
        for a, b, c, d in zip(
            lat1.ravel().tolist(),
            lon1.ravel().tolist(),
            lat2.ravel().tolist(),
            lon2.ravel().tolist(),
            strict=True,
        )
    ]
    return np.asarray(dist_m, dtype=np.float64).reshape(lat1.shape)


# WGS84 semi-major axis (m) and first eccentricity squared.
_WGS84_A_M = 6378137.0
_WGS84_E2 = 6.69437999014e-3


def local_step_distance_m(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Distance between consecutive fixes on the ellipsoid's local tangent plane, m.

    Uses the meridional and prime-vertical radii of curvature of WGS84 at the mid
    latitude of each step. For steps up to kilometres this agrees with the geodesic
    to better than 1e-6 relative, at a twentieth of its cost, which is what screening
    every 10 Hz step for jumps needs.

    Args:
        lat_deg: latitudes, deg.
        lon_deg: longitudes, deg.

    Returns:
        ``n - 1`` distances.
    """
    lat = np.radians(np.asarray(lat_deg, dtype=np.float64))
    lon = np.radians(np.asarray(lon_deg, dtype=np.float64))
    return _tangent_plane_m(lat[:-1], lon[:-1], lat[1:], lon[1:])


def local_distance_m(
    lat1_deg: np.ndarray, lon1_deg: np.ndarray, lat2_deg: np.ndarray, lon2_deg: np.ndarray
) -> np.ndarray:
    """Distance between point pairs on the local tangent plane (as :func:`local_step_distance_m`).

    Args:
        lat1_deg: latitude of the first points, deg.
        lon1_deg: their longitude, deg.
        lat2_deg: latitude of the second points, deg.
        lon2_deg: their longitude, deg.

    Returns:
        Distances, m (within 1e-6 relative of the geodesic for pairs up to kilometres apart).
    """
    east, north = local_step_en_m(lat1_deg, lon1_deg, lat2_deg, lon2_deg)
    return np.hypot(north, east)


def local_step_en_m(
    lat1_deg: np.ndarray, lon1_deg: np.ndarray, lat2_deg: np.ndarray, lon2_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """East and north from the first points to the second on the local tangent plane, m
    (the components of :func:`local_distance_m`'s distance).

    Args:
        lat1_deg, lon1_deg, lat2_deg, lon2_deg: as for :func:`local_distance_m`.

    Returns:
        ``(east_m, north_m)``.
    """
    r = np.radians
    return _tangent_plane_en(
        r(np.asarray(lat1_deg, np.float64)),
        r(np.asarray(lon1_deg, np.float64)),
        r(np.asarray(lat2_deg, np.float64)),
        r(np.asarray(lon2_deg, np.float64)),
    )


def _tangent_plane_m(
    lat1: np.ndarray, lon1: np.ndarray, lat2: np.ndarray, lon2: np.ndarray
) -> np.ndarray:
    """Tangent-plane distance between pairs given in radians."""
    east, north = _tangent_plane_en(lat1, lon1, lat2, lon2)
    return np.hypot(north, east)


def _tangent_plane_en(
    lat1: np.ndarray, lon1: np.ndarray, lat2: np.ndarray, lon2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Tangent-plane east and north from the first points to the second, in radians: the
    meridional and prime-vertical radii of curvature of WGS84 at the mid latitude."""
    mid = 0.5 * (lat2 + lat1)
    sin_mid = np.sin(mid)
    w2 = 1.0 - _WGS84_E2 * (sin_mid * sin_mid)
    w = np.sqrt(w2)
    prime_vertical = _WGS84_A_M / w
    meridional = prime_vertical * ((1.0 - _WGS84_E2) / w2)  # a (1 - e2) / w2^1.5
    d_lon = (lon2 - lon1 + np.pi) % (2.0 * np.pi) - np.pi  # across the antimeridian
    return prime_vertical * np.cos(mid) * d_lon, meridional * (lat2 - lat1)
