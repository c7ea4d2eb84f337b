"""The evaluation study: the same seconds for every model, controls, seeds and intervals."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.errors import InputError
from rwhonet.evaluation.intervals import mean_ci95
from rwhonet.evaluation.names import model_names, recipe_models
from rwhonet.evaluation.selection import choose
from rwhonet.evaluation.study import evaluate as study
from rwhonet.report.tables import render_report
from rwhonet.stages.sample_files import load_role
from stages.conftest import R_CAL_M, write_samples

from .conftest import OVERRIDES


def evaluate(params, frame, preds):
    """The study with R-WhONet as params.yaml fixes it (no selection evidence)."""
    return study(params, choose(params, {}), frame, preds)


def _preds(frame, params, offsets):
    """Per seed, predictions = label - offset[(model, seed)] (default 0: a perfect model).

    ``R@m`` offsets apply to the chosen recipe's model (``R[paper]@m``).
    """
    label = frame["label_m"].to_numpy()
    alias = {f"R[{params.adapt.recipe}]@{m}": f"R@{m}" for m in params.adapt.m_grid}
    out = {}
    for seed in params.seeds:
        cols = {}
        for model in ["G", "S", *recipe_models(params)]:
            off = offsets.get((model, seed), offsets.get(model, offsets.get(alias.get(model), 0.0)))
            if model in ("R[continuous]", "R[continuous_shrink]"):
                cols.update({f"{model}/{L}s": label - off for L in params.evaluate.outages_s})
            else:
                cols[model] = label - off
        out[seed] = pd.DataFrame(cols, index=frame.index)
    return out


def _frame(samples_dir):
    return load_role(samples_dir, ("target_test", "source_test"), seq_len=1).frame


def test_perfect_model_scores_zero_and_wpm_scores_the_label(samples_dir, params):
    frame = _frame(samples_dir)
    ev = evaluate(params, frame, _preds(frame, params, {"G": 0.1}))
    s = ev.summary[ev.summary["role"] == "target_test"].set_index(["drive", "model", "outage_s"])
    assert s.loc[("all", "S", 30), "crse_mean"] == pytest.approx(0.0, abs=1e-9)
    assert s.loc[("all", "G", 30), "crse_mean"] == pytest.approx(3.0)  # 30 s x 0.1 m
    assert s.loc[("all", "G", 60), "cte_mean"] == pytest.approx(6.0)
    # windows: A seg0 300-20=280 -> 9 of 30 s, seg1 200 -> 6; B 400-20=380 -> 12
    assert s.loc[("all", "WPM", 30), "n_windows"] == 27
    assert s.loc[("A", "WPM", 60), "n_windows"] == 4 + 3
    part = ev.per_second[ev.per_second["evaluated"]]
    expected = part.loc[part.drive == "B", "label_m"].to_numpy()[:360].reshape(-1, 30)
    assert s.loc[("B", "WPM", 30), "crse_mean"] == pytest.approx(np.abs(expected).sum(1).mean())
    assert s.loc[("B", "WPM", 30), "crse_max"] >= s.loc[("B", "WPM", 30), "cte_max"]
    assert s.loc[("all", "WPM", 30), "crse_mean_ci95"] == 0.0  # the WPM has no seed


def test_no_model_is_scored_on_adaptation_seconds(samples_dir, params):
    frame = _frame(samples_dir)
    f = evaluate(params, frame, _preds(frame, params, {})).per_second
    assert not f.loc[f["k"] < 20, "evaluated"].any() and f.loc[f["k"] >= 20, "evaluated"].all()


def test_cells_are_means_over_seeds_with_their_t_interval(samples_dir, params):
    frame = _frame(samples_dir)
    p3 = load_params(paths.PARAMS, overrides={**OVERRIDES, "seeds": [1, 2, 3]})
    offsets = {("G", 1): 0.1, ("G", 2): 0.2, ("G", 3): 0.6}  # 30 s CRSE 3, 6, 18 m
    ev = evaluate(p3, frame, _preds(frame, p3, offsets))
    s = ev.summary[ev.summary["role"] == "target_test"].set_index(["drive", "model", "outage_s"])
    mean, half = mean_ci95([3.0, 6.0, 18.0])
    assert s.loc[("all", "G", 30), "crse_mean"] == pytest.approx(9.0) == pytest.approx(mean)
    assert s.loc[("all", "G", 30), "crse_mean_ci95"] == pytest.approx(half)
    assert s.loc[("all", "G", 30), "n_seeds"] == 3
    d = ev.differences.set_index(["pair", "outage_s"])
    assert d.loc[("R - G", 30), "crse_mean"] == pytest.approx(-9.0)  # R is perfect
    assert d.loc[("R - G", 30), "crse_ci95"] == pytest.approx(half)
    j = ev.eval_json
    assert j["n_seeds"] == 3 and j["overall"]["G"]["30s"]["crse_ci95"] == pytest.approx(half, 1e-3)


def test_wpm_m_recovers_a_known_radius_change(tmp_path, params):
    # The target car rolls 2 % further per radian than the source calibration says.
    folder = write_samples(
        tmp_path / "samples", [("A__s0", "A", "target_test", 400)], true_radius_m=1.02 * R_CAL_M
    )
    frame = _frame(folder)
    ev = evaluate(params, frame, _preds(frame, params, {}))
    refit = ev.refits.set_index(["drive", "m"])
    for m in (10, 20):  # GNSS noise 0.05 m per second: 3 sigma is 0.5 % over 10 s of ~10 m/s
        assert refit.loc[("A", m), "r_rl_m"] == pytest.approx(1.02 * R_CAL_M, rel=5e-3)
    s = ev.summary[ev.summary["role"] == "target_test"].set_index(["drive", "model", "outage_s"])
    wpm, refitted = (
        s.loc[("all", "WPM", 30), "crse_mean"],
        s.loc[("all", "WPM-m@20", 30), "crse_mean"],
    )
    assert wpm == pytest.approx(0.02 * 30 * 10, rel=0.1)  # 2 % of ~300 m per window
    assert refitted < 0.25 * wpm  # what is left is the GNSS noise (and a small refit error)
    # the model evaluation reads the radius+G recipe's predictions as given (here: perfect)
    assert s.loc[("all", "R[radius+G]@20", 30), "crse_mean"] == pytest.approx(0.0, abs=1e-9)


def test_eval_json_and_tables(samples_dir, params):
    frame = _frame(samples_dir)
    ev = evaluate(params, frame, _preds(frame, params, {"R@20": -0.2}))
    j = ev.eval_json
    assert set(j["overall"]) == set(model_names(params, ev.choice))
    assert {"WPM-ref", "R@10", "WPM-m@20", "R[radius+G]@10", "R[continuous]"} <= set(j["overall"])
    assert j["overall"]["R"]["30s"]["cte_mean"] == pytest.approx(6.0)  # R is R@20
    assert j["overall"]["R@20"] == j["overall"]["R"]
    assert set(j["overall"]["G"]["30s"]) == {
        "crse_mean",
        "crse_ci95",
        "cte_mean",
        "cte_ci95",
        "n_windows",
    }
    assert set(j["differences"]) == {
        "R - G",
        "R - S",
        "R - WPM-m@20",
        "R - R[radius+G]@20",
        "R - R[continuous]",
    }
    harm = j["no_harm"]["R[paper]@20"]["30s"]  # R@20 is 0.2 m per second off, G perfect
    assert harm["share_worse_than_g"] == 1.0 and harm["worse_on_average"] is True
    assert j["recipe"] == "paper"
    assert set(j["gains"]["R"]) == {"WPM", "WPM-ref"}
    assert set(j["per_drive"]) == {"A", "B"} and "R@10" not in j["per_drive"]["A"]
    md = render_report(ev, params, "prov")
    assert "## Table 2" in md and "## Table 6 — CTE, 60 s GNSS outages" in md
    assert "R-WhONet (m=20) CRSE (m)" in md and "## Every recipe at every m" in md
    assert "## Do no harm" in md and "## Mean CRSE against the time into the drive" in md


def test_the_domain_gap_is_g_on_held_out_source_drives(tmp_path, params):
    folder = write_samples(
        tmp_path / "samples",
        [("A__s0", "A", "target_test", 300), ("H__s0", "H", "source_test", 300)],
    )
    frame = _frame(folder)
    preds = _preds(frame, params, {"G": 0.0})
    for p in preds.values():  # R is only adapted on target drives
        p.loc[frame["role"] == "source_test", [c for c in p.columns if c.startswith("R")]] = np.nan
    ev = evaluate(params, frame, preds)
    gap = ev.eval_json["domain_gap"]
    assert set(gap) == {"WPM", "G"} and set(gap["G"]) == {"target_test", "source_test"}
    assert gap["G"]["source_test"]["30s"]["crse_mean"] == pytest.approx(0.0, abs=1e-9)
    s = ev.summary.set_index(["role", "drive", "model", "outage_s"])
    assert ("source_test", "all", "R@10", 30) not in s.index  # not scored where not adapted
    assert "Domain gap" in render_report(ev, params, "prov")


def test_too_short_drive_is_reported(samples_dir):
    p = load_params(
        paths.PARAMS,
        overrides={
            "adapt.m_grid": [10, 100],
            "adapt.chosen_m": 100,
            "adapt.recipe": "paper",
            "seeds": [1],
        },
    )
    frame = _frame(samples_dir)
    frame = frame[(frame.drive == "B") | (frame.k < 120)].reset_index(drop=True)
    with pytest.raises(InputError, match="too short") as err:  # A: 20 s < the shortest, 30 s
        evaluate(p, frame, _preds(frame, p, {}))
    assert [q.file for q in err.value.problems] == ["A"]


def test_a_drive_too_short_for_the_longest_outage_only_has_none_of_its_windows(samples_dir):
    p = load_params(
        paths.PARAMS,
        overrides={
            "adapt.m_grid": [10, 100],
            "adapt.chosen_m": 100,
            "adapt.recipe": "paper",
            "seeds": [1, 2],
        },
    )
    frame = _frame(samples_dir)
    frame = frame[(frame.drive == "B") | (frame.k < 250)].reset_index(drop=True)  # A: 150 s
    ev = evaluate(p, frame, _preds(frame, p, {}))
    s = ev.summary[ev.summary["role"] == "target_test"].set_index(["drive", "model", "outage_s"])
    assert s.loc[("A", "WPM", 120), "n_windows"] == 1 and ("A", "WPM", 180) not in s.index
    assert s.loc[("all", "WPM", 180), "n_windows"] == 1  # B's 300 s
    md = render_report(ev, p, "provenance")
    assert "## Table 9 — CRSE, 180 s GNSS outages" in md

    gone = frame[frame.drive == "A"].reset_index(drop=True)  # no target drive reaches 180 s
    with pytest.raises(InputError, match="longest outage") as err:
        evaluate(p, gone, _preds(gone, p, {}))
    assert "drop 180 from evaluate.outages_s" in str(err.value)


def test_scenario_errors_per_tag(samples_dir, params):
    frame = _frame(samples_dir).copy()
    frame["scenario"] = ""
    frame.loc[frame.index[200:210], "scenario"] = "roundabout;wet_road"
    frame.loc[frame.index[210:215], "scenario"] = "wet_road"
    ev = evaluate(params, frame, _preds(frame, params, {"G": 0.5}))
    sc = ev.scenarios.set_index("tag")
    assert sc.loc["wet_road", "n_seconds"] == 15 and sc.loc["roundabout", "n_seconds"] == 10
    assert sc.loc["roundabout", "G"] == pytest.approx(0.5)
    assert sc.loc["roundabout", "S"] == pytest.approx(0.0, abs=1e-12)
    expected = frame["label_m"].iloc[200:215].abs().mean()
    assert sc.loc["wet_road", "WPM"] == pytest.approx(expected)
    assert "" not in sc.index


def test_2d_position_error_is_the_distance_error_on_a_straight_drive(samples_dir, params):
    frame = _frame(samples_dir)
    ev = evaluate(params, frame, _preds(frame, params, {"G": 0.1}))
    dead = ev.position_dead_reckoning.set_index(["model", "outage_s"])
    # the earlier dead reckoning, due north at constant heading: a model's 2D error is its
    # summed distance error (the fixture's GNSS displacement has 0.05 m of noise a second,
    # its fixes none: 30 s of it is about 0.27 m)
    assert dead.loc[("G", 30), "pos_mean"] == pytest.approx(3.0, abs=0.3)  # 30 s x 0.1 m
    s = ev.summary[(ev.summary["role"] == "target_test") & (ev.summary["drive"] == "all")]
    wpm_cte = s.set_index(["model", "outage_s"]).loc[("WPM", 30), "cte_mean"]
    assert dead.loc[("WPM", 30), "pos_mean"] == pytest.approx(wpm_cte, rel=0.1)
    # the filter learns a distance's lasting scale error from GNSS before the outage (its
    # odometry-scale state): G's 0.1 m a second short (1 % at 10 m/s) is mostly gone
    pos = ev.position[ev.position["control"] == "fused"].set_index(["model", "outage_s"])
    assert pos.loc[("G", 30), "pos_mean"] < 1.0
    assert pos.loc[("S", 30), "pos_mean"] < 1.0  # perfect
    # a window counts after min_calibration_s (30) s of its segment on GNSS: not the first
    # windows of A's and B's first segments (20 s in), nor the first two of A's second
    # segment (0 and 30 s in; its first second has no course, the filter starts on the next)
    assert (pos.loc[("G", 30), "n_windows"], pos.loc[("G", 30), "n_windows_all"]) == (23, 27)
    out = ev.eval_json
    assert out["position"]["G"]["30s"]["n_windows"] > 0
    assert set(out["position_controls"]["rows"]) == {
        "wheels",
        "gyro",
        "fused",
        "fused, GNSS distance",
    }
    assert out["position_dead_reckoning"]["G"]["30s"]["pos_mean"] == pytest.approx(3.0, abs=0.3)
    assert set(out["uncertainty"]["models"]) >= {"WPM", "G", "S", "R"}
    # the control row on each target test drive apart: its windows add up to the row's
    controls = out["position_controls"]
    by_drive = controls["by_drive"]
    tested = set(frame.loc[frame["role"] == "target_test", "drive"])
    assert set(by_drive) == tested
    for L in ("30s", "60s"):
        whole = controls["rows"]["fused"][L]
        assert sum(d[L]["n_windows"] for d in by_drive.values()) == whole["n_windows"]
        assert sum(d[L]["n_windows_all"] for d in by_drive.values()) == whole["n_windows_all"]
        share = sum(d[L]["cover_2sigma"] * d[L]["n_windows"] for d in by_drive.values())
        assert share / whole["n_windows"] == pytest.approx(whole["cover_2sigma"], abs=1e-3)
    md = render_report(ev, params, "provenance")
    assert "## Where is the car when GNSS returns" in md and "earlier 2D dead reckoning" in md
    assert "| Test drive | 30 s: 1σ / 2σ (windows); error |" in md


def _crse_by_drive_adds_up(unc: dict, frame: pd.DataFrame) -> None:
    """R's CRSE calibration on each target test drive apart: every test drive, and its
    windows and shares adding up to the whole's."""
    by_drive, whole = unc["by_drive"], unc["models"]["R"]
    assert set(by_drive) == set(frame.loc[frame["role"] == "target_test", "drive"])
    for L in ("30s", "60s"):
        counts = [d[L]["n_windows"] for d in by_drive.values() if L in d]
        assert sum(counts) == whole[L]["n_windows"] > 0
        for key in ("crse_cover_1sigma", "crse_cover_2sigma"):
            inside = sum(d[L][key] * d[L]["n_windows"] for d in by_drive.values() if L in d)
            assert inside / whole[L]["n_windows"] == pytest.approx(whole[L][key], abs=1e-3)


