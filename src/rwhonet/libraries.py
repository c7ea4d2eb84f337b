"""Quiet third-party libraries: telemetry, import tips and deprecation noise a user cannot act on;
and a process end their native threads cannot turn into a crash.

Below every layer (like ``io.py``): the stage runner, the ``rwhonet`` command,
``python -m rwhonet.tracking`` and the tests call :func:`quiet` before the
libraries speak; the stage scripts and the ``rwhonet`` command end by
:func:`exit_process` (:func:`exit_with`: a piece of work, then that).
"""

from __future__ import annotations

import atexit
import logging
import os
import sys
import threading
import warnings
from collections.abc import Callable
from typing import NoReturn


def quiet() -> None:
    """Silence library noise that says nothing to a user (telemetry, tips, deprecations)."""
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    os.environ.setdefault("DO_NOT_TRACK", "true")
    os.environ.setdefault("DISABLE_PANDERA_IMPORT_WARNING", "True")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\).*")
    logging.getLogger("lightning.pytorch.utilities.rank_zero").setLevel(logging.WARNING)
    logging.getLogger("lightning.fabric.utilities.rank_zero").setLevel(logging.WARNING)


def exit_with(work: Callable[[], int | str | None]) -> NoReturn:
    """Do ``work`` and end the process by :func:`exit_process` with what it returned,
    or with the code of the ``SystemExit`` it raised (argparse's ``--help``, a stage's
    ``sys.exit``)."""
    try:
        code = work()
    except SystemExit as err:
        code = err.code
    exit_process(code)


def exit_process(code: int | str | None) -> NoReturn:
    """End this process with ``code`` once its work is done, without native teardown.

    ``code`` as ``sys.exit`` takes it (a ``SystemExit``'s): None is 0, an int is the
    status, anything else is printed to stderr and the status is 1.

    A process that read or wrote Parquet can abort after its last byte: Arrow's
    thread pool, torn down by the C++ runtime at exit while a worker is still
    alive, calls ``std::terminate`` ("terminate called without an active
    exception", SIGABRT, exit -6; apache/arrow#34314 and #39862, intermittent and
    more frequent on a loaded machine). Seen here once, in CI: an ``ingest``
    stage of a queued DVC experiment, its outputs written, reported failed. So
    the stage scripts and the ``rwhonet`` command end here: Python's own
    shutdown steps that matter (non-daemon threads joined, as the interpreter
    does first; then every ``atexit`` hook: MLflow's, logging's), the standard
    streams flushed, then ``os._exit``, which skips the C++ static destructors
    and nothing written.

    Only for a process's own end (a script's ``__main__``); never in a library
    call or a test, which would end the test run.
    """
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:
        print(code, file=sys.stderr)
        status = 1
    shutdown = getattr(threading, "_shutdown", None)  # what Py_FinalizeEx calls first
    if shutdown is not None:
        shutdown()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed, or a reader gone: nothing more to say
            pass
    os._exit(status)
