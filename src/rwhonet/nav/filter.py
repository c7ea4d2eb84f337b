"""An extended Kalman filter for a car's 2D position through a GNSS outage.

State (per window; :data:`STATE`), in a local east/north frame in metres
(:mod:`rwhonet.geo.local` turns fixes into it):

====  =========  ===================================================================
 0-1  ``e, n``   the rear-axle centre, m
 2    ``psi``    the body's azimuth, rad clockwise from north
 3    ``b_g``    the gyro's bias, rad/s (left turns positive, as the yaw rate)
 4    ``s_g``    the gyro's scale: true yaw = ``s_g`` (measured − bias)
 5    ``s_d``    the odometry's scale: travel = ``s_d`` × the model's distance
 6    ``s_w``    the wheel yaw's scale (effective track and radius)
 7    ``beta``   the wheel yaw's bias per metre (a left/right radius difference), rad/m
 8    ``c``      the wheels' load-transfer term: they report ``1 + c v²`` times the
                 yaw (:mod:`rwhonet.features.deadreckoning`), s²/m²
 9-10 ``g``      the GNSS receiver's slowly drifting error, east and north, m
 11   ``eps_w``  what the wheel-yaw model misses, rad per second: slip and load
                 effects that differ between the rear wheels and last as long as a
                 speed or a bend (a Gauss-Markov process)
 12   ``beta_v`` the wheel yaw's bias per metre grows with speed by this, rad/m per
                 m/s (the rear tyres' radii part with speed: two pressures, two
                 tread depths)
 13   ``bd_g``   the gyro bias's drift rate, rad/s per s: the sensor warming up after
                 power-on moves its bias at a rate that decays with the warm-up's
                 time constant (``b_g ← b_g + bd_g``, ``bd_g ← e^{−1/τ_w} bd_g`` each
                 second); learnt from GNSS before an outage, extrapolated through it
 14   ``bd_w``   the wheel yaw's bias per metre drifts in time by this, rad/m per s: a
                 rear tyre losing air shrinks its rolling radius at a steady rate, so
                 the left/right radius difference, and with it ``beta``, ramps
                 (``beta ← beta + bd_w`` each second); learnt while the gyro and GNSS
                 watch the wheels, extrapolated through an outage (the comparison of
                 wheel speeds with the yaw rate that indirect tyre-pressure monitoring
                 rests on); inert unless ``NavConfig.leak_per_h`` > 0
====  =========  ===================================================================

Each second ``k`` (from fix ``k`` to fix ``k + 1`` of :class:`NavInputs`):

1. the second's true yaw ``δ`` (left positive) joins the state with a wide
   prior; the gyro's integral ``Y_g = δ / s_g + b_g`` and the rear wheels'
   yaw ``Y_w = (δ − β d − β_v d²)(1 + c d²) / s_w + ε_w`` (``d``: the second's
   distance) are
   measurements of it, each with the noise of its sensor
   (:mod:`rwhonet.nav.sensors`). With both (control ``fused``) their
   difference tells the biases apart every second, GNSS or not: the wheels
   watch the gyro's bias drift through an outage, the gyro watches a tyre's
   radius change. ``wheels`` and ``gyro`` use one sensor alone;
2. propagation by the arc of the second: ``ψ ← ψ − δ``; the position moves by
   the chord ``s_d d sinc(δ/2)`` along the mid-second azimuth ``ψ − δ/2`` (the
   midpoint rule of :func:`rwhonet.features.deadreckoning.dead_reckon`); the
   distance's variance is an input (the odometry model's); the biases and
   scales walk, the GNSS error decays as a Gauss-Markov process;
3. while GNSS is valid: the course of the antenna's chord (two fixes far
   enough apart) and the fix itself (antenna = rear axle + lever arm + ``g``)
   update the state, innovations beyond ``gnss.gate`` standard deviations left
   out (jumps); through an outage the fixes are absent and steps 1-2 alone
   dead-reckon. Before either update, the fix's density under its prediction
   is kept (:attr:`NavTrack.fix_logpdf`): summed over a drive, the log score of
   the filter's predictions of its GNSS;
4. ``δ`` is marginalised out.

Reversing. Wheel speeds are magnitudes, so a car reversing is dead-reckoned
forwards unless something says otherwise; with both yaw sensors (``fused``)
the turn says it: going backwards, the rear wheels' yaw ``Y_w`` counts the
gyro's turn the wrong way round. A second whose wheel yaw lies beyond
``yaw_gate`` standard deviations of the forward prediction and within them of
the reversed one, where the two lie far enough apart to tell (``|δ|`` of at
least ``yaw_gate`` standard deviations) and the car slower than
``reverse_max_m_s`` (a reverse gear's pace), is a reversing second: its distance
moves the car backwards and its wheel yaw is left out. A car changes
direction only through a stop, so a reversing run carries on through its
straight seconds until the car stops (``reverse_stop_m``) or a turn says
forwards again; and the straight seconds since the last stop that were driven
forwards (slowly) before the turn told otherwise are turned round when it does (the
position moves back by twice their travel, heading untouched: the gyro's
yaw holds either way). A straight reverse between two stops shows no turn and
stays undetected, unless the log says so: a logger that signs its wheel speeds
tells every second driven backwards (``NavInputs.backwards``,
:func:`rwhonet.features.seconds.backwards_per_second`), with every control. Such a
second moves the car backwards; with the gyro its wheel yaw is left out, as
the turn-based rule leaves it out (on a simulated reverse round a tight bend
the rear wheels' turn came 4 % above the gyro's: the model's terms are learnt
going forwards), and the wheels alone read it as the reversed turn (``Y_w =
(−δ − β d − β_v d²)(1 + c d²) / s_w + ε_w``: the signed model with the travel
``−d``, negated), their only yaw. The turn-based rule is for the other seconds.

The filter starts on the first second with a course (its azimuth, the fix), or
from a state handed over (:class:`NavStart`: a run over a whole drive segment
with GNSS, snapshotted where each outage window begins, then every window
dead-reckoned from its snapshot), and runs every window of a batch at once
(arrays ``(W, n)``, one loop over the seconds). Covariances are updated in
Joseph form.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from rwhonet.nav.sensors import GATE_SD, GnssSpec, GyroSpec, WheelSpec, lag_compensated

Control = Literal["wheels", "gyro", "fused"]
CONTROLS: tuple[str, ...] = ("wheels", "gyro", "fused")
STATE: tuple[str, ...] = (
    "e",
    "n",
    "psi",
    "b_g",
    "s_g",
    "s_d",
    "s_w",
    "beta",
    "c",
    "g_e",
    "g_n",
    "eps_w",
    "beta_v",
    "bd_g",
    "bd_w",
)
E, N, PSI, BG, SG, SD, SW, BW, CW, GE, GN, EW, BV, BD, BDW = range(len(STATE))
S = len(STATE)
DELTA = S  # the second's yaw, in the augmented state


@dataclass(frozen=True)
class NavConfig:
    """The sensors' error models, the priors and the random walks of the slow states.

    Attributes:
        gyro: the yaw-rate sensor.
        wheels: the rear wheels' CAN speeds and geometry.
        gnss: the receiver.
        antenna_m: the antenna ahead of and left of the rear-axle centre, m.
        dist_scale_sd: prior spread of ``s_d`` around 1.
        wheel_scale_sd: prior spread of ``s_w`` around 1.
        wheel_bias_sd: prior spread of ``beta`` around 0, rad/m.
        load_sd: prior spread of ``c`` around 0, s²/m².
        dist_scale_walk: random walk of ``s_d`` per sqrt(s) (tyres warming).
        gyro_scale_walk: random walk of ``s_g`` per sqrt(s).
        wheel_scale_walk: random walk of ``s_w`` per sqrt(s).
        wheel_bias_walk: random walk of ``beta`` per sqrt(s), rad/m (a tyre losing air).
        load_walk: random walk of ``c`` per sqrt(s).
        wheel_error_sd: spread of ``eps_w``, rad per second. On a simulated
            Fiesta the wheel-yaw model's residual with scale, bias per metre and
            load term fitted to the true yaw averaged -0.0019 to +0.0025 rad per
            second by speed band; with ``beta_v`` too, within ±0.0003
            (docs/positioning.md): errors that last, which as white noise would
            pull the gyro's bias every second.
        wheel_error_tau_s: its correlation time, s.
        wheel_bias_speed_sd: prior spread of ``beta_v`` around 0, rad/m per m/s.
        wheel_bias_speed_walk: its random walk per sqrt(s).
        leak_per_h: prior spread of the rear tyres' rolling-radius difference
            changing per hour, as a fraction of the radius (a tyre losing air):
            ``bd_w``'s prior spread is this over 3,600 s and the rear track
            (:meth:`leak_rate_sd`). 0: no such state (``beta`` only walks), as in
            every configuration the pipeline builds today: measured, not yet used
            (``benchmarks/leak_models.py``, docs/positioning.md section 7).
        leak_change_s: ``bd_w`` walks by its prior spread over this many seconds (a
            leak that speeds up, or the warm tyres' pressures settling).
        heading_walk: heading noise per sqrt(s) besides the yaw sensors', rad.
        yaw_gate: a second sensor's yaw beyond this many standard deviations of the
            first's is left out (a reversing manoeuvre, where wheel speeds, being
            magnitudes, count the turn the wrong way round).
        delta_prior_sd: the prior spread of a second's yaw, rad (wide: the
            sensors decide it).
        reset_after_s: after this many fixes in a row refused by the gate, the
            pose restarts on GNSS (the sensor states are kept).
        reverse_stop_m: a second shorter than this ends a reversing run (the car
            stopped); ``fused`` only (module docstring, Reversing).
        reverse_max_m_s: no second faster than this is taken for reversing: cars
            reverse at walking to jogging pace (parking, a three-point turn), while
            a fast second's large wheel-yaw innovation is slip or a sensor fault.
        load_min: ``c`` is kept in ``[load_min, load_max]`` (the load transfer makes
            the outer wheel report more, never less: 0; 0.01 is a very soft axle).
        load_max: see ``load_min``.
        scale_max_off: the scales are kept within ``1 ± scale_max_off``.
    """

    # The sensors, and where the GNSS antenna sits on the car.
    gyro: GyroSpec = field(default_factory=GyroSpec)
    wheels: WheelSpec = field(default_factory=WheelSpec)
    gnss: GnssSpec = field(default_factory=GnssSpec)
    antenna_m: tuple[float, float] = (0.0, 0.0)
    # Priors: each slow state's spread at the start, and a second's yaw before the sensors.
    dist_scale_sd: float = 0.03
    wheel_scale_sd: float = 0.05
    wheel_bias_sd: float = 0.003
    load_sd: float = 0.003
    wheel_bias_speed_sd: float = 3e-5
    leak_per_h: float = 0.0
    delta_prior_sd: float = 1.0
    # The wheel yaw's lasting error ``eps_w``: a Gauss-Markov state, not white noise.
    wheel_error_sd: float = 0.0005
    wheel_error_tau_s: float = 60.0
    # Random walks per sqrt(s) (the process noise).
    dist_scale_walk: float = 1e-4
    gyro_scale_walk: float = 1e-5
    wheel_scale_walk: float = 1e-4
    wheel_bias_walk: float = 2e-6
    load_walk: float = 1e-6
    wheel_bias_speed_walk: float = 1e-7
    leak_change_s: float = 3600.0
    heading_walk: float = 2e-4
    # Bounds the states are kept within.
    load_min: float = 0.0
    load_max: float = 0.01
    scale_max_off: float = 0.3
    # Gates, and the reversing rule (module docstring, Reversing).
    yaw_gate: float = GATE_SD
    reset_after_s: int = 10
    reverse_stop_m: float = 0.3
    reverse_max_m_s: float = 4.0

    def leak_rate_sd(self) -> float:
        """Prior spread of ``bd_w``, rad/m per s: a radius difference changing by
        ``leak_per_h`` per hour bends the wheels' yaw by that fraction over the track
        per metre."""
        return float(self.leak_per_h / 3600.0 / self.wheels.track_rear_m)

    def with_receiver(self, sigma_m: float, tau_s: float | None = None) -> NavConfig:
        """These settings with the receiver drift's spread (and correlation time) replaced."""
        gnss = replace(self.gnss, sigma_m=float(sigma_m))
        if tau_s is not None:
            gnss = replace(gnss, tau_s=float(tau_s))
        return replace(self, gnss=gnss)


