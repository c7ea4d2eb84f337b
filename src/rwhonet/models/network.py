"""What every network of the pipeline offers: one prediction per window, and the head's inputs.

The pipeline trains, recalibrates, saves, exports and serves any network
selected by ``model.arch`` through this interface alone:

- ``forward(x)``: ``(B, T, n_features)`` windows, oldest second first, to the
  ``(B,)`` predicted GNSS − WPM displacement of each window's last second
  (metres); it is ``head(dropout(features(x)))``;
- ``features(x)``: the ``(B, k)`` inputs of the linear ``head`` (before dropout),
  which ``ridge_head`` refits in closed form (:mod:`rwhonet.models.adapt`);
- ``head``: the ``nn.Linear(k, 1)`` output layer (the ``head`` recipe and freeze
  policy train it alone); everything else is the body;
- ``n_features``: input features per second.

The networks: :class:`~rwhonet.models.whonet.WhONet` (the paper's, the default),
:class:`~rwhonet.models.gru.GRUNet` and :class:`~rwhonet.models.tcn.TCNNet`
(temporal context over the window's seconds). The first two share
:class:`RecurrentNetwork`: a recurrent layer, dropout on its last hidden state
and the head, initialised as Keras' layers are.
"""

from __future__ import annotations

import torch
from torch import nn


class Network(nn.Module):
    """Base class of the pipeline's networks (module docstring); holds no weights itself."""

    head: nn.Linear
    dropout: nn.Dropout

    @property
    def n_features(self) -> int:
        """Input features per time step."""
        raise NotImplementedError

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, n_features) windows -> (B, k) inputs of the head, before dropout."""
        raise NotImplementedError

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, n_features) windows -> (B,) predicted displacement error in metres."""
        return self.head(self.dropout(self.features(x))).squeeze(-1)


class RecurrentNetwork(Network):
    """A torch recurrent layer over the window, dropout on its last hidden state, a linear head.

    Submodules ``rnn``, ``dropout``, ``head``, in that order (their names and order
    are the model file's). Initialisation as Keras' recurrent and ``Dense`` layers:
    Glorot-uniform input and output weights, orthogonal recurrent weights, zero
    biases.

    Args:
        rnn_type: ``nn.RNN`` or ``nn.GRU``.
        n_features: input features per time step.
        hidden: hidden units per layer.
        layers: stacked recurrent layers; the layer's own inter-layer dropout
            (``dropout``) acts between them.
        dropout: rate of the dropout on the last hidden state before the head.
        **rnn_options: further arguments of ``rnn_type`` (``nonlinearity``).
    """

    def __init__(
        self,
        rnn_type: type[nn.RNNBase],
        n_features: int,
        hidden: int,
        layers: int,
        dropout: float,
        **rnn_options: str,
    ) -> None:
        super().__init__()
        check_shape(n_features, hidden, layers, dropout)
        self.rnn = rnn_type(
            input_size=n_features,
            hidden_size=hidden,
            num_layers=layers,
            batch_first=True,
            # torch warns (and does nothing) when asked for dropout with one layer.
            dropout=dropout if layers > 1 else 0.0,
            **rnn_options,
        )
        self.dropout = nn.Dropout(dropout)
        self.head = nn.Linear(hidden, 1)
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Keras-default initialisation (class docstring)."""
        for name, p in self.rnn.named_parameters():
            if name.startswith("weight_hh"):
                nn.init.orthogonal_(p)
            elif name.startswith("weight_ih"):
                nn.init.xavier_uniform_(p)
            else:
                nn.init.zeros_(p)
        nn.init.xavier_uniform_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    @property
    def n_features(self) -> int:
        """Input features per time step."""
        return self.rnn.input_size

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """The last hidden state of the top layer, (B, hidden)."""
        out, _ = self.rnn(x)
        return out[:, -1, :]


def check_shape(n_features: int, hidden: int, layers: int, dropout: float) -> None:
    """Refuse a shape no network can take.

    Raises:
        ValueError: for a non-positive size or a dropout outside [0, 1).
    """
    if n_features < 1 or hidden < 1 or layers < 1:
        raise ValueError(
            f"n_features, hidden and layers must be positive, got {n_features}, {hidden}, {layers}"
        )
    if not 0.0 <= dropout < 1.0:
        raise ValueError(f"dropout must be in [0, 1), got {dropout}")
