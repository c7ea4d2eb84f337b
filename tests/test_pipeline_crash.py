"""Crash tests: a training stage killed mid-epoch, on the `ci` profile in a scratch copy.

Every stage writes its outputs atomically (``rwhonet.io.atomic_outputs``) and
records a failure in MLflow (``rwhonet.runner.run``). Here the real
``train_g@1`` stage is stopped while Lightning trains, three ways:

- SIGKILL to the stage script run by hand: the previous outputs stay, byte for
  byte, and DVC still finds the pipeline up to date;
- SIGTERM to the stage under ``dvc repro``: DVC fails, the store holds one
  KILLED run naming the stage and the signal, and none RUNNING;
- SIGKILL to ``dvc repro`` and its stage together: nothing half-written is left,
  the next ``dvc repro`` completes with the same model and metrics as the
  uninterrupted run, and so does training G again from scratch.

"Mid-epoch" is measured in CPU time, which the machine's load does not stretch:
the stage is stopped once it has used half its fit's length less CPU than the
uninterrupted run's stage used in all; a stopped stage must not have printed
the line it prints once its outputs are written. Slow: about two minutes.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from support.project import BIN, dvc, env, scratch_project
from support.store import integrity, store_runs

pytestmark = [pytest.mark.slow, pytest.mark.crash]

# G's fit lasts several seconds: long enough to be stopped in the middle.
OVERRIDES = {
    ("seeds",): [1],
    ("sim", "profile"): "ci",
    ("train", "epochs"): 400,
    ("adapt", "epochs"): 5,
    ("adapt", "m_grid"): [10, 20],
    ("adapt", "fallback", "m"): 20,
    ("adapt", "steps", "max_steps"): 20,
    ("evaluate", "outages_s"): [30, 180],
}
STAGE = "pipelines/train.py"
DONE = "training seconds from"  # in the line the stage prints once its outputs are written
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def _stage_process(group: int) -> int | None:
    """The pid of the training stage's interpreter in a process group, if it runs."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
            if STAGE.encode() in cmd and os.getpgid(int(entry.name)) == group:
                return int(entry.name)
        except (OSError, ProcessLookupError):
            continue
    return None


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS  # utime + stime


def _stop_mid_fit(proc: subprocess.Popen, at_cpu_s: float, signum: int, *, group: bool) -> None:
    """Send ``signum`` once the stage in ``proc``'s group has used ``at_cpu_s`` of CPU."""
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the stage ended before it could be stopped"
        pid = _stage_process(proc.pid)
        try:
            if pid is not None and _cpu_s(pid) >= at_cpu_s:
                break
        except OSError:
            pass
        time.sleep(0.05)
    else:
        pytest.fail("the stage never reached the middle of its fit")
    if group:
        os.killpg(proc.pid, signum)
    else:
        os.kill(pid, signum)


