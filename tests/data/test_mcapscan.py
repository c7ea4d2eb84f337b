"""A ROS 2 bag's MCAP file cut short, read record by record (rwhonet.data.mcapscan).

``ros2 bag record`` with MCAP storage (ROS 2 Iron's default) writes a file's summary and
footer as it closes it; killed (the car switched off), it leaves the file without them,
usually inside the chunk it was writing, and no ``metadata.yaml``. The files here are
written by ``rosbags``' MCAP writer (chunks of 1 MB, uncompressed or zstd, as rosbag2's
presets write them) and cut where a recorder killed would leave them.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.mcapscan import MAGIC, ScannedMcap, is_finished
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.multirate import per_second, simulated_streams
from support.rosbag import bag_map, tables_bag


def _drive():
    """120 s: 100 Hz wheels, 10 Hz fixes, 50 Hz IMU (2.4 MB of messages: three chunks)."""
    return simulated_streams(120.0, 100.0, 10.0, gyro_hz=50.0)


def _mcap(tmp_path: Path, compression: str | None) -> Path:
    tables, _ = _drive()
    folder = tables_bag(tmp_path / "drive", tables, ros2="mcap", compression=compression)
    return next(folder.glob("*.mcap"))


def _seconds(path: Path, radius: float, name: str):
    streams = read_mdf4(path, bag_map(yaw=True), radius, "m", name)
    grid = resample(streams, nominal_radius_m=radius).drive.columns
    return per_second(grid, radius), streams


def _all(bag) -> list[tuple[str, str, int, bytes]]:
    return [(c.topic, c.msgtype, t, bytes(raw)) for c, t, raw in bag.messages()]


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_a_closed_file_read_record_by_record_gives_rosbags_messages(tmp_path, compression):
    """Every message of a closed file, read record by record, is the one ``rosbags``
    reads by the file's index: the same topic, type, time and bytes, in the same order
    (chunks decompressed, their CRC checked); the same connections, definitions and
    deserialised messages."""
    from rosbags.highlevel import AnyReader

    path = _mcap(tmp_path, compression)
    assert is_finished(path)
    with AnyReader([path]) as want, ScannedMcap([path]) as got:
        assert got.message_count == want.message_count > 19_000
        assert {c.topic: c.msgtype for c in got.connections} == {
            c.topic: c.msgtype for c in want.connections
        }
        ours = _all(got)
        theirs = [(c.topic, c.msgtype, t, bytes(raw)) for c, t, raw in want.messages()]
        assert sorted(ours, key=lambda m: m[2]) == sorted(theirs, key=lambda m: m[2])
        con, _, raw = next(iter(got.messages()))
        assert repr(got.deserialize(raw, con.msgtype)) == repr(want.deserialize(raw, con.msgtype))
        assert len({k for k in got._files[0].chunks}) >= 2  # several chunks
        assert "stops" not in got.said  # the summary after the data's end not read as data


@pytest.mark.parametrize("compression", [None, "zstd"])
@pytest.mark.parametrize("given", ["file", "folder"])
def test_a_recording_cut_short_is_read_as_far_as_it_goes(tmp_path, compression, given):
    """The file cut at 70 % of its length (the recorder killed inside a chunk), alone or in
    its folder without metadata.yaml: refused by rosbags, read record by record here; the
    seconds it holds are the whole file's bit for bit (the last, where it ends, aside); an
    uncompressed chunk cut short gives its whole records, a zstd one those of its whole
    blocks (cut here 4 KB into it: none)."""
    _, radius = _drive()
    whole = _mcap(tmp_path, compression)
    want, _ = _seconds(whole, radius, "whole.mcap")
    data = whole.read_bytes()
    cut = tmp_path / given / "drive_0.mcap"
    cut.parent.mkdir()
    cut.write_bytes(data[: int(len(data) * 0.7)])
    assert not is_finished(cut)
    got, streams = _seconds(cut if given == "file" else cut.parent, radius, "cut")
    said = "\n".join(streams.notes)
    assert "no summary (a recording cut short: ros2 bag record writes it as it closes a" in said
    assert "its MCAP records one by one, rosbags deserialising" in said
    cut_in = "a zstd-compressed chunk" if compression else "a chunk record"
    assert f"drive_0.mcap stops inside {cut_in} at byte" in said
    if compression:
        assert "(a compressed chunk cut short: none of its messages read)" in said
    if given == "folder":
        assert "; the folder has no metadata.yaml" in said
    assert 0.3 * len(want) < len(got) < 0.8 * len(want)
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got)  # every second it holds is one of the whole file's
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)


def test_a_cut_zstd_or_lz4_frame_gives_its_whole_blocks_bit_for_bit():
    """What the readers take of a compressed chunk cut short: the start of its data."""
    import os

    import lz4.frame
    from backports import zstd

    from rwhonet.data.mcapscan import _partly

    data = bytes(range(256)) * 4000 + os.urandom(400_000)
    for name, packed in (("zstd", zstd.compress(data)), ("lz4", lz4.frame.compress(data))):
        got = _partly(name, packed[: len(packed) * 2 // 3])
        assert 0.3 * len(data) < len(got) < len(data) and got == data[: len(got)], name


@pytest.mark.parametrize("compression", ["zstd"])
def test_a_compressed_chunk_cut_short_gives_what_decompresses(tmp_path, compression):
    """A zstd or lz4 file cut inside a chunk (rosbag2's zstd presets): the chunk's whole
    records, as far as its frame's whole blocks decompress, are read (until stop 89, none
    were), each message the whole file's bit for bit; and the half-way cut's seconds are
    the whole file's. Cut before a whole block, the file is refused."""
    _, radius = _drive()
    path = _mcap(tmp_path, compression)
    data = path.read_bytes()
    cut = tmp_path / "early.mcap"
    cut.write_bytes(data[:20_000])
    with ScannedMcap([path]) as whole, ScannedMcap([cut]) as early:
        got = _all(early)
        assert 0 < len(got) < whole.message_count
        assert got == _all(whole)[: len(got)]
        said = early.said
    assert f"stops inside a {compression}-compressed chunk at byte 43 of 20000, its whole " in said
    assert "records read as far as it decompresses" in said and "none of its" not in said
    want, _ = _seconds(path, radius, "whole.mcap")
    half = tmp_path / "half.mcap"
    half.write_bytes(data[: len(data) // 2])
    got, _ = _seconds(half, radius, "half.mcap")
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got) > 0.5 * len(want)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)
    tiny = tmp_path / "tiny.mcap"
    tiny.write_bytes(data[:400])  # inside the first block of the first chunk
    with pytest.raises(InputError) as err:
        read_mdf4(tiny, bag_map(), 0.3, "m", "tiny.mcap")
    text = str(err.value)
    assert "tiny.mcap: expected a ROS 2 bag" in text
    assert f"no whole message: cut short inside a {compression}-compressed chunk at byte 43" in text
    assert "an .mcap file cut short is read as far as its whole records go" in text


