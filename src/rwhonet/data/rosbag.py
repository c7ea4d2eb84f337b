"""A ROS bag: a ROS 1 ``.bag`` (``rosbag record``) or a ROS 2 bag's folder (``ros2 bag
record``: ``metadata.yaml`` beside its ``.db3`` or ``.mcap`` files); the topics a signal map
names, read by ``rosbags``.

Research vehicles that run ROS record their drives as bags: a drive-by-wire kit's wheel
speeds (Dataspeed's ``dbw_mkz_msgs/WheelSpeedReport``: ``front_left`` ... ``rear_right``,
rad/s, as Udacity's self-driving car bags hold them), the receiver's fixes
(``sensor_msgs/NavSatFix``), an IMU's rates (``sensor_msgs/Imu``). A bag given to the
``mdf4`` reader (one file per drive, as a bus tool's CAN log is; a ROS 2 bag one folder) is
read here (:func:`read_rosbag`); ``rosbags`` (Ternaris, Apache-2.0) reads the bag's records
and deserialises its messages by the message definitions the bag itself carries, so a
kit's own message types need nothing installed, and ROS need not be. A ROS 2 bag recorded
before Iron carries none: ROS's own types are known (the latest LTS's), a kit's are
refused, naming the type. A ROS 2 bag's ``.mcap`` or ``.db3`` given alone, or its folder
without ``metadata.yaml`` (a recording cut short), is read from its storage files.

**Signals.** A signal map's channel names a topic and a field of its messages, with a
``.`` between: ``/vehicle/wheel_speed_report.front_left``, ``/gps/fix.latitude``,
``/imu/data.angular_velocity.z``; an element of an array field by its index,
``/joint_states.velocity[2]`` (ROS's names hold no ``.``, so the first one ends the topic).
The map gives each unit: ROS's messages carry none (REP 103's are SI: rad/s, m/s, and
NavSatFix's degrees). A field that is not a number (a string, a message) is refused on the
first message, naming the message type's fields; an index past a later message's array is
no value, counted.

**Times.** Each topic is a stream of its own. Its samples are timed by its messages'
``header.stamp`` (the sensor driver's time of the measurement, ROS's convention) where its
type has a header and no stamp is zero; otherwise by the times the bag recorded them (the
recorder's receipt). The notes say which, per topic. Both are ROS time, the recording
computer's clock: seconds since 1970 (a driver may stamp with the receiver's UTC instead;
``data.gnss_lag`` reports an offset between the fixes and the wheels).

**Fixes.** Where the latitude's message has a ``status.status`` (NavSatFix's, gps_common's
GPSFix's), a message whose status is below 0 (``STATUS_NO_FIX``) has no position; the
notes count them. A NavSatFix holds no satellite count (GPSFix's ``status.satellites_used``
can be mapped as ``n_sats``). Where the map names no ``h_acc`` and the latitude's message
has a ``position_covariance`` (row-major 3x3, east, north, up, m²) with its
``position_covariance_type`` (NavSatFix's, GPSFix's), ``h_acc`` is the root of the sum of
its east and north variances (``[0] + [4]``: the DRMS, m), where the type is not 0
(``COVARIANCE_TYPE_UNKNOWN``: 1 approximated, 2 diagonal known, 3 known) and both are
finite numbers, not negative; NaN otherwise, and a topic none of whose messages states one
has none.

**A recording cut short** (``rosbag record`` killed: ``drive.bag.active``, no index; ``ros2
bag record`` killed: an ``.mcap`` file without its summary and footer) is read record by
record as far as it goes (:mod:`rwhonet.data.bagscan`, :mod:`rwhonet.data.mcapscan`), the
notes saying so; so is a closed bag ``rosbags`` refuses (a damaged chunk, index or
message: :func:`read_bag`), a damaged chunk passed over. A ROS 2 bag's sqlite3 file that
SQLite cannot read (cut short, or a page damaged), or one with a write-ahead log beside it
that commits pages (``drive_0.db3-wal``: rosbag2's ``resilient`` preset, stopped before a
checkpoint; ``rosbags`` never reads the log), is read page by page
(:mod:`rwhonet.data.db3scan`), the log's pages over the file's. A message such a read
cannot deserialise is damaged: passed over and counted.

**Refused** (:class:`~rwhonet.errors.InputError`, nothing read): a file or folder
``rosbags`` cannot read; a topic the bag does not have (its topics and types listed);
a topic recorded with two message types; a mapped topic's type the bag does not define; a
field the type does not have, or not a number.

**Raw CAN frames.** With the map's CAN databases, a bag's topics of raw frames
(socketcan_bridge's and ros2_socketcan's ``can_msgs/Frame``, Dataspeed's
``CanMessageStamped``) are a CAN log's frames (:func:`bag_frames`, each topic a bus named
by it), decoded as :mod:`rwhonet.data.mdf4` decodes a bus tool's log; a channel whose
topic the bag has stays that topic's field.

**Rows.** A sample is named by its message's number among its topic's messages (1-based);
a CAN frame by its number among the bag's messages of frames.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import operator
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data.columnmap import scaled
from rwhonet.data.compressed import without_suffix
from rwhonet.data.signalmap import Group, build_streams, fix_status_unit, pulse_units, to_si
from rwhonet.data.streams import DriveStreams
from rwhonet.errors import InputError, Problem

if TYPE_CHECKING:
    from rwhonet.data.canlog import Frames
    from rwhonet.data.keptframes import FrameFilter

ROSBAG_SUFFIXES = (".bag",)
# a ROS 2 bag's storage file given without its folder's metadata.yaml (rosbags reads it)
ROS2_FILES = (".mcap", ".db3")
UNFINISHED = ".bag.active"  # rosbag record's file while it records, left so when it is killed
CLOCK = "ROS time (s since 1970: the recording computer's clock)"
T = TypeVar("T")  # what a read of an open bag gives (read_bag)
_TOPIC = r"[^.\s\[\]]+"  # ROS's names: letters, digits, _, / and ~
_FIELD = r"[A-Za-z_]\w*(?:\[\d+\])*"
_SIGNAL = re.compile(rf"^({_TOPIC})\.({_FIELD}(?:\.{_FIELD})*)$")
_INDEX = re.compile(r"\[(\d+)\]")
READ_HOW = "rosbags' reader of ROS 1 bags (format 2.0)"
READ_HOW_2 = "rosbags' reader of ROS 2 bags (sqlite3 or mcap storage)"
METADATA = "metadata.yaml"  # a ROS 2 bag folder's description of its storage files


def is_rosbag2_folder(path: Path) -> bool:
    """Whether a path is a ROS 2 bag: a folder holding its ``metadata.yaml``, or only its
    storage files (``.db3``, ``.mcap``: a recording cut short, before ``ros2 bag record``
    wrote its ``metadata.yaml``)."""
    return path.is_dir() and ((path / METADATA).is_file() or bool(_storage_files(path)))


def _storage_files(folder: Path) -> list[Path]:
    """A ROS 2 bag folder's storage files (``drive_0.db3``, ``drive_1.db3``...; compressed
    by rosbag2's file compression too: ``drive_0.mcap.zstd``), in order."""
    return sorted(
        (
            p
            for p in folder.iterdir()
            if p.is_file() and Path(without_suffix(p.name)).suffix.lower() in ROS2_FILES
        ),
        key=lambda p: (len(without_suffix(p.name)), p.name),
    )


