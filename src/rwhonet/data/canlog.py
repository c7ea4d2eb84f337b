"""A log of raw CAN frames as a bus tool writes it: SocketCAN's ``candump -l`` (``.log``),
Vector CANalyzer/CANoe's ASC and BLF, PEAK PCAN-View's TRC.

Such a log holds the bus as it went: each frame's time stamp, identifier and data bytes,
and nothing decoded. Its frames are laid out here as an ASAM MDF4 bus log (a
``CAN_DataFrame`` channel group, as a CANedge or python-can's MF4 writer records the
bus, :func:`bus_log`), so that the map's CAN databases (DBC, ARXML) decode them in
:mod:`rwhonet.data.mdf4` exactly as they decode a raw-frame MDF4 file: one decoder for
every log of raw frames.

**candump** (:func:`_candump`), the format SocketCAN's ``candump -l``/``-L`` and
python-can's ``CanutilsLogWriter`` write, one frame a line::

    (1436509052.249713) can0 0AA#1A2B3C4D5E6F7081
    (1436509052.250112) can1 18FEF100##3112233445566778899AABBCC

is parsed over the file's bytes at once (numpy), not a line at a time: a whole bus's
traffic (thousands of frames a second) for an hour is tens of millions of lines. It is
read 8 MB of lines at a time, so that its memory is a part's and that of the frames
kept: given a :class:`FrameFilter` (the messages the map's signals are in,
:func:`rwhonet.data.mdf4.can_log_groups`), each part's other frames are counted, their
IDs noted (``Frames.log_ids``), and left out as it is read.
Identifiers of 3 hex digits are standard, of 8 extended; ``##`` and a flags digit begin
a CAN FD frame's data. Error frames (the identifier's ``0x20000000`` flag), remote
frames (``#R``) and CAN XL frames (``###``) carry no signal and are passed over, counted;
so are lines that are no frame, counted with the first of them.

**BLF** (:func:`_blf`) is parsed over the file's objects at once by
:func:`rwhonet.data.blf.blf_frames`, and **ASC** (:func:`_asc`) over the file's lines at
once by :func:`rwhonet.data.asc.asc_frames`: python-can's readers' frames, bit for bit, at
several times their rates (an ASC of ``base dec``, or with a control character, still
goes through python-can; an ASC's text is read as UTF-8, else cp1252:
:func:`rwhonet.data.asc.encoding_of`). **TRC** (:func:`_trc`) is parsed over the file's
lines at once by :func:`rwhonet.data.trc.trc_frames`, in PEAK's format of each version
(1.0-2.1): python-can's frames where python-can reads the log, and the logs it refused
whole (a remote frame in 1.x, a 1.2 log) read. Error and remote frames are passed over
and counted in every one (``benchmarks/bench_streams.py`` gives the rates).

**The clock** is the log's own time stamps, as python-can and candump give them:
candump's and BLF's are the logging computer's clock (Unix seconds), TRC's its start time
plus each frame's offset, ASC's seconds since the measurement's start (python-can's
default). An ASC whose header says ``timestamps relative`` stamps each event with the
time since the event before it (Vector's ASC format), which python-can reads as if
absolute: its stamps are summed (:class:`_SummedStamps`, to the nanosecond the format
writes), every stamped event line counting, and python-can reads the sums. An ASC's
date line is that start on the logging computer's clock, local time without a zone:
with the signal map's ``local_zone`` (:func:`asc_start`) it puts the frames on UTC, Unix
seconds, which a receiver's log beside it can share; so does a TRC's start, which PEAK's
tools write on that clock too (:func:`_trc`; python-can reads it as UTC). A drive read
from one log keeps them as they are; its notes say which.
"""

from __future__ import annotations

import contextlib
import dataclasses
import mmap
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rwhonet.data.asc import STAMP, encoding_of, stamp_ns
from rwhonet.data.bytescan import HEX, after, before, floats_or_nan, texts
from rwhonet.data.compressed import without_suffix
from rwhonet.data.keptframes import (
    ID_MASK,
    KEPT_FRAME_BYTES,
    FrameFilter,
    Kept,
    TooManyFrames,
    frame_keys,
    j1939_pgn,
)
from rwhonet.data.texttime import LocalTimeUnclear, local_to_unix, unclear_start
from rwhonet.data.trc import FD_LENGTHS, MAX_BYTES, trc_frames
from rwhonet.errors import InputError, Problem

if TYPE_CHECKING:
    from rwhonet.data.asc import AscFrames
    from rwhonet.data.blf import BlfFrames

CANDUMP, PYTHON_CAN = ".log", (".asc", ".blf", ".trc")
CAN_LOG_SUFFIXES = (CANDUMP, *PYTHON_CAN)
SPLIT_CAN_LOG = "split the log into several (candump and loggers rotate theirs by size)"
ERROR_FLAG = 0x2000_0000  # SocketCAN's CAN_ERR_FLAG in an identifier


def is_can_log_name(name: str) -> bool:
    """Whether a file's name is a raw CAN log's (``bus.log``, ``drive.asc``, ``d.blf.gz``)."""
    return Path(without_suffix(name)).suffix.lower() in CAN_LOG_SUFFIXES


