"""WhONet network: shapes, paper Eq. 12 with a linear head, Keras-style init, dropout."""

from __future__ import annotations

import math

import pytest
import torch

from rwhonet.models.whonet import WhONet


@pytest.mark.parametrize("seq_len", [1, 3])
def test_output_is_one_value_per_window(seq_len: int) -> None:
    net = WhONet()
    out = net(torch.rand(5, seq_len, 40))
    assert out.shape == (5,)
    assert out.dtype == torch.float32


def test_forward_is_eq12_recurrence_with_linear_head() -> None:
    torch.manual_seed(0)
    net = WhONet(n_features=4, hidden=3, dropout=0.5).eval()
    for p in net.parameters():  # non-zero biases so every term of Eq. 12 is exercised
        torch.nn.init.normal_(p)
    x = torch.rand(2, 3, 4)
    r = net.rnn
    h = torch.zeros(2, 3)
    for t in range(3):  # h_t = tanh(U_h h_{t-1} + W_x X_t + b_h), b_h = b_ih + b_hh
        b_h = r.bias_ih_l0 + r.bias_hh_l0
        h = torch.tanh(h @ r.weight_hh_l0.T + x[:, t] @ r.weight_ih_l0.T + b_h)
    expected = (h @ net.head.weight.T + net.head.bias).squeeze(-1)  # linear, no sigmoid
    torch.testing.assert_close(net(x), expected)


def test_one_step_fast_path_is_nn_rnn_with_the_same_gradients() -> None:
    torch.manual_seed(1)
    net = WhONet(hidden=8, dropout=0.0)
    for p in net.parameters():
        torch.nn.init.normal_(p)
    x = torch.rand(16, 1, 40)
    fast = net(x)
    out, _ = net.rnn(x)  # the general path
    slow = net.head(out[:, -1]).squeeze(-1)
    torch.testing.assert_close(fast, slow, rtol=1e-5, atol=1e-5)
    grads = []
    for y in (fast, slow):
        net.zero_grad()
        y.abs().sum().backward(retain_graph=True)
        grads.append(
            {n: p.grad.clone() if p.grad is not None else None for n, p in net.named_parameters()}
        )
    for name, g in grads[1].items():
        if name == "rnn.weight_hh_l0":  # h_{t-1} = 0: U_h gets a zero gradient or none
            assert grads[0][name] is None and not g.any()
        else:
            torch.testing.assert_close(grads[0][name], g, rtol=1e-5, atol=1e-5)


def test_output_is_not_squashed_into_sigmoid_range() -> None:
    net = WhONet(n_features=2, hidden=2, dropout=0.0).eval()
    with torch.no_grad():
        net.head.bias.fill_(-3.0)
    with torch.no_grad():
        assert float(net(torch.zeros(1, 1, 2))) == pytest.approx(-3.0)


def test_keras_default_initialisation() -> None:
    net = WhONet(hidden=72)
    w_hh = net.rnn.weight_hh_l0
    torch.testing.assert_close(w_hh @ w_hh.T, torch.eye(72), atol=1e-5, rtol=0)
    glorot = math.sqrt(6.0 / (40 + 72))
    assert net.rnn.weight_ih_l0.abs().max() <= glorot
    assert net.rnn.weight_ih_l0.std() > glorot / 4  # really uniform on ±bound, not tiny
    assert net.head.weight.abs().max() <= math.sqrt(6.0 / (72 + 1))
    for b in (net.rnn.bias_ih_l0, net.rnn.bias_hh_l0, net.head.bias):
        assert torch.count_nonzero(b) == 0


def test_parameter_count_matches_table1_shape() -> None:
    net = WhONet(n_features=40, hidden=72, layers=1)
    # W_x 72x40, U_h 72x72, two bias vectors of 72, head 72 + 1.
    assert sum(p.numel() for p in net.parameters()) == 72 * 40 + 72 * 72 + 2 * 72 + 73


def test_dropout_acts_in_training_only() -> None:
    torch.manual_seed(0)
    net = WhONet(dropout=0.5)
    x = torch.rand(64, 1, 40)
    net.train()
    assert not torch.equal(net(x), net(x))
    net.eval()
    torch.testing.assert_close(net(x), net(x), rtol=0, atol=0)


def test_stacked_layers_get_inter_layer_dropout() -> None:
    assert WhONet(layers=1, dropout=0.05).rnn.dropout == 0.0
    net = WhONet(layers=2, dropout=0.05)
    assert net.rnn.dropout == 0.05
    assert net(torch.rand(3, 2, 40)).shape == (3,)


@pytest.mark.parametrize(
    "kwargs", [{"hidden": 0}, {"layers": 0}, {"dropout": 1.0}, {"dropout": -0.1}]
)
def test_bad_arguments_raise(kwargs: dict) -> None:
    with pytest.raises(ValueError):
        WhONet(**kwargs)
