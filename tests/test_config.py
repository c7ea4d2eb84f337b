"""params.yaml loads into typed sections; unknown or mistyped keys are errors naming the key."""

import pytest
import yaml

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
        ({"train.trainer.devices": 2}, "2 device(s) on 1 node(s) need strategy: ddp"),
        ({"train.trainer.strategy": "fsdp"}, "train.trainer.strategy: expected one of"),
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


@pytest.mark.parametrize("switch", ["gnss.fit_sigma", "gyro.fit_instability"])
def test_the_filter_s_fits_can_be_switched_off(switch):
    # a switch sits among the sensor figures, which must be > 0; false is not a figure
    nav = load_params(paths.PARAMS, overrides={f"evaluate.navigation.{switch}": False})
    section, key = switch.split(".")
    assert getattr(getattr(nav.evaluate.navigation, section), key) is False
    with pytest.raises(ConfigError, match=f"evaluate.navigation.{switch}: expected true/false"):
        load_params(paths.PARAMS, overrides={f"evaluate.navigation.{switch}": 1})
    with pytest.raises(ConfigError, match="sensor figures must be > 0"):
        load_params(paths.PARAMS, overrides={"evaluate.navigation.gyro.instability_deg_s": 0})


def test_flatten_uses_dotted_keys():
    assert flatten({"a": {"b": 1, "c": {"d": 2}}, "e": []}) == {"a.b": 1, "a.c.d": 2, "e": []}


# --------------------------------------------------------------------------- paths in params

SHARED = "sqlite:////srv/shared/mlflow.db"


@pytest.mark.parametrize(
    "override,needle",
    [
        ({"tracking.tracking_uri": "sqlite:///../elsewhere/mlflow.db"}, "must stay in mlruns/"),
        ({"tracking.tracking_uri": "sqlite:///mlruns/../../x.db"}, "it resolves to '../x.db'"),
        ({"tracking.tracking_uri": "sqlite:///data/raw/mlflow.db"}, "must stay in mlruns/"),
        ({"tracking.tracking_uri": "sqlite:///mlflow.db"}, "must stay in mlruns/"),
        ({"tracking.tracking_uri": "../mlruns"}, "must stay in mlruns/"),
        ({"tracking.tracking_uri": "file:../mlruns"}, "must stay in mlruns/"),
        ({"tracking.tracking_uri": "sqlite:/mlruns/x.db"}, "expected sqlite:///<path>"),
        ({"tracking.experiment": " "}, "tracking.experiment: expected a name"),
        ({"gate.baseline": "/etc/passwd"}, "gate.baseline='/etc/passwd': expected a path relative"),
        ({"gate.baseline": "../baseline.json"}, "expected a path inside the project"),
        ({"gate.rel_tol": -0.1}, "must be >= 0"),
    ],
)
def test_paths_in_params_cannot_lead_a_stage_outside_the_project(override, needle):
    with pytest.raises(ConfigError) as err:
        load_params(paths.PARAMS, overrides=override)
    assert needle in str(err.value)


@pytest.mark.parametrize("tolerance", [0.0, -0.25])
def test_the_yaw_gain_tolerance_must_be_positive(tolerance):
    with pytest.raises(ConfigError, match="validate.yaw_gain_tolerance must be > 0"):
        load_params(paths.PARAMS, overrides={"validate.yaw_gain_tolerance": tolerance})


@pytest.mark.parametrize("name", ["../../../tmp/x", "sub/V-1", ".hidden", "", "a b", "x" * 101])
def test_a_simulated_drive_name_must_be_a_plain_file_name(name):
    drives = yaml.safe_load(paths.PARAMS.read_text())["sim"]["profiles"]["ci"]["drives"]
    drives[0]["name"] = name  # simulate writes data/sim/<role>/<name>.csv
    with pytest.raises(ConfigError, match="becomes a file name"):
        load_params(paths.PARAMS, overrides={"sim.profiles.ci.drives": drives})


@pytest.mark.parametrize(
    "uri", [SHARED, "sqlite:///mlruns/other.db", "http://127.0.0.1:5000", "postgresql://h/db"]
)
def test_stores_that_stay_in_mlruns_or_are_named_absolutely_are_accepted(uri):
    assert load_params(paths.PARAMS, overrides={"tracking.tracking_uri": uri}).tracking


