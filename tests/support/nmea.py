"""NMEA 0183 logs written from a drive's GNSS table, as a receiver writes them."""

from __future__ import annotations

import math
from collections.abc import Sequence
from datetime import UTC, datetime
from functools import reduce
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

KNOT_M_S = 1852.0 / 3600.0


def sentence(body: str) -> str:
    """``$body*hh``: a sentence with its checksum (the XOR of its characters)."""
    return f"${body}*{reduce(lambda a, ch: a ^ ord(ch), body, 0):02X}"


def ddmm(value: float, letters: str) -> tuple[str, str]:
    """A coordinate as NMEA writes it: unsigned ``ddmm.mmmmmm`` and its letter."""
    if not math.isfinite(value):
        return "", ""
    a = abs(value)
    d = int(a)
    width = 2 if letters == "NS" else 3
    return f"{d:0{width}d}{(a - d) * 60.0:09.6f}", letters[0] if value >= 0 else letters[1]


def hhmmss(t_s: float) -> str:
    tod = t_s % 86400.0
    h, rest = divmod(tod, 3600.0)
    m, s = divmod(rest, 60.0)
    return f"{int(h):02d}{int(m):02d}{s:05.2f}"


def ddmmyy(t_s: float) -> str:
    return datetime.fromtimestamp(math.floor(t_s / 86400.0) * 86400.0, UTC).strftime("%d%m%y")


def gga(t_s: float, lat: float, lon: float, sats: float, quality: int = 1, talker="GP") -> str:
    la, ns = ddmm(lat, "NS")
    lo, ew = ddmm(lon, "EW")
    n = "" if not math.isfinite(sats) else f"{int(sats):02d}"
    return sentence(
        f"{talker}GGA,{hhmmss(t_s)},{la},{ns},{lo},{ew},{quality},{n},0.9,112.4,M,47.0,M,,"
    )


def rmc(
    t_s: float, lat: float, lon: float, speed_m_s: float, course: float, status="A", talker="GP"
) -> str:
    la, ns = ddmm(lat, "NS")
    lo, ew = ddmm(lon, "EW")
    kn = f"{speed_m_s / KNOT_M_S:.3f}" if math.isfinite(speed_m_s) else ""
    cog = f"{course:.2f}" if math.isfinite(course) else ""
    mode = "A" if status == "A" else "N"
    return sentence(
        f"{talker}RMC,{hhmmss(t_s)},{status},{la},{ns},{lo},{ew},{kn},{cog},{ddmmyy(t_s)},,,{mode}"
    )


def gns(t_s: float, lat: float, lon: float, sats: float, mode: str = "AA", talker="GN") -> str:
    """NMEA 4.10's GNS as u-blox writes it: a mode letter a constellation, the
    navigational status ``V`` ("not providing navigational status") beside every fix."""
    la, ns = ddmm(lat, "NS")
    lo, ew = ddmm(lon, "EW")
    n = "" if not math.isfinite(sats) else f"{int(sats):02d}"
    return sentence(f"{talker}GNS,{hhmmss(t_s)},{la},{ns},{lo},{ew},{mode},{n},0.9,112.4,47.0,,,V")


def gll(t_s: float, lat: float, lon: float, status="A", mode="A", talker="GP") -> str:
    la, ns = ddmm(lat, "NS")
    lo, ew = ddmm(lon, "EW")
    return sentence(f"{talker}GLL,{la},{ns},{lo},{ew},{hhmmss(t_s)},{status},{mode}")


def vtg(speed_m_s: float, course: float, mode: str = "A", talker="GP", knots: bool = True) -> str:
    """VTG: course true and magnetic (left empty, as most receivers do), speed in knots
    (empty where not ``knots``) and in km/h, the mode letter (v2.3+; ``""``: none, as
    before v2.3)."""
    cog = f"{course:.2f}" if math.isfinite(course) else ""
    kn = f"{speed_m_s / KNOT_M_S:.3f}" if math.isfinite(speed_m_s) and knots else ""
    kmh = f"{speed_m_s * 3.6:.3f}" if math.isfinite(speed_m_s) else ""
    tail = f",{mode}" if mode else ""
    return sentence(f"{talker}VTG,{cog},T,,M,{kn},N,{kmh},K{tail}")


