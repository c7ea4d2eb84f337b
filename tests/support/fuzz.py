"""Hypothesis strategies of corrupted drives, shared by the stages' and the commands' fuzz tests.

- :func:`corrupted_frames`: a good 10 Hz target test drive (``support.corpus``) with a few
  random edits of its values (cells set to NaN, inf, 0, negative or huge values; rows
  dropped, repeated or swapped; columns scaled, shifted, exchanged or negated; the drive cut
  short).
- :func:`edited_stream_drives`: the stream corpus's good drive as one CSV per stream
  (``support.stream_corpus``) with a few random edits of the kind loggers and exports make
  (lines dropped, repeated, swapped, shuffled or written late, the header line again, a
  cell made text, empty, NaN, inf or huge, the file cut mid-line, bytes flipped).
- :func:`edit_lines`: a block of a file's lines dropped, repeated, swapped, shuffled or one
  written late (for the stream CSVs and the NMEA log alike).
- :func:`nothing_on_stdout`: that a fuzzed read printed nothing to the process's stdout.
- :func:`fuzz_settings`: hypothesis's settings for them (fixed examples; ``FUZZ_EXAMPLES``
  sets how many).
- :func:`grid_or_clear_refusal`: that a fuzzed stream drive read and resampled into a grid,
  or was refused naming its own files (:func:`names_only`).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.errors import InputError, Problem
from support.corpus import good_target
from support.stream_corpus import write_good

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


STREAM_FILES = ("wheels.csv", "gnss.csv")
CELLS = ["abc", "", "NaN", "inf", "-inf", "1e300", "-1", "0"]


def _good_stream_lines() -> dict[str, list[str]]:
    with tempfile.TemporaryDirectory() as tmp:
        folder = write_good("csv", Path(tmp))
        return {name: (folder / name).read_text().splitlines() for name in STREAM_FILES}


GOOD_STREAMS = _good_stream_lines()


LINE_EDITS = ("drop", "repeat", "swap", "shuffle", "late")


def edit_lines(draw, rows: list, kind: str, a: int, b: int) -> None:
    """One of :data:`LINE_EDITS` on lines ``a:b`` of ``rows``, in place: dropped, written
    again after themselves, the first and last swapped, shuffled, or line ``a`` written up
    to 40 lines after its place."""
    if kind == "drop":
        del rows[a:b]
    elif kind == "repeat":
        rows[b:b] = rows[a:b]
    elif kind == "swap":
        rows[a], rows[b - 1] = rows[b - 1], rows[a]
    elif kind == "shuffle":
        block = rows[a:b]
        rows[a:b] = [block[i] for i in draw(st.permutations(range(len(block))))]
    else:  # late
        line = rows.pop(a)
        rows.insert(min(len(rows), a + draw(st.integers(1, 40))), line)


def edited_log(draw, rows: list[str], own: Sequence[str], edit_own, line_end: str) -> bytes:
    """A text log's lines with 1-5 random edits, as bytes: :data:`LINE_EDITS` on a block
    of up to 90 lines, the file cut up to 400 bytes short, a byte flipped, or one of the
    log's ``own`` kinds, done by ``edit_own(draw, rows, kind, line)`` in place."""
    cut, flips = None, []
    for _ in range(draw(st.integers(1, 5))):
        n = len(rows)
        if n < 3:
            continue
        a = draw(st.integers(0, n - 2))
        b = min(n, a + draw(st.integers(1, 90)))
        kind = draw(st.sampled_from([*LINE_EDITS, *own, "cut", "flip"]))
        if kind in LINE_EDITS:
            edit_lines(draw, rows, kind, a, b)
        elif kind == "cut":
            cut = draw(st.integers(0, 400))
        elif kind == "flip":
            flips.append((draw(st.integers(0, 10**6)), draw(st.integers(0, 255))))
        else:
            edit_own(draw, rows, kind, a)
    data = bytearray((line_end.join(rows) + line_end).encode())
    for at, value in flips:
        data[at % len(data)] = value
    return bytes(data if cut is None else data[: max(0, len(data) - cut)])


