"""A comma2k19 route: its one-minute segment folders read as one drive.

The dataset keeps each drive (a route, ``dongle_id|start time``) as numbered one-minute
segment folders on the device's one boot clock. One segment is too short for an outage
of a minute or more; the route is the drive. Here the real RAV4 minute is cut into
segments at whole times, as openpilot's logger cuts a route, and read back.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.comma2k19 import read_comma2k19, route_segments
from rwhonet.data.quality import assess
from rwhonet.data.streams import resample
from rwhonet.errors import InputError

from .test_comma2k19 import RAV4_RADIUS_M, REAL

ROUTE = "b0c9d2329ad1606b|2018-08-02--08-34-47"  # as the dataset names a route's folder
CHANNELS = ("CAN/wheel_speed", "CAN/speed", "GNSS/live_gnss_ublox", "IMU/gyro")


@pytest.fixture(scope="module")
def minute():
    if not (REAL / "processed_log").is_dir():
        pytest.skip(f"the real comma2k19 segment is not on this machine ({REAL})")
    arrays = {
        sub: (
            np.load(REAL / "processed_log" / sub / "t"),
            np.load(REAL / "processed_log" / sub / "value"),
        )
        for sub in CHANNELS
    }
    whole = resample(read_comma2k19(REAL, RAV4_RADIUS_M), nominal_radius_m=RAV4_RADIUS_M)
    return arrays, whole


def _cut(arrays, folder: Path, numbers=(9, 10, 11), at=(20.0, 40.0), leave_out=(), edit=None):
    """The minute's channels cut at ``at`` seconds after the first wheel sample into
    segment folders ``numbers`` under ``folder``; ``leave_out``: (segment, channel)
    pairs not written (a whole segment where the channel is None); ``edit(n, sub, t,
    v)``: a segment's arrays changed before they are written."""
    t0 = float(arrays["CAN/wheel_speed"][0][0])
    edges = [-np.inf, *(t0 + a for a in at), np.inf]
    for k, n in enumerate(numbers):
        if (n, None) in leave_out:
            continue
        for sub, (t, v) in arrays.items():
            if (n, sub) in leave_out:
                continue
            mine = (t >= edges[k]) & (t < edges[k + 1])
            tk, vk = t[mine], v[mine]
            if edit is not None:
                tk, vk = edit(n, sub, tk, vk)
            out = folder / str(n) / "processed_log" / sub
            out.mkdir(parents=True, exist_ok=True)
            for name, array in (("t", tk), ("value", vk)):
                with open(out / name, "wb") as f:
                    np.save(f, array)
    return folder


def test_a_route_reads_as_the_minute_its_segments_were_cut_from(minute, tmp_path):
    arrays, whole = minute
    route = _cut(arrays, tmp_path / ROUTE, numbers=(9, 10, 11))  # 10 sorts before 9 as text
    assert [p.name for p in route_segments(route)] == ["9", "10", "11"]
    assert route_segments(route / "10") == [] and route_segments(REAL) == []
    streams = read_comma2k19(route, RAV4_RADIUS_M, display="route")
    got = resample(streams, nominal_radius_m=RAV4_RADIUS_M)
    assert got.drive.n_rows == whole.drive.n_rows == 597
    for k, v in whole.drive.columns.items():  # the same fit of the receiver's epochs, the same grid
        np.testing.assert_array_equal(got.drive.columns[k], v, err_msg=k)
    assert "route: a comma2k19 route of 3 segment(s) (9-11), read as one drive" in " ".join(
        got.drive.notes
    )
    # a sample is named by its own segment's folder and its place in that segment's arrays
    wheels = streams.wheels[0]
    t0 = float(arrays["CAN/wheel_speed"][0][0])
    first_of_10 = int(np.searchsorted(wheels.t_s, t0 + 20.0))
    assert wheels.places(np.array([first_of_10 - 1, first_of_10])) == [
        ("route/9 [CAN/wheel_speed]", first_of_10),
        ("route/10 [CAN/wheel_speed]", 1),
    ]


