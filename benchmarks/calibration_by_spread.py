"""Would a calibration whose scale follows the filter's own spread hold the test windows better?

The 2D calibration (:func:`rwhonet.evaluation.position.calibrate_2d`) scales the
filter's end-of-outage covariance by one ``c`` per outage length, fitted on the target
training drives' windows. docs/positioning.md section 7 finds the filter's covariance
growing faster with speed than its errors do, so that one scale fitted on slow training
windows is too wide for faster test windows. This script tries the obvious remedy,
fitted on the training windows only: each window's scale ``c_L · (s / 10 m)^γ``, ``s``
the filter's own RMS spread ``sqrt(tr Σ / 2)`` at the window's end (known in the field,
unlike the truth's speed), ``γ`` one exponent per run shared by every length, the
tails ``ν`` held at the pooled fit's (:func:`rwhonet.nav.coverage.fit_t2`). It prints,
per run of the control's distance model and the WPM, fused, and outage length: the
training log-likelihood ``γ`` gains (nats, summed over the run's windows), ``γ``, and
the share of test windows inside the 1σ / 2σ regions with ``γ = 0`` and with ``γ``
fitted. A diagnostic, not the pipeline's calibration: it holds ``ν`` as pooled where
``calibrate_2d`` may give a length its own tails.

Run in a built world's folder (``build/worlds/<world>``, or the workspace after
``make run``); it re-runs the evaluate stage's study in memory (minutes) and writes
nothing.

Usage: python benchmarks/calibration_by_spread.py
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import minimize

import rwhonet.evaluation.study as study
import rwhonet.stages.evaluate as stage
from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation.position import _errors_and_covs
from rwhonet.evaluation.result import Evaluation
from rwhonet.evaluation.selection import choose, recommend, selection_scores
from rwhonet.nav.coverage import SIGMA_CONTENT, fit_t2, mahalanobis_sq, t2_quantile
from rwhonet.runner import declared_params

SPREAD_REF_M = 10.0  # s / 10 m: where γ leaves c_L as it is


def windows_of_the_study() -> tuple[pd.DataFrame, pd.DataFrame, str]:
    """The evaluate stage's study, run in memory: (training, test windows; control model)."""
    kept: dict = {}
    fitted = study.calibrate_on_training

    def keep(*args, **kwargs):
        cals, windows = fitted(*args, **kwargs)
        kept["train"] = windows
        return cals, windows

    study.calibrate_on_training = keep
    try:
        result = run_the_study()
    finally:
        study.calibrate_on_training = fitted
    return kept["train"], result.position_windows, result.position_plan["control_model"]


def run_the_study() -> Evaluation:
    """The evaluate stage's study on this folder's drives and models, in memory."""
    params = load_params(paths.PARAMS, only=declared_params("evaluate"), reader="evaluate")
    selection = stage.read_selection(params, paths.SAMPLES, paths.MODELS)
    scores = selection_scores(selection, params)
    choice = choose(params, recommend(scores, params))
    frame, preds = stage.collect_predictions(params, paths.SAMPLES, paths.MODELS)
    evidence = stage.fit_evidence(params, selection, paths.MODELS)
    return study.evaluate(params, choice, frame, preds, scores, evidence)


def radii(windows: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Counted windows' squared Mahalanobis radii, RMS spreads (m) and outage lengths."""
    w = windows[windows["counted"].astype(bool)]
    err, cov = _errors_and_covs(w)
    spread = np.sqrt((cov[:, 0, 0] + cov[:, 1, 1]) / 2.0)
    return mahalanobis_sq(err, cov), spread, w["outage_s"].to_numpy()


def fit(d2: np.ndarray, spread: np.ndarray, length: np.ndarray, nu: float, with_gamma: bool):
    """``ln c_L`` per length (and ``γ``) by maximum likelihood; (parameters, summed NLL)."""
    lengths = np.unique(length)
    ls = np.log(spread / SPREAD_REF_M)

    def nll(theta: np.ndarray) -> float:
        gamma = theta[-1] if with_gamma else 0.0
        total = 0.0
        for i, L in enumerate(lengths):
            m = length == L
            c = np.exp(theta[i] + gamma * ls[m])
            r = d2[m]
            if np.isfinite(nu):
                total += np.sum(np.log(c) + (0.5 * nu + 1.0) * np.log1p(r / (c * nu)))
            else:
                total += np.sum(np.log(c) + 0.5 * r / c)
        return total

    x0 = [np.log(np.mean(d2[length == L]) / 2.0) for L in lengths] + ([0.0] if with_gamma else [])
    bounds = [(-30.0, 30.0)] * len(lengths) + ([(-3.0, 3.0)] if with_gamma else [])
    res = minimize(nll, np.array(x0), method="L-BFGS-B", bounds=bounds)
    return (
        dict(zip(lengths, res.x[: len(lengths)], strict=True)),
        (res.x[-1] if with_gamma else 0.0),
        res.fun,
    )


def main() -> None:
    train, test, control_model = windows_of_the_study()
    rows = []
    keys = ["model", "seed", "control"]
    for (model, seed, control), g in train.groupby(keys, dropna=False, sort=False):
        if control != "fused" or model not in (control_model, "WPM"):
            continue
        d2, spread, length = radii(g)
        _, nu, n = fit_t2(d2)
        if n < 20:
            continue
        ln_c0, _, nll0 = fit(d2, spread, length, nu, with_gamma=False)
        ln_c1, gamma, nll1 = fit(d2, spread, length, nu, with_gamma=True)
        same = (test["model"] == model) & (test["control"] == control)
        same &= test["seed"].isna() if pd.isna(seed) else test["seed"] == seed
        d2_t, spread_t, length_t = radii(test[same])
        for L in ln_c0:
            m = length_t == L
            c0 = np.exp(ln_c0[L])
            c1 = np.exp(ln_c1[L] + gamma * np.log(spread_t[m] / SPREAD_REF_M))
            row = {"model": model, "seed": seed, "outage_s": int(L), "gain_nats": nll0 - nll1}
            row["gamma"] = gamma
            for p, name in zip(SIGMA_CONTENT, ("1σ", "2σ"), strict=True):
                row[f"{name} c"] = 100 * np.mean(d2_t[m] <= t2_quantile(p, c0, nu))
                row[f"{name} c·s^γ"] = 100 * np.mean(d2_t[m] <= t2_quantile(p, c1, nu))
            row["n_test"] = int(m.sum())
            rows.append(row)
    table = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print(table.round(2).to_string(index=False))
    print("\nmeans over seeds (% of test windows inside; the bounds: 68 ± 5 and 95 ± 3):")
    means = table.drop(columns="seed").groupby(["model", "outage_s"]).mean(numeric_only=True)
    print(means.round(1).to_string())


if __name__ == "__main__":
    main()
