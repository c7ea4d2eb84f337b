"""From a route to motion: speed planning, time sampling and pose integration.

Speed planning is the classic forward-backward pass of minimum-time speed
profiles with bounded acceleration (e.g. Lipp & Boyd 2014), written
in ``u = v^2``: under constant acceleration ``u`` is linear in distance, so
``u_i <= u_j + 2 a (s_i - s_j)`` and both passes are running minima
(``np.minimum.accumulate``) instead of loops over nodes. The result is a
piecewise constant-acceleration motion, sampled exactly at the integration
rate; poses are integrated step by step as arcs of constant curvature.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rwhonet.config import SimParams
from rwhonet.data.canonical import G_M_S2
from rwhonet.sim.vehicle import Vehicle, traction_limits_m_s2

if TYPE_CHECKING:
    from rwhonet.sim.roadgrid import Route


@dataclass(frozen=True)
class SpeedPlan:
    """Speed at each route node and when the car passes it.

    Attributes:
        v_m_s: speed at the nodes (>= 0).
        dt_s: driving time of each interval (n - 1).
        accel_m_s2: constant tangential acceleration in each interval (n - 1).
        arrival_s: time the car reaches each node.
        departure_s: time it leaves (arrival + dwell at stops).
    """

    v_m_s: np.ndarray
    dt_s: np.ndarray
    accel_m_s2: np.ndarray
    arrival_s: np.ndarray
    departure_s: np.ndarray

    @property
    def end_s(self) -> float:
        """Time the car leaves the last node (end of its final standstill)."""
        return float(self.departure_s[-1])


def friction(route: Route, sim: SimParams) -> np.ndarray:
    """Tyre-road friction coefficient per route interval.

    Args:
        route: the route (its wet intervals).
        sim: simulator settings (``friction_dry``, ``friction_wet``).

    Returns:
        Friction coefficient per node interval, (n,).
    """
    return np.where(route.wet, sim.friction_wet, sim.friction_dry)


def plan_speed(route: Route, vehicle: Vehicle, sim: SimParams) -> SpeedPlan:
    """Plan the fastest speed profile the driver accepts along ``route``.

    Constraints: the driver's wish ``v_max``; the curve limit
    ``v^2 (|kappa| + b |dkappa/ds|) <= lat_acc_max_g * g`` (the driver's limit; the lateral
    acceleration at the centre of gravity, ``b`` ahead of the rear axle;
    drivers slow down *before* curves);
    zero speed at stops; acceleration and deceleration at most the driver's
    values and at most what the tyres carry at 85 % of friction.

    Args:
        route: the route.
        vehicle: the vehicle (traction limits; its driver's lateral-acceleration limit).
        sim: simulator settings (friction).

    Returns:
        The speed plan.
    """
    ds = route.ds_m
    mu = friction(route, sim)
    a_tyre, d_tyre = traction_limits_m_s2(vehicle, mu)
    accel = np.maximum(np.minimum(route.accel_m_s2, a_tyre), 0.05)[:-1]
    decel = np.maximum(np.minimum(route.decel_m_s2, d_tyre), 0.05)[:-1]
    # The driver feels the lateral acceleration at the centre of gravity, a distance
    # b ahead of the rear axle: a_y = v r + b dr/dt = v^2 (kappa + b dkappa/ds) + b a kappa.
    # dkappa/ds is constant between nodes: a node takes the steeper of its two
    # intervals, so both ends of a clothoid ramp see the ramp's full slope.
    kappa = route.curvature_1_m
    slope = np.abs(np.diff(kappa)) / ds
    slope = np.maximum(np.concatenate([[0.0], slope]), np.concatenate([slope, [0.0]]))
    felt = np.abs(kappa) + vehicle.cg_to_rear_m * slope
    lat_limit = vehicle.params.driver.lat_acc_max_g * G_M_S2 / np.maximum(felt, 1e-9)
    u_max = np.minimum(route.v_max_m_s**2, lat_limit)
    u_max[route.stop] = 0.0

    # Forward pass: u_i <= u_j + 2 (A_i - A_j) for every j <= i.
    a_cum = np.concatenate([[0.0], np.cumsum(2.0 * accel * ds)])
    u = a_cum + np.minimum.accumulate(u_max - a_cum)
    # Backward pass: u_i <= u_j + 2 (D_j - D_i) for every j >= i.
    d_cum = np.concatenate([[0.0], np.cumsum(2.0 * decel * ds)])
    u = np.minimum.accumulate((u + d_cum)[::-1])[::-1] - d_cum
    v = np.sqrt(np.maximum(u, 0.0))
    v[route.stop] = 0.0

    pair = v[:-1] + v[1:]
    # Constant acceleration: ds = (v_i + v_{i+1}) / 2 * dt. Rest-to-rest over one
    # step (never produced by route building) takes 2 sqrt(ds / a).
    dt = np.where(pair > 1e-9, 2.0 * ds / np.maximum(pair, 1e-9), 2.0 * np.sqrt(ds / accel))
    acc = (v[1:] - v[:-1]) / dt
    arrival = np.concatenate([[0.0], np.cumsum(dt + route.dwell_s[:-1])])
    return SpeedPlan(v, dt, acc, arrival, arrival + route.dwell_s)


@dataclass(frozen=True)
class Motion:
    """The car's motion sampled at the integration rate.

    Attributes:
        t_s: time since the start of the recording.
        s_m: travelled distance (forwards and backwards alike).
        speed_m_s: speed of the rear-axle centre (>= 0).
        accel_m_s2: tangential acceleration along the direction of travel.
        curvature_1_m: path curvature, left positive.
        direction: +1 forwards, -1 reversing.
        wet: on a wet road.
        interval: index of the route interval the sample lies in.
    """

    t_s: np.ndarray
    s_m: np.ndarray
    speed_m_s: np.ndarray
    accel_m_s2: np.ndarray
    curvature_1_m: np.ndarray
    direction: np.ndarray
    wet: np.ndarray
    interval: np.ndarray

    @property
    def velocity_m_s(self) -> np.ndarray:
        """Signed longitudinal velocity of the rear-axle centre (negative reversing)."""
        return self.direction * self.speed_m_s

    @property
    def yaw_rate_rad_s(self) -> np.ndarray:
        """Yaw rate ``r = v kappa`` (counter-clockwise positive)."""
        return self.velocity_m_s * self.curvature_1_m


def sample_motion(route: Route, plan: SpeedPlan, hz: int, n_samples: int) -> Motion:
    """Sample the planned motion at ``hz`` (exact for constant acceleration).

    Args:
        route: the route.
        plan: its speed plan.
        hz: sampling rate.
        n_samples: number of samples (from t = 0); after the plan ends the car stands.

    Returns:
        The motion.
    """
    t = np.arange(n_samples) / hz
    last = route.n - 2
    idx = np.clip(np.searchsorted(plan.departure_s, t, side="right") - 1, 0, last)
    since = t - plan.departure_s[idx]
    tau = np.clip(since, 0.0, plan.dt_s[idx])
    v0 = plan.v_m_s[idx]
    a = plan.accel_m_s2[idx]
    s = idx * route.ds_m + v0 * tau + 0.5 * a * tau**2
    speed = np.maximum(v0 + a * tau, 0.0)
    moving = (since >= 0.0) & (since < plan.dt_s[idx])
    s_nodes = route.s_m
    return Motion(
        t_s=t,
        s_m=s,
        speed_m_s=speed,
        accel_m_s2=np.where(moving, a, 0.0),
        curvature_1_m=np.interp(s, s_nodes, route.curvature_1_m),
        direction=route.direction[idx].astype(np.float64),
        wet=route.wet[idx],
        interval=idx,
    )


@dataclass(frozen=True)
class Pose:
    """Pose of the rear-axle centre in a local east/north frame (m, rad from east)."""

    east_m: np.ndarray
    north_m: np.ndarray
    heading_rad: np.ndarray

    def point(self, x_body_m: float, y_body_m: float) -> tuple[np.ndarray, np.ndarray]:
        """East/north position of a point fixed on the body.

        Args:
            x_body_m: ahead of the rear-axle centre.
            y_body_m: left of it.

        Returns:
            ``(east_m, north_m)`` at every sample.
        """
        c, s = np.cos(self.heading_rad), np.sin(self.heading_rad)
        return (
            self.east_m + c * x_body_m - s * y_body_m,
            self.north_m + s * x_body_m + c * y_body_m,
        )


def integrate_pose(
    route: Route, motion: Motion, east0_m: float, north0_m: float, heading0_rad: float
) -> Pose:
    """Integrate the rear-axle-centre pose, one arc of constant curvature per step.

    Heading: ``dpsi = sigma kappa ds`` (``sigma`` = direction), with the
    curvature integral ``K(s)`` taken on the route grid. Position: each step is
    the chord of its arc, ``ds sinc(dpsi / 2)`` long, along the mean heading
    (backwards when reversing), so the path length equals the travelled
    distance up to round-off.

    Args:
        route: the route (curvature on its grid).
        motion: the sampled motion.
        east0_m: initial east position.
        north0_m: initial north position.
        heading0_rad: initial heading, counter-clockwise from east.

    Returns:
        The pose at every motion sample.
    """
    k = route.curvature_1_m
    k_cum = np.concatenate([[0.0], np.cumsum(0.5 * (k[:-1] + k[1:]) * route.ds_m)])
    k_t = np.interp(motion.s_m, route.s_m, k_cum)
    sigma = motion.direction[1:]  # the step k -> k+1 lies in sample k+1's interval
    d_psi = sigma * np.diff(k_t)
    d_s = np.diff(motion.s_m)
    heading = heading0_rad + np.concatenate([[0.0], np.cumsum(d_psi)])
    mid = heading[:-1] + 0.5 * d_psi
    chord = sigma * d_s * np.sinc(d_psi / (2.0 * np.pi))  # np.sinc(x) = sin(pi x) / (pi x)
    east = east0_m + np.concatenate([[0.0], np.cumsum(chord * np.cos(mid))])
    north = north0_m + np.concatenate([[0.0], np.cumsum(chord * np.sin(mid))])
    return Pose(east, north, heading)


def body_point_velocity(
    motion: Motion, pose: Pose, x_body_m: float, y_body_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """East/north velocity of a point fixed on the body (rigid-body kinematics).

    In the body frame the point moves at ``(v - r y, r x)``; rotated by the heading.

    Args:
        motion: the motion.
        pose: the pose.
        x_body_m: point ahead of the rear-axle centre.
        y_body_m: point left of it.

    Returns:
        ``(v_east_m_s, v_north_m_s)``.
    """
    r = motion.yaw_rate_rad_s
    vx = motion.velocity_m_s - r * y_body_m
    vy = r * x_body_m
    c, s = np.cos(pose.heading_rad), np.sin(pose.heading_rad)
    return c * vx - s * vy, s * vx + c * vy


def cg_acceleration(motion: Motion, hz: int, cg_to_rear_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame acceleration of the centre of gravity.

    For a point ``b`` ahead of the rear-axle centre: ``a_x = dv/dt - r^2 b``,
    ``a_y = v r + (dr/dt) b`` (``dr/dt`` by central differences).

    Args:
        motion: the motion.
        hz: its sampling rate.
        cg_to_rear_m: distance from the rear axle to the centre of gravity.

    Returns:
        ``(a_x_m_s2, a_y_m_s2)``.
    """
    r = motion.yaw_rate_rad_s
    r_dot = np.gradient(r, 1.0 / hz) if r.size > 1 else np.zeros_like(r)
    ax = motion.direction * motion.accel_m_s2 - r**2 * cg_to_rear_m
    ay = motion.velocity_m_s * r + r_dot * cg_to_rear_m
    return ax, ay
