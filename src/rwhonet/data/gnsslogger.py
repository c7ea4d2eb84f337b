"""Google's GnssLogger app's log (Android): a phone's fixes, from its Fix or NMEA records.

A phone in the car is many fleets' GNSS receiver, and GnssLogger (Google's
gps-measurement-tools; the Smartphone Decimeter Challenge's ``*_GnssLog.txt``) is how
its fixes are logged: one text file of records, a kind a line, each a comma-separated row
after its kind: ``Raw`` (the chip's measurements), ``Status``, ``Fix`` (a location
Android gives), ``NMEA`` (a sentence the chip writes), the phone's sensors
(``UncalGyro``, ``OrientationDeg`` ...). A header of ``#`` lines names each kind's
columns: ``# Fix,Provider,LatitudeDegrees,LongitudeDegrees,AltitudeMeters,SpeedMps,
AccuracyMeters,BearingDegrees,UnixTimeMillis,...`` (GnssLogger 1.x: ``# Fix,Provider,
Latitude,Longitude,Altitude,Speed,Accuracy,(UTC)TimeInMs``).

Such a file in a stream folder (a ``*.txt``, kept compressed too, told by its first
:data:`SNIFF_BYTES`: a ``# Fix,Provider`` header line, or a ``Fix`` or ``NMEA`` record) is
the drive's GNSS stream (:func:`read_gnsslogger`), placed by its UTC times:

- **its Fix records of the GPS provider**: the chip's own fix (Android's
  ``LocationManager.GPS_PROVIDER``), by the header's columns: latitude and longitude in
  degrees, speed over ground (m/s, ``speed_gnss``) and bearing (degrees, ``heading``), at
  ``UnixTimeMillis``, the fix's UTC time (Android's ``Location.getTime()``); ``h_acc``:
  ``AccuracyMeters`` (1.x: ``Accuracy``), Android's ``Location.getAccuracy()``, "the
  estimated horizontal accuracy radius in meters of this location at the 68th percentile
  confidence level", as given; none where empty or 0 (what ``getAccuracy()`` gives a
  location without one), and a cell that is no number states none, not refused. A record of
  another provider (``fused``/``FLP``: Android's blend of GNSS, Wi-Fi, cell towers and
  the phone's sensors; ``network``/``NLP``) is no receiver's fix, nor is one marked
  ``MockLocation`` (an app's location, not the chip's): they are passed over and
  counted. Two records of one time: the first is kept, the other counted. The altitude
  (above the WGS84 ellipsoid, where NMEA's GGA gives it above mean sea level) and the
  Fix's ``NumberOfUsedSignals`` (signals, two a satellite on L1 and L5, not satellites)
  are not read.
- **the satellites used in each fix (``n_sats``), from its Status records**
  (:func:`_status_counts`): GnssLogger writes a record for each signal of each
  ``GnssStatus`` callback (``SignalCount`` records, ``SignalIndex`` 0 to ``SignalCount``
  - 1, one after another), saying whether the engine used it "in the calculation of the
  most recent position fix" (``UsedInFix``; Android's ``GnssStatus.usedInFix``). A
  satellite counts once however many of its signals it was used on (a
  ``ConstellationType``, ``Svid`` pair), as GGA counts satellites in use. The records'
  ``UnixTimeMillis`` cannot place them (empty in the Smartphone Decimeter Challenge's
  logs; GPSTest writes the last fix's time or 0): the log's order does, as the app wrote
  them. An epoch tells of the most recent fix when it came, so each Fix record takes the
  first Status epoch written after it and before the next GPS Fix record; where there is
  none there (Status at a lower rate than fixes, the log's last fix), the last epoch
  written before it, as a satellite count logged in a message of its own is taken (the
  last at or before a fix). An epoch that is not whole (a record missing, a cell that
  is no number: a damaged line, or a file that starts inside one) gives its fix no
  count, which validate cuts as ``low_sats``, as it does a fix with no epoch on either
  side. A log without Status records (Status logging off; GnssLogger 1.x) gives no
  count, as before.
- **where it has none** (Location logging turned off), **its NMEA records**: ``NMEA,``
  before each sentence and ``,UnixTimeMillis`` after its checksum (the phone's clock when
  the sentence came; on some phones the sentence's own line end splits the record, that
  time alone on the next line) are taken off, and the sentences read by
  :func:`rwhonet.data.nmea.read_nmea`, each named by its line in the file.

The other records are passed over, counted by kind in the notes. A file with neither is
refused, naming what it holds. The phone's gyro (``Gyro``, ``UncalGyro``) is in the
phone's axes, which the log does not tie to the car's: no yaw rate is read from it.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path
from typing import NamedTuple

import numpy as np

from rwhonet.data.bytescan import CommaFields, floats_or_nan
from rwhonet.data.compressed import head_bytes, without_suffix
from rwhonet.data.nmea import FixLog, read_nmea
from rwhonet.errors import InputError, Problem

SNIFF_BYTES = 1 << 16  # the header (about 40 lines) and the first records
_SNIFF = re.compile(rb"(?m)^(#\s*Fix,Provider,|Fix,|NMEA,\$)")
_HEADER = re.compile(rb"(?m)^#\s*Fix,(.*?)\s*$")
_STATUS_HEADER = re.compile(rb"(?m)^#\s*Status,(.*?)\s*$")
_SUFFIX = re.compile(rb"(\*[0-9A-Fa-f]{2}),\s*\d+\s*$")  # a sentence's checksum, the time
GPS_PROVIDERS = ("gps",)  # LocationManager.GPS_PROVIDER, as GnssLogger writes it
LISTED = 20  # problems listed a column
# the Fix header's column names (lower case) for each quantity, every GnssLogger version's
COLUMNS = {
    "provider": ("provider",),
    "lat": ("latitudedegrees", "latitude"),
    "lon": ("longitudedegrees", "longitude"),
    "speed_gnss": ("speedmps", "speed"),
    "heading": ("bearingdegrees", "bearing"),
    "h_acc": ("accuracymeters", "accuracy"),
    "time": ("unixtimemillis", "(utc)timeinms", "utctimemillis"),
    "mock": ("mocklocation",),
}
# the Status header's columns a satellite count is read from
STATUS_COLUMNS = ("signalcount", "signalindex", "constellationtype", "svid", "usedinfix")
YES, NO = [b"1", b"true"], [b"0", b"false"]  # UsedInFix as apps write it


def is_gnsslogger_log(path: Path, name: str | None = None) -> bool:
    """Whether a file is a GnssLogger log: a ``*.txt`` (compressed or not) whose first
    :data:`SNIFF_BYTES` hold a ``# Fix,Provider`` header line or a Fix or NMEA record. A
    file that cannot be read is not."""
    name = name or path.name
    if Path(without_suffix(name)).suffix.lower() != ".txt":
        return False
    head = head_bytes(path, name, SNIFF_BYTES)
    return head is not None and _SNIFF.search(head) is not None


def read_gnsslogger(path: Path, file: str) -> FixLog:
    """Read a GnssLogger log's fixes: its Fix records of the GPS provider, else its NMEA
    records (see the module's docstring).

    Args:
        path: the log (text; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: neither a GPS Fix record nor an NMEA record (naming the records it
            holds); Fix records without the header line naming their columns, or a cell
            that is no number (with its line); what :func:`read_nmea` refuses.
    """
    data = path.read_bytes()
    lines = data.replace(b"\r\n", b"\n").split(b"\n")
    kinds = Counter(line.split(b",", 1)[0].strip() for line in lines if line and line[:1] != b"#")
    kinds.pop(b"", None)
    fixes = [i for i, line in enumerate(lines) if line.startswith(b"Fix,")]
    header = _HEADER.search(data)
    if fixes:
        if header is None:
            raise InputError([_no_header(file, fixes[0] + 1)])
        got = _fix_records(lines, fixes, header.group(1), file, kinds)
        if got is not None:
            return got
    if kinds.get(b"NMEA"):
        return _nmea_records(lines, file, kinds)
    held = ", ".join(f"{n} {k.decode('latin-1')}" for k, n in kinds.most_common(8)) or "none"
    raise InputError(
        [
            Problem(
                file,
                None,
                None,
                "GnssLogger's Fix records of the GPS provider, or its NMEA records",
                f"records: {held}",
                "turn on Location (Fix) or NMEA logging in GnssLogger's settings, or leave "
                "the file out of the drive",
            )
        ]
    )


def _no_header(file: str, row: int) -> Problem:
    return Problem(
        file,
        row,
        None,
        "the header line naming the Fix records' columns (# Fix,Provider,LatitudeDegrees,"
        "...) before them, as GnssLogger writes it",
        "Fix records without it",
        "give the log as GnssLogger wrote it, its # header lines kept",
    )


def _column(names: list[str], key: str) -> int | None:
    return next((names.index(n) for n in COLUMNS[key] if n in names), None)


def _fix_records(
    lines: list[bytes], at: list[int], header: bytes, file: str, kinds: Counter[bytes]
) -> FixLog | None:
    """The Fix records at lines ``at`` (0-based) of the GPS provider as a fix log, by the
    header's columns; None where none is of that provider (the NMEA records are read)."""
    names = [x.strip().lower() for x in header.decode("latin-1").split(",")]
    where = {k: _column(names, k) for k in COLUMNS}
    lacking = [k for k in ("provider", "lat", "lon", "time") if where[k] is None]
    if lacking:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    "# Fix header",
                    "the Fix records' Provider, latitude, longitude and UnixTimeMillis columns",
                    f"no column for {', '.join(lacking)} in {header.decode('latin-1')!r}",
                    "give the log as GnssLogger wrote it",
                )
            ]
        )
    rows = [line.rstrip(b"\r").split(b",")[1:] for line in (lines[i] for i in at)]
    provider = [
        r[where["provider"]].strip().lower() if len(r) > where["provider"] else b"" for r in rows
    ]
    gps = np.array([p.decode("latin-1") in GPS_PROVIDERS for p in provider], bool)
    if not gps.any():
        return None
    mock_at = where["mock"]
    mock = np.array(
        [
            mock_at is not None and len(r) > mock_at and r[mock_at].strip() in (b"1", b"true")
            for r in rows
        ],
        bool,
    )
    line_no = np.asarray(at, np.int64) + 1
    problems: list[Problem] = []

    def numbers(key: str, required: bool, lenient: bool = False) -> np.ndarray:
        """A column's cells of the GPS records as numbers, converted at once (NaN: empty,
        or another provider's); a problem for each that is none (``lenient``: NaN, as
        where empty)."""
        j = where[key]
        if j is None:
            return np.full(len(rows), np.nan)
        cells = np.array([r[j].strip() if len(r) > j else b"" for r in rows], dtype=bytes)
        empty = cells == b""
        values = floats_or_nan(np.where(empty, b"nan", cells))
        bad = gps & ~empty & ~np.isfinite(values)
        if lenient:  # no problem: a cell that is no number is none, as an empty one
            return np.where(gps & ~bad, values, np.nan)
        for i in np.flatnonzero(bad | (gps & empty & required))[: max(0, LISTED - len(problems))]:
            found = "empty" if empty[i] else repr(cells[i].decode("latin-1"))
            problems.append(Problem(file, int(line_no[i]), names[j], "a number", found))
        return np.where(gps & ~bad, values, np.nan)

    lat, lon = numbers("lat", True), numbers("lon", True)
    time_ms = numbers("time", True)
    speed, heading = numbers("speed_gnss", False), numbers("heading", False)
    # the stated accuracy: optional, so a cell that is no number is none (a log read before
    # it was read is read still); 0 is Location.getAccuracy()'s "none" (and no receiver's)
    h_acc = numbers("h_acc", False, lenient=True)
    with np.errstate(invalid="ignore"):
        h_acc[~(h_acc > 0.0)] = np.nan  # NaN stays NaN
    with np.errstate(invalid="ignore"):
        out_of_range = gps & ((np.abs(lat) > 90) | (np.abs(lon) > 180))
    problems += [
        Problem(
            file,
            int(line_no[i]),
            "latitude, longitude",
            "degrees within ±90, ±180",
            f"{lat[i]}, {lon[i]}",
        )
        for i in np.flatnonzero(out_of_range)[:LISTED]
    ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    use = gps & ~mock
    if not use.any():  # every GPS fix an app's: the NMEA records, if any, are the chip's
        return None
    _, first = np.unique(time_ms[use], return_index=True)
    keep = np.flatnonzero(use)[np.sort(first)]
    again = int(use.sum()) - keep.size
    utc = time_ms[keep] / 1000.0
    channels = {"lat": lat[keep], "lon": lon[keep]}
    sources = {"lat": f"Fix {names[where['lat']]}", "lon": f"Fix {names[where['lon']]}"}
    read = {"speed_gnss": speed, "heading": heading, "h_acc": h_acc}
    for key in ("speed_gnss", "heading", "h_acc"):
        if where[key] is not None and np.isfinite(v := read[key][keep]).any():
            channels[key] = v
            sources[key] = f"Fix {names[where[key]]}"
    counted = _status_counts(lines, np.asarray(at)[keep])
    read_kinds = (b"Fix",)
    if counted.sats is not None:
        channels["n_sats"] = counted.sats
        sources["n_sats"] = "Status UsedInFix satellites"
        read_kinds = (b"Fix", b"Status")
    others = Counter(p.decode("latin-1") for p, g in zip(provider, gps, strict=True) if not g)
    passed = [
        f"{n} Fix record(s) of the {p or '(empty)'} provider (no receiver's fix)"
        for p, n in sorted(others.items())
    ]
    if mock[gps].any():
        passed.append(f"{int((mock & gps).sum())} marked MockLocation")
    if again:
        passed.append(f"{again} of a time already given")
    dropped = "; ".join(passed)
    notes = [
        f"{file}: a GnssLogger log: {keep.size} Fix records of the GPS provider read"
        + _records_said(kinds, read_kinds)
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    if counted.said:
        notes.append(f"{file}: {counted.said}")
    return FixLog.on_utc(
        file,
        utc,
        channels,
        sources,
        line_no[keep],
        notes,
        dropped,
        dated_by="Fix UnixTimeMillis",
        kind="GnssLogger",
    )


class _Counted(NamedTuple):
    """The satellites used in each fix (None: the log gives no count) and what is said."""

    sats: np.ndarray | None
    said: str


def _status_counts(lines: list[bytes], fixes: np.ndarray) -> _Counted:
    """The satellites used in the fixes at lines ``fixes`` (0-based, increasing), from the
    log's Status records (see the module's docstring): each fix the count of the first
    Status epoch written after it and before the next fix, else of the last written
    before it; NaN where that epoch is not whole or there is none. The records' fields are
    taken column by column (:class:`~rwhonet.data.bytescan.CommaFields`)."""
    at = np.array([i for i, line in enumerate(lines) if line.startswith(b"Status,")], np.int64)
    if at.size == 0:
        return _Counted(None, "")
    header = _STATUS_HEADER.search(b"\n".join(lines[: at[0]]))
    names = (
        [x.strip().lower() for x in header.group(1).decode("latin-1").split(",")] if header else []
    )
    lacking = [k for k in STATUS_COLUMNS if k not in names]
    if lacking:
        return _Counted(
            None,
            f"its {at.size} Status records give no satellite count: no header line naming "
            f"their {', '.join(lacking)} column(s) before them (# Status,UnixTimeMillis,...)",
        )
    fields = CommaFields([lines[i] for i in at])
    # field 0 is the record's kind, so the header's column k is field k + 1
    count, index, system, svid = (
        floats_or_nan(fields.column(names.index(k) + 1)) for k in STATUS_COLUMNS[:4]
    )
    used_cells = np.char.lower(fields.column(names.index("usedinfix") + 1))
    used = np.select([np.isin(used_cells, YES), np.isin(used_cells, NO)], [1.0, 0.0], np.nan)
    # an epoch starts at each record of SignalIndex 0; records before the first: epoch -1
    epoch = np.cumsum(index == 0) - 1
    n_epochs = int(epoch[-1]) + 1
    if n_epochs == 0:  # no record of SignalIndex 0: no epoch starts
        return _no_whole_epoch(at.size)
    starts = np.searchsorted(epoch, np.arange(n_epochs))  # epoch is non-decreasing
    stops = np.append(starts[1:], epoch.size)
    first, ends = at[starts], at[stops - 1]  # each epoch's first and last line
    inside = epoch >= 0
    e = np.maximum(epoch, 0)
    # a whole epoch's records: SignalCount each, its records' number; SignalIndex in turn
    good = np.isfinite(used) & _small_whole(system, 1 << 8) & _small_whole(svid, 1 << 16)
    good &= (count == (stops - starts)[e]) & (index == np.arange(epoch.size) - starts[e])
    whole = np.bincount(e[inside & ~good], minlength=n_epochs) == 0
    # the satellites used, each (epoch, constellation, svid) once
    take = inside & good & (used == 1.0)
    key = (epoch[take] << 24) | (system[take].astype(np.int64) << 16) | svid[take].astype(np.int64)
    sats = np.bincount(np.unique(key) >> 24, minlength=n_epochs).astype(np.float64)
    sats[~whole] = np.nan
    if not whole.any():
        return _no_whole_epoch(at.size)
    following = np.searchsorted(first, fixes, side="right")  # the first epoch after a fix
    next_fix = np.append(fixes[1:], len(lines))
    after = following < n_epochs
    after[after] = ends[following[after]] < next_fix[after]
    last = np.searchsorted(ends, fixes, side="right") - 1  # the last epoch ended before it
    which = np.where(after, following, last)
    has = which >= 0
    got = np.full(fixes.size, np.nan)
    got[has] = sats[which[has]]
    broken = int((~whole).sum())
    none = int((~has).sum())
    not_whole = int((has & ~whole[np.maximum(which, 0)]).sum())
    said = (
        f"n_sats: the satellites used in each fix (UsedInFix; a satellite once however many "
        f"of its signals), of the Status epoch after its Fix record (else the last before "
        f"it): {int(whole.sum())} whole epoch(s) of {at.size} Status records; "
        f"{int(after.sum())} of {fixes.size} fixes by the epoch after them"
    )
    if broken:
        said += f"; {broken} epoch(s) not whole (a record missing or damaged)"
    if none or not_whole:
        said += (
            f"; {none + not_whole} fix(es) without a count ({none} with no epoch, "
            f"{not_whole} by an epoch not whole)"
        )
    return _Counted(got, said)


def _small_whole(x: np.ndarray, below: int) -> np.ndarray:
    """Whether each of ``x`` is a whole number in [0, ``below``)."""
    with np.errstate(invalid="ignore"):
        return (x >= 0) & (x < below) & (x == np.floor(x))


def _no_whole_epoch(records: int) -> _Counted:
    return _Counted(
        None,
        f"its {records} Status records give no satellite count: no whole epoch among them "
        "(SignalIndex 0 to SignalCount - 1, each a number)",
    )


def _records_said(kinds: Counter[bytes], read: tuple[bytes, ...]) -> str:
    others = [(k, n) for k, n in kinds.most_common() if k not in read]
    if not others:
        return ""
    return "; its other records passed over: " + ", ".join(
        f"{n} {k.decode('latin-1')}" for k, n in others
    )


def _nmea_records(lines: list[bytes], file: str, kinds: Counter[bytes]) -> FixLog:
    """The log's NMEA records as an NMEA log, a line for each of the file's (the others
    blank), each sentence without GnssLogger's ``NMEA,`` and its time after the
    checksum."""
    out = []
    for line in lines:
        if line.startswith(b"NMEA,"):
            out.append(_SUFFIX.sub(rb"\1", line[5:].rstrip(b"\r")))
        else:  # another record, a comment, or a record's time on a line of its own
            out.append(b"")
    log = read_nmea(b"\n".join(out), file)
    said = (
        f"{file}: a GnssLogger log without Fix records of the GPS provider: its NMEA records read"
    )
    return FixLog(
        log.file,
        log.tod_s,
        log.day_s,
        None,
        log.channels,
        log.sources,
        log.rows,
        [said + _records_said(kinds, (b"NMEA",)), *log.notes],
        log.dropped,
        dated_by=log.dated_by,
        kind="GnssLogger",
    )
