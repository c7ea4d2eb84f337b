"""u-blox UBX logs written from a drive's GNSS table by pyubx2 (not by the reader's code),
as a receiver writes them: one NAV-PVT an epoch, other messages between."""

from __future__ import annotations

import math
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd
from pyubx2 import UBXMessage

from rwhonet.data import canonical as c

GPS_EPOCH_S = 315_964_800.0  # 1980-01-06 00:00:00 UTC, as s since 1970
LEAP_S = 18  # GPS - UTC since 2017-01-01
WEEK_S = 604_800.0


def itow_ms(t_utc_s: float, leap_s: int = LEAP_S) -> int:
    """The GPS time of week (ms) of a UTC time (s since 1970)."""
    return int(round(((t_utc_s - GPS_EPOCH_S + leap_s) % WEEK_S) * 1000.0)) % 604_800_000


def utc_fields(t_utc_s: float) -> dict[str, int]:
    """A UTC time's date and time fields as u-blox writes them: to the nearest second, the
    rest in ``nano`` (ns; NAV-TIMEUTC's names, NAV-PVT's but ``second``)."""
    whole = math.floor(t_utc_s + 0.5)
    when = datetime.fromtimestamp(whole, UTC)
    return {
        "year": when.year,
        "month": when.month,
        "day": when.day,
        "hour": when.hour,
        "min": when.minute,
        "sec": when.second,
        "nano": int(round((t_utc_s - whole) * 1e9)),
    }


def nav_pvt(
    t_utc_s: float,
    lat: float,
    lon: float,
    *,
    sats: int = 12,
    height_m: float = 112.4,
    speed_m_s: float = 0.0,
    course_deg: float = 0.0,
    fix_type: int = 3,
    fix_ok: int = 1,
    valid: tuple[int, int, int] = (1, 1, 1),
    invalid_llh: int = 0,
    leap_s: int = LEAP_S,
    h_acc_mm: int = 0,
) -> bytes:
    """One NAV-PVT message of a UTC time (its date and time fields, nano the rest, as the
    receiver rounds them: to the nearest second) at a position (NaN: no fix, zeros), its
    horizontal accuracy estimate ``hAcc`` ``h_acc_mm`` (mm)."""
    fixed = math.isfinite(lat) and math.isfinite(lon)
    date = utc_fields(t_utc_s)
    msg = UBXMessage(
        "NAV",
        "NAV-PVT",
        0,
        iTOW=itow_ms(t_utc_s, leap_s),
        **{k: v for k, v in date.items() if k != "sec"},
        second=date["sec"],
        validDate=valid[0],
        validTime=valid[1],
        fullyResolved=valid[2],
        fixType=fix_type if fixed else 0,
        gnssFixOk=fix_ok if fixed else 0,
        numSV=int(sats) if math.isfinite(sats) else 0,
        lon=lon if fixed else 0.0,
        lat=lat if fixed else 0.0,
        height=int(round(height_m * 1000.0)) + 47_000,
        hMSL=int(round(height_m * 1000.0)),
        gSpeed=int(round(speed_m_s * 1000.0)) if math.isfinite(speed_m_s) else 0,
        headMot=course_deg if math.isfinite(course_deg) else 0.0,
        invalidLlh=invalid_llh,
        hAcc=h_acc_mm,
    )
    return msg.serialize()


def other_messages(itow: int) -> bytes:
    """What a receiver writes beside NAV-PVT: NAV-TIMEUTC and NAV-DOP."""
    return (
        UBXMessage("NAV", "NAV-TIMEUTC", 0, iTOW=itow, year=2019, month=3, day=11).serialize()
        + UBXMessage("NAV", "NAV-DOP", 0, iTOW=itow, gDOP=1.2, pDOP=1.1).serialize()
    )


def ubx_messages(
    gnss: pd.DataFrame, t_utc_s: Sequence[float] | np.ndarray, *, others: bool = True
) -> list[bytes]:
    """A NAV-PVT for each row of a GNSS table (lat, lon, satellites, speed, course, the
    stated accuracy in hAcc where the table has one: 0 where not), at its UTC time, each
    after the receiver's other messages of the epoch."""
    out = []
    cols = {k: gnss[k].to_numpy(float) for k in (c.LAT_DEG, c.LON_DEG, c.N_SATS)}
    speed = gnss[c.SPEED_GNSS_M_S].to_numpy(float) if c.SPEED_GNSS_M_S in gnss else None
    course = gnss[c.HEADING_DEG].to_numpy(float) if c.HEADING_DEG in gnss else None
    h_acc = _h_acc_mm(gnss)
    for i, t in enumerate(np.asarray(t_utc_s, float)):
        pvt = nav_pvt(
            float(t),
            cols[c.LAT_DEG][i],
            cols[c.LON_DEG][i],
            sats=cols[c.N_SATS][i],
            speed_m_s=0.0 if speed is None else speed[i],
            course_deg=0.0 if course is None else course[i] % 360.0,
            h_acc_mm=int(h_acc[i]),
        )
        out.append((other_messages(itow_ms(float(t))) if others else b"") + pvt)
    return out


