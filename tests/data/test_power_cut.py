"""A logger that lost power: the file ends in NUL bytes where its last data were never
written. They are not read, by ingest's readers and predict's; a last row cut off where they
begin is refused, named as such (``csvio.nul_tail``)."""

from __future__ import annotations

import io

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.csvio import BLOCK_BYTES, nul_tail
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
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


def test_a_last_row_cut_off_where_the_nul_bytes_begin_is_named(tmp_path):
    df = wavy_drive(30.0)
    path = write_iovnbd(df, tmp_path / "V-P.csv")
    data = path.read_bytes()
    path.write_bytes(data[: data.rstrip(b"\n").rfind(b"\n") + 40] + b"\x00" * 4096)
    last = len(df)
    for err in refusals(path):
        cut = err.problems[-1]
        assert cut.row == last and "4096 NUL byte(s) to the end of the file" in cut.found
        assert f"delete row {last}" in cut.fix
