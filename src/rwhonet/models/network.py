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
(temporal context over the window's seconds).
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
