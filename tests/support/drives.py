"""Small synthetic drives and writers for the data-package tests.

A straight drive at constant speed: fixes from geographiclib's exact geodesic
(``Geodesic.WGS84.Direct``), wheel speed ``v / r`` on every wheel, so the
implied effective radius is exactly ``r`` and every quantity is known.
"""

from __future__ import annotations

import copy
import dataclasses
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import yaml
from geographiclib.geodesic import Geodesic

from rwhonet.config import Params, load_params
from rwhonet.config import _build as _build_section
from rwhonet.data import canonical as c
from rwhonet.data.iovnbd import HEADERS, LAYOUT


def build_params(raw: dict) -> Params:
    """Typed params from a params.yaml mapping, with load_params's checks."""
    return _build_section(Params, raw, "")


_VEHICLES = load_params().data.vehicles  # the nominal radii real drives are checked against
SOURCE_RADIUS_M = _VEHICLES["source"].nominal_radius_m
TARGET_RADIUS_M = _VEHICLES["target"].nominal_radius_m


def straight_drive(
    duration_s: float = 40.0,
    speed_m_s: float = 15.0,
    radius_m: float = SOURCE_RADIUS_M,
    t0_s: float = 45000.0,
    period_s: float = 0.1,
    lat0_deg: float = 52.4,
    lon0_deg: float = -1.5,
    azimuth_deg: float = 30.0,
    n_sats: float = 9.0,
    first_row_at_t0: bool = True,
) -> pd.DataFrame:
    """A drive along a geodesic at constant speed, in canonical columns.

    Rows are at ``t0_s + i * period_s``; with ``first_row_at_t0`` the first row sits on the
    whole second ``t0_s`` (a start fix), so seconds ``t0+1 .. t0+duration`` are complete.
    """
    n = round(duration_s / period_s) + (1 if first_row_at_t0 else 0)
    i = np.arange(n) + (0 if first_row_at_t0 else 1)
    t = np.round(t0_s + i * period_s, 6)
    s_m = speed_m_s * (t - t0_s)
    geo = [Geodesic.WGS84.Direct(lat0_deg, lon0_deg, azimuth_deg, d) for d in s_m]
    omega = np.full(n, speed_m_s / radius_m)
    return pd.DataFrame(
        {
            c.T_S: t,
            c.LAT_DEG: [g["lat2"] for g in geo],
            c.LON_DEG: [g["lon2"] for g in geo],
            c.OMEGA_FL: omega,
            c.OMEGA_FR: omega,
            c.OMEGA_RL: omega,
            c.OMEGA_RR: omega,
            c.N_SATS: np.full(n, n_sats),
        }
    )


def write_iovnbd(df: pd.DataFrame, path: Path, headers: tuple[str, ...] = HEADERS) -> Path:
    """Write canonical columns as an IO-VNBD "V-" CSV (29 columns, the layout's units)."""
    out = {}
    for col, header in zip(LAYOUT, headers, strict=True):
        if col.canonical is not None and col.canonical in df:
            out[header] = df[col.canonical].to_numpy() / col.to_si
        elif header.strip() == "Sample Period":
            out[header] = np.full(len(df), 0.1)
        else:
            out[header] = np.zeros(len(df))
    path.parent.mkdir(parents=True, exist_ok=True)
    # pyarrow writes the shortest decimal that round-trips, as pandas does, ten times faster;
    # the header by hand, unquoted.
    table = pa.table(
        [pa.array(np.asarray(v, np.float64)) for v in out.values()],
        names=[f"c{i}" for i in range(len(out))],
    )
    with open(path, "wb") as f:
        f.write((",".join(headers) + "\n").encode("utf-8"))
        pa_csv.write_csv(table, f, pa_csv.WriteOptions(include_header=False))
    return path


CUPAC_MAP = {
    "t": ("Time", "ms"),
    "lat": ("Latitude", "deg"),
    "lon": ("Longitude", "deg"),
    "omega_fl": ("WheelSpeedFL", "rpm"),
    "omega_fr": ("WheelSpeedFR", "rpm"),
    "omega_rl": ("WheelSpeedRL", "rpm"),
    "omega_rr": ("WheelSpeedRR", "rpm"),
    "n_sats": ("Satellites", "count"),
}
_TO_SI = {"s": 1.0, "ms": 1e-3, "deg": 1.0, "rad/s": 1.0, "rpm": 2 * np.pi / 60, "count": 1.0}
_TO_SI |= c.YAW_RATE_UNITS | {"m": 1.0, "cm": 0.01, "mm": 0.001}  # written by hand: tested
_KEY = {
    "t": c.T_S,
    "lat": c.LAT_DEG,
    "lon": c.LON_DEG,
    "omega_fl": c.OMEGA_FL,
    "omega_fr": c.OMEGA_FR,
    "omega_rl": c.OMEGA_RL,
    "omega_rr": c.OMEGA_RR,
    "n_sats": c.N_SATS,
    "h_acc": c.H_ACC_M,
    "yaw_rate": c.YAW_RATE_RAD_S,
}


