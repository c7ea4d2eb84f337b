"""Shared fixtures for the model tests: tiny data sets and fast params."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import AdaptParams, ModelParams, TrainParams
from rwhonet.stage import quiet

quiet()


@pytest.fixture(scope="session")
def linear_data() -> tuple[np.ndarray, np.ndarray]:
    """1,200 windows (seq_len 1, 40 features in [0, 1]) with a known linear label in metres."""
    rng = np.random.default_rng(7)
    x = rng.random((1200, 1, 40), dtype=np.float32)
    w = rng.normal(0.0, 0.5, 40)
    y = (x[:, 0, :] @ w - 0.2).astype(np.float32)
    return x, y


@pytest.fixture
def model_params() -> ModelParams:
    return ModelParams(hidden=16, layers=1, dropout=0.05, seq_len=1)


@pytest.fixture
def train_params() -> TrainParams:
    return TrainParams(epochs=3, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)


@pytest.fixture
def adapt_params() -> AdaptParams:
    return AdaptParams(
        m_grid=[10, 50], chosen_m=50, epochs=5, batch_size=128, lr=0.01, trainable="all"
    )
