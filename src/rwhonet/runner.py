"""What every pipeline stage script shares: its params, quiet libraries, readable failures.

A stage script is ``runner.run_script("train", main)``: the runner loads
``params.yaml`` restricted to the params ``dvc.yaml`` declares for that stage
(:func:`declared_params`), so a stage that reads a value it does not declare
stops with an error naming it, rather than leaving DVC to skip it when that
value changes. Input and config errors exit with status 2 and a readable
report, never a traceback.

A stage that fails (any exception, input and config errors included) or is
interrupted (SIGTERM, SIGINT, SIGHUP: :func:`rwhonet.libraries.interruptible`) leaves
a run in the project's MLflow store with status FAILED or KILLED
(:mod:`rwhonet.tracking.failure`); MLflow is imported
only then. An interrupted stage unwinds (its atomic outputs are discarded),
logs, and then dies of the same signal, so DVC and shells see what happened.
"""

from __future__ import annotations

import os
import signal
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path

import yaml

from rwhonet import paths
from rwhonet.config import ConfigError, Params, load_params
from rwhonet.errors import InputError
from rwhonet.io import system_memory_pool
from rwhonet.libraries import (
    Interrupted,
    die_of,
    exit_with,
    ignore_interrupts,
    interruptible,
    quiet,
)

EXIT_INPUT = 2
EXIT_FAILED = 1


def declared_params(stage: str, dvc_yaml: Path | None = None) -> list[str]:
    """The params a stage declares in ``dvc.yaml`` (dotted keys of ``params.yaml``).

    Args:
        stage: the stage's name in ``dvc.yaml`` (a matrix stage by its base name).
        dvc_yaml: the pipeline file; defaults to the project's.

    Returns:
        The declared keys.

    Raises:
        ConfigError: when ``dvc.yaml`` has no such stage.
    """
    dvc_yaml = dvc_yaml or paths.ROOT / "dvc.yaml"
    stages = (yaml.safe_load(dvc_yaml.read_text(encoding="utf-8")) or {}).get("stages", {})
    if stage not in stages:
        raise ConfigError(f"{paths.rel(dvc_yaml)} has no stage {stage!r}; stages: {list(stages)}")
    keys: list[str] = []
    for entry in stages[stage].get("params", []):
        if isinstance(entry, str):
            keys.append(entry)
        else:  # {params-file: [keys]}
            for file_keys in entry.values():
                keys += list(file_keys or [])
    return keys


def run(stage: str, main: Callable[[Params], None]) -> None:
    """Run a stage's ``main`` with its declared params; record any failure in MLflow.

    Input and config errors print their report and exit 2; any other exception
    prints its traceback and exits 1; SIGTERM, SIGINT or SIGHUP ends the process by
    that signal. Each leaves a FAILED or KILLED run in the project's MLflow store.

    Args:
        stage: the stage's name in ``dvc.yaml``.
        main: the stage body; it receives the restricted params.
    """
    quiet()
    started = time.time()
    with interruptible():
        _run(stage, main, started)


def run_script(stage: str, main: Callable[[Params], None]) -> None:
    """A stage script's ``__main__``: :func:`run`, then end the process by its status.

    The process ends by :func:`rwhonet.libraries.exit_process` (Python's exit
    hooks, then no native teardown to abort after the outputs are written); an
    interrupted stage still dies of its signal. Never call it in a process that
    has more to do (the tests call :func:`run`).
    """
    exit_with(lambda: run(stage, main))


def _run(stage: str, main: Callable[[Params], None], started: float) -> None:
    try:
        params = load_params(
            paths.PARAMS, only=declared_params(stage), reader=f"stage {stage} (dvc.yaml)"
        )
        with system_memory_pool():  # Arrow's buffers from malloc (rwhonet.io: faster here)
            main(params)
    except (InputError, ConfigError) as err:
        ignore_interrupts()
        print(
            f"\nERROR in stage {stage} ({os.path.basename(sys.argv[0])}):\n{err}", file=sys.stderr
        )
        _record(stage, "FAILED", err, EXIT_INPUT, started)
        sys.exit(EXIT_INPUT)
    except Interrupted as err:
        ignore_interrupts()
        print(f"\nstage {stage} {err}", file=sys.stderr)
        _record(stage, "KILLED", err, -err.signum, started)
        die_of(err.signum)
    except SystemExit as err:
        if err.code in (None, 0):
            raise
        ignore_interrupts()
        code = err.code if isinstance(err.code, int) else EXIT_FAILED
        _record(stage, "FAILED", err, code, started)
        raise
    except BaseException as err:  # anything else: a bug or a library failure
        ignore_interrupts()
        traceback.print_exception(err, file=sys.stderr)
        _record(stage, "FAILED", err, EXIT_FAILED, started)
        sys.exit(EXIT_FAILED)


def _record(stage: str, status: str, err: BaseException, exit_code: int, started: float) -> None:
    """Log the failure to MLflow; a failure to log is reported, never raised."""
    from rwhonet.tracking.failure import Failure, log_failure

    if isinstance(err, Interrupted):
        error_type, message = signal.Signals(err.signum).name, f"stage {stage} {err}"
    elif isinstance(err, SystemExit):
        said = f": {err.code}" if isinstance(err.code, str) else ""
        error_type, message = "SystemExit", f"stage {stage} exited with status {exit_code}{said}"
    else:
        error_type, message = type(err).__name__, str(err) or type(err).__name__
    failure = Failure(
        stage=stage,
        status=status,
        error_type=error_type,
        message=message,
        traceback="".join(traceback.format_exception(err)),
        exit_code=exit_code,
        command=list(sys.argv),
        started_s=started,
    )
    try:
        run_id, uri = log_failure(failure)
    except Exception as log_err:  # noqa: BLE001 - the stage's own error matters more
        print(f"(the failure could not be logged to MLflow: {log_err})", file=sys.stderr)
        return
    print(f"MLflow: {status} run {run_id} in {uri}", file=sys.stderr)