@dataclass(frozen=True)
class Frames:
    """A CAN log's data frames, in the log's order.

    Attributes:
        t_s: each frame's time stamp, s, on the log's clock.
        ids: its identifier (29 or 11 bits, without flags).
        extended: whether the identifier is extended (29 bits).
        length: its data bytes.
        data: its bytes, zero after ``length`` (a row of ``data.shape[1]`` bytes).
        channel: its bus, 1-based (the log's interfaces in the order first seen).
        buses: the interfaces' names (``can0``), or the channel numbers as the log has them.
        clock: what the time stamps count.
        rows: where each frame is in the log, 1-based: its line in a candump or TRC log,
            its number among the log's frames in ASC and BLF (as python-can, which gives
            no lines, numbers them).
        passed: what was passed over (error, remote, CAN XL frames; lines that are no
            frame), counted; empty when nothing was.
        local_start: the stamps count from a start the log gives only on the logging
            computer's local clock (an ASC log's date line), not put on UTC (no
            ``local_zone``): a clock no UTC stream can share.
        dropped: the log's data frames left out by a :class:`FrameFilter` (read, counted,
            not kept).
        log_ids: where a filter was given, every data frame's bus, identifier and
            whether it is extended, once each (:func:`~rwhonet.data.keptframes.frame_keys`;
            the bus numbered as ``channel`` numbers it), the frames left out
            included; None where every data frame is here.
    """

    t_s: np.ndarray
    ids: np.ndarray
    extended: np.ndarray
    length: np.ndarray
    data: np.ndarray
    channel: np.ndarray
    buses: list[str]
    clock: str
    rows: np.ndarray
    passed: str = ""
    local_start: bool = False
    dropped: int = 0
    log_ids: np.ndarray | None = None

    @property
    def in_log(self) -> int:
        """The log's data frames, those a filter left out included."""
        return int(self.t_s.size) + self.dropped

    def place(self, acq_name: str, comment: str, n: int) -> tuple[str, np.ndarray] | None:
        """The frames a decoded message's ``n`` samples came from, by the name asammdf
        gives its channel group (``CAN1 message ID=0x1A0 EXT=False``; ``comment``:
        ``CAN1 - message WheelSpeeds 0x1A0 EXT=False``; a J1939 message's, by parameter
        group and source address, in its comment alone: ``CAN1 ID=0xCFEBF0B WheelSpeeds
        PGN=0xFEBF SA=0xB``): ``(the message as messages name it, the frames' rows)``; None
        where the names say no message or the count differs."""
        if (group := _J1939_GROUP.fullmatch(comment.strip())) is not None:
            bus, ident, pgn, source = (int(group[k], 0) for k in ("bus", "id", "pgn", "sa"))
            on = (self.channel == bus) & ((self.ids & 0xFF) == source)
            at = np.flatnonzero(on & (j1939_pgn(self.ids) == pgn))
            name = f"{group['name']} 0x{ident:X}"
        elif (message := _message(acq_name)) is not None:
            bus, ident, ext = message
            at = np.flatnonzero(
                (self.channel == bus) & (self.ids == ident) & (self.extended == ext)
            )
            said = _MESSAGE_NAME.search(comment)
            name = f"{said[1]} 0x{ident:X}" if said else f"frames 0x{ident:X}"
        else:
            return None
        if at.size != n:
            return None
        return (name if len(self.buses) < 2 else f"{self.buses[bus - 1]} {name}"), self.rows[at]

    def bus_of(self, acq_name: str, comment: str = "") -> str | None:
        """The interface a decoded message's channel group came from (``can1``), by the
        names asammdf gives the group (:meth:`place`); None where they say none."""
        group = _J1939_GROUP.fullmatch(comment.strip())
        message = _message(acq_name)
        bus = int(group["bus"]) if group else None if message is None else message[0]
        return self.buses[bus - 1] if bus is not None and 0 < bus <= len(self.buses) else None


# how asammdf's extract_bus_logging names a decoded message's channel group
_MESSAGE = re.compile(r"CAN(\d+) message ID=0x([0-9A-Fa-f]+) EXT=(True|False)")
_MESSAGE_NAME = re.compile(r"message (\S+) 0x")
# and a J1939 message's, in the group's comment (its acquisition name: the source address)
_J1939_GROUP = re.compile(
    r"CAN(?P<bus>\d+) ID=(?P<id>0x[0-9A-Fa-f]+) (?P<name>\S+) "
    r"PGN=(?P<pgn>0x[0-9A-Fa-f]+) SA=(?P<sa>0x[0-9A-Fa-f]+)"
)


def _message(acq_name: str) -> tuple[int, int, bool] | None:
    """(bus, identifier, extended) of a decoded message's channel group, by its name."""
    match = _MESSAGE.fullmatch(acq_name.strip())
    return None if match is None else (int(match[1]), int(match[2], 16), match[3] == "True")


FRAME_ARRAYS = ("t_s", "ids", "extended", "length", "data", "channel", "rows")  # one a frame


def _taken(frames: Frames, at: np.ndarray, **changes) -> Frames:  # type: ignore[no-untyped-def]
    """The frames ``at`` of ``frames`` (and ``changes`` to its other fields)."""
    return dataclasses.replace(
        frames, **{name: getattr(frames, name)[at] for name in FRAME_ARRAYS}, **changes
    )


def _read(
    path: Path, file: str, suffix: str, local_zone: str | None, keep: FrameFilter | None
) -> Frames:
    """:func:`read_frames`' reader for the log's format."""
    if suffix == CANDUMP:
        frames = _candump(path, file, keep)
    elif suffix == ".blf":
        frames = _blf(path, file, keep, local_zone)
    elif suffix == ".asc" and (got := _asc(path, file, keep)) is not None:
        frames = got
    elif suffix == ".trc":
        frames = _trc(path, file, local_zone, keep)
    else:
        frames = _python_can(path, file, suffix, keep)
    return frames


def too_many(file: str, err: TooManyFrames) -> Problem:
    """The problem of a log whose frames of the map's messages pass the bound."""
    return Problem(
        file,
        err.row,
        None,
        f"at most {err.max_frames:,} frames of the messages the map's signals are in "
        f"(data.max_file_mb at {KEPT_FRAME_BYTES} bytes a frame kept)",
        "more: this row's frame is one too many",
        f"{SPLIT_CAN_LOG}, or raise data.max_file_mb on a machine with the memory",
    )


def short_passed(
    frames: Frames, need: np.ndarray, name_of: Callable[[int], str], file: str
) -> Frames:
    """``frames`` without those shorter than ``need`` bytes (their message's length in the
    CAN database), counted with what was passed over and with the frames left out.

    A frame shorter than its message (a line a logger cut short as it lost power, ``8 43
    EA`` of an ASC's eight bytes; a damaged candump line ``600#43EA``) would decode the
    signals past its end from zeros: a fix at latitude 0.006. cantools refuses such a
    frame by default (``Wrong data size``); asammdf decodes it. It is passed over here.

    Raises:
        InputError: every frame of a message is short (an ECU that sends it shorter than
            the database says), which would leave its signals missing for no said reason.
    """
    short = frames.length.astype(np.int64) < need
    if not short.any():
        return frames
    keys = frame_keys(frames.channel, frames.ids, frames.extended)
    every = [k for k in np.unique(keys[short]) if short[keys == k].all()]
    if every:
        raise InputError([_all_short(frames, keys, k, need, name_of, file) for k in every])
    n, first = int(short.sum()), int(np.flatnonzero(short)[0])
    said = (
        f"{n} frames shorter than their message in the CAN database, not decoded (first "
        f"at row {frames.rows[first]}: {name_of(first)}, {frames.length[first]} of "
        f"{need[first]} bytes)"
    )
    return _taken(
        frames,
        np.flatnonzero(~short),
        dropped=frames.dropped + n,
        passed=", ".join(p for p in (frames.passed, said) if p),
    )