_LINEAR = {"m/s": 1.0, "km/h": 1 / 3.6, "mph": 0.44704}  # a wheel's circumferential speed


def write_columnmap(
    df: pd.DataFrame, path: Path, cmap: dict = CUPAC_MAP, radius_m: float | None = None
) -> Path:
    """Write canonical columns as a CSV described by a column map (key -> (column, unit));
    a wheel speed in m/s, km/h or mph is the wheel's rad/s times ``radius_m``."""
    out = {"Extra": np.arange(len(df))}  # an unmapped column, to be ignored
    for key, (column, unit) in cmap.items():
        if unit in _LINEAR:
            assert radius_m is not None, f"{key} in {unit}: give the radius"
            out[column] = df[_KEY[key]].to_numpy() * radius_m / _LINEAR[unit]
            continue
        out[column] = df[_KEY[key]].to_numpy() / _TO_SI[unit]
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(out).to_csv(path, index=False)
    return path


def column_map_params(cmap: dict = CUPAC_MAP) -> dict:
    """The params.yaml form of a column map."""
    return {k: {"column": col, "unit": unit} for k, (col, unit) in cmap.items()}


@lru_cache(maxsize=1)
def _project_yaml() -> dict:
    from rwhonet import paths

    # libyaml's loader when there is one: the tests build params hundreds of times. The
    # project's own file, not paths.PARAMS: a test that points that at a params file of
    # its own (monkeypatch) must not leave it cached for the tests after it.
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    return yaml.load((paths.ROOT / "params.yaml").read_text(encoding="utf-8"), Loader=loader)


@lru_cache(maxsize=1)
def _files_params() -> Params:
    return make_params(Path("<root>"), _cache=False)


# Params for short test drives (20-40 s): a target test drive then needs max(adapt.m_grid)
# + min(evaluate.outages_s) = 10 valid seconds.
SHORT = {
    "validate.gnss.min_segment_s": 5,
    "validate.radius_min_moving_s": 10,
    "adapt.m_grid": [5],
    "adapt.chosen_m": 5,
    "adapt.recipe": "paper",
    "evaluate.outages_s": [5],
}


def make_params(root: Path, _cache: bool = True, **overrides) -> Params:
    """Project params reading real-style drives from ``root`` (``data.source=files``).

    Built as :func:`rwhonet.config.load_params` builds them (dotted-key overrides, the
    same strict checks), from the project's params.yaml parsed once per session.
    """
    if _cache and not overrides:  # the usual case: only the root differs
        base = _files_params()
        return dataclasses.replace(base, data=dataclasses.replace(base.data, root=str(root)))
    raw = copy.deepcopy(_project_yaml())
    for dotted, value in {"data.source": "files", "data.root": str(root), **overrides}.items():
        node = raw
        *parents, leaf = dotted.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    return build_params(raw)


def target_drive_args() -> dict:
    """``rwhonet.cli.drive.load_drive``'s keyword arguments for a drive of the target car
    (``write_iovnbd``'s files, its true radius, a global scaler, one-second windows)."""
    from rwhonet.cli.drive import calibration_of
    from rwhonet.features.scaling import MinMaxScaler

    return dict(
        params=load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of((TARGET_RADIUS_M, TARGET_RADIUS_M), "t"),
        scaler=MinMaxScaler("global", (0.0,) * 4, (60.0,) * 4, (), 0),
        wpm_mode="integrated",
        seq_len=1,
    )


def write_fleet(root: Path, duration_s: float = 40.0) -> dict[str, Path]:
    """One clean IO-VNBD drive per required role (the source vehicle's and target's radii)."""
    return {
        "source_train": write_iovnbd(
            straight_drive(duration_s), root / "source_train" / "V-S1.csv"
        ),
        "target_train": write_iovnbd(
            straight_drive(duration_s, radius_m=TARGET_RADIUS_M, azimuth_deg=100.0),
            root / "target_train" / "C-A1.csv",
        ),
        "target_test": write_iovnbd(
            straight_drive(duration_s, radius_m=TARGET_RADIUS_M, lat0_deg=52.41),
            root / "target_test" / "C-B1.csv",
        ),
    }


def write_params_yaml(path: Path, **overrides) -> Path:
    """Write a copy of the project's params.yaml with dotted-key overrides (for stage scripts)."""
    from rwhonet import paths

    raw = yaml.safe_load(paths.PARAMS.read_text(encoding="utf-8"))
    for dotted, value in overrides.items():
        node = raw
        *parents, leaf = dotted.split(".")
        for key in parents:
            node = node.setdefault(key, {})
        node[leaf] = value
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    return path


