"""A Septentrio receiver's binary log (SBF): its PVTGeodetic blocks, one fix an epoch.

Septentrio's receivers (mosaic, AsteRx, PolaRx: research vehicles' and survey rovers')
log their own binary format, the Septentrio Binary Format, to the receiver's disk or
through RxTools: ``log.sbf`` (the receiver's internal logging names its files
``ssssdddf.yy_``, as RINEX names them, with an underscore). A file named ``*.sbf`` or so
(kept compressed too) in a ``stream_csv`` drive's folder is read here as the drive's GNSS
stream (:func:`read_sbf`), and :mod:`rwhonet.data.streamcsv` puts it on the stream files'
clock by its UTC times, as a UBX or NovAtel log.

**The format** (mosaic-X5 Reference Guide, "SBF Outline"; the same in every Septentrio
receiver's): each block starts with the sync ``$@``, then a CRC (u2), its ID (u2: the block
number in bits 0-12, its revision in 13-15) and its length (u2, the whole block's bytes, a
multiple of 4), then its time stamp, ``TOW`` (u4, ms of the GPS week) and ``WNc`` (u2, the
GPS week), and its fields, little-endian. The CRC is CRC-16-CCITT (polynomial 0x1021,
initial value 0: :func:`binascii.crc_hqx`) over the ID, length and body. A block whose CRC
does not match (a byte lost) or that the file ends inside (a logger that lost power) is
passed over and counted; a sync pair inside a good block is not a block.

**The block read: PVTGeodetic** (4007, every revision), **else PVTCartesian** (4006, the
same solution in ECEF: its fields laid out as PVTGeodetic's, ``X``, ``Y``, ``Z`` where
PVTGeodetic has ``Latitude``, ``Longitude``, ``Height``, and ``Vx``, ``Vy``, ``Vz`` where it
has ``Vn``, ``Ve``, ``Vu``). A log with both is read by its PVTGeodetic blocks, the other
counted. From PVTCartesian, the position is X, Y, Z as latitude, longitude and height
above the WGS84 ellipsoid (:func:`rwhonet.geo.ecef.ecef_to_geodetic`, PROJ), and the
velocity's east and north components at it (:func:`rwhonet.geo.ecef.ecef_to_enu_velocity`)
give the horizontal speed; a fix more than :data:`MAX_HEIGHT_M` from the ellipsoid is no
position on a road, and is refused with its block. The fields, from PVTGeodetic:

- ``lat``, ``lon``: ``Latitude``, ``Longitude`` (f8, radians);
- ``height``: ``Height`` (ellipsoidal) less ``Undulation``: above mean sea level, as NMEA
  GGA's altitude and UBX's ``hMSL``;
- ``n_sats``: ``NrSV``, the satellites used;
- ``h_acc``: ``HAccuracy`` (u2, 0.01 m; the reference guide's PVTGeodetic from revision
  2 on, the revision the block's ID bits 13-15; bytes 90-91 of the block), "2DRMS
  horizontal accuracy: twice the root-mean-square of the horizontal distance error",
  halved: the DRMS in metres. A block of revision 0 or 1 (88 bytes), or one too short to
  hold it, states none (a log of such blocks has no ``h_acc``);
- ``speed_gnss``: the horizontal speed of ``Vn`` and ``Ve`` (f4, m/s);
- ``heading``: ``COG``, the course over ground (f4, degrees from true north).

A field the receiver does not know holds its "do-not-use" value (-2e10 for f4 and f8, 255
for ``NrSV``, 65535 for ``HAccuracy``): read as missing. An epoch is a fix where ``Error``
is 0 and the PVT mode (``Mode`` bits 0-3) is a solution from observations: 1
(stand-alone), 2 (differential), 4 and 5 (RTK fixed and float), 6 (SBAS), 7 and 8
(moving-base RTK), 10 (PPP). Mode 0 (no PVT) is not, and neither is 3 (a fixed location,
set by command: a base station's, as NovAtel's ``FIXEDPOS``); such an epoch is kept
without a position.

**The clock.** ``TOW`` and ``WNc`` are GPS time; they are put on UTC by the leap seconds
the log's ReceiverTime blocks (5914) give (``DeltaLS``, where not its do-not-use -128;
their median) or, without one, by the leap seconds IERS announced
(:data:`rwhonet.data.novatel.GPS_UTC_S`). The notes say which. An epoch of a do-not-use
time (before the receiver set its clock) and one whose time was given already are passed
over, counted. Every other block (MeasEpoch, PVTCartesian, ...) is counted by its number.

**Rows.** An epoch is named by its block's number among the file's good blocks (1-based)
and, in refusals, its byte offset.
"""

