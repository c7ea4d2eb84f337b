"""The built-in fleet as a user's own drives, moved and logged otherwise: does anything change?

The README's own-drives path (``data.source=files``) must give the same result for
the same drives wherever on Earth they were driven and however a logger wrote them.
This script takes a built workspace's simulated fleet (``data/sim``, IO-VNBD files)
and writes it again as one of two variants, then runs the whole pipeline on it in a
scratch copy of the working tree (``build/variants/<variant>``, as ``make variant``
makes one) through the README's commands (drives under ``data/raw``, ``dvc commit
data.dvc``, ``dvc exp run -S data.source=files -S data.root=data/raw``):

``relocated``
    every drive moved with its east/north geometry kept (each fix's geodesic
    distance and azimuth from one fleet origin, laid off from a new origin): the
    source car's drives to Sydney, its held-out drives to Tromsø (69.6° N), the
    target car's to Fiji across the antimeridian (some drives cross 180°); written
    as loggers do: time stamps jittered by up to 40 % of a sample, the clock
    passing midnight 5 min into each drive, the columns in another order and
    their names in other case.
``streams``
    every drive as one folder of stream CSVs on one clock, each at its own rate:
    the four CAN wheel speeds at 50 Hz (stamps jittered by a quarter of the
    period, the speeds interpolated linearly between the 10 Hz rows), the GNSS at
    5 Hz, 30 ms after every second row of the file (each fix the position
    interpolated between the file's two fixes around it, so its noise is a mix of
    theirs), stamped at its epoch, as a receiver's own time stamps it
    (``--gnss-stamp-error-ms``: off its epoch by up to that, uniform, as a logger
    stamping fixes on arrival would), the yaw-rate gyro at 25 Hz in deg/s
    clockwise (a z-down sensor, declared so in the signal map).

Then ``compare`` prints the headline figures of the workspace and the variants side
by side: each model's mean CRSE per outage length, the 2D controls' end-of-outage
position errors, and the fused filter's 1σ / 2σ coverage. A relocated fleet should
give the workspace's figures (its labels are the same to a micrometre); the streams
variant within what its 5 Hz fixes change of the GNSS noise. docs/readers.md ("The
fleet, moved and logged otherwise") has the figures measured.

Usage (after ``make run``, in the project folder; each run ~15 min on 2 cores):

    python benchmarks/fleet_variants.py run relocated
    python benchmarks/fleet_variants.py run streams
    python benchmarks/fleet_variants.py run streams --gnss-stamp-error-ms 5
    python benchmarks/fleet_variants.py run streams --gnss-latency-ms 100 [--gnss-lag auto]
    python benchmarks/fleet_variants.py compare . build/variants/relocated \
        build/variants/streams build/variants/streams-stamp5ms
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from rwhonet.geo import latlon_from_offsets_deg, offsets_m
from rwhonet.sim.streams import SIGNAL_MAP

ROLES = ("source_train", "source_calibration", "source_test", "target_train", "target_test")
PLACES = {  # role -> new origin (lat, lon) of the fleet's geometry
    "source_train": (-33.8688, 151.2093),  # Sydney
    "source_calibration": (-33.8688, 151.2093),
    "source_test": (69.6492, 18.9553),  # Tromsø
    "target_train": (-16.4300, 179.9700),  # Vanua Levu, Fiji: across the antimeridian
    "target_test": (-16.4300, 179.9700),
}
LAT, LON, TIME, YAW = "Lat", "Long", "Time", "Yaw Rate (deg/sec)"
WHEELS = {
    "Wheel Speed Front Left (rad/sec)": "WheelSpeed_FL",
    "Wheel Speed Front Right (rad/sec)": "WheelSpeed_FR",
    "Wheel Speed Rear Left (rad/sec)": "WheelSpeed_RL",
    "Wheel Speed Rear Right (rad/sec)": "WheelSpeed_RR",
}
MIDNIGHT_AFTER_S = 300.0
DAY_S = 86400.0
# The simulator's stream writers' signal map (the same column names), and the gyro.
STREAM_MAP = {
    "reader": "stream_csv",
    "signals": {k: {"column": col, "unit": unit} for k, (col, unit) in SIGNAL_MAP.items()}
    | {"yaw_rate": {"column": "YawRate", "unit": "deg/s cw"}},
}


def read_drive(path: Path) -> pd.DataFrame:
    """An IO-VNBD file as the simulator wrote it, headers stripped of their padding."""
    frame = pd.read_csv(path, skipinitialspace=True, dtype=np.float64)
    frame.columns = [str(k).strip() for k in frame.columns]
    return frame


def fleet_origin(sim: Path) -> tuple[float, float]:
    """The first fix of the first source_train drive: the point every drive is moved about."""
    first = read_drive(sorted((sim / "source_train").glob("*.csv"))[0])
    fixed = first[(first[LAT] != 0.0) | (first[LON] != 0.0)]
    return float(fixed[LAT].iloc[0]), float(fixed[LON].iloc[0])


def relocated(frame: pd.DataFrame, origin, place, rng: np.random.Generator) -> pd.DataFrame:
    """The drive moved to ``place`` and written with a logger's habits (module docstring)."""
    out = frame.copy()
    fix = (out[LAT] != 0.0) | (out[LON] != 0.0)  # latitude = longitude = 0: no fix, kept so
    east, north = offsets_m(origin[0], origin[1], out.loc[fix, LAT], out.loc[fix, LON])
    lat, lon = latlon_from_offsets_deg(place[0], place[1], east, north)
    out.loc[fix, LAT], out.loc[fix, LON] = lat, lon
    t = out[TIME].to_numpy()
    t = t - t[0] + DAY_S - MIDNIGHT_AFTER_S + rng.uniform(-0.04, 0.04, t.size)
    out[TIME] = np.round(np.mod(t, DAY_S), 4)
    order = rng.permutation(out.columns.size)
    out = out.iloc[:, order]
    return out.rename(columns={k: k.upper() for k in out.columns if rng.random() < 0.3})


