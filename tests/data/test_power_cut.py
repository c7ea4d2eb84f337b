"""A logger that lost power: the file ends in NUL bytes where its last data were never
written, or in a row it stopped writing. Neither is read, by ingest's readers and predict's
(``csvio.nul_tail``, ``csvio.cut_last_row``): a last row cut short (fewer cells than a row
holds, no line end) is said and left out, its sample lost as a dropped one. A last row
with every cell is read as it stands; one cut where the NUL bytes begin that still holds
every cell, but not a number, is refused, named as such."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.csvio import BLOCK_BYTES, cut_last_row, nul_tail
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.streamcsv import read_stream_csvs
from support.drives import write_columnmap, write_iovnbd
from support.pipes import piped
from support.readers import refusals
from support.serving import wavy_drive

from .test_columnmap_reader import cupac_map

NOTE = "4096 NUL byte(s) at the end of the file not read"


@pytest.mark.parametrize("n", [0, 1, 4096, BLOCK_BYTES + 17, 3 * BLOCK_BYTES])
def test_the_nul_bytes_a_file_ends_in_are_counted(tmp_path, n):
    path = tmp_path / "f.csv"
    path.write_bytes(b"t,a\n0,\x001\n" + b"\x00" * n)  # a NUL inside a row is not the tail
    assert nul_tail(path) == n
    path.write_bytes(b"\x00" * n)
    assert nul_tail(path) == n
    assert nul_tail(tmp_path / "missing.csv") == 0


def test_a_whole_last_row_then_nul_bytes_reads_as_the_drive_by_both_readers(tmp_path):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    path.write_bytes(path.read_bytes() + b"\x00" * 4096)
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    assert any(NOTE in n for n in got.notes), got.notes
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as f:
            lay, blocks = read_rows(f, "<stdin>", block_bytes=1000)
            streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
        np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
        assert any(NOTE in n for n in lay.notes), lay.notes


def test_a_column_mapped_file_separated_by_semicolons_with_nul_bytes_at_its_end(tmp_path):
    """The cut bytes and the separator's translation in one reader."""
    df = wavy_drive(20.0)
    ref = read_columnmap(write_columnmap(df, tmp_path / "C-A.csv"), cupac_map(), "cupac")
    path = write_columnmap(df, tmp_path / "C-P.csv")
    text = path.read_text().replace(",", ";").replace(".", ",")
    path.write_bytes(text.encode() + b"\x00" * 4096)
    got = read_columnmap(path, cupac_map(), "cupac")
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], ref.columns[c.OMEGA_RL])
    assert any(NOTE in n for n in got.notes), got.notes


CUT = "cut short, not read"


def _cut(path, keep: int, tail: bytes = b"") -> None:
    """The file's last row cut after ``keep`` of its bytes, then ``tail``."""
    data = path.read_bytes()
    path.write_bytes(data[: data.rstrip(b"\r\n").rfind(b"\n") + 1 + keep] + tail)


def _streamed(path):
    """predict's reading of the file, from a file and from a pipe: (rows, notes) each."""
    out = []
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as f:
            lay, blocks = read_rows(f, "<stdin>", block_bytes=1000)
            out.append((np.concatenate([b[c.OMEGA_RL] for _, b in blocks]), lay.notes))
    return out


@pytest.mark.parametrize("tail", [b"", b"\x00" * 4096], ids=["end", "nul"])
@pytest.mark.parametrize("keep", [1, 40, -2], ids=["a byte", "some cells", "all but its last"])
def test_a_last_row_cut_short_is_said_and_not_read_by_both_readers(tmp_path, keep, tail):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df.iloc[:-1], tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    last_row = path.read_bytes().rstrip(b"\n").rsplit(b"\n", 1)[1]
    _cut(path, keep if keep > 0 else len(last_row) - last_row[::-1].index(b",") - 1, tail)
    got = read_iovnbd(path)
    for name in c.REQUIRED:
        np.testing.assert_array_equal(got.columns[name], ref.columns[name])
    said = f"the last row ({len(df)}) {CUT}"
    assert any(said in n for n in got.notes), got.notes
    for streamed, notes in _streamed(path):
        np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
        assert any(said in n for n in notes), notes


def test_a_last_row_with_every_cell_and_no_line_end_is_read_as_it_stands(tmp_path):
    df = wavy_drive(30.0)
    ref = read_iovnbd(write_iovnbd(df, tmp_path / "V-A.csv"))
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    path.write_bytes(path.read_bytes().rstrip(b"\n"))
    assert cut_last_row(path, 29) == 0
    got = read_iovnbd(path)
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], ref.columns[c.OMEGA_RL])
    assert not any(CUT in n for n in got.notes), got.notes
    for streamed, notes in _streamed(path):
        np.testing.assert_array_equal(streamed, ref.columns[c.OMEGA_RL])
        assert not any(CUT in n for n in notes), notes