from __future__ import annotations

import binascii
import re
from collections import Counter
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import without_suffix
from rwhonet.data.nmea import FixLog
from rwhonet.data.novatel import GPS_EPOCH_UNIX_S, SECONDS_PER_WEEK, gps_utc_s
from rwhonet.errors import InputError, Problem
from rwhonet.geo.ecef import ecef_to_enu_velocity, ecef_to_geodetic

SBF_SUFFIXES = (".sbf",)
# a Septentrio receiver's internal logging names its files as RINEX does: ssssdddf.yy_
_INTERNAL_NAME = re.compile(r".*\.\d\d_")
SYNC = b"$@"
HEADER_BYTES = 8  # sync, CRC, ID, length
PVT_GEODETIC, PVT_CARTESIAN, RECEIVER_TIME = 4007, 4006, 5914
MAX_HEIGHT_M = 100_000.0  # a PVTCartesian fix further from the ellipsoid is refused
BLOCK_NAMES = {
    PVT_GEODETIC: "PVTGeodetic",
    RECEIVER_TIME: "ReceiverTime",
    PVT_CARTESIAN: "PVTCartesian",
    4027: "MeasEpoch",
    4013: "ChannelStatus",
    4001: "DOP",
    5906: "PosCovGeodetic",
    5908: "VelCovGeodetic",
    4043: "BaseVectorGeod",
    4044: "PosLocal",
    4226: "INSNavGeod",
}
DNU = -2e10  # a float field's do-not-use value
NO_TOW = 4_294_967_295
NO_WEEK = 65_535
NO_SATS = 255
NO_LEAP = -128
FIX_MODES = (1, 2, 4, 5, 6, 7, 8, 10)
# PVTGeodetic's HAccuracy (u2, 0.01 m, 2DRMS), from revision 2 on: after revision 1's
# PPPInfo and revision 2's Latency (u2), at this byte of the block
H_ACCURACY_AT = 90
H_ACCURACY_REVISION = 2
NO_H_ACCURACY = 65_535
# PVTGeodetic's fields read, from the block's start (revision 0's, which later ones extend)
PVT = np.dtype(
    [
        ("sync", "S2"),
        ("crc", "<u2"),
        ("id", "<u2"),
        ("length", "<u2"),
        ("tow", "<u4"),
        ("wnc", "<u2"),
        ("mode", "u1"),
        ("error", "u1"),
        ("lat", "<f8"),
        ("lon", "<f8"),
        ("height", "<f8"),
        ("undulation", "<f4"),
        ("vn", "<f4"),
        ("ve", "<f4"),
        ("vu", "<f4"),
        ("cog", "<f4"),
        ("clock_bias", "<f8"),
        ("clock_drift", "<f4"),
        ("time_system", "u1"),
        ("datum", "u1"),
        ("nr_sv", "u1"),
    ]
)
RECEIVER = np.dtype(
    [
        ("head", "S8"),
        ("tow", "<u4"),
        ("wnc", "<u2"),
        ("utc", "i1", (6,)),
        ("delta_ls", "i1"),
        ("sync_level", "u1"),
    ]
)


def is_sbf_name(name: str) -> bool:
    """Whether a file's name is an SBF log's, kept compressed or not (``log.sbf``,
    ``log.sbf.gz``, a receiver's own ``sept3400.24_``)."""
    bare = without_suffix(name).lower()
    return bare.endswith(SBF_SUFFIXES) or _INTERNAL_NAME.fullmatch(bare) is not None


