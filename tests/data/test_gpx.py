"""A GPS track in GPX beside a drive's stream CSVs (rwhonet.data.gpx).

The tracks are written by gpxpy (tests/support/gpx.py), not by the reader's code, and the
reader's values are compared with what gpxpy reads back from the same file."""

from __future__ import annotations

import gpxpy
import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.gpx import is_gpx_name, read_gpx
from rwhonet.errors import InputError
from support.gpx import track, write_gpx
from support.multirate import receiver_drive, receiver_labels

DAY_S = 1_552_262_400.0  # 2019-03-11 00:00:00 UTC


def _fixes():
    """The drive's fixes with a height, speed and course of their own, to be read back."""
    g = receiver_drive()[0].gnss
    k = np.arange(len(g))
    return g.assign(
        **{
            c.HEIGHT_M: 100.0 + 0.01 * k,
            c.SPEED_GNSS_M_S: 10.0 + 0.001 * k,
            c.HEADING_DEG: (7.5 * k) % 360.0,
        }
    )


def _folder(tmp_path, gnss_csv: bool):
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    keep = tables if gnss_csv else StreamTables(tables.wheels, tables.gnss.iloc[:0])
    return write_stream_csvs(keep, tmp_path)


def _wheels(tmp_path):
    return [f for f in _folder(tmp_path, False).values() if f.name == "wheels.csv"]


def _point(t: str, lat="52.4", lon="-1.5", inner="") -> str:
    return f'<trkpt lat="{lat}" lon="{lon}"><time>{t}</time>{inner}</trkpt>'


def _doc(points: str, version: str = "1.1", segment=True) -> str:
    body = f"<trk><trkseg>{points}</trkseg></trk>" if segment else points
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<gpx version="{version}" creator="test" '
        f'xmlns="http://www.topografix.com/GPX/{version.replace(".", "/")}">\n{body}\n</gpx>\n'
    )


def test_names():
    assert is_gpx_name("track.gpx") and is_gpx_name("Track.GPX.gz")
    assert not is_gpx_name("gps.nmea") and not is_gpx_name("gpx.csv")


@pytest.mark.parametrize(("version", "extensions"), [("1.0", False), ("1.1", True)])
def test_the_reader_reads_what_gpxpy_reads(tmp_path, version, extensions):
    """GPX 1.0 (speed and course its own elements) and 1.1 (in Garmin's
    TrackPointExtension v2), two segments: every point's position, time, height,
    satellites, speed and course as gpxpy reads them back."""
    g = _fixes()
    t = DAY_S + g[c.T_S].to_numpy()
    path = write_gpx(tmp_path / "t.gpx", track(g, t, 2, extensions), version)
    log = read_gpx(path, "t.gpx")
    points = [p for s in gpxpy.parse(path.read_text()).tracks[0].segments for p in s.points]
    assert len(points) == log.rows.size == len(g)
    want = {
        "lat": [p.latitude for p in points],
        "lon": [p.longitude for p in points],
        "height": [p.elevation for p in points],
        "n_sats": [p.satellites for p in points],
    }
    if extensions:
        ext = [{e.tag.rpartition("}")[2]: float(e.text) for e in p.extensions[0]} for p in points]
        want |= {"speed_gnss": [e["speed"] for e in ext], "heading": [e["course"] for e in ext]}
    else:
        want |= {"speed_gnss": [p.speed for p in points], "heading": [p.course for p in points]}
    for key, values in want.items():
        np.testing.assert_array_equal(log.channels[key], np.asarray(values, float), err_msg=key)
    got_t = log.day_s + log.tod_s
    np.testing.assert_allclose(got_t, [p.time.timestamp() for p in points], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got_t, t, rtol=0, atol=1e-6)
    assert log.day_s == DAY_S and log.kind == "GPX" and log.dated_by == "GPX dates"
    assert "a GPX track: 1199 points in 2 segments, 1199 with a fix" in log.notes[0]
    text = path.read_text().splitlines()
    assert all("<trkpt" in text[r - 1] for r in log.rows)  # each point named by its line


