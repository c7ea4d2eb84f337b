"""A ROS 1 bag with a damaged chunk (a disk's or a card's error), read record by record.

``rosbags`` refuses a closed bag whose chunk does not unpack or whose record header is
damaged, and with it the whole drive. :func:`rwhonet.data.rosbag.read_bag` reads such a
bag again from its start (:class:`rwhonet.data.bagscan.ScannedBag`): a compressed chunk
that does not unpack is passed over, a damaged record header passed over to the next
place a record starts (in an uncompressed chunk, or in the file), and the notes say so.
Where nothing whole is left, the bag is refused with ``rosbags``' own error.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.bagscan import MAGIC, OP_CHUNK, NoWholeMessage, ScannedBag, _records
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.errors import InputError
from support.rosbag import bag_map, write_bag

R, V = 0.3, 14.0


def _bag(tmp_path: Path, compression: str | None, name: str = "b.bag") -> Path:
    """60 s of wheels at 50 Hz and fixes at 10 Hz, in chunks of 64 KiB."""
    t_w = np.arange(0.0, 60.0, 0.02) + 100.0
    t_g = np.arange(0.0, 60.0, 0.1) + 100.05
    fixes = (t_g, 48.1 + V * (t_g - 100.0) / 111_200.0, np.full(t_g.size, 11.5))
    wheels = (t_w, np.full((t_w.size, 4), V / R))
    return write_bag(tmp_path / name, wheels, fixes, compression=compression, chunk_bytes=1 << 16)


def _chunks(data: bytes) -> list[tuple[int, int]]:
    """Each chunk record's data: its start and length."""
    return [(s, n) for f, s, n in _records(data, len(MAGIC)) if f["op"][0] == OP_CHUNK]


def _damaged(bag: Path, k: int, at: float = 0.5, name: str = "d.bag") -> Path:
    """The bag with one byte of chunk ``k``'s data changed, ``at`` of the way in."""
    data = bytearray(bag.read_bytes())
    start, n = _chunks(bytes(data))[k]
    data[start + int(n * at)] ^= 0xFF
    out = bag.with_name(name)
    out.write_bytes(bytes(data))
    return out


@pytest.mark.parametrize("compression", [None, "bz2", "lz4"])
def test_a_closed_bag_with_a_damaged_chunk_is_read_past_it(tmp_path, compression):
    bag = _bag(tmp_path, compression)
    whole = read_mdf4(bag, bag_map(), R, "m", "b.bag")
    n_chunks = len(_chunks(bag.read_bytes()))
    assert n_chunks >= 5
    k = n_chunks // 2
    damaged = _damaged(bag, k)
    from rosbags.highlevel import AnyReader

    with pytest.raises(Exception), AnyReader([damaged]) as reader:  # noqa: B017, PT011
        for _ in reader.messages():  # rosbags refuses it, as it opens or reads it
            pass
    streams = read_mdf4(damaged, bag_map(), R, "m", "d.bag")
    said = "\n".join(streams.notes)
    assert "d.bag: rosbags refused the bag (" in said and "closed as it is" in said
    assert "1 damaged stretch(es) passed over (a " in said
    t_all, t_got = whole.gnss.t_s, streams.gnss.t_s
    # every fix read is the whole bag's, with its position; those of the chunk are lost,
    # those after it read
    assert set(t_got) <= set(t_all) and t_got[-1] == t_all[-1]
    i = np.searchsorted(t_all, t_got)
    np.testing.assert_array_equal(
        streams.gnss.channels[c.LAT_DEG], whole.gnss.channels[c.LAT_DEG][i]
    )
    lost = t_all.size - t_got.size
    got = sum(w.t_s.size for w in streams.wheels) + t_got.size
    want = sum(w.t_s.size for w in whole.wheels) + t_all.size
    if compression is None:  # the damaged record passed over, the chunk read on past it
        assert re.search(r"a chunk at byte \d+: its bytes \d+ to \d+ of \d+ passed over", said)
        assert want - 4 <= got < want  # one message lost (each wheel's sample of it)
    else:
        assert 0 < lost < t_all.size / 3


