"""ASAM MDF4 files (what Vector, ETAS and CANedge loggers write), decoded by ``asammdf``.

A signal map (:mod:`rwhonet.data.signalmap`) names the MDF4 signal of each
canonical quantity and its unit; the signals' physical values (the file's own
conversions applied) and time stamps come from ``asammdf.MDF.get``, so no byte of
the format is parsed here. Signals of one channel group share their time stamps
and form one stream. The clock is the file's master time: seconds since the
measurement's start. A log of raw CAN frames (bus logging: a CANedge's, a Vector
logger's) is decoded with the map's CAN databases (DBC, ARXML) by ``asammdf``'s
``extract_bus_logging`` first (:func:`_decoded`); its signals are then named as the DBC
names them (``WhlSpd_FL``, or ``WheelSpeeds.WhlSpd_FL`` where two messages share a name).
A ROS 1 bag (``.bag``) or a ROS 2 bag's folder given to this reader is read by
:mod:`rwhonet.data.rosbag`, its signals its topics' fields (``/gps/fix.latitude``); with the
map's CAN databases, its topics of raw CAN frames are decoded as a bus tool's log
(:func:`_bag_and_bus`).
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet.config import ColumnSpec
from rwhonet.data.canlog import (
    Frames,
    bus_log,
    is_can_log_name,
    read_frames,
    short_passed,
    too_many,
)
from rwhonet.data.columnmap import scaled
from rwhonet.data.compressed import without_suffix
from rwhonet.data.headers import unit_name
from rwhonet.data.keptframes import FrameFilter, TooManyFrames, frame_keys, j1939_pgn, key_id
from rwhonet.data.mdfframes import frame_groups, mdf_frames
from rwhonet.data.rosbag import is_rosbag2_folder, is_rosbag_name
from rwhonet.data.signalmap import (
    Group,
    build_streams,
    check_signal_map,
    fix_status_unit,
    mapped_unit_name,
    pulse_units,
    to_si,
)
from rwhonet.data.streams import DriveStreams
from rwhonet.data.texttime import LocalTimeUnclear, local_to_unix, unclear_start
from rwhonet.errors import InputError, Problem

CLOCK = "the MDF4 file's master time (s since the measurement start)"
# CAN databases: each a file decoding every bus, or (file, bus) decoding that bus alone
Databases = Sequence[str | tuple[str, str | None]]
MDF_SUFFIXES = (".mf4", ".mdf")
# A CANedge's own packing of its MDF4 log files (CSS Electronics' suffixes), which asammdf
# does not read: only the maker's converters unpack them.
CANEDGE_PACKED = {".mfc": "compressed", ".mfe": "encrypted", ".mfm": "compressed and encrypted"}
FLAG_HD_LOCAL_TIME = 1  # MDF4's HDBLOCK time flag: the start is local time, not UTC


def read_mdf4(
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str = "the signal map",
    display: str | None = None,
    dbc: Databases = (),
    local_zone: str | None = None,
    max_mb: float | None = None,
) -> DriveStreams:
    """Read a drive's signals from an MDF4 file into streams for ``resample``.

    Args:
        path: the MDF4 file (``.mf4``; MDF 3 files too, as ``asammdf`` reads them).
        signal_map: key -> signal name and unit (:func:`check_signal_map`; no ``t``).
        radius_m: the car's nominal tyre radius, for wheel speeds logged in m/s or km/h.
        name: how messages name the map (``data.signal_maps.<name>.signals``, a map file).
        display: how the file is named in error reports (default: ``path`` as given).
        dbc: the CAN databases that decode the file's raw CAN frames, each a file (for
            every bus) or ``(file, bus)`` (:attr:`SignalMapSpec.dbc_buses`; none: its signals
            are decoded already).
        local_zone: the logger's time zone (:attr:`SignalMapSpec.local_zone`), for a raw
            CAN log whose clock is local time (an ASC log's date line).
        max_mb: the memory a raw CAN log may take (``data.max_file_mb``; None: no bound;
            :func:`can_log_groups`).

    Returns:
        The drive's streams, one per channel group used.

    Raises:
        ConfigError: the signal map is invalid.
        InputError: the file cannot be decoded, a CAN database is missing, unreadable or
            decodes none of its frames, a mapped signal is missing or in several groups,
            its unit contradicts the map, or its samples are not numbers; every problem is
            listed.
    """
    check_signal_map(name, signal_map, where=name)
    file = display or str(path)
    if is_rosbag_name(Path(path).name) or is_rosbag2_folder(Path(path)):  # topics' fields
        from rwhonet.data.rosbag import read_rosbag

        if not dbc:
            return read_rosbag(Path(path), signal_map, radius_m, name, file)
        return _bag_and_bus(Path(path), signal_map, radius_m, name, file, dbc, max_mb)
    if not Path(path).is_file():
        raise InputError([Problem(file, None, None, "an MDF4 file", "no such file", None)])
    if (how := canedge_packed(Path(path).name)) is not None:
        raise InputError([canedge_packed_problem(file, how)])
    if is_can_log_name(Path(path).name):
        log = can_log_groups(
            Path(path), signal_map, radius_m, name, file, dbc, False, local_zone, max_mb
        )
        streams = build_streams(
            log.groups, log.clock, pulse_units(signal_map), fix_status_unit(signal_map)
        )
        return dataclasses.replace(
            streams,
            notes=(*streams.notes, *log.notes),
            changed=(*streams.changed, *log.changed),
        )
    if dbc:  # an MDF4 bus log: its frames decoded as a bus tool's log, on its master time
        log = can_log_groups(
            Path(path), signal_map, radius_m, name, file, dbc, False, None, max_mb, False
        )
        streams = build_streams(
            log.groups, log.clock, pulse_units(signal_map), fix_status_unit(signal_map)
        )
        return dataclasses.replace(
            streams,
            notes=(*streams.notes, *log.notes),
            changed=(*streams.changed, *log.changed),
        )
    mdf = _opened(path, file)
    try:
        return _read(mdf, signal_map, radius_m, name, file)
    finally:
        mdf.close()


def _bag_and_bus(
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str,
    file: str,
    dbc: Databases,
    max_mb: float | None,
) -> DriveStreams:
    """A ROS bag with CAN databases: a channel whose topic the bag has is that topic's
    field (:func:`rwhonet.data.rosbag.rosbag_groups`), any other a signal the databases
    decode from the bag's topics of raw CAN frames
    (:func:`rwhonet.data.rosbag.bag_frames`, each topic a bus), as from a bus tool's log."""
    from rwhonet.data.rosbag import CLOCK, bag_frames, field_of, read_bag, rosbag_groups

    def read(bag: Any) -> tuple[list[Any], list[str], list[Any]]:
        """The bag's mapped topics' fields and the signals its CAN frames carry, read once."""
        groups, notes, changed = [], [], []
        topics = {c.topic for c in bag.connections}
        on_topics = {
            k: spec
            for k, spec in signal_map.items()
            if (f := field_of(spec.column)) is not None and f.topic in topics
        }
        on_bus = {k: spec for k, spec in signal_map.items() if k not in on_topics}
        if on_topics:
            groups, notes = rosbag_groups(bag, path, on_topics, radius_m, name, file)
        if on_bus:
            log = can_log_groups(
                path,
                on_bus,
                radius_m,
                name,
                file,
                dbc,
                max_mb=max_mb,
                frames_of=lambda keep: bag_frames(bag, file, keep),
            )
            groups += log.groups
            notes += log.notes
            changed += log.changed
        return groups, notes, changed

    groups, notes, changed = read_bag(path, file, read)
    streams = build_streams(groups, CLOCK, pulse_units(signal_map), fix_status_unit(signal_map))
    return dataclasses.replace(
        streams, notes=(*streams.notes, *notes), changed=(*streams.changed, *changed)
    )


@dataclasses.dataclass(frozen=True)
class CanLogGroups:
    """A raw CAN log's decoded messages (:func:`can_log_groups`).

    Attributes:
        groups: one per message holding a mapped signal, its samples' rows the frames'
            lines in the log.
        clock: what the log's time stamps count.
        notes: the decode (databases, frame IDs defined, frames and buses).
        changed: frames passed over (error, remote, damaged lines), for predict to say.
        local_clock: its stamps are on the logging computer's local clock, which no
            ``local_zone`` put on UTC (an ASC log's seconds from its measurement's start,
            an MDF4 bus log whose start is marked local time).
    """

    groups: list[Group]
    clock: str
    notes: list[str]
    changed: list[str]
    local_clock: bool = False


def can_log_groups(
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str,
    file: str,
    dbc: Databases,
    present_only: bool = False,
    local_zone: str | None = None,
    max_mb: float | None = None,
    on_start: bool = True,
    frames_of: Callable[[FrameFilter | None], Frames] | None = None,
) -> CanLogGroups:
    """A raw CAN log's mapped signals, decoded by the CAN databases ``dbc``.

    Args:
        present_only: read the keys whose signal the databases decode from the log and
            leave the others (a log among a stream folder's CSVs, which give the rest);
            else a key whose signal is missing is refused.
        local_zone: the logger's time zone (IANA): a clock of local time (an ASC log's
            date line, an MDF4 bus log whose start is marked local) is put on UTC by it.
        max_mb: the memory a raw CAN log may take (``data.max_file_mb``; None: no bound):
            read a part at a time, its frames of the map's messages are bounded
            (:meth:`FrameFilter.frames_for`); read whole, its file's size.
        on_start: an MDF4 bus log's times are its start plus its master time (a stream
            folder's CANedge files, :func:`_start`); else its master time (one MDF4 file
            a drive).
        frames_of: where the frames come from other than a log's file (a ROS bag's topics
            of them: :func:`rwhonet.data.rosbag.bag_frames`), given the messages to keep;
            None: :func:`~rwhonet.data.canlog.read_frames` reads ``path``.

    Raises:
        InputError: no ``dbc``; the log or a database unreadable (:func:`_decoded`); a
            signal missing (unless ``present_only``), its unit contradicting the map; the
            log above ``max_mb``.
    """
    if not dbc:
        setting = _dbc_setting(name)
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"the CAN databases that decode the log's raw frames ({setting})",
                    "none given",
                    f"give {setting}: the DBC (or ARXML) of the bus the log recorded",
                )
            ]
        )
    frames, wanted, said = None, None, ""
    columns = [spec.column for spec in signal_map.values()]
    # asammdf's to open (.mf4, an MDF 3 .dat)
    mdf_file = frames_of is None and not is_can_log_name(path.name)

    def read(keep: FrameFilter | None = None) -> Frames:
        if frames_of is not None:
            return frames_of(keep)
        return read_frames(path, file, local_zone, keep)

    if mdf_file:  # an MDF4 bus log: a part at a time where it can be
        got = _mdf_kept(path, file, columns, dbc, name, present_only, local_zone, max_mb, on_start)
        if got is not None:
            frames, wanted, said = got
    else:
        _databases_there(dbc, name)  # before the log is read
        wanted = _wanted(dbc, columns, present_only)
        if wanted is None:
            _whole_fits(path, file, max_mb, _not_told_apart(dbc, columns))
            frames = read()
        else:
            bound = None if max_mb is None else FrameFilter.frames_for(max_mb)
            wanted = dataclasses.replace(
                wanted, keep=dataclasses.replace(wanted.keep, max_frames=bound)
            )
            frames = read(wanted.keep)
            if not wanted.in_log(frames, present_only):
                # a message the map needs is not in the log: read it whole, so that what
                # is missing is said as for any log
                lacks = f"the log has no frame of {', '.join(wanted.missing(frames))}"
                _whole_fits(path, file, max_mb, lacks)
                wanted, frames = None, read()
            else:  # a frame shorter than its message: its signals past its end are none
                frames = short_passed(frames, *wanted.lengths(frames), file)
    mdf = _opened(path, file) if frames is None else bus_log(frames)
    try:
        loaded = None if wanted is None else wanted.databases
        decoded = _decoded(mdf, dbc, name, file, frames, loaded, mdf_file)
        try:
            if present_only:
                signal_map = {k: v for k, v in signal_map.items() if decoded.whereis(v.column)}
            groups = _groups(decoded, signal_map, radius_m, name, file, mdf_file, frames)
        finally:
            decoded.close()
        notes = [
            _decoded_note(mdf, dbc)
            if wanted is None or frames is None
            else wanted.note(frames, _bus_channels(_pairs(dbc), frames, None, "", file))
        ]
        start_s, clock, local = 0.0, CLOCK, False
        if frames is None and on_start:
            start_s, clock, said, local = _started(mdf.header, local_zone, file)
    finally:
        mdf.close()
    if frames is None:  # an MDF4 bus log decoded whole (a CANedge's split file: on its start)
        groups = [
            Group(g.name, g.file, g.t_s + start_s, g.channels, g.sources, g.rows) for g in groups
        ]
        told = [n for n in [*notes, said] if n]
        return CanLogGroups(groups, clock, [f"{file}: {n}" for n in told], [], local)
    buses = ", ".join(frames.buses)
    notes.append(f"{frames.in_log} data frames on {len(frames.buses)} bus(es) ({buses})")
    if frames.log_ids is not None:
        notes.append(
            f"{frames.t_s.size} of them decoded, those of the {wanted.messages} "
            "message(s) the map's signals are in; the other frames were counted and left "
            "out as the log was read"
        )
    notes.append(said or f"the time stamps are {frames.clock}")
    passed = [f"{file}: passed over: {frames.passed}"] if frames.passed else []
    return CanLogGroups(
        groups,
        frames.clock,
        [f"{file}: {n}" for n in notes] + passed,
        passed,
        frames.local_start,
    )


