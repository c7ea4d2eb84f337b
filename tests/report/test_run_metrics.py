"""An evaluation as MLflow metrics: R's names are the chosen recipe's, every statistic named."""

import dataclasses
import math

import pytest

from rwhonet.report.run_metrics import drive_keys, position_metrics, scenario_metrics
from stages.conftest import evaluated_once

__all__ = ["evaluated_once"]


def test_scenario_metrics_of_the_chosen_recipe_are_r_s(evaluated_once):
    _, ev = evaluated_once
    g = scenario_metrics(ev, "G")
    assert g["scenario/hard_brake/crse/mean"] == pytest.approx(1.0)  # 10 s x 0.1 m
    assert g["scenario/hard_brake/windows"] == 1.0
    assert g["scenario/hard_brake/cte/ci95"] == 0.0  # both seeds alike
    r = scenario_metrics(ev, "R")
    assert r == scenario_metrics(ev, "R[radius+G]@20") and r["scenario/hard_brake/crse/mean"] == 0
    assert scenario_metrics(ev, "WPM-ref") == {}  # not a scenario-outage model


def test_position_metrics_name_every_window_statistic_of_the_control(evaluated_once):
    _, ev = evaluated_once
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


def test_the_filter_s_fitted_figures_go_to_the_control_model_s_run(evaluated_once):
    _, ev = evaluated_once
    control_model = ev.position_plan["control_model"]
    name = "R" if control_model == ev.choice.model else control_model
    # nothing fitted here (no training evidence): nothing logged
    assert not {k for k in position_metrics(ev, name) if k.count("/") == 1}
    fitted = {
        "receiver": {"sigma_m": 2.7, "fitted": True},
        "geometry": {"antenna_m": [0.95, -0.2], "gyro_latency_s": 0.11, "fitted": True},
        "gyro": {"instability_deg_s": 0.0042, "fitted": True},
    }
    ev = dataclasses.replace(ev, position_plan={**ev.position_plan, **fitted})
    got = {k: v for k, v in position_metrics(ev, name).items() if k.count("/") == 1}
    assert got == {
        "pos/receiver_sigma_m": 2.7,
        "pos/antenna_ahead_m": 0.95,
        "pos/antenna_left_m": -0.2,
        "pos/gyro_latency_s": 0.11,
        "pos/gyro_instability_deg_s": 0.0042,
    }
    other = next(m for m in ("WPM", "G", "S") if m != control_model)
    assert not {k for k in position_metrics(ev, other) if k.count("/") == 1}


def test_each_test_drive_s_cells_go_to_the_control_model_s_run(evaluated_once):
    _, ev = evaluated_once
    control_model = ev.position_plan["control_model"]
    got = position_metrics(ev, "R" if control_model == ev.choice.model else control_model)
    assert len(ev.position_drives)
    for r in ev.position_drives.itertuples():
        key = f"pos/drive/{r.drive}/{int(r.outage_s)}s"
        assert got[f"{key}/mean"] == r.pos_mean and got[f"{key}/windows"] == r.n_windows
        assert got[f"{key}/cover_1sigma"] == r.cover_1sigma
    other = next(m for m in ("WPM", "G", "S") if m != control_model)
    assert not any(k.startswith("pos/drive/") for k in position_metrics(ev, other))


def test_r_s_crse_calibration_per_test_drive(evaluated_once):
    _, ev = evaluated_once
    got = position_metrics(ev, "R")
    assert len(ev.uncertainty_drives)
    for r in ev.uncertainty_drives.itertuples():
        key = f"uncertainty/drive/{r.drive}/{int(r.outage_s)}s"
        if math.isfinite(r.cover_1sigma):
            assert got[f"{key}/crse_cover_1sigma"] == r.cover_1sigma
        assert got[f"{key}/windows"] == r.n_windows
    assert not any(k.startswith("uncertainty/drive/") for k in position_metrics(ev, "WPM"))


def test_drive_names_become_valid_distinct_mlflow_names():
    from mlflow.utils.validation import _validate_metric_name

    route = "b0c9d2329ad1606b|2018-08-02--08-34-47"  # a comma2k19 route folder's name
    drives = ["V-Delta2", "a/b", "a_b", "..", "drive#1 é", "", ".", route, "x (2)"]
    keys = drive_keys(drives)
    assert keys["V-Delta2"] == "V-Delta2"  # an ordinary name stays as it is
    assert keys["a/b"] == "a_b_2" and keys["a_b"] == "a_b"  # no two drives meet...
    assert drive_keys(["a_b", "a/b"]) == {"a_b": "a_b", "a/b": "a_b_2"}  # ...in either order
    assert keys[route] == "b0c9d2329ad1606b_2018-08-02--08-34-47" and keys["x (2)"] == "x _2_"
    assert len(set(keys.values())) == len(drives)
    for key in keys.values():
        _validate_metric_name(f"pos/drive/{key}/30s/mean")  # raises on a bad name
