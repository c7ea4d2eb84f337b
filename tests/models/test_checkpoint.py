"""Model files: one format for G, S and R, read without running pickled code."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import torch

from rwhonet.errors import InputError
from rwhonet.models.checkpoint import load_whonet, save_whonet
from rwhonet.models.loop import predict
from rwhonet.models.whonet import WhONet

HP = {
    "n_features": 40,
    "hidden": 6,
    "layers": 1,
    "dropout": 0.05,
    "seq_len": 1,
    "lr": 7e-4,
    "batch_size": 128,
}


def test_round_trip_gives_the_same_network(tmp_path, linear_data):
    torch.manual_seed(3)
    net = WhONet(40, 6, 1, 0.05)
    save_whonet(net, {**HP, "extra": "dropped"}, tmp_path / "model.pt")
    loaded, hp = load_whonet(tmp_path / "model.pt")
    assert hp == HP and not loaded.training
    x, _ = linear_data
    np.testing.assert_array_equal(predict(loaded, x), predict(net, x))


def test_files_that_are_not_whonet_models_are_named(tmp_path):
    torch.save({"weights": 1}, tmp_path / "other.pt")
    with pytest.raises(InputError) as err:
        load_whonet(tmp_path / "other.pt")
    assert err.value.problems[0].column == "format"
    save_whonet(WhONet(40, 6), HP, tmp_path / "m.pt")
    ckpt = torch.load(tmp_path / "m.pt", weights_only=True)
    del ckpt["hyper_parameters"]["seq_len"]
    torch.save(ckpt, tmp_path / "no_seq_len.pt")
    with pytest.raises(InputError) as err:
        load_whonet(tmp_path / "no_seq_len.pt")
    assert err.value.problems[0].column == "hyper_parameters"
    ckpt = torch.load(tmp_path / "m.pt", weights_only=True)
    ckpt["hyper_parameters"]["hidden"] = 7
    torch.save(ckpt, tmp_path / "wrong_shape.pt")
    with pytest.raises(InputError, match="weights of the saved shape"):
        load_whonet(tmp_path / "wrong_shape.pt")
    (tmp_path / "garbage.pt").write_bytes(b"not a model")
    with pytest.raises(InputError, match="not a WhONet model file"):
        load_whonet(tmp_path / "garbage.pt")


class _Payload:
    def __reduce__(self):
        return (print, ("pickled code ran",))


def test_loading_never_runs_pickled_code(tmp_path, capsys):
    with open(tmp_path / "evil.pt", "wb") as f:
        pickle.dump({"format": "rwhonet.whonet/1", "payload": _Payload()}, f, protocol=2)
    with pytest.raises(InputError):
        load_whonet(tmp_path / "evil.pt")
    assert "pickled code ran" not in capsys.readouterr().out
