"""A stage that fails or is interrupted leaves a run in MLflow: FAILED or KILLED, never RUNNING.

The model stages write run records that ``evaluate`` logs after the fact, so a
stage that never finishes would otherwise leave no trace where users compare
runs. :func:`rwhonet.runner.run` calls :func:`log_failure` when a stage raises
(status FAILED; input and config errors included, with their readable report)
or receives SIGTERM / SIGINT (status KILLED). The run carries the stage name
(tag ``dvc_stage``), ``rwhonet.failure = true``, the error type and message
(tags, and the run's description in the UI), the command, the git commit, and
as artifacts the full message, the traceback and the ``params.yaml`` it ran
with. Find them with ``tags.rwhonet.failure = 'true'``. Every text is logged
through :func:`~rwhonet.tracking.credentials.redact`: a password in a URI or a
secret of the environment never reaches the store, whatever the error said.

The tracking params are read straight from ``params.yaml``, not through the
stage's declared params (a stage need not declare ``tracking``, and a failure
writes no output DVC could cache), and not through the typed loader, which
may be what failed. ``import mlflow`` happens here only, so a stage that
succeeds never pays for it.
"""

from __future__ import annotations

import dataclasses
import os
import shlex
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from rwhonet import paths
from rwhonet.config import tracking_uri_problem
from rwhonet.io import held_signals
from rwhonet.tracking.client import git_commit, open_store, resolve_tracking_uri, retrying
from rwhonet.tracking.credentials import redact

DEFAULT_URI = "sqlite:///mlruns/mlflow.db"
DEFAULT_EXPERIMENT = "rwhonet"
TAG_CHARS = 5000  # MLflow takes at most 8000 characters per tag value
STATUSES = ("FAILED", "KILLED")


@dataclass(frozen=True)
class Failure:
    """What went wrong in one stage process.

    Attributes:
        stage: the stage's name in ``dvc.yaml`` (``train``).
        status: ``FAILED`` (an exception) or ``KILLED`` (a signal).
        error_type: the exception's class name, or the signal's name.
        message: what the user saw (the readable report for input and config errors).
        traceback: the formatted traceback ("" when there is none).
        exit_code: the process's exit status (negative: killed by that signal).
        command: the stage's command line (``sys.argv``).
        started_s: when the stage started (``time.time()``).
    """

    stage: str
    status: str
    error_type: str
    message: str
    traceback: str = ""
    exit_code: int = 1
    command: list[str] = field(default_factory=list)
    started_s: float | None = None

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {self.status!r}")


def tracking_settings(params_file: Path | None = None) -> tuple[str, str]:
    """``tracking.tracking_uri`` and ``tracking.experiment`` read directly from ``params.yaml``.

    Falls back to the defaults when the file cannot be read or parsed, and to
    the default URI when the one given would write outside ``mlruns/``
    (:func:`rwhonet.config.tracking_uri_problem`), so a broken ``params.yaml``
    is still reported.

    Args:
        params_file: the params file; defaults to the project's.

    Returns:
        ``(tracking_uri, experiment)`` as written in the file (URI not yet resolved).
    """
    try:
        raw = yaml.safe_load(Path(params_file or paths.PARAMS).read_text(encoding="utf-8"))
        section = raw.get("tracking") if isinstance(raw, dict) else None
    except (OSError, yaml.YAMLError, UnicodeDecodeError):
        section = None
    section = section if isinstance(section, dict) else {}
    uri, experiment = section.get("tracking_uri"), section.get("experiment")
    if not isinstance(uri, str) or tracking_uri_problem(uri) is not None:
        uri = DEFAULT_URI
    if not isinstance(experiment, str) or not experiment.strip():
        experiment = DEFAULT_EXPERIMENT
    return uri, experiment


def _note(failure: Failure, run_name: str) -> str:
    """The run's description in the MLflow UI (Markdown)."""
    fence = "~~~"
    return (
        f"**{run_name}** (exit status {failure.exit_code})\n\n"
        f"{fence}\n{failure.message[:TAG_CHARS]}\n{fence}\n\n"
        "Traceback and params: artifacts `failure/`."
    )


def log_failure(
    failure: Failure, *, root: Path | None = None, params_file: Path | None = None
) -> tuple[str, str]:
    """Log a failed or killed stage as a terminated run of the project's experiment.

    The run is created and terminated back to back with SIGINT and SIGTERM held,
    so it is never left RUNNING by a second interrupt; the artifacts follow.

    Args:
        failure: what went wrong.
        root: the project root (a queued DVC experiment's temporary copy resolves
            to its repository's store); defaults to :data:`rwhonet.paths.ROOT`.
        params_file: the params file; defaults to the project's.

    Returns:
        ``(run_id, resolved tracking URI)`` (the URI without credentials).
    """
    failure = dataclasses.replace(
        failure,
        message=redact(failure.message),
        traceback=redact(failure.traceback),
        command=[redact(arg) for arg in failure.command],
    )
    # A store behind a server must not hold an interrupted stage for minutes of retries.
    os.environ.setdefault("MLFLOW_HTTP_REQUEST_MAX_RETRIES", "0")
    os.environ.setdefault("MLFLOW_HTTP_REQUEST_TIMEOUT", "10")
    params_file = Path(params_file or paths.PARAMS)
    uri_param, experiment = tracking_settings(params_file)
    uri = resolve_tracking_uri(uri_param, root)
    client, exp_id = open_store(uri, experiment)
    commit = git_commit(root)
    args = " ".join(failure.command[1:])
    run_name = f"{failure.status}: {failure.stage}" + (f" [{args}]" if args else "")
    tags = {
        "dvc_stage": failure.stage,
        "rwhonet.failure": "true",
        "rwhonet.error_type": failure.error_type,
        "rwhonet.error": failure.message[:TAG_CHARS],
        "rwhonet.exit_code": str(failure.exit_code),
        "rwhonet.command": shlex.join(failure.command),
        "git_commit": commit,
        "mlflow.source.git.commit": commit,
        "mlflow.source.type": "LOCAL",
        "mlflow.note.content": _note(failure, run_name),
    }
    if failure.command:
        tags["mlflow.source.name"] = failure.command[0]
    if os.environ.get("DVC_EXP_NAME"):
        tags["dvc_exp_name"] = os.environ["DVC_EXP_NAME"]
    start_ms = int(1000 * (failure.started_s or time.time()))
    with held_signals():
        run = retrying(
            lambda: client.create_run(exp_id, start_time=start_ms, tags=tags, run_name=run_name)
        )
        run_id = run.info.run_id
        end_ms = max(start_ms, int(1000 * time.time()))
        retrying(lambda: client.set_terminated(run_id, failure.status, end_time=end_ms))
    client.log_text(run_id, failure.message + "\n", "failure/error.txt")
    if failure.traceback:
        client.log_text(run_id, failure.traceback, "failure/traceback.txt")
    if params_file.is_file():
        text = params_file.read_text(encoding="utf-8", errors="replace")
        client.log_text(run_id, redact(text), f"failure/{params_file.name}")
    return run_id, uri