def is_rosbag_name(name: str) -> bool:
    """Whether a file's name is a ROS 1 bag's (``.bag``, kept compressed too: ``.bag.gz``;
    or an unfinished ``.bag.active``) or a ROS 2 bag's storage file given alone (``.mcap``,
    ``.db3``; ``.mcap.gz``)."""
    low = without_suffix(name).lower()
    return low.endswith((*ROSBAG_SUFFIXES, UNFINISHED, *ROS2_FILES))


def _is_ros2(path: Path) -> bool:
    """Whether a bag is ROS 2's: a folder, or its storage file alone."""
    return path.is_dir() or path.suffix.lower() in ROS2_FILES


@dataclass(frozen=True)
class Field:
    """A signal map's channel in a bag: a topic and the path to a field of its messages."""

    topic: str
    path: tuple[str | int, ...]
    text: str


def field_of(text: str) -> Field | None:
    """The topic and field a channel names (``/imu/data.angular_velocity.z``,
    ``/joint_states.velocity[2]``; ``gps/fix.latitude`` is ``/gps/fix``'s), or None where it
    names none."""
    m = _SIGNAL.match(text.strip())
    if m is None:
        return None
    path: list[str | int] = []
    for part in m.group(2).split("."):
        name = part.split("[", 1)[0]
        path.append(name)
        path += [int(i) for i in _INDEX.findall(part)]
    topic = m.group(1)  # rosbags names every topic from the root, as rostopic lists it
    return Field(topic if topic.startswith("/") else f"/{topic}", tuple(path), text.strip())


def _fields(signal_map: Mapping[str, ColumnSpec], where: str) -> dict[str, Field]:
    fields, issues = {}, []
    for key, spec in signal_map.items():
        f = field_of(spec.column)
        if f is None:
            issues.append(
                f"{where}.{key}: a ROS bag's signal is a topic and a field of its messages, "
                f"as /topic.field or /topic.field.sub[index] (e.g. /gps/fix.latitude), got "
                f"{spec.column!r}"
            )
        else:
            fields[key] = f
    if issues:
        raise ConfigError("\n".join(issues))
    return fields


def _names(obj: Any) -> list[str]:
    """A message's field names, in its type's order."""
    names = getattr(obj, "__dataclass_fields__", None)
    return [n for n in names if not n.startswith("__")] if names else []


def _type_name(obj: Any) -> str:
    t = getattr(obj, "__msgtype__", None)
    if t:
        return str(t)
    if isinstance(obj, np.ndarray):
        return f"an array of {obj.dtype}"
    return type(obj).__name__


class _Missing(Exception):
    """A field path a message does not have: the object it stopped at and the step."""

    def __init__(self, at: Any, step: str | int) -> None:
        super().__init__(step)
        self.at, self.step = at, step


def _value(msg: Any, path: tuple[str | int, ...]) -> Any:
    obj = msg
    for step in path:
        if isinstance(step, int):
            try:
                obj = obj[step]
            except (IndexError, TypeError, KeyError):
                raise _Missing(obj, step) from None
        else:
            if step not in _names(obj):
                raise _Missing(obj, step)
            obj = getattr(obj, step)
    return obj


def _is_number(v: Any) -> bool:
    """Whether a field's value is a number (a bool is 0 or 1)."""
    return isinstance(v, (int, float, np.integer, np.floating, np.bool_))


def _stamp_ns(msg: Any) -> int | None:
    """A message's ``header.stamp`` in ns (None: no header; 0: a zero stamp)."""
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return None
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _fix_status(msg: Any) -> float:
    status = getattr(getattr(msg, "status", None), "status", None)
    return float(status) if _is_number(status) else np.nan


@dataclass
class _Topic:
    """One topic's samples as read."""

    topic: str
    msgtype: str
    keys: list[str]
    values: dict[str, list[float]]
    stamps: list[int | None]
    recorded: list[int]
    status: list[float]
    past_end: dict[str, int]
    h_acc: list[float] = dataclasses.field(default_factory=list)  # position_covariance's
    damaged: int = 0  # messages that do not deserialise, passed over (a bag read by a scan)


