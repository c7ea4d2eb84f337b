"""Timestamped sensor streams -> one canonical drive on the pipeline's 10 Hz grid.

Real loggers write each sensor at its own rate with its own timestamps (CAN
wheel speeds at 50-100 Hz, GNSS fixes at 1-10 Hz, an IMU at 100 Hz); the
pipeline reads one row every 0.1 s. Every stream reader (comma2k19 folders,
MDF4 files, one CSV per stream) returns :class:`DriveStreams`, and
:func:`resample` is the one way they reach the grid. The result is the
canonical drive the 10 Hz readers give (:class:`~rwhonet.data.csvio.RawDrive`,
``header_match="streams"``), so validate and label run unchanged.

The grid
    Rows at the whole multiples of ``period_s`` (0.1 s) of the streams' own
    clock (the clock every stream of the drive is stamped on: a device's boot
    clock, an MDF4 file's master time, a CSV's time column): ``t_k = k / 10``
    exactly, so whole seconds of that clock are rows and the per-second logic
    of validate and label applies as it is.

Rates (wheel speeds, yaw rate, accelerations, vehicle speed): a time-weighted mean
    Row ``t_k`` holds the mean of the signal over ``[t_k - period/2, t_k + period/2]``,
    the signal taken as piecewise *linear* between its samples (each sample the
    value at its timestamp). Linear rather than piecewise constant: a hold keeps
    each value until the next sample and so delays the signal by half a sample
    period (5-10 ms at 50-100 Hz), a systematic shift of every wheel speed
    against the GNSS fixes; the linear signal has none and integrates a constant
    acceleration exactly. Centred rather than trailing: the label integrates the
    rows with the trapezoid rule between fixes at ``t_a`` and ``t_b``
    (:func:`rwhonet.features.seconds.integrate_per_second`); with centred means
    that integral is the signal's own integral over ``[t_a, t_b]`` up to
    ``period^2 / 24`` times the change of its slope, while trailing means would
    lag the wheels by half a period (0.1 m per second when braking at 2 m/s^2,
    as large as the labels). The mean is computed exactly from the cumulative
    trapezoid integral at the window's edges (no loop over samples).

Fix times: the receiver's epochs where the wheels say so
    A logger that stamps each fix when it arrives places it a few milliseconds from
    where the car was. Where the fixes' stamps scatter about a regular grid of a
    receiver's period and the wheel speeds between fixes fit the grid's epochs
    better than the stamps, the fixes are placed at the epochs
    (:func:`rwhonet.data.fixtimes.fix_times`; the drive's notes say which, and why).
    A constant lag between the fixes' clock and the wheels' (a receiver's latency
    the stamps carry) is then estimated from the wheels, tyre slip told apart
    (:func:`rwhonet.data.fixlag.fix_lag`), said in the notes and, as ``gnss_lag``
    (``data.gnss_lag``) says, left in (``report``, the default) or moved out.

Positions: along the path between fixes, never across a gap, never extrapolated
    A fix at latitude = longitude = 0 is what a receiver without a fix writes: it is
    no fix (:func:`rwhonet.data.fixes.no_fix_rows`), left out as a sample without a
    value is. A row ``t_k`` gets a position only between two fixes around it at most
    ``max_fix_gap_s`` apart; before the first fix, after the last, and between
    fixes further apart, it has none. The position is placed *along the car's path*
    between the two fixes (:func:`travelled_path`): the wheels' rolled distance,
    turned by the gyro's yaw where the drive has one, traces the path's shape
    between the fixes up to a rotation and a scale, which the two fixes fix. A
    position taken linearly in time between fixes a second apart (1 Hz receivers)
    lies on the chord: a quarter of a metre behind an accelerating car at 2 m/s^2,
    and up to the sagitta inside a curve (45 cm for 12 m round a 40 m radius),
    errors every per-second displacement, label and score take
    (docs/readers.md, "What it costs"). Where the wheels pause within the interval,
    or roll less than :data:`MIN_PATH_RAD`, the position is taken linearly in time
    (longitude unwrapped, so the antimeridian is no jump). Speed, height and course
    are interpolated linearly in time (course unwrapped); the satellite count of a
    row is the smaller of its two fixes'.

Gaps
    A rate's row needs samples covering its whole window, with no step between
    samples longer than ``max_wheel_gap_s`` overlapping it. A row without all four
    wheel speeds or without a position is left out of the grid, and so are the rows
    next to it until the hole in the grid is longer than ``split_gap_s``
    (``validate.gnss.max_gap_s``): validate then cuts the seconds there as a
    ``gap`` and splits the drive, exactly as for a 10 Hz file with a GNSS outage
    (``require_fix=False``, what ``rwhonet predict`` reads: a row without a position is
    kept with NaN latitude and longitude, and only wheel holes are left out).
    Optional channels without data in a kept row are NaN. A wheel stream with more
    than :data:`SLOW_STREAM_SHARE` of its steps longer than ``max_wheel_gap_s`` (logged
    at 4-5 Hz, or stamped in ms read as s) is refused rather than resampled into an
    empty or nearly empty grid, and so are streams that leave no row.

Glitches
    A stream that carries all four wheel speeds is screened sample by sample with
    :func:`rwhonet.data.glitches.glitch_mask` (given the car's nominal radius):
    grid rows whose mean used a glitched sample are flagged in
    :attr:`Resampled.glitch`, for validate to cut their seconds
    (:func:`rwhonet.data.quality.assess`, ``wheel_glitch``), never to average them
    away.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.fixes import no_fix_rows
from rwhonet.data.fixlag import lagged_times
from rwhonet.data.fixtimes import fix_times
from rwhonet.data.glitches import WHEEL_GLITCH_G, glitch_mask, running_max
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.data.robust import cumulative_trapezoid
from rwhonet.errors import InputError, Problem
from rwhonet.geo.geodesic import wgs84

GRID_PERIOD_S = 0.1
MAX_WHEEL_GAP_S = 0.2  # 10 to 20 sample periods of a 50-100 Hz CAN stream
FIX_GAP_FACTOR = 1.5  # default max_fix_gap_s: this x the median fix interval...
MIN_FIX_GAP_S = 0.25  # ...and at least this (one missed fix of a 10 Hz receiver)
SPLIT_GAP_S = 0.5  # validate.gnss.max_gap_s: a hole in the grid must be longer
# Between two fixes the car's wheels rolled less than this (rad, ~0.3 m of a 0.3 m tyre):
# the position is interpolated in time, not along the path (which says nothing then).
MIN_PATH_RAD = 1.0
# A wheel stream with more of its steps longer than max_wheel_gap_s is too slow for the
# grid (wheels logged at 4-5 Hz, or a time in ms read as s), not one with dropouts: refused.
SLOW_STREAM_SHARE = 0.1
# A wheel or GNSS stream running on this much beyond the others (s) is said: the grid
# spans only the stretch they all cover (streams end a fraction of a second apart).
SPAN_NOTE_S = 1.0

# Canonical channels averaged over each row's window (rates); the GNSS stream's: c.FIX_CHANNELS.
RATE_CHANNELS = (*c.WHEELS, c.YAW_RATE_RAD_S, c.SPEED_VEHICLE_M_S, c.ACC_LON_M_S2, c.ACC_LAT_M_S2)


@dataclass(frozen=True, eq=False)  # arrays inside: compared by identity, never element-wise
class Stream:
    """One group of channels sampled together, as a logger wrote it.

    Attributes:
        name: the stream as the user knows it (``"CAN/wheel_speed"``, a CSV file name, an
            MDF4 channel group), for messages.
        file: the file or folder it was read from, for messages.
        t_s: sample times, s, on the drive's clock.
        channels: canonical name -> values in SI units (one per sample).
        sources: canonical name -> the source's own channel name (``t_s``: the time's).
        rows: each sample's row in its source, 1-based, for messages (None: sample ``i``
            is row ``i + 1``; a reader that dropped or reordered samples, or split a file
            of several messages, gives them).
        parts: a stream a logger split across files in time (:mod:`rwhonet.data.fileparts`):
            each file's name and the stream's name in it (``file`` then names them
            together); empty for a stream of one file.
        part: each sample's index into ``parts`` (None: one file); ``rows`` are then rows
            of that file.
    """

    name: str
    file: str
    t_s: np.ndarray
    channels: dict[str, np.ndarray]
    sources: dict[str, str] = field(default_factory=dict)
    rows: np.ndarray | None = None
    parts: tuple[tuple[str, str], ...] = ()
    part: np.ndarray | None = None

    def file_rows(self, index: np.ndarray) -> np.ndarray:
        """The source's 1-based rows of samples ``index`` (0-based positions); for a stream
        of several files, rows of each sample's own file (:meth:`places`)."""
        index = np.asarray(index, dtype=np.int64)
        return index + 1 if self.rows is None else np.asarray(self.rows)[index]

    def places(self, index: np.ndarray) -> list[tuple[str, int]]:
        """Where samples ``index`` are: the file as messages name it, and its row."""
        index = np.asarray(index, dtype=np.int64)
        rows = self.file_rows(index)
        if self.part is None:
            return [(self.where(), int(r)) for r in rows]
        wheres = [where_named(f, n) for f, n in self.parts]
        return [(wheres[k], int(r)) for k, r in zip(self.part[index], rows, strict=True)]

    def wheres(self) -> list[str]:
        """How messages name the stream: as a whole, and each of its files."""
        return [self.where(), *(where_named(f, n) for f, n in self.parts)]

    def row_problems(
        self,
        column: str | None,
        index: np.ndarray,
        found: Callable[[int], str],
        expected: str,
        fix: str,
    ) -> list[Problem]:
        """One check's bad samples ``index`` (0-based) as problems naming file and row
        (:func:`rwhonet.data.problems.row_problems`), one list per file of the stream;
        ``found(i)`` says what sample ``i`` holds."""
        index = np.asarray(index, dtype=np.int64)
        if self.part is None:
            found_ = [found(int(i)) for i in index[:ROWS_LISTED]]
            return row_problems(
                self.where(), column, self.file_rows(index), found_, expected, fix=fix
            )
        out = []
        for k, (file, name) in enumerate(self.parts):
            mine = index[self.part[index] == k]
            if mine.size:
                found_ = [found(int(i)) for i in mine[:ROWS_LISTED]]
                rows = self.file_rows(mine)
                out += row_problems(
                    where_named(file, name), column, rows, found_, expected, fix=fix
                )
        return out

    @property
    def n_rows(self) -> int:
        """Samples in the stream."""
        return int(np.size(self.t_s))

    def where(self, name: str | None = None) -> str:
        """How a problem names the stream (and a channel of it): file, stream, channel."""
        what = where_named(self.file, self.name)
        return what if name is None else f"{what} {self.sources.get(name, name)!r}"

    def label(self, name: str) -> str:
        """A channel as the drive's ``source_columns`` name it: stream and channel."""
        return f"{self.name}: {self.sources.get(name, name)}"


