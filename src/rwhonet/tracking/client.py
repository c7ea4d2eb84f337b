"""Where the project's MLflow store is, and how to open it safely from several processes.

Store: SQLite at ``mlruns/mlflow.db`` with artifacts under ``mlruns/artifacts``
(MLflow 3 keeps its file store in maintenance mode, off by default). Relative URIs
resolve against the project root; inside a queued DVC experiment (which runs
in ``.dvc/tmp/exps/<tmp>``) they resolve against the real repository so the
runs are not lost with the temporary copy. ``$MLFLOW_TRACKING_URI`` wins; a
user and password in it move to the environment variables MLflow reads, so the
URI the project uses, prints and logs carries none
(:mod:`rwhonet.tracking.credentials`).

Several processes may write to one store at once (``dvc queue start -j 2``,
two clones sharing a store, a stage failing while ``evaluate`` logs).
:func:`open_store` creates the store and the experiment under a file lock
beside the database, so a fresh store's schema migration runs once, and
:func:`retrying` repeats a store call that SQLite refused because another
writer held the database.

No module here imports MLflow at import time: the stages that only log on
failure (:mod:`rwhonet.tracking.failure`) pay for it only when they fail.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

from rwhonet import paths
from rwhonet.tracking.credentials import access_error, adopt_uri_credentials, check_transport

SQLITE = "sqlite:///"
T = TypeVar("T")


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
        ``$MLFLOW_TRACKING_URI`` if set, else the absolute URI; without a user and
        password (:func:`~rwhonet.tracking.credentials.adopt_uri_credentials`).

    Raises:
        InputError: an ``http://`` URI of another machine while a password is set
            (:func:`~rwhonet.tracking.credentials.transport_problem`).
    """
    env = os.environ.get("MLFLOW_TRACKING_URI")
    if env:
        return check_transport(adopt_uri_credentials(env))
    if uri.startswith(SQLITE) and not uri.startswith(SQLITE + "/"):
        db = main_repo_root(root) / uri[len(SQLITE) :]
        db.parent.mkdir(parents=True, exist_ok=True)
        return SQLITE + str(db)
    return check_transport(uri)


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


def _sqlite_busy(err: BaseException) -> bool:
    """Whether ``err`` (or what caused it) is SQLite refusing a write another process holds."""
    seen: set[int] = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        text = str(err).lower()
        if "database is locked" in text or "database table is locked" in text:
            return True
        err = err.__cause__ or err.__context__
    return False


def retrying(call: Callable[[], T], *, attempts: int = 8, first_wait_s: float = 0.2) -> T:
    """Run a store call, again after a growing pause while SQLite says the database is locked.

    SQLite lets one writer in at a time and makes the others wait a few seconds
    before failing; with two pipelines logging hundreds of runs at once that
    wait can run out. A tracking server's refusal of the login (401) or of the
    action (403) is raised at once as an :class:`~rwhonet.errors.InputError` that
    says what to do (:func:`~rwhonet.tracking.credentials.access_error`); any
    other error is raised at once as it is.

    Args:
        call: the store call (no arguments).
        attempts: how many times to try.
        first_wait_s: the pause after the first refusal; doubled each time.

    Returns:
        What ``call`` returns.
    """
    for attempt in range(attempts):
        try:
            return call()
        except Exception as err:
            refused = access_error(err)
            if refused is not None:
                raise refused from err
            if attempt == attempts - 1 or not _sqlite_busy(err):
                raise
            time.sleep(first_wait_s * 2**attempt)
    raise AssertionError("unreachable")


@contextmanager
def _store_lock(uri: str) -> Iterator[None]:
    """Hold an exclusive lock beside a SQLite store (no lock for other stores)."""
    if not uri.startswith(SQLITE):
        yield
        return
    db = Path(uri[len(SQLITE) :])
    db.parent.mkdir(parents=True, exist_ok=True)
    with open(db.with_name(db.name + ".lock"), "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


# MLflow 3's UI opens an experiment on its GenAI overview unless it is marked as model
# training; marked, it opens on the runs.
EXPERIMENT_KIND_TAG = "mlflow.experimentKind"
EXPERIMENT_KIND = "custom_model_development"


def open_store(uri: str, experiment: str) -> tuple[Any, str]:
    """A client of the store at ``uri`` and the id of ``experiment``, both created if missing.

    The store's schema set-up (a fresh SQLite file runs MLflow's migrations) and
    the experiment's creation happen under a lock, so processes opening one
    store at the same moment neither race on the migration nor create the
    experiment twice. The artifact root of a new experiment is
    :func:`artifact_root` (a tracking server's own default for ``http(s)://``).

    Args:
        uri: resolved tracking URI (:func:`resolve_tracking_uri`).
        experiment: experiment name.

    Returns:
        ``(MlflowClient, experiment_id)``.
    """
    import mlflow

    # On a tracking server MLflow prints two "View run/experiment" lines to stdout per run
    # ended: hundreds from one execution, and none the user asked for.
    os.environ.setdefault("MLFLOW_SUPPRESS_PRINTING_URL_TO_STDOUT", "true")
    with _store_lock(uri):
        client = mlflow.MlflowClient(tracking_uri=uri)
        exp = retrying(lambda: client.get_experiment_by_name(experiment))
        if exp is not None:
            exp_id = exp.experiment_id
            if exp.tags.get(EXPERIMENT_KIND_TAG) != EXPERIMENT_KIND:
                retrying(
                    lambda: client.set_experiment_tag(exp_id, EXPERIMENT_KIND_TAG, EXPERIMENT_KIND)
                )
            return client, exp_id
        exp_id = retrying(
            lambda: client.create_experiment(
                experiment,
                artifact_location=artifact_root(uri),
                tags={EXPERIMENT_KIND_TAG: EXPERIMENT_KIND},
            )
        )
        return client, exp_id