def config_from_params(
    navigation: Any, radius_m: float, track_rear_m: float, **overrides: Any
) -> NavConfig:
    """The filter's settings from ``params.yaml``'s ``evaluate.navigation`` and a car's geometry.

    Args:
        navigation: :class:`rwhonet.config.NavigationParams` (degrees as written there).
        radius_m: the rear wheels' nominal rolling radius, m.
        track_rear_m: the rear track, m.
        **overrides: other :class:`NavConfig` fields.
    """
    g, w, r = navigation.gyro, navigation.wheels, navigation.gnss
    return NavConfig(
        gyro=GyroSpec(
            noise_density=float(np.radians(g.noise_density_deg_s_rthz)),
            lsb=float(np.radians(g.lsb_deg_s)),
            bias_sd=float(np.radians(g.bias_sd_deg_s)),
            bias_instability=float(np.radians(g.instability_deg_s)),
            bias_tau_s=g.instability_tau_s,
            temp_drift_per_k=float(np.radians(g.temp_drift_deg_s_k)),
            warm_rate_k_s=g.warm_rate_k_s,
            warm_tau_s=g.warm_tau_s,
            scale_sd=g.scale_sd,
            latency_s=g.latency_s,
        ),
        wheels=WheelSpec(
            quantum_rad_s=w.quantum_rad_s,
            noise_rad_s=w.noise_rad_s,
            radius_m=radius_m,
            track_rear_m=track_rear_m,
        ),
        gnss=GnssSpec(sigma_m=r.sigma_m, tau_s=r.tau_s, white_m=r.white_m),
        antenna_m=(float(navigation.antenna_m[0]), float(navigation.antenna_m[1])),
        **overrides,
    )


