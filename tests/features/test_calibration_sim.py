"""Radius calibration on drives from the project's simulator (rwhonet.sim)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import load_params
from rwhonet.data.iovnbd import LAYOUT
from rwhonet.features.calibration import fit_radii_ratio_of_sums
from rwhonet.features.seconds import segment_seconds
from rwhonet.sim import SimOptions, simulate_drive, straight_route, vehicles_from_params


def straight_drive(options: SimOptions, seed: int) -> tuple[pd.DataFrame, dict]:
    """A 10-minute straight drive at 15 m/s, in canonical columns, and its truth."""
    params = load_params()
    car = vehicles_from_params(params)["source"]
    frame, _, truth, _ = simulate_drive(
        car, "A", straight_route(15.0, 600.0), seed=seed, sim=params.sim, options=options
    )
    # The file's columns to canonical SI names, as the IO-VNBD reader maps them.
    canonical = pd.DataFrame(
        {
            col.canonical: frame[col.header].to_numpy(np.float64) * col.to_si
            for col in LAYOUT
            if col.canonical
        }
    )
    return canonical, truth


def fit(frame: pd.DataFrame):
    sec = segment_seconds(frame, "sim")
    return fit_radii_ratio_of_sums(
        sec.disp_gnss_m, sec.angle_rl_rad, sec.angle_rr_rad, sec.span_s, 2.0
    )


def test_ideal_drive_recovers_the_static_radius():
    frame, truth = straight_drive(SimOptions.ideal(), seed=0)
    radii = fit(frame)
    # Exact but for the file's 0.01 rad/s wheel-speed resolution: <= 0.005 / 51 = 1e-4.
    assert radii.r_rl_m == pytest.approx(truth["radius_static_m"]["rl"], rel=2e-4)
    assert radii.r_rr_m == pytest.approx(truth["radius_static_m"]["rr"], rel=2e-4)


@pytest.mark.parametrize("seed", [0, 1])
def test_realistic_drive_recovers_the_effective_radius_within_half_a_percent(seed):
    frame, truth = straight_drive(SimOptions(), seed=seed)
    radii = fit(frame)
    for wheel, r in (("rl", radii.r_rl_m), ("rr", radii.r_rr_m)):
        assert r == pytest.approx(truth["radius_mean_m"][wheel], rel=5e-3)
        # What odometry sees is omega = v (1 + slip) / r_e: radius / (1 + slip).
        odometry_radius = truth["radius_mean_m"][wheel] / (1 + truth["slip_mean"][wheel])
        assert r == pytest.approx(odometry_radius, rel=1e-3)