# Every text param, by what the pipeline does with it. A new one fails the test below until
# it is classified here, so no param can become a path a stage writes to unchecked.
TEXT_PARAMS = {
    "data.root": "read from anywhere (drive files)",
    "data.roles.*.glob": "read, under data.root",
    "data.roles.*.format": "a reader's name",
    "data.roles.*.vehicle": "a vehicle's name",
    "data.roles.*.drives[*]": "a drive id's pattern, matched",
    "data.column_maps.*.*.column": "a CSV column name",
    "data.column_maps.*.*.unit": "a unit's name",
    "data.signal_maps.*.signals.*.column": "a logged channel's name (MDF4 signal, CSV column)",
    "data.signal_maps.*.signals.*.unit": "a unit's name",
    "data.signal_maps.*.source": "named in messages only (the --signal-map file)",
    "data.signal_maps.*.local_zone": "a time zone's name, checked against the IANA database",
    "data.signal_maps.*.dbc": "read from anywhere (a CAN database)",
    "data.signal_maps.*.dbc[*]": "read from anywhere (a CAN database)",
    # per bus: the bus (a key) is only matched against the log's buses
    "data.signal_maps.*.dbc.*": "read from anywhere (a CAN database of one bus)",
    "data.signal_maps.*.dbc.*[*]": "read from anywhere (a CAN database of one bus)",
    "validate.cuts[*].drive": "a drive's name, matched",
    "validate.cuts[*].reason": "free text",
    "sim.profile": "a profile's name",
    "sim.profiles.*.vehicles.*": "a vehicle's name",
    "sim.profiles.*.drives_from": "a profile's name",
    "sim.profiles.*.receivers.*": "a receiver grade's name",
    "sim.profiles.*.drives[*].name": "written as a file name: checked (FILE_NAME)",
    "sim.profiles.*.drives[*].vehicle": "a vehicle's name",
    "sim.profiles.*.drives[*].tyre": "a tyre state's letter",
    "tracking.experiment": "an MLflow experiment's name",
    "tracking.tracking_uri": "written: checked (tracking_uri_problem)",
    "gate.baseline": "read by the gate: checked inside the project",
    "evaluate.navigation.control_model": "a model's name, matched",
}


def _text_fields(tp, prefix: str) -> set[str]:
    import dataclasses
    import types
    import typing

    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is str:
        return {prefix}
    if dataclasses.is_dataclass(tp):
        hints = typing.get_type_hints(tp)
        return set().union(
            *(
                _text_fields(hints[f.name], f"{prefix}.{f.name}".lstrip("."))
                for f in dataclasses.fields(tp)
            )
        )
    if origin is list:
        return _text_fields(args[0], prefix + "[*]")
    if origin is dict:
        return _text_fields(args[1], prefix + ".*")
    if origin in (types.UnionType, typing.Union):
        return set().union(*(_text_fields(a, prefix) for a in args))
    return set()


def test_every_text_param_is_classified():
    from rwhonet.config import Params

    assert _text_fields(Params, "") == set(TEXT_PARAMS)


def test_a_stage_s_params_view_pickles_with_its_guard():
    """The train stage hands its view to worker processes (rwhonet.stages.cores)."""
    import pickle

    view = load_params(paths.PARAMS, only=["seeds", "train"], reader="stage train")
    back = pickle.loads(pickle.dumps(view))
    assert back.seeds == view.seeds and back.train.epochs == view.train.epochs
    with pytest.raises(ConfigError, match="stage train reads params 'adapt'"):
        back.adapt  # noqa: B018


def test_a_signal_map_s_local_zone_must_be_a_time_zone():
    """A logger's local clock is put on UTC in the map's local_zone: an IANA name, checked
    when the params load (a misspelt zone would place every frame hours off)."""
    maps = {"bus": {"reader": "mdf4", "signals": {}, "local_zone": "Europe/Berlin"}}
    spec = load_params(paths.PARAMS, overrides={"data.signal_maps": maps}).data.signal_maps
    assert spec["bus"].local_zone == "Europe/Berlin"
    for bad in ("Europe/Berln", "CEST+2", "../etc/passwd"):
        maps["bus"]["local_zone"] = bad
        with pytest.raises(ConfigError, match="no time zone the IANA database names"):
            load_params(paths.PARAMS, overrides={"data.signal_maps": maps})
