"""The WhONet network: a simple RNN over one-second wheel-speed windows and a linear head.

Paper §2.3, Eqs. 12-15 and Table 1 (72 tanh units, one hidden layer, one time
step, dropout 0.05); initialisation as in the authors' Keras ``SimpleRNN`` +
``Dense`` layers.
"""

from __future__ import annotations

import torch
from torch import nn

from rwhonet.contracts import N_FEATURES
from rwhonet.models.network import RecurrentNetwork


class WhONet(RecurrentNetwork):
    """Simple RNN regressor of the per-second wheel-odometry displacement error.

    ``h_t = tanh(U_h h_{t-1} + W_x X_t + b_h)`` (paper Eq. 12) over the input
    window, then ``y_t = W_o h_t + b_o`` on the last step (the window ends at
    the predicted second t, Eqs. 14-15).

    The output is **linear**, not the sigmoid of Eq. 13: the target is a signed
    error in metres (GNSS − WPM, Eq. 11), which a sigmoid can neither make
    negative nor larger than 1 m. The authors' code uses a linear ``Dense(1)``.

    Dropout: the authors' ``SimpleRNN(recurrent_dropout=0.05)`` drops entries of
    ``h_{t-1}``; with one time step that state is all zeros, so it has no effect
    at all. To keep the paper's "dropout of 0.05 of the weighted connections in
    the hidden layers" (§3.3.1) as a real regulariser we drop the last hidden
    state before the head (training only). With ``layers > 1`` ``nn.RNN``'s own
    inter-layer dropout (same rate) also acts between the stacked layers.

    Initialisation follows Keras' defaults for those layers: Glorot-uniform input
    and output weights, orthogonal recurrent weights, zero biases (``nn.RNN``
    carries two bias vectors, ``b_ih`` and ``b_hh``; both start at zero, so
    their sum, ``b_h`` in Eq. 12, does too).

    Args:
        n_features: input features per time step (40).
        hidden: hidden units per layer (Table 1: 72).
        layers: stacked RNN layers (Table 1: 1).
        dropout: dropout rate (Table 1: 0.05).
    """

    def __init__(
        self, n_features: int = N_FEATURES, hidden: int = 72, layers: int = 1, dropout: float = 0.05
    ) -> None:
        super().__init__(nn.RNN, n_features, hidden, layers, dropout, nonlinearity="tanh")

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """The head's inputs: the last hidden state ``h_t`` of every window (Eq. 12).

        Args:
            x: (B, T, n_features) float32 input windows, oldest step first.

        Returns:
            (B, hidden) ``h_t``, before dropout (``ridge_head`` refits the head on these).
        """
        if x.shape[1] == 1 and self.rnn.num_layers == 1:
            # One time step: h_{t-1} = 0, so Eq. 12 is tanh(W_x X_t + b_h). The same
            # weights and the same gradients as nn.RNN (U_h gets none either way),
            # without nn.RNN's per-call set-up, which dominates a step of this size.
            rnn = self.rnn
            return torch.tanh(
                torch.addmm(rnn.bias_ih_l0 + rnn.bias_hh_l0, x[:, 0], rnn.weight_ih_l0.t())
            )
        return super().features(x)
