"""Drive files kept compressed (gzip, bzip2, xz, zstd): read as the text they hold by ingest's
10 Hz readers (through a scratch copy bounded by data.max_file_mb) and by predict's (as it
decompresses), named as the user named them; cut-off data refused, not a traceback."""

from __future__ import annotations

import bz2
import dataclasses
import gzip
import io
import lzma
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.compressed import (
    compressed_note,
    compression_of,
    drive_stem,
    open_decompressed,
)
from rwhonet.data.drivefile import DriveFile, read_any
from rwhonet.data.incremental import read_rows
from rwhonet.data.scenarios import sidecar_path
from rwhonet.errors import InputError
from support.drives import make_params, write_iovnbd
from support.serving import wavy_drive
from support.stream_fleet import (
    read_target_drive,
    role_drive,
    stream_params,
    tables_from_drive,
    write_drive,
)

COMPRESS = {
    "gzip": lambda data: gzip.compress(data, mtime=0),
    "bzip2": bz2.compress,
    "xz": lzma.compress,
    "zstd": lambda data: pa.compress(data, codec="zstd", asbytes=True),
}
SUFFIX = {"gzip": ".gz", "bzip2": ".bz2", "xz": ".xz", "zstd": ".zst"}


def _read(path: Path, root: Path, **overrides):
    data = make_params(root, **overrides).data
    f = DriveFile(drive_stem(path), "target_test", "target", "iovnbd", path)
    return read_any(f, data, lambda p: p.name, None, 0.1, 10.0)[0]


def _packed(tmp_path: Path, kind: str, text: bytes, name: str = "V-T.csv") -> Path:
    path = tmp_path / f"{name}{SUFFIX[kind]}"
    path.write_bytes(COMPRESS[kind](text))
    return path


@pytest.mark.parametrize(
    ("name", "stem"),
    [
        ("V-S1.csv.gz", "V-S1"),
        ("V-S1.CSV.GZ", "V-S1"),
        ("V-S1.csv.zst", "V-S1"),
        ("V-S1.csv", "V-S1"),
        ("drive.2019.csv.bz2", "drive.2019"),
        ("V-S1.gz", "V-S1"),
    ],
)
def test_a_drive_id_is_its_name_without_the_compressions_suffix(name, stem):
    assert drive_stem(Path(name)) == stem
    assert sidecar_path(Path("raw") / name) == Path("raw") / f"{stem}.scenarios.json"


@pytest.mark.parametrize("kind", COMPRESS)
def test_a_compressed_drive_reads_as_the_text_it_holds(tmp_path, kind):
    plain = write_iovnbd(wavy_drive(20.0), tmp_path / "V-A.csv")
    packed = _packed(tmp_path, kind, plain.read_bytes())
    assert compression_of(packed) == kind and compression_of(plain) is None
    want, got = _read(plain, tmp_path), _read(packed, tmp_path)
    for name in want.columns:
        np.testing.assert_array_equal(got.columns[name], want.columns[name])
    assert got.notes[0] == compressed_note(kind)
    with open_decompressed(packed, kind, packed.name) as stream:
        lay, blocks = read_rows(stream, packed.name, block_bytes=4096)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, want.columns[c.OMEGA_RL])


def test_the_kind_is_told_from_the_bytes_not_the_name(tmp_path):
    plain = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    text_named_gz = tmp_path / "V-B.csv.gz"
    text_named_gz.write_bytes(plain.read_bytes())
    gzip_named_csv = tmp_path / "V-C.csv"
    gzip_named_csv.write_bytes(gzip.compress(plain.read_bytes()))
    want = _read(plain, tmp_path).columns[c.T_S]
    np.testing.assert_array_equal(_read(text_named_gz, tmp_path).columns[c.T_S], want)
    np.testing.assert_array_equal(_read(gzip_named_csv, tmp_path).columns[c.T_S], want)


