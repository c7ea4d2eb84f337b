"""A ROS 2 bag's sqlite3 file cut short or damaged, read page by page (rwhonet.data.db3scan).

``ros2 bag record`` with sqlite3 storage (rosbag2's default through Humble) keeps each
message as a row of the file's ``messages`` table. A file cut short (a copy that stopped,
a disk that filled) or with a damaged page is "malformed" to SQLite, and ``rosbags``
refused the whole bag with it. The files here are written by ``rosbags``' writer (as
``ros2 bag record`` lays them out: the schema, metadata, topics, message_definitions and
messages tables) and cut or damaged as a disk would leave them.
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data.db3scan import MAGIC, ScannedDb3
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.multirate import per_second, simulated_streams
from support.rosbag import bag_map, tables_bag, typestore
from support.sqlitewal import resilient_recording, sqlite_rows


def _drive():
    """120 s: 100 Hz wheels, 10 Hz fixes, 50 Hz IMU (19,186 messages, 3.3 MB)."""
    return simulated_streams(120.0, 100.0, 10.0, gyro_hz=50.0)


def _db3(tmp_path: Path, definitions: bool = True) -> Path:
    tables, _ = _drive()
    folder = tables_bag(tmp_path / "drive", tables, ros2="sqlite3")
    db3 = next(folder.glob("*.db3"))
    if not definitions:  # as a bag recorded before Iron
        with sqlite3.connect(db3) as db:
            db.execute("DELETE FROM message_definitions")
        db.close()
    return db3


def _rosbags(db3: Path) -> tuple[list[tuple[str, str]], list[tuple[str, int, bytes]]]:
    """The bag's topics and messages (topic, time, data) as rosbags gives them."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([db3], default_typestore=get_typestore(Stores.LATEST)) as bag:
        topics = sorted((x.topic, x.msgtype) for x in bag.connections)
        return topics, [(x.topic, t, bytes(raw)) for x, t, raw in bag.messages()]


def _seconds(path: Path, radius: float, name: str):
    streams = read_mdf4(path, bag_map(yaw=True), radius, "m", name)
    grid = resample(streams, nominal_radius_m=radius).drive.columns
    return per_second(grid, radius), streams


@pytest.mark.parametrize("definitions", [True, False])
def test_a_whole_file_read_page_by_page_is_what_rosbags_reads(tmp_path, definitions):
    """Every page of a whole file: the topics, and every message (topic, time, data, in
    order) as rosbags gives them, bit for bit; with the message definitions (Iron on) and
    without (before Iron: ROS's own types of the latest LTS), each deserialises."""
    db3 = _db3(tmp_path, definitions)
    topics, want = _rosbags(db3)
    with ScannedDb3([db3], "test") as bag:
        assert sorted((x.topic, x.msgtype) for x in bag.connections) == topics
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
        assert got == want and bag.message_count == len(want) == 19_186
        con = next(x for x in bag.connections if x.topic == "/vehicle/gps/fix")
        fix = bag.deserialize(next(raw for x, _, raw in bag.messages([con])), con.msgtype)
        assert 52.0 < fix.latitude < 53.0
        assert "read page by page, 19186 messages from" in bag.said


@pytest.mark.parametrize("share", [0.3, 0.5, 0.9, 0.999])
def test_a_file_cut_short_reads_its_pages_as_far_as_they_go(tmp_path, share):
    """The file cut at 30 / 50 / 90 / 99.9 % of its bytes, which rosbags refused (SQLite:
    "database disk image is malformed"): read page by page, every message read is the
    whole file's of that time and topic (data bit for bit), the more the longer the file;
    the drive's labelled seconds are the whole file's for the seconds it covers; the notes
    say so."""
    tables, radius = _drive()
    db3 = _db3(tmp_path)
    data = db3.read_bytes()
    cut = tmp_path / "cut" / "drive_0.db3"
    cut.parent.mkdir()
    cut.write_bytes(data[: int(share * len(data))])
    _, whole = _rosbags(db3)
    whole_by = {(topic, t): raw for topic, t, raw in whole}
    with ScannedDb3([cut], "cut") as bag:
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
    assert all(whole_by[(topic, t)] == raw for topic, t, raw in got)
    assert share * len(whole) * 0.8 < len(got) <= len(whole)
    ref, _ = _seconds(db3.parent, radius, "whole")
    secs, streams = _seconds(cut, radius, cut.name)
    said = " ".join(streams.notes)
    assert "rosbags refused the file (" in said  # its error, cut to a length
    assert "read page by page" in said
    assert len(secs) >= 0.6 * share * len(ref)
    same = ref.merge(secs, on="t_s", suffixes=("", "_cut"))
    assert len(same) >= 0.9 * len(secs)
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(same[f"{q}_cut"], same[q], rtol=0, atol=1e-9, err_msg=q)


