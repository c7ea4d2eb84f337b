"""The stream readers' bad-input corpus (tests/support/stream_corpus.py): every case refused.

Each refusal must name the file (folder, array or stream), the row where there
is one, the channel as the file names it, what was expected and what was found,
and say what to do; the good drive of every format must read and resample to
the same grid.
"""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from support.stream_corpus import CASES, T0_S, good_tables, read_case, write_good


@pytest.mark.parametrize("case", CASES, ids=[x.name for x in CASES])
def test_case(case, tmp_path):
    case.write(tmp_path)
    with pytest.raises(InputError) as err:
        read_case(case.fmt, tmp_path)
    expect = case.expect
    match = [
        p
        for p in err.value.problems
        if expect.file in p.file
        and p.row == expect.row
        and p.column == expect.column
        and expect.expected in p.expected
        and expect.found in p.found
    ]
    assert match, f"no problem matches {expect}:\n{err.value}"
    assert all(p.fix for p in err.value.problems), str(err.value)


def test_the_good_drive_reads_the_same_in_every_format(tmp_path):
    # An MDF4 file's clock is its measurement's: from 0 at its start.
    starts = {"comma2k19": T0_S, "mdf4": 0.0, "csv": T0_S}
    drives = {}
    for fmt, t0 in starts.items():
        write_good(fmt, tmp_path / fmt, good_tables(t0_s=t0))
        drives[fmt] = read_case(fmt, tmp_path / fmt).drive.columns
    base = drives["csv"]
    for fmt, d in drives.items():
        np.testing.assert_allclose(d[c.T_S] - starts[fmt], base[c.T_S] - T0_S, atol=1e-6)
        for name in (c.LAT_DEG, c.LON_DEG, *c.WHEELS):
            np.testing.assert_allclose(d[name], base[name], rtol=1e-9, atol=1e-9)


def test_every_format_has_cases():
    assert {x.fmt for x in CASES} == {"comma2k19", "mdf4", "csv"}
    assert len({x.name for x in CASES}) == len(CASES)
