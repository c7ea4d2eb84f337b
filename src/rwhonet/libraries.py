"""Quiet third-party libraries: telemetry, import tips and deprecation noise a user cannot act on;
a process end their native threads cannot turn into a crash; and a stopped process that
cleans up.

Below every layer (like ``io.py``): the stage runner, the ``rwhonet`` command,
``python -m rwhonet.tracking`` and the tests call :func:`quiet` before the
libraries speak; the stage scripts and the ``rwhonet`` command end by
:func:`exit_process` (:func:`exit_with`: a piece of work, then that).

Signals: the stage runner (:mod:`rwhonet.runner`) and the ``rwhonet`` command
(:mod:`rwhonet.cli.main`) run their work inside :func:`interruptible`, so SIGTERM,
SIGINT or SIGHUP raises :class:`Interrupted` where the process is, and ``finally``
blocks and context managers run on the way out (a stage's atomic outputs are
discarded, ``predict``'s half-written output file is removed, ``recalibrate``'s
temporary folder goes); the caller then reports it and ends the process. Without it,
each of these signals ends Python at once, and nothing is cleaned up.
"""

from __future__ import annotations

import atexit
import logging
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, NoReturn


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


# Stop a process: kill and the service manager (SIGTERM), Ctrl-C (SIGINT), the terminal
# closing under it (SIGHUP, where the platform has one).
INTERRUPTS = tuple(
    s for s in (signal.SIGTERM, signal.SIGINT, getattr(signal, "SIGHUP", None)) if s is not None
)  # rwhonet.io.HELD_SIGNALS holds the same ones off during its renames


class Interrupted(BaseException):
    """A signal of :data:`INTERRUPTS` reached the process (raised by the handler).

    A ``BaseException``, like ``KeyboardInterrupt``: ``except Exception`` in library
    code does not swallow it, and ``finally`` blocks and ``atomic_outputs`` clean up
    on the way out.
    """

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(f"interrupted by {signal.Signals(signum).name}")


# The process that installed the handlers, the handlers it had before (_raise_interrupted),
# and the signal a handler raised for (raise_if_interrupted).
_installed: dict[str, Any] = {"pid": None, "previous": {}, "caught": None}


def _raise_interrupted(signum: int, frame: FrameType | None) -> None:
    if os.getpid() != _installed["pid"]:
        # A forked worker (the adapt stage's process pool) inherited this handler: it does
        # what it did before, e.g. dies quietly when its pool terminates it at exit.
        previous = _installed["previous"].get(signum, signal.SIG_DFL)
        if callable(previous):
            previous(signum, frame)
        elif previous != signal.SIG_IGN:
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
        return
    _installed["caught"] = signum
    raise Interrupted(signum)


def raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` again where a handler raised it and it was lost.

    A C library that checks for signals inside a long call (``PyErr_CheckSignals``) runs
    the handler there, and one that drops the error it returns loses the exception:
    numpy's ``np.char.mod`` did, and a live ``predict`` went on reading its pipe after
    SIGTERM (one run in some fifty on a loaded machine). Loops that may wait call this.

    It first runs the handlers of signals that came but whose handler has not run. A signal
    that lands on another thread marks itself pending and asks the main thread's eval loop
    to look, but in CPython 3.11 that request is one flag that any thread may recompute and
    clear, so a main thread that only waits in ``select()`` could go on waiting with the
    signal pending: a possible cause, not reproduced here, of a pipe reader that hung
    through its 60 s timeout in one CI run. ``pthread_sigmask`` with an empty set changes
    nothing but calls ``PyErr_CheckSignals``, which runs every pending handler.
    """
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, ())  # a pending handler runs (or raises) here
    if _installed["caught"] is not None and os.getpid() == _installed["pid"]:
        raise Interrupted(_installed["caught"])


@contextmanager
def interruptible() -> Iterator[None]:
    """Within the block, a signal of :data:`INTERRUPTS` raises :class:`Interrupted`; the
    handlers the process had are restored after it."""
    previous = {signum: signal.signal(signum, _raise_interrupted) for signum in INTERRUPTS}
    _installed.update(pid=os.getpid(), previous=previous, caught=None)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _installed["caught"] = None


def ignore_interrupts() -> None:
    """Let the process report what happened: a second signal no longer interrupts."""
    for signum in INTERRUPTS:
        signal.signal(signum, signal.SIG_IGN)


def die_of(signum: int) -> NoReturn:
    """End the process by ``signum`` (default action), as if it had not been caught."""
    sys.stdout.flush()
    sys.stderr.flush()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)
    sys.exit(128 + signum)  # not reached unless the signal could not end the process