def _all_short(
    frames: Frames,
    keys: np.ndarray,
    key: int,
    need: np.ndarray,
    name_of: Callable[[int], str],
    file: str,
) -> Problem:
    """The problem of a message every frame of which is shorter than the database says."""
    mine = np.flatnonzero(keys == key)
    at = int(mine[0])
    return Problem(
        file,
        int(frames.rows[at]),
        None,
        f"frames of {name_of(at)} of its {need[at]} bytes in the CAN database",
        f"every one of its {mine.size} frames shorter (this row's: {frames.length[at]} bytes)",
        "give the CAN database of the car's own bus (the message's length there), or the "
        "log as the logger wrote it",
    )


def read_frames(
    path: Path, file: str, local_zone: str | None = None, keep: FrameFilter | None = None
) -> Frames:
    """A CAN log's data frames: candump's by :func:`_candump`, BLF's by :func:`_blf`,
    ASC's by :func:`_asc` (python-can's where it leaves the log to it), TRC's by
    :func:`_trc`.

    Args:
        path: the log (its name's suffix says its format).
        file: how messages name it.
        local_zone: the logging computer's time zone (IANA): an ASC log's stamps are then
            put on UTC by its date line (:func:`asc_start`), a TRC's by its ``$STARTTIME``
            (:func:`_trc`); other logs keep their clocks.
        keep: the messages to keep (the others counted and left out, their IDs kept in
            ``log_ids``): each log is read a part at a time (candump's lines, ASC's and
            TRC's chunks, BLF's batches of objects, the batches of messages python-can
            yields where it reads the log itself) and each part's other frames left out
            as it is read, so its memory is that of a part and of the frames kept (at
            most ``keep.max_frames`` of them).

    Raises:
        InputError: no data frame in the log; more frames kept than ``keep.max_frames``;
            a log python-can cannot read (with the frames read before the damage); an ASC
            log with ``local_zone`` and no date line python-can reads; a TRC header PEAK's
            format has not.
    """
    suffix = path.suffix.lower()
    try:
        frames = _read(path, file, suffix, local_zone, keep)
    except TooManyFrames as err:
        raise InputError([too_many(file, err)]) from None
    if suffix == ".asc" and frames.t_s.size and not _counts_unix(frames.t_s):
        if local_zone is None:
            frames = dataclasses.replace(frames, local_start=True)
        else:
            start, said = asc_start(path, file, local_zone)
            frames = dataclasses.replace(frames, t_s=frames.t_s + start, clock=said)
    if not frames.in_log:
        example = {
            CANDUMP: "as candump -l writes them: (1436509052.249713) can0 0AA#1A2B3C4D",
        }.get(suffix, f"as {suffix.lstrip('.').upper()} holds them")
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"CAN data frames, {example}",
                    "none" + (f" ({frames.passed})" if frames.passed else ""),
                    "give the drive's CAN log, or leave the file out",
                )
            ]
        )
    return frames


_CHUNK_CELLS = 1 << 24  # hex digits turned into bytes at once (bounds the memory: 128 MB)


def _hex_values(buf: np.ndarray, start: np.ndarray, count: np.ndarray, width: int) -> np.ndarray:
    """The hex digits ``buf[start:start+count]`` of each line as a (lines, width) matrix
    of digit values, right-aligned, -1 where a character is no hex digit, 0 before."""
    at = start[:, None] + np.arange(width) - (width - count)[:, None]
    inside = at >= start[:, None]
    digits = HEX[buf[np.clip(at, 0, buf.size - 1)]]
    return np.where(inside, digits, 0)


@dataclass(frozen=True)
class _Lines:
    """A part of a candump log, its lines parsed (:func:`_candump_lines`): its data frames
    (``rows`` the lines in the log; ``buses`` the part's own interfaces, in the order first
    seen in it), what it passed over (counts by kind; damaged lines and lines that are no
    frame, each (count, first line))."""

    frames: Frames
    skipped: dict[str, int]
    damaged: tuple[int, int]
    not_frame: tuple[int, int]


_CANDUMP_PART_BYTES = 1 << 23  # a candump log read 8 MB of lines at a time


def _candump(path: Path, file: str, keep: FrameFilter | None = None) -> Frames:
    """A candump log's frames: its lines parsed at once a part of
    :data:`_CANDUMP_PART_BYTES` at a time (:func:`_candump_lines`), the parts' frames
    joined (their interfaces numbered in the order first seen in the log), each part's
    frames of messages ``keep`` leaves out dropped as it is read (see the module's
    docstring)."""
    names: list[str] = []
    parts: list[Frames] = []
    kept = None if keep is None else Kept(keep)
    skipped: dict[str, int] = {}
    damaged = not_frame = (0, 0)
    line0 = 0
    for data in _whole_lines(path, _CANDUMP_PART_BYTES):
        part = _candump_lines(data, line0)
        line0 += data.count(b"\n")
        frames, own = part.frames, part.frames.buses
        names += [n for n in own if n not in names]
        if own != names[: len(own)]:  # the part's numbers on the log's
            number = np.array([0] + [names.index(n) + 1 for n in own], np.uint8)
            frames = dataclasses.replace(frames, channel=number[frames.channel])
        for k, v in part.skipped.items():
            skipped[k] = skipped.get(k, 0) + v
        damaged, not_frame = _first(damaged, part.damaged), _first(not_frame, part.not_frame)
        if kept is not None:
            at = kept.part(frames.ids, frames.extended, frames.channel, rows=frames.rows)
            frames = frames if at.size == frames.t_s.size else _taken(frames, at)
        parts.append(frames)
    width = max((p.data.shape[1] for p in parts), default=8)
    passed = {k: v for k, v in skipped.items() if v}
    if damaged[0]:
        passed[f"lines damaged (first at line {damaged[1]})"] = damaged[0]
    if not_frame[0]:
        passed[f"lines that are no frame (first at line {not_frame[1]})"] = not_frame[0]
    t = _joined(parts, "t_s", np.float64)
    return Frames(
        t,
        _joined(parts, "ids", np.uint32),
        _joined(parts, "extended", bool),
        _joined(parts, "length", np.uint8),
        np.concatenate(
            [np.pad(p.data, ((0, 0), (0, width - p.data.shape[1]))) for p in parts]
            or [np.zeros((0, width), np.uint8)]
        ),
        _joined(parts, "channel", np.uint8),
        names,
        _clock("candump", t),
        _joined(parts, "rows", np.int64),
        ", ".join(f"{v} {k}" for k, v in passed.items()),
        **_left_out(kept),
    )


