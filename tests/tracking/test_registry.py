"""The Model Registry: one version per model and execution, tags, and pyfunc models that predict."""

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts as k
from rwhonet.tracking.records import RunRecord
from rwhonet.tracking.registry import (
    chosen_records,
    input_example,
    register_execution,
    registered_name,
    resolve_model,
)
from rwhonet.tracking.store import open_store
from support.serving import SCALER, base_bundle

mlflow = pytest.importorskip("mlflow")


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = f"sqlite:///{tmp_path}/mlruns/mlflow.db"
    (tmp_path / "mlruns").mkdir()
    return uri


@pytest.fixture
def pipeline_outputs(tmp_path):
    """Model files, scaler, calibration and samples in the layout the stages write."""
    from rwhonet.io import write_json

    g = base_bundle(tmp_path / "g", seed=0)["model_pt"]
    s = base_bundle(tmp_path / "s", seed=1)["model_pt"]
    r = base_bundle(tmp_path / "r", seed=2, wpm_radii=(0.3, 0.297))["model_pt"]
    r_drive = r.with_name("V-Charlie3.pt")
    r.rename(r_drive)
    write_json(tmp_path / "scaler.json", SCALER.to_dict())
    write_json(tmp_path / "calibration.json", {"r_rl_m": 0.294, "r_rr_m": 0.2938})
    samples = tmp_path / "samples"
    samples.mkdir()
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(
        rng.uniform(0, 1, (20, 40)).astype(np.float32), columns=list(k.FEATURE_COLUMNS)
    )
    frame[k.ANGLE_RL_RAD] = rng.uniform(20, 40, 20)
    frame[k.ANGLE_RR_RAD] = frame[k.ANGLE_RL_RAD] * 1.01
    frame.to_parquet(samples / "V-Charlie3__s000.parquet")
    entry = {
        "segment": "V-Charlie3__s000",
        "drive": "V-Charlie3",
        "role": "target_test",
        "vehicle": "target",
        "n_seconds": 20,
    }
    write_json(samples / "manifest.json", {"segments": [entry]})
    return {"g": g, "s": s, "r": r_drive, "root": tmp_path, "frame": frame}


def records(out, seeds=(42, 43)):
    params = {"label.wpm_mode": "integrated"}
    recs = []
    for seed in seeds:
        recs.append(
            RunRecord(
                f"G seed {seed}",
                tags={"model": "G", "seed": str(seed), "vehicle": "source"},
                params=params,
                artifacts=[str(out["g"])],
            )
        )
        recs.append(
            RunRecord(
                f"S seed {seed}",
                tags={"model": "S", "seed": str(seed), "vehicle": "target"},
                params=params,
                artifacts=[str(out["s"])],
            )
        )
        for chosen in (False, True):
            tags = {
                "model": "R",
                "seed": str(seed),
                "vehicle": "target",
                "recipe": "radius+G",
                "m": "50",
            }
            if chosen:
                tags["chosen"] = "true"
            recs.append(
                RunRecord(f"R seed {seed}", tags=tags, params=params, artifacts=[str(out["r"])])
            )
    return recs


def test_the_first_seeds_g_s_and_chosen_r_are_picked():
    recs = records({"g": __file__ + ".pt", "s": "x.pt", "r": "y.pt"})
    assert chosen_records(recs) == {}  # no model file exists: nothing to register
    assert (
        registered_name("R", "target") == "whonet-R-target" and registered_name("G") == "whonet-G"
    )


def register(store, out, execution):
    client, exp = open_store(store, "t")
    logged = []
    for rec in records(out):
        logged.append((rec, client.create_run(exp, run_name=rec.name, tags=rec.tags).info.run_id))
    root = out["root"]
    return (
        client,
        register_execution(
            client,
            logged,
            common_tags={"rwhonet.execution": execution},
            scaler_path=root / "scaler.json",
            calibration_path=root / "calibration.json",
            samples_dir=root / "samples",
        ),
        logged,
    )


def test_an_execution_registers_one_version_per_model_with_tags(store, pipeline_outputs):
    client, done, logged = register(store, pipeline_outputs, "e1")
    assert [(d["name"], d["version"]) for d in done] == [
        ("whonet-G", "1"),
        ("whonet-S", "1"),
        ("whonet-R-target", "1"),
    ]
    runs = {rid: rec for rec, rid in logged}
    assert runs[done[0]["run_id"]].tags["seed"] == "42"  # the first seed's
    assert runs[done[2]["run_id"]].tags.get("chosen") == "true"
    r = client.get_model_version("whonet-R-target", "1")
    assert r.tags["recipe"] == "radius+G" and r.tags["m"] == "50" and r.tags["seed"] == "42"
    assert r.tags["drive"] == "V-Charlie3" and r.tags["rwhonet.execution"] == "e1"
    assert r.tags["base_model"] == "whonet-G" and r.run_id == done[2]["run_id"]
    _, again, _ = register(store, pipeline_outputs, "e2")
    assert [d["version"] for d in again] == ["2", "2", "2"]
    assert client.get_model_version("whonet-G", "2").tags["rwhonet.execution"] == "e2"


def test_pyfunc_models_predict_the_label_from_the_feature_window(store, pipeline_outputs, tmp_path):
    from rwhonet.serve.model import load_served

    register(store, pipeline_outputs, "e1")
    mlflow.set_tracking_uri(store)
    frame = input_example(pipeline_outputs["frame"], 20)
    x = frame[list(k.FEATURE_COLUMNS)].to_numpy(np.float32)[:, None, :]
    for name in ("whonet-G", "whonet-S", "whonet-R-target"):
        model = mlflow.pyfunc.load_model(f"models:/{name}/latest")
        assert model.metadata.signature is not None
        assert model.metadata.get_input_schema().input_names()[:2] == ["x_00", "x_01"]
        pred = model.predict(frame)["pred_m"].to_numpy()
        served = load_served(resolve_model(f"models:/{name}/1", store, tmp_path / name))
        angles = frame[k.ANGLE_RL_RAD].to_numpy(), frame[k.ANGLE_RR_RAD].to_numpy()
        np.testing.assert_allclose(pred, served.predict_label(x, *angles), atol=1e-9)
    r = load_served(tmp_path / "whonet-R-target")
    assert r.meta.wpm_radii == (0.3, 0.297)  # the model file's own radii travel with it
    assert r.meta.source_radii == (0.294, 0.2938)
    g = mlflow.pyfunc.load_model("models:/whonet-G/1")
    assert np.isfinite(g.predict(frame[list(k.FEATURE_COLUMNS)])["pred_m"]).all()  # no angles


def test_an_unknown_model_is_a_readable_error(store, pipeline_outputs):
    from rwhonet.errors import InputError

    register(store, pipeline_outputs, "e1")
    with pytest.raises(InputError, match="whonet-G, whonet-R-target, whonet-S"):
        resolve_model("models:/whonet-X/latest", store)
