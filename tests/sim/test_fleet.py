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
from rwhonet.sim import drive_seed, generate_route, simulate_drive, simulate_fleet
from rwhonet.sim.drive import child_rng

ROOT = Path(__file__).resolve().parents[2]
ROLES = ("source_train", "source_calibration", "target_train", "target_test")
# Each ci test drive: m <= 100 s of adaptation, then two 180 s outage windows.
MIN_TEST_S = 100 + 2 * 180


def test_ci_test_drives_are_long_enough_and_clean(params, vehicles):
    ci = load_params(overrides={"sim.profile": "ci"})
    drives = ci.sim.profiles["ci"].drives
    tests = [(i, d) for i, d in enumerate(drives) if d.role == "target_test"]
    assert len(tests) == 4
    for i, spec in tests:
        assert spec.duration_s >= MIN_TEST_S and not spec.gnss_faults
        seed = drive_seed(ci.seed, i)
        vehicle = vehicles[spec.vehicle]
        route = generate_route(spec, ci.sim, vehicle, child_rng(seed, 0))
        frame, scenarios, _, _ = simulate_drive(vehicle, spec.tyre, route, seed, ci.sim)
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
        faults = {f for d in drives for f in d.gnss_faults}
        assert faults == {"low_sats", "frozen", "jump", "gap"}
    paper = params.sim.profiles["paper"].drives
    minutes = {r: sum(d.duration_s for d in paper if d.role == r) / 60 for r in ROLES}
    assert minutes["source_train"] == pytest.approx(1590, rel=0.05)  # Table A1: ~26.5 h
    assert minutes["target_train"] == pytest.approx(104, rel=0.05)  # Table A2: ~104 min
    tests = sorted(d.duration_s / 60 for d in paper if d.role == "target_test")
    np.testing.assert_allclose(tests, sorted([13.8, 10.5, 59.9, 43.0]), rtol=0.02)  # Table A3
    ci = params.sim.profiles["ci"].drives
    ci_source = sum(d.duration_s for d in ci if d.role == "source_train") / 60
    assert ci_source == pytest.approx(minutes["source_train"] / 20, rel=0.25)


def test_nominal_radii_match_data_vehicles(vehicles, params):
    for name, vehicle in vehicles.items():
        assert vehicle.nominal_radius_m == params.data.vehicles[name].nominal_radius_m
    data = dataclasses.replace(params.data, vehicles={"source": params.data.vehicles["source"]})
    with pytest.raises(ConfigError, match="data.vehicles"):
        simulate_fleet(dataclasses.replace(params, data=data), Path("/nonexistent/never-written"))


@pytest.mark.parametrize(
    "override, message",
    [
        ({"sim.profile": "nope"}, "sim.profile"),
        ({"sim.record_hz": 7}, "multiple"),
        ({"sim.roads.urban.speed_m_s": [14.0, 9.0]}, r"\[min, max\]"),
        ({"sim.roads.urban.per_km": {"teleport": 1.0}}, "SIM_EVENTS|among"),
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
    assert fleet["profile"] == "ci" and fleet["seed"] == ci.seed
    assert [d["drive"] for d in fleet["drives"]] == [d.name for d in drives]
    assert set(fleet["roles"]) == set(ROLES)
    assert summary["roles"]["target_test"]["drives"] == 4
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
