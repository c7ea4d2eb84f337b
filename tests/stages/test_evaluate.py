"""The evaluate stage's records: R-WhONet's Choice is passed as a value, params stay the user's."""

import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation.selection import choose, recommend
from rwhonet.evaluation.study import evaluate
from rwhonet.stages.evaluate import (
    evaluation_record,
    position_metrics,
    provenance_line,
    scenario_metrics,
)
from rwhonet.stages.sample_files import load_role

OVERRIDES = {
    "adapt.m_grid": [10, 20],
    "adapt.fallback.m": 20,
    "evaluate.outages_s": [30, 60],
    "adapt.recipes": ["paper", "radius+G", "continuous"],
    "adapt.fallback.recipe": "radius+G",  # shrink is not among these recipes
    "seeds": [1, 2],
}


@pytest.fixture
def evaluated(samples_dir):
    """An evaluation with ``adapt.recipe: auto`` that fell back to radius+G at 20 s."""
    params = load_params(paths.PARAMS, overrides=OVERRIDES)
    frame = load_role(samples_dir, ("target_test", "source_test"), seq_len=1).frame
    frame.loc[frame.index[frame["drive"] == "B"][100:103], "scenario"] = "hard_brake"
    label = frame["label_m"].to_numpy()
    cols = {"G": label - 0.1, "S": label}
    cols |= {f"R[{r}]@{m}": label for r in ("paper", "radius+G") for m in (10, 20)}
    cols |= {f"R[continuous]/{n}s": label for n in (30, 60)}
    preds = {seed: pd.DataFrame(cols, index=frame.index) for seed in (1, 2)}
    choice = choose(params, recommend(pd.DataFrame(), params))  # no evidence: the fallback
    return params, evaluate(params, choice, frame, preds)


def test_the_parent_run_logs_what_the_user_set_and_the_choice_apart(evaluated):
    params, ev = evaluated
    assert (ev.choice.recipe, ev.choice.m, ev.choice.chosen_by) == ("radius+G", 20, "fallback")
    rec = evaluation_record(params, ev, [])
    assert rec.params["adapt.recipe"] == "auto" and rec.params["adapt.chosen_m"] == "auto"
    assert rec.params["chosen.recipe"] == "radius+G" and rec.params["chosen.m"] == 20
    assert rec.params["chosen.by"] == "fallback"
    assert "R-WhONet = recipe `radius+G` at m = 20 s" in provenance_line(params, ev.choice)
    assert (ev.eval_json["recipe"], ev.eval_json["chosen_m"]) == ("radius+G", 20)
    assert ev.eval_json["selection"]["params"]["recipe"] == "auto"


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
