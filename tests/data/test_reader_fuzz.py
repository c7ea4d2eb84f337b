"""Fuzzing the drive readers: any bytes either read into a drive or raise InputError.

Both readers (IO-VNBD and column map) get arbitrary byte strings and mutations of
a good file (truncated, bytes flipped, commas, line breaks, quotes and NUL bytes
inserted, lines dropped or repeated). Whatever comes in, the reader returns a
drive whose columns all have one length, or raises
:class:`~rwhonet.errors.InputError` whose problems name the file and say what to
do; never another exception, never a hang (each example runs under a deadline).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rwhonet.config import ColumnSpec
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError
from support.drives import CUPAC_MAP

FIXTURES = Path(__file__).parents[1] / "fixtures"
GOOD = {
    "iovnbd": (FIXTURES / "iovnbd" / "V-T1.csv").read_bytes(),
    "cupac": (FIXTURES / "cupac" / "C-T1.csv").read_bytes(),
}
CUPAC = {k: ColumnSpec(col, unit) for k, (col, unit) in CUPAC_MAP.items()}
FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 80)),  # more: FUZZ_EXAMPLES=3000
    deadline=2000,  # ms per example: a hang fails, as does a slow path gone quadratic
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,  # the same examples every run: a failure reproduces
    database=None,
)


def _read(fmt: str, data: bytes) -> None:
    """Read ``data`` as a drive file of ``fmt``; pass on a drive or InputError, fail otherwise."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "V-F1.csv"
        path.write_bytes(data)
        try:
            if fmt == "iovnbd":
                raw = read_iovnbd(path, "V-F1.csv")
            else:
                raw = read_columnmap(path, CUPAC, "cupac", "V-F1.csv")
        except InputError as err:
            assert err.problems, "an InputError without problems"
            assert all(p.file == "V-F1.csv" for p in err.problems)
            assert all(p.fix for p in err.problems), str(err)
            return
    lengths = {len(v) for v in raw.columns.values()}
    assert len(lengths) == 1 and lengths.pop() >= 1
    assert all(v.dtype == np.float64 for v in raw.columns.values())


@st.composite
def mutated(draw, fmt: str) -> bytes:
    """A good file with a few random edits."""
    data = bytearray(GOOD[fmt])
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["truncate", "flip", "insert", "delete", "lines"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if kind == "truncate":
            del data[at:]
        elif kind == "flip" and data:
            data[at] = draw(st.integers(0, 255))
        elif kind == "insert":
            data[at:at] = draw(
                st.sampled_from([b",", b"\n", b"\r", b"\x00", b'"', b";", b"\xff\xfe", b"nan"])
            )
        elif kind == "delete":
            del data[at : at + draw(st.integers(1, 40))]
        else:
            lines = bytes(data).split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            lines = lines[:i] + lines[i + 1 :] if draw(st.booleans()) else [*lines, lines[i]]
            data = bytearray(b"\n".join(lines))
    return bytes(data)


@FUZZ
@given(data=st.binary(max_size=2000))
def test_any_bytes_iovnbd(data):
    _read("iovnbd", data)


@FUZZ
@given(data=st.binary(max_size=2000))
def test_any_bytes_column_map(data):
    _read("cupac", data)


@FUZZ
@given(data=mutated("iovnbd"))
def test_mutated_good_file_iovnbd(data):
    _read("iovnbd", data)


@FUZZ
@given(data=mutated("cupac"))
def test_mutated_good_file_column_map(data):
    _read("cupac", data)


@FUZZ
@given(
    header=st.lists(st.text(max_size=12), min_size=1, max_size=35),
    rows=st.lists(st.lists(st.text(max_size=10), max_size=35), max_size=5),
)
def test_any_text_table_iovnbd(header, rows):
    """Arbitrary cells (any Unicode, quotes, separators) in a CSV-shaped file."""
    text = "\n".join(",".join(r) for r in [header, *rows])
    _read("iovnbd", text.encode("utf-8"))


def test_the_good_files_read():
    _read("iovnbd", GOOD["iovnbd"])
    _read("cupac", GOOD["cupac"])