def _mdf_kept(
    path: Path,
    file: str,
    columns: list[str],
    dbc: Databases,
    name: str,
    present_only: bool,
    local_zone: str | None,
    max_mb: float | None,
    on_start: bool,
) -> tuple[Frames, _Wanted, str] | None:
    """An MDF4 bus log's frames of the map's messages, read a part at a time
    (:func:`~rwhonet.data.mdfframes.mdf_frames`), at most ``max_mb``'s worth
    (:meth:`FrameFilter.frames_for`), those shorter than their message passed over; on its
    start (``on_start``, :func:`_start`: with its note) or its master time. None where it
    is decoded whole by asammdf instead, as before: the map's messages not told apart, no
    raw CAN frames in the file (:func:`_decoded` says so), or a message the map needs
    missing (so that what is missing is said as for any log); read whole, its file's size
    is bounded by ``max_mb`` (:func:`_whole_fits`).

    Raises:
        InputError: a database missing; the file unreadable; its start unclear; more
            frames kept than ``max_mb`` holds; to be read whole and above ``max_mb``.
    """
    _databases_there(dbc, name)
    wanted = _wanted(dbc, columns, present_only)
    if wanted is None:
        _whole_fits(path, file, max_mb, _not_told_apart(dbc, columns))
        return None
    mdf = _opened(path, file, process_bus_logging=False)
    try:
        if not frame_groups(mdf):
            return None
        start_s, clock, said, local = (
            _started(mdf.header, local_zone, file) if on_start else (0.0, CLOCK, "", False)
        )
        bound = None if max_mb is None else FrameFilter.frames_for(max_mb)
        keep = dataclasses.replace(wanted.keep, max_frames=bound)
        try:
            frames = mdf_frames(mdf, keep, start_s, clock, local)
        except TooManyFrames as err:
            raise InputError([too_many(file, err)]) from None
        except Exception as err:  # a damaged block is the file's problem
            fix = "export the log again from the logger's software"
            raise InputError(
                [Problem.unreadable(file, "raw CAN frames asammdf reads", err, fix)]
            ) from None
    finally:
        mdf.close()
    if not wanted.in_log(frames, present_only):
        _whole_fits(
            path, file, max_mb, f"the log has no frame of {', '.join(wanted.missing(frames))}"
        )
        return None
    return short_passed(frames, *wanted.lengths(frames), file), wanted, said


