"""Wall time of the whole pipeline, per stage, for one world or a matrix of worlds.

    .venv/bin/python benchmarks/bench_pipeline.py [--worlds paper large_target ...]
        [--set model.arch=tcn --set model.seq_len=32] [--name bench]

Runs ``make variant`` (a scratch copy of the working tree under ``build/``,
``dvc exp run`` there: every stage from scratch, as on a fresh clone after
installation) once per world (``sim.profile``), one after the other, and
prints per stage the wall seconds from DVC's "Running stage" line to the next
one (a matrix stage's items, ``train_g@42`` ..., summed), the world's total,
the CPU seconds its processes used, and the matrix's total. The machine's
load average before and after is printed too: on a shared machine the wall
time grows with the others' load, the CPU seconds much less.

``make`` is called with ``-o .venv/.installed`` by default (the environment
is taken as installed; ``--make-args ''`` to let make check it).
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNNING = re.compile(r"Running stage '([^']+)'")


def run_world(name: str, sets: list[str], make_args: list[str]) -> tuple[dict, float, float, int]:
    """``make variant`` of one world; ``(stage -> wall s, total wall s, CPU s, exit status)``."""
    cmd = ["make", *make_args, "variant", f"NAME={name}", f"SET={' '.join(sets)}"]
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    marks: list[tuple[float, str]] = []
    with subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    ) as proc:
        for line in proc.stdout:
            hit = RUNNING.search(line)
            if hit:
                marks.append((time.perf_counter(), hit.group(1)))
            elif line.startswith(("Ran experiment", "build/")) and marks and marks[-1][1]:
                marks.append((time.perf_counter(), ""))  # the last stage has ended
    total = time.perf_counter() - start
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    marks.append((start + total, ""))
    stages: dict[str, float] = defaultdict(float)
    for (t, stage), (t_next, _) in zip(marks, marks[1:], strict=False):
        if stage:
            stages[stage.split("@")[0]] += t_next - t
    return dict(stages), total, cpu, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=["paper"], help="sim.profile values")
    ap.add_argument("--set", action="append", default=[], help="another key=value (repeatable)")
    ap.add_argument("--name", default="bench", help="build/<name>-<world>")
    ap.add_argument("--make-args", default="-o .venv/.installed")
    args = ap.parse_args()
    print(f"{os.cpu_count()} CPUs; load average before {os.getloadavg()[0]:.2f}", flush=True)
    results = {}
    for world in args.worlds:
        sets = [f"sim.profile={world}", *args.set]
        stages, total, cpu, status = run_world(
            f"{args.name}-{world}", sets, shlex.split(args.make_args)
        )
        results[world] = total
        cells = "  ".join(f"{s} {v:.0f}" for s, v in stages.items())
        print(
            f"{world}: {total:.0f} s wall, {cpu:.0f} CPU s (exit {status}); per stage (s): {cells}",
            flush=True,
        )
        if status:
            sys.exit(status)
    print(
        f"matrix of {len(results)} world(s): {sum(results.values()):.0f} s wall "
        f"({sum(results.values()) / 60:.1f} min); load average after {os.getloadavg()[0]:.2f}"
    )


if __name__ == "__main__":
    main()