def write_long_iovnbd(path: Path, n_rows: int, chunk_rows: int = 100_000) -> Path:
    """Write a long IO-VNBD drive fast, chunk by chunk (for the large-file tests and benchmark).

    A drive at about 15 m/s back and forth along a 20 km line heading north-east from
    (52.4, -1.5), every one of the 29 columns filled with a plausible value; written with
    ``pyarrow.csv`` so a gigabyte takes seconds, in bounded memory. Fixes follow a
    flat-earth line (accurate to millimetres over a second; validate's radius check
    still sees 15 m/s). About 124 bytes a row: 8.1 M rows make a gigabyte.
    """
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    r = TARGET_RADIUS_M
    deg_lat_m = 111_250.0  # metres per degree of latitude near 52.4 deg (WGS84)
    deg_lon_m = deg_lat_m * np.cos(np.radians(52.4))
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.write((",".join(HEADERS) + "\n").encode("utf-8"))
        writer = None
        for start in range(0, n_rows, chunk_rows):
            i = np.arange(start, min(start + chunk_rows, n_rows), dtype=np.float64)
            t = np.round(45000.0 + 0.1 * i, 1)
            # m/s; the small fast term keeps the rounded wheel speeds from repeating one value
            # for seconds at the slow term's peaks (validate would call that stale wheel data
            # where a peak meets a turn-back of the line, when the GNSS speed dips)
            v = 15.0 + 0.5 * np.sin(i / 300.0) + 0.05 * np.sin(i / 5.0)
            s = 1.5 * i + 15.0 * (1.0 - np.cos(i / 300.0)) + 0.025 * (1.0 - np.cos(i / 5.0))
            s = 20_000.0 - np.abs(s % 40_000.0 - 20_000.0)  # back and forth: never off the map
            cols = {header: np.zeros(i.size) for header in HEADERS}
            cols[HEADERS[0]] = np.full(i.size, 9.0)
            cols[HEADERS[1]] = t
            cols[HEADERS[2]] = np.round(52.4 + s * np.cos(np.radians(30.0)) / deg_lat_m, 8)
            cols[HEADERS[3]] = np.round(-1.5 + s * np.sin(np.radians(30.0)) / deg_lon_m, 8)
            cols[HEADERS[4]] = np.round(v * 3.6, 3)
            cols[HEADERS[5]] = np.full(i.size, 30.0)
            cols[HEADERS[6]] = np.full(i.size, 0.085)
            cols[HEADERS[8]] = np.full(i.size, 0.1)
            for k in range(10, 14):
                cols[HEADERS[k]] = np.round(v / r, 2)
            cols[HEADERS[15]] = np.round(v * 3.6, 1)
            cols[HEADERS[21]] = np.round(v * 150.0, 0)
            cols[HEADERS[22]] = np.full(i.size, 90.0)
            cols[HEADERS[26]] = np.full(i.size, 14.2)
            cols[HEADERS[27]] = np.full(i.size, 12.5)
            cols[HEADERS[28]] = np.full(i.size, 18.0)
            batch = pa.record_batch(
                [pa.array(cols[h]) for h in HEADERS], names=[f"c{k}" for k in range(len(HEADERS))]
            )
            if writer is None:
                writer = pa_csv.CSVWriter(
                    f, batch.schema, write_options=pa_csv.WriteOptions(include_header=False)
                )
            writer.write_batch(batch)
        if writer is not None:
            writer.close()
    return path


def written_twice(df: pd.DataFrame, *rows: int) -> pd.DataFrame:
    """``df`` with each data row of ``rows`` (1-based, of the frame so far) written again
    right after it."""
    for row in rows:
        df = pd.concat([df.iloc[:row], df.iloc[row - 1 :]], ignore_index=True)
    return df


def written_again(df: pd.DataFrame, after: int, first: int, last: int) -> pd.DataFrame:
    """``df`` with its data rows ``first..last`` (1-based) written again after data row
    ``after`` (a block a logger wrote again, or two exports joined that overlap)."""
    return pd.concat(
        [df.iloc[:after], df.iloc[first - 1 : last], df.iloc[after:]], ignore_index=True
    )