def _records(data: bytes) -> list[tuple[int, bytes]]:
    """A closed MCAP file's data section as records (opcode, body), chunks' records
    taken out of them: the file as rosbag2's ``fastwrite`` preset writes it, unchunked."""
    from rosbags.rosbag2.storage_mcap import decompress

    out, pos = [], len(MAGIC)
    while True:
        op, n = struct.unpack_from("<BQ", data, pos)
        body = data[pos + 9 : pos + 9 + n]
        pos += 9 + n
        if op == 0x0F:
            return out
        if op == 0x06:
            size, crc = struct.unpack_from("<QI", body, 16)
            (k,) = struct.unpack_from("<I", body, 28)
            comp = body[32 : 32 + k].decode()
            (m,) = struct.unpack_from("<Q", body, 32 + k)
            inner = decompress(body[40 + k : 40 + k + m], comp, size, crc)
            out += _records(MAGIC + inner + struct.pack("<BQ", 0x0F, 4) + bytes(4))
        elif op != 0x07:  # message indexes point into chunks that are gone
            out.append((op, body))


def test_messages_outside_chunks_cut_inside_one_are_read_to_the_last_whole(tmp_path):
    """An unchunked file (rosbag2's fastwrite preset) cut inside a message record: every
    whole message before it read, the seconds the whole file's bit for bit."""
    _, radius = _drive()
    whole = _mcap(tmp_path, None)
    want, _ = _seconds(whole, radius, "whole.mcap")
    flat = b"".join(struct.pack("<BQ", op, len(b)) + b for op, b in _records(whole.read_bytes()))
    cut = tmp_path / "flat.mcap"
    cut.write_bytes(MAGIC + flat[: int(len(flat) * 0.5) + 3])
    got, streams = _seconds(cut, radius, "flat.mcap")
    said = "\n".join(streams.notes)
    assert "flat.mcap stops inside a message record at byte" in said
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got) > 0.4 * len(want)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)
    with ScannedMcap([cut]) as bag:
        assert all(j < 0 for _, _, j, _, _ in bag._files[0].messages)


