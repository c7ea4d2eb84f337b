"""A whole bus's raw CAN log -> the drive's streams: time and peak memory, per log format.

A logger on a car's bus records every message on it, not only the ones the map's signals
are in. This simulates one drive (``ci`` world) of ``--minutes``, its wheel speeds (100 Hz),
fixes and satellite counts (10 Hz) as raw CAN frames (the test suite's DBC,
``tests/support/canlog.py``), among the rest of the bus: ``--other-fps`` frames a second of
60 other standard identifiers with random bytes (a 500 kbit/s bus at about half its load
carries 2,000-4,000 frames a second). It writes them as a ``candump -l`` log, a Vector BLF,
a Vector ASC and a PEAK TRC (python-can's writers; candump at once), and with
``--formats mf4`` an ASAM MDF4 bus log (python-can's MF4 writer: compressed blocks, 64-byte
payload fields; read a part at a time by ``rwhonet.data.mdfframes``), then reads each
through the map and its DBC (``rwhonet.data.mdf4.read_mdf4``, what ingest and predict call,
its kept frames bounded by the default ``data.max_file_mb`` as theirs are) in a fresh
interpreter, so that each peak is its own. Printed per format: the file's size,
its frames, the wall time of the read and decode, the peak resident memory (``VmHWM``:
``ru_maxrss`` would keep this script's own, from before the interpreter started) and that
after the imports alone.

The code measured is the one the interpreter imports: ``PYTHONPATH=<other checkout>/src``
measures another (the logs are written once, by this checkout's test support, with
``--keep DIR``; ``--reuse DIR`` reads them again).

``--j1939``: a truck's bus instead, every identifier extended: the drive's messages sent
with their ECUs' own priorities and source addresses, a J1939 database naming them by
parameter group (``tests/support/canlog.py``'s ``J1939_DBC``), the other traffic 60
other PDU2 groups (candump then through python-can's writer too).

Usage: python benchmarks/bench_bus_log.py [--minutes 20] [--other-fps 3000] [--j1939]
       [--formats log,blf,asc,trc] [--keep DIR | --reuse DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the CAN log writers of the test suite

import numpy as np  # noqa: E402

CHILD = """
import json, re, sys, time
sys.path.insert(0, sys.argv[3])


def peak_gb():  # the address space's own high-water mark (ru_maxrss keeps the parent's)
    status = open("/proc/self/status").read()
    return int(re.search(r"VmHWM:\\s+(\\d+) kB", status)[1]) / 1e6


