"""The bad-input corpus: corrupted copies of a good drive, each with the behaviour it must get.

Every case writes one target test drive, ``target_test/C-X1.csv``, under a raw
folder that otherwise holds good drives (:func:`write_good_fleet`), plus, for
some, params overrides (a role glob, a column map, a size limit). Its
expectation says what the data stages must do with it:

- :class:`Refuse`: the stage (``params``, ``ingest`` or ``validate``) stops with
  an :class:`~rwhonet.errors.InputError` (a :class:`~rwhonet.config.ConfigError`
  for ``params``) whose problems name the file, the row (where there is one),
  the column, what was expected and what was found, and say what to do;
- :class:`Repair`: validate cuts the bad stretch by a rule, listed in the
  validation report, and the rest of the drive goes on to label;
- :class:`Accept`: the drive goes through validate and label as it is.

``tests/data/bad/test_corpus.py`` runs every case through the real stage
functions; ``tests/data/bad/make_corpus.py`` writes the files out for a look;
``docs/reliability.md`` is the table of it (its counts are checked against
:func:`counts`).
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
from geographiclib.geodesic import Geodesic

from rwhonet.data import canonical as c
from rwhonet.data.iovnbd import HEADERS
from support.drives import (
    CUPAC_MAP,
    SOURCE_RADIUS_M,
    TARGET_RADIUS_M,
    VBO_MAP,
    as_ddmm,
    as_hhmmss,
    column_map_params,
    straight_drive,
    with_held_fixes,
    write_columnmap,
    write_iovnbd,
    write_vbo,
    written_again,
    written_twice,
)

DRIVE = "C-X1"  # the corrupted drive's id
FILE = f"{DRIVE}.csv"
DURATION_S = 150.0  # > max(adapt.m_grid) + min(evaluate.outages_s) = 130 s of the real params
T0 = 45000.0


@dataclass(frozen=True)
class Refuse:
    """The stage stops; one of its problems must match all of these."""

    stage: str  # "params" | "ingest" | "validate"
    row: int | None  # the 1-based data row of the first problem of the check, None: file-wide
    column: str | None  # the file's column name ("" when the file is a folder or params)
    expected: str  # a substring of Problem.expected (of the ConfigError message for params)
    found: str  # a substring of Problem.found
    file: str = FILE  # the file the problem names (its name only)

    kind = "refused"


@dataclass(frozen=True)
class Repair:
    """Validate cuts ``seconds`` (at least) of the drive by ``rule``; the rest is kept."""

    rule: str
    seconds: int
    kind = "repaired"


@dataclass(frozen=True)
class Accept:
    """The drive goes through validate and label unchanged."""

    note: str
    # seconds validate cuts as partial: the drive's first lone row's; a row lost at the end
    # leaves its last second short too
    partial_seconds: int = 1
    kind = "accepted"


@dataclass(frozen=True)
class Case:
    """One bad (or tricky but valid) input."""

    name: str
    corruption: str  # what is wrong with it, for the docs table
    write: Callable[[Path], None]  # writes target_test/C-X1.csv (and more) under a raw root
    expect: Refuse | Repair | Accept
    overrides: dict = field(default_factory=dict)  # params overrides, dotted keys


CASES: list[Case] = []
# Cases also run through the stage scripts (tests/data/bad/test_corpus.py::test_stage_scripts).
SCRIPT_CASES = (
    "text_in_a_number_cell",
    "negated_wheel_speeds",
    "target_test_60s",
    "params_unknown_key",
    "params_wrong_type",
    "windows_line_endings_and_bom",
)


def case(name: str, corruption: str, expect, **overrides):
    """Register the decorated writer as a corpus case."""

    def register(write: Callable[[Path], None]) -> Callable[[Path], None]:
        CASES.append(Case(name, corruption, write, expect, overrides))
        return write

    return register


def counts() -> dict[str, int]:
    """How many cases the corpus has, and how many of each behaviour."""
    out = {"tried": len(CASES), "refused": 0, "repaired": 0, "accepted": 0}
    for x in CASES:
        out[x.expect.kind] += 1
    return out


# --------------------------------------------------------------------------- good drives


def write_good_fleet(raw: Path) -> None:
    """The good drives around the corrupted one: a source_train and a target_train drive."""
    for name, data in _good_fleet().items():
        (raw / name).parent.mkdir(parents=True, exist_ok=True)
        (raw / name).write_bytes(data)


@lru_cache(maxsize=1)
def _good_fleet() -> dict[str, bytes]:
    drives = {
        "source_train/V-S1.csv": _good(60.0, SOURCE_RADIUS_M, 52.40, 30.0),
        "target_train/C-A1.csv": _good(60.0, TARGET_RADIUS_M, 52.42, 100.0),
    }
    with tempfile.TemporaryDirectory() as tmp:
        return {
            name: write_iovnbd(df, Path(tmp) / name.replace("/", "_")).read_bytes()
            for name, df in drives.items()
        }


@lru_cache(maxsize=8)
def _good(duration_s: float, radius_m: float, lat0_deg: float, azimuth_deg: float) -> pd.DataFrame:
    t = 0.1 * np.arange(round(duration_s * 10) + 1)
    speed = 15.0 + 2.0 * np.sin(2.0 * np.pi * t / 40.0)  # m/s: the wheel speeds vary
    return speed_profile_drive(speed, radius_m, lat0_deg, azimuth_deg)


def good_target(duration_s: float = DURATION_S) -> pd.DataFrame:
    """The good target test drive: 13-17 m/s north-east from (52.41, -1.5), 10 Hz, from T0."""
    return _good(duration_s, TARGET_RADIUS_M, 52.41, 30.0).copy()


YAW_COLUMN = " Yaw Rate (deg/sec)"


def weaving_drive(
    duration_s: float,
    speed_m_s: float = 15.0,
    turn_rad_s: float = 0.2,
    lat0_deg: float = 52.41,
    radius_m: float = TARGET_RADIUS_M,
    fix_noise_m: float = 0.0,
    gyro_scale: float = 1.0,
    gyro_bias_rad_s: float = 0.0,
    seed: int = 0,
    track_m: float = 0.0,
    wheelbase_m: float = 0.0,
) -> pd.DataFrame:
    """A drive that weaves: yaw rate ``turn_rad_s · sin(2π t / 40 s)`` (left positive) at a
    constant speed from ``(lat0_deg, -1.5)``, 10 Hz from T0; the fixes with white noise,
    the yaw-rate column (rad/s) the true rate times ``gyro_scale`` plus a bias and, when
    the fixes are noisy, 0.002 rad/s of white noise. Every wheel turns at the car's
    speed, or with ``track_m`` each side's wheels at their own in the turns (the speed
    ± the yaw rate times half the track: ideal rolling, no load transfer); with
    ``wheelbase_m`` the front wheels ``sqrt(1 + (wheelbase · curvature)²)`` times faster
    (the front axle's wider arc about a centre level with the rear axle)."""
    from rwhonet.geo import latlon_from_offsets_deg

    rng = np.random.default_rng(seed)
    t = np.round(T0 + 0.1 * np.arange(round(duration_s * 10) + 1), 6)
    rate = turn_rad_s * np.sin(2.0 * np.pi * (t - T0) / 40.0)
    heading = np.r_[0.0, np.cumsum(0.5 * (rate[1:] + rate[:-1]) * 0.1)]  # from north, left
    # each 0.1 s step along the heading at its middle: the chord of the arc
    mid = np.r_[0.0, 0.5 * (heading[1:] + heading[:-1])]
    east = np.cumsum(speed_m_s * 0.1 * -np.sin(mid) * (np.arange(t.size) > 0))
    north = np.cumsum(speed_m_s * 0.1 * np.cos(mid) * (np.arange(t.size) > 0))
    gyro = gyro_scale * rate + gyro_bias_rad_s
    if fix_noise_m > 0.0:
        east = east + rng.normal(0.0, fix_noise_m, t.size)
        north = north + rng.normal(0.0, fix_noise_m, t.size)
        gyro = gyro + rng.normal(0.0, 0.002, t.size)
    lat, lon = latlon_from_offsets_deg(lat0_deg, -1.5, east, north)
    arc = np.sqrt(1.0 + (wheelbase_m * rate / speed_m_s) ** 2) if wheelbase_m else 1.0
    return pd.DataFrame(
        {
            c.T_S: t,
            c.LAT_DEG: lat,
            c.LON_DEG: lon,
            **{
                w: (speed_m_s + side * 0.5 * track_m * rate) / radius_m * (arc if front else 1.0)
                for w, side, front in zip(
                    c.WHEELS, (-1.0, 1.0, -1.0, 1.0), (True, True, False, False), strict=True
                )
            },
            c.N_SATS: np.full(t.size, 9.0),
            c.YAW_RATE_RAD_S: gyro,
        }
    )


def weaving_target(duration_s: float = DURATION_S) -> pd.DataFrame:
    """A target test drive that turns: 15 m/s, yaw rate 0.2 sin(2π t / 40 s) rad/s (left
    positive), from (52.41, -1.5), exact fixes; the yaw rate in its canonical unit (rad/s)."""
    return weaving_drive(duration_s)


def target_path(raw: Path) -> Path:
    return raw / "target_test" / FILE


def write_target(raw: Path, df: pd.DataFrame, headers: tuple[str, ...] = HEADERS) -> Path:
    return write_iovnbd(df, target_path(raw), headers)


def target_file(raw: Path) -> Path:
    """The corrupted drive's file as a case wrote it: ``C-X1.csv``, or the file a case
    wrote in its place (``C-X1.csv.gz``)."""
    plain = target_path(raw)
    return plain if plain.exists() else next(plain.parent.glob(f"{FILE}.*"))


def edit_lines(
    raw: Path,
    edit: Callable[[list[str]], list[str]],
    df=None,
    headers: tuple[str, ...] = HEADERS,
) -> None:
    """Write the good target drive, then edit its lines (line 0 is the header)."""
    path = write_target(raw, good_target() if df is None else df, headers)
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join(edit(lines)) + "\n", encoding="utf-8")


