"""A gpsd client's log: the JSON reports ``gpspipe -w`` writes, one a line; each TPV a fix.

A Linux logger (a Raspberry Pi or a car PC beside ``candump -l``) reads its GNSS receiver
through gpsd, the Linux GNSS daemon, and keeps what ``gpspipe -w`` prints: one JSON object
a line, each with a ``class`` (gpsd_json(5), "gpsd request/response protocol", gpsd.io):
``VERSION``, ``DEVICES`` and ``WATCH`` at the start, then per epoch a ``TPV``
(time-position-velocity) report and now and then a ``SKY`` report. A file in a
``stream_csv`` drive's folder whose first reports are such objects (``gps.json``,
``gpsd.log``, ``*.jsonl``; kept compressed too) is read here as the drive's GNSS stream
(:func:`read_gpsd`), and :mod:`rwhonet.data.streamcsv` puts it on the stream files' clock
by its UTC times, as it puts a GPX track or a UBX log.

**What is read** (gpsd_json(5), "TPV" and "SKY"):

- each TPV's ``time`` (ISO 8601, UTC; a number of seconds since 1970 in gpsd's protocol
  before 3.10) is its epoch; a TPV without one (no fix yet, or the receiver's date not yet
  known: gpsd writes a GGA's report before the RMC that dates it) is passed over, counted
  in the notes (gpsd's way, not damage);
- ``lat``, ``lon`` (degrees), ``altMSL`` (else ``alt``, which was the altitude above mean
  sea level before gpsd 3.20) as ``height``, ``speed`` (m/s) as ``speed_gnss``, ``track``
  (degrees from true north) as ``heading``;
- ``n_sats``: the satellites used in a fix, from the last SKY report before the TPV (its
  ``uSat``, else the count of its ``satellites`` whose ``used`` is true), where the log has
  SKY reports (gpsd writes one for a receiver's GSV/GSA or its binary satellite message;
  the satellites change slowly, so a SKY written just after its epoch's TPV gives the
  next epoch's);
- **a fix** is a TPV whose ``mode`` is 2 (2D) or 3 (3D) and whose ``status`` is not 5
  (dead reckoning alone), 7 (time only) or 8 (simulated); ``status`` 6 (GNSS with dead
  reckoning) is a fix, as u-blox's ``fixType`` 4 is. Another TPV keeps its epoch without a
  position, speed or course, as an NMEA epoch without a fix.

gpsd's own error estimates (``eph``, ``epx``, ``epy``) are not read as ``h_acc``: gpsd
says the certainty of ``eph`` is unknown and computes ``epx``/``epy`` for many receivers
from the DOPs and an assumed range error, not from the receiver's own estimate.

**Several reports of one epoch.** gpsd may write more than one TPV for one time (a cycle
whose end it did not see): the last is kept, being the one with every sentence of the
cycle merged into it, and the others are passed over, counted.

**Several receivers.** One gpsd may serve several devices, each TPV naming its
``device``: the device with the most fixes is read, the others left out, said.

**Damage** is passed over and counted, with its first line: a line that is no JSON object
(a logger that lost power cuts its last line short), a report without a ``class``.
NMEA sentences among the reports (``gpspipe -w -r``) are passed over, counted; a prefix
before a report's ``{`` (``gpspipe -t``'s local time stamp) is not read. **Refused**, naming
the file, line and field: a latitude or longitude out of range or no number, a time that
is no ISO 8601 date and time, a ``mode`` or ``status`` that is no integer; a log without a
TPV report with a time.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import head_bytes, without_suffix
from rwhonet.data.nmea import FixLog
from rwhonet.data.texttime import ISO8601, expected, parse_text_times
from rwhonet.errors import InputError, Problem

# the names a gpsd client's log has (told by what it holds: a .log may be a CAN log)
GPSD_SUFFIXES = (".json", ".jsonl", ".ndjson", ".log", ".txt", ".gpsd")
# the classes of gpsd's reports (gpsd_json(5)); the first of a log tells it
CLASSES = frozenset(
    {"VERSION", "DEVICES", "DEVICE", "WATCH", "TPV", "SKY", "GST", "ATT", "IMU", "PPS", "TOFF"}
    | {"POLL", "ERROR", "RTCM2", "RTCM3", "AIS", "RAW", "SUBFRAME", "OSC"}
)
NO_FIX_STATUS = {5: "dead reckoning only", 7: "time only", 8: "simulated"}
HEAD_BYTES = 1 << 14
HEAD_LINES = 3  # the first non-empty lines of which one must be a report
LISTED = 20  # problems listed of one kind
# TPV field -> signal-map key
VALUES = {"speed": "speed_gnss", "track": "heading"}


def is_gpsd_log(path: Path, name: str) -> bool:
    """Whether a file is a gpsd client's log: named as one may be (:data:`GPSD_SUFFIXES`,
    kept compressed too) and one of its first :data:`HEAD_LINES` non-empty lines a gpsd
    report (a JSON object whose ``class`` is one of gpsd's; a rotated log's first line may
    be the end of a report cut by the rotation)."""
    if not without_suffix(name).lower().endswith(GPSD_SUFFIXES):
        return False
    head = head_bytes(path, name, HEAD_BYTES)
    if not head:
        return False
    lines = [line for line in head.splitlines() if line.strip()][:HEAD_LINES]
    return any(_report(line) is not None for line in lines)


def _report(line: bytes) -> dict | None:
    """A line's gpsd report (None: no JSON object with a class of gpsd's)."""
    start = line.find(b"{")
    if start < 0:
        return None
    try:
        obj = json.loads(line[start:])
    except (ValueError, UnicodeDecodeError):
        return None
    if isinstance(obj, dict) and isinstance(obj.get("class"), str) and obj["class"] in CLASSES:
        return obj
    return None


def read_gpsd(path: Path, file: str) -> FixLog:
    """Read a gpsd client's log's TPV reports as one fix an epoch, on UTC.

    Args:
        path: the log (text; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: no TPV report with a time; a latitude or longitude out of range or no
            number, a time no ISO 8601 date and time, a mode or status no integer.
    """
    tpv: list[tuple[int, dict]] = []
    sky: list[tuple[int, dict]] = []
    others: Counter[str] = Counter()
    damaged: list[int] = []
    nmea = 0
    lines = path.read_bytes().splitlines()
    for i, line in enumerate(lines, start=1):
        text = line.strip()
        if not text:
            continue
        if text[:1] in (b"$", b"!"):  # gpspipe -r's sentences among the reports
            nmea += 1
            continue
        obj = _report(text)
        if obj is None:
            damaged.append(i)
        elif obj["class"] == "TPV":
            tpv.append((i, obj))
        elif obj["class"] == "SKY":
            sky.append((i, obj))
        else:
            others[obj["class"]] += 1
    tpv, device, device_note = _one_device(tpv)
    if device_note is not None:  # the satellites of the receiver read
        sky = [(i, r) for i, r in sky if _device(r) == device]
    timed = [(i, r) for i, r in tpv if r.get("time") not in (None, "")]
    if not timed:
        raise InputError([_no_fix_reports(file, len(tpv), others)])
    rows = np.array([i for i, _ in timed], dtype=np.int64)
    t, problems = _times([r["time"] for _, r in timed], rows, file)
    mode, p = _integers(timed, "mode", rows, file)
    problems += p
    status, p = _integers(timed, "status", rows, file)
    problems += p
    coords = {}
    for key, limit in (("lat", 90.0), ("lon", 180.0)):
        coords[key], p = _numbers(timed, key, rows, file, limit)
        problems += p
    values = {}
    for field, key in VALUES.items():
        if any(field in r for _, r in timed):
            values[key], p = _numbers(timed, field, rows, file)
            problems += p
    msl = any("altMSL" in r for _, r in timed)
    if msl or any("alt" in r for _, r in timed):
        values["height"], p = _numbers(timed, "altMSL" if msl else "alt", rows, file)
        problems += p
    if problems:
        raise InputError(problems[: 3 * LISTED], summary=f"{len(problems)} problem(s) in {file}")
    fixed = np.isin(mode, (2, 3)) & ~np.isin(status, list(NO_FIX_STATUS))
    last = _last_of_each_time(t)
    keep = np.flatnonzero(last)
    channels = {k: np.where(fixed, v, np.nan)[keep] for k, v in coords.items()}
    for key, v in values.items():
        channels[key] = (np.where(fixed, v, np.nan) if key != "height" else v)[keep]
    sources = {"lat": "TPV lat", "lon": "TPV lon", "speed_gnss": "TPV speed"}
    sources |= {"heading": "TPV track", "height": f"TPV {'altMSL' if msl else 'alt'}"}
    if sky:
        channels["n_sats"] = np.where(fixed, _satellites(rows, sky), np.nan)[keep]
        sources["n_sats"] = "the last SKY report's satellites used"
    # damage, which predict says too (a report without a time is gpsd's way: in the notes)
    dropped = (
        f"{len(damaged)} line(s) that are no gpsd report (first at line {damaged[0]})"
        if damaged
        else ""
    )
    no_fix = Counter(int(s) for s, f in zip(status[keep], fixed[keep], strict=True) if not f)
    said = [
        f"{file}: gpsd's reports: {keep.size} TPV epochs, {int(fixed[keep].sum())} with a fix"
        + (
            "; without one: "
            + ", ".join(
                f"{n} at status {s} ({NO_FIX_STATUS[s]})"
                for s, n in no_fix.items()
                if s in NO_FIX_STATUS
            )
            if any(s in NO_FIX_STATUS for s in no_fix)
            else ""
        )
        + (
            f"; {int((~last).sum())} report(s) of an epoch a later report of it completes "
            "(gpsd writes one as each sentence of the epoch comes)"
            if (~last).any()
            else ""
        )
        + (
            f"; {len(tpv) - len(timed)} TPV report(s) without a time (no fix yet, or its date "
            "not yet known) passed over"
            if len(tpv) > len(timed)
            else ""
        )
        + (f"; {nmea} NMEA sentence(s) among them passed over" if nmea else "")
        + (
            "; other reports passed over: "
            + ", ".join(f"{n} {k}" for k, n in sorted(others.items()))
            if others
            else ""
        )
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    if device_note:
        said.append(f"{file}: {device_note}")
    return FixLog.on_utc(
        file,
        t[keep],
        channels,
        {k: sources[k] for k in channels},
        rows[keep],
        said,
        dropped,
        dated_by="gpsd TPV times",
        kind="gpsd",
    )


def _one_device(
    tpv: list[tuple[int, dict]],
) -> tuple[list[tuple[int, dict]], str | None, str | None]:
    """The TPV reports of the device with the most fixes (all where one device wrote
    them), that device, and what was left out (None: nothing)."""
    fixes = Counter(_device(r) for _, r in tpv if r.get("mode") in (2, 3))
    devices = Counter(_device(r) for _, r in tpv)
    if len(devices) < 2:
        return tpv, None, None
    best = max(devices, key=lambda d: (fixes[d], devices[d]))
    left = ", ".join(f"{d or 'no device'} ({devices[d]} TPV)" for d in devices if d != best)
    note = f"several receivers on one gpsd: the fixes are {best or 'no device'}'s, left out: {left}"
    return [(i, r) for i, r in tpv if _device(r) == best], best, note


def _device(report: dict) -> str | None:
    """The device a report names (None: none, or no text: a damaged report's)."""
    device = report.get("device")
    return device if isinstance(device, str) else None


def _times(cells: list, rows: np.ndarray, file: str) -> tuple[np.ndarray, list[Problem]]:
    """Each TPV's time as s since 1970, UTC: ISO 8601 text, or a number (gpsd before 3.10)."""
    if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in cells):
        return np.asarray(cells, dtype=np.float64), []
    text = [x if isinstance(x, str) else repr(x) for x in cells]
    times = parse_text_times(text, ISO8601)
    return times.seconds, [
        Problem(file, int(rows[i]), "time", expected(ISO8601), why) for i, why in times.bad[:LISTED]
    ]


def _integers(
    timed: list[tuple[int, dict]], field: str, rows: np.ndarray, file: str
) -> tuple[np.ndarray, list[Problem]]:
    """A field as integers (-1 where absent), and a problem for each that is none."""
    out = np.full(len(timed), -1, dtype=np.int64)
    problems = []
    for k, (_, r) in enumerate(timed):
        x = r.get(field)
        if x is None:
            continue
        if isinstance(x, int) and not isinstance(x, bool):
            out[k] = x
        elif len(problems) < LISTED:
            problems.append(Problem(file, int(rows[k]), field, "an integer", repr(x)))
    return out, problems


def _numbers(
    timed: list[tuple[int, dict]],
    field: str,
    rows: np.ndarray,
    file: str,
    limit: float | None = None,
) -> tuple[np.ndarray, list[Problem]]:
    """A field as numbers (NaN where absent), and a problem for each that is no number or
    outside ±``limit``."""
    out = np.full(len(timed), np.nan)
    problems = []
    for k, (_, r) in enumerate(timed):
        x = r.get(field)
        if x is None:
            continue
        ok = isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
        if ok and (limit is None or abs(x) <= limit):
            out[k] = float(x)
        elif len(problems) < LISTED:
            want = "a number" if limit is None else f"a {field} in [-{limit:g}, {limit:g}] degrees"
            problems.append(Problem(file, int(rows[k]), field, want, repr(x)))
    return out, problems


def _last_of_each_time(t: np.ndarray) -> np.ndarray:
    """True for each report that no later report of its time follows."""
    order = np.argsort(t, kind="stable")
    last = np.ones(t.size, dtype=bool)
    last[order[:-1]] = t[order[:-1]] != t[order[1:]]
    return last


def _satellites(rows: np.ndarray, sky: list[tuple[int, dict]]) -> np.ndarray:
    """Each TPV's satellites used: the last SKY report's before its line (NaN: none yet, or
    a SKY that says neither)."""
    lines = np.array([i for i, _ in sky], dtype=np.int64)
    used = np.array([_used(s) for _, s in sky], dtype=np.float64)
    at = np.searchsorted(lines, rows, side="left") - 1
    return np.where(at >= 0, used[np.maximum(at, 0)], np.nan)


def _used(sky: dict) -> float:
    """A SKY report's satellites used: its ``uSat``, else its satellites marked used."""
    u = sky.get("uSat")
    if isinstance(u, int) and not isinstance(u, bool):
        return float(u)
    sats = sky.get("satellites")
    if isinstance(sats, list):
        return float(sum(1 for s in sats if isinstance(s, dict) and s.get("used") is True))
    return math.nan


def _no_fix_reports(file: str, n_tpv: int, others: Counter[str]) -> Problem:
    held = ", ".join(f"{n} {k}" for k, n in sorted(others.items()))
    found = (f"{n_tpv} TPV report(s), none with a time" if n_tpv else "no TPV report") + (
        f" ({held})" if held else ""
    )
    return Problem(
        file,
        None,
        "TPV",
        "a gpsd client's log of TPV reports with their time (gpspipe -w)",
        found,
        "log gpsd's reports while the receiver has a fix (gpspipe -w > gps.json)",
    )
