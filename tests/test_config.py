"""params.yaml loads into typed sections; unknown or mistyped keys are errors naming the key."""

import pytest

from rwhonet import paths
from rwhonet.config import ConfigError, flatten, load_params


def test_project_params_load():
    p = load_params(paths.PARAMS)
    assert p.model.hidden == 72 and p.train.batch_size == 128
    assert p.adapt.auto and p.adapt.chosen_m == "auto"  # chosen by the selection rule
    assert p.adapt.fallback.m in p.adapt.m_grid and p.adapt.fallback.recipe in p.adapt.recipes
    assert p.evaluate.outages_s == [30, 60, 120, 180]


@pytest.mark.parametrize(
    "override,needle",
    [
        ({"train.epoch": 3}, "train: unknown key(s) ['epoch']"),
        ({"train.epochs": "many"}, "train.epochs: expected an integer"),
        ({"label.wpm_mode": "magic"}, "label.wpm_mode: expected one of"),
        (
            {"adapt.chosen_m": 55, "adapt.recipe": "paper"},
            "adapt.chosen_m=55 is not in adapt.m_grid",
        ),
        ({"adapt.chosen_m": 50}, "set both to auto or neither, got recipe='auto', chosen_m=50"),
        (
            {"adapt.chosen_m": "best", "adapt.recipe": "paper"},
            "adapt.chosen_m: expected an integer, got 'best' or expected one of ['auto']",
        ),
        ({"adapt.recipe": "magic"}, "adapt.recipe: expected one of"),
        ({"adapt.fallback.m": 55}, "adapt.fallback.m=55 is not in adapt.m_grid"),
        (
            {"adapt.fallback.recipe": "head", "adapt.recipes": ["paper"]},
            "adapt.fallback.recipe='head' is not in adapt.recipes",
        ),
        ({"data.roles.target_test.vehicle": "bus"}, "vehicle='bus' is not in data.vehicles"),
        ({"data.roles.target_test.format": "xyz"}, "format='xyz'"),
    ],
)
def test_bad_params_name_the_key(override, needle):
    with pytest.raises(ConfigError) as err:
        load_params(paths.PARAMS, overrides=override)
    assert needle in str(err.value)


def test_flatten_uses_dotted_keys():
    assert flatten({"a": {"b": 1, "c": {"d": 2}}, "e": []}) == {"a.b": 1, "a.c.d": 2, "e": []}
