"""IO-VNBD reader: header matching, position fallback, unit conversion, structural errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.iovnbd import HEADERS, LAYOUT, LayoutError, locate_columns, read_iovnbd
from rwhonet.errors import InputError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "iovnbd" / "V-T1.csv"


def _lines() -> list[str]:
    return FIXTURE.read_text(encoding="utf-8").splitlines()


def _write(tmp_path: Path, lines: list[str], name: str = "V-X.csv") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _cells(line: str) -> list[str]:
    return line.split(",")


def test_reads_real_header_names_and_converts_units():
    raw = read_iovnbd(FIXTURE)
    assert raw.header_match == "name"
    assert raw.n_rows == 12
    cols = raw.columns
    # Row 3 of the file (0-based 2), values as written in the fixture.
    assert cols[c.T_S][2] == pytest.approx(45000.2)
    assert cols[c.LAT_DEG][2] == pytest.approx(52.400024, abs=1e-9)
    assert cols[c.LON_DEG][2] == pytest.approx(-1.499984, abs=1e-9)
    assert cols[c.OMEGA_RL][2] == 50.33 and cols[c.OMEGA_RR][2] == 50.35
    assert cols[c.N_SATS][0] == 9
    assert cols[c.SPEED_GNSS_M_S][0] == pytest.approx(15.0)  # 54 km/h
    assert cols[c.HEIGHT_M][0] == pytest.approx(85.0)  # 0.085 km
    assert cols[c.YAW_RATE_RAD_S][0] == pytest.approx(2.0 * math.pi / 180.0)
    assert cols[c.ACC_LON_M_S2][0] == pytest.approx(0.01 * 9.80665)
    # The file's own column names (leading space and all) are kept for messages.
    assert raw.source_columns[c.LAT_DEG] == " Lat"
    assert raw.source_columns[c.OMEGA_RL] == " Wheel Speed Rear Left (rad/sec)"


def test_header_names_match_stripped_and_case_insensitive_in_any_order(tmp_path):
    lines = _lines()
    order = list(reversed(range(len(HEADERS))))
    rows = [",".join(np.array(_cells(line))[order]) for line in lines]
    rows[0] = ",".join(f"  {h.strip().upper()} " for h in rows[0].split(","))
    raw = read_iovnbd(_write(tmp_path, rows))
    assert raw.header_match == "name"
    np.testing.assert_array_equal(raw.columns[c.OMEGA_RR], read_iovnbd(FIXTURE).columns[c.OMEGA_RR])


def test_unknown_header_falls_back_to_position(tmp_path):
    lines = _lines()
    lines[0] = ",".join(f"channel {i}" for i in range(len(HEADERS)))
    raw = read_iovnbd(_write(tmp_path, lines))
    assert raw.header_match == "position"
    expected = read_iovnbd(FIXTURE)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(raw.columns[name], expected.columns[name])
    assert raw.source_columns[c.T_S] == "channel 1"


def test_locate_columns_refuses_positions_when_known_names_moved():
    header = list(HEADERS)
    header[2], header[3] = "Breite", "Laenge"  # unknown names: position would be fine...
    assert locate_columns(header)[1] == "position"
    header[10], header[11] = header[11], header[10]  # ...but known names out of place are not
    with pytest.raises(LayoutError, match="other positions"):
        locate_columns(header)


def test_locate_columns_rejects_duplicated_names():
    with pytest.raises(LayoutError, match="more than once"):
        locate_columns([*HEADERS, " Lat"])


def test_missing_column_names_file_and_column(tmp_path):
    lines = [",".join(_cells(line)[:2] + _cells(line)[3:]) for line in _lines()]  # drop " Lat"
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, lines))
    (problem,) = err.value.problems
    assert problem.file.endswith("V-X.csv") and problem.column == "Lat"
    assert "a column named 'Lat'" in problem.expected
    assert "28 columns" in problem.found
    assert "'Long'" in err.value.summary and "'Lat'" not in err.value.summary


def test_every_non_numeric_cell_is_listed_with_row_and_column(tmp_path):
    lines = _lines()
    cells = _cells(lines[3])
    cells[2] = "52.4x"  # data row 3, " Lat"
    lines[3] = ",".join(cells)
    cells = _cells(lines[7])
    cells[12] = "fast"  # data row 7, rear-left wheel speed
    lines[7] = ",".join(cells)
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, lines))
    found = {(p.row, p.column, p.expected, p.found) for p in err.value.problems}
    assert found == {
        (3, " Lat", "a number", "'52.4x'"),
        (7, " Wheel Speed Rear Left (rad/sec)", "a number", "'fast'"),
    }
    assert "V-X.csv, row 3, column ' Lat': expected a number; found '52.4x'" in str(err.value)


def test_wrong_column_count_is_listed_with_row(tmp_path):
    lines = _lines()
    lines[5] = ",".join(_cells(lines[5])[:20])
    lines[9] = lines[9] + ",1,2"
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, lines))
    rows = {(p.row, p.found.split(":")[0]) for p in err.value.problems}
    assert rows == {(5, "20 column(s)"), (9, "31 column(s)")}
    assert all("29 comma-separated columns" in p.expected for p in err.value.problems)


def test_bad_cells_and_bad_rows_together_keep_true_row_numbers(tmp_path):
    lines = _lines()
    lines[2] = ",".join(_cells(lines[2])[:5])  # data row 2: short row, skipped by pyarrow
    cells = _cells(lines[6])
    cells[1] = "noon"  # data row 6
    lines[6] = ",".join(cells)
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, lines))
    assert {(p.row, p.column) for p in err.value.problems} == {(2, None), (6, " Time")}


def test_many_bad_cells_are_capped_with_a_count(tmp_path):
    lines = _lines()
    for i in range(1, len(lines)):
        cells = _cells(lines[i])
        cells[13] = "n/a!"
        lines[i] = ",".join(cells)
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, lines))
    problems = err.value.problems
    assert [p.row for p in problems] == [1, 2, 3, 4, 5, None]
    assert "7 more row(s)" in problems[-1].found and "rows 6-12" in problems[-1].found


def test_empty_cells_become_nan_for_validate_to_report(tmp_path):
    lines = _lines()
    cells = _cells(lines[4])
    cells[2] = ""
    cells[10] = "NaN"
    lines[4] = ",".join(cells)
    raw = read_iovnbd(_write(tmp_path, lines))
    assert np.isnan(raw.columns[c.LAT_DEG][3]) and np.isnan(raw.columns[c.OMEGA_FL][3])


@pytest.mark.parametrize(
    ("text", "found"), [("", "an empty file"), (",".join(HEADERS) + "\n", "none")]
)
def test_empty_file_and_header_only(tmp_path, text, found):
    path = tmp_path / "V-E.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_iovnbd(path)
    (problem,) = err.value.problems
    assert problem.file.endswith("V-E.csv") and problem.found == found


def test_layout_has_29_columns_and_all_required_channels():
    assert len(LAYOUT) == 29
    assert set(c.REQUIRED) <= {col.canonical for col in LAYOUT}


def test_file_without_header_row_is_refused_not_shortened(tmp_path):
    with pytest.raises(InputError) as err:
        read_iovnbd(_write(tmp_path, _lines()[1:]))
    (problem,) = err.value.problems
    assert problem.expected.startswith("a header row first") and "29 numbers" in problem.found


def test_nmea_fields_named_in_the_header_are_unpacked_by_both_readers(tmp_path):
    """'Time (hhmmss.ss)', 'Lat (ddmm.mmmm)', 'Long (ddmm.mmmm)': the header names NMEA's
    packed fields, and ingest's reader and predict's give the drive in seconds and degrees;
    a minute of 60 or more is refused with its row, the header named as the declaration;
    a packed unit on a channel that has none (a heading) is refused as any unknown unit."""
    import io

    import pandas as pd

    from rwhonet.data.incremental import read_rows
    from support.drives import as_ddmm, as_hhmmss, write_iovnbd
    from support.serving import wavy_drive

    ref_path = write_iovnbd(wavy_drive(30.0), tmp_path / "V-Deg.csv")
    ref = read_iovnbd(ref_path)
    frame = pd.read_csv(ref_path)
    frame[" Lat"], frame[" Long"] = as_ddmm(frame[" Lat"]), as_ddmm(frame[" Long"])
    frame[" Time"] = as_hhmmss(frame[" Time"], decimals=6)
    frame = frame.rename(
        columns={
            " Time": " Time (hhmmss.ss)",
            " Lat": " Lat (ddmm.mmmm)",
            " Long": " Long [ddmm.mmmm]",
        }
    )
    frame.to_csv(tmp_path / "V-Nmea.csv", index=False)
    got = read_iovnbd(tmp_path / "V-Nmea.csv")
    assert got.header_match == "name"
    for name in (c.T_S, c.LAT_DEG, c.LON_DEG, c.OMEGA_RL):
        np.testing.assert_allclose(got.columns[name], ref.columns[name], rtol=0, atol=1e-9)
    _, blocks = read_rows(io.BytesIO((tmp_path / "V-Nmea.csv").read_bytes()), "v", "iovnbd")
    streamed = list(blocks)
    for name in (c.T_S, c.LAT_DEG, c.LON_DEG):
        values = np.concatenate([b[name] for _, b in streamed])
        np.testing.assert_allclose(values, ref.columns[name], rtol=0, atol=1e-9)
    frame.loc[11, " Long [ddmm.mmmm]"] = -160.5
    frame.to_csv(tmp_path / "V-Bad.csv", index=False)
    with pytest.raises(InputError) as err:
        read_iovnbd(tmp_path / "V-Bad.csv")
    (problem,) = err.value.problems
    assert (problem.row, problem.column, problem.found) == (12, "Long [ddmm.mmmm]", "-160.5")
    assert "its header 'Long [ddmm.mmmm]' declares 'ddmm'" in (problem.fix or "")
    frame = frame.rename(columns={" Heading": " Heading (ddmm.mmmm)"})
    frame.to_csv(tmp_path / "V-Heading.csv", index=False)
    with pytest.raises(InputError, match=r"expected a unit of angle \(deg\)"):
        read_iovnbd(tmp_path / "V-Heading.csv")
