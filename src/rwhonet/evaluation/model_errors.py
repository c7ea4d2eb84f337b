"""Every model's per-second error on the test drives, and the WPM-m control it needs.

e = label − prediction for a network (the label is GNSS − WPM, paper Eq. 11),
e = GNSS − WPM for a WPM alone: the same quantity a window's CRSE and CTE sum
(:mod:`rwhonet.evaluation.scoring`).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import CONTINUOUS_RECIPES, alt_wpm, recipe_model
from rwhonet.evaluation.names import recipe_models
from rwhonet.evaluation.scoring import Errors
from rwhonet.features.calibration import refit_radii
from rwhonet.features.wpm import wpm_displacement_m


def refit_wpm(frame: pd.DataFrame, params: Params) -> tuple[dict[int, np.ndarray], pd.DataFrame]:
    """The WPM-m control: each drive's rear radii refitted on its first m seconds, per m.

    Returns:
        ``({m: WPM displacement per row}, refits)``; ``refits`` has one row per
        drive and m with the radii, or NaN (and the source calibration kept) when
        the first m seconds never move faster than ``label.calibration_min_speed_m_s``.
    """
    wpm = frame[k.DISP_WPM_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    a_rl = frame[k.ANGLE_RL_RAD].to_numpy(np.float64)
    a_rr = frame[k.ANGLE_RR_RAD].to_numpy(np.float64)
    drive = frame["drive"].to_numpy()
    rank = frame["k"].to_numpy()
    out, rows = {}, []
    for m in params.adapt.m_grid:
        disp = wpm.copy()
        for d in dict.fromkeys(drive):
            on = drive == d
            first = on & (rank < m)
            radii = refit_radii(
                gnss[first], a_rl[first], a_rr[first], params.label.calibration_min_speed_m_s
            )
            if radii is not None:
                disp[on] = wpm_displacement_m(a_rl[on], a_rr[on], *radii)
            r_rl, r_rr = radii if radii is not None else (math.nan, math.nan)
            rows.append({"drive": d, "m": m, "r_rl_m": r_rl, "r_rr_m": r_rr})
        out[m] = disp
    return out, pd.DataFrame(rows)


def model_errors(
    frame: pd.DataFrame, pred: pd.DataFrame, wpm_m: dict[int, np.ndarray], params: Params
) -> Errors:
    """Per-second error of every model for one seed (NaN where a model does not apply).

    ``R[continuous]`` has one error array per outage length (its predictions
    depend on which window a second is in); every other model one array.
    Aliases (``R``, ``R@m``) are left out: they are copies of recipe models.
    """
    label = frame[k.LABEL_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    alt, alt_col = alt_wpm(params.label.wpm_mode)
    errors: Errors = {
        "WPM": label,
        alt: gnss - frame[alt_col].to_numpy(np.float64),
        "G": label - pred["G"].to_numpy(),
        "S": label - pred["S"].to_numpy(),
    }
    for model in recipe_models(params):
        if model in {recipe_model(r, None) for r in CONTINUOUS_RECIPES}:
            errors[model] = {
                L: label - pred[f"{model}/{L}s"].to_numpy() for L in params.evaluate.outages_s
            }
        else:
            errors[model] = label - pred[model].to_numpy()
    for m in params.adapt.m_grid:
        errors[f"WPM-m@{m}"] = gnss - wpm_m[m]
    return errors