@dataclass(frozen=True)
class NavInputs:
    """What the filter reads, per window and second: arrays ``(W, n)`` (fixes ``(W, n + 1)``).

    Attributes:
        dist_m: the odometry model's distance of each second, m.
        dist_var_m2: its error variance, m².
        wheel_yaw_rad: the rear wheels' yaw of each second with nominal radii
            (:func:`rwhonet.features.deadreckoning.wheel_yaw_rad`), rad; NaN: none.
        gyro_yaw_rad: the gyro's yaw rate integrated over each second, rad; NaN: none.
        fix_e_m: GNSS fixes bounding the seconds, east, m: column ``k`` starts
            second ``k`` and column ``k + 1`` ends it; NaN where no valid fix
            (an outage).
        fix_n_m: their north offsets, m.
        backwards: (W, n) bool, seconds the log says were driven backwards (a logger
            that signs its wheel speeds); None: the log cannot say (magnitudes).
        gyro_yaw_before_rad: (W,) the gyro's yaw over the second before each window's
            first, rad (a window cut from a longer run; NaN or None: none), for the
            channel's latency (:func:`rwhonet.nav.sensors.lag_compensated`).
        yaw_var_rad2: (W, n) variance added to each second's yaw measurements, gyro's
            and wheels' alike, rad² (a second whose yaw was interpolated across a
            logger's gap: :meth:`rwhonet.serve.navigation.StreamNavigator.bridge`); None:
            none.
    """

    dist_m: np.ndarray
    dist_var_m2: np.ndarray
    wheel_yaw_rad: np.ndarray
    gyro_yaw_rad: np.ndarray
    fix_e_m: np.ndarray
    fix_n_m: np.ndarray
    backwards: np.ndarray | None = None
    gyro_yaw_before_rad: np.ndarray | None = None
    yaw_var_rad2: np.ndarray | None = None

    def __post_init__(self) -> None:
        shape = np.shape(self.dist_m)
        if len(shape) != 2:
            raise ValueError(f"NavInputs arrays must be (windows, seconds), got {shape}")
        before = self.gyro_yaw_before_rad
        if before is not None and np.shape(before) != shape[:1]:
            raise ValueError(f"gyro_yaw_before_rad is {np.shape(before)}, expected {shape[:1]}")
        for name in ("dist_var_m2", "wheel_yaw_rad", "gyro_yaw_rad", "backwards", "yaw_var_rad2"):
            if name in ("backwards", "yaw_var_rad2") and getattr(self, name) is None:
                continue
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"{name} is {np.shape(getattr(self, name))}, expected {shape}")
        for name in ("fix_e_m", "fix_n_m"):
            if np.shape(getattr(self, name)) != (shape[0], shape[1] + 1):
                raise ValueError(
                    f"{name} is {np.shape(getattr(self, name))}, expected "
                    f"{(shape[0], shape[1] + 1)} (the fix before each second, then one per second)"
                )


@dataclass(frozen=True)
class NavStart:
    """A state to start rows from instead of waiting for their first course.

    Attributes:
        x: (W, S) the state.
        p: (W, S, S) its covariance.
        on: (W,) the rows that start from it (the others start on their first
            course, as without a start).
    """

    x: np.ndarray
    p: np.ndarray
    on: np.ndarray


@dataclass(frozen=True)
class NavTrack:
    """The filter's output at the end of every second.

    Attributes:
        x: (W, n, S) state; NaN before the filter started.
        cov: (W, n, S, S) its covariance (None unless asked for), else only the last.
        last_cov: (W, S, S) the covariance at the end of the last second.
        fix_pred: (W, n, 2) where the antenna's fix is predicted (east, north), m.
        fix_cov: (W, n, 2, 2) that prediction's covariance (state and the fix's
            white noise), m².
        started: (W, n) the filter runs at the end of that second.
        rejected: how many measurements the gates left out, by kind, and how
            many times a pose restarted (``reset``).
        snapshot_x: (W, K, S) the state at the end of each second of ``snapshots``
            (NaN where the row had not started), or None.
        snapshot_cov: (W, K, S, S) its covariance, or None.
        fix_logpdf: (W, n) the log density of each second's fix (fix ``k + 1``) under
            the filter's prediction of it made before it saw it or the course it ends
            (:func:`fix_log_score`): summed over a drive, the log score of the
            filter's one-step predictions of its GNSS, by which configurations
            (sensor figures) can be compared on drives with GNSS. 0 where there is
            no fix, the filter had not started, or the fix lies beyond the gate.
        wheel_logpdf: (W, n) the log density of each second's rear-wheel yaw under
            its prediction from the state and the gyro's yaw of that second (fused;
            0 where the gyro gave no yaw, the wheels' yaw was left out or refused).
    """

    x: np.ndarray
    cov: np.ndarray | None
    last_cov: np.ndarray
    fix_pred: np.ndarray
    fix_cov: np.ndarray
    started: np.ndarray
    rejected: dict[str, int]
    snapshot_x: np.ndarray | None = None
    snapshot_cov: np.ndarray | None = None
    fix_logpdf: np.ndarray | None = None
    wheel_logpdf: np.ndarray | None = None


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


