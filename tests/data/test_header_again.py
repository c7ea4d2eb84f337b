"""The header's line again among the rows (a logger that writes its header each time it
starts, appending to one file; a drive's files joined with ``cat``): dropped by every 10 Hz
reader and by predict's, the rows after it read, messages still naming the file's rows."""

from __future__ import annotations

import io
from datetime import UTC, datetime

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.csvio import header_again_rows, read_numeric_rows
from rwhonet.data.droprows import FileRows, drop_rows, manifest_rows
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError
from support.drives import write_columnmap, write_iovnbd
from support.pipes import piped
from support.readers import refusals
from support.serving import wavy_drive

from .test_columnmap_reader import cupac_map

NOTE = "the header line again in"


def _joined(path, at: list[int], units: str | None = None) -> list[str]:
    """The file's lines with its header line (and ``units`` under it) written again before
    each data row of ``at`` (1-based, as the file numbers them before the edit)."""
    lines = path.read_text().splitlines()
    head, data = lines[:1] + ([units] if units is not None else []), lines[1:]
    out, start = list(head), 0
    for row in sorted(at):
        out += data[start : row - 1] + head
        start = row - 1
    out += data[start:]
    path.write_text("\n".join(out) + "\n")
    return out


def _read_as(path, ref, header_rows: list[int]) -> None:
    """Ingest's reader and predict's read ``path`` as the drive ``ref``, the rows
    ``header_rows`` (the header's line again) dropped."""
    got = read_iovnbd(path)
    assert got.header_rows.tolist() == header_rows
    np.testing.assert_array_equal(got.columns[c.T_S], ref.columns[c.T_S])
    with io.BytesIO(path.read_bytes()) as f:
        _, blocks = read_rows(f, path.name, block_bytes=2048)
        streamed = np.concatenate([b[c.T_S] for _, b in blocks])
    np.testing.assert_allclose(streamed, ref.columns[c.T_S])


@pytest.mark.parametrize(
    ("text", "rows"),
    [
        (b"t,a\n1,2\nt,a\n3,4\n", [2]),
        (b"t,a\r\n1,2\r\n\r\n \xef\xbb\xbft,a \r\n3,4\r\n", [2]),  # CR LF, a blank line, a BOM
        (b"t,a\ns,m\n1,2\nt,a\ns,m\n3,4\n", [2, 3]),  # its units row under it too
        (b"t,a\n1,2\nt,a\n\ns,m\n3,4\n", [2]),  # a units row the file's header lacks: data
        (b"t,a\n1,2\nt,a,b\n3,4\n", []),  # not the header's line
        (b"t,a\n1,2\n3,4\n", []),
        (b"# logger v2\nt,a\n1,2\nt,a\n3,4\n", [2]),  # after comment lines
    ],
)
def test_the_header_again_is_told_line_by_line(tmp_path, text, rows):
    path = tmp_path / "f.csv"
    path.write_bytes(text)
    assert header_again_rows(path).tolist() == rows


def test_a_drive_in_three_files_joined_reads_as_the_drive(tmp_path):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-T.csv")
    _joined(path, [101, 201])
    got = read_iovnbd(path)
    assert got.header_rows.tolist() == [101, 202]
    for name in ref.columns:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    assert any(NOTE in note and "(101, 202)" in note for note in got.notes)
    assert manifest_rows(got) == {"header_rows": [101, 202]}
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as f:
            lay, blocks = read_rows(f, "<stdin>", block_bytes=2048)
            blocks = list(blocks)
        # each block is consecutive rows of the file: none spans a header line
        rows = np.concatenate([first + np.arange(len(b[c.T_S])) for first, b in blocks])
        assert not {101, 202} & set(rows.tolist())
        assert rows.size == ref.n_rows and rows[-1] == ref.n_rows + 2
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
        np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
        assert any(NOTE in note for note in lay.notes)


def test_rows_after_the_header_again_are_named_as_the_file_numbers_them(tmp_path):
    path = write_iovnbd(wavy_drive(30.0), tmp_path / "V-T.csv")
    lines = _joined(path, [101])
    cells = lines[150].split(",")  # data row 150 of the file (the header again is row 101)
    cells[12] = "fast"  # the rear-left wheel speed
    lines[150] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    for err in refusals(path):
        (problem,) = err.problems
        assert (problem.row, problem.found) == (150, "'fast'"), problem


