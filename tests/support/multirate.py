"""What resampling costs: one simulated truth as a native 10 Hz drive and as logger streams.

Shared by ``tests/data/test_resample_cost.py`` (a stated tolerance) and
``benchmarks/bench_resample.py`` (the table over every rate). The drive's
seconds go through the pipeline's own functions: the GNSS policy
(:func:`rwhonet.data.quality.assess`), the per-second quantities
(:func:`rwhonet.features.seconds.segment_seconds`) and the WPM and label
(:mod:`rwhonet.features.wpm`), with one radius for both versions (the car's
nominal), so the only difference between the two is how the rows were made.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.config import GnssPolicy, SimDrive, load_params
from rwhonet.data import canonical as c
from rwhonet.data.quality import assess
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.features.seconds import segment_seconds
from rwhonet.features.wpm import label_m, wpm_displacement_m
from rwhonet.sim import generate_route, vehicles_from_params
from rwhonet.sim.drive import child_rng
from rwhonet.sim.streams import (
    StreamSpec,
    fine_truth,
    native_drive,
    signal_map,
    stream_tables,
    write_stream_csvs,
)

POLICY = GnssPolicy(
    min_sats=4,
    max_speed_m_s=70.0,
    frozen_min_s=2.0,
    moving_wheel_speed_rad_s=1.0,
    max_gap_s=0.5,
    min_segment_s=30.0,
)
# Every rate pair of the issue: CAN at 50 and 100 Hz, GNSS at 1, 5 and 10 Hz; and at 50 Hz
# with an ESC gyro at 50 Hz too (positions between fixes along the wheels' path, turned by it).
SPECS = (
    *(StreamSpec(w, g) for w in (50.0, 100.0) for g in (1.0, 5.0, 10.0)),
    *(StreamSpec(50.0, g, gyro_hz=50.0) for g in (1.0, 5.0, 10.0)),
)
START_S = 45000.0  # the clock of both versions: seconds of the day


def per_second(drive: Mapping[str, np.ndarray], radius_m: float) -> pd.DataFrame:
    """The labelled seconds of a canonical drive: ``t_s, disp_gnss_m, disp_wpm_m, label_m``."""
    frame = {k: np.asarray(v) for k, v in drive.items()}
    result = assess(frame, POLICY, 0.1)
    parts = []
    for seg in result.segments:
        sub = {k: v[seg.row_start : seg.row_stop] for k, v in frame.items()}
        sec = segment_seconds(sub)
        wpm = wpm_displacement_m(sec.angle_rl_rad, sec.angle_rr_rad, radius_m, radius_m)
        parts.append(
            pd.DataFrame(
                {
                    "t_s": np.round(sec.t_s, 3),
                    "disp_gnss_m": sec.disp_gnss_m,
                    "disp_wpm_m": wpm,
                    "label_m": label_m(sec.disp_gnss_m, wpm),
                }
            )
        )
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


@dataclass(frozen=True)
class Comparison:
    """Per second, the native drive's quantities and the resampled ones' change."""

    spec: StreamSpec
    seconds: pd.DataFrame  # t_s, and per quantity: native, resampled, change
    native_seconds: int  # labelled seconds of the native drive
    input_rows: int  # samples of the streams


def simulated_drive(duration_s: float = 300.0, seed: int = 5, can_noise: bool = False):
    """A ci-world urban/country drive with roundabouts, a hard brake and a sharp turn.

    Returns:
        ``(state, vehicle, sim, seed, native frame)``.
    """
    params = load_params(overrides={"sim.profile": "ci"})
    vehicle = vehicles_from_params(params)["target"]
    spec = SimDrive(
        name="M-1",
        role="target_test",
        vehicle="target",
        tyre="B",
        duration_s=duration_s,
        roads={"urban": 0.5, "country": 0.5},
        events={"roundabout": 2, "hard_brake": 1, "sharp_turn": 1},
    )
    ss = np.random.SeedSequence(seed)
    route = generate_route(spec, params.sim, vehicle, child_rng(ss, 0))
    state = fine_truth(vehicle, spec.tyre, route, ss, params.sim)
    native = native_drive(state, vehicle, params.sim, ss, START_S, can_noise)
    return state, vehicle, params.sim, ss, native


def simulated_streams(
    duration_s: float, wheel_hz: float, gnss_hz: float, seed: int = 5, gyro_hz: float = 0.0
):
    """:func:`simulated_drive`'s streams as a logger writes them (``StreamTables``: wheels at
    ``wheel_hz``, fixes at ``gnss_hz``, the ESC's yaw rate at ``gyro_hz`` where given, from
    :data:`START_S`), and the car's nominal radius."""
    from rwhonet.sim.streams import StreamSpec, stream_tables

    state, vehicle, sim, ss, _ = simulated_drive(duration_s, seed)
    spec = (
        StreamSpec(wheel_hz, gnss_hz, gyro_hz=gyro_hz) if gyro_hz else StreamSpec(wheel_hz, gnss_hz)
    )
    return stream_tables(state, vehicle, sim, ss, spec, START_S), vehicle.nominal_radius_m


