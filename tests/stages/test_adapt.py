"""The adapt stage: R-WhONet per test drive, recipe and m, from G's model file, in one process."""

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import torch

from rwhonet import contracts, paths
from rwhonet.config import load_params
from rwhonet.errors import InputError
from rwhonet.evaluation.windows import outage_windows
from rwhonet.features.wpm import wpm_displacement_m
from rwhonet.io import write_json
from rwhonet.models.adapt import adapt_data, label_prediction, recalibrate
from rwhonet.models.checkpoint import load_whonet, load_wpm_radii, save_whonet
from rwhonet.models.loop import predict
from rwhonet.models.whonet import WhONet
from rwhonet.stages.adapt import adapt_grid
from rwhonet.stages.sample_files import load_role

from .conftest import R_CAL_M, write_samples

OVERRIDES = {
    "adapt.m_grid": [10, 20],
    "adapt.chosen_m": 20,
    "adapt.epochs": 3,
    "adapt.recipe": "paper",
    "adapt.recipes": ["paper", "ridge_head", "radius+G", "continuous"],
    "adapt.fallback.recipe": "radius+G",  # shrink is not among these recipes
    "evaluate.outages_s": [30, 60],
}


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides=OVERRIDES)


def write_g(folder, hidden):
    """A G-WhONet model file (untrained, seeded) in ``folder``; returns the folder."""
    torch.manual_seed(0)
    hp = {
        "n_features": 40,
        "hidden": hidden,
        "layers": 1,
        "dropout": 0.05,
        "seq_len": 1,
        "lr": 7e-4,
        "batch_size": 128,
    }
    folder.mkdir()
    save_whonet(WhONet(40, hidden, 1, 0.05), hp, folder / contracts.MODEL_FILE)
    return folder


@pytest.fixture
def g_dir(tmp_path):
    return write_g(tmp_path / "g", 8)


@pytest.fixture
def calibration(tmp_path):
    path = tmp_path / "calibration.json"
    write_json(
        path,
        {
            "unit": "m/rad",
            "r_rl_m": R_CAL_M,
            "r_rr_m": R_CAL_M,
            "estimator": "ratio_of_sums",
            "min_speed_m_s": 2.0,
            "n_seconds_used": 1,
            "n_seconds_total": 1,
            "distance_m": 1.0,
            "role": "source_calibration",
            "drives": ["V"],
            "segments": ["V__s0"],
        },
    )
    return path


def test_every_drive_recipe_and_m_gets_its_own_model(
    tmp_path, samples_dir, params, g_dir, calibration
):
    records, _ = adapt_grid(params, 7, samples_dir, calibration, g_dir, tmp_path / "r")
    names = [(r.tags["recipe"], r.tags.get("m")) for r in records]
    assert names == [
        ("paper", "10"),
        ("paper", "20"),
        ("ridge_head", "10"),
        ("ridge_head", "20"),
        ("radius+G", "10"),
        ("radius+G", "20"),
        ("continuous", None),
    ]
    g_net, g_hp = load_whonet(g_dir / contracts.MODEL_FILE)
    test = load_role(samples_dir, contracts.TARGET_TEST, params.model.seq_len)
    drive, k = test.frame["drive"].to_numpy(), test.frame["k"].to_numpy()
    for recipe in ("paper", "ridge_head", "radius+G"):
        for m in (10, 20):
            out = tmp_path / "r" / recipe / f"m{m}"
            preds = pd.read_parquet(out / contracts.PREDICTIONS)
            assert len(preds) == len(test) and set(preds["drive"]) == {"A", "B"}
            for d in ("A", "B"):
                first = (drive == d) & (k < m)
                again = recalibrate(
                    recipe,
                    g_net,
                    g_hp,
                    adapt_data(test, first),
                    adapt=params.adapt,
                    seed=7,
                    min_speed_m_s=2.0,
                )
                net, _ = load_whonet(out / f"{d}.pt")
                for (name, a), b in zip(
                    net.state_dict().items(), again.net.state_dict().values(), strict=True
                ):
                    assert torch.equal(a, b), (recipe, name)
                assert load_wpm_radii(out / f"{d}.pt") == again.radii
                np.testing.assert_allclose(
                    preds.loc[preds["drive"] == d, "pred_m"].to_numpy(),
                    label_prediction(again, adapt_data(test, drive == d), (R_CAL_M, R_CAL_M)),
                )
            record = json.loads((out / contracts.RUN_RECORD).read_text())
            assert record["tags"] == {
                "model": "R",
                "recipe": recipe,
                "vehicle": "target",
                "seed": "7",
                "dvc_stage": "adapt@7",
                "m": str(m),
            }
            assert record["metrics"]["drive/A/n_adapt_samples"] == m
            # each drive's fine-tuning curve is the run's CSV artifact; its history their mean
            curves = out / contracts.FINE_TUNE_CURVES
            assert not any(k.startswith("drive/") for row in record["history"] for k in row)
            if recipe != "paper":  # no optimizer steps: no curves
                assert not curves.exists() and record["history"] == []
                continue
            assert str(curves.relative_to(tmp_path)) in " ".join(record["artifacts"])
            table = pd.read_csv(curves)
            assert set(table["drive"]) == {"A", "B"}
            assert list(table.columns[:2]) == ["drive", "epoch"] and "train/loss" in table
            for row in record["history"]:
                at = table[table["epoch"] == row["epoch"]]
                assert row["train/loss"] == pytest.approx(at["train/loss"].mean(), rel=1e-12)
            assert [r["epoch"] for r in record["history"]] == sorted(set(table["epoch"]))
    # the samples' true radius is 2 % above the calibration: radius+G's radii, with G on top,
    # add up to the GNSS distance of the m seconds it saw
    first = (drive == "A") & (k < 20)
    seen = adapt_data(test, first)
    radii = load_wpm_radii(tmp_path / "r" / "radius+G" / "m20" / "A.pt")
    total = wpm_displacement_m(seen.angle_rl_rad, seen.angle_rr_rad, *radii).sum()
    total += predict(g_net, seen.x).astype(np.float64).sum()
    assert total == pytest.approx(seen.disp_gnss_m.sum(), rel=1e-6)
    assert radii == pytest.approx((1.02 * R_CAL_M, 1.02 * R_CAL_M), rel=0.02)


