"""An MDF4 bus log's raw CAN frames read a part at a time (``rwhonet.data.mdfframes``): what
they are, as asammdf's own decode of the whole file gives them, bounded, the short ones
passed over."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data import mdf4, mdfframes
from rwhonet.data.canlog import FRAME_DTYPE
from rwhonet.data.keptframes import FrameFilter
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.errors import InputError
from support.canlog import DBC, FIX_ID, SATS_ID, SIGNALS, WHEELS_ID, can_frames
from support.serving import wavy_drive

RADIUS_M = 0.31
NAME = "data.signal_maps.canedge.signals"
OTHER_ID = 0x123  # a message the map does not need


def _signals() -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(**v) for k, v in SIGNALS.items()}


def _source():  # type: ignore[no-untyped-def]
    from asammdf.blocks.v4_blocks import SourceInformation
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS

    return SourceInformation(source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)


def _write(path: Path, groups: list[tuple[str, np.ndarray, np.ndarray]]) -> Path:
    """An MDF4 file of channel groups ``(name, stamps, records)``, each a bus logging
    group as a CAN logger writes it (``CAN_DataFrame``, ``CAN_ErrorFrame``)."""
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    for name, stamps, records in groups:
        mdf.append(Signal(records, stamps, name=name, source=_source()))
    mdf.save(path, overwrite=True)
    mdf.close()
    path.with_suffix(".dbc").write_text(DBC)
    return path


def _records(ids, data, bus=1, length=None, dtype=FRAME_DTYPE) -> np.ndarray:  # type: ignore[no-untyped-def]
    out = np.zeros(len(ids), dtype)
    out["CAN_DataFrame.ID"] = ids
    out["CAN_DataFrame.DataBytes"] = data
    for field, value in (
        ("BusChannel", bus),
        ("DLC", data.shape[1] if length is None else length),
        ("DataLength", data.shape[1] if length is None else length),
    ):
        if f"CAN_DataFrame.{field}" in out.dtype.names:
            out[f"CAN_DataFrame.{field}"] = value
    return out


@pytest.fixture
def bus(tmp_path):
    """A drive's frames among a whole bus's: each of the drive's frames followed by four of
    another message."""
    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M)
    n = stamps.size
    stamps = np.r_[stamps, np.repeat(stamps, 4) + np.tile([1e-4, 2e-4, 3e-4, 4e-4], n)]
    ids = np.r_[ids, np.full(4 * n, OTHER_ID)]
    data = np.r_[data, np.full((4 * n, 8), 0xAB, np.uint8)]
    order = np.argsort(stamps, kind="stable")
    path = _write(
        tmp_path / "bus.mf4", [("CAN_DataFrame", stamps[order], _records(ids[order], data[order]))]
    )
    return df, path, (stamps[order], ids[order], data[order])


def _read(path: Path, **kw):  # type: ignore[no-untyped-def]
    return read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[str(path.with_suffix(".dbc"))], **kw)


def _whole(path: Path, monkeypatch):  # type: ignore[no-untyped-def]
    """The log decoded whole by asammdf (the map's messages not told apart)."""
    with monkeypatch.context() as m:
        m.setattr(mdf4, "_wanted", lambda *a: None)
        return _read(path)


def _same(a, b) -> None:  # type: ignore[no-untyped-def]
    for x, y in [*zip(a.wheels, b.wheels, strict=True), (a.gnss, b.gnss)]:
        np.testing.assert_array_equal(x.t_s, y.t_s)
        assert sorted(x.channels) == sorted(y.channels)
        for k in x.channels:
            np.testing.assert_array_equal(x.channels[k], y.channels[k])


def test_a_bus_log_read_in_parts_decodes_as_asammdf_decodes_it_whole(bus, monkeypatch):
    """Read 200 bytes of records at a time (8 frames), the map's frames kept, the streams
    are asammdf's decode of the whole file to the bit; the other frames counted, not
    decoded."""
    df, path, (_, ids, _) = bus
    monkeypatch.setattr(mdfframes, "FRAGMENT_BYTES", 200)
    sizes: list[int] = []
    part = mdfframes._part

    def counted(records, stamps, kept):  # type: ignore[no-untyped-def]
        sizes.append(records.size)
        return part(records, stamps, kept)

    monkeypatch.setattr(mdfframes, "_part", counted)
    parts = _read(path)
    assert max(sizes) == 8 and sum(sizes) == ids.size
    _same(parts, _whole(path, monkeypatch))
    np.testing.assert_allclose(parts.wheels[0].t_s, df[c.T_S] - df[c.T_S].iloc[0], atol=1e-9)
    kept = int(np.isin(ids, [WHEELS_ID, FIX_ID, SATS_ID]).sum())
    assert f"{path}: {ids.size} data frames on 1 bus(es) (1)" in parts.notes
    assert any(n.startswith(f"{path}: {kept} of them decoded") for n in parts.notes)
    assert parts.wheels[0].rows is not None  # each sample's frame, numbered in the file


def test_the_frames_numbered_among_the_file_s_and_only_the_map_s_kept(bus):
    _, path, (stamps, ids, data) = bus
    from asammdf import MDF

    keep = FrameFilter(frozenset({(WHEELS_ID, False), (FIX_ID, False)}))
    mdf = MDF(path, process_bus_logging=False)
    try:
        frames = mdfframes.mdf_frames(mdf, keep, 100.0, "a clock")
    finally:
        mdf.close()
    at = np.flatnonzero(np.isin(ids, [WHEELS_ID, FIX_ID]))
    np.testing.assert_array_equal(frames.rows, at + 1)
    np.testing.assert_array_equal(frames.ids, ids[at])
    np.testing.assert_allclose(frames.t_s, stamps[at] + 100.0, atol=1e-9)
    np.testing.assert_array_equal(frames.data, data[at])
    assert frames.dropped == ids.size - at.size and frames.in_log == ids.size
    assert frames.buses == ["1"] and set(frames.channel.tolist()) == {1}
    assert len(frames.log_ids) == 4 and frames.clock == "a clock"


def test_the_file_is_opened_without_asammdf_reading_every_frame_s_id(bus, monkeypatch):
    """asammdf's opening reads every frame's identifier and bus (``process_bus_logging``),
    the whole file's worth; read in parts, it is not called."""
    from asammdf.blocks.mdf_v4 import MDF4

    _, path, _ = bus

    def whole(self) -> None:  # type: ignore[no-untyped-def]
        raise AssertionError("every frame's identifier read at opening")

    monkeypatch.setattr(MDF4, "_process_bus_logging", whole)
    assert _read(path).wheels[0].t_s.size == 301


def test_a_bus_log_past_its_kept_frames_bound_is_refused_naming_the_frame(bus, monkeypatch):
    """Bounded as a bus tool's log is: the frame one too many named by its number in the
    file (the drive's 301 + 2 x 31 frames against 1,228 + 1 room left here)."""
    _, path, (_, ids, _) = bus
    monkeypatch.setattr(mdfframes, "FRAGMENT_BYTES", 2000)
    mine = np.flatnonzero(np.isin(ids, [WHEELS_ID, FIX_ID, SATS_ID]))
    max_mb = 0.05  # 204 frames at 256 bytes each
    bound = FrameFilter.frames_for(max_mb)
    with pytest.raises(InputError) as err:
        _read(path, max_mb=max_mb)
    (problem,) = err.value.problems
    assert problem.row == mine[bound] + 1 and f"at most {bound:,} frames" in problem.expected
    assert _read(path, max_mb=1.0).wheels[0].t_s.size == 301


def test_a_frame_shorter_than_its_message_is_passed_over_not_decoded_from_zeros(tmp_path):
    """A fix frame cut to 2 of its 8 bytes decoded as latitude 0.006, longitude 0 before;
    it is passed over, said with its number in the file."""
    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M)
    length = np.full(ids.size, 8)
    cut = int(np.flatnonzero(ids == FIX_ID)[5])
    length[cut], data[cut, 2:] = 2, 0
    path = _write(
        tmp_path / "bus.mf4", [("CAN_DataFrame", stamps, _records(ids, data, length=length))]
    )
    streams = _read(path)
    fixes = int((ids == FIX_ID).sum())
    assert streams.gnss.t_s.size == fixes - 1
    assert np.abs(streams.gnss.channels[c.LAT_DEG]).min() > 50
    said = f"first at row {cut + 1}: GnssPos 0x600, 2 of 8 bytes"
    assert any(said in n for n in streams.changed)


