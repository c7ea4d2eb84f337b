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

**What a log holds besides messages**: a message is framed by its two sync bytes
(``0xB5 0x62``), class, id, a little-endian payload length and the 8-bit Fletcher checksum
over class, id, length and payload (section 32.4). A NAV-PVT whose checksum does not match
(a byte lost on the serial line) and one cut short at the end (a logger that lost power)
are dropped and counted; a sync pair inside another message's payload is not a message.

**Rows.** A message is named by its number among the log's UBX messages (1-based, as
``pyubx2``'s ``UBXReader`` with the UBX protocol filter counts them) and, in refusals, its
byte offset.

The messages are found and checked over the log's bytes at once (numpy: the sync pairs,
every candidate's checksum from two running sums), and the NAV-PVT payloads read as one
structured array. ``pyubx2`` reads one message at a time in Python: 9.1 s for a two-hour
10 Hz log of NAV-PVT alone on this machine (0.008 M messages/s), where this reader takes
under 0.1 s; the tests read every log they write with ``pyubx2`` too, and compare
(``tests/data/test_ubx.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rwhonet.data.compressed import without_suffix
from rwhonet.data.nmea import FixLog
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
        bad_pvt: byte offsets of NAV-PVT messages whose checksum does not match.
        cut_pvt: the byte offset of a NAV-PVT cut short at the log's end, or None.
        nmea: how many NMEA sentences (``$GPGGA,``) stand between the messages.
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
        pvt = (cls == NAV_PVT[0]) & (ident == NAV_PVT[1]) & np.isin(length, PVT_LENGTHS)
        self.at = head[kept]
        self.cls, self.ident, self.length = cls[kept], ident[kept], length[kept]
        self.number = np.arange(1, self.at.size + 1)
        self.bad_pvt = head[pvt & whole & ~ok & ~inside]
        last_end = int(ends.max(initial=0))
        cut = head[pvt & ~whole & (head >= last_end)]
        self.cut_pvt = int(cut[0]) if cut.size else None
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

    def payloads(self, which: np.ndarray) -> np.ndarray:
        """The NAV-PVT payloads of messages ``which`` as :data:`PVT` records (an 84-byte
        one padded with zeros)."""
        table = np.zeros((which.size, PVT.itemsize), np.uint8)
        for n in PVT_LENGTHS:
            rows = np.flatnonzero(self.length[which] == n)
            if rows.size:
                at = self.at[which[rows]][:, None] + HEADER + np.arange(n)
                table[rows, :n] = self._buf[at]
        return table.view(PVT).ravel()

    def others(self) -> str:
        """The other messages, counted by kind (the most first)."""
        other = ~((self.cls == NAV_PVT[0]) & (self.ident == NAV_PVT[1]))
        keys = self.cls[other].astype(np.int64) * 256 + self.ident[other]
        kinds, counts = np.unique(keys, return_counts=True)
        order = np.argsort(-counts, kind="stable")
        shown = [
            f"{message_name(int(kinds[i]) >> 8, int(kinds[i]) & 0xFF)} {int(counts[i])}"
            for i in order[:NOTED]
        ]
        if order.size > NOTED:
            shown.append(f"{int(counts[order[NOTED:]].sum())} of {order.size - NOTED} other kinds")
        return ", ".join(shown)


def read_ubx(path: Path, file: str) -> FixLog:
    """Read a u-blox receiver's NAV-PVT messages as one fix an epoch.

    Args:
        path: the UBX log (binary; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: no NAV-PVT message (naming what the log holds); no epoch with a valid
            UTC date and time; a fix outside the latitude's or longitude's range.
    """
    frames = _Frames(path.read_bytes())
    is_pvt = (frames.cls == NAV_PVT[0]) & (frames.ident == NAV_PVT[1])
    is_pvt &= np.isin(frames.length, PVT_LENGTHS)
    which = np.flatnonzero(is_pvt)
    besides = _besides(frames)
    if not which.size:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "UBX-NAV-PVT messages (class 0x01, id 0x07), the receiver's solution",
                    "; ".join(x for x in (besides, _dropped(frames, [])) if x) or "no UBX message",
                    "enable NAV-PVT on the port the logger records (u-center: UBX-CFG-MSG "
                    "01-07; u-blox 9 and later: CFG-MSGOUT-UBX_NAV_PVT_<port> = 1), or give "
                    "the drive the receiver's NMEA log (*.nmea)",
                )
            ]
        )
    pvt = frames.payloads(which)
    rows = frames.number[which]
    offsets = frames.at[which]
    # an epoch given again (its iTOW), passed over: the first is kept
    _, once = np.unique(pvt["iTOW"], return_index=True)
    once = np.sort(once)
    again = np.setdiff1d(rows, rows[once])
    dropped = _dropped(frames, again)
    pvt, rows, offsets = pvt[once], rows[once], offsets[once]
    gps_s, weeks = unwrap_midnight(pvt["iTOW"].astype(np.float64) / 1000.0, SECONDS_PER_WEEK)
    offset, how = _utc_offset(pvt, gps_s, file)
    t_utc = gps_s + offset
    fix = (
        ((pvt["flags"] & 1) == 1)
        & np.isin(pvt["fixType"], PVT_FIXES)
        & ~((frames.length[which][once] == PVT_LENGTHS[0]) & ((pvt["flags3"] & 1) == 1))
    )
    lat = np.where(fix, pvt["lat"] * 1e-7, np.nan)
    lon = np.where(fix, pvt["lon"] * 1e-7, np.nan)
    problems = [
        Problem(
            file,
            int(rows[i]),
            f"NAV-PVT {what}",
            f"a {what} in [-{limit}, {limit}] degrees",
            f"{values[i]:.7f} (the message at byte {int(offsets[i])})",
        )
        for what, values, limit in (("lat", lat, 90), ("lon", lon, 180))
        for i in np.flatnonzero(np.abs(values) > limit)[:20]
    ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    day_s = float(np.floor(t_utc[0] / 86400.0) * 86400.0)
    tod_s = gps_s + (offset - day_s)  # whole seconds: the times of day keep their digits
    notes = [
        f"{file}: a UBX log: {pvt.size} NAV-PVT epochs, {int(fix.sum())} with a fix; {how}"
        + (f"; besides them: {besides}" if besides else "")
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    if weeks.size:
        notes.append(
            f"{file}: GPS time of week passed the week's end before message(s) "
            + ", ".join(str(int(rows[i])) for i in weeks[:5])
            + ": a week added after each"
        )
    return FixLog(
        file,
        tod_s,
        day_s,
        None,
        {
            "lat": lat,
            "lon": lon,
            "n_sats": pvt["numSV"].astype(np.float64),
            "height": pvt["hMSL"] * 1e-3,
            "speed_gnss": np.where(fix, pvt["gSpeed"] * 1e-3, np.nan),
            "heading": np.where(fix, pvt["headMot"] * 1e-5, np.nan),
        },
        {
            "lat": "NAV-PVT lat",
            "lon": "NAV-PVT lon",
            "n_sats": "NAV-PVT numSV",
            "height": "NAV-PVT hMSL",
            "speed_gnss": "NAV-PVT gSpeed",
            "heading": "NAV-PVT headMot",
        },
        rows,
        notes,
        dropped,
        dated_by="NAV-PVT dates",
    )


def _besides(frames: _Frames) -> str:
    """What a receiver's log holds besides NAV-PVT: other messages, NMEA sentences."""
    parts = []
    if others := frames.others():
        parts.append(f"other messages ({others})")
    if frames.nmea:
        parts.append(f"{frames.nmea} NMEA sentence(s)")
    return "; ".join(parts)


def _dropped(frames: _Frames, again: np.ndarray | list[int]) -> str:
    """The NAV-PVT messages not read: a checksum that does not match, one cut short at the
    end, an epoch's given again (``again``: their numbers)."""
    parts = []
    if frames.bad_pvt.size:
        parts.append(
            f"{frames.bad_pvt.size} NAV-PVT message(s) with a checksum that does not match "
            f"(first at byte {int(frames.bad_pvt[0])})"
        )
    if frames.cut_pvt is not None:
        parts.append(f"a NAV-PVT message cut short at the log's end (at byte {frames.cut_pvt})")
    if len(again):
        parts.append(
            f"{len(again)} NAV-PVT message(s) of an epoch already given (first message "
            f"{int(again[0])})"
        )
    return "; ".join(parts)


def _utc_offset(pvt: np.ndarray, gps_s: np.ndarray, file: str) -> tuple[float, str]:
    """The whole seconds from the GPS time of week to UTC (s since 1970), and what gave it:
    the median over the epochs with a fully resolved UTC date and time, else over those with
    a valid one."""
    utc = _utc_seconds(pvt)
    for flags, how in (
        (
            FULLY_RESOLVED,
            "placed by iTOW on the UTC of the epochs whose date and time the "
            "receiver had fully resolved",
        ),
        (
            VALID_DATE_TIME,
            "placed by iTOW on the UTC the receiver gave, not fully resolved: "
            "its times may be off by whole (leap) seconds",
        ),
    ):
        use = ((pvt["valid"] & flags) == flags) & np.isfinite(utc)
        if use.any():
            return float(np.round(np.median(utc[use] - gps_s[use]))), how
    raise InputError(
        [
            Problem(
                file,
                None,
                "NAV-PVT valid",
                "an epoch with a valid UTC date and time (validDate and validTime set)",
                f"none of {pvt.size} NAV-PVT epochs",
                "log the receiver until it has its time (a fix), or give the drive its NMEA "
                "log with the logger's stamps",
            )
        ]
    )


def _utc_seconds(pvt: np.ndarray) -> np.ndarray:
    """Each epoch's UTC date and time as s since 1970 (NaN where a field is out of range)."""
    month, day = pvt["month"].astype(np.int64), pvt["day"].astype(np.int64)
    ok = (
        (pvt["year"] >= 1980)
        & (month >= 1)
        & (month <= 12)
        & (day >= 1)
        & (day <= 31)
        & (pvt["hour"] < 24)
        & (pvt["min"] < 60)
        & (pvt["sec"] <= 60)
    )
    years = (np.where(ok, pvt["year"], 1970).astype(np.int64) - 1970).astype("datetime64[Y]")
    months = years.astype("datetime64[M]") + np.where(ok, month - 1, 0)
    days = (months.astype("datetime64[D]") + np.where(ok, day - 1, 0)).astype(np.int64)
    seconds = (
        days * 86400.0
        + pvt["hour"] * 3600.0
        + pvt["min"] * 60.0
        + pvt["sec"].astype(np.float64)
        + pvt["nano"] * 1e-9
    )
    return np.where(ok, seconds, np.nan)