def test_each_model_s_variance_is_fitted_on_the_target_training_drives(samples_dir, params):
    from rwhonet.evaluation.uncertainty import FitEvidence

    frame = _frame(samples_dir)
    train = load_role(samples_dir, "target_train", seq_len=1).frame
    label = train["label_m"].to_numpy()
    cols = {"G": label - 0.1, "S": label, "R[paper]@20": label - 0.02}
    evidence = FitEvidence(train, {s: pd.DataFrame(cols, index=train.index) for s in params.seeds})
    ev = study(params, choose(params, {}), frame, _preds(frame, params, {"G": 0.1}), None, evidence)
    var = ev.variance.set_index("model")
    # G is 0.1 m off every second of the training drive's 80 scored seconds: sigma about 0.1 m
    assert var.loc["G", "n_seconds"] == 80
    assert np.sqrt(var.loc["G", "a_m2"] + var.loc["G", "b"] * 10.0**2) == pytest.approx(
        0.1, rel=0.15
    )
    # S is fitted on the 10 s its training held out: too few, so the assumed variance
    assert var.loc["S", "n_seconds"] == 0
    out = ev.eval_json["uncertainty"]
    assert out["fitted_on"].startswith("target training drives")
    assert out["models"]["R"]["n_seconds"] == 80 and "30s" in out["models"]["R"]
    _crse_by_drive_adds_up(out, frame)
    md = render_report(ev, params, "provenance")
    assert "| Test drive | 30 s: 1σ / 2σ (windows); NLL |" in md
    # the 2D calibration: one training drive holds too few windows to fit, so every run
    # keeps the filter's own normal (and says so: scale 1, no finite degrees of freedom)
    pos = ev.position[ev.position["n_windows"] > 0]
    assert len(pos) and (pos["calib_scale"] == 1.0).all() and pos["calib_dof"].isna().all()
    assert (pos["cover_1sigma"] == pos["cover_1sigma_filter"]).all()
    cell = ev.eval_json["position"]["G"]["30s"]
    assert cell["calib_scale"] == 1.0 and cell["calib_dof"] is None
    # nor is the receiver's drift fitted on too few windows: the configured one, said so
    receiver = ev.eval_json["position_controls"]["receiver"]
    configured = params.evaluate.navigation.gnss.sigma_m
    assert receiver["fitted"] is False and receiver["sigma_m"] == configured
    assert receiver["configured_sigma_m"] == configured


