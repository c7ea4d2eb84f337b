"""Peak memory and time of ingest on a very large drive (~1 GB of IO-VNBD CSV, ~1 GB of MDF4).

CSV: writes a long drive (``tests/support/drives.py: write_long_iovnbd``, 29
columns, ~124 bytes a row) next to two small good drives in a scratch folder,
then runs the ingest stage in a fresh interpreter per case (so each peak is its
own):

1. with the project's ``data.max_file_mb`` (512 MB): the file is refused before
   it is read;
2. with the limit raised above the file: the reader streams it block by block
   into the drive's float64 columns and ingest writes its Arrow file.

MDF4: the same drive as a logger's streams in one MDF4 file (``asammdf``): the four
wheel speeds at 100 Hz in one channel group, the fixes at 10 Hz in another, read
through a signal map (``data.signal_maps``), resampled onto the 10 Hz grid (case
2 only: an MDF4 file is decoded whole, so the limit is what protects memory).

Parquet (``--format parquet``, since stop 92): the same long CSV drive written as a Parquet
file (row groups of 65,536 rows, as a data lake's writer keeps them), ingested with the limit
raised above its CSV text: the table is read a record batch at a time into a scratch CSV
(:mod:`rwhonet.data.columnar`), which the CSV reader then streams, so its peak should be
the CSV case's.

A fleet file (``--format fleet``, since stop 93): the same long CSV drive with a ``trip_id``
column appended that cuts it into drives of an hour each (one block per drive, as an export
sorted by drive writes them), read through a column map whose ``drive`` key names that
column (:mod:`rwhonet.data.fleetfile`): ingest reads the file once, a line at a time, into a
CSV per drive in scratch, and reads each as a drive of its own, so its peak should be the
CSV case's and its time the CSV's plus one copy of the text.

With ``--validate`` the validate stage then runs on what case 2 wrote. Prints, per
case, the outcome, the wall time and the peak resident memory
(``resource.getrusage(...).ru_maxrss``), and the same after the imports alone.

Usage: python benchmarks/bench_large_file.py [--gb 1.0] [--validate] [--keep DIR]
       [--format csv|mdf4|parquet|fleet|both|all]
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

import numpy as np  # noqa: E402

from support.drives import (  # noqa: E402
    IOVNBD_BY_NAME,
    write_fleet,
    write_long_iovnbd,
    write_params_yaml,
)

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


def run(root: Path, stage: str, max_file_mb: float, **overrides) -> dict:
    """Run one stage in a fresh interpreter on the project at ``root``; its JSON line."""
    write_params_yaml(
        root / "params.yaml",
        **{
            "data.source": "files",
            "data.root": "data/raw",
            "data.max_file_mb": max_file_mb,
            **overrides,
        },
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


MDF_MAP = {
    "reader": "mdf4",
    "signals": {
        "omega_fl": {"column": "WheelSpeed_FL", "unit": "rad/s"},
        "omega_fr": {"column": "WheelSpeed_FR", "unit": "rad/s"},
        "omega_rl": {"column": "WheelSpeed_RL", "unit": "rad/s"},
        "omega_rr": {"column": "WheelSpeed_RR", "unit": "rad/s"},
        "lat": {"column": "Latitude", "unit": "deg"},
        "lon": {"column": "Longitude", "unit": "deg"},
        "n_sats": {"column": "NumSV", "unit": "count"},
    },
}
MDF_BYTES_PER_WHEEL_SAMPLE = 44  # 5 float64 at 100 Hz + a tenth of 4 float64 at 10 Hz


def write_long_mdf4(path: Path, n_wheel: int) -> Path:
    """The long drive as an MDF4 file: wheel speeds at 100 Hz, fixes at 10 Hz (asammdf)."""
    from asammdf import MDF, Signal

    from support.drives import TARGET_RADIUS_M

    t_w = np.arange(n_wheel) * 0.01
    v = 15.0 + 0.5 * np.sin(t_w / 30.0)
    omega = v / TARGET_RADIUS_M
    mdf = MDF(version="4.10")
    mdf.append(
        [
            Signal(omega, t_w, name=f"WheelSpeed_{w}", unit="rad/s")
            for w in ("FL", "FR", "RL", "RR")
        ],
        comment="CAN wheel speeds",
    )
    del v, omega
    t_g = np.arange(0.05, t_w[-1], 0.1)
    s = 15.0 * t_g + 15.0 * (1.0 - np.cos(t_g / 30.0))  # the integral of v, m
    s = 20_000.0 - np.abs(s % 40_000.0 - 20_000.0)  # back and forth along a 20 km line
    lat = 52.4 + s * np.cos(np.radians(30.0)) / 111_250.0
    lon = -1.5 + s * np.sin(np.radians(30.0)) / (111_250.0 * np.cos(np.radians(52.4)))
    mdf.append(
        [
            Signal(lat, t_g, name="Latitude", unit="deg"),
            Signal(lon, t_g, name="Longitude", unit="deg"),
            Signal(np.full(t_g.size, 9.0), t_g, name="NumSV", unit=""),
        ],
        comment="GNSS fixes",
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    mdf.save(path, overwrite=True)
    mdf.close()
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gb", type=float, default=1.0, help="size of the drive file (GB)")
    parser.add_argument("--validate", action="store_true", help="also run validate on it")
    parser.add_argument("--keep", type=Path, help="project folder to keep (default: temporary)")
    parser.add_argument(
        "--format", choices=["csv", "mdf4", "parquet", "fleet", "both", "all"], default="both"
    )
    parser.add_argument("--write-mdf4", nargs=2, metavar=("PATH", "N"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.write_mdf4:  # the MDF4 writer's own interpreter (see mdf4_cases)
        write_long_mdf4(Path(args.write_mdf4[0]), int(args.write_mdf4[1]))
        return
    print(f"{'case':<44} {'time s':>7} {'peak MB':>8} {'imports MB':>10}  outcome")
    if args.format in ("csv", "both", "all"):
        csv_cases(args)
    if args.format in ("mdf4", "both", "all"):
        mdf4_cases(args)
    if args.format in ("parquet", "all"):
        parquet_cases(args)
    if args.format in ("fleet", "all"):
        fleet_cases(args)


def _fleet(root: Path) -> Path:
    raw = root / "data" / "raw"
    write_fleet(raw, duration_s=60.0)["target_test"].unlink()  # the large drive is the test drive
    (root / "dvc.yaml").write_text((ROOT / "dvc.yaml").read_text())
    return raw


def _show(name: str, r: dict) -> None:
    print(
        f"{name:<44} {r['seconds']:>7.1f} {r['peak_mb']:>8.0f} {r['imports_mb']:>10.0f}  "
        f"{r['outcome']}"
    )


def _long_csv(raw: Path, name: str, gb: float) -> tuple[Path, int, float]:
    """The long IO-VNBD drive as the test drive ``name``: its path, rows and writing time."""
    rows = round(gb * 2**30 / BYTES_PER_ROW)
    start = time.perf_counter()
    big = write_long_iovnbd(raw / "target_test" / name, rows)
    return big, rows, time.perf_counter() - start


def _run_cases(
    root: Path, label: str, cases: list, limit_mb: float, validate: bool, **overrides
) -> None:
    """Each case (name, stage, data.max_file_mb) in a fresh interpreter, then validate's."""
    if validate:
        cases.append((f"{label}: validate (after the ingest above)", "validate", limit_mb))
    for name, stage, limit in cases:
        _show(name, run(root, stage, limit, **overrides))