def _h_acc_mm(gnss: pd.DataFrame) -> np.ndarray:
    """A GNSS table's stated accuracy (``h_acc_m``) as hAcc's whole mm (0 where it has
    none)."""
    if c.H_ACC_M not in gnss:
        return np.zeros(len(gnss), np.int64)
    m = gnss[c.H_ACC_M].to_numpy(float)
    return np.round(np.where(np.isfinite(m), m, 0.0) * 1000.0).astype(np.int64)


def write_ubx(path: Path, messages: Sequence[bytes]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"".join(messages))
    return path


def pvt_log(gnss: pd.DataFrame, t_utc_s: Sequence[float] | np.ndarray) -> bytes:
    """The NAV-PVT messages :func:`ubx_messages` writes (``others=False``), built at once
    with numpy: for a benchmark's hours of fixes, where pyubx2 takes 0.26 ms a message.
    ``test_ubx.py`` checks that its bytes are pyubx2's."""
    from rwhonet.data.ubx import PVT

    t = np.asarray(t_utc_s, float)
    n = t.size
    whole = np.floor(t + 0.5)
    when = whole.astype("datetime64[s]")
    day = when.astype("datetime64[D]")
    seconds = (when - day).astype(np.int64)
    year = day.astype("datetime64[Y]")
    month = day.astype("datetime64[M]")
    lat, lon = gnss[c.LAT_DEG].to_numpy(float), gnss[c.LON_DEG].to_numpy(float)
    fixed = np.isfinite(lat) & np.isfinite(lon)
    sats = gnss[c.N_SATS].to_numpy(float)
    speed = gnss[c.SPEED_GNSS_M_S].to_numpy(float) if c.SPEED_GNSS_M_S in gnss else np.zeros(n)
    course = gnss[c.HEADING_DEG].to_numpy(float) % 360.0 if c.HEADING_DEG in gnss else np.zeros(n)
    rec = np.zeros(n, PVT)
    rec["iTOW"] = [itow_ms(x) for x in t]
    rec["year"] = year.astype(np.int64) + 1970
    rec["month"] = (month - year.astype("datetime64[M]")).astype(np.int64) + 1
    rec["day"] = (day - month.astype("datetime64[D]")).astype(np.int64) + 1
    rec["hour"], rec["min"], rec["sec"] = seconds // 3600, seconds // 60 % 60, seconds % 60
    rec["valid"] = 0b111
    rec["nano"] = np.round((t - whole) * 1e9).astype(np.int64)
    rec["fixType"] = np.where(fixed, 3, 0)
    rec["flags"] = np.where(fixed, 1, 0)
    rec["numSV"] = np.where(np.isfinite(sats), sats, 0).astype(np.int64)
    # pyubx2 scales by int(value / scale): towards zero
    rec["lon"] = np.where(fixed, np.trunc(np.nan_to_num(lon) / 1e-7), 0).astype(np.int64)
    rec["lat"] = np.where(fixed, np.trunc(np.nan_to_num(lat) / 1e-7), 0).astype(np.int64)
    rec["hMSL"] = 112_400
    rec["height"] = 112_400 + 47_000
    rec["hAcc"] = _h_acc_mm(gnss)
    rec["gSpeed"] = np.round(np.where(np.isfinite(speed), speed, 0.0) * 1000.0).astype(np.int64)
    rec["headMot"] = np.trunc(np.where(np.isfinite(course), course, 0.0) / 1e-5).astype(np.int64)
    body = np.zeros((n, 4 + PVT.itemsize), np.uint8)
    body[:, :4] = [0x01, 0x07, PVT.itemsize, 0]
    body[:, 4:] = rec.view(np.uint8).reshape(n, PVT.itemsize)
    ck_a = np.cumsum(body, axis=1, dtype=np.uint8)
    ck_b = np.cumsum(ck_a, axis=1, dtype=np.uint8)
    out = np.zeros((n, 8 + PVT.itemsize), np.uint8)
    out[:, :2] = [0xB5, 0x62]
    out[:, 2:-2] = body
    out[:, -2], out[:, -1] = ck_a[:, -1], ck_b[:, -1]
    return out.tobytes()


