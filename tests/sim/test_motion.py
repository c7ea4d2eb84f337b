"""Speed planning, time sampling and pose integration."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data.canonical import G_M_S2
from rwhonet.sim import steady_turn_route, straight_route
from rwhonet.sim.motion import integrate_pose, plan_speed, sample_motion
from rwhonet.sim.route import generate_route

from .conftest import drive_spec


@pytest.fixture(scope="module")
def planned(params, source):
    spec = drive_spec(
        duration_s=900.0,
        roads={"urban": 0.5, "country": 0.3, "motorway": 0.2},
        events={"roundabout": 3, "sharp_turn": 3, "successive_turns": 2, "reversing": 2},
        wet_fraction=0.3,
    )
    route = generate_route(spec, params.sim, source, np.random.default_rng(3))
    plan = plan_speed(route, source, params.sim)
    return route, plan


def test_plan_respects_every_constraint(planned, params, source):
    route, plan = planned
    v = plan.v_m_s
    assert np.all(v <= route.v_max_m_s + 1e-9)
    assert np.all(v[route.stop] == 0.0)
    assert np.all(v[~route.stop] > 0.0)
    accel = plan.accel_m_s2
    assert np.all(accel <= route.accel_m_s2[:-1] + 1e-6)
    assert np.all(-accel <= route.decel_m_s2[:-1] + 1e-6)
    # Curve limit on the rear-axle path: v^2 |kappa| <= the driver's lat_acc_max_g g at every node.
    limit = source.params.driver.lat_acc_max_g * G_M_S2
    assert np.max(v**2 * np.abs(route.curvature_1_m)) <= limit + 1e-9
    # Driving time of an interval matches its length at the mean of its end speeds.
    np.testing.assert_allclose(0.5 * (v[:-1] + v[1:]) * plan.dt_s, route.ds_m, rtol=1e-9)


def test_direction_changes_only_at_stops(planned):
    route, _ = planned
    change = np.flatnonzero(np.diff(route.direction[:-1]) != 0) + 1
    assert change.size >= 4  # two reversing manoeuvres, each in and out
    assert np.all(route.stop[change])


def test_generated_route_lasts_exactly_the_drive(planned, params, source):
    route, plan = planned
    assert route.duration_s == 900.0
    assert plan.end_s == pytest.approx(900.0)


def test_sampling_is_exact_constant_acceleration(params, source):
    route = straight_route(20.0, 60.0, accel_m_s2=2.0)
    plan = plan_speed(route, source, params.sim)
    motion = sample_motion(route, plan, 50, 3001)
    assert np.allclose(np.diff(motion.t_s), 0.02)
    # From rest at 2 m/s^2: v = 2 t, s = t^2 until 20 m/s (t = 10 s).
    early = motion.t_s <= 9.9
    np.testing.assert_allclose(motion.speed_m_s[early], 2.0 * motion.t_s[early], atol=1e-9)
    np.testing.assert_allclose(motion.s_m[early], motion.t_s[early] ** 2, atol=1e-9)
    late = motion.t_s > 10.5
    np.testing.assert_allclose(motion.speed_m_s[late], 20.0, atol=1e-9)
    assert np.all(motion.accel_m_s2[late] == 0.0)


def test_pose_follows_a_circle_and_its_length_is_the_distance(params, source):
    radius = 30.0
    route = steady_turn_route(radius, 8.0, 120.0)
    plan = plan_speed(route, source, params.sim)
    motion = sample_motion(route, plan, 50, 6001)
    pose = integrate_pose(route, motion, 0.0, 0.0, 0.0)
    # Heading 0 (east), turning left: the centre is at (0, R).
    dist_to_centre = np.hypot(pose.east_m, pose.north_m - radius)
    np.testing.assert_allclose(dist_to_centre, radius, atol=2e-3)
    path = np.hypot(np.diff(pose.east_m), np.diff(pose.north_m)).sum()
    assert path == pytest.approx(motion.s_m[-1], rel=1e-5)
    np.testing.assert_allclose(pose.heading_rad, motion.s_m / radius, atol=1e-3)


def test_reversing_moves_the_car_backwards(params, source):
    # A reversing block: the rear axle moves opposite to the body heading.
    spec = drive_spec(duration_s=200.0, roads={"urban": 1.0}, events={"reversing": 2})
    route = generate_route(spec, params.sim, source, np.random.default_rng(5))
    plan = plan_speed(route, source, params.sim)
    motion = sample_motion(route, plan, 50, 10001)
    pose = integrate_pose(route, motion, 0.0, 0.0, 0.3)
    back = (motion.direction[1:] < 0) & (np.diff(motion.s_m) > 0)
    assert back.sum() > 50
    step = np.stack([np.diff(pose.east_m), np.diff(pose.north_m)])[:, back]
    forward = np.stack([np.cos(pose.heading_rad[1:]), np.sin(pose.heading_rad[1:])])[:, back]
    assert np.all((step * forward).sum(axis=0) < 0)


def test_each_car_has_its_own_driver(params, vehicles):
    # The CUPAC car's driver (target) cruises a little slower, accelerates and
    # brakes a little harder and accepts less lateral acceleration in curves.
    spec = drive_spec(duration_s=900.0, roads={"country": 1.0})
    plans = {}
    for name in ("source", "target"):
        car = vehicles[name]
        route = generate_route(spec, params.sim, car, np.random.default_rng(8))
        plan = plan_speed(route, car, params.sim)
        driver, road = car.params.driver, params.sim.roads["country"]
        assert np.isclose(route.accel_m_s2, road.accel_m_s2 * driver.accel_factor).mean() > 0.8
        assert np.isclose(route.decel_m_s2, road.decel_m_s2 * driver.decel_factor).mean() > 0.8
        limit = driver.lat_acc_max_g * G_M_S2
        assert np.max(plan.v_m_s**2 * np.abs(route.curvature_1_m)) <= limit + 1e-9
        plans[name] = route
    ratio = np.median(plans["target"].v_max_m_s) / np.median(plans["source"].v_max_m_s)
    drivers = {name: vehicles[name].params.driver for name in plans}
    factor = drivers["target"].speed_factor / drivers["source"].speed_factor
    assert ratio == pytest.approx(factor, abs=0.04)