from pathlib import Path
from rwhonet.config import ColumnSpec
from rwhonet.data.mdf4 import read_mdf4
import asammdf, can
from support.canlog import SIGNALS
imported = peak_gb()
path = Path(sys.argv[1])
# the kept frames bounded as ingest bounds them (data.max_file_mb), where the code can
import inspect
takes = inspect.signature(read_mdf4).parameters
bounded = {"max_mb": float(sys.argv[4])} if "max_mb" in takes else {}
start = time.perf_counter()
streams = read_mdf4(
    path, {k: ColumnSpec(**v) for k, v in SIGNALS.items()}, float(sys.argv[2]),
    dbc=[str(path.parent / "bus.dbc")], **bounded,
)
wall = time.perf_counter() - start
rows = sum(len(w.t_s) for w in streams.wheels) + len(streams.gnss.t_s)
print(json.dumps({
    "s": wall, "peak_gb": peak_gb(),
    "imports_gb": imported, "rows": rows,
    "frames": next((n.split(": ", 1)[1].split(" data frames")[0] for n in streams.notes
                    if " data frames on " in n), "?"),
}))
"""


def write_logs(
    folder: Path, minutes: float, other_fps: float, formats: list[str], j1939: bool = False
) -> float:
    """The drive among the bus's other traffic, in each format; the car's nominal radius."""
    from rwhonet.config import SimDrive, load_params
    from rwhonet.data.keptframes import j1939_pgn
    from rwhonet.sim import generate_route, vehicles_from_params
    from rwhonet.sim.drive import child_rng
    from rwhonet.sim.streams import StreamSpec, fine_truth, stream_tables
    from support.canlog import (
        DBC,
        J1939_DBC,
        J1939_SENT,
        stream_frames,
        write_bus_log,
        write_candump,
    )

    params = load_params(overrides={"sim.profile": "ci"})
    vehicle = vehicles_from_params(params)["target"]
    spec = SimDrive(
        name="B-1",
        role="target_test",
        vehicle="target",
        tyre="B",
        duration_s=minutes * 60.0,
        roads={"urban": 0.4, "country": 0.4, "motorway": 0.2},
    )
    ss = np.random.SeedSequence(1)
    route = generate_route(spec, params.sim, vehicle, child_rng(ss, 0))
    state = fine_truth(vehicle, spec.tyre, route, ss, params.sim, truth_hz=200)
    tables = stream_tables(state, vehicle, params.sim, ss, StreamSpec(100.0, 10.0), 0.0, True)
    t, ids, data = stream_frames(tables, vehicle.nominal_radius_m, 1.7e9)
    rng = np.random.default_rng(2)
    n = int(other_fps * (t[-1] - t[0]))
    if j1939:  # a truck's bus: the drive's messages from its ECUs, 60 other groups' frames
        ids = np.array([J1939_SENT[int(i)] for i in ids], np.int64)
        pf = rng.choice(np.r_[0xF0:0xFF], 60)  # PDU2 groups, none the drive's
        others = 0x18000000 | (pf << 16) | (rng.integers(0, 256, 60) << 8) | 0x21
        groups = j1939_pgn(others)
        others = others[~np.isin(groups, j1939_pgn(np.array(list(J1939_SENT.values()))))]
    else:
        others = rng.choice(np.arange(0x100, 0x7FF), 60)  # not the DBC's 0x1A0, 0x600, 0x601
        others = others[~np.isin(others, (0x1A0, 0x600, 0x601))]
    stamps = np.r_[t, rng.uniform(t[0], t[-1], n)]
    order = np.argsort(stamps, kind="stable")
    stamps = stamps[order]
    ids = np.r_[ids, others[rng.integers(0, others.size, n)]][order]
    data = np.concatenate([data, rng.integers(0, 256, (n, 8), dtype=np.uint8)])[order]
    print(f"{minutes:g} min drive: {t.size:,} frames of its 3 messages among {n:,} others")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "bus.dbc").write_text(J1939_DBC if j1939 else DBC)
    for fmt in formats:
        path = folder / f"bus.{fmt}"
        if fmt == "log" and not j1939:
            write_candump(stamps, ids, data, path)
        else:
            write_bus_log(stamps, ids, data, path, extended=ids > 0x7FF)
    return vehicle.nominal_radius_m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=20.0)
    ap.add_argument("--other-fps", type=float, default=3000.0)
    ap.add_argument("--formats", default="log,blf,asc,trc")
    ap.add_argument(
        "--j1939",
        action="store_true",
        help="a truck's bus: the messages with J1939 identifiers and database, all extended",
    )
    ap.add_argument("--keep", type=Path, help="write the logs here and keep them")
    ap.add_argument("--reuse", type=Path, help="read the logs a --keep run wrote")
    args = ap.parse_args()
    formats = args.formats.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.reuse or args.keep or Path(tmp)
        radius_file = folder / "radius.txt"
        if args.reuse is None:
            radius = write_logs(folder, args.minutes, args.other_fps, formats, args.j1939)
            radius_file.write_text(repr(radius))
        radius = float(radius_file.read_text())
        print(f"code: {os.environ.get('PYTHONPATH') or 'this checkout'}")
        from rwhonet.config import load_params

        max_mb = load_params().data.max_file_mb  # the default, as ingest reads
        print(
            f"{'format':<8} {'MB':>7} {'frames':>10} {'rows':>8} {'s':>7} "
            f"{'peak GB':>8} {'imports GB':>10}"
        )
        for fmt in formats:
            path = folder / f"bus.{fmt}"
            out = subprocess.run(
                [
                    sys.executable,
                    "-c",
                    CHILD,
                    str(path),
                    str(radius),
                    str(ROOT / "tests"),
                    str(max_mb),
                ],
                capture_output=True,
                text=True,
                check=True,
            )
            got = json.loads(out.stdout.strip().splitlines()[-1])
            print(
                f"{fmt:<8} {path.stat().st_size / 1e6:>7.0f} {got['frames']:>10} "
                f"{got['rows']:>8} {got['s']:>7.2f} {got['peak_gb']:>8.2f} "
                f"{got['imports_gb']:>10.2f}"
            )


if __name__ == "__main__":
    main()