def test_a_file_that_is_no_ros2_mcap_file_is_refused(tmp_path):
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    assert is_finished(junk)  # not one to scan: rosbags refuses it
    with pytest.raises(InputError, match="junk.mcap: expected a ROS 2 bag"):
        read_mdf4(junk, bag_map(), 0.3, "m", "junk.mcap")
    other = tmp_path / "other.mcap"
    header = struct.pack("<I", 4) + b"json" + struct.pack("<I", 0)
    other.write_bytes(MAGIC + struct.pack("<BQ", 1, len(header)) + header)
    assert not is_finished(other)
    with pytest.raises(InputError, match="the MCAP profile is 'json', not ros2"):
        read_mdf4(other, bag_map(), 0.3, "m", "other.mcap")
    # a closed file of another profile: rosbags refuses it, and so does its scan, once
    tables, radius = simulated_streams(20.0, 100.0, 10.0)
    closed = next(tables_bag(tmp_path / "d", tables, ros2="mcap").glob("*.mcap")).read_bytes()
    i = closed.index(b"ros2")
    (tmp_path / "json.mcap").write_bytes(closed[:i] + b"json" + closed[i + 4 :])
    with pytest.raises(InputError, match="the MCAP profile is 'json', not ros2"):
        read_mdf4(tmp_path / "json.mcap", bag_map(), radius, "m", "json.mcap")
    only = tmp_path / "only.mcap"
    only.write_bytes(MAGIC)  # killed as it began: the magic alone is no closed file's end
    assert not is_finished(only)
    started = tmp_path / "started.mcap"
    started.write_bytes(MAGIC + b"\x01")  # killed as it wrote its header
    assert not is_finished(started)
    with pytest.raises(InputError, match="no whole message: cut short 1 byte"):
        read_mdf4(started, bag_map(), 0.3, "m", "started.mcap")
    with pytest.raises(ValueError, match="is empty"):
        (tmp_path / "empty.mcap").write_bytes(b"")
        ScannedMcap([tmp_path / "empty.mcap"])
    assert c.T_S  # the canonical names the drives above are read into


def test_a_file_without_definitions_reads_ros_types_and_refuses_a_kit_s(tmp_path):
    """Schemas without their definitions (as rosbag2 wrote them before Iron), the file cut
    short: the kit's WheelSpeedReport refused, naming it; a NavSatFix read by ROS's own
    type (the latest LTS's), its messages up to the cut."""
    from support.rosbag import FIX_TOPIC, IMU_TOPIC, WHEEL_SPEED_REPORT

    tables, radius = _drive()
    whole = _mcap(tmp_path, None)
    bare = []
    for op, body in _records(whole.read_bytes()):
        if op == 0x03:  # schema: id, name, encoding, data -> encoding and data empty
            (k,) = struct.unpack_from("<I", body, 2)
            body = body[: 6 + k] + struct.pack("<I", 0) + struct.pack("<I", 0)
        bare.append(struct.pack("<BQ", op, len(body)) + body)
    cut = tmp_path / "bare.mcap"
    flat = b"".join(bare)
    cut.write_bytes(MAGIC + flat[: int(len(flat) * 0.6)])
    with pytest.raises(InputError) as err:
        read_mdf4(cut, bag_map(), radius, "m", "bare.mcap")
    assert f"the definition of {WHEEL_SPEED_REPORT}, a mapped topic's message type" in str(
        err.value
    )
    with ScannedMcap([cut]) as bag:
        assert {c.topic for c in bag.connections} >= {FIX_TOPIC, IMU_TOPIC}
        fix = next(con for con in bag.connections if con.topic == FIX_TOPIC)
        n = sum(1 for _ in bag.messages([fix]))
        msg = bag.deserialize(next(bag.messages([fix]))[2], fix.msgtype)
    g = tables.gnss
    assert 0.3 * len(g) < n < 0.8 * len(g)
    assert msg.latitude == g[c.LAT_DEG].iloc[0] and msg.longitude == g[c.LON_DEG].iloc[0]


