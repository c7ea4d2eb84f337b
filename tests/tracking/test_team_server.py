"""Team mode: the pipeline and ``rwhonet`` logging to an MLflow tracking server on PostgreSQL.

A throwaway PostgreSQL cluster and ``mlflow server`` on localhost
(:mod:`support.team`; PostgreSQL is installed from Debian's packages on a CI
machine that lacks it), artifacts uploaded through the server. A scratch
project (``ci`` profile, small) runs ``python -m rwhonet.tracking init`` and
``dvc repro`` with ``$MLFLOW_TRACKING_URI`` pointing at the server; then a
stage fails there, and ``rwhonet recalibrate`` / ``predict`` use the models the
pipeline registered. Everything is read back through the server, and the run
count from PostgreSQL itself; a teammate's clone pulls the outputs from a DVC
remote. Slow: two to three minutes (docs/team.md).
"""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from support.project import BIN, commit, dvc, env, scratch_project
from support.team import Unavailable, mlflow_server, postgres, postgres_bin

pytestmark = pytest.mark.slow

OVERRIDES = {
    ("seeds",): [1],
    ("sim", "profile"): "ci",
    ("train", "epochs"): 3,
    ("adapt", "epochs"): 5,
    ("adapt", "m_grid"): [10, 20],
    ("adapt", "recipes"): ["paper", "radius+G"],
    ("adapt", "fallback", "recipe"): "radius+G",
    ("adapt", "fallback", "m"): 20,
    ("evaluate", "outages_s"): [30, 180],
}
EXPERIMENT = "rwhonet"
LOAD_AND_PREDICT = """
import json, sys
import mlflow.pyfunc
from mlflow.models import Model
uri = f"models:/{sys.argv[1]}/1"
example = Model.load(uri).load_input_example(mlflow.artifacts.download_artifacts(uri))
print(json.dumps(mlflow.pyfunc.load_model(uri).predict(example)["pred_m"].tolist()))
"""


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """``{"uri", "db", "artifacts"}`` of a running team server; both servers stop afterwards."""
    try:
        pg_bin = postgres_bin()
    except Unavailable as why:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI must run team mode: {why}")  # a skip would hide it there
        pytest.skip(str(why))
    artifacts = tmp_path_factory.mktemp("team-server") / "artifacts"
    with postgres(pg_bin) as db, mlflow_server(db, artifacts) as uri:
        yield {"uri": uri, "db": db, "artifacts": artifacts}


