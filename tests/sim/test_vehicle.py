"""Tyre and wheel physics: known values and properties."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import ConfigError
from rwhonet.data.canonical import G_M_S2
from rwhonet.sim.vehicle import (
    FRONT,
    P_ATM_PSI,
    T_COLD_K,
    effective_radius_m,
    per_wheel,
    slip_ratio,
    traction_limits_m_s2,
    tyre_pressure_psi,
    tyre_temperature_rise_k,
    vertical_stiffness_n_m,
    wheel_forces,
    wheel_ground_speeds,
    wheel_loads,
    wheel_states,
)

from .conftest import with_params


def nominal_radius(vehicle, **kw):
    tyre = vehicle.params.tyre
    args = dict(
        pressure_psi=tyre.reference_pressure_psi,
        tread_mm=tyre.new_tread_mm,
        load_n=vehicle.static_wheel_load_n[2],
        speed_m_s=0.0,
    )
    args.update(kw)
    return float(effective_radius_m(vehicle, **args))


@pytest.mark.parametrize("name", ["fiesta", "fiesta_cupac", "focus"])
def test_radius_at_reference_conditions_is_the_nominal_radius(cars, name):
    # The spec-sheet radius, shifted by the car's own tyres (brand, manufacturing spread).
    vehicle = cars[name]
    offset = vehicle.params.tyre.free_radius_offset_mm * 1e-3
    assert nominal_radius(vehicle) == pytest.approx(vehicle.nominal_radius_m + offset, abs=1e-12)


def test_radius_known_values(source):
    tyre = source.params.tyre
    r = nominal_radius(source)
    # Worn tread: the free radius shrinks one-for-one (3 mm of wear -> 3 mm).
    assert r - nominal_radius(source, tread_mm=tyre.new_tread_mm - 3.0) == pytest.approx(3e-3)
    # Centrifugal growth at v = V_0 is q_V1 * R_0.
    growth = nominal_radius(source, speed_m_s=tyre.speed_growth_ref_m_s) - r
    assert growth == pytest.approx(tyre.speed_growth_coeff * source.unloaded_radius_new_m)
    # Half the pressure: stiffness falls by p_Fz1 / 2; r_e drops by a third of the extra deflection.
    p_half = tyre.reference_pressure_psi / 2
    c_half = tyre.vertical_stiffness_n_m * (1 - tyre.stiffness_pressure_coeff / 2)
    assert float(vertical_stiffness_n_m(source, p_half)) == pytest.approx(c_half)
    load = source.static_wheel_load_n[2]
    drop = (load / c_half - load / tyre.vertical_stiffness_n_m) / 3
    assert r - nominal_radius(source, pressure_psi=p_half) == pytest.approx(drop)


@pytest.mark.parametrize("name", ["fiesta", "fiesta_cupac", "focus"])
def test_radius_stays_within_validate_tolerance(cars, params, name):
    # validate checks GNSS speed / wheel speed within +-5 % of the nominal radius:
    # every tyre state, cold or fully warm, 0-35 m/s, and wheel loads from 50 % to
    # 150 % of static with the heaviest payload of any drive (a front wheel braking
    # at 0.7 g in a 0.4 g curve carries ~150 %) stay inside.
    drives = [d for prof in params.sim.profiles.values() for d in prof.drives]
    heaviest = max(drives, key=lambda d: d.payload_kg)
    vehicle = cars[name]
    laden = vehicle.with_payload(heaviest.payload_kg, heaviest.payload_x_m).static_wheel_load_n
    load = laden[:, None, None] * np.linspace(0.5, 1.5, 6)[None, :, None]
    speed = np.linspace(0.0, 35.0, 8)[None, None, :]
    hot = tyre_temperature_rise_k(vehicle, np.full(2000, 35.0), 10.0)[-1]
    for state in vehicle.params.tyre_states.values():
        cold = per_wheel(state.pressure_psi)
        for pressure in (cold, tyre_pressure_psi(cold, [0.0], [hot], np.zeros(4))[:, 0]):
            r = effective_radius_m(
                vehicle,
                pressure[:, None, None],
                per_wheel(state.tread_mm)[:, None, None],
                load,
                speed,
            )
            rel = r / vehicle.nominal_radius_m - 1
            assert np.abs(rel).max() < params.validate.radius_tolerance


def test_lower_pressure_and_more_load_give_a_smaller_radius(source):
    p = np.array([14.0, 20.0, 26.0, 32.0, 38.0])
    assert np.all(np.diff(effective_radius_m(source, p, 8.0, 2500.0, 10.0)) > 0)
    loads = np.array([1000.0, 2000.0, 3000.0, 4000.0])
    assert np.all(np.diff(effective_radius_m(source, 30.0, 8.0, loads, 10.0)) < 0)


def test_slip_is_linear_for_small_forces_and_saturates_near_friction():
    load, mu, c = 3000.0, 0.9, 25.0
    # Linear region: kappa = F / (C F_z).
    assert slip_ratio(30.0, load, mu, c) == pytest.approx(30.0 / (c * load), rel=1e-4)
    assert slip_ratio(-30.0, load, mu, c) == pytest.approx(-30.0 / (c * load), rel=1e-4)
    # Near the friction limit the same force needs more slip: artanh(u) / u = 1.37 at u = 0.8.
    dry = slip_ratio(0.8 * mu * load, load, mu, c)
    assert dry == pytest.approx(np.arctanh(0.8) / 0.8 * 0.8 * mu / c)
    # A wet road (lower friction and slip stiffness) needs more slip for the same force.
    f = 0.5 * mu * load
    assert slip_ratio(f, load, 0.6, 0.8 * c) > slip_ratio(f, load, mu, c) * 1.25


def test_wheel_ground_speeds_in_a_steady_turn(source):
    p = source.params
    v, radius = 8.0, 20.0
    ground, steer = wheel_ground_speeds(source, np.array([v]), np.array([1.0 / radius]))
    fl, fr, rl, rr = ground[:, 0]
    yaw = v / radius
    # Rear wheels: v -+ r t/2, so the outer wheel is faster by the track/radius ratio.
    assert rr - rl == pytest.approx(yaw * p.track_rear_m)
    assert rr / rl == pytest.approx((radius + p.track_rear_m / 2) / (radius - p.track_rear_m / 2))
    # Front wheels roll along their velocity (Ackermann).
    assert fl == pytest.approx(np.hypot(v - yaw * p.track_front_m / 2, yaw * p.wheelbase_m))
    assert fr == pytest.approx(np.hypot(v + yaw * p.track_front_m / 2, yaw * p.wheelbase_m))
    assert steer[0, 0] > steer[1, 0] > 0.0  # the inner front wheel steers more
    assert steer[2, 0] == steer[3, 0] == 0.0
    # Straight ahead every wheel moves at v.
    straight, _ = wheel_ground_speeds(source, np.array([v]), np.array([0.0]))
    np.testing.assert_allclose(straight[:, 0], v)


def test_load_transfer_conserves_weight_and_moments(source):
    p = source.params
    ax, ay = np.array([3.0, 0.0]), np.array([0.0, 4.0])
    loads = wheel_loads(source, ax, ay)
    np.testing.assert_allclose(loads.sum(axis=0), p.mass_kg * G_M_S2)
    static_front = source.static_wheel_load_n[:2].sum()
    # Accelerating moves m a h / L from the front axle to the rear.
    assert static_front - loads[:2, 0].sum() == pytest.approx(
        p.mass_kg * 3.0 * p.cg_height_m / p.wheelbase_m
    )
    # Turning left loads the right wheels: total roll moment = m a_y h.
    moment = (loads[1, 1] - loads[0, 1]) * p.track_front_m / 2 + (
        loads[3, 1] - loads[2, 1]
    ) * p.track_rear_m / 2
    assert moment == pytest.approx(p.mass_kg * 4.0 * p.cg_height_m)


def test_forces_sum_to_mass_times_acceleration_plus_drag(source, params):
    p = source.params
    v = np.array([0.0, 10.0, 20.0, 20.0])
    a = np.array([1.0, 2.0, 0.0, -5.0])
    loads = wheel_loads(source, a, np.zeros(4))
    forces = wheel_forces(source, loads, v, a, params.sim.air_density_kg_m3)
    drag = 0.5 * params.sim.air_density_kg_m3 * p.drag_area_m2 * v**2
    np.testing.assert_allclose(forces.sum(axis=0), p.mass_kg * a + drag)
    # Traction: a FWD car pushes with its front wheels; the rear only roll (resist).
    assert np.all(forces[FRONT][:, 1] > 0) and np.all(forces[~FRONT][:, 1] < 0)
    # Hard braking: the rear share never exceeds the rear axle's load share (EBD).
    rear_share = forces[2:, 3].sum() / forces[:, 3].sum()
    assert rear_share <= loads[2:, 3].sum() / loads[:, 3].sum() + 1e-3


def test_traction_limits(source):
    accel, decel = traction_limits_m_s2(source, np.array([0.9, 0.6]))
    assert decel == pytest.approx(0.85 * np.array([0.9, 0.6]) * G_M_S2)
    assert np.all(accel < decel)  # one driven axle carries less than four braked wheels


def _steady_state(vehicle, accel, mu=0.9, **kw):
    n = 3
    return wheel_states(
        vehicle,
        vehicle.tyre_state("E"),
        np.full(n, 15.0),
        np.full(n, accel),
        np.zeros(n),
        np.full(n, accel),
        np.zeros(n),
        np.full(n, mu),
        np.ones(n),
        1.2,
        **kw,
    )


def test_driven_axle_spins_faster_under_traction(source):
    w = _steady_state(source, 2.0)
    assert np.all(w.slip[FRONT] > 0.005)
    assert np.all(w.omega_rad_s[FRONT] * w.radius_m[FRONT] > w.ground_speed_m_s[FRONT])
    assert np.all(w.slip[~FRONT] < 0)  # undriven wheels only resist rolling
    rwd = _steady_state(with_params(source, drive="rwd"), 2.0)
    assert np.all(rwd.slip[~FRONT] > 0.005) and np.all(rwd.slip[FRONT] < 0)


def test_all_wheels_lag_under_braking_more_when_wet(source):
    dry = _steady_state(source, -5.0)
    assert np.all(dry.slip < -0.005)
    assert np.all(dry.omega_rad_s * dry.radius_m < dry.ground_speed_m_s)
    wet = _steady_state(source, -5.0, mu=0.6)
    assert np.all(wet.slip < dry.slip)


def test_without_slip_omega_times_radius_is_the_ground_speed(source):
    w = _steady_state(source, 2.0, slip=False)
    np.testing.assert_allclose(w.omega_rad_s * w.radius_m, w.ground_speed_m_s, rtol=1e-12)


def test_unknown_tyre_state_is_a_config_error(source):
    with pytest.raises(ConfigError, match="tyre_states"):
        source.tyre_state("Z")


def test_tyre_air_warms_up_like_a_first_order_lag_and_cools_when_parked(source):
    tyre = source.params.tyre
    dt = 1.0
    speed = np.concatenate([np.full(3600, tyre.warm_ref_speed_m_s), np.zeros(3600)])
    rise = tyre_temperature_rise_k(source, speed, dt)
    tau = int(tyre.warm_tau_s)
    # At the reference speed the rise tends to warm_rise_k with time constant warm_tau_s.
    assert rise[tau - 1] == pytest.approx(tyre.warm_rise_k * (1 - np.exp(-1)), rel=1e-3)
    assert rise[3599] == pytest.approx(tyre.warm_rise_k, rel=1e-3)
    # Parked, it cools back towards ambient the same way.
    assert rise[3600 + tau - 1] == pytest.approx(tyre.warm_rise_k * np.exp(-1), rel=2e-3)
    # Faster driving: a hotter tyre (equilibrium ~ sqrt(v)).
    fast = tyre_temperature_rise_k(source, np.full(3600, 4 * tyre.warm_ref_speed_m_s), dt)
    assert fast[-1] == pytest.approx(2 * tyre.warm_rise_k, rel=1e-3)


def test_gas_law_and_leaks_set_the_pressure():
    cold = np.array([33.0, 33.0, 30.0, 30.0])
    t = np.array([0.0, 1800.0, 3600.0])
    rise = np.array([0.0, 20.0, 20.0])
    leak = np.array([0.0, 0.0, 4.0 / 3600.0, 0.0])  # rear left: 4 psi per hour
    p = tyre_pressure_psi(cold, t, rise, leak)
    np.testing.assert_allclose(p[:, 0], cold)
    warm = (30.0 + P_ATM_PSI) * (T_COLD_K + 20.0) / T_COLD_K - P_ATM_PSI
    assert p[3, 1] == pytest.approx(warm)  # +3.1 psi: about +10 % of the gauge pressure
    assert warm / 30.0 - 1 == pytest.approx(0.103, abs=0.002)
    leaked = (26.0 + P_ATM_PSI) * (T_COLD_K + 20.0) / T_COLD_K - P_ATM_PSI
    assert p[2, 2] == pytest.approx(leaked)
    assert tyre_pressure_psi(cold, [1e6], [0.0], leak)[2, 0] == pytest.approx(0.0, abs=1e-9)


def test_payload_loads_the_axles_by_moment_balance_and_shrinks_the_radius(source):
    p = source.params
    laden = source.with_payload(150.0, 0.3)  # two passengers on the rear bench
    assert laden.static_wheel_load_n.sum() == pytest.approx((p.mass_kg + 150.0) * G_M_S2)
    extra = laden.static_wheel_load_n - source.static_wheel_load_n
    rear_share = 1.0 - 0.3 / p.wheelbase_m
    np.testing.assert_allclose(extra[2:], 150.0 * G_M_S2 * rear_share / 2.0)
    np.testing.assert_allclose(extra[:2], 150.0 * G_M_S2 * (1.0 - rear_share) / 2.0)
    assert laden.unloaded_radius_new_m == source.unloaded_radius_new_m  # same tyres
    state = source.tyre_state("E")
    pressure, tread = per_wheel(state.pressure_psi), per_wheel(state.tread_mm)
    r0 = effective_radius_m(source, pressure, tread, source.static_wheel_load_n, 0.0)
    r1 = effective_radius_m(laden, pressure, tread, laden.static_wheel_load_n, 0.0)
    # The rear tyres deflect by the extra load over their stiffness; r_e drops by a third of it.
    drop = extra / vertical_stiffness_n_m(source, pressure) / 3.0
    np.testing.assert_allclose(r0 - r1, drop, rtol=1e-9)
    assert -0.5 < 100 * (r1[2] / r0[2] - 1) < -0.2  # percent, rear wheels
