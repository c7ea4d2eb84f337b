"""Would one 2D calibration scale per axis of the predicted ellipse hold the test windows better?

The 2D calibration (:func:`rwhonet.evaluation.position.calibrate_2d`) scales the filter's
end-of-outage covariance ``Σ`` by one ``c`` per outage length, fitted on the target
training drives' windows. docs/positioning.md section 7 found the errors filling the
ellipse's two axes in different shares. This script fits, per run of the control's
distance model (fused) and outage length, on the training windows only, a normal with
one scale (``c Σ``) and with one per principal axis of each window's ``Σ``
(``V diag(c_minor λ_minor, c_major λ_major) Vᵀ``), each by maximum likelihood (the mean
squared standardised error along the axis), and prints: the training log-likelihood the
second scale gains less Akaike's 1 nat; the test windows' share inside the 1σ / 2σ
regions with one scale and with two; and how much of its training scale each axis's
test errors fill (1: as on the training drives). Normals only, where ``calibrate_2d``
may fit Student t tails: a diagnostic, not the pipeline's calibration.

Run in a built world's folder (``build/worlds/<world>``, or the workspace after
``make run``); it re-runs the evaluate stage's study in memory (minutes) and writes
nothing.

Usage: python benchmarks/calibration_by_axis.py
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from calibration_by_spread import windows_of_the_study
from rwhonet.evaluation.position import _errors_and_covs
from rwhonet.nav.coverage import SIGMA_CONTENT, chi2_2dof_quantile

MIN_WINDOWS = 20


def along_axes(windows: pd.DataFrame) -> np.ndarray:
    """Counted windows' squared errors along the minor and major axis over the axis's
    variance: (n, 2)."""
    err, cov = _errors_and_covs(windows)
    lam, vec = np.linalg.eigh(cov)  # ascending: minor, major
    return np.einsum("nij,ni->nj", vec, err) ** 2 / lam


def compare(train: np.ndarray, test: np.ndarray) -> dict:
    """One scale against one per axis, fitted on ``train``, scored on ``test``."""
    q = chi2_2dof_quantile(np.array(SIGMA_CONTENT))
    one = train.sum(axis=1).mean() / 2.0
    two = train.mean(axis=0)
    nll_one = 0.5 * (train.sum(axis=1) / one).sum() + len(train) * np.log(one)
    nll_two = 0.5 * (train / two).sum() + 0.5 * len(train) * np.log(two).sum()
    r_one, r_two = test.sum(axis=1) / one, (test / two).sum(axis=1)
    return {
        "train": len(train),
        "test": len(test),
        "c": one,
        "c_minor": two[0],
        "c_major": two[1],
        "gain_less_aic": nll_one - nll_two - 1.0,
        "one_1s": (r_one <= q[0]).mean(),
        "one_2s": (r_one <= q[1]).mean(),
        "two_1s": (r_two <= q[0]).mean(),
        "two_2s": (r_two <= q[1]).mean(),
        "test_minor": test[:, 0].mean() / two[0],
        "test_major": test[:, 1].mean() / two[1],
    }


def main() -> None:
    train, test, model = windows_of_the_study()

    def mine(w: pd.DataFrame) -> pd.DataFrame:
        keep = (w["model"] == model) & (w["control"] == "fused") & w["counted"].astype(bool)
        return w[keep]

    train, test = mine(train), mine(test)
    rows = []
    for (seed, length), a in train.groupby(["seed", "outage_s"], dropna=False):
        b = test[(test["seed"] == seed) & (test["outage_s"] == length)]
        if len(a) >= MIN_WINDOWS and len(b):
            rows.append({"seed": seed, "outage_s": length, **compare(along_axes(a), along_axes(b))})
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 200):
        print(f"{model}, fused: one scale against one per axis (normals)")
        print(table.round(3).to_string(index=False))
        print("mean over seeds:")
        print(table.drop(columns="seed").groupby("outage_s").mean().round(3).to_string())


if __name__ == "__main__":
    main()