def _not_told_apart(dbc: Databases, columns: list[str]) -> str:
    """Why a raw CAN log's messages the map needs cannot be told apart (:func:`_wanted`
    gave none), for :func:`_whole_fits`."""
    undefined = _undefined(dbc, columns)
    if undefined:
        return f"no database defines {', '.join(undefined)}"
    return "the databases' J1939 messages cannot be grouped"


def _whole_fits(path: Path, file: str, max_mb: float | None, why: str) -> None:
    """Refuse a raw CAN log to be read whole (the map's messages not told apart, or told
    and one missing, read again to say what the log has: ``why``) where its file is
    above ``max_mb`` (``data.max_file_mb``): read whole, every frame is held."""
    size_mb = path.stat().st_size / 2**20
    if max_mb is None or size_mb <= max_mb:
        return
    raise InputError(
        [
            Problem(
                file,
                None,
                None,
                f"a CAN log read whole of at most {max_mb:g} MB (data.max_file_mb)",
                f"{size_mb:,.1f} MB, to be read whole as {why}",
                "give the map's signals as the CAN databases name them and the databases "
                "of the log's messages (its frames are then read a part at a time, only "
                "the map's messages kept), or raise data.max_file_mb on a machine with "
                "the memory",
            )
        ]
    )


def canedge_packed(name: str) -> str | None:
    """How a CANedge packed a log file, by its name (``00000001.MFC``: ``compressed``), or
    None where it did not."""
    return CANEDGE_PACKED.get(Path(without_suffix(name)).suffix.lower())


