"""A failed or killed stage's run: where it goes, what it says, and never RUNNING."""

from __future__ import annotations

import pytest
import yaml

from rwhonet import paths
from rwhonet.tracking.failure import (
    DEFAULT_EXPERIMENT,
    DEFAULT_URI,
    Failure,
    log_failure,
    tracking_settings,
)
from support.store import integrity, store_runs


def _params(path, tracking) -> None:
    raw = yaml.safe_load(paths.PARAMS.read_text())
    raw["tracking"] = tracking
    path.write_text(yaml.safe_dump(raw, sort_keys=False))


def test_tracking_settings_come_straight_from_params_yaml(tmp_path):
    f = tmp_path / "params.yaml"
    _params(f, {"experiment": "mine", "tracking_uri": "sqlite:///mlruns/other.db"})
    assert tracking_settings(f) == ("sqlite:///mlruns/other.db", "mine")


@pytest.mark.parametrize(
    "text",
    [
        "tracking: [",  # not YAML: the typed loader failed on it, the failure is still logged
        "seeds: [1]\n",  # no tracking section
        "tracking: {experiment: '', tracking_uri: 3}\n",
        "tracking: {experiment: x, tracking_uri: 'sqlite:///../outside.db'}\n",  # leaves mlruns/
    ],
)
def test_unusable_tracking_settings_fall_back_to_the_defaults(tmp_path, text):
    f = tmp_path / "params.yaml"
    f.write_text(text)
    uri, experiment = tracking_settings(f)
    assert uri == DEFAULT_URI and experiment in (DEFAULT_EXPERIMENT, "x")
    assert tracking_settings(tmp_path / "missing.yaml") == (DEFAULT_URI, DEFAULT_EXPERIMENT)


def test_a_failure_in_a_queued_experiment_lands_in_the_repository_store(tmp_path, monkeypatch):
    """dvc queue runs a stage in .dvc/tmp/exps/<tmp>: its failure must not go with that copy."""
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    repo = tmp_path / "repo"
    temp_copy = repo / ".dvc" / "tmp" / "exps" / "tmpab12"
    temp_copy.mkdir(parents=True)
    _params(temp_copy / "params.yaml", {"experiment": "q", "tracking_uri": "sqlite:///mlruns/m.db"})
    failure = Failure("adapt", "FAILED", "ValueError", "bad m", "Traceback ...", 1, ["a.py"])
    run_id, uri = log_failure(failure, root=temp_copy, params_file=temp_copy / "params.yaml")
    assert uri == f"sqlite:///{repo}/mlruns/m.db" and not (temp_copy / "mlruns").exists()
    (run,) = store_runs(uri)
    assert run.info.run_id == run_id and run.info.status == "FAILED"
    assert run.info.artifact_uri.startswith(str(repo / "mlruns" / "artifacts"))
    assert integrity(uri) == "ok"


def test_long_messages_are_cut_in_tags_and_kept_whole_as_an_artifact(tmp_path, monkeypatch):
    import mlflow

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    message = "x" * 20_000
    run_id, _ = log_failure(Failure("validate", "FAILED", "InputError", message, exit_code=2))
    (run,) = store_runs(uri)
    assert len(run.data.tags["rwhonet.error"]) == 5000
    text = mlflow.MlflowClient(uri).download_artifacts(run_id, "failure/error.txt", str(tmp_path))
    assert open(text).read().strip() == message


def test_status_is_failed_or_killed():
    with pytest.raises(ValueError, match="status must be one of"):
        Failure("train_g", "RUNNING", "x", "y")


def test_a_failures_record_carries_no_password_and_no_secret_of_the_environment(
    tmp_path, monkeypatch
):
    """Message, traceback, command line and params.yaml all pass through the redaction."""
    import mlflow

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", uri)
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "bucket-key-0123456789")
    db_pw, uri_pw = "database-pw-42", "tracking-pw-42"
    params = tmp_path / "params.yaml"
    raw = yaml.safe_load(paths.PARAMS.read_text())
    raw["tracking"]["tracking_uri"] = f"https://alice:{uri_pw}@mlflow.example"  # refused by config
    params.write_text(yaml.safe_dump(raw, sort_keys=False))
    said = f"cannot reach postgresql://mlflow:{db_pw}@db:5432/mlflow (key bucket-key-0123456789)"
    failure = Failure(
        "evaluate",
        "FAILED",
        "ConnectionError",
        said,
        f"Traceback ...\n  {said}\n",
        1,
        ["pipelines/evaluate.py", f"--uri=https://alice:{uri_pw}@mlflow.example"],
    )
    run_id, _ = log_failure(failure, params_file=params)
    (run,) = store_runs(uri)
    client = mlflow.MlflowClient(uri)
    texts = [*run.data.tags.values(), run.info.run_name]
    for name in ("failure/error.txt", "failure/traceback.txt", "failure/params.yaml"):
        texts.append(open(client.download_artifacts(run_id, name, str(tmp_path))).read())
    logged = "\n".join(texts)
    for secret in (db_pw, uri_pw, "bucket-key-0123456789"):
        assert secret not in logged
    assert "postgresql://mlflow:***@db:5432/mlflow" in logged  # what failed stays readable
