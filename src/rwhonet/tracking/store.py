"""Log a pipeline execution's runs (G, S, R per m and drive, WPM) to the project's MLflow store.

Stages write plain JSON run records next to their outputs; the evaluate stage
logs them all here, in one process, under one parent run per pipeline
execution. That keeps ``import mlflow`` (~2.5 s) and the SQLite set-up out of
the thirteen model stages, and gives every run its CRSE/CTE on the same
evaluation windows, so the UI's compare view lines G, S, R and WPM up.

Store: SQLite at ``mlruns/mlflow.db`` with artifacts under ``mlruns/artifacts``
(MLflow 3 keeps its file store in maintenance mode, off by default). Relative URIs
resolve against the project root; inside a queued DVC experiment (which runs
in ``.dvc/tmp/exps/<tmp>``) they resolve against the real repository so the
runs are not lost with the temporary copy. ``$MLFLOW_TRACKING_URI`` wins.
"""

from __future__ import annotations

import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rwhonet import paths

SQLITE = "sqlite:///"


@dataclass
class RunRecord:
    """Everything one run logs, as plain data (written to JSON by the stages).

    Attributes:
        name: run name shown in the UI (``G``, ``R m=50 V-Charlie3``...).
        tags: model (G/S/R/WPM), m, seed, drive, vehicle, stage...
        params: flat parameters (resolved config).
        history: per-epoch rows ``{"epoch": e, "train/loss": .., "val/loss": ..}``.
        metrics: final metrics (``crse/30s/mean``...).
        artifacts: files to attach.
        children: nested runs (e.g. one per test drive under an R run).
    """

    name: str
    tags: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    history: list[dict[str, float]] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    artifacts: list[str] = field(default_factory=list)
    children: list[RunRecord] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        d["children"] = [c.to_dict() for c in self.children]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RunRecord:
        d = dict(d)
        d["children"] = [cls.from_dict(c) for c in d.get("children", [])]
        return cls(**d)


def main_repo_root(root: Path | None = None) -> Path:
    """Return the repository that owns the store, also from inside a queued DVC experiment."""
    root = Path(root or paths.ROOT).resolve()
    parts = root.parts
    for i in range(len(parts) - 3):
        if parts[i : i + 3] == (".dvc", "tmp", "exps"):
            return Path(*parts[:i])
    return root


def resolve_tracking_uri(uri: str, root: Path | None = None) -> str:
    """Make a relative ``sqlite:///`` URI absolute against the owning repository.

    Args:
        uri: tracking URI from params (``sqlite:///mlruns/mlflow.db``).
        root: project root (defaults to :data:`rwhonet.paths.ROOT`).

    Returns:
        ``$MLFLOW_TRACKING_URI`` if set, else the absolute URI.
    """
    env = os.environ.get("MLFLOW_TRACKING_URI")
    if env:
        return env
    if uri.startswith(SQLITE) and not uri.startswith(SQLITE + "/"):
        db = main_repo_root(root) / uri[len(SQLITE) :]
        db.parent.mkdir(parents=True, exist_ok=True)
        return SQLITE + str(db)
    return uri


def artifact_root(uri: str) -> str | None:
    """Artifacts sit beside the SQLite database (``mlruns/artifacts``)."""
    if uri.startswith(SQLITE):
        return str(Path(uri[len(SQLITE) :]).parent / "artifacts")
    return None


def git_commit(root: Path | None = None) -> str:
    """Current commit of the repository (``unknown`` outside git)."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=main_repo_root(root),
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        )
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _client(uri: str):
    import mlflow

    mlflow.set_tracking_uri(uri)
    return mlflow.MlflowClient(tracking_uri=uri)


def ensure_experiment(uri: str, experiment: str) -> str:
    """Create the store and experiment if missing; return the experiment id.

    Run this once before parallel writers (a fresh SQLite store races on its
    schema migration).
    """
    client = _client(uri)
    exp = client.get_experiment_by_name(experiment)
    if exp is not None:
        return exp.experiment_id
    return client.create_experiment(experiment, artifact_location=artifact_root(uri))


def log_execution(
    records: list[RunRecord],
    *,
    uri: str,
    experiment: str,
    execution: RunRecord,
) -> str:
    """Log one pipeline execution: a parent run with every record as a child.

    Args:
        records: the runs of this execution (children of the parent).
        uri: resolved tracking URI.
        experiment: experiment name.
        execution: the parent run (evaluation-level params, metrics, artifacts).

    Returns:
        The parent run id.
    """
    from mlflow.entities import Metric, Param

    client = _client(uri)
    exp_id = ensure_experiment(uri, experiment)
    execution_id = time.strftime("%Y%m%dT%H%M%S") + f"-{os.getpid()}"
    common = {"rwhonet.execution": execution_id, "git_commit": git_commit()}

    def log(record: RunRecord, parent: str | None) -> str:
        tags = {**common, **record.tags}
        if parent is not None:
            tags["mlflow.parentRunId"] = parent
        run = client.create_run(exp_id, run_name=record.name, tags=tags)
        rid = run.info.run_id
        now = int(time.time() * 1000)
        metrics = [Metric(k, float(v), now, 0) for k, v in record.metrics.items()]
        for row in record.history:
            step = int(row.get("epoch", 0))
            metrics += [
                Metric(k, float(v), now, step) for k, v in row.items() if k != "epoch" and v == v
            ]
        params = [Param(k, str(v)[:6000]) for k, v in sorted(record.params.items())]
        # log_batch takes at most 1000 metrics / 100 params per call.
        for i in range(0, max(len(metrics), 1), 1000):
            client.log_batch(rid, metrics=metrics[i : i + 1000])
        for i in range(0, len(params), 100):
            client.log_batch(rid, params=params[i : i + 100])
        for art in record.artifacts:
            f = Path(art) if Path(art).is_absolute() else paths.ROOT / art
            if f.exists():
                client.log_artifact(rid, str(f))
        for child in record.children:
            log(child, rid)
        client.set_terminated(rid)
        return rid

    parent_id = log(RunRecord(**{**execution.__dict__, "children": []}), None)
    for record in [*execution.children, *records]:
        log(record, parent_id)
    return parent_id
