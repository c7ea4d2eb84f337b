"""rwhonet.stages.cores: jobs on every core, in order, ended at once when the stage stops."""

from __future__ import annotations

import os
import signal
import time
from concurrent.futures.process import BrokenProcessPool

import pytest

from rwhonet.stages import cores


def _square(x: int) -> int:
    import torch

    return x * x * 10 + torch.get_num_threads()  # one thread wherever it runs


def _die(_: int) -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _fail(x: int) -> None:
    raise ValueError(f"job {x} refused")


def _sleep(x: int) -> int:
    time.sleep(60)
    return x


@pytest.fixture
def two_cores(monkeypatch):
    monkeypatch.setattr(cores.os, "cpu_count", lambda: 2)


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_results_come_in_item_order_whatever_the_workers(workers):
    seen = []

    def show(results):
        for r in results:
            seen.append(r)
            yield r

    out = cores.map_on_cores(_square, [3, 1, 2, 5], workers, show=show)
    assert out == seen == [91, 11, 41, 251]


def test_workers_are_one_per_core_at_most_the_cap_and_the_items(two_cores):
    assert cores.workers_for(6, 8) == 2
    assert cores.workers_for(1, 8) == 1
    assert cores.workers_for(6, 1) == 1
    assert cores.workers_for(0, 8) == 1
    assert cores.workers_for(6, 8, threads_each=2) == 1  # jobs on two threads each
    assert cores.cores_for(8) == 2 and cores.cores_for(1) == 1 and cores.cores_for(8, 4) == 1


def test_a_worker_that_dies_fails_the_stage_instead_of_hanging():
    # multiprocessing.Pool waits forever for a killed worker; the executor must not.
    with pytest.raises(BrokenProcessPool):
        cores.map_on_cores(_die, [1, 2, 3], 2)


def test_a_failing_job_raises_its_own_error():
    with pytest.raises(ValueError, match="job 2 refused"):
        cores.map_on_cores(_fail, [2, 3], 2)


def test_an_interrupted_stage_ends_its_workers_instead_of_waiting_for_them():
    """A signal in the stage (here an alarm) stops the pool's jobs now, not in a minute."""

    class Interrupted(Exception):
        pass

    def interrupt(signum, frame):
        raise Interrupted

    pids: list[int] = []

    def show(results):
        pids.extend(p for p in _children())
        yield from results

    before = signal.signal(signal.SIGALRM, interrupt)
    started = time.monotonic()
    try:
        signal.setitimer(signal.ITIMER_REAL, 1.0)
        with pytest.raises(Interrupted):
            cores.map_on_cores(_sleep, [1, 2], 2, show=show)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)
    assert time.monotonic() - started < 20
    assert pids and not [p for p in pids if _alive(p)]


def _children() -> list[int]:
    me = str(os.getpid())
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    if f.read().rsplit(")", 1)[1].split()[1] == me:
                        out.append(int(entry))
            except OSError:
                continue
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False
