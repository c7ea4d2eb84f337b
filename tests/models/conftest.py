"""Fixtures of the model tests: fast params, a briefly trained G (linear_data is in
tests/conftest.py)."""

from __future__ import annotations

import pytest

from rwhonet.config import (
    AdaptParams,
    ContinuousParams,
    FallbackParams,
    ModelParams,
    ShrinkParams,
    StepsParams,
    TrainParams,
)


@pytest.fixture
def model_params() -> ModelParams:
    return ModelParams(hidden=16, layers=1, dropout=0.05, seq_len=1)


@pytest.fixture
def train_params() -> TrainParams:
    return TrainParams(epochs=3, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)


@pytest.fixture
def adapt_params() -> AdaptParams:
    return AdaptParams(
        m_grid=[10, 50],
        chosen_m=50,
        recipe="paper",
        recipes=["paper", "head", "ridge_head", "radius+G", "steps", "continuous"],
        epochs=5,
        batch_size=128,
        lr=0.01,
        ridge_penalty=1.0,
        ridge_penalty_grid=[0.0, 1.0],
        steps=StepsParams(max_steps=60, holdout_fraction=0.25, patience=20),
        continuous=ContinuousParams(inner="ridge_head", window_s=0),
        shrink=ShrinkParams(unknown_car_sd=0.01, min_rest_s=60),
        fallback=FallbackParams(recipe="radius+G", m=50),
    )


@pytest.fixture(scope="module")
def g(linear_data):
    """A WhONet G briefly trained on the linear data: (network, hyperparameters)."""
    from rwhonet.models.train import fit

    x, y = linear_data
    model = ModelParams(hidden=16, layers=1, dropout=0.05, seq_len=1)
    train = TrainParams(epochs=3, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)
    result = fit(x, y, model=model, train=train, seed=1)
    return result.module.net, dict(result.module.hparams)