def where_named(file: str, name: str) -> str:
    """How messages name a stream ``name`` of ``file`` (the file alone where they agree)."""
    return f"{file} [{name}]" if name and name != file else file


@dataclass(frozen=True)
class DriveStreams:
    """What a stream reader returns: a drive as separate timestamped streams on one clock.

    Attributes:
        wheels: the streams holding the four wheel speeds (rad/s), all four in one or
            split over several; each wheel in exactly one.
        gnss: the fixes: ``lat_deg``, ``lon_deg`` and optionally ``n_sats``,
            ``speed_gnss_m_s``, ``heading_deg``, ``height_m``.
        extra: other rate streams (``yaw_rate_rad_s``, ``acc_lon_m_s2``, ...).
        clock: what the time stamps are (for the notes: "boot clock of the device", ...).
        notes: what the reader did that the user should hear about (how the fixes were
            timed, ...); :func:`resample` passes them on in the drive's notes.
        changed: what the reader changed of the samples (copies dropped, samples put in
            time order: :mod:`rwhonet.data.sampleorder`); in the drive's notes too, and
            among those ``rwhonet predict`` says (:attr:`Resampled.lost`).
    """

    wheels: tuple[Stream, ...]
    gnss: Stream
    extra: tuple[Stream, ...] = ()
    clock: str = "the streams' own clock"
    notes: tuple[str, ...] = ()
    changed: tuple[str, ...] = ()

    @property
    def streams(self) -> tuple[Stream, ...]:
        """Every stream."""
        return (*self.wheels, self.gnss, *self.extra)

    @property
    def n_input_rows(self) -> int:
        """Samples over all streams (each stream's rows counted once)."""
        return sum(s.n_rows for s in self.streams)


