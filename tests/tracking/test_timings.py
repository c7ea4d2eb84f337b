"""Timing sidecars: a run's real start and end, found by its output's fingerprint, or none."""

import json
import time

import pytest

from rwhonet import contracts
from rwhonet.io import write_json
from rwhonet.tracking import timings
from rwhonet.tracking.records import RunRecord, Timing
from rwhonet.tracking.store import log_execution


def run_folder(path, loss=0.5):
    path.mkdir(parents=True)
    record = RunRecord("G", history=[{"epoch": 0, "train/loss": loss}])
    write_json(path / contracts.RUN_RECORD, record.to_dict())
    (path / contracts.PREDICTIONS).write_bytes(b"parquet bytes")
    return path


def test_a_timing_is_found_by_the_bytes_of_its_run(tmp_path):
    folder = run_folder(tmp_path / "models/g/seed1")
    out = timings.write_timing(folder, Timing(1_000, 5_000), stage="train_g@1", root=tmp_path)
    assert out.parent == tmp_path / "mlruns" / "timings"
    assert json.loads(out.read_text())["stage"] == "train_g@1"
    assert timings.read_timing(folder, root=tmp_path) == Timing(1_000, 5_000)
    # the same bytes elsewhere (a folder restored from the DVC cache) are the same run
    same = run_folder(tmp_path / "restored")
    assert timings.read_timing(same, root=tmp_path) == Timing(1_000, 5_000)
    # other bytes (another run: other params, other losses) are not
    other = run_folder(tmp_path / "other", loss=0.4)
    assert timings.read_timing(other, root=tmp_path) is None
    (folder / contracts.PREDICTIONS).write_bytes(b"other predictions")
    assert timings.read_timing(folder, root=tmp_path) is None


def test_absent_unreadable_or_nonsense_sidecars_read_as_none(tmp_path):
    folder = run_folder(tmp_path / "run")
    assert timings.read_timing(folder, root=tmp_path) is None  # never recorded
    sidecar = timings.write_timing(folder, Timing(9_000, 1_000), stage="x", root=tmp_path)
    assert timings.read_timing(folder, root=tmp_path) is None  # ends before it starts
    sidecar.write_text("{not json")
    assert timings.read_timing(folder, root=tmp_path) is None
    assert timings.read_timing(tmp_path / "no-such-run", root=tmp_path) is None


def test_a_queued_experiment_keeps_its_timings_in_the_owning_repository(tmp_path):
    temp_copy = tmp_path / "repo" / ".dvc" / "tmp" / "exps" / "tmpab12"
    assert timings.timings_dir(temp_copy) == tmp_path / "repo" / "mlruns" / "timings"


def test_timing_never_reaches_run_json():
    rec = RunRecord("G", tags={"model": "G"}, timing=Timing(1, 2))
    assert "timing" not in rec.to_dict()
    assert RunRecord.from_dict(rec.to_dict()).timing is None


def test_logged_runs_carry_their_real_times_and_untimed_ones_their_logging_time(tmp_path):
    mlflow = pytest.importorskip("mlflow")
    uri = f"sqlite:///{tmp_path}/mlruns/mlflow.db"
    (tmp_path / "mlruns").mkdir()
    day_ago = int(time.time() * 1000) - 86_400_000
    timed = RunRecord(
        "G-WhONet seed 1",
        tags={"model": "G"},
        timing=Timing(day_ago, day_ago + 4_200),
        history=[{"epoch": 0, "train/loss": 0.5}],
    )
    untimed = RunRecord("S-WhONet seed 1", tags={"model": "S"})
    before = int(time.time() * 1000)
    execution = RunRecord("pipeline", timing=Timing(before - 1_000))
    parent = log_execution([timed, untimed], uri=uri, experiment="t", execution=execution)
    client = mlflow.MlflowClient(uri)
    runs = {
        r.info.run_name: r
        for r in client.search_runs([client.get_experiment_by_name("t").experiment_id])
    }
    g, s, p = runs["G-WhONet seed 1"], runs["S-WhONet seed 1"], runs["pipeline"]
    assert (g.info.start_time, g.info.end_time) == (day_ago, day_ago + 4_200)
    assert g.info.status == "FINISHED"
    [loss] = client.get_metric_history(g.info.run_id, "train/loss")
    assert loss.timestamp == day_ago + 4_200  # the epoch's value, stamped with the run's end
    assert before <= s.info.start_time <= s.info.end_time <= int(time.time() * 1000)
    assert p.info.run_id == parent and p.info.start_time == before - 1_000
    assert p.info.end_time >= before
