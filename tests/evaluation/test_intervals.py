"""Means over seeds and their 95 % t intervals, against hand-computed values."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rwhonet.evaluation.intervals import band_chance, mean_ci95, over_seeds


def test_three_seeds_by_hand():
    # 10, 12, 14: mean 12, s = 2, t(0.975, 2) = 4.302653 -> 4.302653 * 2 / sqrt(3) = 4.96828
    mean, half = mean_ci95([10.0, 12.0, 14.0])
    assert mean == 12.0
    assert half == pytest.approx(4.302653 * 2.0 / math.sqrt(3.0), rel=1e-6)
    assert half == pytest.approx(4.96828, rel=1e-5)


def test_five_seeds_by_hand():
    # 1..5: mean 3, s = sqrt(2.5), t(0.975, 4) = 2.776445 -> 1.963243
    mean, half = mean_ci95([1.0, 2.0, 3.0, 4.0, 5.0])
    assert (mean, round(half, 5)) == (3.0, 1.96324)


def test_one_seed_has_no_interval_and_equal_seeds_a_zero_one():
    assert np.isnan(mean_ci95([7.0])[1]) and mean_ci95([7.0])[0] == 7.0
    assert mean_ci95([2.5, 2.5, 2.5]) == (2.5, 0.0)
    # NaN is left out: 1 and 3 -> s = sqrt(2), t(0.975, 1) = 12.706205 -> 12.706205
    assert mean_ci95([1.0, np.nan, 3.0]) == (2.0, pytest.approx(12.706205, rel=1e-6))


def test_over_seeds_keeps_cells_apart():
    per_seed = pd.DataFrame(
        {
            "seed": [1, 2, 3, 1, 2, 3],
            "model": ["G"] * 3 + ["R"] * 3,
            "crse": [10.0, 12.0, 14.0, 5.0, 5.0, 5.0],
        }
    )
    out = over_seeds(per_seed, ["model"], ["crse"])
    assert out["model"].tolist() == ["G", "R"]
    assert out["crse"].tolist() == [12.0, 5.0] and out["n_seeds"].tolist() == [3, 3]
    assert out["crse_ci95"].tolist() == pytest.approx([4.96828, 0.0], abs=1e-5)


def test_band_chance_by_hand():
    # 37 windows, 1σ band 68.27 ± 5 %: inside means 24 to 27 windows (64.9 to 73.0 %)
    n, p = 37, 0.6827
    pmf = [math.comb(n, k) * p**k * (1 - p) ** (n - k) for k in range(n + 1)]
    inside, above, below = band_chance(n, p, 0.05)
    assert inside == pytest.approx(sum(pmf[24:28]), rel=1e-9)
    assert above == pytest.approx(sum(pmf[28:]), rel=1e-9)
    assert below == pytest.approx(sum(pmf[:24]), rel=1e-9)
    # one window: 0 % or 100 %, never inside a ±3 % band about 95.45 %
    assert band_chance(1, 0.9545, 0.03) == pytest.approx((0.0, 0.9545, 0.0455))
    assert all(math.isnan(x) for x in band_chance(0, 0.6827, 0.05))