def test_a_problem_names_the_compressed_file_and_its_row(tmp_path):
    plain = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    lines = plain.read_text().splitlines()
    cells = lines[40].split(",")
    cells[12] = "fast"
    lines[40] = ",".join(cells)
    packed = _packed(tmp_path, "gzip", ("\n".join(lines) + "\n").encode())
    with pytest.raises(InputError) as err:
        _read(packed, tmp_path)
    (problem,) = err.value.problems
    assert (problem.file, problem.row, problem.found) == ("V-T.csv.gz", 40, "'fast'")


def test_the_text_is_bounded_by_max_file_mb(tmp_path):
    text = write_iovnbd(wavy_drive(60.0), tmp_path / "V-A.csv").read_bytes()
    packed = _packed(tmp_path, "gzip", text)
    limit_mb = (packed.stat().st_size + len(text)) / 2 / 2**20  # above the file, below its text
    with pytest.raises(InputError) as err:
        _read(packed, tmp_path, **{"data.max_file_mb": limit_mb})
    assert "once decompressed (data.max_file_mb)" in err.value.problems[0].expected


@pytest.mark.parametrize("kind", COMPRESS)
def test_cut_off_compressed_data_is_refused_by_both_readers(tmp_path, kind):
    text = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv").read_bytes()
    packed = _packed(tmp_path, kind, text)
    packed.write_bytes(packed.read_bytes()[: packed.stat().st_size // 2])
    with pytest.raises(InputError) as err:
        _read(packed, tmp_path)
    assert f"whole {kind}-compressed data" in err.value.problems[0].expected
    with pytest.raises(InputError) as err, open_decompressed(packed, kind, "V-T") as stream:
        list(read_rows(stream, "V-T", block_bytes=4096)[1])
    assert f"whole {kind}-compressed data" in err.value.problems[0].expected


def test_compressed_bytes_in_a_pipe_are_named(tmp_path):
    text = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv").read_bytes()
    with pytest.raises(InputError) as err:
        read_rows(io.BytesIO(gzip.compress(text)), "<stdin>")
    assert "gzip-compressed data (give it as a file" in err.value.problems[0].found


def _zipped(path: Path, members: dict[str, bytes]) -> Path:
    import zipfile

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return path


def test_a_zip_archive_of_one_drive_file_reads_as_it(tmp_path):
    plain = write_iovnbd(wavy_drive(20.0), tmp_path / "V-A.csv")
    packed = _zipped(tmp_path / "V-T.zip", {"export/V-T.csv": plain.read_bytes()})
    assert compression_of(packed) == "zip" and drive_stem(packed) == "V-T"
    want, got = _read(plain, tmp_path), _read(packed, tmp_path)
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], want.columns[c.OMEGA_RL])
    assert got.notes[0] == compressed_note("zip")
    with open_decompressed(packed, "zip", packed.name) as stream:
        lay, blocks = read_rows(stream, packed.name, block_bytes=4096)
        streamed = np.concatenate([b[c.T_S] for _, b in blocks])
    np.testing.assert_allclose(streamed, want.columns[c.T_S])


@pytest.mark.parametrize(
    ("members", "found"),
    [
        ({"a.csv": b"t\n1\n", "b.csv": b"t\n2\n"}, "2 files"),
        ({}, "no file"),
        (
            {"[Content_Types].xml": b"<x/>", "xl/workbook.xml": b"<x/>", "xl/s.xml": b"<x/>"},
            "an Excel workbook",
        ),
        ({"xl/workbook.xml": b"<x/>"}, "an Excel workbook"),
    ],
)
def test_a_zip_archive_not_of_one_drive_file_is_refused(tmp_path, members, found):
    packed = _zipped(tmp_path / "V-T.zip", members)
    for read in (
        lambda: _read(packed, tmp_path),
        lambda: open_decompressed(packed, "zip", packed.name),
    ):
        with pytest.raises(InputError) as err:
            read()
        assert found in err.value.problems[0].found