def _unreadable(file: str, err: BaseException, ros2: bool = False) -> InputError:
    if ros2:
        fix = (
            "give the bag's folder as `ros2 bag record` wrote it (metadata.yaml beside its "
            ".db3 or .mcap files); an .mcap file cut short is read as far as its whole "
            "records go (`mcap doctor`, Foxglove's tool, says what is wrong with it)"
        )
        return InputError([Problem.unreadable(file, f"a ROS 2 bag ({READ_HOW_2})", err, fix)])
    fix = (
        "give the bag as rosbag record wrote it (`rosbag check` and `rosbag reindex`, ROS "
        "1's tools, say what is wrong and mend an index)"
    )
    return InputError([Problem.unreadable(file, f"a ROS 1 bag ({READ_HOW})", err, fix)])


class _Refused(Exception):
    """``rosbags`` refused a closed ROS 1 bag or ROS 2 bag of MCAP or sqlite3 files as it
    opened or read it (a damaged chunk, summary, footer, index or page; a file cut short):
    :func:`read_bag` reads it again record by record, or page by page."""

    def __init__(self, err: BaseException, refusal: InputError) -> None:
        super().__init__(str(err))
        self.why = f"{type(err).__name__}: {str(err)[:120]}"
        self.refusal = refusal


class _ScannedNothing(Exception):
    """A bag :func:`read_bag` read again record by record holds no whole message either."""


def read_bag(path: Path, file: str, read: Callable[[Any], T]) -> T:
    """``read`` of the bag open (:func:`opened_bag`). A closed ROS 1 bag or ROS 2 bag of
    MCAP files that ``rosbags`` refuses (a chunk that fails its CRC or does not unpack, a
    summary, footer or index that does not parse: a disk's error) is read again from its
    start record by record (:class:`~rwhonet.data.bagscan.ScannedBag`,
    :class:`~rwhonet.data.mcapscan.ScannedMcap`, as a recording cut short is: a damaged
    chunk passed over, the notes saying why), and one of sqlite3 files page by page
    (:class:`~rwhonet.data.db3scan.ScannedDb3`); where that reads no message either, the
    bag is refused with ``rosbags``' own error."""
    try:
        with opened_bag(path, file) as bag:
            return read(bag)
    except _Refused as first:
        try:
            with opened_bag(path, file, refused=first.why) as bag:
                return read(bag)
        except _ScannedNothing:
            raise first.refusal from None


@contextlib.contextmanager
def opened_bag(path: Path, file: str, refused: str | None = None) -> Iterator[Any]:
    """The bag open for reading, once for all that is read of it: ``rosbags``'
    ``AnyReader``, or a :class:`~rwhonet.data.bagscan.ScannedBag` for a ROS 1 recording cut
    short. What fails as it opens, and what ``rosbags`` raises while it is read, is refused
    as the bag's (:func:`_unreadable`); anything else raised inside passes as it is. A
    closed ROS 1 bag or ROS 2 bag of MCAP or sqlite3 files ``rosbags`` refuses raises
    :class:`_Refused` (for :func:`read_bag`); ``refused`` (why it did) opens such a bag
    record by record (sqlite3: page by page). A sqlite3 file with a write-ahead log beside
    it (:func:`_logged_db3`) is read page by page from the start.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    from rwhonet.data.bagscan import ScannedBag, has_index
    from rwhonet.data.db3scan import ScannedDb3
    from rwhonet.data.mcapscan import ScannedMcap

    ros2 = _is_ros2(path)
    cut = path.is_dir() and not (path / METADATA).is_file()  # a ROS 2 folder cut short
    with contextlib.ExitStack() as stack:
        try:
            if not ros2 and (
                refused is not None or path.name.lower().endswith(UNFINISHED) or not has_index(path)
            ):
                # cut short, or refused closed: as far as it goes
                bag = stack.enter_context(ScannedBag(path, refused))
            elif ros2 and (unfinished := _unfinished_mcap(path, stack, file, refused)):
                # as far as each goes
                bag = stack.enter_context(ScannedMcap(unfinished, refused))
                if cut:
                    bag.said += f"; the folder has no {METADATA}"
            elif ros2 and (refused is not None or _logged_db3(path)):
                # sqlite3 files SQLite refused, or one with a write-ahead log beside it
                # (rosbags never reads one): page by page
                bag = stack.enter_context(ScannedDb3(_plain_storage(path, stack, file), refused))
                if cut:
                    bag.said += f"; the folder has no {METADATA}"
            else:
                # a ROS 2 bag recorded before Iron carries no message definitions: ROS's
                # own messages are known by the latest LTS's (their layouts have not changed)
                known = get_typestore(Stores.LATEST) if ros2 else None
                # cut short: its files alone
                files = _plain_storage(path, stack, file) if cut else [path]
                bag = stack.enter_context(AnyReader(files, default_typestore=known))
                if cut:
                    bag.said = (
                        f"the folder has no {METADATA} (a recording cut short: `ros2 bag "
                        f"reindex` writes it): its {len(files)} storage file(s) read alone "
                        f"({', '.join(p.name for p in files)})"
                    )
        except InputError:
            raise
        except (AnyReaderError, OSError, ValueError, KeyError, EOFError) as err:
            raise _refusal(path, file, err, ros2, refused) from None
        except Exception as err:  # rosbags' ReaderError, or what its reading met
            if _in_rosbags(err):
                raise _refusal(path, file, err, ros2, refused) from None
            raise
        try:
            yield bag
        except Exception as err:  # rosbags' reading and deserialisation errors
            if _in_rosbags(err):
                raise _refusal(path, file, err, ros2, refused) from None
            raise


def _refusal(
    path: Path, file: str, err: BaseException, ros2: bool, refused: str | None
) -> Exception:
    """The bag refused (:func:`_unreadable`), or, where ``rosbags`` refused a closed ROS 1
    bag (one that starts as a bag) or ROS 2 bag of MCAP or sqlite3 files (all of one kind)
    not yet read record by record, :class:`_Refused`; where such a bag read record by
    record holds no message, :class:`_ScannedNothing`."""
    from rwhonet.data.bagscan import MAGIC, NoWholeMessage

    if refused is not None and isinstance(err, NoWholeMessage):
        return _ScannedNothing()
    refusal = _unreadable(file, err, ros2)
    if refused is not None:
        return refusal
    if not ros2:
        if path.name.lower().endswith(UNFINISHED) or not path.is_file():
            return refusal  # read record by record already, or no file
        with open(path, "rb") as f:
            head = f.read(len(MAGIC))
        return _Refused(err, refusal) if head == MAGIC else refusal
    files = _storage_files(path) if path.is_dir() else [path]
    kinds = {Path(without_suffix(p.name)).suffix.lower() for p in files}
    return _Refused(err, refusal) if len(kinds) == 1 and kinds <= set(ROS2_FILES) else refusal


def _in_rosbags(err: BaseException) -> bool:
    """Whether an error is the bag's: ``rosbags``' own, or raised while ``rosbags`` read
    it (a damaged bag: an lz4 or bz2 chunk that does not decompress, a record that fails
    its own assertions, a name that is no UTF-8 text, an index naming no connection), not
    one of our own reading code's."""
    import traceback

    import rosbags

    if type(err).__module__.startswith("rosbags"):
        return True
    homes = tuple(str(Path(p)) for p in rosbags.__path__)  # a namespace package's folders
    frames = traceback.walk_tb(err.__traceback__)
    return any(f.f_code.co_filename.startswith(homes) for f, _ in frames)