class _Blocks:
    """A file's good SBF blocks (their offsets, block numbers and lengths, in the file's
    order), and what was passed over."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        offsets, ids, lengths = [], [], []
        self.bad_crc: list[int] = []  # byte offsets
        self.cut: list[int] = []
        at = data.find(SYNC)
        while at >= 0:
            if at + HEADER_BYTES > len(data):
                self.cut.append(at)
                break
            crc, ident, length = np.frombuffer(data, "<u2", 3, at + 2).tolist()
            if length < HEADER_BYTES or length % 4:  # no block: a "$@" in other bytes
                at = data.find(SYNC, at + 1)
                continue
            if at + length > len(data):
                self.cut.append(at)
                at = data.find(SYNC, at + 1)
                continue
            if binascii.crc_hqx(data[at + 4 : at + length], 0) != crc:
                self.bad_crc.append(at)
                at = data.find(SYNC, at + 1)
                continue
            offsets.append(at)
            ids.append(ident)
            lengths.append(length)
            at = data.find(SYNC, at + length)
        self.offsets = np.array(offsets, np.int64)
        self.number = np.array(ids, np.int64) & 0x1FFF
        self.revision = np.array(ids, np.int64) >> 13
        self.lengths = np.array(lengths, np.int64)

    def records(self, number: int, dtype: np.dtype) -> tuple[np.ndarray, np.ndarray]:
        """The blocks of ``number`` long enough for ``dtype``: their fields, and their
        indices among the good blocks."""
        at = np.flatnonzero((self.number == number) & (self.lengths >= dtype.itemsize))
        raw = b"".join(self.data[o : o + dtype.itemsize] for o in self.offsets[at].tolist())
        return np.frombuffer(raw, dtype), at

    def h_accuracy_m(self, at: np.ndarray) -> np.ndarray:
        """The PVT blocks ``at``'s (indices among the good blocks) ``HAccuracy`` as
        the DRMS, m: half its 2DRMS. NaN where a block states none: of a revision before
        2 (which has no such field), too short to hold it, or of its do-not-use value."""
        out = np.full(at.size, np.nan)
        has = (self.revision[at] >= H_ACCURACY_REVISION) & (self.lengths[at] >= H_ACCURACY_AT + 2)
        if has.any():
            buf = np.frombuffer(self.data, np.uint8)
            o = self.offsets[at[has]] + H_ACCURACY_AT
            raw = buf[o].astype(np.int64) | (buf[o + 1].astype(np.int64) << 8)
            out[has] = np.where(raw != NO_H_ACCURACY, raw / 200.0, np.nan)  # 0.01 m, halved
        return out

    def besides(self, read: int) -> str:
        """The blocks other than those ``read`` and ReceiverTime, counted by name, the most
        first."""
        counts = Counter(
            BLOCK_NAMES.get(n, f"block {n}")
            for n in self.number.tolist()
            if n not in (read, RECEIVER_TIME)
        )
        return ", ".join(f"{k} {v}" for k, v in counts.most_common(6))


def read_sbf(path: Path, file: str) -> FixLog:
    """Read a Septentrio receiver's PVTGeodetic (else PVTCartesian) blocks as one fix an
    epoch, on UTC.

    Args:
        path: the SBF log (binary; a compressed one already unpacked).
        file: how messages name it.

    Raises:
        InputError: no PVTGeodetic or PVTCartesian block (naming what the log holds); none
            with a time; a fix outside the latitude's or longitude's range, or (PVTCartesian)
            far from the ellipsoid.
    """
    blocks = _Blocks(path.read_bytes())
    number = PVT_GEODETIC
    pvt, at = blocks.records(PVT_GEODETIC, PVT)
    if not pvt.size:
        number = PVT_CARTESIAN
        pvt, at = blocks.records(PVT_CARTESIAN, PVT)
    name = BLOCK_NAMES[number]
    if not pvt.size:
        held = blocks.besides(number) or "no good block"
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a Septentrio receiver's PVTGeodetic (or PVTCartesian) blocks (SBF)",
                    held
                    + (
                        f"; {len(blocks.bad_crc)} whose CRC does not match"
                        if blocks.bad_crc
                        else ""
                    ),
                    "log PVTGeodetic with the drive (setSBFOutput, Stream1, ..., PVTGeodetic, "
                    "msec100), or give the receiver's NMEA output (GGA, RMC)",
                )
            ]
        )
    rows = at + 1
    h_acc = blocks.h_accuracy_m(at)
    timed = (pvt["tow"] != NO_TOW) & (pvt["wnc"] != NO_WEEK)
    gps = pvt["wnc"].astype(np.float64) * SECONDS_PER_WEEK + pvt["tow"] / 1000.0
    _, first = np.unique(np.where(timed, gps, np.nan), return_index=True)
    once = np.zeros(pvt.size, bool)
    once[first] = True
    once &= timed  # np.unique keeps every NaN: an epoch without a time is none
    untimed, again = rows[~timed], rows[timed & ~once]
    pvt, rows, offsets, gps = pvt[once], rows[once], blocks.offsets[at][once], gps[once]
    h_acc = h_acc[once]
    if not pvt.size:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    name,
                    f"{name} blocks with a GPS time",
                    f"{untimed.size} of a do-not-use time, none with a time",
                    "log the drive once the receiver has set its clock",
                )
            ]
        )
    fix = (pvt["error"] == 0) & np.isin(pvt["mode"] & 0x0F, FIX_MODES)
    fix &= (pvt["lat"] != DNU) & (pvt["lon"] != DNU)

    if number == PVT_CARTESIAN:
        lat, lon, ellipsoidal, vn, ve, problems = _from_ecef(pvt, fix, rows, offsets, file)
        fix &= np.isfinite(lat)
    else:
        lat, lon = np.degrees(pvt["lat"]), np.degrees(pvt["lon"])
        ellipsoidal = np.where(pvt["height"] != DNU, pvt["height"], np.nan)
        vn, ve = _known(pvt["vn"]), _known(pvt["ve"])
        problems = [
            Problem(
                file,
                int(rows[i]),
                f"PVTGeodetic {what}",
                f"a {what} in [-{limit}, {limit}] degrees",
                f"{values[i]:.7f} (the block at byte {int(offsets[i])})",
            )
            for what, values, limit in (("Latitude", lat, 90), ("Longitude", lon, 180))
            for i in np.flatnonzero(fix & (np.abs(values) > limit))[:20]
        ]
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {file}")
    height = ellipsoidal - _known(pvt["undulation"])
    speed = np.hypot(vn, ve)
    channels = {
        "lat": np.where(fix, lat, np.nan),
        "lon": np.where(fix, lon, np.nan),
        "height": height,
        "n_sats": np.where(pvt["nr_sv"] != NO_SATS, pvt["nr_sv"].astype(np.float64), np.nan),
        "h_acc": h_acc,
        "speed_gnss": np.where(fix, speed, np.nan),
        "heading": np.where(fix, _known(pvt["cog"]), np.nan),
    }
    # a field every epoch lacks (a receiver that gives no velocity; blocks before
    # revision 2, which state no accuracy) is no channel
    channels = {k: v for k, v in channels.items() if k in ("lat", "lon") or np.isfinite(v).any()}
    sources = (
        {
            "lat": "PVTCartesian X, Y, Z",
            "lon": "PVTCartesian X, Y, Z",
            "height": "PVTCartesian X, Y, Z less Undulation",
            "speed_gnss": "PVTCartesian Vx, Vy, Vz",
        }
        if number == PVT_CARTESIAN
        else {
            "lat": "PVTGeodetic Latitude",
            "lon": "PVTGeodetic Longitude",
            "height": "PVTGeodetic Height less Undulation",
            "speed_gnss": "PVTGeodetic Vn, Ve",
        }
    )
    sources |= {"n_sats": f"{name} NrSV", "h_acc": f"{name} HAccuracy", "heading": f"{name} COG"}
    offset_s, how = _utc_offset(blocks, gps)
    utc = GPS_EPOCH_UNIX_S + gps + offset_s
    dropped = "; ".join(
        part
        for part in (
            f"{len(blocks.bad_crc)} block(s) whose CRC does not match (first at byte "
            f"{blocks.bad_crc[0]})"
            if blocks.bad_crc
            else "",
            f"{len(blocks.cut)} block(s) cut short (first at byte {blocks.cut[0]})"
            if blocks.cut
            else "",
            f"{untimed.size} {name} block(s) of a do-not-use time (first: block {untimed[0]})"
            if untimed.size
            else "",
            f"{again.size} {name} block(s) of an epoch already given (first: block {again[0]})"
            if again.size
            else "",
        )
        if part
    )
    besides = blocks.besides(number)
    notes = [
        f"{file}: an SBF log: {gps.size} epochs ({name}), {int(fix.sum())} with a fix; "
        f"{how}"
        + (f"; besides them: {besides}" if besides else "")
        + (f"; passed over: {dropped}" if dropped else "")
    ]
    return FixLog.on_utc(
        file,
        utc,
        channels,
        {k: sources[k] for k in channels},
        rows,
        notes,
        dropped,
        dated_by="GPS weeks",
        kind="SBF",
    )


def _known(values: np.ndarray) -> np.ndarray:
    """A float field's values, NaN where do-not-use."""
    return np.where(values != np.float32(DNU), values.astype(np.float64), np.nan)


