"""One filter run per outage window: calibrate on the seconds before it, dead-reckon through it.

What the evaluation calls with arrays: per-second data of a drive segment
(distances of any odometry model and their variances, wheel and gyro yaw,
fixes in a local frame) and the windows' first seconds; back come, per
window, the end-of-outage position, its 2x2 covariance and the error against
the GNSS fix that ends the window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rwhonet.nav.filter import Control, NavConfig, NavInputs, run

PER_SECOND = ("dist_m", "dist_var_m2", "wheel_yaw_rad", "gyro_yaw_rad")


@dataclass(frozen=True)
class OutageResult:
    """Each window's end of outage.

    Attributes:
        end_m: (W, 2) where the filter puts the antenna's fix at the end (east, north), m.
        cov_m2: (W, 2, 2) that estimate's covariance (state and the fix's white noise), m².
        truth_m: (W, 2) the GNSS fix that ends the window, m.
        error_m: (W, 2) ``end_m − truth_m``, m.
        horizontal_m: (W,) its length, m.
        distance_m: (W,) how far the fixes went over the window (sum of chords), m.
        state: (W, S) the filter's state at the end.
        state_cov: (W, S, S) its covariance.
        calibrated: (W,) the filter started before the outage (else the rest is NaN).
    """

    end_m: np.ndarray
    cov_m2: np.ndarray
    truth_m: np.ndarray
    error_m: np.ndarray
    horizontal_m: np.ndarray
    distance_m: np.ndarray
    state: np.ndarray
    state_cov: np.ndarray
    calibrated: np.ndarray


def run_outage(
    inputs: NavInputs,
    outage_start: int,
    config: NavConfig | None = None,
    control: Control = "fused",
) -> OutageResult:
    """Filter each window with GNSS up to ``outage_start``, then without it to the end.

    Args:
        inputs: (W, n) windows: seconds ``[0, outage_start)`` calibrate, seconds
            ``[outage_start, n)`` are the outage; their fixes (columns
            ``outage_start + 1 .. n``) are withheld from the filter and the last
            is the truth.
        outage_start: the outage's first second, ≥ 1.
        config: the filter's settings.
        control: ``wheels``, ``gyro`` or ``fused``.

    Returns:
        The windows' ends.

    Raises:
        ValueError: if the outage is empty or has no second before it.
    """
    n = inputs.dist_m.shape[1]
    if not 1 <= outage_start < n:
        raise ValueError(f"outage_start must be in [1, {n - 1}], got {outage_start}")
    fe, fn = np.array(inputs.fix_e_m, np.float64), np.array(inputs.fix_n_m, np.float64)
    truth = np.stack([fe[:, -1], fn[:, -1]], axis=1)
    seg_e, seg_n = fe[:, outage_start:], fn[:, outage_start:]
    distance = np.nansum(np.hypot(np.diff(seg_e, axis=1), np.diff(seg_n, axis=1)), axis=1)
    fe[:, outage_start + 1 :] = np.nan
    fn[:, outage_start + 1 :] = np.nan
    masked = NavInputs(
        inputs.dist_m,
        inputs.dist_var_m2,
        inputs.wheel_yaw_rad,
        inputs.gyro_yaw_rad,
        fe,
        fn,
        inputs.backwards,
        inputs.gyro_yaw_before_rad,
    )
    track = run(masked, config, control)
    calibrated = track.started[:, outage_start - 1]
    end = track.fix_pred[:, -1]
    error = end - truth
    return OutageResult(
        end_m=end,
        cov_m2=track.fix_cov[:, -1],
        truth_m=truth,
        error_m=error,
        horizontal_m=np.hypot(error[:, 0], error[:, 1]),
        distance_m=distance,
        state=track.x[:, -1],
        state_cov=np.where(calibrated[:, None, None], track.last_cov, np.nan),
        calibrated=calibrated,
    )


def window_inputs(
    per_second: dict[str, np.ndarray],
    fix_e_m: np.ndarray,
    fix_n_m: np.ndarray,
    starts: np.ndarray,
    calibration_s: int,
    outage_s: int,
) -> NavInputs:
    """Cut a segment's per-second arrays into windows of calibration + outage seconds.

    Args:
        per_second: the segment's (n,) arrays named as :data:`PER_SECOND` (a
            missing sensor: an all-NaN array) and, where the log says it, ``backwards``
            (bool: seconds driven backwards, :class:`~rwhonet.nav.filter.NavInputs`).
        fix_e_m: (n + 1,) its fixes, east, m (the fix before second 0 first).
        fix_n_m: (n + 1,) north, m.
        starts: (W,) each outage's first second, each ≥ ``calibration_s`` and
            ≤ ``n − outage_s``.
        calibration_s: seconds before the outage the filter calibrates on.
        outage_s: the outage's length, s.

    Returns:
        Inputs of shape (W, calibration_s + outage_s); outage second 0 is column
        ``calibration_s``.

    Raises:
        ValueError: when a window does not fit in the segment.
    """
    starts = np.asarray(starts, np.int64)
    n = len(per_second["dist_m"])
    if starts.size and (starts.min() < calibration_s or starts.max() > n - outage_s):
        raise ValueError(
            f"windows must start in [{calibration_s}, {n - outage_s}] of {n} seconds, "
            f"got {starts.min()}..{starts.max()}"
        )
    rows = starts[:, None] - calibration_s + np.arange(calibration_s + outage_s)
    fix_rows = starts[:, None] - calibration_s + np.arange(calibration_s + outage_s + 1)
    arrays = {key: np.asarray(per_second[key], np.float64)[rows] for key in PER_SECOND}
    back = per_second.get("backwards")
    gyro = np.r_[np.nan, np.asarray(per_second["gyro_yaw_rad"], np.float64)]
    return NavInputs(
        fix_e_m=np.asarray(fix_e_m, np.float64)[fix_rows],
        fix_n_m=np.asarray(fix_n_m, np.float64)[fix_rows],
        backwards=None if back is None else np.asarray(back, bool)[rows],
        gyro_yaw_before_rad=gyro[rows[:, 0]],  # the second before each window's first
        **arrays,
    )