def canedge_packed_problem(file: str, how: str) -> Problem:
    """A CANedge log file the logger packed (:data:`CANEDGE_PACKED`), refused with how to
    unpack it."""
    return Problem(
        file,
        None,
        None,
        "an MDF4 log as asammdf reads it (.MF4)",
        f"a CANedge log file the logger {how} ({Path(without_suffix(file)).suffix})",
        "turn it into a plain .MF4 with CSS Electronics' MDF converter (mdf2finalized; an "
        "encrypted file needs the device's passwords.json), and give that",
    )


def is_mdf_name(name: str) -> bool:
    """Whether a file's name is an MDF file's (``00000001.MF4``, ``drive.mf4.gz``, ``x.mdf``)."""
    return Path(without_suffix(name)).suffix.lower() in MDF_SUFFIXES


def _opened(path: Path, file: str, **options: Any):  # type: ignore[no-untyped-def]
    """``asammdf.MDF(path, **options)``, or its refusal."""
    from asammdf import MDF  # imported here: it takes most of a second to import

    mdf, problem = _open(functools.partial(MDF, **options), path, file)
    if problem is not None:
        raise InputError([problem], summary=f"cannot decode {file}")
    return mdf


def _started(header, zone: str | None, file: str) -> tuple[float, str, str, bool]:  # type: ignore[no-untyped-def]
    """:func:`_start`, a start :func:`local_to_unix` refuses refused naming ``file``."""
    try:
        return _start(header, zone)
    except LocalTimeUnclear as err:
        raise InputError([unclear_start(file, None, "start time", err)]) from None


def _start(header, zone: str | None = None) -> tuple[float, str, str, bool]:  # type: ignore[no-untyped-def]
    """An MDF4 bus log's start among a stream folder's files (a CANedge's split files):
    each file's master time counts from its own start (``header.start_time``), so only the
    start makes the split files of one drive one clock, and a clock the folder's other
    files can share. A start marked local time (no zone) is put on UTC in ``zone`` where
    given. Returns the start (s), what the clock is, the note, and whether it stays on
    local time (marked local, no ``zone``)."""
    local = bool(header.time_flags & FLAG_HD_LOCAL_TIME)
    start = header.abs_time / 1e9
    if local and zone is not None:
        start = local_to_unix(header.start_time.replace(tzinfo=None), zone)
        clock = (
            f"Unix time (the file marks its start as local time; in {zone}, the map's local_zone)"
        )
    elif local:
        clock = "a local time (the file marks its start as local time, without a zone)"
    else:
        clock = "Unix time (the file's start is UTC)"
    said = f"its times are its start ({header.start_time.isoformat()}) plus its master time: "
    return start, clock, said + clock, local and zone is None


def _pairs(dbc: Databases) -> list[tuple[str, str | None]]:
    """Each database with its bus (None: every bus)."""
    return [(d, None) if isinstance(d, str) else (str(d[0]), d[1]) for d in dbc]


def _decoded_note(mdf, dbc: Databases) -> str:  # type: ignore[no-untyped-def]
    """What the drive's notes say of raw frames decoded: by which databases, how many of
    the log's frame IDs they define (the others carry nothing the map can name)."""
    info = mdf.last_call_info.get("CAN", {})
    total = len(info.get("total_unique_ids", ()))
    found = len({i for ids in info.get("found_ids", {}).values() for i in ids})
    return _ids_note(_pairs(dbc), found, total)


def _ids_note(pairs: list[tuple[str, str | None]], found: int, total: int) -> str:
    """The note of a decode: its databases (each with its bus), and of the log's ``total``
    frame IDs, the ``found`` ones they define."""
    files = ", ".join(Path(d).name + (f" ({bus})" if bus else "") for d, bus in pairs)
    return f"raw CAN frames decoded with {files}: {found} of the log's {total} frame IDs defined"


