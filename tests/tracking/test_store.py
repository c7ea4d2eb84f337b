"""MLflow store: URIs resolve to the owning repo; one execution logs a parent with child runs."""

from pathlib import Path

import pytest

from rwhonet.tracking.store import (
    RunRecord,
    log_execution,
    main_repo_root,
    resolve_tracking_uri,
)
from support.store import copy_store


def test_relative_sqlite_uri_resolves_against_root(tmp_path, monkeypatch):
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = resolve_tracking_uri("sqlite:///mlruns/mlflow.db", root=tmp_path)
    assert uri == f"sqlite:///{tmp_path}/mlruns/mlflow.db"
    assert (tmp_path / "mlruns").is_dir()


def test_queued_dvc_experiment_logs_into_the_real_repo(tmp_path, monkeypatch):
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    temp_copy = tmp_path / "repo" / ".dvc" / "tmp" / "exps" / "tmpab12"
    temp_copy.mkdir(parents=True)
    assert main_repo_root(temp_copy) == tmp_path / "repo"
    uri = resolve_tracking_uri("sqlite:///mlruns/mlflow.db", root=temp_copy)
    assert uri == f"sqlite:///{tmp_path}/repo/mlruns/mlflow.db"


def test_env_uri_wins(monkeypatch):
    monkeypatch.setenv("MLFLOW_TRACKING_URI", "sqlite:////x/y.db")
    assert resolve_tracking_uri("sqlite:///mlruns/mlflow.db") == "sqlite:////x/y.db"


def test_record_round_trips_through_dict():
    rec = RunRecord(
        "R m=50", tags={"model": "R"}, children=[RunRecord("child", metrics={"a": 1.0})]
    )
    assert RunRecord.from_dict(rec.to_dict()) == rec


def test_log_execution_parent_and_children(tmp_path, monkeypatch, migrated_store):
    mlflow = pytest.importorskip("mlflow")
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = copy_store(migrated_store, tmp_path / "mlruns" / "mlflow.db")
    art = tmp_path / "model.ckpt"
    art.write_bytes(b"weights")
    g = RunRecord(
        "G-WhONet",
        tags={"model": "G"},
        params={"train.lr": 0.0007},
        history=[{"epoch": 0, "train/loss": 0.5}, {"epoch": 1, "train/loss": 0.4}],
        metrics={"crse/30s/mean": 1.5},
        artifacts=[str(art)],
    )
    r = RunRecord(
        "R m=50",
        tags={"model": "R", "m": "50"},
        children=[RunRecord("R m=50 d1", tags={"model": "R", "drive": "d1"})],
    )
    parent = RunRecord("pipeline", tags={"model": "pipeline"})
    pid = log_execution([g, r], uri=uri, experiment="t", execution=parent)
    mlflow.set_tracking_uri(uri)
    runs = mlflow.search_runs(experiment_names=["t"])
    assert len(runs) == 4
    children = runs[runs["tags.mlflow.parentRunId"] == pid]
    assert set(children["tags.model"]) == {"G", "R"}
    assert runs["tags.rwhonet.execution"].nunique() == 1
    grow = runs[runs["tags.model"] == "G"].iloc[0]
    assert grow["metrics.crse/30s/mean"] == 1.5 and grow["params.train.lr"] == "0.0007"
    hist = mlflow.MlflowClient(uri).get_metric_history(grow["run_id"], "train/loss")
    assert [(m.step, m.value) for m in hist] == [(0, 0.5), (1, 0.4)]
    arts = mlflow.MlflowClient(uri).list_artifacts(grow["run_id"])
    assert [a.path for a in arts] == ["model.ckpt"]
    assert Path(runs.iloc[0]["artifact_uri"].replace("file://", "")).is_relative_to(tmp_path)


