"""Anywhere on Earth: a drive moved anywhere keeps its segments and labels, and nothing raises.

A simulated drive (curves, a roundabout, a GNSS jump and a frozen fix to cut) is
moved with its local geometry kept: every fix is turned into east/north offsets
about the first fix (the azimuthal equidistant of :mod:`rwhonet.geo.local`, exact
from that fix) and back about a new origin. Anywhere in both hemispheres, across
the antimeridian and the prime meridian and near (not at) the poles, the domain
checks validate runs (the schema, the GNSS policy, the wheel-sensor and
plausibility checks, the swapped-coordinates and radians hypotheses, the glitch
screen) must give the same verdicts and segments, and the per-second GNSS
displacement and label must agree within ``TOL_M`` (1 mm: the projection keeps
15 m steps to ~1e-8, the rest is float rounding). The per-drive check validate
and ``rwhonet recalibrate`` run (:func:`rwhonet.data.drivechecks.check_drive`)
is run whole on the moved drives too: no problem, the same segments, cuts and
radius check, and no exception anywhere.

NO_FIX: the one place left out is a fix at exactly latitude = longitude = 0 (a
drive moved to start there, or within float rounding of it), what a receiver without
a fix writes (:func:`rwhonet.data.fixes.no_fix_rows`): validate cuts such rows
(``tests/data/test_gnss_quality.py``). Drives around that point are moved there as
anywhere else.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from rwhonet.config import SimDrive, load_params
from rwhonet.data import canonical as c
from rwhonet.data import plausibility
from rwhonet.data.drivechecks import check_drive
from rwhonet.data.glitches import glitch_rows_mask
from rwhonet.data.iovnbd import LAYOUT
from rwhonet.data.plausibility import (
    implied_radius,
    latlon_swapped_by_range,
    negative_wheel_rows,
    radians_radius,
    stuck_wheel_runs,
    swapped_radius,
    unit_mistake,
    wheel_gnss_runs,
)
from rwhonet.data.quality import assess
from rwhonet.data.schema import schema_problems
from rwhonet.features.seconds import segment_seconds
from rwhonet.features.wpm import label_m, wpm_displacement_m
from rwhonet.geo import geodesic_distance_m, latlon_from_offsets_deg, offsets_m
from rwhonet.sim import generate_route, simulate_drive, vehicles_from_params
from rwhonet.sim.drive import child_rng

TOL_M = 1e-3


@pytest.fixture(scope="module")
def setting():
    params = load_params(overrides={"sim.profile": "ci"})
    vehicle = vehicles_from_params(params)["target"]
    spec = SimDrive(
        name="W-1",
        role="target_test",
        vehicle="target",
        tyre="B",
        duration_s=150.0,
        roads={"urban": 1.0},
        events={"roundabout": 1, "sharp_turn": 1},
        gnss_faults=["jump", "frozen"],
    )
    ss = np.random.SeedSequence(3)
    route = generate_route(spec, params.sim, vehicle, child_rng(ss, 0))
    sim = simulate_drive(vehicle, spec.tyre, route, ss, params.sim, gnss_faults=spec.gnss_faults)
    frame = pd.DataFrame(
        {
            col.canonical: sim.frame[col.header].to_numpy(np.float64) * col.to_si
            for col in LAYOUT
            if col.canonical in (*c.REQUIRED, c.N_SATS, c.YAW_RATE_RAD_S)
        }
    ).assign(**{c.SCENARIO: ""})
    return params, vehicle.nominal_radius_m, frame


def relocate(frame: pd.DataFrame, lat0: float, lon0: float) -> pd.DataFrame:
    """The drive with the same east/north offsets from its first fix, about a new first fix."""
    lat, lon = frame[c.LAT_DEG].to_numpy(), frame[c.LON_DEG].to_numpy()
    east, north = offsets_m(lat[0], lon[0], lat, lon)
    new_lat, new_lon = latlon_from_offsets_deg(lat0, lon0, east, north)
    return frame.assign(**{c.LAT_DEG: new_lat, c.LON_DEG: new_lon})


def at_null_island(frame: pd.DataFrame) -> bool:
    """Whether a fix of the drive lies at exactly latitude = longitude = 0 (NO_FIX)."""
    return bool(((frame[c.LAT_DEG] == 0.0) & (frame[c.LON_DEG] == 0.0)).any())


def verdicts(params, radius: float, frame: pd.DataFrame) -> dict:
    """Everything the domain checks of validate say about a drive, and its labels."""
    vp = params.validate
    out: dict = {
        "schema": [(p.row, p.column, p.expected) for p in schema_problems(frame, vp, "W-1.csv", {})]
    }
    glitch = glitch_rows_mask(frame, radius)
    result = assess(frame, vp.gnss, vp.sample_period_s, wheel_glitch=glitch)
    out["segments"] = [(s.row_start, s.row_stop) for s in result.segments]
    out["cuts"] = [(x.start_s, x.end_s, x.rule) for x in result.cuts]
    est = implied_radius(frame, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    out["radius"] = est.radius_m
    # validate's unit check: the drive's own radius, then (only if it is implausible) the
    # swapped and radians hypotheses. Both are computed here whatever the radius, so that
    # they are seen not to raise anywhere.
    swapped = swapped_radius(frame, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    radians = radians_radius(frame, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    own = unit_mistake(est.radius_m, radius, vp.radius_tolerance)
    out["unit_verdict"] = (
        None
        if own is None
        else "swapped"
        if unit_mistake(swapped.radius_m, radius, vp.radius_tolerance) is None
        else "radians"
        if radians is not None
        and unit_mistake(radians.radius_m, radius, vp.radius_tolerance) is None
        else "unit"
    )
    out["swapped_by_range"] = latlon_swapped_by_range(frame[c.LAT_DEG], frame[c.LON_DEG])
    out["stuck"] = stuck_wheel_runs(frame, vp.wheels, vp.sample_period_s)
    out["silent"] = wheel_gnss_runs(frame, result.segments, radius, vp.wheels, 0.1)[0]
    out["stale"] = len(wheel_gnss_runs(frame, result.segments, radius, vp.wheels, 0.1)[1])
    out["negative"] = {k: list(v) for k, v in negative_wheel_rows(frame, 0.5).items()}
    seconds = []
    for seg in result.segments:
        sec = segment_seconds(frame.iloc[seg.row_start : seg.row_stop])
        wpm = wpm_displacement_m(sec.angle_rl_rad, sec.angle_rr_rad, radius, radius)
        seconds.append(
            pd.DataFrame({"gnss": sec.disp_gnss_m, "label": label_m(sec.disp_gnss_m, wpm)})
        )
    out["seconds"] = pd.concat(seconds, ignore_index=True)
    return out


@pytest.fixture(scope="module")
def home(setting):
    params, radius, frame = setting
    return verdicts(params, radius, frame)


@pytest.fixture()
def checked_geodesic(monkeypatch):
    """The plausibility checks' geodesic, refusing (as a test failure) any impossible latitude."""
    real = plausibility.geodesic_distance_m

    def strict(lat1, lon1, lat2, lon2):
        for lat in (lat1, lat2):
            assert np.all(np.abs(np.asarray(lat)[np.isfinite(lat)]) <= 90.0), "impossible latitude"
        return real(lat1, lon1, lat2, lon2)

    monkeypatch.setattr(plausibility, "geodesic_distance_m", strict)


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    lat0=st.floats(-89.9, 89.9),
    lon0=st.floats(-180.0, 180.0, exclude_max=True),
)
@example(lat0=35.68, lon0=139.77)  # Tokyo
@example(lat0=-33.87, lon0=151.21)  # Sydney
@example(lat0=37.72, lon0=-122.47)  # San Francisco, where the real drive is
@example(lat0=51.4779, lon0=-0.0005)  # across the prime meridian at Greenwich
@example(lat0=-16.8, lon0=179.9995)  # across the antimeridian (Fiji)
@example(lat0=65.0, lon0=-179.9995)  # across it the other way (Chukotka)
@example(lat0=89.9, lon0=10.0)  # 11 km from the North Pole
@example(lat0=-89.9, lon0=-70.0)  # and from the South Pole
def test_a_relocated_drive_keeps_its_segments_and_labels(
    setting, home, checked_geodesic, lat0, lon0
):
    params, radius, frame = setting
    moved = relocate(frame, lat0, lon0)
    assume(not at_null_island(moved))
    # The move keeps every 10 Hz step's length (the local geometry).
    steps = [
        geodesic_distance_m(
            f[c.LAT_DEG][:-1], f[c.LON_DEG][:-1], f[c.LAT_DEG][1:], f[c.LON_DEG][1:]
        )
        for f in (frame, moved)
    ]
    np.testing.assert_allclose(steps[1], steps[0], rtol=0, atol=1e-4)
    got = verdicts(params, radius, moved)
    keys = ("schema", "segments", "cuts", "unit_verdict", "stuck", "silent", "stale", "negative")
    for key in keys:
        assert got[key] == home[key], key
    assert got["radius"] == pytest.approx(home["radius"], rel=1e-7)
    assert got["unit_verdict"] is None and not got["swapped_by_range"]
    a, b = home["seconds"], got["seconds"]
    assert len(a) == len(b) > 60
    np.testing.assert_allclose(b["gnss"], a["gnss"], rtol=0, atol=TOL_M)
    np.testing.assert_allclose(b["label"], a["label"], rtol=0, atol=TOL_M)


