"""The exported ONNX graph reproduces PyTorch on real samples (the label code's, from a drive)."""

import numpy as np
import pytest

from rwhonet.features.calibration import Calibration
from rwhonet.models.loop import predict
from rwhonet.models.onnx import export_onnx
from rwhonet.serve.model import ServedMeta, ServedModel
from support.serving import RADIUS_M, SCALER, base_net, write_drive


@pytest.fixture(scope="module")
def real_samples(tmp_path_factory):
    """Samples of a drive file through the pipeline's ingest, validate and label code."""
    from rwhonet.cli.drive import calibration_of, load_drive
    from rwhonet.config import load_params

    drive = write_drive(tmp_path_factory.mktemp("d") / "V-Wavy.csv", duration_s=600)
    cal: Calibration = calibration_of((RADIUS_M, RADIUS_M), "test")
    return load_drive(
        drive,
        load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=cal,
        scaler=SCALER,
        wpm_mode="integrated",
        seq_len=1,
    ).samples


def _meta(hparams):
    return ServedMeta(hparams, SCALER.to_dict(), (RADIUS_M, RADIUS_M), "integrated")


@pytest.mark.parametrize("seed", [0, 1])
def test_onnx_matches_pytorch_to_1e_5_on_real_samples(real_samples, tmp_path, seed):
    net, hp = base_net(seed)
    path = export_onnx(net, hp, tmp_path / "g.onnx", {"rwhonet": _meta(hp).to_json()})
    x = real_samples.x
    assert len(x) >= 500 and x.shape[1:] == (1, 40)
    diff = np.abs(ServedModel(path).predict(x) - predict(net, x, seq_len=1))
    assert diff.max() < 1e-5


def test_the_general_rnn_path_exports_too(tmp_path):
    net, hp = base_net(3, seq_len=4)
    path = export_onnx(net, hp, tmp_path / "g4.onnx", {"rwhonet": _meta(hp).to_json()})
    x = np.random.default_rng(0).uniform(0, 1, (64, 4, 40)).astype(np.float32)
    served = ServedModel(path)
    assert served.meta.seq_len == 4
    assert np.abs(served.predict(x) - predict(net, x, seq_len=4)).max() < 1e-5