def test_a_continuous_recipe_as_r_wh_onet_gets_its_crse_prediction(samples_dir, params):
    """The rule may choose a continuous recipe (it did on a large_target_consumer world of
    another simulator seed); its CRSE prediction is fitted on its training windows' own
    errors (no filter runs on it: no distance before a window)."""
    from rwhonet.evaluation.uncertainty import FitEvidence

    recipe = "continuous"
    p = dataclasses.replace(params, adapt=dataclasses.replace(params.adapt, recipe=recipe))
    frame = _frame(samples_dir)
    train = load_role(samples_dir, "target_train", seq_len=1).frame
    label = train["label_m"].to_numpy()
    noise = np.random.default_rng(5).normal(0.0, 0.05, (len(p.evaluate.outages_s), len(label)))
    cols = {"G": label - 0.1, "S": label, "R[paper]@20": label - 0.02}
    cols |= {
        f"R[{recipe}]/{L}s": label - n for L, n in zip(p.evaluate.outages_s, noise, strict=True)
    }
    evidence = FitEvidence(train, {s: pd.DataFrame(cols, index=train.index) for s in p.seeds})
    ev = study(p, choose(p, {}), frame, _preds(frame, p, {f"R[{recipe}]": 0.1}), None, evidence)
    r = ev.eval_json["uncertainty"]["models"]["R"]
    # the training drive's 80 scored seconds: two 30 s windows and one of 60 s
    assert r["n_windows"] == 3 and r["n_seconds"] == 120 and r["scale_sd"] == 0.0
    assert np.sqrt(r["a_m2"]) == pytest.approx(0.05, rel=0.3)
    for L in p.evaluate.outages_s:
        assert r[f"{L}s"]["n_windows"] > 0 and r[f"{L}s"]["crse_nll"] is not None
    assert f"R[{recipe}]" not in set(ev.position["model"])  # no filter on it
    _crse_by_drive_adds_up(ev.eval_json["uncertainty"], frame)
    md = render_report(ev, p, "provenance")
    assert f"R[{recipe}]" in md.split("σ² = a + b d²: a (cm²)")[1]


def test_a_continuous_recipe_as_r_wh_onet_is_scored_per_second_on_its_shortest_outage(
    samples_dir, params
):
    """A continuous recipe predicts per outage length; as R-WhONet (the rule may pick one:
    it did on a tcn run of large_target) the per-second scenario errors read its shortest
    outage's run, as the scenario outages do, instead of failing on the per-length dict."""
    recipe = "continuous"
    p = dataclasses.replace(params, adapt=dataclasses.replace(params.adapt, recipe=recipe))
    frame = _frame(samples_dir)
    ev = evaluate(p, frame, _preds(frame, p, {f"R[{recipe}]": 0.1}))
    assert ev.choice.recipe == recipe
    r = ev.summary.set_index(["role", "drive", "model", "outage_s"])
    assert r.loc[("target_test", "all", "R", 30), "crse_mean"] == pytest.approx(3.0)
