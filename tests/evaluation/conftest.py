"""Shared fixtures of the evaluation's tests: a small samples folder and its params."""

import pytest

from rwhonet import paths
from rwhonet.config import load_params
from stages.conftest import samples_dir

__all__ = ["OVERRIDES", "params", "samples_dir"]

# two m values, two outage lengths, three recipes (one continuous), R = the paper's at 20 s
OVERRIDES = {
    "adapt.m_grid": [10, 20],
    "adapt.chosen_m": 20,
    "evaluate.outages_s": [30, 60],
    "adapt.recipe": "paper",
    "adapt.recipes": ["paper", "radius+G", "continuous"],
    "adapt.fallback.recipe": "radius+G",  # shrink is not among these recipes
}


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides={**OVERRIDES, "seeds": [1, 2]})
