"""A NovAtel receiver's ASCII logs written from a drive's GNSS table (BESTPOSA, BESTVELA,
TIMEA), each with its CRC-32 computed bit by bit as NovAtel's reference manual's C code
does (not by the reader's zlib call)."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

GPS_EPOCH_UNIX_S = 315_964_800
LEAP_S = 18  # GPS less UTC since 2017-01-01


def crc32(body: bytes) -> int:
    """CRC-32 as NovAtel's ``CalculateBlockCRC32``: polynomial 0xEDB88320, from 0."""
    crc = 0
    for byte in body:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xEDB88320 if crc & 1 else crc >> 1
    return crc


def log(name: str, gps_s: float, fields: list[str], status: str = "FINESTEERING") -> str:
    """``#NAME,...;fields*crc``: one ASCII log at GPS time ``gps_s`` (s since 1980-01-06)."""
    week, seconds = divmod(gps_s, 604_800.0)
    header = f"{name},COM1,0,83.5,{status},{int(week)},{seconds:.3f},02000040,b1f6,16248"
    body = f"{header};{','.join(fields)}"
    return f"#{body}*{crc32(body.encode()):08x}"


def _f(x: float, digits: int) -> str:
    return f"{x:.{digits}f}" if math.isfinite(x) else "0.0"


def novatel_lines(
    g: pd.DataFrame,
    t_utc_s: np.ndarray,
    position: str = "BESTPOSA",
    velocity: str | None = "BESTVELA",
    time_logs: bool = True,
    time_every: int = 1,
    sigma_m: tuple[float, float] = (1.3648, 1.1806),
) -> list[str]:
    """The fixes as the receiver's logs, an epoch's lines together: TIMEA (where
    ``time_logs``, every ``time_every`` epochs: 10 is a receiver's ``LOG TIMEA ONTIME 1``
    at 10 Hz), the position log (its ``lat σ`` and ``lon σ`` ``sigma_m``) and the velocity
    log (where given and the table has a speed and course)."""
    lines = []
    gps = np.asarray(t_utc_s, dtype=float) - GPS_EPOCH_UNIX_S + LEAP_S
    speed = g[c.SPEED_GNSS_M_S].to_numpy() if c.SPEED_GNSS_M_S in g else None
    course = g[c.HEADING_DEG].to_numpy() if c.HEADING_DEG in g else None
    height = g[c.HEIGHT_M].to_numpy() if c.HEIGHT_M in g else np.full(len(g), 112.4)
    sats = g[c.N_SATS].to_numpy() if c.N_SATS in g else np.full(len(g), 9.0)
    lat, lon = g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy()
    for i, t in enumerate(gps):
        if time_logs and i % time_every == 0:
            lines.append(
                log(
                    "TIMEA",
                    t,
                    [
                        "VALID",
                        "1.667187222e-10",
                        "9.641617960e-10",
                        f"-{LEAP_S}.00000000000",
                        "2019",
                        "3",
                        "11",
                        "0",
                        "0",
                        "0",
                        "VALID",
                    ],
                )
            )
        ok = math.isfinite(lat[i])
        n = int(sats[i]) if math.isfinite(sats[i]) else 0
        lines.append(
            log(
                position,
                t,
                [
                    "SOL_COMPUTED" if ok else "INSUFFICIENT_OBS",
                    "SINGLE" if ok else "NONE",
                    _f(lat[i], 11),
                    _f(lon[i], 11),
                    _f(height[i], 4),
                    "-17.0000",
                    "WGS84",
                    f"{sigma_m[0]:.4f}",
                    f"{sigma_m[1]:.4f}",
                    "3.1112",
                    '""',
                    "0.000",
                    "0.000",
                    str(n + 2),
                    str(n),
                    str(n),
                    "0",
                    "00",
                    "02",
                    "11",
                    "01",
                ],
            )
        )
        if velocity and speed is not None and course is not None:
            lines.append(
                log(
                    velocity,
                    t,
                    [
                        "SOL_COMPUTED",
                        "DOPPLER_VELOCITY",
                        "0.150",
                        "0.000",
                        _f(speed[i], 4),
                        _f(course[i], 6),
                        "0.0000",
                        "0.0",
                    ],
                )
            )
    return lines


def write_novatel(path: Path, lines: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode())
    return path


BESTPOS_B = struct.Struct("<IIdddfIfff4sffBBBBBBBB")
BESTVEL_B = struct.Struct("<IIffdddf")
TIME_B = struct.Struct("<IdddIBBBBII")


def binary_log(msg_id: int, gps_s: float, body: bytes, time_status: int = 180) -> bytes:
    """One binary log (sync, 28-byte header, ``body``, CRC-32) at GPS time ``gps_s``."""
    week, seconds = divmod(gps_s, 604_800.0)
    header = struct.pack(
        "<3sBHBBHHBBHIIHH",
        b"\xaa\x44\x12",
        28,
        msg_id,
        0,
        0x20,
        len(body),
        0,
        160,
        time_status,
        int(week),
        round(seconds * 1000.0),
        0x02000000,
        0xB1F6,
        16248,
    )
    return header + body + struct.pack("<I", crc32(header + body))


def novatel_binary(
    g: pd.DataFrame,
    t_utc_s: np.ndarray,
    position: int = 42,
    sigma_m: tuple[float, float] = (1.0, 1.0),
) -> list[bytes]:
    """The fixes as binary logs, an epoch's together: TIMEB, the position log (BESTPOSB,
    or message ID ``position``; its ``lat σ`` and ``lon σ`` ``sigma_m``) and BESTVELB where
    the table has a speed and course."""
    out = []
    gps = np.asarray(t_utc_s, dtype=float) - GPS_EPOCH_UNIX_S + LEAP_S
    lat, lon = g[c.LAT_DEG].to_numpy(), g[c.LON_DEG].to_numpy()
    sats = g[c.N_SATS].to_numpy() if c.N_SATS in g else np.full(len(g), 9.0)
    speed = g[c.SPEED_GNSS_M_S].to_numpy() if c.SPEED_GNSS_M_S in g else None
    course = g[c.HEADING_DEG].to_numpy() if c.HEADING_DEG in g else None
    for i, t in enumerate(gps):
        out.append(
            binary_log(101, t, TIME_B.pack(0, 0.0, 0.0, -float(LEAP_S), 2019, 3, 11, 0, 0, 0, 1))
        )
        ok = math.isfinite(lat[i])
        n = int(sats[i]) if math.isfinite(sats[i]) else 0
        body = BESTPOS_B.pack(
            0 if ok else 1,
            16 if ok else 0,
            lat[i] if ok else 0.0,
            lon[i] if ok else 0.0,
            112.4,
            -17.0,
            61,
            *sigma_m,
            2.0,
            b"\0" * 4,
            0.0,
            0.0,
            n + 2,
            n,
            n,
            0,
            0,
            2,
            0x11,
            1,
        )
        out.append(binary_log(position, t, body))
        if speed is not None and course is not None:
            out.append(
                binary_log(99, t, BESTVEL_B.pack(0, 8, 0.15, 0.0, speed[i], course[i], 0.0, 0.0))
            )
    return out


def write_binary(path: Path, messages: list[bytes]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"".join(messages))
    return path
