"""A new car in three commands, on a drive of the ``ci`` profile: recalibrate, predict, export.

Slow (fresh interpreters, MLflow): ``make test-fast`` skips it.
"""

import io
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.models.adapt import ShrinkEvidence
from rwhonet.tracking.registry import log_bundle, resolve_model, sha256_file
from rwhonet.tracking.store import open_store
from support.serving import base_bundle, ci_fleet

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """The ci fleet's drives and a store where whonet-G version 1 is registered."""
    root = tmp_path_factory.mktemp("field")
    fleet = ci_fleet(root / "sim")
    uri = f"sqlite:///{root}/mlruns/mlflow.db"
    (root / "mlruns").mkdir()
    client, exp = open_store(uri, "rwhonet")
    rid = client.create_run(exp, run_name="G").info.run_id
    frame = pd.DataFrame(np.full((3, 40), 0.5, np.float32), columns=list(k.FEATURE_COLUMNS))
    frame[k.ANGLE_RL_RAD] = frame[k.ANGLE_RR_RAD] = 30.0
    # the shrink recipe's evidence, as a pipeline run registers it (V(k) = 0.01 m² per second)
    evidence = ShrinkEvidence(
        "target_train", ("T1", "T2"), 0.01, (1, 100), (0.01, 1.0), (2, 2)
    ).to_dict()
    bundle = base_bundle(root / "g", evidence={"target": evidence, "source": None})
    assert log_bundle(client, rid, "whonet-G", bundle, frame, {"model": "G"}) == "1"
    return {"fleet": fleet, "uri": uri, "root": root, "client": client, "evidence": evidence}


def rwhonet(world, *args, stdin=None):
    env = {
        "MLFLOW_TRACKING_URI": world["uri"],
        "PYTHONPATH": str(paths.ROOT / "src"),
        "PATH": "/usr/bin:/bin",
        "HOME": str(world["root"]),
    }
    out = subprocess.run(
        [sys.executable, "-c", "import sys; from rwhonet.cli.main import entry; entry()", *args],
        input=stdin,
        env=env,
        capture_output=True,
        cwd=paths.ROOT,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr.decode()[-3000:]
    return out


def test_recalibrate_then_predict_then_export(world, tmp_path):
    from rwhonet.cli.drive import calibration_of, load_drive
    from rwhonet.config import load_params
    from rwhonet.serve.model import load_served

    drive = world["fleet"] / "target_test" / "V-Charlie3.csv"
    said = rwhonet(
        world,
        "recalibrate",
        "--base",
        "models:/whonet-G/latest",
        "--drive",
        str(drive),
        "--seconds",
        "50",
        "--recipe",
        "head",
    ).stdout.decode()
    assert "registered whonet-R-target version 1" in said and "180s" in said

    version = world["client"].get_model_version("whonet-R-target", "1")
    tags = version.tags
    assert tags["vehicle"] == "target" and tags["m"] == "50" and tags["recipe"] == "head"
    assert tags["base_version"] == "whonet-G v1" and tags["base_model"] == "models:/whonet-G/latest"
    assert tags["drive_sha256"] == sha256_file(drive) and tags["seed"] == "42"
    run = world["client"].get_run(version.run_id)
    assert run.data.metrics["R/crse/180s/mean"] > 0 and "WPM/crse/30s/mean" in run.data.metrics

    # predict streams the drive from stdin with the registered model
    out = rwhonet(
        world,
        "predict",
        "--model",
        "models:/whonet-R-target/latest",
        "--drive",
        "-",
        "--outage",
        "100:280",
        stdin=drive.read_bytes(),
    )
    streamed = pd.read_csv(io.StringIO(out.stdout.decode()))
    assert "outage 100:280 s (180 s" in out.stderr.decode()

    # ... and gives, second by second, what the model predicts on the label code's samples
    r = load_served(resolve_model("models:/whonet-R-target/1", world["uri"], tmp_path / "r"))
    assert r.meta.info["recipe"] == "head" and r.meta.wpm_radii is None
    ref = load_drive(
        drive,
        load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of(r.meta.source_radii, "r"),
        scaler=r.scaler,
        wpm_mode=r.meta.wpm_mode,
        seq_len=1,
    ).samples
    t = ref.frame["t_s"].to_numpy()
    common, i, j = np.intersect1d(streamed["t_s"].to_numpy(), t, return_indices=True)
    assert len(common) >= 0.95 * len(t)
    np.testing.assert_allclose(
        streamed["pred_error_m"].to_numpy()[i], r.predict(ref.x[j]), atol=6e-5
    )
    np.testing.assert_allclose(
        streamed["disp_wpm_m"].to_numpy()[i], ref.frame[k.DISP_WPM_M].to_numpy()[j], atol=6e-5
    )

    # a second recalibration (the default recipe, shrink: it says how sure it is) is the next
    # version; export writes the model as one file
    said = rwhonet(
        world,
        "recalibrate",
        "--drive",
        str(world["fleet"] / "target_test" / "V-Delta2.csv"),
        "--seconds",
        "30",
    ).stdout.decode()
    assert "by `shrink` (adapt.fallback (adapt.recipe: auto))" in said
    assert "(95 % interval " in said and "% of the refit is kept" in said
    assert "(evidence: 2 drives, target_train)" in said
    second = world["client"].get_model_version("whonet-R-target", "2")
    assert second.tags["recipe"] == "shrink" and second.tags["m"] == "30"
    onnx = tmp_path / "r2.onnx"
    rwhonet(
        world,
        "export",
        "--model",
        "models:/whonet-R-target/2",
        "--format",
        "onnx",
        "--output",
        str(onnx),
    )
    served = load_served(onnx).meta
    assert served.wpm_radii is not None  # shrink carries its radii...
    assert served.evidence["target"] == world["evidence"]  # ... and the evidence, to go on
