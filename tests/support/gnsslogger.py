"""A phone's GnssLogger log written from a drive's fixes, as the app writes it (its header
of ``#`` lines naming each record kind's columns, then the records of every kind in the
order they came)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

HEADER_V3 = [
    "#",
    "# Header Description:",
    "#",
    "# Version: v3.0.6.0 Platform: 13 Manufacturer: Google Model: Pixel 7",
    "#",
    "# Raw,utcTimeMillis,TimeNanos,LeapSecond,TimeUncertaintyNanos,FullBiasNanos,Svid,Cn0DbHz",
    "#",
    "# UncalGyro,utcTimeMillis,elapsedRealtimeNanos,UncalGyroXRadPerSec,UncalGyroYRadPerSec,"
    "UncalGyroZRadPerSec,DriftXRadPerSec,DriftYRadPerSec,DriftZRadPerSec",
    "#",
    "# Fix,Provider,LatitudeDegrees,LongitudeDegrees,AltitudeMeters,SpeedMps,AccuracyMeters,"
    "BearingDegrees,UnixTimeMillis,SpeedAccuracyMps,BearingAccuracyDegrees,"
    "elapsedRealtimeNanos,VerticalAccuracyMeters,MockLocation,NumberOfUsedSignals,"
    "VerticalSpeedAccuracyMps,SolutionType",
    "#",
    "# Status,UnixTimeMillis,SignalCount,SignalIndex,ConstellationType,Svid,CarrierFrequencyHz,"
    "Cn0DbHz,AzimuthDegrees,ElevationDegrees,UsedInFix,HasAlmanacData,HasEphemerisData,"
    "BasebandCn0DbHz",
    "#",
]
# GnssLogger 1.x's Fix header, which has no bearing and names the time otherwise
HEADER_V1 = [
    "# ",
    "# Header Description:",
    "# ",
    "# Version: v1.4.0.0 Platform: N Manufacturer: Google Model: Pixel",
    "# ",
    "# Raw,ElapsedRealtimeMillis,TimeNanos,LeapSecond,TimeUncertaintyNanos,FullBiasNanos",
    "# ",
    "# Fix,Provider,Latitude,Longitude,Altitude,Speed,Accuracy,(UTC)TimeInMs",
    "# ",
]


def fix_v3(
    provider: str,
    lat: float,
    lon: float,
    speed: float,
    bearing: float,
    ms: int,
    mock=0,
    accuracy: str = "3.9",
):
    """A GnssLogger 3.x Fix record, its AccuracyMeters cell ``accuracy`` as written."""
    return (
        f"Fix,{provider},{float(lat)!r},{float(lon)!r},112.4,{speed:.3f},{accuracy},{bearing:.2f},"
        f"{ms},0.2,1.5,{ms * 1000},6.1,{mock},23,0.4,"
    )


def fix_v1(provider: str, lat: float, lon: float, speed: float, ms: int, accuracy: str = "3.9"):
    """A GnssLogger 1.x Fix record, its Accuracy cell ``accuracy`` as written."""
    return f"Fix,{provider},{float(lat)!r},{float(lon)!r},112.4,{speed:.3f},{accuracy},{ms}"


def gnsslogger_lines(
    gnss: pd.DataFrame,
    utc_s: np.ndarray,
    version: int = 3,
    others: bool = True,
    speed: np.ndarray | None = None,
    bearing: np.ndarray | None = None,
) -> list[str]:
    """The log's lines for the fixes ``gnss`` at their UTC times (s since 1970): the header,
    then for each fix some Raw and UncalGyro records, the GPS provider's Fix,
    (``others``) the fused provider's Fix of the same time a little elsewhere, and (3.x)
    a Status epoch of the fix's satellites (``n_sats``, else 9), so that each Fix record
    but the first follows the previous fix's epoch."""
    lat, lon = gnss[c.LAT_DEG].to_numpy(), gnss[c.LON_DEG].to_numpy()
    n = len(gnss)
    speed = np.full(n, 10.0) if speed is None else speed
    bearing = np.zeros(n) if bearing is None else bearing
    sats = gnss[c.N_SATS].to_numpy() if c.N_SATS in gnss else np.full(n, 9.0)
    lines = list(HEADER_V3 if version == 3 else HEADER_V1)
    for i in range(n):
        ms = int(round(utc_s[i] * 1000.0))
        lines += [f"Raw,{ms},{ms * 1000},18,0.0,-1234567890123456789,{s},{30 + s}" for s in (3, 7)]
        lines.append(f"UncalGyro,{ms},{ms * 1000},0.01,-0.02,0.003,0.0,0.0,0.0")
        if version == 3:
            lines.append(fix_v3("GPS", lat[i], lon[i], speed[i], bearing[i], ms))
            if others:
                lines.append(fix_v3("FLP", lat[i] + 1e-5, lon[i], speed[i], bearing[i], ms))
        else:
            lines.append(fix_v1("gps", lat[i], lon[i], speed[i], ms))
            if others:
                lines.append(fix_v1("network", lat[i] + 1e-4, lon[i], 0.0, ms))
        if version == 3:  # GnssLogger 1.x wrote no Status records
            lines += status_epoch(int(sats[i]) if np.isfinite(sats[i]) else 0)
    return lines


def status_epoch(used: int, unused: int = 2, ms: str = "") -> list[str]:
    """A GnssStatus callback's Status records, as GnssLogger writes them (``UnixTimeMillis``
    ``ms``, empty as in the Smartphone Decimeter Challenge's logs): ``used`` GPS
    satellites used in the fix, the first two of them on L5 too (a record a signal, one
    satellite still), and ``unused`` Galileo satellites seen but not used."""
    signals = [(1, sv, 1575420030, 1) for sv in range(1, used + 1)]
    signals += [(1, sv, 1176450050, 1) for sv in range(1, min(used, 2) + 1)]
    signals += [(6, sv, 1575420030, 0) for sv in range(1, unused + 1)]
    return [
        f"Status,{ms},{len(signals)},{k},{system},{svid},{hz},31.0,120.0,45.0,{u},1,1,29.0"
        for k, (system, svid, hz, u) in enumerate(signals)
    ]


def write_gnsslogger(path: Path, lines: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path
