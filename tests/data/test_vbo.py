"""Racelogic VBOX files (rwhonet.data.vbo): the [data] section read as a column-mapped CSV."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.incremental import read_rows
from rwhonet.data.vbo import (
    VboAsCsv,
    file_is_vbo,
    is_vbo,
    plain_counts_checked,
    vbo_as_csv,
)
from rwhonet.errors import InputError
from support.drives import VBO_MAP, write_columnmap, write_vbo
from support.serving import wavy_drive

SMALL = b"""File created on 11/03/2019 @ 12:30:00\r
\r
[header]\r
satellites\r
time\r
\r
[comments]\r
a [note] inside a comment\r
[column names]\r
sats time  lat\tlong\r
\r
[data]\r
009 123000.00 +03144.60000 +00090.00000\r
  010   123000.10 +03144.60010\t+00090.00020  \r
"""


def _cmap(spec: dict) -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(col, unit) for k, (col, unit) in spec.items()}


def _converted(data: bytes, file: str = "f.vbo") -> bytes:
    return io.BufferedReader(VboAsCsv(io.BytesIO(data), file)).read()


def test_a_vbox_file_is_the_csv_of_its_column_names_and_data_lines() -> None:
    assert is_vbo(SMALL) and is_vbo(b"\xef\xbb\xbf[header]\nsats\n")
    assert not is_vbo(b"Sats, Time, Lat\n") and not is_vbo(b"")
    assert _converted(SMALL) == (
        b"sats,time,lat,long\n009,123000.00,+03144.60000,+00090.00000\n"
        b"010,123000.10,+03144.60010,+00090.00020\n"
    )


def test_lines_split_across_reads_are_joined_before_they_are_converted() -> None:
    data = SMALL + b"".join(b"011 1230%02d.00 +03144.6 +00090.0\n" % s for s in range(1, 60))

    class Trickle(io.BytesIO):
        def read(self, n: int = -1) -> bytes:  # 7 bytes at a time, as a slow pipe gives
            return super().read(7 if n is None or n < 0 else min(n, 7))

    assert _converted(data) == io.BufferedReader(VboAsCsv(Trickle(data), "f")).read()


@pytest.mark.parametrize(
    ("data", "missing"),
    [
        (b"File created on 11/03/2019\n[header]\nsats\n[data]\n009\n", "[column names]"),
        (b"File created on 11/03/2019\n[column names]\nsats time\n", "[data]"),
        # a 2 MB first section without a line end: the preamble's limit, not the file's end
        (b"File created on 11/03/2019\n" + b"x" * (2 << 20), "[column names]"),
    ],
    ids=["no column names", "no data", "no line end"],
)
def test_a_file_without_its_sections_is_refused_naming_it(data: bytes, missing: str) -> None:
    with pytest.raises(InputError) as err:
        _converted(data, "log.vbo")
    (problem,) = err.value.problems
    assert problem.file == "log.vbo" and problem.found == f"no {missing} section"


def test_a_vbox_drive_reads_as_the_drive_in_degrees_and_seconds(tmp_path) -> None:
    """Minutes positive west, hhmmss.ss times of day across midnight and CAN wheel speeds
    in rpm: through a column map, the drive the CSV in SI units gives, by ingest's reader
    (the scratch CSV) and predict's (the stream converted as it is read)."""
    drive = wavy_drive(60.0, t0_s=86370.0)  # passes midnight 30 s in
    plain = {**VBO_MAP, "t": ("time", "s"), "lat": ("lat", "deg"), "lon": ("long", "deg")}
    plain["n_sats"] = ("sats", "count")
    ref = read_columnmap(write_columnmap(drive, tmp_path / "ref.csv", plain), _cmap(plain), "ref")
    path = write_vbo(drive, tmp_path / "drive.vbo", crlf=True)
    assert file_is_vbo(path) and not file_is_vbo(tmp_path / "ref.csv")
    vbo_as_csv(path, tmp_path / "drive.csv", "drive.vbo")
    got = read_columnmap(tmp_path / "drive.csv", _cmap(VBO_MAP), "vbox", "drive.vbo")
    np.testing.assert_allclose(got.columns[c.T_S], ref.columns[c.T_S], rtol=0, atol=0.006)
    assert got.columns[c.T_S][-1] > 86400.0
    for name in (c.LAT_DEG, c.LON_DEG):
        np.testing.assert_allclose(got.columns[name], ref.columns[name], rtol=0, atol=1e-8)
    for name in c.WHEELS:
        np.testing.assert_allclose(got.columns[name], ref.columns[name], rtol=1e-5, atol=1e-4)
    with open(path, "rb") as f:
        _, blocks = read_rows(
            io.BufferedReader(VboAsCsv(f, "drive.vbo")), "drive.vbo", "vbox", _cmap(VBO_MAP)
        )
        streamed = list(blocks)
    lat = np.concatenate([b[c.LAT_DEG] for _, b in streamed])
    np.testing.assert_allclose(lat, got.columns[c.LAT_DEG], rtol=0, atol=1e-12)


def test_a_bad_cell_is_named_by_its_data_line_after_the_data_section(tmp_path) -> None:
    path = write_vbo(wavy_drive(20.0), tmp_path / "drive.vbo")
    lines = path.read_text().splitlines()
    first = lines.index("[data]") + 1
    cells = lines[first + 6].split(" ")
    cells[2] = "+031x4.6"
    lines[first + 6] = " ".join(cells)
    path.write_text("\n".join(lines) + "\n")
    vbo_as_csv(path, tmp_path / "drive.csv", "drive.vbo")
    with pytest.raises(InputError) as err:
        read_columnmap(tmp_path / "drive.csv", _cmap(VBO_MAP), "vbox", "drive.vbo")
    (problem,) = err.value.problems
    assert (problem.file, problem.row, problem.column) == ("drive.vbo", 7, "lat")