@dataclass(frozen=True)
class Resampled:
    """A drive on the 10 Hz grid, and what the resampler found on the way.

    Attributes:
        drive: the canonical drive (element ``i`` is grid row ``i``).
        glitch: per grid row, whether its wheel-speed mean used a glitched sample.
        glitch_samples: the glitched samples: ``(stream, 1-based sample row, t_s, wheel)``.
        n_input_rows: samples read over all streams.
        glitch_wheels: per wheel (canonical name), the grid rows whose mean of that wheel
            used a glitched sample of it (``glitch`` is their union); what ``rwhonet
            predict`` repairs.
        lost: the notes (among the drive's) that say what of the drive the grid leaves
            out or changes, which ``rwhonet predict`` says on stderr: fixes at latitude =
            longitude = 0, the stretch of a stream beyond the others'.
    """

    drive: RawDrive
    glitch: np.ndarray
    glitch_samples: list[tuple[str, int, float, str]]
    n_input_rows: int
    glitch_wheels: dict[str, np.ndarray] = field(default_factory=dict)
    lost: tuple[str, ...] = ()


# --------------------------------------------------------------------------- checks


def check_streams(streams: DriveStreams) -> None:
    """Refuse streams the resampler cannot read: every problem found, in one report.

    Each stream needs finite, strictly increasing times and at least two samples; the
    wheel streams together hold the four wheels, each once; the GNSS stream holds
    latitude and longitude within range.

    Raises:
        InputError: naming the file, stream and channel, the row and time, what was
            expected and what was found.
    """
    problems: list[Problem] = []
    wheels = [w for s in streams.wheels for w in c.WHEELS if w in s.channels]
    missing = [w for w in c.WHEELS if w not in wheels]
    twice = sorted({w for w in wheels if wheels.count(w) > 1})
    where = ", ".join(s.where() for s in streams.wheels) or "the drive"
    if missing or twice:
        problems.append(
            Problem(
                where,
                None,
                None,
                "the four wheel speeds (front left, front right, rear left, rear right), "
                "each in one stream",
                f"missing {missing}" if missing else f"in two streams: {twice}",
                "map every wheel speed once (column map or signal map)",
            )
        )
    for name in (c.LAT_DEG, c.LON_DEG):
        if name not in streams.gnss.channels:
            problems.append(
                Problem(
                    streams.gnss.where(),
                    None,
                    None,
                    "GNSS fixes with latitude and longitude",
                    f"no {name}",
                    "map the latitude and longitude channels",
                )
            )
    for s in streams.streams:
        problems += stream_problems(s)
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in the drive's streams")


def stream_problems(s: Stream) -> list[Problem]:
    """What :func:`check_streams` refuses in one stream: too few samples, a channel whose
    length is not the time's, a time not finite or not after the previous sample's, a
    latitude or longitude out of range; each naming the source's row (:attr:`Stream.rows`).
    """
    t = np.asarray(s.t_s, dtype=np.float64)
    file = s.where()
    time = s.sources.get(c.T_S, "time")
    out: list[Problem] = []
    if t.ndim != 1 or t.size < 2:
        named = ", ".join(s.sources.get(k, k) for k in s.channels) or time
        return [
            Problem(
                file,
                None,
                named,
                "at least two samples",
                f"{t.size} sample(s)",
                "a stream needs samples over the drive: log the channel, or leave it out of "
                "the map",
            )
        ]
    for name, values in s.channels.items():
        if np.shape(values) != t.shape:
            out.append(
                Problem(
                    file,
                    None,
                    s.sources.get(name, name),
                    f"one value per time stamp ({t.size})",
                    f"{np.size(values)} values",
                    "export the channel with its own time stamps",
                )
            )
    bad = np.flatnonzero(~np.isfinite(t))
    out += s.row_problems(
        time,
        bad,
        lambda i: repr(float(t[i])),
        "a finite time in seconds",
        fix="give every sample its time, or delete the sample",
    )
    if bad.size:
        return out
    step = np.diff(t)
    back = np.flatnonzero(step <= 0) + 1
    out += s.row_problems(
        time,
        back,
        lambda i: (
            f"t = {float(t[i])!r} s after t = {float(t[i - 1])!r} s (step {t[i] - t[i - 1]:+.6g} s)"
        ),
        "a time after the previous sample's (strictly increasing)",
        fix="a clock that went back (a restart, a clock set back) makes two recordings: "
        "split the stream there; a sample at another's time with other values is no copy "
        "(delete the wrong one); samples written twice, or out of order where sorting "
        "neither crowds them nor leaves a gap, the reader puts right",
    )
    for name, limit in ((c.LAT_DEG, 90.0), (c.LON_DEG, 180.0)):
        if name not in s.channels or np.shape(s.channels[name]) != t.shape:
            continue
        values = np.asarray(s.channels[name], dtype=np.float64)
        off = np.flatnonzero(np.abs(values) > limit)
        out += s.row_problems(
            s.sources.get(name, name),
            off,
            lambda i, v=values: f"{float(v[i])!r} at t = {float(t[i])!r} s",
            f"a {'latitude' if name == c.LAT_DEG else 'longitude'} in [-{limit:g}, {limit:g}] deg",
            fix="map the latitude and longitude channels the right way round, in degrees",
        )
    return out


# --------------------------------------------------------------------------- resampling


def grid_times(start_s: float, end_s: float, period_s: float = GRID_PERIOD_S) -> np.ndarray:
    """The grid rows within ``[start_s, end_s]``: every whole multiple of ``period_s``.

    Args:
        start_s: first time, s.
        end_s: last time, s.
        period_s: the grid period; ``1 / period_s`` must be an integer.

    Returns:
        float64 times ``k / (1 / period_s)`` (each the double nearest a whole tenth).
    """
    per_s = round(1.0 / period_s)
    k0, k1 = math.ceil(start_s * per_s - 1e-9), math.floor(end_s * per_s + 1e-9)
    return np.arange(k0, k1 + 1, dtype=np.float64) / per_s


