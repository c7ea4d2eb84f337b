"""Files separated by ';' or tabs (a spreadsheet's locale, decimal commas) read as the
comma-separated files they stand for, by every CSV reader and by predict's."""

import io

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.csvio import as_comma_separated, delimiter_of, read_header
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError
from support.drives import write_iovnbd
from support.serving import wavy_drive


def localised(text: str, sep: str, decimal: str = ",") -> str:
    """A comma-separated file's text as a spreadsheet in another locale writes it."""
    return text.replace(",", "\0").replace(".", decimal).replace("\0", sep)


def test_the_delimiter_is_told_from_the_header_line():
    assert delimiter_of(b"Time;Lat;Lon\r\n") == ";"
    assert delimiter_of(b"Time\tLat\tLon\n") == "\t"
    assert delimiter_of(b"Time,Lat;x,Lon\n") == ","  # a comma: comma-separated
    assert delimiter_of(b"Time\n") == ","
    assert as_comma_separated(b"1,5;52,1;-1,2\n", ";") == b"1.5,52.1,-1.2\n"
    assert as_comma_separated(b"1.5\t52.1\n", "\t") == b"1.5,52.1\n"


@pytest.mark.parametrize(("sep", "decimal"), [(";", ","), ("\t", ","), ("\t", "."), (";", ".")])
def test_an_iovnbd_file_in_another_locale_reads_as_the_comma_separated_one(sep, decimal, tmp_path):
    df = wavy_drive(30.0)
    ref_path = write_iovnbd(df, tmp_path / "V-A.csv")
    ref = read_iovnbd(ref_path)
    path = tmp_path / "V-L.csv"
    path.write_text(localised(ref_path.read_text(), sep, decimal))
    assert read_header(path) == read_header(ref_path)
    got = read_iovnbd(path)
    for k in ref.columns:
        np.testing.assert_array_equal(got.columns[k], ref.columns[k])
    assert any("separated by" in n and "decimal mark" in n for n in got.notes)
    for data, name in ((path.read_bytes(), "file"), (ref_path.read_bytes(), "ref")):
        lay, blocks = read_rows(io.BytesIO(data), name, block_bytes=2048)
        cols = [b for _, b in blocks]
        assert any("separated by" in n for n in lay.notes) == (name == "file")
        if name == "file":
            streamed = {k: np.concatenate([b[k] for b in cols]) for k in c.REQUIRED}
        else:
            for k in c.REQUIRED:
                np.testing.assert_array_equal(streamed[k], np.concatenate([b[k] for b in cols]))


def test_a_bad_cell_of_a_semicolon_file_is_named_with_its_row(tmp_path):
    ref_path = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    lines = localised(ref_path.read_text(), ";").splitlines()
    cells = lines[9].split(";")
    cells[12] = "schnell"
    lines[9] = ";".join(cells)
    path = tmp_path / "V-L.csv"
    path.write_text("\n".join(lines) + "\n")
    for read in (
        lambda: read_iovnbd(path, "V-L.csv"),
        lambda: list(read_rows(io.BytesIO(path.read_bytes()), "V-L.csv")[1]),
    ):
        with pytest.raises(InputError) as err:
            read()
        assert "V-L.csv, row 9, column ' Wheel Speed Rear Left (rad/sec)'" in str(err.value)
        assert "'schnell'" in str(err.value)


def test_stream_csvs_separated_by_semicolons_read_as_comma_separated_ones(tmp_path):
    from rwhonet.data.streamcsv import read_stream_csvs

    t_w, t_g = np.arange(0.0, 20.0, 0.02), np.arange(0.0, 20.0, 0.1)
    wheels = pd.DataFrame({"Time": t_w, **{f"w{k}": 40.0 + t_w / 7 for k in range(4)}})
    gnss = pd.DataFrame({"Time": t_g, "lat": 52.0 + 12.0 * t_g / 111_000.0, "lon": -1.5})
    for name, sep in (("comma", ","), ("semicolon", ";")):
        folder = tmp_path / name
        folder.mkdir()
        for file, df in (("can.csv", wheels), ("gps.csv", gnss)):
            text = df.to_csv(index=False)
            (folder / file).write_text(localised(text, sep) if sep == ";" else text)
    wheel_keys = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
    smap = {key: ColumnSpec(f"w{k}", "rad/s") for k, key in enumerate(wheel_keys)}
    smap |= {"t": ColumnSpec("Time", "s"), "lat": ColumnSpec("lat", "deg")}
    smap |= {"lon": ColumnSpec("lon", "deg")}
    ref = read_stream_csvs(sorted((tmp_path / "comma").glob("*.csv")), smap, 0.3)
    got = read_stream_csvs(sorted((tmp_path / "semicolon").glob("*.csv")), smap, 0.3)
    for a, b in zip(got.streams, ref.streams, strict=True):
        np.testing.assert_array_equal(a.t_s, b.t_s)
        for k in b.channels:
            np.testing.assert_array_equal(a.channels[k], b.channels[k])
