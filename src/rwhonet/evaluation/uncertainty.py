"""How sure each odometry model is: a per-second variance of its distance error, and its check.

Beyond the paper (issue 17, item 3). Every odometry model (the WPMs, G, S, every
recipe, WPM-m) gives each second a distance; this module gives it a variance,

    σ_t² = a + b d_t²            (d_t the model's distance of second t),

a floor (the GNSS label's own noise, standing still) plus an error proportional
to the distance (a radius, a slip). ``a`` and ``b`` are fitted by Gaussian
likelihood (:func:`fit_variance`) on seconds the pipeline may fit on, never a
target test drive: the target *training* drives' scored seconds (after their
first max(m) s) for the WPMs, G and every recipe (their first m s recalibrate,
the rest is out of sample), and for S, which is trained on those drives, only
the tail of each of their segments it was validated on (``train.val_fraction``).
The navigation filter takes σ_t² as the distance's noise
(:mod:`rwhonet.evaluation.position`).

A window's CRSE (paper Eq. 16, ``Σ|e_t|``) is predicted from the same σ_t: with
independent normal seconds its mean is ``sqrt(2/π) Σσ_t`` and its spread
``sqrt((1 − 2/π) Σσ_t²)`` (:func:`rwhonet.nav.coverage.crse_prediction`). A
model's errors are not independent from second to second (a radius error lasts
the whole drive), so that spread is too narrow; the prediction is calibrated
on the same training windows:

    CRSE ~ N(α Σσ_t, κ² Σσ_t² + λ² (Σσ_t)²),

``κ`` the part that adds up like independent seconds (its spread grows as the
square root of the window's length) and ``λ`` the part that lasts through the
window (a scale error the window shares: its spread grows with the length
itself), ``α``, ``κ`` and ``λ`` the maximum-likelihood values over every
training window of every outage length (:func:`fit_crse`; ``λ`` = 0, the
closed form, where Akaike's criterion finds a lasting part not likelier).
Reported on the test windows: the share
of windows within 1σ and 2σ of the prediction, and its mean negative
log-likelihood (:func:`crse_check`); for comparison also the independent-seconds
prediction's share.

Before an outage the car has GNSS, and what the model got wrong on this drive
so far is known: a drive on a tyre and load state the training drives do not
show keeps its own scale error through the window. The prediction is
conditioned on it. Over the segment's seconds before the window the model's
scale error is ``ŝ = Σe/Σd`` with variance ``v = Σσ²/(Σd)²``
(:func:`scale_before`); drives' lasting scale errors spread by ``τ``
(``τ² = mean(ŝ² − v)`` over the training windows with at least
:data:`MIN_BEFORE_M` before them, the method of moments: :func:`fit_scale_sd`),
so the scale the window is expected to keep is ``s = ŝ τ²/(τ² + v)`` (the
normal-normal posterior mean: little seen, little kept). Each second's error is
then ``N(s d_t, ρ²σ_t²)``, ``ρ = α / sqrt(2/π)`` (the seconds' spread as the
calibration found it: ``E|e_t| = α σ_t`` where nothing is kept, while the kept
scale counts in full), its absolute value a folded normal
(:func:`folded_moments`), and ``Σσ_t`` and ``Σσ_t²`` above are replaced by
``M = Σ E|e_t| / (ρ sqrt(2/π))`` and ``V = Σ var|e_t| / (ρ² (1 − 2/π))``, which
are ``Σσ_t`` and ``Σσ_t²`` again where ``s`` = 0 (no seconds before, or ``τ`` =
0); where ``s d_t`` outgrows the seconds' spread, ``α M`` tends to ``Σ|s d_t|``.
``α``, ``κ`` and ``λ`` are fitted on the training windows so conditioned, by
maximum likelihood (:func:`fit_conditioned_crse`: ``M`` and ``V`` depend on
``α``, which is searched in one dimension, ``κ`` and ``λ`` fitted at each).

A continuous recipe (``R[continuous]``, ``R[continuous_shrink]``) refits before
every window on the GNSS seconds before it, so its distances exist only inside
windows, one set per outage length; its variance and CRSE prediction are fitted
on its errors inside the training windows (:func:`fit_window_model`), not
conditioned on the seconds before a window (the recipe has refitted on them).

The filter needs one more figure. It takes each second's error as independent
(white), but a model's errors last: summed over an outage they grow faster than
``sqrt(Σσ_t²)``. What lasts longest, a scale error, the filter learns from GNSS
before the outage (its odometry-scale state); what is left is calibrated per
outage length L on the same training windows: ``γ_L`` = the mean of
``(Σ_w e_t − ŝ Σ_w d_t)² / Σ_w σ_t²``, with ``ŝ = Σ e / Σ d`` over the segment's
seconds before the window (the scale the filter would have learnt), and inside
an outage of L seconds the filter's distance variance is ``γ_L σ_t²``
(:meth:`DistanceVariance.outage_var`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import pandas as pd
from scipy.optimize import minimize, minimize_scalar
from scipy.special import ndtr

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.evaluation.model_errors import refit_wpm
from rwhonet.evaluation.windows import evaluated_rows, window_starts
from rwhonet.nav.coverage import coverage_1d, crse_prediction

HALF_NORMAL_MEAN = float(np.sqrt(2.0 / np.pi))  # E|e| / σ of a normal error
MIN_VAR_M2 = 1e-6  # a variance floor (1 mm): a model is never certain
MIN_SECONDS = 30  # fewer seconds to fit on: no variance model
MIN_WINDOWS = 3  # fewer training windows: the CRSE prediction stays uncalibrated
AIC_NATS = 1.0  # a parameter more is worth 1 nat of summed log-likelihood (Akaike)
MIN_BEFORE_M = 100.0  # fewer metres before a window: its scale error not counted in τ
ALPHA_SPAN = 100.0  # the conditioned α searched within this factor of its starting point


class Seen(NamedTuple):
    """What each window's segment showed of the model's scale error before it.

    Made by :func:`scale_before`.

    Attributes:
        scale: (W,) ``ŝ = Σe/Σd`` (0 with nothing before).
        var: (W,) its variance ``Σσ²/(Σd)²`` (∞ with nothing before).
        dist_m: (W,) ``Σd``, the metres it was seen over.
    """

    scale: np.ndarray
    var: np.ndarray
    dist_m: np.ndarray


@dataclass(frozen=True)
class DistanceVariance:
    """A model's per-second distance variance ``a + b d²`` and its CRSE calibration.

    Attributes:
        a_m2: the floor, m².
        b: the share of the distance, squared (``sqrt(b)``: relative spread).
        crse_scale: ``α``, the CRSE's predicted mean over ``Σσ_t``
            (``sqrt(2/π)`` uncalibrated).
        crse_spread: ``κ``, the part of its predicted spread that adds up like
            independent seconds, over ``sqrt(Σσ_t²)`` (``sqrt(1 − 2/π)`` uncalibrated).
        crse_lasting: ``λ``, the part that lasts through the window, over ``Σσ_t``
            (0 uncalibrated).
        scale_sd: ``τ``, the spread of the lasting scale errors the training windows
            show before them (0: the prediction is not conditioned on them).
        n_seconds: seconds fitted on.
        n_windows: training windows the CRSE prediction was calibrated on (0: not).
        outage_scale: ``{L: γ_L}``, the variance's factor inside an outage of L
            seconds (an outage length without one: 1).
    """

    a_m2: float
    b: float
    crse_scale: float = HALF_NORMAL_MEAN
    crse_spread: float = float(np.sqrt(1.0 - 2.0 / np.pi))
    crse_lasting: float = 0.0
    scale_sd: float = 0.0
    n_seconds: int = 0
    n_windows: int = 0
    outage_scale: dict[int, float] = field(default_factory=dict, hash=False)

    def outage_var(self, dist_m: np.ndarray, outage_s: int) -> np.ndarray:
        """The filter's distance variance inside an outage of ``outage_s``: ``γ_L σ_t²``, m²."""
        return self.outage_scale.get(int(outage_s), 1.0) * self.var(dist_m)

    def var(self, dist_m: np.ndarray) -> np.ndarray:
        """σ_t² of each second, m² (NaN where the distance is)."""
        d = np.asarray(dist_m, np.float64)
        return self.a_m2 + self.b * d * d

    def kept_scale(self, seen: Seen | None) -> np.ndarray | float:
        """The scale error each window is expected to keep: ``ŝ τ²/(τ² + v)`` (0 unseen)."""
        if seen is None or self.scale_sd <= 0.0:
            return 0.0
        tau2 = self.scale_sd**2
        finite = np.isfinite(seen.var)
        return np.where(finite, seen.scale * tau2 / (tau2 + np.where(finite, seen.var, 0.0)), 0.0)

    def crse_sums(
        self, dist_m: np.ndarray, seen: Seen | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``M`` and ``V`` of each window (``Σσ_t`` and ``Σσ_t²`` where nothing is kept).

        Args:
            dist_m: (W, L) the model's distances in each window.
            seen: the scale error seen before each window (:func:`scale_before`), or None.
        """
        d = np.asarray(dist_m, np.float64)
        sd = np.sqrt(self.var(d))
        kept = self.kept_scale(seen)
        if np.ndim(kept) == 0 and kept == 0.0:
            return sd.sum(axis=-1), (sd * sd).sum(axis=-1)
        # the seconds' spread as calibrated (ρσ: E|e| = α σ where nothing is kept), the
        # kept scale as it is; normalised back by ρ, so that α M is the mean
        rho = self.crse_scale / HALF_NORMAL_MEAN
        mean, var = folded_moments(np.asarray(kept)[..., None] * d, rho * sd)
        return (
            mean.sum(axis=-1) / (rho * HALF_NORMAL_MEAN),
            var.sum(axis=-1) / (rho * rho * (1.0 - 2.0 / np.pi)),
        )

    def crse(self, dist_m: np.ndarray, seen: Seen | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted mean and standard deviation of each window's CRSE, m.

        Args:
            dist_m: (W, L) the model's distances in each window.
            seen: the scale error seen before each window (:func:`scale_before`);
                None: not conditioned.
        """
        total, sq = self.crse_sums(dist_m, seen)
        spread = np.sqrt(self.crse_spread**2 * sq + (self.crse_lasting * total) ** 2)
        return self.crse_scale * total, spread


def folded_moments(mu: np.ndarray, sd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of ``|e|`` for ``e ~ N(μ, σ²)`` (the folded normal), elementwise.

    ``E|e| = σ sqrt(2/π) exp(−μ²/2σ²) + μ (1 − 2Φ(−μ/σ))``, ``var|e| = μ² + σ² − E|e|²``
    (Leone, Nelson and Nottingham 1961; ``scipy.stats.foldnorm``).
    """
    mu = np.abs(np.asarray(mu, np.float64))
    sd = np.asarray(sd, np.float64)
    z = mu / sd
    mean = sd * HALF_NORMAL_MEAN * np.exp(-0.5 * z * z) + mu * (1.0 - 2.0 * ndtr(-z))
    return mean, np.maximum(mu * mu + sd * sd - mean * mean, 0.0)


def gaussian_nll(error: np.ndarray, var: np.ndarray) -> float:
    """Mean negative log-likelihood of errors under ``N(0, var)``, nats."""
    e = np.asarray(error, np.float64)
    v = np.asarray(var, np.float64)
    return float(np.mean(0.5 * (np.log(2.0 * np.pi * v) + e * e / v)))


def fit_variance(error: np.ndarray, dist_m: np.ndarray) -> tuple[float, float]:
    """``a`` and ``b`` of ``σ² = a + b d²`` by maximum Gaussian likelihood.

    Started from the least-squares fit of ``e²`` on ``[1, d²]`` (kept positive),
    then the mean negative log-likelihood minimised over ``ln a`` and ``ln b``
    (both positive; L-BFGS-B).

    Args:
        error: (N,) errors, m (NaN seconds left out).
        dist_m: (N,) the distances they are errors of, m.

    Returns:
        ``(a, b)``; ``a`` at least :data:`MIN_VAR_M2`.

    Raises:
        ValueError: fewer than :data:`MIN_SECONDS` finite seconds.
    """
    e = np.asarray(error, np.float64)
    d = np.asarray(dist_m, np.float64)
    ok = np.isfinite(e) & np.isfinite(d)
    e, d = e[ok], d[ok]
    if len(e) < MIN_SECONDS:
        raise ValueError(f"a variance needs {MIN_SECONDS} seconds, got {len(e)}")
    e2, d2 = e * e, d * d
    design = np.stack([np.ones_like(d2), d2], axis=1)
    a0, b0 = np.linalg.lstsq(design, e2, rcond=None)[0]
    a0 = max(a0, 0.1 * float(e2.mean()), MIN_VAR_M2)
    b0 = max(b0, 1e-8)

    def nll(theta: np.ndarray) -> tuple[float, np.ndarray]:
        a, b = np.exp(theta)
        v = a + b * d2
        r = e2 / v
        value = 0.5 * float(np.mean(np.log(v) + r))
        dv = 0.5 * (1.0 - r) / v  # d nll / d v, per second
        grad = np.array([np.mean(dv) * a, np.mean(dv * d2) * b])
        return value, grad

    res = minimize(
        nll,
        np.log([a0, b0]),
        jac=True,
        method="L-BFGS-B",
        bounds=[(np.log(MIN_VAR_M2), None), (np.log(1e-12), None)],
    )
    a, b = np.exp(res.x)
    return float(a), float(b)


def _crse_alpha(c: np.ndarray, m: np.ndarray, var: np.ndarray) -> float:
    """``α`` given each window's variance: the weighted least-squares ``Σ(c m / v) / Σ(m² / v)``."""
    return float(np.sum(c * m / var) / np.sum(m * m / var))


def fit_crse(
    crse_m: np.ndarray, sum_sd: np.ndarray, sum_var: np.ndarray
) -> tuple[float, float, float]:
    """``α``, ``κ``, ``λ`` of ``CRSE ~ N(α Σσ, κ² Σσ² + λ² (Σσ)²)`` by maximum likelihood.

    With ``m = Σσ_t`` and ``v = Σσ_t²`` per window. Without the lasting part
    (``λ`` = 0) the likelihood has a closed form: ``α = Σ(c m / v) / Σ(m² / v)``
    (weighted least squares) and ``κ² = mean((c − α m)² / v)``. From an even
    split of that variance between the two parts, the mean negative
    log-likelihood is minimised over ``κ, λ ≥ 0`` (L-BFGS-B) with ``α`` profiled
    out (its weighted least squares under each window's variance); the closed
    form is kept unless the lasting part, one parameter more, is likelier by
    more than Akaike's criterion asks (the windows' summed log-likelihood up by
    more than 1 nat).

    Args:
        crse_m: (W,) the windows' CRSE, m.
        sum_sd: (W,) ``Σσ_t``.
        sum_var: (W,) ``Σσ_t²``.

    Returns:
        ``(α, κ, λ)``.
    """
    return _fit_crse(crse_m, sum_sd, sum_var)[:3]


def _fit_crse(
    crse_m: np.ndarray, sum_sd: np.ndarray, sum_var: np.ndarray, alpha: float | None = None
) -> tuple[float, float, float, float]:
    """:func:`fit_crse`, or with ``α`` held; also the windows' mean negative log-likelihood."""
    c, m, v = (np.asarray(x, np.float64) for x in (crse_m, sum_sd, sum_var))

    def alpha_at(var: np.ndarray) -> float:
        return _crse_alpha(c, m, var) if alpha is None else alpha

    a0 = alpha_at(v)
    kappa = float(np.sqrt(np.mean((c - a0 * m) ** 2 / v)))
    if kappa == 0.0:
        return a0, 0.0, 0.0, -np.inf

    def nll(theta: np.ndarray) -> float:
        var = theta[0] ** 2 * v + theta[1] ** 2 * m * m
        r = c - alpha_at(var) * m
        return 0.5 * float(np.mean(np.log(2.0 * np.pi * var) + r * r / var))

    closed = nll(np.array([kappa, 0.0]))
    share = float(np.sqrt(0.5 * np.mean(v) / np.mean(m * m)))  # λ for half of κ²'s variance
    res = minimize(
        nll,
        np.array([kappa / np.sqrt(2.0), kappa * share]),
        method="L-BFGS-B",
        bounds=[(1e-9 * kappa, None), (0.0, None)],
    )
    if len(c) * (closed - float(res.fun)) <= AIC_NATS:
        return a0, kappa, 0.0, closed
    k_, lasting = float(res.x[0]), float(res.x[1])
    return alpha_at(k_**2 * v + lasting**2 * m * m), k_, lasting, float(res.fun)


def fit_conditioned_crse(
    fitted: DistanceVariance, crse_m: np.ndarray, windows: list[tuple[np.ndarray, Seen]]
) -> tuple[float, float, float]:
    """``α``, ``κ``, ``λ`` of the CRSE prediction conditioned on the scale seen before each window.

    ``M`` and ``V`` depend on ``α`` (through ``ρ``), so ``α`` is found by a bounded
    one-dimensional search of the windows' likelihood (Brent's, in ``ln α``, within a
    factor :data:`ALPHA_SPAN` of :func:`fit_crse`'s ``α`` on ``M`` and ``V`` at ``ρ`` = 1),
    ``κ`` and ``λ`` fitted at each ``α`` as :func:`fit_crse` does (``λ`` kept where
    Akaike's criterion takes it).

    Args:
        fitted: the model's variance, its ``scale_sd`` (``τ``) fitted.
        crse_m: (W,) the windows' CRSE, m, in the order of ``windows``' rows.
        windows: per group of windows, the model's distances (W_i, L_i) and what was seen.
    """

    def sums(alpha: float) -> tuple[np.ndarray, np.ndarray]:
        trial = replace(fitted, crse_scale=alpha)
        parts = [trial.crse_sums(d, seen) for d, seen in windows]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])

    at_rho_1 = fit_crse(crse_m, *sums(HALF_NORMAL_MEAN))  # M and V at ρ = 1, α profiled
    if fitted.scale_sd == 0.0:  # nothing kept: M and V are Σσ and Σσ² at every α
        return at_rho_1

    def profile(log_alpha: float) -> float:
        alpha = float(np.exp(log_alpha))
        return _fit_crse(crse_m, *sums(alpha), alpha)[3]

    centre = np.log(at_rho_1[0])
    span = np.log(ALPHA_SPAN)
    res = minimize_scalar(
        profile, bounds=(centre - span, centre + span), method="bounded", options={"xatol": 1e-4}
    )
    alpha = float(np.exp(res.x))
    return _fit_crse(crse_m, *sums(alpha), alpha)[:3]


