"""Reading an MLflow store back in tests: every run, and whether the SQLite file is sound."""

from __future__ import annotations

import sqlite3
from typing import Any

SQLITE = "sqlite:///"


def store_runs(uri: str) -> list[Any]:
    """Every run of every experiment in the store at ``uri`` (MLflow ``Run`` objects)."""
    import mlflow
    from mlflow.entities import ViewType

    client = mlflow.MlflowClient(uri)
    ids = [e.experiment_id for e in client.search_experiments(view_type=ViewType.ALL)]
    runs, token = [], None
    while True:
        page = client.search_runs(
            ids, run_view_type=ViewType.ALL, max_results=1000, page_token=token
        )
        runs += list(page)
        token = page.token
        if not token:
            return runs


def integrity(uri: str) -> str:
    """SQLite's own check of the store file (``ok`` when sound)."""
    with sqlite3.connect(uri.removeprefix(SQLITE)) as db:
        return db.execute("PRAGMA integrity_check").fetchone()[0]
