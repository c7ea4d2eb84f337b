"""Means over training seeds with 95 % confidence intervals (Student's t).

Every model is trained, adapted and evaluated once per seed; a table cell is
the mean of its per-seed values with the half-width of the two-sided 95 %
interval ``t_{0.975, n-1} s / sqrt(n)`` (``s`` the sample standard deviation,
ddof = 1). With one seed there is no interval (NaN). The interval covers the
randomness of training (initial weights, shuffling, dropout) on one fixed
world, not the choice of drives.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy.stats import t as student_t

CONFIDENCE = 0.95


def mean_ci95(values: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """Mean and 95 % interval half-width of per-seed values.

    Args:
        values: one value per seed (NaN values are left out).

    Returns:
        ``(mean, half_width)``; the half-width is NaN with fewer than two values,
        and 0 when every seed gives the same value.
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[~np.isnan(v)]
    if len(v) == 0:
        return float("nan"), float("nan")
    if len(v) < 2:
        return float(v.mean()), float("nan")
    q = student_t.ppf(0.5 + CONFIDENCE / 2.0, df=len(v) - 1)
    return float(v.mean()), float(q * v.std(ddof=1) / np.sqrt(len(v)))


def over_seeds(per_seed: pd.DataFrame, keys: list[str], values: list[str]) -> pd.DataFrame:
    """Collapse per-seed rows to one row per ``keys``: the mean and 95 % half-width of each value.

    Args:
        per_seed: one row per seed and key combination (a ``seed`` column and ``keys``).
        keys: the columns that identify a cell (drive, model, outage_s...).
        values: the columns to average; each gives ``<value>`` (mean over seeds)
            and ``<value>_ci95`` (half-width).

    Returns:
        One row per key combination, in first-appearance order, with ``n_seeds``.
    """
    rows = []
    for key, group in per_seed.groupby(keys, sort=False, dropna=False):
        row = dict(zip(keys, key if isinstance(key, tuple) else (key,), strict=True))
        for col in values:
            row[col], row[f"{col}_ci95"] = mean_ci95(group[col].to_numpy(np.float64))
        row["n_seeds"] = int(group["seed"].nunique())
        rows.append(row)
    return pd.DataFrame(rows)
