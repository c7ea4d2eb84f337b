"""A u-blox receiver's binary log (UBX): its navigation solutions, one fix an epoch.

A u-blox receiver (the GNSS of comma's devices, of most research vehicles' loggers, of
many phones' and dashcams' modules) writes its solution in its own binary protocol
beside NMEA, and u-center, ``gpsd``'s ``ubxtool`` and most loggers record that stream as
it comes: ``gps.ubx``. Its NMEA holds a position to 1e-5 or 1e-7 arc minutes as the
receiver is set; UBX-NAV-PVT holds it to 1e-7 degrees (1.1 cm), with the fix's kind,
flags and the UTC date of every epoch. A file named ``*.ubx`` (kept compressed too:
``gps.ubx.gz``) in a ``stream_csv`` drive's folder is read here as the drive's GNSS
stream (:func:`read_ubx`), and :mod:`rwhonet.data.streamcsv` puts it on the stream files'
clock as it puts an NMEA log (:func:`rwhonet.data.nmea.on_clock`).

**The message read: UBX-NAV-PVT** (class 0x01, id 0x07), "Navigation position velocity
time solution", 92 bytes of payload (u-blox 8 / M8 receiver description, UBX-13003221,
section 32.17.17; the same in the F9 and M10 interface descriptions; 84 bytes on u-blox 7,
protocol 14, without ``flags3`` and after). Every other message (NAV-SAT, RXM-RAWX, an
ESF sensor message, ...) and NMEA sentences written into the same stream are passed over
and counted.

- ``lat``, ``lon``: ``lat``, ``lon`` (1e-7 deg);
- ``height``: ``hMSL``, height above mean sea level (mm), as NMEA GGA's altitude;
- ``n_sats``: ``numSV``, the satellites used;
- ``h_acc``: ``hAcc``, "horizontal accuracy estimate" (u4, mm), in metres as given; an
  epoch without a fix keeps its own (the receiver's, large), which no screen takes: the
  screen of ``validate.gnss.max_h_acc_m`` looks at fixes only;
- ``speed_gnss``: ``gSpeed``, ground speed (mm/s);
- ``heading``: ``headMot``, heading of motion (1e-5 deg), as NMEA RMC's course.

**A fix that is no fix.** An epoch is a fix where the receiver sets ``gnssFixOK`` (flags
bit 0: "within DOP and accuracy masks"), its ``fixType`` is 2 (2D), 3 (3D) or 4 (GNSS
combined with the receiver's own dead reckoning: u-blox writes it as NMEA GGA quality 1
and RMC mode A, which :mod:`rwhonet.data.nmea` takes as fixes too), and ``flags3``'s
``invalidLlh`` (bit 0) is clear. ``fixType`` 0 (none), 1 (dead reckoning only) and 5
(time only) are not: such an epoch is kept, its position, speed and course missing, as
an NMEA log's epoch without a fix is.

**The clock.** Every epoch carries ``iTOW``, its GPS time of week (ms), and a UTC date and
time (``year`` .. ``sec``, ``nano``) with flags saying whether they are valid and whether
the receiver knows the leap seconds (``fullyResolved``). The epochs are placed by iTOW
(continuous, made so across the week's end: :func:`rwhonet.data.timebase.unwrap_midnight`
with a week), put on UTC by the offset the epochs with a fully resolved UTC date and time
give (a whole number of seconds: the week's start less the leap seconds; their median).
An epoch before the receiver knew its UTC (the first minutes of a cold start) is placed
so too. Where no epoch is fully resolved, the valid UTC times give the offset, and a note
says that they may be off by whole (leap) seconds; where none is valid, the log is
refused. A NAV-PVT of an epoch already given (the same iTOW) is passed over, counted.

**A u-blox 6** (NEO-6M and its kin: protocol 7-13, GPS.G6-SW-10018) has no NAV-PVT. Its
log's epochs are its NAV-POSLLH messages (``lat``, ``lon``, ``hMSL``; ``hAcc``, mm, as
NAV-PVT's), joined by iTOW with the fix of NAV-SOL (``gpsFix``, ``GPSfixOK``, and
``numSV``) or, without one, NAV-STATUS (``gpsFix``, ``gpsFixOk``), with NAV-VELNED's
``gSpeed`` (cm/s) and ``heading``, and with the time of NAV-TIMEUTC (valid: ``validTOW``
and ``validWKN``; fully resolved: ``validUTC``) or, without one, NAV-TIMEGPS (the GPS
week and time less ``leapS``; fully resolved: ``leapSValid``). A fix is as NAV-PVT's
(``gpsFix`` 2, 3 or 4 with the OK flag); an epoch without a NAV-SOL or NAV-STATUS of its
iTOW has none. A log with NAV-PVT is read by its NAV-PVT alone.

**The yaw rate of a dead-reckoning receiver.** A u-blox ADR receiver (NEO-M8L, ZED-F9K;
the ZED-F9R's HPS) writes UBX-ESF-INS: the angular rates its fusion compensated, in the
vehicle frame, x forward, y right, z down (ZED-F9R integration manual, UBX-20039643,
3.2.7.4.2 and 3.2.7.4.5), 1e-3 deg/s. Its ``zAngRate`` where valid (``bitfield0`` bit
10), negated (turning left is a negative rotation about z down), is the log's yaw rate in
rad/s turning left positive (ISO 8855, as the pipeline's), a stream at its own times
(:class:`rwhonet.data.nmea.ReceiverRates`). Where the map names ``yaw_rate`` and no stream
file has it, :mod:`rwhonet.data.streamcsv` takes it from here. A UDR receiver (NEO-M8U)
writes ESF-INS in its body frame, which is the vehicle's only where it is mounted level
and straight; ESF-MEAS and ESF-RAW (the IMU's own frame) are not read.

**NMEA in a .ubx.** A u-blox's factory output is NMEA alone, and u-center records whatever
the receiver sends as ``.ubx``. A log with neither NAV-PVT nor NAV-POSLLH but NMEA
sentences is read by :func:`rwhonet.data.nmea.read_nmea`, its UBX messages taken out
first (each for a line end: their bytes may hold a ``$`` or a line end), and its epochs
placed by their UTC times (nothing before a ``$`` in it is a logger's stamp).

**What a log holds besides messages**: a message is framed by its two sync bytes
(``0xB5 0x62``), class, id, a little-endian payload length and the 8-bit Fletcher checksum
over class, id, length and payload (section 32.4). A NAV-PVT whose checksum does not match
(a byte lost on the serial line) and one cut short at the end (a logger that lost power)
are dropped and counted; a sync pair inside another message's payload is not a message.

**Rows.** An epoch is named by its NAV-PVT's (NAV-POSLLH's) number among the log's UBX
messages (1-based, as ``pyubx2``'s ``UBXReader`` with the UBX protocol filter counts them)
and, in refusals, its byte offset.

The messages are found and checked over the log's bytes at once (numpy: the sync pairs,
every candidate's checksum from two running sums), and each kind's payloads read as one
structured array. ``pyubx2`` reads one message at a time in Python: 9.1 s for a two-hour
10 Hz log of NAV-PVT alone on this machine (0.008 M messages/s), where this reader took
0.09-0.23 s (5 Dec 2026); the tests write their logs with ``pyubx2`` and compare with what
it reads back (``tests/data/test_ubx.py``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import without_suffix
from rwhonet.data.nmea import FixLog, ReceiverRates, read_nmea
from rwhonet.data.timebase import SECONDS_PER_WEEK, unwrap_midnight
from rwhonet.errors import InputError, Problem

UBX_SUFFIXES = (".ubx",)
SYNC = b"\xb5\x62"
NAV_PVT = (0x01, 0x07)
PVT_LENGTHS = (92, 84)  # u-blox 8 on (protocol 15+); u-blox 7 (protocol 14)
HEADER = 6  # sync (2), class, id, length (2)
# NAV-PVT's payload (UBX-13003221 32.17.17); an 84-byte one is read padded with zeros
PVT = np.dtype(
    [
        ("iTOW", "<u4"),
        ("year", "<u2"),
        ("month", "u1"),
        ("day", "u1"),
        ("hour", "u1"),
        ("min", "u1"),
        ("sec", "u1"),
        ("valid", "u1"),
        ("tAcc", "<u4"),
        ("nano", "<i4"),
        ("fixType", "u1"),
        ("flags", "u1"),
        ("flags2", "u1"),
        ("numSV", "u1"),
        ("lon", "<i4"),
        ("lat", "<i4"),
        ("height", "<i4"),
        ("hMSL", "<i4"),
        ("hAcc", "<u4"),
        ("vAcc", "<u4"),
        ("velN", "<i4"),
        ("velE", "<i4"),
        ("velD", "<i4"),
        ("gSpeed", "<i4"),
        ("headMot", "<i4"),
        ("sAcc", "<u4"),
        ("headAcc", "<u4"),
        ("pDOP", "<u2"),
        ("flags3", "<u2"),
        ("reserved0", "V4"),
        ("headVeh", "<i4"),
        ("magDec", "<i2"),
        ("magAcc", "<u2"),
    ]
)
assert PVT.itemsize == PVT_LENGTHS[0]
# a u-blox 6's solution (protocol 7-13, GPS.G6-SW-10018, 35.x; kept by later receivers):
# NAV-POSLLH, NAV-SOL, NAV-STATUS, NAV-VELNED, NAV-TIMEUTC, NAV-TIMEGPS
NAV_POSLLH, NAV_STATUS, NAV_SOL = (0x01, 0x02), (0x01, 0x03), (0x01, 0x06)
NAV_VELNED, NAV_TIMEGPS, NAV_TIMEUTC = (0x01, 0x12), (0x01, 0x20), (0x01, 0x21)
LEGACY = (NAV_POSLLH, NAV_STATUS, NAV_SOL, NAV_VELNED, NAV_TIMEGPS, NAV_TIMEUTC)
POSLLH = np.dtype(
    [("iTOW", "<u4"), ("lon", "<i4"), ("lat", "<i4"), ("height", "<i4"), ("hMSL", "<i4")]
    + [("hAcc", "<u4"), ("vAcc", "<u4")]
)
SOL = np.dtype(
    [("iTOW", "<u4"), ("fTOW", "<i4"), ("week", "<i2"), ("gpsFix", "u1"), ("flags", "u1")]
    + [("ecef", "<i4", 3), ("pAcc", "<u4"), ("ecefV", "<i4", 3), ("sAcc", "<u4")]
    + [("pDOP", "<u2"), ("reserved1", "u1"), ("numSV", "u1"), ("reserved2", "<u4")]
)
STATUS = np.dtype(
    [("iTOW", "<u4"), ("gpsFix", "u1"), ("flags", "u1"), ("fixStat", "u1"), ("flags2", "u1")]
    + [("ttff", "<u4"), ("msss", "<u4")]
)
VELNED = np.dtype(
    [("iTOW", "<u4"), ("velN", "<i4"), ("velE", "<i4"), ("velD", "<i4"), ("speed", "<u4")]
    + [("gSpeed", "<u4"), ("heading", "<i4"), ("sAcc", "<u4"), ("cAcc", "<u4")]
)
TIMEUTC = np.dtype(
    [("iTOW", "<u4"), ("tAcc", "<u4"), ("nano", "<i4"), ("year", "<u2"), ("month", "u1")]
    + [("day", "u1"), ("hour", "u1"), ("min", "u1"), ("sec", "u1"), ("valid", "u1")]
)
TIMEGPS = np.dtype(
    [("iTOW", "<u4"), ("fTOW", "<i4"), ("week", "<i2"), ("leapS", "i1"), ("valid", "u1")]
    + [("tAcc", "<u4")]
)
assert (POSLLH.itemsize, SOL.itemsize, STATUS.itemsize) == (28, 52, 16)
assert (VELNED.itemsize, TIMEUTC.itemsize, TIMEGPS.itemsize) == (36, 20, 16)
# a dead-reckoning receiver's vehicle dynamics (u-blox ADR: NEO-M8L, ZED-F9K; HPS: ZED-F9R):
# UBX-ESF-INS, the compensated angular rates in the vehicle frame, x forward, y right, z
# down (ZED-F9R integration manual UBX-20039643, 3.2.7.4.2 and 3.2.7.4.5), 1e-3 deg/s
ESF_INS = (0x10, 0x15)
INS = np.dtype(
    [("bitfield0", "<u4"), ("reserved0", "V4"), ("iTOW", "<u4"), ("xAngRate", "<i4")]
    + [("yAngRate", "<i4"), ("zAngRate", "<i4"), ("xAccel", "<i4"), ("yAccel", "<i4")]
    + [("zAccel", "<i4")]
)
assert INS.itemsize == 36
Z_ANG_RATE_VALID = 1 << 10
LENGTHS = {NAV_PVT: PVT_LENGTHS, ESF_INS: (INS.itemsize,)} | {
    k: (d.itemsize,)
    for k, d in zip(LEGACY, (POSLLH, STATUS, SOL, VELNED, TIMEGPS, TIMEUTC), strict=True)
}
GPS_EPOCH_S = 315_964_800.0  # 1980-01-06 00:00:00 UTC, s since 1970
# fixType: 2 2D, 3 3D, 4 GNSS + dead reckoning are fixes; 0 none, 1 dead reckoning only,
# 5 time only are not
PVT_FIXES = (2, 3, 4)
# valid: bit 0 validDate, bit 1 validTime, bit 2 fullyResolved
VALID_DATE_TIME = 0b011
FULLY_RESOLVED = 0b111
# messages a note names (class, id) -> name; others by their numbers
NAMES = {
    (0x01, 0x01): "NAV-POSECEF",
    (0x01, 0x02): "NAV-POSLLH",
    (0x01, 0x03): "NAV-STATUS",
    (0x01, 0x04): "NAV-DOP",
    (0x01, 0x05): "NAV-ATT",
    (0x01, 0x06): "NAV-SOL",
    (0x01, 0x07): "NAV-PVT",
    (0x01, 0x12): "NAV-VELNED",
    (0x01, 0x14): "NAV-HPPOSLLH",
    (0x01, 0x20): "NAV-TIMEGPS",
    (0x01, 0x21): "NAV-TIMEUTC",
    (0x01, 0x35): "NAV-SAT",
    (0x01, 0x3C): "NAV-RELPOSNED",
    (0x02, 0x13): "RXM-SFRBX",
    (0x02, 0x15): "RXM-RAWX",
    (0x05, 0x00): "ACK-NAK",
    (0x05, 0x01): "ACK-ACK",
    (0x0A, 0x09): "MON-HW",
    (0x10, 0x02): "ESF-MEAS",
    (0x10, 0x03): "ESF-RAW",
    (0x10, 0x10): "ESF-STATUS",
    (0x10, 0x15): "ESF-INS",
    (0x28, 0x00): "HNR-PVT",
}
NOTED = 6  # kinds of other messages a note names


def is_ubx_name(name: str) -> bool:
    """Whether a file's name is a UBX log's, kept compressed or not (``gps.ubx``,
    ``gps.ubx.gz``)."""
    return without_suffix(name).lower().endswith(UBX_SUFFIXES)


def message_name(cls: int, ident: int) -> str:
    """A message's name (``NAV-PVT``), or its class and id (``0x01-0x99``)."""
    return NAMES.get((cls, ident), f"0x{cls:02X}-0x{ident:02X}")


