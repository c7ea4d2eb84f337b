"""Earth-centred, Earth-fixed (ECEF) positions and velocities on the WGS84 ellipsoid.

A receiver that logs its solution in ECEF (Septentrio's PVTCartesian: X, Y, Z and Vx,
Vy, Vz in the WGS84 / ITRS frame) gives no latitude or longitude; these turn it into
the geodetic position and the local east / north velocity the readers need.

- :func:`ecef_to_geodetic`: X, Y, Z (m) to latitude, longitude (degrees) and height
  above the ellipsoid (m), through PROJ (``pyproj``: EPSG:4978 to EPSG:4979), exact to
  well under a micrometre on the ellipsoid's surface.
- :func:`ecef_to_enu_velocity`: an ECEF velocity rotated into the local east, north and
  up axes at a geodetic latitude and longitude (the rotation of ESA's Navipedia,
  "Transformations between ECEF and ENU coordinates").
"""

from __future__ import annotations

from functools import cache

import numpy as np
from pyproj import Transformer


@cache
def _to_geodetic() -> Transformer:
    """PROJ's WGS84 geocentric (EPSG:4978) to WGS84 geographic 3D (EPSG:4979), x = lon."""
    return Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)


def ecef_to_geodetic(
    x: np.ndarray, y: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS84 ECEF coordinates (m) as geodetic latitude and longitude (degrees, longitude in
    [-180, 180]) and ellipsoidal height (m); NaN in, NaN out."""
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (x, y, z))
    lon, lat, h = _to_geodetic().transform(x, y, z)
    return np.asarray(lat, np.float64), np.asarray(lon, np.float64), np.asarray(h, np.float64)


def ecef_to_enu_velocity(
    vx: np.ndarray, vy: np.ndarray, vz: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An ECEF velocity (m/s) as its east, north and up components at geodetic
    ``lat_deg``, ``lon_deg``."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    east = -sl * vx + cl * vy
    north = -sp * cl * vx - sp * sl * vy + cp * vz
    up = cp * cl * vx + cp * sl * vy + sp * vz
    return east, north, up
