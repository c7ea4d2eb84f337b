"""What the stop-60, stop-61, stop-67, stop-68 and stop-69 logger habits cost the readers: one
hour of a drive read plain, with its header line again, kept compressed, logged at 50 Hz,
stamped with a bell curve's jitter, its rows out of order, its last row cut, its clock set
back and its times cut to the second; and one hour of a
drive as stream CSVs, plain, with samples written late, written twice or shuffled, and the
header again.

Writes a one-hour IO-VNBD drive (``tests/support/drives.py: write_long_iovnbd``, 36,000
rows at 10 Hz), then the same drive as a logger that wrote its header again three times
(a restart, files joined: the reader's slow path finds them), gzip- and zstd-compressed
(read through a scratch copy of the text), and a 50 Hz table of it (every channel linear
between the 10 Hz rows: read as streams and resampled onto the grid), stamped with a bell
curve's jitter of 20 ms (rows placed in their slots by the rows' order), with 20 pairs of
rows swapped and with its halves joined the wrong way (put in time order), with its
last row cut short 40 bytes before its end (not read), jittered by the bell curve from half
way on only (a logger that gets busy: the reach told by the rows around each place), and
restarted half way after 1.3 s on a phase 48 ms off (each run on its own), its clock set
back 0.23 s half way (an NTP step: the rows after it put on by whole seconds), and its times
cut to the second (each stamp's rows placed 0.1 s apart), and times, in this
process, ingest's reader (``rwhonet.data.drivefile.read_any``) and predict's
(``rwhonet.data.incremental.read_rows`` to its last block) on each, best of ``--repeat``.

Then the hour as stream CSVs (``wheels.csv``: 360,000 wheel samples at 100 Hz, stamps
jittered ±0.3 ms; ``gnss.csv``: 36,000 fixes at 10 Hz): as logged; with 1 % of the wheel
samples written up to 50 ms late (receive buffers merged in arrival order); with a 10 s
block of them written twice after a retry, every minute; with its rows shuffled; and with
the header line again three times. Timed: the stream reader and the resampler
(``rwhonet.data.streamcsv.read_stream_csvs`` + ``rwhonet.data.streams.resample``), which
ingest and predict both run, best of ``--repeat``.

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

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pyarrow as pa  # noqa: E402

from rwhonet.data import canonical as c  # noqa: E402
from rwhonet.data.compressed import compression_of, drive_stem, open_decompressed  # noqa: E402
from rwhonet.data.drivefile import DriveFile, read_any  # noqa: E402
from rwhonet.data.incremental import read_rows  # noqa: E402
from rwhonet.data.iovnbd import read_iovnbd  # noqa: E402
from rwhonet.data.streamcsv import read_stream_csvs  # noqa: E402
from rwhonet.data.streams import resample  # noqa: E402
from rwhonet.sim.streams import StreamTables, signal_map, write_stream_csvs  # noqa: E402
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
    # stop 67: stamps of a bell curve's 20 ms; 20 pairs of rows swapped; the halves joined
    # the wrong way (the header again between); the last row cut short by a power cut
    rng = np.random.default_rng(1)
    bell = frame.assign(**{c.T_S: np.round(frame[c.T_S] + rng.normal(0, 0.02, len(frame)), 3)})
    out["bell 20 ms"] = write_iovnbd(bell, folder / "V-B.csv")
    order = np.arange(len(frame))
    for k in rng.choice(len(frame) - 1, 20, replace=False):
        order[[k, k + 1]] = order[[k + 1, k]]
    out["rows swapped x20"] = write_iovnbd(frame.iloc[order], folder / "V-S.csv")
    half = 1 + ROWS // 2
    out["halves swapped"] = folder / "V-W.csv"
    out["halves swapped"].write_bytes(b"\n".join(lines[:1] + lines[half:-1] + lines[:half]))
    out["last row cut"] = folder / "V-C.csv"
    out["last row cut"].write_bytes(text.rstrip(b"\n")[:-40])
    # stop 68: the bell curve's 20 ms from half way on (a logger that gets busy); a logger
    # restarted half way, after 1.3 s, its stamps 48 ms into each tenth
    busy = bell.copy()
    busy.loc[: ROWS // 2, c.T_S] = frame.loc[: ROWS // 2, c.T_S]
    out["busy half way"] = write_iovnbd(busy, folder / "V-U.csv")
    restarted = frame.copy()
    restarted.loc[ROWS // 2 :, c.T_S] = np.round(restarted.loc[ROWS // 2 :, c.T_S] + 1.348, 3)
    out["restart 48 ms"] = write_iovnbd(restarted, folder / "V-R.csv")
    # stop 69: the clock set back 0.23 s half way (an NTP step: put on by whole seconds);
    # the times cut to the second (hh:mm:ss without its fraction: each stamp's rows placed)
    set_back = frame.copy()
    set_back.loc[ROWS // 2 :, c.T_S] = np.round(set_back.loc[ROWS // 2 :, c.T_S] - 0.23, 3)
    out["clock set back"] = write_iovnbd(set_back, folder / "V-K.csv")
    whole = frame.copy()
    whole[c.T_S] = np.floor(whole[c.T_S].to_numpy() - 0.1 + 1e-6)
    out["to the second"] = write_iovnbd(whole, folder / "V-T.csv")
    return out


RADIUS_M = 0.3


def stream_variants(folder: Path) -> dict[str, list[Path]]:
    """One hour as stream CSVs, as each stream habit writes it (a folder each)."""
    rng = np.random.default_rng(0)
    t_w = np.arange(0.0, 3600.0, 0.01)
    t_w = 1000.0 + t_w + rng.uniform(-3e-4, 3e-4, t_w.size)
    speed = 15.0 + 5.0 * np.sin(t_w / 40.0)  # no two samples alike
    wheels = pd.DataFrame({c.T_S: t_w} | {w: speed / RADIUS_M for w in c.WHEELS})
    t_g = 1000.05 + np.arange(0.0, 3600.0, 0.1)
    north = np.interp(t_g, t_w, np.cumsum(speed) * 0.01)
    gnss = pd.DataFrame(
        {c.T_S: t_g, c.LAT_DEG: 52.0 + north / 111_195.0, c.LON_DEG: -1.5, c.N_SATS: 9.0}
    )
    n = len(wheels)
    late = np.arange(n) + np.where(rng.random(n) < 0.01, rng.uniform(0, 5, n), 0.0)
    twice = np.concatenate(
        [np.r_[a : a + 6000, a : a + 1000] for a in range(0, n, 6000)]  # 10 s again a minute
    )
    out = {}
    for name, rows in (
        ("streams plain", np.arange(n)),
        ("1 % late", np.argsort(late, kind="stable")),
        ("10 s twice a min", twice[twice < n]),
        ("rows shuffled", rng.permutation(n)),
        ("header again x3", np.arange(n)),
    ):
        files = write_stream_csvs(StreamTables(wheels.iloc[rows], gnss), folder / name)
        if name == "header again x3":
            lines = files["wheels"].read_bytes().split(b"\n")
            cut = [1, 90_001, 180_001, 270_001, len(lines)]
            joined = [lines[:1]]
            for a, b in zip(cut[:-1], cut[1:], strict=False):
                joined += [lines[a:b], lines[:1]]
            files["wheels"].write_bytes(b"\n".join(sum(joined[:-1], [])))
        out[name] = sorted(files.values())
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

        def streams(paths: list[Path]):
            signals = read_stream_csvs(paths, signal_map(), RADIUS_M)
            return resample(signals, nominal_radius_m=RADIUS_M)

        print("one hour as stream CSVs (360,000 wheel samples at 100 Hz + 36,000 fixes):")
        print(f"{'':>16}  {'MB':>6}  {'read+resample s':>15}  samples kept  grid rows  as logged")
        logged = None
        for name, paths in stream_variants(folder).items():
            cols = streams(paths).drive.columns
            logged = logged or cols
            same = cols.keys() == logged.keys() and all(
                np.array_equal(cols[k], logged[k], equal_nan=True) for k in cols
            )
            took = best(lambda p=paths: streams(p), args.repeat)
            res = streams(paths)
            mb = sum(p.stat().st_size for p in paths) / 2**20
            print(
                f"{name:>16}  {mb:6.1f}  {took:15.3f}  {res.n_input_rows:12,}  "
                f"{res.drive.n_rows:9,}  {'same grid' if same else 'DIFFERS'}"
            )


if __name__ == "__main__":
    main()