def _from_ecef(
    pvt: np.ndarray, fix: np.ndarray, rows: np.ndarray, offsets: np.ndarray, file: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[Problem]]:
    """PVTCartesian blocks' fixes as latitude, longitude (degrees) and ellipsoidal height
    (m), their velocity's north and east components (m/s), and a problem for each fix more
    than :data:`MAX_HEIGHT_M` from the ellipsoid (at most 20). The fields sit where
    PVTGeodetic's do: X, Y, Z in ``lat``, ``lon``, ``height``; Vx, Vy, Vz in ``vn``, ``ve``,
    ``vu``. NaN where not a fix (or Z is do-not-use) and where a velocity field is."""
    x, y, z = (pvt[k].astype(np.float64) for k in ("lat", "lon", "height"))
    use = fix & (z != DNU)
    lat, lon, h = (np.full(pvt.size, np.nan) for _ in range(3))
    lat[use], lon[use], h[use] = ecef_to_geodetic(x[use], y[use], z[use])
    with np.errstate(invalid="ignore"):
        far = np.flatnonzero(use & ~(np.abs(h) <= MAX_HEIGHT_M))
    problems = [
        Problem(
            file,
            int(rows[i]),
            "PVTCartesian X, Y, Z",
            f"a position within {MAX_HEIGHT_M / 1000:.0f} km of the WGS84 ellipsoid",
            f"{abs(h[i]) / 1000:.1f} km {'below' if h[i] < 0 else 'above'} it (X, Y, Z = "
            f"{x[i]:.3f}, {y[i]:.3f}, {z[i]:.3f} m; "
            f"the block at byte {int(offsets[i])})",
        )
        for i in far[:20]
    ]
    v = [_known(pvt[k]) for k in ("vn", "ve", "vu")]
    east, north, _ = ecef_to_enu_velocity(v[0], v[1], v[2], lat, lon)
    return lat, lon, h, north, east, problems


def _utc_offset(blocks: _Blocks, gps: np.ndarray) -> tuple[float, str]:
    """UTC less GPS time (s): the log's ReceiverTime blocks' ``DeltaLS`` (their median),
    or the leap seconds IERS announced at the first epoch."""
    times, _ = blocks.records(RECEIVER_TIME, RECEIVER)
    leaps = times["delta_ls"][times["delta_ls"] != NO_LEAP] if times.size else np.zeros(0)
    if leaps.size:
        leap = float(np.median(leaps))
        return -leap, f"GPS time put on UTC by its ReceiverTime blocks' DeltaLS ({leap:g} s)"
    leap = gps_utc_s(GPS_EPOCH_UNIX_S + float(gps[0]))
    return -float(leap), (
        f"GPS time put on UTC by the leap seconds to its date ({leap} s; no ReceiverTime "
        "block with DeltaLS)"
    )