def _left_out(kept: Kept | None) -> dict:  # type: ignore[type-arg]
    """:class:`Frames`' fields of what a filter left out (none where there was none)."""
    return {} if kept is None else {"dropped": kept.dropped, "log_ids": kept.log_ids()}


def _joined(parts: list[Frames], name: str, dtype: type) -> np.ndarray:
    """The parts' arrays ``name`` one after the other."""
    return np.concatenate([getattr(p, name) for p in parts] or [np.zeros(0, dtype)])


def _first(seen: tuple[int, int], part: tuple[int, int]) -> tuple[int, int]:
    """(count, first line) of lines of a kind, over the parts read so far."""
    return (seen[0] + part[0], seen[1] if seen[0] else part[1])


def _whole_lines(path: Path, size: int) -> Iterator[bytes]:
    """A file's bytes in parts of about ``size`` bytes, each ending at a line's end (the
    last where the file ends); a line longer than ``size`` makes its part longer."""
    carry = b""
    with open(path, "rb") as f:
        while block := f.read(size):
            data = carry + block
            cut = data.rfind(b"\n") + 1
            carry, data = data[cut:], data[:cut]
            if data:
                yield data
    if carry:
        yield carry


def _candump_lines(data: bytes, line0: int) -> _Lines:
    """A part of a candump log (whole lines, the first the log's line ``line0 + 1``), every
    line parsed at once."""
    buf = np.frombuffer(data + b"\n", np.uint8)
    size = buf.size
    ends = np.flatnonzero(buf == ord("\n"))
    starts = np.concatenate([[0], ends[:-1] + 1])
    end = ends.copy()  # without trailing spaces and CR
    space = np.zeros(256, bool)
    space[np.frombuffer(b" \t\r", np.uint8)] = True
    while (step := space[buf[np.maximum(end - 1, 0)]] & (end > starts)).any():
        end = end - step
    first = starts.copy()  # without leading spaces
    while (step := space[buf[np.minimum(first, size - 1)]] & (first < end)).any():
        first = first + step
    blank = first >= end
    opened = ~blank & (buf[np.minimum(first, size - 1)] == ord("("))
    close = after(np.flatnonzero(buf == ord(")")), first, size)
    hashes = np.flatnonzero(buf == ord("#"))
    hash_at = after(hashes, close, size)
    spaces = np.flatnonzero((buf == ord(" ")) | (buf == ord("\t")))
    iface_at = after(spaces, close, size)  # the space after ")"
    id_start = before(spaces, hash_at) + 1  # after the last space before "#"
    # "(stamp) iface frame": one space each side of the interface's name (candump and
    # python-can write no other); a name with a space in it is a damaged line
    between = np.searchsorted(spaces, hash_at) - np.searchsorted(spaces, close)
    shaped = opened & (close < end) & (hash_at < end) & (iface_at < id_start - 1) & (between == 2)
    comment = ~blank & (buf[np.minimum(first, size - 1)] == ord("#"))
    line = np.flatnonzero(shaped)
    not_frame = np.flatnonzero(~shaped & ~blank & ~comment) + 1
    # time stamps: the text between the brackets, converted in one go
    t = _stamps(buf, first[line] + 1, close[line])
    id_len = hash_at[line] - id_start[line]
    id_digits = _hex_values(buf, id_start[line], id_len, 8)
    ids = (id_digits.astype(np.int64) << (4 * np.arange(7, -1, -1))).sum(axis=1)
    behind = np.minimum(hash_at[line] + 1, size - 1)
    fd = buf[behind] == ord("#")
    xl = fd & (buf[np.minimum(behind + 1, size - 1)] == ord("#"))
    remote = buf[behind] == ord("R")
    data_start = np.where(fd, hash_at[line] + 3, hash_at[line] + 1)  # "##" and a flags digit
    # the data end at the line's end, a space (newer can-utils and python-can write the
    # direction after it: " R", " T") or a "_" (a classic frame's DLC above 8 after it)
    stops = np.flatnonzero((buf == ord("_")) | (buf == ord(" ")) | (buf == ord("\t")))
    data_end = np.minimum(after(stops, data_start, size), end[line])
    n_chars = data_end - data_start
    flags = HEX[buf[np.minimum(hash_at[line] + 2, size - 1)]]  # an FD frame's flags digit
    good = (
        np.isfinite(t)
        & ((id_len == 3) | (id_len == 8))
        & (~fd | xl | (flags >= 0))
        & (id_digits >= 0).all(axis=1)
        & (
            remote  # "#R", or "#R" and its length code: no data
            | ((n_chars % 2 == 0) & (n_chars >= 0) & (n_chars <= 2 * np.where(fd, MAX_BYTES, 8)))
        )
    )
    error = good & (ids & ERROR_FLAG != 0) & (id_len == 8)
    skipped = {
        "error frames": int(error.sum()),
        "remote frames": int((good & remote & ~error).sum()),
        "CAN XL frames": int((good & xl & ~error).sum()),
    }
    keep = good & ~error & ~remote & ~xl
    lengths = n_chars // 2
    odd_fd = keep & fd & ~np.isin(lengths, FD_LENGTHS)  # an FD frame's bytes are one of these
    keep &= ~odd_fd
    damaged = line[~good | odd_fd] + 1
    kept = np.flatnonzero(keep)
    width = 8 if not fd[kept].any() else MAX_BYTES
    payload = np.zeros((kept.size, width), np.uint8)
    bad_data = np.zeros(kept.size, bool)
    chunk = max(1, _CHUNK_CELLS // (2 * width))  # lines a chunk: 1 M classic, 131 k FD
    for a in range(0, kept.size, chunk):
        k = kept[a : a + chunk]
        count = n_chars[k]
        at = data_start[k][:, None] + np.arange(2 * width)
        inside = np.arange(2 * width) < count[:, None]
        digits = np.where(inside, HEX[buf[np.minimum(at, size - 1)]], 0)
        bad_data[a : a + k.size] = (digits < 0).any(axis=1)
        payload[a : a + k.size] = (digits[:, 0::2] * 16 + digits[:, 1::2]).astype(np.uint8)
    if bad_data.any():
        damaged = np.union1d(damaged, line[kept[bad_data]] + 1)
        kept, payload = kept[~bad_data], payload[~bad_data]
    names, channel = _interfaces(buf, iface_at[line[kept]] + 1, id_start[line[kept]] - 1)
    frames = Frames(
        t[kept],
        (ids[kept] & ID_MASK).astype(np.uint32),
        id_len[kept] == 8,
        lengths[kept].astype(np.uint8),
        payload,
        channel,
        names,
        "",
        line0 + line[kept] + 1,
    )
    return _Lines(
        frames,
        skipped,
        (int(damaged.size), line0 + int(damaged[0]) if damaged.size else 0),
        (int(not_frame.size), line0 + int(not_frame[0]) if not_frame.size else 0),
    )


def _interfaces(
    buf: np.ndarray, start: np.ndarray, end: np.ndarray
) -> tuple[list[str], np.ndarray]:
    """Each frame's interface (``buf[start:end]``, ``can0``) as a bus number, 1-based in
    the order first seen, and the interfaces' names. Names of up to 8 bytes (every
    SocketCAN name we know) are compared as one 64-bit number each, not as strings."""
    length = end - start
    if not length.size:
        return [], np.zeros(0, np.uint8)
    if int(length.max()) > 8:
        keys = texts(buf, start, end)
    else:
        at = start[:, None] + np.arange(8)
        chars = np.where(np.arange(8) < length[:, None], buf[np.minimum(at, buf.size - 1)], 0)
        keys = np.ascontiguousarray(chars.astype(np.uint8)).view(np.uint64).ravel()
    if (keys == keys[0]).all():  # one bus: the usual log
        first = np.zeros(1, np.int64)
        channel = np.ones(keys.size, np.uint8)
    else:
        _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        order = np.argsort(first)
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        channel = (rank[inverse.ravel()] + 1).astype(np.uint8)
        first = first[order]
    names = [bytes(buf[start[i] : end[i]]).decode("ascii", "replace") for i in first.tolist()]
    return names, channel


def _stamps(buf: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The time stamps ``buf[start:end]`` of each line as floats, NaN where one is none.

    candump writes every stamp as ``%010u.%06u`` (python-can's writer ``%.6f``): where all
    have one length and their point in one place, the digits are read as one integer and
    divided by the power of ten after the point. Both are exact in float64 (Unix
    microseconds stay below 2**53 until the year 2255), so the one division rounds as
    ``float()`` does: the same bits, without a string a line. Other stamps go through
    ``float()``.
    """
    length = end - start
    if not length.size:
        return np.zeros(0)
    width = int(length[0])
    if 3 <= width <= 17 and (length == width).all():
        chars = buf[start[:, None] + np.arange(width)]
        point = chars[0] == ord(".")
        at = np.flatnonzero(point)
        if at.size == 1 and (chars[:, at[0]] == ord(".")).all():
            digits = np.delete(chars, at[0], axis=1).astype(np.int64) - ord("0")
            if ((digits >= 0) & (digits <= 9)).all():
                powers = 10 ** np.arange(width - 2, -1, -1, dtype=np.int64)
                whole = digits @ powers
                if int(whole.max()) < 2**53:  # exact in float64
                    return whole / 10.0 ** (width - 1 - int(at[0]))
    return floats_or_nan(texts(buf, start, end))


PYTHON_CAN_BATCH = 100_000  # python-can's messages held as Python objects at once


def _python_can(path: Path, file: str, suffix: str, keep: FrameFilter | None = None) -> Frames:
    """An ASC, BLF or TRC log's data frames, read by python-can a frame at a time (the
    pipeline's path for an ASC :func:`_asc` leaves to it; the tests' reference for BLF,
    ASC and TRC). The messages are held as Python objects :data:`PYTHON_CAN_BATCH` at a
    time, each batch made arrays and, with ``keep``, its other frames left out
    (:class:`Kept`) before the next is read: a whole bus's ASC that python-can reads
    (``base dec``, a stray control byte) takes the memory of a batch and of the frames
    kept, not of every message."""
    import can
    from can.io.asc import ASCReader
    from can.io.trc import TRCReader

    kept = None if keep is None else Kept(keep)
    batch = _Batch()
    parts: list[_Batch] = []
    codes: dict[str, int] = {}  # each bus's name -> its number, in the order first seen
    skipped = {"error frames": 0, "remote frames": 0}
    kind = suffix.lstrip(".").upper()
    relative = False
    read = 0  # data frames read
    try:
        if suffix == ".asc":  # read in the encoding the fast reader takes (encoding_of)
            encoding = file_encoding(path)
            relative = asc_header(path, encoding).relative
            opened = _SummedStamps(path, encoding) if relative else open(path, encoding=encoding)
            reader = ASCReader(opened)
        elif suffix == ".trc":  # a text log too: UTF-8, else cp1252 (PCAN-View on Windows)
            reader = TRCReader(open(path, encoding=file_encoding(path)))
        else:
            reader = can.LogReader(path)
        with reader:
            for row, msg in enumerate(reader, 1):
                if msg.is_error_frame:
                    skipped["error frames"] += 1
                    continue
                if msg.is_remote_frame:
                    skipped["remote frames"] += 1
                    continue
                name = str(msg.channel) if msg.channel is not None else ""
                batch.add(msg, row, codes.setdefault(name, len(codes)))
                read += 1
                if len(batch.t) >= PYTHON_CAN_BATCH:
                    parts.append(batch.arrays(kept))
                    batch = _Batch()
    except Exception as err:  # python-can's readers raise what their parsers raise
        raise _unreadable(file, kind, err, read) from None
    parts.append(batch.arrays(kept))
    width = max(p.data.shape[1] for p in parts)
    code = np.concatenate([p.code for p in parts])
    t = np.concatenate([p.t for p in parts])
    return Frames(
        t,
        np.concatenate([p.ids for p in parts]) & np.uint32(ID_MASK),
        np.concatenate([p.ext for p in parts]),
        np.concatenate([p.lengths for p in parts]).astype(np.uint8),
        np.concatenate([np.pad(p.data, ((0, 0), (0, width - p.data.shape[1]))) for p in parts]),
        (code + 1).astype(np.uint8) if kept is None else kept.channel(code),
        list(codes),  # first seen among every data frame: the codes' order
        _clock(kind, t) + (", each event's time since the one before, summed" if relative else ""),
        np.concatenate([p.rows for p in parts]),
        ", ".join(f"{v} {k}" for k, v in skipped.items() if v),
        **_left_out(kept),
    )


@dataclass
class _Batch:
    """python-can's data frames as it yields them (lists), then as arrays (:meth:`arrays`)."""

    t: Any = dataclasses.field(default_factory=list)
    ids: Any = dataclasses.field(default_factory=list)
    ext: Any = dataclasses.field(default_factory=list)
    payloads: Any = dataclasses.field(default_factory=list)
    code: Any = dataclasses.field(default_factory=list)
    rows: Any = dataclasses.field(default_factory=list)
    lengths: Any = None
    data: Any = None

    def add(self, msg: Any, row: int, code: int) -> None:
        """A data frame, its number among the log's messages and its bus's number."""
        self.t.append(msg.timestamp)
        self.rows.append(row)
        self.ids.append(msg.arbitration_id & ID_MASK)  # python-can takes any int
        self.ext.append(msg.is_extended_id)
        self.payloads.append(bytes(msg.data))
        self.code.append(code)

    def arrays(self, kept: Kept | None) -> _Batch:
        """The batch as arrays, the frames ``kept`` leaves out left out."""
        ids = np.asarray(self.ids, np.int64)
        ext = np.asarray(self.ext, bool)
        code = np.asarray(self.code, np.int64)
        at = np.arange(ids.size) if kept is None else kept.part(ids, ext, code)
        payloads = [self.payloads[i] for i in at.tolist()]
        lengths = np.array([len(x) for x in payloads], np.int64)
        width = 8 if lengths.max(initial=0) <= 8 else MAX_BYTES
        data = np.zeros((len(payloads), width), np.uint8)
        if payloads:
            flat = np.frombuffer(b"".join(payloads), np.uint8)
            each = np.repeat(np.arange(len(payloads)), lengths)  # each byte's frame
            cols = np.arange(flat.size) - np.repeat(np.cumsum(lengths) - lengths, lengths)
            data[each, cols] = flat
        return _Batch(
            np.asarray(self.t, np.float64)[at],
            ids[at].astype(np.uint32),
            ext[at],
            None,
            code[at],
            np.asarray(self.rows, np.int64)[at],
            lengths,
            data,
        )


def _unreadable(file: str, kind: str, err: BaseException, frames: int | None) -> InputError:
    """A log python-can's reader (or ours, reading as it does) stops in: its error, and
    the data frames read before it."""
    read = f"after {frames} frame(s)" if frames else "before any frame"
    return InputError(
        [
            Problem.unreadable(
                file,
                f"{'an' if kind == 'ASC' else 'a'} {kind} CAN log python-can reads",
                err,
                f"export the log again from the bus tool (it failed {read})",
            )
        ]
    )


def _buses(chans: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Each frame's channel (python-can's, as text) as a bus number, 1-based in the order
    first seen, and the buses' names in that order."""
    if not chans.size:
        return np.zeros(0, np.uint8), []
    buses, first_at, channel = np.unique(chans, True, True)
    order = np.argsort(first_at)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return (rank[channel.ravel()] + 1).astype(np.uint8), [str(b) for b in buses[order]]


def _blf(
    path: Path, file: str, keep: FrameFilter | None = None, local_zone: str | None = None
) -> Frames:
    """A BLF log's data frames, the frames python-can's reader gives, parsed a batch of
    objects at a time (:func:`rwhonet.data.blf.blf_frames`), the header's start read as
    UTC, or in ``local_zone`` (the clock note then says it)."""
    from rwhonet.data.blf import CAN_MSG_EXT, BlfError, blf_frames

    kept = None if keep is None else Kept(keep)
    cut: list[str] = []
    try:
        with _mapped(path) as raw:
            got = blf_frames(raw, kept, cut, local_zone)
    except BlfError as err:
        raise _unreadable(file, "BLF", err, err.data_frames) from None
    except LocalTimeUnclear as err:
        raise InputError([unclear_start(file, None, "start time", err)]) from None
    extended = (got.ids & CAN_MSG_EXT) != 0
    said = "" if local_zone is None else f", its header's start in {local_zone}"
    frames = _yielded("BLF", got, got.ids & ID_MASK, extended, said, kept)
    if not cut:
        return frames
    return dataclasses.replace(frames, passed=", ".join(p for p in (frames.passed, *cut) if p))


def _yielded(
    kind: str,
    got: BlfFrames | AscFrames,
    ids: np.ndarray,
    extended: np.ndarray,
    said: str = "",
    kept: Kept | None = None,
) -> Frames:
    """The data frames among the messages python-can's reader yields for a log, given as
    arrays (``got``), with their identifiers without flags (``ids``) and whether each is
    extended; error and remote frames passed over and counted, the frames numbered among
    all the messages; ``said`` is added to the clock's words. ``kept``: ``got`` holds the
    messages it kept (numbered among all the log's there), not all."""
    keep = ~got.error & ~got.remote
    skipped = {
        "error frames": int(got.error.sum()),
        "remote frames": int((got.remote & ~got.error).sum()),
    }
    lengths = got.length[keep]
    width = 8 if lengths.max(initial=0) <= 8 else MAX_BYTES
    t = got.t_s[keep]
    if kept is None:
        bus, buses = _buses(got.channel[keep])
        rows = np.flatnonzero(keep).astype(np.int64) + 1
    else:
        bus, buses, rows = kept.channel(got.channel[keep]), kept.buses, kept.numbers[keep]
    return Frames(
        t,
        ids[keep].astype(np.uint32),
        extended[keep],
        lengths.astype(np.uint8),
        np.ascontiguousarray(got.data[keep][:, :width]),
        bus,
        buses,
        _clock(kind, t) + said,
        rows,
        ", ".join(f"{v} {k}" for k, v in skipped.items() if v),
        **_left_out(kept),
    )


def _asc(path: Path, file: str, keep: FrameFilter | None = None) -> Frames | None:
    """An ASC log's data frames, the frames python-can's reader gives, parsed at once
    (:func:`rwhonet.data.asc.asc_frames`); None where the log is one python-can reads
    itself (``base dec``, a control character: :mod:`rwhonet.data.asc` says which)."""
    from rwhonet.data.asc import AscError, asc_frames

    kept = None if keep is None else Kept(keep)
    try:
        with open(path, "rb") as raw:  # read a part at a time
            encoding = encoding_of(raw)
            relative = asc_header(path, encoding).relative
            got = asc_frames(raw, relative, encoding, kept)
    except AscError as err:
        raise _unreadable(file, "ASC", err.cause, err.data_frames) from None
    if got is None:
        return None
    said = ", each event's time since the one before, summed" if relative else ""
    return _yielded("ASC", got, got.ids & ID_MASK, got.extended, said, kept)


def _trc(
    path: Path, file: str, local_zone: str | None = None, keep: FrameFilter | None = None
) -> Frames:
    """A TRC log's data frames, parsed at once in PEAK's format of its version
    (:func:`rwhonet.data.trc.trc_frames`): python-can's where it reads the log.

    PEAK's tools write ``$STARTTIME`` on the logging computer's clock, local time without
    a zone (a Windows date; the header's ``Start time`` comment beside it prints the same
    time). python-can reads it as UTC, and so do the frames here unless the signal map
    gives ``local_zone``, which puts the start on UTC; without it a log of PEAK's keeps
    python-can's reading, marked a local clock (a refusal of a receiver's log beside it
    then says to give ``local_zone``). python-can's own writer's start is UTC, as its
    header says, and is kept. A 1.0 log (no start) keeps its offsets; with ``local_zone``
    it is refused, as an ASC without a date line is.

    Raises:
        InputError: ``local_zone`` given and the log has no ``$STARTTIME``.
    """
    from datetime import UTC

    kept = None if keep is None else Kept(keep)
    with _mapped(path) as raw:
        got = trc_frames(raw, file, kept)
    bus, buses = (
        _buses(got.bus.astype(str)) if kept is None else (kept.channel(got.bus), kept.buses)
    )
    width = MAX_BYTES if got.length.max(initial=0) > 8 else 8
    t, clock = got.t_s, _clock("TRC", got.t_s) + f", TRC {got.version}"
    local = got.start_wall is None or not got.start_utc
    if got.start_wall is None and local_zone is not None and got.t_s.size:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    "$STARTTIME",
                    "the measurement's start, which the signal map's local_zone puts on "
                    "UTC (PEAK's TRC 1.1 and later write it: ;$STARTTIME=45930.5)",
                    f"none (a TRC {got.version} log: its frames' offsets only)",
                    "export the log again as TRC 2.1 (PCAN-View, PEAK-Converter), or leave "
                    "local_zone out of the map (the frames then keep their offsets)",
                )
            ]
        )
    if got.start_wall is not None and not got.start_utc:
        if local_zone is None:
            clock += ", its $STARTTIME the logging computer's local clock, read as UTC"
        else:
            wall = got.start_wall
            try:
                start = local_to_unix(wall, local_zone)
            except LocalTimeUnclear as err:
                raise InputError([unclear_start(file, None, "$STARTTIME", err)]) from None
            t = got.offset_s + start
            local = False
            shift = (start - wall.replace(tzinfo=UTC).timestamp()) / 3600.0
            clock = (
                f"the TRC log's frame time stamps: its $STARTTIME ({wall.isoformat()} in "
                f"{local_zone}, UTC{-shift:+g} h) plus each frame's offset: Unix time, s, "
                f"TRC {got.version}"
            )
    return Frames(
        t,
        (got.ids & ID_MASK).astype(np.uint32),
        got.extended,
        got.length.astype(np.uint8),
        np.ascontiguousarray(got.data[:, :width]),
        bus,
        buses,
        clock,
        got.rows,
        ", ".join(f"{v} {k}" for k, v in got.passed.items()),
        local,
        **_left_out(kept),
    )


