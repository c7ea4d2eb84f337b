"""IO-VNBD "V-" drive files (shared/reference/iovnbd-format.md).

The only module that knows the IO-VNBD header names. Real headers start with
a space (" Wheel Speed Front Left (rad/sec)"); columns are matched by
stripped, case-insensitive name and fall back to position.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from rwhonet.data import canonical as c


class IovnbdColumn(NamedTuple):
    header: str            # as written in the file (leading space included)
    canonical: str | None  # canonical name, None when not carried downstream
    to_si: float           # factor converting the file's unit to the canonical SI unit


# Position (0-based) == index in this tuple.
LAYOUT: tuple[IovnbdColumn, ...] = (
    IovnbdColumn("Sats", c.N_SATS, 1.0),
    IovnbdColumn(" Time", c.T_S, 1.0),
    IovnbdColumn(" Lat", c.LAT_DEG, 1.0),
    IovnbdColumn(" Long", c.LON_DEG, 1.0),
    IovnbdColumn(" Velocity kmh", c.SPEED_GNSS_M_S, c.KMH_M_S),
    IovnbdColumn(" Heading", c.HEADING_DEG, 1.0),
    IovnbdColumn(" Height", c.HEIGHT_M, 1000.0),
    IovnbdColumn(" Vertical velocity kmh", None, c.KMH_M_S),
    IovnbdColumn(" Sample Period", None, 1.0),
    IovnbdColumn(" Steering Angle (deg)", None, 1.0),
    IovnbdColumn(" Wheel Speed Front Left (rad/sec)", c.OMEGA_FL, 1.0),
    IovnbdColumn(" Wheel Speed Front Right (rad/sec)", c.OMEGA_FR, 1.0),
    IovnbdColumn(" Wheel Speed Rear Left (rad/sec)", c.OMEGA_RL, 1.0),
    IovnbdColumn(" Wheel Speed Rear Right (rad/sec)", c.OMEGA_RR, 1.0),
    IovnbdColumn(" Yaw Rate (deg/sec)", c.YAW_RATE_RAD_S, math.pi / 180.0),
    IovnbdColumn(" Indicated Vehicle Speed (km/h)", c.SPEED_VEHICLE_M_S, c.KMH_M_S),
    IovnbdColumn(" Indicated Longitudinal Acceleration (g)", c.ACC_LON_M_S2, c.G_M_S2),
    IovnbdColumn(" Indicated Lateral Acceleration (g)", c.ACC_LAT_M_S2, c.G_M_S2),
    IovnbdColumn(" Handbrake", None, 1.0),
    IovnbdColumn(" Gear Requested", None, 1.0),
    IovnbdColumn(" Gear", None, 1.0),
    IovnbdColumn(" Engine Speed (rpm)", None, 1.0),
    IovnbdColumn(" Coolant Temperature (degC)", None, 1.0),
    IovnbdColumn(" Clutch Position", None, 1.0),
    IovnbdColumn(" Brake Pressure (psi)", None, 1.0),
    IovnbdColumn(" Brake Position", None, 1.0),
    IovnbdColumn(" Battery Voltage (V)", None, 1.0),
    IovnbdColumn(" Air Temperature (degC)", None, 1.0),
    IovnbdColumn(" Accelerator Pedal Position (%)", None, 1.0),
)

HEADERS: tuple[str, ...] = tuple(col.header for col in LAYOUT)