def _start(repo: Path, *cmd: str) -> subprocess.Popen:
    return subprocess.Popen(
        list(cmd),
        cwd=repo,
        env=env(repo),
        start_new_session=True,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _run_watching_cpu(repo: Path, *cmd: str) -> tuple[str, float]:
    """Run ``cmd`` to its end; return its output and the CPU seconds its stage process used."""
    proc = _start(repo, *cmd)
    cpu = 0.0
    while proc.poll() is None:
        pid = _stage_process(proc.pid)
        try:
            cpu = max(cpu, _cpu_s(pid)) if pid is not None else cpu
        except OSError:
            pass
        time.sleep(0.05)
    output = proc.stdout.read()
    assert proc.returncode == 0, output
    return output, cpu


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    """The ci pipeline run once, uninterrupted; and the CPU seconds at which G is mid-fit."""
    repo = scratch_project(tmp_path_factory.mktemp("crash") / "repo", OVERRIDES)
    out = dvc(repo, "repro", "label")
    assert out.returncode == 0, out.stdout + out.stderr
    output, stage_cpu_s = _run_watching_cpu(repo, str(BIN / "dvc"), "repro", "train_g@1")
    fit_s = float(re.search(r"epochs in ([\d.]+) s", output).group(1))
    out = dvc(repo, "repro")
    assert out.returncode == 0, out.stdout + out.stderr
    return {
        "repo": repo,
        "mid_fit_cpu_s": stage_cpu_s - fit_s / 2,
        "eval": (repo / "metrics/eval.json").read_text(),
        "g": _files(repo / "models/g/seed1"),
        "g_inode": (repo / "models/g/seed1").stat().st_ino,
    }


def test_sigkill_to_the_stage_leaves_its_previous_outputs(project):
    repo = project["repo"]
    proc = _start(repo, str(BIN / "python"), STAGE, "G", "--seed", "1")
    _stop_mid_fit(proc, project["mid_fit_cpu_s"], signal.SIGKILL, group=True)
    output, _ = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert DONE not in output  # it was still training
    # the very folder of the uninterrupted run, untouched (a finished rerun would have
    # renamed a new one into place, with the same bytes: training is deterministic)
    assert (repo / "models/g/seed1").stat().st_ino == project["g_inode"]
    assert _files(repo / "models/g/seed1") == project["g"]
    assert [p.name for p in (repo / "models/g").iterdir() if p.name != ".gitignore"] == ["seed1"]
    status = dvc(repo, "status")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout


def test_sigterm_to_the_stage_under_dvc_is_a_killed_run(project):
    repo = project["repo"]
    proc = _start(repo, str(BIN / "dvc"), "repro", "--force", "--single-item", "train_g@1")
    _stop_mid_fit(proc, project["mid_fit_cpu_s"], signal.SIGTERM, group=False)
    output, _ = proc.communicate(timeout=300)
    assert proc.returncode != 0 and DONE not in output, output
    # -15 when DVC's shell execs the command, 143 (128 + 15) when the shell reports it
    assert "failed to reproduce 'train_g@1'" in output
    assert re.search(r"exited with (-15|143)\b", output), output
    assert "stage train_g interrupted by SIGTERM" in output and "MLflow: KILLED run" in output
    uri = f"sqlite:///{repo}/mlruns/mlflow.db"
    runs = store_runs(uri)
    assert not [r for r in runs if r.info.status == "RUNNING"]
    (killed,) = [r for r in runs if r.data.tags.get("rwhonet.failure") == "true"]
    assert killed.info.status == "KILLED"
    assert killed.data.tags["dvc_stage"] == "train_g"
    assert killed.data.tags["rwhonet.command"] == f"{STAGE} G --seed 1"
    assert killed.data.tags["rwhonet.error"] == "stage train_g interrupted by SIGTERM"
    assert integrity(uri) == "ok"
    seed1 = repo / "models/g/seed1"
    assert not seed1.exists() or _files(seed1) == project["g"]


def test_sigkill_to_dvc_repro_then_dvc_repro_gives_the_same_metrics(project):
    repo = project["repo"]
    proc = _start(repo, str(BIN / "dvc"), "repro", "--force", "--single-item", "train_g@1")
    _stop_mid_fit(proc, project["mid_fit_cpu_s"], signal.SIGKILL, group=True)
    output, _ = proc.communicate(timeout=60)
    assert DONE not in output, output
    g = repo / "models/g"
    left = [p.name for p in g.iterdir() if p.name != ".gitignore"]
    assert left in ([], ["seed1"]), left  # DVC removes a stage's outputs before running it
    if left:
        assert _files(g / "seed1") == project["g"]
    out = dvc(repo, "repro")  # what a user runs next
    assert out.returncode == 0, out.stdout + out.stderr
    assert _files(g / "seed1") == project["g"]
    assert (repo / "metrics/eval.json").read_text() == project["eval"]
    status = dvc(repo, "status")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout
    # and trained again for real (--force bypasses the run cache): the same weights, byte for byte
    out = dvc(repo, "repro", "--force", "--single-item", "train_g@1")
    assert out.returncode == 0 and "Running stage 'train_g@1'" in out.stdout, out.stdout
    assert _files(g / "seed1") == project["g"]
    assert [p.name for p in g.iterdir() if p.name != ".gitignore"] == ["seed1"]
    assert dvc(repo, "status").stdout.strip().endswith("up to date.")