@contextlib.contextmanager
def _mapped(path: Path) -> Iterator[bytes | mmap.mmap]:
    """A file's bytes mapped in memory (read as needed, not held); an empty file's ``b""``."""
    if path.stat().st_size == 0:
        yield b""
        return
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as raw:
        yield raw


def file_encoding(path: Path) -> str:
    """A text log's encoding (:func:`rwhonet.data.asc.encoding_of`), its bytes read a part
    at a time, not held whole."""
    with open(path, "rb") as raw:
        return encoding_of(raw)


def asc_start(path: Path, file: str, zone: str) -> tuple[float, str]:
    """An ASC log's measurement start in Unix seconds, by its date line
    (``date Fri Dec 5 10:15:30.123 am 2026``: the logging computer's clock, local time)
    read as python-can reads it, in ``zone``; and the clock as the drive's notes say it.

    Raises:
        InputError: no date line before the first frame, or one python-can cannot read.
    """
    from datetime import datetime

    from can.io.asc import ASCReader

    head = asc_header(path)
    line, at = head.date, head.date_row
    wall = None
    if line is not None:
        try:  # python-can's reading (its month names, 12 and 24 h) gives the machine's epoch;
            # back to the wall clock as written (exact but in the machine's own DST gap)
            wall = datetime.fromtimestamp(ASCReader._datetime_to_timestamp(line))
        except (ValueError, OverflowError, OSError):
            wall = None
    if wall is None:
        raise InputError(
            [
                Problem(
                    file,
                    at,
                    None,
                    "a date line before the first frame, as CANalyzer and CANoe write it "
                    "(date Fri Dec 5 10:15:30.123 am 2026): the measurement's start, which "
                    "the signal map's local_zone puts on UTC",
                    f"{line!r}, which python-can cannot read" if line else "none",
                    "give the log as the bus tool wrote it, or leave local_zone out of the "
                    "map (the frames then keep seconds since the measurement's start)",
                )
            ]
        )
    try:
        start = local_to_unix(wall, zone)
    except LocalTimeUnclear as err:
        raise InputError([unclear_start(file, at, None, err)]) from None
    said = (
        f"the ASC log's frame time stamps, s since the measurement's start, plus its date "
        f"line ({wall.isoformat()} in {zone}): Unix time, s"
    )
    return start, said


