"""The Model Registry: one version per model and execution, tags, and pyfunc models that predict."""

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts as k
from rwhonet.tracking.records import RunRecord
from rwhonet.tracking.registry import (
    chosen_records,
    input_example,
    navigation_meta,
    register_execution,
    registered_name,
    resolve_model,
)
from rwhonet.tracking.store import open_store
from support.nopickle import forbid_pickle
from support.serving import SCALER, base_bundle

mlflow = pytest.importorskip("mlflow")


@pytest.fixture
def store(store_uri, monkeypatch):
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    return store_uri


def pipeline_file(folder, **kwargs):
    """A ``model.pt`` as the pipeline's stages write one (:func:`base_bundle`'s source)."""
    base_bundle(folder, **kwargs)
    return folder / "source.pt"


@pytest.fixture
def pipeline_outputs(tmp_path):
    """Model files, scaler, calibration and samples in the layout the stages write."""
    from rwhonet.io import write_json

    g = pipeline_file(tmp_path / "g", seed=0)
    s = pipeline_file(tmp_path / "s", seed=1)
    r = pipeline_file(tmp_path / "r", seed=2, wpm_radii=(0.3, 0.297))
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


def register(store, out, execution, models_root=None, eval_path=None):
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
            models_root=models_root or root / "models",
            eval_path=eval_path or root / "no-eval.json",
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
    r = load_served(resolve_model("models:/whonet-R-target/1", store, tmp_path / "r"))
    assert r.meta.wpm_radii == (0.3, 0.297)  # the model file's own radii travel with it
    assert r.meta.source_radii == (0.294, 0.2938)
    g = mlflow.pyfunc.load_model("models:/whonet-G/1")
    assert np.isfinite(g.predict(frame[list(k.FEATURE_COLUMNS)])["pred_m"]).all()  # no angles


def test_every_model_carries_the_shrink_evidence_of_its_seed(store, pipeline_outputs, tmp_path):
    from rwhonet.io import write_json
    from rwhonet.serve.model import load_served

    models = tmp_path / "models"
    for seed in (42, 43):
        (models / "r" / f"seed{seed}").mkdir(parents=True)
    evidence = {"target": {"role": "target_train", "prior_sd": 0.004}, "source": None}
    write_json(models / "r" / "seed42" / k.SHRINK_EVIDENCE, evidence)
    write_json(models / "r" / "seed43" / k.SHRINK_EVIDENCE, {"target": None, "source": None})
    register(store, pipeline_outputs, "e1", models)
    for name in ("whonet-G", "whonet-S", "whonet-R-target"):  # the first seed's, 42
        served = load_served(resolve_model(f"models:/{name}/1", store, tmp_path / name))
        assert served.meta.evidence == evidence
    register(store, pipeline_outputs, "e2", tmp_path / "nothing")
    g = load_served(resolve_model("models:/whonet-G/2", store, tmp_path / "g2"))
    assert g.meta.evidence is None  # no adapt stage ran: nothing to carry


EVALUATED = {
    "seeds": [42, 43],
    "position": {
        "G": {
            "30s": {"calib_scale": 0.7, "calib_dof": 8.0},
            "180s": {"calib_scale": 0.6, "calib_dof": 10.0},
        },
        "R": {"30s": {"calib_scale": 0.9, "calib_dof": None}},
    },
    "position_controls": {
        "receiver": {"sigma_m": 2.72, "tau_s": 100.0, "fitted": True},
        "geometry": {"antenna_m": [0.95, -0.2], "gyro_latency_s": 0.11, "fitted": True},
        "gyro": {"instability_deg_s": 0.0042, "fitted": True},
    },
    "uncertainty": {"models": {"G": {"a_m2": 0.002, "outage_scale": {"30s": 8.4, "180s": 18.8}}}},
}


