"""Stage outputs: written all at once or not at all, plus the shared file writers.

A stage writes each output (a folder or a file) into a temporary sibling and
moves them all into place only when everything succeeded
(:func:`atomic_outputs`). The moves happen back to back with SIGINT/SIGTERM/SIGHUP
held off (:func:`held_signals`), so an interrupted stage leaves either its old
outputs or its new ones, never a mix; only a SIGKILL inside those few renames
could split them.
DVC does not record an interrupted stage in ``dvc.lock``, so the next
``dvc repro`` runs it again in any case.

A temporary sibling is named ``.<output>.tmp-<pid>-<random>``. A process killed
outright (SIGKILL, a power cut) cannot remove its own, so the next write of
the same output removes those whose process is gone: they would otherwise
sit beside the outputs (where ``models/g`` as a whole is a dependency of
``evaluate``) and in ``git status``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import pyarrow as pa
import pyarrow.feather as feather
import pyarrow.parquet as pq

from rwhonet.contracts import SCENARIO

# The signals that stop a stage (rwhonet.libraries.INTERRUPTS; io sits below libraries)
HELD_SIGNALS = tuple(
    s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None
)
T = TypeVar("T")
R = TypeVar("R")


@contextmanager
def held_signals(signals: tuple[int, ...] = HELD_SIGNALS) -> Iterator[None]:
    """Handle SIGINT, SIGTERM and SIGHUP that arrive inside the block only once it has finished.

    The block runs with handlers that only note a signal; on the way out the
    previous handlers come back and each noted signal is raised again, so it
    does then what it would have done (end the process, or raise in it).
    Blocking with ``pthread_sigmask`` would not do: a process with other threads
    (Arrow's, torch's) receives the signal on one of them, and Python runs its
    handler in the main thread all the same. Outside the main thread, where
    handlers cannot be set, the block runs as it is.

    Args:
        signals: the signals to hold.

    Yields:
        Nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in signals}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in dict.fromkeys(caught):
            if previous[s] is not signal.SIG_IGN:
                signal.raise_signal(s)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _tmp_prefix(path: Path) -> str:
    return f".{path.name}.tmp-"


