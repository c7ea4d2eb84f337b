"""MLflow stores in tests: a new one made quickly, every run read back, the SQLite file sound."""

from __future__ import annotations

import contextlib
import sqlite3
from pathlib import Path
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


def migrated_store(db: Path) -> Path:
    """A new SQLite store at ``db`` as MLflow leaves it once its migrations ran; no runs.

    MLflow runs its whole chain of schema migrations on a new SQLite file, about
    2 s each time (tracking/client.py's ``open_store`` on this machine); a copy of
    this file (:func:`copy_store`) opens in milliseconds.
    """
    import mlflow

    db.parent.mkdir(parents=True, exist_ok=True)
    mlflow.MlflowClient(f"{SQLITE}{db}").search_experiments()
    return db


def copy_store(template: Path, db: Path) -> str:
    """Copy the store ``template`` to ``db`` (SQLite's own backup, whole); return its URI."""
    db.parent.mkdir(parents=True, exist_ok=True)
    # sqlite3's context manager commits; closing() closes (no connection left to the GC)
    with (
        contextlib.closing(sqlite3.connect(template)) as src,
        contextlib.closing(sqlite3.connect(db)) as dest,
    ):
        src.backup(dest)
    return f"{SQLITE}{db}"
