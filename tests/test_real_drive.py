"""The README's real-drive commands, word for word, on the real RAV4 minute.

README.md, "A real drive", shows the commands that recalibrate the pipeline's
G-WhONet (``models:/whonet-G/latest``, which a pipeline run registers) on the
first 20 s of ``../shared/real/comma2k19-example1`` with the RAV4's tyre radius,
and stream the drive through the result. This test takes those commands out of
the README (so the README cannot drift from what works) and runs them in the
session's ci project after ``dvc repro`` (its registry then holds whonet-G),
with the real folder where the README's relative path finds it.

Slow (a pipeline run, shared with tests/test_pipeline.py); skipped where the real
segment is not on the machine.
"""

from __future__ import annotations

import re
import shlex
import subprocess

import pandas as pd
import pytest

from rwhonet import paths
from support.project import env

pytestmark = pytest.mark.slow

REAL = paths.ROOT.parent / "shared" / "real" / "comma2k19-example1"
SECTION = "## A real drive"


def readme_commands() -> list[str]:
    """The ``rwhonet`` commands of the README's real-drive section, in order."""
    text = (paths.ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index(SECTION) :]
    section = section[: section.find("\n## ", len(SECTION))]
    blocks = re.findall(r"```bash\n(.*?)```", section, flags=re.S)
    return [ln.strip() for b in blocks for ln in b.splitlines() if ln.startswith("rwhonet ")]


def test_the_readme_shows_both_commands_on_the_real_folder():
    commands = readme_commands()
    assert [shlex.split(c)[1] for c in commands] == ["recalibrate", "predict"]
    for c in commands:
        args = shlex.split(c)
        assert args[args.index("--drive") + 1] == "../shared/real/comma2k19-example1"
        assert args[args.index("--format") + 1] == "comma2k19"
        assert args[args.index("--nominal-radius") + 1] == "0.362"
    recalibrate = shlex.split(commands[0])
    assert recalibrate[recalibrate.index("--base") + 1] == "models:/whonet-G/latest"
    assert recalibrate[recalibrate.index("--seconds") + 1] == "20"


@pytest.fixture(scope="module")
def ran(ci_pipeline, request):
    if not (REAL / "processed_log").is_dir():
        pytest.skip(f"the real comma2k19 segment is not on this machine ({REAL})")
    request.getfixturevalue("ci_repro")  # the session's whole ci pipeline, run once
    # The README's path is relative to the checkout: ../shared/real/... beside it.
    beside = ci_pipeline.parent / "shared" / "real" / REAL.name
    if not beside.exists():
        beside.parent.mkdir(parents=True, exist_ok=True)
        beside.symlink_to(REAL, target_is_directory=True)
    out = []
    for command in readme_commands():
        done = subprocess.run(
            ["bash", "-c", command],
            cwd=ci_pipeline,
            env=env(ci_pipeline),
            capture_output=True,
            text=True,
            timeout=600,
        )
        out.append(done)
    return ci_pipeline, out


def test_recalibrate_reads_checks_and_registers_the_real_drive(ran):
    _, (recal, _) = ran
    assert recal.returncode == 0, recal.stdout + recal.stderr
    said = recal.stdout
    assert "../shared/real/comma2k19-example1: 59 valid s of 61 s (cut: partial_second 2 s)" in said
    assert "on the first 20 s" in said and "registered whonet-R-rav4 version 1" in said
    assert "scored on the remaining 39 s" in said
    # a car the pipeline has no drives of: the source car's evidence, the prior on its size
    assert "prior centred on 0.35" in said and "drives, source)" in said
    assert re.search(r"^\s+30s\s+1\s", said, flags=re.M), said  # one 30 s window scored
    assert "Traceback" not in recal.stderr


def test_predict_streams_the_real_drive_through_the_recalibrated_model(ran):
    repo, (_, pred) = ran
    assert pred.returncode == 0, pred.stdout + pred.stderr
    assert "../shared/real/comma2k19-example1: 597 rows -> 59 seconds" in pred.stderr
    # the phone gyro reaches predict's check (and filter): too straight a minute to tell
    assert "yaw rate's unit and sign not told" in pred.stderr and "gain 0.97" in pred.stderr
    frame = pd.read_csv(repo / "rav4.csv")
    assert len(frame) == 59 and frame["t_s"].iloc[0] == 46410.0
    assert frame["disp_gnss_m"].sum() == pytest.approx(frame["disp_corrected_m"].sum(), rel=0.02)
