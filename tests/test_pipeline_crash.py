"""Crash tests: a training stage killed mid-epoch, on the `ci` profile in a scratch copy.

Every stage writes its outputs atomically (``rwhonet.io.atomic_outputs``) and
records a failure in MLflow (``rwhonet.runner.run``). Here the real
``train`` stage (G and S of one seed, side by side in two worker processes) is
stopped while Lightning trains, three ways:

- SIGKILL to the stage script run by hand: the previous outputs stay, byte for
  byte, and DVC still finds the stage up to date;
- SIGTERM to the stage under ``dvc repro``: DVC fails, the store holds one
  KILLED run naming the stage and the signal, and none RUNNING;
- SIGKILL to ``dvc repro`` and its stage together: nothing half-written is left,
  the next ``dvc repro`` completes with the same model as the uninterrupted run,
  and so does training G again from scratch.

The project runs the pipeline up to ``train`` only: the later stages' inputs are
train's outputs, the same bytes after every crash here, so DVC would never run
them again and their metrics could not differ (training is deterministic:
``tests/test_pipeline.py``).

"Mid-epoch" is measured in CPU time (the stage's processes summed), which the
machine's load does not stretch: the stage is stopped once it has used as much
CPU as the uninterrupted run's stage used before its shorter fit was half done
(both fits start together); a stopped stage must not have printed the line it
prints once a model's outputs are written. Slow: about two minutes.
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
}
STAGE = "pipelines/train.py"
DONE = "training seconds from"  # in the line the stage prints once its outputs are written
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def _stage_processes(group: int) -> list[int]:
    """The training stage's interpreters in a process group: its own and its workers'."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
            if STAGE.encode() in cmd and os.getpgid(int(entry.name)) == group:
                pids.append(int(entry.name))
        except (OSError, ProcessLookupError):
            continue
    return pids


def _main_process(pids: list[int]) -> int | None:
    """The stage's own interpreter: the one whose parent is not one of them (a worker's is)."""
    for pid in pids:
        try:
            parent = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
        except OSError:
            continue
        if parent not in pids:
            return pid
    return None


def _cpu_s(pids: list[int]) -> float:
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # it ended
            continue
        total += (int(fields[11]) + int(fields[12])) / CLOCK_TICKS  # utime + stime
    return total


def _stop_mid_fit(proc: subprocess.Popen, at_cpu_s: float, signum: int, *, group: bool) -> None:
    """Send ``signum`` once the stage in ``proc``'s group has used ``at_cpu_s`` of CPU."""
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline:
        assert proc.poll() is None, "the stage ended before it could be stopped"
        pids = _stage_processes(proc.pid)
        if pids and _cpu_s(pids) >= at_cpu_s:
            break
        time.sleep(0.05)
    else:
        pytest.fail("the stage never reached the middle of its fit")
    if group:
        os.killpg(proc.pid, signum)
    else:
        os.kill(_main_process(pids), signum)


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
        cpu = max(cpu, _cpu_s(_stage_processes(proc.pid)))
        time.sleep(0.05)
    output = proc.stdout.read()
    assert proc.returncode == 0, output
    return output, cpu


@pytest.fixture(scope="module")
def project(tmp_path_factory, ci_data):
    """The ci pipeline to train, run once, uninterrupted; and the CPU seconds G is mid-fit."""
    repo = scratch_project(tmp_path_factory.mktemp("crash") / "repo", OVERRIDES, ci_data)
    out = dvc(repo, "repro", "label")
    assert out.returncode == 0, out.stdout + out.stderr
    output, stage_cpu_s = _run_watching_cpu(repo, str(BIN / "dvc"), "repro", "train")
    fits_s = [float(s) for s in re.findall(r"epochs in ([\d.]+) s", output)]
    assert len(fits_s) == 2, output  # G and S of seed 1
    return {
        "repo": repo,
        # both fits start together: the shorter is half done when the two have used it all
        "mid_fit_cpu_s": stage_cpu_s - sum(fits_s) + min(fits_s),
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
    status = dvc(repo, "status", "train")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout


def test_sigterm_to_the_stage_under_dvc_is_a_killed_run(project):
    repo = project["repo"]
    proc = _start(repo, str(BIN / "dvc"), "repro", "--force", "--single-item", "train")
    _stop_mid_fit(proc, project["mid_fit_cpu_s"], signal.SIGTERM, group=False)
    output, _ = proc.communicate(timeout=300)
    assert proc.returncode != 0 and DONE not in output, output
    # -15 when DVC's shell execs the command, 143 (128 + 15) when the shell reports it
    assert "failed to reproduce 'train'" in output
    assert not _stage_processes(proc.pid)  # the workers were ended with it, not left to train
    assert re.search(r"exited with (-15|143)\b", output), output
    assert "stage train interrupted by SIGTERM" in output and "MLflow: KILLED run" in output
    uri = f"sqlite:///{repo}/mlruns/mlflow.db"
    runs = store_runs(uri)
    assert not [r for r in runs if r.info.status == "RUNNING"]
    (killed,) = [r for r in runs if r.data.tags.get("rwhonet.failure") == "true"]
    assert killed.info.status == "KILLED"
    assert killed.data.tags["dvc_stage"] == "train"
    assert killed.data.tags["rwhonet.command"] == STAGE
    assert killed.data.tags["rwhonet.error"] == "stage train interrupted by SIGTERM"
    assert integrity(uri) == "ok"
    seed1 = repo / "models/g/seed1"
    assert not seed1.exists() or _files(seed1) == project["g"]


def test_sigkill_to_dvc_repro_then_dvc_repro_gives_the_same_model(project):
    repo = project["repo"]
    proc = _start(repo, str(BIN / "dvc"), "repro", "--force", "--single-item", "train")
    _stop_mid_fit(proc, project["mid_fit_cpu_s"], signal.SIGKILL, group=True)
    output, _ = proc.communicate(timeout=60)
    assert DONE not in output, output
    g = repo / "models/g"
    left = [p.name for p in g.iterdir() if p.name != ".gitignore"] if g.exists() else []
    assert left in ([], ["seed1"]), left  # DVC removes a stage's outputs before running it
    if left:
        assert _files(g / "seed1") == project["g"]
    out = dvc(repo, "repro", "train")  # what a user runs next (the project stops at train)
    assert out.returncode == 0, out.stdout + out.stderr
    assert _files(g / "seed1") == project["g"]
    status = dvc(repo, "status", "train")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout
    # and trained again for real (--force bypasses the run cache): the same weights, byte for byte
    out = dvc(repo, "repro", "--force", "--single-item", "train")
    assert out.returncode == 0 and "Running stage 'train'" in out.stdout, out.stdout
    assert _files(g / "seed1") == project["g"]
    assert [p.name for p in g.iterdir() if p.name != ".gitignore"] == ["seed1"]
    assert dvc(repo, "status", "train").stdout.strip().endswith("up to date.")
