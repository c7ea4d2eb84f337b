"""The simulate stage in a files-mode project: no fleet, and ingest reads data/raw."""

from __future__ import annotations

import json

import pytest

from rwhonet.stages.simulate import NOT_SIMULATED
from support.drives import write_fleet
from support.project import dvc, scratch_project


@pytest.mark.slow  # a scratch project and two real DVC stages
def test_files_mode_simulates_nothing_and_ingests_data_raw(tmp_path):
    repo = scratch_project(
        tmp_path / "repo", {("data", "source"): "files", ("data", "root"): "data/raw"}
    )
    written = write_fleet(repo / "data" / "raw", duration_s=5.0)
    # The user's step of README "Your own drives": data.dvc tracks the new drives.
    out = dvc(repo, "commit", "-q", "-f", "data.dvc")
    assert out.returncode == 0, out.stderr

    out = dvc(repo, "repro", "simulate", "ingest")
    assert out.returncode == 0, out.stdout + out.stderr
    assert "no drives simulated" in out.stdout

    sim = repo / "data" / "sim"
    assert [p.name for p in sim.iterdir()] == [NOT_SIMULATED]
    manifest = json.loads((repo / "data" / "interim" / "drives" / "manifest.json").read_text())
    assert {d["source_file"] for d in manifest["drives"]} == {
        str(p.relative_to(repo)) for p in written.values()
    }
    # The note is a cached output like the fleet: nothing is left to run.
    status = dvc(repo, "status", "simulate", "ingest")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout
