"""Vehicle and tyre physics: wheel ground speeds, loads, forces, slip and rolling radius.

Everything here is vectorised over time samples; per-wheel arrays have shape
``(4, n)`` in the order of :data:`WHEELS` (front left, front right, rear left,
rear right). Body frame: x forward, y left, origin at the rear-axle centre
(the reference point of the kinematic bicycle model). Models and parameter
sources are in docs/simulator.md.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.signal import lfilter

from rwhonet.config import ConfigError, SimTyreState, SimVehicle, SimWheels
from rwhonet.data.canonical import G_M_S2

WHEELS = ("fl", "fr", "rl", "rr")
FRONT = np.array([True, True, False, False])
LEFT = np.array([True, False, True, False])

# A tyre cannot carry more than mu * F_z; utilisation is clipped below 1 so that
# artanh stays finite (the planner keeps utilisation <= 0.85 anyway).
MAX_UTILISATION = 0.95


@dataclass(frozen=True)
class Vehicle:
    """A simulated vehicle: its name, nominal radius, physical parameters and payload.

    Attributes:
        name: key in ``sim.vehicles``.
        nominal_radius_m: spec-sheet effective rolling radius of a rear tyre at the
            reference pressure, new tread, static load without payload and walking
            speed (``sim.vehicles.<name>.nominal_radius_m``).
        params: the ``sim.vehicles.<name>`` section.
        payload_kg: passengers and luggage besides the driver (0: as configured).
        payload_x_m: their centre of mass ahead of the rear axle (the boot: negative).
        receiver: the ``sim.receivers`` grade fitted in place of the car's own GNSS
            receiver (``params.gnss`` is then that grade), or None.
    """

    name: str
    nominal_radius_m: float
    params: SimVehicle
    payload_kg: float = 0.0
    payload_x_m: float = 0.0
    receiver: str | None = None

    def with_payload(self, payload_kg: float, payload_x_m: float) -> Vehicle:
        """The same car carrying a payload (its tyres keep their free radius).

        Args:
            payload_kg: passengers and luggage, kg.
            payload_x_m: their centre of mass ahead of the rear axle, m.

        Returns:
            The laden vehicle.
        """
        return replace(self, payload_kg=float(payload_kg), payload_x_m=float(payload_x_m))

    @property
    def mass_kg(self) -> float:
        """Mass with payload (kg)."""
        return self.params.mass_kg + self.payload_kg

    @property
    def front_load_fraction(self) -> float:
        """Static share of the weight on the front axle, with payload.

        A payload at ``x`` ahead of the rear axle puts ``x / L`` of its weight on
        the front axle (moment balance about the rear axle).
        """
        p = self.params
        payload_front = self.payload_kg * self.payload_x_m / p.wheelbase_m
        front = p.mass_kg * p.front_load_fraction + payload_front
        return front / self.mass_kg

    @cached_property
    def static_wheel_load_n(self) -> np.ndarray:
        """Static normal load of each wheel with payload (N), shape (4,), order :data:`WHEELS`."""
        return _static_loads(self.mass_kg, self.front_load_fraction)

    @cached_property
    def unloaded_radius_new_m(self) -> float:
        """Free radius of a new tyre of this car (m).

        Inverts :func:`effective_radius_m` at the nominal conditions (rear wheel,
        static load without payload): ``r_nominal = r_0 - F_z,rear / (3 C_z0)``,
        then adds this car's tyre offset (``tyre.free_radius_offset_mm``: brand
        and manufacturing spread of one size).
        """
        tyre = self.params.tyre
        unladen_rear = _static_loads(self.params.mass_kg, self.params.front_load_fraction)[2]
        return (
            self.nominal_radius_m
            + unladen_rear / (3.0 * tyre.vertical_stiffness_n_m)
            + tyre.free_radius_offset_mm * 1e-3
        )

    @property
    def cg_to_rear_m(self) -> float:
        """Distance from the rear axle to the centre of gravity, with payload (m)."""
        return self.params.wheelbase_m * self.front_load_fraction

    def tyre_state(self, state: str) -> SimTyreState:
        """Return the named tyre state (pressures, tread).

        Raises:
            ConfigError: if the vehicle has no such state.
        """
        try:
            return self.params.tyre_states[state]
        except KeyError:
            raise ConfigError(
                f"sim.vehicles.{self.name}.tyre_states has no state {state!r}; "
                f"expected one of {sorted(self.params.tyre_states)}"
            ) from None


def _static_loads(mass_kg: float, front_fraction: float) -> np.ndarray:
    front = mass_kg * G_M_S2 * front_fraction / 2.0
    rear = mass_kg * G_M_S2 * (1.0 - front_fraction) / 2.0
    return np.array([front, front, rear, rear])


def per_wheel(values: SimWheels) -> np.ndarray:
    """Return per-wheel config values as an array.

    Args:
        values: one number per wheel.

    Returns:
        (4,) float array in the order of :data:`WHEELS`.
    """
    return np.array([getattr(values, w) for w in WHEELS], dtype=np.float64)


def vertical_stiffness_n_m(vehicle: Vehicle, pressure_psi: np.ndarray) -> np.ndarray:
    """Tyre vertical stiffness at an inflation pressure.

    MF-Swift / MF-Tyre 6.1 pressure dependence (Besselink et al. 2010):
    ``C_z = C_z0 (1 + p_Fz1 dp)`` with ``dp = (p - p_ref) / p_ref``. Kept above
    20 % of C_z0 so a flat tyre stays a (very soft) spring.

    Args:
        vehicle: the vehicle (its ``tyre`` constants).
        pressure_psi: inflation pressure(s), psi.

    Returns:
        Vertical stiffness, N/m, with the shape of ``pressure_psi``.
    """
    tyre = vehicle.params.tyre
    dp = (np.asarray(pressure_psi, dtype=np.float64) - tyre.reference_pressure_psi) / (
        tyre.reference_pressure_psi
    )
    factor = np.maximum(1.0 + tyre.stiffness_pressure_coeff * dp, 0.2)
    return tyre.vertical_stiffness_n_m * factor


def effective_radius_m(
    vehicle: Vehicle,
    pressure_psi: np.ndarray,
    tread_mm: np.ndarray,
    load_n: np.ndarray,
    speed_m_s: np.ndarray,
) -> np.ndarray:
    """Effective rolling radius of a tyre (distance travelled per radian of wheel turn).

    ``r_e = R_0 (1 + q_V1 (v / V_0)^2) - F_z / (3 C_z(p))``, with
    ``R_0 = R_0,new - (tread_new - tread)``: a worn tread shrinks the free radius
    one-for-one; the centrifugal growth term is MF-Tyre 6.1's (Pacejka 2012,
    loaded-radius model); the effective rolling radius of a radial tyre lies
    about one third of the vertical deflection below the free radius (Pacejka
    2012, rolling radius of radial-ply tyres).

    Args:
        vehicle: the vehicle.
        pressure_psi: inflation pressure, psi (broadcasts with the others).
        tread_mm: tread depth, mm.
        load_n: normal load, N.
        speed_m_s: wheel centre speed over ground, m/s (sign ignored).

    Returns:
        Effective rolling radius, m.
    """
    tyre = vehicle.params.tyre
    r0 = vehicle.unloaded_radius_new_m - (tyre.new_tread_mm - np.asarray(tread_mm)) * 1e-3
    growth = (
        1.0 + tyre.speed_growth_coeff * (np.asarray(speed_m_s) / tyre.speed_growth_ref_m_s) ** 2
    )
    deflection_m = np.asarray(load_n) / vertical_stiffness_n_m(vehicle, pressure_psi)
    return r0 * growth - deflection_m / 3.0


# Gas law for the tyre air: absolute pressure over absolute temperature is constant
# for a fixed amount of air in a (nearly) fixed volume.
P_ATM_PSI = 14.696  # standard atmosphere
T_COLD_K = 288.15  # ISA sea-level temperature: the tyres' cold (ambient) temperature


def tyre_temperature_rise_k(
    vehicle: Vehicle, speed_m_s: np.ndarray, dt_s: float, start_k: float = 0.0
) -> np.ndarray:
    """Rise of the tyre-air temperature over ambient while driving (first-order lag).

    ``dT/dt = (T_eq(v) - T) / tau`` with ``T_eq = warm_rise_k sqrt(v / warm_ref_speed_m_s)``:
    the heat a rolling tyre generates grows like the rolling-resistance power
    (~ v) and the convective cooling of its surface like ``v^{1/2}`` (laminar
    forced convection, Nu ~ Re^{1/2}), so the equilibrium rise grows like
    ``v^{1/2}``; standing, the tyre cools towards ambient with the same time
    constant. Exact discretisation for a piecewise-constant input (one IIR
    filter, no loop over samples).

    Args:
        vehicle: the vehicle (``tyre.warm_*``).
        speed_m_s: speed at every sample (>= 0), (n,).
        dt_s: sampling interval.
        start_k: temperature rise at the first sample (0: a cold start).

    Returns:
        Temperature rise, K, (n,).
    """
    tyre = vehicle.params.tyre
    drive = tyre.warm_rise_k * np.sqrt(np.maximum(speed_m_s, 0.0) / tyre.warm_ref_speed_m_s)
    phi = np.exp(-dt_s / tyre.warm_tau_s)
    if drive.size == 0:
        return drive
    rise, _ = lfilter([1.0 - phi], [1.0, -phi], drive, zi=[phi * start_k])
    return rise


def tyre_pressure_psi(
    cold_psi: np.ndarray,
    t_s: np.ndarray,
    temperature_rise_k: np.ndarray,
    leak_psi_per_s: np.ndarray,
) -> np.ndarray:
    """Inflation pressure of each tyre over a drive: warm-up (gas law) and leaks.

    A leak removes air at a constant rate, expressed as the cold pressure it
    costs per second; the remaining air follows the gas law
    ``p_abs = p_abs,cold (T_cold + dT) / T_cold``.

    Args:
        cold_psi: cold gauge pressure of each wheel at the start, psi, (4,).
        t_s: time since the start, (n,).
        temperature_rise_k: tyre-air temperature rise over ambient, (n,).
        leak_psi_per_s: cold pressure lost per second by each wheel, (4,).

    Returns:
        Gauge pressure, psi, (4, n) (never below 0).
    """
    cold = np.maximum(
        np.asarray(cold_psi, dtype=np.float64)[:, None]
        - np.asarray(leak_psi_per_s, dtype=np.float64)[:, None] * np.asarray(t_s)[None, :],
        0.0,
    )
    warm = (cold + P_ATM_PSI) * (T_COLD_K + np.asarray(temperature_rise_k)[None, :]) / T_COLD_K
    return np.maximum(warm - P_ATM_PSI, 0.0)


def slip_ratio(
    force_n: np.ndarray, load_n: np.ndarray, mu: np.ndarray, stiffness_per_load: np.ndarray
) -> np.ndarray:
    """Longitudinal slip ratio that carries a longitudinal tyre force.

    Saturating force-slip curve ``F = mu F_z tanh(C F_z kappa / (mu F_z))``
    (initial slope = slip stiffness ``C_Fkappa = C F_z``, Pacejka 2012; the
    force saturates at the friction limit), inverted:
    ``kappa = (mu / C) artanh(F / (mu F_z))``. A wet road lowers both ``mu``
    and ``C`` (slip slope, Gustafsson 1997), so the same force needs more slip.

    Args:
        force_n: longitudinal tyre force along the direction of travel, N
            (positive: traction, negative: braking or rolling resistance).
        load_n: normal load, N (> 0).
        mu: tyre-road friction coefficient.
        stiffness_per_load: slip stiffness per unit load ``C_Fkappa / F_z``.

    Returns:
        Slip ratio ``(omega r_e - v) / |v|``: positive when the wheel spins faster
        than it rolls (traction), negative when it lags (braking).
    """
    utilisation = np.clip(force_n / (mu * load_n), -MAX_UTILISATION, MAX_UTILISATION)
    return (mu / stiffness_per_load) * np.arctanh(utilisation)


def traction_limits_m_s2(vehicle: Vehicle, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest acceleration and deceleration the tyres carry at 85 % of friction.

    Acceleration is limited by the driven axle's load, which shrinks (FWD) or
    grows (RWD) with longitudinal load transfer ``m a h / L``; braking uses all
    four wheels (electronic brake-force distribution keeps both axles at the
    same utilisation), so ``d <= 0.85 mu g``.

    Args:
        vehicle: the vehicle.
        mu: friction coefficient(s).

    Returns:
        ``(accel_max_m_s2, decel_max_m_s2)``.
    """
    p = vehicle.params
    m = 0.85 * np.asarray(mu)
    h_over_l = p.cg_height_m / p.wheelbase_m
    front = vehicle.front_load_fraction
    if p.drive == "fwd":
        accel = m * G_M_S2 * front / (1.0 + m * h_over_l)
    else:
        accel = m * G_M_S2 * (1.0 - front) / (1.0 - m * h_over_l)
    return accel, m * G_M_S2