@pytest.mark.parametrize("packed", [False, True])
def test_a_split_recording_s_last_file_cut_short_is_read_after_the_closed_ones(tmp_path, packed):
    """``--max-bag-duration`` splits a recording into drive_0.mcap, drive_1.mcap, ...; killed,
    the recorder leaves the last file open and no metadata.yaml. The closed first file and
    the cut second are read in order, each with its own channels: the seconds are the
    whole drive's bit for bit up to the cut. With ``--compression-mode file`` rosbag2
    compressed the closed file as it closed it (drive_0.mcap.zstd; the open one is not):
    the same seconds."""
    import pyarrow as pa

    from rwhonet.sim.streams import StreamTables

    tables, radius = _drive()
    want, _ = _seconds(
        next(tables_bag(tmp_path / "w", tables, ros2="mcap").glob("*.mcap")), radius, "w"
    )
    t_split = float(tables.wheels[c.T_S].iloc[0]) + 60.0
    folder = tmp_path / "drive"
    folder.mkdir()
    for k, part in enumerate((lambda t: t < t_split, lambda t: t >= t_split)):
        frames = [f[part(f[c.T_S])] for f in (tables.wheels, tables.gnss, tables.gyro)]
        written = next(tables_bag(tmp_path / f"p{k}", StreamTables(*frames), ros2="mcap").glob("*"))
        data = written.read_bytes()
        if k == 0 and packed:
            zstd = pa.compress(data, codec="zstd", asbytes=True)
            (folder / "drive_0.mcap.zstd").write_bytes(zstd)
            continue
        (folder / f"drive_{k}.mcap").write_bytes(data if k == 0 else data[: int(len(data) * 0.7)])
    from rwhonet.data.rosbag import _storage_files

    first = "drive_0.mcap.zstd" if packed else "drive_0.mcap"
    assert [p.name for p in _storage_files(folder)] == [first, "drive_1.mcap"]  # in order
    got, streams = _seconds(folder, radius, "drive")
    said = "\n".join(streams.notes)
    assert "its files have no summary" in said and "drive_1.mcap stops inside" in said
    assert "drive_0.mcap stops" not in said
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got) and 0.7 * len(want) < len(got) < 0.95 * len(want)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)


def _first_chunk(data: bytes) -> int:
    """Where a file's first chunk record starts (after the magic and the header record)."""
    (n,) = struct.unpack_from("<Q", data, len(MAGIC) + 1)
    at = len(MAGIC) + 9 + n
    assert data[at] == 0x06
    return at


def test_a_chunk_s_crc_is_checked_and_a_cut_in_its_header_is_no_message(tmp_path):
    """A chunk whose records do not match its CRC-32 (a corrupted write) is refused; with
    its right CRC it is read; a file cut inside the first chunk's header holds no message."""
    import zlib

    _, radius = _drive()
    data = bytearray(_mcap(tmp_path, None).read_bytes())
    at = _first_chunk(bytes(data))
    (usize,) = struct.unpack_from("<Q", data, at + 9 + 16)
    (k,) = struct.unpack_from("<I", data, at + 9 + 28)
    records = bytes(data[at + 9 + 32 + k + 8 : at + 9 + 32 + k + 8 + usize])
    cut = int(len(data) * 0.7)
    right = tmp_path / "right.mcap"
    struct.pack_into("<I", data, at + 9 + 24, zlib.crc32(records))
    right.write_bytes(bytes(data[:cut]))
    assert len(_seconds(right, radius, "right.mcap")[0]) > 30
    struct.pack_into("<I", data, at + 9 + 24, zlib.crc32(records) ^ 1)
    wrong = tmp_path / "wrong.mcap"
    wrong.write_bytes(bytes(data[:cut]))
    with pytest.raises(InputError, match="wrong.mcap: expected a ROS 2 bag .*checksum mismatch"):
        read_mdf4(wrong, bag_map(), radius, "m", "wrong.mcap")
    header = tmp_path / "header.mcap"
    header.write_bytes(bytes(data[: at + 9 + 20]))
    with pytest.raises(
        InputError, match=f"no whole message: cut short inside a chunk record at byte {at}"
    ):
        read_mdf4(header, bag_map(), radius, "m", "header.mcap")


def test_a_folder_of_files_rosbag2_compressed_is_read_without_its_metadata(tmp_path):
    """A recording with ``--compression-mode file`` stopped between files (every file
    closed, drive_0.db3.zstd, and no metadata.yaml): its files decompressed and read in
    order, the folder's grid with its metadata bit for bit; a .mcap.zstd alone is a ROS 2
    bag's file kept compressed (ingest's reader decompresses it)."""
    import shutil

    import pyarrow as pa

    from rwhonet.data.drivefile import DriveFile, read_any
    from rwhonet.data.rosbag import is_rosbag2_folder, is_rosbag_name
    from support.drives import make_params

    tables, radius = _drive()
    folder = tables_bag(tmp_path / "drive", tables, ros2="sqlite3")
    want = resample(read_mdf4(folder, bag_map(), radius, "m", "drive"), nominal_radius_m=radius)
    db3 = next(folder.glob("*.db3"))
    packed = tmp_path / "packed"
    packed.mkdir()
    (packed / (db3.name + ".zstd")).write_bytes(
        pa.compress(db3.read_bytes(), codec="zstd", asbytes=True)
    )
    assert is_rosbag2_folder(packed) and is_rosbag_name("drive_0.mcap.zstd")
    streams = read_mdf4(packed, bag_map(), radius, "m", "packed")
    assert any("its 1 storage file(s) read alone (drive.db3)" in n for n in streams.notes)
    got = resample(streams, nominal_radius_m=radius).drive.columns
    for k in want.drive.columns:
        np.testing.assert_array_equal(got[k], want.drive.columns[k], err_msg=k)
    mcap = _mcap(tmp_path / "m", None)
    alone = tmp_path / "raw" / "V-1.mcap.zstd"
    alone.parent.mkdir()
    alone.write_bytes(pa.compress(mcap.read_bytes(), codec="zstd", asbytes=True))
    signals = {k: {"column": v.column, "unit": v.unit} for k, v in bag_map().items()}
    data = make_params(
        tmp_path, **{"data.signal_maps": {"ros": {"reader": "mdf4", "signals": signals}}}
    ).data
    raw = read_any(
        DriveFile("V-1", "target_test", "target", "ros", alone), data, str, radius, 0.1, 10.0
    )[0]
    ref = resample(read_mdf4(mcap, bag_map(), radius, "m", "x"), nominal_radius_m=radius)
    np.testing.assert_array_equal(raw.columns[c.LAT_DEG], ref.drive.columns[c.LAT_DEG])
    shutil.rmtree(packed)