# an ASC log's header lines (python-can's ASCReader takes the same)
_ASC_DATE = re.compile(r"date\s+\w+\s+(?P<when>.+)", re.IGNORECASE)
_ASC_BASE = re.compile(r"base\s+(hex|dec)\s+timestamps\s+(?P<stamps>absolute|relative)", re.I)
_ASC_HEADER = re.compile(r"(date\s|base\s|//|no\s+internal|internal\s|$)", re.IGNORECASE)


@dataclass(frozen=True)
class AscHeader:
    """What an ASC log's header says (:func:`asc_header`)."""

    date: str | None  # the date line's date, as written (None: no date line)
    date_row: int | None  # its line, 1-based
    relative: bool  # ``timestamps relative``: each event stamped since the one before


def asc_header(path: Path, encoding: str | None = None) -> AscHeader:
    """The header lines of an ASC log before its first event, as python-can's ASCReader
    reads them, in its text ``encoding`` (None: :func:`rwhonet.data.asc.encoding_of` it)."""
    date, row, relative = None, None, False
    encoding = encoding or file_encoding(path)
    with open(path, encoding=encoding) as f:
        for at, text in enumerate(f, 1):
            line = text.strip()
            if (match := _ASC_DATE.match(line)) is not None and date is None:
                date, row = match["when"], at
            elif (match := _ASC_BASE.match(line)) is not None:
                relative = match["stamps"].lower() == "relative"
            elif _ASC_HEADER.match(line) is None:  # the first event: the header is over
                break
    return AscHeader(date, row, relative)


