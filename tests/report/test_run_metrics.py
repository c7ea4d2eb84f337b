"""An evaluation as MLflow metrics: R's names are the chosen recipe's, every statistic named."""

import pytest

from rwhonet.report.run_metrics import position_metrics, scenario_metrics
from stages.conftest import evaluated, samples_dir

__all__ = ["evaluated", "samples_dir"]


def test_scenario_metrics_of_the_chosen_recipe_are_r_s(evaluated):
    _, ev = evaluated
    g = scenario_metrics(ev, "G")
    assert g["scenario/hard_brake/crse/mean"] == pytest.approx(1.0)  # 10 s x 0.1 m
    assert g["scenario/hard_brake/windows"] == 1.0
    assert g["scenario/hard_brake/cte/ci95"] == 0.0  # both seeds alike
    r = scenario_metrics(ev, "R")
    assert r == scenario_metrics(ev, "R[radius+G]@20") and r["scenario/hard_brake/crse/mean"] == 0
    assert scenario_metrics(ev, "WPM-ref") == {}  # not a scenario-outage model


def test_position_metrics_name_every_window_statistic_of_the_control(evaluated):
    _, ev = evaluated
    got = position_metrics(ev, "G")
    row = ev.position[
        (ev.position["model"] == "G")
        & (ev.position["control"] == ev.position_plan["control"])
        & (ev.position["outage_s"] == 30)
    ].iloc[0]
    assert got["pos/30s/mean"] == row["pos_mean"] and got["pos/30s/pct_max"] == row["pos_pct_max"]
    assert got["pos/30s/cover_2sigma"] == row["cover_2sigma"]
    assert got["pos/30s/cover_2sigma_filter"] == row["cover_2sigma_filter"]
    # no evidence here, so no calibration: scale 1, and no degrees of freedom (a normal)
    assert got["pos/30s/calib_scale"] == 1.0 and "pos/30s/calib_dof" not in got
    assert position_metrics(ev, "R") == position_metrics(ev, ev.choice.model)
