"""Opening the store from several processes at once; retrying while SQLite is locked."""

from __future__ import annotations

import sqlite3
import subprocess
import sys

import pytest

from rwhonet.tracking.client import open_store, retrying
from support.store import integrity, store_runs


@pytest.mark.concurrency
def test_retrying_waits_out_a_locked_database():
    calls = []

    def flaky():
        calls.append(1)
        if len(calls) < 3:
            try:
                raise sqlite3.OperationalError("database is locked")
            except sqlite3.OperationalError as err:
                raise RuntimeError("(sqlite3.OperationalError) wrapped by SQLAlchemy") from err
        return "done"

    assert retrying(flaky, first_wait_s=0.001) == "done" and len(calls) == 3


@pytest.mark.concurrency
def test_retrying_raises_other_errors_at_once_and_gives_up_in_the_end():
    calls = []

    def broken():
        calls.append(1)
        raise ValueError("no such table")

    with pytest.raises(ValueError):
        retrying(broken, first_wait_s=0.001)
    assert len(calls) == 1

    def locked():
        raise sqlite3.OperationalError("database is locked")

    with pytest.raises(sqlite3.OperationalError):
        retrying(locked, attempts=3, first_wait_s=0.001)


OPEN = """
import sys, time
from rwhonet.tracking.client import open_store
start = float(sys.argv[2])
while time.time() < start:
    time.sleep(0.001)
client, exp = open_store(sys.argv[1], "race")
client.set_terminated(client.create_run(exp).info.run_id)
"""


@pytest.mark.concurrency
@pytest.mark.slow
def test_processes_opening_a_fresh_store_at_once_do_not_race_on_its_migration(tmp_path):
    """Without the lock, most of these fail (3 of 4 did): MLflow's migration runs in each."""
    import time

    uri = f"sqlite:///{tmp_path}/mlruns/mlflow.db"
    start = str(time.time() + 4)  # all past their imports, then off together
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", OPEN, uri, start], stderr=subprocess.PIPE, text=True
        )
        for _ in range(4)
    ]
    errors = [p.communicate(timeout=120)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * 4, errors
    runs = store_runs(uri)
    assert len(runs) == 4 and {r.info.experiment_id for r in runs} == {open_store(uri, "race")[1]}
    assert integrity(uri) == "ok"


def test_the_experiment_is_marked_as_model_training(tmp_path):
    # MLflow 3's UI opens such an experiment on its runs, not on the GenAI overview.
    from rwhonet.tracking.client import EXPERIMENT_KIND, EXPERIMENT_KIND_TAG, open_store

    uri = f"sqlite:///{tmp_path}/mlflow.db"
    client, exp_id = open_store(uri, "rwhonet")
    assert client.get_experiment(exp_id).tags[EXPERIMENT_KIND_TAG] == EXPERIMENT_KIND
    client.delete_experiment_tag(exp_id, EXPERIMENT_KIND_TAG)  # a store from before the tag
    client, again = open_store(uri, "rwhonet")
    assert again == exp_id
    assert client.get_experiment(exp_id).tags[EXPERIMENT_KIND_TAG] == EXPERIMENT_KIND


def test_a_tracking_server_uri_is_taken_as_it_is_and_never_locked(tmp_path, monkeypatch):
    """Team mode (docs/team.md): the SQLite lock, paths and artifact root stay out of http URIs."""
    from rwhonet.tracking.client import _store_lock, artifact_root, resolve_tracking_uri

    monkeypatch.chdir(tmp_path)
    server = "http://127.0.0.1:5000"
    monkeypatch.setenv("MLFLOW_TRACKING_URI", server)
    assert resolve_tracking_uri("sqlite:///mlruns/mlflow.db", tmp_path) == server
    monkeypatch.delenv("MLFLOW_TRACKING_URI")
    assert resolve_tracking_uri("https://mlflow.example.com", tmp_path) == (
        "https://mlflow.example.com"
    )
    assert artifact_root(server) is None  # the server's own artifact root
    with _store_lock(server):
        pass
    assert not list(tmp_path.iterdir())  # no lock file, no folder named after the URI
