"""A Septentrio receiver's SBF log written from a drive's GNSS table by ``pysbf2`` (a
generator and parser of SBF written from Septentrio's reference guide, not by the
reader): PVTGeodetic revision 2 blocks, a ReceiverTime every ``time_every`` epochs, and
the receiver's other blocks between them (DOP)."""

from __future__ import annotations

import binascii
import math
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

GPS_EPOCH_UNIX_S = 315_964_800
LEAP_S = 18  # GPS less UTC since 2017-01-01
DNU = -2e10
NO_H_ACCURACY = 655.35  # HAccuracy's do-not-use 65535, in pysbf2's metres (0.01 m)


def revised(block: bytes, revision: int, length: int | None = None) -> bytes:
    """A block with its ID's revision (bits 13-15) set, as a receiver writes it (pysbf2
    writes every block's as 0), cut to ``length`` bytes where given (a revision 0 or 1
    PVTGeodetic's 88: without revision 2's fields), its CRC computed again."""
    body = bytearray(block if length is None else block[:length])
    ident = int.from_bytes(body[4:6], "little") & 0x1FFF | revision << 13
    body[4:6] = ident.to_bytes(2, "little")
    body[6:8] = len(body).to_bytes(2, "little")
    body[2:4] = binascii.crc_hqx(bytes(body[4:]), 0).to_bytes(2, "little")
    return bytes(body)


def pvt(gps_s: float, revision: int = 2, **fields) -> bytes:  # type: ignore[no-untyped-def]
    """One PVTGeodetic block of ``revision`` at GPS time ``gps_s`` (s since 1980-01-06); its
    HAccuracy (m, 2DRMS) do-not-use where ``fields`` gives none."""
    from pysbf2 import SBFMessage

    week, seconds = divmod(gps_s, 604_800.0)
    tow = int(round(seconds * 1000.0))
    fields.setdefault("HAccuracy", NO_H_ACCURACY)
    block = SBFMessage("PVTGeodetic", revno=revision, TOW=tow, WNc=int(week), **fields)
    return revised(block.serialize(), revision, None if revision >= 2 else 88)


def receiver_time(gps_s: float, delta_ls: int = LEAP_S) -> bytes:
    from pysbf2 import SBFMessage

    week, seconds = divmod(gps_s, 604_800.0)
    tow = int(round(seconds * 1000.0))
    return SBFMessage(
        "ReceiverTime", TOW=tow, WNc=int(week), DeltaLS=delta_ls, SyncLevel=3
    ).serialize()


def dop(gps_s: float, pdop: float = 1.5, vdop: float = 1.2) -> bytes:
    from pysbf2 import SBFMessage

    week, seconds = divmod(gps_s, 604_800.0)
    tow = int(round(seconds * 1000.0))
    return SBFMessage(
        "DOP", TOW=tow, WNc=int(week), NrSV=9, PDOP=pdop, TDOP=0.9, HDOP=1.0, VDOP=vdop
    ).serialize()


def pvt_untimed() -> bytes:
    """A PVTGeodetic of a do-not-use time: a receiver that has not set its clock."""
    from pysbf2 import SBFMessage

    block = SBFMessage(
        "PVTGeodetic",
        revno=2,
        TOW=4_294_967_295,
        WNc=65_535,
        Type=1,
        Latitude=0.91,
        Longitude=-0.03,
        NrSV=9,
        HAccuracy=NO_H_ACCURACY,
    )
    return revised(block.serialize(), 2)


A_M, F = 6_378_137.0, 1.0 / 298.257223563  # WGS84
E2 = F * (2.0 - F)


