"""The simulated drives as one file of many drives: each drive as its own file gives it.

Writes every IO-VNBD drive under ``data/sim`` (``make run``'s fleet, every role) as one
CSV with a ``trip_id`` column, each drive's rows interleaved row by row with the others'
(a log of several cars sorted by time: the hardest order for the split), then reads it
through a column map of the IO-VNBD names whose ``drive`` key names ``trip_id``
(:mod:`rwhonet.data.fleetfile`), and each drive's own file through the same map without
the key. Prints the file's size, the split's time and how many canonical columns differ
(expected: none). Run from a checkout where ``make run`` has written ``data/sim``.

Usage: python benchmarks/fleet_file_check.py [--sim data/sim] [--keep DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the drive maps of the test suite

from rwhonet.config import load_params  # noqa: E402
from rwhonet.data.drivefile import DriveFile, fleet_drives, read_any  # noqa: E402
from support.drives import IOVNBD_BY_NAME  # noqa: E402

IOVNBD_MAP = IOVNBD_BY_NAME | {"yaw_rate": {"column": "Yaw Rate", "unit": "deg/s"}}
DRIVE = {"drive": {"column": "trip_id", "unit": "text"}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", type=Path, default=Path("data/sim"))
    parser.add_argument("--keep", type=Path, help="folder for the fleet file and its split")
    args = parser.parse_args()
    files = sorted(args.sim.glob("*/*.csv"))
    if not files:
        raise SystemExit(f"no drive under {args.sim}: run make run first")
    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        frames = [pd.read_csv(f, dtype=str).assign(trip_id=f.stem) for f in files]
        rank = np.concatenate(
            [np.arange(len(fr)) + k / (len(files) + 1) for k, fr in enumerate(frames)]
        )
        fleet = root / "fleet.csv"
        pd.concat(frames).iloc[np.argsort(rank, kind="stable")].to_csv(fleet, index=False)
        rows = sum(len(fr) for fr in frames)
        print(
            f"{len(files)} drives, {rows:,} rows interleaved, {fleet.stat().st_size / 2**20:.0f} MB"
        )
        overrides = {
            "data.column_maps.sim": IOVNBD_MAP,
            "data.column_maps.trips": IOVNBD_MAP | DRIVE,
        }
        data = load_params(overrides=overrides).data
        split = root / "split"
        split.mkdir(exist_ok=True)
        start = time.perf_counter()
        parts = fleet_drives(DriveFile("fleet", "t", "car", "trips", fleet), data, str, split)
        print(f"split into {len(parts)} drives in {time.perf_counter() - start:.1f} s")
        differ = 0
        for f, part in zip(files, parts, strict=True):
            assert part.drive == f.stem, (part.drive, f.stem)
            own = read_any(DriveFile(f.stem, "t", "car", "sim", f), data, str, None, 0.1, 10.0)[0]
            got = read_any(part, data, str, None, 0.1, 10.0)[0]
            for name, want in own.columns.items():
                if not np.array_equal(got.columns[name], want, equal_nan=True):
                    differ += 1
                    print(f"differs: {f.stem} {name}")
        print(f"{len(files)} drives compared with their own files: {differ} column(s) differ")


if __name__ == "__main__":
    main()
