"""One set of missing-value spellings for every reader (``canonical.MISSING_CELLS``): ingest's
(pyarrow) and predict's took different ones ('None' and '#N/A' read by one, refused by the
other)."""

from __future__ import annotations

import io

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.csvio import NULL_VALUES
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from support.drives import write_iovnbd
from support.readers import refusals
from support.serving import wavy_drive


def _with_fixes_written(path, word: str) -> None:
    """Data rows 21-25 with ``word`` for latitude and longitude (a logger without a fix)."""
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    at = [i for i, h in enumerate(header) if h.strip().split(" ")[0] in ("Lat", "Long")]
    for k in range(21, 26):
        cells = lines[k].split(",")
        for i in at:
            cells[i] = word
        lines[k] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "word", ["N/A", "n/a", "NA", "null", "NULL", "None", "none", "#N/A", "nan", "-NaN", "1.#QNAN"]
)
def test_every_reader_takes_the_same_words_for_no_value(tmp_path, word):
    df = wavy_drive(20.0)
    path = write_iovnbd(df, tmp_path / "V-N.csv")
    _with_fixes_written(path, word)
    got = read_iovnbd(path)
    lat = got.columns[c.LAT_DEG]
    assert np.isnan(lat[20:25]).all() and not np.isnan(lat[:20]).any()
    _, blocks = read_rows(io.BytesIO(path.read_bytes()), "V-N.csv")
    np.testing.assert_array_equal(np.concatenate([b[c.LAT_DEG] for _, b in blocks]), lat)


def test_a_lone_dash_is_refused_by_every_reader(tmp_path):
    path = write_iovnbd(wavy_drive(20.0), tmp_path / "V-D.csv")
    _with_fixes_written(path, "-")
    for err in refusals(path):
        assert (err.problems[0].row, err.problems[0].found) == (21, "'-'"), err.problems[0]


def test_ingest_still_takes_every_word_pyarrow_took():
    import pyarrow.csv as pacsv

    assert set(pacsv.ConvertOptions().null_values) <= set(NULL_VALUES)