def test_a_message_of_no_channel_is_passed_over_and_a_damaged_record_ends_the_read(tmp_path):
    """An unchunked file whose 100th message names a channel no record defines (its id
    damaged): passed over, counted; a message record further on too short for its header
    (a damaged write): the file is read up to it, the notes saying where, the seconds
    before it the whole file's bit for bit."""
    _, radius = _drive()
    whole = _mcap(tmp_path, None)
    want, _ = _seconds(whole, radius, "whole.mcap")
    records = _records(whole.read_bytes())
    at = [i for i, (op, _) in enumerate(records) if op == 0x05]
    op, body = records[at[100]]
    records[at[100]] = (op, struct.pack("<H", 999) + body[2:])
    flat = [struct.pack("<BQ", op, len(b)) + b for op, b in records]
    damaged = at[len(at) // 2]
    flat[damaged] = struct.pack("<BQ", 0x05, 3) + b"abc"
    path = tmp_path / "damaged.mcap"
    path.write_bytes(MAGIC + b"".join(flat))
    got, streams = _seconds(path, radius, "damaged.mcap")
    said = "\n".join(streams.notes)
    byte = len(MAGIC) + sum(len(r) for r in flat[:damaged])
    assert f"stops at a damaged message record at byte {byte} of" in said
    assert "(3 bytes, fewer than a message's header)" in said
    assert "; 1 message(s) of no channel record passed over" in said
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got) > 0.3 * len(want)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_a_file_cut_and_damaged_anywhere_is_read_or_refused_never_a_traceback(
    tmp_path, compression
):
    """120 files cut at random and with up to three random bytes changed (a recorder that
    lost power mid-write): each is read as far as it goes, or refused with the problem
    named; none ends in another exception (a struct error, a KeyError, a decompressor's)."""
    from rwhonet.sim.streams import StreamTables

    tables, radius = simulated_streams(20.0, 100.0, 10.0, gyro_hz=50.0)
    data = next(
        tables_bag(
            tmp_path / "d",
            StreamTables(tables.wheels, tables.gnss, tables.gyro),
            ros2="mcap",
            compression=compression,
        ).glob("*.mcap")
    ).read_bytes()
    rng = np.random.default_rng(7)
    read = refused = damaged = 0
    for i in range(120):
        b = bytearray(data[: int(rng.integers(8, len(data) - 1))])
        for _ in range(int(rng.integers(0, 4))):
            if len(b) > 9:
                b[int(rng.integers(8, len(b)))] = int(rng.integers(0, 256))
        path = tmp_path / f"f{i}.mcap"
        path.write_bytes(bytes(b))
        try:
            notes = read_mdf4(path, bag_map(), radius, "m", path.name).notes
            read += 1
            damaged += any("damaged message(s) that rosbags cannot" in n for n in notes)
        except InputError as err:
            assert f"{path.name}: expected a ROS 2 bag" in str(err) or "problem" in str(err)
            refused += 1
    # damage is found, not read as data: a message that does not deserialise is passed
    # over and said (until stop 89, the file was refused for it)
    assert read > 20 and refused + damaged > 5


