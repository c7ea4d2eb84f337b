"""The one real drive we have: a minute of a Toyota RAV4 (comma2k19, MIT licence; its
README says what is in it), for tests that read it or write it as another logger would."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import pytest

from rwhonet import paths

REAL = paths.ROOT.parent / "shared" / "real" / "comma2k19-example1"
RAV4_RADIUS_M = 0.362  # 225/65 R17, unloaded (the folder's README)


@dataclass(frozen=True)
class Minute:
    """The minute's streams as comma2k19's processed log holds them, on the phone's boot
    clock: the CAN wheel speeds (m/s: fl, fr, rl, rr) and the u-blox fixes (lat, lon,
    height, UTC ms, speed, course)."""

    t_wheels: np.ndarray
    wheels: np.ndarray
    t_gnss: np.ndarray
    gnss: np.ndarray


def real_minute() -> Minute:
    """The minute's streams (the test is skipped where the segment is not on the machine)."""
    log = REAL / "processed_log"
    if not log.is_dir():
        pytest.skip(f"the real comma2k19 segment is not on this machine ({REAL})")
    return Minute(
        np.load(log / "CAN/wheel_speed/t"),
        np.load(log / "CAN/wheel_speed/value"),
        np.load(log / "GNSS/live_gnss_ublox/t"),
        np.load(log / "GNSS/live_gnss_ublox/value"),
    )


@cache
def reference_seconds():
    """The comma2k19 reader's labelled seconds of the minute (the reference the other
    loggers' forms of it are held to)."""
    from rwhonet.data.comma2k19 import read_comma2k19
    from rwhonet.data.streams import resample
    from support.multirate import per_second

    real_minute()
    drive = resample(read_comma2k19(REAL, RAV4_RADIUS_M), nominal_radius_m=RAV4_RADIUS_M)
    return per_second(drive.drive.columns, RAV4_RADIUS_M)
