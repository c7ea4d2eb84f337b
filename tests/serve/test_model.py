"""The served model: an ONNX file with its metadata, run by ONNX Runtime."""

import json

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.features.wpm import wpm_displacement_m
from rwhonet.serve.model import ServedMeta, ServedModel, load_served


def test_a_bundle_an_onnx_file_and_an_mlflow_layout_load_alike(bundle, tmp_path):
    onnx = bundle["model_onnx"]
    mlflow_like = tmp_path / "m" / "artifacts"
    mlflow_like.mkdir(parents=True)
    (mlflow_like / "model.onnx").write_bytes(onnx.read_bytes())
    x = np.random.default_rng(0).uniform(0, 1, (7, 1, 40)).astype(np.float32)
    preds = [load_served(p).predict(x) for p in (onnx, onnx.parent, tmp_path / "m")]
    assert all(np.array_equal(preds[0], p) for p in preds[1:])
    meta = load_served(onnx).meta
    assert meta.seq_len == 1 and meta.source_radii == (0.294, 0.294) and meta.wpm_radii is None
    assert meta.info["model"] == "G"
    assert json.loads((onnx.parent / "rwhonet.json").read_text()) == json.loads(meta.to_json())


def test_own_radii_move_the_label_prediction_by_the_wpm_difference(bundle):
    model = load_served(bundle["model_onnx"])
    own = ServedModel(
        bundle["model_onnx"], ServedMeta(**{**model.meta.__dict__, "wpm_radii": (0.30, 0.296)})
    )
    x = np.full((3, 1, 40), 0.4, np.float32)
    a_rl, a_rr = np.array([30.0, 0.0, 10.0]), np.array([31.0, 0.0, 10.5])
    shift = wpm_displacement_m(a_rl, a_rr, 0.30, 0.296) - wpm_displacement_m(
        a_rl, a_rr, 0.294, 0.294
    )
    np.testing.assert_allclose(
        own.predict_label(x, a_rl, a_rr) - model.predict_label(x), shift, atol=1e-12
    )
    # the old served formula, pred + (WPM(own) - WPM(source)): now the pipeline's one order
    np.testing.assert_allclose(
        own.predict_label(x, a_rl, a_rr), own.predict(x) + shift, rtol=0, atol=1e-12
    )
    with pytest.raises(InputError, match="rear wheel angles"):
        own.predict_label(x)


def test_what_is_not_a_served_model_is_named(tmp_path, bundle):
    with pytest.raises(InputError, match="no model at"):
        load_served(tmp_path / "nothing")
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"not onnx")
    with pytest.raises(InputError, match="not an rwhonet model"):
        load_served(junk)
    with pytest.raises(InputError, match="windows of shape"):
        load_served(bundle["model_onnx"]).predict(np.zeros((2, 40), np.float32))
    with pytest.raises(InputError, match="format"):
        ServedMeta.from_json('{"format": "other"}', "m.json")


def test_the_evaluation_s_navigation_travels_in_the_metadata_and_a_bad_one_is_named(bundle):
    meta = load_served(bundle["model_onnx"]).meta
    assert meta.navigation is None  # a bundle from before, or not evaluated: the generic filter
    nav = {
        "receiver_sigma_m": 2.7,
        "receiver_tau_s": 100.0,
        "antenna_m": [0.95, -0.2],
        "gyro_latency_s": 0.11,
        "gyro_instability_deg_s": 0.004,
        "outage_scale": {"30": 8.4, "180": 18.8},
        "calibration": {"scales": {"30": 0.7, "180": 0.6}, "dofs": {"30": 5.0, "180": None}},
        "from": "evaluate",
    }
    withnav = ServedMeta(**{**meta.__dict__, "navigation": nav})
    assert ServedMeta.from_json(withnav.to_json(), "m.json").navigation == nav
    for bad in (
        "a string",
        {"receiver_sigma_m": -1.0},
        {"gyro_latency_s": -0.1},
        {"gyro_latency_s": float("nan")},
        {"gyro_instability_deg_s": 0.0},
        {"gyro_instability_deg_s": 50.0},
        {"gyro_instability_deg_s": "0.004"},
        {"outage_scale": {"30": 0.0}},
        {"outage_scale": {"thirty": 8.0}},
        {"outage_scale": [8.0]},
        {"antenna_m": [1.0]},
        {"antenna_m": [1.0, "left"]},
        {"calibration": {"scales": {"thirty": 0.7}}},
        {"calibration": {"scales": {"30": 0.0}}},
        {"calibration": {"scales": {"30": 0.7}, "dof": "many"}},
        {"calibration": {"scales": {"30": 0.7}, "dofs": {"30": -2.0}}},
        {"calibration": {"scales": {"30": 0.7}, "dofs": [5.0]}},
    ):
        text = ServedMeta(**{**meta.__dict__, "navigation": bad}).to_json()
        with pytest.raises(InputError, match="navigation"):
            ServedMeta.from_json(text, "m.json")
