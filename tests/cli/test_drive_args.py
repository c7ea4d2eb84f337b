"""A new car and any drive format from the command line (cli/drive.py, rwhonet --help)."""

from __future__ import annotations

import pytest
import yaml

from rwhonet.cli.drive import (
    drive_sha256,
    set_vehicle,
    with_car,
    with_format,
    with_vehicle,
)
from rwhonet.cli.main import main
from rwhonet.config import ConfigError, load_params
from rwhonet.data.drivefile import reader_kind
from rwhonet.errors import InputError
from rwhonet.sim.streams import SIGNAL_MAP


@pytest.fixture(scope="module")
def params():
    return load_params()


def test_a_vehicle_params_do_not_know_gets_a_radius_and_a_track(params):
    """`--vehicle rav4` once ended in TypeError: VehicleSpec needs track_rear_m."""
    got = with_vehicle(params, "rav4", 0.362)
    assert got.nominal_radius_m("rav4") == 0.362
    assert got.track_rear_m("rav4") == params.data.vehicles["target"].track_rear_m
    assert with_vehicle(params, "target", 0.5) is params  # a car params know: as it is


def test_the_car_from_the_command_line(params, tmp_path):
    assert with_car(params, "rav4") is params
    car = with_car(params, "rav4", nominal_radius_m=0.362, track_rear_m=1.57)
    assert (car.nominal_radius_m("rav4"), car.track_rear_m("rav4")) == (0.362, 1.57)
    # An explicit radius replaces what params say, also for a car they know (read as real).
    assert with_car(params, "target", nominal_radius_m=0.31).nominal_radius_m("target") == 0.31
    path = tmp_path / "car.yaml"
    path.write_text(yaml.safe_dump({"nominal_radius_m": 0.362, "track_rear_m": 1.57}))
    assert with_car(params, "rav4", vehicle_file=str(path)).nominal_radius_m("rav4") == 0.362


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ({"nominal_radius_m": 0.362}, "track_rear_m: missing"),
        ({"nominal_radius_m": 0.362, "track_rear_m": 1.5, "mass": 1}, "unknown key(s) ['mass']"),
        ({"nominal_radius_m": "big", "track_rear_m": 1.5}, "expected a number"),
        ({"nominal_radius_m": -0.3, "track_rear_m": 1.5}, "nominal_radius_m: expected > 0"),
    ],
)
def test_a_bad_vehicle_file_names_the_key(params, tmp_path, content, message):
    path = tmp_path / "car.yaml"
    path.write_text(yaml.safe_dump(content))
    with pytest.raises(ConfigError, match="--vehicle-file") as err:
        with_car(params, "rav4", vehicle_file=str(path))
    assert message in str(err.value)