def ecef(lat_deg, lon_deg, h_m):  # type: ignore[no-untyped-def]
    """A geodetic position (numbers or arrays) as WGS84 ECEF X, Y, Z (m), by the closed
    form (the prime vertical radius N; not PROJ, which the reader's inverse uses)."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    n = A_M / np.sqrt(1.0 - E2 * np.sin(phi) ** 2)
    return (
        (n + h_m) * np.cos(phi) * np.cos(lam),
        (n + h_m) * np.cos(phi) * np.sin(lam),
        (n * (1.0 - E2) + h_m) * np.sin(phi),
    )


def ecef_velocity(lat_deg: float, lon_deg: float, north: float, east: float, up: float):
    """A local north / east / up velocity (m/s) as ECEF Vx, Vy, Vz: the local axes' unit
    vectors in ECEF, each written out."""
    phi, lam = math.radians(lat_deg), math.radians(lon_deg)
    e = (-math.sin(lam), math.cos(lam), 0.0)
    n = (-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi))
    u = (math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi))
    return tuple(east * e[k] + north * n[k] + up * u[k] for k in range(3))


def sbf_blocks(
    g: pd.DataFrame,
    t_utc_s: np.ndarray,
    time_every: int = 10,
    leap: bool = True,
    cartesian: bool = False,
) -> list[bytes]:
    """The fixes as the receiver's blocks, an epoch's together: a ReceiverTime (where
    ``leap``, every ``time_every`` epochs), the PVTGeodetic (mode 1, stand-alone, where
    the table has a fix; 0, no PVT, its fields do-not-use, where not; its HAccuracy
    twice the table's ``h_acc_m``, the 2DRMS, where it has one) and a DOP.
    ``cartesian``: a PVTCartesian in place of the PVTGeodetic, the same solution in
    ECEF (:func:`ecef`, :func:`ecef_velocity`, the height 160.4 m above the ellipsoid)."""
    gps = np.asarray(t_utc_s, dtype=float) - GPS_EPOCH_UNIX_S + LEAP_S
    lat, lon = g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy()
    speed = g[c.SPEED_GNSS_M_S].to_numpy() if c.SPEED_GNSS_M_S in g else None
    course = g[c.HEADING_DEG].to_numpy() if c.HEADING_DEG in g else None
    sats = g[c.N_SATS].to_numpy() if c.N_SATS in g else np.full(len(g), 9.0)
    h_acc = g[c.H_ACC_M].to_numpy() if c.H_ACC_M in g else np.full(len(g), np.nan)
    out = []
    for i, t in enumerate(gps):
        if leap and i % time_every == 0:
            out.append(receiver_time(t))
        ok = math.isfinite(lat[i])
        v = speed[i] if speed is not None and ok else DNU
        h = math.radians(course[i]) if course is not None and ok else None
        if cartesian:
            n_sv = int(sats[i]) if math.isfinite(sats[i]) else 255
            cog = course[i] if course is not None and ok else None
            out.append(_cartesian(t, lat[i], lon[i], v, cog, n_sv, h_acc[i], ok))
            out.append(dop(t))
            continue
        out.append(
            pvt(
                t,
                Type=1 if ok else 0,
                Error=0 if ok else 1,
                Latitude=math.radians(lat[i]) if ok else DNU,
                Longitude=math.radians(lon[i]) if ok else DNU,
                Height=160.4 if ok else DNU,
                Undulation=48.0 if ok else DNU,
                Vn=v * math.cos(h) if h is not None and v != DNU else DNU,
                Ve=v * math.sin(h) if h is not None and v != DNU else DNU,
                Vu=0.0,
                COG=course[i] if course is not None and ok else DNU,
                NrSV=int(sats[i]) if math.isfinite(sats[i]) else 255,
                HAccuracy=2.0 * h_acc[i] if ok and math.isfinite(h_acc[i]) else NO_H_ACCURACY,
            )
        )
        out.append(dop(t))
    return out


def _cartesian(t, lat, lon, v, cog, sats, h_acc, ok) -> bytes:  # type: ignore[no-untyped-def]
    """One PVTCartesian block (revision 2) of the fix (``v`` m/s along ``cog`` degrees), or
    of no PVT where not ``ok``."""
    from pysbf2 import SBFMessage

    week, seconds = divmod(t, 604_800.0)
    fields = {"Type": 0, "Error": 1, "X": DNU, "Y": DNU, "Z": DNU, "Vx": DNU, "Vy": DNU}
    fields |= {"Vz": DNU, "COG": DNU, "Undulation": DNU, "NrSV": 255}
    if ok:
        x, y, z = (float(v) for v in ecef(lat, lon, 160.4))
        fields = {"Type": 1, "Error": 0, "X": x, "Y": y, "Z": z, "Undulation": 48.0}
        fields["NrSV"] = sats
        if cog is not None and v != DNU:
            course = math.radians(cog)
            vx, vy, vz = ecef_velocity(lat, lon, v * math.cos(course), v * math.sin(course), 0.0)
            fields |= {"Vx": vx, "Vy": vy, "Vz": vz, "COG": cog}
        else:
            fields |= {"Vx": DNU, "Vy": DNU, "Vz": DNU, "COG": DNU}
    fields["HAccuracy"] = 2.0 * h_acc if ok and math.isfinite(h_acc) else NO_H_ACCURACY
    block = SBFMessage(
        "PVTCartesian", revno=2, TOW=int(round(seconds * 1000.0)), WNc=int(week), **fields
    )
    return revised(block.serialize(), 2)


def write_sbf(path: Path, blocks: list[bytes]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"".join(blocks))
    return path