def test_a_bag_whose_every_chunk_is_damaged_is_refused_with_rosbags_error(tmp_path):
    bag = _bag(tmp_path, "bz2")
    data = bytearray(bag.read_bytes())
    for start, n in _chunks(bytes(data)):
        data[start + n // 2] ^= 0xFF
    damaged = tmp_path / "all.bag"
    damaged.write_bytes(bytes(data))
    with pytest.raises(InputError) as err:
        read_mdf4(damaged, bag_map(), R, "m", "all.bag")
    (p,) = err.value.problems
    assert p.file == "all.bag" and "OSError: Invalid data stream" in p.found
    with pytest.raises(NoWholeMessage, match=r"no whole message: \d+ damaged stretch\(es\) passed"):
        ScannedBag(damaged, refused="OSError")


def test_a_file_that_is_no_bag_is_refused_as_before_not_scanned(tmp_path):
    junk = tmp_path / "j.bag"
    junk.write_bytes(b"not a bag at all\n" * 100)
    with pytest.raises(InputError) as err:
        read_mdf4(junk, bag_map(), R, "m", "j.bag")
    (p,) = err.value.problems
    assert "ROS 1 bag" in p.expected and p.found == "AnyReaderError: File magic is invalid."


@pytest.mark.parametrize(
    ("compression", "which"), [(None, "middle"), (None, "first"), ("lz4", "middle")]
)
def test_a_chunk_record_s_header_damaged_is_passed_over_to_the_next_chunk(
    tmp_path, compression, which
):
    """A chunk record whose header is damaged (no ``op``) is no record: the read goes on at
    the next record of the file (the chunk's index record, not a connection record inside
    the chunk: the first chunk holds them), says which bytes it passed over, and reads
    every chunk after it; the chunk's own records are read where it is uncompressed (its
    header still says ``compression=none``), not where it is lz4 (whose literals may hold
    a record's header without its data)."""
    bag = _bag(tmp_path, compression)
    whole = ScannedBag(bag, refused="test")
    n_whole = whole.message_count
    whole.close()
    data = bytearray(bag.read_bytes())
    starts = _chunks(bytes(data))
    k = len(starts) // 2 if which == "middle" else 0
    at = data.rindex(b"op=", 0, starts[k][0])  # the chunk record's own op field
    data[at : at + 2] = b"xx"
    damaged = tmp_path / "h.bag"
    damaged.write_bytes(bytes(data))
    with ScannedBag(damaged, refused="ReaderError") as scanned:
        said = scanned.said
        assert "where no whole record starts" in said and "it stops" not in said
        got = scanned.message_count
        chunks = {k2 for _, _, k2, _, _ in scanned._scan.messages}
    # the chunks after it read; the damaged one too, where uncompressed
    assert chunks == set(range(len(starts) - (compression is not None)))
    if compression is None:
        assert got == n_whole and "messages read from the records in them" in said
    else:
        assert n_whole * 0.7 < got < n_whole and "read from the records" not in said


def test_a_damaged_message_is_passed_over_and_counted(tmp_path):
    """An uncompressed chunk's message whose data no longer deserialises (its header's
    frame_id length changed): rosbags refuses the bag; read record by record, that one
    message is passed over and counted, every other read."""
    from rwhonet.data.bagscan import OP_MESSAGE

    bag = _bag(tmp_path, None)
    whole = read_mdf4(bag, bag_map(), R, "m", "b.bag")
    data = bytearray(bag.read_bytes())
    start, n = _chunks(bytes(data))[2]
    inner = [
        at for f, at, _ in _records(bytes(data[start : start + n]), 0) if f["op"][0] == OP_MESSAGE
    ]
    at = start + inner[len(inner) // 2]
    data[at + 12 : at + 16] = (10**6).to_bytes(4, "little")  # seq, stamp, then the length
    damaged = tmp_path / "m.bag"
    damaged.write_bytes(bytes(data))
    streams = read_mdf4(damaged, bag_map(), R, "m", "m.bag")
    said = "\n".join(streams.notes)
    assert "m.bag: rosbags refused the bag (" in said and "passed over (" not in said
    assert "1 damaged message(s) that rosbags cannot deserialise as " in said
    got = sum(g.t_s.size for g in (*streams.wheels, streams.gnss))
    want = sum(g.t_s.size for g in (*whole.wheels, whole.gnss))
    assert got == want - 1


def test_a_chunk_cut_short_is_not_said_to_be_damaged(tmp_path):
    """A recording cut short inside an uncompressed chunk: its whole records read, and the
    notes say where it stops, not that a chunk was damaged."""
    bag = _bag(tmp_path, None)
    data = bag.read_bytes()
    start, n = _chunks(data)[3]
    cut = tmp_path / "c.bag.active"
    cut.write_bytes(data[: start + n // 2])
    said = "\n".join(read_mdf4(cut, bag_map(), R, "m", cut.name).notes)
    assert "the bag has no index" in said and "it stops inside a chunk at byte" in said
    assert "damaged" not in said


@pytest.mark.parametrize("damage", ["time", "length"])
def test_a_record_whose_fields_are_damaged_is_passed_over_and_its_chunk_read_on(tmp_path, damage):
    """A message record of an uncompressed chunk whose ``time`` field's name is damaged,
    or whose data length runs past the chunk: passed over, the chunk's records before and
    after it read (from the next place whose header's fields fill it exactly), and the
    chunks after the chunk."""
    from rwhonet.data.bagscan import OP_MESSAGE

    bag = _bag(tmp_path, None)
    data = bytearray(bag.read_bytes())
    start, n = _chunks(bytes(data))[2]
    inner = [
        at for f, at, _ in _records(bytes(data[start : start + n]), 0) if f["op"][0] == OP_MESSAGE
    ]
    k = len(inner) // 2
    if damage == "time":
        field = data.index(b"time=", start + inner[k - 1], start + inner[k])
        data[field : field + 5] = b"tume="
    else:  # the u4 before the data: its length
        data[start + inner[k] - 4 : start + inner[k]] = (1 << 30).to_bytes(4, "little")
    damaged = tmp_path / "t.bag"
    damaged.write_bytes(bytes(data))
    with ScannedBag(damaged, refused="ReaderError") as scanned:
        why = "(KeyError: 'time')" if damage == "time" else "(a record damaged)"
        assert f"passed over {why}" in scanned.said
        in_chunk = [m for m in scanned._scan.messages if m[2] == 2]
        assert len(in_chunk) == len(inner) - 1  # the damaged one (the k-th) passed over
        assert start + inner[k] not in {start + m[3] for m in in_chunk}
        assert max(m[2] for m in scanned._scan.messages) == len(_chunks(bytes(data))) - 1


def test_a_damaged_can_frame_message_is_passed_over_and_counted(tmp_path):
    """A bag of raw CAN frames (can_msgs/Frame) one of which no longer deserialises: read
    record by record, that frame is passed over and counted among those passed over."""
    from rwhonet.config import ColumnSpec
    from rwhonet.data.bagscan import OP_MESSAGE
    from support.canlog import DBC, SIGNALS, stream_frames
    from support.multirate import simulated_streams
    from support.rosbag import CAN_FRAME, CAN_FRAME_DEF, CAN_TOPIC, can_messages

    tables, radius = simulated_streams(40.0, 100.0, 10.0)
    stamps, ids, data = stream_frames(tables, radius, 1.5e9)
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC)
    smap = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    extra = [(CAN_TOPIC, CAN_FRAME, can_messages(np.round(stamps, 6), ids, data))]
    bag = write_bag(
        tmp_path / "bus.bag",
        None,
        None,
        extra=extra,
        msgdefs={CAN_FRAME: CAN_FRAME_DEF},
        chunk_bytes=1 << 16,
    )
    whole = read_mdf4(bag, smap, radius, "m", "bus.bag", dbc=[str(dbc)])
    raw = bytearray(bag.read_bytes())
    start, n = _chunks(bytes(raw))[1]
    inner = [
        at for f, at, _ in _records(bytes(raw[start : start + n]), 0) if f["op"][0] == OP_MESSAGE
    ]
    at = start + inner[len(inner) // 2]
    raw[at + 12 : at + 16] = (10**6).to_bytes(4, "little")  # its frame_id's length
    damaged = tmp_path / "d.bag"
    damaged.write_bytes(bytes(raw))
    streams = read_mdf4(damaged, smap, radius, "m", "d.bag", dbc=[str(dbc)])
    said = "\n".join(streams.notes)
    assert "rosbags refused the bag (" in said and "closed as it is" in said
    assert "d.bag: passed over: 1 damaged messages" in said
    got = sum(g.t_s.size for g in (*streams.wheels, streams.gnss))
    assert got == sum(g.t_s.size for g in (*whole.wheels, whole.gnss)) - 1


def _header(**fields: bytes) -> bytes:
    """A record header of ``fields`` (each ``name=value`` with its u4 length), its u4
    length first."""
    body = b"".join(
        len(b := f"{k}=".encode() + v).to_bytes(4, "little") + b for k, v in fields.items()
    )
    return len(body).to_bytes(4, "little") + body


def _message(conn: int = 0, sec: int = 100, nsec: int = 5, data: bytes = b"abcd") -> bytes:
    head = _header(conn=conn.to_bytes(4, "little"), op=b"\x02", time=struct.pack("<II", sec, nsec))
    return head + len(data).to_bytes(4, "little") + data


def test_exact_fields_fill_a_header_or_are_none():
    """Fields that fill a header exactly, each ``name=value`` of a lower-case name: read;
    a field without ``=``, a name of other bytes, a length running past the header, or
    1-3 bytes after the last field: none."""
    from rwhonet.data.bagscan import _exact_fields

    body = _header(op=b"\x02", conn=b"\x00" * 4)[4:]
    assert _exact_fields(body) == {"op": b"\x02", "conn": b"\x00" * 4}
    assert _exact_fields(body + b"\x01\x02") is None
    assert _exact_fields(body[:-1]) is None
    assert _exact_fields(_header(op=b"\x02")[4:].replace(b"op=", b"op:")) is None
    assert _exact_fields(_header(Op=b"\x02")[4:]) is None


def test_a_record_s_fields_must_be_its_op_s_own():
    """A message's ``conn`` of 4 bytes and ``time`` of 8 whose nanoseconds are under 10^9;
    a chunk's ``compression`` and 4-byte ``size``; a connection's ``conn`` and ``topic``;
    an ``op`` among those looked for."""
    from rwhonet.data.bagscan import IN_CHUNK, IN_FILE, _fits

    t = struct.pack("<II", 100, 999_999_999)
    assert _fits({"op": b"\x02", "conn": b"\x00" * 4, "time": t}, IN_CHUNK)
    assert not _fits({"op": b"\x02", "conn": b"\x00" * 4, "time": t}, IN_FILE)
    late = struct.pack("<II", 100, 1_000_000_000)
    assert not _fits({"op": b"\x02", "conn": b"\x00" * 4, "time": late}, IN_CHUNK)
    assert not _fits({"op": b"\x02", "conn": b"\x00" * 3, "time": t}, IN_CHUNK)
    assert _fits({"op": b"\x05", "compression": b"none", "size": b"\x00" * 4}, IN_FILE)
    assert not _fits({"op": b"\x05", "compression": b"none"}, IN_FILE)
    assert not _fits({"op": b"\x05", "size": b"\x00" * 4}, IN_FILE)
    assert _fits({"op": b"\x07", "conn": b"\x00" * 4, "topic": b"/a"}, IN_CHUNK)
    assert not _fits({"op": b"\x07", "conn": b"\x00" * 4}, IN_CHUNK)


def test_the_next_record_is_the_first_whole_one_of_its_kind():
    """After bytes that are no record: the first message whose header's fields fill it
    and whose data fit; not one whose data run past the end, nor an op field inside
    another field's value, nor a message's header where a chunk's is looked for."""
    from rwhonet.data.bagscan import IN_CHUNK, IN_FILE, _next_record

    junk = bytes(range(7, 60))
    good = _message(conn=1)
    buf = junk + good + _message(conn=2)
    assert _next_record(buf, 0, IN_CHUNK, len(buf)) == len(junk)
    assert _next_record(buf, len(junk) + 1, IN_CHUNK, len(buf)) == len(junk) + len(good)
    assert _next_record(buf, 0, IN_FILE, len(buf)) is None
    cut = junk + good[:-1]  # its data one byte short of the end
    assert _next_record(cut, 0, IN_CHUNK, len(cut)) is None
    # a message record inside a connection record's topic: where messages alone are
    # looked for, the message (the connection's header spans its op field, but is no
    # message's); where connections are too, the connection, which starts first
    head = _header(conn=b"\x00" * 4, op=b"\x07", topic=b"/x" + good)
    buf = junk + head + (0).to_bytes(4, "little")
    assert _next_record(buf, 0, (2,), len(buf)) == buf.index(good)
    assert _next_record(buf, 0, IN_CHUNK, len(buf)) == len(junk)