def test_records_damaged_in_their_fields_end_the_read_where_they_are(tmp_path):
    """A record shorter than its fields at the file's end, a string whose length runs past
    the data, a schema's name that is no UTF-8 inside the chunk being written: each is
    where the read stops (or, with no whole message before it, why the file is refused)."""
    _, radius = _drive()
    whole = _mcap(tmp_path, None)
    records = _records(whole.read_bytes())
    flat = [struct.pack("<BQ", op, len(b)) + b for op, b in records]
    half = MAGIC + b"".join(flat[: len(flat) // 2])
    short = tmp_path / "short.mcap"
    short.write_bytes(half + struct.pack("<BQ", 0x04, 1) + b"x")  # a channel of 1 byte
    said = "\n".join(_seconds(short, radius, "short.mcap")[1].notes)
    assert f"stops at a damaged channel record at byte {len(half)} of {len(half) + 10} (" in said
    channel = next(i for i, (op, _) in enumerate(records) if op == 0x04)
    op, body = records[channel]
    flat[channel] = struct.pack("<BQ", op, len(body)) + body[:4] + b"\xff\xff\xff\x7f" + body[8:]
    long = tmp_path / "long.mcap"
    long.write_bytes(MAGIC + b"".join(flat))
    with pytest.raises(InputError, match="a string of 2147483647 bytes past the data's end"):
        read_mdf4(long, bag_map(), radius, "m", "long.mcap")
    data = bytearray(whole.read_bytes())
    at = _first_chunk(bytes(data))
    name = data.index(b"sensor_msgs/msg/")  # the first schema's name, in the first chunk
    data[name] = 0xFF
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(bytes(data[: at + 200_000]))
    with pytest.raises(
        InputError, match=f"inside a chunk record at byte {at} of {at + 200_000}, damaged in it"
    ):
        read_mdf4(cut, bag_map(), radius, "m", "cut.mcap")


def _chunks(data: bytearray) -> list[tuple[int, int]]:
    """Each top-level chunk record of a file: where it starts and its whole length; each
    given its CRC-32, as rosbag2's writer (Foxglove's C++ library) gives it by default
    (``rosbags``' writer leaves it 0: not computed)."""
    import zlib

    from rosbags.rosbag2.storage_mcap import decompress

    out, pos = [], len(MAGIC)
    while pos + 9 <= len(data):
        op, n = struct.unpack_from("<BQ", data, pos)
        if op == 0x0F:
            break
        if op == 0x06:
            body = pos + 9
            (size,) = struct.unpack_from("<Q", data, body + 16)
            (k,) = struct.unpack_from("<I", data, body + 28)
            comp = bytes(data[body + 32 : body + 32 + k]).decode()
            (m,) = struct.unpack_from("<Q", data, body + 32 + k)
            raw = bytes(data[body + 40 + k : body + 40 + k + m])
            records = decompress(raw, comp, size, 0)
            struct.pack_into("<I", data, body + 24, zlib.crc32(records))
            out.append((pos, 9 + n))
        pos += 9 + n
    return out


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_a_damaged_chunk_is_passed_over_and_the_records_after_it_read(tmp_path, compression):
    """A recording cut short whose second chunk was damaged on the disk (a byte of its data
    changed): as ``mcap recover`` does, that chunk is passed over, said with its byte and
    why, and the chunks after it are read. Every second read is the whole file's (bit for
    bit before the damage; after it, to the last bits of a sum); those of the damaged
    chunk are missing (a gap the grid splits at), and more is read than up to the
    damage."""
    _, radius = _drive()
    whole = _mcap(tmp_path, compression)
    want, _ = _seconds(whole, radius, "whole.mcap")
    data = bytearray(whole.read_bytes())
    chunks = _chunks(data)
    assert len(chunks) >= 3
    at, n = chunks[1]
    data[at + n // 2] ^= 0xFF  # inside its data
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data[: chunks[-1][0] + chunks[-1][1]]))  # cut after the last
    got, streams = _seconds(damaged, radius, "damaged.mcap")
    said = "\n".join(streams.notes)
    assert f"damaged.mcap: 1 damaged chunk(s) passed over (byte {at}: " in said
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got)  # every second read is one of the whole file's
    ends = np.flatnonzero(np.diff(got["t_s"].to_numpy()) > 1.5)  # the damaged chunk's gap
    assert ends.size == 1
    last = len(got) - 1
    keep = np.ones(len(both), bool)
    keep[[ends[0], ends[0] + 1, last]] = False  # beside the gap and the file's end
    before = keep & (np.arange(len(both)) <= ends[0])
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][before], both[f"{q}_cut"][before], err_msg=q)
        # after it, a wheel's rolled angle sums from another start: to its last bits
        np.testing.assert_allclose(both[q][keep], both[f"{q}_cut"][keep], atol=1e-12, err_msg=q)
    # more than up to the damage: the chunks after it
    up_to = damaged.with_name("up_to.mcap")
    up_to.write_bytes(bytes(data[:at]))
    assert len(got) > len(_seconds(up_to, radius, "up_to.mcap")[0]) + 20