def test_rows_dropped_after_the_header_again_are_the_file_rows(tmp_path):
    path = write_iovnbd(wavy_drive(30.0), tmp_path / "V-T.csv")
    lines = _joined(path, [101])
    lines.insert(151, lines[150])  # data row 150 written twice: row 151 its copy
    cells = lines[200].split(",")
    cells[12] = ""  # data row 200 without its rear-left wheel speed
    lines[200] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    raw = read_iovnbd(path)
    dropped = drop_rows(raw, path.name)
    assert manifest_rows(dropped) == {
        "repeated_rows": [151],
        "wheelless_rows": [200],
        "header_rows": [101],
    }
    rows = FileRows.of(manifest_rows(dropped))
    np.testing.assert_array_equal(
        rows(np.array([0, 99, 100, 148, 149, 196])), [1, 100, 102, 150, 152, 199]
    )
    assert rows.header_between(100) == 101 and rows.header_between(101) is None


def test_the_units_row_under_the_header_again_is_dropped_with_it(tmp_path):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-T.csv")
    units = ",".join(["count", "s", "deg", "deg"] + [""] * 25)
    _joined(path, [101], units)
    _read_as(path, ref, [101, 102])


def test_text_times_and_a_column_map_read_past_the_header_again(tmp_path):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-T.csv")
    lines = path.read_text().splitlines()
    for i in range(1, len(lines)):
        cells = lines[i].split(",")
        stamp = datetime.fromtimestamp(1.5e9 + float(cells[1]), UTC)
        cells[1] = stamp.isoformat(timespec="milliseconds").replace("+00:00", "Z")
        lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    _joined(path, [50, 250])
    got = read_iovnbd(path)
    assert got.header_rows.tolist() == [50, 251]
    np.testing.assert_allclose(got.columns[c.T_S] - 1.5e9, ref.columns[c.T_S], atol=1e-6)

    from rwhonet.data.columnmap import read_columnmap

    want = read_columnmap(write_columnmap(df, tmp_path / "C-A.csv"), cupac_map(), "cupac")
    mapped = write_columnmap(df, tmp_path / "C-T.csv")
    _joined(mapped, [77])
    got = read_columnmap(mapped, cupac_map(), "cupac")
    assert got.header_rows.tolist() == [77]
    np.testing.assert_array_equal(got.columns[c.OMEGA_FL], want.columns[c.OMEGA_FL])


