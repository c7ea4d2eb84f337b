"""A drive as a CAN logger records it: raw CAN frames in an MDF4 file (ASAM bus logging, as
a CANedge or python-can's MF4Writer writes it) and the DBC that decodes them."""

from __future__ import annotations

from datetime import UTC
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c
from rwhonet.data.canlog import FRAME_DTYPE

WHEELS_ID, FIX_ID, SATS_ID = 0x1A0, 0x600, 0x601
# Wheel speeds as the wheels' circumferential speeds in 0.01 km/h (16 bits, Intel); the
# fix in 1e-7 deg (signed 32 bits); the satellite count in a message of its own.
DBC = f"""VERSION ""

NS_ :

BS_:

BU_: ESC GNSS

BO_ {WHEELS_ID} WheelSpeeds: 8 ESC
 SG_ WhlSpd_FL : 0|16@1+ (0.01,0) [0|655.35] "km/h" Vector__XXX
 SG_ WhlSpd_FR : 16|16@1+ (0.01,0) [0|655.35] "km/h" Vector__XXX
 SG_ WhlSpd_RL : 32|16@1+ (0.01,0) [0|655.35] "km/h" Vector__XXX
 SG_ WhlSpd_RR : 48|16@1+ (0.01,0) [0|655.35] "km/h" Vector__XXX

BO_ {FIX_ID} GnssPos: 8 GNSS
 SG_ Lat : 0|32@1- (1e-07,0) [-90|90] "deg" Vector__XXX
 SG_ Lon : 32|32@1- (1e-07,0) [-180|180] "deg" Vector__XXX

BO_ {SATS_ID} GnssStatus: 1 GNSS
 SG_ Sats : 0|8@1+ (1,0) [0|255] "" Vector__XXX
"""
SIGNALS = {
    **{
        f"omega_{w}": {"column": f"WhlSpd_{w.upper()}", "unit": "km/h"}
        for w in ("fl", "fr", "rl", "rr")
    },
    "lat": {"column": "Lat", "unit": "deg"},
    "lon": {"column": "Lon", "unit": "deg"},
    "n_sats": {"column": "Sats", "unit": "count"},
}


# The same messages as a truck's J1939 database defines them (extended identifiers: EBC2's
# group, a PDU1 group with a destination address, a proprietary PDU2 group), a message the
# map does not name at group 0 (TSC1: which a standard identifier's group is too), and the
# frames as the truck's ECUs send them: their own priorities and source addresses.
J1939_FLAG = 'BA_DEF_ "ProtocolType" STRING ;\nBA_ "ProtocolType" "J1939";\n'
J1939_IDS = {WHEELS_ID: 0x18FEBFFE, FIX_ID: 0x18EF00FE, SATS_ID: 0x18FF21FE}
J1939_SENT = {WHEELS_ID: 0x0CFEBF0B, FIX_ID: 0x18EF0B1C, SATS_ID: 0x18FF211C}


def _j1939_dbc() -> str:
    text = DBC
    for ours, theirs in J1939_IDS.items():
        text = text.replace(f"BO_ {ours} ", f"BO_ {theirs | 0x80000000} ")
    tsc1 = '\nBO_ 2348810494 TSC1: 8 EMS\n SG_ Torque : 0|8@1+ (1,0) [0|255] "" Vector__XXX\n'
    return text.replace("BU_:", J1939_FLAG + "BU_:") + tsc1


J1939_DBC = _j1939_dbc()