Key = tuple[int, bool]  # a message's identifier and whether it is extended


@dataclasses.dataclass(frozen=True)
class _Matcher:
    """Which message of one CAN database asammdf's bus-logging decode gives a frame
    (``MDF4._extract_can_logging``, asammdf 8.8): the message of the frame's identifier,
    else the first J1939 message of the frame's parameter group (:func:`j1939_pgn`). A
    J1939 message is one canmatrix marks so, or any of a database whose ``ProtocolType`` is
    J1939 where all its identifiers are extended (asammdf drops the database's flag
    otherwise).

    Attributes:
        exact: each message's key -> (its key, name, parameter group where J1939 else None).
        by_group: each J1939 parameter group -> its first message's, as in ``exact``.
        sizes: each message's key -> its length in the database, bytes.
    """

    exact: dict[Key, tuple[Key, str, int | None]]
    by_group: dict[int, tuple[Key, str, int | None]]
    sizes: dict[Key, int]

    @classmethod
    def of(cls, db: Any) -> _Matcher:
        """The database's messages, as asammdf looks them up (its later duplicates win)."""
        flagged = db.attributes.get("ProtocolType", "").lower() == "j1939"
        every = flagged and all(m.arbitration_id.extended for m in db)

        def entry(m: Any) -> tuple[Key, str, int | None]:
            key = (int(m.arbitration_id.id), bool(m.arbitration_id.extended))
            return key, m.name, int(m.arbitration_id.pgn) if m.is_j1939 or every else None

        exact = {(int(m.arbitration_id.id), bool(m.arbitration_id.extended)): entry(m) for m in db}
        groups = {
            (int(m.arbitration_id.pgn), m.arbitration_id.j1939_source): entry(m)
            for m in db
            if m.is_j1939 or every
        }
        by_group: dict[int, tuple[Key, str, int | None]] = {}
        for (pgn, _), item in groups.items():
            by_group.setdefault(pgn, item)
        sizes = {
            (int(m.arbitration_id.id), bool(m.arbitration_id.extended)): int(m.size) for m in db
        }
        return cls(exact, by_group, sizes)

    def decoded(self, ids: list[Key]) -> list[tuple[Key, tuple[Any, ...], str]]:
        """For each frame identifier the database decodes: its message's key, asammdf's
        key of what it found (``(group, source address, True)`` for a J1939 message,
        ``(identifier, extended, False)`` else), and the message's name."""
        groups = j1939_pgn(np.array([i for i, _ in ids], np.int64)).tolist() if ids else []
        out = []
        for (i, x), group in zip(ids, groups, strict=True):
            item = self.exact.get((i, x)) or self.by_group.get(group)
            if item is not None:
                key, name, pgn = item
                found = (pgn, i & 0xFF, True) if pgn is not None else (i, x, False)
                out.append((key, found, name))
        return out


@dataclasses.dataclass(frozen=True)
class _Wanted:
    """The messages a raw CAN log's decode needs (:func:`_wanted`).

    Attributes:
        keep: the frames of the messages that carry the map's signals (a J1939 message's
            by its parameter group).
        pairs: the map's databases, each with its bus (None: every bus).
        matchers: how each database's messages are found, in ``pairs``' order.
        wanted: each database's messages that carry the map's signals (their keys).
        databases: each database as loaded (canmatrix), in ``pairs``' order: the decode
            takes them, not loading each file again.
    """

    keep: FrameFilter
    pairs: list[tuple[str, str | None]]
    matchers: list[_Matcher]
    wanted: list[frozenset[Key]]
    databases: list[Any]  # the CanMatrix of each, for the decode

    @property
    def messages(self) -> int:
        """How many messages carry the map's signals."""
        return len(frozenset().union(*self.wanted))

    def in_log(self, frames: Frames, present_only: bool) -> bool:
        """Whether the log has frames that decode as every message wanted (on any bus);
        among a stream folder's files (``present_only``: the others may hold the rest), as
        any."""
        found = self._found(frames)
        return bool(found) if present_only else found == self._needed()

    def missing(self, frames: Frames) -> list[str]:
        """The messages wanted that no frame of the log decodes as, each named with its
        identifier (``WheelSpeeds 0x1A0``), sorted."""
        return sorted(
            {
                f"{name} 0x{i:0{8 if x else 3}X}"
                for k, key in self._needed() - self._found(frames)
                for (i, x), name, _ in [self.matchers[k].exact[key]]
            }
        )

    def lengths(self, frames: Frames) -> tuple[np.ndarray, Callable[[int], str]]:
        """Each frame's length in the database of the wanted message it decodes as (the
        longest where databases differ; 0 where none), and the name of frame ``n``'s
        message (``GnssPos 0x600``), for :func:`rwhonet.data.canlog.short_passed`."""
        keys = frame_keys(np.zeros(frames.t_s.size, np.int64), frames.ids, frames.extended)
        unique, inverse = np.unique(keys, return_inverse=True)
        _, ident, ext = key_id(unique)
        need = np.zeros(unique.size, np.int64)
        names: dict[int, str] = {}
        for u, (i, x) in enumerate(zip(ident.tolist(), ext.tolist(), strict=True)):
            for k, matcher in enumerate(self.matchers):
                for key, _, name in matcher.decoded([(i, x)]):
                    if key in self.wanted[k] and matcher.sizes.get(key, 0) > need[u]:
                        need[u], names[u] = matcher.sizes[key], f"{name} 0x{i:X}"
        return need[inverse], lambda n: names.get(int(inverse[n]), "")

    def _needed(self) -> set[tuple[int, Key]]:
        return {(k, key) for k, keys in enumerate(self.wanted) for key in keys}

    def _found(self, frames: Frames) -> set[tuple[int, Key]]:
        """Each database's wanted messages some frame of the log decodes as."""
        _, ident, ext = key_id(frames.log_ids)
        ids = list(zip(ident.tolist(), ext.tolist(), strict=True))
        return {
            (k, key)
            for k, matcher in enumerate(self.matchers)
            for key, _, _ in matcher.decoded(ids)
            if key in self.wanted[k]
        }

    def note(self, frames: Frames, channels: list[tuple[str, int]]) -> str:
        """:func:`_decoded_note` for a log read with ``keep``: of the IDs on the buses a
        database decodes (every bus, or its own: ``channels``, as :func:`_bus_channels`
        numbers them), those it decodes, counted as asammdf counts them (a J1939 message's
        by parameter group and source address)."""
        bus, ident, ext = key_id(frames.log_ids)
        on_bus = list(zip(bus.tolist(), ident.tolist(), ext.tolist(), strict=True))
        total: set[Key] = set()
        found: set[tuple[tuple[Any, ...], str]] = set()
        for (_, channel), matcher in zip(channels, self.matchers, strict=True):
            on = sorted({(i, x) for b, i, x in on_bus if channel in (0, b)})
            total |= set(on)
            found |= {(key, name) for _, key, name in matcher.decoded(on)}
        return _ids_note(self.pairs, len(found), len(total))