def rows(df: pd.DataFrame, first: int, last: int) -> pd.Series:
    """Mask of data rows ``first..last`` (1-based, inclusive) of a drive frame."""
    return (df.index >= first - 1) & (df.index <= last - 1)


def speed_profile_drive(
    speed_m_s: np.ndarray,
    radius_m: float = TARGET_RADIUS_M,
    lat0_deg: float = 52.41,
    azimuth_deg: float = 30.0,
) -> pd.DataFrame:
    """A drive along one geodesic from ``(lat0_deg, -1.5)`` with a signed speed per row.

    Negative speeds reverse along the geodesic; wheel speeds are the magnitudes ``|v| / r``,
    as ABS sensors give them. Positions are the trapezoid integral of the speed, the WPM's
    own integral, so a true radius gives labels of zero.
    """
    v = np.asarray(speed_m_s, dtype=np.float64)
    t = np.round(T0 + 0.1 * np.arange(v.size), 6)
    s = np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1]) * 0.1)]
    geo = [Geodesic.WGS84.Direct(lat0_deg, -1.5, azimuth_deg, d) for d in s]
    omega = np.abs(v) / radius_m
    return pd.DataFrame(
        {
            c.T_S: t,
            c.LAT_DEG: [g["lat2"] for g in geo],
            c.LON_DEG: [g["lon2"] for g in geo],
            **{w: omega for w in c.WHEELS},
            c.N_SATS: np.full(v.size, 9.0),
        }
    )


WHEEL_RL = " Wheel Speed Rear Left (rad/sec)"
WHEEL_RR = " Wheel Speed Rear Right (rad/sec)"
WHEEL_FL = " Wheel Speed Front Left (rad/sec)"
WHEEL_FR = " Wheel Speed Front Right (rad/sec)"
REAR_PAIR = f"{WHEEL_RL} / {WHEEL_RR}"
ALL_WHEELS = " / ".join(w.strip() for w in (WHEEL_FL, WHEEL_FR, WHEEL_RL, WHEEL_RR))


# --------------------------------------------------------------------------- ingest: the file


@case("empty_file", "0 bytes", Refuse("ingest", None, None, "a header row", "an empty file"))
def _(raw: Path) -> None:
    target_path(raw).parent.mkdir(parents=True, exist_ok=True)
    target_path(raw).write_bytes(b"")