def write_relocated(sim: Path, raw: Path) -> None:
    origin = fleet_origin(sim)
    rng = np.random.default_rng(20261202)
    for role in ROLES:
        for path in sorted((sim / role).glob("*.csv")):
            out = relocated(read_drive(path), origin, PLACES[role], rng)
            (raw / role).mkdir(parents=True, exist_ok=True)
            out.to_csv(raw / role / path.name, index=False)


@dataclass(frozen=True)
class GnssStream:
    """How the streams variant's receiver and logger write the fixes.

    Attributes:
        hz: the fix rate (a divisor of the file's 10 Hz).
        phase_s: the fixes' offset after the file's first row (the receiver's grid
            against the logger's clock).
        stamp_error_s: each fix stamped up to this off its epoch (uniform; 0: at it).
        latency_s: each fix stamped this much after its epoch besides (a receiver's
            processing and link, as a logger stamping on arrival sees it).
        lag: ``data.gnss_lag`` for the run (``report``, the default, or ``auto``).
    """

    hz: float = 5.0
    phase_s: float = 0.03
    stamp_error_s: float = 0.0
    latency_s: float = 0.0
    lag: str = "report"

    @property
    def suffix(self) -> str:
        """The variant's folder suffix: what differs from the default."""
        out = "" if self.hz == 5.0 else f"-{self.hz:g}hz"
        out += "" if self.phase_s == 0.03 else f"-phase{self.phase_s:g}s"
        out += "" if not self.stamp_error_s else f"-stamp{self.stamp_error_s * 1e3:g}ms"
        out += "" if not self.latency_s else f"-late{self.latency_s * 1e3:g}ms"
        return out + ("" if self.lag == "report" else f"-lag{self.lag}")