def test_ingest_reads_vbo_files_its_role_names_and_says_so(tmp_path) -> None:
    """A role whose glob names .vbo files and whose format is a column map: ingest reads
    them as the CSVs they stand for and its manifest says how; nothing is left in the
    scratch folder."""
    import json
    import tempfile

    from rwhonet.stages.ingest import ingest
    from support.corpus import good_target, write_good_fleet
    from support.drives import column_map_params, make_params

    raw = tmp_path / "raw"
    write_good_fleet(raw)
    for old in (raw / "target_test").glob("*.csv"):
        old.unlink()
    write_vbo(good_target(), raw / "target_test" / "C-V1.vbo")
    params = make_params(
        raw,
        **{
            "data.column_maps.vbox": column_map_params(VBO_MAP),
            "data.roles.target_test": {
                "glob": "target_test/*.vbo",
                "format": "vbox",
                "vehicle": "target",
            },
        },
    )
    scratch_before = set(Path(tempfile.gettempdir()).glob("rwhonet-vbo-*"))
    ingest(params, tmp_path / "drives", tmp_path / "failed.json")
    manifest = json.loads((tmp_path / "drives" / "manifest.json").read_text())
    entry = next(d for d in manifest["drives"] if d["source_file"].endswith("C-V1.vbo"))
    assert any("Racelogic VBOX file" in note for note in entry["notes"])
    assert set(Path(tempfile.gettempdir()).glob("rwhonet-vbo-*")) == scratch_before


def test_the_satellite_count_s_flags_are_taken_off_or_a_plain_count_refused(tmp_path) -> None:
    """VBOX adds 128 to its satellite count while it uses DGPS and 64 while the brake
    trigger is on (Racelogic, 'VBO File Format'): declared 'vbox', 9 satellites read as 9
    by both readers; declared 'count', predict refuses the first row (ingest: the corpus
    case racelogic_vbox_satellites_as_a_plain_count)."""
    drive = wavy_drive(20.0)
    braking = (np.arange(len(drive)) % 50 < 10) * 64
    path = write_vbo(drive, tmp_path / "drive.vbo", flags=128 + braking)
    assert "\n137 " in path.read_text() and "\n201 " in path.read_text()
    vbo_as_csv(path, tmp_path / "drive.csv", "drive.vbo")
    got = read_columnmap(tmp_path / "drive.csv", _cmap(VBO_MAP), "vbox", "drive.vbo")
    np.testing.assert_array_equal(got.columns[c.N_SATS], np.full(len(drive), 9.0))
    plain = _cmap(VBO_MAP | {"n_sats": ("sats", "count")})
    with open(path, "rb") as f:
        reader = io.BufferedReader(VboAsCsv(f, "drive.vbo"))
        _, blocks = read_rows(reader, "drive.vbo", "vbox", _cmap(VBO_MAP), block_bytes=2048)
        sats = np.concatenate([b[c.N_SATS] for _, b in blocks])
    np.testing.assert_array_equal(sats, np.full(len(drive), 9.0))
    with open(path, "rb") as f:
        reader = io.BufferedReader(VboAsCsv(f, "drive.vbo"))
        _, blocks = read_rows(reader, "drive.vbo", "vbox", plain, block_bytes=2048)
        checked = plain_counts_checked(
            blocks, "drive.vbo", "sats", "data.column_maps.vbox.n_sats.unit"
        )
        with pytest.raises(InputError) as err:
            list(checked)
    first = err.value.problems[0]
    assert (first.file, first.row, first.column, first.found) == ("drive.vbo", 1, "sats", "201.0")
    assert "'vbox'" in first.fix and "data.column_maps.vbox.n_sats.unit" in first.fix


def test_predict_s_reader_takes_a_vbox_file_from_a_pipe_as_from_its_file(tmp_path) -> None:
    """read_rows tells a VBOX file by its first line (blank lines before it aside), from a
    file or a pipe (rwhonet predict --drive -): the same rows, the reader's note; the
    IO-VNBD format refuses it."""
    from support.pipes import piped

    path = write_vbo(wavy_drive(40.0), tmp_path / "drive.vbo", crlf=True, flags=128)
    with open(path, "rb") as f:
        ref_lay, blocks = read_rows(f, "drive.vbo", "vbox", _cmap(VBO_MAP), block_bytes=4096)
        ref = [b for _, b in blocks]
    # blank lines before the first, as ingest's file_is_vbo skips them
    for data in (path.read_bytes(), b"\r\n\r\n" + path.read_bytes()):
        with piped(data) as f:
            lay, blocks = read_rows(f, "<stdin>", "vbox", _cmap(VBO_MAP), block_bytes=4096)
            got = [b for _, b in blocks]
        assert lay.names == ref_lay.names and "Racelogic VBOX file" in lay.notes[0]
        assert ref_lay.notes == lay.notes
        for name in (c.T_S, c.LAT_DEG, c.OMEGA_RL, c.N_SATS):
            np.testing.assert_array_equal(
                np.concatenate([b[name] for b in got]), np.concatenate([b[name] for b in ref])
            )
    assert np.concatenate([b[c.N_SATS] for b in got]).max() == 9.0  # 137: DGPS's flag off
    with pytest.raises(InputError, match="a Racelogic VBOX file"):
        read_rows(io.BytesIO(path.read_bytes()), "<stdin>", "iovnbd")
