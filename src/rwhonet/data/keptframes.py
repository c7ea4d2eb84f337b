"""Which of a raw CAN log's frames a decode needs, kept a part of the log at a time.

A logger on a car's bus records every message on it: thousands of frames a second, of
which the map's signals are in a few messages (the wheel speeds', the receiver's). A
:class:`FrameFilter` names those messages (:func:`rwhonet.data.mdf4.can_log_groups` finds
them in the CAN databases); each log's reader (:mod:`rwhonet.data.canlog`, and the
parsers of :mod:`rwhonet.data.trc`, :mod:`rwhonet.data.asc`, :mod:`rwhonet.data.blf`) hands
:class:`Kept` each part of the log as it parses it, and keeps only what :meth:`Kept.part`
gives: so the log's other frames take neither memory nor the decoder's time. What is left
out is still counted, each frame's bus and identifier noted (for the drive's notes and for
a message the map needs that the log lacks), and the buses numbered in the order first
seen among every frame, as they are when the whole log is kept.

So a raw CAN log's memory is not its file's size but that of the frames kept: a filter
bounds them (:attr:`FrameFilter.max_frames`, from ``data.max_file_mb`` and
:data:`KEPT_FRAME_BYTES`), and a log whose kept frames pass it is refused as they do
(:class:`TooManyFrames`), before the decode holds them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

ID_MASK = 0x1FFF_FFFF  # an extended identifier's 29 bits
# what a kept frame costs through the read and decode (``rwhonet.data.mdf4.read_mdf4``),
# at most: a log of the map's messages alone, 216,000 frames against 864,000, took 46
# (candump) and 123 (BLF) bytes a frame more at its peak (``benchmarks/bench_bus_log.py
# --other-fps 0``); 256 leaves room for FD frames' longer payloads
KEPT_FRAME_BYTES = 256
_LOW = (1 << 40) - 1


def frame_keys(channel: np.ndarray, ids: np.ndarray, extended: np.ndarray) -> np.ndarray:
    """Each frame's bus, identifier and whether it is extended as one number:
    ``bus << 40 | extended << 32 | identifier``."""
    return (
        (channel.astype(np.int64) << 40) | (extended.astype(np.int64) << 32) | ids.astype(np.int64)
    )


def key_id(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`frame_keys` taken apart: (bus, identifier, extended)."""
    return keys >> 40, keys & 0xFFFF_FFFF, (keys >> 32) & 1 != 0


def j1939_pgn(ids: np.ndarray) -> np.ndarray:
    """Each identifier's J1939 parameter group number, as asammdf's bus-logging decode
    reckons it for any frame (``MDF4._extract_can_logging``): the data page bits and PDU
    format, and the PDU specific where the format is 240 or more (PDU2: a group extension,
    not a destination); a standard identifier's is 0."""
    ids = ids.astype(np.int64) & ID_MASK
    shifted = ids >> 8
    base = shifted & 0x3FF00
    return np.where(((ids >> 16) & 0xFF) >= 240, base + (shifted & 0xFF), base)