def _logged_db3(path: Path) -> bool:
    """Whether a ROS 2 bag's sqlite3 file has a write-ahead log beside it that commits a
    page (:func:`rwhonet.data.db3scan.wal_beside`: a recorder stopped before SQLite moved
    its last pages into the file)."""
    from rwhonet.data.db3scan import wal_beside

    files = _storage_files(path) if path.is_dir() else [path]
    return any(p.suffix.lower() == ".db3" and wal_beside(p) is not None for p in files)


def _unfinished_mcap(
    path: Path, stack: contextlib.ExitStack, file: str, refused: str | None = None
) -> list[Path]:
    """A ROS 2 bag's MCAP files, in order, where one of them ends without its summary and
    footer (a recording cut short: :mod:`rwhonet.data.mcapscan`), or ``rosbags`` refused
    them (``refused``), those rosbag2 compressed as it closed them decompressed
    (:func:`_plain_storage`); none where every one is closed and ``rosbags`` reads them,
    or the bag's storage is sqlite3."""
    from rwhonet.data.mcapscan import is_finished

    files = _storage_files(path) if path.is_dir() else [path]
    if refused is None and not any(
        p.suffix.lower() == ".mcap" and not is_finished(p) for p in files
    ):
        return []
    return [p for p in _plain_storage(path, stack, file) if p.suffix.lower() == ".mcap"]


def _plain_storage(path: Path, stack: contextlib.ExitStack, file: str) -> list[Path]:
    """A ROS 2 bag's storage files read without its ``metadata.yaml``, in order: where
    rosbag2's file compression (``--compression-mode file``) compressed those it closed
    (``drive_0.mcap.zstd``; the one it was writing is not), each is decompressed into a
    scratch folder that lives as long as ``stack``."""
    import tempfile

    from rwhonet.data.compressed import compression_of, decompressed_copy

    files = _storage_files(path) if path.is_dir() else [path]
    out: list[Path] = []
    scratch = None
    for p in files:
        kind = compression_of(p)
        if kind is None:
            out.append(p)
            continue
        if scratch is None:
            scratch = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="rwhonet-bag-")))
        plain = scratch / without_suffix(p.name)
        shown = f"{file}/{p.name}" if path.is_dir() else file
        decompressed_copy(p, kind, plain, None, shown, "a ROS 2 bag's storage file")
        out.append(plain)
    return out


def read_rosbag(
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str,
    file: str,
) -> DriveStreams:
    """Read a drive's signals from a ROS 1 bag, or a ROS 2 bag's folder, into streams for
    ``resample`` (:func:`rosbag_groups`, every channel a topic's field).

    Raises:
        ConfigError: a channel that names no topic and field.
        InputError: as :func:`rosbag_groups`.
    """
    groups, notes = read_bag(
        path, file, lambda bag: rosbag_groups(bag, path, signal_map, radius_m, name, file)
    )
    streams = build_streams(groups, CLOCK, pulse_units(signal_map), fix_status_unit(signal_map))
    return dataclasses.replace(streams, notes=(*streams.notes, *notes))


