"""A Vector BLF log's frames parsed a batch of objects at a time (rwhonet.data.blf):
python-can's reader's messages, bit for bit, on logs its writer wrote, on objects built by
its layouts (the ones its writer does not write), on every cut of a log, and on damaged and
edited logs; each in one batch, a container a batch, and batches of 200 bytes."""

from __future__ import annotations

import contextlib
import os
import time
import zlib
from collections.abc import Iterator
from pathlib import Path

import can
import numpy as np
import pytest
from can.io.blf import (
    CAN_FD_MSG_64_STRUCT,
    CAN_MSG_STRUCT,
    FILE_HEADER_SIZE,
    FILE_HEADER_STRUCT,
    LOG_CONTAINER_STRUCT,
    OBJ_HEADER_BASE_STRUCT,
    OBJ_HEADER_V1_STRUCT,
    OBJ_HEADER_V2_STRUCT,
)
from hypothesis import given
from hypothesis import strategies as st

from rwhonet.data.blf import BlfError, blf_frames
from rwhonet.data.canlog import _blf, _python_can
from rwhonet.errors import InputError
from support.canlog import assert_same_frames
from support.fuzz import fuzz_settings

T0_S = 1_700_000_000.0


@pytest.fixture(autouse=True, params=["whole", 1, 200])
def batch(request, monkeypatch):  # type: ignore[no-untyped-def]
    """Every test on the objects parsed in one batch (a log here is far below
    BATCH_BYTES), a container a batch, and batches of about 200 inflated bytes: objects
    run on from one batch into the next, cut anywhere."""
    from rwhonet.data import blf

    if request.param != "whole":
        monkeypatch.setattr(blf, "BATCH_BYTES", request.param)
    return request.param


@contextlib.contextmanager
def _in_zone(zone: str) -> Iterator[None]:
    """The process's local time zone set to ``zone`` (python-can reads a BLF's start on
    it), then set back."""
    before = os.environ.get("TZ")
    os.environ["TZ"] = zone
    time.tzset()
    try:
        yield
    finally:
        if before is None:
            del os.environ["TZ"]
        else:
            os.environ["TZ"] = before
        time.tzset()


def _python_can_messages(path: Path) -> tuple[list[can.Message], Exception | None]:
    """What python-can's reader yields, and the error it stops with (None: none), read on
    a UTC clock, as this reader reads a BLF's start wherever it runs."""
    got: list[can.Message] = []
    try:
        with _in_zone("UTC"), can.BLFReader(path) as reader:
            got.extend(reader)
    except Exception as err:  # whatever its parsers raise
        return got, err
    return got, None


def _same_as_python_can(path: Path) -> int:
    """That the reader gives python-can's messages, or stops where python-can stops with
    the data frames it yielded before; the messages' count (-1: both refused). python-can
    is not asked where the reader finds an object of size 0: its reader would find that
    object again for ever (-2)."""
    try:
        got = blf_frames(path.read_bytes())
    except BlfError as err:
        if "an object of size 0" in str(err):
            return -2
        want, error = _python_can_messages(path)
        assert error is not None, f"python-can read {len(want)} messages; ours: {err}"
        data = [m for m in want if not m.is_error_frame and not m.is_remote_frame]
        assert err.data_frames in (len(data), None)
        return -1
    want, error = _python_can_messages(path)
    assert error is None, f"python-can stopped with {error!r}; ours read {got.t_s.size}"
    assert got.t_s.tolist() == [m.timestamp for m in want]
    assert (got.ids & 0x1FFF_FFFF).tolist() == [m.arbitration_id for m in want]
    assert ((got.ids & 0x8000_0000) != 0).tolist() == [m.is_extended_id for m in want]
    assert got.error.tolist() == [m.is_error_frame for m in want]
    assert got.remote.tolist() == [m.is_remote_frame for m in want]
    assert got.channel.tolist() == [m.channel for m in want]
    data = [
        bytes(row[:n]) for row, n, r in zip(got.data, got.length, got.remote, strict=True) if not r
    ]
    assert data == [bytes(m.data) for m in want if not m.is_remote_frame]
    return len(want)