def can_frames(df: pd.DataFrame, radius_m: float, t0_s: float = 0.0):
    """The canonical drive ``df`` as raw CAN frames: ``(stamps, ids, data)`` in time order
    (its wheel speeds times ``radius_m`` in km/h, a frame per row; its fixes and satellite
    counts, a frame each where there is a fix), the stamps from ``t0_s``."""
    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    kmh = np.ascontiguousarray(
        np.round(df[list(c.WHEELS)].to_numpy() * radius_m * 3.6 / 0.01).astype("<u2")
    )
    fix = df[c.LAT_DEG].notna().to_numpy()
    latlon = np.ascontiguousarray(
        np.round(df.loc[fix, [c.LAT_DEG, c.LON_DEG]].to_numpy() / 1e-7).astype("<i4")
    )
    sats = np.zeros((int(fix.sum()), 8), np.uint8)
    sats[:, 0] = df.loc[fix, c.N_SATS].to_numpy()
    ids = np.r_[np.full(len(t), WHEELS_ID), np.full(fix.sum(), FIX_ID), np.full(fix.sum(), SATS_ID)]
    data = np.concatenate([kmh.view(np.uint8), latlon.view(np.uint8), sats])
    stamps = np.r_[t, t[fix] + 0.002, t[fix] + 0.001]  # the status, then the fix, after the row
    order = np.argsort(stamps, kind="stable")
    return t0_s + stamps[order], ids[order], data[order]


def write_can_log(df: pd.DataFrame, path: Path, radius_m: float) -> Path:
    """Write the canonical drive ``df`` as raw CAN frames (:func:`can_frames`) in an MDF4
    file; the DBC goes beside it as ``<stem>.dbc``."""
    from asammdf import MDF, Signal
    from asammdf.blocks.v4_blocks import SourceInformation
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS

    stamps, ids, data = can_frames(df, radius_m)
    frames = np.zeros(len(stamps), FRAME_DTYPE)
    frames["CAN_DataFrame.BusChannel"] = 1
    frames["CAN_DataFrame.ID"] = ids
    frames["CAN_DataFrame.DLC"] = frames["CAN_DataFrame.DataLength"] = 8
    frames["CAN_DataFrame.DataBytes"] = data
    mdf = MDF(version="4.10")
    source = SourceInformation(source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)
    mdf.append(Signal(frames, stamps, name="CAN_DataFrame", source=source))
    mdf.save(path, overwrite=True)
    mdf.close()
    path.with_suffix(".dbc").write_text(DBC)
    return path


def write_mdf_bus_log(stamps: np.ndarray, ids: np.ndarray, data: np.ndarray, path: Path) -> Path:
    """Frames as a CANedge writes a split file: an MDF4 bus log whose header's start is the
    first frame's time (UTC) and whose master time counts from it."""
    from datetime import datetime

    from asammdf import MDF, Signal
    from asammdf.blocks.v4_blocks import SourceInformation
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS

    frames = np.zeros(len(stamps), FRAME_DTYPE)
    frames["CAN_DataFrame.BusChannel"] = 1
    frames["CAN_DataFrame.ID"] = ids
    frames["CAN_DataFrame.DLC"] = frames["CAN_DataFrame.DataLength"] = data.shape[1]
    frames["CAN_DataFrame.DataBytes"] = data
    start_ns = int(round(float(stamps[0]) * 1e6)) * 1000  # whole microseconds
    mdf = MDF(version="4.10")
    mdf.header.start_time = datetime.fromtimestamp(start_ns / 1e9, UTC)
    mdf.header.abs_time = start_ns
    source = SourceInformation(source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)
    mdf.append(Signal(frames, stamps - start_ns / 1e9, name="CAN_DataFrame", source=source))
    path.parent.mkdir(parents=True, exist_ok=True)
    saved = Path(mdf.save(path, overwrite=True))  # asammdf writes the suffix in lower case
    mdf.close()
    saved.rename(path)  # a CANedge's: 00000001.MF4
    return path


