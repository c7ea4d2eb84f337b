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


def minute_fixes():
    """The minute's recorded u-blox fixes as a GNSS table (9 satellites each) and their UTC
    times (s since 1970) to 0.01 s, as an NMEA writer writes them (the recorded UTC ms sit
    1 ms before the receiver's 100 ms epochs: 8.299 s)."""
    import pandas as pd

    from rwhonet.data import canonical as c

    vg = real_minute().gnss
    fixes = pd.DataFrame(
        {
            c.LAT_DEG: vg[:, 0],
            c.LON_DEG: vg[:, 1],
            c.N_SATS: 9.0,
            c.SPEED_GNSS_M_S: vg[:, 2],
            c.HEADING_DEG: vg[:, 5],
        }
    )
    return fixes, np.round(vg[:, 3] / 1000.0, 2)


def write_minute_nmea(folder, fixes, t):
    """The fixes as the receiver's GGA and RMC sentences (``gps.nmea``)."""
    from rwhonet.data import canonical as c
    from support.nmea import gga, rmc, write_nmea

    cols = fixes[[c.LAT_DEG, c.LON_DEG, c.SPEED_GNSS_M_S, c.HEADING_DEG]].to_numpy()
    lines = []
    for i in range(len(t)):
        lines += [gga(t[i], cols[i, 0], cols[i, 1], 9), rmc(t[i], *cols[i])]
    return write_nmea(folder / "gps.nmea", lines)


def minute_seconds(folder, write_fixes):
    """The minute's labelled seconds from a folder of its wheel speeds in ``wheels.csv``
    (m/s, on the receiver's UTC: the phone's boot clock put on it by the receiver's own
    clock fit) and its fixes written by ``write_fixes(folder, fixes, t)``
    (:func:`minute_fixes`), read and resampled as a stream folder; and the notes."""
    import pandas as pd

    from rwhonet.config import ColumnSpec
    from rwhonet.data.fixtimes import receiver_epochs
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample
    from support.multirate import per_second

    minute = real_minute()
    fit = receiver_epochs(minute.t_gnss, minute.gnss[:, 3])
    utc = minute.t_wheels + fit.offset_s + fit.drift * (minute.t_wheels - fit.t_ref_s)
    folder.mkdir(parents=True)
    names = ("fl", "fr", "rl", "rr")
    columns = {"t": utc} | {w: minute.wheels[:, k] for k, w in enumerate(names)}
    pd.DataFrame(columns).to_csv(folder / "wheels.csv", index=False, float_format="%.6f")
    write_fixes(folder, *minute_fixes())
    smap = {"t": ColumnSpec("t", "s")} | {f"omega_{w}": ColumnSpec(w, "m/s") for w in names}
    streams = read_stream_csvs(sorted(folder.iterdir()), smap, RAV4_RADIUS_M, "map")
    drive = resample(streams, nominal_radius_m=RAV4_RADIUS_M).drive.columns
    return per_second(drive, RAV4_RADIUS_M), " ".join(streams.notes)
