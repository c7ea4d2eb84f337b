"""The navigation filter on a stream: where the car is, second by second, through an outage.

``rwhonet predict`` corrects each second's distance with the served model
(:mod:`rwhonet.serve.stream`); :class:`StreamNavigator` runs the extended
Kalman filter of :mod:`rwhonet.nav` on those seconds as they come, carrying its
state from one block of seconds to the next (:class:`rwhonet.nav.NavStart`):
propagated by the corrected distance and by the yaw of the gyro fused with the
rear wheels (the wheels alone when the drive has no yaw rate), updated by the
GNSS course and fix while they are there. Inside an outage the fixes are
withheld from the filter (they stay in the file, to compare with): it
dead-reckons, and its predicted fix and covariance are the outage's position.

The corrected distance's variance ``a + b d²`` is fitted on the stream's own
seconds outside the outages where GNSS is there (least squares of ``e²`` on
``[1, d²]`` from running sums, ``e`` = corrected − GNSS distance; an assumed
``0.05² + (0.01 d)²`` until :data:`MIN_SECONDS` seconds are in). Inside an
outage that variance grows by the factor ``γ`` the evaluation fitted for how the
model's errors last (:mod:`rwhonet.evaluation.uncertainty`), when the model
carries it (:meth:`PositionCalibration.outage_variance`). What the
evaluation measured of the filter on the model's car (the receiver drift, the
antenna's place and the gyro's latency it fitted, its 2D calibration), when the
model carries it, sets the filter's receiver, antenna and gyro and sizes the
outage's regions (:class:`PositionCalibration`).
Nothing here imports torch.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from rwhonet.data.robust import cumulative_trapezoid
from rwhonet.features.deadreckoning import wheel_yaw_rad
from rwhonet.geo.local import latlon_from_offsets_deg, offsets_m
from rwhonet.nav import NavConfig, NavInputs, NavStart, run, t2_quantile


@dataclass(frozen=True)
class PositionCalibration:
    """What the evaluation measured of the filter on the model's car, as a bundle carries it.

    The evaluation (:mod:`rwhonet.evaluation.position`) fits the receiver's drift
    and calibrates the filter's end-of-outage covariance ``Σ`` on the target
    training drives as a bivariate Student t: scale matrix ``c(L) Σ`` at each
    outage length ``L``, ``ν(L)`` degrees of freedom. A registered model's metadata
    (``navigation``) carries them; here they size the region the car is in after
    ``t`` seconds of an outage, ``c`` interpolated in ``ln L`` between the
    evaluated lengths and ``1/ν`` likewise (0: a normal), the nearest outside them.

    Attributes:
        scales: ``c`` per evaluated outage length, s (empty: not calibrated, the
            filter's own normal).
        dof: ``ν`` of a length without its own (``inf``: a normal).
        dofs: ``ν`` per evaluated outage length (``inf``: a normal).
        receiver_sigma_m: the receiver drift's spread the filter is to use, m
            (None: the filter's generic one).
        receiver_tau_s: its correlation time, s.
        antenna_m: where the evaluation fitted the antenna, ahead of and left of the
            rear axle, m (None: the filter's configured place).
        gyro_latency_s: how late it fitted the gyro to read, s (None: as configured).
        gyro_instability_deg_s: the gyro's bias instability it fitted, °/s (None: as
            configured).
        outage_scales: ``γ`` per evaluated outage length: the factor by which the
            corrected distance's per-second variance grows inside an outage of that
            length, fitted on the target training drives (its errors last; the
            evaluation's filter and calibration use it). Empty: 1, errors independent.
    """

    scales: dict[int, float] = field(default_factory=dict)
    dof: float = float("inf")
    receiver_sigma_m: float | None = None
    receiver_tau_s: float | None = None
    dofs: dict[int, float] = field(default_factory=dict)
    antenna_m: tuple[float, float] | None = None
    gyro_latency_s: float | None = None
    gyro_instability_deg_s: float | None = None
    outage_scales: dict[int, float] = field(default_factory=dict)

    @property
    def calibrated(self) -> bool:
        return bool(self.scales)

    @classmethod
    def from_meta(cls, navigation: dict[str, Any] | None) -> PositionCalibration:
        """From a bundle's ``navigation`` metadata (None: nothing known, the generic filter)."""
        if not navigation:
            return cls()
        cal = navigation.get("calibration") or {}
        dof = cal.get("dof")
        antenna, late = navigation.get("antenna_m"), navigation.get("gyro_latency_s")
        unstable = navigation.get("gyro_instability_deg_s")
        return cls(
            {int(L): float(c) for L, c in (cal.get("scales") or {}).items()},
            float(dof) if dof is not None else float("inf"),
            navigation.get("receiver_sigma_m"),
            navigation.get("receiver_tau_s"),
            {
                int(L): float(v) if v is not None else float("inf")
                for L, v in (cal.get("dofs") or {}).items()
            },
            None if antenna is None else (float(antenna[0]), float(antenna[1])),
            None if late is None else float(late),
            None if unstable is None else float(unstable),
            {int(L): float(g) for L, g in (navigation.get("outage_scale") or {}).items()},
        )

    def nav_config(self, config: NavConfig) -> NavConfig:
        """``config`` with the fitted receiver drift, antenna and gyro figures, where known."""
        if self.antenna_m is not None:
            config = replace(config, antenna_m=self.antenna_m)
        if self.gyro_latency_s is not None:
            config = replace(config, gyro=replace(config.gyro, latency_s=self.gyro_latency_s))
        if self.gyro_instability_deg_s is not None:
            b = float(np.radians(self.gyro_instability_deg_s))
            config = replace(config, gyro=replace(config.gyro, bias_instability=b))
        if self.receiver_sigma_m is None:
            return config
        return config.with_receiver(self.receiver_sigma_m, self.receiver_tau_s)

    def outage_scale_at(self, elapsed_s: np.ndarray) -> np.ndarray:
        """``γ`` after ``elapsed_s`` seconds of an outage, interpolated in ``ln L`` (1: none)."""
        return _factor_at(self.outage_scales, elapsed_s)

    def outage_variance(self, var_m2: np.ndarray, withheld: np.ndarray, carried=(0, 0.0)):
        """Each second's distance variance for the filter, inside an outage grown by ``γ``.

        The evaluation's filter takes ``γ_L σ_t²`` for every second of an outage of ``L``
        s, so that its along-track variance at the end is ``γ_L Σ σ_t²``. A stream does
        not know how long an outage will last; so the ``t``-th second of one adds
        ``γ(t) S_t − γ(t − 1) S_(t−1)`` (``S_t``: the sum of ``σ²`` over its first ``t``
        seconds, ``γ(0) = 0``): the variance summed over the outage so far is
        ``γ(t) S_t`` at every ``t``, the evaluation's at an outage of that length.

        Args:
            var_m2: (n,) the seconds' variances ``σ²``, m².
            withheld: (n,) the seconds inside an outage.
            carried: ``(t, S)`` of an outage running when the block starts.

        Returns:
            ``(variances (n,), (t, S) at the block's end)``.
        """
        var = np.asarray(var_m2, np.float64).copy()
        withheld = np.asarray(withheld, bool)
        if not self.outage_scales or not withheld.any():
            return var, (0, 0.0)
        t0, s0 = int(carried[0]), float(carried[1])
        # one run of withheld seconds after another; the first carries on from `carried`
        edges = np.diff(np.concatenate(([0], withheld.astype(np.int8), [0])))
        runs = zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)
        t, total = 0, 0.0
        for first, end in runs:
            t, total = (t0, s0) if first == 0 else (0, 0.0)
            elapsed = t + np.arange(0, end - first + 1)  # t, t + 1, ..., t + its length
            summed = total + np.concatenate(([0.0], np.cumsum(var[first:end])))
            grown = np.where(elapsed > 0, self.outage_scale_at(elapsed) * summed, 0.0)
            var[first:end] = np.diff(grown)
            t, total = int(elapsed[-1]), float(summed[-1])
        return var, ((t, total) if withheld[-1] else (0, 0.0))

    def scale_at(self, elapsed_s: np.ndarray) -> np.ndarray:
        """``c`` after ``elapsed_s`` seconds of an outage (1 when not calibrated)."""
        return _factor_at(self.scales, elapsed_s)

    def dof_at(self, elapsed_s: np.ndarray) -> np.ndarray:
        """``ν`` after ``elapsed_s`` seconds of an outage: ``1/ν`` interpolated in ``ln L``
        between the evaluated lengths (``inf``: a normal; ``dof`` where none has its own)."""
        if not self.dofs:
            return np.full_like(np.asarray(elapsed_s, np.float64), self.dof)
        x = _in_ln_l({L: 1.0 / nu for L, nu in self.dofs.items()}, elapsed_s)  # 1/inf = 0
        with np.errstate(divide="ignore"):
            return np.where(x > 0, 1.0 / np.where(x > 0, x, 1.0), np.inf)

    def semi_axis(
        self, cov: np.ndarray, elapsed_s: np.ndarray, p: float | tuple[float, ...]
    ) -> np.ndarray:
        """The major semi-axis of the region holding ``p`` of the cars, m: (n,), or
        (len(p), n) for several contents (one eigen-decomposition for all).

        The region is ``{e: eᵀ Σ⁻¹ e ≤ q}`` with ``q`` the t's quantile
        (:func:`rwhonet.nav.coverage.t2_quantile`, scale ``c(t)``); its major
        semi-axis is ``sqrt(q λ_max(Σ))``.

        Args:
            cov: (n, 2, 2) the filter's covariances (NaN: none).
            elapsed_s: (n,) seconds into the outage.
            p: the content, or contents (:data:`rwhonet.nav.SIGMA_CONTENT`: 68.27 % and
                95.45 %).
        """
        cov = np.asarray(cov, np.float64)
        ok = np.isfinite(cov).all(axis=(1, 2))
        lam = np.full(len(cov), np.nan)
        if ok.any():
            lam[ok] = np.linalg.eigvalsh(cov[ok])[:, -1]
        q = t2_quantile(np.asarray(p, np.float64)[..., None], 1.0, self.dof_at(elapsed_s))
        q = q * self.scale_at(elapsed_s)
        return np.sqrt(np.maximum(lam, 0.0) * q)


def _factor_at(factors: dict[int, float], elapsed_s: np.ndarray) -> np.ndarray:
    """A positive factor per evaluated outage length (``c``, ``γ``) at ``elapsed_s``,
    interpolated in ``ln L`` on its logarithm (1 where none is known)."""
    if not factors:
        return np.ones_like(np.asarray(elapsed_s, np.float64))
    return np.exp(_in_ln_l({L: np.log(f) for L, f in factors.items()}, elapsed_s))


def _in_ln_l(values: dict[int, float], elapsed_s: np.ndarray) -> np.ndarray:
    """``values`` (one per evaluated outage length) interpolated linearly in ``ln L`` at
    ``elapsed_s``, held at the nearest length outside them."""
    lengths = np.array(sorted(values), np.float64)
    v = np.array([values[int(L)] for L in lengths])
    t = np.asarray(elapsed_s, np.float64)
    return np.interp(np.log(np.maximum(t, 1e-9)), np.log(lengths), v)


MIN_SECONDS = 30  # seconds with GNSS before the distance variance is fitted on the stream
ASSUMED_A_M2, ASSUMED_B = 0.05**2, 0.01**2
MIN_VAR_M2 = 1e-4


def variance_fit(sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a`` and ``b`` of ``e² ≈ a + b d²`` by least squares from running sums.

    Args:
        sums: (k, 5) ``n, Σd², Σd⁴, Σe², Σe²d²``.

    Returns:
        ``(a, b)``, each (k,): the assumed values below :data:`MIN_SECONDS` seconds;
        ``a`` at least :data:`MIN_VAR_M2`, ``b`` at least 0 (refitted with the other
        held at its bound).
    """
    n, d2, d4, e2, e2d2 = np.asarray(sums, np.float64).T
    det = n * d4 - d2 * d2
    safe = np.where(det > 0, det, 1.0)
    a = (d4 * e2 - d2 * e2d2) / safe
    b = (n * e2d2 - d2 * e2) / safe
    mean = e2 / np.maximum(n, 1.0)
    flat = (det <= 0) | (b < 0)  # no spread of distances, or e² falling with them: a alone
    a = np.where(flat, np.maximum(mean, MIN_VAR_M2), a)
    b = np.where(flat, 0.0, b)
    low = a < MIN_VAR_M2  # a floor: b refitted through it
    b = np.where(low, np.maximum((e2d2 - MIN_VAR_M2 * d2) / np.where(d4 > 0, d4, 1.0), 0.0), b)
    a = np.maximum(a, MIN_VAR_M2)
    few = n < MIN_SECONDS
    return np.where(few, ASSUMED_A_M2, a), np.where(few, ASSUMED_B, b)


MIN_CHANGES = 30  # second-to-second changes seen before a gap can be bridged (diffusion)


@dataclass
class StreamNavigator:
    """The filter's state between blocks of seconds.

    Args:
        config: the filter's settings (its wheel geometry: ``config.wheels``).
        radii_m: the rear-left and rear-right radii the wheel angles are turned into
            travel with (the WPM's), m.
        gyro: whether the drive has a yaw rate (control ``fused``, else ``wheels``).
        calibration: what the evaluation measured (its ``γ`` grows the corrected
            distance's variance inside an outage: :meth:`PositionCalibration.outage_variance`).
    """

    config: NavConfig
    radii_m: tuple[float, float]
    gyro: bool
    calibration: PositionCalibration = field(default_factory=PositionCalibration)
    _outage: tuple[int, float] = (0, 0.0)  # seconds into the running outage, their Σσ²
    _x: np.ndarray | None = None
    _p: np.ndarray | None = None
    _ref: tuple[float, float] | None = None
    _last_fix: tuple[float, float] = (np.nan, np.nan)  # ending the last second, raw, m
    _last_latlon: tuple[float, float] = (np.nan, np.nan)  # ... as a fix
    _last_withheld: bool = False  # ... and kept from the filter (an outage's second)
    _last_pred: tuple[float, float] = (np.nan, np.nan)
    _last_gyro: float = np.nan  # the gyro's yaw over the last second (its latency's)
    _sums: np.ndarray = field(default_factory=lambda: np.zeros(5))
    # how fast the speed and the yaw rate change (bridge): the last second's distance and
    # yaw, then the number of second-to-second changes seen and their sums of squares
    _prev: tuple[float, float] = (np.nan, np.nan)
    _changes: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def started(self) -> bool:
        """Whether the filter has a state (it starts on a GNSS course)."""
        return self._x is not None

    @property
    def control(self) -> str:
        return "fused" if self.gyro else "wheels"

    def reset(self) -> None:
        """A new run of seconds (after a gap in the drive): the filter starts afresh."""
        self._x = self._p = None
        self._outage = (0, 0.0)
        self._last_fix = self._last_pred = self._last_latlon = (np.nan, np.nan)
        self._last_withheld = False
        self._last_gyro = np.nan
        self._prev = (np.nan, np.nan)

    def diffusion(self) -> tuple[float, float] | None:
        """How fast the car's speed and yaw rate wander, from its seconds so far:
        ``(q_v in m²/s³, q_r in rad²/s³)``, or None before :data:`MIN_CHANGES` changes.

        Taken as Brownian (a random walk of the speed and of the yaw rate), the change
        between two consecutive seconds' means has variance ``2/3 q``, so ``q`` is 1.5
        times the mean squared change of the per-second distance and yaw.
        """
        n, sv, sr = self._changes
        if n < MIN_CHANGES:
            return None
        return 1.5 * sv / n, 1.5 * sr / n

    def bridge(
        self,
        t_s: np.ndarray,
        omega_rl: np.ndarray,
        omega_rr: np.ndarray,
        yaw_rate: np.ndarray | None,
        end_fix: tuple[float, float],
        end_withheld: bool,
    ) -> bool:
        """Carry the filter across a logger's gap instead of starting afresh.

        The rows run from the end of the last second filtered, across the gap, to the
        row that starts the next one (the rows on either side are the logger's own; inside
        the gap the wheels' speeds and the yaw rate are taken as changing linearly). The
        span is cut into ``round(span)`` steps of about a second, each step's wheel angles
        and gyro yaw integrated by the trapezoid rule, its distance the rear wheels' travel
        with the WPM's radii (the model needs whole seconds of rows), and its yaw the gyro's
        (the wheels' where the drive has no gyro: one line across the gap is one guess of
        the turn, not two sensors' news). What the line across the gap may miss is added to
        the steps' variances: a speed and a yaw rate that wander as random walks
        (:meth:`diffusion`) leave ``q g³ / 12`` on the integral across a gap of ``g`` s
        (a Brownian bridge's integral), shared out over the steps. The fix ending the span
        updates the filter unless it is withheld (an outage's).

        Returns:
            Whether the filter was carried across (False: it had not started, or the drive
            has not shown how fast its speed changes yet; then it starts afresh).
        """
        q = self.diffusion()
        t = np.asarray(t_s, np.float64)
        if not self.started or q is None or len(t) < 2:
            self.reset()
            return False
        span = float(t[-1] - t[0])
        k = max(1, round(span))
        edges = t[0] + span * np.arange(k + 1) / k

        def per_step(values: np.ndarray) -> np.ndarray:
            v = np.asarray(values, np.float64)
            cum = cumulative_trapezoid(v, t)
            return np.diff(np.interp(edges, t, cum))

        a_rl, a_rr = per_step(np.abs(omega_rl)), per_step(np.abs(omega_rr))
        r_rl, r_rr = self.radii_m
        dist = 0.5 * (a_rl * r_rl + a_rr * r_rr)
        gyro = per_step(yaw_rate) if yaw_rate is not None else np.full(k, np.nan)
        gaps3 = float(np.sum(np.diff(t) ** 3)) / 12.0 / k  # each step's share
        a, b = self.variance()
        lat, lon = (float(v) for v in end_fix)
        fix = (np.nan, np.nan)  # the fix ending the span, raw, m
        if self._ref is not None and np.isfinite(lat) and np.isfinite(lon):
            e, n = offsets_m(*self._ref, np.array([lat]), np.array([lon]))
            fix = (float(e[0]), float(n[0]))
        seen_e = np.full(k + 1, np.nan)
        seen_n = np.full(k + 1, np.nan)
        if not self._last_withheld:
            seen_e[0], seen_n[0] = self._last_fix
        if not end_withheld:
            seen_e[-1], seen_n[-1] = fix
        wheels = wheel_yaw_rad(a_rl, a_rr, r_rl, r_rr, self.config.wheels.track_rear_m)
        # the line across the gap is one guess of the turn, whichever sensor it is drawn
        # through: the gyro's where it has one, so that its spread is not counted twice
        wheels = np.where(np.isfinite(gyro), np.nan, wheels)
        inputs = NavInputs(
            dist_m=dist[None],
            dist_var_m2=(a + b * dist**2 + q[0] * gaps3)[None],
            wheel_yaw_rad=wheels[None],
            gyro_yaw_rad=gyro[None],
            fix_e_m=seen_e[None],
            fix_n_m=seen_n[None],
            gyro_yaw_before_rad=np.array([self._last_gyro]),
            yaw_var_rad2=np.full((1, k), q[1] * gaps3),
        )
        start = NavStart(self._x[None], self._p[None], np.ones(1, bool))
        track = run(inputs, self.config, self.control, start=start)
        self._x, self._p = track.x[0, -1], track.last_cov[0]
        self._last_fix = fix
        self._last_latlon = (lat, lon)
        self._last_withheld = bool(end_withheld)
        self._last_gyro = float(gyro[-1])
        pred = track.fix_pred[0, -1]
        self._last_pred = tuple(float(v[0]) for v in self._latlon(pred[:1], pred[1:]))
        self._prev = (np.nan, np.nan)  # the steps are not seconds of the drive's own
        return True

    def variance(self) -> tuple[float, float]:
        """``(a, b)`` of the corrected distance's variance so far (module docstring)."""
        a, b = variance_fit(self._sums[None])
        return float(a[0]), float(b[0])

    def step(self, sec: dict[str, np.ndarray], withheld: np.ndarray) -> dict[str, np.ndarray]:
        """Filter a block of seconds.

        Args:
            sec: per second ``disp_corrected_m``, ``disp_gnss_m``, ``angle_rl_rad``,
                ``angle_rr_rad``, ``gyro_yaw_rad``, ``lat_deg`` and ``lon_deg`` (the fix
                ending the second; NaN where none) and, optionally, ``backwards`` (bool:
                the log says the second was driven backwards, a logger that signs its
                wheel speeds).
            withheld: (n,) seconds inside an outage: their fixes do not reach the filter.

        Returns:
            Per second: ``pred_lat``, ``pred_lon`` (the filter's fix at the end of the
            second; NaN before it starts), ``cov`` (n, 2, 2: its covariance, east/north
            m², in the filter's frame: the stream's first fix's, whose axes turn from the
            local ones by the meridians' convergence, a few thousandths of a radian
            within tens of kilometres), ``start_lat``, ``start_lon`` (the GNSS fix at the
            start of each second, withheld or not; NaN where none) and
            ``start_pred_lat``, ``start_pred_lon`` (the filter's fix there).
        """
        dist = np.asarray(sec["disp_corrected_m"], np.float64)
        n = len(dist)
        lat = np.asarray(sec["lat_deg"], np.float64)
        lon = np.asarray(sec["lon_deg"], np.float64)
        fix_e, fix_n = np.full(n, np.nan), np.full(n, np.nan)
        ok = np.isfinite(lat) & np.isfinite(lon)
        if self._ref is None and ok.any():
            first = int(np.flatnonzero(ok)[0])
            self._ref = (float(lat[first]), float(lon[first]))
        if self._ref is not None and ok.any():
            fix_e[ok], fix_n[ok] = offsets_m(*self._ref, lat[ok], lon[ok])
        # the distance's variance from the seconds outside the outages with GNSS, each
        # second's from those before it (the same whatever the blocks)
        gnss = np.asarray(sec["disp_gnss_m"], np.float64)
        use = ~withheld & np.isfinite(gnss) & np.isfinite(dist)
        e = np.where(use, dist - gnss, 0.0)
        d = np.where(use, dist, 0.0)
        terms = np.stack([use, d * d, d**4, e * e, e * e * d * d], axis=1).astype(np.float64)
        sums = self._sums + np.cumsum(np.r_[np.zeros((1, 5)), terms[:-1]], axis=0)
        self._sums = sums[-1] + terms[-1]
        a, b = variance_fit(sums)
        r_rl, r_rr = self.radii_m
        yaw = wheel_yaw_rad(
            sec["angle_rl_rad"], sec["angle_rr_rad"], r_rl, r_rr, self.config.wheels.track_rear_m
        )
        gyro = np.asarray(sec["gyro_yaw_rad"], np.float64)
        # how fast the speed and the yaw change from second to second (bridge)
        turn = np.where(np.isfinite(gyro), gyro, yaw)
        chg_d = np.diff(np.r_[self._prev[0], dist])
        chg_r = np.diff(np.r_[self._prev[1], turn])
        ok = np.isfinite(chg_d) & np.isfinite(chg_r)
        self._changes += (ok.sum(), np.sum(chg_d[ok] ** 2), np.sum(chg_r[ok] ** 2))
        self._prev = (float(dist[-1]), float(turn[-1])) if n else self._prev
        # the filter sees the fixes of the seconds outside the outages, and the fix that
        # starts the block unless the second that ended on it was an outage's
        seen_e = np.r_[self._last_fix[0], np.where(withheld, np.nan, fix_e)]
        seen_n = np.r_[self._last_fix[1], np.where(withheld, np.nan, fix_n)]
        if self._last_withheld:
            seen_e[0] = seen_n[0] = np.nan
        var, self._outage = self.calibration.outage_variance(
            a + b * np.nan_to_num(dist) ** 2, withheld, self._outage
        )
        inputs = NavInputs(
            dist_m=np.nan_to_num(dist)[None],
            dist_var_m2=var[None],
            wheel_yaw_rad=yaw[None],
            gyro_yaw_rad=gyro[None],
            fix_e_m=seen_e[None],
            fix_n_m=seen_n[None],
            backwards=np.asarray(sec.get("backwards", np.zeros(n, bool)), bool)[None],
            gyro_yaw_before_rad=np.array([self._last_gyro]),
        )
        start = None
        if self._x is not None:
            start = NavStart(self._x[None], self._p[None], np.ones(1, bool))
        track = run(inputs, self.config, self.control, start=start)
        pred = track.fix_pred[0]
        if track.started[0, -1]:
            self._x, self._p = track.x[0, -1], track.last_cov[0]
        start_lat = np.r_[self._last_latlon[0], lat[:-1]]
        start_lon = np.r_[self._last_latlon[1], lon[:-1]]
        pred_lat, pred_lon = self._latlon(pred[:, 0], pred[:, 1])
        start_pred_lat = np.r_[self._last_pred[0], pred_lat[:-1]]
        start_pred_lon = np.r_[self._last_pred[1], pred_lon[:-1]]
        self._last_fix = (float(fix_e[-1]), float(fix_n[-1]))
        self._last_latlon = (float(lat[-1]), float(lon[-1]))
        self._last_withheld = bool(withheld[-1])
        self._last_gyro = float(gyro[-1]) if n else np.nan
        self._last_pred = (float(pred_lat[-1]), float(pred_lon[-1]))
        return {
            "pred_lat": pred_lat,
            "pred_lon": pred_lon,
            "cov": track.fix_cov[0],
            "start_lat": start_lat,
            "start_lon": start_lon,
            "start_pred_lat": start_pred_lat,
            "start_pred_lon": start_pred_lon,
        }

    def _latlon(self, east: np.ndarray, north: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the filter's frame as fixes (NaN where not finite)."""
        lat, lon = np.full(len(east), np.nan), np.full(len(east), np.nan)
        ok = np.isfinite(east) & np.isfinite(north)
        if self._ref is not None and ok.any():
            lat[ok], lon[ok] = latlon_from_offsets_deg(*self._ref, east[ok], north[ok])
        return lat, lon
