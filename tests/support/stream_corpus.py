"""The bad-input corpus of the stream readers: a good multi-rate drive, corrupted one way each.

Like :mod:`support.corpus` for the 10 Hz files: every case writes a drive in one
of the stream formats (a comma2k19 folder, an MDF4 file, one CSV per stream)
under a folder, with one thing wrong, and says what the reader and resampler
must answer: an :class:`~rwhonet.errors.InputError` one of whose problems names
the file (or folder, array, stream), the row where there is one, the column or
channel, and holds the expected and found texts given. The good drive is 40 s
north at 12 m/s: wheel speeds at 100 Hz, fixes at 10 Hz, on a clock starting at
1000 s. ``tests/data/bad/test_stream_corpus.py`` runs every case.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c
from rwhonet.sim.streams import (
    StreamTables,
    signal_map,
    write_comma2k19,
    write_stream_csvs,
    write_stream_mdf4,
)

RADIUS_M = 0.3
T0_S = 1000.0


@dataclass(frozen=True)
class Refuse:
    """The reader or resampler stops; one of its problems must match all of these."""

    file: str  # a substring of Problem.file
    row: int | None  # 1-based sample row of the stream (None: file-wide)
    column: str | None  # the channel as the file names it
    expected: str  # a substring of Problem.expected
    found: str  # a substring of Problem.found


@dataclass(frozen=True)
class StreamCase:
    """One bad stream drive: its format, what is wrong, how to write it, what must happen."""

    name: str
    fmt: str  # "comma2k19" | "mdf4" | "csv"
    corruption: str
    write: Callable[[Path], None]
    expect: Refuse


CASES: list[StreamCase] = []


def case(name: str, fmt: str, corruption: str, expect: Refuse):
    """Register the decorated writer as a corpus case."""

    def register(write: Callable[[Path], None]) -> Callable[[Path], None]:
        CASES.append(StreamCase(name, fmt, corruption, write, expect))
        return write

    return register


def good_tables(t0_s: float = T0_S) -> StreamTables:
    """The good drive's streams."""
    t_w = np.arange(0.0, 40.0, 0.01)
    t_g = np.arange(0.05, 40.0, 0.1)
    lat = 37.7 + 12.0 * t_g / 111_000.0
    omega = np.full(t_w.size, 12.0 / RADIUS_M)
    wheels = pd.DataFrame({c.T_S: t0_s + t_w, **{w: omega for w in c.WHEELS}})
    gnss = pd.DataFrame(
        {
            c.T_S: t0_s + t_g,
            c.LAT_DEG: lat,
            c.LON_DEG: np.full(t_g.size, -122.4),
            c.N_SATS: np.full(t_g.size, 9.0),
        }
    )
    return StreamTables(wheels, gnss)


def folder_of(fmt: str, root: Path) -> Path:
    """Where a case of this format writes its drive."""
    return root / {"comma2k19": "seg", "mdf4": "drive.mf4", "csv": "streams"}[fmt]


def write_good(fmt: str, root: Path, tables: StreamTables | None = None) -> Path:
    """Write the good drive in a format; return the folder or file the reader is given."""
    tables = tables or good_tables()
    target = folder_of(fmt, root)
    if fmt == "comma2k19":
        write_comma2k19(tables, target, RADIUS_M)
    elif fmt == "mdf4":
        write_stream_mdf4(tables, target)
    else:
        write_stream_csvs(tables, target)
    return target


def _edit_csv(root: Path, name: str, edit: Callable[[list[str]], list[str]]) -> None:
    write_good("csv", root)
    path = folder_of("csv", root) / name
    path.write_text("\n".join(edit(path.read_text().splitlines())) + "\n")


def _save(path: Path, array: np.ndarray) -> None:
    with open(path, "wb") as f:
        np.save(f, array)


# --------------------------------------------------------------------------- comma2k19


@case(
    "comma_no_folder",
    "comma2k19",
    "the segment folder is not there",
    Refuse("seg", None, None, "a comma2k19 segment folder", "no such folder"),
)
def _(root: Path) -> None:
    pass


