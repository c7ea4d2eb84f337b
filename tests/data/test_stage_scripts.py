"""The ingest and validate stage scripts, run as DVC runs them (a subprocess from the root)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rwhonet import paths

from .drives import straight_drive, write_fleet, write_iovnbd, write_params_yaml

pytestmark = pytest.mark.slow  # two interpreter start-ups per stage (pandas, pandera, pyarrow)


def stage(name: str, root: Path) -> subprocess.CompletedProcess:
    env = os.environ | {"RWHONET_ROOT": str(root)}
    script = paths.ROOT / "pipelines" / f"{name}.py"
    return subprocess.run(
        [sys.executable, str(script)], cwd=root, env=env, capture_output=True, text=True
    )


def test_ingest_then_validate_and_a_failing_validate(tmp_path):
    raw = tmp_path / "data" / "raw"
    files = write_fleet(raw, duration_s=40.0)
    write_params_yaml(tmp_path / "params.yaml", **{"data.source": "files", "data.root": "data/raw"})

    done = stage("ingest", tmp_path)
    assert done.returncode == 0, done.stderr
    assert "3 drive(s), 1203 rows" in done.stdout and "M rows/s" in done.stdout
    done = stage("validate", tmp_path)
    assert done.returncode == 0, done.stderr
    assert "120 of 123 s kept" in done.stdout
    segments = tmp_path / "data" / "interim" / "segments"
    report = json.loads((tmp_path / "reports" / "validation.json").read_text())
    assert report["totals"]["segments"] == 3
    before = sorted(p.name for p in segments.iterdir())

    df = straight_drive(40.0)
    df.loc[99, "lat_deg"] = -95.0  # data row 100
    write_iovnbd(df, files["source_train"])
    assert stage("ingest", tmp_path).returncode == 0
    done = stage("validate", tmp_path)
    assert done.returncode == 2
    assert "ERROR in stage validate.py" in done.stderr
    assert "V-S1.csv, row 100, column ' Lat': expected a latitude in [-90, 90] deg" in done.stderr
    assert sorted(p.name for p in segments.iterdir()) == before
