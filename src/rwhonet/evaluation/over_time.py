"""CRSE over time: does a recalibration hold as the drive goes on?

Windows are binned by how far into the drive they start (:data:`TIME_BINS_S`);
beyond the paper, which scores each drive's windows together.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from rwhonet.config import Params
from rwhonet.evaluation.intervals import over_seeds
from rwhonet.evaluation.names import recipe_models
from rwhonet.evaluation.selection import Choice

TIME_BINS_S = (0, 300, 600, 1200, 2400, 3600, math.inf)  # seconds into the drive


def crse_over_time(timeline: pd.DataFrame, params: Params, choice: Choice) -> pd.DataFrame:
    """Mean window CRSE against the time into the drive a window starts (target test drives).

    Args:
        timeline: per seed, model, outage and window: ``start_s`` (seconds into
            the drive) and ``crse`` (:func:`rwhonet.evaluation.scoring.score_seed`).
        params: ``adapt.recipes``.
        choice: R-WhONet; the models shown are those at its m.

    Returns:
        Per model, outage and bin: the mean over its windows, per seed, then the
        mean over seeds with its interval (``crse``, ``crse_ci95``, ``n_windows``,
        ``from_s``, ``to_s``).
    """
    chosen = choice.m
    models = ["WPM", "G", "S", "R", f"WPM-m@{chosen}"] + [
        m for m in recipe_models(params) if m.endswith(f"@{chosen}") or "@" not in m
    ]
    t = timeline[timeline["model"].isin(models)].copy()
    edges = np.asarray(TIME_BINS_S, dtype=np.float64)
    t["bin"] = np.searchsorted(edges, t["start_s"].to_numpy(), side="right") - 1
    per_seed = (
        t.groupby(["model", "outage_s", "bin", "seed"], sort=False)
        .agg(crse=("crse", "mean"), n_windows=("crse", "size"))
        .reset_index()
    )
    out = over_seeds(per_seed, ["model", "outage_s", "bin"], ["crse"])
    n = per_seed.groupby(["model", "outage_s", "bin"], sort=False)["n_windows"].first()
    out = out.join(n, on=["model", "outage_s", "bin"])
    out["from_s"] = edges[out["bin"]]
    out["to_s"] = edges[out["bin"] + 1]
    return out.sort_values(["outage_s", "model", "bin"], ignore_index=True)
