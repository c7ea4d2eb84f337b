"""A ROS 1 bag (``rwhonet.data.rosbag``): the topics' fields a signal map names give the
labels of the same samples in stream CSVs."""

from __future__ import annotations

import dataclasses
import gzip
import shutil

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.mdf4 import read_mdf4
from rwhonet.data.rosbag import field_of, is_rosbag_name
from rwhonet.data.streamcsv import read_stream_csvs
from rwhonet.data.streams import resample
from rwhonet.errors import InputError
from support.multirate import per_second, simulated_streams
from support.rosbag import (
    FIX_TOPIC,
    IMU_TOPIC,
    NO_HEADER,
    WHEEL_TOPIC,
    bag_map,
    tables_bag,
    typestore,
    write_bag,
)


def _float32_wheels(tables):
    """The streams with the wheel speeds as a float32 message field holds them."""
    from rwhonet.sim.streams import StreamTables

    w = tables.wheels.copy()
    for k in c.WHEELS:
        w[k] = w[k].to_numpy().astype(np.float32).astype(np.float64)
    return StreamTables(w, tables.gnss, tables.gyro)


def _drive():
    tables, radius = simulated_streams(120.0, 100.0, 10.0, gyro_hz=50.0)
    return _float32_wheels(tables), radius


def _grid(streams, radius):
    return resample(streams, nominal_radius_m=radius).drive.columns


def test_names():
    assert field_of("/vehicle/gps/fix.latitude").topic == "/vehicle/gps/fix"
    assert field_of("/imu/data.angular_velocity.z").path == ("angular_velocity", "z")
    assert field_of(" /joint_states.velocity[2] ").path == ("velocity", 2)
    assert field_of("/m.data[1][0].x").path == ("data", 1, 0, "x")
    assert field_of("gps/fix.latitude").topic == "/gps/fix"  # as rosbags names it
    for bad in ("/gps/fix", "/gps/fix.", "/gps/fix.lat itude", "/a.b[x]", ".latitude", "/a.1b"):
        assert field_of(bad) is None, bad
    assert is_rosbag_name("drive.BAG") and is_rosbag_name("d.bag.gz")
    assert is_rosbag_name("d.bag.active") and not is_rosbag_name("bag.csv")


def test_a_bag_gives_the_labels_and_yaw_rate_of_the_same_streams_in_csvs(tmp_path):
    """A 120 s simulated drive (100 Hz wheels in a Dataspeed WheelSpeedReport, 10 Hz
    NavSatFix fixes, a 50 Hz IMU), each message stamped by its header and recorded 30 ms
    later: the grid of the same streams in stream CSVs within 1e-7 (the stamps are whole
    ns: 5e-9 rad/s moved), the labels within 0.1 um; each topic a stream, on its stamps."""
    from rwhonet.sim.streams import signal_map, write_stream_csvs

    tables, radius = _drive()
    files = write_stream_csvs(tables, tmp_path / "csv")
    want = _grid(read_stream_csvs(list(files.values()), signal_map(gyro=True), radius), radius)
    bag = tables_bag(tmp_path / "drive.bag", tables, lag_ns=30_000_000)
    streams = read_mdf4(bag, bag_map(yaw=True), radius, "map.yaml", "drive.bag")
    got = _grid(streams, radius)
    assert got[c.T_S].size == want[c.T_S].size > 1000
    for k in (c.T_S, *c.WHEELS, c.LAT_DEG, c.LON_DEG, c.YAW_RATE_RAD_S):
        np.testing.assert_allclose(got[k], want[k], rtol=0, atol=1e-7, err_msg=k)
    a, b = per_second(got, radius), per_second(want, radius)
    assert len(a) == len(b) > 100
    np.testing.assert_allclose(a["label_m"], b["label_m"], rtol=0, atol=1e-7)
    said = "\n".join(streams.notes)
    assert f"a ROS 1 bag of {tables.n_rows} messages on 3 topic(s); read 3 of them" in said
    n = len(tables.wheels)
    kit = "dbw_mkz_msgs/msg/WheelSpeedReport"
    assert f"{WHEEL_TOPIC}: {n} message(s) ({kit}), on their header stamps" in said
    assert f"{FIX_TOPIC}: {len(tables.gnss)} message(s) (sensor_msgs/msg/NavSatFix)" in said
    assert [s.name for s in streams.streams] == [WHEEL_TOPIC, FIX_TOPIC, IMU_TOPIC]
    assert streams.gnss.sources[c.LAT_DEG] == f"{FIX_TOPIC}.latitude"
    assert streams.gnss.sources[c.T_S] == f"{FIX_TOPIC} header.stamp"