class _Frames:
    """The UBX messages of a log's bytes, found and checked at once (in the log's order).

    Attributes:
        at: each message's sync position (byte offset).
        cls, ident, length: its class, id and payload length.
        number: its number among the log's messages, 1-based.
        bad: (byte offsets, class * 256 + id, payload lengths) of the messages whose
            checksum does not match (and of sync pairs that frame none).
        cut: (byte offset, class * 256 + id, payload length) of a message cut short at the
            log's end (or of a last sync pair that frames none), or None.
        nmea: how many NMEA sentences (``$GPGGA,``) stand between the messages.
        data: the log's bytes.
    """

    def __init__(self, data: bytes) -> None:
        buf = np.frombuffer(data, np.uint8)
        size = buf.size
        sync = np.flatnonzero((buf[:-1] == SYNC[0]) & (buf[1:] == SYNC[1])) if size > 1 else []
        sync = np.asarray(sync, np.int64)
        head = sync[sync + HEADER <= size]
        length = buf[head + 4].astype(np.int64) | (buf[head + 5].astype(np.int64) << 8)
        end = head + HEADER + length + 2  # after the checksum
        whole = end <= size
        # the 8-bit Fletcher sums over class .. payload, [a, b), from running sums mod 256:
        # ck_a = S1[b] - S1[a]; ck_b = sum_{m=a+1..b} S1[m] - (b - a) S1[a]
        s1 = np.zeros(size + 1, np.uint8)
        np.cumsum(buf, dtype=np.uint8, out=s1[1:])
        s2 = np.zeros(size + 2, np.uint8)
        np.cumsum(s1, dtype=np.uint8, out=s2[1:])
        a = head[whole] + 2
        b = head[whole] + HEADER + length[whole]
        ck_a = s1[b] - s1[a]
        ck_b = (s2[b + 1] - s2[a + 1]).astype(np.int64) - (b - a) * s1[a].astype(np.int64)
        ok = np.zeros(head.size, bool)
        ok[whole] = (ck_a == buf[b]) & ((ck_b & 0xFF) == buf[b + 1])
        # a sync pair inside a message's payload is none
        ends = np.where(ok, end, 0)
        before = np.maximum.accumulate(np.r_[0, ends[:-1]]) if ends.size else ends
        inside = head < before
        kept = ok & ~inside
        cls, ident = buf[head + 2], buf[head + 3]
        key = cls.astype(np.int64) * 256 + ident
        self.at = head[kept]
        self.cls, self.ident, self.length = cls[kept], ident[kept], length[kept]
        self.number = np.arange(1, self.at.size + 1)
        bad = whole & ~ok & ~inside
        self.bad = (head[bad], key[bad], length[bad])
        cut = np.flatnonzero(~whole & (head >= int(ends.max(initial=0))))
        self.cut = (int(head[cut[0]]), int(key[cut[0]]), int(length[cut[0]])) if cut.size else None
        # an NMEA sentence between the messages: "$", a talker and a type (five capitals
        # or digits: GPGGA, GNRMC), a comma
        dollar = np.flatnonzero(buf[: max(size - 6, 0)] == ord("$"))
        word = buf[dollar[:, None] + np.arange(1, 6)] if dollar.size else np.zeros((0, 5))
        capital = ((word >= ord("A")) & (word <= ord("Z"))) | (
            (word >= ord("0")) & (word <= ord("9"))
        )
        sentence = capital.all(axis=1) & (buf[dollar + 6] == ord(",")) if dollar.size else dollar
        self.nmea = int(np.count_nonzero(sentence))
        self._buf = buf
        self.data = data

    def which(self, kind: tuple[int, int]) -> np.ndarray:
        """The messages of a kind (class, id) with one of its payload lengths (:data:`LENGTHS`)."""
        return np.flatnonzero(
            (self.cls == kind[0]) & (self.ident == kind[1]) & np.isin(self.length, LENGTHS[kind])
        )

    def payloads(self, which: np.ndarray, dtype: np.dtype) -> np.ndarray:
        """The payloads of messages ``which`` as ``dtype`` records (a shorter one padded
        with zeros: an 84-byte NAV-PVT)."""
        table = np.zeros((which.size, dtype.itemsize), np.uint8)
        for n in np.unique(self.length[which]).tolist():
            rows = np.flatnonzero(self.length[which] == n)
            at = self.at[which[rows]][:, None] + HEADER + np.arange(min(n, dtype.itemsize))
            table[rows, : at.shape[1]] = self._buf[at]
        return table.view(dtype).ravel()

    def others(self, read: tuple[tuple[int, int], ...]) -> str:
        """The messages of the kinds not ``read``, counted by kind (the most first)."""
        keys = self.cls.astype(np.int64) * 256 + self.ident
        other = ~np.isin(keys, [a * 256 + b for a, b in read])
        kinds, counts = np.unique(keys[other], return_counts=True)
        order = np.argsort(-counts, kind="stable")
        shown = [
            f"{message_name(int(kinds[i]) >> 8, int(kinds[i]) & 0xFF)} {int(counts[i])}"
            for i in order[:NOTED]
        ]
        if order.size > NOTED:
            shown.append(f"{int(counts[order[NOTED:]].sum())} of {order.size - NOTED} other kinds")
        return ", ".join(shown)