@case(
    "comma_missing_array",
    "comma2k19",
    "CAN/wheel_speed/t deleted",
    Refuse("seg/CAN/wheel_speed/t", None, None, "the NumPy array 't'", "no such file"),
)
def _(root: Path) -> None:
    (write_good("comma2k19", root) / "processed_log/CAN/wheel_speed/t").unlink()


@case(
    "comma_not_numpy",
    "comma2k19",
    "GNSS/live_gnss_ublox/value holds bytes that are not a NumPy array",
    Refuse("seg/GNSS/live_gnss_ublox/value", None, None, "a NumPy array file", "Error"),
)
def _(root: Path) -> None:
    seg = write_good("comma2k19", root)
    (seg / "processed_log/GNSS/live_gnss_ublox/value").write_bytes(b"\x00garbage" * 10)


@case(
    "comma_wrong_shape",
    "comma2k19",
    "CAN/wheel_speed/value has 10 rows for 4000 times",
    Refuse("seg/CAN/wheel_speed", None, "value", "one row of 4 value(s) per time", "(10, 4)"),
)
def _(root: Path) -> None:
    _save(write_good("comma2k19", root) / "processed_log/CAN/wheel_speed/value", np.zeros((10, 4)))


@case(
    "comma_time_backwards",
    "comma2k19",
    "wheel-speed sample 501 stamped 1 ms after sample 499 (at 499's time and with its values it "
    "would be a copy, dropped)",
    Refuse("seg [CAN/wheel_speed]", 501, "t", "strictly increasing", "t = 1004.981"),
)
def _(root: Path) -> None:
    path = write_good("comma2k19", root) / "processed_log/CAN/wheel_speed/t"
    t = np.load(path)
    t[500] = t[498] + 0.001
    _save(path, t)


@case(
    "comma_latitude_out_of_range",
    "comma2k19",
    "fix 31 has latitude 137.7 (a corrupted fix)",
    Refuse("seg [GNSS/live_gnss_ublox]", 31, "value[:, 0] (latitude)", "[-90, 90]", "137.7"),
)
def _(root: Path) -> None:
    path = write_good("comma2k19", root) / "processed_log/GNSS/live_gnss_ublox/value"
    v = np.load(path)
    v[30, 0] += 100.0
    _save(path, v)


# --------------------------------------------------------------------------- MDF4


@case(
    "mdf_not_mdf",
    "mdf4",
    "a text file saved with an .mf4 name",
    Refuse("drive.mf4", None, None, "an ASAM MDF file", "not a valid ASAM MDF file"),
)
def _(root: Path) -> None:
    folder_of("mdf4", root).write_text("Time,Lat\n1,2\n")


def _mdf(root: Path, wheel_unit: str = "rad/s", leave_out: tuple[str, ...] = ()) -> None:
    """The good drive as an MDF4 file written by hand: a wheel unit, signals left out."""
    from asammdf import MDF, Signal

    t = good_tables(t0_s=0.0)
    names = dict(
        zip(
            c.WHEELS,
            ("WheelSpeed_FL", "WheelSpeed_FR", "WheelSpeed_RL", "WheelSpeed_RR"),
            strict=True,
        )
    )
    mdf = MDF(version="4.10")
    tw = t.wheels[c.T_S].to_numpy()
    mdf.append(
        [
            Signal(t.wheels[w].to_numpy(), tw, name=n, unit=wheel_unit)
            for w, n in names.items()
            if n not in leave_out
        ]
    )
    tg = t.gnss[c.T_S].to_numpy()
    fixes = (
        (c.LAT_DEG, "Latitude", "deg"),
        (c.LON_DEG, "Longitude", "deg"),
        (c.N_SATS, "NumSV", ""),
    )
    mdf.append([Signal(t.gnss[k].to_numpy(), tg, name=n, unit=u) for k, n, u in fixes])
    mdf.save(folder_of("mdf4", root), overwrite=True)
    mdf.close()