def test_a_short_row_with_its_line_end_is_still_refused_by_its_row(tmp_path):
    """A row with fewer cells that the logger ended is no power cut: it says so."""
    df = wavy_drive(30.0)
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    _cut(path, 40, b"\n")
    for err in refusals(path):
        assert err.problems[0].row == len(df), err.problems


def test_a_column_mapped_file_separated_by_semicolons_with_its_last_row_cut(tmp_path):
    """The cut counted in the file's own separator, before its translation."""
    df = wavy_drive(20.0)
    ref = read_columnmap(write_columnmap(df.iloc[:-1], tmp_path / "C-A.csv"), cupac_map(), "cupac")
    path = write_columnmap(df, tmp_path / "C-P.csv")
    path.write_text(path.read_text().replace(",", ";").replace(".", ","))
    _cut(path, 12)
    got = read_columnmap(path, cupac_map(), "cupac")
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], ref.columns[c.OMEGA_RL])
    assert any(f"the last row ({len(df)}) {CUT}" in n for n in got.notes), got.notes


def test_a_stream_csv_whose_last_row_is_cut_gives_its_other_samples(tmp_path):
    t = np.arange(0.0, 20.0, 0.02) + 700.0
    wheels = pd.DataFrame({"t": t, **{f"w{k}": 40.0 + np.sin(t + k) for k in range(4)}})
    gps = pd.DataFrame({"t": t[::50] + 0.01, "lat": 52.0 + 1e-5 * t[::50], "lon": -1.5})
    smap = {
        "t": ColumnSpec("t", "s"),
        **{
            f"omega_{w}": ColumnSpec(f"w{k}", "rad/s")
            for k, w in enumerate(("fl", "fr", "rl", "rr"))
        },
        "lat": ColumnSpec("lat", "deg"),
        "lon": ColumnSpec("lon", "deg"),
    }
    whole, cut = tmp_path / "whole", tmp_path / "cut"
    for root, rows in ((whole, len(wheels) - 1), (cut, len(wheels))):
        root.mkdir()
        wheels.iloc[:rows].to_csv(root / "wheels.csv", index=False)
        gps.to_csv(root / "gps.csv", index=False)
    _cut(cut / "wheels.csv", 9)
    ref = read_stream_csvs(sorted(whole.glob("*.csv")), smap, None)
    got = read_stream_csvs(sorted(cut.glob("*.csv")), smap, None)
    for a, b in zip(ref.streams, got.streams, strict=True):
        np.testing.assert_array_equal(a.t_s, b.t_s)
        for name in a.channels:
            np.testing.assert_array_equal(a.channels[name], b.channels[name])
    said = f"wheels.csv: the last row ({len(wheels)}) {CUT}"
    assert any(said in n for n in got.changed), got.changed


@pytest.mark.parametrize(
    ("text", "cut"),
    [
        (b"t,a,b", 0),  # the header alone
        (b"t,a,b\n1,2", 0),  # the first row (no row before it): left to the reader
        (b"t,a,b\n1,2,3\n4,5", 3),
        (b"t,a,b\r\n1,2,3\r\n4,", 2),
        (b"t,a,b\n1,2,3\n4,5,6", 0),  # every cell
        (b"t,a,b\n1,2,3\n", 0),
        (b"t,a,b\n1,2,3\n  ", 0),  # blank
        (b't,a,b\n1,2,3\n4,"5', 0),  # a quote: the reader judges
        (b"t;a;b\n1;2,5;3\n4;5,1", 5),  # separated by ';', ',' its decimal mark
    ],
)
def test_cut_last_row_counts_the_bytes_of_a_row_cut_short(tmp_path, text, cut):
    path = tmp_path / "f.csv"
    path.write_bytes(text)
    assert cut_last_row(path, 3) == cut


def test_a_last_row_before_the_nul_bytes_with_a_cell_not_a_number_is_refused(tmp_path):
    """Every cell, its time not a number (cut inside the cell, the rest written before):
    refused, naming the row and the column; predict names the NUL bytes too."""
    df = wavy_drive(30.0)
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    head, last = path.read_bytes().rstrip(b"\n").rsplit(b"\n", 1)
    cells = last.split(b",")
    cells[1] = cells[1][:3] + b"e"
    path.write_bytes(head + b"\n" + b",".join(cells) + b"\x00" * 4096)
    ingest, predict = refusals(path)
    for err in (ingest, predict):
        assert (err.problems[0].row, err.problems[0].column) == (len(df), " Time"), err.problems
    cut = predict.problems[-1]
    assert "4096 NUL byte(s) to the end of the file" in cut.found
    assert f"delete row {len(df)}" in cut.fix
