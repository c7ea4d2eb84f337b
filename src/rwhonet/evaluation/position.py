"""2D position error at the end of each outage window, for the WPM and each model.

Beyond the paper, whose metrics (CRSE, CTE) are distances travelled. For every
target test window of every outage length (the same windows as CRSE/CTE), the
car is dead-reckoned from the GNSS fix before the window
(:mod:`rwhonet.features.deadreckoning`): heading from the rear wheels, fitted
to the GNSS course over ``evaluate.dead_reckoning.calibration_s`` seconds
before the window (0: all of its segment before it); each second's distance is
the model's (the WPM's, or the WPM corrected by the model: GNSS displacement
minus the model's error). The
error is the horizontal distance between where that ends and the GNSS fix at
the window's end. The heading is the same for every model, so the differences
between models are their distance errors seen in 2D.

A window needs the second before it in its segment (its start fix) and a GNSS
course in its calibration stretch; windows without are left out and counted.
The row :data:`HEADING_ONLY` dead-reckons the GNSS's own distances: its error is
the heading's alone, the floor under every distance model.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.evaluation.windows import outage_windows
from rwhonet.features.deadreckoning import course_rad, dead_reckon, fit_heading, wheel_yaw_rad
from rwhonet.geo.local import offsets_m

HEADING_ONLY = "heading only (GNSS distance)"


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
    vehicle = params.data.roles[k.TARGET_TEST].vehicle
    r = params.nominal_radius_m(vehicle)
    yaw_all = wheel_yaw_rad(
        frame[k.ANGLE_RL_RAD].to_numpy(np.float64),
        frame[k.ANGLE_RR_RAD].to_numpy(np.float64),
        r,
        r,
        params.track_rear_m(vehicle),
    )
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
