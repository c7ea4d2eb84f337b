"""Freeze policy for R-WhONet's fine-tuning (adapt.trainable)."""

from __future__ import annotations

import pytest
import torch

from rwhonet.models.freeze import apply_trainable, count_parameters
from rwhonet.models.module import WhONetModule
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
    with pytest.raises(ValueError, match="network"):
        apply_trainable(torch.nn.Linear(2, 2), "all")