def csv_cases(args) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = (args.keep / "csv") if args.keep else Path(tmp)
        big, rows, took = _long_csv(_fleet(root), "C-L1.csv", args.gb)
        size_mb = big.stat().st_size / 2**20
        hours = rows / 36_000
        print(
            f"wrote {big.name}: {size_mb:,.0f} MB, {rows:,} rows ({hours:,.0f} h) in {took:.1f} s; "
            f"float64 columns read (15 channels): {15 * 8 * rows / 2**20:,.0f} MB"
        )
        cases = [
            ("CSV: ingest, data.max_file_mb 512", "ingest", 512.0),
            (f"CSV: ingest, data.max_file_mb {2 * size_mb:.0f}", "ingest", 2 * size_mb),
        ]
        _run_cases(root, "CSV", cases, 2 * size_mb, args.validate)


def parquet_cases(args) -> None:
    import pyarrow.csv as pa_csv
    import pyarrow.parquet as pq

    with tempfile.TemporaryDirectory() as tmp:
        root = (args.keep / "parquet") if args.keep else Path(tmp)
        start = time.perf_counter()
        csv, rows, _ = _long_csv(_fleet(root), "C-P1.csv", args.gb)
        csv_mb = csv.stat().st_size / 2**20
        big = csv.with_suffix(".parquet")
        reader = pa_csv.open_csv(csv)  # streamed: the table never whole in this process
        with pq.ParquetWriter(big, reader.schema) as writer:
            for batch in reader:
                writer.write_batch(batch, row_group_size=65_536)
        csv.unlink()
        size_mb = big.stat().st_size / 2**20
        print(
            f"wrote {big.name}: {size_mb:,.0f} MB ({csv_mb:,.0f} MB as CSV), {rows:,} rows "
            f"({rows / 36_000:,.0f} h) in {time.perf_counter() - start:.1f} s"
        )
        role = {"glob": "target_test/*.parquet", "format": "iovnbd", "vehicle": "target"}
        cases = [(f"Parquet: ingest, data.max_file_mb {2 * csv_mb:.0f}", "ingest", 2 * csv_mb)]
        _run_cases(
            root, "Parquet", cases, 2 * csv_mb, args.validate, **{"data.roles.target_test": role}
        )


