"""A row of units under the header (a second header line many loggers' CSV exports write)
read as the columns' units, by every CSV reader and by predict's."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.csvio import is_units_row, read_header, with_units
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import HEADERS, read_iovnbd
from rwhonet.errors import InputError
from support.drives import CUPAC_MAP, write_columnmap, write_iovnbd
from support.readers import refusals
from support.serving import wavy_drive

# The IO-VNBD layout's units, as a logger's units row writes them (blank: none)
IOVNBD_UNITS = [
    "",
    "s",
    "deg",
    "deg",
    "km/h",
    "deg",
    "m",
    "km/h",
    "s",
    "deg",
    *["rad/s"] * 4,
    "deg/s",
    "km/h",
    "g",
    "g",
    "",
    "",
    "",
    "rpm",
    "degC",
    "%",
    "psi",
    "%",
    "V",
    "degC",
    "%",
]


def _with_units_row(path, units) -> None:
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0], ",".join(units), *lines[1:]]) + "\n")


@pytest.mark.parametrize(
    ("cells", "units"),
    [
        (["s", "deg", "deg", "rpm", "", "count"], True),
        (["[s]", "[°]", "[km/h]", "[1/min]"], True),
        (["sec", "m/s^2", "%", "degC"], True),  # half known at least
        (["", "", ""], False),
        (["0.0", "52.4", "-1.5", "100"], False),
        (["12:00:00.1", "52.4", "N", "-1.5", "W"], False),  # a text time, letters
        (["NaN", "NaN", "NaN"], False),
        (["NA", "NA"], False),
        (["%", "V", "degC", "psi"], False),  # no unit the readers know
        (["s", "12"], False),
    ],
)
def test_a_units_row_is_told_from_a_data_row(cells, units):
    assert is_units_row(cells) is units


def test_a_unit_merges_into_its_header_cell_and_a_contradiction_is_refused():
    header = ["Time", "Speed (km/h)", "Lat"]
    assert with_units(header, ["s", "km/h", "[deg]"], "f.csv") == [
        "Time (s)",
        "Speed (km/h)",
        "Lat (deg)",
    ]
    assert with_units(header, ["s"], "f.csv") == ["Time (s)", "Speed (km/h)", "Lat"]
    assert with_units(["Coolant (degC)"], ["degC"], "f.csv") == ["Coolant (degC)"]
    with pytest.raises(InputError, match="'%'"):
        with_units(["Coolant (degC)"], ["%"], "f.csv")
    with pytest.raises(InputError) as err:
        with_units(header, ["s", "m/s", ""], "f.csv")
    (problem,) = err.value.problems
    assert (problem.file, problem.column) == ("f.csv", "Speed (km/h)") and "'m/s'" in problem.found


def test_an_iovnbd_file_with_a_units_row_reads_as_without_it_by_both_readers(tmp_path):
    """The units the layout has: the same drive, ingest's reader and predict's; the row
    numbers of a bad cell are data rows after the units row; the notes say so."""
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-U.csv")
    _with_units_row(path, IOVNBD_UNITS)
    assert read_header(path)[0] == "Sats" and read_header(path)[1] == " Time (s)"
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    assert any("a row of units under the header" in n for n in got.notes)
    lay, blocks = read_rows(io.BytesIO(path.read_bytes()), "V-U.csv", block_bytes=4096)
    streamed = [b for _, b in blocks]
    assert "a row of units under the header" in " ".join(lay.notes)
    np.testing.assert_array_equal(
        np.concatenate([b[c.OMEGA_RL] for b in streamed]), ref.columns[c.OMEGA_RL]
    )
    lines = path.read_text().splitlines()
    lines[2 + 6] = lines[2 + 6].replace(",", ",x", 1)  # data row 7: 'x' in the time
    path.write_text("\n".join(lines) + "\n")
    for err in refusals(path):
        assert err.problems[0].row == 7, err.problems[0]


def test_a_units_row_s_unit_is_honoured_or_checked(tmp_path):
    """Wheel speeds in rpm under header names without a unit: the units row says rpm and
    the IO-VNBD reader converts them, as it does 'Wheel Speed RL (rpm)'; a column map
    declaring rad/s where the units row says rpm is refused, as the header's unit is."""
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    rpm = df.assign(**{w: df[w] * 60 / (2 * np.pi) for w in c.WHEELS})
    bare = tuple(h.replace(" (rad/sec)", "") for h in HEADERS)
    path = write_iovnbd(rpm, tmp_path / "V-R.csv", bare)
    _with_units_row(path, [u if u != "rad/s" else "rpm" for u in IOVNBD_UNITS])
    got = read_iovnbd(path)
    np.testing.assert_allclose(got.columns[c.OMEGA_RL], ref.columns[c.OMEGA_RL], rtol=1e-12)
    cmap_path = write_columnmap(df, tmp_path / "C-A.csv")
    frame = pd.read_csv(cmap_path)
    units = ["", "ms", "deg", "deg", "rpm", "rpm", "rpm", "rpm", "count"]
    _with_units_row(cmap_path, units[: len(frame.columns)])
    cmap = {k: ColumnSpec(*v) for k, v in CUPAC_MAP.items()}
    raw = read_columnmap(cmap_path, cmap, "cupac")
    np.testing.assert_allclose(raw.columns[c.OMEGA_RL], df[c.OMEGA_RL], rtol=1e-12)
    wrong = cmap | {"omega_rl": ColumnSpec("WheelSpeedRL", "rad/s")}
    with pytest.raises(InputError, match="the header names the column's unit 'rpm'"):
        read_columnmap(cmap_path, wrong, "cupac")


