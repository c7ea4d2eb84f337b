"""Fuzzing ingest and validate together: any corrupted drive gets through or gets a clear error.

Random edits of a good target test drive, at the level of its values (cells set to
NaN, inf, 0, negative or huge values; rows dropped, repeated or swapped; columns
scaled, shifted, exchanged or negated; the drive cut short) and of its bytes,
go through the real ``ingest`` and ``validate`` stage functions among good
drives. Each must end in segments and a report, or in an ``InputError`` whose
problems name the corrupted file and say what to do; never another exception.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import validate
from support.corpus import DRIVE, FILE, good_target, target_path, write_good_fleet, write_target
from support.drives import make_params

FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 12)),  # more: FUZZ_EXAMPLES=1000
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=True,
    database=None,
)
COLUMNS = [c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS, c.N_SATS]
VALUES = [np.nan, np.inf, -np.inf, 0.0, -1.0, 1e9, -1e9, 95.0, 200.0, 1e-9]


@st.composite
def corrupted_frames(draw) -> pd.DataFrame:
    """A good target drive (shortened at random) with a few random edits of its values."""
    df = good_target(draw(st.sampled_from([3.0, 40.0, 150.0])))
    n = len(df)
    for _ in range(draw(st.integers(1, 4))):
        if n == 0:
            break
        kind = draw(st.sampled_from(["cells", "rows", "column", "truncate"]))
        a = draw(st.integers(0, n - 1))
        b = min(n, a + draw(st.integers(1, 400)))
        col = draw(st.sampled_from(COLUMNS))
        if kind == "cells":
            df.loc[a : b - 1, col] = draw(st.sampled_from(VALUES))
        elif kind == "rows":
            how = draw(st.sampled_from(["drop", "repeat", "swap"]))
            if how == "drop":
                df = df.drop(index=df.index[a:b])
            elif how == "repeat":
                df = pd.concat([df.iloc[:b], df.iloc[a:]])
            else:
                order = np.arange(len(df))
                order[a], order[b - 1] = order[b - 1], order[a]
                df = df.iloc[order]
            df = df.reset_index(drop=True)
            n = len(df)
        elif kind == "column":
            how = draw(st.sampled_from(["scale", "shift", "negate", "exchange"]))
            if how == "scale":
                df[col] = df[col] * draw(st.sampled_from([0.0, 0.001, 0.5, 3.6, 1000.0]))
            elif how == "shift":
                df[col] = df[col] + draw(st.sampled_from([-100.0, 0.05, 86400.0]))
            elif how == "negate":
                df[col] = -df[col]
            else:
                other = draw(st.sampled_from(COLUMNS))
                df[[col, other]] = df[[other, col]].to_numpy()
        elif len(df) > 1:
            df = df.iloc[: draw(st.integers(1, len(df)))].reset_index(drop=True)
            n = len(df)
    return df


def _run(write) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        write_good_fleet(root / "raw")
        write(root / "raw")
        params = make_params(root / "raw")
        try:
            ingest(params, root / "drives")
            validate(params, root / "drives", root / "segments", root / "report.json")
        except InputError as err:
            assert {Path(p.file).name for p in err.problems} == {FILE}, str(err)
            assert all(p.fix for p in err.problems), str(err)
            return
        assert (root / "segments" / "manifest.json").is_file()


@FUZZ
@given(df=corrupted_frames())
def test_corrupted_values(df):
    _run(lambda raw: write_target(raw, df))


@FUZZ
@given(
    cuts=st.lists(st.tuples(st.integers(0, 300_000), st.binary(max_size=8)), max_size=6),
    truncate=st.one_of(st.none(), st.integers(0, 300_000)),
)
def test_corrupted_bytes(cuts, truncate):
    def write(raw: Path) -> None:
        data = bytearray(write_target(raw, good_target()).read_bytes())
        for at, insert in cuts:
            at = min(at, len(data))
            data[at : at + len(insert)] = insert  # overwrite a few bytes
        target_path(raw).write_bytes(bytes(data[:truncate] if truncate is not None else data))

    _run(write)


def test_the_drive_is_named_as_expected():
    assert FILE == f"{DRIVE}.csv"