def test_swapped_hypothesis_west_of_90_w_is_ruled_out_without_the_geodesic(
    setting, checked_geodesic
):
    """The crash of issue 15: a drive at 122 W whose wheels do not fit the nominal radius."""
    params, radius, frame = setting
    moved = relocate(frame, 37.72, -122.47)
    moved[list(c.WHEELS)] *= 1.3  # wheels off the nominal radius: the swap is then tried
    vp = params.validate
    result = assess(moved, vp.gnss, vp.sample_period_s)
    est = implied_radius(moved, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    assert unit_mistake(est.radius_m, radius, vp.radius_tolerance) is not None
    swapped = swapped_radius(moved, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    assert np.isnan(swapped.radius_m) and swapped.moving_s == 0
    assert unit_mistake(swapped.radius_m, radius, vp.radius_tolerance) is not None


def checked(params, frame: pd.DataFrame) -> dict:
    """What validate's per-drive check (schema, then check_drive) says about a drive."""
    entry = {
        "drive": "W-1",
        "role": "target_train",
        "vehicle": "target",
        "source_file": "W-1.csv",
        "columns": {},
    }
    found = schema_problems(frame, params.validate, "W-1.csv", {})
    problems, result, units, glitches = check_drive(params, entry, frame, found, [])
    radius_m = params.nominal_radius_m("target")
    seconds = [segment_seconds(frame.iloc[s.row_start : s.row_stop]) for s in result.segments]
    labels = [
        label_m(
            sec.disp_gnss_m, wpm_displacement_m(sec.angle_rl_rad, sec.angle_rr_rad, *2 * [radius_m])
        )
        for sec in seconds
    ]
    return {
        "problems": problems,
        "segments": [(s.row_start, s.row_stop, s.start_s, s.end_s) for s in result.segments],
        "cuts": [(x.start_s, x.end_s, x.rule) for x in result.cuts],
        "radius": units["radius"],
        "yaw_rate": units["yaw_rate"],
        "wheel_sides": units["wheel_sides"],
        "wheel_axles": units["wheel_axles"],
        "glitches": glitches,
        "gnss": np.concatenate([sec.disp_gnss_m for sec in seconds]),
        "label": np.concatenate(labels),
    }


@pytest.fixture(scope="module")
def home_checked(setting):
    params, _, frame = setting
    return checked(params, frame)


@settings(
    max_examples=15,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    lat0=st.floats(-89.9, 89.9),
    lon0=st.floats(-180.0, 180.0, exclude_max=True),
)
@example(lat0=37.72, lon0=-122.47)  # San Francisco, where the real drive is
@example(lat0=51.4779, lon0=-0.0005)  # across the prime meridian at Greenwich
@example(lat0=-16.8, lon0=179.9995)  # across the antimeridian (Fiji)
@example(lat0=89.9, lon0=10.0)  # 11 km from the North Pole
@example(lat0=-89.9, lon0=-70.0)  # and from the South Pole
def test_validate_s_per_drive_check_passes_a_relocated_drive_alike(
    setting, home_checked, checked_geodesic, lat0, lon0
):
    params, _, frame = setting
    moved = relocate(frame, lat0, lon0)
    assume(not at_null_island(moved))
    got = checked(params, moved)
    want = home_checked
    assert got["problems"] == want["problems"] == []
    assert got["segments"] == want["segments"] and got["cuts"] == want["cuts"]
    assert got["glitches"] == want["glitches"]
    assert got["radius"]["checked"] and got["radius"]["moving_s"] == want["radius"]["moving_s"]
    assert got["radius"]["implied_m"] == pytest.approx(want["radius"]["implied_m"], rel=1e-7)
    # the yaw rate's gain against the course: the same turns anywhere, the poles included
    assert got["yaw_rate"]["checked"] and want["yaw_rate"]["checked"]
    assert got["yaw_rate"]["seconds"] == want["yaw_rate"]["seconds"]
    assert got["yaw_rate"]["gain"] == pytest.approx(want["yaw_rate"]["gain"], abs=1e-6)
    # and each axle's wheels: their sides told alike (stop 72)
    assert got["wheel_sides"]["checked"] and want["wheel_sides"]["checked"]
    for axle in ("rear", "front"):
        assert got["wheel_sides"][axle]["seconds"] == want["wheel_sides"][axle]["seconds"]
        assert got["wheel_sides"][axle]["gain"] == pytest.approx(
            want["wheel_sides"][axle]["gain"], abs=1e-6
        )
    # and the front axle's wider arc in the turns (stop 74): told alike
    axles, home = got["wheel_axles"], want["wheel_axles"]
    assert axles["checked"] == home["checked"] and axles["seconds"] == home["seconds"]
    assert axles["tight_turns"] == home["tight_turns"]
    assert axles["gain"] == pytest.approx(home["gain"], rel=1e-6)
    np.testing.assert_allclose(got["gnss"], want["gnss"], rtol=0, atol=TOL_M)
    np.testing.assert_allclose(got["label"], want["label"], rtol=0, atol=TOL_M)