@dataclass
class _Epochs:
    """A log's epochs, one a navigation solution, as its messages give them.

    Attributes:
        itow: GPS time of week, ms.
        rows: the message that gives the position: its number among the log's messages.
        offsets: its byte offset.
        utc: the epoch's UTC as s since 1970 where the log gives one (NaN: none).
        valid: whether that UTC's date and time are valid.
        resolved: whether the receiver had fully resolved it (knew the leap seconds).
        fix: whether the epoch is a fix.
        channels: signal-map key -> values, SI units (NaN where none).
        sources: key -> the message field it came from.
        kind: the message that gives the position (``NAV-PVT``, ``NAV-POSLLH``).
        what: the messages that gave the epochs, for the note.
        dated: what gave the dates (``NAV-PVT dates``), for the clock's note.
    """

    itow: np.ndarray
    rows: np.ndarray
    offsets: np.ndarray
    utc: np.ndarray
    valid: np.ndarray
    resolved: np.ndarray
    fix: np.ndarray
    channels: dict[str, np.ndarray]
    sources: dict[str, str]
    kind: str
    what: str
    dated: str

    def take(self, keep: np.ndarray) -> _Epochs:
        """The epochs ``keep``."""
        arrays = ("itow", "rows", "offsets", "utc", "valid", "resolved", "fix")
        return dataclasses.replace(
            self,
            **{name: getattr(self, name)[keep] for name in arrays},
            channels={k: v[keep] for k, v in self.channels.items()},
        )


