"""A fleet of drives written as loggers write them: every role's drives in one stream format.

A 10 Hz drive in canonical columns (:func:`support.corpus.speed_profile_drive`, or
any other) is turned into the streams a logger would have recorded of it: CAN wheel
speeds at ``wheel_hz`` with jittered stamps (the wheel speeds interpolated
linearly between the 10 Hz rows, the signal :func:`rwhonet.data.streams.resample`
assumes), fixes at ``gnss_hz`` at a phase off the whole tenths. The writers of
:mod:`rwhonet.sim.streams` put them on disk as a comma2k19 folder, an MDF4 file
or a folder of stream CSVs, and :func:`stream_params` gives the params that read
them through ingest, validate and label (``data.signal_maps``, the roles' format).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c
from rwhonet.sim.streams import (
    SIGNAL_MAP,
    StreamTables,
    write_comma2k19,
    write_comma2k19_route,
    write_stream_csvs,
    write_stream_mdf4,
)
from support.corpus import speed_profile_drive
from support.drives import SOURCE_RADIUS_M, TARGET_RADIUS_M, make_params

# comma2k19_route: a comma2k19 route, the drive's one-minute segments in numbered folders
FORMATS = ("comma2k19", "comma2k19_route", "mdf4", "stream_csv")
MAP_NAME = {"mdf4": "logger_mf4", "stream_csv": "logger_csv", "comma2k19_route": "comma2k19"}
ROLE_DRIVES = {  # role -> (drive id, radius, azimuth, start latitude)
    "source_train": ("V-S1", SOURCE_RADIUS_M, 30.0, 52.40),
    "target_train": ("C-A1", TARGET_RADIUS_M, 100.0, 52.42),
    "target_test": ("C-B1", TARGET_RADIUS_M, 30.0, 52.41),
}


def tables_from_drive(
    drive: pd.DataFrame,
    wheel_hz: float = 100.0,
    gnss_hz: float = 10.0,
    jitter: float = 0.25,
    gnss_phase_s: float = 0.03,
    seed: int = 0,
) -> StreamTables:
    """The streams a logger records of a 10 Hz drive (canonical columns, rows on tenths).

    Args:
        drive: the drive.
        wheel_hz: CAN rate.
        gnss_hz: fix rate.
        jitter: each CAN stamp up to this fraction of the CAN period off its instant.
        gnss_phase_s: the fixes' offset from the drive's whole tenths.
        seed: the jitter's seed.

    Returns:
        The wheel and GNSS streams, on the drive's clock.
    """
    t = drive[c.T_S].to_numpy(np.float64)
    rng = np.random.default_rng(seed)
    period = 1.0 / wheel_hz
    t_w = t[0] + np.arange(int((t[-1] - t[0]) / period) + 1) * period
    t_w = np.sort(t_w + rng.uniform(-jitter, jitter, t_w.size) * period)
    t_w = t_w[(t_w >= t[0]) & (t_w <= t[-1])]
    t_g = (
        t[0] + gnss_phase_s + np.arange(int((t[-1] - t[0] - gnss_phase_s) * gnss_hz) + 1) / gnss_hz
    )
    wheels = pd.DataFrame(
        {c.T_S: t_w, **{w: np.interp(t_w, t, drive[w].to_numpy(np.float64)) for w in c.WHEELS}}
    )
    gnss = pd.DataFrame(
        {
            c.T_S: t_g,
            c.LAT_DEG: np.interp(t_g, t, drive[c.LAT_DEG].to_numpy(np.float64)),
            c.LON_DEG: np.interp(t_g, t, drive[c.LON_DEG].to_numpy(np.float64)),
            c.N_SATS: np.full(t_g.size, 9.0),
        }
    )
    return StreamTables(wheels, gnss)


def write_drive(fmt: str, tables: StreamTables, folder: Path, drive: str, radius_m: float) -> Path:
    """Write one drive's streams in ``fmt`` under ``folder``; return the drive's path."""
    if fmt == "comma2k19":
        write_comma2k19(tables, folder / drive, radius_m)
        return folder / drive
    if fmt == "comma2k19_route":
        write_comma2k19_route(tables, folder / drive, radius_m)
        return folder / drive
    if fmt == "mdf4":
        t0 = float(tables.wheels[c.T_S].iloc[0])  # an MDF4 clock starts at its measurement
        shifted = StreamTables(
            tables.wheels.assign(**{c.T_S: tables.wheels[c.T_S] - t0}),
            tables.gnss.assign(**{c.T_S: tables.gnss[c.T_S] - t0}),
        )
        return write_stream_mdf4(shifted, folder / f"{drive}.mf4")
    write_stream_csvs(tables, folder / drive)
    return folder / drive


def role_drive(role: str, duration_s: float = 150.0) -> pd.DataFrame:
    """The 10 Hz drive each role gets: straight, 13-17 m/s, with its car's radius, from
    whole second 45000 of the day."""
    _, radius, azimuth, lat0 = ROLE_DRIVES[role]
    t = 0.1 * np.arange(round(duration_s * 10) + 1)
    speed = 15.0 + 2.0 * np.sin(2.0 * np.pi * t / 40.0)
    return speed_profile_drive(speed, radius, lat0, azimuth)


def write_stream_fleet(root: Path, fmt: str, duration_s: float = 150.0) -> dict[str, Path]:
    """One drive per required role, every one in ``fmt``; return role -> the drive's path."""
    out = {}
    for role, (drive, radius, _, _) in ROLE_DRIVES.items():
        tables = tables_from_drive(role_drive(role, duration_s))
        out[role] = write_drive(fmt, tables, root / role, drive, radius)
    return out


def signal_map_params(fmt: str) -> dict:
    """The params.yaml form of the writers' signal map for ``fmt`` (MDF4 or stream CSVs)."""
    signals = {
        k: {"column": col, "unit": unit}
        for k, (col, unit) in SIGNAL_MAP.items()
        if fmt == "stream_csv" or k != "t"
    }
    return {"reader": fmt, "signals": signals}


def stream_params(root: Path, fmt: str, **overrides):
    """Params reading :func:`write_stream_fleet`'s drives (files mode, every role in ``fmt``)."""
    name = MAP_NAME.get(fmt, fmt)
    glob = "*.mf4" if fmt == "mdf4" else "*"
    roles = {
        role: {"glob": f"{role}/{glob}", "format": name, "vehicle": vehicle, "required": True}
        for role, vehicle in (
            ("source_train", "source"),
            ("target_train", "target"),
            ("target_test", "target"),
        )
    }
    maps = {name: signal_map_params(fmt)} if fmt in ("mdf4", "stream_csv") else {}
    return make_params(root, **{"data.roles": roles, "data.signal_maps": maps, **overrides})


def read_target_drive(params, path: Path, radius_m: float = 0.3, data=None):
    """Read one target-test drive in the format of ``params``' fleet (:func:`stream_params`)
    as ingest reads it (``rwhonet.data.drivefile.read_canonical``); ``data``: another
    ``data`` section (a smaller size limit, ...)."""
    from rwhonet.data.compressed import drive_stem
    from rwhonet.data.drivefile import DriveFile, read_canonical

    fmt = params.data.roles["target_test"].format
    vp = params.validate
    f = DriveFile(drive_stem(path), "target_test", "target", fmt, path)
    data = params.data if data is None else data
    return read_canonical(f, data, str, radius_m, vp.sample_period_s, vp.gnss.max_gap_s)