def test_navigation_meta_takes_the_model_s_calibration_and_the_receiver_from_eval_json():
    g = navigation_meta(EVALUATED, "G", "target")
    assert g["vehicle"] == "target" and g["receiver_sigma_m"] == 2.72
    assert g["receiver_tau_s"] == 100.0
    assert g["antenna_m"] == [0.95, -0.2] and g["gyro_latency_s"] == 0.11
    assert g["gyro_instability_deg_s"] == 0.0042
    assert g["outage_scale"] == {"30": 8.4, "180": 18.8}
    assert navigation_meta(EVALUATED, "R")["outage_scale"] == {}  # none measured: 1
    assert g["calibration"] == {"scales": {"30": 0.7, "180": 0.6}, "dofs": {"30": 8.0, "180": 10.0}}
    assert "fitted" in g["from"] and "[42, 43]" in g["from"]
    r = navigation_meta(EVALUATED, "R")["calibration"]  # a normal: null ν
    assert r == {"scales": {"30": 0.9}, "dofs": {"30": None}}
    assert navigation_meta(EVALUATED, "S") is None and navigation_meta({}, "G") is None


def test_every_model_carries_what_the_evaluation_measured_of_the_filter_with_it(
    store, pipeline_outputs, tmp_path
):
    from rwhonet.io import write_json
    from rwhonet.serve.model import load_served

    evaluated = tmp_path / "eval.json"
    write_json(evaluated, EVALUATED)
    register(store, pipeline_outputs, "e1", eval_path=evaluated)
    served = {
        name: load_served(resolve_model(f"models:/{name}/1", store, tmp_path / name)).meta
        for name in ("whonet-G", "whonet-S", "whonet-R-target")
    }
    assert served["whonet-G"].navigation == navigation_meta(EVALUATED, "G", "target")
    assert served["whonet-R-target"].navigation["calibration"]["scales"] == {"30": 0.9}
    assert served["whonet-S"].navigation is None  # eval.json has no position for it


def test_a_model_with_context_predicts_each_row_from_the_rows_before_it(
    store, pipeline_outputs, tmp_path
):
    """model.arch tcn: consecutive rows are the window; a change of ``segment`` restarts it."""
    from rwhonet.features.sequences import sequences
    from rwhonet.serve.model import load_served

    out = dict(pipeline_outputs)
    for key, seed in (("g", 0), ("s", 1)):
        out[key] = pipeline_file(tmp_path / f"tcn-{key}", seed=seed, arch="tcn", seq_len=8)
    r = pipeline_file(tmp_path / "tcn-r", seed=2, arch="tcn", seq_len=8)
    out["r"] = r.rename(r.with_name("V-Charlie3.pt"))
    register(store, out, "e1")
    mlflow.set_tracking_uri(store)
    frame = input_example(pipeline_outputs["frame"], 20)
    frame["segment"] = ["a"] * 12 + ["b"] * 8
    x = sequences(frame[list(k.FEATURE_COLUMNS)].to_numpy(np.float32), 8, frame["segment"])
    model = mlflow.pyfunc.load_model("models:/whonet-G/latest")
    assert "segment" in model.metadata.get_input_schema().input_names()
    served = load_served(resolve_model("models:/whonet-G/1", store, tmp_path / "served"))
    assert served.meta.seq_len == 8 and served.meta.hparams["arch"] == "tcn"
    pred = model.predict(frame)["pred_m"].to_numpy()
    np.testing.assert_allclose(pred, served.predict(x), atol=1e-7)
    one_stretch = model.predict(frame.drop(columns="segment"))["pred_m"].to_numpy()
    np.testing.assert_allclose(one_stretch[:12], pred[:12], atol=1e-7)  # the past is the same
    assert not np.allclose(one_stretch[12:], pred[12:])  # 'b' starts without 'a's seconds


def test_an_unknown_model_is_a_readable_error(store, pipeline_outputs):
    from rwhonet.errors import InputError

    register(store, pipeline_outputs, "e1")
    with pytest.raises(InputError, match="whonet-G, whonet-R-target, whonet-S"):
        resolve_model("models:/whonet-X/latest", store)


# --------------------------------------------------------------------------- models without code


def stored_folder(client, name: str, version: str = "1"):
    """Where the local store keeps a version's files (what an attacker with write access edits)."""
    from pathlib import Path

    return Path(client.get_model_version_download_uri(name, version))