def test_continuous_predicts_exactly_the_evaluated_windows(
    tmp_path, samples_dir, params, g_dir, calibration
):
    adapt_grid(params, 7, samples_dir, calibration, g_dir, tmp_path / "r")
    preds = pd.read_parquet(tmp_path / "r" / "continuous" / contracts.PREDICTIONS)
    test = load_role(samples_dir, contracts.TARGET_TEST, params.model.seq_len)
    for L in (30, 60):
        covered = np.flatnonzero(np.isfinite(preds[f"pred_m_{L}s"].to_numpy()))
        np.testing.assert_array_equal(
            covered, np.sort(outage_windows(test.frame, [10, 20], L).ravel())
        )


def test_a_drive_not_longer_than_the_largest_m_is_refused(
    tmp_path, samples_dir, g_dir, calibration
):
    params = load_params(
        paths.PARAMS,
        overrides={**OVERRIDES, "adapt.m_grid": [10, 500], "adapt.chosen_m": 10},
    )
    with pytest.raises(InputError, match="too short") as err:
        adapt_grid(params, 7, samples_dir, calibration, g_dir, tmp_path / "r")
    assert [p.file for p in err.value.problems] == ["A", "B"]
    assert not (tmp_path / "r").exists()


def test_the_outputs_do_not_depend_on_the_number_of_workers(
    tmp_path, samples_dir, params, calibration, monkeypatch
):
    from rwhonet.stages import adapt as stage
    from rwhonet.stages import cores

    # G as wide as the pipeline's (model.hidden): torch splits its products over threads
    g_dir = write_g(tmp_path / "g72", 72)
    monkeypatch.setattr(cores.os, "cpu_count", lambda: 4)
    outputs = {}
    for workers in (1, 2, 3):
        monkeypatch.setattr(stage, "MAX_WORKERS", workers)
        out = tmp_path / f"r{workers}"
        adapt_grid(params, 7, samples_dir, calibration, g_dir, out)
        outputs[workers] = {
            p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()
        }
        for name in [n for n in outputs[workers] if n.name == contracts.RUN_RECORD]:
            # the run records list the model files by their path, folder included
            outputs[workers][name] = outputs[workers][name].replace(out.name.encode(), b"r")
    assert any(p.suffix == ".pt" for p in outputs[1])
    assert outputs[1] == outputs[2] == outputs[3]


def test_the_shrink_evidence_is_measured_on_one_thread(
    tmp_path, samples_dir, params, calibration, monkeypatch
):
    """G's predictions for the evidence run in the stage's own process on one thread, as
    every job does: MKL sums in an order fixed only by a fixed thread count."""
    from rwhonet.stages import adapt as stage

    seen = []
    measure = stage.Evidence.measure.__func__

    def spy(cls, *args, **kwargs):
        seen.append(torch.get_num_threads())
        return measure(cls, *args, **kwargs)

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        monkeypatch.setattr(stage.Evidence, "measure", classmethod(spy))
        adapt_grid(params, 7, samples_dir, calibration, write_g(tmp_path / "g", 8), tmp_path / "r")
        assert seen == [1] and torch.get_num_threads() == 2  # and the process's own again
    finally:
        torch.set_num_threads(before)