class _SummedStamps:
    """An ASC log of relative time stamps (each event's time since the event before it)
    read line by line as one of absolute stamps: each event line's stamp replaced by the
    sum of the stamps so far, in integer nanoseconds (no float drift over millions of
    events), for python-can's ``ASCReader`` to read. Lines without a stamp (the header,
    trigger blocks, comments) pass as they are."""

    def __init__(self, path: Path, encoding: str) -> None:
        self._file = open(path, encoding=encoding)  # closed by the reader (close)
        self._ns = 0

    # python-can takes an object with ``read`` and ``write`` as an opened file
    read = write = None

    def __iter__(self) -> _SummedStamps:
        return self

    def __next__(self) -> str:
        line = next(self._file)
        match = STAMP.fullmatch(line)
        if match is None:
            return line
        self._ns += stamp_ns(match)
        seconds, ns = divmod(self._ns, 1_000_000_000)
        return f"{match['lead']}{seconds}.{ns:09d}{match['rest']}"

    def close(self) -> None:
        self._file.close()


def _counts_unix(t_s: np.ndarray) -> bool:
    """Whether a log's time stamps are Unix seconds (its first in 2000-2100), not seconds
    since its measurement's start."""
    return bool(t_s.size) and 946_684_800.0 <= float(t_s[0]) < 4_102_444_800.0