def rosbag_groups(
    bag: Any,
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str,
    file: str,
) -> tuple[list[Group], list[str]]:
    """A bag's mapped topics' fields as channel groups, one a topic, and the notes.

    Args:
        bag: the bag, open (:func:`opened_bag`).
        path: the bag (a ROS 2 bag: its folder).
        signal_map: key -> ``/topic.field`` and unit (checked already:
            :func:`rwhonet.data.signalmap.check_signal_map`).
        radius_m: the car's nominal tyre radius, for wheel speeds given in m/s or km/h.
        name: how messages name the map.
        file: how messages name the bag.

    Raises:
        ConfigError: a channel that names no topic and field.
        InputError: the bag unreadable, a topic missing or of two types, its type not
            defined, a field missing or no number (every problem listed).
    """
    fields = _fields(signal_map, name)
    by_topic: dict[str, list[str]] = {}
    for key, f in fields.items():
        by_topic.setdefault(f.topic, []).append(key)
    read = _read_topics(bag, by_topic, fields, file)
    n_messages, n_topics = bag.message_count, len(bag.topics)
    carried = _carries_definitions(bag)
    said = getattr(bag, "said", "")  # a recording cut short, read as far as it goes
    ros2 = _is_ros2(path)
    kind, how = ("a ROS 2 bag", READ_HOW_2) if ros2 else ("a ROS 1 bag", READ_HOW)
    if ros2 and not path.is_dir():
        kind = f"a ROS 2 bag's {path.suffix.lstrip('.')} file (without its metadata.yaml)"
    how = getattr(bag, "how", how)  # a recording cut short, read record by record
    notes = [
        f"{file}: {kind} of {n_messages} messages on {n_topics} topic(s); read {len(read)} "
        f"of them ({how}"
        + ("" if carried else "; the bag carries no message definitions: ROS's own types")
        + ")"
    ]
    if said:
        notes.append(f"{file}: {said}")
    groups = []
    for topic in read:
        group, told = _group(topic, fields, signal_map, radius_m, file)
        groups.append(group)
        notes += told
    return groups, notes


# A topic of raw CAN frames: socketcan_bridge's and ros2_socketcan's can_msgs/Frame (id,
# is_extended, is_error, is_rtr, dlc, data[8]), Dataspeed's CanMessageStamped (its msg:
# id, extended, dlc, data[8])
_CAN_FIELDS = ({"id", "dlc", "data", "is_extended"}, {"id", "dlc", "data", "extended"})
FRAME_BATCH = 100_000  # a bag's CAN frames held as Python objects at once


def _frame_of(fields: dict[str, Any], msgtype: str) -> str | None:
    """Where a message type holds a CAN frame: ``""`` (its own fields), ``"msg"`` (a
    stamped wrapper's), or None (no frame)."""
    own = {n for n, _ in fields[msgtype][1]}
    if any(need <= own for need in _CAN_FIELDS):
        return ""
    inner = dict(fields[msgtype][1]).get("msg")  # (node type, the type's name)
    name = inner[1] if isinstance(inner, tuple) and len(inner) == 2 else None
    if isinstance(name, str) and name in fields and _frame_of(fields, name) == "":
        return "msg"
    return None


def _can_topics(bag: Any) -> list[tuple[str, str]]:
    """The bag's topics of raw CAN frames and their types."""
    defs = bag.typestore.fielddefs
    found = {(c.topic, c.msgtype) for c in bag.connections if c.msgtype in defs}
    return sorted((t, m) for t, m in found if _frame_of(defs, m) is not None)


def bag_frames(bag: Any, file: str, keep: FrameFilter | None = None) -> Frames:
    """The raw CAN frames a bag's topics of them hold, each topic a bus (named by it), in
    the bag's order, as a CAN log's (:class:`~rwhonet.data.canlog.Frames`): timed by their
    header stamps, else by the times the bag recorded them; error and remote frames passed
    over, counted; with ``keep``, the frames of other messages counted and left out as the
    bag is read. ``bag``: the bag, open (:func:`opened_bag`).

    Raises:
        InputError: no topic of CAN frames, or no data frame in them.
    """
    from rwhonet.data.canlog import Frames, too_many
    from rwhonet.data.keptframes import ID_MASK, Kept, TooManyFrames

    topics = _can_topics(bag)
    if not topics:
        listed = ", ".join(f"{c.topic} ({c.msgtype})" for c in bag.connections)
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a topic of raw CAN frames (can_msgs/Frame, dataspeed_can_msgs/"
                    "CanMessageStamped) for the map's dbc to decode",
                    f"none; its topics: {listed or 'none'}",
                    "record the bus's frames (socketcan_bridge, ros2_socketcan), or map "
                    "the topics a driver decoded",
                )
            ]
        )
    kept = None if keep is None else Kept(keep)
    bus = {t: k for k, (t, _) in enumerate(topics)}
    parts: list[dict[str, np.ndarray]] = []
    # a damaged message of a bag read record by record: passed over, as _read_topics does
    skipped = {"error frames": 0, "remote frames": 0, "damaged messages": 0}
    rows = 0
    defs = bag.typestore.fielddefs
    where = {m: _frame_of(defs, m) for _, m in topics}
    taken = set(topics)
    cons = [c for c in bag.connections if (c.topic, c.msgtype) in taken]
    said = getattr(bag, "said", "")  # a recording cut short, read as far as it goes
    batch: dict[str, list[Any]] = {k: [] for k in ("t", "id", "ext", "data", "code", "row")}

    def flush() -> None:
        ids = np.asarray(batch["id"], np.int64) & ID_MASK
        ext = np.asarray(batch["ext"], bool)
        code = np.asarray(batch["code"], np.int64)
        try:
            at = np.arange(ids.size) if kept is None else kept.part(ids, ext, code)
        except TooManyFrames as err:  # more of the map's messages than max_mb holds
            raise InputError([too_many(file, err)]) from None
        data = [batch["data"][i] for i in at.tolist()]
        lengths = np.array([len(d) for d in data], np.int64)
        table = np.zeros((len(data), 8), np.uint8)
        for i, d in enumerate(data):
            table[i, : len(d)] = np.frombuffer(d, np.uint8)
        parts.append(
            {
                "t": np.asarray(batch["t"], np.int64)[at],
                "id": ids[at].astype(np.uint32),
                "ext": ext[at],
                "len": lengths.astype(np.uint8),
                "data": table,
                "code": code[at],
                "row": np.asarray(batch["row"], np.int64)[at],
            }
        )
        for v in batch.values():
            v.clear()

    for con, recorded_ns, raw in bag.messages(connections=cons):
        rows += 1
        if (msg := _deserialised(bag, raw, con.msgtype)) is None:
            skipped["damaged messages"] += 1
            continue
        frame = msg.msg if where[con.msgtype] == "msg" else msg
        if getattr(frame, "is_error", False):
            skipped["error frames"] += 1
            continue
        if getattr(frame, "is_rtr", False):
            skipped["remote frames"] += 1
            continue
        stamp = _stamp_ns(msg)
        batch["t"].append(recorded_ns if not stamp else stamp)
        batch["id"].append(int(frame.id))
        ext = frame.is_extended if hasattr(frame, "is_extended") else frame.extended
        batch["ext"].append(bool(ext))
        n = min(int(frame.dlc), len(frame.data))
        batch["data"].append(bytes(np.asarray(frame.data, np.uint8)[:n]))
        batch["code"].append(bus[con.topic])
        batch["row"].append(rows)
        if len(batch["t"]) >= FRAME_BATCH:
            flush()
    flush()
    passed = ", ".join(f"{v} {k}" for k, v in skipped.items() if v)
    if rows == sum(skipped.values()):  # as a CAN log without a data frame is refused
        listed = ", ".join(t for t, _ in topics)
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"CAN data frames in the bag's topics of them ({listed})",
                    f"none ({passed or 'no message'})",
                    "give the drive's bag with its bus recorded, or map decoded topics",
                )
            ]
        )
    got = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    channel = (got["code"] + 1).astype(np.uint8) if kept is None else kept.channel(got["code"])
    names = [t for t, _ in topics] if kept is None else [topics[int(b)][0] for b in kept.buses]
    return Frames(
        got["t"] / 1e9,
        got["id"],
        got["ext"],
        got["len"],
        got["data"],
        channel,
        names,
        f"the bag's CAN frames' header stamps, else their record times ({CLOCK})"
        + (f"; {said}" if said else ""),
        got["row"],
        passed,
        **({} if kept is None else {"dropped": kept.dropped, "log_ids": kept.log_ids()}),
    )