@case(
    "header_only",
    "the header line and no data row",
    Refuse("ingest", None, None, "at least one data row", "none"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: lines[:1])


@case(
    "no_header_row",
    "the header line deleted: the file starts with data",
    Refuse("ingest", None, None, "a header row first", "a row of 29 numbers"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: lines[1:])


@case(
    "extra_cell_in_a_row",
    "data row 50 has a 30th cell (a stray comma)",
    Refuse("ingest", 50, None, "29 comma-separated columns", "30 column(s)"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [*lines[:50], lines[50] + ",7", *lines[51:]])


@case(
    "truncated_last_row",
    "the copy was cut off in the middle of the last row",
    Refuse("ingest", 1501, None, "29 comma-separated columns", "column(s)"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [*lines[:-1], lines[-1][: len(lines[-1]) // 2]])


@case(
    "every_row_ends_in_a_comma",
    "every data row ends in a comma the header does not (a logger that writes each value "
    "and a comma after it)",
    Accept("read as an empty last column, and said so in the drive's notes"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [lines[0], *(line + "," for line in lines[1:])])


@case(
    "header_ends_in_a_comma",
    "the header ends in a comma its data rows do not (a header written with a comma after "
    "each name, the rows without)",
    Accept("the header's empty last cell not read, and said so in the drive's notes"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [lines[0] + ",", *lines[1:]])


@case(
    "power_cut_after_a_whole_row",
    "the file ends in 4096 NUL bytes after its last whole row (a logger that lost power: "
    "the file's length already counted a cluster its data never reached)",
    Accept("the NUL bytes not read, and said so in the drive's notes"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    path.write_bytes(path.read_bytes() + b"\x00" * 4096)


@case(
    "power_cut_in_the_middle_of_a_row",
    "the last row cut off where 4096 NUL bytes begin (a logger that lost power while writing it)",
    Accept(
        "the NUL bytes and the row cut short (fewer cells, no line end) not read, its sample "
        "lost as a dropped one (its second cut as partial); both said in the drive's notes",
        partial_seconds=2,
    ),
)
def _(raw: Path) -> None:
    _cut_into_the_last_row(raw, b"\x00" * 4096)


def _cut_into_the_last_row(raw: Path, tail: bytes = b"") -> None:
    """The good target drive, its file ending 40 bytes into its last row, then ``tail``."""
    path = write_target(raw, good_target())
    data = path.read_bytes()
    path.write_bytes(data[: data.rstrip(b"\n").rfind(b"\n") + 40] + tail)


@case(
    "file_ends_in_the_middle_of_a_row",
    "the file ends 40 bytes into its last row, without a line end (a logger that lost power "
    "while writing it; a copy stopped part way)",
    Accept(
        "the row cut short not read, its sample lost as a dropped one (its second cut as "
        "partial); said in the drive's notes",
        partial_seconds=2,
    ),
)
def _(raw: Path) -> None:
    _cut_into_the_last_row(raw)


@case(
    "short_last_row_with_its_line_end",
    "the last row holds 3 of the 29 cells and ends in its line end (a logger that wrote part "
    "of a row, then its line end)",
    Refuse("ingest", 1501, None, "29 comma-separated columns", "3 column(s)"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    data = path.read_bytes()
    start = data.rstrip(b"\n").rfind(b"\n") + 1
    path.write_bytes(data[:start] + b",".join(data[start:].split(b",")[:3]) + b"\n")


@case(
    "decimal_commas",
    "decimal commas in a comma-separated file (a spreadsheet's locale)",
    Refuse("ingest", 1, None, "29 comma-separated columns", "column(s)"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [lines[0], *(line.replace(".", ",") for line in lines[1:])])


@case(
    "semicolon_separated",
    "';'-separated with decimal commas (a spreadsheet's locale)",
    Accept("read as the comma-separated file it stands for, ',' as the decimal mark"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [x.replace(",", ";").replace(".", ",") for x in lines])


@case(
    "missing_column",
    "the rear-left wheel speed column deleted (28 columns)",
    Refuse(
        "ingest",
        None,
        "Wheel Speed Rear Left (rad/sec)",
        "a column named 'Wheel Speed Rear Left (rad/sec)'",
        "28 columns",
    ),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [",".join(x.split(",")[:12] + x.split(",")[13:]) for x in lines])


@case(
    "renamed_header_and_extra_column",
    "' Long' renamed 'Easting' (no longitude by any known name) and a 30th column added: no "
    "name, no position to trust",
    Refuse("ingest", None, "Long", "a column named 'Long'", "no such name"),
)
def _(raw: Path) -> None:
    def edit(lines):
        head = lines[0].replace(" Long,", "Easting,") + ",Comment"
        return [head, *(x + ",ok" for x in lines[1:])]

    edit_lines(raw, edit)


@case(
    "duplicated_header_name",
    "' Height' renamed ' Lat': two columns of one name",
    Refuse("ingest", None, None, "each IO-VNBD column name once", "more than once"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda lines: [lines[0].replace(" Height,", " Lat,"), *lines[1:]])


@case(
    "text_in_a_number_cell",
    "'fast' in the rear-left wheel speed of data row 77",
    Refuse("ingest", 77, WHEEL_RL, "a number", "'fast'"),
)
def _(raw: Path) -> None:
    def edit(lines):
        cells = lines[77].split(",")
        cells[12] = "fast"
        lines[77] = ",".join(cells)
        return lines

    edit_lines(raw, edit)


@case(
    "nul_bytes_in_a_row",
    "NUL bytes inside the latitude of data row 30 (a disk or transfer error)",
    Refuse("ingest", 30, " Lat", "a number", "\\x00"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    lines = path.read_bytes().split(b"\n")
    cells = lines[30].split(b",")
    cells[2] = cells[2][:4] + b"\x00\x00" + cells[2][4:]
    lines[30] = b",".join(cells)
    path.write_bytes(b"\n".join(lines))


@case(
    "windows_1252_byte_in_a_cell",
    "a Windows-1252 byte (0x91, a curly quote) after the latitude of data row 60",
    Refuse("ingest", 60, " Lat", "a number", "52.4"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    lines = path.read_bytes().split(b"\n")
    cells = lines[60].split(b",")
    cells[2] += b"\x91"
    lines[60] = b",".join(cells)
    path.write_bytes(b"\n".join(lines))


@case(
    "non_utf8_row_with_a_stray_comma",
    "data row 80 ends in ',\\xe9' (Latin-1 text and one cell too many)",
    Refuse("ingest", 80, None, "29 comma-separated columns of UTF-8 text", "Expected 29 columns"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    lines = path.read_bytes().split(b"\n")
    lines[80] += b",\xe9"
    path.write_bytes(b"\n".join(lines))


@case(
    "two_files_joined",
    "a second drive appended with its header (row 1502 repeats the header), driven an hour "
    "earlier: its time goes back",
    Refuse(
        "validate",
        1503,
        " Time",
        "time strictly increasing",
        "the header's line again in row 1502 between them",
    ),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    lines = path.read_text(encoding="utf-8").splitlines()
    earlier = good_target()
    earlier[c.T_S] -= 3600.0
    other = write_iovnbd(earlier, path.with_name("earlier.tmp")).read_text(encoding="utf-8")
    path.with_name("earlier.tmp").unlink()
    path.write_text("\n".join(lines + other.splitlines()) + "\n", encoding="utf-8")


@case(
    "drive_file_gzip_compressed",
    "the drive kept gzip-compressed as C-X1.csv.gz (data.roles.target_test.glob "
    "'target_test/*.csv.gz'), as fleets archive them",
    Accept("read as the text it holds, its id C-X1 (the name without .csv.gz)"),
    **{
        "data.roles.target_test": {
            "glob": "target_test/*.csv.gz",
            "format": "iovnbd",
            "vehicle": "target",
            "required": True,
        }
    },
)
def _(raw: Path) -> None:
    import gzip

    path = write_target(raw, good_target())
    path.with_name(f"{FILE}.gz").write_bytes(gzip.compress(path.read_bytes(), mtime=0))
    path.unlink()


@case(
    "one_drive_in_three_files_joined",
    "a logger's three files of one drive (it starts a file every 50 s) joined with cat: the "
    "header again in rows 501 and 1002",
    Accept("the header's lines again are dropped at ingest; the drive is the one written once"),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda x: x[:501] + x[:1] + x[501:1001] + x[:1] + x[1001:])


@case(
    "logger_restarted_and_wrote_its_header_again",
    "the logger off for 30 s (data rows 601-900 not written), then its header written again "
    "as it restarted, appending to the same file, its clock (time of day) going on",
    Repair("gap", 30),
)
def _(raw: Path) -> None:
    edit_lines(raw, lambda x: x[:601] + x[:1] + x[901:], good_target(200.0))


@case(
    "logger_restarted_on_another_phase",
    "the logger off for 1.3 s, then its stamps 48 ms later in the tenth than before (its "
    "clock started again at another instant), jittered by up to 3 ms",
    # each run on its own phase of the grid (rwhonet.data.timebase.nominal_times): the
    # second run's rows keep their stamps, its seconds counted on them; the gap cut
    Repair("gap", 1),
)
def _(raw: Path) -> None:
    df = good_target(200.0)
    t = df[c.T_S].to_numpy()
    later = np.arange(t.size) >= 700
    jitter = np.random.default_rng(8).uniform(-0.003, 0.003, later.sum())
    df.loc[later, c.T_S] = np.round(t[later] + 1.3 + 0.048 + jitter, 3)
    write_target(raw, df)


@case(
    "clock_set_back_by_ntp",
    "the logger's clock stepped back 0.3 s by NTP after data row 700 (its rows stamped "
    "0.3 s earlier from row 701 on), the car driving on",
    # rwhonet.data.sampleorder.clock_set_back: the rows from row 701 on put 1 s on, the
    # fixes either side showing the car went on; the seconds around the step cut
    Repair("gap", 1),
)
def _(raw: Path) -> None:
    _clock_set_back(raw, 0.3)


def _clock_set_back(raw: Path, back_s: float) -> None:
    """The 200 s good target drive, its rows from data row 701 on stamped ``back_s``
    earlier (the logger's clock set back as the car drove on)."""
    df = good_target(200.0)
    df.loc[rows(df, 701, len(df)), c.T_S] = np.round(df[c.T_S].to_numpy()[700:] - back_s, 3)
    write_target(raw, df)


@case(
    "clock_set_back_an_hour",
    "a logger on local time, summer time ending after data row 700: its rows from row 701 "
    "on stamped an hour earlier, the car driving on",
    Repair("gap", 1),
)
def _(raw: Path) -> None:
    _clock_set_back(raw, 3600.0)


@case(
    "second_recording_appended_at_another_place",
    "a second recording appended to the first without its header, stamped 100 s before "
    "the first ended, driven 30 km away (another drive logged on another day)",
    Refuse("validate", 702, " Time", "time strictly increasing", "time goes backwards"),
)
def _(raw: Path) -> None:
    first, second = good_target(70.0), good_target(130.0)
    second[c.T_S] = np.round(second[c.T_S].to_numpy() + 70.0 - 100.0, 3)
    second[c.LAT_DEG] = second[c.LAT_DEG] + 0.27  # 30 km north
    write_target(raw, pd.concat([first, second], ignore_index=True))


@case(
    "utf16_text",
    "saved as UTF-16 ('Unicode Text')",
    Refuse("ingest", None, None, "a CSV text file", "UTF-16"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    path.write_bytes(path.read_text(encoding="utf-8").encode("utf-16"))


@case(
    "xlsx_named_csv",
    "an Excel workbook (a ZIP archive) saved with a .csv name",
    Refuse("ingest", None, None, "a ZIP archive holding one drive file", "an Excel workbook"),
)
def _(raw: Path) -> None:
    import zipfile

    target_path(raw).parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(target_path(raw), "w") as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        z.writestr("xl/workbook.xml", "<workbook/>")


@case(
    "binary_garbage",
    "random bytes (a corrupted download)",
    Refuse("ingest", None, None, "a CSV text file", "NUL bytes"),
)
def _(raw: Path) -> None:
    target_path(raw).parent.mkdir(parents=True, exist_ok=True)
    target_path(raw).write_bytes(np.random.default_rng(9).bytes(4096).replace(b"\x00", b"\x01", 0))
    data = bytearray(target_path(raw).read_bytes())
    data[10] = 0  # in the first line
    data = data.replace(b"\n", b" ")
    target_path(raw).write_bytes(bytes(data))


@case(
    "file_too_large",
    "a drive file above data.max_file_mb (here a 0.2 MB limit, the file 0.3 MB)",
    Refuse("ingest", None, None, "a drive file of at most 0.2 MB", " MB"),
    **{"data.max_file_mb": 0.2},
)
def _(raw: Path) -> None:
    write_target(raw, good_target())


@case(
    "broken_scenarios_sidecar",
    "the optional C-X1.scenarios.json holds invalid JSON",
    Refuse("ingest", None, None, "valid JSON", "Expecting", file=f"{DRIVE}.scenarios.json"),
)
def _(raw: Path) -> None:
    write_target(raw, good_target())
    (raw / "target_test" / f"{DRIVE}.scenarios.json").write_text('{"intervals": [', "utf-8")


# --------------------------------------------------------------------------- ingest: the params


@case(
    "role_glob_matches_no_file",
    "data.roles.target_test.glob '*.CSV' (upper case) matches no file",
    Refuse("ingest", None, None, "'target_test/*.CSV'", "no matching file", file="target_test"),
    **{
        "data.roles.target_test": {
            "glob": "target_test/*.CSV",
            "format": "iovnbd",
            "vehicle": "target",
            "required": True,
        }
    },
)
def _(raw: Path) -> None:
    write_target(raw, good_target())


_CUPAC_ROLE = {"glob": "target_test/*.csv", "format": "cupac", "vehicle": "target"}


@case(
    "column_map_names_a_missing_column",
    "the column map names 'WheelSpeedRL', the file calls it 'WheelSpeedRearLeft'",
    Refuse("ingest", None, "WheelSpeedRL", "data.column_maps.cupac.omega_rl", "no such name"),
    **{
        "data.column_maps.cupac": column_map_params(CUPAC_MAP),
        "data.roles.target_test": _CUPAC_ROLE,
    },
)
def _(raw: Path) -> None:
    cmap = dict(CUPAC_MAP) | {"omega_rl": ("WheelSpeedRearLeft", "rpm")}
    write_columnmap(good_target(), target_path(raw), cmap)


@case(
    "params_unknown_key",
    "params.yaml: validate.gnss.min_sat (a typo of min_sats)",
    Refuse("params", None, None, "unknown key(s) ['min_sat']", "validate.gnss", file="params.yaml"),
    **{"validate.gnss.min_sat": 4},
)
def _(raw: Path) -> None:
    write_target(raw, good_target())


@case(
    "params_wrong_type",
    "params.yaml: validate.gnss.min_sats: 'four'",
    Refuse(
        "params", None, None, "expected an integer", "validate.gnss.min_sats", file="params.yaml"
    ),
    **{"validate.gnss.min_sats": "four"},
)
def _(raw: Path) -> None:
    write_target(raw, good_target())


# --------------------------------------------------------------------------- validate: refused


@case(
    "wheel_channel_empty",
    "the rear-left wheel speed column left empty in every row (a channel not logged)",
    Refuse("ingest", None, WHEEL_RL, "a wheel speed in the rows", "no value in any of"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.OMEGA_RL] = np.nan
    write_target(raw, df)


@case(
    "wheel_speed_in_every_other_row",
    "the wheel speeds written in every other row only (a 5 Hz CAN channel in a 10 Hz file)",
    # half the rows are not lost samples: a layout, refused where it is read
    Refuse("ingest", 2, None, "the four wheel speeds in most rows", "(50 %) without all four"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[df.index % 2 == 1, list(c.WHEELS)] = np.nan
    write_target(raw, df)


@case(
    "time_not_finite",
    "'inf' in the time column of data row 40",
    Refuse("validate", 40, " Time", "a finite time in seconds", "inf"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 40, 40), c.T_S] = np.inf
    write_target(raw, df)


@case(
    "time_goes_backwards",
    "data row 300 stamped 5 s before row 299",
    Refuse("validate", 300, " Time", "time strictly increasing", "time goes backwards"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 300, 300), c.T_S] -= 5.0
    write_target(raw, df)


@case(
    "duplicated_timestamps",
    "data row 200 written twice (rows 200 and 201 identical in every cell)",
    Accept("the copy (row 201) is dropped at ingest; its notes and validate's report name it"),
)
def _(raw: Path) -> None:
    write_target(raw, written_twice(good_target(), 200))


@case(
    "block_written_again",
    "data rows 301-350 written again after row 400 (a logger that wrote a buffer again "
    "after a retry): the time goes back 10 s",
    Accept("the 50 copies (rows 401-450) are dropped at ingest; the drive is the one written once"),
)
def _(raw: Path) -> None:
    write_target(raw, written_again(good_target(), 400, 301, 350))


@case(
    "two_exports_joined_with_an_overlap",
    "two exports of the drive joined, the second starting 20 s before the first ended "
    "(rows 701-900 twice)",
    Accept("the second copy of the overlap (rows 901-1100) is dropped at ingest"),
)
def _(raw: Path) -> None:
    write_target(raw, written_again(good_target(), 900, 701, 900))


@case(
    "rows_swapped",
    "data rows 300 and 301 written in each other's place (a logger writing two buffers in turn)",
    Accept(
        "the rows put in time order at ingest; the notes name row 301, and messages the file's rows"
    ),
)
def _(raw: Path) -> None:
    df = good_target()
    order = np.arange(len(df))
    order[[299, 300]] = order[[300, 299]]
    write_target(raw, df.iloc[order].reset_index(drop=True))


def _joined_the_wrong_way(lines: list[str]) -> list[str]:
    """A drive's two exports joined with cat in the wrong order: its second half (data
    rows 751-1501), the header again, then its first half (rows 1-750)."""
    return [lines[0], *lines[751:], lines[0], *lines[1:751]]


@case(
    "two_exports_joined_in_the_wrong_order",
    "the drive's two exports joined with cat in the wrong order: its rows 751-1501, the "
    "header again (data row 752), then its rows 1-750",
    Accept("the header's line again dropped, the rows put in time order at ingest"),
)
def _(raw: Path) -> None:
    edit_lines(raw, _joined_the_wrong_way)


@case(
    "joined_in_the_wrong_order_and_a_latitude_out_of_range",
    "as two_exports_joined_in_the_wrong_order, the drive's row 100 (the file's data row 852) "
    "with a latitude of 95 deg",
    Refuse("validate", 852, " Lat", "a latitude in [-90, 90] deg", "95.0"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 100, 100), c.LAT_DEG] = 95.0
    edit_lines(raw, _joined_the_wrong_way, df)


@case(
    "rows_sorted_by_speed",
    "every row in the order of its rear-left wheel speed, fastest first (a spreadsheet's "
    "table sorted by a column)",
    Accept("the rows put in time order at ingest"),
)
def _(raw: Path) -> None:
    df = good_target()
    write_target(raw, df.iloc[np.argsort(-df[c.OMEGA_RL].to_numpy(), kind="stable")])


@case(
    "block_written_again_with_one_value_changed",
    "data rows 301-350 written again after row 400, the rear-left wheel speed of row 411 "
    "not as first written",
    Refuse("validate", 411, " Time", "time strictly increasing", "time goes backwards"),
)
def _(raw: Path) -> None:
    df = written_again(good_target(), 400, 301, 350)
    df.loc[rows(df, 411, 411), c.OMEGA_RL] += 0.01
    write_target(raw, df)


@case(
    "same_time_other_values",
    "data row 201 stamped with row 200's time, its values its own (a clock that stuck once)",
    Refuse("validate", 201, " Time", "time strictly increasing", "again (as in row 200)"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 201, 201), c.T_S] = df.loc[199, c.T_S]
    write_target(raw, df)


@case(
    "empty_cells",
    "rear-left wheel speed cells of data rows 100-102 left empty (CAN frames missed)",
    # dropped as lost samples: the two seconds they fall in are cut and split the drive
    Repair("partial_second", 2),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 100, 102), c.OMEGA_RL] = np.nan
    write_target(raw, df)


@case(
    "empty_cells_after_a_row_written_twice",
    "data row 100 written twice, then the rear-left wheel speed of data row 800 left empty",
    # the file's row (800, not the drive's 799th) is the one dropped: its second is cut
    Repair("partial_second", 1),
)
def _(raw: Path) -> None:
    df = written_twice(good_target(), 100)
    df.loc[rows(df, 800, 800), c.OMEGA_RL] = np.nan
    write_target(raw, df)


@case(
    "stuck_wheel_after_rows_written_twice",
    "data rows 100 and 600 written twice, the rear-right wheel 0 in data rows 502-701",
    # the file's rows, before and after the copy of row 600 inside the stretch (dropped)
    Refuse("validate", 502, WHEEL_RR, "each wheel turning", "(rows 502-701,"),
)
def _(raw: Path) -> None:
    df = written_twice(good_target(), 100, 600)
    df.loc[rows(df, 502, 701), c.OMEGA_RR] = 0.0
    write_target(raw, df)


@case(
    "dropped_samples",
    "two samples missing after data row 500 (a 0.3 s step)",
    Repair("partial_second", 1),
)
def _(raw: Path) -> None:
    df = good_target()
    write_target(raw, df.drop(index=[500, 501]).reset_index(drop=True))


@case(
    "five_hz",
    "sampled at 5 Hz (every other row)",
    Refuse("validate", None, " Time", "a median step of 0.1", "sampled at 5 Hz"),
)
def _(raw: Path) -> None:
    write_target(raw, good_target().iloc[::2].reset_index(drop=True))


@case(
    "time_in_ms",
    "time in milliseconds in the IO-VNBD time column",
    Refuse("validate", None, " Time", "a median step of 0.1", "time in ms instead of s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.T_S] = df[c.T_S] * 1000.0
    write_target(raw, df)


@case(
    "latitude_out_of_range",
    "latitude 95 deg in data rows 400-404",
    Refuse("validate", 400, " Lat", "a latitude in [-90, 90] deg", "95.0"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 400, 404), c.LAT_DEG] = 95.0
    write_target(raw, df)


@case(
    "longitude_out_of_range",
    "longitude 200 deg in data row 500",
    Refuse("validate", 500, " Long", "a longitude in [-180, 180] deg", "200.0"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 500, 500), c.LON_DEG] = 200.0
    write_target(raw, df)


@case(
    "latlon_swapped",
    "latitude and longitude columns swapped (both still in range near Coventry)",
    Refuse("validate", None, " Lat /  Long", "the latitude in ' Lat'", "look swapped"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[[c.LAT_DEG, c.LON_DEG]] = df[[c.LON_DEG, c.LAT_DEG]].to_numpy()
    write_target(raw, df)


@case(
    "latlon_swapped_out_of_range",
    "latitude and longitude swapped in a drive near Shanghai (latitude 121 deg)",
    Refuse("validate", None, " Lat /  Long", "the latitude in ' Lat'", "beyond ±90 deg"),
)
def _(raw: Path) -> None:
    df = straight_drive(DURATION_S, radius_m=TARGET_RADIUS_M, lat0_deg=31.2, lon0_deg=121.5)
    df[[c.LAT_DEG, c.LON_DEG]] = df[[c.LON_DEG, c.LAT_DEG]].to_numpy()
    write_target(raw, df)


@case(
    "coordinates_in_degrees_read_as_minutes",
    "latitude and longitude divided by 60: degrees that a map's 'min' or 'ddmm' read as "
    "minutes of arc",
    Refuse("validate", None, " Lat /  Long", "decimal degrees", "degrees read as minutes of arc"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[[c.LAT_DEG, c.LON_DEG]] = df[[c.LAT_DEG, c.LON_DEG]].to_numpy() / 60.0
    write_target(raw, df)


@case(
    "coordinates_in_radians",
    "latitude and longitude in radians",
    Refuse("validate", None, " Lat /  Long", "decimal degrees", "look like radians"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[[c.LAT_DEG, c.LON_DEG]] = np.radians(df[[c.LAT_DEG, c.LON_DEG]].to_numpy())
    write_target(raw, df)


@case(
    "stuck_wheel_whole_drive",
    "front-left wheel speed 0 throughout while the other three turn (issue 9)",
    Refuse("validate", 1, WHEEL_FL, "each wheel turning with the others", "stuck"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.OMEGA_FL] = 0.0
    write_target(raw, df)


@case(
    "stuck_wheel_20s",
    "rear-right wheel speed 0 for 20 s (data rows 501-700) at 15 m/s",
    Refuse("validate", 501, WHEEL_RR, "each wheel turning", "for 20 s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 501, 700), c.OMEGA_RR] = 0.0
    write_target(raw, df)


@case(
    "wheel_far_below_the_others",
    "rear-left wheel reads a fifth of the others for 10 s (a failing sensor)",
    Refuse("validate", 1001, WHEEL_RL, "each wheel turning", "stuck"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 1001, 1100), c.OMEGA_RL] *= 0.2
    write_target(raw, df)


@case(
    "no_wheel_data",
    "all four wheel speeds 0 throughout while GNSS shows 15 m/s (wheel columns left as zeros)",
    Refuse("validate", 11, ALL_WHEELS, "follow the GNSS speed", "no wheel data"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] = 0.0
    write_target(raw, df)


@case(
    "wheel_data_stops_for_30s",
    "all four wheel speeds 0 for 30 s mid-drive (a CAN channel that stopped logging)",
    Refuse("validate", 601, ALL_WHEELS, "follow the GNSS speed", "for 30 s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 601, 900), list(c.WHEELS)] = 0.0
    write_target(raw, df)


@case(
    "wheel_values_frozen_for_20s",
    "the logger repeats the last wheel speeds for 20 s while the car speeds up (stale CAN)",
    Refuse("validate", 601, ALL_WHEELS, "change with the car's speed", "stale wheel data"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 601, 800), list(c.WHEELS)] = df.loc[599, list(c.WHEELS)].to_numpy()
    write_target(raw, df)


@case(
    "negated_wheel_speeds",
    "all four wheel speeds negated (a sign error in the export) while GNSS moves on (issue 9)",
    Refuse("validate", 1, WHEEL_FL, "magnitudes >= 0", "looks negated"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] = -df[list(c.WHEELS)]
    write_target(raw, df)


@case(
    "signed_wheel_speeds",
    "a logger that signs its wheel speeds: all four negative while reversing for 5 s",
    Accept(
        "all four wheels negative together on 3 % of the moving rows: reversing, "
        "magnitudes taken, rows counted in the validation report"
    ),
)
def _(raw: Path) -> None:
    ramp = np.linspace(8.0, 0.0, 40)
    v = np.r_[
        np.full(560, 8.0), ramp, -np.full(50, 2.0), np.zeros(10), ramp[::-1], np.full(841, 8.0)
    ]
    df = speed_profile_drive(v)
    df.loc[rows(df, 601, 650), list(c.WHEELS)] *= -1.0
    write_target(raw, df)


@case(
    "one_wheel_negative",
    "the front-left wheel speed negative for 5 s while the other three turn forwards",
    Refuse("validate", 601, WHEEL_FL, "magnitudes >= 0", "not reversing"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 601, 650), c.OMEGA_FL] *= -1.0
    write_target(raw, df)


@case(
    "wheel_speeds_in_kmh",
    "wheel speeds in km/h (the linear speed) instead of rad/s",
    Refuse("validate", None, REAR_PAIR, "effective radius", "look like km/h"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] *= TARGET_RADIUS_M * 3.6  # the linear speed in km/h
    write_target(raw, df)


_KMH_WHEELS = {k: (col, "km/h") for k, (col, _) in CUPAC_MAP.items() if k.startswith("omega_")}


@case(
    "can_wheel_speeds_in_kmh_by_column_map",
    "a column-mapped CSV whose four wheel speeds are in km/h (the wheels' circumferential "
    "speeds, as many cars put them on the CAN bus), declared km/h in the map",
    Accept("divided by the car's nominal tyre radius: the drive in rad/s"),
    **{
        "data.column_maps.cupac": column_map_params(CUPAC_MAP | _KMH_WHEELS),
        "data.roles.target_test": _CUPAC_ROLE,
    },
)
def _(raw: Path) -> None:
    write_columnmap(good_target(), target_path(raw), CUPAC_MAP | _KMH_WHEELS, TARGET_RADIUS_M)


@case(
    "wheel_speeds_in_kmh_headed_so",
    "an IO-VNBD file whose wheel-speed headers say km/h ('Wheel Speed Rear Left (km/h)')",
    Refuse("ingest", None, "Wheel Speed Rear Left (km/h)", "a unit of wheel", "unit 'km/h'"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] *= TARGET_RADIUS_M * 3.6
    write_target(raw, df, tuple(h.replace("(rad/sec)", "(km/h)") for h in HEADERS))


@case(
    "wheel_speeds_in_rpm",
    "wheel speeds in rpm instead of rad/s",
    Refuse("validate", None, REAR_PAIR, "effective radius", "look like rpm"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] *= 60.0 / (2.0 * math.pi)
    write_target(raw, df)


@case(
    "wheel_speeds_in_deg_per_s",
    "wheel speeds in deg/s instead of rad/s",
    Refuse("validate", None, REAR_PAIR, "effective radius", "look like deg/s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[list(c.WHEELS)] *= 180.0 / math.pi
    write_target(raw, df)


@case(
    "wheel_speed_spike",
    "rear-left wheel speed 1e6 rad/s in data row 123: a one-row glitch past the range too",
    Repair("wheel_glitch", 1),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[rows(df, 123, 123), c.OMEGA_RL] = 1e6
    write_target(raw, df)


@case(
    "time_in_ms_by_column_map",
    "a column-mapped CSV whose map says time in s, the file has ms",
    Refuse("validate", None, "Time", "a median step of 0.1", "time in ms instead of s"),
    **{
        "data.column_maps.cupac": column_map_params(CUPAC_MAP | {"t": ("Time", "s")}),
        "data.roles.target_test": _CUPAC_ROLE,
    },
)
def _(raw: Path) -> None:
    write_columnmap(good_target(), target_path(raw), CUPAC_MAP)  # written in ms


@case(
    "target_test_60s",
    "a 60 s target test drive: adapt needs 100 s and the shortest outage 30 s more (issue 9)",
    Refuse("validate", None, None, "at least 130 GNSS-valid seconds", "keeps 60 valid s"),
)
def _(raw: Path) -> None:
    write_target(raw, good_target(60.0))


@case(
    "target_test_short_after_cuts",
    "a 200 s target test drive with 0 satellites for 100 s: 99 valid s left",
    Refuse("validate", None, None, "at least 130 GNSS-valid seconds", "low_sats 100 s"),
)
def _(raw: Path) -> None:
    df = good_target(200.0)
    df.loc[df[c.T_S].between(T0 + 50.05, T0 + 150.0), c.N_SATS] = 0.0
    write_target(raw, df)


@case(
    "no_valid_segment",
    "0 satellites throughout: nothing survives the GNSS policy",
    Refuse("validate", None, None, "at least one GNSS-valid stretch", "low_sats 150 s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.N_SATS] = 0.0
    write_target(raw, df)


@case(
    "gnss_frozen_throughout",
    "the GNSS fix never changes while the wheels turn",
    Refuse("validate", None, None, "at least one GNSS-valid stretch", "frozen"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[[c.LAT_DEG, c.LON_DEG]] = df.loc[0, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    write_target(raw, df)


# --------------------------------------------------------------------------- validate: repaired


def _long_target() -> pd.DataFrame:
    return good_target(200.0)


def faster(df: pd.DataFrame, hz: float, fix_hz: int | None = None) -> pd.DataFrame:
    """A drive logged at ``hz`` rows a second: every channel linear between its 10 Hz
    rows, the fix held from a ``fix_hz`` receiver (each fix until the next; None: a fix
    in every row)."""
    t = df[c.T_S].to_numpy()
    fast = np.round(t[0] + np.arange(round((t[-1] - t[0]) * hz) + 1) / hz, 6)
    out = pd.DataFrame({k: np.interp(fast, t, df[k].to_numpy()) for k in df.columns})
    out[c.T_S] = fast
    if fix_hz is not None:
        epoch = np.floor((fast - t[0]) * fix_hz + 1e-9) / fix_hz + t[0]
        for k in (c.LAT_DEG, c.LON_DEG):
            out[k] = np.interp(epoch, t, df[k].to_numpy())
    return out


@case(
    "logged_at_20_hz",
    "the drive logged at 20 Hz (a VBOX set to 20 Hz): every channel, the fix too, in rows "
    "every 0.05 s",
    Repair("partial_second", 2),  # read as streams, resampled: the grid's first and last
    # rows lack a whole window of samples, so the drive's first and last seconds are cut
)
def _(raw: Path) -> None:
    write_target(raw, faster(_long_target(), 20))


@case(
    "logger_loop_at_9_9_hz",
    "a logger that reads, writes its row and sleeps 0.1 s (a Python or Arduino loop): "
    "rows at 9.9 Hz, their stamps right, to the ms",
    Repair("partial_second", 2),  # read as streams at the logger's own rate, resampled:
    # the grid's first and last rows lack a whole window, their seconds cut (on the grid a
    # slot slipped every 100 rows, a second cut every 10 s: the drive was refused)
)
def _(raw: Path) -> None:
    df = faster(_long_target(), 9.9)
    df[c.T_S] = np.round(df[c.T_S], 3)
    write_target(raw, df)


@case(
    "can_table_at_50_hz_with_the_fix_held",
    "a CAN logger's table at 50 Hz: the wheel speeds in every row, the fix of a 10 Hz "
    "receiver held over five rows until the next",
    # as logged_at_20_hz, the fixes taken where they change (the first one held from before
    # the log began is no fix: its second is cut as start_fix)
    Repair("partial_second", 1),
)
def _(raw: Path) -> None:
    write_target(raw, faster(_long_target(), 50, fix_hz=10))


@case(
    "gap_30s",
    "30 s of rows missing in the middle (a logger pause)",
    Repair("gap", 30),
)
def _(raw: Path) -> None:
    df = _long_target()
    write_target(raw, df[~df[c.T_S].between(T0 + 80.05, T0 + 110.0)].reset_index(drop=True))


@case(
    "gnss_frozen_20s",
    "GNSS fix frozen for 20 s while driving",
    Repair("frozen", 20),
)
def _(raw: Path) -> None:
    df = _long_target()
    stuck = df[c.T_S].between(T0 + 80.0, T0 + 100.0)
    df.loc[stuck, [c.LAT_DEG, c.LON_DEG]] = df.loc[
        stuck.idxmax(), [c.LAT_DEG, c.LON_DEG]
    ].to_numpy()
    write_target(raw, df)


@case(
    "gnss_jump_500m",
    "one fix 500 m off (data row 801): out and back",
    Repair("jump", 1),
)
def _(raw: Path) -> None:
    df = _long_target()
    i = 800
    g = Geodesic.WGS84.Direct(df.loc[i, c.LAT_DEG], df.loc[i, c.LON_DEG], 120.0, 500.0)
    df.loc[i, [c.LAT_DEG, c.LON_DEG]] = [g["lat2"], g["lon2"]]
    write_target(raw, df)


@case(
    "zero_satellites_20s",
    "0 satellites for 20 s",
    Repair("low_sats", 20),
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[df[c.T_S].between(T0 + 60.05, T0 + 80.0), c.N_SATS] = 0.0
    write_target(raw, df)


@case(
    "no_fix_written_as_zeros",
    "20 s of latitude and longitude 0.0 (a logger's 'no fix')",
    Repair("low_sats", 20),  # no fix: cut by the rule for fixes not trusted (no_fix_rows)
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[df[c.T_S].between(T0 + 60.05, T0 + 80.0), [c.LAT_DEG, c.LON_DEG]] = 0.0
    write_target(raw, df)


@case(
    "no_fix_written_as_empty_cells",
    "20 s of latitude and longitude cells left empty (a logger's 'no fix')",
    Repair("low_sats", 20),  # an empty fix is no fix, as (0, 0) is (no_fix_rows)
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[df[c.T_S].between(T0 + 60.05, T0 + 80.0), [c.LAT_DEG, c.LON_DEG]] = np.nan
    write_target(raw, df)


@case(
    "one_empty_longitude",
    "the longitude cell of data row 1200 left empty, its latitude written",
    Repair("low_sats", 1),
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[rows(df, 1200, 1200), c.LON_DEG] = np.nan
    write_target(raw, df)


@case(
    "stuck_wheel_cut_by_hand",
    "rear-right wheel stuck for 20 s, cut with validate.cuts as the refusal advises",
    Repair("manual", 20),
    **{
        "validate.cuts": [
            {"drive": DRIVE, "start_s": T0 + 50.0, "end_s": T0 + 70.0, "reason": "stuck RR sensor"}
        ]
    },
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[df[c.T_S].between(T0 + 50.05, T0 + 70.0), c.OMEGA_RR] = 0.0
    write_target(raw, df)


@case(
    "yaw_rate_clockwise",
    "a turning drive whose yaw rate is positive turning right (a z-down gyro, SAE J670)",
    Refuse("validate", None, YAW_COLUMN, "positive turning left (ISO 8855)", "turning right"),
)
def _(raw: Path) -> None:
    df = weaving_target()
    df[c.YAW_RATE_RAD_S] = -df[c.YAW_RATE_RAD_S]
    write_target(raw, df)


@case(
    "latlon_swapped_told_by_the_turns",
    "latitude and longitude swapped on a weaving drive: every turn of the course mirrored",
    Refuse(
        "validate", None, " Lat /  Long", "the latitude in ' Lat'", "times with the two exchanged"
    ),
)
def _(raw: Path) -> None:
    df = weaving_target()
    df[[c.LAT_DEG, c.LON_DEG]] = df[[c.LON_DEG, c.LAT_DEG]].to_numpy()
    write_target(raw, df)


@case(
    "rear_wheels_left_and_right_exchanged",
    "a turning drive whose rear wheels' speeds are written to each other's columns",
    Refuse(
        "validate",
        None,
        " Wheel Speed Rear Left (rad/sec) /  Wheel Speed Rear Right (rad/sec)",
        "the rear left wheel's speed in ' Wheel Speed Rear Left (rad/sec)'",
        "the two columns look exchanged (left for right)",
    ),
)
def _(raw: Path) -> None:
    df = weaving_drive(DURATION_S, track_m=1.5)
    df[[c.OMEGA_RL, c.OMEGA_RR]] = df[[c.OMEGA_RR, c.OMEGA_RL]].to_numpy()
    write_target(raw, df)


@case(
    "front_and_rear_wheels_exchanged",
    "a drive through tight turns whose front wheels' speeds are written to the rear columns "
    "and the rear wheels' to the front (left with left, right with right)",
    Refuse(
        "validate",
        None,
        " Wheel Speed Front Left (rad/sec) /  Wheel Speed Front Right (rad/sec) /  Wheel Speed "
        "Rear Left (rad/sec) /  Wheel Speed Rear Right (rad/sec)",
        "the front axle runs on the wider arc in a turn",
        "the front and rear columns look exchanged",
    ),
)
def _(raw: Path) -> None:
    df = weaving_drive(DURATION_S, 8.0, 0.6, track_m=1.5, wheelbase_m=2.7)
    front, rear = [c.OMEGA_FL, c.OMEGA_FR], [c.OMEGA_RL, c.OMEGA_RR]
    df[front + rear] = df[rear + front].to_numpy()
    write_target(raw, df)


@case(
    "one_diagonal_pair_of_wheels_exchanged",
    "a drive through tight turns whose front left wheel's speed is written to the rear right "
    "column and the rear right's to the front left (a diagonal pair: each axle's columns "
    "then hold two wheels of one side)",
    Refuse(
        "validate",
        None,
        " Wheel Speed Front Left (rad/sec) /  Wheel Speed Rear Right (rad/sec)",
        "the front left wheel's speed in ' Wheel Speed Front Left (rad/sec)'",
        "(a diagonal pair: front left for rear right)",
    ),
)
def _(raw: Path) -> None:
    df = weaving_drive(DURATION_S, 8.0, 0.6, track_m=1.5, wheelbase_m=2.7)
    df[[c.OMEGA_FL, c.OMEGA_RR]] = df[[c.OMEGA_RR, c.OMEGA_FL]].to_numpy()
    write_target(raw, df)


@case(
    "yaw_rate_in_rad_s",
    "a turning drive whose yaw-rate column (deg/s by the layout) holds rad/s",
    Refuse("validate", None, YAW_COLUMN, "in the declared unit", "rad/s where deg/s"),
)
def _(raw: Path) -> None:
    df = weaving_target()
    df[c.YAW_RATE_RAD_S] = df[c.YAW_RATE_RAD_S] * (math.pi / 180.0)  # written as rad/s values
    write_target(raw, df)


@case(
    "yaw_rate_zeros_while_turning",
    "a turning drive whose yaw-rate column is 0 throughout (a log without a gyro)",
    Refuse("validate", None, YAW_COLUMN, "in the declared unit", "never changes"),
)
def _(raw: Path) -> None:
    df = weaving_target()
    df[c.YAW_RATE_RAD_S] = 0.0
    write_target(raw, df)


# --------------------------------------------------------------------------- accepted


@case(
    "reversing",
    "a genuine 5 s reversing manoeuvre: stop, back up at 2 m/s, drive on (speeds as magnitudes)",
    Accept("GNSS moves backwards, wheel speeds stay positive: the WPM distance matches"),
)
def _(raw: Path) -> None:
    ramp = np.linspace(8.0, 0.0, 40)
    v = np.r_[
        np.full(560, 8.0), ramp, -np.full(50, 2.0), np.zeros(10), ramp[::-1], np.full(841, 8.0)
    ]
    write_target(raw, speed_profile_drive(v))


@case(
    "standstill",
    "stopped for 30 s: all wheels 0, GNSS still",
    Accept("no wheel turns: nothing is stuck, frozen or negative"),
)
def _(raw: Path) -> None:
    v = np.r_[np.full(600, 10.0), np.zeros(300), np.full(601, 10.0)]
    write_target(raw, speed_profile_drive(v))


@case(
    "windows_line_endings_and_bom",
    "CRLF line endings and a UTF-8 byte-order mark (Excel's 'CSV UTF-8')",
    Accept("the BOM is dropped from the first header name; CRLF is a line break"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    text = path.read_text(encoding="utf-8").replace("\n", "\r\n")
    path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))


@case(
    "old_mac_line_endings",
    "CR-only line endings",
    Accept("a CR alone is a line break too"),
)
def _(raw: Path) -> None:
    path = write_target(raw, good_target())
    path.write_bytes(path.read_bytes().replace(b"\n", b"\r"))


@case(
    "renamed_headers_same_layout",
    "every header renamed ('channel 0'..'channel 28'), the 29 IO-VNBD columns in order",
    Accept("read by position; the manifest says header_match: position"),
)
def _(raw: Path) -> None:
    write_target(raw, good_target(), tuple(f"channel {i}" for i in range(len(HEADERS))))


@case(
    "quoted_cells_blank_lines_and_spaces",
    "quoted numbers, spaces around cells, a blank line at the end",
    Accept("CSV quoting and padding are read as numbers"),
)
def _(raw: Path) -> None:
    def edit(lines):
        body = [
            ",".join(f'"{x}"' if i % 2 else f" {x} " for i, x in enumerate(line.split(",")))
            for line in lines[1:]
        ]
        return [lines[0], *body, ""]

    edit_lines(raw, edit)


# the IO-VNBD columns' units (the satellite count's blank), the wheel speeds in rpm
_UNITS_ROW = (
    ",s,deg,deg,km/h,deg,m,km/h,s,deg,rpm,rpm,rpm,rpm,deg/s,km/h,g,g,,,,rpm,degC,%,psi,%,V,degC,%"
)


def _rpm_under_bare_names() -> tuple[pd.DataFrame, tuple[str, ...]]:
    """The good target drive with its wheel speeds in rpm, and the IO-VNBD headers without
    their units (a units row gives them)."""
    df = good_target()
    df[list(c.WHEELS)] *= 60.0 / (2.0 * math.pi)
    return df, tuple(h.replace(" (rad/sec)", "") for h in HEADERS)


@case(
    "units_row_under_the_header",
    "a row of units under the header (s, deg, ..., the wheel speeds in rpm under names "
    "without a unit), as many loggers' CSV exports write it",
    Accept("the row read as the columns' units: the wheel speeds converted from rpm"),
)
def _(raw: Path) -> None:
    df, bare = _rpm_under_bare_names()
    edit_lines(raw, lambda lines: [lines[0], _UNITS_ROW, *lines[1:]], df, bare)


@case(
    "comment_lines_before_the_header",
    "three lines starting with '#' before the header (the logger's version, the car with "
    "commas in it, an empty comment), as many loggers write their settings",
    Accept("the comment lines skipped; the rows numbered from the first after the header"),
)
def _(raw: Path) -> None:
    comments = ["# logger v1.2", "# car: Fiesta, 195/55 R15, 10 Hz", "#"]
    edit_lines(raw, lambda lines: [*comments, *lines])


# MoTeC i2's "Export Data" CSV: its preamble of key and value lines, two blank lines, the
# header and a row of units, a blank line, every cell quoted
_MOTEC_PREAMBLE = [
    '"Format","MoTeC CSV File",,,"Workbook",""',
    '"Venue","Coventry",,,"Worksheet",""',
    '"Device","ADL"',
    '"Log Date","14/07/2026",,,"Origin Time","0.000","s"',
    '"Sample Rate","10.000","Hz",,"End Time","150.000","s"',
    '"Beacon Markers",""',
    "",
    "",
]


def _quoted(line: str) -> str:
    return ",".join(f'"{cell}"' for cell in line.split(","))


@case(
    "motec_i2_csv_export",
    "the drive as MoTeC i2 exports a CSV: key and value lines before the header (Format, "
    "Venue, Sample Rate, ...), blank lines, a row of units (wheel speeds in rpm) and every "
    "cell quoted",
    Accept("the preamble skipped, the header found above the rows of data; rpm converted"),
)
def _(raw: Path) -> None:
    df, bare = _rpm_under_bare_names()
    edit_lines(
        raw,
        lambda lines: [
            *_MOTEC_PREAMBLE,
            *map(_quoted, [lines[0], _UNITS_ROW]),
            "",
            *map(_quoted, lines[1:]),
        ],
        df,
        bare,
    )


@case(
    "units_row_contradicts_the_header",
    "a row of units saying km/h under wheel-speed headers that say rad/sec",
    Refuse(
        "ingest", None, "Wheel Speed Rear Left (rad/sec)", "the unit the header names", "'km/h'"
    ),
)
def _(raw: Path) -> None:
    units = _UNITS_ROW.replace("rpm,rpm,rpm,rpm", "km/h,km/h,km/h,km/h", 1)
    edit_lines(raw, lambda lines: [lines[0], units, *lines[1:]])


@case(
    "reordered_variant_names_and_extras",
    "the 29 columns in reverse order under other spellings ('Latitude [deg]', 'time_s', "
    "'WheelSpeed_RL (rad/s)', ...) and two extra columns",
    Accept("columns are found by name, whatever the case, spacing and unit suffix"),
)
def _(raw: Path) -> None:
    variants = {
        " Time": "time_s",
        " Lat": "Latitude [deg]",
        " Long": "LONGITUDE",
        "Sats": "Satellites",
        " Wheel Speed Front Left (rad/sec)": "WheelSpeed_FL (rad/s)",
        " Wheel Speed Front Right (rad/sec)": "wheel speed front right",
        " Wheel Speed Rear Left (rad/sec)": "WheelSpeed_RL (rad/s)",
        " Wheel Speed Rear Right (rad/sec)": "ws_rr",
    }

    def edit(lines):
        rows = [line.split(",") for line in lines]
        rows[0] = [variants.get(h, h) for h in rows[0]]
        rows = [["extra", *reversed(r), "x"] for r in rows]
        return [",".join(r) for r in rows]

    edit_lines(raw, edit)


@case(
    "time_jitter_4ms",
    "every time stamp off by up to +-4 ms (still increasing), as CAN loggers stamp rows",
    Accept("rows are placed in their seconds by their slot on the 0.1 s grid"),
)
def _(raw: Path) -> None:
    df = good_target()
    jitter = np.random.default_rng(15).uniform(-0.004, 0.004, len(df))
    df[c.T_S] = np.round(df[c.T_S] + jitter, 4)
    write_target(raw, df)


@case(
    "time_jitter_20ms_bell_curve",
    "every time stamp off by a bell curve's jitter (sd 20 ms, to the ms): rows nearest "
    "another row's slot, stamps going back, as a busy phone or laptop logger writes them",
    Accept("each row placed in its own slot of the 0.1 s grid by the rows' order"),
)
def _(raw: Path) -> None:
    df = _bell_curve_stamps(0.02, seed=2)
    assert (np.diff(df[c.T_S]) < 0).any()  # a stamp before the one above it (seed 2: one)
    write_target(raw, df)


@case(
    "time_jitter_20ms_from_the_last_minute",
    "the stamps on their grid for 90 s, then off by a bell curve's jitter (sd 20 ms, to the "
    "ms), as a logger that gets busy during the drive writes them: rows nearest another "
    "row's slot where the drive's stamps, taken whole, hardly spread",
    Accept("each row placed in its own slot, told jittered by the rows around it"),
)
def _(raw: Path) -> None:
    df = _bell_curve_stamps(0.02, seed=5, first_row=900)
    nearest = np.rint(df[c.T_S].to_numpy() / 0.1)
    assert (np.diff(nearest) <= 0).sum() >= 3  # rows nearest another's slot, or before it
    write_target(raw, df)


def _bell_curve_stamps(sigma_s: float, seed: int, first_row: int = 0) -> pd.DataFrame:
    """The good target drive, each stamp from ``first_row`` on off by a bell curve's
    jitter, to the ms."""
    df = good_target()
    jitter = np.random.default_rng(seed).normal(0.0, sigma_s, len(df))
    jitter[:first_row] = 0.0
    df[c.T_S] = np.round(df[c.T_S] + jitter, 3)
    return df


def late_rows_before_a_restart() -> pd.DataFrame:
    """The good target drive (150 s) stamped with a bell curve's jitter of 10 ms up to
    row 476, where the logger restarted 1.348 s later (on its grid after it), and the two
    rows before it, the last of the second ending at row 470 (45047.0 s), 80 and 25 ms
    late."""
    df = good_target(150.0)
    t = df[c.T_S].to_numpy()
    jitter = np.random.default_rng(13).normal(0.0, 0.01, t.size)
    jitter[466:] = 0.0
    jitter[469], jitter[470] = 0.08, 0.025
    df[c.T_S] = np.round(t + jitter + np.where(np.arange(t.size) >= 476, 1.348, 0.0), 3)
    return df


@case(
    "time_jitter_rows_late_before_a_restart",
    "stamps off by a bell curve's jitter (sd 10 ms, to the ms), the two rows before the "
    "logger's restart 1.3 s later 80 and 25 ms late, past half a period",
    # validate cuts the gap on the whole drive's slots and writes them into the segments;
    # placed alone, the segment's last two rows took the next slots and its last second
    # was labelled 1.7 m off (until stop 70)
    Repair("gap", 1),
)
def _(raw: Path) -> None:
    write_target(raw, late_rows_before_a_restart())


def rows_leaning_into_lost_samples() -> pd.DataFrame:
    """The good target drive (200 s) stamped with a bell curve's jitter of 10 ms, and four
    rows beside a lost sample placed a slot off, each stamped 60 ms off its own slot (past
    half a period, as a bell curve of 25 ms does to 2 % of rows):

    - the drive's first row (45000.0) stamped 60 ms early: placed at 44999.9, its slot left
      empty; the second after it would start on it (the last row before the empty slot);
    - 45050.0 lost, 45050.1 stamped 60 ms early: placed at 45050.0, the end of a whole
      second;
    - 45100.0 lost, 45099.9 stamped 60 ms late: placed at 45100.0, the start of the next;
    - 45149.9 lost, 45150.0 stamped 60 ms early: placed at 45149.9, the row before a lost
      whole second, from which the second after it would start.

    Labelled on the placed times, each of those seconds is a row's travel off (the wheels
    integrated over 0.1 s more or less than the fixes span)."""
    df = good_target(200.0)
    t = df[c.T_S].to_numpy()
    jitter = np.random.default_rng(3).normal(0.0, 0.01, t.size)
    for row, off in ((0, -0.06), (501, -0.06), (999, 0.06), (1500, -0.06)):
        jitter[max(row - 1, 0) : row + 2] = 0.0  # the rows beside it on time
        jitter[row] = off
    df[c.T_S] = np.round(t + jitter, 3)
    return df.drop(index=[500, 1000, 1499]).reset_index(drop=True)


@case(
    "time_jitter_rows_leaning_into_lost_samples",
    "stamps off by a bell curve's jitter (sd 10 ms, to the ms), four rows beside a lost "
    "sample stamped 60 ms toward it, each placed in a slot beside its own at a second's "
    "edge",
    # the seconds that would start or end on such a row are cut as drop_edge; labelled on
    # it (until stop 71) each was a row's travel (1.3-1.7 m) off
    Repair("drop_edge", 4),
)
def _(raw: Path) -> None:
    write_target(raw, rows_leaning_into_lost_samples())


def hiccups_on_a_clean_logger() -> pd.DataFrame:
    """The good target drive (150 s) stamped within 2 ms of its grid (uniform, to the ms),
    but for three rows in its first 20 s written 40, 43 and 45 ms late: a logger's hiccups
    (a garbage collection, a flush to the card)."""
    df = good_target(150.0)
    t = df[c.T_S].to_numpy()
    jitter = np.random.default_rng(1).uniform(-0.002, 0.002, t.size)
    jitter[[57, 120, 181]] = [0.04, 0.043, 0.045]
    df[c.T_S] = np.round(t + jitter, 3)
    return df


@case(
    "time_hiccups_on_a_clean_logger",
    "stamps within 2 ms of their grid but three rows in the first 20 s written 40-45 ms "
    "late: a logger's hiccups",
    # the grid's phase is the middle of the arc the stamps fill, its 2 % at either end left
    # out; until stop 71 the hiccups set the arc's end, the phase moved 21.5 ms and every
    # second of the drive ended on x.9 s rows (the first and last seconds partial)
    Accept("the seconds of the drive stamped on its grid, labels within 1e-9 m"),
)
def _(raw: Path) -> None:
    write_target(raw, hiccups_on_a_clean_logger())


def rows_written_at_once_after_stalls() -> pd.DataFrame:
    """The good target drive (150 s) stamped within 2 ms of its grid (uniform, to the ms),
    by a logger that stamps rows when it writes them and stalls three times: the 2, 3 and
    4 rows up to rows 400, 800 and 1200 written at once, 1 ms apart from the last one's
    time (0.1-0.3 s late)."""
    df = good_target(150.0)
    t = df[c.T_S].to_numpy() + np.random.default_rng(2).uniform(-0.002, 0.002, len(df))
    for at, held in ((400, 2), (800, 3), (1200, 4)):
        t[at - held + 1 : at + 1] = t[at] + 0.001 * np.arange(held)
    df[c.T_S] = np.round(t, 3)
    return df


@case(
    "time_rows_written_at_once_after_stalls",
    "a logger stamping rows when it writes them stalls three times, then writes the 2-4 "
    "rows it held at once, 1 ms apart (0.1-0.3 s late)",
    # each held row fills the slot its stall left empty (rows written late: the latest
    # slot at or before its stamp's); until stop 71 two or more rows in a slot: refused
    Accept("each row in the slot its stall left, the seconds of the drive stamped on its grid"),
)
def _(raw: Path) -> None:
    write_target(raw, rows_written_at_once_after_stalls())


@case(
    "time_jitter_35ms_bell_curve",
    "every time stamp off by a bell curve's jitter of sd 35 ms: rows two slots off",
    Refuse("validate", 215, " Time", "time strictly increasing", "the stamps' jitter"),
)
def _(raw: Path) -> None:
    write_target(raw, _bell_curve_stamps(0.035, seed=15))


@case(
    "fixes_held_from_a_1_hz_receiver",
    "the fix (and course, height) of a 1 Hz receiver written into every row until the next, "
    "each arriving 0.4 s after the second",
    # placed along the wheels' path from the receiver's fixes (rwhonet.data.heldfixes);
    # the rows before its first fix and after its last have none: cut as no fix
    Repair("low_sats", 1),
)
def _(raw: Path) -> None:
    write_target(raw, with_held_fixes(good_target(), 10, 4))


@case(
    "fixes_only_in_the_rows_they_came_in",
    "a 1 Hz receiver's fix (and course, height) written only in the row it came in, 0.7 s "
    "after the second, the cells of the nine rows between empty",
    # placed along the wheels' path from the receiver's fixes (rwhonet.data.heldfixes);
    # the rows before its first fix and after its last have none: cut as no fix
    Repair("low_sats", 1),
)
def _(raw: Path) -> None:
    write_target(raw, with_held_fixes(good_target(), 10, 7, empty=True))


@case(
    "across_midnight",
    "a drive from 23:59:00 that goes on past midnight (time of day restarts at 0)",
    Accept("the reader adds a day after the rollover: one continuous clock"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.T_S] = np.round((df[c.T_S] - T0 + 86340.0) % 86400.0, 6)
    write_target(raw, df)


def _time_as_text(raw: Path, form: Callable[[float], str], df=None) -> None:
    """The good target drive with its time column (data column 1) written by ``form``."""

    times = (df if df is not None else good_target())[c.T_S]

    def edit(lines):
        out = [lines[0]]
        for line, t in zip(lines[1:], times, strict=True):
            cells = line.split(",")
            cells[1] = form(float(t))
            out.append(",".join(cells))
        return out

    edit_lines(raw, edit, df)


def _iso_utc(t: float) -> str:
    """A time of day (s) on 2019-03-11 as ISO 8601 UTC text, to the millisecond."""
    ms = round(t * 1000)
    h, rest = divmod(ms, 3_600_000)
    m, rest = divmod(rest, 60_000)
    return f"2019-03-11T{h:02d}:{m:02d}:{rest // 1000:02d}.{rest % 1000:03d}Z"


def _clock(t: float) -> str:
    ms = round(t * 1000)
    h, rest = divmod(ms, 3_600_000)
    m, rest = divmod(rest, 60_000)
    return f"{h:02d}:{m:02d}:{rest / 1000:06.3f}"


@case(
    "time_as_iso_8601_text",
    "the time column written as ISO 8601 UTC text (2019-03-11T12:30:00.100Z), as many "
    "loggers and spreadsheet exports write it",
    Accept("read as seconds since 1970 (UTC); the reader's note says so"),
)
def _(raw: Path) -> None:
    _time_as_text(raw, _iso_utc)


@case(
    "time_as_clock_text_across_midnight",
    "the time column written as hh:mm:ss.sss time of day, from 23:59:00 on past midnight",
    Accept("read as h*3600 + m*60 + s; the reader adds a day after the rollover"),
)
def _(raw: Path) -> None:
    df = good_target()
    df[c.T_S] = np.round((df[c.T_S] - T0 + 86340.0) % 86400.0, 6)
    _time_as_text(raw, _clock, df)


def _whole_clock(t: float) -> str:  # hh:mm:ss of the second a row's time falls in
    s = math.floor(t - 0.1 + 1e-6)
    return f"{s // 3600:02d}:{s % 3600 // 60:02d}:{s % 60:02d}"


@case(
    "time_as_hh_mm_ss_without_its_fraction",
    "the time column saved by a spreadsheet that shows it as hh:mm:ss: the fraction of "
    "the second lost, the ten rows of each second stamped alike",
    # rwhonet.data.timebase.coarse_places: each stamp's rows 0.1 s apart after it
    Accept("each stamp's rows placed 0.1 s apart after it, in the file's order"),
)
def _(raw: Path) -> None:
    _time_as_text(raw, _whole_clock)


@case(
    "time_to_the_second_and_a_sample_lost",
    "the time column as hh:mm:ss without its fraction, and data row 500 lost: its "
    "second's stamp holds nine rows",
    # its nine rows untimed (which was lost the stamps do not tell), left out: a gap
    Repair("gap", 2),
)
def _(raw: Path) -> None:
    df = good_target().drop(index=499).reset_index(drop=True)
    _time_as_text(raw, _whole_clock, df)


@case(
    "time_as_text_with_an_impossible_time",
    "ISO 8601 times with one impossible minute (12:61) in data row 400",
    Refuse("ingest", 400, " Time", "an ISO 8601 date and time", "'2019-03-11T12:61:"),
)
def _(raw: Path) -> None:
    def form(t: float) -> str:
        text = _iso_utc(t)
        return text.replace("T12:30:", "T12:61:") if abs(t - (T0 + 39.9)) < 1e-6 else text

    _time_as_text(raw, form)


@case(
    "extra_columns_by_name",
    "two extra columns (a comment, a GPS-time string) besides the 29 IO-VNBD ones",
    Accept("columns are found by name; the others are ignored"),
)
def _(raw: Path) -> None:
    def edit(lines):
        return [lines[0] + ",Comment,UTC", *(x + ",ok,12:00:00" for x in lines[1:])]

    edit_lines(raw, edit)


@case(
    "wheel_glitch_one_row",
    "one wheel read at 4x its speed for one 0.1 s row (data row 606): a CAN glitch",
    Repair("wheel_glitch", 1),
)
def _(raw: Path) -> None:
    df = _long_target()
    df.loc[605, c.OMEGA_RL] *= 4.0  # mid-second: its second is cut, no other
    write_target(raw, df)


@case(
    "wheel_glitch_every_second",
    "one wheel spiking to 4x its speed once in every second: a channel misbehaving throughout",
    Refuse("validate", 6, WHEEL_FR, "g above the road speed", "glitches in 150 of 151 s"),
)
def _(raw: Path) -> None:
    df = good_target()
    df.loc[5::10, c.OMEGA_FR] *= 4.0
    write_target(raw, df)


@case(
    "turning_with_a_yaw_rate",
    "a drive that turns (±0.2 rad/s), its yaw rate in deg/s positive left as the layout says",
    Accept("the GNSS course turns as the yaw rate does: gain 1 (validation report: yaw_rate)"),
)
def _(raw: Path) -> None:
    write_target(raw, weaving_target())


_NMEA_MAP = CUPAC_MAP | {
    "date": ("Date", "ddmmyy"),
    "t": ("UTC", "hhmmss"),
    "lat": ("Lat", "ddmm"),
    "lat_hemisphere": ("NS", "N/S"),
    "lon": ("Lon", "ddmm"),
    "lon_hemisphere": ("EW", "E/W"),
}


@case(
    "nmea_fields_through_a_column_map",
    "a GGA/RMC sentence's fields as columns: date as ddmmyy, UTC as hhmmss.ss, latitude and "
    "longitude as unsigned ddmm.mmmm with N/S and E/W letters (west of Greenwich)",
    Accept("the map's date, hhmmss, ddmm and hemisphere keys: the drive in seconds and degrees"),
    **{
        "data.column_maps.cupac": column_map_params(_NMEA_MAP),
        "data.roles.target_test": _CUPAC_ROLE,
    },
)
def _(raw: Path) -> None:
    df = good_target()
    path = write_columnmap(df, target_path(raw), CUPAC_MAP | {"t": ("Time", "s")})
    frame = pd.read_csv(path)
    utc = as_hhmmss(frame.pop("Time"))
    parts = {}
    for key, letters in (("Latitude", "NS"), ("Longitude", "EW")):
        deg = frame.pop(key).to_numpy()
        parts[key] = (as_ddmm(np.abs(deg)), np.where(deg < 0, *letters[::-1]))
    frame.insert(0, "Date", "110319")
    frame.insert(1, "UTC", [f"{x:.2f}" for x in utc])
    frame.insert(2, "Lat", parts["Latitude"][0])
    frame.insert(3, "NS", parts["Latitude"][1])
    frame.insert(4, "Lon", parts["Longitude"][0])
    frame.insert(5, "EW", parts["Longitude"][1])
    frame.to_csv(path, index=False)


@case(
    "racelogic_vbox_file",
    "a Racelogic VBOX file as the logger writes it (sections, space-separated values, time "
    "as hhmmss.ss, latitude and longitude in minutes, longitude positive west, CRLF, the "
    "satellite count with its DGPS and brake-trigger flags), its CAN wheel speeds in rpm",
    Accept("read through a column map as the CSV it stands for"),
    **{
        "data.column_maps.vbox": column_map_params(VBO_MAP),
        "data.roles.target_test": {**_CUPAC_ROLE, "format": "vbox"},
    },
)
def _(raw: Path) -> None:
    df = good_target()
    braking = (df.index.to_numpy() % 100 < 20) * 64  # the brake trigger, 2 s in 10
    write_vbo(df, target_path(raw), crlf=True, flags=128 + braking)


@case(
    "racelogic_vbox_satellites_as_a_plain_count",
    "a VBOX file whose satellite count carries the logger's DGPS flag (128 added: '137' is "
    "9 satellites), mapped as a plain count",
    Refuse("ingest", 1, "sats", "a satellite count below 64", "137.0"),
    **{
        "data.column_maps.vbox": column_map_params(VBO_MAP | {"n_sats": ("sats", "count")}),
        "data.roles.target_test": {**_CUPAC_ROLE, "format": "vbox"},
    },
)
def _(raw: Path) -> None:
    write_vbo(good_target(), target_path(raw), flags=128)


@case(
    "racelogic_vbox_file_as_iovnbd",
    "the same VBOX file given to the IO-VNBD reader (format iovnbd)",
    Refuse("ingest", None, None, "an IO-VNBD CSV", "a Racelogic VBOX file"),
)
def _(raw: Path) -> None:
    write_vbo(good_target(), target_path(raw))


@case(
    "yaw_rate_clockwise_declared",
    "a column-mapped CSV whose gyro is positive clockwise, declared 'deg/s cw' in the map",
    Accept("the map's unit turns it round: the GNSS course turns as the yaw rate does"),
    **{
        "data.column_maps.cupac": column_map_params(
            CUPAC_MAP | {"yaw_rate": ("YawRate", "deg/s cw")}
        ),
        "data.roles.target_test": _CUPAC_ROLE,
    },
)
def _(raw: Path) -> None:
    write_columnmap(
        weaving_target(), target_path(raw), CUPAC_MAP | {"yaw_rate": ("YawRate", "deg/s cw")}
    )