def window_means(
    t_s: np.ndarray,
    values: np.ndarray | Sequence[np.ndarray],
    start_s: np.ndarray,
    end_s: np.ndarray,
    max_gap_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Time-weighted means of piecewise-linear signals over windows ``[start, end]``.

    Args:
        t_s: sample times (m,), strictly increasing, m >= 2.
        values: samples (c, m), or c arrays (m,): c signals sharing the time stamps.
        start_s: window starts (n,).
        end_s: window ends (n,), each after its start.
        max_gap_s: a window overlapping a step between samples longer than this is invalid.

    Returns:
        ``(means (c, n), valid (n,))``; the means of invalid windows are meaningless.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if isinstance(values, np.ndarray) and values.ndim == 1:
        values = [values]
    rows = [np.asarray(v, dtype=np.float64) for v in values]
    m = t.size
    dt = np.diff(t)
    # The window edges' places among the samples, once for every signal.
    j_start = np.clip(np.searchsorted(t, start_s, side="right") - 1, 0, m - 2)
    j_end = np.clip(np.searchsorted(t, end_s, side="right") - 1, 0, m - 2)
    u_start, u_end = start_s - t[j_start], end_s - t[j_end]
    means = np.empty((len(rows), np.size(start_s)))
    for i, v in enumerate(rows):  # per signal, not per sample: one signal's integral in memory
        # Cumulative trapezoid integral: F[j] = integral from t_0 to t_j.
        cum = np.zeros(m)
        np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, out=cum[1:])
        slope = np.diff(v) / dt
        f_start = cum[j_start] + u_start * (v[j_start] + 0.5 * slope[j_start] * u_start)
        f_end = cum[j_end] + u_end * (v[j_end] + 0.5 * slope[j_end] * u_end)
        means[i] = (f_end - f_start) / (end_s - start_s)
    # Steps overlapping [start, end]: from the one holding start to the one ending at/after end.
    j_last = np.clip(np.searchsorted(t, end_s, side="left") - 1, 0, m - 2)
    long_before = np.r_[0, np.cumsum(dt > max_gap_s)]
    valid = (
        (start_s >= t[0]) & (end_s <= t[-1]) & (long_before[j_last + 1] - long_before[j_start] == 0)
    )
    return means, valid


