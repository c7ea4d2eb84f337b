"""Scratch copies of the project for tests that run real DVC stages.

:func:`scratch_project` copies the working tree's tracked and unignored files
(``git ls-files -co --exclude-standard``, what ``make variant`` copies), sets
params overrides, and makes it a git repository of its own with ``data.dvc``
committed, so ``dvc repro`` there never touches the workspace's outputs. Given a project where
the data stages ran (:func:`data_stages_done`, built once per test session), it
starts from their outputs, as a user's workspace after ``dvc repro label`` does.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from rwhonet import paths

BIN = Path(sys.executable).parent
GIT = ["git", "-c", "user.name=t", "-c", "user.email=t@localhost"]

# The small but complete pipeline the slow tests share (tests/conftest.py: ci_pipeline):
# every stage, two seeds, two m values, two outage lengths.
CI_PIPELINE = {
    ("seeds",): [1, 2],
    ("sim", "profile"): "ci",
    ("train", "epochs"): 3,
    ("adapt", "epochs"): 5,
    ("adapt", "m_grid"): [10, 20],
    ("adapt", "fallback", "m"): 20,  # recipe and chosen_m stay auto
    ("adapt", "steps", "max_steps"): 20,
    ("evaluate", "outages_s"): [30, 180],
}


def env(repo: Path, **extra: str) -> dict[str, str]:
    """The environment a stage sees under ``dvc repro`` in ``repo`` (the venv's python first)."""
    e = dict(os.environ)
    e["PATH"] = f"{BIN}{os.pathsep}{e['PATH']}"
    e["PYTHONPATH"] = str(repo / "src")
    e["DVC_NO_ANALYTICS"] = "1"
    e["PYTHONUNBUFFERED"] = "1"
    for var in ("MLFLOW_TRACKING_URI", "RWHONET_ROOT"):
        e.pop(var, None)
    e.update(extra)
    return e


def dvc(repo: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run ``dvc <args>`` in ``repo``."""
    return subprocess.run(
        [str(BIN / "dvc"), *args],
        cwd=repo,
        env=env(repo),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def set_params(repo: Path, overrides: Mapping[tuple[str, ...], Any]) -> None:
    """Replace values of ``repo/params.yaml`` (keys as tuples: ``("train", "epochs")``)."""
    params = yaml.safe_load((repo / "params.yaml").read_text())
    for keys, value in overrides.items():
        node = params
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = value
    (repo / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))


def scratch_project(
    dest: Path, overrides: Mapping[tuple[str, ...], Any], stages_from: Path | None = None
) -> Path:
    """A copy of the working tree at ``dest``: its own git repository, ``data.dvc`` committed.

    Args:
        dest: a folder that does not exist yet.
        overrides: params to set before the snapshot commit.
        stages_from: a project where the data stages ran (:func:`data_stages_done`):
            ``dest`` starts with their outputs, cache and ``dvc.lock`` entries
            (:func:`take_stages`).

    Returns:
        ``dest``.
    """
    files = subprocess.run(
        ["git", "ls-files", "-co", "--exclude-standard", "-z"],
        cwd=paths.ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split("\0")
    for f in filter(None, files):
        src = paths.ROOT / f
        if src.is_file():
            (dest / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / f)
    set_params(dest, overrides)
    if stages_from is not None:
        take_stages(stages_from, dest)
    subprocess.run([*GIT, "init", "-q"], cwd=dest, check=True)
    subprocess.run([*GIT, "add", "-A"], cwd=dest, check=True)
    subprocess.run([*GIT, "commit", "-qm", "snapshot"], cwd=dest, check=True)
    (dest / "data" / "raw").mkdir(parents=True, exist_ok=True)
    out = dvc(dest, "commit", "-q", "-f", "data.dvc")
    assert out.returncode == 0, out.stderr
    return dest


# The stages before training: every ci-profile project in the suite would run them alike.
DATA_STAGES = ("simulate", "ingest", "validate", "label")


def take_stages(done: Path, dest: Path, stages: tuple[str, ...] = DATA_STAGES) -> None:
    """Give ``dest`` what ``stages`` left in ``done``: outputs, DVC cache, ``dvc.lock`` entries.

    DVC then finds each such stage up to date in ``dest`` where its code, params and
    inputs there are those it ran with in ``done``, and runs it again where they are
    not (another profile, other validate params): DVC decides, from the lock.
    """
    theirs = yaml.safe_load((done / "dvc.lock").read_text())["stages"]
    lock = dest / "dvc.lock"
    mine = yaml.safe_load(lock.read_text()) if lock.exists() else {"schema": "2.0", "stages": {}}
    for stage in stages:
        mine["stages"][stage] = theirs[stage]
        for out in theirs[stage].get("outs", []):
            src, to = done / out["path"], dest / out["path"]
            if to.is_dir():
                shutil.rmtree(to)
            to.parent.mkdir(parents=True, exist_ok=True)
            (shutil.copytree if src.is_dir() else shutil.copy2)(src, to)
    lock.write_text(yaml.safe_dump(mine, sort_keys=False))
    shutil.copytree(done / ".dvc" / "cache", dest / ".dvc" / "cache", dirs_exist_ok=True)


def data_stages_done(shared: Path) -> Path:
    """A ci-pipeline project (:data:`CI_PIPELINE`) under ``shared`` whose data stages ran.

    Built once for every process that asks with the same ``shared`` folder (the
    pytest-xdist workers of one session: ``tests/conftest.py``), under a lock: the
    first builds it, the others wait for it.
    """
    done = shared / "ci-data-stages"
    with open(shared / "ci-data-stages.lock", "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        if not (done / ".ran").exists():
            shutil.rmtree(done, ignore_errors=True)
            scratch_project(done, CI_PIPELINE)
            out = dvc(done, "repro", DATA_STAGES[-1])
            assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
            (done / ".ran").touch()
    return done


def commit(repo: Path, message: str) -> None:
    """Commit everything in ``repo`` (what ``dvc exp run --queue`` snapshots)."""
    subprocess.run([*GIT, "add", "-A"], cwd=repo, check=True)
    subprocess.run([*GIT, "commit", "-qm", message], cwd=repo, check=True)
