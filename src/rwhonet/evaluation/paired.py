"""Paired statistics over training seeds: differences, gains over the WPMs, "do no harm".

Every comparison is made within a seed (the same windows, the same training
randomness), then averaged over seeds with its 95 % interval
(:mod:`rwhonet.evaluation.intervals`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import alt_wpm, recipe_model
from rwhonet.evaluation.intervals import mean_ci95
from rwhonet.evaluation.names import pairs, recipe_models
from rwhonet.evaluation.selection import Choice


def paired(
    per_seed: pd.DataFrame, params: Params, choice: Choice
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-seed differences between models and gains over the WPMs, averaged with intervals.

    Both on the target test drives' overall means (all windows of all drives).
    """
    overall = per_seed[(per_seed["role"] == k.TARGET_TEST) & (per_seed["drive"] == "all")]
    table = overall.set_index(["model", "outage_s", "seed"])
    diff_rows, gain_rows = [], []
    chosen = choice.m
    gain_models = ["G", "S", "R", f"WPM-m@{chosen}"] + [
        recipe_model(r, chosen)
        for r in params.adapt.recipes
        if recipe_model(r, chosen) != choice.model
    ]
    for L in params.evaluate.outages_s:
        for a, b in pairs(params, choice):
            row: dict[str, Any] = {"pair": f"{a} - {b}", "outage_s": L}
            for metric in ("crse", "cte"):
                d = [
                    table.loc[(a, L, s), f"{metric}_mean"] - table.loc[(b, L, s), f"{metric}_mean"]
                    for s in params.seeds
                ]
                row[f"{metric}_mean"], row[f"{metric}_ci95"] = mean_ci95(d)
            base = float(np.mean([table.loc[(b, L, s), "crse_mean"] for s in params.seeds]))
            row["crse_rel"] = row["crse_mean"] / base if base > 0 else math.nan
            diff_rows.append(row)
        for baseline in ("WPM", alt_wpm(params.label.wpm_mode)[0]):
            for model in gain_models:
                g = [
                    _gain(
                        table.loc[(model, L, s), "crse_mean"],
                        table.loc[(baseline, L, s), "crse_mean"],
                    )
                    for s in params.seeds
                ]
                mean, ci = mean_ci95(g)
                gain_rows.append(
                    {
                        "model": model,
                        "baseline": baseline,
                        "outage_s": L,
                        "gain": mean,
                        "gain_ci95": ci,
                    }
                )
    return pd.DataFrame(diff_rows), pd.DataFrame(gain_rows)


def no_harm(per_seed: pd.DataFrame, params: Params) -> pd.DataFrame:
    """For every recalibrated model: how often, and by how much, it is worse than G.

    Over the (target test drive, seed) pairs: the share where the model's mean
    CRSE on that drive exceeds G's (same seed, same windows), and the mean
    relative excess over those pairs; ``worse_on_average`` when the model's
    mean over seeds and drives is above G's.
    """
    drives = per_seed[(per_seed["role"] == k.TARGET_TEST) & (per_seed["drive"] != "all")]
    table = drives.set_index(["model", "outage_s", "seed", "drive"])["crse_mean"].sort_index()
    rows = []
    for model in recipe_models(params):
        for L in params.evaluate.outages_s:
            r = table.loc[model, L]
            g = table.loc["G", L].reindex(r.index)
            rel = (r / g - 1.0).to_numpy()
            worse = rel > 0
            rows.append(
                {
                    "model": model,
                    "outage_s": L,
                    "pairs": len(rel),
                    "share_worse": float(worse.mean()),
                    "mean_excess": float(rel[worse].mean()) if worse.any() else 0.0,
                    "max_excess": float(rel.max()),
                    "worse_on_average": bool(r.mean() > g.mean()),
                }
            )
    return pd.DataFrame(rows)


def _gain(value: float, baseline: float) -> float:
    return 1.0 - value / baseline if baseline > 0 else math.nan