_ON_BUS = re.compile(r"CAN\d+\.")  # a decoded signal's name with its bus: CAN1.Message.Signal


def _wanted(dbc: Databases, columns: list[str], present_only: bool) -> _Wanted | None:
    """The messages of the CAN databases ``dbc`` that carry the signals ``columns`` name
    (a signal's name, ``Message.Signal`` or ``CAN1.Message.Signal``, as the decoded log
    names them), for :func:`rwhonet.data.canlog.read_frames` to keep: by identifier, and a
    J1939 message by its parameter group (:class:`_Matcher`: the decode matches those by
    group and the frame's source address, as a truck's ECUs send them). None where the
    log is to be read whole: a database missing or not loaded (:func:`_decoded` refuses
    it), one whose J1939 messages canmatrix cannot group, or a column no database's signal
    (unless ``present_only``: there such a column is another file's, and where none is,
    the log's decode finds nothing either)."""
    pairs = _pairs(dbc)
    bare = _bare(columns)
    keys: set[Key] = set()
    groups: set[int] = set()
    named: set[str] = set()
    matchers: list[_Matcher] = []
    wanted: list[frozenset[Key]] = []
    databases = []
    for d, _ in pairs:
        db = _database(Path(d))
        if db is None:
            return None
        try:
            matcher = _Matcher.of(db)
        except Exception:  # noqa: BLE001 (a J1939 message of a standard identifier: the decode says)
            return None
        databases.append(db)
        matchers.append(matcher)
        mine: set[Key] = set()
        for message in db:
            key = (int(message.arbitration_id.id), bool(message.arbitration_id.extended))
            names = _signal_names(message)
            hit = {c for c, b in bare.items() if b in names}
            if hit:
                _, _, group = matcher.exact[key]
                if group is None:
                    keys.add(key)
                else:
                    groups.add(group)
                mine.add(key)
                named |= hit
        wanted.append(frozenset(mine))
    if not named or (not present_only and named != set(columns)):
        return None
    keep = FrameFilter(frozenset(keys), frozenset(groups))
    return _Wanted(keep, pairs, matchers, wanted, databases)


def _bare(columns: Sequence[str]) -> dict[str, str]:
    """Each column's signal name without its bus (``CAN1.Message.Signal``: ``Message.Signal``)."""
    return {c: c[m.end() :] if (m := _ON_BUS.match(c)) else c for c in columns}


def _signal_names(message: Any) -> set[str]:
    """The names a decode gives a database message's signals: ``Signal`` and
    ``Message.Signal``."""
    names = {s.name for s in message.signals}
    return names | {f"{message.name}.{n}" for n in names}


def _undefined(dbc: Databases, columns: Sequence[str]) -> list[str]:
    """The columns no loaded database among ``dbc`` has a signal of (a database not
    loaded defines none)."""
    names: set[str] = set()
    for d, _ in _pairs(dbc):
        db = _database(Path(d))
        names |= {n for message in db or () for n in _signal_names(message)}
    return sorted(c for c, b in _bare(columns).items() if b not in names)


def _database(path: Path):  # type: ignore[no-untyped-def]
    """A CAN database as asammdf loads it (canmatrix), kept for the process by the file's
    path, size and time: a car's DBC of some 2,000 messages takes 0.1-0.2 s to load, once
    a log (a folder of rotated logs, predict's every call). None: not there, or not
    loaded."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return _database_of(str(path.resolve()), stat.st_size, stat.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _database_of(path: str, size: int, mtime_ns: int):  # type: ignore[no-untyped-def]
    """:func:`_database`, cached by the file's size and time."""
    from asammdf.blocks.utils import load_can_database

    try:
        return load_can_database(Path(path))
    except Exception:  # noqa: BLE001 (the decode says what is wrong with the database)
        return None


