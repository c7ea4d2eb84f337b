"""Signal maps: which logged channel holds which canonical quantity, in which unit.

The stream readers (:mod:`rwhonet.data.mdf4`, :mod:`rwhonet.data.streamcsv`)
are told by a map, as the 10 Hz column maps are (``params.yaml:
data.column_maps``): each key names the logger's channel (an MDF4 signal, a CSV
column) and its unit. Keys and units:

============================================  =================================================
``omega_fl``, ``omega_fr``, ``omega_rl``,     ``rad/s``, ``rpm``, ``deg/s``; or the wheel's
``omega_rr`` (required)                       circumferential speed ``m/s``, ``km/h``, ``mph``
                                              (divided by the car's nominal tyre radius);
                                              or the wheel's pulse counter, ``pulses/N``
                                              or ``pulses/N mod M``
                                              (:mod:`rwhonet.data.wheelpulses`)
``lat``, ``lon`` (required)                   ``deg``, ``min`` (minutes of arc), ``ddmm``
                                              (NMEA's ddmm.mmmm); ``lon`` also ``deg W``,
                                              ``min W``, ``ddmm W`` (positive west)
``t`` (CSV streams: required in every file)   ``s``, ``ms``, ``us``, ``ns``; ``hhmmss`` (a
                                              time of day as hhmmss.ss); as text
                                              ``iso8601``, ``hh:mm:ss`` or a strptime pattern
``n_sats``                                    ``count``; ``vbox`` (a VBOX's count, its flags
                                              taken off)
``h_acc``                                     ``m``, ``cm``, ``mm``: the receiver's stated
                                              horizontal accuracy (DRMS; docs/readers.md)
``speed_gnss``, ``speed_vehicle``             ``m/s``, ``km/h``, ``mph``
``heading``                                   ``deg``
``height``                                    ``m``, ``km``
``yaw_rate``                                  ``rad/s``, ``deg/s`` (positive turning left, ISO
                                              8855 z up); ``rad/s cw``, ``deg/s cw`` for a
                                              gyro positive clockwise (z down)
``acc_lon``, ``acc_lat``                      ``m/s2``, ``g``
``fix``                                       ``gga``, ``ubx``, ``navsat``, ``sbf``,
                                              ``gpsd``, ``flag``; CSV streams also
                                              ``rmc``, ``gpx`` (text): the
                                              receiver's fix status; a position it says is
                                              no fix is taken as none
                                              (:mod:`rwhonet.data.fixstatus`)
``date`` (CSV streams: then in every file)    ``ddmmyy`` or a strptime date pattern; ``t``
                                              is then the time of day
``lat_hemisphere``, ``lon_hemisphere`` (CSV   ``N/S``, ``E/W``: NMEA's letters, in the file
streams)                                      of their coordinate, which is then unsigned
============================================  =================================================

Channels sampled together (one CSV file, one MDF4 channel group) form one
:class:`~rwhonet.data.streams.Stream`; :func:`build_streams` sorts them into
the wheel, GNSS and other streams :func:`rwhonet.data.streams.resample` takes.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from math import nan

import numpy as np

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import AUX_KEYS, FIX, WHEEL_KEYS, aux_key_issues, scale_issues
from rwhonet.data.fixstatus import FIX_STATUS, is_text, refuse_bad_codes, screen
from rwhonet.data.fixstatus import UNITS as FIX_STATUS_UNITS
from rwhonet.data.fixstatus import note as fix_status_note
from rwhonet.data.headers import map_unit_name
from rwhonet.data.packed import HHMMSS, VBOX_SATS, is_packed, unpack_or_refuse
from rwhonet.data.sampleorder import time_order
from rwhonet.data.streams import DriveStreams, Stream, stream_problems, where_named
from rwhonet.data.texttime import CLOCK, ISO8601, is_pattern, pattern_problem
from rwhonet.data.wheelpulses import (
    PULSE_UNIT_FORM,
    PulseUnit,
    is_pulse_unit,
    pulse_unit,
    pulses_to_rad_s,
)
from rwhonet.data.wheelunits import WHEEL_UNITS, wheel_speed_rad_s
from rwhonet.errors import InputError, Problem

_SPEED = {"m/s": 1.0, "km/h": c.KMH_M_S, "mph": 0.44704}
# Key -> (canonical name, {unit: factor to SI}); wheel speeds: WHEEL_UNITS via the radius.
KEYS: dict[str, tuple[str, dict[str, float] | None]] = {
    # iso8601, hh:mm:ss: a CSV stream's time written as text (rwhonet.data.texttime)
    # hhmmss: a time of day as hhmmss.ss (NMEA, VBOX), unpacked (rwhonet.data.packed)
    "t": (
        c.T_S,
        {**c.TIME_UNITS, ISO8601: 1.0, CLOCK: 1.0, HHMMSS: nan},
    ),
    # minutes of arc (Racelogic VBOX logs), NMEA's ddmm.mmmm (rwhonet.data.packed), a
    # longitude positive west ("W"): c.LAT_UNITS
    "lat": (c.LAT_DEG, c.LAT_UNITS),
    "lon": (c.LON_DEG, c.LON_UNITS),
    **{key: (name, None) for key, name in zip(WHEEL_KEYS, c.WHEELS, strict=True)},
    "n_sats": (c.N_SATS, {"count": 1.0, VBOX_SATS: nan}),  # vbox: rwhonet.data.packed
    "h_acc": (c.H_ACC_M, c.ACCURACY_UNITS),
    "speed_gnss": (c.SPEED_GNSS_M_S, _SPEED),
    "heading": (c.HEADING_DEG, {"deg": 1.0}),
    "height": (c.HEIGHT_M, {"m": 1.0, "km": 1000.0}),
    "yaw_rate": (c.YAW_RATE_RAD_S, c.YAW_RATE_UNITS),
    "speed_vehicle": (c.SPEED_VEHICLE_M_S, _SPEED),
    "acc_lon": (c.ACC_LON_M_S2, {"m/s2": 1.0, "g": c.G_M_S2}),
    "acc_lat": (c.ACC_LAT_M_S2, {"m/s2": 1.0, "g": c.G_M_S2}),
    # codes as logged, read by build_streams (rwhonet.data.fixstatus); no channel of a drive
    FIX: (FIX_STATUS, dict.fromkeys(FIX_STATUS_UNITS, 1.0)),
}
REQUIRED_KEYS = (*WHEEL_KEYS, "lat", "lon")
FIX_KEYS = ("lat", "lon", "n_sats", "h_acc", "speed_gnss", "heading", "height", FIX)


def units_of(key: str) -> tuple[str, ...]:
    """The units a key may be given in."""
    units = KEYS[key][1]
    return WHEEL_UNITS if units is None else tuple(units)


def check_signal_map(
    name: str,
    signal_map: Mapping[str, ColumnSpec],
    with_time: bool = False,
    where: str | None = None,
) -> None:
    """Check a signal map's keys and units before any file is read.

    Args:
        name: the map's name (for messages: ``data.signal_maps.<name>``).
        signal_map: key -> channel name and unit.
        with_time: whether ``t`` is required (CSV streams; an MDF4 file has its own time).
        where: how messages name the map (default ``data.signal_maps.<name>.signals``; a
            map file's name for ``--signal-map``).

    Raises:
        ConfigError: naming every unknown key, missing required key and unknown unit.
    """
    where = where or f"data.signal_maps.{name}.signals"
    # a date and hemisphere letters in columns of their own: stream CSVs, as column maps
    aux = AUX_KEYS if with_time else ()
    issues = [
        f"{where}.{k}: unknown key; expected one of {[*KEYS, *aux]}"
        + ("" if k not in AUX_KEYS else " (a date or hemisphere column: stream CSVs only)")
        for k in signal_map
        if k not in KEYS and k not in aux
    ]
    # CSV streams: the fixes may come from the drive's NMEA log instead (rwhonet.data.nmea)
    required = (*WHEEL_KEYS, "t") if with_time else REQUIRED_KEYS
    issues += [f"{where}.{k}: missing" for k in required if k not in signal_map]
    issues += [
        f"{where}.{k}.unit: expected one of {list(units_of(k))}"
        + (" or a strptime pattern (%d.%m.%Y %H:%M:%S.%f)" if k == "t" else "")
        + (f" or {PULSE_UNIT_FORM}" if k in WHEEL_KEYS else "")
        + f", got {spec.unit!r}"
        for k, spec in signal_map.items()
        if k in KEYS
        and spec.unit not in units_of(k)
        and not (k == "t" and is_pattern(spec.unit))
        and not (k in WHEEL_KEYS and is_pulse_unit(spec.unit))
    ]
    issues += [
        f"{where}.t.unit: expected {problem}"
        for k, spec in signal_map.items()
        if k == "t" and is_pattern(spec.unit) and (problem := pattern_problem(spec.unit))
    ]
    if with_time:
        issues += aux_key_issues(where, signal_map)
    elif FIX in signal_map and is_text(signal_map[FIX].unit):
        codes = ", ".join(u for u in units_of(FIX) if not is_text(u))
        issues.append(
            f"{where}.fix.unit: expected a code unit ({codes}) for a logger's signal, got "
            f"{signal_map[FIX].unit!r} (a status written as text: stream CSVs and column "
            "maps only)"
        )
    issues += scale_issues(where, signal_map)
    if issues:
        raise ConfigError("\n".join(issues))


def to_si(
    key: str,
    values: np.ndarray,
    unit: str,
    radius_m: float | None,
    where: str,
    source: tuple[str, str] | None = None,
) -> np.ndarray:
    """A channel's values in the canonical SI unit.

    Args:
        key: the signal-map key.
        values: the values as logged.
        unit: their unit (checked by :func:`check_signal_map`).
        radius_m: the car's nominal tyre radius (for linear wheel speeds).
        where: the channel, for messages.
        source: the file and the logger's channel name, for a packed unit's messages
            (default: ``where`` and the key).

    Returns:
        float64 values (a wheel's pulse counter: its counts, which :func:`build_streams`
        makes speeds once its samples are in time order).

    Raises:
        InputError: a wheel speed's unit cannot be converted; a packed angle or time
            (``ddmm``, ``hhmmss``) with cells not of its form, each named by its row
            (the sample's number, for an MDF4 signal).
    """
    factors = KEYS[key][1]
    if factors is None and is_pulse_unit(unit):  # counts: a speed once in time order
        return np.asarray(values, dtype=np.float64)
    if factors is None:
        return wheel_speed_rad_s(values, unit, radius_m, where)
    if is_packed(unit):
        file, column = source or (where, key)
        return unpack_or_refuse(values, unit, file, column, setting=f"the map's {key}.unit")
    values = np.asarray(values, dtype=np.float64)
    factor = factors.get(unit, 1.0)  # a time's strptime pattern: parsed to seconds already
    return values if factor == 1.0 else values * factor  # SI already: no copy


@dataclass(frozen=True)
class Group:
    """Channels sampled together: one CSV file, one MDF4 channel group.

    Attributes:
        name: the group as the user knows it.
        file: its file.
        t_s: sample times, s.
        channels: signal-map key -> values in SI units.
        sources: signal-map key -> the logger's channel name (``t``: the time's).
        rows: each sample's row in the file, 1-based (None: sample ``i`` is row ``i + 1``).
        parts, part: a group a logger split across files, as :class:`Stream` has them.
    """

    name: str
    file: str
    t_s: np.ndarray
    channels: dict[str, np.ndarray]
    sources: dict[str, str]
    rows: np.ndarray | None = None
    parts: tuple[tuple[str, str], ...] = ()
    part: np.ndarray | None = None

    @property
    def where(self) -> str:
        """The group as messages name it (as :meth:`Stream.where` does)."""
        return where_named(self.file, self.name)


def in_time_order(g: Group) -> tuple[Group, tuple[str, ...]]:
    """A group with its samples written twice dropped and those written out of time order
    put in order, where safe (:func:`rwhonet.data.sampleorder.time_order`), and what the
    reader says of it."""
    order = time_order(g.t_s, g.channels, g.rows, g.where)
    if order.index is None:
        return g, order.notes
    i = order.index
    rows = i + 1 if g.rows is None else np.asarray(g.rows)[i]
    channels = {k: np.ascontiguousarray(np.asarray(v)[i]) for k, v in g.channels.items()}
    t = np.ascontiguousarray(np.asarray(g.t_s)[i])
    part = None if g.part is None else np.asarray(g.part)[i]
    return Group(g.name, g.file, t, channels, g.sources, rows, g.parts, part), order.notes


def mapped_unit_name(unit: str) -> str | None:
    """The name a signal map's unit has among the units a header or an MDF4 signal says
    (:func:`rwhonet.data.headers.map_unit_name`); a wheel's pulse counter is a count, so a
    header or signal that says ``rad/s`` contradicts it."""
    return "count" if is_pulse_unit(unit) else map_unit_name(unit)


def pulse_units(signal_map: Mapping[str, ColumnSpec]) -> dict[str, PulseUnit]:
    """The wheels a map gives as pulse counters, and their units."""
    return {
        k: unit
        for k, spec in signal_map.items()
        if k in WHEEL_KEYS and (unit := pulse_unit(spec.unit)) is not None
    }


def _counted(g: Group, pulses: Mapping[str, PulseUnit]) -> tuple[Group, list[str]]:
    """A group (in time order) with its wheels' pulse counts made speeds, and the notes."""
    counted = [k for k in g.channels if k in pulses]
    if not counted:
        return g, []
    channels, notes = dict(g.channels), []
    for k in counted:
        got = pulses_to_rad_s(g.t_s, g.channels[k], pulses[k], g.where, g.sources[k], g.rows)
        channels[k] = got.rad_s
        notes.append(f"{g.where}: {got.said(g.sources[k], pulses[k])}")
    return dataclasses.replace(g, channels=channels), notes


def fix_status_unit(signal_map: Mapping[str, ColumnSpec]) -> str | None:
    """The unit of the map's fix status (``fix`` key), or None where it names none."""
    return signal_map[FIX].unit if FIX in signal_map else None


def build_streams(
    groups: Sequence[Group],
    clock: str,
    pulses: Mapping[str, PulseUnit] | None = None,
    fix_unit: str | None = None,
) -> DriveStreams:
    """Sort groups of channels into the wheel, GNSS and other streams of a drive.

    A group holding wheel speeds is a wheel stream (with any other rates it holds); the
    group holding latitude and longitude is the GNSS stream; GNSS channels logged apart
    from the fixes (a satellite count in another message) are taken at the fixes' times
    (the satellite count and fix status of the last message at or before a fix, the
    others interpolated); the remaining rates are streams of their own. A position whose
    fix status (``fix`` key) says no fix is taken as none
    (:func:`rwhonet.data.fixstatus.screen`).

    Args:
        groups: the channel groups (each key in one group; ``t`` not among the channels).
        clock: what the times are.
        pulses: the wheels given as pulse counters (:func:`pulse_units`): their counts
            are made speeds once the samples are in time order
            (:func:`rwhonet.data.wheelpulses.pulses_to_rad_s`).
        fix_unit: the unit of the fix status a group holds (:func:`fix_status_unit`).

    Returns:
        The drive's streams.

    Raises:
        InputError: latitude and longitude in different groups with different times; a
            pulse count that is no count; a fix status that is no code of its unit.
    """

    def stream(g: Group, keys: Sequence[str]) -> Stream:
        return Stream(
            g.name,
            g.file,
            g.t_s,
            {KEYS[k][0]: g.channels[k] for k in keys},
            {KEYS[k][0]: g.sources[k] for k in (*keys, "t") if k in g.sources},
            g.rows,
            g.parts,
            g.part,
        )

    notes: list[str] = []
    converted: list[str] = []
    ordered = []
    for g in groups:
        g, said = in_time_order(g)
        g, counted = _counted(g, pulses or {})
        ordered.append(g)
        notes += said
        converted += counted
    groups = ordered
    wheels, extra = [], []
    fix_group = None
    for g in groups:
        if FIX in g.channels:  # every code checked where it was logged, with its row
            assert fix_unit is not None, "a fix status without its unit"
            rows = g.rows if g.rows is not None else np.arange(1, g.t_s.size + 1)
            setting = f"the map's {FIX}.unit"
            refuse_bad_codes(g.channels[FIX], fix_unit, g.where, g.sources[FIX], rows, setting)
    for g in groups:
        keys = list(g.channels)
        if "lat" in keys or "lon" in keys:
            if fix_group is not None:
                raise _split_fix(fix_group, g)
            fix_group = g
        rates = [k for k in keys if k not in FIX_KEYS]
        if any(k in WHEEL_KEYS for k in keys):
            wheels.append(stream(g, rates))
        elif rates:
            extra.append(stream(g, rates))
    if fix_group is None or not {"lat", "lon"} <= set(fix_group.channels):
        raise _split_fix(fix_group, None)
    fixes = {k: fix_group.channels[k] for k in FIX_KEYS if k in fix_group.channels}
    sources = {k: fix_group.sources[k] for k in (*fixes, "t") if k in fix_group.sources}
    for g in groups:
        if g is fix_group:
            continue
        if any(k in g.channels for k in FIX_KEYS):  # taken at the fixes' times: in order
            problems = stream_problems(stream(g, [k for k in g.channels if k in FIX_KEYS]))
            if problems:
                raise InputError(problems, summary=f"{len(problems)} problem(s) in {g.where}")
        for k in FIX_KEYS:
            if k in g.channels:
                fixes[k] = _at_times(k, g.t_s, g.channels[k], fix_group.t_s)
                sources[k] = f"{g.sources[k]} (at the fixes' times)"
    channels = {KEYS[k][0]: v for k, v in fixes.items()}
    if FIX in fixes:
        assert fix_unit is not None
        counts: Counter = Counter()
        channels = screen(channels, fix_unit, counts)
        if said := fix_status_note(counts, fix_unit, fix_group.where, sources[FIX]):
            converted.append(said)
    gnss = Stream(
        fix_group.name,
        fix_group.file,
        fix_group.t_s,
        channels,
        {KEYS[k][0]: s for k, s in sources.items() if k != FIX},
        fix_group.rows,
        fix_group.parts,
        fix_group.part,
    )
    return DriveStreams(
        tuple(wheels), gnss, tuple(extra), clock, notes=tuple(converted), changed=tuple(notes)
    )


def _at_times(key: str, t: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    if t.size == 0:
        return np.full(at.size, np.nan)
    if key in ("n_sats", FIX):  # a count, a code: the last logged, not between two
        i = np.searchsorted(t, at, side="right") - 1
        return np.where(i >= 0, values[np.maximum(i, 0)], np.nan)
    period = 360.0 if key == "heading" else None
    v = np.unwrap(values, period=period) if period else values
    out = np.interp(at, t, v, left=np.nan, right=np.nan)
    return out % 360.0 if period else out


def _split_fix(a: Group | None, b: Group | None) -> InputError:
    if a is None:
        found = "no group with both latitude and longitude"
        where = "the drive's streams"
    else:
        found = f"latitude/longitude split over {a.name!r} and {b.name if b else '?'!r}"
        where = a.file
    return InputError(
        [
            Problem(
                where,
                None,
                None,
                "latitude and longitude logged together (one CSV file, one MDF4 group)",
                found,
                "map the latitude and longitude of one GNSS message",
            )
        ]
    )
