"""What m seconds of GNSS can tell about a car: the physical limit of recalibration from m s.

Recalibrating on a drive's first m seconds faces three errors no recipe removes:

1. identifiability: m seconds of GNSS, whose error is smooth and correlated
   over tens of seconds (docs/simulator.md "Label noise"), fix the car's rear
   radius only so well; the per-second GNSS error does not average down within
   its correlation time;
2. non-stationarity: the first m seconds are not the rest of the drive (tyres
   warm up over minutes, pressure leaks, the car pulls away from a stop);
3. the label's own noise, which every model's CRSE carries in full (CRSE sums
   |e| per second, and e includes the GNSS error of each second).

For the WPM alone (the one-parameter model every recipe here ends up close to),
per target test drive, m and the longest outage, scored on the evaluation's own
windows (:func:`rwhonet.evaluation.windows.outage_windows`):

- ``first``: rear radii fitted on the drive's first m s (the WPM-m@m control);
- ``any``: fitted on each non-overlapping m-s block of the drive, anywhere in
  it; the mean CRSE over blocks, and the spread of the fitted radius over them
  (``radius_sd_pct``, the identifiability from m s plus within-drive change);
- ``whole``: fitted on every second of the drive, the scored ones included:
  not a usable model, the best a single radius per drive can do. What is left
  is the label noise and what a constant radius cannot follow.

So ``first − any`` is what the start of a drive costs (non-stationarity),
``any − whole`` what m seconds cost (identifiability), and ``whole`` is the
floor for any recipe that amounts to a radius. The estimator is
:func:`rwhonet.features.calibration.refit_radii`, the one WPM-m and ``radius+G`` use.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.evaluation.windows import outage_windows
from rwhonet.features.calibration import refit_radii

LIMIT_COLUMNS = ("m", "first", "any", "whole", "radius_sd_pct", "n_blocks", "n_windows")


def _crse(
    gnss: np.ndarray, a_rl: np.ndarray, a_rr: np.ndarray, windows: np.ndarray, radii: np.ndarray
) -> np.ndarray:
    """Mean window CRSE of the WPM for each row of ``radii`` ((B, 2) rear-left, rear-right)."""
    g, left, right = gnss[windows], a_rl[windows], a_rr[windows]  # (W, L)
    e = g[None] - 0.5 * (
        radii[:, 0, None, None] * left[None] + radii[:, 1, None, None] * right[None]
    )
    return np.abs(e).sum(axis=2).mean(axis=1)


def radius_limits(frame: pd.DataFrame, params: Params) -> pd.DataFrame:
    """The ``first``/``any``/``whole`` WPM CRSE per m on the target test drives (module docstring).

    Args:
        frame: the test drives' samples (every role; only ``target_test`` is used).
        params: ``adapt.m_grid``, ``evaluate.outages_s``, ``label.calibration_min_speed_m_s``.

    Returns:
        One row per m: :data:`LIMIT_COLUMNS` (CRSE in metres at the longest
        outage, window-weighted over drives; ``radius_sd_pct`` the median over
        drives of the fitted mean rear radius' standard deviation over blocks,
        in % of its mean). Empty when there is no target test drive.
    """
    L = max(params.evaluate.outages_s)
    grid = params.adapt.m_grid
    v_min = params.label.calibration_min_speed_m_s
    target = frame[frame["role"] == k.TARGET_TEST]
    acc = {m: {"first": 0.0, "any": 0.0, "whole": 0.0, "sd": [], "blocks": 0} for m in grid}
    n_windows = 0
    for _, drive in target.groupby("drive", sort=False):
        drive = drive.reset_index(drop=True)
        windows = outage_windows(drive, grid, L)
        if not len(windows):
            continue
        gnss = drive[k.DISP_GNSS_M].to_numpy(np.float64)
        a_rl = drive[k.ANGLE_RL_RAD].to_numpy(np.float64)
        a_rr = drive[k.ANGLE_RR_RAD].to_numpy(np.float64)
        label = drive[k.LABEL_M].to_numpy(np.float64)
        rank = drive["k"].to_numpy()
        w = len(windows)
        n_windows += w
        whole = refit_radii(gnss, a_rl, a_rr, v_min)
        whole_crse = _crse(gnss, a_rl, a_rr, windows, np.array([whole]))[0] if whole else np.nan
        for m in grid:
            first = refit_radii(gnss[rank < m], a_rl[rank < m], a_rr[rank < m], v_min)
            blocks = [
                refit_radii(gnss[b], a_rl[b], a_rr[b], v_min)
                for b in np.split(np.arange(len(drive)), range(m, len(drive), m))
                if len(b) == m
            ]
            fitted = np.array([b for b in blocks if b is not None])
            a = acc[m]
            a["whole"] += w * whole_crse
            # no moving second in the first m s: the source calibration stays (as in WPM-m)
            a["first"] += w * (
                _crse(gnss, a_rl, a_rr, windows, np.array([first]))[0]
                if first
                else np.abs(label[windows]).sum(axis=1).mean()
            )
            a["any"] += w * _crse(gnss, a_rl, a_rr, windows, fitted).mean()
            mean_r = fitted.mean(axis=1)
            a["sd"].append(100 * mean_r.std(ddof=1) / mean_r.mean())
            a["blocks"] += len(fitted)
    if not n_windows:
        return pd.DataFrame(columns=list(LIMIT_COLUMNS))
    return pd.DataFrame(
        [
            {
                "m": m,
                "first": a["first"] / n_windows,
                "any": a["any"] / n_windows,
                "whole": a["whole"] / n_windows,
                "radius_sd_pct": float(np.median(a["sd"])),
                "n_blocks": a["blocks"],
                "n_windows": n_windows,
            }
            for m, a in acc.items()
        ]
    )
