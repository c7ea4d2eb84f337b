"""Wall time of the whole pipeline, per stage, for one world or a matrix of worlds.

    .venv/bin/python benchmarks/bench_pipeline.py [--worlds paper large_target ...]
        [--jobs 2] [--set model.arch=tcn --set model.seq_len=32] [--name bench]

Runs ``make variant`` (a scratch copy of the working tree under ``build/``,
``dvc exp run`` there: every stage from scratch, as on a fresh clone after
installation) once per world (``sim.profile``), ``--jobs`` worlds at a time
(1: one after the other; ``make worlds`` runs two), and prints per stage the
wall seconds from DVC's "Running stage" line to the next one (a matrix
stage's items, ``adapt@42`` ..., summed), the world's total, the CPU
seconds its processes used, and the matrix's wall time from the first
world's start to the last one's end. The machine's load average before and
after is printed too: on a shared machine the wall time grows with the
others' load, the CPU seconds much less.

``make`` is called with ``-o .venv/.installed`` by default (the environment
is taken as installed; ``--make-args ''`` to let make check it).
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNNING = re.compile(r"Running stage '([^']+)'")


def run_world(name: str, sets: list[str], make_args: list[str]) -> tuple[dict, float, float, int]:
    """``make variant`` of one world; ``(stage -> wall s, total wall s, CPU s, exit status)``.

    The CPU seconds are those of the ``make`` process and every process it waited
    for (``wait4``'s resource usage), so worlds run side by side are told apart.
    """
    cmd = ["make", *make_args, "variant", f"NAME={name}", f"SET={' '.join(sets)}"]
    start = time.perf_counter()
    marks: list[tuple[float, str]] = []
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    for line in proc.stdout:
        hit = RUNNING.search(line)
        if hit:
            marks.append((time.perf_counter(), hit.group(1)))
        elif line.startswith(("Ran experiment", "build/")) and marks and marks[-1][1]:
            marks.append((time.perf_counter(), ""))  # the last stage has ended
    proc.stdout.close()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    total = time.perf_counter() - start
    cpu = usage.ru_utime + usage.ru_stime
    marks.append((start + total, ""))
    stages: dict[str, float] = defaultdict(float)
    for (t, stage), (t_next, _) in zip(marks, marks[1:], strict=False):
        if stage:
            stages[stage.split("@")[0]] += t_next - t
    return dict(stages), total, cpu, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=["paper"], help="sim.profile values")
    ap.add_argument("--jobs", type=int, default=1, help="worlds run at a time (make worlds: 2)")
    ap.add_argument("--set", action="append", default=[], help="another key=value (repeatable)")
    ap.add_argument("--name", default="bench", help="build/<name>-<world>")
    ap.add_argument("--make-args", default="-o .venv/.installed")
    args = ap.parse_args()
    print(
        f"{os.cpu_count()} CPUs; {args.jobs} world(s) at a time; "
        f"load average before {os.getloadavg()[0]:.2f}",
        flush=True,
    )

    def one(world: str) -> tuple[str, tuple[dict, float, float, int]]:
        sets = [f"sim.profile={world}", *args.set]
        return world, run_world(f"{args.name}-{world}", sets, shlex.split(args.make_args))

    start = time.perf_counter()
    failed = 0
    cpu_all = 0.0
    with ThreadPoolExecutor(max(1, args.jobs)) as pool:
        for world, (stages, total, cpu, status) in pool.map(one, args.worlds):
            cpu_all += cpu
            cells = "  ".join(f"{s} {v:.0f}" for s, v in stages.items())
            print(
                f"{world}: {total:.0f} s wall, {cpu:.0f} CPU s (exit {status}); "
                f"per stage (s): {cells}",
                flush=True,
            )
            failed = failed or status
    wall = time.perf_counter() - start
    print(
        f"matrix of {len(args.worlds)} world(s), {args.jobs} at a time: {wall:.0f} s wall "
        f"({wall / 60:.1f} min), {cpu_all:.0f} CPU s; load average after {os.getloadavg()[0]:.2f}"
    )
    if failed:
        sys.exit(failed)


if __name__ == "__main__":
    main()