def write_bus_log(
    stamps: np.ndarray,
    ids: np.ndarray,
    data: np.ndarray,
    path: Path,
    channel: str = "can0",
    extended=None,
) -> Path:
    """Frames written by python-can's writer for ``path``'s suffix (candump ``.log``,
    ``.asc``, ``.blf``, ``.trc``), as a bus tool records them."""
    import can

    path.parent.mkdir(parents=True, exist_ok=True)
    ext = np.zeros(len(ids), bool) if extended is None else extended
    with can.Logger(str(path)) as writer:
        for t, i, d, x in zip(stamps.tolist(), ids.tolist(), data, ext.tolist(), strict=True):
            writer.on_message_received(
                can.Message(
                    timestamp=t,
                    arbitration_id=i,
                    is_extended_id=x,
                    data=bytes(d),
                    channel=channel,
                )
            )
    return path


def stream_frames(tables, radius_m: float, t0_s: float = 0.0):
    """A drive's streams (``rwhonet.sim.streams.StreamTables``: wheels and fixes at their
    own times) as raw CAN frames in time order: ``(stamps, ids, data)``, as
    :func:`can_frames` encodes them."""
    w, g = tables.wheels, tables.gnss
    kmh = np.round(w[list(c.WHEELS)].to_numpy() * radius_m * 3.6 / 0.01)
    kmh = np.ascontiguousarray(np.clip(kmh, 0, 65535).astype("<u2"))
    fix = g[c.LAT_DEG].notna().to_numpy()
    latlon = np.ascontiguousarray(
        np.round(g.loc[fix, [c.LAT_DEG, c.LON_DEG]].to_numpy() / 1e-7).astype("<i4")
    )
    sats = np.zeros((int(fix.sum()), 8), np.uint8)
    sats[:, 0] = g.loc[fix, c.N_SATS].to_numpy()
    tg = g[c.T_S].to_numpy()[fix]
    ids = np.r_[np.full(len(w), WHEELS_ID), np.full(fix.sum(), SATS_ID), np.full(fix.sum(), FIX_ID)]
    data = np.concatenate([kmh.view(np.uint8), sats, latlon.view(np.uint8)])
    stamps = np.r_[w[c.T_S].to_numpy(), tg, tg]
    order = np.argsort(stamps, kind="stable")
    return t0_s + stamps[order], ids[order], data[order]


def write_asc(stamps: np.ndarray, ids: np.ndarray, data: np.ndarray, path: Path) -> Path:
    """Frames as python-can's ASC writer (and CANalyzer) writes them, many at once: its
    header, then a line a frame, each stamp since the first (python-can's writer takes a
    frame at a time: minutes for a long drive)."""
    hexes = np.char.upper(np.char.mod("%02x", data)).reshape(data.shape)
    body = [" ".join(row) for row in hexes.tolist()]
    t = stamps - stamps[0]
    head = (
        "date Sun Dec 06 23:12:13.18 2026\nbase hex  timestamps absolute\n"
        "internal events logged\nBegin Triggerblock Sun Dec 06 23:12:13.18 2026\n"
        " 0.000000 Start of measurement\n"
    )
    lines = [
        f"{s:9.6f} 1  {i:<15X} Rx   d {len(b) // 3 + 1:X} {b}"
        for s, i, b in zip(t.tolist(), ids.tolist(), body, strict=True)
    ]
    path.write_text(head + "\n".join(lines) + "\nEnd TriggerBlock\n")
    return path