def test_a_segment_not_in_the_route_leaves_a_hole_validate_cuts(minute, tmp_path):
    arrays, _ = minute
    route = _cut(arrays, tmp_path / ROUTE, numbers=(9, 10, 11), leave_out={(10, None)})
    got = resample(read_comma2k19(route, RAV4_RADIUS_M, display="route"), nominal_radius_m=0.362)
    assert "route: segment(s) 10 not in the folder: the drive has a hole there" in " ".join(
        got.drive.notes
    )
    vp = load_params().validate
    result = assess(got.drive.columns, vp.gnss, vp.sample_period_s)
    (gap,) = [cut for cut in result.cuts if cut.rule == "gap"]
    t0 = float(arrays["CAN/wheel_speed"][0][0])
    assert gap.start_s <= t0 + 20.0 and gap.end_s >= t0 + 40.0  # segment 10's 20 s
    # the 20 s on each side are too short a stretch for validate (min_segment_s: 30 s)
    assert result.segments == [] and result.cut_seconds_by_rule["short_segment"] == 38


def test_a_segment_without_the_gyro_leaves_the_yaw_rate_missing_there(minute, tmp_path):
    arrays, whole = minute
    route = _cut(arrays, tmp_path / ROUTE, leave_out={(10, "IMU/gyro")})
    got = resample(read_comma2k19(route, RAV4_RADIUS_M, display="route"), nominal_radius_m=0.362)
    assert "route: IMU/gyro in 2 of 3 segments (not in 10): missing there" in got.drive.notes
    t = got.drive.columns[c.T_S]
    yaw, logged = got.drive.columns[c.YAW_RATE_RAD_S], whole.drive.columns[c.YAW_RATE_RAD_S]
    t0 = float(arrays["CAN/wheel_speed"][0][0])
    inside = (t > t0 + 20.2) & (t < t0 + 39.8)
    assert np.isnan(yaw[inside]).all() and inside.sum() > 180
    outside = (t < t0 + 19.8) | (t > t0 + 40.2)
    np.testing.assert_allclose(yaw[outside], logged[outside], rtol=1e-9)  # sums restarted


def test_a_clock_restarted_between_segments_is_refused_naming_the_segment(minute, tmp_path):
    arrays, _ = minute

    def restarted(n, sub, t, v):  # segment 11 on a clock that began again
        return (t - 1000.0 if n == 11 else t), v

    route = _cut(arrays, tmp_path / ROUTE, edit=restarted)
    with pytest.raises(InputError) as err:
        read_comma2k19(route, RAV4_RADIUS_M, display="route")
    files = {p.file for p in err.value.problems}
    assert "route/11/CAN/wheel_speed/t" in files
    (wheel,) = [p for p in err.value.problems if p.file == "route/11/CAN/wheel_speed/t"]
    assert "restarted" in wheel.found and "route/10" in wheel.expected


def test_a_segment_without_its_wheel_speeds_is_refused_naming_it(minute, tmp_path):
    arrays, _ = minute
    route = _cut(arrays, tmp_path / ROUTE, leave_out={(10, "CAN/wheel_speed")})
    with pytest.raises(InputError) as err:
        read_comma2k19(route, RAV4_RADIUS_M, display="route")
    assert {p.file for p in err.value.problems} == {
        "route/10/CAN/wheel_speed/t",
        "route/10/CAN/wheel_speed/value",
    }


