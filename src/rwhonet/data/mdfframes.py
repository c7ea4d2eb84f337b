"""An MDF4 bus log's raw CAN frames (ASAM MDF bus logging's ``CAN_DataFrame`` records, as a
CANedge or a Vector logger writes them), read a part at a time into
:class:`~rwhonet.data.canlog.Frames`, the frames of the map's messages kept.

asammdf's own decode (``MDF.extract_bus_logging``) decodes every frame of the file, and
opening the file reads every frame's identifier and bus first (``process_bus_logging``):
20 minutes of a whole bus (94 MB) took 0.83 GB. Read here with asammdf's ``MDF.iter_get``
:data:`FRAGMENT_BYTES` of records at a time (each compressed block inflated once), each
part's frames of other messages left out as it is read (:class:`~rwhonet.data.keptframes.Kept`),
an MDF4 bus log is decoded as a bus tool's log is (:func:`rwhonet.data.mdf4.can_log_groups`):
its memory that of a part and of the frames kept (at most ``keep.max_frames``), its frames
shorter than their message passed over (:func:`rwhonet.data.canlog.short_passed`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rwhonet.data.canlog import Frames
from rwhonet.data.keptframes import ID_MASK, FrameFilter, Kept
from rwhonet.data.trc import FD_LENGTHS

# the bytes of records read at a time (asammdf's ``read_fragment_size``): some 100,000
# frames of a CAN FD layout's 64-byte payloads, 360,000 of a classic one's 8
FRAGMENT_BYTES = 8 << 20
DATA_FRAME = "CAN_DataFrame"
# the other frames ASAM bus logging records, each in channel groups of their own
OTHER_FRAMES = {"CAN_ErrorFrame": "error frames", "CAN_RemoteFrame": "remote frames"}


def frame_groups(mdf: Any) -> list[int]:
    """The channel groups of ``mdf`` that hold raw CAN data frames (a ``CAN_DataFrame``
    channel), as asammdf's bus-logging decode finds them."""
    return [i for i, g in enumerate(mdf.groups) if _has(g, DATA_FRAME)]


def mdf_frames(
    mdf: Any, keep: FrameFilter, t0_s: float, clock: str, local_start: bool = False
) -> Frames:
    """The data frames of ``mdf``'s :func:`frame_groups` that ``keep`` keeps, group after
    group, then in time order where there are several groups.

    Args:
        mdf: an ``asammdf.MDF``, best opened with ``process_bus_logging=False`` (which
            would read every frame's identifier at once).
        keep: the messages kept, and the most frames kept (:class:`TooManyFrames` past it).
        t0_s: added to the master time (the file's start, where the frames are on it).
        clock: what the stamps count, for the notes.
        local_start: the start is local time no zone put on UTC.

    Returns:
        The kept frames, numbered among the file's data frames (1-based, group after
        group); their buses named by the log's bus channel numbers (``"1"``), numbered in
        the order first seen; the error and remote frames' groups counted in ``passed``.
    """
    kept = Kept(keep)
    parts: list[tuple[np.ndarray, ...]] = []
    mdf.configure(read_fragment_size=FRAGMENT_BYTES)
    groups = frame_groups(mdf)
    for g in groups:
        index = [ch.name for ch in mdf.groups[g].channels].index(DATA_FRAME)
        for got in mdf.iter_get(group=g, index=index, raw=True):
            parts.append(_part(got.samples, got.timestamps, kept))
    t, ids, ext, length, bus, rows = (
        np.concatenate([p[k] for p in parts] or [np.zeros(0, d)])
        for k, d in enumerate((np.float64, np.uint32, bool, np.uint8, np.int64, np.int64))
    )
    width = max([p[6].shape[1] for p in parts if p[6].size] or [8])
    data = np.concatenate(
        [np.pad(p[6], ((0, 0), (0, width - p[6].shape[1]))) for p in parts]
        or [np.zeros((0, width), np.uint8)]
    )
    order = np.argsort(t, kind="stable") if len(groups) > 1 else slice(None)
    skipped = {
        said: sum(int(g.channel_group.cycles_nr) for g in mdf.groups if _has(g, name))
        for name, said in OTHER_FRAMES.items()
    }
    return Frames(
        t[order] + t0_s,
        ids[order],
        ext[order],
        length[order],
        data[order],
        kept.channel(bus[order]),
        kept.buses,
        clock,
        rows[order],
        ", ".join(f"{v} {k}" for k, v in skipped.items() if v),
        local_start,
        kept.dropped,
        kept.log_ids(),
    )


def _has(group: Any, name: str) -> bool:
    return any(ch.name == name for ch in group.channels)


def _part(records: np.ndarray, stamps: np.ndarray, kept: Kept) -> tuple[Any, ...]:
    """The kept frames of a part's ``CAN_DataFrame`` records (a structured array of its
    fields: ``CAN_DataFrame.ID``, ...): (time, identifier, extended, length, bus, row,
    data)."""
    names = records.dtype.names or ()

    def field(name: str) -> np.ndarray | None:
        key = f"{DATA_FRAME}.{name}"
        return np.asarray(records[key]) if key in names else None

    raw_ids = np.asarray(field("ID")).astype(np.uint32)
    ide = field("IDE")
    ext = (raw_ids >> 31).astype(bool) if ide is None else ide != 0
    ids = raw_ids & np.uint32(ID_MASK)
    channel = field("BusChannel")
    bus = np.ones(ids.size, np.int64) if channel is None else channel.astype(np.int64)
    first = kept.messages
    at = kept.part(ids, ext, bus)
    data = payloads(np.asarray(field("DataBytes"))[at])
    length = _lengths(field("DataLength"), field("DLC"), data, at)
    return (
        np.asarray(stamps, np.float64)[at],
        ids[at],
        ext[at],
        np.minimum(length, data.shape[1]).astype(np.uint8),
        bus[at],
        first + at.astype(np.int64) + 1,
        data,
    )


def payloads(samples: np.ndarray) -> np.ndarray:
    """Frames' data bytes as rows of one width (8, or 64 where any is longer; zero after a
    frame's own): a fixed-size byte array as it is, a variable-length one (a VLSD
    channel, each frame's bytes an object) laid out."""
    if samples.dtype == np.uint8 and samples.ndim == 2:
        return samples
    each = [bytes(x) for x in samples.tolist()]
    lengths = np.array([len(x) for x in each], np.int64)
    width = 8 if lengths.max(initial=0) <= 8 else max(64, int(lengths.max()))
    data = np.zeros((len(each), width), np.uint8)
    for row, x in enumerate(each):
        data[row, : len(x)] = np.frombuffer(x, np.uint8)
    return data


def _lengths(
    length: np.ndarray | None, dlc: np.ndarray | None, data: np.ndarray, at: np.ndarray
) -> np.ndarray:
    """Each kept frame's data length: ``DataLength`` where the file has it, else its
    ``DLC`` (an FD frame's code past 8 as its bytes), else its data's width."""
    if length is not None:
        return length[at].astype(np.int64)
    if dlc is not None:
        code = dlc[at].astype(np.int64)
        return np.where(code <= 8, code, FD_LENGTHS[np.minimum(code, 15)])
    return np.full(at.size, data.shape[1], np.int64)