def write_candump(stamps: np.ndarray, ids: np.ndarray, data: np.ndarray, path: Path) -> Path:
    """Frames as ``candump -l`` writes them, many at once (python-can's writer takes a
    frame at a time: minutes for a long drive)."""
    hexes = np.char.upper(np.char.mod("%02x", data)).reshape(data.shape)
    body = ["".join(row) for row in hexes.tolist()]
    lines = [
        f"({t:.6f}) can0 {i:03X}#{b}"
        for t, i, b in zip(stamps.tolist(), ids.tolist(), body, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_asc_in_zone(
    stamps: np.ndarray, ids: np.ndarray, data: np.ndarray, path: Path, zone: str
) -> float:
    """Frames as CANalyzer on a computer whose clock keeps ``zone``'s local time logs
    them: an ASC whose date line is the measurement's start on that clock (to the
    millisecond, as CANoe writes it) and whose stamps are seconds since it. The start is a
    whole millisecond 0.5 s before the first frame, where a frame of an identifier no
    database defines (0x7FF, other traffic on the bus) is logged. Returns the start, Unix
    seconds."""
    from datetime import datetime
    from zoneinfo import ZoneInfo

    from can.io.asc import ASCWriter

    start = np.floor((float(stamps[0]) - 0.5) * 1000.0) / 1000.0
    first = np.zeros((1, data.shape[1]), data.dtype)
    write_bus_log(
        np.r_[start, stamps], np.r_[0x7FF, ids], np.vstack([first, data]), path, channel="1"
    )
    wall = datetime.fromtimestamp(start, ZoneInfo(zone)).replace(tzinfo=None)
    date = ASCWriter._format_header_datetime(ASCWriter, wall)  # python-can writing it
    lines = path.read_text().splitlines(keepends=True)
    assert lines[0].startswith("date ")
    lines[0] = f"date {date}\n"
    lines = [
        f"Begin Triggerblock {date}\n" if x.startswith("Begin Triggerblock") else x for x in lines
    ]
    path.write_text("".join(lines))
    return start


def write_trc_in_zone(
    stamps: np.ndarray, ids: np.ndarray, data: np.ndarray, path: Path, zone: str
) -> float:
    """Frames as PCAN-View on a computer whose clock keeps ``zone``'s local time logs them:
    a TRC 2.1 whose ``$STARTTIME`` is the measurement's start on that clock (days since
    1899-12-30, ten decimals as PEAK writes them) and each frame's offset from it. The
    start is a whole second before the first frame, where a frame of an identifier no
    database defines (0x7FF) is logged. Written by python-can's writer, its header then
    made PCAN-View's. Returns the start, Unix seconds."""
    from datetime import datetime, timedelta
    from zoneinfo import ZoneInfo

    start = float(np.floor(float(stamps[0])) - 1.0)
    first = np.zeros((1, data.shape[1]), data.dtype)
    write_bus_log(
        np.r_[start, stamps], np.r_[0x7FF, ids], np.vstack([first, data]), path, channel="1"
    )
    wall = datetime.fromtimestamp(start, ZoneInfo(zone)).replace(tzinfo=None)
    days = (wall - datetime(1899, 12, 30)) / timedelta(days=1)
    lines = path.read_text().splitlines(keepends=True)
    assert lines[1].startswith(";$STARTTIME=")
    lines[1] = f";$STARTTIME={days:.10f}\n"
    text = "".join(lines).replace("Generated by python-can TRCWriter", "Generated by PCAN-View")
    path.write_text(text)
    return start


def asc_as_relative(text: str) -> str:
    """An ASC log of absolute stamps written again as CANoe logs it with relative ones:
    ``timestamps relative`` in its header, each event line's stamp the time since the
    event line before it (in whole µs, as the log's 6 digits hold them)."""
    out, before = [], 0
    for line in text.splitlines(keepends=True):
        head = line.split(maxsplit=1)
        if head and head[0].replace(".", "", 1).isdigit():
            us = round(float(head[0]) * 1e6)
            gap, before = us - before, us
            line = line.replace(head[0], f"{gap // 1_000_000}.{gap % 1_000_000:06d}", 1)
        out.append(line.replace("timestamps absolute", "timestamps relative"))
    return "".join(out)


def assert_same_frames(ours, theirs) -> None:  # type: ignore[no-untyped-def]
    """Two readers' ``Frames`` of one log alike, array for array (dtypes too), with the
    same buses, clock and passed-over count."""
    for name in ("t_s", "ids", "extended", "length", "data", "channel", "rows"):
        a, b = getattr(ours, name), getattr(theirs, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert (ours.buses, ours.clock, ours.passed) == (theirs.buses, theirs.clock, theirs.passed)