FLEET_MAP = IOVNBD_BY_NAME | {"drive": {"column": "trip_id", "unit": "text"}}
FLEET_DRIVE_ROWS = 36_000  # an hour at 10 Hz


def fleet_cases(args) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = (args.keep / "fleet") if args.keep else Path(tmp)
        start = time.perf_counter()
        csv, rows, _ = _long_csv(_fleet(root), "C-F1.csv", args.gb)
        big = csv.with_name("fleet.csv")
        with open(csv, "rb") as src, open(big, "wb") as out:
            out.write(src.readline().rstrip(b"\r\n") + b",trip_id\n")
            for k, line in enumerate(src):
                out.write(line.rstrip(b"\r\n") + b",T-%04d\n" % (k // FLEET_DRIVE_ROWS))
        csv.unlink()
        size_mb = big.stat().st_size / 2**20
        drives = -(-rows // FLEET_DRIVE_ROWS)
        print(
            f"wrote {big.name}: {size_mb:,.0f} MB, {rows:,} rows, {drives:,} drives of an hour "
            f"in {time.perf_counter() - start:.1f} s"
        )
        overrides = {
            "data.column_maps": {"fleet": FLEET_MAP},
            "data.roles.target_test": {
                "glob": "target_test/fleet.csv",
                "format": "fleet",
                "vehicle": "target",
                "required": True,
            },
        }
        # the limit is each drive's: the file is split before a drive is read
        cases = [(f"fleet: ingest, {drives} drives, data.max_file_mb 512", "ingest", 512.0)]
        _run_cases(root, "fleet", cases, 512.0, args.validate, **overrides)


def mdf4_cases(args) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = (args.keep / "mdf4") if args.keep else Path(tmp)
        raw = _fleet(root)
        n_wheel = round(args.gb * 2**30 / MDF_BYTES_PER_WHEEL_SAMPLE)
        start = time.perf_counter()
        # Written by another interpreter: a child's peak RSS starts from its parent's RSS
        # at the fork, and writing the file holds its arrays.
        big = raw / "target_test" / "C-M1.mf4"
        subprocess.run(
            [sys.executable, __file__, "--write-mdf4", str(big), str(n_wheel)],
            check=True,
            env={
                **os.environ,
                "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT / "tests")]),
            },
        )
        size_mb = big.stat().st_size / 2**20
        print(
            f"wrote {big.name}: {size_mb:,.0f} MB, {n_wheel:,} wheel samples at 100 Hz + "
            f"{n_wheel // 10:,} fixes ({n_wheel / 360_000:,.0f} h) in "
            f"{time.perf_counter() - start:.1f} s"
        )
        overrides = {
            "data.signal_maps": {"big_mf4": MDF_MAP},
            "data.roles.target_test": {
                "glob": "target_test/*.mf4",
                "format": "big_mf4",
                "vehicle": "target",
                "required": True,
            },
        }
        cases = [(f"MDF4: ingest, data.max_file_mb {2 * size_mb:.0f}", "ingest", 2 * size_mb)]
        _run_cases(root, "MDF4", cases, 2 * size_mb, args.validate, **overrides)


if __name__ == "__main__":
    main()