def read_ubx(path: Path, file: str) -> FixLog:
    """Read a u-blox receiver's navigation solutions as one fix an epoch: its NAV-PVT
    messages, or (a u-blox 6, which has none) its NAV-POSLLH with NAV-SOL or NAV-STATUS,
    NAV-VELNED and NAV-TIMEUTC or NAV-TIMEGPS of the same iTOW.

    Args:
        path: the UBX log (binary; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: neither NAV-PVT nor NAV-POSLLH with a fix status (naming what the log
            holds); no epoch with a valid UTC date and time; a fix outside the latitude's
            or longitude's range.
    """
    frames = _Frames(path.read_bytes())
    pvt = frames.which(NAV_PVT)
    if not pvt.size and not frames.which(NAV_POSLLH).size and frames.nmea:
        return _nmea_in_ubx(file, frames)
    read = ((NAV_PVT,) if pvt.size else LEGACY) + (ESF_INS,)
    besides = _besides(frames, read)
    epochs = _pvt_epochs(frames, pvt) if pvt.size else _legacy_epochs(frames, file)
    # an epoch given again (its iTOW), passed over: the first is kept
    _, once = np.unique(epochs.itow, return_index=True)
    once = np.sort(once)
    again = np.setdiff1d(epochs.rows, epochs.rows[once])
    epochs = epochs.take(once)
    dropped = _dropped(frames, again, epochs.kind, read)
    gps_s, weeks = unwrap_midnight(epochs.itow.astype(np.float64) / 1000.0, SECONDS_PER_WEEK)
    offset, how = _utc_offset(epochs, gps_s, file)
    lat, lon = epochs.channels["lat"], epochs.channels["lon"]
    problems = [
        Problem(
            file,
            int(epochs.rows[i]),
            f"{epochs.kind} {what}",
            f"a {what} in [-{limit}, {limit}] degrees",
            f"{values[i]:.7f} (the message at byte {int(epochs.offsets[i])})",
        )
        for what, values, limit in (("lat", lat, 90), ("lon", lon, 180))
        for i in np.flatnonzero(np.abs(values) > limit)[:20]
    ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    day_s = float(np.floor((gps_s[0] + offset) / 86400.0) * 86400.0)
    tod_s = gps_s + (offset - day_s)  # whole seconds: the times of day keep their digits
    rates = _yaw_rates(frames, gps_s, offset - day_s)
    yaw = (
        f"; {rates.rows.size} yaw rates (ESF-INS zAngRate negated: the vehicle frame's z "
        "points down)"
        if rates is not None
        else ""
    )
    notes = [
        f"{file}: a UBX log: {epochs.itow.size} epochs ({epochs.what}), "
        f"{int(epochs.fix.sum())} with a fix{yaw}; {how}"
        + (f"; besides them: {besides}" if besides else "")
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    if weeks.size:
        notes.append(
            f"{file}: GPS time of week passed the week's end before message(s) "
            + ", ".join(str(int(epochs.rows[i])) for i in weeks[:5])
            + ": a week added after each"
        )
    return FixLog(
        file,
        tod_s,
        day_s,
        None,
        epochs.channels,
        {k: epochs.sources[k] for k in epochs.channels},
        epochs.rows,
        notes,
        dropped,
        dated_by=epochs.dated,
        kind="UBX",
        rates=rates,
    )


def _yaw_rates(frames: _Frames, gps_s: np.ndarray, to_tod_s: float) -> ReceiverRates | None:
    """The log's ESF-INS yaw rates with a valid z (none: None), as rad/s turning left
    positive (ISO 8855; the vehicle frame's z points down), on the epochs' clock: their
    iTOW made continuous and put in the epochs' week (``gps_s``), then ``to_tod_s`` added."""
    which = frames.which(ESF_INS)
    ins = frames.payloads(which, INS)
    valid = (ins["bitfield0"] & Z_ANG_RATE_VALID) != 0
    which, ins = which[valid], ins[valid]
    _, once = np.unique(ins["iTOW"], return_index=True)
    once = np.sort(once)
    if not once.size:
        return None
    which, ins = which[once], ins[once]
    t, _ = unwrap_midnight(ins["iTOW"].astype(np.float64) / 1000.0, SECONDS_PER_WEEK)
    t += SECONDS_PER_WEEK * np.round((gps_s[0] - t[0]) / SECONDS_PER_WEEK)
    return ReceiverRates(
        t + to_tod_s,
        {"yaw_rate": np.deg2rad(-1e-3 * ins["zAngRate"].astype(np.float64))},
        {"yaw_rate": "ESF-INS zAngRate (negated: z down)"},
        frames.number[which],
        "ESF-INS",
    )


def _nmea_in_ubx(file: str, frames: _Frames) -> FixLog:
    """A ``.ubx`` log whose fixes are NMEA sentences (a u-blox's factory output is NMEA
    alone, and u-center records whatever comes as ``.ubx``), read as an NMEA log: each
    UBX message is taken out for a line end (its bytes may hold a ``$`` or a line end of
    their own), and the rest read by the NMEA reader, its lines those of what is left.
    What stands before a ``$`` then is no logger's stamp, so the epochs are placed by
    their UTC times."""
    data = frames.data
    ends = frames.at + HEADER + frames.length + 2
    edges = np.zeros(len(data) + 1, np.int64)
    np.add.at(edges, frames.at, 1)
    np.add.at(edges, ends, -1)
    kept = np.cumsum(edges)[:-1] == 0  # no message's byte (messages do not overlap)
    text = np.frombuffer(data, np.uint8).copy()
    text[frames.at] = ord("\n")  # each message's first byte: a line end
    kept[frames.at] = True
    log = read_nmea(text[kept].tobytes(), file)
    held = frames.others(())
    note = (
        f"{file}: a UBX log without NAV-PVT or NAV-POSLLH: its {frames.nmea} NMEA "
        "sentence(s) read as the receiver's NMEA log" + (f" (besides them: {held})" if held else "")
    )
    return dataclasses.replace(
        log, stamps=None, unstamped=np.zeros(0, np.int64), notes=[note, *log.notes]
    )


def _pvt_epochs(frames: _Frames, which: np.ndarray) -> _Epochs:
    """The epochs of a log's NAV-PVT messages ``which``."""
    pvt = frames.payloads(which, PVT)
    long = frames.length[which] == PVT_LENGTHS[0]  # an 84-byte one has no flags3
    fix = (
        ((pvt["flags"] & 1) == 1)
        & np.isin(pvt["fixType"], PVT_FIXES)
        & ~(long & ((pvt["flags3"] & 1) == 1))
    )
    return _Epochs(
        pvt["iTOW"],
        frames.number[which],
        frames.at[which],
        _utc_seconds(pvt, ("year", "month", "day", "hour", "min", "sec", "nano")),
        (pvt["valid"] & VALID_DATE_TIME) == VALID_DATE_TIME,
        (pvt["valid"] & FULLY_RESOLVED) == FULLY_RESOLVED,
        fix,
        {
            "lat": np.where(fix, pvt["lat"] * 1e-7, np.nan),
            "lon": np.where(fix, pvt["lon"] * 1e-7, np.nan),
            "n_sats": pvt["numSV"].astype(np.float64),
            # an epoch without a fix keeps its hAcc: only a fix's is screened
            "h_acc": pvt["hAcc"] / 1000.0,
            "height": pvt["hMSL"] * 1e-3,
            "speed_gnss": np.where(fix, pvt["gSpeed"] * 1e-3, np.nan),
            "heading": np.where(fix, pvt["headMot"] * 1e-5, np.nan),
        },
        {
            "lat": "NAV-PVT lat",
            "lon": "NAV-PVT lon",
            "n_sats": "NAV-PVT numSV",
            "h_acc": "NAV-PVT hAcc",
            "height": "NAV-PVT hMSL",
            "speed_gnss": "NAV-PVT gSpeed",
            "heading": "NAV-PVT headMot",
        },
        "NAV-PVT",
        "NAV-PVT",
        "NAV-PVT dates",
    )


def _legacy_epochs(frames: _Frames, file: str) -> _Epochs:
    """The epochs of a u-blox 6's messages: NAV-POSLLH's position, the fix from NAV-SOL (else
    NAV-STATUS) of its iTOW, the satellites from NAV-SOL, speed and course from NAV-VELNED,
    the UTC from NAV-TIMEUTC (else NAV-TIMEGPS's GPS week and leap seconds).

    Raises:
        InputError: no NAV-POSLLH, or none with a NAV-SOL or NAV-STATUS of its iTOW.
    """
    which = frames.which(NAV_POSLLH)
    pos = frames.payloads(which, POSLLH)
    n = which.size
    sol = _matched(frames, NAV_SOL, SOL, pos["iTOW"])
    status = _matched(frames, NAV_STATUS, STATUS, pos["iTOW"])
    if not n or not (sol.found.any() or status.found.any()):
        held = "; ".join(
            x for x in (_besides(frames, ()), _dropped(frames, [], "", (NAV_PVT, *LEGACY))) if x
        )
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "UBX-NAV-PVT messages (class 0x01, id 0x07), the receiver's solution; or, "
                    "from a u-blox 6, NAV-POSLLH with NAV-SOL or NAV-STATUS (its fix)",
                    held or "no UBX message",
                    "enable NAV-PVT on the port the logger records (u-center: UBX-CFG-MSG "
                    "01-07; u-blox 9 and later: CFG-MSGOUT-UBX_NAV_PVT_<port> = 1), or on a "
                    "u-blox 6 NAV-POSLLH, NAV-SOL and NAV-TIMEUTC; or give the drive the "
                    "receiver's NMEA log (*.nmea)",
                )
            ]
        )
    # the fix: NAV-SOL's where the epoch has one, else NAV-STATUS's
    fix_type = np.where(sol.found, sol.values["gpsFix"], status.values["gpsFix"])
    fix_ok = np.where(sol.found, sol.values["flags"], status.values["flags"]) & 1
    fix = (sol.found | status.found) & (fix_ok == 1) & np.isin(fix_type, PVT_FIXES)
    vel = _matched(frames, NAV_VELNED, VELNED, pos["iTOW"])
    moving = fix & vel.found
    channels = {
        "lat": np.where(fix, pos["lat"] * 1e-7, np.nan),
        "lon": np.where(fix, pos["lon"] * 1e-7, np.nan),
        "n_sats": np.where(sol.found, sol.values["numSV"], np.nan),
        "h_acc": pos["hAcc"] / 1000.0,  # as NAV-PVT's: an epoch without a fix keeps its own
        "height": pos["hMSL"] * 1e-3,
        "speed_gnss": np.where(moving, vel.values["gSpeed"] * 1e-2, np.nan),
        "heading": np.where(moving, vel.values["heading"] * 1e-5, np.nan),
    }
    gave = [n for n, m in (("NAV-SOL", sol), ("NAV-VELNED", vel)) if m.found.any()]
    keep = {"lat", "lon", "height", "h_acc"} | ({"n_sats"} if sol.found.any() else set())
    keep |= {"speed_gnss", "heading"} if vel.found.any() else set()
    utc, valid, resolved, timed = _legacy_utc(frames, pos["iTOW"])
    what = ", ".join(["NAV-POSLLH", *gave, *([] if sol.found.any() else ["NAV-STATUS"]), timed])
    return _Epochs(
        pos["iTOW"],
        frames.number[which],
        frames.at[which],
        utc,
        valid,
        resolved,
        fix,
        {k: v.astype(np.float64) for k, v in channels.items() if k in keep},
        {
            "lat": "NAV-POSLLH lat",
            "lon": "NAV-POSLLH lon",
            "n_sats": "NAV-SOL numSV",
            "h_acc": "NAV-POSLLH hAcc",
            "height": "NAV-POSLLH hMSL",
            "speed_gnss": "NAV-VELNED gSpeed",
            "heading": "NAV-VELNED heading",
        },
        "NAV-POSLLH",
        what.rstrip(", "),
        "NAV-TIMEUTC dates" if timed.startswith("NAV-TIMEUTC") else "NAV-TIMEGPS weeks",
    )


