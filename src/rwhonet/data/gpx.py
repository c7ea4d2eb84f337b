"""A GPS track in GPX, the exchange format of phones' and handhelds' loggers: one fix a point.

A phone's GPS logger (GPSLogger for Android, OsmAnd, a dashcam's app), a handheld
(Garmin), and GPSBabel's conversion of a receiver's own log write the fixes of a drive as
a GPX file: XML, its track points ``<trkpt lat=".." lon="..">`` in track segments, each
with its UTC ``<time>``. A file named ``*.gpx`` (kept compressed too: ``track.gpx.gz``;
rotated: ``track.gpx.1``) in a ``stream_csv`` drive's folder is read here as the drive's
GNSS stream (:func:`read_gpx`), and :mod:`rwhonet.data.streamcsv` puts it on the stream
files' clock as it puts a receiver's UBX log (:func:`rwhonet.data.nmea.on_clock`): by its
UTC times, never by a logger's stamp (a GPX point has none).

**What is read** (GPX 1.1, topografix.com/GPX/1/1, ``wptType``; GPX 1.0, its
``trkpt``), by each element's local name, so GPX 1.0, 1.1 and a file that names no
namespace read alike:

- ``lat``, ``lon``: the point's attributes (decimal degrees, WGS84);
- ``time``: ISO 8601 date and time. GPX says UTC; a time with an offset (``+01:00``) is
  put on UTC, one without a zone is read as UTC (the notes say so);
- ``height``: ``<ele>``, metres (GPX does not say above what; receivers' and GPSBabel's
  files carry the altitude above mean sea level, as NMEA GGA's);
- ``n_sats``: ``<sat>``, the satellites used;
- ``speed_gnss``: ``<speed>``, m/s: GPX 1.0's element, or an element of that name in the
  point's ``<extensions>`` (Garmin's TrackPointExtension v2, OsmAnd's; both m/s);
- ``heading``: ``<course>``, degrees from true north, likewise (GPX 1.0, or extensions).

A quantity is given where any point has it; a point without it has NaN there.

**A fix that is no fix.** ``<fix>none</fix>`` ("GPS had no fix", GPX 1.1's ``fixType``)
keeps its epoch without a position, speed or course, as an NMEA log's epoch without a fix;
``2d``, ``3d``, ``dgps``, ``pps`` and a point without ``<fix>`` are fixes.

**Segments.** GPX starts a new track segment where "GPS reception was lost, or the GPS
receiver was turned off" (GPX 1.1, ``trksegType``). The points of every track and segment
are read in the file's order; a time between segments is a gap as any other (the
resampler never places a position across a gap longer than ``max_fix_gap_s``), and the
notes count the segments.

**Damage.** A logger that lost power leaves its file cut short, without the closing
``</trkseg></trk></gpx>`` or inside a point: the complete points before the cut are read,
and a note (and ``rwhonet predict``) says where it was cut. XML that is wrong anywhere else
(an element not closed, a character XML forbids) is refused at its line and column, as the
XML parser reports it. A point without a ``<time>`` (a track drawn, not recorded) is
passed over, counted; a point at the time of an earlier one with the same position (a
point written twice) is passed over, counted, and one with another position is refused:
times to whole seconds beside points several a second (a writer that drops the
fraction), which no clock can place.

**Refused**, naming the file, the point's line and the element: a coordinate or value that
is no number, a latitude outside [-90, 90], a longitude outside [-180, 180], a time that is
no ISO 8601 date and time, a ``<fix>`` none of GPX's five; a file with no track point with a
time (naming the waypoints and route points it holds: a route is planned, not driven); a
file that declares entities (``<!ENTITY``: GPX needs none, and an entity can expand a small
file into gigabytes).

The file is parsed with the standard library's ``xml.etree.ElementTree`` (expat), its
points' values converted column by column; ``gpxpy`` builds a Python object a point and
took 5.7 s for a 2 h track at 10 Hz (72,000 points), against 0.7 s here
(docs/readers.md, "A GPS track in GPX").
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data.compressed import without_suffix
from rwhonet.data.nmea import FixLog
from rwhonet.data.texttime import ISO8601, TextTimes, expected, parse_text_times
from rwhonet.errors import InputError, Problem

GPX_SUFFIXES = (".gpx",)
FIXES = ("2d", "3d", "dgps", "pps")  # GPX 1.1 fixType's values that are fixes
NO_FIX = "none"
# signal-map key -> the point's element (a child, or under <extensions> for these two)
ELEMENTS = {"height": "ele", "n_sats": "sat", "speed_gnss": "speed", "heading": "course"}
IN_EXTENSIONS = ("speed", "course")
FIX_ONLY = ("speed_gnss", "heading")  # NaN where no fix, as a position
LISTED = 20  # problems listed of one kind
_POINT = re.compile(rb"<(?:[A-Za-z_][\w.-]*:)?trkpt[\s/>]")  # a point's start tag
# a point's end tag, or its start tag closing it (<trkpt lat=".." lon=".."/>)
_CLOSED = re.compile(rb"</(?:[A-Za-z_][\w.-]*:)?trkpt\s*>|<(?:[A-Za-z_][\w.-]*:)?trkpt\s[^>]*/>")


def is_gpx_name(name: str) -> bool:
    """Whether a file's name is a GPX track's, kept compressed or not (``track.gpx``,
    ``track.gpx.gz``)."""
    return without_suffix(name).lower().endswith(GPX_SUFFIXES)


def _local(tag: str) -> str:
    """An element's name without its namespace (``{http://...GPX/1/1}trkpt`` -> ``trkpt``)."""
    return tag.rpartition("}")[2]


