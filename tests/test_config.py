"""params.yaml loads into typed sections; unknown or mistyped keys are errors naming the key."""

import pytest

from rwhonet import paths
from rwhonet.config import ConfigError, flatten, load_params


def test_project_params_load():
    p = load_params(paths.PARAMS)
    assert p.model.hidden == 72 and p.train.batch_size == 128
    assert p.adapt.chosen_m in p.adapt.m_grid
    assert p.evaluate.outages_s == [30, 60, 120, 180]


@pytest.mark.parametrize(
    "override,needle",
    [
        ({"train.epoch": 3}, "train: unknown key(s) ['epoch']"),
        ({"train.epochs": "many"}, "train.epochs: expected an integer"),
        ({"label.wpm_mode": "magic"}, "label.wpm_mode: expected one of"),
        ({"adapt.chosen_m": 55}, "adapt.chosen_m=55 is not in adapt.m_grid"),
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
