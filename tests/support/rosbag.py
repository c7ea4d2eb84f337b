"""ROS 1 bags as a car running ROS records them, written with ``rosbags``' writer: a
drive-by-wire kit's wheel speeds (Dataspeed's ``dbw_mkz_msgs/WheelSpeedReport``, whose
definition the bag carries), the receiver's ``sensor_msgs/NavSatFix`` and an IMU's
``sensor_msgs/Imu``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c

WHEEL_TOPIC, FIX_TOPIC, IMU_TOPIC = "/vehicle/wheel_speed_report", "/vehicle/gps/fix", "/imu/data"
WHEEL_SPEED_REPORT = "dbw_mkz_msgs/msg/WheelSpeedReport"
# Dataspeed's message (dbw_mkz_msgs, BSD): the four wheels' speeds, rad/s
WHEEL_SPEED_DEF = """std_msgs/Header header
float32 front_left
float32 front_right
float32 rear_left
float32 rear_right
"""
NO_HEADER = "rwhonet_test/msg/Wheels"  # a kit's type without a header
NO_HEADER_DEF = "float64 fl\nfloat64 fr\nfloat64 rl\nfloat64 rr\n"


def typestore(ros2: bool = False):  # type: ignore[no-untyped-def]
    """ROS Noetic's (or ROS 2 Humble's) types and the kits' wheel-speed types."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    ts.register(get_types_from_msg(WHEEL_SPEED_DEF, WHEEL_SPEED_REPORT))
    ts.register(get_types_from_msg(NO_HEADER_DEF, NO_HEADER))
    return ts


def _ns(t_s: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64)