@dataclass(frozen=True)
class FrameFilter:
    """The frames a decode needs: those whose identifier (and whether it is extended) is
    one of ``messages``', or whose J1939 parameter group is one of ``pgns``, on any bus.

    Attributes:
        messages: ``(identifier, extended)`` of each message kept.
        pgns: the parameter groups of the J1939 messages kept (which a decode matches by
            group and the frame's own source address, not by identifier).
        max_frames: the most data frames kept (None: no bound).
    """

    messages: frozenset[tuple[int, bool]]
    pgns: frozenset[int] = frozenset()
    max_frames: int | None = None

    @staticmethod
    def frames_for(max_mb: float) -> int:
        """The frames kept in ``max_mb`` MB of memory (``data.max_file_mb``), at
        :data:`KEPT_FRAME_BYTES` each."""
        return int(max_mb * 2**20 // KEPT_FRAME_BYTES)

    def bound(
        self, before: int, kept: np.ndarray, row: Callable[[int], int] = lambda i: i + 1
    ) -> int:
        """How many frames are kept with the part ``kept`` (a mask) after ``before``;
        :class:`TooManyFrames` where that passes :attr:`max_frames`, naming the frame that
        does by ``row`` (of its place in the part)."""
        total = before + int(np.count_nonzero(kept))
        if self.max_frames is not None and total > self.max_frames:
            raise TooManyFrames(
                self.max_frames, row(int(np.flatnonzero(kept)[self.max_frames - before]))
            )
        return total

    def mask(self, ids: np.ndarray, extended: np.ndarray) -> np.ndarray:
        """Which frames are of a kept message."""
        code = ids.astype(np.int64) | (extended.astype(np.int64) << 32)
        wanted = np.array(sorted(i | (int(x) << 32) for i, x in self.messages), np.int64)
        keep = np.isin(code, wanted)
        if self.pgns:
            keep |= np.isin(j1939_pgn(ids), np.array(sorted(self.pgns), np.int64))
        return keep


class TooManyFrames(Exception):
    """A log's kept frames passed :attr:`FrameFilter.max_frames`.

    Attributes:
        max_frames: the bound.
        row: the frame that passed it, as ``Frames.rows`` numbers it: its line in a candump
            or TRC log, its number among the log's messages in ASC and BLF.
    """

    def __init__(self, max_frames: int, row: int) -> None:
        super().__init__(f"more than {max_frames} frames kept, at row {row}")
        self.max_frames, self.row = max_frames, row


class Kept:
    """A log's messages kept part by part, in the log's order, by a :class:`FrameFilter`.

    Each part's messages go through :meth:`part`, which says which to keep: the data
    frames of the filter's messages, and every message that is no data frame (an error
    or remote frame, which the reader counts itself). The kept messages are numbered among
    all the log's (:attr:`numbers`), the data frames left out counted (:attr:`dropped`),
    and every data frame's bus (as the log gives it) and identifier noted.
    """

    def __init__(self, keep: FrameFilter) -> None:
        self.keep = keep
        self.messages = 0  # messages handed in so far
        self.dropped = 0
        self.kept = 0  # data frames kept so far
        self._numbers: list[np.ndarray] = []
        self._seen: list[np.ndarray] = []
        self._order: list[int] = []  # buses, in the order first seen among the data frames

    def part(
        self,
        ids: np.ndarray,
        extended: np.ndarray,
        bus: np.ndarray,
        not_data: np.ndarray | None = None,
        rows: np.ndarray | None = None,
    ) -> np.ndarray:
        """The messages of the next part to keep (their indices in it).

        Args:
            ids: each message's identifier (29 bits, no flags).
            extended: whether it is extended.
            bus: its bus, an integer as the log numbers it.
            not_data: which messages are no data frame (None: all are data frames).
            rows: each message's row where the reader numbers them otherwise than among
                the log's messages (a candump or TRC log's lines), to name a frame past
                :attr:`FrameFilter.max_frames` by.
        """
        bus = np.asarray(bus).astype(np.int64)
        data = np.ones(ids.size, bool) if not_data is None else ~not_data
        on, first = np.unique(bus[data], return_index=True)
        self._order += [b for b in on[np.argsort(first)].tolist() if b not in self._order]
        self._seen.append(np.unique(frame_keys(bus[data], ids[data], extended[data])))
        wanted = data & self.keep.mask(ids, extended)
        first = self.messages
        self.kept = self.keep.bound(
            self.kept, wanted, (lambda i: first + i + 1) if rows is None else rows.item
        )
        self.dropped += int(data.sum() - wanted.sum())
        at = np.flatnonzero(wanted if not_data is None else wanted | not_data)
        self._numbers.append(self.messages + at + 1)
        self.messages += ids.size
        return at

    @property
    def numbers(self) -> np.ndarray:
        """Each kept message's number among all the log's messages, 1-based."""
        return np.concatenate([*self._numbers, np.zeros(0, np.int64)])

    @property
    def buses(self) -> list[str]:
        """The buses' names (as the log numbers them), in the order first seen."""
        return [str(b) for b in self._order]

    def channel(self, bus: np.ndarray) -> np.ndarray:
        """Kept frames' buses as the log numbers them, numbered 1, 2, ... in the order
        first seen among every data frame."""
        return self._number(np.asarray(bus).astype(np.int64)).astype(np.uint8)

    def log_ids(self) -> np.ndarray:
        """Every data frame's bus (numbered as :meth:`channel` numbers it), identifier and
        whether it is extended, once each (:func:`frame_keys`)."""
        seen = np.unique(np.concatenate([*self._seen, np.zeros(0, np.int64)]))
        return np.unique((self._number(seen >> 40) << 40) | (seen & _LOW))

    def _number(self, bus: np.ndarray) -> np.ndarray:
        order = np.array(self._order, np.int64)
        rank = np.argsort(order)
        return rank[np.searchsorted(order, bus, sorter=rank)].astype(np.int64) + 1
