"""The physical limit of recalibration from m s: known radii in, known CRSE out."""

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation.limits import radius_limits


@pytest.fixture
def params():
    return load_params(
        paths.PARAMS,
        overrides={
            "adapt.m_grid": [10, 20],
            "adapt.chosen_m": 20,
            "adapt.recipe": "paper",
            "evaluate.outages_s": [30, 60],
        },
    )


def _drive(radius_m, n, noise_m=0.0, seed=0, name="A"):
    """One target test drive at 10 m/s whose true rear radius per second is ``radius_m(k)``."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    angle = np.full(n, 10.0 / 0.3)
    gnss = radius_m(k) * angle + rng.normal(0.0, noise_m, n)
    return pd.DataFrame(
        {
            "drive": name,
            "role": "target_test",
            "group": 0,
            "k": k,
            "disp_gnss_m": gnss,
            "angle_rl_rad": angle,
            "angle_rr_rad": angle,
            "label_m": gnss - 0.3 * angle,
        }
    )


def test_a_constant_radius_without_noise_is_found_exactly_from_any_m(params):
    frame = _drive(lambda k: np.full(len(k), 0.305), 380)
    lim = radius_limits(frame, params).set_index("m")
    assert np.allclose(lim[["first", "any", "whole", "radius_sd_pct"]], 0.0, atol=1e-9)
    # 380 - 20 evaluated seconds -> 6 windows of 60 s; blocks of 10 s: 38, of 20 s: 19
    assert lim.loc[10, "n_windows"] == 6 and lim.loc[10, "n_blocks"] == 38
    assert lim.loc[20, "n_blocks"] == 19


def test_a_drive_whose_first_seconds_differ_costs_first_more_than_any(params):
    # cold tyres: 1 % smaller for the first 20 s (none scored), then the true 0.305 m
    frame = _drive(lambda k: np.where(k < 20, 0.305 * 0.99, 0.305), 380)
    lim = radius_limits(frame, params).set_index("m")
    # first m s: radius 1 % low over every scored 60 s window at 10.17 m/s -> 6.1 m each
    assert lim.loc[10, "first"] == pytest.approx(0.01 * 0.305 * 10 / 0.3 * 60, rel=1e-9)
    assert lim.loc[10, "any"] < lim.loc[10, "first"] / 5  # 2 of 38 blocks are cold
    assert lim.loc[10, "whole"] < lim.loc[10, "any"]
    assert lim.loc[10, "radius_sd_pct"] > 0


def test_gnss_noise_shrinks_the_radius_spread_with_m(params):
    frame = _drive(lambda k: np.full(len(k), 0.305), 2000, noise_m=0.3, seed=3)
    lim = radius_limits(frame, params).set_index("m")
    # white noise: sd of the radius ~ 1/sqrt(m)
    assert lim.loc[20, "radius_sd_pct"] == pytest.approx(
        lim.loc[10, "radius_sd_pct"] / np.sqrt(2), rel=0.15
    )
    assert lim.loc[20, "any"] < lim.loc[10, "any"]
