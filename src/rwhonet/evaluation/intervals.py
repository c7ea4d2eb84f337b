"""Means over training seeds with 95 % confidence intervals (Student's t), and how far
chance scatters a calibrated prediction's coverage.

Every model is trained, adapted and evaluated once per seed; a table cell is
the mean of its per-seed values with the half-width of the two-sided 95 %
interval ``t_{0.975, n-1} s / sqrt(n)`` (``s`` the sample standard deviation,
ddof = 1). With one seed there is no interval (NaN). The interval covers the
randomness of training (initial weights, shuffling, dropout) on one fixed
world, not the choice of drives.

:func:`band_chance`: the share of ``n`` windows inside a calibrated prediction's region
is binomial, and on a few dozen windows it scatters more widely than issue 17's
68 ± 5 % / 95 ± 3 % bands (:data:`COVER_BANDS`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy.stats import t as student_t

CONFIDENCE = 0.95
# issue 17: a region of content 68.27 % (1σ) holds 68 ± 5 % of windows, 95.45 % (2σ) 95 ± 3 %
COVER_BANDS = ((0.6827, 0.05), (0.9545, 0.03))


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


def band_chance(n: int, p: float, tol: float) -> tuple[float, float, float]:
    """What a calibrated prediction's share of ``n`` windows does against the band ``p ± tol``.

    The number of windows inside a region of content ``p`` is binomial (``n``, ``p``)
    when the windows are independent, so its share lands inside the band, above it (the
    region too wide) or below it (too narrow) with these probabilities. With 37 windows
    a calibrated 1σ region lands inside 68 ± 5 % about one time in two: the band is
    narrower than the chance scatter of so few windows. Windows of one drive miss
    together, which widens the scatter, so ``inside`` is the most a calibrated
    prediction can expect.

    Returns:
        (inside, above, below) probabilities; NaN each for no window. A share exactly on
        a bound counts as inside.
    """
    from scipy.stats import binom

    if n <= 0:
        return float("nan"), float("nan"), float("nan")
    k = np.arange(n + 1)
    pmf = binom.pmf(k, n, p)
    share = k / n
    eps = 1e-12
    above = float(pmf[share > p + tol + eps].sum())
    below = float(pmf[share < p - tol - eps].sum())
    return 1.0 - above - below, above, below