def test_two_groups_give_their_frames_in_time_order_on_their_own_buses(tmp_path, monkeypatch):
    """A logger that writes a group a bus (channel 2's wheel frames, channel 1's fixes):
    the frames in time order, numbered group after group, each bus by its number."""
    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M)
    wheels = ids == WHEELS_ID
    path = _write(
        tmp_path / "bus.mf4",
        [
            ("CAN_DataFrame", stamps[wheels], _records(ids[wheels], data[wheels], bus=2)),
            ("CAN_DataFrame", stamps[~wheels], _records(ids[~wheels], data[~wheels], bus=1)),
        ],
    )
    from asammdf import MDF

    keep = FrameFilter(frozenset({(WHEELS_ID, False), (FIX_ID, False), (SATS_ID, False)}))
    mdf = MDF(path, process_bus_logging=False)
    try:
        frames = mdfframes.mdf_frames(mdf, keep, 0.0, "")
    finally:
        mdf.close()
    assert np.all(np.diff(frames.t_s) >= 0)
    assert frames.buses == ["2", "1"]  # in the order first seen: the first group's
    assert set(frames.channel[frames.ids == WHEELS_ID].tolist()) == {1}
    np.testing.assert_array_equal(np.sort(frames.rows), np.arange(ids.size) + 1)
    assert frames.rows[np.argmax(frames.ids != WHEELS_ID)] == wheels.sum() + 1
    with pytest.raises(InputError) as err:  # a bus the log has not, named by its number
        read_mdf4(path, _signals(), RADIUS_M, NAME, dbc=[(str(path.with_suffix(".dbc")), "3")])
    (problem,) = err.value.problems
    assert problem.found == "the log's buses are 2, 1" and "bus channel number" in problem.fix
    _same(_read(path), _whole(path, monkeypatch))