def interpolate_fixes(
    t_s: np.ndarray,
    fixes: Mapping[str, np.ndarray],
    at_s: np.ndarray,
    max_gap_s: float,
    path: TravelledPath | None = None,
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Interpolate GNSS fixes at given times, only between fixes at most ``max_gap_s`` apart.

    Args:
        t_s: fix times (m,), strictly increasing.
        fixes: canonical channel -> values (m,): ``lat_deg``, ``lon_deg`` and optionally
            ``n_sats``, ``h_acc_m``, ``speed_gnss_m_s``, ``heading_deg``, ``height_m``.
        at_s: the times wanted (n,).
        max_gap_s: fixes further apart than this are not interpolated between.
        path: the car's path as its sensors trace it (:func:`travelled_path`), or None.
            Given, a position between two fixes is placed along it (the module
            docstring, "Positions") wherever it covers both fixes and the car rolled
            at least :data:`MIN_PATH_RAD` between them; elsewhere, and for every other
            channel, linearly in time.

    Returns:
        ``(values, valid)``: each channel at ``at_s`` (longitude in [-180, 180), course in
        [0, 360), satellites and a stated accuracy a fix's own on it, and between two
        the smaller count and the larger accuracy), and whether a time lies
        between two such fixes or on a fix. Never extrapolated.
    """
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(at_s, dtype=np.float64)
    m = t.size
    j = np.searchsorted(t, x, side="right") - 1  # the fix at or before x
    at_fix = np.maximum(j, 0)
    on_fix = (j >= 0) & (x == t[at_fix])
    j = np.clip(j, 0, m - 2)
    span = t[j + 1] - t[j]
    valid = ((x >= t[0]) & (x <= t[-1]) & (span <= max_gap_s)) | on_fix
    w = np.clip((x - t[j]) / span, 0.0, 1.0)
    # Longitude and course unwrapped (the antimeridian and north are no jump), once.
    values_of = {
        name: np.unwrap(a, period=360.0) if name in (c.LON_DEG, c.HEADING_DEG) else a
        for name, a in ((k, np.asarray(v, dtype=np.float64)) for k, v in fixes.items())
    }
    along = None
    if path is not None and c.LAT_DEG in fixes and c.LON_DEG in fixes:
        lat, lon = values_of[c.LAT_DEG], values_of[c.LON_DEG]
        along = _along_path(path, t, lat, lon, x, j, valid & ~on_fix)
    out = {}
    for name, a in values_of.items():
        # a fix's own count and accuracy on it; between two, the worse (NaN if either is)
        if name == c.N_SATS:
            out[name] = np.where(on_fix, a[at_fix], np.minimum(a[j], a[j + 1]))
            continue
        if name == c.H_ACC_M:
            out[name] = np.where(on_fix, a[at_fix], np.maximum(a[j], a[j + 1]))
            continue
        value = a[j] + w * (a[j + 1] - a[j])
        if along is not None and name in (c.LAT_DEG, c.LON_DEG):
            value[along[0]] = along[1] if name == c.LAT_DEG else along[2]
        if name == c.LON_DEG:
            value = (value + 180.0) % 360.0 - 180.0
        elif name == c.HEADING_DEG:
            value = value % 360.0
        out[name] = value
    return out, valid


@dataclass(frozen=True)
class TravelledPath:
    """The car's path as its wheels (and gyro) trace it (:func:`travelled_path`).

    Attributes:
        t_s: the wheel samples' times (those with a value), s.
        rolled_rad: the rolled angle's cumulative trapezoid integral at them, rad.
        z: the path's complex point at them (east real, north imaginary), rad; real
            (the rolled angle) without a gyro.
        piece: the unbroken stretch of wheel samples each begins (steps longer than the
            gap limit break it).
    """

    t_s: np.ndarray
    rolled_rad: np.ndarray
    z: np.ndarray
    piece: np.ndarray

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(z, piece)`` at times ``x``: the point reached, linear between samples, and
        the stretch it lies in (-1 outside the samples)."""
        t, x = self.t_s, np.asarray(x, np.float64)
        if t.size < 2:
            return np.zeros(x.size, np.complex128), np.full(x.size, -1)
        i, u = self._locate(x)
        inside = (x >= t[0]) & (x <= t[-1])
        last = np.where(x == t[-1], self.piece[-1], self.piece[i])  # the end sample's own
        return self.z[i] + u * (self.z[i + 1] - self.z[i]), np.where(inside, last, -1)

    def _locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each time's sample interval ``i`` (clipped to the first and last) and its share
        ``u`` of the way to the next sample (held at 0 or 1 beyond the ends); 2+ samples."""
        t = self.t_s
        i = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
        return i, np.clip((x - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0)

    def sample(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(z, rolled)`` at times ``x``, both linear between samples from one search of
        the samples (held at the ends): the point reached, as :meth:`__call__` gives it,
        and the rolled angle's cumulative integral, whose differences :meth:`rolled`
        gives; for a caller that needs both at the same times (``fix_lag``)."""
        x = np.asarray(x, np.float64)
        if self.t_s.size < 2:
            return np.zeros(x.size, np.complex128), np.zeros(x.size)
        i, u = self._locate(x)
        z, cum = self.z, self.rolled_rad
        return z[i] + u * (z[i + 1] - z[i]), cum[i] + u * (cum[i + 1] - cum[i])

    def rolled(self, start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How far the wheels rolled between two times (rad; linear between samples, within
        ``a dt^2 / 8`` of :func:`window_means`' exact integral at 50-100 Hz), and whether
        the samples cover the interval: ``fix_times``' question."""
        t, cum = self.t_s, self.rolled_rad
        if t.size < 2:
            return np.zeros(np.shape(start)), np.zeros(np.shape(start), dtype=bool)
        angle = np.interp(end, t, cum) - np.interp(start, t, cum)
        return angle, (start >= t[0]) & (end <= t[-1])


def travelled_path(
    t_s: np.ndarray,
    wheel_rad_s: np.ndarray | Sequence[np.ndarray],
    max_gap_s: float = MAX_WHEEL_GAP_S,
    yaw_t_s: np.ndarray | None = None,
    yaw_rad_s: np.ndarray | None = None,
) -> TravelledPath:
    """The car's path as its wheels (and gyro) trace it, up to a rotation and a scale.

    Args:
        t_s: the wheel stream's times (strictly increasing), s.
        wheel_rad_s: one wheel's speed, or several (their mean's magnitude), rad/s;
            samples without a value are left out.
        max_gap_s: a step between wheel samples longer than this breaks the path.
        yaw_t_s: the gyro's times, or None (no gyro: a straight path).
        yaw_rad_s: its yaw rate (ISO 8855, positive turning left), rad/s.

    Returns:
        The path: called with times, ``(z, piece)``, the complex point (east real, north
        imaginary, in radians the wheels rolled) the car reached at each time, the
        rolled angle's cumulative trapezoid integral turned by the gyro's (``z = sum
        exp(i psi) ds`` over the wheel samples, ``psi`` the yaw rate's cumulative integral
        at them), and the stretch of unbroken wheel samples each time lies in (-1 outside
        them). Between two times of one stretch, ``z``'s difference is the car's
        displacement turned and scaled by constants: the gyro's heading offset, the tyre
        radius and a wheel scale error cancel in :func:`interpolate_fixes`' ratio. A gyro
        bias ``b`` does not: it bends the path between fixes ``T`` apart and ``L`` metres
        of chord by ``L b T / 8`` at most (2.6 cm for 12 m in a second at 1 deg/s; a
        straight path without a gyro misses a curve's arc by its sagitta,
        ``L^2 / (8 radius)``, 45 cm for 12 m on a 40 m radius).
    """
    omega = np.abs(np.mean(np.atleast_2d(np.asarray(wheel_rad_s, np.float64)), axis=0))
    ok = np.isfinite(omega)
    t, omega = np.asarray(t_s, np.float64)[ok], omega[ok]
    if t.size < 2:  # no path: every time outside it
        return TravelledPath(t, np.zeros(t.size), np.zeros(t.size, np.complex128), np.zeros(0))
    cum = cumulative_trapezoid(omega, t)
    z = cum  # without a gyro, a straight line: the rolled angle itself (real)
    if yaw_t_s is not None and yaw_rad_s is not None:
        ty, r = np.asarray(yaw_t_s, np.float64), np.asarray(yaw_rad_s, np.float64)
        good = np.isfinite(ty) & np.isfinite(r)
        psi = np.interp(t, ty[good], cumulative_trapezoid(r[good], ty[good]))
        step = np.diff(cum) * np.exp(0.5j * (psi[1:] + psi[:-1]))
        z = np.concatenate([[0.0], np.cumsum(step)])
    piece = np.concatenate([[0], np.cumsum(np.diff(t) > max_gap_s)])
    return TravelledPath(t, cum, z, piece)


def _along_path(
    path: TravelledPath,
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    x: np.ndarray,
    j: np.ndarray,
    between: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Latitude and longitude (unwrapped) placed along the path between fixes ``j`` and
    ``j + 1``, where the path can tell.

    A time is placed where it lies between two fixes of one unbroken stretch of the path
    and the wheels rolled at least :data:`MIN_PATH_RAD` between them. The chord between
    the two fixes, in a local plane where a degree of longitude and one of latitude are
    the same metres (east scaled by ``cos(lat) N / M``, the WGS84 normal and meridional
    radii: ``(1 - e^2 sin^2 lat) / (1 - e^2)``), so that turning it is a rotation, is
    turned and scaled by the complex ratio ``(z(x) - z(t_j)) / (z(t_j+1) - z(t_j))``.

    Args:
        path: the path.
        t: fix times (m,); lat, lon: the fixes, longitude unwrapped.
        x: the times wanted (n,); j: the fix at or before each; between: the times
            between two fixes close enough to interpolate across.

    Returns:
        ``(rows, lat, lon)`` for the rows of ``x`` placed, or None when none is.
    """
    k = np.flatnonzero(between)
    if not k.size:
        return None
    zx, px = path(x[k])
    zf, pf = path(t)  # every fix once
    a, b = j[k], j[k] + 1
    d = zf[b] - zf[a]
    ok = (pf[a] >= 0) & (pf[a] == pf[b]) & (px == pf[a]) & (np.abs(d) >= MIN_PATH_RAD)
    if not ok.any():
        return None
    k, a, b = k[ok], a[ok], b[ok]
    q = (zx[ok] - zf[a]) / d[ok]
    mid = np.radians(0.5 * (lat[a] + lat[b]))
    e2 = wgs84().es
    scale = np.cos(mid) * (1.0 - e2 * np.sin(mid) ** 2) / (1.0 - e2)
    offset = q * ((lon[b] - lon[a]) * scale + 1j * (lat[b] - lat[a]))
    return k, lat[a] + offset.imag, lon[a] + offset.real / scale


def default_fix_gap_s(t_s: np.ndarray) -> float:
    """The default ``max_fix_gap_s`` of a GNSS stream: 1.5 x its median interval, >= 0.25 s."""
    step = np.diff(np.asarray(t_s, dtype=np.float64))
    return max(FIX_GAP_FACTOR * float(np.median(step)), MIN_FIX_GAP_S) if step.size else 0.0


def resample(
    streams: DriveStreams,
    period_s: float = GRID_PERIOD_S,
    max_wheel_gap_s: float = MAX_WHEEL_GAP_S,
    max_fix_gap_s: float | None = None,
    split_gap_s: float = SPLIT_GAP_S,
    nominal_radius_m: float | None = None,
    glitch_g: float = WHEEL_GLITCH_G,
    require_fix: bool = True,
    gnss_lag: str | float = "report",
) -> Resampled:
    """Put a drive's streams on the pipeline's grid (the method: see the module docstring).

    Args:
        streams: the drive's streams (checked with :func:`check_streams`).
        period_s: the grid period (``validate.sample_period_s``).
        max_wheel_gap_s: longest step between samples of a rate that a row may span.
        max_fix_gap_s: longest interval between two fixes interpolated across (None:
            :func:`default_fix_gap_s` of the GNSS stream).
        split_gap_s: holes in the grid are made longer than this (``validate.gnss.max_gap_s``).
        nominal_radius_m: the car's nominal tyre radius, for the sample-level glitch screen
            of streams carrying all four wheels (None: not screened here).
        glitch_g: the glitch bound (:data:`rwhonet.data.glitches.WHEEL_GLITCH_G`).
        require_fix: a row needs a position (the pipeline: validate's schema wants one in
            every row, and cuts the hole as a gap). False (``rwhonet predict``): a row with
            the four wheel speeds but no fix is kept, its latitude and longitude NaN, as a
            10 Hz file with empty fix cells is read, so an outage can be driven through.
        gnss_lag: the fixes against the wheels' clock (``data.gnss_lag``,
            :func:`rwhonet.data.fixlag.fix_lag`): ``"report"`` estimates the lag and says
            it in the notes, ``"auto"`` also moves the fixes where the estimate is clear,
            a number moves them by that many seconds (``t - lag``).

    Returns:
        The canonical drive on the grid and the glitched rows.

    Raises:
        InputError: the streams' problems (:func:`check_streams`), streams that share
            no stretch of time, a wheel stream too slow for the grid, or no row left.
    """
    check_streams(streams)
    half = 0.5 * period_s
    required = (*streams.wheels, streams.gnss)
    notes = list(streams.notes)
    lost: list[str] = list(streams.changed)  # the notes predict says too
    fix_gap = default_fix_gap_s(streams.gnss.t_s) if max_fix_gap_s is None else max_fix_gap_s
    gnss_t, gnss, _ = _finite_rows(streams.gnss, notes, True)
    gnss_t, gnss = _real_fixes(streams.gnss, gnss_t, gnss, lost)
    path = _travelled_path(streams, max_wheel_gap_s)
    raw_t, where = gnss_t, streams.gnss.where()
    timing = fix_times(raw_t, gnss[c.LAT_DEG], gnss[c.LON_DEG], path.rolled, where)
    stamped = timing.t_s
    gnss_t, lag_note, moved, two_clocks = lagged_times(
        stamped, gnss[c.LAT_DEG], gnss[c.LON_DEG], path, gnss_lag, where
    )
    shift = float(np.median(gnss_t - stamped)) if moved and gnss_t.size else 0.0
    if two_clocks:  # the fix times placed again, on the wheels'
        timing = fix_times(raw_t + shift, gnss[c.LAT_DEG], gnss[c.LON_DEG], path.rolled, where)
        gnss_t = timing.t_s
    if timing.note:  # fixes moved: said by predict too, as what the grid changes
        (lost if timing.at_epochs else notes).append(timing.note)
    if lag_note:
        (lost if moved else notes).append(lag_note)
    # the fixes' stream where the lag moved it (seconds, for two clocks): the grid spans
    # what the wheels and the moved fixes both cover
    spans = {
        s.where(): (float(s.t_s[0]), float(s.t_s[-1]))
        if s is not streams.gnss
        else (float(s.t_s[0]) + shift, float(s.t_s[-1]) + shift)
        for s in required
    }
    start = max(first for first, _ in spans.values())
    end = min(last for _, last in spans.values())
    if not end - start >= period_s:
        shown = "; ".join(f"{w} {a:.6g}-{b:.6g} s" for w, (a, b) in spans.items())
        raise InputError(
            [
                Problem(
                    streams.gnss.where(),
                    None,
                    "time",
                    "wheel-speed and GNSS streams that overlap in time (one clock)",
                    f"no common stretch: {shown}",
                    "stamp every stream on one clock (or give the offset between them)",
                )
            ]
        )
    grid = grid_times(start, end, period_s)
    lo, hi = grid - half, grid + half
    keep = np.ones(grid.size, dtype=bool)
    columns: dict[str, np.ndarray] = {c.T_S: grid}
    sources: dict[str, str] = {c.T_S: f"grid of {period_s:g} s on {streams.clock}"}
    glitch = np.zeros(grid.size, dtype=bool)
    by_wheel = {w: np.zeros(grid.size, dtype=bool) for w in c.WHEELS}
    glitch_samples: list[tuple[str, int, float, str]] = []
    beyond = [
        f"{w} {a:.6g}-{b:.6g} s"
        for w, (a, b) in spans.items()
        if start - a > SPAN_NOTE_S or b - end > SPAN_NOTE_S
    ]
    if beyond:
        lost.append(
            f"the drive is cut to {start:.6g}-{end:.6g} s, where the wheel speeds and the "
            f"fixes all have samples; beyond it: {'; '.join(beyond)}"
        )

    fixes, fix_ok = interpolate_fixes(
        gnss_t,
        {k: v for k, v in gnss.items() if k in c.FIX_CHANNELS},
        grid,
        fix_gap,
        path,
    )
    if require_fix:
        keep &= fix_ok
    for name, values in fixes.items():  # NaN where no fix (rows the pipeline leaves out)
        columns[name] = np.where(fix_ok, values, np.nan)
        sources[name] = streams.gnss.label(name)

    n_wheel_streams = len(streams.wheels)
    slow: list[Problem] = []
    for i, s in enumerate((*streams.wheels, *streams.extra)):
        t, chans, kept = _finite_rows(s, notes, required=i < n_wheel_streams)
        if i < n_wheel_streams:
            slow += _slow_stream(s, t, max_wheel_gap_s, period_s)
        names = [n for n in RATE_CHANNELS if n in chans]
        if not names or t.size < 2:  # an optional stream without values: its channels stay out
            continue
        if i >= n_wheel_streams:  # a gyro on another clock would drop out without a word
            _on_the_clock(s, t, float(grid[0]), float(grid[-1]), required, period_s)
        means, ok = window_means(t, [chans[n] for n in names], lo, hi, max_wheel_gap_s)
        wheel_stream = any(n in c.WHEELS for n in names)
        if wheel_stream:
            keep &= ok
        if not wheel_stream and not ok.any():  # overlapping, but no row spans short steps
            slow += _slow_stream(s, t, max_wheel_gap_s, period_s, always=True)
        for name, row in zip(names, means, strict=True):
            columns[name] = row if wheel_stream else np.where(ok, row, np.nan)
            sources[name] = s.label(name)
        if nominal_radius_m is not None and all(w in chans for w in c.WHEELS):
            bad = glitch_mask(t, [chans[w] for w in c.WHEELS], nominal_radius_m, glitch_g)
            rows = np.flatnonzero(bad.any(axis=0))
            if rows.size:
                glitch |= _rows_using(t, rows, grid, half)
                for k, w in enumerate(c.WHEELS):
                    if bad[k].any():
                        by_wheel[w] |= _rows_using(t, np.flatnonzero(bad[k]), grid, half)
                glitch_samples += [
                    (where, r, float(t[i]), c.WHEELS[int(np.argmax(bad[:, i]))])
                    for i, (where, r) in zip(rows, s.places(kept[rows]), strict=True)
                ]

    if slow:
        raise InputError(slow, summary="streams too sparse for the grid")
    keep = _widen_holes(keep, split_gap_s, period_s)
    if not keep.any():
        raise InputError(
            [
                Problem(
                    ", ".join(s.where() for s in required),
                    None,
                    None,
                    "grid rows with the four wheel speeds and a GNSS fix (rates: no step "
                    f"between samples longer than {max_wheel_gap_s:g} s over a row; fixes: at "
                    f"most {fix_gap:.3g} s apart around it)",
                    f"none of the {grid.size} rows of {start:.6g}-{end:.6g} s",
                    "export the wheel speeds and the fixes of the same stretch of the drive, "
                    "each at its logger's rate",
                )
            ],
            summary="no grid row to keep",
        )
    dropped = int((~keep).sum())
    if dropped:
        notes.append(
            f"{dropped} of {grid.size} grid rows left out (no wheel speeds "
            + ("or no fix " if require_fix else "")
            + f"within the gap limits: wheels {max_wheel_gap_s:g} s, fixes {fix_gap:.3g} s), "
            "so that validate cuts those seconds as gaps"
        )
    unfixed = int((keep & ~fix_ok).sum())
    if unfixed:
        lost.append(
            f"{streams.gnss.where()}: {unfixed} of {int(keep.sum())} grid rows have the wheel "
            f"speeds but no fix (no two fixes at most {fix_gap:.3g} s apart around them): kept "
            "without a position"
        )
    order = [n for n in (*c.REQUIRED, *c.OPTIONAL) if n in columns]
    drive = RawDrive(
        columns={n: np.ascontiguousarray(columns[n][keep]) for n in order},
        source_columns={n: sources[n] for n in order},
        header_match="streams",
        notes=(*notes, *lost),
    )
    return Resampled(
        drive,
        glitch[keep],
        glitch_samples,
        streams.n_input_rows,
        {w: rows[keep] for w, rows in by_wheel.items()},
        tuple(lost),
    )


def _travelled_path(streams: DriveStreams, max_gap_s: float) -> TravelledPath:
    """:func:`travelled_path` of the first wheel stream's wheels, turned by the drive's
    gyro where a stream carries a yaw rate with two samples or more."""
    s = streams.wheels[0]
    yaw = [
        r
        for r in (*streams.wheels, *streams.extra)
        if c.YAW_RATE_RAD_S in r.channels
        and np.isfinite(np.asarray(r.channels[c.YAW_RATE_RAD_S], np.float64)).sum() >= 2
    ]
    return travelled_path(
        s.t_s,
        [s.channels[w] for w in c.WHEELS if w in s.channels],
        max_gap_s,
        yaw[0].t_s if yaw else None,
        yaw[0].channels[c.YAW_RATE_RAD_S] if yaw else None,
    )


def _finite_rows(
    s: Stream, notes: list[str], required: bool = False
) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """A stream's samples whose every channel has a value (a NaN fix is no fix): their
    times, values, and positions in the stream (0-based, for the source's rows).

    Raises:
        InputError: a ``required`` stream (wheel speeds, fixes) has fewer than two such samples.
    """
    t = np.asarray(s.t_s, dtype=np.float64)
    chans = {k: np.asarray(v, dtype=np.float64) for k, v in s.channels.items()}
    if not chans:
        return t, chans, np.arange(t.size)
    ok = np.logical_and.reduce([np.isfinite(v) for v in chans.values()])
    if ok.all():
        return t, chans, np.arange(t.size)
    if required and ok.sum() < 2:
        blank = {k: int((~np.isfinite(v)).sum()) for k, v in chans.items()}
        named = [s.sources.get(k, k) for k, n in blank.items() if n]
        raise InputError(
            [
                Problem(
                    s.where(),
                    None,
                    ", ".join(named),
                    "samples with a value in every channel",
                    f"{int(ok.sum())} of {ok.size}; blank or NaN cells: "
                    + ", ".join(f"{s.sources.get(k, k)!r} in {n}" for k, n in blank.items() if n),
                    "export the stream's values (empty or NaN cells are no samples); a file "
                    "that holds several messages, each row one message's samples, needs each "
                    "message's columns filled in the same rows, or one file per message",
                )
            ]
        )
    notes.append(f"{s.where()}: {int((~ok).sum())} sample(s) without a value left out")
    return t[ok], {k: v[ok] for k, v in chans.items()}, np.flatnonzero(ok)


def _on_the_clock(
    s: Stream,
    t: np.ndarray,
    start_s: float,
    end_s: float,
    required: Sequence[Stream],
    period_s: float,
) -> None:
    """Refuse an optional stream that shares no stretch of time with the grid.

    All streams of a drive share one clock; a gyro stamped in ms while the others are in
    s, or an MDF4 group on another time base, lies wholly beside the wheel speeds and
    fixes, and its channel would be NaN in every row. One that covers part of the drive
    (started late, stopped early) is kept: its rows outside it are NaN.

    Raises:
        InputError: naming the stream, its time column, and both spans.
    """
    if min(float(t[-1]), end_s) - max(float(t[0]), start_s) >= period_s:
        return
    time = s.sources.get(c.T_S, "time")
    spans = "; ".join(
        f"{r.where()} {float(r.t_s[0]):.6g}-{float(r.t_s[-1]):.6g} s" for r in required
    )
    raise InputError(
        [
            Problem(
                s.where(),
                None,
                time,
                "every stream on the drive's one clock, overlapping the wheel speeds and "
                f"fixes ({start_s:.6g}-{end_s:.6g} s on the grid)",
                f"no common stretch: {s.where()} {float(t[0]):.6g}-{float(t[-1]):.6g} s; {spans}",
                "stamp every stream on one clock (the same unit and origin as the wheel "
                "speeds' time), or leave this stream out of the drive",
            )
        ],
        summary=f"{s.where()} is on another clock than the wheel speeds and fixes",
    )


def _slow_stream(
    s: Stream, t: np.ndarray, max_gap_s: float, period_s: float, always: bool = False
) -> list[Problem]:
    """A rate stream most of whose steps no grid row may span (:data:`SLOW_STREAM_SHARE`).

    A stream with dropouts has a few long steps among short ones, and the rows over them
    are left out as gaps; a stream logged too slowly (or stamped in another unit than
    declared) has them everywhere, and would leave an empty or nearly empty grid (wheel
    speeds) or a channel without a value (an optional rate). ``always``: the problem,
    whatever the share (a stream that gave no row a value).
    """
    step = np.diff(t)
    long = int((step > max_gap_s).sum())
    if not step.size or (long <= SLOW_STREAM_SHARE * step.size and not always):
        return []
    lo, mid, hi = (float(x) for x in np.percentile(step, [5, 50, 95]))
    steps = f"{lo:.3g} s" if f"{lo:.3g}" == f"{hi:.3g}" else f"{lo:.3g}-{hi:.3g} s"
    rates = [n for n in RATE_CHANNELS if n in s.channels]
    what = "wheel speeds" if any(n in c.WHEELS for n in rates) else "rates"
    time = s.sources.get(c.T_S, "time")
    return [
        Problem(
            s.where(),
            None,
            ", ".join(s.sources.get(n, n) for n in rates),
            f"{what} sampled at {1.0 / period_s:g} Hz or faster: steps between samples "
            f"of at most {max_gap_s:g} s (max_wheel_gap_s), the longest a {period_s:g} s grid "
            "row may span",
            f"{long} of {step.size} steps longer: steps of {steps} (median {mid:.3g} s, "
            f"about {1.0 / mid:.3g} Hz)",
            f"log the {what} at 10 Hz or faster (CAN wheel-speed messages come at "
            f"50-100 Hz); if the logger did, check the unit of the time {time!r} (a time in "
            "ms read as s makes every step 1000 times longer)",
        )
    ]


def _real_fixes(
    s: Stream, t: np.ndarray, fixes: dict[str, np.ndarray], notes: list[str]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The fixes less those at latitude = longitude = 0 (a receiver without a fix writes
    zeros: :func:`rwhonet.data.fixes.no_fix_rows`), which are no fix, said in a note.

    Raises:
        InputError: fewer than two fixes are left.
    """
    zero = no_fix_rows(fixes[c.LAT_DEG], fixes[c.LON_DEG])
    if not zero.any():
        return t, fixes
    if (~zero).sum() < 2:
        lat, lon = (s.sources.get(k, k) for k in (c.LAT_DEG, c.LON_DEG))
        raise InputError(
            [
                Problem(
                    s.where(),
                    None,
                    f"{lat} / {lon}",
                    "GNSS fixes (latitude = longitude = 0 is a receiver without a fix)",
                    f"{int((~zero).sum())} of {zero.size} samples not at (0, 0)",
                    "export the drive's fixes (a log from before the receiver had a fix has none)",
                )
            ]
        )
    notes.append(
        f"{s.where()}: {int(zero.sum())} fix(es) at latitude = longitude = 0 left out (a "
        "receiver without a fix writes zeros): no position there"
    )
    return t[~zero], {k: v[~zero] for k, v in fixes.items()}


def _rows_using(t: np.ndarray, rows: np.ndarray, grid: np.ndarray, half: float) -> np.ndarray:
    """Grid rows whose window overlaps the steps next to given samples (their means use them)."""
    before = t[np.maximum(rows - 1, 0)]
    after = t[np.minimum(rows + 1, t.size - 1)]
    first = np.searchsorted(grid, before - half, side="right")
    stop = np.searchsorted(grid, after + half, side="left")
    marks = np.zeros(grid.size + 1, dtype=np.int64)
    np.add.at(marks, first, 1)
    np.add.at(marks, stop, -1)
    return np.cumsum(marks[:-1]) > 0


def _widen_holes(keep: np.ndarray, split_gap_s: float, period_s: float) -> np.ndarray:
    """Leave out rows next to each hole until every hole in the grid exceeds ``split_gap_s``.

    A hole of ``k`` rows makes a step of ``(k + 1) period``; a step longer than one period
    but not longer than ``split_gap_s`` would be neither a sample step nor a gap for
    validate. Widening every hole by ``d`` rows on each side makes it at least
    ``1 + 2 d`` rows long.
    """
    need = math.floor(split_gap_s / period_s + 1e-9)  # rows a hole needs
    d = max(math.ceil((need - 1) / 2), 0)
    if d == 0 or keep.all():
        return keep
    # a row is left out where any row within d of it is a hole (the ends held: a hole there
    # is within d of every row whose window passes the end)
    return running_max((~keep).astype(np.float64), 2 * d + 1) == 0
