"""The networks with temporal context (model.arch gru, tcn): shapes, causality, files, ONNX."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from torch import nn

from rwhonet.config import ModelParams, TrainParams
from rwhonet.errors import InputError
from rwhonet.features.sequences import sequences
from rwhonet.models.checkpoint import load_whonet, save_whonet
from rwhonet.models.freeze import apply_trainable
from rwhonet.models.gru import GRUNet
from rwhonet.models.loop import net_from_hparams, predict
from rwhonet.models.onnx import export_onnx
from rwhonet.models.tcn import TCNNet
from rwhonet.models.train import fit
from rwhonet.models.whonet import WhONet
from rwhonet.serve.model import ServedMeta, ServedModel
from support.serving import RADIUS_M, SCALER, base_net

TEMPORAL = ("gru", "tcn")


def hparams(arch: str, seq_len: int, hidden: int = 12) -> dict:
    hp = {
        "n_features": 40,
        "hidden": hidden,
        "layers": 1,
        "dropout": 0.05,
        "seq_len": seq_len,
        "lr": 0.01,
        "batch_size": 64,
    }
    if arch == "whonet":
        return hp
    return {**hp, "arch": arch, **({"channels": 6} if arch == "tcn" else {})}


def random_net(arch: str, seq_len: int, seed: int = 0) -> nn.Module:
    """A network with every weight drawn at random (non-zero biases: every term counts)."""
    torch.manual_seed(seed)
    net = net_from_hparams(hparams(arch, seq_len))
    with torch.no_grad():
        for p in net.parameters():
            p.normal_(0.0, 0.4)
    return net.eval()


@pytest.mark.parametrize("arch", TEMPORAL)
@pytest.mark.parametrize("seq_len", [1, 5, 32])
def test_one_value_per_window_and_the_heads_inputs(arch, seq_len):
    net = net_from_hparams(hparams(arch, seq_len))
    assert isinstance(net, GRUNet if arch == "gru" else TCNNet) and net.n_features == 40
    x = torch.rand(7, seq_len, 40)
    out, h = net(x), net.features(x)
    assert out.shape == (7,) and out.dtype == torch.float32 and h.shape == (7, 12)
    net.eval()
    torch.testing.assert_close(net(x), net.head(net.features(x)).squeeze(-1))


@pytest.mark.parametrize("arch", TEMPORAL)
def test_a_later_second_never_changes_an_earlier_prediction(arch):
    """Through the pipeline's windows: no look-ahead, and nothing from another segment."""
    rng = np.random.default_rng(1)
    group = np.repeat([0, 1, 0], [40, 25, 30])  # the last 0 is a segment of its own
    x = rng.uniform(0, 1, (len(group), 40)).astype(np.float32)
    net = random_net(arch, 8)
    before = predict(net, sequences(x, 8, group))
    run = np.concatenate([[0], np.cumsum(np.diff(group) != 0)])
    for i in (0, 5, 39, 40, 41, 70, 94):
        later = x.copy()
        later[i + 1 :] = rng.uniform(0, 1, later[i + 1 :].shape)
        np.testing.assert_array_equal(
            predict(net, sequences(later, 8, group))[: i + 1], before[: i + 1]
        )
        other = x.copy()
        other[run != run[i]] = rng.uniform(0, 1, other[run != run[i]].shape)
        after = predict(net, sequences(other, 8, group))
        np.testing.assert_array_equal(after[run == run[i]], before[run == run[i]])
    # and the context is real: an earlier second of the same segment does change it
    earlier = x.copy()
    earlier[30] += 0.5
    assert predict(net, sequences(earlier, 8, group))[33] != before[33]


def test_the_tcn_is_a_causal_dilated_convolution():
    """Its context equals a kernel-2 Conv1d stack with dilations 1, 2, 4, ... at the last second."""
    net = random_net("tcn", 16)
    assert (net.n_levels, net.span) == (4, 16)
    x = torch.rand(3, 16, 40)
    z = x.transpose(1, 2)  # (B, C, T)
    for i, level in enumerate(net.levels):
        conv = nn.Conv1d(level.in_features // 2, level.out_features, 2, dilation=2**i)
        with torch.no_grad():  # a level's inputs are (older, newer) side by side
            half = level.in_features // 2
            conv.weight.copy_(torch.stack([level.weight[:, :half], level.weight[:, half:]], -1))
            conv.bias.copy_(level.bias)
        z = torch.tanh(conv(nn.functional.pad(z, (2**i, 0))))  # causal: pad the past only
    with torch.no_grad():
        torch.testing.assert_close(net.context(x), z[:, :, -1], rtol=1e-5, atol=1e-6)


def test_a_tcn_window_shorter_than_its_span_is_padded_with_its_first_second():
    net = random_net("tcn", 12)  # sees 16 s: the oldest second stands for 4 more
    x = torch.rand(2, 12, 40)
    padded = torch.cat([x[:, :1].expand(2, 4, 40), x], 1)
    with torch.no_grad():
        torch.testing.assert_close(net.context(x), net.context(padded))
        with pytest.raises(ValueError, match="do not fit"):
            net.context(torch.rand(2, 17, 40))


@pytest.mark.parametrize("arch", TEMPORAL)
def test_every_weight_learns_where_whonets_recurrent_weights_cannot(arch):
    """The issue's point: at one time step 5,184 of WhONet's weights never get a gradient."""
    x, y = torch.rand(64, 16, 40), torch.rand(64)
    net = net_from_hparams(hparams(arch, 16)).train()
    nn.functional.l1_loss(net(x), y).backward()
    for name, p in net.named_parameters():
        assert p.grad is not None and p.grad.abs().sum() > 0, name
    whonet = WhONet(hidden=12).train()
    nn.functional.l1_loss(whonet(x[:, -1:]), y).backward()
    assert whonet.rnn.weight_hh_l0.grad is None


def test_a_lagged_label_is_learned_with_context_and_not_without():
    """A label that is a feature of 3 s ago: only a network that sees it can fit it."""
    rng = np.random.default_rng(3)
    n = 3000
    group = np.repeat(np.arange(10), n // 10)
    per_second = rng.uniform(0, 1, (n, 40)).astype(np.float32)
    lagged = np.concatenate([np.zeros(3), per_second[:-3, 0]])
    first = np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]]))
    keep = np.ones(n, bool)
    for f in first:
        keep[f : f + 3] = False  # no lag within the segment yet
    y = np.where(keep, lagged, 0.0).astype(np.float32)
    train = TrainParams(epochs=15, batch_size=64, lr=0.01, val_fraction=0.0, num_threads=1)
    mae = {}
    for arch, seq_len in (("whonet", 1), ("tcn", 4), ("gru", 4)):
        model = ModelParams(hidden=16, layers=1, dropout=0.0, seq_len=seq_len, arch=arch)
        x = sequences(per_second, seq_len, group)
        net = fit(x[keep], y[keep], model=model, train=train, seed=0).module
        mae[arch] = float(np.mean(np.abs(predict(net, x[keep]) - y[keep])))
    assert mae["whonet"] > 0.2  # the label's own spread: uniform on [0, 1] has MAE 0.25
    assert mae["tcn"] < 0.5 * mae["whonet"] and mae["gru"] < 0.5 * mae["whonet"]