def test_an_fd_log_without_ide_or_data_length_reads_them_from_id_and_dlc(tmp_path):
    """A log whose records have no ``IDE`` (the extended flag in the identifier's bit 31)
    and no ``DataLength`` (an FD frame's DLC 9: 12 bytes) of 64-byte payloads."""
    from asammdf import MDF

    dtype = np.dtype(
        [
            ("CAN_DataFrame.BusChannel", "<u1"),
            ("CAN_DataFrame.ID", "<u4"),
            ("CAN_DataFrame.DLC", "<u1"),
            ("CAN_DataFrame.DataBytes", "(64,)u1"),
        ]
    )
    records = np.zeros(3, dtype)
    records["CAN_DataFrame.BusChannel"] = 1
    records["CAN_DataFrame.ID"] = [0x1A0, 0x18FEBFFE | 0x8000_0000, 0x1A0]
    records["CAN_DataFrame.DLC"] = [8, 9, 15]
    records["CAN_DataFrame.DataBytes"][:, 0] = [1, 2, 3]
    path = _write(tmp_path / "fd.mf4", [("CAN_DataFrame", np.array([0.0, 0.1, 0.2]), records)])
    keep = FrameFilter(frozenset({(0x1A0, False), (0x18FEBFFE, True)}))
    mdf = MDF(path, process_bus_logging=False)
    try:
        frames = mdfframes.mdf_frames(mdf, keep, 0.0, "")
    finally:
        mdf.close()
    assert frames.ids.tolist() == [0x1A0, 0x18FEBFFE, 0x1A0]
    assert frames.extended.tolist() == [False, True, False]
    assert frames.length.tolist() == [8, 12, 64] and frames.data.shape == (3, 64)
    assert frames.data[:, 0].tolist() == [1, 2, 3]


