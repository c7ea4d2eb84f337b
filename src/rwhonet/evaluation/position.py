"""2D position at the end of each outage window: the navigation filter, per model and control.

Beyond the paper, whose metrics (CRSE, CTE) are distances travelled (issue 17).
For every target test window of every outage length (the same windows as
CRSE/CTE), where is the car when GNSS returns, and how sure is the filter?

**The filter** (:mod:`rwhonet.nav`): per target test segment, the extended
Kalman filter runs over every second with GNSS (course and fix updates),
propagated by a model's distance of each second with that model's variance
(:mod:`rwhonet.evaluation.uncertainty`) and by the yaw of the gyro, the rear
wheels, or both fused; its state is kept where each window begins
(:class:`rwhonet.nav.NavStart`), and from there every window is dead-reckoned
through its outage without GNSS. The error is the horizontal distance between
the predicted fix and the GNSS fix ending the window; the filter's 2x2
covariance of that prediction, calibrated as a bivariate Student t on the same
filter's windows of the target training drives (:func:`calibrate_on_training`;
the receiver drift and the gyro's bias instability the filter uses fitted on
the same windows first, :func:`fit_noise`),
gives the coverage of its 68.27 % / 95.45 % regions and the negative
log-likelihood, beside those of the filter's own normal ellipses
(:mod:`rwhonet.nav.coverage`). A
window counts when the filter has run at least
``evaluate.navigation.min_calibration_s`` seconds of its segment before it,
and, for the controls that use the gyro, when every second of the outage has a
gyro yaw; windows left out are counted.

Rows: every odometry model (WPM, G, S, WPM-m and every recipe at the chosen m;
not ``R[continuous]``, whose distances exist only inside the windows, so the
filter has none to run on before them) with the fused control; and the
filter's own controls with ``evaluate.navigation.control_model``'s distances
(R-WhONet by default): ``wheels`` alone, ``gyro`` alone, ``fused``, and
``fused`` on the GNSS's own distances (:data:`GNSS_DISTANCE`: the error left is
the heading's). Drives without a yaw rate have no gyro and no fused rows: the
models' rows then use the wheels (``position_control`` in eval.json says which).

**The dead-reckoning control** (:func:`window_tracks`, :func:`position_errors`):
the previous 2D estimate, kept for comparison. From the GNSS fix before the
window, heading from the rear wheels fitted to the GNSS course over
``evaluate.dead_reckoning.calibration_s`` seconds before it
(:mod:`rwhonet.features.deadreckoning`); each second's distance is the model's.
The row :data:`HEADING_ONLY` dead-reckons the GNSS's own distances.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import CONTINUOUS
from rwhonet.evaluation.uncertainty import (
    AIC_NATS,
    ASSUMED,
    DistanceVariance,
    FitEvidence,
    TrainingErrors,
    masked_windows,
)
from rwhonet.evaluation.windows import evaluated_rows, outage_windows
from rwhonet.features.deadreckoning import course_rad, dead_reckon, fit_heading, wheel_yaw_rad
from rwhonet.geo.local import offsets_m
from rwhonet.nav import (
    MIN_T2_WINDOWS,
    SIGMA_CONTENT,
    NavConfig,
    NavInputs,
    NavStart,
    NavTrack,
    config_from_params,
    coverage_2d,
    fit_t2,
    fit_t2_scale,
    mahalanobis_sq,
    nll_2d,
    run,
    t2_radius_nll,
)

GNSS_DISTANCE = "GNSS distance"  # the filter's control on the GNSS's own distances

HEADING_ONLY = "heading only (GNSS distance)"


def _nominal_wheel_yaw(frame: pd.DataFrame, params: Params) -> np.ndarray:
    """Every row's rear-wheel yaw with the target car's nominal radius (both wheels) and track."""
    vehicle = params.data.roles[k.TARGET_TEST].vehicle
    r = params.nominal_radius_m(vehicle)
    return wheel_yaw_rad(
        frame[k.ANGLE_RL_RAD].to_numpy(np.float64),
        frame[k.ANGLE_RR_RAD].to_numpy(np.float64),
        r,
        r,
        params.track_rear_m(vehicle),
    )


def window_tracks(frame: pd.DataFrame, params: Params, outage_s: int) -> dict[str, np.ndarray]:
    """Everything but the distances: per target test window, its heading fit and truth.

    Returns:
        ``rows`` (W, L) row indices of the windows, ``azimuth0``, ``scale``,
        ``bias``, ``load`` (per window), ``truth_e``/``truth_n`` (the GNSS offset of the
        window's end from its start fix, m) and ``yaw`` (W, L); only windows that
        could be dead-reckoned.
    """
    cfg = params.evaluate.dead_reckoning
    windows = outage_windows(frame, params.adapt.m_grid, outage_s)
    role = frame["role"].to_numpy()
    windows = windows[role[windows[:, 0]] == k.TARGET_TEST] if len(windows) else windows
    group = frame["group"].to_numpy()
    lat = frame[k.LAT_DEG].to_numpy(np.float64)
    lon = frame[k.LON_DEG].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    # The yaw's scale (radius / track) and the rear wheels' radius difference are fitted
    # per window against GNSS, so the nominal radius and track only need to be close.
    yaw_all = _nominal_wheel_yaw(frame, params)
    # GNSS course per row, within each segment (the first row of a segment has none)
    course = np.full(len(frame), np.nan)
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    for a, b in zip(starts, np.r_[starts[1:], len(frame)], strict=True):
        course[a:b] = course_rad(lat[a:b], lon[a:b], cfg.min_step_m)
    first_row = starts[np.searchsorted(starts, np.arange(len(frame)), side="right") - 1]
    keys = ("rows", "azimuth0", "scale", "bias", "load", "truth_e", "truth_n")
    out: dict[str, list] = {key: [] for key in keys}
    for rows in windows:
        i0 = rows[0]
        if i0 == first_row[i0]:
            continue  # no fix before the window in its segment
        # 0: every second of the segment before the window (never one after its start)
        a = first_row[i0] if cfg.calibration_s == 0 else max(first_row[i0], i0 - cfg.calibration_s)
        fit = fit_heading(course[a:i0], yaw_all[a:i0], gnss[a:i0])
        if fit is None:
            continue
        e, n = offsets_m(lat[i0 - 1], lon[i0 - 1], lat[rows[-1]], lon[rows[-1]])
        for key, value in (
            ("rows", rows),
            ("azimuth0", fit.azimuth_end_rad),
            ("scale", fit.scale),
            ("bias", fit.bias_rad_per_m),
            ("load", fit.load_s2_m2),
            ("truth_e", float(e)),
            ("truth_n", float(n)),
        ):
            out[key].append(value)
    length = outage_s
    result = {key: np.asarray(v, np.float64) for key, v in out.items() if key != "rows"}
    result["rows"] = np.asarray(out["rows"], np.int64).reshape(-1, length)
    result["yaw"] = yaw_all[result["rows"]] if len(result["rows"]) else np.empty((0, length))
    result["n_windows"] = np.asarray(len(windows))
    return result


def position_errors(
    frame: pd.DataFrame,
    tracks: dict[int, dict[str, np.ndarray]],
    errors: dict[str, np.ndarray | dict[int, np.ndarray]],
) -> list[dict]:
    """Horizontal error at the end of every window, per model.

    Args:
        frame: the test drives' samples (every row).
        tracks: per outage length, :func:`window_tracks`.
        errors: per model, its per-second error (label − prediction) on every row
            of ``frame`` (the WPM's is the label); or, for a model whose error
            depends on the window (``R[continuous]``), one such array per outage.

    Returns:
        One row per model and outage: ``model, outage_s, pos_mean, pos_max,
        n_windows`` (m; windows dead-reckoned).
    """
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    out = []
    for L, t in tracks.items():
        rows = t["rows"]
        for model, per_model in errors.items():
            err = per_model[L] if isinstance(per_model, dict) else per_model
            if not len(rows):
                continue
            dist = gnss[rows] - err[rows]  # the model's distance each second
            end = np.empty(len(rows))
            for w in range(len(rows)):
                e, n = dead_reckon(
                    t["azimuth0"][w],
                    dist[w],
                    t["yaw"][w],
                    t["scale"][w],
                    t["bias"][w],
                    t["load"][w],
                )
                end[w] = np.hypot(e[-1] - t["truth_e"][w], n[-1] - t["truth_n"][w])
            out.append(
                {
                    "model": model,
                    "outage_s": L,
                    "pos_mean": float(end.mean()),
                    "pos_max": float(end.max()),
                    "n_windows": len(rows),
                }
            )
    return out


# --------------------------------------------------------------------------- the filter


@dataclass(frozen=True)
class Odometry:
    """One filter run: a model's distance of every second, its variance, and the yaw control.

    Attributes:
        model: the row's name (a model, or :data:`GNSS_DISTANCE`).
        seed: the training seed, None when the same for every seed (WPM, WPM-m, GNSS).
        control: ``wheels``, ``gyro`` or ``fused``.
        dist_m: (N,) the distance of every row of the frame, m.
        var_m2: (N,) its error variance, m².
        outage_var_m2: per outage length, the variance inside such an outage
            (errors that last; default: ``var_m2``).
    """

    model: str
    seed: int | None
    control: str
    dist_m: np.ndarray
    var_m2: np.ndarray
    outage_var_m2: dict[int, np.ndarray] = field(default_factory=dict)


def model_runs(
    model: str,
    seed: int | None,
    dist_m: np.ndarray,
    fit: DistanceVariance,
    plan: dict,
    outages_s: list[int],
) -> list[Odometry]:
    """A model's filter runs: its plan's control, or every control on ``control_model``'s.

    Args:
        model: the model.
        seed: its seed (None: the same run for every seed).
        dist_m: its distance of every row, m.
        fit: its distance variance (per second and inside each outage length).
        plan: :func:`rwhonet.evaluation.study.navigation_plan`'s ``control``,
            ``control_model`` and ``controls``.
        outages_s: the outage lengths.
    """
    controls = plan["controls"] if model == plan["control_model"] else [plan["control"]]
    outage_var = {L: fit.outage_var(dist_m, L) for L in outages_s}
    return [Odometry(model, seed, c, dist_m, fit.var(dist_m), outage_var) for c in controls]


def gnss_run(gnss_m: np.ndarray, plan: dict, cfg: NavConfig) -> Odometry:
    """The filter's control on the GNSS's own distance of each second (the heading's error)."""
    var = np.full(len(gnss_m), gnss_distance_var(cfg))
    return Odometry(GNSS_DISTANCE, None, plan["control"], gnss_m, var)


def filter_models(model_list: list[str]) -> list[str]:
    """The models the filter runs on: all but ``R[continuous]`` (no distance before a window)."""
    return [m for m in model_list if CONTINUOUS not in m]


def nav_config(params: Params) -> NavConfig:
    """The filter's settings: ``evaluate.navigation`` and the target car's radius and track."""
    vehicle = params.data.roles[k.TARGET_TEST].vehicle
    return config_from_params(
        params.evaluate.navigation,
        params.nominal_radius_m(vehicle),
        params.track_rear_m(vehicle),
    )


def gnss_distance_var(cfg: NavConfig) -> float:
    """The variance of a second's GNSS distance: both fixes' white noise, and 5 cm besides."""
    return 0.05**2 + 2.0 * cfg.gnss.white_m**2


@dataclass(frozen=True)
class Segments:
    """The target test segments' per-second arrays for the filter, padded to the longest.

    Attributes:
        first_row: (G,) the frame row of each segment's first second.
        length: (G,) its seconds.
        wheel_yaw: (G, n) the rear wheels' yaw of each second (nominal radii), rad.
        gyro_yaw: (G, n) the gyro's, rad (NaN: none).
        backwards: (G, n) seconds the log says were driven backwards (a logger that
            signs its wheel speeds; :data:`rwhonet.contracts.BACKWARDS`).
        fix_e: (G, n + 1) the GNSS fixes east of the segment's first fix, m: column
            ``j + 1`` ends second ``j``; column 0 (the fix before the first second,
            not in the samples) and the padding are NaN.
        fix_n: (G, n + 1) north, m.
        segment_of: (N,) each frame row's segment, -1 outside the target test drives.
    """

    first_row: np.ndarray
    length: np.ndarray
    wheel_yaw: np.ndarray
    gyro_yaw: np.ndarray
    fix_e: np.ndarray
    fix_n: np.ndarray
    segment_of: np.ndarray
    backwards: np.ndarray

    def gather(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """A per-row array of the frame as (G, n) per segment and second, padded with ``fill``."""
        return _gather(values, self.first_row, self.length, self.wheel_yaw.shape[1], fill)


def _gather(
    values: np.ndarray, first_row: np.ndarray, length: np.ndarray, n: int, fill: float
) -> np.ndarray:
    idx = first_row[:, None] + np.arange(n)
    inside = np.arange(n) < length[:, None]
    v = np.asarray(values, np.float64)
    return np.where(inside, v[np.where(inside, idx, 0)], fill)


def nav_segments(frame: pd.DataFrame, params: Params, role: str = k.TARGET_TEST) -> Segments:
    """Cut the drives of one role (the target test drives) into the filter's per-segment arrays."""
    group = frame["group"].to_numpy()
    target = (frame["role"] == role).to_numpy()
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    ends = np.r_[starts[1:], len(frame)]
    keep = target[starts] if len(starts) else np.zeros(0, bool)
    first, length = starts[keep], (ends - starts)[keep]
    segment_of = np.full(len(frame), -1, np.int64)
    for i, (a, n) in enumerate(zip(first, length, strict=True)):
        segment_of[a : a + n] = i
    yaw = _nominal_wheel_yaw(frame, params)
    gyro = (
        frame[k.GYRO_YAW_RAD].to_numpy(np.float64)
        if k.GYRO_YAW_RAD in frame
        else np.full(len(frame), np.nan)
    )
    back = frame[k.BACKWARDS].to_numpy(np.float64) if k.BACKWARDS in frame else np.zeros(len(frame))
    n_max = int(length.max()) if len(length) else 0
    lat = frame[k.LAT_DEG].to_numpy(np.float64)
    lon = frame[k.LON_DEG].to_numpy(np.float64)
    fix_e = np.full((len(first), n_max + 1), np.nan)
    fix_n = np.full((len(first), n_max + 1), np.nan)
    for i, (a, n) in enumerate(zip(first, length, strict=True)):
        fix_e[i, 1 : n + 1], fix_n[i, 1 : n + 1] = offsets_m(
            lat[a], lon[a], lat[a : a + n], lon[a : a + n]
        )
    return Segments(
        first,
        length,
        _gather(yaw, first, length, n_max, 0.0),
        _gather(gyro, first, length, n_max, np.nan),
        fix_e,
        fix_n,
        segment_of,
        _gather(back, first, length, n_max, 0.0) > 0.5,
    )


def segment_pass(
    segs: Segments, runs: list[Odometry], cfg: NavConfig, snapshots: np.ndarray | None = None
) -> NavTrack:
    """One filter pass of every run (one control) over every segment with GNSS throughout.

    Returns:
        The track, rows run-major: row ``i · G + g`` is run ``i`` on segment ``g``.
    """
    dist = np.stack([segs.gather(r.dist_m) for r in runs])  # (R, G, n)
    var = np.stack([segs.gather(r.var_m2) for r in runs])
    shape = (len(runs) * dist.shape[1], dist.shape[2])
    tile = (len(runs), 1)
    return run(
        NavInputs(
            dist.reshape(shape),
            var.reshape(shape),
            np.tile(segs.wheel_yaw, tile),
            np.tile(segs.gyro_yaw, tile),
            np.tile(segs.fix_e, tile),
            np.tile(segs.fix_n, tile),
            np.tile(segs.backwards, tile),
        ),
        cfg,
        runs[0].control,
        snapshots=snapshots,
    )


def target_windows(
    frame: pd.DataFrame, params: Params, outage_s: int, role: str = k.TARGET_TEST
) -> np.ndarray:
    """The windows of ``outage_s`` on one role's drives (rows (W, L)); on the target test
    drives, the CRSE/CTE windows."""
    windows = outage_windows(frame, params.adapt.m_grid, outage_s)
    roles = frame["role"].to_numpy()
    return windows[roles[windows[:, 0]] == role] if len(windows) else windows


WINDOW_COLUMNS = (
    "model",
    "seed",
    "control",
    "outage_s",
    "window",
    "drive",
    "counted",
    "err_e_m",
    "err_n_m",
    "cov_ee_m2",
    "cov_en_m2",
    "cov_nn_m2",
    "horizontal_m",
    "distance_m",
)


def filter_windows(
    frame: pd.DataFrame,
    params: Params,
    runs: list[Odometry],
    outages_s: list[int],
    cfg: NavConfig | None = None,
    role: str = k.TARGET_TEST,
    windows: dict[int, np.ndarray] | None = None,
) -> pd.DataFrame:
    """Every run's end of every target test window: error, predicted covariance, distance.

    Per control, one filter pass over every target test segment of every run (all
    at once), snapshotted where the windows begin; then per outage length every
    window of every run dead-reckoned from its snapshot.

    Args:
        frame: the test drives' samples (every test role).
        params: ``adapt.m_grid``, ``evaluate.navigation``, the target car.
        runs: the filter runs.
        outages_s: the outage lengths.
        cfg: the filter's settings (default: :func:`nav_config`).
        role: whose drives: the target test drives, or the target training drives
            the 2D calibration is fitted on (:func:`calibrate_2d`).
        windows: per outage length, the windows' rows (W, L) on that role's drives
            (default: :func:`target_windows`).

    Returns:
        One row per run, outage length and window (:data:`WINDOW_COLUMNS`);
        ``counted`` is False for a window the filter had not calibrated on
        ``min_calibration_s`` seconds before, or (gyro, fused) without a gyro yaw
        in every second of its outage; its other values are then NaN.
    """
    cfg = cfg or nav_config(params)
    min_cal = params.evaluate.navigation.min_calibration_s
    segs = nav_segments(frame, params, role)
    n_seg = len(segs.first_row)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    if windows is None:
        windows = {L: target_windows(frame, params, L, role) for L in outages_s}
    where = {}
    for L, rows in windows.items():
        g = segs.segment_of[rows[:, 0]] if len(rows) else np.zeros(0, np.int64)
        where[L] = (g, rows[:, 0] - segs.first_row[g] if len(rows) else g)
    if not n_seg or not runs:
        return pd.DataFrame(columns=list(WINDOW_COLUMNS))
    snaps = np.unique(np.concatenate([np.maximum(s - 1, 0) for _, s in where.values()]))
    out = []
    for control in dict.fromkeys(r.control for r in runs):
        mine = [r for r in runs if r.control == control]
        n_run = len(mine)
        dist = np.stack([segs.gather(r.dist_m) for r in mine])  # (R, G, n)
        track = segment_pass(segs, mine, cfg, snaps)
        for L, rows in windows.items():
            g, s = where[L]
            n_win = len(g)
            if not n_win:
                continue
            row = np.arange(n_run)[:, None] * n_seg + g[None, :]  # (R, W) pass-1 rows
            slot = np.searchsorted(snaps, np.maximum(s - 1, 0))
            ready = s - 1 - min_cal
            calibrated = (ready >= 0)[None, :] & track.started[row, np.maximum(ready, 0)[None, :]]
            sec = s[:, None] + np.arange(L)  # (W, L) seconds of the segment
            gyro_w = segs.gyro_yaw[g[:, None], sec]
            gyro_before = np.where(s > 0, segs.gyro_yaw[g, np.maximum(s - 1, 0)], np.nan)
            has_gyro = np.isfinite(gyro_w).all(axis=1)
            counted = calibrated & (has_gyro[None, :] if control != "wheels" else True)
            flat = n_run * n_win
            n_state = track.snapshot_x.shape[-1]
            start = NavStart(
                track.snapshot_x[row, slot[None, :]].reshape(flat, -1),
                track.snapshot_cov[row, slot[None, :]].reshape(flat, n_state, n_state),
                counted.reshape(flat),
            )
            var_out = np.stack(
                [segs.gather(r.outage_var_m2.get(L, r.var_m2)) for r in mine]
            )  # (R, G, n)
            blind = np.full((flat, L + 1), np.nan)
            ends = run(
                NavInputs(
                    dist[:, g[:, None], sec].reshape(flat, L),
                    var_out[:, g[:, None], sec].reshape(flat, L),
                    np.broadcast_to(segs.wheel_yaw[g[:, None], sec], (n_run, n_win, L)).reshape(
                        flat, L
                    ),
                    np.broadcast_to(gyro_w, (n_run, n_win, L)).reshape(flat, L),
                    blind,
                    blind,
                    np.broadcast_to(segs.backwards[g[:, None], sec], (n_run, n_win, L)).reshape(
                        flat, L
                    ),
                    np.broadcast_to(gyro_before, (n_run, n_win)).reshape(flat),
                ),
                cfg,
                control,
                start=start,
            )
            truth = np.stack([segs.fix_e[g, s + L], segs.fix_n[g, s + L]], axis=1)
            err = ends.fix_pred[:, -1].reshape(n_run, n_win, 2) - truth[None]
            cov = ends.fix_cov[:, -1].reshape(n_run, n_win, 2, 2)
            driven = gnss[rows].sum(axis=1)
            drive = frame["drive"].to_numpy()[rows[:, 0]]
            for i, r in enumerate(mine):
                ok = counted[i]
                e = np.where(ok[:, None], err[i], np.nan)
                out.append(
                    pd.DataFrame(
                        {
                            "model": r.model,
                            "seed": r.seed,
                            "control": control,
                            "outage_s": L,
                            "window": np.arange(n_win),
                            "drive": drive,
                            "counted": ok,
                            "err_e_m": e[:, 0],
                            "err_n_m": e[:, 1],
                            "cov_ee_m2": np.where(ok, cov[i, :, 0, 0], np.nan),
                            "cov_en_m2": np.where(ok, cov[i, :, 0, 1], np.nan),
                            "cov_nn_m2": np.where(ok, cov[i, :, 1, 1], np.nan),
                            "horizontal_m": np.hypot(e[:, 0], e[:, 1]),
                            "distance_m": driven,
                        }
                    )
                )
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame(columns=list(WINDOW_COLUMNS))


WINDOW_STATS = (
    "pos_mean",
    "pos_max",
    "pos_pct",
    "pos_pct_max",
    "cover_1sigma",
    "cover_2sigma",
    "nll",
    "cover_1sigma_filter",
    "cover_2sigma_filter",
    "nll_filter",
    "calib_scale",
    "calib_dof",
)


@dataclass(frozen=True)
class Calibration2D:
    """A run's 2D calibration, fitted on target training windows (:func:`calibrate_2d`).

    Attributes:
        scale: ``c``, the filter's covariance times it is the t's scale matrix
            (fitted over every outage length).
        dof: ``ν``, its degrees of freedom (``inf``: a normal).
        n_windows: training windows fitted on (below
            :data:`~rwhonet.nav.coverage.MIN_T2_WINDOWS`: not fitted, ``c = 1, ν = ∞``).
        scales: ``c`` of each outage length with enough windows of its own
            (:func:`calibrate_2d`); other lengths take ``scale``.
        dofs: ``ν`` of each outage length whose windows' tails are their own
            (:func:`calibrate_2d`: likelier by Akaike's criterion); other lengths
            take ``dof``.
    """

    scale: float = 1.0
    dof: float = float("inf")
    n_windows: int = 0
    scales: dict[int, float] = field(default_factory=dict)
    dofs: dict[int, float] = field(default_factory=dict)

    def scale_at(self, outage_s: int | None) -> float:
        """``c`` for windows of one outage length."""
        return self.scales.get(outage_s, self.scale) if outage_s is not None else self.scale

    def dof_at(self, outage_s: int | None) -> float:
        """``ν`` for windows of one outage length."""
        return self.dofs.get(outage_s, self.dof) if outage_s is not None else self.dof


def _errors_and_covs(w: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    err = w[["err_e_m", "err_n_m"]].to_numpy(np.float64)
    cov = np.stack(
        [
            w[["cov_ee_m2", "cov_en_m2"]].to_numpy(np.float64),
            w[["cov_en_m2", "cov_nn_m2"]].to_numpy(np.float64),
        ],
        axis=1,
    )
    return err, cov


def window_stats(
    windows: pd.DataFrame, calibration: Calibration2D | None = None, outage_s: int | None = None
) -> dict:
    """One run's windows of one outage length (``outage_s``: its calibration's scale)
    summarised.

    Returns:
        ``pos_mean``, ``pos_max`` (m); ``pos_pct`` (the errors' sum over the
        distances' sum, %: the mean error as a share of the mean distance, so a
        window standing in traffic does not blow it up) and ``pos_pct_max`` (the
        worst window's error over its own distance, %); ``cover_1sigma`` and
        ``cover_2sigma`` (share of windows inside the predicted 68.27 % / 95.45 %
        regions of the calibrated prediction, :func:`rwhonet.nav.coverage.coverage_2d`)
        and ``nll`` (nats); the same of the filter's own normal (``..._filter``); the
        calibration (``calib_scale``, ``calib_dof``: NaN for a normal, ``ν = ∞``);
        ``n_windows`` (counted). NaN without a counted window.
    """
    cal = calibration or Calibration2D()
    w = windows[windows["counted"]]
    if not len(w):
        return {**dict.fromkeys(WINDOW_STATS, float("nan")), "n_windows": 0}
    h = w["horizontal_m"].to_numpy(np.float64)
    d = w["distance_m"].to_numpy(np.float64)
    err, cov = _errors_and_covs(w)
    scale, dof = cal.scale_at(outage_s), cal.dof_at(outage_s)
    cover = coverage_2d(err, cov, scale=scale, dof=dof)
    own = coverage_2d(err, cov)
    worst = int(np.argmax(h))
    return {
        "pos_mean": float(h.mean()),
        "pos_max": float(h[worst]),
        "pos_pct": float(100.0 * h.sum() / d.sum()) if d.sum() > 0 else float("nan"),
        "pos_pct_max": float(100.0 * h[worst] / d[worst]) if d[worst] > 0 else float("nan"),
        "cover_1sigma": cover[SIGMA_CONTENT[0]],
        "cover_2sigma": cover[SIGMA_CONTENT[1]],
        "nll": nll_2d(err, cov, scale, dof),
        "cover_1sigma_filter": own[SIGMA_CONTENT[0]],
        "cover_2sigma_filter": own[SIGMA_CONTENT[1]],
        "nll_filter": nll_2d(err, cov),
        "calib_scale": scale,
        "calib_dof": dof if np.isfinite(dof) else float("nan"),
        "n_windows": len(w),
    }


def calibrate_2d(windows: pd.DataFrame) -> dict[tuple, Calibration2D]:
    """Each run's bivariate-t calibration from its training windows' ends.

    The tails (``ν``) and a scale from every outage length's counted windows pooled
    (:func:`rwhonet.nav.coverage.fit_t2`); then each length's own scale with ``ν``
    held, where it has :data:`~rwhonet.nav.coverage.MIN_T2_WINDOWS` windows
    (:func:`rwhonet.nav.coverage.fit_t2_scale`): the filter's covariance grows with
    the outage, but not necessarily at the rate its errors do (its random walks are
    generic figures, not the car's), so one scale can be right for short outages and
    too large for long ones. Then each such length's own tails: its scale and ``ν``
    fitted together (:func:`rwhonet.nav.coverage.fit_t2`) replace the held ``ν``
    where they are likelier by more than Akaike's criterion asks for the one
    parameter more (the length's summed log-likelihood up by more than
    :data:`~rwhonet.evaluation.uncertainty.AIC_NATS`). Measured on the training
    windows: a short outage's errors are heavier-tailed (a few seconds of a bad
    GNSS fix or a manoeuvre weigh more) than a long one's.

    Args:
        windows: :func:`filter_windows` on the target training drives.

    Returns:
        ``{(model, seed, control): calibration}`` (``seed`` None for the runs shared
        by every seed).
    """
    out = {}
    for (model, seed, control), g in windows.groupby(
        ["model", "seed", "control"], sort=False, dropna=False
    ):
        w = g[g["counted"]]
        err, cov = _errors_and_covs(w)
        d2 = mahalanobis_sq(err, cov) if len(w) else np.zeros(0)
        scale, dof, n = fit_t2(d2)
        scales, dofs = {}, {}
        if n >= MIN_T2_WINDOWS:
            lengths = w["outage_s"].to_numpy()
            for L in np.unique(lengths):
                r = d2[lengths == L]
                c_l = fit_t2_scale(r, dof)
                if c_l is None:
                    continue
                scales[int(L)] = c_l
                c_own, dof_own, m = fit_t2(r)
                gain = m * (t2_radius_nll(r, c_l, dof) - t2_radius_nll(r, c_own, dof_own))
                if gain > AIC_NATS:
                    scales[int(L)], dofs[int(L)] = c_own, dof_own
        key_seed = None if pd.isna(seed) else int(seed)
        out[(model, key_seed, control)] = Calibration2D(scale, dof, n, scales, dofs)
    return out


def position_per_seed(
    windows: pd.DataFrame,
    seeds: list[int],
    calibrations: dict[tuple, Calibration2D] | None = None,
    by: tuple[str, ...] = (),
) -> pd.DataFrame:
    """Per seed, row (model, control) and outage length: :func:`window_stats`.

    Rows the same for every seed (``seed`` None) are repeated for each seed, so
    that every cell's mean over seeds has the same seeds. ``calibrations``
    (:func:`calibrate_2d`) calibrate each run's coverage; a run without one keeps
    the filter's normal. ``by``: more columns of ``windows`` to split the cells by
    (``("drive",)``: each test drive's windows apart, under its run's calibration).
    """
    calibrations = calibrations or {}
    rows = []
    for key_values, g in windows.groupby(
        ["model", "control", "outage_s", "seed", *by], sort=False, dropna=False
    ):
        model, control, L, seed = key_values[:4]
        key = (model, None if pd.isna(seed) else int(seed), control)
        stats = window_stats(g, calibrations.get(key), int(L))
        for s in seeds if pd.isna(seed) else [int(seed)]:
            rows.append(
                {
                    "seed": s,
                    "model": model,
                    "control": control,
                    "outage_s": int(L),
                    **dict(zip(by, key_values[4:], strict=True)),
                    **stats,
                    "n_windows_all": len(g),
                }
            )
    return pd.DataFrame(rows)


def training_passes(
    evidence: FitEvidence,
    errors: list[TrainingErrors],
    params: Params,
    plan: dict,
    fits: dict[tuple[int | None, str], DistanceVariance],
    outages_s: list[int],
    cfg: NavConfig,
) -> list[tuple[list[Odometry], dict[int, np.ndarray]]]:
    """The filter's runs on the target training drives, grouped by where they may be fitted.

    The same runs as on the test drives (:func:`model_runs` for every model of
    ``plan``, :func:`gnss_run`), each model's distance variance as fitted there
    (``fits``), over the windows where it may be fitted (``errors``' masks: S on its
    segments' validation tails); one group per mask, with its windows.

    Unlike the test windows (consecutive, the paper's), the training windows of every
    length start every ``min(outages_s)`` seconds, so the longer ones overlap: an
    outage may begin at any instant, and consecutive 180 s windows would fit that
    length's scale on one start in 180 s (on the large_target_consumer world 25
    windows per run, against 112 with a start every 30 s). The overlapping windows are
    correlated; the maximum-likelihood fit over them is a composite likelihood, whose
    estimate stays consistent.

    Returns:
        ``[(runs, {outage length: windows' rows (W, L)})]``.
    """
    frame = evidence.frame
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    groups: dict[str, tuple[np.ndarray, list[Odometry]]] = {
        "scored": (evaluated_rows(frame, params.adapt.m_grid), [gnss_run(gnss, plan, cfg)])
    }
    for t in errors:
        fit = fits.get((t.seed, t.model), ASSUMED)
        mask, runs = groups.setdefault("tail" if t.model == "S" else "scored", (t.mask, []))
        runs += model_runs(t.model, t.seed, gnss - t.error, fit, plan, outages_s)
    stride = min(outages_s)
    return [
        (runs, {L: masked_windows(frame, mask, L, stride) for L in outages_s})
        for mask, runs in groups.values()
    ]


def _training_windows(
    frame: pd.DataFrame,
    params: Params,
    passes: list[tuple[list[Odometry], dict[int, np.ndarray]]],
    outages_s: list[int],
    cfg: NavConfig,
) -> pd.DataFrame:
    ends = [
        filter_windows(frame, params, runs, outages_s, cfg, k.TARGET_TRAIN, windows)
        for runs, windows in passes
        if runs
    ]
    return (
        pd.concat(ends, ignore_index=True) if ends else pd.DataFrame(columns=list(WINDOW_COLUMNS))
    )


def calibrated_nll(windows: pd.DataFrame) -> tuple[float, int]:
    """The windows' mean negative log-likelihood under each run's own 2D calibration.

    Each run (model, seed, control) calibrated on these windows (:func:`calibrate_2d`),
    then every counted window's NLL under its run's bivariate t at its outage length:
    the likelihood the calibration maximises, so two filter settings compare by it.

    Returns:
        ``(mean NLL in nats, counted windows)``; ``(nan, 0)`` without one.
    """
    cals = calibrate_2d(windows)
    total, n = 0.0, 0
    counted = windows[windows["counted"].astype(bool)]  # an empty frame's column is object
    for (model, seed, control, L), g in counted.groupby(
        ["model", "seed", "control", "outage_s"], sort=False, dropna=False
    ):
        cal = cals[(model, None if pd.isna(seed) else int(seed), control)]
        err, cov = _errors_and_covs(g)
        total += nll_2d(err, cov, cal.scale_at(int(L)), cal.dof_at(int(L))) * len(g)
        n += len(g)
    return (total / n, n) if n else (float("nan"), 0)


@dataclass(frozen=True)
class ReceiverFit:
    """The receiver drift the filter uses, fitted on the target training drives.

    Attributes:
        sigma_m: the drift's spread (``evaluate.navigation.gnss.sigma_m`` when not
            fitted), m.
        tau_s: its correlation time (held at ``evaluate.navigation.gnss.tau_s``).
        configured_m: ``evaluate.navigation.gnss.sigma_m``.
        fitted: False: not asked for (``fit_sigma: false``), or too few windows.
        nll: the spreads tried and the training windows' mean calibrated NLL at each
            (:func:`calibrated_nll`), nats.
        n_windows: the counted training windows per spread tried.
    """

    sigma_m: float
    tau_s: float
    configured_m: float
    fitted: bool = False
    nll: dict[float, float] = field(default_factory=dict)
    n_windows: int = 0

    def as_dict(self) -> dict:
        """eval.json's ``position_controls.receiver``."""
        return {
            "sigma_m": round(self.sigma_m, 4),
            "tau_s": self.tau_s,
            "configured_sigma_m": self.configured_m,
            "fitted": self.fitted,
            "n_windows": self.n_windows,
            "nll": {f"{s:.4g}": round(v, 5) for s, v in sorted(self.nll.items())},
        }


RECEIVER_STEP = float(np.sqrt(2.0))  # the spreads tried: the configured one times powers of this
RECEIVER_SIGMA_M = (0.1, 30.0)  # and within this range
# the gyro's bias instability tried, deg/s: the configured one times powers of
# RECEIVER_STEP, within this range (a MEMS yaw-rate sensor's data sheet: 0.001-0.1 °/s)
GYRO_INSTABILITY_DEG_S = (0.0005, 0.2)
NOISE_ROUNDS = 4  # rounds over the two figures at most (:func:`climb`)


@dataclass(frozen=True)
class InstabilityFit:
    """The gyro's bias instability the filter uses, fitted with the receiver's drift.

    Attributes:
        instability_rad_s: the bias's Gauss-Markov spread ``B``
            (``evaluate.navigation.gyro.instability_deg_s`` when not fitted), rad/s.
        configured_rad_s: ``evaluate.navigation.gyro.instability_deg_s``, rad/s.
        fitted: False: not asked for (``gyro.fit_instability: false``), no gyro in the
            plan's control, or too few windows.
        nll: the instabilities tried at the fitted receiver drift, rad/s, and the
            training windows' mean calibrated NLL at each, nats.
        n_windows: the counted training windows per setting tried.
    """

    instability_rad_s: float
    configured_rad_s: float
    fitted: bool = False
    nll: dict[float, float] = field(default_factory=dict)
    n_windows: int = 0

    def apply(self, cfg: NavConfig) -> NavConfig:
        """``cfg`` with this bias instability."""
        return replace(cfg, gyro=replace(cfg.gyro, bias_instability=self.instability_rad_s))

    def as_dict(self) -> dict:
        """eval.json's ``position_controls.gyro`` (deg/s, as params.yaml writes it)."""
        return {
            "instability_deg_s": round(float(np.degrees(self.instability_rad_s)), 6),
            "configured_instability_deg_s": round(float(np.degrees(self.configured_rad_s)), 6),
            "fitted": self.fitted,
            "n_windows": self.n_windows,
            "nll": {f"{np.degrees(b):.4g}": round(v, 5) for b, v in sorted(self.nll.items())},
        }


def fit_noise(
    frame: pd.DataFrame,
    params: Params,
    passes: list[tuple[list[Odometry], dict[int, np.ndarray]]],
    plan: dict,
    outages_s: list[int],
    cfg: NavConfig,
) -> tuple[ReceiverFit, InstabilityFit]:
    """The receiver drift's spread and the gyro's bias instability that make the training
    windows' ends likeliest.

    The filter's GNSS model (a Gauss-Markov drift, ``sigma_m`` and ``tau_s``, plus
    white noise) is a receiver's datasheet figure, and a car's receiver, antenna and
    roads are not the datasheet's: with ``sigma_m`` of another grade the filter
    weighs the fixes before an outage wrongly and misjudges the error of the fix that
    ends it (on the large_target_consumer world, whose u-blox M8-class receiver drifts
    2.12 m with 60 s against the configured 1.5 m with 100 s, the calibrated test NLL
    fell at every outage length with the receiver's own figures). The gyro's bias
    instability ``B`` is the same kind of figure: the generic 0.01 °/s bounds the
    automotive sensors whose data sheets the filter's defaults come from, and a
    better gyro held to it lets the rear wheels pull its bias through every outage
    (docs/positioning.md: with the antenna and the gyro's latency fitted, the
    simulated cars' 0.0025 °/s gyros ended 180 s outages about a fifth closer with
    ``B`` fitted). Both change how far the filter's covariance grows through an
    outage and trade off against each other there, so they are fitted together, by
    maximum likelihood on the target training drives' windows
    (:func:`training_passes`), never a test drive: the filter with
    ``control_model``'s distances and ``plan['control']`` (its seeds) runs on them
    for each setting tried, and each setting is scored by the windows' mean NLL
    under their own calibration (:func:`calibrated_nll`). Each figure steps by
    :data:`RECEIVER_STEP` from the configured one towards the likelier side until
    the likelihood falls again (within :data:`RECEIVER_SIGMA_M` and
    :data:`GYRO_INSTABILITY_DEG_S`), refined by the vertex of the parabola through
    the best and its two neighbours in the figure's logarithm (:func:`ascend`), one
    figure after the other in rounds until neither moves (:func:`climb`, at most
    :data:`NOISE_ROUNDS`). Each figure's reported likelihoods are those at the fit and a
    step either side of it, the other figure held at its fit (with what else was tried
    there): how sharply the windows tell it.

    ``tau_s`` and the bias's correlation time are held: the windows' likelihood runs
    along a ridge of nearly equal values where ``σ²/τ`` (the rate at which the drift
    wanders) is constant, so the data do not tell ``σ`` and ``τ`` apart
    (docs/positioning.md).

    Returns:
        The receiver's fit and the gyro's (each not fitted, at the configured figure,
        when its switch, ``gnss.fit_sigma`` or ``gyro.fit_instability``, is false, when
        the plan's control model has no run, when the control has no gyro (``B``), or
        when the windows are fewer than :data:`~rwhonet.nav.coverage.MIN_T2_WINDOWS`).
    """
    nav = params.evaluate.navigation
    sigma0, b0 = float(cfg.gnss.sigma_m), float(cfg.gyro.bias_instability)
    receiver = ReceiverFit(sigma0, float(cfg.gnss.tau_s), float(nav.gnss.sigma_m))
    gyro = InstabilityFit(b0, float(np.radians(nav.gyro.instability_deg_s)))
    mine = [
        ([r for r in runs if r.model == plan["control_model"] and r.control == plan["control"]], w)
        for runs, w in passes
    ]
    mine = [(runs, w) for runs, w in mine if runs]
    log_step = np.log(RECEIVER_STEP)

    def steps(lowest: float, highest: float, at: float) -> tuple[float, float]:
        return (np.log(lowest / at) / log_step, np.log(highest / at) / log_step)

    axes = {}
    if nav.gnss.fit_sigma:
        axes["sigma"] = ({"sigma": 1.0}, {"sigma": steps(*RECEIVER_SIGMA_M, sigma0)})
    if nav.gyro.fit_instability and plan["control"] != "wheels":
        lowest, highest = (float(np.radians(b)) for b in GYRO_INSTABILITY_DEG_S)
        axes["instability"] = ({"instability": 1.0}, {"instability": steps(lowest, highest, b0)})
    if not axes or not mine:
        return receiver, gyro
    # (steps of sigma, steps of B) -> (sigma, B, mean NLL, windows)
    scores: dict[tuple[float, float], tuple[float, float, float, int]] = {}

    def key(x: dict[str, float]) -> tuple[float, float]:
        return round(x["sigma"], 6), round(x["instability"], 6)

    def at(x: dict[str, float]) -> float:
        if key(x) not in scores:
            sigma, b = sigma0 * RECEIVER_STEP ** x["sigma"], b0 * RECEIVER_STEP ** x["instability"]
            tried = replace(gyro, instability_rad_s=b).apply(cfg.with_receiver(sigma))
            windows = _training_windows(frame, params, mine, outages_s, tried)
            scores[key(x)] = (sigma, b, *calibrated_nll(windows))
        return -scores[key(x)][2]  # NaN (no window counted) never wins

    x = {"sigma": 0.0, "instability": 0.0}
    first = at(x)
    n = scores[key(x)][3]
    if not np.isfinite(first) or n < MIN_T2_WINDOWS:
        return replace(receiver, n_windows=n), replace(gyro, n_windows=n)
    x = climb(at, x, axes, NOISE_ROUNDS)
    # what the report shows of each figure: the point reached (a parabola's vertex may
    # not have been scored) and a step either side of it, the other figure held there
    at(x)
    for name, (_, bounds) in axes.items():
        for side in (-1.0, 1.0):
            if bounds[name][0] <= x[name] + side <= bounds[name][1]:
                at({**x, name: x[name] + side})
    sigma, b, _, n = scores[key(x)]
    i_x, j_x = key(x)
    # each figure's settings tried with the other at its fit: value -> mean NLL, without
    # the earlier rounds' points a hair from those kept
    along_sigma = _spaced({i - i_x: (s, v) for (i, j), (s, _, v, _) in scores.items() if j == j_x})
    along_b = _spaced({j - j_x: (g, v) for (i, j), (_, g, v, _) in scores.items() if i == i_x})
    done = {"fitted": True, "n_windows": n}
    if "sigma" in axes:
        receiver = replace(receiver, sigma_m=float(sigma), nll=along_sigma, **done)
    if "instability" in axes:
        gyro = replace(gyro, instability_rad_s=float(b), nll=along_b, **done)
    return receiver, gyro


def _spaced(tried: dict[float, tuple[float, float]]) -> dict[float, float]:
    """``{figure: mean NLL}`` of the settings ``tried`` (keyed by their steps from the fit):
    the fit, a step either side and the likeliest setting scored (the climb stops within
    half a step of the top, so one tried on the way may score a hair better than the
    fit), then the others nearest the fit first, each at least half a step from those
    already taken."""
    best = min(tried, key=lambda o: np.nan_to_num(tried[o][1], nan=np.inf))
    kept = [best]

    def first(o: float) -> bool:  # the fit or a step from it (keys are rounded)
        return min(abs(o), abs(abs(o) - 1.0)) < 1e-5

    for offset in sorted(tried, key=lambda o: (not first(o), abs(o), o)):
        if first(offset) and offset not in kept or all(abs(offset - k) >= 0.5 for k in kept):
            kept.append(offset)
    return {tried[k][0]: tried[k][1] for k in sorted(kept)}


def fix_score(
    frame: pd.DataFrame,
    params: Params,
    runs: list[Odometry],
    rows: np.ndarray,
    cfg: NavConfig,
    role: str = k.TARGET_TRAIN,
) -> tuple[float, int]:
    """The fixes' log score of the filter's runs over one role's segments, at ``rows``.

    Each run's filter passes over every segment of ``role`` with GNSS throughout (no
    outage); each second's fix is scored by its density under the filter's one-step
    prediction of it (:attr:`rwhonet.nav.NavTrack.fix_logpdf`; 0 where the gate
    refuses it), and the scores of the frame's ``rows`` are summed.

    Args:
        frame: the samples (``role``'s drives among them).
        params: as :func:`filter_windows`.
        runs: the runs (one control).
        rows: the frame rows whose fixes are scored.
        cfg: the filter's settings.
        role: whose drives.

    Returns:
        ``(score summed over the rows, mean over the runs, nats; seconds scored per run)``.
    """
    segs = nav_segments(frame, params, role)
    if not len(segs.first_row) or not runs:
        return float("nan"), 0
    track = segment_pass(segs, runs, cfg)
    tile = (len(runs), 1)
    chosen = np.zeros(len(frame))
    chosen[np.asarray(rows, np.int64)] = 1.0
    scored = np.tile(segs.gather(chosen) > 0.5, tile)
    logpdf = np.where(scored, track.fix_logpdf, 0.0)
    return float(logpdf.sum()) / len(runs), int(np.count_nonzero(logpdf)) // len(runs)


@dataclass(frozen=True)
class GeometryFit:
    """Where the GNSS antenna sits on the car and how late its gyro reads, as fitted.

    Attributes:
        antenna_m: the antenna ahead of and left of the rear-axle centre, m.
        latency_s: how late the gyro's channel reads the turn against the fixes, s.
        configured_antenna_m: ``evaluate.navigation.antenna_m``.
        configured_latency_s: ``evaluate.navigation.gyro.latency_s``.
        fitted: False: not asked for (``fit_geometry: false``) or nothing to fit on.
        score: the training fixes' log score at the fit, nats (:func:`fix_score`).
        configured_score: at the configured figures.
        n_seconds: the training seconds scored (per run).
        tried: how many settings were scored.
    """

    antenna_m: tuple[float, float]
    latency_s: float
    configured_antenna_m: tuple[float, float]
    configured_latency_s: float
    fitted: bool = False
    score: float = float("nan")
    configured_score: float = float("nan")
    n_seconds: int = 0
    tried: int = 0

    def apply(self, cfg: NavConfig) -> NavConfig:
        """``cfg`` with this antenna and gyro latency."""
        return replace(
            cfg,
            antenna_m=(float(self.antenna_m[0]), float(self.antenna_m[1])),
            gyro=replace(cfg.gyro, latency_s=float(self.latency_s)),
        )

    def as_dict(self) -> dict:
        """eval.json's ``position_controls.geometry``."""
        return {
            "antenna_m": [round(float(v), 3) for v in self.antenna_m],
            "gyro_latency_s": round(float(self.latency_s), 4),
            "configured_antenna_m": [float(v) for v in self.configured_antenna_m],
            "configured_gyro_latency_s": float(self.configured_latency_s),
            "fitted": self.fitted,
            "score": round(self.score, 2) if np.isfinite(self.score) else None,
            "configured_score": (
                round(self.configured_score, 2) if np.isfinite(self.configured_score) else None
            ),
            "n_seconds": self.n_seconds,
            "tried": self.tried,
        }


# The geometry's fit: (step, lowest, highest) of the antenna ahead and left, m, and the
# gyro's latency, s; each searched from the configured value in these steps.
ANTENNA_AHEAD_M = (0.25, -2.0, 5.0)
ANTENNA_LEFT_M = (0.25, -2.0, 2.0)
GYRO_LATENCY_S = (0.025, 0.0, 0.5)
GEOMETRY_ROUNDS = 6  # rounds over the axes at most
RIDGE_MIN_SPEED_M_S = 2.0  # seconds slower than this leave the ridge's direction alone


def climb(
    score: Callable[[dict[str, float]], float],
    start: dict[str, float],
    axes: dict[str, tuple[dict[str, float], dict[str, tuple[float, float]]]],
    rounds: int,
) -> dict[str, float]:
    """Coordinate ascent over search directions, each by :func:`ascend`, in rounds.

    Args:
        score: the score of a point (to maximise).
        start: the point to start from (name -> value).
        axes: direction name -> (the step, name -> change of each value a step makes; the
            range, name -> (lowest, highest) of the values it moves), in the order tried.
        rounds: rounds over the directions at most (the ascent ends when none moves).

    Returns:
        The point reached.
    """
    x = dict(start)
    for _ in range(rounds):
        moved = False
        for step, bounds in axes.values():
            x0 = dict(x)
            lo, hi = -np.inf, np.inf  # the steps that keep every value in its range
            for name, d in step.items():
                a, b = ((bounds[name][0] - x0[name]) / d, (bounds[name][1] - x0[name]) / d)
                lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
            low, high = int(np.ceil(lo - 1e-9)), int(np.floor(hi + 1e-9))

            def along(i: float, x0: dict = x0, step: dict = step) -> float:
                return score({**x0, **{n: x0[n] + i * d for n, d in step.items()}})

            i = ascend(along, min(low, 0), max(high, 0))
            x = {**x0, **{n: x0[n] + i * d for n, d in step.items()}}
            moved |= abs(i) > 0.5
        if not moved:
            break
    return x


def ridge_s_per_m(frame: pd.DataFrame, rows: np.ndarray) -> float | None:
    """How much gyro latency a metre of antenna lever arm ahead stands in for, s/m.

    In a bend at yaw rate ``r`` and speed ``v`` a lever arm ``a`` ahead of the rear axle
    turns the fixes' course ahead of the car's heading by ``a r / v``, and a gyro ``L``
    late leaves the heading behind by ``L r``: what the fixes tell is about
    ``r (a / v + L)``, so the score has a ridge along which ``a`` and ``L`` trade off.
    Over seconds whose misfit counts by its square, the latency that best makes up for
    a change ``da`` of the lever arm is ``-da Σ r²/v / Σ r²``: this ratio, from the
    gyro's yaw and the GNSS distance of ``rows`` (seconds of at least
    :data:`RIDGE_MIN_SPEED_M_S`).

    Args:
        frame: the samples (the GNSS distance and the gyro's yaw of each second).
        rows: the seconds the fit scores.

    Returns:
        The ratio, s/m; None without a turning second with a yaw rate.
    """
    v = frame[k.DISP_GNSS_M].to_numpy(np.float64)[rows]
    r = frame[k.GYRO_YAW_RAD].to_numpy(np.float64)[rows] if k.GYRO_YAW_RAD in frame else v * np.nan
    ok = np.isfinite(v) & np.isfinite(r) & (v >= RIDGE_MIN_SPEED_M_S)
    weight = float(np.sum(r[ok] ** 2))
    if weight <= 0.0:
        return None
    return float(np.sum(r[ok] ** 2 / v[ok])) / weight


def ascend(score: Callable[[int], float], lo: int, hi: int) -> float:
    """The integer step in ``[lo, hi]`` where ``score`` peaks, from 0, refined by a parabola.

    Steps from 0 towards the rising side until the score falls again (one side only:
    where the first side rises the other is not searched); the answer is the best
    step, moved to the vertex of the parabola through it and its two neighbours
    (at most half a step) where it lies inside the range and the curve is concave.

    Args:
        score: the score of a step (to maximise; NaN never wins).
        lo: the lowest step allowed (``≤ 0``).
        hi: the highest (``≥ 0``).
    """
    best = 0
    for direction in (1, -1):
        step = best + direction
        while lo <= step <= hi and score(step) > score(best):
            best, step = step, step + direction
        if best != 0:
            break  # a rise found: the other side falls
    if lo < best < hi:
        f0, f1, f2 = score(best - 1), score(best), score(best + 1)
        curve = f0 - 2.0 * f1 + f2
        if curve < 0:
            return best + float(np.clip(0.5 * (f0 - f2) / curve, -0.5, 0.5))
    return float(best)


def fit_geometry(
    frame: pd.DataFrame | None,
    params: Params,
    passes: list[tuple[list[Odometry], dict[int, np.ndarray]]],
    plan: dict,
    cfg: NavConfig,
) -> GeometryFit:
    """The antenna's place and the gyro's latency that best predict the training drives' fixes.

    Neither is on a data sheet a user has: where the receiver's antenna sits on the
    car moves each fix by the lever arm as the car turns, and the gyro's channel
    reads the turn late (the sensor's low-pass, the CAN cycle, the logger's
    stamping), which leaves the heading behind the car's in every bend. With either
    wrong the filter's heading disagrees with the fixes' track in bends: in the
    simulated worlds, whose cars carry their antenna 0.95-1.25 m ahead of the rear
    axle and a gyro 30-100 ms late, the fixes' log score rises by hundreds of
    nats at the cars' own figures (docs/positioning.md). So they are fitted on the
    target training drives (never a test drive), by the fixes' log score of the
    control model's run on its first seed (:func:`fix_score`, the seconds of the
    training windows; the geometry is the car's, not the model's): the antenna
    ahead, the latency (with a gyro), the antenna left, each by :func:`ascend` from
    the value so far in the steps of :data:`ANTENNA_AHEAD_M`, :data:`GYRO_LATENCY_S`,
    :data:`ANTENNA_LEFT_M`, and then along the ridge where the lever arm ahead and
    the latency trade off (:func:`ridge_s_per_m`: both put the heading behind the
    track in a bend, one by ``a/v``, the other by ``L``, and only the drives' range
    of speeds tells them apart), in rounds until none moves (:func:`climb`, at most
    :data:`GEOMETRY_ROUNDS`). Without the ridge's direction the ascent stopped on
    the ridge short of its top: on a coarse gyro 0.1 s late, from (0 m, 0 s) it
    reached 1.75 m ahead and 16 ms, 40 nats below the score a start at the car's own
    figures climbed to (docs/positioning.md).

    Args:
        frame: the target training drives' samples (None: none).
        params: ``evaluate.navigation.fit_geometry``; as :func:`filter_windows`.
        passes: the training runs and windows (:func:`training_passes`).
        plan: :func:`rwhonet.evaluation.study.navigation_plan`'s ``control_model``
            and ``control``.
        cfg: the filter's settings (their antenna and latency the starting point).

    Returns:
        The fit (the configured figures, not fitted, when ``fit_geometry`` is false or
        the control model has no training run or window).
    """
    out = GeometryFit(cfg.antenna_m, cfg.gyro.latency_s, cfg.antenna_m, cfg.gyro.latency_s)
    mine = [
        ([r for r in runs if r.model == plan["control_model"] and r.control == plan["control"]], w)
        for runs, w in passes
    ]
    mine = [(runs, w) for runs, w in mine if runs and w]
    if not params.evaluate.navigation.fit_geometry or frame is None or not mine:
        return out
    runs, windows = mine[0]
    runs = runs[:1]  # the car's geometry, not the model's: one seed's distances tell it
    rows = np.unique(windows[min(windows)])
    if not rows.size:
        return out
    x = {"ahead": cfg.antenna_m[0], "left": cfg.antenna_m[1], "latency": cfg.gyro.latency_s}
    scores: dict[tuple[float, float, float], tuple[float, int]] = {}

    def at(values: dict[str, float]) -> float:
        key = (round(values["ahead"], 6), round(values["left"], 6), round(values["latency"], 6))
        if key not in scores:
            fit = replace(out, antenna_m=(key[0], key[1]), latency_s=key[2])
            scores[key] = fix_score(frame, params, runs, rows, fit.apply(cfg))
        return scores[key][0]

    bounds = {
        "ahead": ANTENNA_AHEAD_M[1:],
        "left": ANTENNA_LEFT_M[1:],
        "latency": GYRO_LATENCY_S[1:],
    }
    axes = {
        "ahead": ({"ahead": ANTENNA_AHEAD_M[0]}, bounds),
        "latency": ({"latency": GYRO_LATENCY_S[0]}, bounds),
        "left": ({"left": ANTENNA_LEFT_M[0]}, bounds),
    }
    ridge = ridge_s_per_m(frame, rows)
    if ridge is not None:  # along the ridge: the lever arm ahead traded for the latency
        step = ANTENNA_AHEAD_M[0]
        axes["ridge"] = ({"ahead": step, "latency": -step * ridge}, bounds)
    if plan["control"] == "wheels" or ridge is None:  # no gyro: no latency to fit
        axes = {n: a for n, a in axes.items() if n in ("ahead", "left")}
    configured = at(x)
    x = climb(at, x, axes, GEOMETRY_ROUNDS)
    best = at(x)
    return replace(
        out,
        antenna_m=(x["ahead"], x["left"]),
        latency_s=x["latency"],
        fitted=True,
        score=best,
        configured_score=configured,
        n_seconds=max(n for _, n in scores.values()),
        tried=len(scores),
    )


def calibrate_on_training(
    frame: pd.DataFrame,
    params: Params,
    passes: list[tuple[list[Odometry], dict[int, np.ndarray]]],
    outages_s: list[int],
    cfg: NavConfig,
) -> tuple[dict[tuple, Calibration2D], pd.DataFrame]:
    """The filter's runs on the target training drives, and each run's 2D calibration.

    Args:
        frame: the target training drives' samples (``FitEvidence.frame``).
        params: as :func:`filter_windows`.
        passes: the runs and their windows (:func:`training_passes`).
        outages_s: the outage lengths.
        cfg: the filter's settings (with the receiver drift and the gyro's bias instability
            :func:`fit_noise` chose).

    Returns:
        ``({(model, seed, control): calibration}, the training windows' ends)``.
    """
    windows_2d = _training_windows(frame, params, passes, outages_s, cfg)
    return calibrate_2d(windows_2d), windows_2d