def window_crse(error: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Each window's CRSE (paper Eq. 16): ``Σ|e_t|`` over its rows, m."""
    return np.abs(np.asarray(error, np.float64)[rows]).sum(axis=1)


def _before(values: list[np.ndarray], group: np.ndarray, rows: np.ndarray) -> list[np.ndarray]:
    """Each array summed over the seconds of each window's segment before its first row."""
    start = np.flatnonzero(np.r_[True, group[1:] != group[:-1]]) if len(group) else np.zeros(0)
    first = start[np.searchsorted(start, np.arange(len(group)), side="right") - 1]
    r0 = rows[:, 0]
    out = []
    for x in values:
        c = np.r_[0.0, np.cumsum(x)]
        out.append(c[r0] - c[first[r0]])
    return out


def scale_before(
    error: np.ndarray, dist_m: np.ndarray, var: np.ndarray, group: np.ndarray, rows: np.ndarray
) -> Seen:
    """The scale error each window's segment showed before it, and its variance.

    ``ŝ = Σe/Σd`` and ``v = Σσ²/(Σd)²`` over the seconds of the window's segment
    before its first (those with an error, a distance and a variance); ``(0, ∞)``
    with none.

    Args:
        error: (N,) per-second errors, m.
        dist_m: (N,) the distances they are errors of, m.
        var: (N,) the seconds' variances σ², m².
        group: (N,) segment ids (each one contiguous run).
        rows: (W, L) the windows' rows.
    """
    e, d, v = (np.asarray(x, np.float64) for x in (error, dist_m, var))
    ok = np.isfinite(e) & np.isfinite(d) & np.isfinite(v)
    se, sd, sv = _before([np.where(ok, x, 0.0) for x in (e, d, v)], group, rows)
    seen = sd > 0
    safe = np.where(seen, sd, 1.0)
    return Seen(np.where(seen, se / safe, 0.0), np.where(seen, sv / (safe * safe), np.inf), sd)


def fit_scale_sd(seen: Seen) -> float:
    """``τ``, the spread of the lasting scale errors, by the method of moments.

    ``τ² = mean(ŝ² − v)`` over the windows with at least :data:`MIN_BEFORE_M` before
    them (``ŝ`` is the lasting error plus a noise of variance ``v``); 0 where that is
    not positive or no window qualifies.
    """
    keep = seen.dist_m >= MIN_BEFORE_M
    if not keep.any():
        return 0.0
    tau2 = float(np.mean(seen.scale[keep] ** 2 - seen.var[keep]))
    return float(np.sqrt(tau2)) if tau2 > 0.0 else 0.0


def scale_left(
    error: np.ndarray, dist_m: np.ndarray, group: np.ndarray, rows: np.ndarray
) -> np.ndarray:
    """Each window's summed error less the scale its segment's seconds before it show.

    ``Σ_w e_t − ŝ Σ_w d_t`` with ``ŝ = Σ e / Σ d`` over the seconds of the window's
    segment before its first (0 without any): what is left once a filter has
    learnt the distance's scale from GNSS before the outage.

    Args:
        error: (N,) per-second errors (NaN counted as 0 before a window).
        dist_m: (N,) the distances they are errors of.
        group: (N,) segment ids (each one contiguous run).
        rows: (W, L) the windows' rows.
    """
    e = np.nan_to_num(np.asarray(error, np.float64))
    d = np.nan_to_num(np.asarray(dist_m, np.float64))
    before_e, before_d = _before([e, d], group, rows)
    scale = np.where(before_d > 0, before_e / np.where(before_d > 0, before_d, 1.0), 0.0)
    return e[rows].sum(axis=1) - scale * d[rows].sum(axis=1)


def complete_windows(values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The windows (rows of ``rows``, (W, L) indices into ``values``) with every second finite."""
    rows = np.asarray(rows)
    if not len(rows):
        return rows
    return rows[np.isfinite(np.asarray(values, np.float64)[rows]).all(axis=1)]


def fit_model(
    error: np.ndarray,
    dist_m: np.ndarray,
    seconds: np.ndarray,
    windows: dict[int, np.ndarray],
    group: np.ndarray,
) -> DistanceVariance | None:
    """A model's variance and CRSE calibration from its errors where it may be fitted.

    Args:
        error: (N,) the model's per-second error, m.
        dist_m: (N,) its distances, m.
        seconds: (N,) bool, the seconds to fit ``a`` and ``b`` on.
        windows: per outage length, row indices (W, L) of the training windows to
            calibrate the CRSE prediction and ``γ_L`` on.
        group: (N,) segment ids (for ``γ_L``: the seconds before each window).

    Returns:
        The fitted variance, or None with fewer than :data:`MIN_SECONDS` seconds.
    """
    try:
        a, b = fit_variance(error[seconds], dist_m[seconds])
    except ValueError:
        return None
    fitted = DistanceVariance(a, b, n_seconds=int(np.isfinite(error[seconds]).sum()))
    var = fitted.var(dist_m)
    kept, crse, seen, gamma = {}, [], [], {}
    for L, rows in windows.items():
        rows = complete_windows(error, rows)
        if not len(rows):
            continue
        kept[L] = rows
        crse.append(window_crse(error, rows))
        seen.append(scale_before(error, dist_m, var, group, rows))
        if len(rows) >= MIN_WINDOWS:
            left = scale_left(error, dist_m, group, rows)
            sd = np.sqrt(var[rows])
            gamma[int(L)] = float(np.mean(left * left / (sd * sd).sum(axis=1)))
    n = sum(len(c) for c in crse)
    if n < MIN_WINDOWS:
        return replace(fitted, outage_scale=gamma)
    pooled = Seen(*(np.concatenate(x) for x in zip(*seen, strict=True)))
    fitted = replace(fitted, scale_sd=fit_scale_sd(pooled))
    parts = [(dist_m[r], w) for r, w in zip(kept.values(), seen, strict=True)]
    alpha, kappa, lasting = fit_conditioned_crse(fitted, np.concatenate(crse), parts)
    return replace(
        fitted,
        crse_scale=alpha,
        crse_spread=kappa,
        crse_lasting=lasting,
        n_windows=n,
        outage_scale=gamma,
    )


def fit_window_model(
    errors: dict[int, np.ndarray], gnss_m: np.ndarray, windows: dict[int, np.ndarray]
) -> DistanceVariance | None:
    """A continuous recipe's variance and CRSE calibration, from its errors inside windows.

    A continuous recipe refits before every window on the GNSS seconds before it, so
    its distances exist only inside windows, one set per outage length. ``a`` and
    ``b`` are fitted on the seconds of every length's windows together (a second in
    windows of several lengths counts once per length: a composite likelihood), the
    CRSE prediction calibrated on the same windows (:func:`fit_crse`), not
    conditioned on the scale seen before each window: the recipe has already
    refitted on it. No ``γ_L``: the navigation filter does not run on a continuous
    recipe (no distance before a window).

    Args:
        errors: per outage length L, (N,) the errors of that length's predictions, m
            (NaN outside its windows).
        gnss_m: (N,) the GNSS distance of each second (a prediction is the GNSS's less
            its error).
        windows: per outage length, row indices (W, L) of the training windows; those
            with a second without a prediction are left out.

    Returns:
        The fitted variance (``n_seconds``: the window seconds fitted on), or None
        with fewer than :data:`MIN_SECONDS` of them.
    """
    gnss = np.asarray(gnss_m, np.float64)
    kept = {}
    for L, rows in windows.items():
        e = errors.get(int(L))
        rows = complete_windows(e, rows) if e is not None else rows[:0]
        if len(rows):
            kept[int(L)] = rows
    if not kept:
        return None
    dist = {L: gnss - errors[L] for L in kept}
    e_all = np.concatenate([errors[L][rows].ravel() for L, rows in kept.items()])
    d_all = np.concatenate([dist[L][rows].ravel() for L, rows in kept.items()])
    try:
        a, b = fit_variance(e_all, d_all)
    except ValueError:
        return None
    fitted = DistanceVariance(a, b, n_seconds=int(np.isfinite(e_all).sum()))
    crse = np.concatenate([window_crse(errors[L], rows) for L, rows in kept.items()])
    if len(crse) < MIN_WINDOWS:
        return fitted
    sums = [fitted.crse_sums(dist[L][rows]) for L, rows in kept.items()]
    alpha, kappa, lasting = fit_crse(
        crse, np.concatenate([m for m, _ in sums]), np.concatenate([v for _, v in sums])
    )
    return replace(
        fitted, crse_scale=alpha, crse_spread=kappa, crse_lasting=lasting, n_windows=len(crse)
    )


def crse_check(
    error: np.ndarray,
    dist_m: np.ndarray,
    rows: np.ndarray,
    fitted: DistanceVariance,
    group: np.ndarray | None = None,
):
    """How well a fitted model predicts its CRSE on windows (the test windows).

    Args:
        error: (N,) the model's per-second error, m.
        dist_m: (N,) its distances, m.
        rows: (W, L) the windows' rows.
        fitted: the model's variance.
        group: (N,) segment ids: the prediction is conditioned on the scale error
            each window's segment showed before it (:func:`scale_before`); None: not.

    Returns:
        ``{cover_1sigma, cover_2sigma, nll, cover_1sigma_independent,
        cover_2sigma_independent, second_cover_1sigma, second_cover_2sigma,
        n_windows}``: the shares of windows whose CRSE is within 1σ / 2σ of the
        calibrated prediction, its mean Gaussian negative log-likelihood (nats),
        the same shares for the independent-seconds prediction
        (:func:`rwhonet.nav.coverage.crse_coverage`), and the shares of the
        windows' seconds whose error is within 1σ_t / 2σ_t.
    """
    rows = complete_windows(error, rows)
    e = np.asarray(error, np.float64)[rows]
    if not len(rows):
        return {"n_windows": 0}
    crse = np.abs(e).sum(axis=1)
    seen = (
        None
        if group is None
        else scale_before(error, dist_m, fitted.var(dist_m), np.asarray(group), rows)
    )
    mean, sd = fitted.crse(dist_m[rows], seen)
    cover = coverage_1d(crse - mean, sd)
    sd_t = np.sqrt(fitted.var(dist_m[rows]))
    indep_mean, indep_sd = crse_prediction(sd_t)
    indep = coverage_1d(crse - indep_mean, indep_sd)
    seconds = coverage_1d(e.ravel(), sd_t.ravel())
    return {
        "cover_1sigma": cover[1.0],
        "cover_2sigma": cover[2.0],
        "nll": gaussian_nll(crse - mean, sd * sd),
        "cover_1sigma_independent": indep[1.0],
        "cover_2sigma_independent": indep[2.0],
        "second_cover_1sigma": seconds[1.0],
        "second_cover_2sigma": seconds[2.0],
        "n_windows": int(len(rows)),
    }


# --------------------------------------------------------------------------- where to fit

# Without fitting evidence (no target training drives): a variance assumed, not fitted.
ASSUMED = DistanceVariance(a_m2=0.05**2, b=0.01**2)


@dataclass(frozen=True)
class FitEvidence:
    """The target training drives' samples and every seed's predictions of them.

    Attributes:
        frame: their samples (``drive, segment, group, k, role``, the sample columns).
        per_seed: per seed, one column per model (``G``, ``S``, ``R[head]@70``...;
            a continuous recipe's one per outage length, ``R[continuous]/30s``...)
            row-aligned with ``frame`` (NaN where a model has no prediction).
    """

    frame: pd.DataFrame
    per_seed: dict[int, pd.DataFrame]


def masked_windows(
    frame: pd.DataFrame, mask: np.ndarray, outage_s: int, stride_s: int | None = None
) -> np.ndarray:
    """Windows of ``outage_s`` over the rows where ``mask`` holds, per segment.

    ``mask`` must be one contiguous run within each segment (a drive's seconds
    after its first m, a segment's tail), as :func:`rwhonet.evaluation.windows.window_starts`
    asks; a window starts every ``stride_s`` seconds (default: consecutive windows).
    """
    rows = np.flatnonzero(mask)
    start, _ = window_starts(frame["group"].to_numpy()[rows], outage_s, stride_s)
    return (
        rows[start[:, None] + np.arange(outage_s)] if len(start) else np.zeros((0, outage_s), int)
    )


def held_out_tail(frame: pd.DataFrame, fraction: float) -> np.ndarray:
    """The last ``fraction`` of each segment: what the train stage holds out of S's training."""
    group = frame["group"].to_numpy()
    rank = frame.groupby("group", sort=False).cumcount().to_numpy()
    size = np.bincount(group)[group] if len(group) else np.zeros(0, int)
    return rank >= size - np.floor(size * fraction).astype(int)


@dataclass(frozen=True)
class TrainingErrors:
    """One model's errors on the target training drives, where it may be fitted.

    Attributes:
        seed: the training seed (None: the WPMs, the same for every seed).
        model: the model's name.
        error: (N,) its per-second error, m, row-aligned with the evidence's frame; a
            continuous recipe's ``{L: (N,)}``, one per outage length (its distances
            are made inside each window, NaN outside them).
        mask: (N,) the seconds it may be fitted on: after each drive's first max(m) s,
            for S only its segments' validation tails.
    """

    seed: int | None
    model: str
    error: np.ndarray | dict[int, np.ndarray]
    mask: np.ndarray

    @property
    def per_window(self) -> bool:
        """A continuous recipe's errors: one array per outage length, inside its windows."""
        return isinstance(self.error, dict)


def training_errors(
    evidence: FitEvidence, models: list[str], params: Params
) -> list[TrainingErrors]:
    """Every model's errors on the target training drives, per seed (the WPMs once).

    The WPM's is its label, WPM-m's its refit's; G, S and every recipe's the label
    less their prediction (a continuous recipe's per outage length, inside that
    length's windows). Where they may be fitted: the seconds after each drive's
    first max(m) s (out of sample there for all but S), and for S, which was
    trained on those drives, only the tails of their segments it was validated on
    (``train.val_fraction``).
    """
    frame = evidence.frame
    if not len(frame):
        return []
    label = frame[k.LABEL_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    scored = evaluated_rows(frame, params.adapt.m_grid)
    tail = held_out_tail(frame, params.train.val_fraction)
    wpm_m = {m: gnss - d for m, d in refit_wpm(frame, params)[0].items()}
    out = []
    for model in models:
        if model == "WPM":
            out.append(TrainingErrors(None, model, label, scored))
        elif model.startswith("WPM-m@"):
            m = int(model.removeprefix("WPM-m@"))
            out.append(TrainingErrors(None, model, wpm_m[m], scored))
    outages = params.evaluate.outages_s
    for seed, preds in evidence.per_seed.items():
        for model in models:
            if model in preds:
                error = label - preds[model].to_numpy(np.float64)
                out.append(TrainingErrors(seed, model, error, tail if model == "S" else scored))
            elif all(f"{model}/{L}s" in preds for L in outages):
                columns = {L: preds[f"{model}/{L}s"].to_numpy(np.float64) for L in outages}
                by_length = {L: label - p for L, p in columns.items()}
                out.append(TrainingErrors(seed, model, by_length, scored))
    return out


def fit_variances(
    evidence: FitEvidence, errors: list[TrainingErrors], params: Params
) -> dict[tuple[int | None, str], DistanceVariance]:
    """Every model's variance, per seed (``None``: the WPMs, the same for every seed).

    Fitted where :func:`training_errors` says each model may be; the CRSE prediction
    calibrated on the windows of every outage length over the same seconds (a
    continuous recipe's on its errors inside them: :func:`fit_window_model`).

    Args:
        evidence: the target training drives and the predictions of them.
        errors: every model's errors there (:func:`training_errors`).
        params: ``evaluate.outages_s``.

    Returns:
        ``{(seed, model): fit}``; a model without enough seconds is absent.
    """
    frame = evidence.frame
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64) if len(frame) else np.zeros(0)
    group = frame["group"].to_numpy() if len(frame) else np.zeros(0, int)
    out: dict[tuple[int | None, str], DistanceVariance | None] = {}
    for t in errors:
        windows = {L: masked_windows(frame, t.mask, L) for L in params.evaluate.outages_s}
        if t.per_window:
            out[(t.seed, t.model)] = fit_window_model(t.error, gnss, windows)
        else:
            out[(t.seed, t.model)] = fit_model(t.error, gnss - t.error, t.mask, windows, group)
    return {key: v for key, v in out.items() if v is not None}
