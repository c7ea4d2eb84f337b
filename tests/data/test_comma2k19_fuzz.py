"""Fuzzing the comma2k19 reader on the one real drive we have: any edit reads or is refused clearly.

The real RAV4 minute (``../shared/real/comma2k19-example1``: CAN wheel speeds at
about 80 Hz on a phone's jittered stamps, u-blox fixes at 10 Hz, the phone's gyro)
gets 1-4 random edits of its arrays, of the kind a logger, a conversion script or
a copy makes: a stretch of samples dropped (from the times and the values
together, or from the values only), repeated, swapped, shuffled or written late;
a value made NaN, inf or 1e300; the times saved as float32; a stream's times
moved by a clock offset; an array file cut short. Reading and resampling it as
ingest and ``rwhonet predict`` do either gives a 10 Hz grid whose times increase
and whose columns have one length, or raises :class:`~rwhonet.errors.InputError`
whose problems name the segment's arrays and say what to do; never another
exception, never a hang.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rwhonet import paths
from rwhonet.data.comma2k19 import read_comma2k19
from rwhonet.data.streams import resample
from support.fuzz import fuzz_settings, grid_or_clear_refusal, nothing_on_stdout

REAL = paths.ROOT.parent / "shared" / "real" / "comma2k19-example1"
RAV4_RADIUS_M = 0.362
STREAMS = ("CAN/wheel_speed", "GNSS/live_gnss_ublox", "IMU/gyro")
FUZZ = fuzz_settings(30, deadline_ms=10_000)


@st.composite
def edits(draw) -> list[tuple]:
    """1-4 edits: (stream, kind, and the kind's numbers drawn as fractions or values)."""
    kinds = ["drop", "drop_values", "repeat", "swap", "shuffle", "late", "cell", "float32"]
    kinds += ["offset", "cut"]
    out = []
    for _ in range(draw(st.integers(1, 4))):
        out.append(
            (
                draw(st.sampled_from(STREAMS)),
                draw(st.sampled_from(kinds)),
                draw(st.floats(0.0, 1.0)),  # where
                draw(st.integers(1, 400)),  # how many samples
                draw(st.sampled_from([np.nan, np.inf, -np.inf, 1e300, 0.0, -5.0])),
                draw(st.sampled_from([-40.0, -1.5, 0.3, 18.0, 3600.0])),  # a clock offset, s
                draw(st.permutations(range(8))),
            )
        )
    return out


def _apply(folder: Path, edit: tuple) -> None:
    stream, kind, where, n, value, offset, perm = edit
    base = folder / "processed_log" / stream
    t, v = np.load(base / "t"), np.load(base / "value")
    a = int(where * (t.size - 1))
    b = min(t.size, a + n)
    if kind == "drop":
        keep = np.r_[0:a, b : t.size]
        t, v = t[keep], v[keep]
    elif kind == "drop_values":
        v = np.delete(v, np.s_[a:b], axis=0)
    elif kind == "repeat":
        t, v = np.r_[t[:b], t[a:]], np.concatenate([v[:b], v[a:]])
    elif kind == "swap":
        order = np.arange(t.size)
        order[a], order[b - 1] = order[b - 1], order[a]
        t, v = t[order], v[order]
    elif kind == "shuffle":
        order = np.arange(t.size)
        block = order[a:b].copy()
        for i in range(0, block.size - 1, 8):  # each run of eight in the drawn order
            chunk = block[i : i + 8]
            order[a + i : a + i + chunk.size] = chunk[[p for p in perm if p < chunk.size]]
        t, v = t[order], v[order]
    elif kind == "late":
        order = np.arange(t.size)
        order = np.insert(np.delete(order, a), min(t.size - 1, a + n % 40 + 1), a)
        t, v = t[order], v[order]
    elif kind == "cell":
        v = v.astype(np.float64)
        v.reshape(v.shape[0], -1)[a, n % v.reshape(v.shape[0], -1).shape[1]] = value
    elif kind == "float32":
        t = t.astype(np.float32)
    elif kind == "offset":
        t = t + offset
    for name, array in (("t", t), ("value", v)):
        with open(base / name, "wb") as f:
            np.save(f, array)
    if kind == "cut":
        data = (base / "value").read_bytes()
        (base / "value").write_bytes(data[: int(where * len(data))])


@pytest.fixture(scope="module")
def real():
    if not (REAL / "processed_log").is_dir():
        pytest.skip(f"the real comma2k19 segment is not on this machine ({REAL})")
    return REAL


@FUZZ
@given(changes=edits())
def test_an_edited_real_segment_reads_or_is_refused_clearly(real, changes, capfd):
    capfd.readouterr()
    with tempfile.TemporaryDirectory() as tmp, nothing_on_stdout(capfd):
        folder = Path(tmp) / "seg"
        shutil.copytree(real / "processed_log", folder / "processed_log")
        broken: set[str] = set()  # a stream cut short or its arrays of two lengths: as left
        for edit in changes:
            if edit[0] not in broken:
                _apply(folder, edit)
            if edit[1] in ("cut", "drop_values"):
                broken.add(edit[0])
        grid_or_clear_refusal(
            lambda: (
                resample(
                    read_comma2k19(folder, RAV4_RADIUS_M, display="seg"),
                    nominal_radius_m=RAV4_RADIUS_M,
                    require_fix=False,
                ).drive
            ),
            lambda p: p.file.startswith("seg"),
        )
