"""The comma2k19 / openpilot processed-log folder: one folder per channel, NumPy arrays inside.

Layout (the comma2k19 dataset, ``commaai/comma2k19``; a segment's ``processed_log``):
every channel is a folder holding ``t`` (time, s, on the recording device's boot
clock, one clock for every channel) and ``value`` (one row per time), NumPy
``.npy`` arrays saved without the extension. ``numpy.load`` decodes them; this
module only knows which folder holds what:

==============================  =============================================================
``CAN/wheel_speed``             four columns: front left, front right, rear left, rear right,
                                m/s (the car's circumferential wheel speeds; divided by the
                                tyre radius here); ``CAN/wheel_speeds`` as the dataset's
                                README names it
``GNSS/live_gnss_ublox``        latitude (deg), longitude (deg), speed (m/s), UTC time (ms),
                                altitude (m), bearing (deg) (``GNSS/live_gnss_qcom``, the
                                phone's own receiver, when there is no u-blox)
``IMU/gyro``                    angular rate about the phone's [forward, right, down] axes,
                                rad/s (optional)
``CAN/speed``                   the car's speed, m/s (optional; ``CAN/car_speed``)
==============================  =============================================================

A route (the dataset's ``<dongle_id>|<start time>`` folder) holds one such folder per
one-minute segment, named by its number, on the device's one boot clock: read as one
drive (:func:`route_segments`, :func:`read_comma2k19`).

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
from rwhonet.data.fileparts import join_parts
from rwhonet.data.fixtimes import MAX_EPOCH_SCATTER_S, receiver_epochs
from rwhonet.data.sampleorder import time_order
from rwhonet.data.signalmap import Group, in_time_order
from rwhonet.data.streams import DriveStreams, Stream
from rwhonet.data.wheelunits import wheel_speed_rad_s
from rwhonet.errors import InputError, Problem

# Each channel's folder: the first of the names that is there. The dataset's folders are
# CAN/wheel_speed and CAN/speed; its README (Log Format) writes wheel_speeds and car_speed.
WHEEL_SPEED = ("CAN/wheel_speed", "CAN/wheel_speeds")
GNSS = ("GNSS/live_gnss_ublox", "GNSS/live_gnss_qcom")
GYRO = ("IMU/gyro",)
CAR_SPEED = ("CAN/speed", "CAN/car_speed")
PROCESSED_LOG = "processed_log"
SEGMENT_FOLDERS = ("CAN", "GNSS", "IMU")  # under processed_log: what makes a segment
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


def _is_segment(folder: Path) -> bool:
    root = processed_log(folder)
    return any((root / top).is_dir() for top in SEGMENT_FOLDERS)


def route_segments(folder: Path) -> list[Path]:
    """A comma2k19 route folder's segment folders, in segment-number order.

    A route (``dongle_id|start time``) holds one folder per one-minute segment, named by
    its number (``0``, ``1``, ... ``40``); every folder named by a number counts once one
    of them is a segment. Empty where ``folder`` is a segment itself, or holds none.
    """
    folder = Path(folder)
    if not folder.is_dir() or _is_segment(folder):
        return []
    numbered = [p for p in folder.iterdir() if p.is_dir() and p.name.isdigit()]
    if not any(_is_segment(p) for p in numbered):
        return []
    return sorted(numbered, key=lambda p: int(p.name))


def _routes_in(folder: Path) -> list[str]:
    """The names of the route folders a folder holds (a dataset chunk's)."""
    return sorted(p.name for p in folder.iterdir() if p.is_dir() and route_segments(p))


def read_comma2k19(
    folder: Path, radius_m: float, display: str | None = None, wheel_unit: str = "m/s"
) -> DriveStreams:
    """Read a comma2k19 segment, or a route of segments, into streams for
    :func:`rwhonet.data.streams.resample`.

    A route folder's segments (:func:`route_segments`) are one drive: each channel's
    arrays joined in segment order on the device's boot clock, as a stream a logger split
    across files (:func:`rwhonet.data.fileparts.join_parts`: each segment's samples put
    in time order, a sample written into two segments taken once, any other overlap
    refused naming both). A segment not in the folder, or a channel a segment lacks,
    leaves a hole, said in the notes; a segment that starts before the one numbered
    before it (a clock restarted) is refused.

    Args:
        folder: the segment folder, or its ``processed_log`` folder, or a route folder.
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
    name = display or str(folder)
    if segments := route_segments(folder):
        return _read_route(segments, radius_m, name, wheel_unit)
    root = processed_log(folder)
    problems: list[Problem] = []
    changed: list[str] = []  # what time_order did (copies dropped, samples put in order)
    if root.is_dir() and not _is_segment(root) and (routes := _routes_in(root)):
        raise InputError(
            [
                Problem(
                    name,
                    None,
                    None,
                    "a comma2k19 segment folder, or a route folder of numbered segment folders",
                    f"a folder of {len(routes)} route(s) ({', '.join(routes[:2])}"
                    f"{', ...' if len(routes) > 2 else ''}), as a dataset chunk holds them",
                    "give each route as a drive: a role's glob of the routes "
                    "('Chunk_1/*') for the pipeline, one route's folder for --drive",
                )
            ]
        )
    if not root.is_dir():
        raise InputError(
            [
                Problem(
                    name,
                    None,
                    None,
                    "a comma2k19 segment folder (with processed_log/CAN, GNSS, IMU), or a route "
                    "folder of numbered segment folders",
                    "no such folder",
                    "give the segment's folder (the one holding processed_log), or the route's",
                )
            ]
        )

    def channel(sub: str, columns: int | None, required: bool) -> Group | None:
        loaded = _channel(root, sub, columns, required, name, problems)
        if loaded is None:
            return None
        t, v = loaded
        # samples written twice dropped, those out of time order put in order where safe,
        # as for the other stream formats (a segment's arrays joined, a conversion's copy)
        by_column = {f"value[:, {k}]": v[:, k] for k in range(v.shape[1])}
        order = time_order(t, by_column, None, f"{name}/{sub}")
        changed.extend(order.notes)
        rows = None
        if order.index is not None:
            t, v = t[order.index], v[order.index]
            rows = order.index + 1
        return _group(sub, name, t, v, rows)

    def there(names: tuple[str, ...]) -> str:
        return next((g for g in names if (root / g).is_dir()), names[0])

    wheels = channel(there(WHEEL_SPEED), 4, True)
    gnss = channel(there(GNSS), 6, True)
    gyro = channel(there(GYRO), 3, False) if (root / there(GYRO)).is_dir() else None
    speed = channel(there(CAR_SPEED), 1, False) if (root / there(CAR_SPEED)).is_dir() else None
    if problems or wheels is None or gnss is None:
        raise InputError(problems, summary=f"cannot read the comma2k19 segment {name}")
    return _drive_streams(name, wheels, gnss, gyro, speed, radius_m, wheel_unit, [], changed)


def _read_route(segments: list[Path], radius_m: float, name: str, wheel_unit: str) -> DriveStreams:
    """The segments of a route as one drive (:func:`read_comma2k19`)."""
    numbers = [int(p.name) for p in segments]
    shown = [f"{name}/{p.name}" for p in segments]
    roots = [processed_log(p) for p in segments]
    problems: list[Problem] = []
    notes = [
        f"{name}: a comma2k19 route of {len(segments)} segment(s) ({_numbers(numbers)}), read "
        "as one drive on the device's boot clock"
    ]
    if missing := sorted(set(range(numbers[0], numbers[-1] + 1)) - set(numbers)):
        notes.append(
            f"{name}: segment(s) {_numbers(missing)} not in the folder: the drive has a hole "
            "there (validate cuts it as a gap)"
        )
    changed: list[str] = []

    def channel(subs: tuple[str, ...], columns: int, required: bool) -> Group | None:
        # the first of subs every segment holds (else the first any holds)
        sub = next(
            (g for g in subs if all((r / g).is_dir() for r in roots)),
            next((g for g in subs if any((r / g).is_dir() for r in roots)), subs[0]),
        )
        before = len(problems)
        groups = []
        for root, where in zip(roots, shown, strict=True):
            if not required and not (root / sub).is_dir():
                continue
            loaded = _channel(root, sub, columns, required, where, problems)
            if loaded is not None:
                groups.append(_group(sub, where, *loaded))
        if not groups:
            return None
        if not required and len(groups) < len(segments):
            have = {g.file for g in groups}
            lacking = [n for n, w in zip(numbers, shown, strict=True) if w not in have]
            notes.append(
                f"{name}: {sub} in {len(groups)} of {len(segments)} segments (not in "
                f"{_numbers(lacking)}): missing there"
            )
        problems.extend(_restarted(groups))
        if len(problems) > before:
            return None
        if len(groups) == 1:
            one, said = in_time_order(groups[0])
            changed.extend(said)
            return one
        said: list[str] = []
        try:
            (joined,) = join_parts(groups, said, changed)
        except InputError as err:
            problems.extend(err.problems)
            return None
        # the join's own note names the files (here the segments) but not the channel
        notes.extend(x for x in said if "one stream split across" not in x)
        ends = np.flatnonzero(np.diff(joined.part) != 0)
        steps = np.asarray(joined.t_s)[ends + 1] - np.asarray(joined.t_s)[ends]
        widest = f"; the longest step between two {float(steps.max()):.3g} s" if steps.size else ""
        notes.append(f"{name}: {sub} of {len(groups)} segments joined in time order{widest}")
        return joined

    wheels = channel(WHEEL_SPEED, 4, True)
    gnss = channel(GNSS, 6, True)
    gyro = channel(GYRO, 3, False)
    speed = channel(CAR_SPEED, 1, False)
    if problems or wheels is None or gnss is None:
        raise InputError(problems, summary=f"cannot read the comma2k19 route {name}")
    return _drive_streams(name, wheels, gnss, gyro, speed, radius_m, wheel_unit, notes, changed)


def _numbers(numbers: list[int]) -> str:
    """Segment numbers as runs: ``3-5, 9``."""
    runs: list[list[int]] = []
    for n in numbers:
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)


def _restarted(groups: list[Group]) -> list[Problem]:
    """A segment whose samples start before those of the segment numbered before it: the
    device's clock restarted between them (not one route), refused naming both."""
    out = []
    for prev, g in zip(groups, groups[1:], strict=False):
        t_prev, t = np.asarray(prev.t_s), np.asarray(g.t_s)
        if t.size and t_prev.size and np.nanmin(t) < np.nanmin(t_prev):
            out.append(
                Problem(
                    f"{g.file}/{g.name}/t",
                    1,
                    "t",
                    f"a segment starting after the one numbered before it ({prev.file}, which "
                    f"starts at t = {float(np.nanmin(t_prev))!r} s on the boot clock)",
                    f"t = {float(np.nanmin(t))!r} s: the device's clock restarted between them",
                    "a route is one run of the device; give the segments after the restart "
                    "as a drive of their own",
                )
            )
    return out


def _group(
    sub: str, file: str, t: np.ndarray, v: np.ndarray, rows: np.ndarray | None = None
) -> Group:
    """A channel's arrays as a group of channels ``value[:, k]`` (one per column)."""
    columns = {f"value[:, {k}]": v[:, k] for k in range(v.shape[1])}
    return Group(sub, file, t, columns, {"t": "t"}, rows)


def _stream(g: Group, channels: dict[str, np.ndarray], sources: dict[str, str]) -> Stream:
    """A channel's group as the stream of ``channels`` (canonical names)."""
    return Stream(g.name, g.file, g.t_s, channels, sources, g.rows, g.parts, g.part)


def _drive_streams(
    name: str,
    wheels: Group,
    gnss: Group,
    gyro: Group | None,
    speed: Group | None,
    radius_m: float,
    wheel_unit: str,
    notes: list[str],
    changed: list[str],
) -> DriveStreams:
    """The drive's streams from its channels' groups (a segment's, or a route's joined)."""
    value = wheels.channels
    # the channel as a problem names it: one folder's, or the route's joined channel
    wheel_where = wheels.where if wheels.parts else f"{wheels.file}/{wheels.name}"
    wheel_stream = _stream(
        wheels,
        {
            w: wheel_speed_rad_s(value[f"value[:, {k}]"], wheel_unit, radius_m, wheel_where)
            for k, w in enumerate(c.WHEELS)
        },
        {c.T_S: "t"}
        | {w: f"value[:, {k}] ({_WHEEL_NAMES[w]}, {wheel_unit})" for k, w in enumerate(c.WHEELS)},
    )
    fixes = gnss.channels
    tg = np.asarray(gnss.t_s)
    utc = fixes[f"value[:, {UTC_COLUMN}]"]
    fit = receiver_epochs(tg, utc)
    sub = gnss.name
    if fit is None:
        time_source = "t"
        notes.append(
            f"{name}/{sub}: the fixes keep the device's stamps t (the receiver's epochs in "
            f"value[:, {UTC_COLUMN}] do not fit one clock offset: missing, not increasing or "
            f"scattered by more than {MAX_EPOCH_SCATTER_S * 1000:.0f} ms); the resampler moves "
            "them to the regular grid they scatter about where the wheel speeds say so"
        )
    else:
        tg = fit.on_device_clock(utc / 1000.0)
        time_source = f"value[:, {UTC_COLUMN}] (receiver epoch, UTC ms) on the device clock"
        notes.append(
            f"{name}/{sub}: fixes placed at their receiver epochs (value[:, {UTC_COLUMN}], "
            f"UTC) on the device clock: t = UTC - {fit.offset_s:.6f} s - drift "
            f"{fit.drift * 1e6:+.2f} ppm x (t - {fit.t_ref_s:.3f} s), fitted robustly over "
            f"{fit.n_fixes} fixes; the log stamps scatter {fit.scatter_s * 1000:.1f} ms around it"
        )
    gnss_stream = Stream(
        sub,
        gnss.file,
        tg,
        {k: fixes[f"value[:, {col}]"] for k, col in _GNSS_COLUMNS.items()},
        {c.T_S: time_source}
        | {k: f"value[:, {col}] ({_GNSS_NAMES[k]})" for k, col in _GNSS_COLUMNS.items()},
        gnss.rows,
        gnss.parts,
        gnss.part,
    )
    extra = []
    if gyro is not None and np.size(gyro.t_s):
        extra.append(
            _stream(
                gyro,
                {c.YAW_RATE_RAD_S: -gyro.channels["value[:, 2]"]},
                {c.T_S: "t", c.YAW_RATE_RAD_S: "-value[:, 2] (minus the rate about down)"},
            )
        )
    if speed is not None and np.size(speed.t_s):
        extra.append(
            _stream(
                speed,
                {c.SPEED_VEHICLE_M_S: speed.channels["value[:, 0]"]},
                {c.T_S: "t", c.SPEED_VEHICLE_M_S: "value"},
            )
        )
    return DriveStreams(
        (wheel_stream,),
        gnss_stream,
        tuple(extra),
        clock="the device's boot clock",
        notes=tuple(notes),
        changed=tuple(changed),
    )


def _channel(
    root: Path,
    sub: str,
    columns: int | None,
    required: bool,
    name: str,
    problems: list[Problem],
) -> tuple[np.ndarray, np.ndarray] | None:
    """A channel's ``t`` and ``value`` arrays (float64, ``value`` two-dimensional), or None
    with the problem added: an array missing (where ``required``) or damaged, shapes that
    do not match, stamps saved too coarse for the clock."""
    t = _load(root, sub, "t", name, problems, required)
    v = _load(root, sub, "value", name, problems, required)
    if t is None or v is None:
        return None
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
        return None
    coarse = _coarse_times(t, f"{name}/{sub}/t")
    if coarse is not None:
        problems.append(coarse)
        return None
    return t.astype(np.float64), v.astype(np.float64)


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