def test_rows_that_end_in_a_comma_and_the_header_again_without_one(tmp_path):
    df = wavy_drive(20.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-T.csv")
    lines = path.read_text().splitlines()
    lines[1:] = [line + "," for line in lines[1:]]
    lines.insert(60, lines[0])  # the header, as the logger writes it: no comma at its end
    path.write_text("\n".join(lines) + "\n")
    _read_as(path, ref, [60])


def test_text_times_in_rows_that_end_in_a_comma_past_the_header_again(tmp_path):
    path = tmp_path / "V-T.csv"
    rows = [
        f"2019-03-11T12:00:{i / 10:04.1f}Z,52.4,-1.5,{','.join(['50'] * 4)}," for i in range(30)
    ]
    header = "Time,Lat,Long,ws_fl,ws_fr,ws_rl,ws_rr"
    path.write_text("\n".join([header, *rows[:10], header, *rows[10:]]) + "\n")
    got = read_iovnbd(path)
    assert got.header_rows.tolist() == [11]
    np.testing.assert_allclose(np.diff(got.columns[c.T_S]), 0.1, atol=1e-6)
    assert got.n_rows == 30


@pytest.mark.parametrize("text", [b"t,lat\nt,lat\n", b"t,lat\nt,lat\n\nt,lat"])
def test_a_file_of_its_header_again_only_has_no_data_rows(tmp_path, text):
    path = tmp_path / "f.csv"
    path.write_bytes(text)
    with pytest.raises(InputError) as err:
        read_numeric_rows(path, 2, {0: "t", 1: "lat"})
    assert "at least one data row" in err.value.problems[0].expected
    drive = write_iovnbd(wavy_drive(2.0), tmp_path / "V-T.csv")
    header = drive.read_text().splitlines()[0]
    drive.write_text(f"{header}\n{header}\n\n{header}\n")
    for refused in refusals(drive):
        assert "at least one data row" in refused.problems[0].expected


def test_a_stream_csv_with_its_header_again_reads_as_the_file_without_it(tmp_path):
    """A stream CSV whose logger wrote its header again (files of one stream joined, a
    restart appending to the file): the line dropped, the samples the clean file's; where
    the clock restarted with the logger, refused naming the file's row after the line."""
    from support.stream_corpus import folder_of, read_case, write_good

    write_good("csv", tmp_path / "clean")
    clean = read_case("csv", tmp_path / "clean")
    for case in ("joined", "restarted"):
        write_good("csv", tmp_path / case)
        path = folder_of("csv", tmp_path / case) / "wheels.csv"
        lines = path.read_text().splitlines()
        after = lines[1501:]
        if case == "restarted":  # the logger's clock from 0 again: 1,015 s back
            after = [
                ",".join([f"{float(x.split(',')[0]) - 1015.0:.2f}", *x.split(",")[1:]])
                for x in after
            ]
        path.write_text("\n".join([*lines[:1501], lines[0], *after]) + "\n")
        if case == "restarted":
            with pytest.raises(InputError) as err:
                read_case("csv", tmp_path / case)
            (p,) = err.value.problems
            assert (p.file, p.row, p.column) == ("wheels.csv", 1502, "Time")
            continue
        got = read_case("csv", tmp_path / case)
        for name, values in clean.drive.columns.items():
            np.testing.assert_array_equal(got.drive.columns[name], values)
        assert any("wheels.csv: " + NOTE + " 1 data row(s) (1501)" in n for n in got.drive.notes)
        assert any(NOTE in n for n in got.lost)  # said by predict too, as a 10 Hz file's


@pytest.mark.parametrize("change", ["reordered", "added"])
def test_a_stream_csv_whose_logger_restarted_with_other_columns_is_refused_at_that_line(
    tmp_path, change
):
    """A logger that restarted with another configuration, appending to its file: the
    header line again with two wheels' columns in the other order (the rows after it
    would be read into each other's columns) or with a column added (every row after it
    one cell wider). Refused at that line, naming it and how to split the file (first,
    before the wider rows after it); split as it says (two parts of the stream, each
    under its own header), the folder reads as the clean drive."""
    from support.stream_corpus import folder_of, read_case, write_good

    write_good("csv", tmp_path / "clean")
    clean = read_case("csv", tmp_path / "clean")
    write_good("csv", tmp_path / change)
    path = folder_of("csv", tmp_path / change) / "wheels.csv"
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    if change == "reordered":
        order = [0, 2, 1, 3, 4]  # front right before front left
        second = [",".join(head[i] for i in order)]
        second += [",".join(x.split(",")[i] for i in order) for x in lines[1501:]]
    else:
        second = [lines[0] + ",Brake"] + [x + ",0" for x in lines[1501:]]
    path.write_text("\n".join([*lines[:1501], *second]) + "\n")
    with pytest.raises(InputError) as err:
        read_case("csv", tmp_path / change)
    p, *after = err.value.problems  # added: the rows after it, a cell wider, listed after it
    assert all(q.expected.startswith("5 comma-separated") for q in after) and bool(after) == (
        change == "added"
    )
    assert (p.file, p.row, p.column) == ("wheels.csv", 1501, None)
    assert p.found.startswith("a header line again with other columns or another order: ")
    assert second[0].split(",")[1] in p.found
    assert p.fix.startswith("split the file at this row, each part under its own header")
    path.write_text("\n".join(lines[:1501]) + "\n")  # split as the fix says
    path.with_name("wheels_2.csv").write_text("\n".join(second) + "\n")
    got = read_case("csv", tmp_path / change)
    for name, values in clean.drive.columns.items():
        np.testing.assert_array_equal(got.drive.columns[name], values)


def test_a_10_hz_file_s_header_again_in_another_order_is_refused_by_ingest_and_predict(tmp_path):
    """An IO-VNBD file whose logger restarted with the latitude and the time in each
    other's places: ingest's reader and predict's (block by block) refuse it at that line
    alone, in the same words; the header again in its own order is still dropped."""
    path = write_iovnbd(wavy_drive(30.0), tmp_path / "V-T.csv")
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    order = [0, 2, 1, *range(3, len(head))]  # Lat before Time
    second = [",".join(head[i] for i in order)]
    second += [",".join(x.split(",")[i] for i in order) for x in lines[151:]]
    path.write_text("\n".join([*lines[:151], *second]) + "\n")
    for err in refusals(path):
        (p,) = err.problems
        assert (p.row, p.column) == (151, None), p
        assert p.found.startswith("a header line again with other columns or another order")
        assert p.fix.startswith("split the file at this row")
