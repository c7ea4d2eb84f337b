"""The filter's noise, from the sensors' stated error models.

Every figure the filter needs is a per-second variance or random walk, derived
here from what a data sheet or a CAN database states. The defaults are generic
automotive figures, the same as ``params.yaml``'s ``evaluate.navigation``
(docs/positioning.md gives each one's source): what the filter assumes for a car
that comes with no data sheet.

- **gyro** (the ESC's yaw-rate sensor): the integral of ``hz`` samples over one
  second carries the angle random walk of its noise density ``N`` (``N²·1 s``,
  IEEE Std 952 / 1431's definition) plus the rounding of each sample to the
  LSB (``LSB²/12`` per sample, white when the noise dithers it), weighted by
  the trapezoid rule the pipeline integrates with (:func:`trapezoid_weight_sq`);
  its bias wanders as a first-order Gauss-Markov process of standard deviation
  ``B`` (bias instability) and correlation time ``τ``, which the filter
  carries as a random walk of ``2 B² / τ`` per second (the process's
  short-term increment); and it drifts with temperature while the sensor
  warms up after power-on: a rate (``°/s per K`` times the warm-up's initial
  ``K per s``) that decays with the warm-up's time constant, which the filter
  carries as a state of its own (a ramp, not a random walk: a random walk
  of the same rate per square-root second would grow as ``r sqrt(T)`` where
  the ramp grows as ``r T``, 13 times less over 180 s); and its channel reads
  the turn late (the sensor's low-pass, the CAN cycle, the logger's stamping:
  ``latency_s``), which leaves the integrated heading ``latency_s`` behind the
  car's, ``latency_s`` times the yaw rate: in a bend, a heading error the fixes
  see and a dead-reckoned track carries (:func:`lag_compensated`);
- **wheels**: the rear wheels' travel difference over one second, from CAN
  wheel speeds with white noise ``σ`` and resolution ``q`` (rounding: ``q²/12``
  per sample) on both wheels, times ``r / b`` (radius over rear track);
- **GNSS**: its position error is a Gauss-Markov drift (``σ``, ``τ``) plus white
  noise per fix; a course from two fixes ``D`` metres apart is off by about
  ``sqrt(2) σ_white / D`` plus the drift's change over the second.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rwhonet.contracts import ROWS_PER_SECOND

GATE_SD = 5.0  # the filter's default gates: standard deviations beyond which a value is an outlier


def trapezoid_weight_sq(rows_per_second: int = ROWS_PER_SECOND) -> float:
    """Sum of the squared trapezoid weights of one second's samples, in seconds².

    The integral over one second of a rate sampled at ``h = 1 / rows`` is
    ``h (x_0/2 + x_1 + ... + x_(rows-1) + x_rows/2)``: white noise of variance
    ``v`` per sample gives the integral the variance ``v h² (rows − 1/2)``.

    Args:
        rows_per_second: samples per second.

    Returns:
        ``h² (rows − 1/2)``, s².
    """
    h = 1.0 / rows_per_second
    return h * h * (rows_per_second - 0.5)


@dataclass(frozen=True)
class GyroSpec:
    """An automotive yaw-rate sensor's error terms (rad/s unless stated).

    Attributes:
        noise_density: white rate noise, rad/s/sqrt(Hz).
        lsb: resolution of the CAN signal, rad/s.
        bias_sd: spread of the turn-on bias (the filter's prior), rad/s.
        bias_instability: Gauss-Markov bias wander, rad/s.
        bias_tau_s: its correlation time, s.
        temp_drift_per_k: bias change per kelvin, rad/s/K.
        warm_rate_k_s: the sensor's warm-up rate at power-on, K/s.
        warm_tau_s: the warm-up's time constant, s (the drift rate decays with it).
        scale_sd: spread of the scale-factor error (the filter's prior).
        latency_s: how late the channel reads the turn against the fixes, s
            (:func:`lag_compensated`; 0: read as stamped).
    """

    noise_density: float = float(np.radians(0.02))
    lsb: float = float(np.radians(0.05))
    bias_sd: float = float(np.radians(0.5))
    bias_instability: float = float(np.radians(0.01))
    bias_tau_s: float = 300.0
    temp_drift_per_k: float = float(np.radians(0.01))
    warm_rate_k_s: float = 15.0 / 600.0
    warm_tau_s: float = 600.0
    scale_sd: float = 0.02
    latency_s: float = 0.0

    def yaw_sd_rad(self, rows_per_second: int = ROWS_PER_SECOND) -> float:
        """Noise of one second's integrated yaw as the filter reads it (lag-compensated), rad.

        The compensation (:func:`lag_compensated`) adds ``L`` times the difference of
        two seconds' yaws, so each second's noise enters ``(1 + L)² + L²`` times.
        """
        quant = self.lsb**2 / 12.0 * trapezoid_weight_sq(rows_per_second)
        gain = (1.0 + self.latency_s) ** 2 + self.latency_s**2
        return float(np.sqrt((self.noise_density**2 * 1.0 + quant) * gain))

    def bias_walk_rad_s(self) -> float:
        """Random walk of the bias per square-root second (its instability), rad/s/sqrt(s)."""
        return float(np.sqrt(2.0 * self.bias_instability**2 / self.bias_tau_s))

    def drift_rate_sd(self) -> float:
        """Spread of the bias's drift rate at power-on (warming up), rad/s per s."""
        return float(abs(self.temp_drift_per_k) * self.warm_rate_k_s)


def lag_compensated(
    yaw_rad: np.ndarray, latency_s: float, before_rad: np.ndarray | None = None
) -> np.ndarray:
    """Each second's gyro yaw as the turn of that second, for a channel ``latency_s`` late.

    A channel that reads the yaw rate ``L`` seconds late integrates over second
    ``k`` the turn of ``[k − 1 − L, k − L]``: summed, the heading it gives lags the
    car's by ``L`` times the rate. Adding ``L`` times the change of rate since the
    second before, ``y_k + L (y_k − y_(k−1))``, makes the sum the lagging heading
    plus ``L`` times the latest second's mean rate, which is half a second old: on a
    turn whose rate changes by ``a`` per second the heading then stays behind by
    ``a L (1 + L) / 2`` instead of ``L`` times the rate. Causal: a stream can do
    it second by second; on simulated drives it predicted the fixes better than
    the interpolation towards the next second's yaw, which a stream does not have
    yet (docs/positioning.md).

    Args:
        yaw_rad: (..., n) the gyro's yaw over each second, rad (NaN: none).
        latency_s: ``L``, s (0: unchanged).
        before_rad: (...,) the yaw over the second before the first (NaN or None:
            none; the first second is then taken as read).

    Returns:
        The compensated yaws, (..., n); a second with no yaw before it as read.
    """
    y = np.asarray(yaw_rad, np.float64)
    if latency_s == 0.0 or y.shape[-1] == 0:
        return y
    first = np.full(y.shape[:-1], np.nan) if before_rad is None else np.asarray(before_rad)
    prev = np.concatenate([np.asarray(first, np.float64)[..., None], y[..., :-1]], axis=-1)
    return np.where(np.isfinite(prev), y + latency_s * (y - prev), y)


@dataclass(frozen=True)
class WheelSpec:
    """The rear wheels' CAN speeds and the geometry that turns them into yaw.

    Attributes:
        quantum_rad_s: resolution of the wheel-speed signal, rad/s.
        noise_rad_s: white noise of each sample, rad/s.
        radius_m: nominal rolling radius, m.
        track_rear_m: rear track, m.
        model_sd_rad: what the wheel-yaw model (scale, bias per metre, load
            transfer) leaves per second besides the sensor noise: slip,
            unequal load transfer, rad.
        model_rel: the same, as a share of the second's yaw.
    """

    quantum_rad_s: float = 0.01
    noise_rad_s: float = 0.03
    radius_m: float = 0.294
    track_rear_m: float = 1.46
    model_sd_rad: float = 0.001
    model_rel: float = 0.01

    def yaw_sd_rad(self, rows_per_second: int = ROWS_PER_SECOND) -> float:
        """Noise of one second's wheel yaw from the sensors alone, rad."""
        per_sample = self.noise_rad_s**2 + self.quantum_rad_s**2 / 12.0
        angle_var = per_sample * trapezoid_weight_sq(rows_per_second)
        return float(self.radius_m / self.track_rear_m * np.sqrt(2.0 * angle_var))


@dataclass(frozen=True)
class GnssSpec:
    """The receiver's position error (per axis, m) and when its course is used.

    Attributes:
        sigma_m: stationary spread of the Gauss-Markov drift.
        tau_s: its correlation time, s.
        white_m: white noise per fix.
        course_sd_rad: course noise left besides the fixes' white noise (the
            drift's change over a second, the antenna's sway), rad.
        min_course_m: a course needs its two fixes at least this far apart.
        gate: innovations beyond this many standard deviations are left out
            (jumps), for positions and courses alike.
    """

    sigma_m: float = 1.5
    tau_s: float = 100.0
    white_m: float = 0.05
    course_sd_rad: float = 0.01
    min_course_m: float = 3.0
    gate: float = GATE_SD