def test_without_stamps_a_topic_is_timed_by_the_bag_s_record_times(tmp_path):
    """Wheels of a type without a header, fixes whose stamps are zero: each on the times
    the bag recorded them, the notes saying why; the grid is the stamped bag's moved by the
    recorder's 20 ms."""
    tables, radius = _drive()
    stamped = read_mdf4(tables_bag(tmp_path / "a.bag", tables), bag_map(), radius, "m", "a.bag")
    w, g = tables.wheels, tables.gnss
    wheels = (w[c.T_S].to_numpy(), w[list(c.WHEELS)].to_numpy())
    fixes = (g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    headless = write_bag(tmp_path / "b.bag", wheels, fixes, lag_ns=20_000_000, wheel_type=NO_HEADER)
    smap = bag_map() | {
        f"omega_{w}": ColumnSpec(f"{WHEEL_TOPIC}.{w}", "rad/s") for w in ("fl", "fr", "rl", "rr")
    }
    got = read_mdf4(headless, smap, radius, "m", "b.bag")
    said = "\n".join(got.notes)
    assert f"{WHEEL_TOPIC}: {len(w)} message(s) ({NO_HEADER}), on the times the bag " in said
    assert "recorded them (the type has no header)" in said
    assert f"{FIX_TOPIC}: {len(g)} message(s) (sensor_msgs/msg/NavSatFix), on their header" in said
    np.testing.assert_allclose(got.wheels[0].t_s, stamped.wheels[0].t_s + 0.02, atol=1e-6)
    unstamped = write_bag(tmp_path / "c.bag", wheels, fixes, lag_ns=20_000_000, stamped=False)
    said = "\n".join(read_mdf4(unstamped, bag_map(), radius, "m", "c.bag").notes)
    assert f"on the times the bag recorded them ({len(g)} of the header stamps are zero)" in said


def test_a_fix_whose_status_says_no_fix_has_no_position(tmp_path):
    """NavSatFix status -1 (STATUS_NO_FIX) on 25 fixes: those have no position (its last
    coordinates, as some drivers repeat them, are not taken), counted; status 0-2 are fixes."""
    tables, radius = _drive()
    status = np.zeros(len(tables.gnss), dtype=int)
    status[300:325] = -1
    status[400:410] = 2  # GBAS fix
    bag = tables_bag(tmp_path / "d.bag", tables, status=status)
    streams = read_mdf4(bag, bag_map(), radius, "m", "d.bag")
    lat = streams.gnss.channels[c.LAT_DEG]
    assert np.isnan(lat[300:325]).all() and not np.isnan(np.delete(lat, range(300, 325))).any()
    assert f"{FIX_TOPIC}: 25 message(s) with status.status below 0 (no fix)" in "\n".join(
        streams.notes
    )


def test_an_array_s_element_and_one_missing_from_a_later_message(tmp_path):
    """Wheel speeds as a JointState's velocity[0..3] (a robot's wheel joints): read by index;
    three messages with two elements give no value for the rear wheels, counted; the first
    message short is refused with its row."""
    tables, radius = _drive()
    ts = typestore()
    js, hdr = ts.types["sensor_msgs/msg/JointState"], ts.types["std_msgs/msg/Header"]
    time = ts.types["builtin_interfaces/msg/Time"]
    w = tables.wheels
    msgs = []
    for i, (t, *v) in enumerate(w[[c.T_S, *c.WHEELS]].to_numpy()):
        ns = int(round(t * 1e9))
        vel = np.array(v[:2] if i in (500, 501, 502) else v)
        h = hdr(seq=i, stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")
        msgs.append((ns, js(h, ["fl", "fr", "rl", "rr"], np.zeros(4), vel, np.zeros(4))))
    g = tables.gnss
    fixes = (g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    extra = [("/joint_states", "sensor_msgs/msg/JointState", msgs)]
    bag = write_bag(tmp_path / "j.bag", None, fixes, extra=extra)
    smap = bag_map() | {
        f"omega_{w}": ColumnSpec(f"/joint_states.velocity[{k}]", "rad/s")
        for k, w in enumerate(("fl", "fr", "rl", "rr"))
    }
    streams = read_mdf4(bag, smap, radius, "m", "j.bag")
    rl = streams.wheels[0].channels[c.OMEGA_RL]
    assert np.isnan(rl[500:503]).all() and np.isnan(rl).sum() == 3
    np.testing.assert_array_equal(streams.wheels[0].channels[c.OMEGA_FL], w[c.OMEGA_FL])
    said = "\n".join(streams.notes)
    assert "/joint_states.velocity[2]: 3 message(s) whose array has no such element" in said
    msgs[0] = (msgs[0][0], js(msgs[0][1].header, ["fl"], np.zeros(1), np.zeros(1), np.zeros(1)))
    bag = write_bag(tmp_path / "k.bag", None, fixes, extra=extra)
    with pytest.raises(InputError) as err:
        read_mdf4(bag, smap, radius, "m", "k.bag")
    text = str(err.value)
    assert "k.bag, row 1, column '/joint_states.velocity[1]': expected an element [1]" in text
    assert "found an array of float64 of 1 element(s)" in text


def test_what_the_bag_does_not_hold_is_refused_naming_what_it_holds(tmp_path):
    tables, radius = _drive()
    bag = tables_bag(tmp_path / "d.bag", tables)

    def refused(smap, **kw):
        with pytest.raises((InputError, ConfigError)) as err:
            read_mdf4(bag, smap, radius, "map.yaml", "d.bag", **kw)
        return str(err.value)

    text = refused(bag_map() | {"lat": ColumnSpec("/gps/fix.latitude", "deg")})
    assert "column '/gps/fix.latitude': expected a topic /gps/fix in the bag" in text
    assert f"its topics: {IMU_TOPIC} (sensor_msgs/msg/Imu), {FIX_TOPIC} (sensor_msgs" in text
    assert "rosbag info" in text
    text = refused(bag_map() | {"lat": ColumnSpec(f"{FIX_TOPIC}.lat", "deg")})
    assert (
        f"expected a field 'lat' in the messages of {FIX_TOPIC} (sensor_msgs/msg/NavSatFix)" in text
    )
    assert "found sensor_msgs/msg/NavSatFix, whose fields are header, status, latitude, " in text
    text = refused(bag_map() | {"lat": ColumnSpec(f"{FIX_TOPIC}.status.x", "deg")})
    assert "found sensor_msgs/msg/NavSatStatus, whose fields are status, service" in text
    text = refused(bag_map() | {"n_sats": ColumnSpec(f"{FIX_TOPIC}.header.frame_id", "count")})
    assert "d.bag, row 1, column '/vehicle/gps/fix.header.frame_id': expected a number" in text
    assert "found ''" in text
    text = refused(bag_map() | {"yaw_rate": ColumnSpec(f"{IMU_TOPIC}.angular_velocity", "rad/s")})
    assert "expected a number" in text and "found geometry_msgs/msg/Vector3" in text
    text = refused(bag_map() | {"lat": ColumnSpec("Latitude", "deg")})
    assert "map.yaml.lat: a ROS bag's signal is a topic and a field of its messages" in text
    ts = typestore()
    vec = ts.types["geometry_msgs/msg/Vector3"]
    two = [(IMU_TOPIC, "geometry_msgs/msg/Vector3", [(10**9, vec(0.0, 0.0, 0.1))])]
    bag = tables_bag(tmp_path / "two.bag", tables, extra=two)
    text = refused(bag_map(yaw=True))
    assert f"column '{IMU_TOPIC}': expected one message type a topic" in text
    assert "found geometry_msgs/msg/Vector3 and sensor_msgs/msg/Imu" in text


def test_a_file_that_is_no_bag_is_refused(tmp_path):
    _, radius = _drive()
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    with pytest.raises(InputError) as err:
        read_mdf4(junk, bag_map(), radius, "m", junk.name)
    text = str(err.value)
    assert "junk.bag: expected a ROS 1 bag (rosbags' reader" in text
    assert "rosbag reindex" in text


def _cut(bag, at: float):
    """A bag as a recorder killed while recording leaves it: no index (the header's
    index_pos 0), the file ending at ``at`` of its length (inside a chunk)."""
    data = bytearray(bag.read_bytes())
    i = data.index(b"index_pos=") + len(b"index_pos=")
    data[i : i + 8] = bytes(8)
    cut = bag.with_name(bag.name + ".active")
    cut.write_bytes(bytes(data[: int(len(data) * at)]))
    return cut


@pytest.mark.parametrize("compression", [None, "lz4"])
def test_a_recording_cut_short_is_read_as_far_as_it_goes(tmp_path, compression):
    """A bag of 64 KB chunks without its index, cut at 60 % of its length (rosbag record
    killed: the .bag.active): read record by record, its whole messages; the seconds it
    holds are the whole bag's, bit for bit (the last, where the file ends, aside); an
    uncompressed chunk cut short gives its whole records, an lz4 one none (cut inside its
    first, the bag is refused); a whole bag renamed .bag.active is read whole so."""
    tables, radius = _drive()
    whole = tables_bag(tmp_path / "d.bag", tables, compression=compression, chunk_bytes=1 << 16)
    want = per_second(_grid(read_mdf4(whole, bag_map(), radius, "m", "d.bag"), radius), radius)
    cut = _cut(whole, 0.6)
    streams = read_mdf4(cut, bag_map(), radius, "m", cut.name)
    said = "\n".join(streams.notes)
    assert "the bag has no index (a recording cut short" in said
    assert "read 2 of them (record by record, rosbags deserialising)" in said
    stops = "inside a lz4 chunk" if compression else "inside a chunk"
    assert f"whole messages; it stops {stops} at byte" in said
    got = per_second(_grid(streams, radius), radius)
    assert 0.4 * len(want) < len(got) < 0.7 * len(want)
    both = want.merge(got, on="t_s", suffixes=("", "_cut"))
    assert len(both) == len(got)  # every second it holds is one of the whole bag's
    for q in ("disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_array_equal(both[q][:-1], both[f"{q}_cut"][:-1], err_msg=q)
    early = _cut(whole, 0.01)  # inside its first chunk: an lz4 one gives nothing whole
    if compression:
        with pytest.raises(InputError) as err:
            read_mdf4(early, bag_map(), radius, "m", "early.bag.active")
        text = str(err.value)
        assert "no whole message: the recording was cut short inside its first chunk" in text
    else:
        streams = read_mdf4(early, bag_map(), radius, "m", "early.bag.active")
        assert 0 < streams.wheels[0].t_s.size < 0.05 * len(tables.wheels)
    renamed = tmp_path / "r.bag.active"
    shutil.copy(whole, renamed)
    streams = read_mdf4(renamed, bag_map(), radius, "m", renamed.name)
    again = per_second(_grid(streams, radius), radius)
    pd.testing.assert_frame_equal(again, want)
    assert "it stops" not in "\n".join(streams.notes)


def test_a_wheel_s_pulse_counter_in_a_bag_is_read_as_its_speed(tmp_path):
    """A kit's report of the four wheels' 10-bit counters of 96 pulses a turn (uint16, at
    100 Hz): each second's wheel distance within 1.5 pulses of the speeds' bag's."""
    from rosbags.typesys import get_types_from_msg

    tables, radius = _drive()
    w = tables.wheels
    t = w[c.T_S].to_numpy()
    counts = []
    for k in c.WHEELS:
        v = w[k].to_numpy()
        angle = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        counts.append(np.mod(100 + np.floor(angle * 96 / (2 * np.pi)), 1024))
    ts = typestore()
    pulses = "rwhonet_test/msg/WheelPulses"
    pulses_def = "std_msgs/Header header\nuint16 fl\nuint16 fr\nuint16 rl\nuint16 rr\n"
    ts.register(get_types_from_msg(pulses_def, pulses))
    hdr, time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    msgs = []
    for i in range(t.size):
        ns = int(round(t[i] * 1e9))
        h = hdr(seq=i, stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")
        msgs.append((ns, ts.types[pulses](h, *(int(n[i]) for n in counts))))
    g = tables.gnss
    fixes = (g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    bag = write_bag(
        tmp_path / "p.bag",
        None,
        fixes,
        extra=[("/wheel_pulses", pulses, msgs)],
        msgdefs={pulses: pulses_def},
    )
    smap = bag_map() | {
        f"omega_{k}": ColumnSpec(f"/wheel_pulses.{k}", "pulses/96 mod 1024")
        for k in ("fl", "fr", "rl", "rr")
    }
    streams = read_mdf4(bag, smap, radius, "m", "p.bag")
    got = per_second(_grid(streams, radius), radius)
    want = per_second(
        _grid(
            read_mdf4(tables_bag(tmp_path / "s.bag", tables), bag_map(), radius, "m", "s.bag"),
            radius,
        ),
        radius,
    )
    assert len(got) == len(want) > 100
    pulse_m = 2 * np.pi * radius / 96
    assert np.abs(got["disp_wpm_m"] - want["disp_wpm_m"]).max() < 1.5 * pulse_m
    assert any("pulses" in n for n in streams.notes)


def test_a_bag_plain_or_compressed_through_ingest_s_reader(tmp_path):
    """``reader: mdf4`` with a ``.bag`` and a ``.bag.gz``: the same drive, the compressed
    one said so; a bag's own times (ROS time) and its notes in the drive's."""
    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params

    tables, radius = _drive()
    bag = tables_bag(tmp_path / "raw" / "V-1.bag", tables)
    (tmp_path / "raw" / "V-2.bag.gz").write_bytes(gzip.compress(bag.read_bytes(), mtime=0))
    signals = {k: {"column": v.column, "unit": v.unit} for k, v in bag_map().items()}
    maps = {"ros": {"reader": "mdf4", "signals": signals}}
    data = make_params(tmp_path, **{"data.signal_maps": maps}).data
    got = {}
    for name in ("V-1.bag", "V-2.bag.gz"):
        f = DriveFile(name.split(".")[0], "target_test", "target", "ros", tmp_path / "raw" / name)
        got[name] = read_any(f, data, lambda p: p.name, radius, 0.1, 10.0)[0]
    a, b = got["V-1.bag"], got["V-2.bag.gz"]
    assert a.columns[c.T_S].size > 1000
    for k, v in a.columns.items():
        np.testing.assert_array_equal(b.columns[k], v, err_msg=k)
    assert any("a ROS 1 bag of" in n for n in a.notes)
    assert any("the ROS bag" in n for n in b.notes)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_ros2_bag_s_folder_gives_the_ros1_bag_s_grid_bit_for_bit(tmp_path, storage):
    """The same drive recorded by ``ros2 bag record`` (format 9, the types' definitions in
    it), in either storage: the ROS 1 bag's grid bit for bit (CDR and ROS 1's serialisation
    hold the same float32 and float64 values), the notes saying a ROS 2 bag."""
    tables, radius = _drive()
    one = _grid(
        read_mdf4(tables_bag(tmp_path / "a.bag", tables), bag_map(yaw=True), radius), radius
    )
    bag = tables_bag(tmp_path / "drive", tables, ros2=storage)
    assert (bag / "metadata.yaml").is_file()
    streams = read_mdf4(bag, bag_map(yaw=True), radius, "m", "drive")
    two = _grid(streams, radius)
    assert one.keys() == two.keys()
    for k in one:
        np.testing.assert_array_equal(two[k], one[k], err_msg=k)
    said = "\n".join(streams.notes)
    assert f"drive: a ROS 2 bag of {tables.n_rows} messages on 3 topic(s); read 3" in said
    assert "no message definitions" not in said


def test_a_ros2_bag_without_definitions_reads_ros_s_own_types_and_refuses_a_kit_s(tmp_path):
    """A ROS 2 bag as Humble's recorder writes it, without the types' definitions (here: a
    format-9 bag's definitions deleted): NavSatFix and a JointState's wheel velocities are
    read by ROS's own types, the notes saying so; a kit's WheelSpeedReport is refused,
    naming the type."""
    import sqlite3

    tables, radius = _drive()

    def without_definitions(bag):
        with sqlite3.connect(next(bag.glob("*.db3"))) as db:
            db.execute("DELETE FROM message_definitions")
        return bag

    bag = without_definitions(tables_bag(tmp_path / "kit", tables, ros2="sqlite3"))
    with pytest.raises(InputError) as err:
        read_mdf4(bag, bag_map(), radius, "m", "kit")
    text = str(err.value)
    assert "kit: expected the definition of dbw_mkz_msgs/msg/WheelSpeedReport" in text
    assert "found none in the bag (a ROS 2 bag recorded before Iron carries none)" in text
    ts = typestore(ros2=True)
    js, hdr = ts.types["sensor_msgs/msg/JointState"], ts.types["std_msgs/msg/Header"]
    time = ts.types["builtin_interfaces/msg/Time"]
    msgs = []
    for t, *v in tables.wheels[[c.T_S, *c.WHEELS]].to_numpy():
        ns = int(round(t * 1e9))
        h = hdr(stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")
        msgs.append((ns, js(h, ["fl", "fr", "rl", "rr"], np.zeros(4), np.array(v), np.zeros(4))))
    g = tables.gnss
    fixes = (g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    extra = [("/joint_states", "sensor_msgs/msg/JointState", msgs)]
    bag = without_definitions(write_bag(tmp_path / "js", None, fixes, extra=extra, ros2="sqlite3"))
    smap = bag_map() | {
        f"omega_{w}": ColumnSpec(f"/joint_states.velocity[{k}]", "rad/s")
        for k, w in enumerate(("fl", "fr", "rl", "rr"))
    }
    streams = read_mdf4(bag, smap, radius, "m", "js")
    np.testing.assert_array_equal(streams.wheels[0].channels[c.OMEGA_RR], tables.wheels[c.OMEGA_RR])
    assert "the bag carries no message definitions: ROS's own types" in "\n".join(streams.notes)


def test_a_ros2_bag_s_folder_is_a_drive_of_a_role_and_a_folder_without_metadata_is_not(
    tmp_path,
):
    """ingest's listing takes a ROS 2 bag's folder as an ``mdf4`` role's drive (named by
    the folder), beside a ROS 1 bag; a folder without metadata.yaml is passed over, and
    given to the reader it is refused as a folder; the bag's files count against
    ``data.max_file_mb``."""
    from rwhonet.data.drivefile import DriveFile, read_any
    from rwhonet.stages.ingest import discover
    from support.drives import make_params

    tables, radius = _drive()
    raw = tmp_path / "raw" / "target_test"
    tables_bag(raw / "V-1.bag", tables)
    tables_bag(raw / "V-2.ros2", tables, ros2="mcap")  # a folder's name is its drive
    (raw / "V-3").mkdir()
    (raw / "V-3" / "notes.txt").write_text("no bag\n")
    signals = {k: {"column": v.column, "unit": v.unit} for k, v in bag_map().items()}
    overrides = {
        "data.source": "files",
        "data.root": str(tmp_path / "raw"),
        "data.signal_maps": {"ros": {"reader": "mdf4", "signals": signals}},
    }
    data = make_params(tmp_path, **overrides).data
    roles = {r: dataclasses.replace(spec, format="ros") for r, spec in data.roles.items()}
    roles["target_test"] = dataclasses.replace(roles["target_test"], glob="target_test/*")
    data = dataclasses.replace(data, roles={"target_test": roles["target_test"]})
    found = discover(data)
    assert [(f.drive, f.path.name) for f in found] == [("V-1", "V-1.bag"), ("V-2.ros2",) * 2]
    grids = [read_any(f, data, lambda p: p.name, radius, 0.1, 10.0)[0] for f in found]
    for k, v in grids[0].columns.items():
        np.testing.assert_array_equal(grids[1].columns[k], v, err_msg=k)
    small = dataclasses.replace(data, max_file_mb=0.1)  # the folder's files count
    with pytest.raises(InputError) as err:
        read_any(found[1], small, lambda p: p.name, radius, 0.1, 10.0)
    assert "V-2.ros2: expected a drive file of at most 0.1 MB (data.max_file_mb)" in str(err.value)
    f = DriveFile("V-3", "target_test", "target", "ros", raw / "V-3")
    with pytest.raises(InputError) as err:
        read_any(f, data, lambda p: p.name, radius, 0.1, 10.0)
    assert "or a ROS 2 bag's folder (holding metadata.yaml) (format 'ros'); found a folder" in str(
        err.value
    )


@pytest.mark.parametrize("ros2", [None, "mcap"])
def test_a_bag_s_raw_can_frames_are_decoded_by_the_map_s_dbc_as_a_candump_log_s(tmp_path, ros2):
    """socketcan_bridge's can_msgs/Frame messages of the drive's frames (wheels at 100 Hz,
    the fix and the satellite count at 10 Hz), an error and a remote frame after every
    500th, each recorded 4 ms after its stamp, the status message one byte long: the map's
    DBC decodes them as it decodes the same frames in a candump log (the grid within 1e-6:
    a bag's stamps are ns, candump's us), on their stamps, those passed over counted;
    with the fixes from a NavSatFix topic instead (a channel whose topic the bag has is
    that topic's field), the fixes' grid is the NavSatFix bag's."""
    from rwhonet.data.rosbag import bag_frames, opened_bag
    from support.canlog import DBC, SATS_ID, SIGNALS, stream_frames, write_candump
    from support.rosbag import CAN_FRAME, CAN_FRAME_DEF, CAN_TOPIC, can_messages

    tables, radius = _drive()
    stamps, ids, data = stream_frames(tables, radius, 1.5e9)
    stamps = np.round(stamps, 6)
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC)
    smap = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    log = write_candump(stamps, ids, data, tmp_path / "bus.log")
    want = _grid(read_mdf4(log, smap, radius, "m", "bus.log", dbc=[str(dbc)]), radius)
    lengths = np.where(ids == SATS_ID, 1, 8)  # the status message's one byte, as sent
    messages = can_messages(stamps, ids, data, ros2 is not None, 500, 4_000_000, lengths)
    extra = [(CAN_TOPIC, CAN_FRAME, messages)]  # recorded 4 ms after their stamps
    path = tmp_path / ("bus" if ros2 else "bus.bag")
    bag = write_bag(path, None, None, extra=extra, msgdefs={CAN_FRAME: CAN_FRAME_DEF}, ros2=ros2)
    with opened_bag(bag, bag.name) as opened:
        frames = bag_frames(opened, bag.name)
    np.testing.assert_array_equal(frames.length, lengths)
    assert frames.buses == [CAN_TOPIC] and frames.t_s[0] == stamps[0]
    streams = read_mdf4(bag, smap, radius, "m", bag.name, dbc=[str(dbc)])
    got = _grid(streams, radius)
    assert got[c.T_S].size == want[c.T_S].size > 1000
    for k in (c.T_S, *c.WHEELS, c.LAT_DEG, c.LON_DEG, c.N_SATS):
        np.testing.assert_allclose(got[k], want[k], rtol=0, atol=1e-6, err_msg=k)
    said = "\n".join(streams.notes)
    errors = len(range(0, len(ids), 500))
    assert f"{len(ids)} data frames on 1 bus(es) ({CAN_TOPIC})" in said
    assert f"passed over: {errors} error frames, {errors} remote frames" in said
    # the fixes from the receiver's topic, the wheels from the bus
    g = tables.gnss
    fixes = (1.5e9 + g[c.T_S].to_numpy(), g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy())
    both = write_bag(
        tmp_path / ("both" if ros2 else "both.bag"),
        None,
        fixes,
        extra=extra,
        msgdefs={CAN_FRAME: CAN_FRAME_DEF},
        ros2=ros2,
    )
    mixed = {k: v for k, v in smap.items() if k not in ("lat", "lon", "n_sats")} | {
        # a DBC's message.signal, which no topic of the bag is: the bus's
        "omega_fl": ColumnSpec("WheelSpeeds.WhlSpd_FL", "km/h"),
        "lat": ColumnSpec(f"{FIX_TOPIC}.latitude", "deg"),
        "lon": ColumnSpec(f"{FIX_TOPIC}.longitude", "deg"),
    }
    streams = read_mdf4(both, mixed, radius, "m", both.name, dbc=[str(dbc)])
    assert streams.gnss.name == FIX_TOPIC
    assert streams.wheels[0].sources[c.OMEGA_FL] == "WheelSpeeds.WhlSpd_FL"
    np.testing.assert_array_equal(streams.gnss.channels[c.LAT_DEG], g[c.LAT_DEG])
    mixed_grid = _grid(streams, radius)
    for k in c.WHEELS:
        np.testing.assert_allclose(mixed_grid[k], want[k], rtol=0, atol=1e-6, err_msg=k)


def test_a_bag_without_can_frames_for_the_map_s_dbc_is_refused_naming_its_topics(tmp_path):
    """No topic of frames: refused naming the bag's topics; a topic of error frames only:
    refused as a CAN log without a data frame is, counting them."""
    from support.canlog import DBC, SIGNALS, stream_frames
    from support.rosbag import CAN_FRAME, CAN_FRAME_DEF, CAN_TOPIC, can_messages

    tables, radius = _drive()
    bag = tables_bag(tmp_path / "d.bag", tables)
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC)
    smap = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    with pytest.raises(InputError) as err:
        read_mdf4(bag, smap, radius, "m", "d.bag", dbc=[str(dbc)])
    text = str(err.value)
    assert "d.bag: expected a topic of raw CAN frames (can_msgs/Frame" in text
    assert f"found none; its topics: {WHEEL_TOPIC} (dbw_mkz_msgs/msg/WheelSpeedReport)" in text
    stamps, ids, data = stream_frames(tables, radius, 1.5e9)
    errors = [
        m for m in can_messages(stamps[:5], ids[:5], data[:5], every_error=1) if m[1].is_error
    ]
    extra = [(CAN_TOPIC, CAN_FRAME, errors)]
    bag = write_bag(tmp_path / "e.bag", None, None, extra=extra, msgdefs={CAN_FRAME: CAN_FRAME_DEF})
    with pytest.raises(InputError) as err:
        read_mdf4(bag, smap, radius, "m", "e.bag", dbc=[str(dbc)])
    said = "e.bag: expected CAN data frames in the bag's topics of them (/can_tx); found none"
    assert f"{said} (5 error frames)" in str(err.value)


def test_two_can_topics_are_two_buses_each_decoded_by_its_own_dbc(tmp_path):
    """The wheels' frames in Dataspeed's CanMessageStamped on /can_b, the fix's and the
    status's in can_msgs/Frame on /can_a (with an extended frame no database defines):
    two buses, named by their topics in the order their frames first came, each decoded by
    the database the map gives it; the grid is the one-topic bag's."""
    from rosbags.typesys import get_types_from_msg

    from rwhonet.data.rosbag import bag_frames, opened_bag
    from support.canlog import DBC, SIGNALS, WHEELS_ID, stream_frames
    from support.rosbag import CAN_FRAME, CAN_FRAME_DEF, can_messages

    tables, radius = _drive()
    stamps, ids, data = stream_frames(tables, radius, 1.5e9)
    wheels = ids == WHEELS_ID
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DBC)
    smap = {k: ColumnSpec(**v) for k, v in SIGNALS.items()}
    one = write_bag(
        tmp_path / "one.bag",
        None,
        None,
        extra=[("/can", CAN_FRAME, can_messages(stamps, ids, data))],
        msgdefs={CAN_FRAME: CAN_FRAME_DEF},
    )
    want = _grid(read_mdf4(one, smap, radius, "m", "one.bag", dbc=[str(dbc)]), radius)
    stamped = "dataspeed_can_msgs/msg/CanMessageStamped"
    defs = {
        CAN_FRAME: CAN_FRAME_DEF,
        "dataspeed_can_msgs/msg/CanMessage": "uint8[8] data\nuint32 id\nbool extended\nuint8 dlc\n",
        stamped: "std_msgs/Header header\ndataspeed_can_msgs/CanMessage msg\n",
    }
    ts = typestore()
    for name, text in defs.items():
        ts.register(get_types_from_msg(text, name))
    inner, outer = ts.types["dataspeed_can_msgs/msg/CanMessage"], ts.types[stamped]
    kit = [
        (t, outer(m.header, inner(m.data, m.id, False, 8)))
        for t, m in can_messages(stamps[wheels], ids[wheels], data[wheels])
    ]
    bus_a = can_messages(stamps[~wheels], ids[~wheels], data[~wheels])
    frame = ts.types[CAN_FRAME]
    late = bus_a[-1][0] + 1
    bus_a.append((late, frame(bus_a[-1][1].header, 0x18FEF100, False, True, False, 8, data[0])))
    bag = write_bag(
        tmp_path / "two.bag",
        None,
        None,
        extra=[("/can_b", stamped, kit), ("/can_a", CAN_FRAME, bus_a)],
        msgdefs=defs,
    )
    with opened_bag(bag, "two.bag") as opened:
        frames = bag_frames(opened, "two.bag")
    assert frames.buses == ["/can_a", "/can_b"] and int(frames.extended.sum()) == 1
    per_bus = [(str(dbc), "/can_b"), (str(dbc), "/can_a")]
    streams = read_mdf4(bag, smap, radius, "m", "two.bag", dbc=per_bus)
    said = "\n".join(streams.notes)
    assert f"{len(ids) + 1} data frames on 2 bus(es) (/can_b, /can_a)" in said
    got = _grid(streams, radius)
    for k in (c.T_S, *c.WHEELS, c.LAT_DEG, c.LON_DEG, c.N_SATS):
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


def test_the_real_minute_as_a_bag_gives_the_comma2k19_reader_s_seconds(tmp_path):
    """The real RAV4 minute (comma2k19, MIT) as a car running ROS would record it: the CAN
    wheel speeds (m/s) as a JointState's velocities and the u-blox fixes as NavSatFix, each
    stamped on the phone's boot clock: the comma2k19 reader's 59 labelled seconds within
    0.01 mm (measured: 2.4 um at most, in the GNSS distances). A test of the path on a real
    drive, not a result."""
    from support.realminute import RAV4_RADIUS_M, real_minute, reference_seconds

    minute = real_minute()
    ref = reference_seconds()
    ts = typestore()
    js, hdr = ts.types["sensor_msgs/msg/JointState"], ts.types["std_msgs/msg/Header"]
    time = ts.types["builtin_interfaces/msg/Time"]
    msgs = []
    for i, (t, v) in enumerate(zip(minute.t_wheels, minute.wheels, strict=True)):
        ns = int(round(t * 1e9))
        h = hdr(seq=i, stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")
        msgs.append((ns, js(h, ["fl", "fr", "rl", "rr"], np.zeros(4), np.array(v), np.zeros(4))))
    g = minute.gnss
    bag = write_bag(
        tmp_path / "rav4.bag",
        None,
        (minute.t_gnss, g[:, 0], g[:, 1]),
        extra=[("/joint_states", "sensor_msgs/msg/JointState", msgs)],
    )
    smap = bag_map() | {
        f"omega_{w}": ColumnSpec(f"/joint_states.velocity[{k}]", "m/s")
        for k, w in enumerate(("fl", "fr", "rl", "rr"))
    }
    streams = read_mdf4(bag, smap, RAV4_RADIUS_M, "m", "rav4.bag")
    got = per_second(_grid(streams, RAV4_RADIUS_M), RAV4_RADIUS_M)
    assert len(got) == len(ref) == 59
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-5, err_msg=q)


@pytest.mark.parametrize("compression", [None, "bz2", "lz4"])
def test_a_bag_read_record_by_record_gives_rosbags_messages(tmp_path, compression):
    """A whole bag read record by record (rwhonet.data.bagscan) gives what rosbags' indexed
    reader gives: the same connections, and every message's topic, record time and bytes,
    in the same order; a header that points past the file's end (a copy cut short) or to
    no index (0) is read so, not refused."""
    from rosbags.highlevel import AnyReader

    from rwhonet.data.bagscan import ScannedBag, has_index

    tables, radius = _drive()
    bag = tables_bag(tmp_path / "d.bag", tables, compression=compression, chunk_bytes=1 << 16)
    with AnyReader([bag]) as ref, ScannedBag(bag) as got:
        assert [(c.topic, c.msgtype) for c in got.connections] == [
            (c.topic, c.msgtype) for c in ref.connections
        ]
        want = [(c.topic, t, bytes(raw)) for c, t, raw in ref.messages()]
        assert [(c.topic, t, raw) for c, t, raw in got.messages()] == want
        assert got.message_count == len(want) == tables.n_rows
    assert has_index(bag)
    data = bag.read_bytes()
    short = tmp_path / "short.bag"  # its index lost with its end
    short.write_bytes(data[: int(len(data) * 0.9)])
    zero = tmp_path / "zero.bag"
    i = data.index(b"index_pos=") + len(b"index_pos=")
    zero.write_bytes(data[:i] + bytes(8) + data[i + 8 :])
    assert not has_index(short) and not has_index(zero)
    want = _grid(read_mdf4(bag, bag_map(), radius, "m", "d.bag"), radius)
    streams = read_mdf4(zero, bag_map(), radius, "m", "zero.bag")
    assert any("the bag has no index" in n for n in streams.notes)
    got = _grid(streams, radius)
    for k in want:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)
    assert any("it stops" in n for n in read_mdf4(short, bag_map(), radius, "m", "s").notes)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_ros2_bag_s_storage_file_given_alone_is_read_as_its_folder(tmp_path, storage):
    """A ROS 2 bag's .mcap or .db3 without its folder's metadata.yaml (as such a recording
    is often shared), plain and gzipped through ingest's reader: the folder's grid bit for
    bit, the notes saying so."""
    from rwhonet.data.drivefile import DriveFile, read_any
    from support.drives import make_params

    tables, radius = _drive()
    folder = tables_bag(tmp_path / "drive", tables, ros2=storage)
    want = _grid(read_mdf4(folder, bag_map(yaw=True), radius, "m", "drive"), radius)
    suffix = ".mcap" if storage == "mcap" else ".db3"
    alone = tmp_path / "raw" / f"V-1{suffix}"
    alone.parent.mkdir()
    shutil.copy(next(folder.glob(f"*{suffix}")), alone)
    packed = tmp_path / "raw" / f"V-2{suffix}.gz"
    packed.write_bytes(gzip.compress(alone.read_bytes(), mtime=0))
    streams = read_mdf4(alone, bag_map(yaw=True), radius, "m", alone.name)
    said = f"{alone.name}: a ROS 2 bag's {suffix[1:]} file (without its metadata.yaml) of "
    assert any(n.startswith(f"{said}{tables.n_rows} messages on 3") for n in streams.notes)
    got = _grid(streams, radius)
    for k in want:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)
    signals = {k: {"column": v.column, "unit": v.unit} for k, v in bag_map(yaw=True).items()}
    maps = {"ros": {"reader": "mdf4", "signals": signals}}
    data = make_params(tmp_path, **{"data.signal_maps": maps}).data
    raw = read_any(
        DriveFile("V-2", "target_test", "target", "ros", packed), data, str, radius, 0.1, 10.0
    )[0]
    for k in want:
        np.testing.assert_array_equal(raw.columns[k], got[k] if k in got else raw.columns[k])
    assert any("the ROS bag" in n for n in raw.notes)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_ros2_bag_s_folder_without_its_metadata_is_read_by_its_storage_files(tmp_path, storage):
    """``ros2 bag record`` writes metadata.yaml as it stops; killed, it leaves the folder
    with its storage files alone: listed as a drive and read from them, the folder's grid
    bit for bit, the notes saying so. A folder of neither is no bag."""
    from rwhonet.data.rosbag import is_rosbag2_folder

    tables, radius = _drive()
    folder = tables_bag(tmp_path / "drive", tables, ros2=storage)
    want = _grid(read_mdf4(folder, bag_map(), radius, "m", "drive"), radius)
    (folder / "metadata.yaml").unlink()
    assert is_rosbag2_folder(folder) and not is_rosbag2_folder(tmp_path)
    streams = read_mdf4(folder, bag_map(), radius, "m", "drive")
    said = "\n".join(streams.notes)
    assert "drive: the folder has no metadata.yaml (a recording cut short" in said
    assert "its 1 storage file(s) read alone (drive." in said
    got = _grid(streams, radius)
    for k in want:
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


@pytest.mark.parametrize("compression", [None, "lz4", "bz2"])
def test_a_damaged_bag_is_read_or_refused_never_a_traceback(tmp_path, compression):
    """60 whole bags with one to three random bytes changed (a damaged copy): each is read,
    or refused as the bag's problem; what rosbags' reader meets inside it (an lz4 or bz2
    chunk that does not decompress, its own assertions, a name that is no UTF-8, an index
    naming no connection) is never a traceback. A bag rosbags refuses is read again record
    by record (rwhonet.data.bagscan), its damaged chunk passed over and said."""
    from rwhonet.sim.streams import StreamTables

    tables, radius = simulated_streams(20.0, 100.0, 10.0, gyro_hz=50.0)
    bag = tables_bag(
        tmp_path / "d.bag",
        StreamTables(tables.wheels, tables.gnss, tables.gyro),
        compression=compression,
        chunk_bytes=1 << 16,
    )
    data = bag.read_bytes()
    rng = np.random.default_rng(0)
    refused = rescanned = 0
    for i in range(60):
        b = bytearray(data)
        for _ in range(int(rng.integers(1, 4))):
            b[int(rng.integers(13, len(b)))] = int(rng.integers(0, 256))
        path = tmp_path / f"f{i}.bag"
        path.write_bytes(bytes(b))
        try:
            streams = read_mdf4(path, bag_map(), radius, "m", path.name)
        except InputError as err:
            assert f"{path.name}: expected a ROS 1 bag" in str(err) or "problem" in str(err)
            refused += 1
        else:
            rescanned += any(f"{path.name}: rosbags refused the bag (" in n for n in streams.notes)
    assert refused + rescanned > 5  # damage is found, not read as data


@pytest.mark.parametrize("ros2", [None, "mcap"])
def test_a_navsatfix_s_position_covariance_gives_the_stated_accuracy(tmp_path, ros2):
    """NavSatFix's position_covariance (ENU, m²) where its type is not UNKNOWN: h_acc is
    the root of its east and north variances, 9 and 16 making 5.0 m (DIAGONAL_KNOWN; KNOWN
    and APPROXIMATED alike); a message of type UNKNOWN (0), or of a variance NaN or
    negative, states none (NaN). The drive's h_acc_m has it where the fixes state it."""
    tables, radius = _drive()
    n = len(tables.gnss)
    cov = np.zeros((n, 9))
    cov[:, 0], cov[:, 4], cov[:, 8] = 9.0, 16.0, 25.0
    cov[:, [1, 3]] = 2.0  # an east-north covariance, which the DRMS leaves out
    kind = np.full(n, 2)
    kind[100:110] = 3
    kind[200:210] = 1
    kind[300:320] = 0  # UNKNOWN: the driver filled in nothing it knows
    cov[400, 0] = np.nan
    cov[401, 4] = -1.0
    bag = tables_bag(
        tmp_path / ("drive" if ros2 else "drive.bag"),
        tables,
        covariance=cov,
        covariance_type=kind,
        ros2=ros2,
    )
    streams = read_mdf4(bag, bag_map(), radius, "m", "drive.bag")
    h = streams.gnss.channels[c.H_ACC_M]
    assert h.dtype == np.float64
    unknown = np.zeros(n, bool)
    unknown[[*range(300, 320), 400, 401]] = True
    np.testing.assert_array_equal(h[~unknown], 5.0)
    assert np.isnan(h[unknown]).all()
    assert streams.gnss.sources[c.H_ACC_M] == f"{FIX_TOPIC}.position_covariance"
    said = "\n".join(streams.notes)
    assert f"{FIX_TOPIC}: h_acc from position_covariance, the root of its east and north " in said
    assert f"on {n - 22} of {n} message(s)" in said
    grid = _grid(streams, radius)
    assert np.nanmax(grid[c.H_ACC_M]) == 5.0 and np.isfinite(grid[c.H_ACC_M]).sum() > 1000


def test_a_navsatfix_whose_covariance_is_unknown_states_no_accuracy(tmp_path):
    """A driver that leaves position_covariance_type UNKNOWN (0) on every fix, whatever the
    covariance holds: no h_acc channel, the grid as before. A map that names h_acc itself
    takes its field, not the covariance."""
    tables, radius = _drive()
    n = len(tables.gnss)
    cov = np.zeros((n, 9))
    cov[:, 0] = cov[:, 4] = 4.0
    bag = tables_bag(tmp_path / "a.bag", tables, covariance=cov, covariance_type=0)
    streams = read_mdf4(bag, bag_map(), radius, "m", "a.bag")
    assert c.H_ACC_M not in streams.gnss.channels and c.H_ACC_M not in streams.gnss.sources
    assert c.H_ACC_M not in _grid(streams, radius)
    assert "position_covariance" not in "\n".join(streams.notes)
    known = tables_bag(tmp_path / "b.bag", tables, covariance=cov, covariance_type=2)
    smap = bag_map() | {"h_acc": ColumnSpec(f"{FIX_TOPIC}.position_covariance[0]", "cm")}
    streams = read_mdf4(known, smap, radius, "m", "b.bag")
    np.testing.assert_array_equal(streams.gnss.channels[c.H_ACC_M], 0.04)
    assert streams.gnss.sources[c.H_ACC_M] == f"{FIX_TOPIC}.position_covariance[0]"


def _patched(bag, out, topic_conn: int, k: int, offset: int | None, new: bytes):
    """The bag with ``new`` written at byte ``offset`` of the ``k``-th message of
    connection ``topic_conn`` (its serialised data: a header's seq, stamp sec and nsec
    first; None: over its record's ``time`` field's seconds), as a flipped bit on a disk
    would leave it; rosbags reads it as it is."""
    from rwhonet.data.bagscan import MAGIC, OP_CHUNK, OP_MESSAGE, _records

    data = bytearray(bag.read_bytes())
    seen = 0
    for f, start, n in _records(bytes(data), len(MAGIC)):
        if f["op"][0] != OP_CHUNK:
            continue
        for g, at, _ in _records(bytes(data[start : start + n]), 0):
            if g["op"][0] == OP_MESSAGE and int.from_bytes(g["conn"], "little") == topic_conn:
                if seen == k:
                    if offset is None:  # the record header's time, just before the data
                        offset = data.rindex(b"time=", start + at - 64, start + at) + 5
                        offset -= start + at
                    data[start + at + offset : start + at + offset + len(new)] = new
                    out.write_bytes(bytes(data))
                    return out
                seen += 1
    raise AssertionError("no such message")


def _conn(bag, topic: str) -> int:
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as r:
        return next(x.id for x in r.connections if x.topic == topic)


@pytest.mark.parametrize("what", ["latitude", "stamp", "record time"])
def test_a_value_no_message_holds_alone_among_its_neighbours_is_passed_over(tmp_path, what):
    """A bag rosbags reads as it is (a ROS 1 chunk has no checksum) with one fix's latitude
    a flipped exponent bit made 1e173, one wheel message's stamp 16,384 s late (a bit of
    its seconds): that message passed over, the notes saying so, every other message read
    and put on the grid, where until stop 90 the drive was refused ("expected a latitude in
    [-90, 90]", "a clock that went back"). A fix whose record time is 64 s early, its stamp
    in its place: kept (which of the two times a bit moved, the stamps' order tells)."""
    import struct

    tables, radius = _drive()
    bag = tables_bag(tmp_path / "w.bag", tables)
    whole = read_mdf4(bag, bag_map(yaw=True), radius, "m", "w.bag")
    out = tmp_path / "d.bag"
    if what == "latitude":  # header (seq, stamp, an empty frame_id), status (1 + 2 bytes)
        lat = struct.pack("<d", 1e173)
        topic = FIX_TOPIC
        _patched(bag, out, _conn(bag, topic), 40, 4 + 8 + 4 + 3, lat)
    elif what == "stamp":
        sec = int(tables.wheels[c.T_S].iloc[500]) + 16_384
        topic = WHEEL_TOPIC
        _patched(bag, out, _conn(bag, topic), 500, 4, sec.to_bytes(4, "little"))
    else:  # the record's own time, in its header: the message's stamp is right
        sec = int(tables.gnss[c.T_S].iloc[40]) - 64
        topic = FIX_TOPIC
        _patched(bag, out, _conn(bag, topic), 40, None, sec.to_bytes(4, "little"))
    streams = read_mdf4(out, bag_map(yaw=True), radius, "m", "d.bag")
    said = "\n".join(streams.notes)
    got = {g.name: g.t_s.size for g in (*streams.wheels, streams.gnss)}
    want = {g.name: g.t_s.size for g in (*whole.wheels, whole.gnss)}
    lost = {k: want[k] - got[k] for k in want}
    _grid(streams, radius)  # and on the grid: until stop 90 refused there
    if what == "record time":  # its stamp in its place: kept (the index it fails: refused)
        assert "damaged message" not in said and set(lost.values()) == {0}
        assert "rosbags refused" in said
        return
    assert f"d.bag: {topic}: 1 damaged message(s) whose value no message holds" in said
    assert "rosbags refused" not in said
    assert sorted(set(lost.values())) == [0, 1]
    # the messages after it keep their numbers in the topic, for messages
    group = next(g for g in (*streams.wheels, streams.gnss) if g.name == topic)
    k = 40 if what == "latitude" else 500
    assert group.rows is not None and group.rows[k - 1] == k and group.rows[k] == k + 2


@pytest.mark.parametrize(
    ("bad", "passed"), [([40], True), ([40, 41], False), (list(range(5, 1200, 10)), False)]
)
def test_values_no_message_holds_together_or_many_are_refused_as_before(tmp_path, bad, passed):
    """Latitudes beyond ±90°: one alone is a flipped bit, passed over; two side by side,
    or one fix in ten (more than 1 % of a topic's messages), are no flipped bits but a
    sensor's or a map's doing: the drive is refused as before, saying where."""
    tables, radius = _drive()
    gnss = tables.gnss.copy()
    lat = gnss[c.LAT_DEG].to_numpy().copy()
    lat[bad] = 1e173
    gnss[c.LAT_DEG] = lat
    from rwhonet.sim.streams import StreamTables

    bag = tables_bag(tmp_path / "b.bag", StreamTables(tables.wheels, gnss, tables.gyro))
    streams = read_mdf4(bag, bag_map(yaw=True), radius, "m", "b.bag")
    said = "\n".join(streams.notes)
    if passed:
        assert "1 damaged message(s) whose value no message holds, each alone" in said
        assert "1 with a latitude beyond ±90°" in said
        _grid(streams, radius)
        return
    assert "damaged message" not in said
    with pytest.raises(InputError, match=r"expected a latitude in \[-90, 90\] deg"):
        _grid(streams, radius)