# The filter steps a batch of windows second by second, so a second's cost is mostly
# numpy's overhead per call: the helpers below give numpy's own results, bit for bit,
# in fewer calls (benchmarks/bench_nav_filter.py prints the time and a digest).
_FMAX = np.finfo(np.float64).max
_EPS = np.finfo(np.float64).eps


def _nan0(a: np.ndarray) -> np.ndarray:
    """``np.nan_to_num(a)`` of a float64 array without its Python wrapper."""
    return np.minimum(np.maximum(np.where(np.isnan(a), 0.0, a), -_FMAX), _FMAX)


def _pick(rows: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.where`` of ``a`` and ``b`` by their first axis: ``a`` itself where every row is."""
    if rows.all():
        return a
    return np.where(rows.reshape(rows.shape + (1,) * (np.ndim(a) - 1)), a, b)


def lever(
    psi: np.ndarray, antenna_m: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """East/north offset of the antenna from the rear-axle centre at azimuth ``psi``, and its slope.

    Forward is ``(sin ψ, cos ψ)``, left is ``(−cos ψ, sin ψ)`` (azimuth clockwise from north).

    Returns:
        ``(east, north, d east / dψ, d north / dψ)``, m and m/rad.
    """
    x, y = antenna_m
    s, c = np.sin(psi), np.cos(psi)
    north = x * c + y * s  # the east offset's slope too
    return x * s - y * c, north, north, -x * s + y * c


def sinc_half(delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f(δ) = sin(δ/2) / (δ/2)`` (the chord of an arc of unit length) and ``f'(δ)``."""
    u = 0.5 * np.asarray(delta, np.float64)
    y = np.pi * (u / np.pi)  # np.sinc(u / π), written out as numpy computes it
    y = np.where(y != 0, y, _EPS)
    f = np.sin(y) / y
    small = np.abs(u) < 1e-4
    safe = np.where(small, 1.0, u)
    df = np.where(small, -u / 6.0, 0.5 * (u * np.cos(u) - np.sin(u)) / (safe * safe))
    return f, df


def propagate(
    xa: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Move the augmented state by one second's arc.

    Args:
        xa: (W, S + 1) state with the second's yaw ``δ`` last.
        d: (W,) the odometry's distance of the second, m.

    Returns:
        ``(xa_new, F, g_e, g_n)``: the new state (GNSS error not yet decayed),
        the Jacobian ``∂xa_new/∂xa`` (W, S + 1, S + 1), and how the distance's
        noise moves east and north (W,) each.
    """
    psi, delta, s_d = xa[:, PSI], xa[:, DELTA], xa[:, SD]
    f, df = sinc_half(delta)
    dist = s_d * d
    chord = dist * f
    mid = psi - 0.5 * delta
    sm, cm = np.sin(mid), np.cos(mid)
    out = xa.copy()
    out[:, E] += chord * sm
    out[:, N] += chord * cm
    out[:, PSI] = psi - delta
    w = xa.shape[0]
    jac = np.broadcast_to(_EYE_A, (w, S + 1, S + 1)).copy()
    jac[:, E, PSI] = chord * cm
    jac[:, N, PSI] = -chord * sm
    jac[:, E, DELTA] = dist * df * sm - 0.5 * chord * cm
    jac[:, N, DELTA] = dist * df * cm + 0.5 * chord * sm
    jac[:, E, SD] = d * f * sm
    jac[:, N, SD] = d * f * cm
    jac[:, PSI, DELTA] = -1.0
    return out, jac, f * sm, f * cm


def course_model(
    xa: np.ndarray, d: np.ndarray, antenna_m: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """The azimuth of the antenna's chord over the second just propagated, and its Jacobian.

    Args:
        xa: (W, S + 1) state after :func:`propagate` (``ψ`` at the end of the
            second, ``δ`` its yaw).
        d: (W,) the odometry's distance of the second, m.
        antenna_m: the lever arm.

    Returns:
        ``(h, H)``: (W,) azimuth, rad; (W, S + 1) its derivatives.
    """
    psi, delta, s_d = xa[:, PSI], xa[:, DELTA], xa[:, SD]
    f, df = sinc_half(delta)
    chord = s_d * d * f
    mid = psi + 0.5 * delta
    sm, cm = np.sin(mid), np.cos(mid)
    old = psi + delta
    le1, ln1, de1, dn1 = lever(psi, antenna_m)
    le0, ln0, de0, dn0 = lever(old, antenna_m)
    east = chord * sm + le1 - le0
    north = chord * cm + ln1 - ln0
    # derivatives of (east, north) by psi, delta, s_d
    e_psi, n_psi = chord * cm + de1 - de0, -chord * sm + dn1 - dn0
    e_del = s_d * d * df * sm + 0.5 * chord * cm - de0
    n_del = s_d * d * df * cm - 0.5 * chord * sm - dn0
    e_sd, n_sd = d * f * sm, d * f * cm
    r2 = np.maximum(east * east + north * north, 1e-12)
    jac = np.zeros((xa.shape[0], S + 1))
    for col, de_, dn_ in ((PSI, e_psi, n_psi), (DELTA, e_del, n_del), (SD, e_sd, n_sd)):
        jac[:, col] = (north * de_ - east * dn_) / r2
    return np.arctan2(east, north), jac


def fix_model(x: np.ndarray, antenna_m: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The antenna's predicted fix ``p + lever(ψ) + g`` and its Jacobian.

    Args:
        x: (W, K) state, K ≥ S.
        antenna_m: the lever arm.

    Returns:
        ``(h, H)``: (W, 2) east/north, m; (W, 2, K).
    """
    psi = x[:, PSI]
    le, ln, de, dn = lever(psi, antenna_m)
    h = np.empty((x.shape[0], 2))
    h[:, 0] = x[:, E] + le + x[:, GE]
    h[:, 1] = x[:, N] + ln + x[:, GN]
    jac = np.zeros((x.shape[0], 2, x.shape[1]))
    jac[:, 0, E] = jac[:, 1, N] = 1.0
    jac[:, 0, GE] = jac[:, 1, GN] = 1.0
    jac[:, 0, PSI], jac[:, 1, PSI] = de, dn
    return h, jac


def _scalar_update(xa, pa, h_row, innov, r, use, gate=None):
    """Joseph-form update by one scalar measurement where ``use``; returns the state, its
    covariance, the rows applied and the innovation's variance ``hᵀ P h + r`` (before it).

    ``(I − k hᵀ) P (I − k hᵀ)ᵀ + r k kᵀ`` expanded (``P`` symmetric, ``p_h = P h``,
    ``s = hᵀ P h + r``): ``P − k p_hᵀ − p_h kᵀ + s k kᵀ = P + k vᵀ + v kᵀ`` with
    ``v = s k / 2 − p_h``, the same matrix for any gain without the two (K × K)
    products per row. Rows not updated get a zero gain: their state and covariance
    come back unchanged, bit for bit.
    """
    ph = (pa @ h_row[:, :, None])[:, :, 0]  # matmul: far faster than einsum on stacks
    s = (h_row * ph).sum(axis=1) + r
    ok = use & np.isfinite(innov) & (s > 0)
    if gate is not None:
        ok &= innov * innov <= gate * gate * s
    k = np.where(ok[:, None], ph / np.where(ok, s, 1.0)[:, None], 0.0)
    new_x = xa + k * np.where(ok, innov, 0.0)[:, None]
    v = np.where(ok[:, None], 0.5 * s[:, None] * k - ph, 0.0)
    kv = k[:, :, None] * v[:, None, :]
    new_p = pa + kv
    new_p += kv.swapaxes(1, 2)
    return new_x, new_p, ok, s


def _vector_update(xa, pa, h_mat, innov, r_mat, use, gate):
    """Joseph-form update by a 2D measurement where ``use`` and within the gate.

    Expanded as in :func:`_scalar_update`: ``P − K P_Hᵀ − P_H Kᵀ + K S Kᵀ =
    P + K Vᵀ + V Kᵀ`` with ``P_H = P Hᵀ``, ``S = H P Hᵀ + R`` and ``V = K S / 2 − P_H``;
    rows not updated get a zero gain.
    """
    ph = pa @ h_mat.swapaxes(1, 2)  # (W, K, 2)
    s = h_mat @ ph + r_mat
    ok = use & np.isfinite(innov).all(axis=1)
    s = np.where(ok[:, None, None], s, np.eye(2))
    innov = np.where(ok[:, None], innov, 0.0)
    det = s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]
    ok &= det > 0
    det = np.where(ok, det, 1.0)
    adj = np.empty_like(s)
    adj[:, 0, 0], adj[:, 0, 1] = s[:, 1, 1], -s[:, 0, 1]
    adj[:, 1, 0], adj[:, 1, 1] = -s[:, 1, 0], s[:, 0, 0]
    s_inv = adj / det[:, None, None]
    ok &= (innov * (s_inv @ innov[:, :, None])[:, :, 0]).sum(axis=1) <= gate * gate
    k = np.where(ok[:, None, None], ph @ s_inv, 0.0)
    new_x = xa + (k @ innov[:, :, None])[:, :, 0]
    v = np.where(ok[:, None, None], 0.5 * (k @ s) - ph, 0.0)
    kv = k[:, :, None, 0] * v[:, None, :, 0] + k[:, :, None, 1] * v[:, None, :, 1]
    new_p = pa + kv
    new_p += kv.swapaxes(1, 2)
    return new_x, new_p, ok


# The rows of the propagation's Jacobian that differ from the identity's.
MOVED_ROWS = np.array([E, N, PSI, BG, BW, GE, GN, EW, BD])
_EYE_A = np.eye(S + 1)


def fix_log_score(
    pa: np.ndarray,
    h_mat: np.ndarray,
    innov: np.ndarray,
    r_mat: np.ndarray,
    use: np.ndarray,
    gate: float,
) -> np.ndarray:
    """Each row's log density of a fix under its prediction: ``log N(innov; 0, H P Hᵀ + R)``.

    Args:
        pa: (W, K, K) the state's covariance before the fix.
        h_mat: (W, 2, K) the fix model's Jacobian (:func:`fix_model`).
        innov: (W, 2) the fix less its prediction, m.
        r_mat: (W, 2, 2) the fix's white noise, m².
        use: (W,) rows with a fix to score.
        gate: rows whose squared Mahalanobis distance exceeds ``gate²`` score 0 (a
            jump the update would leave out too), as do rows not used. Scored in
            full, the few seconds where the filter has lost the car (before its pose
            restarts) outweighed every other second: on a built-in world's training
            drives two gyro noise figures' sums parted by 1,440 nats ungated and by 8
            gated (docs/positioning.md section 4).

    Returns:
        (W,) nats.
    """
    s = h_mat @ pa @ h_mat.swapaxes(1, 2) + r_mat
    det = s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]
    ok = use & np.isfinite(innov).all(axis=1) & (det > 0)
    det = np.where(ok, det, 1.0)
    i_ok = np.where(ok[:, None], innov, 0.0)
    # (e, n) S⁻¹ (e, n)ᵀ with the 2 × 2 inverse written out
    m2 = (
        s[:, 1, 1] * i_ok[:, 0] ** 2
        - (s[:, 0, 1] + s[:, 1, 0]) * i_ok[:, 0] * i_ok[:, 1]
        + s[:, 0, 0] * i_ok[:, 1] ** 2
    ) / det
    ok &= m2 <= gate * gate
    return np.where(ok, -0.5 * (m2 + np.log((2.0 * np.pi) ** 2 * det)), 0.0)