def u6_messages(
    gnss: pd.DataFrame,
    t_utc_s: Sequence[float] | np.ndarray,
    *,
    status: str = "NAV-SOL",
    clock: str = "NAV-TIMEUTC",
    velned: bool = True,
    fix_type: int = 3,
    leap_valid: int = 1,
    h_acc_mm: int = 0,
) -> list[bytes]:
    """A u-blox 6's solution for each row of a GNSS table, as pyubx2 writes it: NAV-POSLLH,
    the fix in ``status`` (NAV-SOL with the satellites, or NAV-STATUS), NAV-VELNED (where
    ``velned``), and the time in ``clock`` (NAV-TIMEUTC, or NAV-TIMEGPS's week and leap
    seconds), all of one iTOW; NAV-POSLLH's ``hAcc`` ``h_acc_mm`` (mm)."""
    out = []
    lat, lon = gnss[c.LAT_DEG].to_numpy(float), gnss[c.LON_DEG].to_numpy(float)
    sats = gnss[c.N_SATS].to_numpy(float)
    speed = gnss[c.SPEED_GNSS_M_S].to_numpy(float) if c.SPEED_GNSS_M_S in gnss else None
    course = gnss[c.HEADING_DEG].to_numpy(float) if c.HEADING_DEG in gnss else None
    for i, t in enumerate(np.asarray(t_utc_s, float)):
        itow = itow_ms(float(t))
        gps = float(t) - GPS_EPOCH_S + LEAP_S
        week = int(gps // WEEK_S)
        f_tow = int(round((gps - week * WEEK_S) * 1e9 - itow * 1e6))
        fixed = math.isfinite(lat[i]) and math.isfinite(lon[i])
        msgs = [
            UBXMessage(
                "NAV",
                "NAV-POSLLH",
                0,
                iTOW=itow,
                lon=lon[i] if fixed else 0.0,
                lat=lat[i] if fixed else 0.0,
                height=159_400,
                hMSL=112_400,
                hAcc=h_acc_mm,
            )
        ]
        fix = {"gpsFix": fix_type if fixed else 0}
        if status == "NAV-SOL":
            n = int(sats[i]) if math.isfinite(sats[i]) else 0
            kw = fix | {"gpsfixOK": int(fixed), "numSV": n, "week": week, "fTOW": f_tow}
            msgs.append(UBXMessage("NAV", "NAV-SOL", 0, iTOW=itow, **kw))
        else:
            msgs.append(UBXMessage("NAV", "NAV-STATUS", 0, iTOW=itow, gpsFixOk=int(fixed), **fix))
        if velned:
            v = 0.0 if speed is None or not math.isfinite(speed[i]) else speed[i]
            h = 0.0 if course is None or not math.isfinite(course[i]) else course[i] % 360.0
            msgs.append(
                UBXMessage(
                    "NAV", "NAV-VELNED", 0, iTOW=itow, gSpeed=int(round(v * 100.0)), heading=h
                )
            )
        if clock == "NAV-TIMEUTC":
            date = utc_fields(float(t))
            valid = {"validTOW": 1, "validWKN": 1, "validUTC": 1}
            msgs.append(UBXMessage("NAV", "NAV-TIMEUTC", 0, iTOW=itow, **date, **valid))
        else:
            msgs.append(
                UBXMessage(
                    "NAV",
                    "NAV-TIMEGPS",
                    0,
                    iTOW=itow,
                    fTOW=f_tow,
                    week=week,
                    leapS=LEAP_S,
                    towValid=1,
                    weekValid=1,
                    leapSValid=leap_valid,
                )
            )
        out.append(b"".join(m.serialize() for m in msgs))
    return out


def esf_ins(t_utc_s: Sequence[float] | np.ndarray, yaw_rate_rad_s: Sequence[float]) -> list[bytes]:
    """A u-blox dead-reckoning receiver's UBX-ESF-INS messages (pyubx2) of yaw rates turning
    left positive: their z angular rate, the vehicle frame's z pointing down, is the
    negative (deg/s, 1e-3 resolution), marked valid."""
    return [
        UBXMessage(
            "ESF",
            "ESF-INS",
            0,
            version=1,
            zAngRateValid=1,
            iTOW=itow_ms(float(t)),
            zAngRate=-math.degrees(float(r)),
        ).serialize()
        for t, r in zip(np.asarray(t_utc_s, float), yaw_rate_rad_s, strict=True)
    ]
