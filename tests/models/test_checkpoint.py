"""Model files: one format for G, S and R, read without running pickled code.

The ``.safetensors`` form (what a registered version carries) is read without pickle at all.
"""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import torch
from safetensors.torch import save_file

from rwhonet.errors import InputError
from rwhonet.models.checkpoint import (
    FORMAT,
    META_KEY,
    load_whonet,
    load_wpm_radii,
    save_whonet,
    to_safetensors,
)
from rwhonet.models.loop import net_from_hparams, predict
from rwhonet.models.whonet import WhONet
from support.nopickle import forbid_pickle

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


# --------------------------------------------------------------------------- safetensors form

ARCH_HP = {
    "whonet": HP,
    "gru": {**HP, "arch": "gru"},
    "tcn": {**HP, "seq_len": 8, "arch": "tcn", "channels": 16},
}


def _no_pickle(monkeypatch):
    """Make torch.load and every pickle loader fail the test if anything calls them."""
    forbid_pickle(monkeypatch)


@pytest.mark.parametrize("arch", sorted(ARCH_HP))
@pytest.mark.parametrize("radii", [None, (0.3012, 0.2987)])
def test_the_safetensors_form_is_the_same_model_read_without_pickle(
    tmp_path, linear_data, monkeypatch, arch, radii
):
    hp = ARCH_HP[arch]
    torch.manual_seed(5)
    net = net_from_hparams(hp)
    save_whonet(net, hp, tmp_path / "model.pt", wpm_radii=radii)
    converted = to_safetensors(tmp_path / "model.pt", tmp_path / "model.safetensors")
    save_whonet(net, hp, tmp_path / "direct.safetensors", wpm_radii=radii)
    # one model is one file, byte for byte, however it was written
    assert converted.read_bytes() == (tmp_path / "direct.safetensors").read_bytes()
    _no_pickle(monkeypatch)
    loaded, hp2 = load_whonet(converted)
    assert hp2 == hp and not loaded.training
    assert load_wpm_radii(converted) == radii
    want, got = net.state_dict(), loaded.state_dict()
    assert list(got) == list(want)
    assert all(torch.equal(got[k], want[k]) for k in want)
    x, _ = linear_data
    x = np.repeat(x, hp["seq_len"], axis=1) if hp["seq_len"] > 1 else x
    np.testing.assert_array_equal(
        predict(loaded, x, seq_len=hp["seq_len"]), predict(net, x, seq_len=hp["seq_len"])
    )


def _write(path, tensors, meta):
    save_file(tensors, str(path), metadata=meta)
    return path


def _entry(**fields):
    return {META_KEY: json.dumps(fields)}


def test_a_malformed_safetensors_file_is_refused_naming_what_is_wrong(tmp_path, monkeypatch):
    net = WhONet(40, 6)
    save_whonet(net, HP, tmp_path / "model.pt")
    (tmp_path / "renamed.safetensors").write_bytes((tmp_path / "model.pt").read_bytes())
    (tmp_path / "garbage.safetensors").write_bytes(b"not a model")
    weights = {k: v.contiguous() for k, v in net.state_dict().items()}
    _no_pickle(monkeypatch)  # a .safetensors file is never handed to torch.load
    for name in ("renamed", "garbage"):
        with pytest.raises(InputError, match="a WhONet model file \\(safetensors\\)") as err:
            load_whonet(tmp_path / f"{name}.safetensors")
        assert err.value.problems[0].file == str(tmp_path / f"{name}.safetensors")
    cases = {
        "no_metadata": ({}, f"metadata.{META_KEY}", "no such entry"),
        "not_json": ({META_KEY: "{oops"}, f"metadata.{META_KEY}", "'{oops'"),
        "other_format": (
            _entry(format="other/1", hyper_parameters=HP),
            "format",
            "'other/1'",
        ),
        "no_seq_len": (
            _entry(format=FORMAT, hyper_parameters={k: v for k, v in HP.items() if k != "seq_len"}),
            "hyper_parameters",
            "'hidden'",
        ),
        "unknown_arch": (
            _entry(format=FORMAT, hyper_parameters={**HP, "arch": "lstm"}),
            "hyper_parameters.arch",
            "'lstm'",
        ),
        "bad_radii": (
            _entry(format=FORMAT, hyper_parameters=HP, wpm_radii=[0.3]),
            "wpm_radii",
            "[0.3]",
        ),
        "wrong_shape": (
            _entry(format=FORMAT, hyper_parameters={**HP, "hidden": 7}),
            "state_dict",
            "size mismatch",
        ),
    }
    for name, (meta, column, found) in cases.items():
        path = _write(tmp_path / f"{name}.safetensors", weights, meta)
        with pytest.raises(InputError, match="not a WhONet model file") as err:
            load_whonet(path)
        problem = err.value.problems[0]
        assert (problem.file, problem.column) == (str(path), column), name
        assert found in problem.found, (name, problem.found)
    with pytest.raises(InputError) as err:  # the radii are read with the same checks
        load_wpm_radii(tmp_path / "bad_radii.safetensors")
    assert err.value.problems[0].column == "wpm_radii"
    with pytest.raises(ValueError, match=".safetensors"):
        to_safetensors(tmp_path / "direct.safetensors", tmp_path / "out.pt")
