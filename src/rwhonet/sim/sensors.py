"""Sensors: CAN wheel speeds, the yaw-rate gyro, the GNSS receiver and its degraded stretches.

Every sensor samples the 50 Hz ground truth at the record rate. Models and
parameter sources are in docs/simulator.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.signal import lfilter

from rwhonet.config import SimCan, SimGnss, SimGyro
from rwhonet.geo import latlon_from_offsets_deg

FAULT_KINDS = ("low_sats", "frozen", "jump", "gap")
# Duration ranges (s) of the degraded stretches. A frozen fix must outlast
# validate.gnss.frozen_min_s (2 s); a gap must exceed validate.gnss.max_gap_s (0.5 s).
_FAULT_S = {"low_sats": (10.0, 40.0), "frozen": (3.0, 10.0), "jump": (1.0, 3.0), "gap": (1.0, 5.0)}
_FAULT_MOVING_M_S = 3.0  # a frozen fix is placed where the car moves (wheels turn)
_FAULT_EDGE_S = 30.0  # keep faults this far from the ends and from each other


def gauss_markov(
    n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator, rows: int = 1
) -> np.ndarray:
    """Stationary first-order Gauss-Markov process (exact discretisation, AR(1)).

    ``x_k = phi x_{k-1} + w_k`` with ``phi = exp(-dt / tau)`` and
    ``w_k ~ N(0, sigma^2 (1 - phi^2))``; ``x_0 ~ N(0, sigma^2)``, so every sample
    has standard deviation ``sigma`` and the autocorrelation at lag ``T`` is
    ``exp(-T / tau)`` (the usual GNSS position-error model, e.g. Groves 2013).

    Args:
        n: samples per row.
        dt_s: sampling interval.
        sigma: stationary standard deviation.
        tau_s: correlation time.
        rng: random generator.
        rows: independent processes (one per axis).

    Returns:
        Array (rows, n).
    """
    phi = np.exp(-dt_s / tau_s)
    w = rng.standard_normal((rows, n)) * sigma * np.sqrt(1.0 - phi**2)
    if n:
        w[:, 0] = rng.standard_normal(rows) * sigma
    return lfilter([1.0], [1.0, -phi], w, axis=1)


def filtered_gauss_markov(
    n: int,
    dt_s: float,
    sigma: float,
    tau_s: float,
    filter_tau_s: float,
    rng: np.random.Generator,
    rows: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """A Gauss-Markov drift seen through a first-order low-pass filter (stationary).

    ``x`` is a first-order Gauss-Markov process (correlation time ``tau_s``);
    the output ``e`` follows it through ``de/dt = (x - e) / filter_tau_s``, a
    receiver's navigation filter smoothing a slowly drifting pseudorange error.
    ``e`` is a second-order process with a differentiable (smooth) path:
    autocorrelation ``(a exp(-T/a) - b exp(-T/b)) / (a - b)`` with ``a = tau_s``,
    ``b = filter_tau_s`` (see :func:`gnss_error_autocorrelation`). Both stages
    are discretised exactly for a piecewise-constant input (two IIR filters),
    the first sample is drawn from the stationary joint distribution of
    ``(x, e)``, and ``x`` is scaled so that ``e`` has std ``sigma`` exactly.

    Args:
        n: samples per row.
        dt_s: sampling interval.
        sigma: stationary standard deviation of the output.
        tau_s: correlation time of the drift.
        filter_tau_s: time constant of the low-pass filter.
        rng: random generator.
        rows: independent processes (one per axis).

    Returns:
        ``(e, de_dt)``, each (rows, n): the process and its rate of change.
    """
    phi = np.exp(-dt_s / tau_s)
    beta = np.exp(-dt_s / filter_tau_s)
    # Stationary moments of the discrete cascade for a unit-variance drift x:
    # C = Cov(x_k, e_k), V = Var(e_k).
    c = (1.0 - beta) / (1.0 - beta * phi)
    v = (2.0 * beta * (1.0 - beta) * phi * c + (1.0 - beta) ** 2) / (1.0 - beta**2)
    scale = sigma / np.sqrt(v)
    if n == 0:
        empty = np.zeros((rows, 0))
        return empty, empty
    w = rng.standard_normal((rows, n)) * np.sqrt(1.0 - phi**2)
    e0 = rng.standard_normal(rows) * np.sqrt(v)
    w[:, 0] = c / v * e0 + rng.standard_normal(rows) * np.sqrt(1.0 - c**2 / v)
    x = lfilter([1.0], [1.0, -phi], w, axis=1)
    e, _ = lfilter([1.0 - beta], [1.0, -beta], x, axis=1, zi=(e0 - (1.0 - beta) * x[:, 0])[:, None])
    return e * scale, (x - e) * scale / filter_tau_s


def gnss_error_autocorrelation(lag_s: np.ndarray | float, tau_s: float, filter_tau_s: float):
    """Autocorrelation of the filtered Gauss-Markov error at lag ``T`` (continuous time).

    ``rho(T) = (a exp(-T/a) - b exp(-T/b)) / (a - b)`` with ``a = tau_s`` and
    ``b = filter_tau_s``; for ``a = b`` its limit ``(1 + T/a) exp(-T/a)``.

    Args:
        lag_s: lag(s), s.
        tau_s: drift correlation time.
        filter_tau_s: filter time constant.

    Returns:
        The autocorrelation, like ``lag_s``.
    """
    t = np.abs(np.asarray(lag_s, dtype=np.float64))
    a, b = float(tau_s), float(filter_tau_s)
    if abs(a - b) < 1e-9 * a:
        return (1.0 + t / a) * np.exp(-t / a)
    return (a * np.exp(-t / a) - b * np.exp(-t / b)) / (a - b)


def gnss_increment_std_m(gnss: SimGnss, lag_s: float = 1.0) -> float:
    """Standard deviation of the open-sky position error's change over ``lag_s``, per axis.

    ``Var(e(t + T) - e(t)) = 2 sigma^2 (1 - rho(T)) + 2 white^2``: what one
    second of GNSS displacement carries as noise along the direction of travel,
    i.e. the per-second label noise of a perfect odometer (docs/simulator.md,
    "Label noise").

    Args:
        gnss: the receiver.
        lag_s: the interval, s.

    Returns:
        The standard deviation, m.
    """
    rho = float(gnss_error_autocorrelation(lag_s, gnss.tau_s, gnss.filter_tau_s))
    return float(np.sqrt(2.0 * gnss.sigma_m**2 * (1.0 - rho) + 2.0 * gnss.white_m**2))


def satellites(n: int, hz: int, sats: list[int], rng: np.random.Generator) -> np.ndarray:
    """Satellites in the fix: an integer that changes every 20-120 s (open sky).

    Args:
        n: samples.
        hz: sampling rate.
        sats: ``[min, max]`` satellites.
        rng: random generator.

    Returns:
        int64 array (n,).
    """
    duration = n / hz
    changes = np.cumsum(rng.uniform(20.0, 120.0, size=int(duration / 20.0) + 2))
    values = rng.integers(sats[0], sats[1] + 1, size=changes.size + 1)
    return values[np.searchsorted(changes, np.arange(n) / hz, side="right")].astype(np.int64)


def can_wheel_speeds(
    t_record_s: np.ndarray,
    t_true_s: np.ndarray,
    omega_rad_s: np.ndarray,
    can: SimCan,
    rng: np.random.Generator,
    noise: bool = True,
) -> np.ndarray:
    """Wheel speeds as the CAN bus carries them.

    The ABS sensor's value is ``latency_s`` old, carries white noise, reads 0
    below ``min_speed_rad_s`` (too few tooth pulses per window) and is
    quantised to ``quantum_rad_s``. It is a magnitude: a passive ABS sensor does
    not tell forwards from backwards.

    Args:
        t_record_s: record times (m,).
        t_true_s: ground-truth times (n,).
        omega_rad_s: true wheel angular speed magnitudes (4, n).
        can: CAN signal parameters.
        rng: random generator.
        noise: False for an ideal sensor (no latency, noise, dead band or quantisation).

    Returns:
        Measured wheel speeds (4, m), rad/s.
    """
    if not noise:
        return np.stack([np.interp(t_record_s, t_true_s, w) for w in omega_rad_s])
    t = np.maximum(t_record_s - can.latency_s, t_true_s[0])
    true = np.stack([np.interp(t, t_true_s, w) for w in omega_rad_s])
    measured = true + rng.standard_normal(true.shape) * can.noise_rad_s
    measured = np.where(true < can.min_speed_rad_s, 0.0, np.maximum(measured, 0.0))
    return np.round(measured / can.quantum_rad_s) * can.quantum_rad_s


@dataclass(frozen=True)
class YawRate:
    """The yaw-rate channel at the record rate and the errors drawn for this drive.

    Attributes:
        deg_s: measured yaw rate, deg/s, positive to the left (counter-clockwise).
        bias_deg_s: the whole bias at each record row (turn-on + instability +
            temperature), deg/s.
        temperature_rise_k: the sensor's temperature over its start, K.
        turn_on_bias_deg_s: the turn-on bias drawn for this drive, deg/s.
    """

    deg_s: np.ndarray
    bias_deg_s: np.ndarray
    temperature_rise_k: np.ndarray
    turn_on_bias_deg_s: float


def sensor_warmup_k(t_s: np.ndarray, gyro: SimGyro) -> np.ndarray:
    """Temperature rise of the yaw-rate sensor over a drive from a cold start.

    ``dT(t) = warmup_k (1 - exp(-t / warmup_tau_s))``: the cabin (or the ESC's
    control unit) warming from ambient towards its running temperature, a
    first-order lag like the tyres' (docs/simulator.md, Section 7).

    Args:
        t_s: time since the start of the drive, s.
        gyro: the sensor.

    Returns:
        Temperature rise, K, like ``t_s``.
    """
    return gyro.warmup_k * -np.expm1(-np.asarray(t_s, dtype=np.float64) / gyro.warmup_tau_s)


def yaw_rate_sensor(
    t_record_s: np.ndarray,
    t_true_s: np.ndarray,
    heading_rad: np.ndarray,
    gyro: SimGyro,
    rng: np.random.Generator,
    errors: bool = True,
) -> YawRate:
    """The ESC yaw-rate sensor's channel, sampled at the record rate.

    Each value is the sensor's mean rate over the record period ending
    ``latency_s`` before its row, ``(psi(t - L) - psi(t - L - T)) / T`` of the
    body heading ``psi`` that moves the car (the output of a digital gyro is
    the average of its decimation window), so that a perfect sensor summed
    over the rows, times ``T``, gives the heading change exactly. Then

        measured = (1 + scale_error_pct / 100) true + b0 + b_GM(t) + tco dT(t) + n

    with ``b0 ~ N(0, bias_sigma^2)`` drawn per drive (turn-on bias), ``b_GM`` a
    stationary first-order Gauss-Markov bias instability, ``dT`` the sensor's
    warm-up (:func:`sensor_warmup_k`) and ``n`` white noise of the noise
    density averaged over the period (noise-equivalent bandwidth ``1 / (2 T)``),
    quantised to ``quantum_deg_s``. Sources of every value: docs/simulator.md,
    Section 7.

    Args:
        t_record_s: record times (m,), evenly spaced.
        t_true_s: ground-truth times (n,).
        heading_rad: body heading at ``t_true_s``, counter-clockwise, unwrapped (n,).
        gyro: the sensor.
        rng: the sensor's own random generator.
        errors: False for a perfect sensor (no bias, scale error, noise,
            quantisation or latency; the mean rate over each record period).

    Returns:
        The channel and the errors drawn.
    """
    m = t_record_s.size
    period = float(t_record_s[1] - t_record_s[0]) if m > 1 else 1.0
    latency = gyro.latency_s if errors else 0.0
    # Before the first truth sample the car stands at its initial heading (np.interp holds it).
    t_end = t_record_s - latency
    psi = np.interp(np.concatenate([t_end[:1] - period, t_end]), t_true_s, heading_rad)
    true_deg_s = np.degrees(np.diff(psi)) / period
    t_drive = t_record_s - t_record_s[0]
    rise = sensor_warmup_k(t_drive, gyro)
    if not errors:
        return YawRate(true_deg_s, np.zeros(m), rise, 0.0)
    b0 = float(rng.normal(0.0, gyro.bias_sigma_deg_s))
    drift = gauss_markov(m, period, gyro.instability_sigma_deg_s, gyro.instability_tau_s, rng)[0]
    bias = b0 + drift + gyro.temp_coeff_deg_s_k * rise
    noise = rng.standard_normal(m) * gyro.noise_density_deg_s_rthz / np.sqrt(2.0 * period)
    measured = (1.0 + gyro.scale_error_pct / 100.0) * true_deg_s + bias + noise
    if gyro.quantum_deg_s > 0:
        measured = np.round(measured / gyro.quantum_deg_s) * gyro.quantum_deg_s
    return YawRate(measured, bias, rise, b0)


@dataclass(frozen=True)
class Fault:
    """A degraded GNSS stretch, record rows ``[i0, i1)``."""

    kind: str
    i0: int
    i1: int


def place_faults(
    kinds: list[str] | tuple[str, ...],
    speed_m_s: np.ndarray,
    hz: int,
    rng: np.random.Generator,
) -> list[Fault]:
    """Choose where each requested degraded stretch happens.

    Stretches do not overlap, stay ``30 s`` away from the ends and from each
    other, and a frozen fix only happens while the car moves (a fix frozen at
    standstill would be indistinguishable from a good one).

    Args:
        kinds: fault kinds (:data:`FAULT_KINDS`), one stretch each.
        speed_m_s: speed at the record rows.
        hz: record rate.
        rng: random generator.

    Returns:
        The faults, by start row.
    """
    n = speed_m_s.size
    edge = int(_FAULT_EDGE_S * hz)
    free = np.ones(n, dtype=bool)
    free[:edge] = False
    free[max(n - edge, 0) :] = False
    faults: list[Fault] = []
    for kind in kinds:
        if kind not in FAULT_KINDS:
            raise ValueError(f"unknown GNSS fault {kind!r}; expected one of {FAULT_KINDS}")
        length = int(round(rng.uniform(*_FAULT_S[kind]) * hz))
        if length >= n:
            continue
        ok = sliding_window_view(free, length).all(axis=1)
        if kind == "frozen":
            ok &= sliding_window_view(speed_m_s, length).min(axis=1) > _FAULT_MOVING_M_S
        starts = np.flatnonzero(ok)
        if starts.size == 0:
            continue  # drive too short or too slow for this fault
        i0 = int(rng.choice(starts))
        faults.append(Fault(kind, i0, i0 + length))
        free[max(i0 - edge, 0) : i0 + length + edge] = False
    return sorted(faults, key=lambda f: f.i0)


@dataclass(frozen=True)
class GnssTrack:
    """GNSS receiver output at the record rate."""

    lat_deg: np.ndarray
    lon_deg: np.ndarray
    height_m: np.ndarray
    speed_m_s: np.ndarray
    heading_deg: np.ndarray
    vertical_speed_m_s: np.ndarray
    sats: np.ndarray


def gnss_track(
    east_m: np.ndarray,
    north_m: np.ndarray,
    v_east_m_s: np.ndarray,
    v_north_m_s: np.ndarray,
    origin: tuple[float, float, float],
    gnss: SimGnss,
    hz: int,
    rng: np.random.Generator,
    faults: list[Fault],
    heading_rad: np.ndarray,
    noise: bool = True,
) -> GnssTrack:
    """Fixes of the antenna: truth + a smooth receiver error + white noise, then faults.

    Position error per axis (east, north, up): a slow Gauss-Markov drift seen
    through the receiver's navigation filter (:func:`filtered_gauss_markov`;
    ``sigma_m``, ``tau_s``, ``filter_tau_s``; up scaled by ``vertical_factor``)
    plus white noise ``white_m``. The local east/north position is mapped to
    WGS84 by the geodesic direct problem from ``origin`` (azimuthal
    equidistant, :func:`rwhonet.geo.latlon_from_offsets_deg`). Speed and course
    come from the antenna velocity plus the error's rate of change (the filter
    moves position and velocity together) plus white speed noise; the course
    is held while the car is (nearly) stopped. Faults: ``low_sats`` 2-3
    satellites and a multipath error (a fast Gauss-Markov process,
    ``multipath_sigma_m``, ``multipath_tau_s``) on top; ``jump`` the fix jumps
    30-100 m away; ``frozen`` the receiver repeats its last fix; ``gap`` rows
    are dropped by the writer.

    Args:
        east_m: antenna east position in the local frame (m,).
        north_m: antenna north position (m,).
        v_east_m_s: antenna east velocity (m,).
        v_north_m_s: antenna north velocity (m,).
        origin: ``(lat_deg, lon_deg, height_m)`` of the local frame's origin.
        gnss: receiver parameters.
        hz: record rate.
        rng: random generator.
        faults: degraded stretches (from :func:`place_faults`).
        heading_rad: body heading (counter-clockwise from east), the course a
            receiver reports before the car first moves.
        noise: False for a perfect receiver (truth only; faults still applied).

    Returns:
        The receiver output.
    """
    n = east_m.size
    dt = 1.0 / hz
    sats = satellites(n, hz, gnss.sats, rng)
    err = np.zeros((3, n))
    rate = np.zeros((3, n))
    speed_noise = np.zeros(n)
    if noise:
        scale = np.array([1.0, 1.0, gnss.vertical_factor])[:, None]
        err, rate = filtered_gauss_markov(
            n, dt, gnss.sigma_m, gnss.tau_s, gnss.filter_tau_s, rng, rows=3
        )
        err, rate = err * scale, rate * scale
        err[:2] += rng.standard_normal((2, n)) * gnss.white_m
        speed_noise = rng.standard_normal(n) * gnss.speed_noise_m_s
    for f in faults:
        sl = slice(f.i0, f.i1)
        if f.kind == "low_sats":
            sats[sl] = rng.integers(2, 4, size=f.i1 - f.i0)
            err[:2, sl] += gauss_markov(
                f.i1 - f.i0, dt, gnss.multipath_sigma_m, gnss.multipath_tau_s, rng, rows=2
            )
        elif f.kind == "jump":
            dist = rng.uniform(30.0, 100.0)
            az = rng.uniform(0.0, 2.0 * np.pi)
            err[:2, sl] += np.array([[dist * np.cos(az)], [dist * np.sin(az)]])
    lat0, lon0, h0 = origin
    lat, lon = latlon_from_offsets_deg(lat0, lon0, east_m + err[0], north_m + err[1])
    ve, vn = v_east_m_s + rate[0], v_north_m_s + rate[1]
    speed = np.maximum(np.hypot(ve, vn) + speed_noise, 0.0)
    course = np.degrees(np.arctan2(ve, vn)) % 360.0
    valid = speed > 0.5
    if n and not valid[0]:  # before the first move: the parked car's heading
        course[0] = (90.0 - np.degrees(heading_rad[0])) % 360.0
        valid[0] = True
    course = course[np.maximum.accumulate(np.where(valid, np.arange(n), 0))]
    height = h0 + err[2]
    # Doppler vertical velocity: the error's rate plus white noise (a flat world).
    vertical = rate[2] + (rng.standard_normal(n) * 2.0 * gnss.speed_noise_m_s if noise else 0.0)
    for f in faults:
        if f.kind == "frozen":
            hold = max(f.i0 - 1, 0)
            for arr in (lat, lon, height, speed, course, vertical):
                arr[f.i0 : f.i1] = arr[hold]
    return GnssTrack(lat, lon, height, speed, course, vertical, sats)