def zda(t_s: float, talker="GP") -> str:
    """ZDA: the UTC time and date (day, month, four-digit year), the local zone's hours and
    minutes left empty, as receivers write them."""
    day = datetime.fromtimestamp(math.floor(t_s / 86400.0) * 86400.0, UTC)
    return sentence(f"{talker}ZDA,{hhmmss(t_s)},{day:%d},{day:%m},{day:%Y},,")


def gst(t_s: float, lat_err: float, lon_err: float, alt_err: float = 2.2, talker="GP") -> str:
    """GST as u-blox writes it: the UTC time, the range residuals' RMS, the error ellipse
    left empty, the standard deviations of the latitude, longitude and altitude errors (m;
    NaN: empty)."""
    errs = ",".join(f"{x:.3f}" if math.isfinite(x) else "" for x in (lat_err, lon_err, alt_err))
    return sentence(f"{talker}GST,{hhmmss(t_s)},1.8,,,,{errs}")


def gsa(prns: Sequence[int], fix_type: int = 3, talker="GN", system: int | None = None) -> str:
    """GSA: automatic mode, the fix type (1 none, 2 2D, 3 3D), the ids of the satellites
    used (12 fields, the rest empty), PDOP, HDOP, VDOP, and NMEA 4.10's system id where
    given (u-blox writes one GNGSA a constellation so)."""
    ids = [f"{p:02d}" for p in prns] + [""] * (12 - len(prns))
    tail = "" if system is None else f",{system}"
    return sentence(f"{talker}GSA,A,{fix_type},{','.join(ids)},1.9,0.9,1.7{tail}")


def nmea_lines(
    gnss: pd.DataFrame,
    utc_s: np.ndarray,
    sentences: Sequence[str] = ("GGA", "RMC"),
    stamps: np.ndarray | None = None,
    other: bool = True,
    stamp_format: str = "{:.6f},",
) -> list[str]:
    """The receiver's lines for each fix: the ``sentences`` (GGA, GNS, RMC, GLL, ZDA, GST)
    at the fix's UTC time (s since 1970),
    a GSV between (passed over by the reader), each line after the logger's stamp where
    ``stamps`` (written by ``stamp_format``). A GST's latitude and longitude errors are
    0.6 and 0.8 times the table's ``h_acc_m`` (their root sum of squares: it), empty where
    it has none."""
    lat, lon = gnss[c.LAT_DEG].to_numpy(), gnss[c.LON_DEG].to_numpy()
    sats = gnss[c.N_SATS].to_numpy() if c.N_SATS in gnss else np.full(len(gnss), 9.0)
    h_acc = gnss[c.H_ACC_M].to_numpy() if c.H_ACC_M in gnss else np.full(len(gnss), np.nan)
    step = np.gradient(lat * 111_000.0, utc_s) if len(gnss) > 1 else np.zeros(len(gnss))
    lines = []
    for i, t in enumerate(utc_s):
        prefix = "" if stamps is None else stamp_format.format(stamps[i])
        out = []
        if "GGA" in sentences:
            out.append(gga(t, lat[i], lon[i], sats[i]))
        if other:
            out.append(sentence("GPGSV,1,1,01,05,40,083,46"))
        if "GNS" in sentences:
            out.append(gns(t, lat[i], lon[i], sats[i]))
        if "RMC" in sentences:
            out.append(rmc(t, lat[i], lon[i], abs(step[i]), 0.0))
        if "GLL" in sentences:
            out.append(gll(t, lat[i], lon[i]))
        if "ZDA" in sentences:
            out.append(zda(t))
        if "GST" in sentences:
            out.append(gst(t, 0.6 * h_acc[i], 0.8 * h_acc[i]))
        lines += [prefix + s for s in out]
    return lines


def write_nmea(path: Path, lines: Sequence[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\r\n".join(lines) + "\r\n")  # a serial line's CR LF
    return path