def test_a_cut_off_zip_archive_is_refused(tmp_path):
    text = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv").read_bytes()
    packed = _zipped(tmp_path / "V-T.zip", {"V-T.csv": text})
    packed.write_bytes(packed.read_bytes()[: packed.stat().st_size // 2])
    with pytest.raises(InputError) as err:
        _read(packed, tmp_path)
    assert "whole zip-compressed data" in err.value.problems[0].expected


def test_stream_csvs_kept_compressed_read_as_the_folder_of_their_text(tmp_path):

    tables = tables_from_drive(role_drive("target_test", 60.0))
    plain = write_drive("stream_csv", tables, tmp_path / "plain", "C-B1", 0.3)
    packed = write_drive("stream_csv", tables, tmp_path / "packed", "C-B1", 0.3)
    kinds = iter(COMPRESS)
    for path in sorted(packed.glob("*.csv")):
        kind = next(kinds)
        path.with_name(path.name + SUFFIX[kind]).write_bytes(COMPRESS[kind](path.read_bytes()))
        path.unlink()
    params = stream_params(tmp_path, "stream_csv")
    want, got = read_target_drive(params, plain), read_target_drive(params, packed)
    for name in want.raw.columns:
        np.testing.assert_array_equal(got.raw.columns[name], want.raw.columns[name])
    assert any("compressed" in note for note in got.raw.notes)
    # each stream named by the file the user has, not by its scratch copy
    assert {s["file"] for s in got.streams.streams} <= {str(p) for p in packed.iterdir()}


@pytest.mark.parametrize("kind", ["gzip", "zstd", "zip"])
def test_an_mdf4_log_kept_compressed_reads_as_the_log_it_holds(tmp_path, kind):
    """A logger's MDF4 file archived compressed (drive.mf4.gz, zipped alone): decompressed
    to a scratch copy bounded by data.max_file_mb, read as the log, named as kept."""
    import zipfile

    tables = tables_from_drive(role_drive("target_test", 60.0))
    plain = write_drive("mdf4", tables, tmp_path / "plain", "C-B1", 0.3)
    if kind == "zip":
        packed = tmp_path / "C-B1.mf4.zip"
        with zipfile.ZipFile(packed, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.write(plain, plain.name)
    else:
        packed = _packed(tmp_path, kind, plain.read_bytes(), plain.name)
    params = stream_params(tmp_path, "mdf4")
    want, got = read_target_drive(params, plain), read_target_drive(params, packed)
    assert drive_stem(packed) == "C-B1"
    for name in want.raw.columns:
        np.testing.assert_array_equal(got.raw.columns[name], want.raw.columns[name])
    assert got.raw.notes[0] == f"a {kind}-compressed file, read as the MDF4 log it holds"
    assert {s["file"] for s in got.streams.streams} == {str(packed)}
    small = dataclasses.replace(params.data, max_file_mb=plain.stat().st_size / 2**20 / 2)
    with pytest.raises(InputError) as err:
        read_target_drive(params, packed, data=small)
    assert err.value.problems[0].file == str(packed)
    assert "once decompressed" in err.value.problems[0].expected


@pytest.mark.parametrize("kind", ["gzip", "bzip2", "xz", "zip"])
def test_corrupted_compressed_data_is_refused_not_a_traceback(tmp_path, kind):
    text = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv").read_bytes()
    if kind == "zip":
        packed = _zipped(tmp_path / "V-T.zip", {"V-T.csv": text})
    else:
        packed = _packed(tmp_path, kind, text)
    data = bytearray(packed.read_bytes())
    for i in range(len(data) // 3, len(data) // 3 + 40):  # a disk or transfer error
        data[i] ^= 0x5A
    packed.write_bytes(bytes(data))
    with pytest.raises(InputError) as err:
        _read(packed, tmp_path)
    assert f"whole {kind}-compressed data" in err.value.problems[0].expected


def test_a_log_rotator_s_number_is_left_off_the_name():
    from rwhonet.data.compressed import without_rotation

    assert without_rotation("gps.nmea.1") == "gps.nmea"
    assert without_rotation("can0.log.12.gz") == "can0.log.gz"
    assert without_rotation("wheels.csv") == "wheels.csv"
    assert without_rotation("drive.2024.csv") == "drive.2024.csv"
    assert without_rotation("data.1") == "data.1"  # no name with a suffix before it