def _sandwich(p: np.ndarray, jac: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``J P Jᵀ`` for a Jacobian equal to the identity outside ``rows`` (W, K, K).

    ``(J P)`` differs from ``P`` in those rows only, and ``(J P) Jᵀ`` from ``J P`` in
    those columns only: two products of ``len(rows)`` rows instead of two of K.
    """
    jr = jac[:, rows, :]
    m = p.copy()
    m[:, rows, :] = jr @ p
    out = m.copy()
    out[:, :, rows] = m @ jr.swapaxes(1, 2)
    return out


def _initial(
    course: np.ndarray,
    course_var: np.ndarray,
    fix: np.ndarray,
    yaw_guess: np.ndarray,
    dist: np.ndarray,
    cfg: NavConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """State and covariance at the end of the first second with a course (W rows)."""
    w = course.shape[0]
    x = np.zeros((w, S))
    x[:, SG] = x[:, SD] = x[:, SW] = 1.0
    x[:, PSI] = _wrap(course - 0.5 * np.nan_to_num(yaw_guess))
    # the antenna's chord turns with the lever arm: solve course = h(psi) (dh/dpsi ~ 1)
    xa = np.concatenate([x, np.nan_to_num(yaw_guess)[:, None]], axis=1)
    for _ in range(4):
        xa[:, PSI] += _wrap(course - course_model(xa, dist, cfg.antenna_m)[0])
    psi = xa[:, PSI]
    psi_var = course_var + 0.02**2  # and half a second's yaw, not known better yet
    le, ln, de, dn = lever(psi, cfg.antenna_m)
    x[:, E], x[:, N], x[:, PSI] = fix[:, 0] - le, fix[:, 1] - ln, psi
    p = np.zeros((w, S, S))
    g2 = cfg.gnss.sigma_m**2
    for i, var in (
        (BG, cfg.gyro.bias_sd**2),
        (SG, cfg.gyro.scale_sd**2),
        (SD, cfg.dist_scale_sd**2),
        (SW, cfg.wheel_scale_sd**2),
        (BW, cfg.wheel_bias_sd**2),
        (CW, cfg.load_sd**2),
        (EW, cfg.wheel_error_sd**2),
        (BV, cfg.wheel_bias_speed_sd**2),
        (BD, cfg.gyro.drift_rate_sd() ** 2),
        (BDW, cfg.leak_rate_sd() ** 2),
        (GE, g2),
        (GN, g2),
    ):
        p[:, i, i] = var
    # p = fix − lever(ψ) − g: the fix's white noise, the drift (less g), the lever's turn
    white2 = cfg.gnss.white_m**2
    p[:, PSI, PSI] = psi_var
    p[:, E, E] = white2 + g2 + de * de * psi_var
    p[:, N, N] = white2 + g2 + dn * dn * psi_var
    p[:, E, N] = p[:, N, E] = de * dn * psi_var
    p[:, E, PSI] = p[:, PSI, E] = -de * psi_var
    p[:, N, PSI] = p[:, PSI, N] = -dn * psi_var
    p[:, E, GE] = p[:, GE, E] = -g2
    p[:, N, GN] = p[:, GN, N] = -g2
    return x, p


def _reversing(
    pa: np.ndarray,
    h_row: np.ndarray,
    innov: np.ndarray,
    r: np.ndarray,
    flip: np.ndarray,
    measured: np.ndarray,
    before: np.ndarray,
    gate: float,
) -> np.ndarray:
    """Which rows reverse this second (module docstring, Reversing).

    The gyro has updated the second's yaw ``δ`` (``measured`` rows); the rear
    wheels' yaw is compared with its forward prediction (``innov``, its Jacobian
    ``h_row``, noise ``r``) and with the reversed one, ``flip`` further away
    (``2 δ`` in the wheels' units), each in standard deviations of the forward
    innovation. A run starts on a second beyond the gate ahead and within it
    behind; once started, it goes on while the reversed prediction is the nearer
    (the wheel-yaw model, fitted going forwards, fits a reversing turn less well).
    Where the two predictions are too close to tell apart (a straight second), the
    row keeps what it was (``before``).
    """
    var = (h_row * (pa @ h_row[:, :, None])[:, :, 0]).sum(axis=1) + r
    g2 = gate * gate * var
    far_ahead = innov * innov > g2
    near_behind = (innov + flip) ** 2 <= g2
    telling = flip * flip > 4.0 * g2
    nearer_behind = (innov + flip) ** 2 < innov * innov
    decided = measured & np.isfinite(innov) & telling
    return np.where(decided, np.where(before, nearer_behind, far_ahead & near_behind), before)


def run(
    inputs: NavInputs,
    config: NavConfig | None = None,
    control: Control = "fused",
    keep_cov: bool = False,
    start: NavStart | None = None,
    snapshots: np.ndarray | None = None,
) -> NavTrack:
    """Filter every window of ``inputs`` over its seconds (module docstring).

    Args:
        inputs: the windows' per-second data.
        config: sensors, priors and random walks (default: :class:`NavConfig`).
        control: which yaw sensors to use: ``wheels``, ``gyro`` or ``fused``.
        keep_cov: keep the full covariance of every second (W·n·S² floats).
        start: rows that start from a given state (the rest wait for a course).
        snapshots: seconds (0-based, within ``[0, n)``) at whose end the state and
            its covariance are kept for every row.

    Returns:
        The track.

    Raises:
        ValueError: on an unknown control, a start or snapshots of the wrong shape.
    """
    if control not in CONTROLS:
        raise ValueError(f"control must be one of {CONTROLS}, got {control!r}")
    cfg = config or NavConfig()
    use_gyro, use_wheels = control in ("gyro", "fused"), control in ("wheels", "fused")
    dist = np.asarray(inputs.dist_m, np.float64)
    dist_var = np.asarray(inputs.dist_var_m2, np.float64)
    y_w = np.asarray(inputs.wheel_yaw_rad, np.float64)
    y_g = lag_compensated(inputs.gyro_yaw_rad, cfg.gyro.latency_s, inputs.gyro_yaw_before_rad)
    fe = np.asarray(inputs.fix_e_m, np.float64)
    fn = np.asarray(inputs.fix_n_m, np.float64)
    w, n = dist.shape
    told_back = (
        np.zeros((w, n), bool) if inputs.backwards is None else np.asarray(inputs.backwards, bool)
    )
    gn = cfg.gnss
    r_gyro = cfg.gyro.yaw_sd_rad() ** 2
    yaw_extra = np.zeros((w, n)) if inputs.yaw_var_rad2 is None else np.asarray(inputs.yaw_var_rad2)
    wheel_var = cfg.wheels.yaw_sd_rad() ** 2 + cfg.wheels.model_sd_rad**2
    phi = np.exp(-1.0 / gn.tau_s)
    q_g = gn.sigma_m**2 * (1.0 - phi * phi)
    # the drift's change over one second, per axis: noise on a course besides the white
    drift_step2 = 2.0 * gn.sigma_m**2 * (1.0 - phi)
    q_diag = np.zeros(S + 1)
    q_diag[PSI] = cfg.heading_walk**2
    q_diag[BG] = cfg.gyro.bias_walk_rad_s() ** 2
    q_diag[SG] = cfg.gyro_scale_walk**2
    q_diag[SD] = cfg.dist_scale_walk**2
    q_diag[SW] = cfg.wheel_scale_walk**2
    q_diag[BW] = cfg.wheel_bias_walk**2
    q_diag[CW] = cfg.load_walk**2
    q_diag[GE] = q_diag[GN] = q_g
    phi_w = np.exp(-1.0 / cfg.wheel_error_tau_s)
    q_diag[EW] = cfg.wheel_error_sd**2 * (1.0 - phi_w * phi_w)
    q_diag[BV] = cfg.wheel_bias_speed_walk**2
    q_diag[BDW] = cfg.leak_rate_sd() ** 2 / cfg.leak_change_s
    q_mat = np.diag(q_diag)
    scale_lo, scale_hi = 1.0 - cfg.scale_max_off, 1.0 + cfg.scale_max_off  # np.clip's bounds
    # the warm-up's drift rate decays and is not driven: a ramp whose start is unknown
    phi_d = np.exp(-1.0 / cfg.gyro.warm_tau_s)
    r_fix = np.broadcast_to(np.eye(2) * gn.white_m**2, (w, 2, 2))

    xs = np.full((w, n, S), np.nan)
    covs = np.full((w, n, S, S), np.nan) if keep_cov else None
    fix_pred = np.full((w, n, 2), np.nan)
    fix_cov = np.full((w, n, 2, 2), np.nan)
    started = np.zeros((w, n), bool)
    # rows that have not started carry a harmless state (unit scales) until they do
    x = np.zeros((w, S))
    x[:, SG] = x[:, SD] = x[:, SW] = 1.0
    p = np.broadcast_to(np.eye(S), (w, S, S)).copy()
    on = np.zeros(w, bool)
    if start is not None:
        on = np.asarray(start.on, bool).copy()
        if on.shape != (w,) or np.shape(start.x) != (w, S) or np.shape(start.p) != (w, S, S):
            raise ValueError(f"a start must hold {w} rows of the {S} states and covariances")
        x = np.where(on[:, None], start.x, x)
        p = np.where(on[:, None, None], start.p, p)
    snap = np.zeros(0, np.int64) if snapshots is None else np.asarray(snapshots, np.int64)
    if snap.size and (snap.min() < 0 or snap.max() >= n):
        raise ValueError(f"snapshots must be seconds in [0, {n}), got {snap.min()}..{snap.max()}")
    snap_slot: dict[int, list[int]] = {}
    for i, sec in enumerate(snap.tolist()):
        snap_slot.setdefault(sec, []).append(i)
    snap_x = np.full((w, snap.size, S), np.nan) if snapshots is not None else None
    snap_p = np.full((w, snap.size, S, S), np.nan) if snapshots is not None else None
    rejected = {"wheels": 0, "course": 0, "fix": 0, "reset": 0, "reversing": 0}
    fix_logpdf = np.zeros((w, n))
    wheel_logpdf = np.zeros((w, n))
    refused = np.zeros(w, np.int64)  # consecutive fixes the gate refused
    backwards = np.zeros(w, bool)  # in a reversing run (module docstring)
    since_stop = np.zeros((w, 2))  # east/north travel since the car last stood, forwards
    for k in range(n):
        d = dist[:, k]
        d0 = _nan0(d)
        ce, cn = fe[:, k + 1] - fe[:, k], fn[:, k + 1] - fn[:, k]
        chord = np.hypot(ce, cn)
        has_fix = np.isfinite(fe[:, k + 1]) & np.isfinite(fn[:, k + 1])
        fix_k = np.empty((w, 2))
        fix_k[:, 0], fix_k[:, 1] = fe[:, k + 1], fn[:, k + 1]
        # A course needs the car to move, by the odometry as well as by the fixes: a
        # standing car's fixes metres apart (a consumer receiver's noise) point anywhere.
        has_course = (
            has_fix & np.isfinite(chord) & (chord >= gn.min_course_m) & (d0 >= gn.min_course_m)
        )
        course = np.arctan2(ce, cn)
        # The course's fixes are the position updates' too: its white part counts twice
        # (4 instead of 2 sigma²) so that the two do not claim the same noise as news. Its
        # spread is taken over the odometry's distance, not over the chord, which the
        # fixes' noise lengthens as often as it turns it.
        course_var = (
            gn.course_sd_rad**2
            + (4.0 * gn.white_m**2 + drift_step2) / np.where(has_course, d, 1.0) ** 2
        )
        g_k = np.where(np.isfinite(y_g[:, k]), y_g[:, k], np.nan)
        wh_k = np.where(np.isfinite(y_w[:, k]), y_w[:, k], np.nan)
        told = told_back[:, k]  # the log says this second went backwards
        first = ~on & has_course
        if on.any():
            # 1. the second's yaw joins the state
            guess_g = x[:, SG] * (g_k - x[:, BG])
            c_d2 = 1.0 + x[:, CW] * d * d
            guess_w = x[:, SW] * (wh_k - x[:, EW]) / c_d2 + (x[:, BW] + x[:, BV] * d) * d
            guess_w = np.where(told, -guess_w, guess_w)
            delta0 = np.where(use_gyro & np.isfinite(g_k), guess_g, np.nan)
            delta0 = np.where(np.isfinite(delta0), delta0, np.where(use_wheels, guess_w, np.nan))
            delta0 = _nan0(delta0)
            xa = np.concatenate([x, delta0[:, None]], axis=1)
            pa = np.zeros((w, S + 1, S + 1))
            pa[:, :S, :S] = p
            pa[:, DELTA, DELTA] = cfg.delta_prior_sd**2
            measured = np.zeros(w, bool)
            if use_gyro:
                s_g, dl = xa[:, SG], xa[:, DELTA]
                h_row = np.zeros((w, S + 1))
                h_row[:, DELTA], h_row[:, SG], h_row[:, BG] = 1.0 / s_g, -dl / s_g**2, 1.0
                innov = g_k - (dl / s_g + xa[:, BG])
                xa, pa, ok, _ = _scalar_update(xa, pa, h_row, innov, r_gyro + yaw_extra[:, k], on)
                measured |= ok
            if use_wheels:
                s_w, dl, beta, c = xa[:, SW], xa[:, DELTA], xa[:, BW], xa[:, CW]
                c_d2 = 1.0 + c * d * d
                way = np.where(told, -1.0, 1.0)  # a told reverse: the reversed turn
                turn = way * dl - (beta + xa[:, BV] * d) * d
                h_row = np.zeros((w, S + 1))
                h_row[:, DELTA] = way * c_d2 / s_w
                h_row[:, BW] = -d * c_d2 / s_w
                h_row[:, CW] = turn * d * d / s_w
                h_row[:, SW] = -turn * c_d2 / s_w**2
                h_row[:, EW] = 1.0
                h_row[:, BV] = -d * d * c_d2 / s_w
                innov = wh_k - turn * c_d2 / s_w - xa[:, EW]
                r = wheel_var + (cfg.wheels.model_rel * _nan0(wh_k)) ** 2 + yaw_extra[:, k]
                if use_gyro:
                    flip = 2.0 * dl * c_d2 / s_w
                    before = backwards
                    backwards = _reversing(
                        pa, h_row, innov, r, flip, measured, backwards, cfg.yaw_gate
                    )
                    backwards &= on & (d0 >= cfg.reverse_stop_m) & (d0 <= cfg.reverse_max_m_s)
                    backwards &= ~told  # told, not guessed (nor its start turned round)
                    rejected["reversing"] += int(backwards.sum())
                    # the run's straight start, driven forwards so far, turned round
                    turned = backwards & ~before
                    xa[:, [E, N]] -= np.where(turned[:, None], 2.0 * since_stop, 0.0)
                    since_stop = np.where(turned[:, None], 0.0, since_stop)
                gate = np.where(measured, cfg.yaw_gate, np.inf)
                # with the gyro, a reversing second's wheel yaw is left out, told or not:
                # the wheel-yaw model, fitted going forwards, fits a reversing turn less well
                use = on & ~backwards & ~(told & use_gyro)
                xa, pa, ok, s_var = _scalar_update(xa, pa, h_row, innov, r, use, gate)
                wheel_logpdf[:, k] = np.where(
                    ok & measured, -0.5 * (np.log(2 * np.pi * s_var) + innov**2 / s_var), 0.0
                )
                rejected["wheels"] += int((use & np.isfinite(wh_k) & ~ok).sum())
            # 2. the arc of the second (backwards in a reversing second)
            d_signed = np.where(backwards | told, -d, d)
            xa_new, jac, ge, gnn = propagate(xa, d_signed)
            xa_new[:, GE] *= phi
            xa_new[:, GN] *= phi
            xa_new[:, EW] *= phi_w
            xa_new[:, BG] += xa[:, BD]  # the bias ramps while the sensor warms
            xa_new[:, BD] *= phi_d
            xa_new[:, BW] += xa[:, BDW]  # a leaking tyre's radius falls steadily
            jac[:, GE, GE] = jac[:, GN, GN] = phi
            jac[:, EW, EW] = phi_w
            jac[:, BG, BD] = 1.0
            jac[:, BD, BD] = phi_d
            jac[:, BW, BDW] = 1.0
            pa_new = _sandwich(pa, jac, MOVED_ROWS)
            pa_new += q_mat
            var_d = _nan0(dist_var[:, k])
            pa_new[:, E, E] += var_d * ge * ge
            pa_new[:, N, N] += var_d * gnn * gnn
            pa_new[:, E, N] += var_d * ge * gnn
            pa_new[:, N, E] += var_d * ge * gnn
            # a reversing run is slow throughout: a faster second cannot be one's start
            forwards = (
                on & ~backwards & ~told & (d0 >= cfg.reverse_stop_m) & (d0 <= cfg.reverse_max_m_s)
            )
            moved = xa_new[:, [E, N]] - xa[:, [E, N]]
            since_stop = np.where(forwards[:, None], since_stop + moved, 0.0)
            xa = _pick(on, xa_new, xa)
            pa = _pick(on, pa_new, pa)
            # 3. GNSS (the fix's prediction scored first, before any of it is seen)
            h2, h_mat = fix_model(xa, cfg.antenna_m)
            fix_logpdf[:, k] = fix_log_score(pa, h_mat, fix_k - h2, r_fix, on & has_fix, gn.gate)
            h, h_row = course_model(xa, d_signed, cfg.antenna_m)
            innov = _wrap(course - h)
            xa, pa, ok, _ = _scalar_update(
                xa, pa, h_row, innov, course_var, on & has_course, gn.gate
            )
            rejected["course"] += int((on & has_course & ~ok).sum())
            h2, h_mat = fix_model(xa, cfg.antenna_m)
            xa, pa, ok = _vector_update(xa, pa, h_mat, fix_k - h2, r_fix, on & has_fix, gn.gate)
            rejected["fix"] += int((on & has_fix & ~ok).sum())
            refused = np.where(on & has_fix, np.where(ok, 0, refused + 1), refused)
            # 4. marginalise the second's yaw; keep the model's terms where they mean
            # something (a projection: the load term cannot turn the wheels' yaw
            # around, scales stay near 1), else noisy courses can walk the weakly
            # observed ones into a region where 1 + c d² vanishes
            xa[:, CW] = np.minimum(np.maximum(xa[:, CW], cfg.load_min), cfg.load_max)
            for i in (SG, SD, SW):
                xa[:, i] = np.minimum(np.maximum(xa[:, i], scale_lo), scale_hi)
            x = _pick(on, xa[:, :S], x)
            p = _pick(on, pa[:, :S, :S], p)
        # A filter that has refused every fix for reset_after_s seconds has lost the car
        # (its own heading went wrong, e.g. the wheels counting a reversing turn the wrong
        # way round, and its covariance no longer covers it): start the pose afresh on
        # GNSS, keeping what it learnt about the sensors.
        reset = on & has_course & (refused >= cfg.reset_after_s)
        rejected["reset"] += int(reset.sum())
        refused = np.where(reset, 0, refused)
        first = first | reset
        if first.any():
            yaw_guess = np.where(use_gyro & np.isfinite(g_k), g_k, np.nan_to_num(wh_k))
            x0, p0 = _initial(
                course,
                course_var,
                fix_k,
                yaw_guess,
                d,
                cfg,
            )
            pose = np.zeros(S, bool)
            pose[[E, N, PSI, GE, GN]] = True
            keep = reset[:, None] & ~pose  # sensor states of a reset row stay
            x = np.where(first[:, None] & ~keep, x0, x)
            both = keep[:, :, None] & keep[:, None, :]
            p = np.where(reset[:, None, None] & both, p, np.where(first[:, None, None], p0, p))
            on = on | first
        p = 0.5 * (p + p.swapaxes(1, 2))
        h2, h_mat = fix_model(x, cfg.antenna_m)
        xs[:, k] = _pick(on, x, np.nan)
        fix_pred[:, k] = _pick(on, h2, np.nan)
        fix_cov[:, k] = _pick(on, h_mat @ p @ h_mat.swapaxes(1, 2) + r_fix, np.nan)
        if covs is not None:
            covs[:, k] = _pick(on, p, np.nan)
        for i in snap_slot.get(k, ()):
            snap_x[:, i] = xs[:, k]
            snap_p[:, i] = _pick(on, p, np.nan)
        started[:, k] = on
    return NavTrack(
        xs, covs, p, fix_pred, fix_cov, started, rejected, snap_x, snap_p, fix_logpdf, wheel_logpdf
    )