def test_error_and_remote_frames_groups_are_counted_as_passed_over(bus):
    _, path, (stamps, ids, data) = bus
    errors = np.zeros(
        5, [("CAN_ErrorFrame.BusChannel", "<u1"), ("CAN_ErrorFrame.ErrorType", "<u1")]
    )
    remote = np.zeros(2, [("CAN_RemoteFrame.BusChannel", "<u1"), ("CAN_RemoteFrame.ID", "<u4")])
    _write(
        path,
        [
            ("CAN_DataFrame", stamps, _records(ids, data)),
            ("CAN_ErrorFrame", np.arange(5.0), errors),
            ("CAN_RemoteFrame", np.arange(2.0), remote),
        ],
    )
    streams = _read(path)
    assert f"{path}: passed over: 5 error frames, 2 remote frames" in streams.notes


def test_variable_length_payloads_are_laid_out_in_rows():
    got = mdfframes.payloads(np.array([b"\x01\x02", b"", b"\x03" * 8], dtype=object))
    assert got.shape == (3, 8) and got[0, :3].tolist() == [1, 2, 0] and got[2].sum() == 24
    fd = mdfframes.payloads(np.array([b"\x01", b"\x02" * 20], dtype=object))
    assert fd.shape == (2, 64) and fd[1, :21].tolist() == [2] * 20 + [0]


def test_a_stream_folder_s_canedge_file_read_in_parts_is_on_its_start(tmp_path, monkeypatch):
    """A CANedge's split file among a stream folder's: its frames on its start (UTC), as
    decoded whole before."""
    from rwhonet.data.mdf4 import can_log_groups
    from support.canlog import write_mdf_bus_log

    df = wavy_drive(30.0)
    stamps, ids, data = can_frames(df, RADIUS_M, t0_s=1.7e9)
    path = write_mdf_bus_log(stamps, ids, data, tmp_path / "00000001.MF4")
    (tmp_path / "bus.dbc").write_text(DBC)
    dbc = [str(tmp_path / "bus.dbc")]
    parts = can_log_groups(path, _signals(), RADIUS_M, NAME, "00000001.MF4", dbc)
    with monkeypatch.context() as m:
        m.setattr(mdf4, "_wanted", lambda *a: None)
        whole = can_log_groups(path, _signals(), RADIUS_M, NAME, "00000001.MF4", dbc)
    assert parts.clock == whole.clock == "Unix time (the file's start is UTC)"
    for a, b in zip(parts.groups, whole.groups, strict=True):
        np.testing.assert_array_equal(a.t_s, b.t_s)
        for k in a.channels:
            np.testing.assert_array_equal(a.channels[k], b.channels[k])
    np.testing.assert_allclose(parts.groups[0].t_s[0], stamps[0], atol=1e-6)
    assert any("plus its master time" in n for n in parts.notes)


def _fat_bus(tmp_path: Path, others: int = 20) -> tuple[Path, int]:
    """The drive's frames, each followed by ``others`` of another message: (the log, how
    many frames of the drive's)."""
    stamps, ids, data = can_frames(wavy_drive(30.0), RADIUS_M)
    n = stamps.size
    step = np.arange(1, others + 1) * 1e-5
    stamps = np.r_[stamps, np.repeat(stamps, others) + np.tile(step, n)]
    order = np.argsort(stamps, kind="stable")
    ids = np.r_[ids, np.full(others * n, OTHER_ID)][order]
    data = np.r_[data, np.full((others * n, 8), 0xAB, np.uint8)][order]
    path = _write(tmp_path / "bus.mf4", [("CAN_DataFrame", stamps[order], _records(ids, data))])
    return path, n


