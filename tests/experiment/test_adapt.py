"""adapt@m: R-WhONet per test drive, fine-tuned on the lean path in a Lightning-free process."""

import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
import torch

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.experiment.adapt import CHECKPOINT, PREDICTIONS, RUN_RECORD
from rwhonet.experiment.samples import load_role
from rwhonet.models.train import fine_tune, fit, load_module, predict, save_checkpoint

OVERRIDES = {"adapt.m_grid": [10, 20], "adapt.chosen_m": 20, "adapt.epochs": 3}

# The stage's work in a fresh interpreter, as `python pipelines/adapt.py M` runs it.
ADAPT_CHILD = """
import json, sys
from pathlib import Path
from rwhonet.config import load_params
from rwhonet.experiment.adapt import adapt_m

job = json.loads(sys.argv[1])
params = load_params(overrides=job["overrides"])
adapt_m(params, job["m"], Path(job["samples"]), Path(job["g"]), Path(job["out"]))
loaded = sorted(m for m in sys.modules if m.partition(".")[0] in ("lightning", "pytorch_lightning"))
assert not loaded, loaded
"""


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides=OVERRIDES)


@pytest.mark.slow  # a fresh interpreter importing torch and pandas: about 5 s
def test_adapt_stage_runs_without_lightning_and_matches_the_lightning_fine_tune(
    tmp_path, samples_dir, params
):
    m = 20
    g_dir = tmp_path / "g"
    source = load_role(samples_dir, "target_train", params.model.seq_len)
    train = replace(params.train, epochs=2)
    save_checkpoint(
        fit(source.x, source.y, model=params.model, train=train, seed=params.seed),
        g_dir / CHECKPOINT,
    )
    out = tmp_path / "r" / f"m{m}"
    job = {"overrides": OVERRIDES, "m": m, "samples": str(samples_dir), "g": str(g_dir),
           "out": str(out)}  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-c", ADAPT_CHILD, json.dumps(job)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr

    test = load_role(samples_dir, "target_test", params.model.seq_len)
    drive, k = test.frame["drive"].to_numpy(), test.frame["k"].to_numpy()
    preds = pd.read_parquet(out / PREDICTIONS)
    assert len(preds) == len(test) and set(preds["drive"]) == {"A", "B"}
    for d in ("A", "B"):
        first = (drive == d) & (k < m)
        lit = fine_tune(g_dir / CHECKPOINT, test.x[first], test.y[first], adapt=params.adapt,
                        seed=params.seed)  # fmt: skip
        r = load_module(out / f"{d}.ckpt")
        assert dict(r.hparams) == dict(lit.module.hparams)
        for (name, a), b in zip(
            r.state_dict().items(), lit.module.state_dict().values(), strict=True
        ):
            assert torch.equal(a, b), name
        on_drive = test.take(drive == d)
        np.testing.assert_array_equal(
            preds.loc[preds["drive"] == d, "pred_m"].to_numpy(),
            predict(lit.module, on_drive.x).astype(np.float64),
        )

    with open(out / RUN_RECORD) as f:
        record = json.load(f)
    assert record["tags"]["dvc_stage"] == f"adapt@{m}"
    assert [c["tags"]["drive"] for c in record["children"]] == ["A", "B"]
    assert all(c["metrics"]["n_adapt_samples"] == m for c in record["children"])
    assert record["metrics"]["n_trainable_params"] == record["metrics"]["n_total_params"]
