"""Geodesy on the WGS84 ellipsoid (GeographicLib algorithms).

- :mod:`rwhonet.geo.geodesic`: distances between fixes (paper Eq. 11's x_GNSS), and a
  fast tangent-plane distance (and its east and north) for screening every step of a
  track.
- :mod:`rwhonet.geo.local`: local east/north offsets around a reference fix.
- :mod:`rwhonet.geo.ecef`: Earth-centred, Earth-fixed positions and velocities as
  latitude, longitude, height and east / north / up (a receiver's PVTCartesian);
  imported from its module, so that what imports this package does not load it.
"""

from rwhonet.geo.geodesic import (
    geodesic_distance_m,
    geodesic_distance_reference_m,
    local_distance_m,
    local_step_distance_m,
    local_step_en_m,
)
from rwhonet.geo.local import destination_deg, latlon_from_offsets_deg, offsets_m

__all__ = [
    "destination_deg",
    "geodesic_distance_m",
    "geodesic_distance_reference_m",
    "latlon_from_offsets_deg",
    "local_distance_m",
    "local_step_distance_m",
    "local_step_en_m",
    "offsets_m",
]