def _drive(path: Path, max_mb: float, signals=None, dbc: bool = True):  # type: ignore[no-untyped-def]
    """The drive as ingest reads it (``read_any``) under ``data.max_file_mb``: a file with
    ``reader: mdf4``, a folder with ``reader: stream_csv``."""
    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params

    spec = {"reader": "mdf4", "signals": signals or SIGNALS}
    if path.is_dir():
        spec = {"reader": "stream_csv", "signals": {"t": {"column": "t", "unit": "s"}, **SIGNALS}}
    if dbc:
        spec["dbc"] = str((path if path.is_dir() else path.parent) / "bus.dbc")
    params = {"data.signal_maps": {"bus": spec}, "data.max_file_mb": max_mb}
    data = make_params(path.parent, **params).data
    f = DriveFile("bus", "target_test", "target", "bus", path)
    return read_any(f, data, lambda p: p.name, RADIUS_M, 0.1, 10.0)[0]


def test_an_mdf4_bus_log_above_the_size_limit_is_read_bounded_by_its_kept_frames(tmp_path):
    """A bus log of 0.45 MB under a data.max_file_mb of 0.3 (1,228 frames): its 903 frames of
    the map's messages are kept, as a bus tool's log's are (the base 3308815 refused it by
    its size); kept compressed too (its copy bounded by the disk), and as a CANedge
    session's file in a stream folder. Where it would be read
    whole (a signal no database defines) its size is bounded, the reason said."""
    import gzip

    path, n = _fat_bus(tmp_path)
    size_mb = path.stat().st_size / 2**20
    assert size_mb > 0.4 and FrameFilter.frames_for(0.3) >= n > FrameFilter.frames_for(0.2)
    got = _drive(path, 0.3)
    assert got.columns[c.T_S].size > 200
    with pytest.raises(InputError) as err:
        _drive(path, 0.2)  # 819 frames
    assert "frames of the messages the map's signals are in" in err.value.problems[0].expected
    packed = tmp_path / "bus.mf4.gz"
    packed.write_bytes(gzip.compress(path.read_bytes(), mtime=0))
    np.testing.assert_array_equal(_drive(packed, 0.3).columns[c.T_S], got.columns[c.T_S])
    folder = tmp_path / "LOG"  # a CANedge's session: the file on its start
    folder.mkdir()
    path.rename(folder / "00000001.MF4")
    (folder / "bus.dbc").write_text(DBC)
    assert _drive(folder, 0.3).columns[c.T_S].size == got.columns[c.T_S].size
    (folder / "00000001.MF4").rename(path)
    (folder / "00000001.MF4.gz").write_bytes(packed.read_bytes())  # kept compressed there
    assert _drive(folder, 0.3).columns[c.T_S].size == got.columns[c.T_S].size
    yaw = {**SIGNALS, "yaw_rate": {"column": "YawRate", "unit": "deg/s"}}
    with pytest.raises(InputError) as err:
        _drive(path, 0.3, yaw)
    (problem,) = err.value.problems
    assert problem.expected == "a CAN log read whole of at most 0.3 MB (data.max_file_mb)"
    assert problem.found.endswith("to be read whole as no database defines YawRate")


def test_an_mdf4_file_without_a_dbc_still_counts_by_its_size(tmp_path):
    """Without the map's dbc an MDF4 file's signals are decoded already, read whole: the
    file is refused above data.max_file_mb before it is read."""
    path, _ = _fat_bus(tmp_path)
    with pytest.raises(InputError) as err:
        _drive(path, 0.3, dbc=False)
    assert err.value.problems[0].expected == "a drive file of at most 0.3 MB (data.max_file_mb)"


def test_an_mdf_bus_log_of_another_suffix_is_read_as_an_mdf_file(bus, tmp_path):
    """A logger's MDF file named otherwise (``drive.dat``, as INCA and older Vector tools
    name theirs) is asammdf's to open, read a part at a time as any MDF4 bus log."""
    _, path, (_, ids, _) = bus
    dat = path.rename(path.with_suffix(".dat"))
    streams = read_mdf4(dat, _signals(), RADIUS_M, NAME, dbc=[str(path.with_suffix(".dbc"))])
    assert streams.wheels[0].t_s.size == int((ids == WHEELS_ID).sum())
    assert f"{dat}: {ids.size} data frames on 1 bus(es) (1)" in streams.notes
