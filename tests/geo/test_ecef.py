"""ECEF positions and velocities as geodetic ones (``rwhonet.geo.ecef``): known points, the
closed-form forward conversion undone, and the local axes' rotation."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.geo.ecef import ecef_to_enu_velocity, ecef_to_geodetic
from support.sbf import A_M, E2, F, ecef

B_M = A_M * (1.0 - F)


@pytest.mark.parametrize(
    ("xyz", "want"),
    [
        ((A_M, 0.0, 0.0), (0.0, 0.0, 0.0)),  # the equator at Greenwich
        ((0.0, A_M + 100.0, 0.0), (0.0, 90.0, 100.0)),  # 90 E, 100 m up
        ((-A_M, 0.0, 0.0), (0.0, 180.0, 0.0)),
        ((0.0, 0.0, B_M), (90.0, 0.0, 0.0)),  # the north pole
        ((0.0, 0.0, -B_M - 50.0), (-90.0, 0.0, 50.0)),
    ],
)
def test_known_points(xyz, want):
    lat, lon, h = ecef_to_geodetic(*(np.array([v]) for v in xyz))
    assert lat[0] == pytest.approx(want[0], abs=1e-12)
    assert abs((lon[0] - want[1] + 180.0) % 360.0 - 180.0) < 1e-12
    assert h[0] == pytest.approx(want[2], abs=1e-6)


def test_the_closed_form_is_undone_everywhere_on_and_near_the_ellipsoid():
    """10,000 positions over the whole Earth, 400 m below to 9 km above it: back within
    1e-11 degrees (1 micrometre) and 1 micrometre of height."""
    rng = np.random.default_rng(3)
    lat = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, 10_000)))
    lon = rng.uniform(-180.0, 180.0, 10_000)
    h = rng.uniform(-400.0, 9_000.0, 10_000)
    got_lat, got_lon, got_h = ecef_to_geodetic(*ecef(lat, lon, h))
    np.testing.assert_allclose(got_lat, lat, rtol=0, atol=1e-11)
    np.testing.assert_allclose((got_lon - lon + 180.0) % 360.0 - 180.0, 0.0, atol=1e-11)
    np.testing.assert_allclose(got_h, h, rtol=0, atol=1e-6)
    assert np.isnan(ecef_to_geodetic(np.array([np.nan]), np.zeros(1), np.zeros(1))[0]).all()


def test_the_velocity_s_local_axes():
    """At 0 N 0 E, ECEF Y is east, Z north, X up; at the north pole on the Greenwich
    meridian, -X is north and Y east. The rotation keeps a velocity's length, and a
    velocity along the local axes written in ECEF (the closed form's derivative, a small
    step of the position) comes back as it was."""
    e, n, u = ecef_to_enu_velocity(1.0, 2.0, 3.0, 0.0, 0.0)
    assert (e, n, u) == pytest.approx((2.0, 3.0, 1.0), abs=1e-15)
    e, n, u = ecef_to_enu_velocity(-1.0, 2.0, 0.0, 90.0, 0.0)
    assert (e, n, u) == pytest.approx((2.0, 1.0, 0.0), abs=1e-15)
    rng = np.random.default_rng(4)
    lat, lon = rng.uniform(-85, 85, 500), rng.uniform(-180, 180, 500)
    v = rng.normal(size=(3, 500))
    out = np.array(ecef_to_enu_velocity(v[0], v[1], v[2], lat, lon))
    np.testing.assert_allclose(np.linalg.norm(out, axis=0), np.linalg.norm(v, axis=0), rtol=1e-12)
    # 1 s of 10 m/s north and 5 m/s east at 52.4 N, 1.5 W, as the position's step
    lat0, lon0, step = 52.4, -1.5, 1.0
    m_per_deg_n = np.radians(1.0) * A_M * (1 - E2) / (1 - E2 * np.sin(np.radians(lat0)) ** 2) ** 1.5
    n_radius = A_M / np.sqrt(1 - E2 * np.sin(np.radians(lat0)) ** 2)
    m_per_deg_e = np.radians(1.0) * n_radius * np.cos(np.radians(lat0))
    a = np.array(ecef(lat0, lon0, 0.0))
    b = np.array(ecef(lat0 + 10.0 * step / m_per_deg_n, lon0 + 5.0 * step / m_per_deg_e, 0.0))
    vx, vy, vz = (b - a) / step
    e, n, u = ecef_to_enu_velocity(vx, vy, vz, lat0, lon0)
    assert (e, n, u) == pytest.approx((5.0, 10.0, 0.0), abs=1e-4)