def test_a_version_is_a_model_from_code_with_no_pickle_and_the_sha256_of_its_files(
    store, pipeline_outputs
):
    import yaml

    from rwhonet.serve.bundle import digests_from_text, file_digests
    from rwhonet.tracking.registry import FILES_TAG

    client, done, _ = register(store, pipeline_outputs, "e1")
    for d in done:
        folder = stored_folder(client, d["name"], d["version"])
        files = file_digests(folder)
        assert not [f for f in files if f.endswith(".pkl")], files  # no python_model.pkl
        pyfunc = yaml.safe_load((folder / "MLmodel").read_text())["flavors"]["python_function"]
        assert pyfunc["model_code_path"].endswith("pyfunc_model.py")
        assert "python_model" not in pyfunc
        assert {
            "artifacts/model.onnx",
            "artifacts/model.safetensors",
            "artifacts/rwhonet.json",
            "pyfunc_model.py",
        } <= set(files)
        assert not [f for f in files if f.endswith(".pt")], files  # the weights without pickle
        record = client.get_model_version(d["name"], d["version"]).tags[FILES_TAG]
        assert digests_from_text(record, "tag") == files


def test_a_version_carries_the_pipeline_model_file_s_weights_as_safetensors(
    store, pipeline_outputs
):
    import torch

    from rwhonet.models.checkpoint import load_whonet, load_wpm_radii

    client, done, _ = register(store, pipeline_outputs, "e1")
    for d, key in zip(done, ("g", "s", "r"), strict=True):
        stored = stored_folder(client, d["name"], d["version"]) / "artifacts" / "model.safetensors"
        net, hparams = load_whonet(stored)
        want, want_hparams = load_whonet(pipeline_outputs[key])
        assert hparams == want_hparams
        assert all(torch.equal(net.state_dict()[n], t) for n, t in want.state_dict().items())
        assert load_wpm_radii(stored) == load_wpm_radii(pipeline_outputs[key])
    assert load_wpm_radii(stored) == (0.3, 0.297)  # R's own radii travel in the file


def _change(folder):
    (folder / "artifacts" / "model.onnx").write_bytes(b"not the registered graph")


def _add_pickle(folder):
    (folder / "python_model.pkl").write_bytes(b"\x80\x04K\x01.")


def _remove(folder):
    (folder / "artifacts" / "rwhonet.json").unlink()


@pytest.mark.parametrize(
    ("tamper", "file"),
    [
        (_change, "artifacts/model.onnx"),
        (_add_pickle, "python_model.pkl"),
        (_remove, "artifacts/rwhonet.json"),
    ],
)
def test_a_version_whose_files_changed_is_refused_naming_it(
    store, pipeline_outputs, tmp_path, tamper, file
):
    from rwhonet.errors import InputError

    client, _, _ = register(store, pipeline_outputs, "e1")
    tamper(stored_folder(client, "whonet-G"))
    for spec in ("models:/whonet-G/1", "models:/whonet-G/latest"):
        with pytest.raises(InputError) as err:
            resolve_model(spec, store, tmp_path / spec.rsplit("/", 1)[1])
        assert "whonet-G version 1" in str(err.value) and file in str(err.value)
    assert resolve_model("models:/whonet-S/1", store, tmp_path / "s").is_dir()  # others stand


def test_a_version_without_its_files_record_is_refused(store, pipeline_outputs, tmp_path):
    from rwhonet.errors import InputError

    client, done, _ = register(store, pipeline_outputs, "e1")
    g = client.get_model_version("whonet-G", "1")
    client.create_model_version("whonet-G", g.source, g.run_id)  # version 2: no tags
    with pytest.raises(InputError, match="whonet-G version 2 cannot be verified"):
        resolve_model("models:/whonet-G/latest", store, tmp_path / "g")
    client.set_registered_model_alias("whonet-G", "field", "1")  # an alias pins a version
    assert resolve_model("models:/whonet-G@field", store, tmp_path / "alias").is_dir()
    # a run's folder is checked against the version registered from it
    assert resolve_model(f"runs:/{done[1]['run_id']}/model", store, tmp_path / "s").is_dir()