def _written(path: Path, n: int = 3000, seed: int = 0) -> Path:
    """python-can's writer's log of ``n`` messages: standard and extended data frames of
    0-8 bytes, CAN FD frames of every length, remote and error frames, on three channels,
    some of whose data hold ``LOBJ`` (an object's signature inside another's bytes)."""
    rng = np.random.default_rng(seed)
    t = T0_S + np.cumsum(rng.uniform(0.0, 0.002, n))
    fd_lengths = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64]
    with can.BLFWriter(str(path)) as writer:
        for i in range(n):
            kind, channel = int(rng.integers(0, 6)), int(rng.integers(0, 3))
            payload = bytes(rng.integers(0, 256, int(rng.integers(0, 9))).tolist())
            if kind == 0:
                msg = can.Message(arbitration_id=int(rng.integers(0, 0x800)), data=payload)
            elif kind == 1:
                msg = can.Message(
                    arbitration_id=int(rng.integers(0, 0x2000_0000)),
                    is_extended_id=True,
                    data=payload,
                )
            elif kind == 2:
                size = fd_lengths[int(rng.integers(0, 16))]
                msg = can.Message(
                    arbitration_id=0x123,
                    is_fd=True,
                    bitrate_switch=True,
                    data=bytes(rng.integers(0, 256, size).tolist()),
                )
            elif kind == 3:
                msg = can.Message(arbitration_id=0x55, is_remote_frame=True, dlc=4)
            elif kind == 4:
                msg = can.Message(arbitration_id=0x2000_0080, is_error_frame=True)
            else:
                msg = can.Message(arbitration_id=0x1A0, data=b"LOBJ" + payload[:4])
            msg.timestamp, msg.channel = float(t[i]), channel
            writer.on_message_received(msg)
    return path


def test_python_can_s_writer_s_log_reads_as_python_can_reads_it(tmp_path):
    path = _written(tmp_path / "bus.blf")
    assert _same_as_python_can(path) == 3000
    # and the Frames the pipeline decodes: python-can's reader's, array for array
    ours, theirs = _blf(path, "bus.blf"), _python_can(path, "bus.blf", ".blf")
    assert_same_frames(ours, theirs)
    assert "error frames" in ours.passed and "remote frames" in ours.passed