@dataclass(frozen=True)
class WheelStates:
    """Per-wheel ground truth at the integration rate; arrays (4, n), order :data:`WHEELS`.

    Attributes:
        ground_speed_m_s: speed of each wheel centre over ground (>= 0).
        load_n: normal load.
        force_n: longitudinal tyre force along the direction of travel.
        slip: longitudinal slip ratio.
        radius_m: effective rolling radius.
        omega_rad_s: wheel angular speed magnitude, ``v (1 + slip) / r_e``.
        steer_rad: road-wheel steer angle (0 for rear wheels), positive left.
    """

    ground_speed_m_s: np.ndarray
    load_n: np.ndarray
    force_n: np.ndarray
    slip: np.ndarray
    radius_m: np.ndarray
    omega_rad_s: np.ndarray
    steer_rad: np.ndarray


def wheel_ground_speeds(
    vehicle: Vehicle, speed_m_s: np.ndarray, curvature_1_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rigid-body (Ackermann) ground speed and steer angle of each wheel.

    The rear-axle centre moves along the body x-axis at ``v`` with yaw rate
    ``r = v kappa``. A point at body ``(x, y)`` moves at ``(v - r y, r x)``:
    rear wheels at ``v (1 -+ kappa t_r / 2)``, front wheels (steered to roll
    along their velocity) at ``|v| hypot(1 -+ kappa t_f / 2, kappa L)``.

    Args:
        vehicle: the vehicle.
        speed_m_s: rear-axle-centre speed (>= 0; direction of travel does not
            change the magnitudes).
        curvature_1_m: path curvature of the rear-axle centre, 1/m, positive left.

    Returns:
        ``(ground_speed_m_s, steer_rad)``, each (4, n).
    """
    p = vehicle.params
    k = np.asarray(curvature_1_m, dtype=np.float64)
    v = np.asarray(speed_m_s, dtype=np.float64)
    half = np.array([p.track_front_m, p.track_front_m, p.track_rear_m, p.track_rear_m]) / 2.0
    side = np.where(LEFT, -1.0, 1.0)[:, None]  # left wheels are on the inside of a left turn
    along = 1.0 + side * k[None, :] * half[:, None]
    across = np.where(FRONT[:, None], k[None, :] * p.wheelbase_m, 0.0)
    ground = v[None, :] * np.hypot(along, across)
    steer = np.arctan2(across, along)
    return ground, steer


def wheel_loads(vehicle: Vehicle, accel_x_m_s2: np.ndarray, accel_y_m_s2: np.ndarray) -> np.ndarray:
    """Normal load of each wheel with longitudinal and lateral load transfer.

    Longitudinal: ``m a_x h / L`` moves from the front to the rear axle.
    Lateral: ``m a_y h / t`` per axle, shared between axles like the static load
    (equal roll-stiffness share), moves from the left to the right wheels when
    ``a_y > 0`` (left turn). A wheel keeps at least 5 % of its static load.

    Args:
        vehicle: the vehicle.
        accel_x_m_s2: body longitudinal acceleration of the centre of gravity.
        accel_y_m_s2: body lateral acceleration of the centre of gravity (left +).

    Returns:
        Loads, N, shape (4, n).
    """
    p = vehicle.params
    m, h = vehicle.mass_kg, p.cg_height_m
    ax = np.asarray(accel_x_m_s2, dtype=np.float64)
    ay = np.asarray(accel_y_m_s2, dtype=np.float64)
    static = vehicle.static_wheel_load_n[:, None]
    lon = m * ax * h / p.wheelbase_m / 2.0  # per wheel, leaves each front wheel
    front = vehicle.front_load_fraction
    share = np.array([front] * 2 + [1.0 - front] * 2)
    track = np.array([p.track_front_m] * 2 + [p.track_rear_m] * 2)
    # Roll moment of an axle's share: (F_right - F_left) t / 2 = share m a_y h.
    lat = (m * h * share / track)[:, None] * ay[None, :]
    sign_lon = np.where(FRONT, -1.0, 1.0)[:, None]
    sign_lat = np.where(LEFT, -1.0, 1.0)[:, None]
    loads = static + sign_lon * lon[None, :] + sign_lat * lat
    return np.maximum(loads, 0.05 * static)


def wheel_forces(
    vehicle: Vehicle,
    load_n: np.ndarray,
    speed_m_s: np.ndarray,
    accel_m_s2: np.ndarray,
    air_density_kg_m3: float,
) -> np.ndarray:
    """Longitudinal tyre forces along the direction of travel.

    The tyres must supply ``m a + drag``. Each wheel carries its rolling
    resistance ``-f_rr F_z`` (while moving); the powertrain or the brakes add
    ``F_p = m a + 1/2 rho C_d A v^2 + f_rr m g``. Traction (``F_p > 0``) goes to
    the driven axle, split equally (open differential). Braking is shared by
    the brake balance, with the rear share capped at the rear axle's dynamic
    load fraction (electronic brake-force distribution, which stops the rear
    wheels from locking first); left and right brake equally.

    Args:
        vehicle: the vehicle.
        load_n: wheel loads, (4, n).
        speed_m_s: speed (>= 0), (n,).
        accel_m_s2: tangential acceleration along the direction of travel, (n,).
        air_density_kg_m3: air density.

    Returns:
        Forces, N, (4, n); their sum is ``m a + drag``.
    """
    p = vehicle.params
    v = np.asarray(speed_m_s, dtype=np.float64)
    moving = (v > 1e-3).astype(np.float64)
    rolling = p.tyre.rolling_resistance * load_n * moving[None, :]
    drag = 0.5 * air_density_kg_m3 * p.drag_area_m2 * v**2
    propulsive = vehicle.mass_kg * np.asarray(accel_m_s2) + drag + rolling.sum(axis=0)
    driven = FRONT if p.drive == "fwd" else ~FRONT
    traction = np.where(driven[:, None], 0.5, 0.0) * np.maximum(propulsive, 0.0)[None, :]
    rear_load_fraction = load_n[2:].sum(axis=0) / load_n.sum(axis=0)
    rear_share = np.minimum(1.0 - p.brake_front_share, rear_load_fraction)
    axle_share = np.where(FRONT[:, None], 1.0 - rear_share[None, :], rear_share[None, :])
    braking = 0.5 * axle_share * np.minimum(propulsive, 0.0)[None, :]
    return traction + braking - rolling


def wheel_states(
    vehicle: Vehicle,
    tyre: SimTyreState,
    speed_m_s: np.ndarray,
    accel_m_s2: np.ndarray,
    curvature_1_m: np.ndarray,
    accel_x_cg_m_s2: np.ndarray,
    accel_y_cg_m_s2: np.ndarray,
    mu: np.ndarray,
    slip_stiffness_factor: np.ndarray,
    air_density_kg_m3: float,
    *,
    slip: bool = True,
    radius_load: bool = True,
    radius_speed: bool = True,
    pressure_psi: np.ndarray | None = None,
) -> WheelStates:
    """Ground truth of the four wheels: ``omega = v_wheel (1 + slip) / r_e``.

    Args:
        vehicle: the vehicle.
        tyre: its tyre state (pressures, tread).
        speed_m_s: rear-axle-centre speed (>= 0), (n,).
        accel_m_s2: tangential acceleration along the direction of travel, (n,).
        curvature_1_m: path curvature, (n,).
        accel_x_cg_m_s2: body longitudinal acceleration of the centre of gravity, (n,).
        accel_y_cg_m_s2: body lateral acceleration of the centre of gravity, (n,).
        mu: friction coefficient, (n,).
        slip_stiffness_factor: slip stiffness relative to a dry road, (n,).
        air_density_kg_m3: air density.
        slip: False: wheels roll without slip.
        radius_load: False: radius at the static load (no load transfer).
        radius_speed: False: no centrifugal growth.
        pressure_psi: inflation pressure over time, (4, n) or (4, 1) (warm-up,
            leaks: :func:`tyre_pressure_psi`); default: the tyre state's pressure.

    Returns:
        The wheel states.
    """
    ground, steer = wheel_ground_speeds(vehicle, speed_m_s, curvature_1_m)
    loads = wheel_loads(vehicle, accel_x_cg_m_s2, accel_y_cg_m_s2)
    forces = wheel_forces(vehicle, loads, speed_m_s, accel_m_s2, air_density_kg_m3)
    if slip:
        stiffness = vehicle.params.tyre.slip_stiffness_per_load * slip_stiffness_factor
        kappa = slip_ratio(forces, loads, mu[None, :], stiffness[None, :])
    else:
        kappa = np.zeros_like(forces)
    if pressure_psi is None:
        pressure_psi = per_wheel(tyre.pressure_psi)[:, None]
    radius = effective_radius_m(
        vehicle,
        pressure_psi,
        per_wheel(tyre.tread_mm)[:, None],
        loads if radius_load else vehicle.static_wheel_load_n[:, None],
        ground if radius_speed else 0.0,
    )
    radius = np.broadcast_to(radius, ground.shape)
    omega = ground * (1.0 + kappa) / radius
    return WheelStates(ground, loads, forces, kappa, radius, omega, steer)
