"""A temporal convolutional network over the window's seconds (``model.arch: tcn``).

Causal dilated convolutions with kernel 2 and dilations 1, 2, 4, ... (WaveNet,
van den Oord et al. 2016; a TCN, Bai et al. 2018) summarise the window's
seconds into ``channels`` context features; WhONet's tanh layer then takes the
present second's 40 features *and* that context, and the same dropout and
linear head give the displacement error (so with the context weights at zero
it is WhONet at one time step).

Only the window's last output is needed, so each level is computed only where
that output reads it: level ``l`` (dilation ``2^(l-1)``) combines neighbouring
pairs of the level below, which is a kernel-2, stride-2 convolution, one
matrix product per level. ``L = ceil(log2(seq_len))`` levels see ``2^L``
seconds; a shorter window is padded at its old end with its first second, as
:func:`rwhonet.features.sequences.sequences` pads a segment's first seconds.
Nothing reaches past the window: no context crosses a GNSS cut, none looks
ahead. The cost per window grows with ``seq_len`` as ``2 seq_len`` small
products of ``2 * channels`` inputs, not as a convolution at every second.

Initialisation: Glorot-uniform weights, zero biases (Keras' defaults).
"""

from __future__ import annotations

import math

import torch
from torch import nn

from rwhonet.contracts import N_FEATURES
from rwhonet.models.network import Network, check_shape


class TCNNet(Network):
    """Causal TCN context encoder joined with WhONet's one-second tanh layer.

    Keyword arguments only: the TCN's own (``seq_len``, ``channels``), then the
    shape every network takes.

    Args:
        seq_len: seconds per window; sets the levels (module docstring).
        channels: context features per level (``model.channels``).
        n_features: input features per second (40).
        hidden: units of the tanh layer the head reads (``model.hidden``).
        layers: unused (kept so every network takes the same hyperparameters).
        dropout: rate of the dropout on the tanh layer before the head.
    """

    def __init__(
        self,
        *,
        seq_len: int = 32,
        channels: int = 16,
        n_features: int = N_FEATURES,
        hidden: int = 72,
        layers: int = 1,
        dropout: float = 0.05,
    ) -> None:
        super().__init__()
        check_shape(n_features, hidden, layers, dropout)
        if seq_len < 1 or channels < 1:
            raise ValueError(f"seq_len and channels must be positive, got {seq_len}, {channels}")
        self._n_features = n_features
        self.n_levels = math.ceil(math.log2(seq_len)) if seq_len > 1 else 0
        self.span = 2**self.n_levels  # seconds the context sees
        widths = [n_features] + [channels] * self.n_levels
        self.levels = nn.ModuleList(
            nn.Linear(2 * widths[i], widths[i + 1]) for i in range(self.n_levels)
        )
        context = channels if self.n_levels else 0
        self.joint = nn.Linear(n_features + context, hidden)
        self.dropout = nn.Dropout(dropout)
        self.head = nn.Linear(hidden, 1)
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Glorot-uniform weights, zero biases."""
        for layer in (*self.levels, self.joint, self.head):
            nn.init.xavier_uniform_(layer.weight)
            nn.init.zeros_(layer.bias)

    @property
    def n_features(self) -> int:
        return self._n_features

    def context(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, n_features) windows, T <= span -> (B, channels) context of the last second."""
        t = x.shape[1]
        if t > self.span:
            raise ValueError(f"windows of {t} s do not fit a TCN that sees {self.span} s")
        if t < self.span:  # pad the old end with the window's first second
            index = torch.tensor([0] * (self.span - t) + list(range(t)), device=x.device)
            x = torch.index_select(x, 1, index)
        z, length = x, self.span
        for level in self.levels:
            # (B, L, c) -> (B, L/2, 2c): pairs (older, newer) side by side; one product each
            length //= 2
            z = torch.tanh(level(z.reshape(-1, length, level.in_features)))
        return z[:, 0, :]

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """tanh(W [x_t, context] + b): the tanh layer the head reads, (B, hidden)."""
        now = x[:, -1, :]
        if self.n_levels:
            now = torch.cat([now, self.context(x)], dim=1)
        return torch.tanh(self.joint(now))
