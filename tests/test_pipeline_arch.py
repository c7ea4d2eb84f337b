"""Integration: the ci pipeline with a network with temporal context, then serving its models.

``model.arch: tcn`` with 16 s windows, otherwise the slow tests' ci pipeline
(``support.project.CI_PIPELINE``): every stage and every recipe run on it, the
evaluation scores the same seconds and windows as the WhONet pipeline (its
network-free cells are those of ``tests/evaluation/fixtures/ci_pipeline_before``,
the WhONet pipeline's), and a registered model goes through ``rwhonet
recalibrate``, ``export`` and ``predict``.

Slow (a fresh pipeline); ``make test-fast`` skips it.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from support.project import CI_PIPELINE, dvc, scratch_project

pytestmark = pytest.mark.slow

OVERRIDES = {**CI_PIPELINE, ("model", "arch"): "tcn", ("model", "seq_len"): 16}
BEFORE = Path(__file__).parent / "evaluation" / "fixtures" / "ci_pipeline_before" / "eval.json"
NETWORK_FREE = ("WPM", "WPM-ref", "WPM-int", "WPM-m@")


@pytest.fixture(scope="module")
def repo(tmp_path_factory, ci_data):
    repo = scratch_project(tmp_path_factory.mktemp("tcn") / "repo", OVERRIDES, ci_data)
    out = dvc(repo, "repro")
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
    return repo


def rwhonet(repo: Path, *args: str) -> str:
    """The ``rwhonet`` command in the project (its params.yaml, its MLflow store)."""
    env = {k: v for k, v in os.environ.items() if k not in ("MLFLOW_TRACKING_URI", "RWHONET_ROOT")}
    env["PYTHONPATH"] = str(repo / "src")
    out = subprocess.run(
        [sys.executable, "-c", "from rwhonet.cli.main import entry; entry()", *args],
        cwd=repo,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    return out.stdout + out.stderr


def test_every_model_is_a_tcn_and_is_scored_on_the_whonet_pipelines_windows(repo):
    import torch

    ev = json.loads((repo / "metrics" / "eval.json").read_text())
    before = json.loads(BEFORE.read_text())
    assert {"G", "S", "R", "R[continuous]"} <= set(ev["overall"])
    for model, by_outage in before["overall"].items():
        for outage, stats in by_outage.items():
            assert ev["overall"][model][outage]["n_windows"] == stats["n_windows"], model
            if model.startswith(NETWORK_FREE):
                assert ev["overall"][model][outage] == stats, (model, outage)
    for f in (
        repo / "models" / "g" / "seed1" / "model.pt",
        repo / "models" / "s" / "seed2" / "model.pt",
        next((repo / "models" / "r" / "seed1" / "paper" / "m10").glob("*.pt")),
    ):
        hp = torch.load(f, weights_only=True)["hyper_parameters"]
        assert (hp["arch"], hp["seq_len"], hp["channels"]) == ("tcn", 16, 16), f


def test_a_registered_tcn_recalibrates_exports_and_predicts(repo, tmp_path):
    drive = repo / "data" / "sim" / "target_test" / "V-Charlie3.csv"
    said = rwhonet(
        repo,
        "recalibrate",
        "--base",
        "models:/whonet-G/latest",
        "--drive",
        str(drive),
        "--seconds",
        "20",
        "--recipe",
        "ridge_head",
    )
    assert "registered whonet-R-target" in said
    onnx = tmp_path / "r.onnx"
    said = rwhonet(
        repo, "export", "--model", "models:/whonet-R-target/latest", "--output", str(onnx)
    )
    assert "(batch, 16, 40)" in said
    out = tmp_path / "p.parquet"
    rwhonet(repo, "predict", "--model", str(onnx), "--drive", str(drive), "--output", str(out))
    frame = pd.read_parquet(out)
    assert len(frame) > 500 and frame["pred_error_m"].notna().all()