@case(
    "mdf_signal_missing",
    "mdf4",
    "the map names 'WheelSpeed_RL', the file has no such signal",
    Refuse("drive.mf4", None, "WheelSpeed_RL", "a signal named 'WheelSpeed_RL'", "no such signal"),
)
def _(root: Path) -> None:
    _mdf(root, leave_out=("WheelSpeed_RL",))


@case(
    "mdf_unit_contradicts_map",
    "mdf4",
    "the wheel speeds in the file say rpm, the map says rad/s",
    Refuse("drive.mf4", None, "WheelSpeed_FL", "the unit 'rad/s'", "the file says 'rpm'"),
)
def _(root: Path) -> None:
    _mdf(root, wheel_unit="rpm")


@case(
    "mdf_time_backwards",
    "mdf4",
    "GNSS sample 21 stamped before sample 20",
    Refuse("drive.mf4 [channel group 1]", 21, "master time", "strictly increasing", "step -"),
)
def _(root: Path) -> None:
    t = good_tables()
    gnss = t.gnss.copy()
    gnss.loc[20, c.T_S] = gnss.loc[18, c.T_S]
    write_good("mdf4", root, StreamTables(t.wheels, gnss))


# --------------------------------------------------------------------------- one CSV per stream


@case(
    "csv_no_time_column",
    "csv",
    "gnss.csv has no 'Time' column",
    Refuse("gnss.csv", None, "Time", "the time column 'Time'", "no such name"),
)
def _(root: Path) -> None:
    _edit_csv(root, "gnss.csv", lambda lines: [lines[0].replace("Time", "Stamp"), *lines[1:]])


@case(
    "csv_quantity_in_no_file",
    "csv",
    "the map names 'WheelSpeed_RL', wheels.csv calls it 'WheelSpeedRearLeft'",
    Refuse("gnss.csv", None, "WheelSpeed_RL", "in exactly one stream file", "in none of them"),
)
def _(root: Path) -> None:
    _edit_csv(
        root,
        "wheels.csv",
        lambda lines: [lines[0].replace("WheelSpeed_RL", "WheelSpeedRearLeft"), *lines[1:]],
    )


@case(
    "csv_quantity_in_two_files",
    "csv",
    "wheels.csv also has a 'Latitude' column",
    Refuse("wheels.csv", None, "Latitude", "in exactly one stream file", "in 2 files"),
)
def _(root: Path) -> None:
    _edit_csv(
        root, "wheels.csv", lambda lines: [lines[0] + ",Latitude", *(x + ",0" for x in lines[1:])]
    )


@case(
    "csv_text_in_a_cell",
    "csv",
    "'fast' in the rear-left wheel speed of data row 77",
    Refuse("wheels.csv", 77, "WheelSpeed_RL", "a number", "'fast'"),
)
def _(root: Path) -> None:
    def edit(lines):
        cells = lines[77].split(",")
        cells[3] = "fast"
        lines[77] = ",".join(cells)
        return lines

    _edit_csv(root, "wheels.csv", edit)


@case(
    "csv_time_backwards",
    "csv",
    "gnss.csv data row 40 stamped 1 s early",
    Refuse("gnss.csv", 40, "Time", "strictly increasing", "step -"),
)
def _(root: Path) -> None:
    def edit(lines):
        cells = lines[40].split(",")
        cells[0] = str(float(cells[0]) - 1.0)
        lines[40] = ",".join(cells)
        return lines

    _edit_csv(root, "gnss.csv", edit)


@case(
    "csv_clock_set_back",
    "csv",
    "wheels.csv's clock set back 0.4567 s from data row 1501 on (the two stretches overlap)",
    Refuse("wheels.csv", 1501, "Time", "strictly increasing", "step -"),
)
def _(root: Path) -> None:
    t = good_tables()
    wheels = t.wheels.copy()
    wheels.loc[1500:, c.T_S] -= 0.4567
    write_good("csv", root, StreamTables(wheels, t.gnss))


