"""A tool's preamble before the header (MoTeC i2's and AiM Race Studio's CSV exports: key
and value lines, blank lines) skipped by every CSV reader and by predict's; the header found
as the line of names above the first rows of data (``csvio.find_header``)."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.csvio import find_header, head_lines, read_head
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError
from support.drives import write_iovnbd
from support.pipes import piped
from support.readers import refusals
from support.serving import wavy_drive

from .test_units_row import IOVNBD_UNITS

# MoTeC i2's "Export Data" CSV: key and value lines of varying width, two blank lines
MOTEC = [
    '"Format","MoTeC CSV File",,,"Workbook",""',
    '"Venue","Coventry",,,"Worksheet",""',
    '"Vehicle","Fiesta",,,"Vehicle Desc",""',
    '"Driver","",,,"Engine ID",""',
    '"Device","ADL"',
    '"Comment","",,,"Session","1"',
    '"Log Date","14/07/2026",,,"Origin Time","0.000","s"',
    '"Log Time","10:00:00",,,"Start Time","0.000","s"',
    '"Sample Rate","10.000","Hz",,"End Time","30.000","s"',
    '"Duration","30.000","s",,"Start Distance","0","m"',
    '"Range","entire outing",,,"End Distance","0","m"',
    '"Beacon Markers",""',
    "",
    "",
]
# AiM Race Studio's CSV export: two-cell key and value lines, numbers among them, a
# "Time" line of names above two lines of a name and a number
AIM = [
    '"Format","AiM CSV File"',
    '"Session","Coventry"',
    '"Vehicle","Fiesta"',
    '"Racer",""',
    '"Comment",""',
    '"Date","Tuesday, July 14, 2026"',
    '"Time","10:00 AM"',
    '"Sample Rate","10"',
    '"Duration","30.000"',
    '"Segment","Session"',
    '"Beacon Markers",""',
    "",
]


def _lines(text: str) -> list[bytes]:
    return [line.encode() + b"\n" for line in text.splitlines()]


def _quoted(line: str) -> str:
    return ",".join(f'"{cell}"' for cell in next(csv.reader([line])))


@pytest.mark.parametrize(
    ("text", "at"),
    [
        ("t,a,b\n0,1,2\n0.1,1,2\n", 0),
        ("t,a,b\ns,m,m\n0,1,2\n", 0),
        ("\n".join([*MOTEC, "t,a,b", "s,m,m", "", "0,1,2", "0.1,1,2", "0.2,1,2"]), 14),
        ("\n".join([*AIM, "t,a,b", "s,m,m", "0,1,2", "0.1,1,2", "0.2,1,2"]), 12),
        ("\n\nt,a,b\n0,1,2\n0.1,1,2\n0.2,1,2\n", 2),  # blank lines first
        ("Run 7;car A\nt;a;b\n0,5;1,2;3\n0,6;1;3\n0,7;1;3\n", 1),  # ';' and decimal commas
        # the first line not the data's width, and no line of names above the data's rows
        ("t,a\n0,1,2\n0.1,1,2\n0.2,1,2\n0.3,1,2\n", 0),
        # a second line of names as wide as the first (units the readers do not know):
        # which is the header cannot be told, the first is (its reader refuses the second)
        ("t,a,b\nfoo,bar,baz\n0,1,2\n0.1,1,2\n0.2,1,2\n", 0),
        # names above two rows of data only, then other lines: not a header
        ("Format,x\nTime,10:00 AM\nRate,10\nLen,30\nSeg,S\n", 0),
    ],
)
def test_the_header_is_the_line_of_names_above_the_data(text, at):
    assert find_header(_lines(text), ended=True) == at
    head, after = read_head(iter(_lines(text)))  # after: the lines read past the header
    assert head.preamble == at and after and after == _lines(text)[at + 1 : at + 1 + len(after)]


def test_more_lines_are_read_only_until_the_header_is_told():
    """A plain file is told from its first data row; a preamble asks for lines until the
    rows of data under a line of names (so a pipe is not read further than needed)."""
    assert find_header(_lines("t,a,b\n"), ended=False) is None
    assert find_header(_lines("t,a,b\n0,1,2\n"), ended=False) == 0
    motec = _lines("\n".join([*MOTEC, "t,a,b", "s,m,m", "0,1,2", "0.1,1,2"]))
    assert find_header(motec, ended=False) is None
    assert find_header([*motec, b"0.2,1,2\n"], ended=False) == 14


def test_a_file_not_text_is_not_searched():
    head, after = read_head(iter([b"PK\x03\x04" + b"\x00" * 50 + b"\n", b"x\n"]))
    assert head.header.startswith(b"PK") and head.preamble == 0 and after == []


def _motec(path, df) -> list[str]:
    """``df`` as MoTeC i2 exports it: the preamble, the header and a row of units, a
    blank line, every cell quoted."""
    lines = write_iovnbd(df, path).read_text().splitlines()
    bare = lines[0].replace(" (rad/sec)", "")
    lines = [*MOTEC, _quoted(bare), _quoted(",".join(IOVNBD_UNITS)), "", *map(_quoted, lines[1:])]
    path.write_text("\n".join(lines) + "\n")
    return lines


@pytest.mark.parametrize("ending", ["\n", "\r\n", "\r"])
def test_a_motec_export_reads_as_the_drive_by_both_readers(tmp_path, ending):
    """The same drive as without the preamble, by ingest's reader and predict's (a file and
    a pipe), with any line ends; the notes name the preamble; a bad cell is named by its
    data row."""
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = tmp_path / "V-M.csv"
    lines = _motec(path, df)
    path.write_bytes(ending.join(lines).encode() + ending.encode())
    assert head_lines(path).skipped == len(MOTEC) + 2
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    said = "14 line(s) before the header skipped, from 'Format, MoTeC CSV File, Workbook'"
    assert any(said in n for n in got.notes), got.notes
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as f:
            lay, blocks = read_rows(f, "<stdin>", block_bytes=4096)
            streamed = [b for _, b in blocks]
        for name in (c.T_S, c.OMEGA_RL, c.LAT_DEG):
            got_ = np.concatenate([b[name] for b in streamed])
            np.testing.assert_array_equal(got_, ref.columns[name])
        assert any(said in n for n in lay.notes), lay.notes
    first = len(MOTEC) + 3  # the first data row's line
    lines[first + 6] = lines[first + 6].replace('"', "x", 1)  # data row 7: 'x' in the time
    path.write_bytes(ending.join(lines).encode() + ending.encode())
    for err in refusals(path):
        assert err.problems[0].row == 7, err.problems[0]


def test_blank_lines_before_the_header_are_skipped_and_said(tmp_path):
    df = wavy_drive(10.0)
    path = write_iovnbd(df, tmp_path / "V-B.csv")
    path.write_text("\n\n" + path.read_text())
    got = read_iovnbd(path)
    assert got.n_rows == len(df)
    assert "2 blank line(s) before the header skipped" in got.notes


def test_a_file_of_comment_lines_only_is_said_so(tmp_path):
    path = tmp_path / "V-C.csv"
    path.write_text("# logger v1.2\n# car: Fiesta\n")
    for read in (
        lambda: read_iovnbd(path),
        lambda: read_rows(io.BytesIO(path.read_bytes()), "V-C.csv"),
    ):
        with pytest.raises(InputError) as err:
            read()
        assert (
            "2 comment line(s) starting with '#' and nothing after" in err.value.problems[0].found
        )


def test_units_the_readers_do_not_know_make_a_units_row_with_data_under_it():
    """A tool's export of many channels: most units unknown to the readers (C, kPa, V)
    make a units row where a row of data as wide is under it, not otherwise."""
    from rwhonet.data.csvio import is_units_row, units_row_in

    cells = ["s", "C", "kPa", "V", "bar", "%"]
    assert not is_units_row(cells) and is_units_row(cells, data_below=True)
    assert not is_units_row(["Venue", "Coventry", "Worksheet"], data_below=True)
    header, units = b"t,a,b,c,d,e\n", b"s,C,kPa,V,bar,%\n"
    assert units_row_in(header, units, b"0,1,2,3,4,5\n") == cells
    for below in (b"", b"0,1,2\n", b"x,y,z,u,v,w\n"):  # none read, not as wide, not data
        assert units_row_in(header, units, below) is None
    text = _lines("t,a,b,c,d,e\ns,C,kPa,V,bar,%\n\n0,1,2,3,4,5\n")
    assert find_header(text[:2], ended=False) is None  # told by the line under it
    assert find_header(text, ended=False) == 0


def test_a_motec_export_of_many_channels_reads_as_the_drive(tmp_path):
    """Thirty channels more, their units ones the readers do not know (the units row's
    known units under half of its cells): the same drive, by ingest's reader and
    predict's from a pipe."""
    df = wavy_drive(20.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = tmp_path / "V-M.csv"
    lines = _motec(path, df)
    at = len(MOTEC)
    extra = [f'"Extra {k}"' for k in range(30)], ['"kPa"', '"C"', '"V"'] * 10, ['"101.3"'] * 30
    lines[at] += "," + ",".join(extra[0])
    lines[at + 1] += "," + ",".join(extra[1])
    lines[at + 3 :] = [line + "," + ",".join(extra[2]) for line in lines[at + 3 :]]
    path.write_text("\n".join(lines) + "\n")
    got = read_iovnbd(path)
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], ref.columns[c.OMEGA_RL])
    assert any("a row of units" in n for n in got.notes)
    with piped(path.read_bytes()) as f:
        lay, blocks = read_rows(f, "<stdin>", block_bytes=4096)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
