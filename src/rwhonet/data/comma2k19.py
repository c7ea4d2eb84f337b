"""The comma2k19 / openpilot processed-log folder: one folder per channel, NumPy arrays inside.

Layout (the comma2k19 dataset, ``commaai/comma2k19``; a segment's ``processed_log``):
every channel is a folder holding ``t`` (time, s, on the recording device's boot
clock, one clock for every channel) and ``value`` (one row per time), NumPy
``.npy`` arrays saved without the extension. ``numpy.load`` decodes them; this
module only knows which folder holds what:

==============================  =============================================================
``CAN/wheel_speed``             four columns: front left, front right, rear left, rear right,
                                m/s (the car's circumferential wheel speeds; divided by the
                                tyre radius here)
``GNSS/live_gnss_ublox``        latitude (deg), longitude (deg), speed (m/s), UTC time (ms),
                                altitude (m), bearing (deg) (``GNSS/live_gnss_qcom``, the
                                phone's own receiver, when there is no u-blox)
``IMU/gyro``                    angular rate about the phone's [forward, right, down] axes,
                                rad/s (optional)
``CAN/speed``                   the car's speed, m/s (optional)
==============================  =============================================================

The yaw rate is the rate about the vertical, in the canonical convention of
ISO 8855 (z up, positive turning left, as the simulator writes it): minus the
gyro's rate about *down*. The GNSS stream has no satellite count, so validate's
``low_sats`` rule does not apply to such a drive.

GNSS time
    A fix's ``t`` is when the logging device received it, after the receiver's
    processing and the serial link: it trails the fix's own epoch by a latency
    that varies from fix to fix (9 ms standard deviation on the example segment:
    0.15 m of position at 17 m/s). The receiver stamps each fix with its epoch
    (value column 3, UTC in ms, on whole 100 ms of GPS time), as a logger like
    the VBOX records GNSS on its own time base.
    :func:`rwhonet.data.fixtimes.receiver_epochs` maps
    those epochs onto the device's clock with one robust straight-line fit of
    ``UTC - t`` against ``t`` over the drive's fixes: an offset and a drift
    (the device clock's rate error; slope: the median of the slopes between
    fixes half the drive apart; offset: the median of the residuals, so a fix
    is placed at its epoch plus the *median* latency of the log, a constant
    shift that the wheel speeds' own CAN latency shares in kind). The fixes
    then sit at their epochs, 100 ms apart, and the jitter of the log stamps is
    gone. A drive whose UTC column does not fit such a line (missing, not
    increasing, or residuals above :data:`MAX_EPOCH_SCATTER_S`) keeps the log
    stamps, and the notes say so; the resampler then places the fixes on the
    regular grid of the receiver's rate where the wheel speeds fit that grid
    better than the stamps (:func:`rwhonet.data.fixtimes.fix_times`: on the example
    segment without its UTC column it finds the same epochs, to a microsecond).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.fixtimes import MAX_EPOCH_SCATTER_S, receiver_epochs
from rwhonet.data.sampleorder import time_order
from rwhonet.data.streams import DriveStreams, Stream
from rwhonet.data.wheelunits import wheel_speed_rad_s
from rwhonet.errors import InputError, Problem

WHEEL_SPEED = "CAN/wheel_speed"
GNSS = ("GNSS/live_gnss_ublox", "GNSS/live_gnss_qcom")
GYRO = "IMU/gyro"
CAR_SPEED = "CAN/speed"
PROCESSED_LOG = "processed_log"
# Columns of the GNSS value array.
_GNSS_COLUMNS = {c.LAT_DEG: 0, c.LON_DEG: 1, c.SPEED_GNSS_M_S: 2, c.HEIGHT_M: 4, c.HEADING_DEG: 5}
_GNSS_NAMES = {
    c.LAT_DEG: "latitude",
    c.LON_DEG: "longitude",
    c.SPEED_GNSS_M_S: "speed",
    c.HEIGHT_M: "altitude",
    c.HEADING_DEG: "bearing",
}
UTC_COLUMN = 3  # of the GNSS value array: the receiver's epoch, UTC, ms
_WHEEL_NAMES = {
    c.OMEGA_FL: "front left",
    c.OMEGA_FR: "front right",
    c.OMEGA_RL: "rear left",
    c.OMEGA_RR: "rear right",
}


def processed_log(folder: Path) -> Path:
    """The ``processed_log`` folder of a segment folder (or the folder itself)."""
    folder = Path(folder)
    inner = folder / PROCESSED_LOG
    return inner if inner.is_dir() else folder


def read_comma2k19(
    folder: Path, radius_m: float, display: str | None = None, wheel_unit: str = "m/s"
) -> DriveStreams:
    """Read a comma2k19 segment into streams for :func:`rwhonet.data.streams.resample`.

    Args:
        folder: the segment folder, or its ``processed_log`` folder.
        radius_m: the car's nominal tyre radius, m (the CAN wheel speeds are m/s).
        display: how the folder is named in error reports (default: ``folder`` as given).
        wheel_unit: the unit of ``CAN/wheel_speed`` (comma's logs: m/s).

    Returns:
        The wheel-speed stream (rad/s), the GNSS stream (each fix at its receiver epoch on
        the device clock, :func:`receiver_epochs`, when the epochs fit) and, when present,
        the yaw rate (from the gyro) and the car's speed.

    Raises:
        InputError: a missing channel folder or array, an array that is not NumPy data,
            or values of the wrong shape; naming the folder and the array.
    """
    root = processed_log(folder)
    name = display or str(folder)
    problems: list[Problem] = []
    changed: list[str] = []  # what time_order did (copies dropped, samples put in order)
    rows: dict[str, np.ndarray] = {}  # each sample's index in its arrays + 1, where reordered
    if not root.is_dir():
        raise InputError(
            [
                Problem(
                    name,
                    None,
                    None,
                    "a comma2k19 segment folder (with processed_log/CAN, GNSS, IMU)",
                    "no such folder",
                    "give the segment's folder (the one holding processed_log)",
                )
            ]
        )

    def channel(sub: str, columns: int | None, required: bool) -> tuple[np.ndarray, np.ndarray]:
        t = _load(root, sub, "t", name, problems, required)
        v = _load(root, sub, "value", name, problems, required)
        if t is None or v is None:
            return np.zeros(0), np.zeros((0, columns or 1))
        v = v.reshape(-1, 1) if v.ndim == 1 else v
        if t.ndim != 1 or v.ndim != 2 or v.shape[0] != t.size or (columns and v.shape[1] < columns):
            problems.append(
                Problem(
                    f"{name}/{sub}",
                    None,
                    "value",
                    f"one row of {columns or 'some'} value(s) per time in 't' ({t.shape})",
                    f"'value' of shape {v.shape}",
                    "copy the channel folder as the logger wrote it",
                )
            )
            return np.zeros(0), np.zeros((0, columns or 1))
        coarse = _coarse_times(t, f"{name}/{sub}/t")
        if coarse is not None:
            problems.append(coarse)
            return np.zeros(0), np.zeros((0, columns or 1))
        t, v = t.astype(np.float64), v.astype(np.float64)
        # samples written twice dropped, those out of time order put in order where safe,
        # as for the other stream formats (a segment's arrays joined, a conversion's copy)
        by_column = {f"value[:, {k}]": v[:, k] for k in range(v.shape[1])}
        order = time_order(t, by_column, None, f"{name}/{sub}")
        changed.extend(order.notes)
        if order.index is not None:
            t, v = t[order.index], v[order.index]
            rows[sub] = order.index + 1
        return t, v

    gnss_sub = next((g for g in GNSS if (root / g).is_dir()), GNSS[0])
    tw, vw = channel(WHEEL_SPEED, 4, True)
    tg, vg = channel(gnss_sub, 6, True)
    has_gyro = (root / GYRO).is_dir()
    has_speed = (root / CAR_SPEED).is_dir()
    ti, vi = channel(GYRO, 3, False) if has_gyro else (None, None)
    ts, vs = channel(CAR_SPEED, 1, False) if has_speed else (None, None)
    if problems:
        raise InputError(problems, summary=f"cannot read the comma2k19 segment {name}")

    wheel_where = f"{name}/{WHEEL_SPEED}"
    wheels = Stream(
        WHEEL_SPEED,
        name,
        tw,
        {
            w: wheel_speed_rad_s(vw[:, k], wheel_unit, radius_m, wheel_where)
            for k, w in enumerate(c.WHEELS)
        },
        {c.T_S: "t"}
        | {w: f"value[:, {k}] ({_WHEEL_NAMES[w]}, {wheel_unit})" for k, w in enumerate(c.WHEELS)},
        rows.get(WHEEL_SPEED),
    )
    fit = receiver_epochs(tg, vg[:, UTC_COLUMN])
    if fit is None:
        time_source = "t"
        notes = [
            f"{name}/{gnss_sub}: the fixes keep the device's stamps t (the receiver's epochs in "
            f"value[:, {UTC_COLUMN}] do not fit one clock offset: missing, not increasing or "
            f"scattered by more than {MAX_EPOCH_SCATTER_S * 1000:.0f} ms); the resampler moves "
            "them to the regular grid they scatter about where the wheel speeds say so"
        ]
    else:
        tg = fit.on_device_clock(vg[:, UTC_COLUMN] / 1000.0)
        time_source = f"value[:, {UTC_COLUMN}] (receiver epoch, UTC ms) on the device clock"
        notes = [
            f"{name}/{gnss_sub}: fixes placed at their receiver epochs (value[:, {UTC_COLUMN}], "
            f"UTC) on the device clock: t = UTC - {fit.offset_s:.6f} s - drift "
            f"{fit.drift * 1e6:+.2f} ppm x (t - {fit.t_ref_s:.3f} s), fitted robustly over "
            f"{fit.n_fixes} fixes; the log stamps scatter {fit.scatter_s * 1000:.1f} ms around it"
        ]
    gnss = Stream(
        gnss_sub,
        name,
        tg,
        {k: vg[:, col] for k, col in _GNSS_COLUMNS.items()},
        {c.T_S: time_source}
        | {k: f"value[:, {col}] ({_GNSS_NAMES[k]})" for k, col in _GNSS_COLUMNS.items()},
        rows.get(gnss_sub),
    )
    extra = []
    if ti is not None and ti.size:
        extra.append(
            Stream(
                GYRO,
                name,
                ti,
                {c.YAW_RATE_RAD_S: -vi[:, 2]},
                {c.T_S: "t", c.YAW_RATE_RAD_S: "-value[:, 2] (minus the rate about down)"},
                rows.get(GYRO),
            )
        )
    if ts is not None and ts.size:
        extra.append(
            Stream(
                CAR_SPEED,
                name,
                ts,
                {c.SPEED_VEHICLE_M_S: vs[:, 0]},
                {c.T_S: "t", c.SPEED_VEHICLE_M_S: "value"},
                rows.get(CAR_SPEED),
            )
        )
    return DriveStreams(
        (wheels,),
        gnss,
        tuple(extra),
        clock="the device's boot clock",
        notes=tuple(notes),
        changed=tuple(changed),
    )


def _coarse_times(t: np.ndarray, where: str) -> Problem | None:
    """Time stamps saved in a float type too coarse for the clock: the cause named.

    comma's arrays are float64; saved as float32 (about 7 digits), a boot clock of hours
    keeps only a few milliseconds, and an 83 Hz CAN stream's samples repeat their stamps,
    which the resampler would report as time going back.
    """
    if t.dtype.kind != "f" or t.dtype.itemsize >= 8 or t.size < 2:
        return None
    repeated = int((np.diff(t) <= 0).sum())
    if not repeated:
        return None
    finest = float(np.spacing(np.abs(t).max()))
    return Problem(
        where,
        None,
        "t",
        "time stamps saved as float64 (numpy.save of the log's times)",
        f"{t.dtype} stamps: at {float(np.abs(t).max()):.6g} s they are {finest:.3g} s apart "
        f"at the finest, so {repeated} of {t.size} samples repeat the stamp before them",
        "save the arrays as float64: float32 keeps about 7 digits, too few for a clock of hours",
    )


def _load(
    root: Path, sub: str, array: str, name: str, problems: list[Problem], required: bool
) -> np.ndarray | None:
    path = root / sub / array
    where = f"{name}/{sub}/{array}"
    if not path.is_file():
        if required:
            problems.append(
                Problem(
                    where,
                    None,
                    None,
                    f"the NumPy array '{array}' of channel {sub}",
                    "no such file",
                    f"copy the channel folder {sub} with its 't' and 'value' arrays",
                )
            )
        return None
    try:
        # allow_pickle=False: a data file never runs code.
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as err:
        problems.append(
            Problem(
                where,
                None,
                None,
                "a NumPy array file (numpy.save's format)",
                f"{type(err).__name__}: {str(err)[:120]}",
                "copy the file again from the dataset (it is damaged or not an array)",
            )
        )
        return None
