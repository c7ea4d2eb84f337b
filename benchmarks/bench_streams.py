"""Multi-rate path throughput: stream files -> the canonical 10 Hz drive, in input rows per second.

Simulates one long drive (default 2 h, ci world; truth at 200 Hz, which is
enough for timing), samples it as a logger's streams (CAN wheel speeds at
100 Hz with jittered stamps, GNSS at 10 Hz), writes them in each format the
readers take (one CSV per stream, the wheels' CSV with the fixes as the receiver's
NMEA log, a u-blox receiver's UBX log, a NovAtel receiver's ASCII logs (BESTPOSA an
epoch, TIMEA a second), a Septentrio receiver's SBF log (pysbf2's: PVTGeodetic and DOP an
epoch, ReceiverTime a second), a phone's GnssLogger log (its GPS and fused providers'
Fix records an epoch among Raw, Status and gyro records), gpsd's JSON reports (two TPV an
epoch, a SKY a second) or a GPX track (gpxpy's, GPX 1.0), one MDF4 file, a ROS 1 bag
(rosbags' writer: a drive-by-wire kit's wheel-speed report and a NavSatFix, each stamped),
a comma2k19 folder and a comma2k19 route of one-minute segment folders, raw CAN
frames as a candump log, a Vector BLF, a Vector ASC, absolute and relative stamps, and a PEAK
TRC, with their DBC) and times,
in this process (imports excluded, best of ``--repeat``), reading the files and
resampling them onto the 10 Hz grid (``rwhonet.data.streams.resample``, with the
sample-level glitch screen). Rows are every stream's samples, counted once.
Also timed: the same grid through the GNSS policy and the per-second quantities
(``assess`` + ``segment_seconds``), and the whole data path through the stages
themselves: the drive as every role's drive (source_train, target_train,
target_test) in one format, through ``ingest`` (read, resample, Arrow file),
``validate`` and ``label`` (files -> labelled samples, the 10 Hz path's
``bench_data.py`` measure), with wall and CPU time.

Usage: python benchmarks/bench_streams.py [--hours 2] [--repeat 3]
Target (issue 15): >= 1 M input rows/s from files to labelled samples.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # support.multirate

from rwhonet.config import ColumnSpec, SimDrive, load_params  # noqa: E402
from rwhonet.data.comma2k19 import read_comma2k19  # noqa: E402
from rwhonet.data.mdf4 import read_mdf4  # noqa: E402
from rwhonet.data.quality import assess  # noqa: E402
from rwhonet.data.streamcsv import read_stream_csvs  # noqa: E402
from rwhonet.data.streams import resample  # noqa: E402
from rwhonet.features.seconds import segment_seconds  # noqa: E402
from rwhonet.io import system_memory_pool  # noqa: E402
from rwhonet.sim import generate_route, vehicles_from_params  # noqa: E402
from rwhonet.sim.drive import child_rng  # noqa: E402
from rwhonet.sim.streams import (  # noqa: E402
    StreamSpec,
    fine_truth,
    signal_map,
    stream_tables,
    write_comma2k19,
    write_comma2k19_route,
    write_stream_csvs,
    write_stream_mdf4,
)
from support.canlog import (  # noqa: E402
    DBC,
    SIGNALS,
    asc_as_relative,
    stream_frames,
    write_bus_log,
    write_candump,
)
from support.gnsslogger import gnsslogger_lines, write_gnsslogger  # noqa: E402
from support.gpsd import gpsd_lines, write_gpsd  # noqa: E402
from support.gpx import track, write_gpx  # noqa: E402
from support.nmea import nmea_lines, write_nmea  # noqa: E402
from support.novatel import novatel_lines, write_novatel  # noqa: E402
from support.rosbag import bag_map, tables_bag  # noqa: E402
from support.sbf import sbf_blocks, write_sbf  # noqa: E402
from support.ubx import pvt_log  # noqa: E402


def best(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, min(times)


def rotated_csvs(csvs: dict[str, Path], folder: Path, every_s: float) -> list[Path]:
    """Each stream CSV cut into files of ``every_s`` seconds (``wheels_000.csv``, ...), the
    header in each, as a logger rotating its files writes them."""
    folder.mkdir()
    out = []
    for name, path in csvs.items():
        header, *rows = path.read_text().splitlines()
        t = np.array([float(r.split(",", 1)[0]) for r in rows])
        cuts = np.flatnonzero(np.diff(np.floor(t / every_s))) + 1
        for k, part in enumerate(np.split(np.arange(len(rows)), cuts)):
            f = folder / f"{name}_{k:03d}.csv"
            f.write_text("\n".join([header, *(rows[i] for i in part)]) + "\n")
            out.append(f)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=2.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    params = load_params(overrides={"sim.profile": "ci"})
    vehicle = vehicles_from_params(params)["target"]
    radius = vehicle.nominal_radius_m
    spec = SimDrive(
        name="B-1",
        role="target_test",
        vehicle="target",
        tyre="B",
        duration_s=args.hours * 3600.0,
        roads={"urban": 0.4, "country": 0.4, "motorway": 0.2},
    )
    ss = np.random.SeedSequence(1)
    route = generate_route(spec, params.sim, vehicle, child_rng(ss, 0))
    state = fine_truth(vehicle, spec.tyre, route, ss, params.sim, truth_hz=200)
    tables = stream_tables(state, vehicle, params.sim, ss, StreamSpec(100.0, 10.0), 0.0, True)
    n = tables.n_rows
    print(
        f"{args.hours:g} h drive: {len(tables.wheels):,} wheel rows (100 Hz) + "
        f"{len(tables.gnss):,} fixes (10 Hz) = {n:,} input rows"
    )
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        csvs = write_stream_csvs(tables, root / "csv")
        mf4 = write_stream_mdf4(tables, root / "drive.mf4")
        write_comma2k19(tables, root / "seg", radius)
        route = write_comma2k19_route(tables, root / "route", radius)
        # the fixes as the receiver's NMEA log (GGA, GSV, RMC a fix, each after the stamp)
        t_fix = tables.gnss["t_s"].to_numpy()
        nmea = write_nmea(
            root / "csv" / "gps.nmea", nmea_lines(tables.gnss, 1.55e9 + t_fix, stamps=t_fix)
        )
        # ... and as a u-blox receiver's NAV-PVT messages, placed by their UTC times on the
        # wheels' clock read as seconds of the day (the day's midnight at the drive's 0 s)
        ubx = root / "csv" / "gps.ubx"
        ubx.write_bytes(pvt_log(tables.gnss, 1_552_262_400.0 + t_fix))
        # ... and as a NovAtel receiver's ASCII logs (BESTPOSA an epoch, TIMEA a second),
        # placed so too
        novatel = write_novatel(
            root / "csv" / "drive.gps",
            novatel_lines(tables.gnss, 1_552_262_400.0 + t_fix, time_every=10),
        )
        # ... and as a Septentrio receiver's SBF log (pysbf2 writes it: PVTGeodetic and DOP
        # an epoch, ReceiverTime a second), placed so too
        sbf = write_sbf(root / "csv" / "log.sbf", sbf_blocks(tables.gnss, 1_552_262_400.0 + t_fix))
        # ... and as a phone's GnssLogger log (a GPS and a fused Fix record an epoch, two
        # Raw and an UncalGyro record, and a Status epoch of 13 signals, which give the
        # satellite count), placed so too
        phone = write_gnsslogger(
            root / "csv" / "gnss_log.txt", gnsslogger_lines(tables.gnss, 1_552_262_400.0 + t_fix)
        )
        # ... and as gpsd's reports (gpspipe -w: two TPV an epoch, a SKY a second), so too
        gpsd = write_gpsd(
            root / "csv" / "gps.json", gpsd_lines(tables.gnss, 1_552_262_400.0 + t_fix)
        )
        # ... and as a phone logger's GPX track (gpxpy writes it), placed so too
        gpx = write_gpx(root / "csv" / "track.gpx", track(tables.gnss, 1_552_262_400.0 + t_fix))
        # ... and the wheels and the fixes as a ROS 1 bag's topics (a WheelSpeedReport and a
        # NavSatFix a sample, each stamped by its header)
        bag = tables_bag(root / "drive.bag", tables)
        # the streams as raw CAN frames (wheels, fix, satellites) on a Unix clock: a
        # candump log (written at once) and a Vector BLF (python-can's writer), and the DBC
        frames = stream_frames(tables, radius, 1.7e9)
        candump = write_candump(*frames, root / "bus.log")
        blf = write_bus_log(*frames, root / "bus.blf")
        # and Vector ASC (python-can's writer: stamps from the measurement's start), and the
        # same log with relative stamps (each event's time since the one before), as CANoe
        # can log it
        asc = write_bus_log(*frames, root / "bus.asc")
        relative_asc = root / "relative" / "bus.asc"
        relative_asc.parent.mkdir()
        relative_asc.write_text(asc_as_relative(asc.read_text()))
        # and PEAK's TRC (python-can's writer: TRC 2.1, its start and each frame's offset)
        trc = write_bus_log(*frames, root / "bus.trc")
        (root / "bus.dbc").write_text(DBC)
        can_map = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
        # the stream CSVs as a logger rotating its files every 10 minutes writes them
        rotated = rotated_csvs(csvs, root / "rotated", 600.0)
        dbc = [str(root / "bus.dbc")]
        readers = {
            "one CSV per stream": lambda: read_stream_csvs(
                list(csvs.values()), signal_map(), radius
            ),
            "CSVs in 10 min files": lambda: read_stream_csvs(rotated, signal_map(), radius),
            "CSV + NMEA log": lambda: read_stream_csvs(
                [csvs["wheels"], nmea], signal_map(), radius
            ),
            "CSV + UBX log": lambda: read_stream_csvs([csvs["wheels"], ubx], signal_map(), radius),
            "CSV + NovAtel log": lambda: read_stream_csvs(
                [csvs["wheels"], novatel], signal_map(), radius
            ),
            "CSV + SBF log": lambda: read_stream_csvs([csvs["wheels"], sbf], signal_map(), radius),
            "CSV + GnssLogger": lambda: read_stream_csvs(
                [csvs["wheels"], phone], signal_map(), radius
            ),
            "CSV + gpsd log": lambda: read_stream_csvs(
                [csvs["wheels"], gpsd], signal_map(), radius
            ),
            "CSV + GPX track": lambda: read_stream_csvs(
                [csvs["wheels"], gpx], signal_map(), radius
            ),
            "MDF4 (asammdf)": lambda: read_mdf4(mf4, signal_map(with_time=False), radius),
            "ROS 1 bag": lambda: read_mdf4(bag, bag_map(), radius),
            "comma2k19 folder": lambda: read_comma2k19(root / "seg", radius),
            "comma2k19 route": lambda: read_comma2k19(root / "route", radius),
            "candump log + DBC": lambda: read_mdf4(candump, can_map, radius, dbc=dbc),
            "BLF log + DBC": lambda: read_mdf4(blf, can_map, radius, dbc=dbc),
            "ASC log + DBC": lambda: read_mdf4(asc, can_map, radius, dbc=dbc),
            "ASC relative + DBC": lambda: read_mdf4(relative_asc, can_map, radius, dbc=dbc),
            "TRC log + DBC": lambda: read_mdf4(trc, can_map, radius, dbc=dbc),
        }
        print(f"{'format':<20} {'read s':>7} {'resample s':>10} {'total s':>8} {'M rows/s':>9}")
        results = {}
        for name, read in readers.items():
            streams, t_read = best(read, args.repeat)
            res, t_res = best(lambda s=streams: resample(s, nominal_radius_m=radius), args.repeat)
            total = t_read + t_res
            results[name] = res, total
            print(f"{name:<20} {t_read:>7.3f} {t_res:>10.3f} {total:>8.3f} {n / total / 1e6:>9.2f}")
        one, split = (
            results[k][0].drive.columns for k in ("one CSV per stream", "CSVs in 10 min files")
        )
        same = one.keys() == split.keys() and all(
            np.array_equal(one[k], split[k], equal_nan=True) for k in one
        )
        print(f"the {len(rotated)} rotated files give the one-file grid bit for bit: {same}")
        seg, joined = (results[k][0].drive.columns for k in ("comma2k19 folder", "comma2k19 route"))
        same = seg.keys() == joined.keys() and all(
            np.array_equal(seg[k], joined[k], equal_nan=True) for k in seg
        )
        print(f"the route's {len(route)} segments give the one folder's grid bit for bit: {same}")
        plain, summed = (
            results[k][0].drive.columns for k in ("ASC log + DBC", "ASC relative + DBC")
        )
        same = plain.keys() == summed.keys() and all(
            np.array_equal(plain[k], summed[k], equal_nan=True) for k in plain
        )
        print(f"the ASC of relative stamps gives the absolute one's grid bit for bit: {same}")
        res, total = results["comma2k19 folder"]
        grid = res.drive.columns
        vp = params.validate

        def label_seconds():
            result = assess(grid, vp.gnss, vp.sample_period_s, wheel_glitch=res.glitch)
            return [
                segment_seconds({k: v[s.row_start : s.row_stop] for k, v in grid.items()})
                for s in result.segments
            ]

        _, t_label = best(label_seconds, args.repeat)
        print(
            f"then GNSS policy + per-second quantities on the {len(grid['t_s']):,}-row grid: "
            f"{t_label:.3f} s ({n / (total + t_label) / 1e6:.2f} M input rows/s files -> seconds, "
            "comma2k19 folder)"
        )
        print("through the data stages (the drive as each of 3 roles' drive; wall, CPU):")
        for fmt in ("stream_csv", "mdf4", "comma2k19", "comma2k19_route"):
            wall, cpu = best(lambda f=fmt: stages(f, tables, radius, root / f), args.repeat)[0]
            print(
                f"  {fmt:<15} ingest+validate+label {wall:.2f} s wall, {cpu:.2f} s CPU: "
                f"{3 * n / wall / 1e6:.2f} M input rows/s ({3 * n:,} rows)"
            )


def stages(fmt: str, tables, radius: float, work: Path) -> tuple[float, float]:
    """The drive as every role's drive, in ``fmt``, through ingest, validate and label."""
    from rwhonet.stages.ingest import ingest
    from rwhonet.stages.label import label
    from rwhonet.stages.validate import validate
    from support.stream_fleet import ROLE_DRIVES, stream_params, write_drive

    raw = work / "raw"
    if not raw.is_dir():
        for role, (drive, *_) in ROLE_DRIVES.items():
            write_drive(fmt, tables, raw / role, drive, radius)
    params = stream_params(
        raw,
        fmt,
        **{
            "data.vehicles.source.nominal_radius_m": radius,
            "data.vehicles.target.nominal_radius_m": radius,
        },
    )
    t0, c0 = time.perf_counter(), time.process_time()
    # the pool every stage runs in (rwhonet.runner)
    with contextlib.redirect_stdout(io.StringIO()), system_memory_pool():
        ingest(params, work / "drives")
        validate(params, work / "drives", work / "segments", work / "validation.json")
        label(params, work / "segments", work / "samples", work / "cal.json", work / "scaler.json")
    return time.perf_counter() - t0, time.process_time() - c0


if __name__ == "__main__":
    main()
