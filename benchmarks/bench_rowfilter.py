"""What predict's copy filter costs: rows written again, dropped as blocks arrive.

``rwhonet predict`` drops a row that repeats any earlier row of the drive
(:class:`rwhonet.data.droprows.RowFilter`). It keeps every row and compares rows only
where a block's time does not run past every earlier row's. Printed: the seconds one
hour of a 10 Hz drive (the nine channels predict reads) takes through the filter, in
blocks of a pipe that delivers a few rows at a time and of a 64 kB file block, for a
clean drive, every row written twice, and a 100-row block written again every 1,000
rows (a logger's retry). Real time is 3,600 s.

Usage: python benchmarks/bench_rowfilter.py [--hours 1] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.droprows import RowFilter


def drive(n: int) -> dict[str, np.ndarray]:
    t = np.arange(n) * 0.1
    wheels = {w: 10.0 + np.sin(t + j) for j, w in enumerate(c.WHEELS)}
    return {
        c.T_S: t,
        c.LAT_DEG: 52.0 + t * 1e-6,
        c.LON_DEG: -1.5 + t * 1e-6,
        **wheels,
        c.YAW_RATE_RAD_S: np.cos(t),
        c.N_SATS: np.full(n, 9.0),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    n = int(round(args.hours * 36_000 / 1000)) * 1000
    cols = drive(n)
    orders = {
        "clean": np.arange(n),
        "every row twice": np.repeat(np.arange(n), 2),
        "100 rows again every 1,000": np.concatenate(
            [np.r_[np.arange(k, k + 1000), np.arange(k + 500, k + 600)] for k in range(0, n, 1000)]
        ),
    }
    print(f"{n:,} rows ({args.hours:g} h at 10 Hz), best of {args.repeat}")
    for name, order in orders.items():
        file_cols = {k: v[order] for k, v in cols.items()}
        for rows in (5, 600):
            best, kept = np.inf, 0
            for _ in range(args.repeat):
                f = RowFilter()
                blocks = (
                    (i + 1, {k: v[i : i + rows] for k, v in file_cols.items()})
                    for i in range(0, order.size, rows)
                )
                start = time.perf_counter()
                kept = sum(len(b[c.T_S]) for _, b in f.blocks(blocks))
                best = min(best, time.perf_counter() - start)
            assert kept == n, (name, kept)
            print(
                f"{name:>28}, blocks of {rows:>3} rows: {best:6.2f} s ({len(f.dropped):,} dropped)"
            )


if __name__ == "__main__":
    main()