def test_no_pickle_is_loaded_from_the_registry_to_a_prediction(
    store, pipeline_outputs, tmp_path, monkeypatch
):
    """rwhonet predict's path (fetch, check, ONNX) and the pyfunc's path, with pickle disabled."""

    from rwhonet.serve.model import load_served
    from rwhonet.tracking.registry import load_pyfunc

    register(store, pipeline_outputs, "e1")
    frame = input_example(pipeline_outputs["frame"], 20)
    x = frame[list(k.FEATURE_COLUMNS)].to_numpy(np.float32)[:, None, :]
    angles = frame[k.ANGLE_RL_RAD].to_numpy(), frame[k.ANGLE_RR_RAD].to_numpy()

    forbid_pickle(monkeypatch)
    served = load_served(resolve_model("models:/whonet-R-target/1", store, tmp_path / "r"))
    pyfunc = load_pyfunc("models:/whonet-R-target/1", store, tmp_path / "p")
    np.testing.assert_allclose(
        pyfunc.predict(frame)["pred_m"].to_numpy(), served.predict_label(x, *angles), atol=1e-9
    )


@pytest.mark.parametrize("command", ["predict", "export", "recalibrate"])
def test_the_cli_refuses_a_tampered_version_with_exit_status_2(
    store, pipeline_outputs, tmp_path, monkeypatch, capsys, command
):
    from rwhonet.cli.main import main

    client, _, _ = register(store, pipeline_outputs, "e1")
    _change(stored_folder(client, "whonet-G"))
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store)
    out = tmp_path / "out.file"
    args = {
        "predict": ["--model", "models:/whonet-G/1", "--drive", "d.csv", "--output", str(out)],
        "export": ["--model", "models:/whonet-G/1", "--output", str(out)],
        "recalibrate": ["--base", "models:/whonet-G/1", "--drive", "d.csv"],
    }[command]
    assert main([command, *args]) == 2
    said = capsys.readouterr().err
    assert "whonet-G version 1" in said and "artifacts/model.onnx" in said
    assert not out.exists()  # nothing written from a refused model
    assert len(client.search_model_versions("name = 'whonet-R-target'")) == 1  # none registered


# --------------------------------------------------------------------------- weights without pickle

_LOADED: list[str] = []  # what the audit hook saw while a test watched (see _watch_pickle)
_WATCHING: list[bool] = []


def _audit(event, args):
    if _WATCHING and event == "pickle.find_class":
        _LOADED.append(f"{args[0]}.{args[1]}")


@pytest.fixture
def no_pickle(monkeypatch):
    """``start()``: from then on any torch.load or pickle load fails the test, and an audit
    hook records any unpickler's class lookups; it returns that record (empty: nothing was
    unpickled). Started after registering: the pipeline's own model.pt files are read then.
    """
    import sys

    if not getattr(_audit, "installed", False):  # an audit hook cannot be removed: once
        sys.addaudithook(_audit)
        _audit.installed = True

    def start():
        forbid_pickle(monkeypatch)
        _LOADED.clear()
        _WATCHING.append(True)
        return _LOADED

    try:
        yield start
    finally:
        _WATCHING.clear()


def test_export_and_recalibrate_read_a_registered_version_without_pickle(
    store, pipeline_outputs, tmp_path, monkeypatch, capsys, no_pickle
):
    """The path from the registry to a recalibrated model's prediction: no torch.load, no pickle."""
    from rwhonet.cli.main import main
    from rwhonet.models.checkpoint import load_wpm_radii
    from rwhonet.serve.bundle import file_digests
    from rwhonet.serve.model import load_served
    from support.serving import write_drive

    client, _, _ = register(store, pipeline_outputs, "e1")
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store)
    drive = write_drive(tmp_path / "V-Wavy.csv", duration_s=300)
    unpickled = no_pickle()
    with pytest.raises(AssertionError, match="a pickle was loaded"):  # the guard guards
        __import__("torch").load(pipeline_outputs["g"])

    onnx = tmp_path / "r.onnx"
    assert main(["export", "--model", "models:/whonet-R-target/1", "--output", str(onnx)]) == 0
    assert "max |ONNX - PyTorch|" in capsys.readouterr().out
    assert load_served(onnx).meta.wpm_radii == (0.3, 0.297)
    argv = ["--drive", str(drive), "--seconds", "30", "--recipe", "radius+G"]
    assert main(["recalibrate", "--base", "models:/whonet-G/1", *argv]) == 0, capsys.readouterr()
    assert "registered whonet-R-target version 2" in capsys.readouterr().out
    files = file_digests(stored_folder(client, "whonet-R-target", "2"))
    assert "artifacts/model.safetensors" in files
    assert not [f for f in files if f.endswith((".pt", ".pkl"))], files
    radii = load_wpm_radii(
        stored_folder(client, "whonet-R-target", "2") / "artifacts" / "model.safetensors"
    )
    onnx2 = tmp_path / "r2.onnx"
    assert main(["export", "--model", "models:/whonet-R-target/2", "--output", str(onnx2)]) == 0
    assert radii is not None and load_served(onnx2).meta.wpm_radii == radii
    assert unpickled == []  # no unpickler looked up a class (the audit hook's record)