def _clock(kind: str, t_s: np.ndarray) -> str:
    """What a log's time stamps count, as the drive's notes say it."""
    counts = "Unix time, s" if _counts_unix(t_s) else "s since the measurement's start"
    return f"the {kind} log's frame time stamps ({counts})"


# one classic frame of an ASAM MDF4 bus log's CAN_DataFrame channel group, as python-can's
# MF4 writer and a CANedge lay it out (an FD log's DataBytes are 64 wide: bus_log)
FRAME_DTYPE = np.dtype(
    [
        ("CAN_DataFrame.BusChannel", "<u1"),
        ("CAN_DataFrame.ID", "<u4"),
        ("CAN_DataFrame.IDE", "<u1"),
        ("CAN_DataFrame.DLC", "<u1"),
        ("CAN_DataFrame.DataLength", "<u1"),
        ("CAN_DataFrame.DataBytes", "(8,)u1"),
        ("CAN_DataFrame.Dir", "<u1"),
    ]
)


def bus_log(frames: Frames):  # type: ignore[no-untyped-def]
    """The frames as an in-memory ASAM MDF4 bus log (a ``CAN_DataFrame`` channel group, as
    python-can's MF4 writer lays it out), for ``MDF.extract_bus_logging`` to decode; its
    master time is the frames' stamps as logged (float64 holds a Unix time in s to 0.24 µs)."""
    from asammdf import MDF, Signal
    from asammdf.blocks.v4_blocks import SourceInformation
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS

    width = frames.data.shape[1]
    dtype = np.dtype(
        [
            (n, f"({width},)u1") if n.endswith("DataBytes") else (n, FRAME_DTYPE.fields[n][0])
            for n in FRAME_DTYPE.names
        ]
    )
    rows = np.zeros(frames.t_s.size, dtype)
    rows["CAN_DataFrame.BusChannel"] = frames.channel
    rows["CAN_DataFrame.ID"] = frames.ids
    rows["CAN_DataFrame.IDE"] = frames.extended
    lengths = frames.length.astype(np.int64)
    rows["CAN_DataFrame.DLC"] = np.where(
        lengths <= 8, lengths, np.searchsorted(FD_LENGTHS, lengths)
    )
    rows["CAN_DataFrame.DataLength"] = frames.length
    rows["CAN_DataFrame.DataBytes"] = frames.data
    mdf = MDF(version="4.10")
    source = SourceInformation(source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)
    mdf.append(Signal(rows, frames.t_s, name="CAN_DataFrame", source=source))
    return mdf