def test_damaged_cells_are_passed_over_and_the_pages_after_read(tmp_path):
    """Bytes of a leaf page in the file's middle overwritten (a disk's bad sector): its
    cells that no longer parse are passed over, counted, and every other message read as
    the whole file's."""
    db3 = _db3(tmp_path)
    data = bytearray(db3.read_bytes())
    page = int.from_bytes(data[16:18], "big")
    middle = (len(data) // page // 2) * page
    assert data[middle] == 13  # a table leaf page
    data[middle + 8 : middle + page] = bytes(range(256)) * ((page - 8) // 256) + bytes(
        (page - 8) % 256
    )
    bad = tmp_path / "bad" / "drive_0.db3"
    bad.parent.mkdir()
    bad.write_bytes(bytes(data))
    _, whole = _rosbags(db3)
    whole_by = {(topic, t): raw for topic, t, raw in whole}
    with ScannedDb3([bad], "bad") as bag:
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
        said = bag.said
    assert all(whole_by[(topic, t)] == raw or raw == b"" for topic, t, raw in got)
    assert len(whole) - 200 < len(got) < len(whole)
    assert f"{len(got)} messages from" in said and "26 damaged cell(s) passed over" in said


def _strings(path: Path, texts: list[tuple[int, str]], page_size: int | None = None) -> Path:
    """A ROS 2 sqlite3 bag of ``std_msgs/String`` messages on ``/notes``, written in the
    order given (time ns, text), its file's pages ``page_size`` bytes where given."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = typestore(ros2=True)
    string = ts.types["std_msgs/msg/String"]
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        con = w.add_connection("/notes", "std_msgs/msg/String", typestore=ts)
        for t, text in texts:
            w.write(con, t, ts.serialize_cdr(string(data=text), "std_msgs/msg/String"))
    db3 = next(path.glob("*.db3"))
    if page_size:
        with sqlite3.connect(db3) as db:
            db.execute(f"PRAGMA page_size={page_size}")
            db.execute("VACUUM")
        db.close()
    return db3


def _text(n: int) -> str:
    return "".join(chr(65 + k % 26) for k in range(n))


def test_a_message_longer_than_a_page_is_read_through_its_overflow_pages(tmp_path):
    """Messages of 20 to 24 kB (a String: a map's or a diagnostic's text) span overflow
    pages, their parts on the page every size SQLite's rule gives (the least, or more):
    read bit for bit; a chain broken (an overflow page's pointer off the file), its
    message is given empty, which rosbags cannot deserialise and the reader passes over
    as damaged."""
    t0 = 1_552_307_400_000_000_000
    sizes = [20_000 + 600 * k for k in range(8)]  # the page's part: every residue of 4092
    db3 = _strings(tmp_path / "big", [(t0 + k, _text(n)) for k, n in enumerate(sizes)])
    _, want = _rosbags(db3)
    with ScannedDb3([db3], "test") as bag:
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
        con = bag.connections[0]
        texts = [bag.deserialize(raw, con.msgtype).data for _, _, raw in bag.messages()]
    assert got == want and texts == [_text(n) for n in sizes]
    # an overflow page: its next page's number (0: the chain's last), then the text; break
    # one chain at a page that is not its last
    data = bytearray(db3.read_bytes())
    page = int.from_bytes(data[16:18], "big")
    first = next(
        p
        for p in range(len(data) // page)
        if data[p * page + 4 : (p + 1) * page].isalpha() and any(data[p * page : p * page + 4])
    )
    data[first * page : first * page + 4] = (10**6).to_bytes(4, "big")
    broken = tmp_path / "broken.db3"
    broken.write_bytes(bytes(data))
    with ScannedDb3([broken], "test") as bag:
        read = [raw for _, _, raw in bag.messages()]
    kept = [raw for raw in read if raw]
    assert len(read) == len(want) and len(kept) == len(want) - 1
    assert all(raw in {w[2] for w in want} for raw in kept)


@pytest.mark.parametrize("page_size", [512, 65536])
def test_any_page_size_and_rows_written_out_of_time_order(tmp_path, page_size):
    """A file of 512-byte pages and one of 65,536 (its header's 1), its messages written
    out of time order (a recorder's clock stepped back): every message in time order, as
    rosbags gives them, bit for bit."""
    times = [5, 1, 4, 2, 3]
    db3 = _strings(tmp_path / "b", [(t, _text(300 * t)) for t in times], page_size)
    assert int.from_bytes(db3.read_bytes()[16:18], "big") == min(
        page_size, 1 if page_size > 32768 else page_size
    )
    _, want = _rosbags(db3)
    with ScannedDb3([db3], "test") as bag:
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
    assert got == want and [t for _, t, _ in got] == sorted(times)


def test_what_is_no_database_or_holds_no_message_is_refused_with_rosbags_error(tmp_path):
    """A .db3 that is no SQLite file is refused as before, not read page by page; one whose
    topics' page is lost holds no message of a known topic: refused with rosbags' own
    error."""
    db3 = _db3(tmp_path)
    junk = tmp_path / "junk" / "drive_0.db3"
    junk.parent.mkdir()
    junk.write_bytes(b"not a database" * 1000)
    with pytest.raises(InputError) as err:
        read_mdf4(junk, bag_map(), 1.0, "m", junk.name)
    assert "read page by page" not in str(err.value)
    with pytest.raises(ValueError, match="does not start as an SQLite database"):
        ScannedDb3([junk], "test")
    data = bytearray(db3.read_bytes())
    page = int.from_bytes(data[16:18], "big")
    with sqlite3.connect(db3) as db:
        (root,) = db.execute("SELECT rootpage FROM sqlite_master WHERE name='topics'").fetchone()
    db.close()
    data[(root - 1) * page : root * page] = bytes(page)  # the topics' page zeroed
    lost = tmp_path / "lost" / "drive_0.db3"
    lost.parent.mkdir()
    lost.write_bytes(bytes(data[: len(data) // 2]))
    with pytest.raises(InputError) as err:
        read_mdf4(lost, bag_map(), 1.0, "m", lost.name)
    said = str(err.value)
    assert "database disk image is malformed" in said and "read page by page" not in said
    assert MAGIC == data[:16]


def test_a_folder_cut_short_with_its_metadata_reads_through_ingest_s_reader(tmp_path):
    """The bag's folder as rosbag2 leaves it, metadata.yaml and its db3 cut at half: read
    through the folder, the notes saying how."""
    tables, radius = _drive()
    db3 = _db3(tmp_path)
    folder = tmp_path / "copy"
    shutil.copytree(db3.parent, folder)
    half = folder / db3.name
    half.write_bytes(db3.read_bytes()[: db3.stat().st_size // 2])
    secs, streams = _seconds(folder, radius, "copy")
    assert len(secs) > 30
    assert any("read page by page" in n for n in streams.notes)
    assert np.isfinite(secs["label_m"]).all()


def _record(*columns: object) -> bytes:
    """A record as SQLite writes it (every varint here one byte): NULL, a one-byte
    integer, a BLOB (bytes) or a text (str)."""
    types, body = [], b""
    for v in columns:
        if v is None:
            types.append(0)
        elif isinstance(v, int):
            types.append(1)
            body += v.to_bytes(1, "big", signed=True)
        elif isinstance(v, bytes):
            types.append(12 + 2 * len(v))
            body += v
        else:
            types.append(13 + 2 * len(v.encode()))
            body += v.encode()
    return bytes([len(types) + 1, *types]) + body


def _leaf(cells: list[tuple[int, bytes]], page: int, at: int = 0) -> bytes:
    """A table leaf page of ``page`` bytes (its header at byte ``at``: 100 on page 1),
    the cells (rowid, payload) at its end."""
    out = bytearray(page)
    end, pointers = page, []
    for rowid, payload in cells:
        cell = bytes([len(payload), rowid]) + payload
        end -= len(cell)
        out[end : end + len(cell)] = cell
        pointers.append(end)
    out[at] = 13
    out[at + 3 : at + 5] = len(cells).to_bytes(2, "big")
    out[at + 5 : at + 7] = end.to_bytes(2, "big")
    for k, p in enumerate(pointers):
        out[at + 8 + 2 * k : at + 10 + 2 * k] = p.to_bytes(2, "big")
    return bytes(out)


def test_cells_whose_records_do_not_add_up_are_damaged_and_page_1_is_read_past_its_header(
    tmp_path,
):
    """Pages laid out by hand (512 bytes): page 1's cells, after the file's 100-byte header,
    and page 2's are read; a message whose BLOB's serial type claims more bytes than its
    cell holds, and a topic's row with a byte after its last column, are damaged: passed
    over, counted; so is each of page 3's 300 cells (its pointers zero, 48 of them past
    the page's end)."""
    topic = _record(None, "/notes", "std_msgs/msg/String", "cdr", "")
    message = _record(None, 1, 7, b"\x00\x01\x00\x00ab")
    claims_more = bytearray(_record(None, 1, 8, b"\x00\x01\x00\x00cd"))
    claims_more[4] += 2 * 4  # the BLOB's serial type: 4 bytes more than there are
    one_more = _record(None, "/more", "std_msgs/msg/String", "cdr", "") + b"\x00"
    page1 = bytearray(_leaf([(1, topic), (2, one_more)], 512, at=100))
    page1[:100] = bytes(100)
    page1[:16] = MAGIC
    page1[16:18] = (512).to_bytes(2, "big")
    page2 = _leaf([(1, message), (2, bytes(claims_more))], 512)
    page3 = bytearray(512)
    page3[0] = 13
    page3[3:5] = (300).to_bytes(2, "big")  # 252 pointers fit in its 504 bytes
    db3 = tmp_path / "hand.db3"
    db3.write_bytes(bytes(page1) + page2 + page3)
    with ScannedDb3([db3], "test") as bag:
        assert [(c.id, c.topic) for c in bag.connections] == [(1, "/notes")]
        assert [(t, raw) for _, t, raw in bag.messages()] == [(7, b"\x00\x01\x00\x00ab")]
        assert "read page by page, 1 messages from 3 pages; 302 damaged cell(s) passed over" in (
            bag.said
        )


def _sqlite_messages(db3: Path, scratch: Path) -> list[tuple[str, int, bytes]]:
    """The bag's messages (topic, time, data) in time order as SQLite reads the file with
    its write-ahead log."""
    rows = sqlite_rows(
        db3,
        scratch,
        "SELECT t.name, m.timestamp, m.data FROM messages m JOIN topics t "
        "ON m.topic_id = t.id ORDER BY m.timestamp, m.id",
    )
    return [(name, t, bytes(data)) for name, t, data in rows]


def test_a_file_emptied_by_the_crash_is_read_from_its_log(tmp_path):
    """A file a crash left empty (a file system that had not yet written it) beside a log
    that holds every page, its header's too: read from the log alone, every message
    SQLite reads of the file as it was (SQLite itself takes an empty file for a new
    database, and does not read the log)."""
    db3 = _db3(tmp_path)
    killed = resilient_recording(db3, tmp_path / "killed", 0.25)
    want = _sqlite_messages(killed, tmp_path / "sqlite")
    killed.write_bytes(b"")
    with ScannedDb3([killed], None) as bag:
        assert [(x.topic, t, raw) for x, t, raw in bag.messages()] == want
    assert len(want) == int(0.25 * 19_186)


@pytest.mark.parametrize(("share", "checkpoint"), [(0.25, 1000), (0.8, 100)])
def test_a_bag_recorded_resilient_and_killed_is_read_through_its_log(tmp_path, share, checkpoint):
    """rosbag2's ``resilient`` preset (SQLite's write-ahead log) killed after a quarter of the
    drive's messages with no checkpoint yet (every page in ``drive_0.db3-wal``: the file
    holds its header alone: rosbags, which opens it ``immutable``, finds no table), and
    after 80 % with a checkpoint every 100 pages (the file holds the drive up to the last
    one, rosbags reads that much and no more): every message SQLite reads through the log
    is read, bit for bit, in time order; the drive's labelled seconds are the whole
    bag's for the seconds it covers; the notes name the log."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    tables, radius = _drive()
    db3 = _db3(tmp_path)
    folder = tmp_path / "killed"
    killed = resilient_recording(db3, folder, share, checkpoint)
    want = _sqlite_messages(killed, tmp_path / "sqlite")
    _, whole = _rosbags(db3)
    assert len(want) == int(share * len(whole))  # every batch committed
    with ScannedDb3([killed], None) as bag:
        got = [(x.topic, t, raw) for x, t, raw in bag.messages()]
        assert "drive.db3-wal (a recorder stopped" in bag.said
    assert got == want
    # what rosbags reads of the file alone: nothing, or up to the last checkpoint
    try:
        with AnyReader([killed], default_typestore=get_typestore(Stores.LATEST)) as alone:
            before = alone.message_count
    except Exception as err:  # rosbags' error: the file holds no table yet
        assert checkpoint == 1000 and "missing tables" in str(err)
    else:
        assert checkpoint == 100 and 0 < before < len(want)
    ref, _ = _seconds(db3.parent, radius, "whole")
    secs, streams = _seconds(folder, radius, "killed")
    said = " ".join(streams.notes)
    assert "read page by page" in said and "rosbags refused" not in said
    assert "-wal" in said and "no metadata.yaml" in said
    for topic in {x[0] for x in whole}:
        n = sum(x[0] == topic for x in want)
        assert f"{topic}: {n} message(s)" in said
    if share < 0.5:  # 30 s: no valid stretch of min_segment_s (30 s) to label
        return
    assert 0.9 * share * len(ref) <= len(secs) <= share * len(ref) + 1
    same = ref.merge(secs, on="t_s", suffixes=("", "_wal"))
    assert len(same) >= len(secs) - 2
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(same[f"{q}_wal"], same[q], rtol=0, atol=1e-9, err_msg=q)


def test_a_log_that_commits_nothing_leaves_the_bag_to_rosbags(tmp_path):
    """A ``-wal`` beside a closed file that holds only its header (a log SQLite emptied
    at its last checkpoint), or frames that fail their checksums: the file is read by
    rosbags as before, not page by page."""
    tables, radius = _drive()
    db3 = _db3(tmp_path)
    folder = tmp_path / "copy"
    shutil.copytree(db3.parent, folder)
    log = folder / (db3.name + "-wal")
    log.write_bytes(b"\x37\x7f\x06\x82" + bytes(60))  # no header checksum: void
    secs, streams = _seconds(folder, radius, "copy")
    assert not any("page by page" in n for n in streams.notes)
    ref, _ = _seconds(db3.parent, radius, "whole")
    assert len(secs) == len(ref)
    # read page by page (rosbags refused it for another reason): the file alone
    _, want = _rosbags(db3)
    with ScannedDb3([folder / db3.name], "test") as bag:
        assert [(x.topic, t, raw) for x, t, raw in bag.messages()] == want
        assert "-wal" not in bag.said


def test_a_db3_given_alone_with_its_log_is_one_drive(tmp_path):
    """``target_test/*`` matching a killed recording's ``drive_0.db3`` and its
    ``drive_0.db3-wal`` (and SQLite's ``-shm``): one drive, read through its log as
    ingest reads it; a ``-wal`` with no ``.db3`` beside it is a file of its own."""
    import dataclasses

    from rwhonet.data.drivefile import read_any
    from rwhonet.stages.ingest import discover
    from support.drives import make_params

    tables, radius = _drive()
    db3 = _db3(tmp_path)
    killed = resilient_recording(db3, tmp_path / "raw" / "target_test", 0.5)
    killed.with_name(killed.name + "-shm").write_bytes(bytes(32768))
    (killed.parent / "other.db3-wal").write_bytes(b"x")
    signals = {k: {"column": v.column, "unit": v.unit} for k, v in bag_map().items()}
    data = make_params(
        tmp_path,
        **{
            "data.source": "files",
            "data.root": str(tmp_path / "raw"),
            "data.signal_maps": {"ros": {"reader": "mdf4", "signals": signals}},
        },
    ).data
    spec = dataclasses.replace(data.roles["target_test"], format="ros", glob="target_test/*")
    data = dataclasses.replace(data, roles={"target_test": spec})
    found = discover(data)
    assert [f.path.name for f in found] == ["drive.db3", "other.db3-wal"]
    raw, _ = read_any(found[0], data, lambda p: p.name, radius, 0.1, 10.0)
    assert any("drive.db3-wal" in n for n in raw.notes)
