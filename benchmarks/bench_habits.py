"""What the stop-60 logger habits cost the readers: one hour of a drive read plain, with its
header line again, kept compressed, and logged at 50 Hz.

Writes a one-hour IO-VNBD drive (``tests/support/drives.py: write_long_iovnbd``, 36,000
rows at 10 Hz), then the same drive as a logger that wrote its header again three times
(a restart, files joined: the reader's slow path finds them), gzip- and zstd-compressed
(read through a scratch copy of the text), and a 50 Hz table of it (every channel linear
between the 10 Hz rows: read as streams and resampled onto the grid), and times, in this
process, ingest's reader (``rwhonet.data.drivefile.read_any``) and predict's
(``rwhonet.data.incremental.read_rows`` to its last block) on each, best of ``--repeat``.

Usage: python benchmarks/bench_habits.py [--repeat 3] [--keep DIR]
"""

from __future__ import annotations

import argparse
import gzip
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the drive writers of the test suite

import pandas as pd  # noqa: E402
import pyarrow as pa  # noqa: E402

from rwhonet.data import canonical as c  # noqa: E402
from rwhonet.data.compressed import compression_of, drive_stem, open_decompressed  # noqa: E402
from rwhonet.data.drivefile import DriveFile, read_any  # noqa: E402
from rwhonet.data.incremental import read_rows  # noqa: E402
from rwhonet.data.iovnbd import read_iovnbd  # noqa: E402
from support.corpus import faster  # noqa: E402
from support.drives import make_params, write_iovnbd, write_long_iovnbd  # noqa: E402

ROWS = 36_000  # one hour at 10 Hz


def variants(folder: Path) -> dict[str, Path]:
    """The drive as each habit writes it."""
    plain = write_long_iovnbd(folder / "V-A.csv", ROWS)
    text = plain.read_bytes()
    lines = text.split(b"\n")
    again = lines[:1] + lines[1:9001] + lines[:1] + lines[9001:18001] + lines[:1]
    again += lines[18001:27001] + lines[:1] + lines[27001:]
    out = {"plain": plain, "header again x3": folder / "V-H.csv"}
    out["header again x3"].write_bytes(b"\n".join(again))
    out["gzip"] = folder / "V-G.csv.gz"
    out["gzip"].write_bytes(gzip.compress(text, mtime=0))
    out["zstd"] = folder / "V-Z.csv.zst"
    out["zstd"].write_bytes(pa.compress(text, codec="zstd", asbytes=True))
    drive = read_iovnbd(plain).columns
    frame = pd.DataFrame({k: drive[k] for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)})
    out["50 Hz table"] = write_iovnbd(faster(frame, 50), folder / "V-F.csv")
    return out


def best(run, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--keep", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-habits-") as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        files = variants(folder)
        data = make_params(folder).data

        def ingest(path: Path) -> int:
            f = DriveFile(drive_stem(path), "target_test", "target", "iovnbd", path)
            raw, _ = read_any(f, data, lambda p: p.name, None, 0.1, 0.5)
            return raw.n_rows

        def predict(path: Path) -> int:
            kind = compression_of(path)
            with open(path, "rb") if kind is None else open_decompressed(path, kind, "x") as f:
                _, blocks = read_rows(f, path.name)
                return sum(len(b[c.T_S]) for _, b in blocks)

        print(f"one hour of a drive ({ROWS:,} rows at 10 Hz), best of {args.repeat}:")
        print(f"{'':>16}  {'MB':>6}  {'ingest s':>9}  {'predict s':>9}  rows kept")
        for name, path in files.items():
            rows = ingest(path)
            t_in = best(lambda p=path: ingest(p), args.repeat)
            t_out = best(lambda p=path: predict(p), args.repeat)
            mb = path.stat().st_size / 2**20
            print(f"{name:>16}  {mb:6.1f}  {t_in:9.3f}  {t_out:9.3f}  {rows:,}")


if __name__ == "__main__":
    main()