def run(repo: Path, uri: str, *cmd: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """A command in the scratch project, logging to ``uri`` (the venv first on PATH)."""
    return subprocess.run(
        list(cmd),
        cwd=repo,
        env=env(repo, MLFLOW_TRACKING_URI=uri),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.fixture(scope="module")
def project(server, tmp_path_factory):
    """A scratch project whose store was initialised on the server and whose pipeline ran."""
    repo = scratch_project(tmp_path_factory.mktemp("team") / "repo", OVERRIDES)
    init = run(repo, server["uri"], sys.executable, "-m", "rwhonet.tracking", "init")
    assert init.returncode == 0, init.stdout + init.stderr
    repro = run(repo, server["uri"], str(BIN / "dvc"), "repro")
    assert repro.returncode == 0, repro.stdout + repro.stderr
    return {"repo": repo, "init": init.stdout, "repro": repro.stdout, "repro_err": repro.stderr}


@pytest.fixture(scope="module")
def client(server):
    from mlflow import MlflowClient

    return MlflowClient(server["uri"])


def runs(client, filter_string: str = "") -> list:
    exp = client.get_experiment_by_name(EXPERIMENT)
    return list(client.search_runs([exp.experiment_id], filter_string, max_results=5000))


def test_init_creates_the_experiment_on_the_server(server, project, client):
    assert f"MLflow store {server['uri']}, experiment '{EXPERIMENT}'" in project["init"]
    exp = client.get_experiment_by_name(EXPERIMENT)
    assert exp.tags["mlflow.experimentKind"] == "custom_model_development"
    # the server chose where artifacts go (proxied), not the project's mlruns/
    assert exp.artifact_location.startswith("mlflow-artifacts:")
    assert not (project["repo"] / "mlruns" / "mlflow.db").exists()
    # MLflow's per-run links and registry notes stay out of the stage's output
    assert "View run" not in project["repro"] and "Waiting up to" not in project["repro_err"]


def test_the_pipeline_logs_runs_metrics_and_artifacts_through_the_server(server, project, client):
    import psycopg

    (parent,) = runs(client, "tags.model = 'pipeline'")
    family = runs(client, f"tags.`rwhonet.execution` = '{parent.data.tags['rwhonet.execution']}'")
    assert len(family) > 10 and {r.info.status for r in family} == {"FINISHED"}
    children = [r for r in family if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id]
    by_name = {r.info.run_name: r for r in children}
    g = by_name["G-WhONet seed 1"]
    assert g.data.metrics["crse/180s/mean"] > 0 and g.data.params["train.epochs"] == "3"
    assert [m.step for m in client.get_metric_history(g.info.run_id, "train/loss")] == [0, 1, 2]
    assert parent.data.metrics and parent.data.params["sim.profile"] == "ci"

    # artifacts: uploaded through the server, listed and read back through it
    listed = {a.path for a in client.list_artifacts(parent.info.run_id)}
    assert {"eval.json", "tables.md"} <= listed
    local = client.download_artifacts(parent.info.run_id, "eval.json", str(project["repo"] / "dl"))
    assert Path(local).read_bytes() == (project["repo"] / "metrics" / "eval.json").read_bytes()
    assert "model.pt" in {a.path for a in client.list_artifacts(g.info.run_id)}
    stored = server["artifacts"] / parent.info.experiment_id / parent.info.run_id
    assert (stored / "artifacts" / "eval.json").is_file()

    # and PostgreSQL is the store the server keeps them in
    with psycopg.connect(server["db"]) as db:
        (n_runs,) = db.execute("SELECT count(*) FROM runs").fetchone()
    assert n_runs == len(runs(client)) >= len(family)


def test_the_pipeline_registers_its_models_on_the_server(project, server, client):
    names = {m.name for m in client.search_registered_models()}
    assert {"whonet-G", "whonet-S", "whonet-R-target"} <= names
    r = client.get_model_version("whonet-R-target", "1")
    assert (r.tags["recipe"], r.tags["m"], r.tags["seed"]) == ("radius+G", "20", "1")
    assert r.status == "READY" and client.get_run(r.run_id).data.tags["chosen"] == "true"
    # a team member loads it by name: downloaded through the server, it predicts its example
    load = run(project["repo"], server["uri"], sys.executable, "-c", LOAD_AND_PREDICT, "whonet-G")
    assert load.returncode == 0, load.stderr
    pred = json.loads(load.stdout.splitlines()[-1])
    assert len(pred) == 5 and all(math.isfinite(p) for p in pred)


def test_a_teammate_pulls_the_pipeline_outputs_from_a_dvc_remote(project, tmp_path):
    repo, clone = project["repo"], tmp_path / "clone"
    commit(repo, "pipeline outputs")
    added = dvc(repo, "remote", "add", "-d", "team", str(tmp_path / "dvc-remote"))
    assert added.returncode == 0, added.stderr
    commit(repo, "team remote")  # .dvc/config: a clone finds the remote
    pushed = dvc(repo, "push")
    assert pushed.returncode == 0, pushed.stdout + pushed.stderr
    subprocess.run(["git", "clone", "-q", str(repo), str(clone)], check=True)
    pulled = dvc(clone, "pull")
    assert pulled.returncode == 0, pulled.stdout + pulled.stderr
    status = dvc(clone, "status")
    assert "Data and pipelines are up to date" in status.stdout, status.stdout + status.stderr
    assert (clone / "models").is_dir()
    for f in ("metrics/eval.json", "models/g/seed1/model.pt"):
        assert (clone / f).read_bytes() == (repo / f).read_bytes(), f


def test_a_failed_stage_logs_its_run_and_artifacts_on_the_server(project, server, client):
    repo = project["repo"]
    params = repo / "params.yaml"
    original = params.read_text()
    broken = yaml.safe_load(original)
    broken["evaluate"]["no_such_key"] = 1  # the typed loader stops on it
    params.write_text(yaml.safe_dump(broken, sort_keys=False))
    try:
        out = run(repo, server["uri"], sys.executable, "pipelines/evaluate.py")
    finally:
        params.write_text(original)
    assert out.returncode == 2, out.stdout + out.stderr
    assert "MLflow: FAILED run" in out.stderr and server["uri"] in out.stderr
    (failed,) = runs(client, "tags.`rwhonet.failure` = 'true'")
    assert failed.info.status == "FAILED" and failed.data.tags["dvc_stage"] == "evaluate"
    listed = {a.path for a in client.list_artifacts(failed.info.run_id, "failure")}
    assert {"failure/error.txt", "failure/params.yaml"} <= listed


def test_rwhonet_recalibrates_predicts_and_exports_from_the_servers_registry(
    project, server, client
):
    from rwhonet.serve.model import load_served

    repo = project["repo"]
    drive = sorted((repo / "data" / "sim" / "target_test").glob("*.csv"))[0]
    cli = [str(BIN / "rwhonet")]
    said = run(
        repo,
        server["uri"],
        *cli,
        "recalibrate",
        "--base",
        "models:/whonet-G/latest",
        "--drive",
        str(drive),
        "--seconds",
        "50",
    )
    assert said.returncode == 0, said.stdout + said.stderr
    assert "registered whonet-R-target version 2" in said.stdout
    version = client.get_model_version("whonet-R-target", "2")
    assert version.tags["base_version"] == "whonet-G v1" and version.tags["m"] == "50"

    out = run(
        repo,
        server["uri"],
        *cli,
        "predict",
        "--model",
        "models:/whonet-R-target/2",
        "--drive",
        str(drive),
        "--outage",
        "100:280",
        "--output",
        "-",
    )
    assert out.returncode == 0, out.stderr
    streamed = pd.read_csv(io.StringIO(out.stdout))  # stdout holds the CSV and nothing else
    assert len(streamed) > 280 and streamed["pred_error_m"].notna().all()
    assert "outage 100:280 s (180 s" in out.stderr

    onnx = project["repo"] / "r2.onnx"
    out = run(
        repo,
        server["uri"],
        *cli,
        "export",
        "--model",
        "models:/whonet-R-target/2",
        "--output",
        str(onnx),
    )
    assert out.returncode == 0, out.stderr
    assert load_served(onnx).meta.info["recipe"] == version.tags["recipe"]
