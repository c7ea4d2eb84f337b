"""Peak memory and time of ingest on a very large drive file (~1 GB of IO-VNBD CSV).

Writes a long drive (``tests/support/drives.py: write_long_iovnbd``, 29 columns,
~124 bytes a row) next to two small good drives in a scratch folder, then runs
the ingest stage in a fresh interpreter per case (so each peak is its own):

1. with the project's ``data.max_file_mb`` (512 MB): the file is refused before
   it is read;
2. with the limit raised above the file: the reader streams it block by block
   into the drive's float64 columns and ingest writes its Parquet.

With ``--validate`` the validate stage then runs on what case 2 wrote. Prints, per
case, the outcome, the wall time and the peak resident memory
(``resource.getrusage(...).ru_maxrss``), and the same after the imports alone.

Usage: python benchmarks/bench_large_file.py [--gb 1.0] [--validate] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the drive writers of the test suite

from support.drives import write_fleet, write_long_iovnbd, write_params_yaml  # noqa: E402

BYTES_PER_ROW = 124  # what write_long_iovnbd writes, on average

CHILD = """
import json, resource, sys, time
from rwhonet.config import load_params
from rwhonet import paths
from rwhonet.errors import InputError
from rwhonet.stages import ingest, validate
import pyarrow.parquet, pandas, pandera
imported_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
params = load_params(paths.PARAMS)
start = time.perf_counter()
try:
    if sys.argv[1] == "ingest":
        m = ingest.ingest(params, paths.DRIVES)
        outcome = f"ingested {sum(d['n_rows'] for d in m['drives']):,} rows"
    else:
        r = validate.validate(params, paths.DRIVES, paths.SEGMENTS, paths.VALIDATION_REPORT)
        outcome = f"validated: {r['totals']['seconds_kept']:,} s kept"
except InputError as err:
    outcome = "refused: " + err.problems[0].expected + "; found " + err.problems[0].found
print(json.dumps({
    "outcome": outcome,
    "seconds": time.perf_counter() - start,
    "imports_mb": imported_mb,
    "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
}))
"""


def run(root: Path, stage: str, max_file_mb: float) -> dict:
    """Run one stage in a fresh interpreter on the project at ``root``; its JSON line."""
    write_params_yaml(
        root / "params.yaml",
        **{"data.source": "files", "data.root": "data/raw", "data.max_file_mb": max_file_mb},
    )
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, stage],
        cwd=ROOT,
        env={**os.environ, "RWHONET_ROOT": str(root)},
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gb", type=float, default=1.0, help="size of the drive file (GB)")
    parser.add_argument("--validate", action="store_true", help="also run validate on it")
    parser.add_argument("--keep", type=Path, help="project folder to keep (default: temporary)")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        raw = root / "data" / "raw"
        write_fleet(raw, duration_s=60.0)["target_test"].unlink()  # C-L1 is the test drive
        (root / "dvc.yaml").write_text((ROOT / "dvc.yaml").read_text())
        rows = round(args.gb * 2**30 / BYTES_PER_ROW)
        start = time.perf_counter()
        big = write_long_iovnbd(raw / "target_test" / "C-L1.csv", rows)
        size_mb = big.stat().st_size / 2**20
        took = time.perf_counter() - start
        hours = rows / 36_000
        print(
            f"wrote {big.name}: {size_mb:,.0f} MB, {rows:,} rows ({hours:,.0f} h) in {took:.1f} s"
        )
        print(f"float64 columns read (15 channels): {15 * 8 * rows / 2**20:,.0f} MB")
        cases = [
            ("ingest, data.max_file_mb 512", "ingest", 512.0),
            (f"ingest, data.max_file_mb {2 * size_mb:.0f}", "ingest", 2 * size_mb),
        ]
        if args.validate:
            cases.append(("validate (after the ingest above)", "validate", 2 * size_mb))
        print(f"{'case':<36} {'time s':>7} {'peak MB':>8} {'imports MB':>10}  outcome")
        for name, stage, limit in cases:
            r = run(root, stage, limit)
            print(
                f"{name:<36} {r['seconds']:>7.1f} {r['peak_mb']:>8.0f} "
                f"{r['imports_mb']:>10.0f}  {r['outcome']}"
            )


if __name__ == "__main__":
    main()
