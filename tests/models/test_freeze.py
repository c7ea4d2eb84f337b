"""Freeze policy for R-WhONet's fine-tuning (adapt.trainable)."""

from __future__ import annotations

from dataclasses import replace

import pytest
import torch

from rwhonet.models.freeze import apply_trainable, count_parameters
from rwhonet.models.module import WhONetModule
from rwhonet.models.train import fine_tune, fit, save_checkpoint
from rwhonet.models.whonet import WhONet

RNN_72 = 72 * 40 + 72 * 72 + 2 * 72  # 8208
HEAD_72 = 72 + 1


@pytest.mark.parametrize(
    ("policy", "expected"),
    [("all", RNN_72 + HEAD_72), ("rnn", RNN_72), ("head", HEAD_72)],
)
def test_counts(policy: str, expected: int) -> None:
    module = WhONetModule(hidden=72)
    assert apply_trainable(module, policy) == (expected, RNN_72 + HEAD_72)
    assert count_parameters(module) == (expected, RNN_72 + HEAD_72)


def test_policy_flags_the_right_parts() -> None:
    net = WhONet(hidden=8)
    apply_trainable(net, "rnn")
    assert all(p.requires_grad for p in net.rnn.parameters())
    assert not any(p.requires_grad for p in net.head.parameters())
    apply_trainable(net, "all")  # a policy also un-freezes
    assert all(p.requires_grad for p in net.parameters())


def test_bad_policy_or_module() -> None:
    with pytest.raises(ValueError, match="trainable"):
        apply_trainable(WhONet(), "encoder")
    with pytest.raises(ValueError, match="WhONet"):
        apply_trainable(torch.nn.Linear(2, 2), "all")


@pytest.mark.parametrize(
    ("policy", "frozen", "moving"), [("rnn", "head", "rnn"), ("head", "rnn", "head")]
)
def test_frozen_weights_do_not_move_in_fine_tuning(
    tmp_path, linear_data, model_params, train_params, adapt_params, policy, frozen, moving
):
    x, y = linear_data
    g = fit(x, y, model=model_params, train=train_params, seed=1)
    save_checkpoint(g, tmp_path / "g.ckpt")
    before = {k: v.clone() for k, v in g.module.net.state_dict().items()}
    r = fine_tune(tmp_path / "g.ckpt", x[:50], y[:50] + 1.0,
                  adapt=replace(adapt_params, trainable=policy), seed=2)  # fmt: skip
    after = r.module.net.state_dict()
    assert r.n_trainable == count_parameters(getattr(r.module.net, moving))[1]
    for k, v in after.items():
        # With one time step h_{t-1} = 0, so U_h (weight_hh) gets no gradient and
        # never moves, trainable or not (as in the authors' one-step SimpleRNN).
        if k.startswith(frozen) or k.startswith("rnn.weight_hh"):
            assert torch.equal(v, before[k]), k
        else:
            assert not torch.equal(v, before[k]), k