def test_a_damaged_chunk_followed_by_no_record_ends_the_read_there(tmp_path):
    """A chunk whose data and length are both damaged: where its length says the next
    record begins there is no opcode of the format, so the read ends at that chunk (no
    garbage taken for records)."""
    _, radius = _drive()
    data = bytearray(_mcap(tmp_path, None).read_bytes())
    chunks = _chunks(data)
    at, n = chunks[1]
    data[at + n // 2] ^= 0xFF
    short = next(k for k in range(1000, 2000) if data[at + n - k] not in range(1, 16))
    struct.pack_into("<Q", data, at + 1, n - 9 - short)  # its length that much short
    path = tmp_path / "twice.mcap"
    path.write_bytes(bytes(data[: chunks[-1][0] + 100]))
    _, streams = _seconds(path, radius, "twice.mcap")
    said = "\n".join(streams.notes)
    assert f"twice.mcap stops at a damaged chunk record at byte {at} of" in said
    assert "passed over" not in said


def _chunk_records(data: bytes, at: int) -> list[tuple[int, int, int]]:
    """An uncompressed chunk's records: (opcode, where in the file, length)."""
    (k,) = struct.unpack_from("<I", data, at + 9 + 28)
    (m,) = struct.unpack_from("<Q", data, at + 9 + 32 + k)
    pos = start = at + 9 + 32 + k + 8
    out = []
    while pos < start + m:
        op, n = struct.unpack_from("<BQ", data, pos)
        out.append((op, pos, n))
        pos += 9 + n
    return out


def test_a_chunk_without_a_crc_gives_its_records_before_the_damaged_one(tmp_path):
    """A chunk without a CRC (``rosbags``' writer computes none) whose message record
    halfway has a length too short for a message: its whole records before that one are
    read (as a chunk cut short gives them), the rest of it passed over, and every chunk
    after it read; a chunk whose records' length runs past the chunk's own end is passed
    over, saying so."""
    whole = _mcap(tmp_path, None)
    data = bytearray(whole.read_bytes())
    at = _chunks(bytearray(data))[1][0]  # (a copy: this file's chunks keep no CRC)
    (crc,) = struct.unpack_from("<I", data, at + 9 + 24)
    assert crc == 0
    messages = [r for r in _chunk_records(bytes(data), at) if r[0] == 0x05]
    damaged = messages[len(messages) // 2]
    struct.pack_into("<Q", data, damaged[1] + 1, 3)
    path = tmp_path / "short.mcap"
    end = len(data) - 200  # its summary and footer cut off
    path.write_bytes(bytes(data[:end]))
    with ScannedMcap([whole]) as want, ScannedMcap([path]) as got:
        assert got.message_count == want.message_count - (len(messages) - len(messages) // 2)
        assert f"1 damaged chunk(s) passed over (byte {at}: 3 bytes, fewer than a message" in (
            got.said
        )
    (k,) = struct.unpack_from("<I", data, at + 9 + 28)
    data = bytearray(whole.read_bytes())
    struct.pack_into("<Q", data, at + 9 + 32 + k, 10**9)  # its records' length
    path.write_bytes(bytes(data[:end]))
    with ScannedMcap([whole]) as want, ScannedMcap([path]) as got:
        assert got.message_count == want.message_count - len(messages)
        assert f"(byte {at}: records of 1000000000 bytes past the chunk's end)" in got.said


def test_a_chunk_whose_compression_is_no_text_is_passed_over(tmp_path):
    """A zstd chunk whose compression string was damaged into bytes that are no UTF-8: the
    chunk is passed over, saying why, and the chunks after it read."""
    whole = _mcap(tmp_path, "zstd")
    data = bytearray(whole.read_bytes())
    at = _chunks(bytearray(data))[1][0]
    assert data[at + 9 + 32 : at + 9 + 36] == b"zstd"
    data[at + 9 + 32 : at + 9 + 36] = b"\xff\xfe\xfd\xfc"
    path = tmp_path / "name.mcap"
    path.write_bytes(bytes(data[: len(data) - 200]))
    with ScannedMcap([whole]) as want, ScannedMcap([path]) as got:
        assert 0 < got.message_count < want.message_count
        assert f"(byte {at}: 'utf-8' codec can't decode byte 0xff" in got.said
        assert got._files[0].chunks[-1][0] > at  # a chunk after it read


def _closed_damaged(tmp_path: Path, compression: str | None, chunk: int) -> tuple[Path, int]:
    """The closed file, its chunks given their CRCs (as rosbag2 writes them), one changed
    in the middle of its data: the CRC fails."""
    data = bytearray(_mcap(tmp_path, compression).read_bytes())
    chunks = _chunks(data)
    at, n = chunks[chunk]
    data[at + n // 2] ^= 0xFF
    path = tmp_path / f"closed_{chunk}.mcap"
    path.write_bytes(bytes(data))
    assert is_finished(path)
    return path, at


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_a_closed_file_rosbags_refuses_is_read_record_by_record(tmp_path, compression):
    """A closed file (summary and footer whole) whose second chunk fails its CRC: rosbags
    refuses it as it reads that chunk, so it is read again from its start record by
    record, the chunk passed over and the notes saying why: the seconds of the file cut
    short with the same damage, the whole file's but the damaged chunk's."""
    from rosbags.highlevel import AnyReader

    _, radius = _drive()
    path, at = _closed_damaged(tmp_path, compression, 1)
    with pytest.raises(Exception, match="(?i)checksum|crc"), AnyReader([path]) as bag:
        for _ in bag.messages():
            pass
    got, streams = _seconds(path, radius, "closed.mcap")
    said = "\n".join(streams.notes)
    assert "closed.mcap: rosbags refused the file (" in said
    assert ", closed as they are: read record by record, " in said
    assert f"1 damaged chunk(s) passed over (byte {at}: " in said
    cut = tmp_path / "cut.mcap"
    data = path.read_bytes()
    cut.write_bytes(data[: _chunks(bytearray(data))[-1][0] + _chunks(bytearray(data))[-1][1]])
    want, _ = _seconds(cut, radius, "cut.mcap")
    assert len(got) == len(want) == 75
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(got[q], want[q], err_msg=q)


def test_a_closed_file_whose_footer_is_damaged_is_read_whole(tmp_path):
    """The footer's summary start changed (rosbags cannot find the summary): every chunk
    is whole, so read record by record the file gives the undamaged file's seconds bit
    for bit."""
    _, radius = _drive()
    whole = _mcap(tmp_path, None)
    want, _ = _seconds(whole, radius, "whole.mcap")
    data = bytearray(whole.read_bytes())
    footer = len(data) - len(MAGIC) - 29  # opcode, length, summary start, offsets, CRC
    assert data[footer] == 0x02
    struct.pack_into("<Q", data, footer + 9, 7)  # the summary "starts" inside the header
    path = tmp_path / "footer.mcap"
    path.write_bytes(bytes(data))
    got, streams = _seconds(path, radius, "footer.mcap")
    assert "footer.mcap: rosbags refused the file (" in "\n".join(streams.notes)
    assert len(got) == len(want)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(got[q], want[q], err_msg=q)


def test_a_closed_file_whose_first_chunk_is_damaged_is_refused_with_rosbags_error(tmp_path):
    """The first chunk holds the channel records: passed over, no later message has a
    channel, so the file is refused, with the error rosbags gave (its CRC)."""
    _, radius = _drive()
    path, _ = _closed_damaged(tmp_path, None, 0)
    with pytest.raises(InputError) as err:
        read_mdf4(path, bag_map(), radius, "m", "first.mcap")
    text = str(err.value)
    assert "first.mcap: expected a ROS 2 bag" in text and "no whole message" not in text
    assert "checksum" in text.lower() or "crc" in text.lower()


def test_a_message_that_does_not_deserialise_is_passed_over_and_counted(tmp_path):
    """A closed, uncompressed file (rosbags' writer leaves the chunk CRCs 0: unchecked)
    one of whose wheel messages has its header's frame_id length damaged: rosbags cannot
    deserialise it and refuses the file; read record by record, that message is passed
    over and counted, every other one read."""
    tables, radius = simulated_streams(20.0, 100.0, 10.0)
    folder = tables_bag(tmp_path / "d", tables, ros2="mcap")
    path = next(folder.glob("*.mcap"))
    whole = read_mdf4(path, bag_map(), radius, "m", "w.mcap")
    with ScannedMcap([path]) as scanned:
        f = scanned._files[0]
        _, _, k, start, _ = f.messages[len(f.messages) // 2]
        at = f.chunks[k][0] + start  # the chunk's records are its bytes in the file
    data = bytearray(path.read_bytes())
    # CDR: the encapsulation (4 bytes), the stamp (8), then frame_id's length
    data[at + 12 : at + 16] = (10**6).to_bytes(4, "little")
    damaged = tmp_path / "m.mcap"
    damaged.write_bytes(bytes(data))
    streams = read_mdf4(damaged, bag_map(), radius, "m", "m.mcap")
    said = "\n".join(streams.notes)
    assert "m.mcap: rosbags refused the file (" in said
    assert ": 1 damaged message(s) that rosbags cannot deserialise as " in said
    got = sum(g.t_s.size for g in (*streams.wheels, streams.gnss))
    assert got == sum(g.t_s.size for g in (*whole.wheels, whole.gnss)) - 1