@pytest.mark.slow  # a fresh interpreter importing torch and pandas
def test_the_stage_process_never_imports_lightning(tmp_path, samples_dir, g_dir, calibration):
    code = f"""
import sys
from pathlib import Path
from rwhonet.config import load_params
from rwhonet.stages.adapt import adapt_grid
from rwhonet.tracking import timings
timings.timings_dir = lambda root=None: Path({str(tmp_path)!r}) / "timings"  # not the project's
params = load_params(overrides={OVERRIDES!r})
out = Path({str(tmp_path)!r}) / "r"
adapt_grid(params, 7, Path({str(samples_dir)!r}), Path({str(calibration)!r}),
           Path({str(g_dir)!r}), out)
print(sorted(m for m in sys.modules if m.split(".")[0] in ("lightning", "pytorch_lightning")))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"  # after the stage's progress lines


def test_shrink_sizes_its_update_by_evidence_from_the_training_drives_only(
    tmp_path, g_dir, calibration
):
    """evidence.json: the target car's training drives (each left out of its own selection
    run) and the source car's; every shrink model is the recipe run with that evidence."""
    from rwhonet.models.adapt import ShrinkEvidence, evidence_terms, shrink_evidence

    samples = write_samples(
        tmp_path / "samples",
        [
            ("A__s0", "A", "target_test", 300),
            ("B__s0", "B", "target_test", 250),
            *((f"T{i}__s0", f"T{i}", "target_train", 200 + 20 * i) for i in range(3)),
            *((f"S{i}__s0", f"S{i}", "source_train", 150) for i in range(2)),
        ],
    )
    params = load_params(
        paths.PARAMS,
        overrides={
            **OVERRIDES,
            "adapt.recipes": ["radius+G", "shrink", "continuous_shrink"],
            "adapt.recipe": "shrink",
            "adapt.fallback.recipe": "shrink",
        },
    )
    out = tmp_path / "r"
    records, _ = adapt_grid(params, 7, samples, calibration, g_dir, out)
    assert [(r.tags["recipe"], r.tags.get("m")) for r in records][-3:] == [
        ("shrink", "10"),
        ("shrink", "20"),
        ("continuous_shrink", None),
    ]
    saved = json.loads((out / contracts.SHRINK_EVIDENCE).read_text())
    target = ShrinkEvidence.from_dict(saved["target"], "evidence.json")
    assert target.role == "target_train" and target.drives == ("T0", "T1", "T2")
    assert ShrinkEvidence.from_dict(saved["source"], "x").drives == ("S0", "S1")
    # measured on G's residuals of the training drives, as the recipe's own code measures
    g_net, g_hp = load_whonet(g_dir / contracts.MODEL_FILE)
    train = load_role(samples, contracts.TARGET_TRAIN, 1)
    source = load_role(samples, ("source_train",), 1)

    def terms(s):
        f = s.frame
        return evidence_terms(
            f["drive"].to_numpy(),
            f["k"].to_numpy(),
            f["disp_gnss_m"].to_numpy(),
            f["angle_rl_rad"].to_numpy(),
            f["angle_rr_rad"].to_numpy(),
            predict(g_net, s.x).astype(np.float64),
            source_radii=(R_CAL_M, R_CAL_M),
            min_speed_m_s=2.0,
            min_rest_s=params.adapt.shrink.min_rest_s,
        )

    spread = terms(source).scale
    assert target == shrink_evidence(terms(train), "target_train", spread_of=spread)
    test = load_role(samples, contracts.TARGET_TEST, 1)
    drive, k = test.frame["drive"].to_numpy(), test.frame["k"].to_numpy()
    for m in (10, 20):
        for d in ("A", "B"):
            again = recalibrate(
                "shrink",
                g_net,
                g_hp,
                adapt_data(test, (drive == d) & (k < m)),
                adapt=params.adapt,
                seed=7,
                min_speed_m_s=2.0,
                evidence=target,
                source_radii=(R_CAL_M, R_CAL_M),
            )
            assert load_wpm_radii(out / "shrink" / f"m{m}" / f"{d}.pt") == again.radii
            assert 0 < again.info["shrink_weight"] < 1
    # a training drive scored for the selection is left out of its own evidence
    t_drive, t_k = train.frame["drive"].to_numpy(), train.frame["k"].to_numpy()
    loo = shrink_evidence(terms(train), "target_train", exclude="T1", spread_of=spread)
    assert loo.drives == ("T0", "T2")
    again = recalibrate(
        "shrink",
        g_net,
        g_hp,
        adapt_data(train, (t_drive == "T1") & (t_k < 20)),
        adapt=params.adapt,
        seed=7,
        min_speed_m_s=2.0,
        evidence=loo,
        source_radii=(R_CAL_M, R_CAL_M),
    )
    selection = pd.read_parquet(out / "selection" / "target_train.parquet")
    np.testing.assert_array_equal(
        selection.loc[selection["drive"] == "T1", "pred_m__R[shrink]@20"].to_numpy(),
        label_prediction(again, adapt_data(train, t_drive == "T1"), (R_CAL_M, R_CAL_M)),
    )
    assert "pred_m__R[continuous_shrink]/30s" in selection.columns
    cont = pd.read_parquet(out / "continuous_shrink" / contracts.PREDICTIONS)
    for L in (30, 60):
        covered = np.flatnonzero(np.isfinite(cont[f"pred_m_{L}s"].to_numpy()))
        np.testing.assert_array_equal(
            covered, np.sort(outage_windows(test.frame, [10, 20], L).ravel())
        )