@cache
def receiver_drive():
    """A simulated 120 s drive's streams (100 Hz wheels, a 10 Hz receiver, on the time of
    day) and the car's nominal radius: the drive the receiver logs' tests write (NMEA,
    UBX, NovAtel, GPX)."""
    return simulated_streams(120.0, 100.0, 10.0)


def receiver_folder(folder: Path, gnss):  # type: ignore[no-untyped-def]
    """:func:`receiver_drive`'s wheels with the fixes ``gnss`` as stream CSVs in
    ``folder`` (``gnss.iloc[:0]``: none, for a receiver's log to give them)."""
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    return write_stream_csvs(StreamTables(tables.wheels, gnss), folder)


def fixes_to_the_ms():  # type: ignore[no-untyped-def]
    """:func:`receiver_drive`'s fixes at times to the millisecond, as a receiver's log
    holds them (a NovAtel header's seconds, an SBF block's TOW)."""
    g = receiver_drive()[0].gnss
    return g.assign(t_s=np.round(g[c.T_S].to_numpy(), 3))


def receiver_labels(files, smap=None, gnss_lag="report"):
    """The labelled seconds of :func:`receiver_drive`'s stream ``files`` as a stream folder
    reads them (its signal map, or ``smap``), and the streams."""
    _, radius = receiver_drive()
    streams = read_stream_csvs(files, smap or signal_map(), radius)
    drive = resample(streams, nominal_radius_m=radius, gnss_lag=gnss_lag).drive.columns
    return per_second(drive, radius), streams


def compare(
    drive,
    spec: StreamSpec,
    folder: Path,
    can_noise: bool = False,
) -> Comparison:
    """Write the drive's streams as CSVs, read and resample them, compare second by second."""
    state, vehicle, sim, ss, native = drive
    radius = vehicle.nominal_radius_m
    tables = stream_tables(state, vehicle, sim, ss, spec, START_S, can_noise)
    files = write_stream_csvs(tables, folder)
    streams = read_stream_csvs(
        list(files.values()), signal_map(gyro=tables.gyro is not None), radius
    )
    grid = resample(streams, nominal_radius_m=radius).drive
    a = per_second(native, radius)
    b = per_second(grid.columns, radius)
    both = a.merge(b, on="t_s", suffixes=("_native", "_resampled"))
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        both[f"{q}_change"] = both[f"{q}_resampled"] - both[f"{q}_native"]
    return Comparison(spec, both, len(a), streams.n_input_rows)


def summary(comp: Comparison) -> dict[str, float]:
    """RMS, 99th percentile and largest absolute change per quantity, and coverage."""
    out: dict[str, float] = {
        "seconds": len(comp.seconds),
        "native_seconds": comp.native_seconds,
    }
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        d = np.abs(comp.seconds[f"{q}_change"].to_numpy())
        out[f"{q}_rms"] = float(np.sqrt(np.mean(d**2))) if d.size else float("nan")
        out[f"{q}_p99"] = float(np.percentile(d, 99)) if d.size else float("nan")
        out[f"{q}_max"] = float(d.max()) if d.size else float("nan")
    out["label_native_rms"] = float(np.sqrt(np.mean(comp.seconds["label_m_native"] ** 2)))
    return out


__all__ = ["SPECS", "Comparison", "compare", "per_second", "simulated_drive", "summary", "c"]