def test_a_run_over_log_batchs_limits_is_logged_whole_in_as_few_calls_as_fit(
    tmp_path, monkeypatch, migrated_store
):
    mlflow = pytest.importorskip("mlflow")
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = copy_store(migrated_store, tmp_path / "mlruns" / "mlflow.db")
    # 230 params (100 a call at most) and 1,950 metric points (1,000 entities a call in all)
    params = {f"p{i:03d}": i for i in range(230)}
    history = [{"epoch": e, **{f"m{j}": float(e + j) for j in range(3)}} for e in range(650)]
    calls = []
    real = mlflow.MlflowClient.log_batch

    def counting(self, run_id, metrics=(), params=(), tags=(), **kw):
        calls.append((len(metrics), len(params)))
        return real(self, run_id, metrics=metrics, params=params, tags=tags, **kw)

    monkeypatch.setattr(mlflow.MlflowClient, "log_batch", counting)
    rec = RunRecord("big", tags={"model": "G"}, params=params, history=history)
    log_execution([rec], uri=uri, experiment="t", execution=RunRecord("pipeline"))
    # the parent has nothing to log; the child: 100 + 900, 100 + 900, 30 + 150
    assert calls == [(900, 100), (900, 100), (150, 30)]
    client = mlflow.MlflowClient(uri)
    run = client.search_runs(client.get_experiment_by_name("t").experiment_id, "tags.model = 'G'")[
        0
    ]
    assert run.data.params == {k: str(v) for k, v in params.items()}
    for j in range(3):
        hist = client.get_metric_history(run.info.run_id, f"m{j}")
        assert sorted((m.step, m.value) for m in hist) == [(e, float(e + j)) for e in range(650)]


@pytest.mark.crash
def test_an_interrupted_execution_leaves_no_run_running(tmp_path, monkeypatch):
    """A logger stopped mid-run marks the run it was writing KILLED (FAILED on an error)."""
    mlflow = pytest.importorskip("mlflow")
    from support.store import store_runs

    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    uri = f"sqlite:///{tmp_path}/mlruns/mlflow.db"
    art = tmp_path / "model.pt"
    art.write_bytes(b"weights")

    def interrupted(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(mlflow.MlflowClient, "log_artifact", interrupted)
    with pytest.raises(KeyboardInterrupt):
        log_execution(
            [RunRecord("G-WhONet", artifacts=[str(art)])],
            uri=uri,
            experiment="t",
            execution=RunRecord("pipeline"),
        )
    statuses = {r.info.run_name: r.info.status for r in store_runs(uri)}
    assert statuses == {"pipeline": "FINISHED", "G-WhONet": "KILLED"}


def test_the_comparison_goes_on_the_parent_run_and_a_shared_view_shows_its_columns(
    tmp_path, migrated_store
):
    import json

    mlflow = pytest.importorskip("mlflow")
    from rwhonet.tracking.store import HEADLINE_VIEW, SHARED_VIEW_TAG, log_comparison

    uri = copy_store(migrated_store, tmp_path / "mlruns" / "mlflow.db")
    parent = log_execution([], uri=uri, experiment="t", execution=RunRecord("pipeline"))
    rows = [
        {"model": "G", "outage_s": 30, "crse_mean": 2.1, "cte_mean": 1.8},
        {"model": "R", "outage_s": 30, "crse_mean": 1.1, "cte_mean": 0.9},
    ]
    exp_id = log_comparison(
        uri,
        parent,
        rows=rows,
        note="| model | CRSE |",
        page="<html></html>",
        view_metrics=["R/crse/30s/mean"],
    )
    client = mlflow.MlflowClient(uri)
    run = client.get_run(parent)
    assert run.data.tags["mlflow.note.content"] == "| model | CRSE |"
    assert {a.path for a in client.list_artifacts(parent, "comparison")} == {
        "comparison/crse_cte.json",
        "comparison/crse_cte.html",
    }
    table = json.loads(
        (
            tmp_path
            / "mlruns"
            / "artifacts"
            / parent
            / "artifacts"
            / "comparison"
            / "crse_cte.json"
        ).read_text()
    )
    assert table["columns"] == ["model", "outage_s", "crse_mean", "cte_mean"]
    assert table["data"] == [["G", 30, 2.1, 1.8], ["R", 30, 1.1, 0.9]]
    view = json.loads(client.get_experiment(exp_id).tags[SHARED_VIEW_TAG + HEADLINE_VIEW])
    assert "metrics.`R/crse/30s/mean`" in view["selectedColumns"]
    assert view["searchFilter"] == "tags.model = 'pipeline'"
    # `make ui` (python -m rwhonet.tracking init) prints the view's address once it exists
    from rwhonet.tracking.__main__ import headline_view

    assert headline_view(uri, exp_id) == (
        f"http://127.0.0.1:5000/#/experiments/{exp_id}/runs?workflowType=machine_learning"
        "&viewStateShareKey=rwhonet-headline"
    )
    other = client.create_experiment("other")
    assert headline_view(uri, other) is None
