"""Canonical column names of a drive after ingestion (SI units, names carry the unit).

Readers (``iovnbd.py``, ``columnmap.py``) are the only modules that know file
column names; everything downstream uses these names.
"""

from __future__ import annotations

import math

T_S = "t_s"  # time, s (monotonic within a drive)
LAT_DEG = "lat_deg"  # WGS84 latitude, deg
LON_DEG = "lon_deg"  # WGS84 longitude, deg
N_SATS = "n_sats"  # GNSS satellites in the fix, count
# The receiver's own estimate of its horizontal position error, m: the root of the sum of
# its east and north variances (DRMS) where it gives them; each reader says what it takes
# (docs/readers.md, "A receiver's stated accuracy").
H_ACC_M = "h_acc_m"
OMEGA_FL = "omega_fl_rad_s"  # wheel angular speed front left, rad/s
OMEGA_FR = "omega_fr_rad_s"
OMEGA_RL = "omega_rl_rad_s"
OMEGA_RR = "omega_rr_rad_s"

# Optional channels of the IO-VNBD layout, converted to SI.
SPEED_GNSS_M_S = "speed_gnss_m_s"
HEADING_DEG = "heading_deg"
HEIGHT_M = "height_m"
YAW_RATE_RAD_S = "yaw_rate_rad_s"
SPEED_VEHICLE_M_S = "speed_vehicle_m_s"
ACC_LON_M_S2 = "acc_lon_m_s2"
ACC_LAT_M_S2 = "acc_lat_m_s2"

SCENARIO = "scenario"  # ';'-joined scenario tags of the row ('' when none/unknown)

WHEELS = (OMEGA_FL, OMEGA_FR, OMEGA_RL, OMEGA_RR)
# The channels a GNSS fix carries (a stream's fixes interpolated onto the grid, a held fix
# placed with its position): rwhonet.data.streams, rwhonet.data.heldfixes.
FIX_CHANNELS = (LAT_DEG, LON_DEG, N_SATS, H_ACC_M, SPEED_GNSS_M_S, HEADING_DEG, HEIGHT_M)
# Feature order of the authors' code: RR, RL, FR, FL (reference notes, "Per-second samples").
FEATURE_WHEEL_ORDER = (OMEGA_RR, OMEGA_RL, OMEGA_FR, OMEGA_FL)
REQUIRED = (T_S, LAT_DEG, LON_DEG, *WHEELS)
OPTIONAL = (
    N_SATS,
    H_ACC_M,
    SPEED_GNSS_M_S,
    HEADING_DEG,
    HEIGHT_M,
    YAW_RATE_RAD_S,
    SPEED_VEHICLE_M_S,
    ACC_LON_M_S2,
    ACC_LAT_M_S2,
)

G_M_S2 = 9.80665
# A stated accuracy's units in a column or signal map -> factor to metres.
ACCURACY_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
# A time's units as numbers -> factor to seconds (a column map's, a signal map's, a header's).
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
# How a CSV cell says "no value", case aside: every reader (ingest's, predict's, text
# times, hemisphere letters) takes these, and only these, for a missing value (NaN). The
# words of pyarrow's and pandas' defaults: Excel's #N/A, and a NaN as old Microsoft C
# runtimes print it (1.#QNAN, -1.#IND); a lone '-' is not among them (a cut-off negative
# number looks the same).
MISSING_CELLS = frozenset(
    {"", "nan", "-nan", "na", "n/a", "#n/a", "#na", "#n/a n/a", "null", "none"}
    | {"1.#ind", "-1.#ind", "1.#qnan", "-1.#qnan"}
)
KMH_M_S = 1.0 / 3.6
# A yaw rate's units in a column or signal map -> factor to rad/s, positive turning left
# (ISO 8855, z up); "cw": a gyro positive clockwise (z down, SAE J670).
YAW_RATE_UNITS = {
    "rad/s": 1.0,
    "deg/s": math.pi / 180.0,
    "rad/s cw": -1.0,
    "deg/s cw": -math.pi / 180.0,
}
# A latitude's and a longitude's units in a column or signal map -> factor to degrees:
# "min", minutes of arc (Racelogic VBOX files log both so); "W", a longitude positive
# west (VBOX's convention too: check the logger's), as against ISO 6709's east.
# "ddmm": degrees and minutes run together (NMEA's ddmm.mmmm), no factor (NaN: a reader
# that multiplied by it would give no values, not wrong ones): rwhonet.data.packed.
DDMM = "ddmm"
DDMM_W = "ddmm W"
LAT_UNITS = {"deg": 1.0, "min": 1.0 / 60.0, DDMM: math.nan}
LON_UNITS = {
    "deg": 1.0,
    "min": 1.0 / 60.0,
    "deg W": -1.0,
    "min W": -1.0 / 60.0,
    DDMM: math.nan,
    DDMM_W: math.nan,
}

# A row block's column GLITCH_FLAG + wheel (booleans, optional): grid rows the stream
# resampler flagged, whose mean of that wheel used a glitched sample, which ``rwhonet
# predict`` repairs (rwhonet.cli.drive.canonical_blocks, rwhonet.data.incremental).
GLITCH_FLAG = "glitch:"