def _dbc_setting(name: str) -> str:
    """Where a map's CAN databases are set: ``data.signal_maps.<name>.dbc``, or a map
    file's ``dbc`` (``name``: how messages name the map's signals)."""
    if name.endswith(".signals"):
        return name.removesuffix(".signals") + ".dbc"
    return f"dbc in {name}"


def _databases_there(dbc: Databases, name: str) -> None:
    """Refuse the CAN databases that are not there, each named."""
    missing = [d for d, _ in _pairs(dbc) if not Path(d).is_file()]
    if missing:
        setting = _dbc_setting(name)
        raise InputError(
            [
                Problem(d, None, None, f"a CAN database ({setting})", "no such file", None)
                for d in missing
            ]
        )


def _decoded(  # type: ignore[no-untyped-def]
    mdf,
    dbc: Databases,
    name: str,
    file: str,
    frames: Frames | None,
    loaded: list | None = None,
    numbered: bool = False,
):
    """The signals of ``mdf``'s raw CAN frames, decoded by the CAN databases ``dbc``, each
    for every bus or for its own (named as the log names it: ``frames.buses`` for a bus
    tool's log, a bus channel number for an MDF4 bus log, ``numbered``, or ``mdf`` itself
    without ``frames``).

    Raises:
        InputError: a database missing or unreadable, a bus the log does not have, the file
            without raw CAN frames, or none of its frames' IDs in the databases.
    """
    setting = _dbc_setting(name)
    pairs = _pairs(dbc)
    _databases_there(dbc, name)
    if not mdf.whereis("CAN_DataFrame"):
        found = ", ".join(sorted(k for k in mdf.channels_db if k not in ("time", "t")))[:200]
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"raw CAN frames (a CAN_DataFrame channel) for {setting} to decode",
                    f"none; the file has {found}",
                    f"remove {setting} (the file's signals are decoded already) and map them",
                )
            ]
        )
    channels = _bus_channels(pairs, frames, mdf, setting, file, numbered)
    if loaded is not None:  # the databases :func:`_wanted` loaded, not loaded again
        channels = [(db, bus) for db, (_, bus) in zip(loaded, channels, strict=True)]
    try:
        decoded = mdf.extract_bus_logging({"CAN": channels})
    except Exception as err:  # a database canmatrix cannot load, a damaged block
        fix = f"give {setting} a DBC or ARXML file the logger's tool reads"
        raise InputError(
            [Problem.unreadable(file, "raw CAN frames the CAN databases decode", err, fix)]
        ) from None
    info = mdf.last_call_info.get("CAN", {})
    if not any(info.get("found_ids", {}).values()):
        ids = sorted(i for i, _ in info.get("total_unique_ids", ()))
        shown = ", ".join(f"0x{i:X}" for i in ids[:12]) + (" ..." if len(ids) > 12 else "")
        decoded.close()
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"frames whose IDs the CAN databases of {setting} define",
                    f"{len(ids)} frame ID(s) ({shown}), none in "
                    + ", ".join(d + (f" (bus {b})" if b else "") for d, b in pairs),
                    "give the DBC of the bus the logger recorded",
                )
            ]
        )
    return decoded


def _bus_channels(
    pairs: list[tuple[str, str | None]],
    frames: Frames | None,
    mdf,
    setting: str,
    file: str,
    numbered: bool = False,
) -> list[tuple[str, int]]:  # type: ignore[no-untyped-def]
    """``extract_bus_logging``'s ``(database, bus channel)`` pairs (0: every bus): a bus
    tool's interface by its place among the log's buses, an MDF4 bus log's by its number
    (its frames' ``buses`` its numbers where ``numbered``).

    Raises:
        InputError: a bus the log does not have (naming the ones it has).
    """
    if all(bus is None for _, bus in pairs):  # every database for every bus
        return [(str(d), 0) for d, _ in pairs]
    out, problems = [], []
    if frames is not None:
        have = list(frames.buses)
    else:
        buses = (
            mdf.get("CAN_DataFrame.BusChannel", raw=True).samples
            if mdf.whereis("CAN_DataFrame.BusChannel")
            else np.zeros(0)
        )
        have = [str(int(b)) for b in np.unique(buses)]
    for d, bus in pairs:
        if bus is None:
            out.append((str(d), 0))
        elif bus in have:
            out.append((str(d), have.index(bus) + 1 if frames is not None else int(bus)))
        else:
            problems.append(
                Problem(
                    file,
                    None,
                    None,
                    f"the bus {bus!r} that {setting} gives {Path(d).name} to",
                    f"the log's buses are {', '.join(have) or 'none'}",
                    "name the bus as the log names it"
                    + (
                        " (an MDF4 bus log: its bus channel number)"
                        if frames is None or numbered
                        else ""
                    ),
                )
            )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) decoding {file}")
    return out


def _open(mdf_class, path: Path, file: str) -> tuple[Any, Problem | None]:
    """``asammdf.MDF(path)``, or the problem that it could not be decoded.

    A file asammdf gives up on half way (a truncated log) leaves a half-built reader whose
    destructor fails in turn; Python would print that second error as "Exception ignored
    in ... Traceback" after our report. The half-built reader is collected here, with
    that destructor's error muted, so a refused file shows the report and nothing else.
    """
    hook = sys.unraisablehook
    sys.unraisablehook = _mute
    try:
        try:
            return mdf_class(path), None
        except Exception as err:  # any failure to decode is the file's problem
            expected = "an ASAM MDF file (MDF4, as CAN loggers write it)"
            fix = "export the log as MDF4 (.mf4) from the logger's software"
            problem = Problem.unreadable(file, expected, err, fix)
        gc.collect()  # the error's frames held the half-built reader: it goes now, muted
        return None, problem
    finally:
        sys.unraisablehook = hook