@case(
    "csv_other_clock",
    "csv",
    "gnss.csv stamped in UNIX time, wheels.csv in seconds from the start",
    Refuse("gnss.csv", None, "time", "one clock", "no common stretch"),
)
def _(root: Path) -> None:
    t = good_tables()
    gnss = t.gnss.assign(**{c.T_S: t.gnss[c.T_S] + 1.5e9})
    write_good("csv", root, StreamTables(t.wheels, gnss))


@case(
    "csv_wheels_at_4_hz",
    "csv",
    "wheels.csv logged at 4 Hz: every step longer than a grid row may span",
    Refuse(
        "wheels.csv",
        None,
        "WheelSpeed_FL, WheelSpeed_FR, WheelSpeed_RL, WheelSpeed_RR",
        "max_wheel_gap_s",
        "steps of 0.25 s",
    ),
)
def _(root: Path) -> None:
    t = good_tables()
    write_good("csv", root, StreamTables(t.wheels.iloc[::25].reset_index(drop=True), t.gnss))


@case(
    "csv_time_unit_contradicts_map",
    "csv",
    "wheels.csv's time column says ms ('Time [ms]'), the map says s",
    Refuse("wheels.csv", None, "Time [ms]", "the unit 's'", "the header says 'ms'"),
)
def _(root: Path) -> None:
    def edit(lines):
        rows = [x.split(",", 1) for x in lines[1:]]
        return [lines[0].replace("Time", "Time [ms]", 1)] + [
            f"{float(t) * 1000.0!r},{rest}" for t, rest in rows
        ]

    _edit_csv(root, "wheels.csv", edit)


@case(
    "comma_wheels_at_4_hz",
    "comma2k19",
    "CAN/wheel_speed logged at 4 Hz",
    Refuse(
        "seg [CAN/wheel_speed]",
        None,
        ", ".join(
            f"value[:, {k}] ({w}, m/s)"
            for k, w in enumerate(("front left", "front right", "rear left", "rear right"))
        ),
        "10 Hz or faster",
        "steps of 0.25 s",
    ),
)
def _(root: Path) -> None:
    t = good_tables()
    write_good("comma2k19", root, StreamTables(t.wheels.iloc[::25].reset_index(drop=True), t.gnss))


@case(
    "comma_gyro_in_ns",
    "comma2k19",
    "IMU/gyro/t in ns while every other channel's t is in s",
    Refuse("seg [IMU/gyro]", None, "t", "one clock", "no common stretch"),
)
def _(root: Path) -> None:
    gyro = write_good("comma2k19", root) / "processed_log/IMU/gyro"
    gyro.mkdir(parents=True)
    t = T0_S + np.arange(0.0, 40.0, 0.01)
    _save(gyro / "t", t * 1e9)
    _save(gyro / "value", np.zeros((t.size, 3)))


@case(
    "comma_times_saved_as_float32",
    "comma2k19",
    "CAN/wheel_speed/t saved as float32: at 400000 s of boot clock, 31 ms apart at best",
    Refuse("seg/CAN/wheel_speed/t", None, "t", "saved as float64", "float32 stamps"),
)
def _(root: Path) -> None:
    t = good_tables(t0_s=400_000.0)
    path = write_good("comma2k19", root, t) / "processed_log/CAN/wheel_speed/t"
    _save(path, np.load(path).astype(np.float32))


def read_case(fmt: str, root: Path):
    """Read and resample a case's drive as a user's command would."""
    from rwhonet.data.comma2k19 import read_comma2k19
    from rwhonet.data.mdf4 import read_mdf4
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample

    target = folder_of(fmt, root)
    if fmt == "comma2k19":
        streams = read_comma2k19(target, RADIUS_M, display="seg")
    elif fmt == "mdf4":
        streams = read_mdf4(target, signal_map(with_time=False), RADIUS_M, display="drive.mf4")
    else:
        files = sorted(target.glob("*.csv")) if target.is_dir() else []
        shown = {p: p.name for p in files}
        streams = read_stream_csvs(files, signal_map(), RADIUS_M, display=shown)
    return resample(streams, nominal_radius_m=RADIUS_M)