@dataclass(frozen=True)
class _Match:
    """A message kind's payloads matched to epochs by iTOW (the first of each epoch's)."""

    found: np.ndarray
    values: np.ndarray


def _matched(frames: _Frames, kind: tuple[int, int], dtype: np.dtype, itow: np.ndarray) -> _Match:
    """Each epoch's (``itow``) first message of a kind, where it has one."""
    which = frames.which(kind)
    records = frames.payloads(which, dtype)
    out = np.zeros(itow.size, dtype)
    found = np.zeros(itow.size, bool)
    if records.size and itow.size:
        msg_itow, first = np.unique(records["iTOW"], return_index=True)
        k = np.clip(np.searchsorted(msg_itow, itow), 0, msg_itow.size - 1)
        found = msg_itow[k] == itow
        out[found] = records[first[k[found]]]
    return _Match(found, out)


def _legacy_utc(
    frames: _Frames, itow: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Each epoch's UTC (s since 1970), whether it is valid and fully resolved, from the
    NAV-TIMEUTC of its iTOW (valid: validTOW and validWKN; resolved: validUTC), else from
    its NAV-TIMEGPS (GPS week and time less the leap seconds; resolved: leapSValid); and
    which message gave them."""
    utc = np.full(itow.size, np.nan)
    valid = np.zeros(itow.size, bool)
    resolved = np.zeros(itow.size, bool)
    said = []
    timeutc = _matched(frames, NAV_TIMEUTC, TIMEUTC, itow)
    if timeutc.found.any():
        v = timeutc.values
        at = timeutc.found
        fields = ("year", "month", "day", "hour", "min", "sec", "nano")
        utc[at] = _utc_seconds(v[at], fields)
        valid[at] = (v["valid"][at] & 0b011) == 0b011
        resolved[at] = valid[at] & ((v["valid"][at] & 0b100) == 0b100)
        said.append("NAV-TIMEUTC")
    timegps = _matched(frames, NAV_TIMEGPS, TIMEGPS, itow)
    other = timegps.found & ~timeutc.found
    if other.any():
        v = timegps.values[other]
        utc[other] = (
            GPS_EPOCH_S
            + v["week"] * SECONDS_PER_WEEK
            + v["iTOW"] / 1000.0
            + v["fTOW"] * 1e-9
            - v["leapS"]
        )
        valid[other] = (v["valid"] & 0b011) == 0b011
        resolved[other] = valid[other] & ((v["valid"] & 0b100) == 0b100)
        said.append("NAV-TIMEGPS")
    return utc, valid, resolved, ", ".join(said)


def _besides(frames: _Frames, read: tuple[tuple[int, int], ...]) -> str:
    """What a receiver's log holds besides the messages ``read``: other messages, NMEA
    sentences."""
    parts = []
    if others := frames.others(read):
        parts.append(f"other messages ({others})")
    if frames.nmea:
        parts.append(f"{frames.nmea} NMEA sentence(s)")
    return "; ".join(parts)


def _dropped(
    frames: _Frames, again: np.ndarray | list[int], kind: str, read: tuple[tuple[int, int], ...]
) -> str:
    """The messages of the kinds ``read`` not read: those whose checksum does not match, one
    cut short at the log's end; the position messages (``kind``) of an epoch given again
    (``again``: their numbers)."""
    parts = []
    offsets, keys, lengths = frames.bad
    for k in read:
        bad = offsets[(keys == k[0] * 256 + k[1]) & np.isin(lengths, LENGTHS[k])]
        if bad.size:
            parts.append(
                f"{bad.size} {message_name(*k)} message(s) with a checksum that does not match "
                f"(first at byte {int(bad[0])})"
            )
    if frames.cut is not None:
        at, key, length = frames.cut
        k = (key >> 8, key & 0xFF)
        if k in read and length in LENGTHS[k]:
            parts.append(f"a {message_name(*k)} message cut short at the log's end (at byte {at})")
    if len(again):
        parts.append(
            f"{len(again)} {kind} message(s) of an epoch already given (first message "
            f"{int(again[0])})"
        )
    return "; ".join(parts)


def _utc_offset(epochs: _Epochs, gps_s: np.ndarray, file: str) -> tuple[float, str]:
    """The whole seconds from the GPS time of week (``gps_s``, continuous) to UTC (s since
    1970), and what gave it: the median over the epochs with a fully resolved UTC date and
    time, else over those with a valid one."""
    for use, how in (
        (
            epochs.resolved,
            "placed by iTOW on the UTC of the epochs whose date and time the receiver had "
            "fully resolved",
        ),
        (
            epochs.valid,
            "placed by iTOW on the UTC the receiver gave, not fully resolved: its times may "
            "be off by whole (leap) seconds",
        ),
    ):
        use = use & np.isfinite(epochs.utc)
        if use.any():
            return float(np.round(np.median(epochs.utc[use] - gps_s[use]))), how
    legacy = epochs.kind != "NAV-PVT"
    raise InputError(
        [
            Problem(
                file,
                None,
                "NAV-TIMEUTC valid" if legacy else "NAV-PVT valid",
                "an epoch with a valid UTC date and time ("
                + (
                    "a NAV-TIMEUTC with validTOW and validWKN, or a NAV-TIMEGPS with "
                    "towValid and weekValid, of its iTOW"
                    if legacy
                    else "validDate and validTime set"
                )
                + ")",
                f"none of {epochs.itow.size} {epochs.kind} epochs",
                "log the receiver until it has its time (a fix)"
                + (", with NAV-TIMEUTC enabled" if legacy else "")
                + ", or give the drive its NMEA log with the logger's stamps",
            )
        ]
    )


def _utc_seconds(rec: np.ndarray, fields: tuple[str, ...]) -> np.ndarray:
    """A date and time (``fields``: year, month, day, hour, minute, second, ns) as s since
    1970 (NaN where a field is out of range)."""
    year_f, month_f, day_f, hour_f, min_f, sec_f, nano_f = fields
    month, day = rec[month_f].astype(np.int64), rec[day_f].astype(np.int64)
    ok = (
        (rec[year_f] >= 1980)
        & (month >= 1)
        & (month <= 12)
        & (day >= 1)
        & (day <= 31)
        & (rec[hour_f] < 24)
        & (rec[min_f] < 60)
        & (rec[sec_f] <= 60)
    )
    years = (np.where(ok, rec[year_f], 1970).astype(np.int64) - 1970).astype("datetime64[Y]")
    months = years.astype("datetime64[M]") + np.where(ok, month - 1, 0)
    days = (months.astype("datetime64[D]") + np.where(ok, day - 1, 0)).astype(np.int64)
    seconds = (
        days * 86400.0
        + rec[hour_f] * 3600.0
        + rec[min_f] * 60.0
        + rec[sec_f].astype(np.float64)
        + rec[nano_f] * 1e-9
    )
    return np.where(ok, seconds, np.nan)