def streams(
    frame: pd.DataFrame, rng: np.random.Generator, gnss: GnssStream = GnssStream()
) -> dict[str, pd.DataFrame]:
    """The drive's wheel, GNSS and gyro streams (module docstring)."""
    t = frame[TIME].to_numpy()

    def clock(hz: float, jitter: float) -> np.ndarray:
        n = int((t[-1] - t[0]) * hz) + 1
        tt = t[0] + np.arange(n) / hz + rng.uniform(-jitter, jitter, n) / hz
        return np.sort(tt[(tt >= t[0]) & (tt <= t[-1])])

    t_w, t_y = clock(50.0, 0.25), clock(25.0, 0.25)
    wheels = pd.DataFrame(
        {"Time": t_w, **{v: np.interp(t_w, t, frame[k].to_numpy()) for k, v in WHEELS.items()}}
    )
    gyro = pd.DataFrame({"Time": t_y, "YawRate": -np.interp(t_y, t, frame[YAW].to_numpy())})
    # Fixes every 10 / hz rows, phase_s after the first row: each the position interpolated
    # between the two 10 Hz fixes around it (no fix where either is none), and stamped
    # stamp_error_s off its epoch at most (0: at its epoch, as a receiver's own time).
    lat, lon, sats = (frame[k].to_numpy() for k in (LAT, LON, "Sats"))
    rows = int(np.floor(gnss.phase_s / 0.1 + 1e-9))  # the row each fix follows
    after = gnss.phase_s - 0.1 * rows  # seconds after that row (across a logger's gap too)
    i = np.arange(rows, t.size - 1, round(10.0 / gnss.hz))
    w = after / (t[i + 1] - t[i])
    fix = ((lat != 0.0) | (lon != 0.0))[i] & ((lat != 0.0) | (lon != 0.0))[i + 1]
    dlon = (lon[i + 1] - lon[i] + 180.0) % 360.0 - 180.0  # the short way across 180°
    table = pd.DataFrame(
        {
            "Time": t[i]
            + w * (t[i + 1] - t[i])
            + rng.uniform(-1, 1, i.size) * gnss.stamp_error_s
            + gnss.latency_s,
            "Latitude": np.where(fix, lat[i] + w * (lat[i + 1] - lat[i]), 0.0),
            "Longitude": np.where(fix, (lon[i] + w * dlon + 180.0) % 360.0 - 180.0, 0.0),
            "NumSV": np.minimum(sats[i], sats[i + 1]),
        }
    )
    return {"wheels": wheels, "gnss": table, "gyro": gyro}


def write_streams(sim: Path, raw: Path, gnss: GnssStream = GnssStream()) -> None:
    rng = np.random.default_rng(20261203)
    for role in ROLES:
        for path in sorted((sim / role).glob("*.csv")):
            folder = raw / role / path.stem
            folder.mkdir(parents=True, exist_ok=True)
            for name, table in streams(read_drive(path), rng, gnss).items():
                table.to_csv(folder / f"{name}.csv", index=False)


def set_params(params_file: Path, variant: str) -> None:
    """Point the roles at the variant's files (the user's edit of params.yaml)."""
    params = yaml.safe_load(params_file.read_text())
    roles = params["data"]["roles"]
    if variant == "streams":
        params["data"].setdefault("signal_maps", {})["fleet_streams"] = STREAM_MAP
        for role in ROLES:
            roles[role]["glob"] = f"{role}/*"
            roles[role]["format"] = "fleet_streams"
    params_file.write_text(yaml.safe_dump(params, sort_keys=False))


