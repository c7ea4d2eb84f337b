"""Log a pipeline execution's runs (G, S, R per m and drive, WPM) to the project's MLflow store.

Stages write plain JSON run records next to their outputs; the evaluate stage
logs them all here, in one process, under one parent run per pipeline
execution. That keeps ``import mlflow`` (~2.5 s) and the SQLite set-up out of
the thirteen model stages, and gives every run its CRSE/CTE on the same
evaluation windows, so the UI's compare view lines G, S, R and WPM up. The
execution's G, S and chosen R are then registered in the Model Registry
(:mod:`rwhonet.tracking.registry`).

Where the store is and how it is opened under concurrency: :mod:`rwhonet.tracking.client`.
"""

from __future__ import annotations

import json
import os
import time
import uuid
import warnings
from pathlib import Path
from typing import Any

from rwhonet import paths
from rwhonet.tracking.client import (  # noqa: F401 - re-exported: callers find the store here
    SQLITE,
    artifact_root,
    git_commit,
    main_repo_root,
    open_store,
    resolve_tracking_uri,
    retrying,
)
from rwhonet.tracking.records import RunRecord

# What `dvc exp run` (queued or not) tells every stage it runs, as run tags.
DVC_EXPERIMENT_TAGS = {
    "dvc_exp_name": "DVC_EXP_NAME",
    "dvc_exp_baseline_rev": "DVC_EXP_BASELINE_REV",
}


def dvc_experiment() -> dict[str, str]:
    """The DVC experiment this process runs in, as tags; empty outside ``dvc exp run``.

    ``dvc_exp_name`` is the experiment's name (``dvc exp show``, ``-n``) and
    ``dvc_exp_baseline_rev`` the commit it was queued on, so MLflow's runs of
    a sweep can be told apart and matched to ``dvc exp show``'s rows.
    """
    return {tag: os.environ[var] for tag, var in DVC_EXPERIMENT_TAGS.items() if os.environ.get(var)}


def ensure_experiment(uri: str, experiment: str) -> str:
    """Create the store and experiment if missing; return the experiment id.

    ``python -m rwhonet.tracking init`` runs this before parallel writers;
    :func:`~rwhonet.tracking.client.open_store` makes it safe without, too.
    """
    return open_store(uri, experiment)[1]


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

    client, exp_id = open_store(uri, experiment)
    # Unique across processes and machines sharing a store (pids repeat across containers).
    execution_id = f"{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}-{uuid.uuid4().hex[:6]}"
    common = {"rwhonet.execution": execution_id, "git_commit": git_commit(), **dvc_experiment()}

    def log(record: RunRecord, parent: str | None) -> str:
        tags = {**common, **record.tags}
        if parent is not None:
            tags["mlflow.parentRunId"] = parent
        # A record's timing is when its stage really ran it; without one, the run is
        # timed by its own logging.
        timing = record.timing
        run = retrying(
            lambda: client.create_run(
                exp_id,
                run_name=record.name,
                tags=tags,
                start_time=timing.start_ms if timing else None,
            )
        )
        rid = run.info.run_id
        end_ms = timing.end_ms if timing else None
        try:
            _log_contents(client, rid, record)
            for child in record.children:
                log(child, rid)
        except BaseException as err:
            # Never leave a run RUNNING: an interrupted logger marks what it was writing.
            status = "FAILED" if isinstance(err, Exception) else "KILLED"
            retrying(lambda: client.set_terminated(rid, status))
            raise
        retrying(lambda: client.set_terminated(rid, end_time=end_ms))
        return rid

    def _log_contents(client: Any, rid: str, record: RunRecord) -> None:
        # Metrics are stamped with the end of the run they belong to (MLflow's wall-time axis).
        timing = record.timing
        now = timing.end_ms if timing and timing.end_ms else int(time.time() * 1000)
        metrics = [Metric(k, float(v), now, 0) for k, v in record.metrics.items()]
        for row in record.history:
            step = int(row.get("epoch", 0))
            metrics += [
                Metric(k, float(v), now, step) for k, v in row.items() if k != "epoch" and v == v
            ]
        params = [Param(k, str(v)[:6000]) for k, v in sorted(record.params.items())]
        # One log_batch call (a store transaction) for both where they fit: it takes at
        # most 100 params and 1000 entities in all per call.
        while metrics or params:
            batch_params, params = params[:100], params[100:]
            cut = 1000 - len(batch_params)
            batch_metrics, metrics = metrics[:cut], metrics[cut:]
            retrying(
                lambda m=batch_metrics, p=batch_params: client.log_batch(rid, metrics=m, params=p)
            )
        for art in record.artifacts:
            f = Path(art) if Path(art).is_absolute() else paths.ROOT / art
            if f.exists():
                client.log_artifact(rid, str(f))

    parent_id = log(RunRecord(**{**execution.__dict__, "children": []}), None)
    logged = [(record, log(record, parent_id)) for record in [*execution.children, *records]]
    _register(client, logged, {**common, "parent_run_id": parent_id})
    return parent_id