def test_two_segments_holding_the_same_times_with_other_values_are_refused(minute, tmp_path):
    arrays, _ = minute

    def overlapping(n, sub, t, v):  # segment 10 begins with 2 s of other values
        if n != 10 or sub != "CAN/wheel_speed":
            return t, v
        early = t[:200] - 2.0
        return np.r_[early, t], np.r_[v[:200] + 1.0, v]

    route = _cut(arrays, tmp_path / ROUTE, edit=overlapping)
    with pytest.raises(InputError) as err:
        read_comma2k19(route, RAV4_RADIUS_M, display="route")
    (problem,) = err.value.problems
    assert problem.file == "route/10 [CAN/wheel_speed]" and "overlap" in problem.found
    assert "route/9 [CAN/wheel_speed]" in problem.expected


def test_a_copy_of_the_route_folder_reads_alike(minute, tmp_path):
    """Anything beside the numbered folders (a preview, a checksum list) is not a segment."""
    arrays, whole = minute
    route = _cut(arrays, tmp_path / ROUTE)
    (route / "SHA256SUMS").write_text("")
    (route / "notes").mkdir()
    shutil.copytree(route / "9", tmp_path / "one" / "40")  # a route of one segment
    got = resample(read_comma2k19(route, RAV4_RADIUS_M), nominal_radius_m=RAV4_RADIUS_M)
    np.testing.assert_array_equal(got.drive.columns[c.T_S], whole.drive.columns[c.T_S])
    one = read_comma2k19(tmp_path / "one", RAV4_RADIUS_M, display="one")
    assert one.wheels[0].file == "one/40"


def test_a_folder_of_routes_is_refused_saying_to_give_each_route(minute, tmp_path):
    arrays, _ = minute
    chunk = tmp_path / "Chunk_1"
    _cut(arrays, chunk / ROUTE)
    _cut(arrays, chunk / "b0c9d2329ad1606b|2018-08-02--09-10-11")
    with pytest.raises(InputError) as err:
        read_comma2k19(chunk, RAV4_RADIUS_M, display="Chunk_1")
    (problem,) = err.value.problems
    assert problem.file == "Chunk_1" and "a folder of 2 route(s)" in problem.found
    assert "'Chunk_1/*'" in problem.fix


def test_the_channel_folders_as_the_dataset_s_readme_names_them_read_alike(minute, tmp_path):
    """The dataset's folders are CAN/wheel_speed and CAN/speed; its README writes
    wheel_speeds and car_speed. A copy named as the README says reads the same."""
    _, whole = minute
    copy = tmp_path / "seg" / "processed_log"
    shutil.copytree(REAL / "processed_log", copy)
    (copy / "CAN/wheel_speed").rename(copy / "CAN/wheel_speeds")
    (copy / "CAN/speed").rename(copy / "CAN/car_speed")
    streams = read_comma2k19(copy.parent, RAV4_RADIUS_M, display="seg")
    assert streams.wheels[0].name == "CAN/wheel_speeds"
    assert "CAN/car_speed" in {s.name for s in streams.extra}
    got = resample(streams, nominal_radius_m=RAV4_RADIUS_M)
    for k, v in whole.drive.columns.items():
        np.testing.assert_array_equal(got.drive.columns[k], v, err_msg=k)


def test_predict_through_a_route_s_missing_segment_says_why_there_is_no_position(
    minute, tmp_path, capsys
):
    """A segment missing inside an outage is a logger gap of 10 s: predict's filter starts
    afresh after it and waits for a GNSS course, so the outage ends without a position,
    and the summary says why."""
    from rwhonet.cli.main import main
    from support.serving import base_bundle, predict_args

    arrays, _ = minute
    route = _cut(arrays, tmp_path / ROUTE, at=(20.0, 30.0), leave_out={(10, None)})
    bundle = base_bundle(tmp_path / "bundle")
    args = ["--format", "comma2k19", "--nominal-radius", "0.362", "--outage", "5:45"]
    assert main(predict_args(bundle, route, tmp_path / "out.csv", *args)) == 0
    err = capsys.readouterr().err
    assert "10.6 s after 19.6 s (the position filter started afresh)" in err
    assert "position: none at its end" in err and "started it afresh" in err