def _deserialised(bag: Any, raw: bytes, msgtype: str) -> Any:
    """A message deserialised; None where it is damaged: a bag read record by record (cut
    short, or refused closed) whose message ``rosbags`` cannot deserialise, passed over and
    counted by the caller. Read by its index, such a message is the bag's refusal."""
    try:
        return bag.deserialize(raw, msgtype)
    except Exception as err:
        if not getattr(bag, "scanned", False) or not _in_rosbags(err):
            raise
        return None


def _read_topics(
    bag: Any, by_topic: Mapping[str, list[str]], fields: Mapping[str, Field], file: str
) -> list[_Topic]:
    """The mapped topics' samples, each topic's messages in the bag's order."""
    present: dict[str, list[Any]] = {}
    for con in bag.connections:
        present.setdefault(con.topic, []).append(con)
    unknown = sorted(
        {c.msgtype for t in by_topic if t in present for c in present[t]}
        - set(bag.typestore.fielddefs)
    )
    if unknown:
        raise InputError([_no_definition(file, t) for t in unknown])
    listed = ", ".join(
        f"{t} ({', '.join(sorted({c.msgtype for c in cons}))})"
        for t, cons in sorted(present.items())
    )
    problems = []
    for topic, keys in by_topic.items():
        if topic not in present:
            problems += [
                Problem(
                    file,
                    None,
                    fields[k].text,
                    f"a topic {topic} in the bag",
                    f"none; its topics: {listed or 'none'}",
                    "name the topic as `rosbag info` lists it",
                )
                for k in keys
            ]
        elif len(types := sorted({c.msgtype for c in present[topic]})) > 1:
            problems.append(
                Problem(
                    file,
                    None,
                    topic,
                    "one message type a topic",
                    f"{' and '.join(types)}",
                    "record each sensor's messages on a topic of their own",
                )
            )
    if problems:
        raise InputError(problems)
    out = []
    for topic, keys in by_topic.items():
        cons = present[topic]
        msgtype = cons[0].msgtype
        t = _Topic(topic, msgtype, keys, {k: [] for k in keys}, [], [], [], dict.fromkeys(keys, 0))
        fix = "lat" in keys or "lon" in keys
        getters: dict[str, tuple[Any, bool]] = {}
        stamp = status = accuracy = None
        for con, recorded_ns, raw in bag.messages(connections=cons):
            if (msg := _deserialised(bag, raw, con.msgtype)) is None:
                t.damaged += 1
                continue
            if not t.recorded:  # the first message: every field checked, then read as it
                for k in keys:
                    try:
                        v = _value(msg, fields[k].path)
                    except _Missing as miss:
                        raise InputError([_no_field(file, fields[k], msg, miss)]) from None
                    if not _is_number(v):
                        raise InputError([_not_a_number(file, fields[k], msgtype, v, 0)])
                    getters[k] = _getter(fields[k].path)
                stamp = _stamp_getter(msg)
                status = _status_getter(msg) if fix else None
                # the fixes' stated accuracy, where the map names none of its own
                accuracy = _accuracy_getter(msg) if fix and "h_acc" not in fields else None
            for k, (get, indexed) in getters.items():
                if indexed:
                    try:
                        v = get(msg)
                    except IndexError:
                        t.past_end[k] += 1
                        v = np.nan
                    t.values[k].append(v)
                else:
                    t.values[k].append(get(msg))
            t.stamps.append(None if stamp is None else stamp(msg))
            t.recorded.append(recorded_ns)
            if status is not None:
                t.status.append(status(msg))
            if accuracy is not None:
                t.h_acc.append(accuracy(msg))
        out.append(t)
    return out