def _register(client: Any, logged: list[tuple[RunRecord, str]], tags: dict[str, str]) -> None:
    """Register the execution's G, S and chosen R in the Model Registry, and say which."""
    from rwhonet.tracking.registry import register_execution

    done = register_execution(client, logged, common_tags=tags)
    if done:
        listed = ", ".join(f"{d['name']} v{d['version']}" for d in done)
        retrying(lambda: client.set_tag(tags["parent_run_id"], "registered_models", listed))
        print(f"MLflow Model Registry: {listed}")


# MLflow's UI keeps the runs table's columns in the browser (localStorage); a view
# shared under this experiment-tag prefix opens with the columns and filter it holds
# (``#/experiments/<id>/runs?viewStateShareKey=<key>``). MLflow 3.17 has no server-side
# default columns.
SHARED_VIEW_TAG = "mlflow.sharedViewState."
HEADLINE_VIEW = "rwhonet-headline"


def runs_view_url(experiment_id: str, key: str = HEADLINE_VIEW, base: str = "") -> str:
    """The UI address of a shared runs view (``base``: ``http://127.0.0.1:5000``, or none)."""
    return (
        f"{base}/#/experiments/{experiment_id}/runs?workflowType=machine_learning"
        f"&viewStateShareKey={key}"
    )


def share_runs_view(
    client: Any,
    experiment_id: str,
    key: str,
    *,
    search_filter: str,
    metrics: list[str],
    tags: tuple[str, ...] = (),
) -> None:
    """Save a runs-table view (filter and columns) that the UI opens from :func:`runs_view_url`.

    The value is the view state the UI's own "share" writes: search facets and the
    table's UI state, as JSON in an experiment tag.
    """
    columns = [
        "attributes.`Duration`",
        *(f"metrics.`{m}`" for m in metrics),
        *(f"tags.`{t}`" for t in tags),
    ]
    state = {
        "searchFilter": search_filter,
        "orderByKey": "attributes.start_time",
        "orderByAsc": False,
        "startTime": "ALL",
        "lifecycleFilter": "Active",
        "datasetsFilter": [],
        "modelVersionFilter": "All Runs",
        "selectedColumns": columns,
        "columnOrder": columns,
        "columnWidths": {},
        "runsHiddenMode": "SHOW_ALL",
        "viewMaximized": False,
        "runListHidden": False,
        "isAccordionReordered": False,
        "useGroupedValuesInCharts": True,
        "hideEmptyCharts": True,
        "groupBy": None,
        "groupsExpanded": {},
    }
    retrying(
        lambda: client.set_experiment_tag(experiment_id, SHARED_VIEW_TAG + key, json.dumps(state))
    )


def log_comparison(
    uri: str,
    run_id: str,
    *,
    rows: list[dict[str, Any]],
    note: str,
    page: str,
    view_metrics: list[str],
) -> str:
    """Put an execution's comparison where the UI shows it first, on its parent run.

    Args:
        uri: resolved tracking URI.
        run_id: the parent run.
        rows: one row per model and outage (:func:`rwhonet.report.headline.comparison_rows`),
            logged as an MLflow table (``comparison/crse_cte.json``: the artifact view shows
            it as a table, the artifact compare view across executions).
        note: Markdown, the run's description (the top of its page).
        page: a self-contained HTML page with the table and charts
            (``comparison/crse_cte.html``, rendered in the artifact view).
        view_metrics: the parent-run metrics the shared view :data:`HEADLINE_VIEW`
            shows as columns of every execution's row.

    Returns:
        The experiment id.
    """
    import mlflow

    client = mlflow.MlflowClient(tracking_uri=uri)
    experiment_id = client.get_run(run_id).info.experiment_id
    with warnings.catch_warnings():  # MLflow's own pandas 3 deprecation, nothing of ours
        warnings.filterwarnings("ignore", message=r".*select_dtypes.*")
        retrying(
            lambda: client.log_table(
                run_id,
                data={k: [r[k] for r in rows] for k in rows[0]},
                artifact_file="comparison/crse_cte.json",
            )
        )
    client.log_text(run_id, page, "comparison/crse_cte.html")
    retrying(lambda: client.set_tag(run_id, "mlflow.note.content", note))
    share_runs_view(
        client,
        experiment_id,
        HEADLINE_VIEW,
        search_filter="tags.model = 'pipeline'",
        metrics=view_metrics,
        tags=("rwhonet.execution",),
    )
    return experiment_id
