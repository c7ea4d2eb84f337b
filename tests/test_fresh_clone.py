"""A fresh clone of the committed repository has everything `make run` and CI need.

Checks what a new user or CI meets first: the pipeline's code and params are
tracked (not ignored, not only on this machine), data.dvc is clean once the
empty data/raw exists, and DVC sees the whole pipeline.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from rwhonet import paths

BIN = Path(sys.executable).parent

pytestmark = pytest.mark.slow  # git clone and several dvc commands


def _run(cmd, cwd, **kw):
    env = dict(os.environ, DVC_NO_ANALYTICS="1", PATH=f"{BIN}{os.pathsep}{os.environ['PATH']}")
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300, **kw)


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    if not (paths.ROOT / ".git").exists() or shutil.which("git") is None:
        pytest.skip("not a git checkout")
    head = _run(["git", "rev-parse", "--verify", "HEAD"], paths.ROOT)
    if head.returncode != 0:
        pytest.skip("no commit yet")
    dest = tmp_path_factory.mktemp("clone") / "repo"
    out = _run(["git", "clone", "-q", str(paths.ROOT), str(dest)], paths.ROOT)
    assert out.returncode == 0, out.stderr
    return dest


def test_pipeline_code_and_params_are_tracked(clone):
    stages = yaml.safe_load((clone / "dvc.yaml").read_text())["stages"]
    outs = set()
    for st in stages.values():
        for o in st.get("outs", []) + st.get("metrics", []):
            outs.add((next(iter(o)) if isinstance(o, dict) else o).split("${")[0])
    for name, st in stages.items():
        for dep in st.get("deps", []):
            # outputs of other stages (or folders holding them) appear only when the stage runs
            if "${" in dep or any(dep.startswith(o) or o.startswith(dep) for o in outs):
                continue
            assert (clone / dep).exists(), f"stage {name}: dependency {dep} is not in a fresh clone"
        script = st["cmd"].split()[1]
        assert (clone / script).is_file(), f"stage {name}: {script} missing from a fresh clone"
    for f in ("params.yaml", "data.dvc", "Makefile", "pyproject.toml", ".ci/run", "README.md"):
        assert (clone / f).is_file(), f
    assert os.access(clone / ".ci/run", os.X_OK)
    assert "make test" in (clone / ".ci/run").read_text()


def test_data_dvc_clean_and_pipeline_plannable(clone):
    (clone / "data" / "raw").mkdir(parents=True, exist_ok=True)
    assert _run(["dvc", "commit", "-q", "-f", "data.dvc"], clone).returncode == 0
    status = _run(["dvc", "status", "data.dvc"], clone)
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout
    assert _run(["git", "status", "--porcelain", "data.dvc"], clone).stdout == ""
    dag = _run(["dvc", "dag", "--md"], clone)
    assert dag.returncode == 0, dag.stderr
    for stage in ("simulate", "ingest", "validate", "label", "train", "adapt"):
        assert stage in dag.stdout
    assert "evaluate" in dag.stdout


def test_readme_commands_exist(clone):
    for target in ("run", "test"):
        out = _run(["make", "-n", target], clone)
        assert out.returncode == 0, out.stderr
    readme = (clone / "README.md").read_text()
    assert "make run" in readme and "make test" in readme
