"""G's training under DDP: two CPU processes (gloo) match one, and only rank 0 writes.

Two processes at ``batch_size`` 64 take the same global mini-batches as one
process at 128 (``rwhonet.models.loop.ShardSampler``), and DDP averages their
gradients, so without dropout the two runs differ only by floating-point
summation order: the losses and predictions must agree to 1e-4 m. With
dropout each process draws its own masks, so the runs would differ by chance
rather than by rounding; a process whose gradients were not averaged would
follow its own half of every mini-batch and miss that tolerance.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts, paths
from rwhonet.config import load_params
from rwhonet.contracts import FEATURE_COLUMNS
from rwhonet.stages.train import train_model
from support.drives import write_params_yaml

from .conftest import write_samples

SEED = 7
SEGMENTS = [
    ("S__s0", "S", "source_train", 1400),
    ("S__s1", "S", "source_train", 1000),
    ("A__s0", "A", "target_test", 300),
    ("T__s0", "T", "target_train", 100),
]


def _learnable_samples(folder):
    """Samples whose label is a function of the features, so training has something to fit."""
    write_samples(folder, SEGMENTS)
    for seg, *_ in SEGMENTS:
        path = folder / f"{seg}.parquet"
        df = pd.read_parquet(path)
        x = df[list(FEATURE_COLUMNS)].to_numpy()
        df["label_m"] = 0.4 * x[:, 0] - 0.3 * x[:, 5] + 0.2 * x[:, 17] * x[:, 30]
        df.to_parquet(path, index=False)
    return folder


def test_a_process_other_than_rank_0_writes_nothing(tmp_path, monkeypatch):
    from rwhonet.models import train as models_train

    real_fit = models_train.fit

    def fit_as_rank_1(*args, **kwargs):
        return dataclasses.replace(real_fit(*args, **kwargs), global_rank=1, world_size=2)

    monkeypatch.setattr(models_train, "fit", fit_as_rank_1)
    params = load_params(paths.PARAMS, overrides={"train.epochs": 1, "model.hidden": 8})
    samples = write_samples(tmp_path / "samples", SEGMENTS)
    assert train_model(params, "G", SEED, samples, tmp_path / "g") is None
    assert not (tmp_path / "g").exists()


def _train_g(root, **overrides):
    """``pipelines/train.py G`` in a project at ``root`` with these params; its output."""
    write_params_yaml(
        root / "params.yaml", **{"train.epochs": 6, "model.dropout": 0.0, **overrides}
    )
    shutil.rmtree(root / "models", ignore_errors=True)
    out = subprocess.run(
        [sys.executable, str(paths.ROOT / "pipelines" / "train.py"), "G", "--seed", str(SEED)],
        cwd=root,
        env={**_env(), "RWHONET_ROOT": str(root)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    folder = root / "models" / "g" / f"seed{SEED}"
    record = json.loads((folder / contracts.RUN_RECORD).read_text())
    pred = pd.read_parquet(folder / contracts.PREDICTIONS)["pred_m"].to_numpy()
    return out.stdout, record, pred


def _env():
    env = dict(os.environ, PYTHONPATH=str(paths.ROOT / "src"))  # this checkout's code
    env.pop("MLFLOW_TRACKING_URI", None)
    return env


@pytest.mark.slow  # three processes, one of them DDP's second rank
def test_ddp_on_two_cpu_processes_matches_one_process(tmp_path):
    root = tmp_path / "project"
    _learnable_samples(root / "data" / "processed" / "samples")
    shutil.copy(paths.ROOT / "dvc.yaml", root / "dvc.yaml")

    one_out, one, one_pred = _train_g(root, **{"train.batch_size": 128})
    two_out, two, two_pred = _train_g(
        root,
        **{
            "train.batch_size": 64,
            "train.trainer.strategy": "ddp",
            "train.trainer.devices": 2,
        },
    )

    # One writer: rank 0 reports its outputs, rank 1 says it wrote nothing.
    assert one_out.count(f"-> models/g/seed{SEED}") == 1
    assert two_out.count(f"-> models/g/seed{SEED}") == 1, two_out
    assert two_out.count("other than rank 0, writes nothing") == 1, two_out
    assert two["params"]["train.trainer.strategy"] == "ddp"

    first, last = one["history"][0], one["history"][-1]
    assert last["train/loss"] < 0.5 * first["train/loss"]  # it learnt something
    for h1, h2 in zip(one["history"], two["history"], strict=True):
        for key in ("train/loss", "val/loss"):
            assert h2[key] == pytest.approx(h1[key], abs=1e-4), (h1, h2)
    assert np.max(np.abs(two_pred - one_pred)) < 1e-4