def test_every_cut_of_a_log_reads_as_python_can_reads_it(tmp_path):
    """A logger that lost power: the file cut at any byte (in the header, in a container's
    header, inside its deflated data, between containers) gives python-can's messages."""
    raw = _written(tmp_path / "whole.blf", n=1500).read_bytes()
    counts = []
    for cut in [*range(0, 200, 7), *range(200, len(raw), max(1, len(raw) // 150)), len(raw)]:
        path = tmp_path / "cut.blf"
        path.write_bytes(raw[:cut])
        counts.append(_same_as_python_can(path))
    assert counts[-1] == 1500 and len({c for c in counts if c > 0}) > 50


def test_a_log_cut_inside_an_object_says_so(tmp_path):
    """A cut inside a container (or any top-level object) is read as far as it goes, as
    python-can reads it, and said with what was passed over (for the drive's notes and
    predict's summary): where, and how much of the object is there. A log cut between
    objects, or whole, says nothing; a cut in an object's header is refused, as python-can
    refuses it (above)."""
    import struct

    raw = _written(tmp_path / "whole.blf", n=12000).read_bytes()
    header = FILE_HEADER_STRUCT.unpack_from(raw)[1]
    starts, pos = [], header
    while pos + 16 <= len(raw):
        starts.append(pos)
        pos += struct.unpack_from("<L", raw, pos + 8)[0]
        pos += (pos - starts[-1]) % 4
    assert len(starts) > 2 and pos == len(raw)
    second, third = starts[1], starts[2]
    size = struct.unpack_from("<L", raw, second + 8)[0]  # without its padding to 4
    for cut, said in [
        (len(raw), None),
        (third, None),
        (
            second + 100,
            f"the log cut short: it ends in an object of {size:,} bytes at byte {second:,}, "
            "100 of them there (read as far as it goes)",
        ),
    ]:
        path = tmp_path / "cut.blf"
        path.write_bytes(raw[:cut])
        frames = _blf(path, "cut.blf")
        assert (said in frames.passed) if said else "cut short" not in frames.passed
        assert _same_as_python_can(path) > 0  # python-can's messages, bit for bit


def _object(kind: int, body: bytes, stamp: int, version: int = 1, flags: int = 2) -> bytes:
    """An inner object: its base header, its version's header, the body, padded to 4."""
    if version == 1:
        head = OBJ_HEADER_V1_STRUCT.pack(flags, 0, 0, stamp)
    elif version == 2:
        head = OBJ_HEADER_V2_STRUCT.pack(flags, 0, 0, stamp)
    else:
        head = bytes(16)
    size = OBJ_HEADER_BASE_STRUCT.size + len(head) + len(body)
    base = OBJ_HEADER_BASE_STRUCT.pack(b"LOBJ", 16 + len(head), version, size, kind)
    return base + head + body + bytes(size % 4)


def _log(inner: bytes, split: int | None = None, methods=(2, 2)) -> bytes:
    """A BLF file of the inner objects in one or two containers (split at byte ``split``):
    method 2 deflated, 0 stored, anything else a method python-can passes over."""
    header = FILE_HEADER_STRUCT.pack(
        b"LOGG", FILE_HEADER_SIZE, 5, 0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0,
        *(2023, 11, 2, 14, 22, 13, 20, 0), *(2023, 11, 2, 14, 22, 13, 21, 0),
    )  # fmt: skip
    out = header + bytes(FILE_HEADER_SIZE - len(header))
    parts = [inner] if split is None else [inner[:split], inner[split:]]
    for part, method in zip(parts, methods, strict=False):
        data = zlib.compress(part) if method == 2 else part
        body = LOG_CONTAINER_STRUCT.pack(method, len(part)) + data
        size = 16 + len(body)
        out += OBJ_HEADER_BASE_STRUCT.pack(b"LOBJ", 16, 1, size, 10) + body + bytes(size % 4)
    return out


def _built() -> bytes:
    """Objects python-can's writer does not write and its reader reads or passes over:
    CAN_MESSAGE2, CAN_FD_MESSAGE_64 (data frames and a remote one), header version 2,
    stamps in 10 µs, a marker (passed over), an object of an unknown header version."""
    classic = CAN_MSG_STRUCT.pack(2, 0, 8, 0x1A0, bytes(range(8)))
    fd64_head = CAN_FD_MSG_64_STRUCT.pack(
        1, 13, 32, 0, 0x8000_0123, 0, 0x1000, 0, 0, 0, 0, 0, 0, 0, 0
    )
    fd64_remote = CAN_FD_MSG_64_STRUCT.pack(3, 4, 0, 0, 0x77, 0, 0x0010, 0, 0, 0, 0, 0, 0, 0, 0)
    return b"".join(
        [
            _object(1, classic, 1_000_000),
            _object(86, CAN_MSG_STRUCT.pack(1, 0, 3, 0x2A, b"abc" + bytes(5)), 2_000_000),
            _object(101, fd64_head + bytes(range(32)), 3_000_000),
            _object(101, fd64_remote, 3_500_000),
            _object(96, bytes(40), 4_000_000),  # a global marker
            _object(1, classic, 5_000_000, version=2),
            _object(1, classic, 500, flags=1),  # 10 µs stamps: 5 ms
            _object(1, classic, 6_000_000, version=3),  # an unknown header version
            _object(86, CAN_MSG_STRUCT.pack(1, 0x80, 2, 0x31, bytes(8)), 7_000_000),  # remote
        ]
    )  # fmt: skip


@pytest.mark.parametrize(
    ("split", "methods"),
    [(None, (2,)), (None, (0,)), (100, (2, 2)), (37, (0, 2)), (10, (0, 2)), (150, (2, 9))],
)
def test_objects_python_can_s_writer_does_not_write_read_as_python_can_reads_them(
    tmp_path, split, methods
):
    """In one container or two (an object split across them, or the first object's header:
    10 bytes), deflated or stored, or the second of a compression method python-can passes
    over."""
    path = tmp_path / "built.blf"
    path.write_bytes(_log(_built(), split, methods))
    n = _same_as_python_can(path)
    assert n == 7 if methods[-1] != 9 else 0 < n < 7
    if split is None:
        got = blf_frames(path.read_bytes())
        assert got.length.tolist() == [8, 3, 32, 0, 8, 8, 2]
        assert got.remote.tolist() == [False, False, False, True, False, False, True]


def test_damage_python_can_stops_at_is_refused_with_the_frames_before(tmp_path):
    """Bytes that are no object between two objects, a top-level object whose signature
    was lost, a container zlib cannot inflate: refused where python-can's reader stops,
    naming the data frames read before; through the pipeline's reader, an input error
    naming the file."""
    objects = _built()
    garbage = objects[:48] + b"\x00" * 12 + objects[48:]  # after the first object (48 bytes)
    cases = {
        "garbage": _log(garbage),
        "signature": (lambda r: r[:FILE_HEADER_SIZE] + b"XOBJ" + r[FILE_HEADER_SIZE + 4 :])(
            _log(objects)
        ),
        "deflate": (lambda r: r[:-20] + bytes(20))(_log(objects)),
        "second_signature": (lambda r, at: r[:at] + b"XOBJ" + r[at + 4 :])(
            _log(objects, 100), len(_log(objects[:100]))
        ),
    }
    for name, raw in cases.items():
        path = tmp_path / f"{name}.blf"
        path.write_bytes(raw)
        assert _same_as_python_can(path) == -1, name
        with pytest.raises(InputError) as err:
            _blf(path, path.name)
        (problem,) = err.value.problems
        assert problem.file == path.name and "a BLF CAN log python-can reads" in problem.expected
    with pytest.raises(BlfError) as err:
        blf_frames(_log(garbage))
    assert err.value.data_frames == 1 and "no object where the one before ends" in str(err.value)


@pytest.mark.parametrize("header_size", [60, 71, 72, 100, 144, 4000])
def test_a_file_header_s_size_is_taken_as_python_can_takes_it(tmp_path, header_size):
    """The header's own size field (144 as written; its fields take 72 bytes): python-can
    reads that many bytes before the objects (71, or more than the file holds: the rest of
    the file, no frame; under 71: it refuses)."""
    raw = _log(_built())
    path = tmp_path / "bus.blf"
    path.write_bytes(raw[:4] + header_size.to_bytes(4, "little") + raw[8:])
    n = _same_as_python_can(path)
    assert n == (7 if header_size == 144 else 0 if header_size in (71, 4000) else -1)


def test_an_object_of_size_0_is_refused_where_python_can_would_read_it_for_ever(tmp_path):
    first = _built()[:48]
    zero = OBJ_HEADER_BASE_STRUCT.pack(b"LOBJ", 32, 1, 0, 1) + bytes(36)
    with pytest.raises(BlfError, match="an object of size 0") as err:
        blf_frames(_log(first + zero))
    assert err.value.data_frames == 1


def test_a_file_that_is_no_blf_is_refused(tmp_path):
    path = tmp_path / "bus.blf"
    path.write_bytes(b"date Fri Dec 05 10:15:30.123 am 2025\n" * 10)
    with pytest.raises(InputError) as err:
        _blf(path, "bus.blf")
    assert "before any frame" in err.value.problems[0].fix


@st.composite
def _edited(draw) -> bytes:
    """A log with a few bytes overwritten, a block dropped or repeated, or cut; its
    containers mostly stored (not deflated), so that the edits reach the objects."""
    methods = draw(st.sampled_from([(0, 0), (0, 0), (0, 2), (2, 2)]))
    raw = bytearray(_log(_built() * 3, split=200, methods=methods))
    for _ in range(draw(st.integers(1, 3))):
        if not raw:
            break
        at = draw(st.integers(0, len(raw) - 1))
        kind = draw(st.sampled_from(["bytes", "drop", "repeat", "cut"]))
        if kind == "bytes":
            raw[at : at + 4] = draw(st.binary(min_size=1, max_size=4))
        elif kind == "drop":
            del raw[at : at + draw(st.integers(1, 64))]
        elif kind == "repeat":
            raw[at:at] = raw[at : at + draw(st.integers(1, 64))]
        else:
            del raw[at:]
    return bytes(raw)


@given(_edited())
@fuzz_settings(60, 10_000)
def test_an_edited_log_reads_as_python_can_reads_it_or_both_stop(tmp_path_factory, raw):
    """Whatever the edits, the reader gives python-can's messages or stops where it stops
    (python-can not asked where an object's size is 0: its reader would not end)."""
    path = tmp_path_factory.mktemp("edited") / "bus.blf"
    path.write_bytes(raw)
    _same_as_python_can(path)


def test_an_object_that_runs_past_its_container_is_read_from_the_next(tmp_path):
    """A classic message object 8 bytes short (python-can reads its message on into the
    next object's bytes), its container ending where it ends: read with the next
    container's bytes as python-can reads it, in every batching (a batch ending there goes
    on from the object, not after it)."""
    short = _object(1, CAN_MSG_STRUCT.pack(2, 0, 8, 0x1A0, bytes(range(8)))[:8], 1_000_000)
    inner = short + _built()
    path = tmp_path / "short.blf"
    path.write_bytes(_log(inner, split=len(short), methods=(0, 2)))
    assert _same_as_python_can(path) == 8
    assert blf_frames(path.read_bytes()).ids[0] == 0x1A0


def test_no_object_where_the_inner_stream_starts_is_said_so_in_every_batching(tmp_path):
    """Six bytes that are no object before the first (in a container of their own): python-
    can stops before any frame, and so does this, saying where, however the objects are
    batched."""
    path = tmp_path / "garbage.blf"
    path.write_bytes(_log(b"\x00" * 6 + _built(), split=6, methods=(0, 2)))
    assert _same_as_python_can(path) == -1
    with pytest.raises(BlfError) as err:
        blf_frames(path.read_bytes())
    assert "no object where the inner stream starts" in str(err.value)
    assert err.value.data_frames == 0


@pytest.mark.parametrize("zone", ["Europe/Berlin", "America/Detroit", "UTC"])
def test_a_blf_s_start_reads_alike_on_every_machine_and_in_the_map_s_zone(tmp_path, zone):
    """The header's start is a wall time without a zone: python-can reads it on the
    reading machine's clock (an hour apart in Berlin and on a UTC server); here it reads
    as UTC wherever the reader runs, and in the map's local_zone where given (14 Nov
    2023: CET, UTC+1 h; EST, UTC-5 h), its frames then on UTC an hour (five) earlier
    (later); a start in the hour Berlin's clocks went back is refused."""
    from datetime import UTC, datetime

    from rwhonet.data.canlog import read_frames

    path = _written(tmp_path / "bus.blf", n=200)
    with _in_zone("UTC"):
        utc = read_frames(path, "bus.blf")
    with _in_zone(zone):
        here = read_frames(path, "bus.blf")
        zoned = read_frames(path, "bus.blf", "Europe/Berlin")
        detroit = read_frames(path, "bus.blf", "America/Detroit")
    np.testing.assert_array_equal(here.t_s, utc.t_s)
    np.testing.assert_allclose(zoned.t_s, utc.t_s - 3600.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(detroit.t_s, utc.t_s + 5 * 3600.0, rtol=0, atol=1e-6)
    assert zoned.clock.endswith(", its header's start in Europe/Berlin")
    raw = bytearray(path.read_bytes())
    start = FILE_HEADER_STRUCT.unpack_from(raw)[14:22]
    fields = list(FILE_HEADER_STRUCT.unpack_from(raw))
    fields[14:22] = [2024, 10, 0, 27, 2, 30, 0, 0]  # 02:30 on the night the clocks went back
    raw[: FILE_HEADER_STRUCT.size] = FILE_HEADER_STRUCT.pack(*fields)
    path.write_bytes(bytes(raw))
    with pytest.raises(InputError) as err:
        read_frames(path, "bus.blf", "Europe/Berlin")
    assert "in the hour its clocks went back: UTC+2 or UTC+1" in str(err.value)
    first = read_frames(path, "bus.blf", "Etc/GMT-2").t_s[0]
    assert datetime(2024, 10, 27, 0, 30, tzinfo=UTC).timestamp() <= first
    assert start[0] == 2023  # the writer's start (16 Nov 2023), as it wrote it