def _process_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove the temporary siblings of ``path`` left by processes that no longer run.

    Args:
        path: an output path (file or folder).

    Returns:
        What was removed.
    """
    prefix, removed = _tmp_prefix(path), []
    if not path.parent.is_dir():
        return removed
    for entry in path.parent.iterdir():
        if not entry.name.startswith(prefix):
            continue
        pid = entry.name[len(prefix) :].split("-", 1)[0]
        if pid.isdigit() and not _process_alive(int(pid)):
            _remove(entry)
            removed.append(entry)
    return removed


SCRATCH_PREFIX = "rwhonet-"
# rwhonet-<kind>-<pid>-<random>: a scratch folder of :func:`scratch_dir`
_SCRATCH = re.compile(r"^rwhonet-[a-z]+-(\d+)-")
STALE_SCRATCH_S = 3600.0


@contextmanager
def scratch_dir(kind: str) -> Iterator[Path]:
    """A scratch folder in the system's temporary directory, removed when the block ends.

    It is named with this process's id (``rwhonet-<kind>-<pid>-...``), and before it is
    made the scratch folders of rwhonet processes that no longer run are removed
    (:func:`remove_stale_scratch`): a command killed by SIGKILL or a power cut cannot
    remove its own, and a decompressed drive in one can be gigabytes.

    Args:
        kind: what the folder is for (lower-case letters: ``unpacked``, ``model``, ...).
    """
    remove_stale_scratch()
    with tempfile.TemporaryDirectory(prefix=scratch_prefix(kind)) as tmp:
        yield Path(tmp)


def scratch_prefix(kind: str) -> str:
    """The name a scratch folder of this process starts with (``rwhonet-<kind>-<pid>-``),
    for a folder :func:`scratch_dir` does not remove itself: :func:`remove_stale_scratch`
    removes it once the process has ended."""
    return f"{SCRATCH_PREFIX}{kind}-{os.getpid()}-"


def remove_stale_scratch(
    root: Path | None = None, min_age_s: float = STALE_SCRATCH_S
) -> list[Path]:
    """Remove the scratch folders (:func:`scratch_dir`) of processes that no longer run.

    A folder is removed only when its process is gone and it was last changed over
    ``min_age_s`` ago: a process in another PID namespace that shares the temporary
    directory (a container) looks gone from here, and its folder is left alone for that
    long.

    Args:
        root: the temporary directory (default: the system's).
        min_age_s: how long since the folder last changed.

    Returns:
        What was removed.
    """
    root = Path(root or tempfile.gettempdir())
    removed: list[Path] = []
    now = time.time()
    try:
        entries = list(root.iterdir())
    except OSError:
        return removed
    for entry in entries:
        m = _SCRATCH.match(entry.name)
        if m is None or _process_alive(int(m.group(1))):
            continue
        try:
            stale = entry.is_dir() and not entry.is_symlink()
            stale = stale and now - entry.stat().st_mtime > min_age_s
        except OSError:
            continue
        if stale:
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _temporary(path: Path, folder: bool) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    prefix = f"{_tmp_prefix(path)}{os.getpid()}-"
    if folder:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=path.parent))
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700; outputs get the usual permissions
    else:
        fd, name = tempfile.mkstemp(prefix=prefix, dir=path.parent)
        os.close(fd)
        tmp = Path(name)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600
    return tmp


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


@contextmanager
def atomic_outputs(*outputs: Path, folders: tuple[bool, ...] | None = None) -> Iterator[list[Path]]:
    """Yield temporary paths that replace ``outputs`` together, only if the block succeeds.

    Args:
        outputs: the stage's output paths (folders or files).
        folders: whether each output is a folder (default: all folders).

    Yields:
        One temporary path per output, siblings of the outputs (same file system,
        so the final moves are renames): folders created empty, files created empty.
    """
    paths = [Path(p) for p in outputs]
    kinds = folders if folders is not None else (True,) * len(paths)
    if len(kinds) != len(paths):
        raise ValueError(f"{len(paths)} outputs but {len(kinds)} folder flags")
    tmps: list[Path] = []
    try:
        for path, folder in zip(paths, kinds, strict=True):
            tmps.append(_temporary(path, folder))
        yield list(tmps)
    except BaseException:
        for tmp in tmps:
            _remove(tmp)
        raise
    # Everything is written: swap all outputs in with renames only (old ones are moved
    # aside, deleted afterwards), interrupts held until the last rename is done.
    old: list[Path] = []
    with held_signals():
        for path, tmp in zip(paths, tmps, strict=True):
            if path.exists() or path.is_symlink():
                aside = tmp.with_name(tmp.name + ".old")
                os.replace(path, aside)
                old.append(aside)
            os.replace(tmp, path)
        for aside in old:
            _remove(aside)


@contextmanager
def atomic_dir(path: Path) -> Iterator[Path]:
    """Yield a temporary folder that replaces ``path`` only if the block succeeds."""
    with atomic_outputs(path) as (tmp,):
        yield tmp


@contextmanager
def atomic_file(path: Path) -> Iterator[Path]:
    """Yield a temporary file path that replaces ``path`` only if the block succeeds."""
    with atomic_outputs(path, folders=(False,)) as (tmp,):
        yield tmp


def write_json(path: Path, obj: Any) -> None:
    """Write ``obj`` as indented JSON, atomically."""
    with atomic_file(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=2, sort_keys=False) + "\n", encoding="utf-8")


def read_json(path: Path) -> Any:
    """Read a JSON file."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


@contextmanager
def system_memory_pool() -> Iterator[None]:
    """Let Arrow allocate with the C library's malloc inside the block (also a decorator).

    pyarrow's default pool on Linux is mimalloc; the data stages ran faster with
    the system allocator on the machines this project is measured on, with
    identical output (``benchmarks/bench_data.py`` compares). Buffers remember
    the pool they came from, so those still alive after the block are freed
    correctly; the previous default is restored.

    Yields:
        Nothing; Arrow's default memory pool is the system pool until the block exits.
    """
    previous = pa.default_memory_pool()
    pa.set_memory_pool(pa.system_memory_pool())
    try:
        yield
    finally:
        pa.set_memory_pool(previous)


def write_parquet(table: pa.Table, path: Path) -> None:
    """Write a samples table (or any table users open in other tools) to Parquet, uncompressed.

    Dictionary encoding only for ``scenario``: on float channels it buys nothing
    (few repeated values) and makes writing several times slower. No compression:
    these files are working data handed from one stage to the next, and
    compressing them costs more time than the extra bytes
    (``benchmarks/bench_data.py``).

    Args:
        table: the table (column types and nullability as built by its stage).
        path: the Parquet file to write.
    """
    pq.write_table(
        table,
        path,
        compression="none",
        use_dictionary=[SCENARIO] if SCENARIO in table.column_names else False,
    )


def write_arrow(table: pa.Table, path: Path) -> None:
    """Write a drive or segment table as an Arrow IPC file (Feather v2), uncompressed.

    The files ``ingest`` and ``validate`` hand on (``data/interim``) are the drive's own
    columns, read back whole by the next stage: in Arrow's own format writing them is a
    copy of their buffers and reading them another, where Parquet encodes and decodes
    every page (a quarter of the data path's time, ``benchmarks/bench_data.py``). Read
    them with :func:`read_arrow`, ``pyarrow.feather.read_table`` or ``pandas.read_feather``.

    Args:
        table: the table (column types and nullability as built by its stage).
        path: the ``.arrow`` file to write.
    """
    feather.write_feather(table, path, compression="uncompressed")


def read_arrow(path: Path, columns: list[str] | None = None) -> pa.Table:
    """Read an Arrow IPC file written by :func:`write_arrow`: all its columns, or some.

    Read into memory rather than mapped: a file replaced while mapped could end the
    process with SIGBUS, and the copy costs little next to what a stage does with it.
    One thread: the stages read a few files at a time already (:func:`map_in_order`),
    and Arrow's own pool on top only costs CPU.

    Args:
        path: the ``.arrow`` file.
        columns: read those of these columns the file has, in its order (default: all).

    Returns:
        The table.

    Raises:
        OSError, pyarrow.ArrowException: the file is missing or not an Arrow IPC file.
    """
    if columns is not None:
        with pa.OSFile(str(path)) as source:
            present = set(pa.ipc.open_file(source).schema.names)  # the file's footer only
        columns = [name for name in columns if name in present]
    return feather.read_table(path, columns=columns, memory_map=False, use_threads=False)


# Drives a data stage reads, checks and writes at once: pyarrow's CSV and Parquet code and
# numpy's loops over a drive's arrays run without Python's lock, so two drives in two threads
# use two cores (the machine the figures are measured on has two); each holds its drive.
# $RWHONET_DATA_THREADS sets it (1: one drive at a time, in the stage's own thread). The
# outputs are the same whatever it is.
DATA_THREADS = max(1, int(os.environ.get("RWHONET_DATA_THREADS", min(2, os.cpu_count() or 1))))


def map_in_order(
    fn: Callable[[T], R], items: Iterable[T], workers: int = DATA_THREADS
) -> Iterator[tuple[T, Future[R]]]:
    """Run ``fn`` on the items in up to ``workers`` threads; yield ``(item, future)`` in order.

    At most ``workers`` items are in flight beyond the one the caller holds, so memory holds
    that many results (drives) at once. ``future.result()`` returns ``fn(item)`` or raises
    what it raised, so the caller handles each item's errors where it did in a plain loop.
    With one worker, ``fn`` runs in the caller's thread, item by item.

    Args:
        fn: the work on one item (thread-safe: no shared state it writes).
        items: the items.
        workers: threads.

    Yields:
        Each item with the future of its result, in the items' order.
    """
    items = list(items)
    if workers <= 1 or len(items) <= 1:
        for item in items:
            done: Future[R] = Future()
            try:
                done.set_result(fn(item))
            except BaseException as err:  # handed to the caller, as the threads do
                done.set_exception(err)
            yield item, done
        return
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="rwhonet-data") as pool:
        pending: deque[tuple[T, Future[R]]] = deque()
        for i, item in enumerate(items):
            try:
                pending.append((item, pool.submit(fn, item)))
            except RuntimeError:  # no thread could start (memory, limits): go on item by item
                yield from pending
                yield from map_in_order(fn, items[i:], workers=1)
                return
            if len(pending) > workers:
                yield pending.popleft()
        while pending:
            yield pending.popleft()