def test_the_gpx_track_gives_the_labels_of_the_csv_fixes(tmp_path):
    """wheels.csv on the time of day and the receiver's fixes as track.gpx: the seconds and
    labels of the same fixes in gnss.csv, within 0.1 mm (GPX writes the coordinates in
    full, the times to the microsecond: 12 um measured)."""
    g = receiver_drive()[0].gnss
    ref, _ = receiver_labels(list(_folder(tmp_path / "csv", True).values()))
    gpx = write_gpx(tmp_path / "gpx" / "track.gpx", track(g, DAY_S + g[c.T_S].to_numpy()))
    got, streams = receiver_labels([*_wheels(tmp_path / "gpx"), gpx])
    assert len(got) == len(ref) > 100
    for q in ("t_s", "disp_gnss_m", "disp_wpm_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=1e-4, err_msg=q)
    gnss = next(s for s in streams.streams if s.name == "track.gpx")
    assert gnss.sources[c.LAT_DEG] == "GPX trkpt lat"
    said = " ".join(streams.notes)
    assert "track.gpx: a GPX track: 1199 points, 1199 with a fix" in said


@pytest.mark.parametrize(
    ("fix", "is_fix"),
    [("none", False), ("2d", True), ("3d", True), ("dgps", True), ("pps", True), (None, True)],
)
def test_what_is_a_fix(tmp_path, fix, is_fix):
    """<fix>none</fix> keeps the epoch without a position, speed or course; the other four
    values and no <fix> at all are fixes. The satellites and height stay."""
    inner = "<ele>12.5</ele><speed>3.0</speed><course>90</course><sat>4</sat>" + (
        f"<fix>{fix}</fix>" if fix else ""
    )
    doc = _doc(_point("2019-03-11T12:00:00Z", inner=inner), "1.0")
    log = read_gpx(write_gpx(tmp_path / "a.gpx", doc), "a.gpx")
    for key in ("lat", "lon", "speed_gnss", "heading"):
        assert np.isfinite(log.channels[key][0]) == is_fix, key
    assert log.channels["n_sats"][0] == 4 and log.channels["height"][0] == 12.5


def test_times_with_an_offset_or_without_a_zone_are_put_on_utc(tmp_path):
    """GPX says UTC: an offset is applied, a time without a zone read as UTC (said)."""
    points = "".join(
        _point(t)
        for t in ("2019-03-11T13:00:00+01:00", "2019-03-11T12:00:01Z", "2019-03-11T12:00:02.25")
    )
    log = read_gpx(write_gpx(tmp_path / "a.gpx", _doc(points)), "a.gpx")
    np.testing.assert_array_equal(log.day_s + log.tod_s, DAY_S + 43200.0 + np.array([0, 1, 2.25]))
    assert "times without a zone read as UTC, as GPX says" in log.notes[0]


def test_a_file_cut_short_reads_the_points_before_the_cut(tmp_path):
    """A logger that lost power: no closing tags, and its last point unfinished. The
    complete points are read; the note (and predict, through ``dropped``) says where."""
    points = "\n".join(_point(f"2019-03-11T12:00:0{k}Z", lat=f"52.{k}") for k in range(5))
    text = _doc(points)
    whole = read_gpx(write_gpx(tmp_path / "w.gpx", text), "w.gpx")
    closed = text[: text.index("</trkseg>")]  # all five points, no closing tags
    log = read_gpx(write_gpx(tmp_path / "c.gpx", closed), "c.gpx")
    np.testing.assert_array_equal(log.channels["lat"], whole.channels["lat"])
    assert "without its closing tags" in log.notes[0] and not log.dropped
    cut = text[: text.index('lon="-1.5"><time>2019-03-11T12:00:04Z')]  # inside the fifth
    log = read_gpx(write_gpx(tmp_path / "p.gpx", cut), "p.gpx")
    np.testing.assert_array_equal(log.channels["lat"], whole.channels["lat"][:4])
    assert log.dropped == "a track point cut short at the file's end (line 7)"
    np.testing.assert_array_equal(log.rows, [3, 4, 5, 6])


def test_xml_wrong_before_the_end_is_refused_at_its_line(tmp_path):
    points = "\n".join(_point(f"2019-03-11T12:00:0{k}Z") for k in range(5))
    bad = _doc(points).replace("</time></trkpt>\n<trkpt", "</time>\n<trkpt", 1)
    with pytest.raises(InputError) as err:
        read_gpx(write_gpx(tmp_path / "a.gpx", bad), "a.gpx")
    said = str(err.value)
    # the first point left open: expat finds it where </trkseg> closes another element
    assert "a.gpx, row 7: expected a GPX file: well-formed XML; found mismatched tag" in said


def test_bad_values_are_refused_naming_the_point_s_line_and_element(tmp_path):
    points = "\n".join(
        [
            _point("2019-03-11T12:00:00Z"),
            _point("2019-03-11T12:00:01Z", lat="95.0"),
            _point("2019-03-11T12:00:02Z", lon="1,5"),
            _point("2019-03-11T12:00:03Z", inner="<ele>high</ele>"),
            _point("2019-03-11T25:00:04Z"),
            _point("2019-03-11T12:00:05Z", inner="<fix>3D-fix</fix>"),
            '<trkpt lat="52.4"><time>2019-03-11T12:00:06Z</time></trkpt>',
            _point("2019-03-11T12:00:07Z", lat=""),
        ]
    )
    with pytest.raises(InputError) as err:
        read_gpx(write_gpx(tmp_path / "a.gpx", _doc(points)), "a.gpx")
    said = str(err.value)
    for line, column in ((4, "lat"), (5, "lon"), (6, "ele"), (7, "time"), (8, "fix"), (9, "lon")):
        assert f"a.gpx, row {line}, column '{column}'" in said, (line, column)
    assert "a lat in [-90, 90] degrees; found '95.0'" in said
    assert "row 9, column 'lon': expected the point's lon attribute; found none" in said
    assert "row 10, column 'lat': expected the point's lat attribute; found an empty one" in said


def test_points_without_a_time_or_given_twice_are_passed_over(tmp_path):
    """A point without <time> and a point written again (its time and position): passed
    over, counted; two points of one time at other positions: refused, both named."""
    points = "\n".join(
        [
            _point("2019-03-11T12:00:00Z"),
            '<trkpt lat="52.4" lon="-1.5"></trkpt>',
            _point("2019-03-11T12:00:01Z", lat="52.41"),
            _point("2019-03-11T12:00:01Z", lat="52.41"),
        ]
    )
    log = read_gpx(write_gpx(tmp_path / "a.gpx", _doc(points)), "a.gpx")
    assert log.rows.tolist() == [3, 5]
    assert log.dropped == (
        "1 track point(s) without a time (first at line 4); 1 track point(s) at an earlier "
        "one's time and position (first at line 6)"
    )
    points = points.replace('lat="52.41"', 'lat="52.42"', 1)
    with pytest.raises(InputError) as err:
        read_gpx(write_gpx(tmp_path / "b.gpx", _doc(points)), "b.gpx")
    said = str(err.value)
    assert "b.gpx, row 6, column 'time'" in said and "the point at line 5 with another" in said


def test_a_route_or_waypoints_alone_are_refused_naming_what_the_file_holds(tmp_path):
    doc = _doc(
        '<wpt lat="52.4" lon="-1.5"><time>2019-03-11T12:00:00Z</time></wpt>'
        '<rte><rtept lat="52.4" lon="-1.5"/><rtept lat="52.5" lon="-1.5"/></rte>',
        segment=False,
    )
    with pytest.raises(InputError) as err:
        read_gpx(write_gpx(tmp_path / "a.gpx", doc), "a.gpx")
    said = str(err.value)
    assert "no track point with a time (1 waypoint(s) (<wpt>), 2 route point(s) (<rtept>))" in said
    assert "a route or waypoints are planned, not driven" in said


def test_entities_are_refused(tmp_path):
    doc = (
        '<?xml version="1.0"?>\n<!DOCTYPE gpx [<!ENTITY a "aaaa">]>\n'
        + _doc(_point("2019-03-11T12:00:00Z")).split("\n", 1)[1]
    )
    with pytest.raises(InputError, match="a.gpx, row 2: expected a GPX file .GPX declares no"):
        read_gpx(write_gpx(tmp_path / "a.gpx", doc), "a.gpx")


def test_beside_the_receiver_s_nmea_log_the_nmea_log_is_read(tmp_path):
    """A phone app that kept both: the NMEA log is read, the GPX track left out, said."""
    from support.nmea import nmea_lines, write_nmea

    g = receiver_drive()[0].gnss
    t = DAY_S + g[c.T_S].to_numpy()
    folder = tmp_path / "both"
    wheels = _wheels(folder)
    nmea = write_nmea(folder / "gps.nmea", nmea_lines(g, t))
    moved = g.assign(**{c.LAT_DEG: g[c.LAT_DEG] + 1.0})  # another place: must not be read
    gpx = write_gpx(folder / "track.gpx", track(moved, t))
    got, streams = receiver_labels([*wheels, nmea, gpx])
    alone, _ = receiver_labels([*wheels, nmea])
    np.testing.assert_array_equal(got["disp_gnss_m"], alone["disp_gnss_m"])
    said = " ".join(streams.notes)
    assert "track.gpx: GPX log(s), left out: the fixes are the receiver's NMEA log's" in said


def test_a_gpx_track_per_hour_is_joined(tmp_path):
    """A logger that starts a file a period: the files, given in no order, are the one
    track's labels exactly."""
    g = receiver_drive()[0].gnss
    t = DAY_S + g[c.T_S].to_numpy()
    wheels = _wheels(tmp_path / "w")
    one, _ = receiver_labels([*wheels, write_gpx(tmp_path / "one" / "track.gpx", track(g, t))])
    cuts = [0, 400, 777, len(g)]
    files = [
        write_gpx(tmp_path / "three" / f"track_{k}.gpx", track(g.iloc[a:b], t[a:b]))
        for k, (a, b) in enumerate(zip(cuts, cuts[1:], strict=False))
    ]
    three, streams = receiver_labels([*wheels, *files[::-1]])
    for q in one.columns:
        np.testing.assert_array_equal(three[q], one[q], err_msg=q)
    assert "one stream split across 3 files, joined in time order" in " ".join(streams.notes)


def test_a_gpx_track_beside_a_logger_s_own_clock_is_refused_saying_what_to_do(tmp_path):
    from rwhonet.sim.streams import StreamTables, write_stream_csvs

    tables, _ = receiver_drive()
    g = tables.gnss
    t0 = float(tables.wheels[c.T_S].iloc[0])
    own = StreamTables(tables.wheels.assign(t_s=tables.wheels[c.T_S] - t0), g.iloc[:0])
    files = write_stream_csvs(own, tmp_path / "own")
    gpx = write_gpx(tmp_path / "own" / "track.gpx", track(g, DAY_S + g[c.T_S].to_numpy()))
    with pytest.raises(InputError) as err:
        receiver_labels([files["wheels"], gpx])
    assert "a GPX log (no logger stamps in it), and the stream files' time in 's'" in str(err.value)


def test_the_real_minute_s_fixes_as_a_gpx_track(tmp_path):
    """The RAV4's wheel speeds in wheels.csv on the receiver's UTC, its recorded u-blox fixes
    as a GPX track (gpxpy, GPX 1.0 with speed and course) in place of GGA and RMC
    sentences: the same 59 seconds, their GNSS displacements within 2 mm (the NMEA log's
    ddmm.mmmmmm against GPX's full digits), the wheels' travel the same."""
    from support.realminute import minute_seconds, write_minute_nmea

    ref, _ = minute_seconds(tmp_path / "nmea", write_minute_nmea)
    got, said = minute_seconds(
        tmp_path / "gpx", lambda d, f, t: write_gpx(d / "track.gpx", track(f, t))
    )
    assert "GPX dates, on the stream files' UTC" in said
    assert len(got) == len(ref) == 59
    for q in ("t_s", "disp_wpm_m"):
        np.testing.assert_array_equal(got[q], ref[q], err_msg=q)
    for q in ("disp_gnss_m", "label_m"):
        np.testing.assert_allclose(got[q], ref[q], rtol=0, atol=2e-3, err_msg=q)


def test_times_read_at_once_are_those_read_cell_by_cell(tmp_path):
    """GPX writers' usual form (``...Z``) is parsed by numpy at once; one time with an
    offset sends them all the cell-by-cell way of a text time column: the same seconds.
    A leap second (60 s, which numpy refuses) is read too."""
    stamps = [f"2019-03-11T12:00:{k:02d}.{k * 37 % 1000:03d}Z" for k in range(20)]
    stamps[7] = "2019-03-11T12:00:07Z"  # no fraction
    stamps[8] = "2019-03-11T12:00:08.123456789Z"  # to the nanosecond
    points = "".join(_point(t, lat=f"52.{k}") for k, t in enumerate(stamps))
    fast = read_gpx(write_gpx(tmp_path / "a.gpx", _doc(points)), "a.gpx")
    slow = read_gpx(
        write_gpx(tmp_path / "b.gpx", _doc(points.replace("12:00:19.703Z", "12:00:19.703+00:00"))),
        "b.gpx",
    )
    np.testing.assert_allclose(fast.day_s + fast.tod_s, slow.day_s + slow.tod_s, rtol=0, atol=1e-6)
    want = DAY_S + 43200.0 + np.array([float(t[17:-1]) for t in stamps])
    np.testing.assert_allclose(fast.day_s + fast.tod_s, want, rtol=0, atol=1e-6)
    leap = _doc(_point("2016-12-31T23:59:59Z") + _point("2016-12-31T23:59:60Z", lat="52.5"))
    log = read_gpx(write_gpx(tmp_path / "c.gpx", leap), "c.gpx")
    assert np.diff(log.tod_s).tolist() == [1.0]


def test_a_file_that_names_no_namespace_reads_as_gpx_1_1(tmp_path):
    points = _point("2019-03-11T12:00:00Z", inner="<ele>3</ele>") + _point(
        "2019-03-11T12:00:01Z", lat="52.41"
    )
    text = _doc(points).replace(' xmlns="http://www.topografix.com/GPX/1/1"', "")
    log = read_gpx(write_gpx(tmp_path / "a.gpx", text), "a.gpx")
    assert log.channels["lat"].tolist() == [52.4, 52.41] and log.rows.tolist() == [3, 3]