def test_a_vehicle_file_that_is_not_there_or_not_yaml(params, tmp_path):
    with pytest.raises(InputError, match="no such file|FileNotFoundError"):
        with_car(params, "rav4", vehicle_file=str(tmp_path / "none.yaml"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("nominal_radius_m: [0.3\n")
    with pytest.raises(InputError) as err:
        with_car(params, "rav4", vehicle_file=str(bad))
    assert "not YAML" in err.value.problems[0].found
    with pytest.raises(ConfigError, match="one way"):
        with_car(params, "rav4", nominal_radius_m=0.3, vehicle_file=str(bad))
    with pytest.raises(ConfigError, match="expected a length"):
        set_vehicle(params, "rav4", 0.0)


def _map(tmp_path, with_time: bool, nested: bool = False):
    signals = {k: {"column": c, "unit": u} for k, (c, u) in SIGNAL_MAP.items()}
    if not with_time:
        del signals["t"]
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump({"signals": signals} if nested else signals))
    return str(path)


def test_every_reader_is_a_format(params, tmp_path):
    assert reader_kind("iovnbd", params.data) == "iovnbd"
    assert reader_kind("comma2k19", with_format(params, "comma2k19").data) == "comma2k19"
    for fmt, with_time in (("mdf4", False), ("stream_csv", True)):
        for nested in (False, True):
            path = _map(tmp_path, with_time, nested)
            got = with_format(params, fmt, path)
            assert reader_kind(fmt, got.data) == fmt
            assert got.data.signal_maps[fmt].source == path  # messages name the user's file


def test_a_map_file_gives_its_loggers_time_zone(params, tmp_path):
    """A map file beside its signals: the logging computer's time zone (an ASC log's date
    line, local time), kept on the map; a name the IANA database lacks is refused naming
    the file."""
    path = tmp_path / "map.yaml"
    assert _map(tmp_path, True, True) == str(path)  # the signals, nested, written there
    signals = yaml.safe_load(path.read_text())["signals"]
    path.write_text(yaml.safe_dump({"signals": signals, "local_zone": "America/Detroit"}))
    got = with_format(params, "stream_csv", str(path))
    assert got.data.signal_maps["stream_csv"].local_zone == "America/Detroit"
    path.write_text(yaml.safe_dump({"signals": signals, "local_zone": "Detroit"}))
    with pytest.raises(ConfigError, match=r"map.yaml: local_zone 'Detroit' is no time zone"):
        with_format(params, "stream_csv", str(path))


def test_a_map_file_s_misspelt_key_beside_its_signals_is_refused(params, tmp_path):
    """A key beside ``signals`` that the map file does not take (``local_zon``) would be
    dropped in silence, and with it the zone an ASC log needs: refused, naming the file,
    the key and the keys it takes."""
    path = tmp_path / "map.yaml"
    _map(tmp_path, True, True)
    signals = yaml.safe_load(path.read_text())["signals"]
    path.write_text(yaml.safe_dump({"signals": signals, "local_zon": "America/Detroit"}))
    with pytest.raises(ConfigError) as err:
        with_format(params, "stream_csv", str(path))
    said = str(err.value)
    assert f"--signal-map {path}: unknown key(s) 'local_zon' beside signals" in said
    assert said.endswith("expected signals, dbc, local_zone")


def test_a_format_without_its_map_or_an_unknown_one_is_refused(params, tmp_path):
    with pytest.raises(InputError) as err:
        with_format(params, "mdf4")
    assert "--signal-map" in err.value.problems[0].found
    with pytest.raises(InputError, match="unknown --format"):
        with_format(params, "parquet")
    with pytest.raises(InputError, match="--format mdf4 or stream_csv"):
        with_format(params, "iovnbd", _map(tmp_path, False))
    with pytest.raises(ConfigError, match=r"map.yaml.t: missing"):  # CSV streams need their time
        with_format(params, "stream_csv", _map(tmp_path, with_time=False))


def test_a_folder_drive_has_a_digest_of_its_files(tmp_path):
    (tmp_path / "seg" / "CAN").mkdir(parents=True)
    (tmp_path / "seg" / "CAN" / "t").write_bytes(b"1")
    first = drive_sha256(tmp_path / "seg")
    (tmp_path / "seg" / "CAN" / "t").write_bytes(b"2")
    assert drive_sha256(tmp_path / "seg") != first and len(first) == 64


@pytest.mark.parametrize("command", ["recalibrate", "predict"])
def test_help_says_how_to_give_a_new_car_and_a_format(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for flag in ("--nominal-radius", "--vehicle-file", "--track-rear", "--signal-map"):
        assert flag in text
    assert "comma2k19" in text and "mdf4" in text and "stream_csv" in text


def test_a_map_file_with_an_unquoted_index_in_braces_says_to_quote_it(tmp_path):
    """YAML reads ``[2]`` inside ``{...}`` as a list and fails: the refusal names the line
    and says to quote the channel; quoted, the map is read."""
    line = "omega_rl: {column: %s, unit: rad/s}\n"
    bad = tmp_path / "bad.yaml"
    bad.write_text("lat: {column: /fix.latitude, unit: deg}\n" + line % "/js.velocity[2]")
    with pytest.raises(InputError) as err:
        with_format(load_params(), "mdf4", str(bad))
    text = str(err.value)
    assert "bad.yaml, row 2: expected a signal map" in text
    assert 'quote a channel with an index in {...}: {column: "/joint_states.velocity[2]"' in text
    good = tmp_path / "good.yaml"
    rest = "".join(f"omega_{w}: {{column: /w.{w}, unit: rad/s}}\n" for w in ("fl", "fr", "rr"))
    good.write_text(
        "lat: {column: /fix.latitude, unit: deg}\nlon: {column: /fix.longitude, unit: deg}\n"
        + rest
        + line % '"/js.velocity[2]"'
    )
    spec = with_format(load_params(), "mdf4", str(good)).data.signal_maps["mdf4"]
    assert spec.signals["omega_rl"].column == "/js.velocity[2]"
