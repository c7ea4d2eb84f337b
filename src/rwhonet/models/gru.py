"""A GRU over the window's seconds: WhONet with a memory that learns (``model.arch: gru``).

WhONet at one time step (paper Table 1) is a one-layer perceptron: its recurrent
weights never see a non-zero state and never get a gradient. This network runs
a gated recurrent unit (Cho et al. 2014) over the ``seq_len`` seconds of each
window, oldest first, and predicts the last second's displacement error from
the last hidden state, through the same dropout and linear head as WhONet.
Context over tens of seconds (``model.seq_len``) lets it see what one second
cannot: how the car got to its present speed, the stops and turns of the last
half minute. Windows reach back at most to their segment's first second
(:func:`rwhonet.features.sequences.sequences`), so no context crosses a GNSS cut
and none looks ahead.

Initialisation as Keras' ``GRU`` layer: Glorot-uniform input weights, orthogonal
recurrent weights, zero biases.
"""

from __future__ import annotations

from torch import nn

from rwhonet.contracts import N_FEATURES
from rwhonet.models.network import RecurrentNetwork


class GRUNet(RecurrentNetwork):
    """GRU regressor of the per-second wheel-odometry displacement error.

    Args:
        n_features: input features per second (40).
        hidden: GRU units per layer (``model.hidden``).
        layers: stacked GRU layers (``model.layers``); ``nn.GRU``'s own
            inter-layer dropout (``dropout``) acts between them.
        dropout: rate of the dropout on the last hidden state before the head.
    """

    def __init__(
        self, n_features: int = N_FEATURES, hidden: int = 72, layers: int = 1, dropout: float = 0.05
    ) -> None:
        super().__init__(nn.GRU, n_features, hidden, layers, dropout)
