"""The train stage: byte-reproducible outputs, the fit's real times beside them, progress."""

import sys
import time

import pytest

from rwhonet import contracts, paths
from rwhonet.config import load_params
from rwhonet.stages.train import train_model
from rwhonet.tracking.timings import read_timing
from support.project import dvc
from support.project import env as project_env
from support.terminal import run_in_terminal

from .conftest import write_samples


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides={"train.epochs": 2, "model.hidden": 8})


def test_the_run_is_timed_by_its_fit_and_the_time_stays_out_of_the_outputs(tmp_path, params):
    samples = write_samples(
        tmp_path / "samples",
        [
            ("S__s0", "S", "source_train", 600),
            ("T__s0", "T", "target_train", 100),
            ("A__s0", "A", "target_test", 300),
        ],
    )
    before = int(time.time() * 1000)
    record, fit_s = train_model(params, "G", 1, samples, tmp_path / "g")
    after = int(time.time() * 1000)
    timing = read_timing(tmp_path / "g")
    assert timing == record.timing
    assert before <= timing.start_ms < timing.end_ms <= after
    # the run's duration is the fit's (plus building the module and Trainer around it)
    assert fit_s <= (timing.end_ms - timing.start_ms) / 1000 + 0.002 <= fit_s + 1.0
    first = {f.name: f.read_bytes() for f in (tmp_path / "g").iterdir()}
    assert b"start_ms" not in first[contracts.RUN_RECORD]
    train_model(params, "G", 1, samples, tmp_path / "g")  # a re-run: same bytes, a new time
    assert {f.name: f.read_bytes() for f in (tmp_path / "g").iterdir()} == first
    assert read_timing(tmp_path / "g").start_ms >= timing.end_ms


@pytest.mark.slow
@pytest.mark.parametrize("ci", [None, "true"])
def test_lightnings_bar_on_a_terminal_and_plain_epoch_lines_in_ci(ci_pipeline, ci):
    """The train stage run as a person (a terminal) and as CI (CI=true on a terminal) sees it."""
    repo = ci_pipeline
    assert dvc(repo, "repro", "label").returncode == 0
    env = {k: v for k, v in project_env(repo).items() if k != "CI"}
    if ci:
        env["CI"] = ci
    # the same bytes as the pipeline's own train stage (dvc status stays clean)
    code, out = run_in_terminal(
        [sys.executable, "pipelines/train.py", "G", "--seed", "1"], env=env, cwd=repo
    )
    assert code == 0, out
    text = out.replace("\r\n", "\n")  # the terminal's line ending is not a redraw
    epochs = [ln for ln in text.splitlines() if ln.startswith("G-WhONet seed 1: epoch ")]
    if ci:
        assert "\r" not in text, text
        assert epochs and epochs[-1].startswith("G-WhONet seed 1: epoch 3/3, train MAE ")
    else:
        assert "\r" in text and "Epoch 2" in text, text  # Lightning's bar, redrawn in place
        assert not epochs
    assert "training seconds from" in text