@dataclass
class _Points:
    """A GPX file's complete track points, as their text gives them.

    Attributes:
        lat, lon: the attributes' text (None where missing).
        time: the ``<time>`` text (None: none).
        fix: the ``<fix>`` text (None: none).
        values: signal-map key -> each point's element's text (None: none).
        segment: each point's segment, counted over the file's tracks from 0.
        others: counts of the file's waypoints and route points.
        cut: the line the file ends on where it ends inside an element (cut short), or
            None.
    """

    lat: list[str | None]
    lon: list[str | None]
    time: list[str | None]
    fix: list[str | None]
    values: dict[str, list[str | None]]
    segment: list[int]
    others: dict[str, int]
    cut: int | None

    def drop_last(self) -> None:
        """Leave the last point out (the file ends inside it)."""
        for cells in (self.lat, self.lon, self.time, self.fix, self.segment, *self.values.values()):
            cells.pop()


def _stripped(text: str | None) -> str | None:
    return None if text is None else text.strip()


def _parse(data: bytes, file: str) -> _Points:
    """The file's complete track points, in its order; a cut at the end kept as far as it
    goes, any other XML error refused."""
    if b"<!ENTITY" in data:
        line = data[: data.index(b"<!ENTITY")].count(b"\n") + 1
        raise InputError(
            [
                Problem(
                    file,
                    line,
                    None,
                    "a GPX file (GPX declares no entities)",
                    "an entity declaration (<!ENTITY)",
                    "give the track as its logger wrote it",
                )
            ]
        )
    builder = ET.TreeBuilder()
    parser = ET.XMLParser(target=builder)
    try:
        parser.feed(data)  # an error inside the data: here; the data ending early: at close
    except ET.ParseError as err:
        line, col = err.position
        raise InputError(
            [
                Problem(
                    file,
                    line,
                    None,
                    "a GPX file: well-formed XML",
                    f"{err.msg.split(':')[0]} at line {line}, column {col + 1}",
                    "mend the XML there (a GPX file cut short at its end is read as far as "
                    "it goes)",
                )
            ]
        ) from None
    cut = None
    try:
        parser.close()
    except ET.ParseError as err:  # the data ended inside an element: cut short
        cut = int(err.position[0])
    root = builder.close()  # the tree as far as it goes
    points = _Points([], [], [], [], {k: [] for k in ELEMENTS}, [], {"wpt": 0, "rtept": 0}, cut)
    if root is not None:
        _gather(root, points)
    if cut is not None and len(points.lat) > len(_CLOSED.findall(data)):
        points.drop_last()  # the point the file ends in, unfinished
    return points


def _gather(root: ET.Element, points: _Points) -> None:
    """The tree's track points, in the file's order, into ``points``."""
    names: dict[str, str] = {}  # tag -> its local name
    for segment, seg in enumerate(root.iterfind("{*}trk/{*}trkseg")):
        for pt in seg.iterfind("{*}trkpt"):
            children = {}
            extensions = None
            for child in pt:
                n = names.get(child.tag) or names.setdefault(child.tag, _local(child.tag))
                if n == "extensions":
                    extensions = child
                elif n not in children:
                    children[n] = child.text
            points.lat.append(pt.get("lat"))
            points.lon.append(pt.get("lon"))
            points.time.append(_stripped(children.get("time")))
            points.fix.append(_stripped(children.get("fix")))
            for key, n in ELEMENTS.items():
                text = children.get(n)
                if text is None and n in IN_EXTENSIONS and extensions is not None:
                    text = next((e.text for e in extensions.iter() if _local(e.tag) == n), None)
                points.values[key].append(_stripped(text))
            points.segment.append(segment)
    points.others["wpt"] = sum(1 for _ in root.iterfind("{*}wpt"))
    points.others["rtept"] = sum(1 for _ in root.iterfind("{*}rte/{*}rtept"))


