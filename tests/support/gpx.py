"""GPX tracks written from a drive's GNSS table by gpxpy, as a phone's or handheld's logger
writes them (the reader, rwhonet.data.gpx, is compared with what gpxpy reads back)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from datetime import UTC, datetime
from pathlib import Path

import gpxpy.gpx as gpx
import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

GARMIN_TPX = "http://www.garmin.com/xmlschemas/TrackPointExtension/v2"


def _value(x) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def track(
    fixes: pd.DataFrame,
    t_utc_s: np.ndarray,
    segments: int = 1,
    extensions: bool = False,
) -> gpx.GPX:
    """The fixes as a GPX track (split into ``segments`` of equal length), their speed and
    course in GPX 1.0's elements, or with ``extensions`` in Garmin's TrackPointExtension v2
    (GPX 1.1 has neither element)."""
    out = gpx.GPX()
    trk = gpx.GPXTrack()
    out.tracks.append(trk)
    if extensions:
        out.nsmap["gpxtpx"] = GARMIN_TPX
    cols = {
        k: fixes[k].to_numpy() if k in fixes else None
        for k in (c.LAT_DEG, c.LON_DEG, c.N_SATS, c.SPEED_GNSS_M_S, c.HEADING_DEG, c.HEIGHT_M)
    }
    for part in np.array_split(np.arange(len(fixes)), segments):
        seg = gpx.GPXTrackSegment()
        trk.segments.append(seg)
        for i in part:
            t = datetime.fromtimestamp(float(t_utc_s[i]), UTC)
            p = gpx.GPXTrackPoint(
                float(cols[c.LAT_DEG][i]),
                float(cols[c.LON_DEG][i]),
                elevation=None if cols[c.HEIGHT_M] is None else _value(cols[c.HEIGHT_M][i]),
                time=t,
            )
            if cols[c.N_SATS] is not None and math.isfinite(cols[c.N_SATS][i]):
                p.satellites = int(cols[c.N_SATS][i])
            speed = None if cols[c.SPEED_GNSS_M_S] is None else _value(cols[c.SPEED_GNSS_M_S][i])
            course = None if cols[c.HEADING_DEG] is None else _value(cols[c.HEADING_DEG][i])
            if extensions:
                ext = ET.Element(f"{{{GARMIN_TPX}}}TrackPointExtension")
                for name, v in (("speed", speed), ("course", course)):
                    if v is not None:
                        ET.SubElement(ext, f"{{{GARMIN_TPX}}}{name}").text = repr(v)
                p.extensions.append(ext)
            else:
                p.speed, p.course = speed, course
            seg.points.append(p)
    return out


def write_gpx(path: Path, doc: gpx.GPX | str, version: str = "1.0") -> Path:
    """A GPX file (gpxpy's XML of ``doc``, or the text given)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    text = doc if isinstance(doc, str) else doc.to_xml(version)
    path.write_text(text, encoding="utf-8")
    return path
