"""A stage's independent jobs on every core: a fork pool, torch on one thread everywhere.

The model stages run jobs that share nothing (``train``: one WhONet per model and
seed; ``adapt``: one recalibration per drive, recipe and m). Each job gets its
inputs as the item itself (pickled to a forked worker) and runs torch on one
thread wherever it runs, alone in this process or in a worker, so its result does
not depend on how many workers there are.

A pool is ended as soon as the stage stops: if a job fails, or the stage is
interrupted (SIGTERM, Ctrl-C: :mod:`rwhonet.runner`), the workers still running
are terminated rather than waited for, so a killed stage does not train on in
the background and the failure is reported at once.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")


def cores_for(max_workers: int, threads_each: int = 1) -> int:
    """Processes this machine runs side by side: one per ``threads_each`` cores (a job
    that sets its own torch threads), at most ``max_workers``."""
    return max(1, min((os.cpu_count() or 1) // max(1, threads_each), max_workers))


def workers_for(n_items: int, max_workers: int, threads_each: int = 1) -> int:
    """How many processes run ``n_items`` jobs (:func:`cores_for`, no more than the jobs)."""
    return max(1, min(cores_for(max_workers, threads_each), n_items))


def map_on_cores(
    function: Callable[[T], R],
    items: list[T],
    workers: int,
    chunksize: int = 1,
    show: Callable[[Iterator[R]], Iterable[R]] | None = None,
) -> list[R]:
    """``function(item)`` for every item, on ``workers`` processes; results in item order.

    With fewer than two workers (or items) the items run here, one after the other.

    Args:
        function: a module-level function (a forked worker calls it by reference).
        items: its arguments, one job each.
        workers: processes to use (:func:`workers_for`).
        chunksize: items handed to a worker at a time (many short jobs: more than 1).
        show: wraps the results as they come, in order (a progress bar:
            :func:`rwhonet.progress.track`).
    """
    show = show if show is not None else iter
    if workers < 2 or len(items) < 2:
        with one_thread_here():
            return list(show(function(item) for item in items))
    # ProcessPoolExecutor rather than multiprocessing.Pool: if a worker dies (killed, out
    # of memory) the map raises BrokenProcessPool, where a Pool would wait forever.
    pool = ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("fork"), initializer=one_thread
    )
    try:
        return list(show(pool.map(function, items, chunksize=chunksize)))
    except BaseException:
        _terminate(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop a pool's workers now (Python 3.14 has ``terminate_workers``; 3.11 does not)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=10)


def one_thread() -> None:
    """torch on one thread in this process (a pool worker's initializer)."""
    import torch

    torch.set_num_threads(1)


@contextmanager
def one_thread_here() -> Iterator[None]:
    """torch on one thread in this process for a while (as in a pool's workers)."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)