def edited_messages(draw, rows: list[bytes], edit_one) -> bytes:
    """A binary log's messages (an epoch's a row) with 1-5 random edits, as bytes:
    :data:`LINE_EDITS` on a block of up to 90 rows, one row's message edited by
    ``edit_one(draw, rows, row)`` in place (a byte set, its checksum mended or not), the
    file cut up to 400 bytes short, a byte flipped."""
    cut, flips = None, []
    for _ in range(draw(st.integers(1, 5))):
        a = draw(st.integers(0, len(rows) - 2)) if len(rows) > 2 else 0
        kind = draw(st.sampled_from([*LINE_EDITS, "field", "cut", "flip"]))
        if kind in LINE_EDITS and len(rows) > 2:
            edit_lines(draw, rows, kind, a, min(len(rows), a + draw(st.integers(1, 90))))
        elif kind == "field" and rows:
            edit_one(draw, rows, a)
        elif kind == "cut":
            cut = draw(st.integers(0, 400))
        elif kind == "flip":
            flips.append((draw(st.integers(0, 10**6)), draw(st.integers(0, 255))))
    data = bytearray(b"".join(rows))
    for at, value in flips:
        if data:
            data[at % len(data)] = value
    return bytes(data if cut is None else data[: max(0, len(data) - cut)])


def names_only(files: set[str]) -> Callable[[Problem], bool]:
    """Whether a problem names only ``files`` (a problem of several files names them all:
    ``gnss.csv, wheels.csv``)."""
    return lambda p: {Path(part).name for part in p.file.split(", ")} <= files


@st.composite
def edited_stream_drives(draw) -> dict[str, bytes]:
    """The good drive's two files with 1-5 random edits."""
    lines = {name: list(rows) for name, rows in GOOD_STREAMS.items()}
    cut: dict[str, int] = {}
    flips: list[tuple[str, int, int]] = []
    for _ in range(draw(st.integers(1, 5))):
        name = draw(st.sampled_from(STREAM_FILES))
        rows = lines[name]
        n = len(rows)
        if n < 3:
            continue
        a = draw(st.integers(1, n - 1))  # a data line (0 is the header)
        b = min(n, a + draw(st.integers(1, 300)))
        kind = draw(
            st.sampled_from(
                ["drop", "repeat", "swap", "shuffle", "late", "header", "cell", "cut", "flip"]
            )
        )
        if kind in LINE_EDITS:
            edit_lines(draw, rows, kind, a, b)
        elif kind == "header":
            rows.insert(a, rows[0])
        elif kind == "cell":
            cells = rows[a].split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(CELLS))
            rows[a] = ",".join(cells)
        elif kind == "cut":
            cut[name] = draw(st.integers(0, 400))  # bytes kept of the last line... of the file
        else:
            flips.append((name, draw(st.integers(0, 10**6)), draw(st.integers(0, 255))))
    out = {}
    for name, rows in lines.items():
        data = bytearray(("\n".join(rows) + "\n").encode())
        for file, at, value in flips:
            if file == name and data:
                data[at % len(data)] = value
        if name in cut:
            data = data[: max(0, len(data) - cut[name])]
        out[name] = bytes(data)
    return out


@contextmanager
def nothing_on_stdout(capfd) -> Iterator[None]:
    """Nothing written to the process's stdout, by Python or by a C library (LAPACK prints
    there on a matrix that is not finite): ``rwhonet predict`` writes its seconds there."""
    yield
    assert capfd.readouterr().out == ""


def grid_or_clear_refusal(read: Callable[[], RawDrive], named: Callable[[Problem], bool]) -> None:
    """``read()`` (a stream drive read and resampled) gives a grid whose columns have one
    length and whose times increase, or raises :class:`~rwhonet.errors.InputError` whose
    every problem is ``named`` (names the drive's own files) and says what was expected."""
    try:
        drive = read()
    except InputError as err:
        assert err.problems, str(err)
        assert all(named(p) for p in err.problems), str(err)
        assert all(p.fix or p.expected for p in err.problems), str(err)
        return
    t = np.asarray(drive.columns[c.T_S])
    assert all(len(np.asarray(v)) == t.size for v in drive.columns.values())
    assert t.size and (np.diff(t) > 0).all()


def fuzz_settings(examples: int, deadline_ms: int | None) -> settings:
    """``examples`` fixed examples per test (``FUZZ_EXAMPLES`` in the environment: that many),
    the same every run so a failure reproduces; each under ``deadline_ms`` (None: none), so
    a hang or a path gone quadratic fails."""
    return settings(
        max_examples=int(os.environ.get("FUZZ_EXAMPLES", examples)),
        deadline=deadline_ms,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
            HealthCheck.function_scoped_fixture,
        ],
        derandomize=True,
        database=None,
    )
