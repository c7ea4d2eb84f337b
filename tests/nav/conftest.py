"""Synthetic drives drawn from the navigation filter's own model, with their truth.

Written from the model's equations (``rwhonet.nav.filter``'s docstring), not from
its code: the truth moves along arcs of constant curvature per second, every
sensor and every slowly varying error is drawn from the distribution the filter
assumes (priors, random walks, Gauss-Markov processes, white noise). On such
drives a correct filter is consistent: its errors match its covariance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rwhonet.nav import NavConfig, NavInputs

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class Truth:
    """What the filter estimates, per run and second (arrays (W, n)) or per run (W,)."""

    e: np.ndarray
    n: np.ndarray
    psi: np.ndarray
    b_g: np.ndarray
    s_g: np.ndarray
    travel: np.ndarray


def antenna(e, n, psi, antenna_m):
    """The antenna ``antenna_m`` (ahead, left) of the rear axle at azimuth ``psi``."""
    x, y = antenna_m
    return e + x * np.sin(psi) - y * np.cos(psi), n + x * np.cos(psi) + y * np.sin(psi)


def gauss_markov(rng, shape, sigma, tau_s):
    """Stationary first-order Gauss-Markov processes along the last axis (1 s steps)."""
    phi = np.exp(-1.0 / tau_s)
    out = np.empty(shape)
    out[..., 0] = rng.normal(0.0, sigma, shape[:-1])
    step = rng.normal(0.0, sigma * np.sqrt(1.0 - phi * phi), shape)
    for k in range(1, shape[-1]):
        out[..., k] = phi * out[..., k - 1] + step[..., k]
    return out


def walk(rng, start, sd_per_s, n):
    """Random walks from ``start`` (W,): ``n`` values, the first ``start`` itself."""
    steps = rng.normal(0.0, sd_per_s, (start.size, n - 1))
    return start[:, None] + np.c_[np.zeros(start.size), np.cumsum(steps, axis=1)]


def model_drives(rng, cfg: NavConfig, w: int, n: int, *, exact: bool = False):
    """``w`` drives of ``n`` seconds of S-bends at 6-14 m/s, sensed as the filter's model says.

    Args:
        rng: random generator.
        cfg: the filter's settings: every error is drawn from them.
        w: drives.
        n: seconds each.
        exact: every error zero (perfect sensors, perfect odometry, no GNSS error).

    Returns:
        ``(inputs, truth)``.
    """
    k = np.arange(n)
    phase = rng.uniform(0.0, TWO_PI, (w, 2))
    d = 10.0 + 4.0 * np.sin(k / 50.0 + phase[:, :1])
    delta = 0.06 * np.sin(k / 20.0 + phase[:, 1:])
    psi0 = rng.uniform(-np.pi, np.pi, w)
    gy, wh, gn = cfg.gyro, cfg.wheels, cfg.gnss

    def draw(sd, shape=(w,)):
        return np.zeros(shape) if exact else rng.normal(0.0, sd, shape)

    def drift(start_sd, walk_sd, centre=0.0):
        """A slow state as the filter models it: its prior, then a random walk; the value a
        second uses is the one at that second's start."""
        if exact:
            return np.full((w, n), centre)
        return walk(rng, centre + draw(start_sd), walk_sd, n + 1)[:, :-1]

    dist_var = np.full((w, n), 0.0 if exact else 0.05**2)
    s_d = drift(cfg.dist_scale_sd, cfg.dist_scale_walk, 1.0)
    travel = s_d * d + draw(0.05, (w, n))
    # the heading walks after each second's arc (the filter's process noise on psi)
    psi = (
        psi0[:, None] - np.cumsum(delta, axis=1) + np.cumsum(draw(cfg.heading_walk, (w, n)), axis=1)
    )
    mid = np.c_[psi0, psi[:, :-1]] - 0.5 * delta
    chord = travel * np.sinc(delta / TWO_PI)
    e = np.cumsum(chord * np.sin(mid), axis=1)
    nn = np.cumsum(chord * np.cos(mid), axis=1)

    s_g = drift(gy.scale_sd, cfg.gyro_scale_walk, 1.0)
    # the bias: its prior, a random walk (instability), and the warm-up's ramp: a drift
    # rate drawn at the start that decays with the warm-up's time constant
    rate = draw(gy.drift_rate_sd())[:, None] * np.exp(-np.arange(n) / gy.warm_tau_s)
    b_g = drift(gy.bias_sd, gy.bias_walk_rad_s()) + np.c_[np.zeros(w), np.cumsum(rate, 1)[:, :-1]]
    gyro = delta / s_g + b_g + draw(gy.yaw_sd_rad(), (w, n))
    s_w = drift(cfg.wheel_scale_sd, cfg.wheel_scale_walk, 1.0)
    beta = drift(cfg.wheel_bias_sd, cfg.wheel_bias_walk)
    beta_v = drift(cfg.wheel_bias_speed_sd, cfg.wheel_bias_speed_walk)
    c = drift(cfg.load_sd, cfg.load_walk)
    eps = (
        np.zeros((w, n))
        if exact
        else gauss_markov(rng, (w, n), cfg.wheel_error_sd, cfg.wheel_error_tau_s)
    )
    wheel_sd = np.sqrt(wh.yaw_sd_rad() ** 2 + wh.model_sd_rad**2)
    wheels = (delta - (beta + beta_v * d) * d) * (1.0 + c * d * d) / s_w + eps
    wheels = wheels + draw(wheel_sd, (w, n))

    # fixes: the one before the first second, then one per second
    ant_e, ant_n = antenna(
        np.c_[np.zeros(w), e], np.c_[np.zeros(w), nn], np.c_[psi0, psi], cfg.antenna_m
    )
    g = np.zeros((2, w, n + 1)) if exact else gauss_markov(rng, (2, w, n + 1), gn.sigma_m, gn.tau_s)
    fix_e = ant_e + g[0] + draw(gn.white_m, (w, n + 1))
    fix_n = ant_n + g[1] + draw(gn.white_m, (w, n + 1))
    inputs = NavInputs(d, dist_var, wheels, gyro, fix_e, fix_n)
    return inputs, Truth(e, nn, psi, b_g, s_g, travel)