# a message whose header stamp stands this far from where its neighbours' stand against
# the bag's record times is damaged, where it stands so alone (_damaged_values)
STAMP_JUMP_S = 1.0
STAMP_NEIGHBOURS = 31  # the messages (centred) whose median says where they stand
# such messages passed over at most (and at least 3): more are a clock's or a map's doing
DAMAGED_MAX = 0.01


def _damaged_values(
    t_ns: np.ndarray, recorded: np.ndarray, channels: Mapping[str, np.ndarray], stamped: bool
) -> tuple[np.ndarray, str]:
    """Which messages of a topic to keep, and what the notes say of the others: a message
    whose value no message can hold, alone among its neighbours, is damaged (a flipped bit:
    a ROS 1 chunk, an unchunked MCAP message and an sqlite3 page have no checksum, and
    ``rosbags`` reads such a bag as it is), and passed over where until stop 90 it refused
    the drive. Such a value is a latitude beyond ±90° or a longitude beyond ±180° (or
    infinite), or a header stamp (``stamped``) that stands more than
    :data:`STAMP_JUMP_S` from the bag's record time where the median of its
    :data:`STAMP_NEIGHBOURS` neighbours' stands (a transport's delay moves them together;
    a bit of the stamp or of the record time moves one) and out of order with the stamps
    beside it (the stamp's bit: a record time's alone leaves the stamp in its place, and
    the message is kept). Alone: neither message beside it is so; and at most
    :data:`DAMAGED_MAX` of the topic's messages (at least 3) are. Otherwise they are the
    map's or the clock's doing (every fix's latitude in 1e-7 deg, a clock stepped), left
    to the checks that refuse them, saying why."""
    import pandas as pd

    n = t_ns.size
    most = max(3, int(DAMAGED_MAX * n))
    bad = np.zeros(n, bool)
    parts = []
    kinds: list[tuple[str, np.ndarray]] = []
    for k, limit, what in (
        ("lat", 90.0, "a latitude beyond ±90°"),
        ("lon", 180.0, "a longitude beyond ±180°"),
    ):
        if k in channels:
            v = channels[k]
            kinds.append((what, np.abs(np.nan_to_num(v)) > limit))  # inf: the largest
    if stamped and n:
        offset = (t_ns - recorded) / 1e9
        where = pd.Series(offset).rolling(STAMP_NEIGHBOURS, center=True, min_periods=1).median()
        jump = np.abs(offset - where.to_numpy()) > STAMP_JUMP_S
        # the stamp's bit, not the record time's: a stamp out of order with those beside it
        after_last = np.r_[True, t_ns[1:] > t_ns[:-1]]
        before_next = np.r_[t_ns[:-1] < t_ns[1:], True]
        jump &= ~(after_last & before_next)
        kinds.append(
            (
                f"a header stamp more than {STAMP_JUMP_S:g} s from the bag's record time "
                "where its neighbours' stand",
                jump,
            )
        )
    for what, odd in kinds:
        side_by_side = odd[1:] & odd[:-1]
        if odd.any() and not side_by_side.any() and odd.sum() <= most:
            bad |= odd
            parts.append(f"{int(odd.sum())} with {what}")
    if not bad.any():
        return ~bad, ""
    return ~bad, (
        f"{int(bad.sum())} damaged message(s) whose value no message holds, each alone among "
        f"its neighbours ({'; '.join(parts)}: a flipped bit), passed over"
    )


def _carries_definitions(bag: Any) -> bool:
    from rosbags.interfaces import MessageDefinitionFormat

    return any(c.msgdef.format != MessageDefinitionFormat.NONE for c in bag.connections)


def _no_definition(file: str, msgtype: str) -> Problem:
    """A mapped topic's type the bag does not define and ROS's own types do not hold."""
    return Problem(
        file,
        None,
        None,
        f"the definition of {msgtype}, a mapped topic's message type (a bag carries its "
        "types' definitions; ROS's own are known here)",
        "none in the bag (a ROS 2 bag recorded before Iron carries none)",
        "record the drive with ROS 2 Iron or later, or with mcap storage, which keep the "
        "definitions; or give it as a ROS 1 bag (`rosbags-convert`)",
    )


def _getter(path: tuple[str | int, ...]) -> tuple[Any, bool]:
    """A field's reader for every message of a topic (its path checked on the first), and
    whether it indexes an array (which a later message may hold fewer of)."""
    if all(isinstance(step, str) for step in path):
        return operator.attrgetter(".".join(path)), False  # type: ignore[arg-type]

    def get(msg: Any) -> Any:
        obj = msg
        for step in path:
            obj = obj[step] if isinstance(step, int) else getattr(obj, step)
        return obj

    return get, True


def _stamp_getter(msg: Any) -> Any:
    """A reader of a message's ``header.stamp`` in ns (None: its type has no header)."""
    if _stamp_ns(msg) is None:
        return None
    sec, nanosec = operator.attrgetter("header.stamp.sec", "header.stamp.nanosec")(msg)
    if not (_is_number(sec) and _is_number(nanosec)):
        return None
    return _stamp_ns


def _status_getter(msg: Any) -> Any:
    """A reader of a fix message's ``status.status`` (None: its type has none)."""
    return _fix_status if np.isfinite(_fix_status(msg)) else None


