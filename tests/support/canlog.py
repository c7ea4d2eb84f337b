"""A drive as a CAN logger records it: raw CAN frames in an MDF4 file (ASAM bus logging, as
a CANedge or python-can's MF4Writer writes it) and the DBC that decodes them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet.data import canonical as c

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
_FRAME = np.dtype(
    [
        ("CAN_DataFrame.BusChannel", "<u1"),
        ("CAN_DataFrame.ID", "<u4"),
        ("CAN_DataFrame.IDE", "<u1"),
        ("CAN_DataFrame.DLC", "<u1"),
        ("CAN_DataFrame.DataLength", "<u1"),
        ("CAN_DataFrame.DataBytes", "(8,)u1"),
        ("CAN_DataFrame.Dir", "<u1"),
    ]
)


def write_can_log(df: pd.DataFrame, path: Path, radius_m: float) -> Path:
    """Write the canonical drive ``df`` as raw CAN frames (its wheel speeds times
    ``radius_m`` in km/h, a frame per row; its fixes and satellite counts, a frame each
    where there is a fix) in an MDF4 file; the DBC goes beside it as ``<stem>.dbc``."""
    from asammdf import MDF, Signal
    from asammdf.blocks.v4_blocks import SourceInformation
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS

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
    frames = np.zeros(len(stamps), _FRAME)
    frames["CAN_DataFrame.BusChannel"] = 1
    frames["CAN_DataFrame.ID"] = ids[order]
    frames["CAN_DataFrame.DLC"] = frames["CAN_DataFrame.DataLength"] = 8
    frames["CAN_DataFrame.DataBytes"] = data[order]
    mdf = MDF(version="4.10")
    source = SourceInformation(source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)
    mdf.append(Signal(frames, stamps[order], name="CAN_DataFrame", source=source))
    mdf.save(path, overwrite=True)
    mdf.close()
    path.with_suffix(".dbc").write_text(DBC)
    return path
