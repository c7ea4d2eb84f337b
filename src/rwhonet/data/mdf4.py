"""ASAM MDF4 files (what Vector, ETAS and CANedge loggers write), decoded by ``asammdf``.

A signal map (:mod:`rwhonet.data.signalmap`) names the MDF4 signal of each
canonical quantity and its unit; the signals' physical values (the file's own
conversions applied) and time stamps come from ``asammdf.MDF.get``, so no byte of
the format is parsed here. Signals of one channel group share their time stamps
and form one stream. The clock is the file's master time: seconds since the
measurement's start. A CAN log that still holds raw frames must be decoded with
its DBC first (``asammdf``'s ``extract_bus_logging``, or the logger's tool).
"""

from __future__ import annotations

import gc
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet.config import ColumnSpec
from rwhonet.data.headers import map_unit_name, unit_name
from rwhonet.data.signalmap import Group, build_streams, check_signal_map, to_si
from rwhonet.data.streams import DriveStreams
from rwhonet.errors import InputError, Problem

CLOCK = "the MDF4 file's master time (s since the measurement start)"


def read_mdf4(
    path: Path,
    signal_map: Mapping[str, ColumnSpec],
    radius_m: float | None,
    name: str = "the signal map",
    display: str | None = None,
) -> DriveStreams:
    """Read a drive's signals from an MDF4 file into streams for ``resample``.

    Args:
        path: the MDF4 file (``.mf4``; MDF 3 files too, as ``asammdf`` reads them).
        signal_map: key -> signal name and unit (:func:`check_signal_map`; no ``t``).
        radius_m: the car's nominal tyre radius, for wheel speeds logged in m/s or km/h.
        name: how messages name the map (``data.signal_maps.<name>.signals``, a map file).
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The drive's streams, one per channel group used.

    Raises:
        ConfigError: the signal map is invalid.
        InputError: the file cannot be decoded, a mapped signal is missing or in several
            groups, its unit contradicts the map, or its samples are not numbers; every
            problem is listed.
    """
    from asammdf import MDF  # imported here: it takes most of a second to import

    check_signal_map(name, signal_map, where=name)
    file = display or str(path)
    if not Path(path).is_file():
        raise InputError([Problem(file, None, None, "an MDF4 file", "no such file", None)])
    mdf, problem = _open(MDF, path, file)
    if problem is not None:
        raise InputError([problem], summary=f"cannot decode {file}")
    try:
        return _read(mdf, signal_map, radius_m, name, file)
    finally:
        mdf.close()


def _open(mdf_class, path: Path, file: str) -> tuple[Any, Problem | None]:
    """``asammdf.MDF(path)``, or the problem that it could not be decoded.

    A file asammdf gives up on half way (a truncated log) leaves a half-built reader whose
    destructor fails in turn; Python would print that second error as "Exception ignored
    in ... Traceback" after our report. The half-built reader is collected here, with
    that destructor's error muted, so a refused file shows the report and nothing else.
    """
    hook = sys.unraisablehook
    sys.unraisablehook = _mute
    try:
        try:
            return mdf_class(path), None
        except Exception as err:  # any failure to decode is the file's problem
            expected = "an ASAM MDF file (MDF4, as CAN loggers write it)"
            fix = "export the log as MDF4 (.mf4) from the logger's software"
            problem = Problem.unreadable(file, expected, err, fix)
        gc.collect()  # the error's frames held the half-built reader: it goes now, muted
        return None, problem
    finally:
        sys.unraisablehook = hook


def _mute(_: Any) -> None:
    """An unraisable error (a half-built reader's destructor) that is not the user's."""


def _read(
    mdf, signal_map: Mapping[str, ColumnSpec], radius_m: float | None, name: str, file: str
) -> DriveStreams:
    problems: list[Problem] = []
    by_group: dict[int, dict[str, tuple[np.ndarray | None, np.ndarray, str]]] = {}
    for key, spec in signal_map.items():
        where = mdf.whereis(spec.column)
        if not where:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    f"a signal named {spec.column!r} ({name}.{key})",
                    "no such signal; the file has "
                    + ", ".join(sorted(k for k in mdf.channels_db if k not in ("time", "t")))[:300],
                    f"name the logged signal in {name}.{key}.column",
                )
            )
            continue
        groups = sorted({g for g, _ in where})
        if len(groups) > 1:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    f"one signal named {spec.column!r}",
                    f"{len(groups)} signals of that name, in channel groups {groups}",
                    "rename the copies, or export only the message that carries it",
                )
            )
            continue
        group, index = where[0]
        try:
            signal = mdf.get(spec.column, group=group, index=index)
        except Exception as err:  # a damaged block is the file's problem
            fix = "export the log again from the logger's software"
            problems.append(
                Problem.unreadable(file, "a signal asammdf can decode", err, fix, spec.column)
            )
            continue
        samples = np.asarray(signal.samples)
        if samples.dtype.kind not in "biuf" or samples.ndim != 1:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    "one number per time stamp",
                    f"samples of type {samples.dtype} and shape {samples.shape}",
                    "map a numeric signal (decode raw CAN frames with the DBC first)",
                )
            )
            continue
        declared = unit_name(signal.unit or None)
        mapped = map_unit_name(spec.unit)
        if declared is not None and mapped is not None and declared != mapped:
            problems.append(
                Problem(
                    file,
                    None,
                    spec.column,
                    f"the unit {spec.unit!r} ({name}.{key})",
                    f"the file says {signal.unit!r}",
                    f"set {name}.{key}.unit to the file's unit",
                )
            )
            continue
        # The signals of a group share its time stamps: keep the first signal's only (a long
        # log's stamps are hundreds of MB per signal).
        t = None if group in by_group else np.asarray(signal.timestamps, dtype=np.float64)
        values = to_si(
            key, samples, spec.unit, radius_m, f"{file} {spec.column!r}", (file, spec.column)
        )
        del signal, samples
        by_group.setdefault(group, {})[key] = (t, values, spec.column)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) reading {file}")
    groups = []
    for g, channels in sorted(by_group.items()):
        t = next(iter(channels.values()))[0]  # the group's first signal's stamps
        groups.append(
            Group(
                f"channel group {g}",
                file,
                t,
                {k: v for k, (_, v, _) in channels.items()},
                {"t": "master time"} | {k: s for k, (_, _, s) in channels.items()},
            )
        )
    return build_streams(groups, CLOCK)
