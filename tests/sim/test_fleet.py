"""Fleet profiles, simulate_fleet's outputs and the DVC stage script."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ConfigError, load_params
from rwhonet.sim import (
    drive_seed,
    generate_route,
    simulate_drive,
    simulate_fleet,
    vehicles_from_params,
)
from rwhonet.sim.drive import child_rng
from rwhonet.sim.sensors import gnss_increment_std_m

ROOT = Path(__file__).resolve().parents[2]
ROLES = ("source_train", "source_calibration", "source_test", "target_train", "target_test")
# Each ci test drive: m <= 100 s of adaptation, then two 180 s outage windows.
MIN_TEST_S = 100 + 2 * 180


def test_ci_test_drives_are_long_enough_and_clean(params):
    ci = load_params(overrides={"sim.profile": "ci"})
    drives = ci.sim.profiles["ci"].drives
    vehicles = vehicles_from_params(ci)
    tests = [(i, d) for i, d in enumerate(drives) if d.role in ("target_test", "source_test")]
    assert sorted(d.role for _, d in tests) == ["source_test"] * 2 + ["target_test"] * 4
    for i, spec in tests:
        assert spec.duration_s >= MIN_TEST_S and not spec.gnss_faults
        seed = drive_seed(ci.sim.seed, i)
        vehicle = vehicles[spec.vehicle].with_payload(spec.payload_kg, spec.payload_x_m)
        route = generate_route(spec, ci.sim, vehicle, child_rng(seed, 0))
        frame, scenarios, _, _ = simulate_drive(
            vehicle, spec.tyre, route, seed, ci.sim, leaks=spec.leaks
        )
        assert len(frame) / ci.sim.record_hz >= MIN_TEST_S
        assert not [i for i in scenarios["intervals"] if i["tag"].startswith("gnss_")]
        assert frame["Sats"].min() >= params.validate.gnss.min_sats


def test_profiles_mirror_the_paper(params):
    for name in ("paper", "ci"):
        drives = params.sim.profiles[name].drives
        assert {d.role for d in drives} == set(ROLES)
        train = {d.tyre for d in drives if d.role == "target_train"}
        test = {d.tyre for d in drives if d.role == "target_test"}
        assert test - train, "some target test drives must be in an unseen tyre state"
        source = [d.tyre for d in drives if d.role == "source_train"]
        assert {"A", "C", "D", "E"} <= set(source)
        held_out = {d.tyre for d in drives if d.role == "source_test"}
        assert held_out <= set(source), "held-out source drives: tyre states seen in training"
        faults = {f for d in drives for f in d.gnss_faults}
        assert faults == {"low_sats", "frozen", "jump", "gap"}
        # What the first m seconds of a target test drive cannot show: a slow leak, and
        # a payload heavier than any target training drive carried.
        target_test = [d for d in drives if d.role == "target_test"]
        assert any(d.leaks for d in target_test)
        assert not any(d.leaks for d in drives if d.role == "target_train")
        most_trained = max(d.payload_kg for d in drives if d.role == "target_train")
        assert max(d.payload_kg for d in target_test) > most_trained
    paper = params.sim.profiles["paper"].drives
    minutes = {r: sum(d.duration_s for d in paper if d.role == r) / 60 for r in ROLES}
    assert minutes["source_train"] == pytest.approx(1590, rel=0.05)  # Table A1: ~26.5 h
    assert minutes["target_train"] == pytest.approx(104, rel=0.05)  # Table A2: ~104 min
    tests = sorted(d.duration_s / 60 for d in paper if d.role == "target_test")
    np.testing.assert_allclose(tests, sorted([13.8, 10.5, 59.9, 43.0]), rtol=0.02)  # Table A3
    held_out = [d for d in paper if d.role == "source_test"]
    assert len(held_out) == 3 and all(20 <= d.duration_s / 60 <= 40 for d in held_out)
    assert all(len(d.roads) >= 2 for d in held_out)  # mixed roads
    ci = params.sim.profiles["ci"].drives
    ci_source = sum(d.duration_s for d in ci if d.role == "source_train") / 60
    assert ci_source == pytest.approx(minutes["source_train"] / 20, rel=0.25)


def test_the_paper_target_is_another_car_of_the_source_model(params, cars):
    # Paper 3.1.1-3.1.2: IO-VNBD and CUPAC were both recorded on Ford Fiestas.
    mapping = params.sim.profiles["paper"].vehicles
    source, target = cars[mapping["source"]], cars[mapping["target"]]
    assert source.name != target.name
    assert target.nominal_radius_m == source.nominal_radius_m  # same tyre size
    for key in ("wheelbase_m", "track_front_m", "track_rear_m", "drive", "gear_ratios"):
        assert getattr(target.params, key) == getattr(source.params, key), key
    # Their new tyres differ within the manufacturing tolerance of one size: UN R30
    # allows the section height 2H to lie between 97 % and 104 % of its design value.
    section_height = 0.55 * 0.195  # 195/55 R15
    spread = target.unloaded_radius_new_m - source.unloaded_radius_new_m
    assert 0.0 < abs(spread) < 0.04 * section_height
    # ...and so do sensors, logger and driver.
    assert target.params.can != source.params.can
    assert target.params.gnss != source.params.gnss
    assert target.params.driver != source.params.driver
    # The car-size shift stays one override away: the large_target profile.
    large = params.sim.profiles["large_target"]
    assert large.drives == params.sim.profiles["paper"].drives
    big = cars[large.vehicles["target"]]
    assert big.nominal_radius_m > 1.05 * source.nominal_radius_m


@pytest.mark.parametrize(
    "consumer, parent", [("paper_consumer", "paper"), ("large_target_consumer", "large_target")]
)
def test_consumer_worlds_differ_from_their_parents_only_in_the_targets_receiver(
    params, consumer, parent
):
    # Issue 16's matrix: each target car under both receiver grades, the same drives and seeds.
    world, base = params.sim.profiles[consumer], params.sim.profiles[parent]
    assert world.vehicles == base.vehicles and world.drives == base.drives
    cars, parents = vehicles_from_params(params, consumer), vehicles_from_params(params, parent)
    assert cars["source"] == parents["source"] and cars["source"].receiver is None
    target, own = cars["target"], parents["target"]
    assert target.name == own.name and target.receiver == "ublox_m8"
    assert target.params.gnss == params.sim.receivers["ublox_m8"] != own.params.gnss
    assert dataclasses.replace(target.params, gnss=own.params.gnss) == own.params
    # The consumer receiver's per-second displacement noise is a few times the logger's.
    assert gnss_increment_std_m(target.params.gnss) > 2.0 * gnss_increment_std_m(own.params.gnss)


@pytest.mark.parametrize("profile, target_radius", [("paper", 0.294), ("large_target", 0.317)])
def test_nominal_radius_comes_from_the_simulated_car_or_data_vehicles(profile, target_radius):
    sim = load_params(overrides={"sim.profile": profile})
    assert sim.nominal_radius_m("target") == target_radius
    assert sim.nominal_radius_m("source") == sim.sim.vehicles["fiesta"].nominal_radius_m
    files = load_params(overrides={"sim.profile": profile, "data.source": "files"})
    for vehicle, spec in files.data.vehicles.items():
        assert files.nominal_radius_m(vehicle) == spec.nominal_radius_m
    with pytest.raises(ConfigError, match="bus"):
        sim.nominal_radius_m("bus")
    with pytest.raises(ConfigError, match="bus"):
        files.nominal_radius_m("bus")


def test_vehicles_from_params_follow_the_profile(params):
    paper = vehicles_from_params(params)
    assert {k: v.name for k, v in paper.items()} == {"source": "fiesta", "target": "fiesta_cupac"}
    large = vehicles_from_params(params, "large_target")
    assert large["target"].name == "focus" and large["source"] == paper["source"]
    with pytest.raises(ConfigError, match="sim.profiles"):
        vehicles_from_params(params, "nope")


def test_the_world_seed_is_sim_seed(params):
    spec = params.sim.profiles["ci"].drives[0]
    vehicle = vehicles_from_params(params)[spec.vehicle]

    def route_length(p):
        seed = drive_seed(p.sim.seed, 0)
        return generate_route(spec, p.sim, vehicle, child_rng(seed, 0)).n

    base = route_length(params)
    assert route_length(load_params(overrides={"seeds": [s + 1 for s in params.seeds]})) == base
    assert route_length(load_params(overrides={"sim.seed": params.sim.seed + 1})) != base


@pytest.mark.parametrize(
    "override, message",
    [
        ({"sim.profile": "nope"}, "sim.profile"),
        ({"sim.record_hz": 7}, "multiple"),
        ({"sim.roads.urban.speed_m_s": [14.0, 9.0]}, r"\[min, max\]"),
        ({"sim.roads.urban.per_km": {"teleport": 1.0}}, "SIM_EVENTS|among"),
        ({"sim.profiles.large_target.drives_from": "nope"}, "drives_from"),
        ({"sim.profiles.large_target.drives_from": "large_target"}, "drives_from"),
        ({"sim.profiles.large_target.vehicles.target": "bus"}, "not in sim.vehicles"),
        ({"sim.profiles.large_target.vehicles": {"source": "fiesta"}}, "vehicle 'target'"),
        ({"sim.vehicles.fiesta.gnss.filter_tau_s": 0.0}, "filter_tau_s must be > 0"),
        ({"sim.receivers.ublox_m8.tau_s": 0.0}, "sim.receivers.ublox_m8.tau_s must be > 0"),
        ({"sim.receivers.ublox_m8.sats": [18, 10]}, r"ublox_m8.sats: expected \[min, max\]"),
        ({"sim.profiles.paper_consumer.receivers.target": "vbox"}, "not in sim.receivers"),
        ({"sim.profiles.paper_consumer.receivers": {"bus": "ublox_m8"}}, "'bus' is not in"),
        ({"sim.vehicles.focus.gyro.warmup_tau_s": 0.0}, "gyro.warmup_tau_s must be > 0"),
        ({"sim.vehicles.focus.gyro.quantum_deg_s": -0.01}, "gyro.quantum_deg_s must be >= 0"),
        ({"sim.seed": "abc"}, "sim.seed"),
    ],
)
def test_bad_sim_params_are_config_errors(override, message):
    with pytest.raises(ConfigError, match=message):
        load_params(overrides=override)


def test_ci_fleet_outputs_and_determinism(tmp_path):
    ci = load_params(overrides={"sim.profile": "ci"})
    out = []
    for k in range(2):
        summary = simulate_fleet(ci, tmp_path / f"run{k}" / "sim")
        out.append(tmp_path / f"run{k}" / "sim")
    a, b = out
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    for rel in files:
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel
    drives = ci.sim.profiles["ci"].drives
    for d in drives:
        for suffix in (".csv", ".scenarios.json", ".truth.json"):
            assert (a / d.role / f"{d.name}{suffix}").is_file()
    fleet = json.loads((a / "fleet.json").read_text())
    assert fleet["profile"] == "ci" and fleet["seed"] == ci.sim.seed
    assert fleet["vehicles"] == {"source": "fiesta", "target": "fiesta_cupac"}
    assert [d["drive"] for d in fleet["drives"]] == [d.name for d in drives]
    assert set(fleet["roles"]) == set(ROLES)
    assert summary["roles"]["target_test"]["drives"] == 4
    assert summary["roles"]["source_test"]["drives"] == 2
    truth = json.loads((a / "source_test" / "V-H1.truth.json").read_text())
    assert truth["vehicle"] == "fiesta" and truth["pipeline_vehicle"] == "source"
    delta2 = json.loads((a / "target_test" / "V-Delta2.truth.json").read_text())
    assert delta2["leaks"] == [{"wheel": "rl", "psi_per_h": 4.0}]
    assert delta2["tyre_timeline"]["t_s"][0] == 0.0
    kinds = {k for d in summary["drives"] for k in d["gnss_faults"]}
    assert kinds == {"low_sats", "frozen", "jump", "gap"}
    assert not list(tmp_path.glob("run0/.sim.tmp-*"))  # nothing left behind


@pytest.mark.slow
def test_paper_fleet_in_well_under_a_minute(tmp_path, params):
    start = time.perf_counter()
    summary = simulate_fleet(params, tmp_path / "sim")
    seconds = time.perf_counter() - start
    assert seconds < 60.0
    roles = summary["roles"]
    assert roles["source_train"]["hours"] == pytest.approx(26.5, rel=0.01)
    assert roles["source_train"]["km"] > 900  # paper: 1165 km
    assert roles["target_test"]["drives"] == 4
    truths = [json.loads(p.read_text()) for p in (tmp_path / "sim").rglob("*.truth.json")]
    assert len(truths) == len(params.sim.profiles["paper"].drives)


@pytest.mark.slow
def test_stage_script_writes_data_sim(tmp_path):
    params_text = (ROOT / "params.yaml").read_text().replace("  profile: paper", "  profile: ci", 1)
    (tmp_path / "params.yaml").write_text(params_text)
    (tmp_path / "dvc.yaml").write_text((ROOT / "dvc.yaml").read_text())
    env = {**os.environ, "RWHONET_ROOT": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, str(ROOT / "pipelines" / "simulate.py")],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert "Simulated profile 'ci'" in done.stdout and "target_test 4 drives" in done.stdout
    assert len(list((tmp_path / "data" / "sim" / "target_test").glob("*.csv"))) == 4