def run(variant: str, workspace: Path, gnss: GnssStream = GnssStream()) -> Path:
    """Write the variant fleet into a scratch copy of the working tree and run the pipeline."""
    suffix = gnss.suffix if variant == "streams" else ""
    dest = workspace / "build" / "variants" / f"{variant}{suffix}"
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    files = subprocess.run(
        ["git", "ls-files", "-co", "--exclude-standard", "-z"],
        cwd=workspace,
        capture_output=True,
        check=True,
    ).stdout.split(b"\0")
    for name in filter(None, files):
        src = workspace / name.decode()
        if src.is_file():
            (dest / name.decode()).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name.decode())
    sim = workspace / "data" / "sim"
    if not (sim / "source_train").is_dir():
        sys.exit(f"{sim}: no simulated fleet to write again; run `make run` in {workspace} first")
    if variant == "relocated":
        write_relocated(sim, dest / "data" / "raw")
    else:
        write_streams(sim, dest / "data" / "raw", gnss)
    set_params(dest / "params.yaml", variant)
    # The stages' `python` must be this interpreter (the project's venv).
    bin_dir = str(Path(sys.executable).parent)
    env = {
        **os.environ,
        "PYTHONPATH": str(dest / "src"),
        "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
    }

    def sh(*cmd: str) -> None:
        subprocess.run(cmd, cwd=dest, env=env, check=True)

    sh("git", "init", "-q")
    sh("git", "-c", "user.name=variant", "-c", "user.email=variant@localhost", "add", "-A", ".")
    sh("git", "-c", "user.name=variant", "-c", "user.email=v@l", "commit", "-qm", "snapshot")
    sh(sys.executable, "-m", "dvc", "commit", "-q", "-f", "data.dvc")
    sh(sys.executable, "-m", "rwhonet.tracking", "init")
    files_path = ("-S", "data.source=files", "-S", "data.root=data/raw")
    lag = ("-S", f"data.gnss_lag={gnss.lag}") if variant == "streams" else ()
    sh(sys.executable, "-m", "dvc", "exp", "run", *files_path, *lag)
    return dest


def headline(folder: Path) -> dict[str, float]:
    """The figures compared: mean CRSE per model and length, the 2D controls' end errors."""
    ev = json.loads((folder / "metrics" / "eval.json").read_text())
    out: dict[str, float] = {}
    for model in ("WPM", "G", "S", "R"):
        for length, m in ev["overall"].get(model, {}).items():
            out[f"CRSE {model} {length} (m)"] = m["crse_mean"]
    for control, by_len in ev["position_controls"]["rows"].items():
        for length, m in by_len.items():
            out[f"2D {control} {length} (% of distance)"] = m["pos_pct"]
            if control == "fused":
                out[f"2D {control} {length} in 1 sigma"] = m["cover_1sigma"]
                out[f"2D {control} {length} in 2 sigma"] = m["cover_2sigma"]
    return out


def compare(folders: list[Path]) -> None:
    rows = [headline(f) for f in folders]
    keys = [k for k in rows[0] if all(k in r for r in rows[1:])]
    width = max(len(k) for k in keys)
    names = [f.resolve().name for f in folders]
    print(f"{'':{width}}" + "".join(f"{n[:14]:>15}" for n in names))
    for k in keys:
        print(f"{k:{width}}" + "".join(f"{r[k]:15.4f}" for r in rows))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="write the variant fleet and run the pipeline on it")
    r.add_argument("variant", choices=("relocated", "streams"))
    r.add_argument("--workspace", type=Path, default=Path("."))
    r.add_argument("--gnss-hz", type=float, default=5.0, help="streams: 1, 2, 5 or 10")
    r.add_argument("--gnss-phase-s", type=float, default=0.03, help="streams: fixes' offset")
    r.add_argument("--gnss-stamp-error-ms", type=float, default=0.0)
    r.add_argument("--gnss-latency-ms", type=float, default=0.0, help="streams: fixes stamped late")
    r.add_argument("--gnss-lag", choices=("report", "auto"), default="report")
    c = sub.add_parser("compare", help="headline figures of built folders side by side")
    c.add_argument("folders", type=Path, nargs="+")
    args = ap.parse_args(argv)
    if args.cmd == "run":
        gnss = GnssStream(
            args.gnss_hz,
            args.gnss_phase_s,
            args.gnss_stamp_error_ms / 1000.0,
            args.gnss_latency_ms / 1000.0,
            args.gnss_lag,
        )
        print(run(args.variant, args.workspace.resolve(), gnss))
    else:
        compare(args.folders)
    return 0


if __name__ == "__main__":
    sys.exit(main())