def _lines(data: bytes, starts: list[int], n: int, lost: bool) -> tuple[np.ndarray, str]:
    """Each complete track point's line (1-based), and how points are named: by line where
    the file's ``<trkpt`` tags (at ``starts``) are its points one for one (one more where
    the file was cut inside its last: ``lost``), else by their number (a ``<trkpt`` in a
    comment)."""
    if len(starts) == n + lost:
        breaks = np.flatnonzero(np.frombuffer(data, np.uint8) == 0x0A)
        return np.searchsorted(breaks, np.asarray(starts[:n]), side="left") + 1, "line"
    return np.arange(1, n + 1), "point"


def _numbers(
    cells: list[str | None], file: str, rows: np.ndarray, what: str, expected: str
) -> tuple[np.ndarray, list[Problem]]:
    """Cells as numbers (NaN: none), and a problem for each that is no number."""
    s = pd.Series(cells, dtype=object)
    x = pd.to_numeric(s, errors="coerce").to_numpy(np.float64)
    bad = np.flatnonzero(np.isnan(x) & s.notna().to_numpy() & (s.astype(str) != ""))
    return x, [Problem(file, int(rows[i]), what, expected, repr(cells[i])) for i in bad[:LISTED]]


def read_gpx(path: Path, file: str) -> FixLog:
    """Read a GPX file's track points as one fix an epoch, on UTC.

    Args:
        path: the GPX file (text; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: XML that is not well formed before the file's end; entity
            declarations; no track point with a time; a point's coordinate, value or time
            that is none, a latitude or longitude out of range, a ``<fix>`` GPX does not
            know; two points at one time with other positions.
    """
    data = path.read_bytes()
    pts = _parse(data, file)
    starts = [m.start() for m in _POINT.finditer(data)]
    # a file cut short inside a point: more <trkpt starts than points closed
    lost = pts.cut is not None and len(starts) > len(_CLOSED.findall(data))
    rows, named = _lines(data, starts, len(pts.lat), lost)
    timed = np.array([bool(t) for t in pts.time], dtype=bool)
    if not timed.any():
        raise InputError([_no_track(pts, file)])
    at = np.flatnonzero(timed)
    lat, lon, fix, values, problems = _columns(pts, rows, file)
    times = _utc_times([pts.time[i] for i in at])
    problems += [
        Problem(file, int(rows[at[i]]), "time", expected(ISO8601), why)
        for i, why in times.bad[:LISTED]
    ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    again, problems = _again(times.seconds, lat[at], lon[at], rows[at], file, named)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    keep = at[~again]
    t = times.seconds[~again]
    fixed = fix[keep]
    channels = {k: np.where(fixed, v[keep], np.nan) for k, v in (("lat", lat), ("lon", lon))}
    for key, v in values.items():
        channels[key] = np.where(fixed, v[keep], np.nan) if key in FIX_ONLY else v[keep]
    sources = {"lat": "GPX trkpt lat", "lon": "GPX trkpt lon"} | {
        k: f"GPX {ELEMENTS[k]}" for k in values
    }
    untimed = np.flatnonzero(~timed)
    dropped = "; ".join(
        part
        for part in (
            f"{untimed.size} track point(s) without a time (first at {named} "
            f"{int(rows[untimed[0]])})"
            if untimed.size
            else "",
            f"{int(again.sum())} track point(s) at an earlier one's time and position "
            f"(first at {named} {int(rows[at[again][0]])})"
            if again.any()
            else "",
            f"a track point cut short at the file's end (line {pts.cut})" if lost else "",
        )
        if part
    )
    zoneless = times.zoned is False or times.mixed is not None
    segments = len(set(pts.segment))
    notes = [
        f"{file}: a GPX track: {t.size} points"
        + (f" in {segments} segments" if segments > 1 else "")
        + f", {int(fixed.sum())} with a fix"
        + ("; times without a zone read as UTC, as GPX says" if zoneless else "")
        + ("; points named by their number in the file" if named == "point" else "")
        + (
            f"; the file ends at line {pts.cut} inside an element, without its closing tags "
            "(a logger that lost power?): the points before it read"
            if pts.cut is not None
            else ""
        )
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    return FixLog.on_utc(
        file,
        t,
        channels,
        {k: sources[k] for k in channels},
        rows[keep],
        notes,
        dropped,
        dated_by="GPX dates",
        kind="GPX",
    )


def _no_track(pts: _Points, file: str) -> Problem:
    """A file without a track point that has a time: what it holds instead."""
    held = [
        f"{k} {what}"
        for what, k in (
            ("track point(s) without a time", len(pts.lat)),
            ("waypoint(s) (<wpt>)", pts.others["wpt"]),
            ("route point(s) (<rtept>)", pts.others["rtept"]),
        )
        if k
    ]
    return Problem(
        file,
        None,
        "trkpt",
        "a recorded track: track points (<trkpt>) with their <time>",
        "no track point with a time" + (f" ({', '.join(held)})" if held else ""),
        "export the logger's recorded track (a route or waypoints are planned, not driven)",
    )


def _columns(pts: _Points, rows: np.ndarray, file: str):
    """The points' coordinates, fix and values as numbers, and every problem."""
    problems: list[Problem] = []
    coords = []
    for what, cells, limit in (("lat", pts.lat, 90), ("lon", pts.lon, 180)):
        x, p = _numbers(cells, file, rows, what, f"a {what} in decimal degrees")
        problems += p
        problems += [
            Problem(
                file,
                int(rows[i]),
                what,
                f"the point's {what} attribute",
                "none" if cells[i] is None else "an empty one",
            )
            for i in [i for i, cell in enumerate(cells) if not cell][:LISTED]
        ]
        problems += [
            Problem(
                file, int(rows[i]), what, f"a {what} in [-{limit}, {limit}] degrees", repr(cells[i])
            )
            for i in np.flatnonzero(np.abs(x) > limit)[:LISTED]
        ]
        coords.append(x)
    fix_cells = pd.Series(pts.fix, dtype=object).str.lower()
    known = fix_cells.isna() | fix_cells.isin([*FIXES, NO_FIX])
    problems += [
        Problem(
            file, int(rows[i]), "fix", f"a fix of {', '.join((NO_FIX, *FIXES))}", repr(pts.fix[i])
        )
        for i in np.flatnonzero(~known.to_numpy(bool))[:LISTED]
    ]
    fix = ~fix_cells.eq(NO_FIX).fillna(False).to_numpy(bool)
    values = {}
    for key, element in ELEMENTS.items():
        if any(v for v in pts.values[key]):
            values[key], p = _numbers(pts.values[key], file, rows, element, "a number")
            problems += p
    return coords[0], coords[1], fix, values, problems


def _utc_times(cells: list[str]) -> TextTimes:
    """The timed points' times as s since 1970, UTC: as a text time column's ISO 8601 cells
    (:func:`rwhonet.data.texttime.parse_text_times`), where every time is written as GPX
    writers write it (``2019-03-11T12:00:00.25Z``, each cell its own form) parsed at once by
    numpy, which gives the same seconds (a leap second's 60, which numpy refuses, goes the
    cell-by-cell way)."""
    if all(
        len(c) >= 20
        and c[-1] in "Zz"
        and c[10] in "Tt"
        and c[13] == c[16] == ":"
        and "+" not in c
        and "-" not in c[10:]
        for c in cells
    ):
        try:
            ns = np.array([c[:-1] for c in cells], dtype="datetime64[ns]").astype(np.int64)
        except ValueError:
            pass
        else:
            return TextTimes(ns / 1e9, [], None, True)
    return parse_text_times(cells, ISO8601)


def _again(
    t: np.ndarray, lat: np.ndarray, lon: np.ndarray, rows: np.ndarray, file: str, named: str
) -> tuple[np.ndarray, list[Problem]]:
    """Points at an earlier point's time: passed over (True) where at its position too,
    refused where elsewhere."""
    order = np.argsort(t, kind="stable")
    same = np.zeros(t.size, dtype=bool)
    same[order[1:]] = t[order[1:]] == t[order[:-1]]
    again = np.zeros(t.size, dtype=bool)
    problems = []
    for i in np.flatnonzero(same):
        j = order[np.searchsorted(t[order], t[i], side="left")]  # the first at its time
        if np.array_equal([lat[i], lon[i]], [lat[j], lon[j]], equal_nan=True):
            again[i] = True
        elif len(problems) < LISTED:
            problems.append(
                Problem(
                    file,
                    int(rows[i]),
                    "time",
                    "one point a time: a time no earlier point has, or its position",
                    f"the time of the point at {named} {int(rows[j])} with another position "
                    f"({lat[i]:.7f}, {lon[i]:.7f} against {lat[j]:.7f}, {lon[j]:.7f})",
                    "have the logger write each point's time with its fraction of a second "
                    "(a writer that drops it gives several points of one second)",
                )
            )
    return again, problems
