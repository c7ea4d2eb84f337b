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

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import validate
from support.corpus import DRIVE, FILE, good_target, target_path, write_good_fleet, write_target
from support.drives import make_params
from support.fuzz import corrupted_frames

FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 12)),  # more: FUZZ_EXAMPLES=1000
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=True,
    database=None,
)


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
            # a faster table's streams are named by the file and the rows ("C-X1.csv [rows
            # with a fix]")
            named = {Path(p.file.split(" [")[0]).name for p in err.problems}
            assert named == {FILE}, str(err)
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