# NavSatFix's position_covariance_type (GPSFix's the same): 0 COVARIANCE_TYPE_UNKNOWN, the
# covariance not filled in; 1 APPROXIMATED, 2 DIAGONAL_KNOWN, 3 KNOWN
COVARIANCE_TYPE_UNKNOWN = 0


def _h_acc_m(msg: Any) -> float:
    """A fix message's stated horizontal accuracy, m: the root of the sum of its
    ``position_covariance``'s east and north variances (row-major ENU, m²: ``[0]`` and
    ``[4]``), the DRMS; NaN where its ``position_covariance_type`` is unknown (0) or either
    variance is not a finite number, or negative."""
    kind, cov = msg.position_covariance_type, msg.position_covariance
    if not _is_number(kind) or int(kind) == COVARIANCE_TYPE_UNKNOWN or len(cov) < 5:
        return np.nan
    east, north = cov[0], cov[4]
    if not (_is_number(east) and _is_number(north)):
        return np.nan
    east, north = float(east), float(north)
    ok = math.isfinite(east) and math.isfinite(north) and east >= 0.0 and north >= 0.0
    return math.sqrt(east + north) if ok else np.nan


def _accuracy_getter(msg: Any) -> Any:
    """A reader of a fix message's stated accuracy (:func:`_h_acc_m`; None: its type has no
    ``position_covariance`` and ``position_covariance_type``)."""
    names = _names(msg)
    has = "position_covariance" in names and "position_covariance_type" in names
    return _h_acc_m if has else None


def _no_field(file: str, f: Field, msg: Any, miss: _Missing) -> Problem:
    at = miss.at
    if isinstance(miss.step, int):
        found = f"{_type_name(at)} of {len(at) if hasattr(at, '__len__') else 0} element(s)"
        expected = f"an element [{miss.step}]"
    else:
        have = _names(at)
        found = (
            f"{_type_name(at)}, whose fields are {', '.join(have)}"
            if have
            else f"{_type_name(at)}, which has no fields"
        )
        expected = f"a field {miss.step!r}"
    return Problem(
        file,
        1,
        f.text,
        f"{expected} in the messages of {f.topic} ({_type_name(msg)})",
        found,
        "name the field as `rosmsg show` gives the type (/topic.field.sub[index])",
    )


def _not_a_number(file: str, f: Field, msgtype: str, v: Any, row: int) -> Problem:
    shown = repr(v) if isinstance(v, str) else _type_name(v)
    return Problem(
        file,
        row + 1,
        f.text,
        f"a number in the messages of {f.topic} ({msgtype})",
        shown[:80],
        "map a numeric field (a message's own fields: /topic.field.sub)",
    )


def _group(
    t: _Topic,
    fields: Mapping[str, Field],
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    file: str,
) -> tuple[Group, list[str]]:
    """One topic's samples as a channel group, on its stamps or its record times."""
    n = len(t.recorded)
    stamps = t.stamps
    zero = sum(1 for s in stamps if s == 0)
    if n and all(s is not None for s in stamps) and zero == 0:
        t_ns = np.array(stamps, dtype=np.int64)
        how = "on their header stamps"
    else:
        t_ns = np.array(t.recorded, dtype=np.int64)
        how = (
            "on the times the bag recorded them (the type has no header)"
            if any(s is None for s in stamps) or not n
            else f"on the times the bag recorded them ({zero} of the header stamps are zero)"
        )
    t_s = t_ns / 1e9
    channels = {}
    for k in t.keys:
        where = f"{file} [{fields[k].text}]"
        values = np.array(t.values[k], dtype=np.float64)
        values = scaled(values, signal_map[k])  # a raw integer field: ublox_msgs' 1e-7 deg
        channels[k] = to_si(k, values, signal_map[k].unit, radius_m, where, (file, fields[k].text))
    said = [f"{file}: {t.topic}: {n} message(s) ({t.msgtype}), {how}"]
    recorded = np.array(t.recorded, dtype=np.int64)
    keep, told = _damaged_values(t_ns, recorded, channels, how.startswith("on their header"))
    if told:
        said.append(f"{file}: {t.topic}: {told}")
        t_s = t_s[keep]
        channels = {k: v[keep] for k, v in channels.items()}
    if t.status:
        status = np.array(t.status)[keep]
        no_fix = status < 0
        if no_fix.any():
            for k in ("lat", "lon"):
                if k in channels:
                    channels[k] = np.where(no_fix, np.nan, channels[k])
            said.append(
                f"{file}: {t.topic}: {int(no_fix.sum())} message(s) with status.status below 0 "
                "(no fix): no position"
            )
    said += [
        f"{file}: {fields[k].text}: {c} message(s) whose array has no such element: no value"
        for k, c in t.past_end.items()
        if c
    ]
    if t.damaged:
        said.append(
            f"{file}: {t.topic}: {t.damaged} damaged message(s) that rosbags cannot "
            f"deserialise as {t.msgtype}, passed over"
        )
    sources = {k: fields[k].text for k in t.keys}
    h_acc = np.array(t.h_acc, dtype=np.float64)[keep] if t.h_acc else np.array([])
    if h_acc.size and np.isfinite(h_acc).any():  # a topic that states none has none
        channels["h_acc"] = h_acc
        sources["h_acc"] = f"{t.topic}.position_covariance"
        said.append(
            f"{file}: {t.topic}: h_acc from position_covariance, the root of its east and "
            f"north variances, on {int(np.isfinite(h_acc).sum())} of {n} message(s)"
        )
    sources["t"] = f"{t.topic} header.stamp" if how.startswith("on their header") else t.topic
    # messages' numbers in the topic, 1-based, where damaged ones were passed over
    rows = None if keep.all() else np.flatnonzero(keep) + 1
    return Group(t.topic, file, t_s, channels, sources, rows), said
