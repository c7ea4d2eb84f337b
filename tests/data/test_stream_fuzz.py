"""Fuzzing the stream CSV reader and resampler: any edit of a good drive reads or is refused.

A good drive of one CSV per stream (wheel speeds at 100 Hz, fixes at 10 Hz:
``support.stream_corpus``) gets random edits of the kind loggers and exports
make, several at once: lines dropped, repeated, swapped, shuffled or written
late, the header line again, a cell made text, empty, NaN, inf or huge, the
file cut mid-line, bytes flipped. Whatever comes out, reading and resampling it
(as ingest and ``rwhonet predict`` do) either gives a 10 Hz grid whose columns
have one length and whose times increase, or raises
:class:`~rwhonet.errors.InputError` whose problems name a file of the drive and
say what to do; never another exception, never a hang.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings

from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from support.fuzz import STREAM_FILES, edited_stream_drives
from support.stream_corpus import folder_of, read_case

FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 40)),  # more: FUZZ_EXAMPLES=1000
    deadline=5000,  # ms per example: a hang fails, as does a slow path gone quadratic
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=True,  # the same examples every run: a failure reproduces
    database=None,
)


@FUZZ
@given(files=edited_stream_drives())
def test_an_edited_stream_drive_reads_or_is_refused_clearly(files):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folder = folder_of("csv", root)
        folder.mkdir(parents=True)
        for name, data in files.items():
            (folder / name).write_bytes(data)
        try:
            drive = read_case("csv", root).drive
        except InputError as err:
            assert err.problems, str(err)
            # a problem of several files names them all ("gnss.csv, wheels.csv")
            named = {Path(part).name for p in err.problems for part in p.file.split(", ")}
            assert named <= {*STREAM_FILES, "streams"}, f"problems name {named}:\n{err}"
            assert all(p.fix or p.expected for p in err.problems), str(err)
            return
        t = np.asarray(drive.columns[c.T_S])
        assert all(len(np.asarray(v)) == t.size for v in drive.columns.values())
        assert t.size and (np.diff(t) > 0).all()
