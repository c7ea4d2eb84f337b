"""R-WhONet's fine-tuning recipe as an explicit freeze policy (paper §2.6, §3.3.3).

The paper fine-tunes G-WhONet on the first m seconds of a target drive but does
not say which weights move; ``adapt.trainable`` makes the choice explicit:

- ``all``: every weight is fine-tuned (the default; the paper's wording).
- ``rnn``: the recurrent layer (for any network: everything below the head)
  adapts, the linear head stays as trained on the source vehicle.
- ``head``: only the linear head adapts (a re-scaling of G's features to the
  new vehicle, 73 weights), the recurrent layer stays frozen.

Plain torch, no Lightning (:mod:`rwhonet.models.adapt` applies it before fine-tuning).
"""

from __future__ import annotations

import logging
from typing import Literal

from torch import nn

from rwhonet.models.network import Network

log = logging.getLogger(__name__)

Trainable = Literal["all", "rnn", "head"]
POLICIES: tuple[str, ...] = ("all", "rnn", "head")


def count_parameters(module: nn.Module) -> tuple[int, int]:
    """Count trainable and total parameters.

    Args:
        module: any module.

    Returns:
        ``(n_trainable, n_total)`` scalar weights.
    """
    params = list(module.parameters())
    return sum(p.numel() for p in params if p.requires_grad), sum(p.numel() for p in params)


def apply_trainable(module: nn.Module, trainable: Trainable) -> tuple[int, int]:
    """Set which of WhONet's weights are fine-tuned; everything else is frozen.

    Apply it before the optimizer is built (``Trainer.fit`` or
    :func:`rwhonet.models.adapt.fine_tune`): it then holds the trainable
    parameters only, so frozen ones are never touched.

    Args:
        module: a network (:class:`~rwhonet.models.network.Network`), or a module
            holding one as ``.net`` (the :class:`~rwhonet.models.module.WhONetModule`).
        trainable: ``all``, ``rnn`` or ``head`` (module docstring).

    Returns:
        ``(n_trainable, n_total)`` scalar weights after the policy (also logged).

    Raises:
        ValueError: for an unknown policy or a module without a network.
    """
    if trainable not in POLICIES:
        raise ValueError(f"trainable must be one of {POLICIES}, got {trainable!r}")
    net = module if isinstance(module, Network) else getattr(module, "net", None)
    if not isinstance(net, Network):
        raise ValueError(f"expected a network or a module with a network .net, got {type(module)}")
    for name, p in net.named_parameters():
        part = "head" if name.startswith("head.") else "rnn"
        p.requires_grad_(trainable in ("all", part))
    n_trainable, n_total = count_parameters(module)
    log.info("freeze policy %r: %d of %d parameters trainable", trainable, n_trainable, n_total)
    return n_trainable, n_total
