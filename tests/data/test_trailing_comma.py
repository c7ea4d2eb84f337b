"""Rows of data that end in a comma the header does not (a logger that writes each value and
a comma after it): read as an empty last column by every CSV reader and by predict's."""

from __future__ import annotations

import io

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.csvio import head_lines
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from support.drives import write_columnmap, write_iovnbd
from support.pipes import piped
from support.readers import refusals
from support.serving import wavy_drive

from .test_columnmap_reader import cupac_map

NOTE = "every row of data ends in a comma the header does not: an empty last column"


def _commas(path, rows=slice(1, None)) -> list[str]:
    lines = path.read_text().splitlines()
    lines[rows] = [line + "," for line in lines[rows]]
    path.write_text("\n".join(lines) + "\n")
    return lines


@pytest.mark.parametrize(
    ("text", "trailing", "short"),
    [
        (b"t,a,b\n0,1,2,\n", True, False),
        (b"t,a,b\ns,m,m\n\n0,1,2,\n", True, False),  # under a units row and a blank line
        (b"t,a,b\n0,1,2\n", False, False),
        (b"t,a,b,\n0,1,2,\n", False, False),  # the header ends in one too: as wide
        (b"t,a,b\n0,1,2,3\n", False, False),  # a fourth value: not an empty cell
        (b"t,a,b\nx,y,z,\n", False, False),  # not a row of data
        (b"t,a,b,\n0,1,2\n", False, True),  # the header ends in one its rows lack
        (b"t,a,b,\ns,m,m\n\n0,1,2\n", False, True),  # under a units row and a blank line
        (b"t,a,b,\ns,m,m,\n0,1,2\n", False, True),  # the units row ends in one too
        (b"t,a,,\n0,1,2\n", False, False),  # two empty names: not one comma too many
        (b"t,a,b,\nx,y,z\n", False, False),  # not a row of data
    ],
)
def test_a_comma_at_the_end_of_the_rows_or_the_header_is_told(tmp_path, text, trailing, short):
    path = tmp_path / "f.csv"
    path.write_bytes(text)
    head = head_lines(path)
    assert (head.trailing_cell, head.short_rows) == (trailing, short)


def _header_comma(path) -> list[str]:
    lines = path.read_text().splitlines()
    lines[0] += ","
    path.write_text("\n".join(lines) + "\n")
    return lines


HEADER_NOTE = "the header ends in a comma its rows do not: its empty last cell not read"


@pytest.mark.parametrize(("edit", "note"), [(_commas, NOTE), (_header_comma, HEADER_NOTE)])
def test_a_comma_at_the_end_of_the_rows_or_the_header_is_read_by_every_reader(tmp_path, edit, note):
    df = wavy_drive(20.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-T.csv")
    edit(path)
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    assert note in got.notes
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as f:
            lay, blocks = read_rows(f, "<stdin>", block_bytes=4096)
            streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
        np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
        assert note in lay.notes
    mapped = write_columnmap(df, tmp_path / "C-T.csv")
    want = read_columnmap_(write_columnmap(df, tmp_path / "C-A.csv"))
    edit(mapped)
    np.testing.assert_array_equal(read_columnmap_(mapped).columns[c.T_S], want.columns[c.T_S])


def read_columnmap_(path):
    from rwhonet.data.columnmap import read_columnmap

    return read_columnmap(path, cupac_map(), "cupac")


def test_a_row_without_the_comma_is_named_with_what_the_rows_hold(tmp_path):
    path = write_iovnbd(wavy_drive(20.0), tmp_path / "V-T.csv")
    lines = _commas(path, slice(1, 5))  # rows 1-4 end in a comma, the rest do not
    assert len(lines) > 10
    for err in refusals(path):
        first = err.problems[0]
        assert first.row == 5, first
        assert "30 comma-separated columns: the header's 29 and the empty one" in first.expected


def test_a_row_with_the_headers_comma_is_named_with_what_the_rows_hold(tmp_path):
    path = write_iovnbd(wavy_drive(20.0), tmp_path / "V-T.csv")
    lines = _header_comma(path)
    lines[7] += ","  # data row 7 ends in the comma the other rows lack
    path.write_text("\n".join(lines) + "\n")
    for err in refusals(path):
        first = err.problems[0]
        assert first.row == 7, first
        assert "29 comma-separated columns: the header's 30 without its empty last" in (
            first.expected
        )