@pytest.mark.parametrize("arch", TEMPORAL)
def test_head_and_body_freeze_policies(arch):
    net = net_from_hparams(hparams(arch, 4))
    apply_trainable(net, "head")
    assert [n for n, p in net.named_parameters() if p.requires_grad] == ["head.weight", "head.bias"]
    apply_trainable(net, "rnn")
    assert all(p.requires_grad != n.startswith("head.") for n, p in net.named_parameters())


@pytest.mark.parametrize("arch", TEMPORAL)
def test_a_model_file_rebuilds_the_network(tmp_path, arch):
    net = random_net(arch, 10)
    hp = hparams(arch, 10)
    save_whonet(net, {**hp, "unrelated": 1}, tmp_path / "m.pt")
    ckpt = torch.load(tmp_path / "m.pt", weights_only=True)
    assert ckpt["hyper_parameters"] == hp  # arch (and a tcn's channels) saved, nothing else
    loaded, hp2 = load_whonet(tmp_path / "m.pt")
    assert type(loaded) is type(net) and hp2 == hp and not loaded.training
    x = np.random.default_rng(0).uniform(0, 1, (20, 10, 40)).astype(np.float32)
    np.testing.assert_array_equal(predict(loaded, x), predict(net, x))


def test_a_whonet_file_names_no_arch_and_an_unknown_arch_is_refused(tmp_path):
    net, hp = base_net(0)
    save_whonet(net, {**hp, "arch": "whonet", "channels": 16}, tmp_path / "w.pt")
    ckpt = torch.load(tmp_path / "w.pt", weights_only=True)
    assert "arch" not in ckpt["hyper_parameters"]  # the paper network's file, as before
    ckpt["hyper_parameters"]["arch"] = "lstm"
    torch.save(ckpt, tmp_path / "lstm.pt")
    with pytest.raises(InputError, match="not a WhONet model file") as err:
        load_whonet(tmp_path / "lstm.pt")
    assert "lstm" in str(err.value.problems[0])
    tcn = random_net("tcn", 8)
    save_whonet(tcn, hparams("tcn", 8), tmp_path / "t.pt")
    ckpt = torch.load(tmp_path / "t.pt", weights_only=True)
    del ckpt["hyper_parameters"]["channels"]
    torch.save(ckpt, tmp_path / "no_channels.pt")
    with pytest.raises(InputError, match="not a WhONet model file"):
        load_whonet(tmp_path / "no_channels.pt")


@pytest.mark.parametrize("arch", TEMPORAL)
@pytest.mark.parametrize("seq_len", [30, 32])
def test_onnx_matches_pytorch_to_1e_5(tmp_path, arch, seq_len):
    net, hp = base_net(1, seq_len, arch)
    meta = ServedMeta(hp, SCALER.to_dict(), (RADIUS_M, RADIUS_M), "integrated")
    path = export_onnx(net, hp, tmp_path / "m.onnx", {"rwhonet": meta.to_json()})
    rng = np.random.default_rng(seq_len)
    group = np.repeat([0, 1], [300, 200])
    x = sequences(rng.uniform(-0.1, 1.1, (500, 40)).astype(np.float32), seq_len, group)
    served = ServedModel(path)
    assert served.meta.seq_len == seq_len and served.meta.hparams["arch"] == arch
    assert np.abs(served.predict(x) - predict(net, x, seq_len=seq_len)).max() < 1e-5
    assert np.abs(served.predict(x[:1]) - predict(net, x[:1], seq_len=seq_len)).max() < 1e-5


def test_the_tcn_weights_are_few():
    """As many as WhONet's that learn: 40 x 72 + 72 + 73 = 3,025, plus the context's."""
    net = TCNNet(hidden=72, seq_len=32, channels=16)
    n = sum(p.numel() for p in net.parameters())
    levels = (80 * 16 + 16) + 4 * (32 * 16 + 16)
    assert n == levels + (56 * 72 + 72) + 73
    assert math.isclose(net.span, 32)
