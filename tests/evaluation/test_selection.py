"""The selection rule and its Choice: known scores in, the documented pick out; params untouched."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.evaluation.selection import (
    SelectionPredictions,
    choose,
    recommend,
    selection_disagreements,
    selection_scores,
)
from rwhonet.stages.sample_files import load_role


def _scores(rows):
    """Selection scores as selection_scores returns them, from (role, model, outage, crse)."""
    return pd.DataFrame(
        [
            {
                "role": r,
                "model": m,
                "outage_s": L,
                "crse_mean": c,
                "crse_mean_ci95": 0.0,
                "n_windows": 4,
            }
            for r, m, L, c in rows
        ]
    )


def test_selection_rule_drops_harm_then_takes_the_fewest_seconds_within_tolerance(params):
    t = "target_train"
    rows = [(t, "G", 30, 2.0), (t, "G", 60, 4.0)]
    rows += [(t, "R[paper]@10", 30, 2.1), (t, "R[paper]@10", 60, 2.0)]  # worse than G at 30 s
    rows += [(t, "R[paper]@20", 30, 1.0), (t, "R[paper]@20", 60, 3.0)]  # 3.0 > 2.9 * 1.05
    rows += [(t, "R[radius+G]@10", 30, 1.0), (t, "R[radius+G]@10", 60, 3.04)]  # within 5 %
    rows += [(t, "R[radius+G]@20", 30, 1.0), (t, "R[radius+G]@20", 60, 2.9)]  # the best
    rec = recommend(_scores(rows), params)
    assert rec["recommended"]["recipe"] == "radius+G" and rec["recommended"]["m"] == 10

    # continuous counts as max(m_grid) seconds: it loses the tie-break to m = 10 ...
    cont = [(t, "R[continuous]", 30, 1.0), (t, "R[continuous]", 60, 2.95)]
    assert recommend(_scores(rows + cont), params)["recommended"]["m"] == 10
    # ... and wins when it is the only one within tolerance
    cont = [(t, "R[continuous]", 30, 1.0), (t, "R[continuous]", 60, 2.5)]
    rec = recommend(_scores(rows + cont), params)
    assert rec["recommended"] == {
        "recipe": "continuous",
        "m": None,
        "crse_60s": 2.5,
        "best_crse_60s": 2.5,
    }
    notes = selection_disagreements(rec)
    assert len(notes) == 1 and "continuous" in notes[0] and "paper at 20" in notes[0]

    # the ridge penalty: lowest mean over m on the held-out source drives
    s = "source_test"
    ridge = [
        (s, f"ridge_head lambda={lam}@{m}", 60, c)
        for lam, m, c in [(0.1, 10, 5.0), (0.1, 20, 3.0), (1.0, 10, 4.5), (1.0, 20, 3.8)]
    ]
    rec = recommend(_scores(rows + ridge), params)
    assert rec["ridge"]["recommended_penalty"] == 0.1
    assert any("ridge_penalty 0.1" in n for n in selection_disagreements(rec))


def test_selection_rule_recommends_nothing_when_every_recipe_harms(params):
    t = "target_train"
    rows = [
        (t, "G", 30, 1.0),
        (t, "G", 60, 2.0),
        (t, "R[paper]@20", 30, 1.1),
        (t, "R[paper]@20", 60, 1.0),
    ]
    rec = recommend(_scores(rows), params)
    assert "recommended" not in rec and "no_recommendation" in rec
    assert selection_disagreements(rec) == []


def test_auto_takes_the_rules_choice_else_the_fallback_and_params_keep_auto():
    auto = load_params(paths.PARAMS, overrides={"adapt.m_grid": [10, 20], "adapt.fallback.m": 20})
    c = choose(auto, {"recommended": {"recipe": "head", "m": 10}})
    assert (c.recipe, c.m, c.chosen_by, c.model) == ("head", 10, "rule", "R[head]@10")
    c = choose(auto, {"recommended": {"recipe": "continuous", "m": None}})
    assert (c.recipe, c.m, c.model) == ("continuous", 20, "R[continuous]")  # m: max(m_grid)
    c = choose(auto, {"recommended": {"recipe": "continuous_shrink", "m": None}})
    assert (c.recipe, c.m, c.model) == ("continuous_shrink", 20, "R[continuous_shrink]")
    evidence = {"no_recommendation": "every recipe is worse than G somewhere"}
    c = choose(auto, evidence)
    assert (c.recipe, c.m, c.chosen_by) == ("shrink", 20, "fallback")
    chosen = {"recipe": "shrink", "m": 20}
    assert c.as_selection() == {**evidence, "chosen_by": "fallback", "chosen": chosen}
    assert evidence == {"no_recommendation": "every recipe is worse than G somewhere"}  # untouched
    assert (auto.adapt.recipe, auto.adapt.chosen_m) == ("auto", "auto")  # what the user set

    fixed = load_params(paths.PARAMS, overrides={"adapt.recipe": "paper", "adapt.chosen_m": 50})
    c = choose(fixed, {"recommended": {"recipe": "head", "m": 10}})
    assert (c.recipe, c.m, c.chosen_by) == ("paper", 50, "params")
    assert c.ridge_penalty == fixed.adapt.ridge_penalty
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.m = 10  # type: ignore[misc]


def test_a_guarded_view_is_enough_to_choose():
    from rwhonet.config import ConfigError

    p = load_params(paths.PARAMS, only=["adapt", "seeds"], reader="stage evaluate")
    c = choose(p, {"recommended": {"recipe": "paper", "m": 30}})
    assert (c.recipe, c.m) == ("paper", 30) and p.adapt.chosen_m == "auto"
    with pytest.raises(ConfigError, match="does not declare it"):
        p.train  # noqa: B018


def test_selection_scores_are_the_test_scoring_on_the_training_drives(samples_dir, params):
    frame = load_role(samples_dir, "target_train", seq_len=1).frame  # T: 100 s
    keys = frame[["drive", "segment", "t_s"]]
    label = frame["label_m"].to_numpy()
    offsets = {1: 0.1, 2: 0.3}  # R[paper]@10 is off by this much a second, per seed
    per_seed = {
        seed: (
            keys.assign(**{"pred_m__R[paper]@10": label - off}),
            keys.assign(pred_m=label),  # G: perfect
        )
        for seed, off in offsets.items()
    }
    scores = selection_scores({"target_train": SelectionPredictions(frame, per_seed)}, params)
    s = scores.set_index(["model", "outage_s"])
    # 100 - 20 scored seconds: two 30 s windows and one 60 s window
    assert s.loc[("R[paper]@10", 30), "n_windows"] == 2 and s.loc[("G", 60), "n_windows"] == 1
    assert s.loc[("R[paper]@10", 30), "crse_mean"] == pytest.approx(30 * np.mean([0.1, 0.3]))
    assert s.loc[("R[paper]@10", 30), "crse_mean_ci95"] > 0
    assert s.loc[("G", 60), "crse_mean"] == pytest.approx(0.0, abs=1e-9)
    assert set(scores["role"]) == {"target_train"}
