"""The adapt stage: R-WhONet per test drive and per m, from G's model file, in one process."""

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
from rwhonet.models.adapt import fine_tune
from rwhonet.models.checkpoint import load_whonet, save_whonet
from rwhonet.models.loop import predict
from rwhonet.models.whonet import WhONet
from rwhonet.stages.adapt import adapt_grid
from rwhonet.stages.samples import load_role

OVERRIDES = {"adapt.m_grid": [10, 20], "adapt.chosen_m": 20, "adapt.epochs": 3}


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides=OVERRIDES)


@pytest.fixture
def g_dir(tmp_path, params):
    torch.manual_seed(0)
    hp = {"n_features": 40, "hidden": 8, "layers": 1, "dropout": 0.05, "seq_len": 1,
          "lr": 7e-4, "batch_size": 128}  # fmt: skip
    folder = tmp_path / "g"
    folder.mkdir()
    save_whonet(WhONet(40, 8, 1, 0.05), hp, folder / contracts.MODEL_FILE)
    return folder


def test_every_drive_and_m_gets_its_own_model_from_its_first_m_seconds(
    tmp_path, samples_dir, params, g_dir
):
    records, _ = adapt_grid(params, 7, samples_dir, g_dir, tmp_path / "r")
    assert [r.tags["m"] for r in records] == ["10", "20"]
    g_net, g_hp = load_whonet(g_dir / contracts.MODEL_FILE)
    test = load_role(samples_dir, contracts.TARGET_TEST, params.model.seq_len)
    drive, k = test.frame["drive"].to_numpy(), test.frame["k"].to_numpy()
    for m in (10, 20):
        out = tmp_path / "r" / f"m{m}"
        preds = pd.read_parquet(out / contracts.PREDICTIONS)
        assert len(preds) == len(test) and set(preds["drive"]) == {"A", "B"}
        for d in ("A", "B"):
            first = (drive == d) & (k < m)
            again = fine_tune(g_net, g_hp, test.x[first], test.y[first], adapt=params.adapt,
                              seed=7)  # fmt: skip
            net, hp = load_whonet(out / f"{d}.pt")
            assert hp == {**g_hp, "lr": params.adapt.lr, "batch_size": params.adapt.batch_size}
            for (name, a), b in zip(net.state_dict().items(), again.net.state_dict().values(),
                                    strict=True):  # fmt: skip
                assert torch.equal(a, b), name
            assert not torch.equal(net.head.weight, g_net.head.weight)  # it moved from G
            np.testing.assert_array_equal(
                preds.loc[preds["drive"] == d, "pred_m"].to_numpy(),
                predict(net, test.take(drive == d).x).astype(np.float64),
            )
        record = json.loads((out / contracts.RUN_RECORD).read_text())
        assert record["tags"] == {"model": "R", "m": str(m), "vehicle": "target",
                                  "seed": "7", "dvc_stage": "adapt"}  # fmt: skip
        assert [c["tags"]["drive"] for c in record["children"]] == ["A", "B"]
        assert all(c["metrics"]["n_adapt_samples"] == m for c in record["children"])


def test_a_drive_not_longer_than_the_largest_m_is_refused(tmp_path, samples_dir, g_dir):
    params = load_params(paths.PARAMS, overrides={**OVERRIDES, "adapt.m_grid": [10, 500],
                                                  "adapt.chosen_m": 10})  # fmt: skip
    with pytest.raises(InputError, match="too short") as err:
        adapt_grid(params, 7, samples_dir, g_dir, tmp_path / "r")
    assert [p.file for p in err.value.problems] == ["A", "B"]
    assert not (tmp_path / "r").exists()


@pytest.mark.slow  # a fresh interpreter importing torch and pandas
def test_the_stage_process_never_imports_lightning(tmp_path, samples_dir, g_dir):
    code = f"""
import sys
from pathlib import Path
from rwhonet.config import load_params
from rwhonet.stages.adapt import adapt_grid
params = load_params(overrides={OVERRIDES!r})
out = Path({str(tmp_path)!r}) / "r"
adapt_grid(params, 7, Path({str(samples_dir)!r}), Path({str(g_dir)!r}), out)
print(sorted(m for m in sys.modules if m.split(".")[0] in ("lightning", "pytorch_lightning")))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
