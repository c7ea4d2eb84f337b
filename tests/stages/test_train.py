"""The train stage: a model folder DVC reproduces byte for byte; the fit's real times beside it."""

import time

import pytest

from rwhonet import contracts, paths
from rwhonet.config import load_params
from rwhonet.stages.train import train_model
from rwhonet.tracking.timings import read_timing

from .conftest import write_samples


@pytest.fixture
def params():
    return load_params(paths.PARAMS, overrides={"train.epochs": 2, "model.hidden": 8})


def test_the_run_is_timed_by_its_fit_and_the_time_stays_out_of_the_outputs(tmp_path, params):
    samples = write_samples(tmp_path / "samples", [
        ("S__s0", "S", "source_train", 600), ("T__s0", "T", "target_train", 100),
        ("A__s0", "A", "target_test", 300),
    ])  # fmt: skip
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