def _header(ts, seq: int, t_ns: int, stamped: bool = True):  # type: ignore[no-untyped-def]
    h, time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    t_ns = t_ns if stamped else 0
    stamp = time(sec=t_ns // 10**9, nanosec=t_ns % 10**9)
    if "seq" not in h.__dataclass_fields__:  # ROS 2's header has none
        return h(stamp=stamp, frame_id="")
    return h(seq=seq, stamp=stamp, frame_id="")


def write_bag(
    path: Path,
    wheels: tuple[np.ndarray, np.ndarray] | None,
    fixes: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    yaw: tuple[np.ndarray, np.ndarray] | None = None,
    status: np.ndarray | None = None,
    lag_ns: int = 0,
    stamped: bool = True,
    wheel_type: str = WHEEL_SPEED_REPORT,
    extra: Sequence[tuple[str, str, list[tuple[int, object]]]] = (),
    msgdefs: dict[str, str] | None = None,
    ros2: str | None = None,
    compression: str | None = None,
    chunk_bytes: int = 1 << 20,
    covariance: np.ndarray | None = None,
    covariance_type: np.ndarray | int = 0,
) -> Path:
    """A bag of a drive's streams, each message recorded ``lag_ns`` after its stamp.

    Args:
        wheels: times (s) and the four wheels' speeds (rad/s, n x 4).
        fixes: times, latitudes, longitudes (degrees).
        yaw: times and the yaw rate (rad/s, z up).
        status: each fix's NavSatStatus status (default 0, a fix).
        covariance: each fix's position_covariance (n x 9, ENU, m²; default zeros).
        covariance_type: each fix's position_covariance_type (default 0, UNKNOWN).
        stamped: False: every header stamp zero (a driver that does not stamp).
        wheel_type: :data:`WHEEL_SPEED_REPORT` or :data:`NO_HEADER`.
        extra: more topics: name, type, (record time ns, message) pairs.
        msgdefs: more message types (name -> definition), for ``extra``.
        ros2: a ROS 2 bag's folder (``path``) in this storage (``sqlite3``, ``mcap``), as
            ``ros2 bag record`` writes it (format 9, the types' definitions in it); None: a
            ROS 1 bag.
        compression: a ROS 1 bag's chunks compressed so (``bz2``, ``lz4``); a ROS 2 mcap
            bag's (``zstd``).
        chunk_bytes: a ROS 1 bag's chunks' size (rosbags' 1 MB; rosbag record's 768 KB).
    """
    ts = typestore(ros2 is not None)
    if ros2 is None:
        from rosbags.rosbag1 import Writer

        def writer():  # type: ignore[no-untyped-def]
            w = Writer(path)
            w.chunk_threshold = chunk_bytes
            if compression:
                w.set_compression(Writer.CompressionFormat[compression.upper()])
            return w

        def serialize(msg, msgtype):  # type: ignore[no-untyped-def]
            return ts.serialize_ros1(msg, msgtype)
    else:
        from rosbags.rosbag2 import StoragePlugin
        from rosbags.rosbag2 import Writer as Writer2

        def writer():  # type: ignore[no-untyped-def]
            w = Writer2(path, version=9, storage_plugin=StoragePlugin[ros2.upper()])
            if compression:  # mcap's chunks compressed (rosbag2's zstd presets)
                from rosbags.rosbag2 import CompressionFormat, CompressionMode

                w.set_compression(CompressionMode.STORAGE, CompressionFormat[compression.upper()])
            return w

        def serialize(msg, msgtype):  # type: ignore[no-untyped-def]
            return ts.serialize_cdr(msg, msgtype)

    if msgdefs:
        from rosbags.typesys import get_types_from_msg

        for name, text in msgdefs.items():
            ts.register(get_types_from_msg(text, name))
    path.parent.mkdir(parents=True, exist_ok=True)
    records: list[tuple[int, int, bytes]] = []  # record time, connection, bytes
    with writer() as w:
        cons = []

        def add(topic: str, msgtype: str) -> int:
            cons.append(w.add_connection(topic, msgtype, typestore=ts))
            return len(cons) - 1

        if wheels is not None:
            k = add(WHEEL_TOPIC, wheel_type)
            t, v = _ns(wheels[0]), np.asarray(wheels[1], dtype=np.float64)
            cls = ts.types[wheel_type]
            for i in range(t.size):
                if wheel_type == WHEEL_SPEED_REPORT:
                    msg = cls(_header(ts, i, int(t[i]), stamped), *map(float, v[i]))
                else:
                    msg = cls(*map(float, v[i]))
                records.append((int(t[i]) + lag_ns, k, serialize(msg, wheel_type)))
        if fixes is not None:
            k = add(FIX_TOPIC, "sensor_msgs/msg/NavSatFix")
            nav, st = (
                ts.types["sensor_msgs/msg/NavSatFix"],
                ts.types["sensor_msgs/msg/NavSatStatus"],
            )
            t = _ns(fixes[0])
            codes = np.zeros(t.size, dtype=int) if status is None else status
            cov = np.zeros((t.size, 9)) if covariance is None else np.asarray(covariance, float)
            kinds = np.broadcast_to(np.asarray(covariance_type, dtype=int), (t.size,))
            for i in range(t.size):
                msg = nav(
                    _header(ts, i, int(t[i]), stamped),
                    st(status=int(codes[i]), service=1),
                    float(fixes[1][i]),
                    float(fixes[2][i]),
                    100.0,
                    cov[i].copy(),
                    int(kinds[i]),
                )
                records.append((int(t[i]) + lag_ns, k, serialize(msg, nav.__msgtype__)))
        if yaw is not None:
            k = add(IMU_TOPIC, "sensor_msgs/msg/Imu")
            imu, v3 = ts.types["sensor_msgs/msg/Imu"], ts.types["geometry_msgs/msg/Vector3"]
            q = ts.types["geometry_msgs/msg/Quaternion"]
            t = _ns(yaw[0])
            for i in range(t.size):
                msg = imu(
                    _header(ts, i, int(t[i]), stamped),
                    q(0.0, 0.0, 0.0, 1.0),
                    np.zeros(9),
                    v3(0.0, 0.0, float(yaw[1][i])),
                    np.zeros(9),
                    v3(0.0, 0.0, 9.81),
                    np.zeros(9),
                )
                records.append((int(t[i]) + lag_ns, k, serialize(msg, imu.__msgtype__)))
        for topic, msgtype, messages in extra:
            k = add(topic, msgtype)
            records += [(t, k, serialize(m, msgtype)) for t, m in messages]
        for t_rec, k, raw in sorted(records, key=lambda r: r[0]):  # a recorder's order
            w.write(cons[k], t_rec, raw)
    return path


def bag_map(yaw: bool = False, wheel_unit: str = "rad/s") -> dict[str, ColumnSpec]:
    """The signal map of :func:`write_bag`'s topics."""
    names = ("front_left", "front_right", "rear_left", "rear_right")
    smap = {
        f"omega_{w}": ColumnSpec(f"{WHEEL_TOPIC}.{n}", wheel_unit)
        for w, n in zip(("fl", "fr", "rl", "rr"), names, strict=True)
    }
    smap |= {
        "lat": ColumnSpec(f"{FIX_TOPIC}.latitude", "deg"),
        "lon": ColumnSpec(f"{FIX_TOPIC}.longitude", "deg"),
    }
    if yaw:
        smap["yaw_rate"] = ColumnSpec(f"{IMU_TOPIC}.angular_velocity.z", "rad/s")
    return smap


def tables_bag(path: Path, tables, **kw) -> Path:  # type: ignore[no-untyped-def]
    """A simulated drive's streams (``rwhonet.sim.streams.StreamTables``) as a bag."""
    w = tables.wheels
    wheels = (w[c.T_S].to_numpy(), w[list(c.WHEELS)].to_numpy())
    g = tables.gnss
    fixes = (g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    yaw = None
    if tables.gyro is not None:
        yaw = (tables.gyro[c.T_S].to_numpy(), tables.gyro[c.YAW_RATE_RAD_S].to_numpy())
    return write_bag(path, wheels, fixes, yaw, **kw)


CAN_FRAME = "can_msgs/msg/Frame"  # socketcan_bridge's (can_msgs, BSD)
CAN_FRAME_DEF = (
    "std_msgs/Header header\nuint32 id\nbool is_rtr\nbool is_extended\nbool is_error\n"
    "uint8 dlc\nuint8[8] data\n"
)
CAN_TOPIC = "/can_tx"


def can_messages(  # type: ignore[no-untyped-def]
    stamps, ids, data, ros2: bool = False, every_error: int = 0, lag_ns: int = 0, lengths=None
):
    """Raw CAN frames (``support.canlog.stream_frames``) as can_msgs/Frame messages, each
    stamped at its time and recorded ``lag_ns`` later; with ``every_error``, an error frame
    and a remote frame after every that many; ``lengths``: each frame's dlc (default 8)."""
    from rosbags.typesys import get_types_from_msg

    ts = typestore(ros2)
    ts.register(get_types_from_msg(CAN_FRAME_DEF, CAN_FRAME))
    frame = ts.types[CAN_FRAME]
    out = []
    for i, (t, ident, d) in enumerate(zip(_ns(stamps).tolist(), ids.tolist(), data, strict=True)):
        h = _header(ts, i, t)
        n = 8 if lengths is None else int(lengths[i])
        r = t + lag_ns
        out.append((r, frame(h, int(ident), False, False, False, n, np.asarray(d, np.uint8))))
        if every_error and i % every_error == 0:
            out.append((r, frame(h, 0, False, False, True, 0, np.zeros(8, np.uint8))))
            out.append((r, frame(h, int(ident), True, False, False, 8, np.zeros(8, np.uint8))))
    return out