def with_held_fixes(df: pd.DataFrame, every: int, phase: int, empty: bool = False) -> pd.DataFrame:
    """``df`` as a logger writes a receiver of one fix every ``every`` rows, arriving
    ``phase`` rows into each period: its last fix (and course, height, satellites) in every
    row until the next, or (``empty``) only in the row it came in, the cells between empty."""
    rows = np.arange(len(df))
    src = np.maximum(rows - (rows - phase) % every, 0)
    out = df.copy()
    for name in (c.LAT_DEG, c.LON_DEG, c.N_SATS, c.SPEED_GNSS_M_S, c.HEADING_DEG, c.HEIGHT_M):
        if name in df:
            values = df[name].to_numpy()[src]
            if empty:  # only in the rows a fix came in
                values = np.where((rows - phase) % every == 0, values, np.nan)
            out[name] = values
    return out


def as_ddmm(deg) -> np.ndarray:
    """Degrees as NMEA writes them: degrees and minutes run together (ddmm.mmmm), signed."""
    deg = np.asarray(deg, dtype=np.float64)
    whole = np.trunc(np.abs(deg))
    return np.copysign(100.0 * whole + 60.0 * (np.abs(deg) - whole), deg)


def as_hhmmss(t_s, decimals: int = 3) -> np.ndarray:
    """Times (s; of the day, taken modulo 86,400) as NMEA's hhmmss.sss numbers."""
    hours, rest = np.divmod(np.round(np.asarray(t_s, dtype=np.float64), decimals) % 86400.0, 3600.0)
    minutes, seconds = np.divmod(rest, 60.0)
    return 10_000.0 * hours + 100.0 * minutes + seconds


# The IO-VNBD columns by name, as a column map's params (a map finds them as a header's:
# ``Wheel Speed Rear Left`` is `` Wheel Speed Rear Left (rad/sec)``): the benchmarks' files
# of many drives add their drive column to it.
IOVNBD_BY_NAME = {
    "t": {"column": "Time", "unit": "s"},
    "lat": {"column": "Lat", "unit": "deg"},
    "lon": {"column": "Long", "unit": "deg"},
    "omega_fl": {"column": "Wheel Speed Front Left", "unit": "rad/s"},
    "omega_fr": {"column": "Wheel Speed Front Right", "unit": "rad/s"},
    "omega_rl": {"column": "Wheel Speed Rear Left", "unit": "rad/s"},
    "omega_rr": {"column": "Wheel Speed Rear Right", "unit": "rad/s"},
    "n_sats": {"column": "Sats", "unit": "count"},
}


VBO_MAP = {
    "t": ("time", "hhmmss"),
    "lat": ("lat", "min"),
    "lon": ("long", "min W"),
    "omega_fl": ("Wheel_Speed_FL", "rpm"),
    "omega_fr": ("Wheel_Speed_FR", "rpm"),
    "omega_rl": ("Wheel_Speed_RL", "rpm"),
    "omega_rr": ("Wheel_Speed_RR", "rpm"),
    "n_sats": ("sats", "vbox"),
}


def write_vbo(
    df: pd.DataFrame, path: Path, crlf: bool = False, flags: int | np.ndarray = 0
) -> Path:
    """Write canonical columns as a Racelogic VBOX file (:data:`VBO_MAP`'s columns): its
    sections, the UTC time of day as hhmmss.ss, latitude and longitude in signed minutes
    (longitude positive west), the values separated by spaces, in VBOX's fixed widths;
    ``flags`` (per row, or one for all) added to the satellite count (64: brake trigger,
    128: DGPS)."""
    times = as_hhmmss(df[c.T_S].to_numpy(), decimals=2)
    rpm = {w: df[w].to_numpy() * 60.0 / (2.0 * np.pi) for w in c.WHEELS}
    lines = [
        "File created on 11/03/2019 @ 12:30:00",
        "",
        "[header]",
        "satellites",
        "time",
        "latitude",
        "longitude",
        "velocity kmh",
        *(f"Wheel_Speed_{w}" for w in ("FL", "FR", "RL", "RR")),
        "",
        "[comments]",
        "Log rate (Hz) : 10.00",
        "",
        "[column names]",
        "sats time lat long velocity "
        + " ".join(f"Wheel_Speed_{w}" for w in ("FL", "FR", "RL", "RR")),
        "",
        "[data]",
    ]
    lat_min = df[c.LAT_DEG].to_numpy() * 60.0
    long_min = -df[c.LON_DEG].to_numpy() * 60.0
    added = np.broadcast_to(np.asarray(flags, dtype=int), (len(df),))
    for i in range(len(df)):
        sats = (int(df[c.N_SATS].iloc[i]) if c.N_SATS in df else 9) + int(added[i])
        hhmmss = times[i]
        wheels = " ".join(f"{rpm[w][i]:08.3f}" for w in c.WHEELS)
        lines.append(
            f"{sats:03d} {hhmmss:09.2f} {lat_min[i]:+012.7f} {long_min[i]:+013.7f} 050.000 {wheels}"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(("\r\n" if crlf else "\n").join(lines).encode() + (b"\r\n" if crlf else b"\n"))
    return path