def test_stream_csvs_with_a_units_row_read_as_without_it(tmp_path):
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from rwhonet.sim.streams import signal_map
    from support.stream_corpus import RADIUS_M, write_good

    plain = write_good("csv", tmp_path / "plain")
    ref = resample(read_stream_csvs(sorted(plain.glob("*.csv")), signal_map(), RADIUS_M))
    united = write_good("csv", tmp_path / "units")
    units = {"Time": "s", "WheelSpeed": "rad/s", "Latitude": "deg", "Longitude": "deg"}
    for path in united.glob("*.csv"):
        lines = path.read_text().splitlines()
        cells = [
            next((u for name, u in units.items() if h.startswith(name)), "")
            for h in lines[0].split(",")
        ]
        _with_units_row(path, cells)
    got = resample(read_stream_csvs(sorted(united.glob("*.csv")), signal_map(), RADIUS_M))
    for name in (c.T_S, c.LAT_DEG, c.OMEGA_RL):
        np.testing.assert_array_equal(got.drive.columns[name], ref.drive.columns[name])


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_comment_lines_before_the_header_are_skipped_by_both_readers(tmp_path, ending):
    """'#' lines before the header (a logger's version, the car, its settings; one with
    commas, one after a byte-order mark) and a row of units: the drive read as without
    them, its bad cell named by its data row, by ingest's reader and predict's (a file
    and a pipe)."""
    from support.pipes import piped

    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-C.csv")
    lines = path.read_text().splitlines()
    comments = ["\ufeff# logger v1.2", "# car: Fiesta, tyres 195/55 R15, 10 Hz", "#"]
    lines = [*comments, lines[0], ",".join(IOVNBD_UNITS), *lines[1:]]
    path.write_bytes(ending.join(lines).encode() + ending.encode())
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    assert any("3 comment line(s)" in n for n in got.notes)
    with piped(path.read_bytes()) as f:
        lay, blocks = read_rows(f, "<stdin>", block_bytes=4096)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
    assert any("3 comment line(s)" in n for n in lay.notes), lay.notes
    lines[5 + 6] = lines[5 + 6].replace(",", ",x", 1)  # data row 7
    path.write_bytes(ending.join(lines).encode() + ending.encode())
    for err in refusals(path):
        assert err.problems[0].row == 7, err.problems[0]
