"""The other IO-VNBD channels: vehicle CAN signals filled plausibly from the ground truth.

These channels are not used by the pipeline (only wheel speeds, time, position
and satellites are), but a simulated file should look like a real one: each
is derived from the same motion, with small sensor noise. Sign conventions:
lateral acceleration positive to the left; accelerations in g. The yaw rate is
not filled here: it is the ESC gyro's model (:func:`rwhonet.sim.sensors.yaw_rate_sensor`).
"""

from __future__ import annotations

import numpy as np

from rwhonet.data.canonical import G_M_S2
from rwhonet.sim.vehicle import FRONT, Vehicle

# Filler-channel constants (plausible values for a small petrol car; not used downstream).
_SHIFT_UP_KMH = (15.0, 30.0, 45.0, 65.0)  # upshift speeds 1->2, 2->3, 3->4, 4->5
_POWER_W_PER_KG = 60.0  # peak power / mass
_MAX_ACCEL_M_S2 = 4.0  # full-throttle acceleration at low speed
_PSI_PER_G = 1400.0  # brake line pressure per g of braking
_HOLD_PSI = 200.0  # foot on the brake while standing
_HANDBRAKE_AFTER_S = 20.0  # standstills longer than this use the handbrake
_CLUTCH_SHIFT_S = 0.4


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each sample: index of its run of equal mask values, that run's start and end."""
    change = np.flatnonzero(np.diff(mask.astype(np.int8))) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [mask.size]])
    run = np.repeat(np.arange(starts.size), ends - starts)
    return run, starts[run], ends[run]


def can_channels(
    vehicle: Vehicle,
    hz: int,
    speed_m_s: np.ndarray,
    accel_m_s2: np.ndarray,
    direction: np.ndarray,
    curvature_1_m: np.ndarray,
    accel_x_cg_m_s2: np.ndarray,
    accel_y_cg_m_s2: np.ndarray,
    omega_true_rad_s: np.ndarray,
    omega_can_rad_s: np.ndarray,
    air_density_kg_m3: float,
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """CAN channels at the record rate, keyed by canonical-ish names.

    Args:
        vehicle: the vehicle.
        hz: record rate.
        speed_m_s: speed (>= 0).
        accel_m_s2: tangential acceleration along the direction of travel.
        direction: +1 forwards, -1 reversing.
        curvature_1_m: path curvature.
        accel_x_cg_m_s2: body longitudinal acceleration of the centre of gravity.
        accel_y_cg_m_s2: body lateral acceleration of the centre of gravity.
        omega_true_rad_s: true wheel speeds (4, m).
        omega_can_rad_s: CAN wheel speeds (4, m).
        air_density_kg_m3: air density.
        rng: random generator.

    Returns:
        Arrays (m,) for steering_deg, indicated_speed_kmh,
        acc_lon_g, acc_lat_g, handbrake, gear, engine_rpm, coolant_c, clutch,
        brake_psi, brake_on, battery_v, air_c, pedal_pct.
    """
    p = vehicle.params
    m = speed_m_s.size
    t = np.arange(m) / hz
    still = speed_m_s < 0.05
    out: dict[str, np.ndarray] = {}
    out["steering_deg"] = p.steering_ratio * np.degrees(np.arctan(p.wheelbase_m * curvature_1_m))
    out["steering_deg"] += rng.standard_normal(m) * 0.1
    # The yaw rate is the ESC gyro's (sensors.yaw_rate_sensor, on a stream of its own). These
    # draws are what the filler yaw rate once took: the channels below keep their values.
    rng.standard_normal(m + 1)
    out["indicated_speed_kmh"] = omega_can_rad_s.mean(axis=0) * vehicle.nominal_radius_m * 3.6
    out["acc_lon_g"] = accel_x_cg_m_s2 / G_M_S2 + rng.normal(0.0, 0.005, m)
    out["acc_lat_g"] = accel_y_cg_m_s2 / G_M_S2 + rng.normal(0.0, 0.005, m)

    _, start, end = _runs(still)
    long_stop = still & ((end - start) / hz > _HANDBRAKE_AFTER_S)
    handbrake = long_stop & ((t - start / hz) > 3.0) & ((end / hz - t) > 2.0)
    out["handbrake"] = handbrake.astype(np.int64)

    kmh = speed_m_s * 3.6
    gear = 1 + np.searchsorted(np.asarray(_SHIFT_UP_KMH), kmh, side="right")
    gear = np.where((direction < 0) | still, 1, np.minimum(gear, len(p.gear_ratios)))
    out["gear"] = gear.astype(np.int64)
    driven = FRONT if p.drive == "fwd" else ~FRONT
    ratio = np.asarray(p.gear_ratios)[gear - 1] * p.final_drive
    rpm = omega_true_rad_s[driven].mean(axis=0) * ratio * 60.0 / (2.0 * np.pi)
    out["engine_rpm"] = np.clip(rpm, p.idle_rpm, 6000.0) + rng.normal(0.0, 10.0, m)
    shift = np.concatenate([[0], np.diff(gear) != 0]).astype(np.float64)
    after_shift = np.convolve(shift, np.ones(int(_CLUTCH_SHIFT_S * hz)))[:m] > 0
    out["clutch"] = (still | after_shift).astype(np.int64)

    air_c = rng.uniform(4.0, 22.0)
    coolant0 = rng.uniform(air_c, 90.0)
    out["coolant_c"] = 90.0 - (90.0 - coolant0) * np.exp(-t / 400.0)
    out["air_c"] = air_c + 0.5 * np.sin(2.0 * np.pi * t / max(t[-1] if m else 1.0, 1.0))

    moving = (~still).astype(np.float64)
    drag = 0.5 * air_density_kg_m3 * p.drag_area_m2 * speed_m_s**2
    mass = vehicle.mass_kg
    propulsive = mass * (accel_m_s2 + p.tyre.rolling_resistance * G_M_S2 * moving) + drag
    brake_psi = np.maximum(-propulsive, 0.0) / (mass * G_M_S2) * _PSI_PER_G
    brake_psi = np.where(still & ~handbrake, _HOLD_PSI, brake_psi)
    out["brake_psi"] = brake_psi
    out["brake_on"] = (brake_psi > 15.0).astype(np.int64)
    # The engine's force does not grow with the payload: scale by the unladen mass.
    max_force = np.minimum(
        p.mass_kg * _MAX_ACCEL_M_S2,
        _POWER_W_PER_KG * p.mass_kg / np.maximum(speed_m_s, 0.1),
    )
    out["pedal_pct"] = np.clip(100.0 * propulsive / max_force, 0.0, 100.0) * moving
    out["battery_v"] = 14.2 + rng.normal(0.0, 0.03, m)
    return out