def _register_old_style(client, name, pipeline_file, folder):
    """A version as rwhonet registered it before model.safetensors: its bundle holds model.pt."""
    import shutil

    import mlflow.pyfunc

    from rwhonet.serve.bundle import digests_to_text, file_digests
    from rwhonet.serve.pyfunc import MODEL_CODE
    from rwhonet.tracking.registry import FILES_TAG, MODEL_PATH

    current = stored_folder(client, name) / "artifacts"
    bundle = folder / "bundle"
    bundle.mkdir(parents=True)
    for f in ("model.onnx", "rwhonet.json"):
        shutil.copyfile(current / f, bundle / f)
    shutil.copyfile(pipeline_file, bundle / "model.pt")
    local = folder / MODEL_PATH
    mlflow.pyfunc.save_model(
        local,
        python_model=str(MODEL_CODE),
        artifacts={
            "model_onnx": str(bundle / "model.onnx"),
            "model_pt": str(bundle / "model.pt"),
            "meta": str(bundle / "rwhonet.json"),
        },
    )
    run_id = client.get_model_version(name, "1").run_id
    client.log_artifacts(run_id, str(local), "old-model")
    run = client.get_run(run_id)
    version = client.create_model_version(
        name,
        source=f"{run.info.artifact_uri}/old-model",
        run_id=run_id,
        tags={FILES_TAG: digests_to_text(file_digests(local))},
    )
    return str(version.version)


@pytest.mark.parametrize("command", ["export", "recalibrate"])
def test_a_version_registered_with_a_model_pt_is_refused_not_unpickled(
    store, pipeline_outputs, tmp_path, monkeypatch, capsys, no_pickle, command
):
    from rwhonet.cli.main import main
    from support.serving import write_drive

    client, _, _ = register(store, pipeline_outputs, "e1")
    version = _register_old_style(client, "whonet-G", pipeline_outputs["g"], tmp_path / "old")
    assert version == "2"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store)
    drive = write_drive(tmp_path / "V-Wavy.csv", duration_s=120)
    unpickled = no_pickle()
    out = tmp_path / "out.onnx"
    args = {
        "export": ["export", "--model", "models:/whonet-G/latest", "--output", str(out)],
        "recalibrate": ["recalibrate", "--base", "models:/whonet-G/2", "--drive", str(drive)],
    }[command]
    assert main(args) == 2
    said = capsys.readouterr().err
    assert "whonet-G version 2" in said and "artifacts/model.pt" in said
    assert "register the model again" in said
    assert not out.exists()
    assert len(client.search_model_versions("name = 'whonet-R-target'")) == 1  # none registered
    assert unpickled == []  # nothing was unpickled on the way to the refusal
    # `rwhonet predict` runs such a version still: it reads the ONNX file alone
    csv = tmp_path / "p.csv"
    argv = ["--model", "models:/whonet-G/2", "--drive", str(drive), "--output", str(csv)]
    assert main(["predict", *argv, "--quiet"]) == 0 and csv.is_file()


def test_predict_opens_a_registered_model_and_leaves_no_copy_behind(
    store, pipeline_outputs, tmp_path, monkeypatch
):
    import tempfile

    from rwhonet.cli.predict import open_model

    register(store, pipeline_outputs, "e1")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    served = open_model("models:/whonet-G/1", store)
    assert served.meta.seq_len > 0
    assert list(scratch.iterdir()) == []  # before: a model copy in the temp folder per run