def _mute(_: Any) -> None:
    """An unraisable error (a half-built reader's destructor) that is not the user's."""


def _read(
    mdf, signal_map: Mapping[str, ColumnSpec], radius_m: float | None, name: str, file: str
) -> DriveStreams:
    """The mapped signals of ``mdf``, one stream per channel group."""
    return build_streams(
        _groups(mdf, signal_map, radius_m, name, file),
        CLOCK,
        pulse_units(signal_map),
        fix_status_unit(signal_map),
    )


def _groups(
    mdf,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str,
    file: str,
    master: bool = True,
    frames: Frames | None = None,
) -> list[Group]:
    """The mapped signals of ``mdf``, a group per channel group. ``master``: the times are
    the file's master time (else a raw log's frame stamps); ``frames`` (the raw log's)
    name a decoded group's message and bus, and give its samples' rows in the log."""
    problems: list[Problem] = []
    by_group: dict[int, dict[str, tuple[np.ndarray | None, np.ndarray, str]]] = {}
    for key, spec in signal_map.items():
        where = mdf.whereis(spec.column)
        if not where:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    f"a signal named {spec.column!r} ({name}.{key})",
                    "no such signal; the file has "
                    + ", ".join(sorted(k for k in mdf.channels_db if k not in ("time", "t")))[:300],
                    f"the file holds raw CAN frames: give {_dbc_setting(name)}, the CAN "
                    "database (DBC) that decodes them"
                    if mdf.whereis("CAN_DataFrame")
                    else f"name the logged signal in {name}.{key}.column",
                )
            )
            continue
        groups = sorted({g for g, _ in where})
        if len(groups) > 1:
            cgs = [mdf.groups[g].channel_group for g in groups]
            buses = (
                None
                if frames is None
                else [frames.bus_of(cg.acq_name or "", cg.comment or "") for cg in cgs]
            )
            if buses and None not in buses and len(set(buses)) > 1:  # a raw log's buses
                found = f"{len(groups)} signals of that name, on the buses {', '.join(buses)}"
                fix = (
                    f"decode one bus's frames: give {_dbc_setting(name)} per bus "
                    f"({{{buses[0]}: <the DBC>}}), log that interface alone (candump -l "
                    f"{buses[0]}), or keep its lines (grep ' {buses[0]} ')"
                )
            else:  # a raw log's messages by their names (group numbers are the decode's)
                placed = [
                    None
                    if frames is None
                    else frames.place(cg.acq_name or "", cg.comment or "", cg.cycles_nr)
                    for cg in cgs
                ]
                where_said = (
                    f"in the messages {', '.join(p[0] for p in placed if p)}"
                    if all(placed)
                    else f"in channel groups {groups}"
                )
                found = f"{len(groups)} signals of that name, {where_said}"
                fix = "rename the copies, or export only the message that carries it"
            problems.append(
                Problem(file, None, spec.column, f"one signal named {spec.column!r}", found, fix)
            )
            continue
        group, index = where[0]
        try:
            signal = mdf.get(spec.column, group=group, index=index)
        except Exception as err:  # a damaged block is the file's problem
            fix = "export the log again from the logger's software"
            problems.append(
                Problem.unreadable(file, "a signal asammdf can decode", err, fix, spec.column)
            )
            continue
        samples = np.asarray(signal.samples)
        if samples.dtype.kind not in "biuf" or samples.ndim != 1:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    "one number per time stamp",
                    f"samples of type {samples.dtype} and shape {samples.shape}",
                    "map a numeric signal (decode raw CAN frames with the DBC first)",
                )
            )
            continue
        declared = unit_name(signal.unit or None)
        mapped = mapped_unit_name(spec.unit)
        if declared is not None and mapped is not None and declared != mapped:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    f"the unit {spec.unit!r} ({name}.{key})",
                    f"the file says {signal.unit!r}",
                    f"set {name}.{key}.unit to the file's unit",
                )
            )
            continue
        # The signals of a group share its time stamps: keep the first signal's only (a long
        # log's stamps are hundreds of MB per signal).
        t = None if group in by_group else np.asarray(signal.timestamps, dtype=np.float64)
        values = to_si(
            key,
            scaled(samples, spec),
            spec.unit,
            radius_m,
            f"{file} {spec.column!r}",
            (file, spec.column),
        )
        del signal, samples
        by_group.setdefault(group, {})[key] = (t, values, spec.column)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) reading {file}")
    groups = []
    for g, channels in sorted(by_group.items()):
        t = next(iter(channels.values()))[0]  # the group's first signal's stamps
        group = mdf.groups[g].channel_group
        found = (
            None
            if frames is None
            else frames.place(group.acq_name or "", group.comment or "", t.size)
        )
        groups.append(
            Group(
                f"channel group {g}" if found is None else found[0],
                file,
                t,
                {k: v for k, (_, v, _) in channels.items()},
                {"t": "master time" if master else "frame time stamp"}
                | {k: s for k, (_, _, s) in channels.items()},
                None if found is None else found[1],
            )
        )
    return groups
