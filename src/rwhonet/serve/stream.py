"""Corrected odometry second by second: 10 Hz rows in, one output row per whole second out.

:class:`SecondStream` takes a drive's rows as they arrive
(:func:`rwhonet.data.incremental.read_rows`) and emits every second as soon as its
ten rows are in. A second is cut as the label stage cuts it
(:mod:`rwhonet.features.seconds`): from the fix at a whole second of the
drive's clock (the last row at or before it) to the fix ten rows later; a
time gap longer than ``max_gap_s`` ends a run of seconds, and the next run
starts at the next whole second. A row beside a dropped sample whose stamp leans toward
it (:func:`rwhonet.data.timebase.leans_into_drop`, the label's ``drop_edge`` rule) is no
fix a second starts or ends on: a second that would end on such a row before the next
row is in is held until it comes (or :meth:`SecondStream.finish`). Per second:

- ``disp_wpm_m``: the WPM displacement with the source calibration's radii
  (paper Eqs. 6-10, :mod:`rwhonet.features.wpm`);
- ``pred_error_m``: the model's predicted error of that WPM (the label, GNSS − WPM);
- ``disp_corrected_m``: their sum;
- ``disp_gnss_m``: the GNSS displacement where both fixes exist (else empty).

During each outage (``--outage START:END``, seconds since the drive's first
row; a second belongs to it when its end lies in ``(START, END]``) also the
cumulative distances ``dist_wpm_m``, ``dist_corrected_m``, ``dist_gnss_m``
and, where GNSS exists, the cumulative signed errors ``err_*_m`` (WPM or
corrected minus GNSS: CTE is the last one's absolute value) and ``crse_*_m``
(Σ|error| per second: the paper's CRSE); and where the car is: ``east_m``,
``north_m`` (the navigation filter's position at the end of the second, metres
east and north of the last GNSS fix before the outage, or of the filter's own
position there when that fix is missing, in the local frame there), the same
position as WGS-84 ``lat_deg``, ``lon_deg``, its
covariance ``cov_ee_m2``, ``cov_en_m2``, ``cov_nn_m2`` (the filter's own), ``r68_m``
and ``r95_m``, the major semi-axes of the ellipses that hold 68.27 % and 95.45 % of
such positions (calibrated as the evaluation calibrated the filter on the model's
car, when the model carries it: :class:`rwhonet.serve.navigation.PositionCalibration`;
else the filter's own normal), and ``pos_err_m``, its
horizontal distance to the GNSS fix where the file has one
(:mod:`rwhonet.serve.navigation`: the filter runs on the whole stream, the
outage's fixes withheld from it). Nothing here
imports torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from rwhonet.contracts import ROWS_PER_SECOND
from rwhonet.data import canonical as c
from rwhonet.data.droprows import FILE_ROW, RowFilter
from rwhonet.data.glitches import (
    WHEEL_GLITCH_G,
    YAW_GLITCH_SHARE,
    glitch_mask,
    repaired_yaw_rate,
    yaw_rate_glitches,
)
from rwhonet.data.timebase import STAMP_LEAN, TIME_EPS_S, lean_limit_s
from rwhonet.errors import InputError, Problem
from rwhonet.features.seconds import (
    backwards_per_second,
    end_of_second,
    gnss_displacement_m,
    gyro_yaw_rad,
    integrate_per_second,
    span_s,
    wheel_features_rad_s,
)
from rwhonet.features.wpm import wheel_angle_rad, wpm_displacement_m
from rwhonet.geo.local import offsets_m
from rwhonet.nav import SIGMA_CONTENT, NavConfig, WheelSpec
from rwhonet.serve.model import ServedModel
from rwhonet.serve.navigation import PositionCalibration, StreamNavigator

if TYPE_CHECKING:  # built by rwhonet.cli.predict (data checks stay out of this import)
    from rwhonet.data.drivechecks import StreamRadiusCheck

# A logger's gap of rows is bridged by the navigation filter up to this span (from the
# last whole second before it to the first after it; StreamNavigator.bridge), s: the
# dropouts of a CAN logger (a bus-off recovery, a storage stall) are a few seconds; over a
# longer one the line drawn across it says little of where the car turned.
BRIDGE_MAX_S = 10.0
SPAN_TOLERANCE_S = 0.5  # ten rows span 1 s +/- this (rwhonet.features.seconds.SPAN_TOLERANCE_S)
COLUMNS = (
    "t_s",
    "elapsed_s",
    "disp_wpm_m",
    "pred_error_m",
    "disp_corrected_m",
    "disp_gnss_m",
    "outage",
    "dist_wpm_m",
    "dist_corrected_m",
    "dist_gnss_m",
    "err_wpm_m",
    "err_corrected_m",
    "crse_wpm_m",
    "crse_corrected_m",
    "east_m",
    "north_m",
    "lat_deg",
    "lon_deg",
    "cov_ee_m2",
    "cov_en_m2",
    "cov_nn_m2",
    "r68_m",
    "r95_m",
    "pos_err_m",
)
OUTAGE_COLUMNS = COLUMNS[7:]
CUMULATIVE_COLUMNS = OUTAGE_COLUMNS[:7]  # the running sums over an outage's seconds
POSITION_COLUMNS = COLUMNS[COLUMNS.index("east_m") :]


@dataclass(frozen=True)
class Outage:
    """A GNSS outage to report on: seconds ``(start_s, end_s]`` after the drive's first row."""

    start_s: float
    end_s: float

    @property
    def label(self) -> str:
        return f"{self.start_s:g}:{self.end_s:g}"


def parse_outage(text: str) -> Outage:
    """``"300:480"`` -> :class:`Outage`.

    Raises:
        InputError: not two numbers ``START:END`` with ``END > START >= 0``.
    """
    start, sep, end = text.partition(":")
    try:
        outage = Outage(float(start), float(end)) if sep else None
    except ValueError:
        outage = None
    if outage is None or not (0 <= outage.start_s < outage.end_s) or math.isinf(outage.end_s):
        raise InputError(
            [
                Problem(
                    "--outage",
                    None,
                    None,
                    "START:END in seconds since the drive's first row, "
                    "0 <= START < END (e.g. 300:480)",
                    repr(text),
                )
            ],
            "bad --outage",
        )
    return outage


@dataclass
class _Totals:
    """Running sums of one outage."""

    n: int = 0
    # each cumulative column's value at the last second so far
    sums: dict[str, float] = field(default_factory=lambda: dict.fromkeys(CUMULATIVE_COLUMNS, 0.0))
    gnss_s: int = 0  # seconds with a GNSS displacement
    gyro_s: int = 0  # seconds with the gyro's yaw (the filter's yaw fused, not wheels alone)
    origin: tuple[float, float] | None = None  # the position the outage starts from
    east: float = math.nan  # the filter's position at the last second so far
    north: float = math.nan
    lat: float = math.nan  # ... as WGS-84 coordinates
    lon: float = math.nan
    pos_err: float = math.nan  # ... its distance to the GNSS fix there (NaN: none)
    pos_sd: float = math.nan  # ... the major semi-axis of its 1-sigma ellipse
    r68: float = math.nan  # ... of its 68.27 % and 95.45 % regions (PositionCalibration)
    r95: float = math.nan


@dataclass
class SecondStream:
    """Turn row blocks into per-second output blocks (see the module docstring).

    Args:
        model: the served model.
        outages: the outages to report on (not overlapping).
        file: the drive's name, for error reports.
        names: canonical name -> the file's column name, for error reports.
        max_gap_s: a time step longer than this ends a run of seconds
            (``validate.gnss.max_gap_s``).
        period_s, period_tol_s: the sample period and its tolerance
            (``validate.sample_period_s``, ``validate.sample_period_tol_s``): a step
            longer than their sum skips a slot of the grid (a dropped sample), which
            cuts its second and ends the run too.
        nav: the navigation filter's settings (default: the generic
            :class:`rwhonet.nav.NavConfig` with the model's rear radius, ``track_rear_m``
            and the receiver drift the model's evaluation fitted, if it carries one).
        unit_check: validate's wheel-unit check, fed the rows as they come (after the
            wheels' glitch repair, before the yaw rate's, which it makes itself as
            validate does); it refuses the drive from the block where it can decide
            (:class:`rwhonet.data.drivechecks.StreamRadiusCheck`). None: not checked.
        track_rear_m: the car's rear track, m, for the default ``nav`` (the wheels' yaw
            is their travel difference over it); None: the filter's default.
    """

    model: ServedModel
    outages: list[Outage] = field(default_factory=list)
    file: str = "<stdin>"
    names: dict[str, str] = field(default_factory=dict)
    max_gap_s: float = 0.5
    period_s: float = 0.1
    period_tol_s: float = 0.05
    nav: NavConfig | None = None
    unit_check: StreamRadiusCheck | None = None
    track_rear_m: float | None = None
    calibration: PositionCalibration = field(default_factory=PositionCalibration)
    _keys: tuple[str, ...] = c.REQUIRED  # the channels kept: the yaw rate too, if there
    _gyro_seen: bool = False  # a yaw rate with a value has come
    _navigator: StreamNavigator | None = None
    _rows: dict[str, np.ndarray] | None = None  # rows from the current anchor on
    dropped: RowFilter = field(default_factory=RowFilter)  # copies, rows without wheels
    _anchored: bool = False
    _t0: float | None = None
    _history: np.ndarray | None = None  # the run's last seq_len - 1 feature rows (padded)
    # the rows from the last second's end to a gap, until the next run's first second
    _across: dict[str, np.ndarray] | None = None
    _gap: dict[str, float | bool] = field(default_factory=dict)  # the split _across ends at
    _fix_skips_slot: bool = False  # the run's start fix is the row before a dropped slot
    _final: bool = False  # the drive has ended (finish): no second is held for the next row
    gaps: list[dict[str, float | bool]] = field(default_factory=list)  # gaps met (_bridge)
    totals: dict[str, _Totals] = field(default_factory=dict)
    glitches: list[dict[str, float | int | str]] = field(default_factory=list)
    _yaw_counts: list[int] = field(default_factory=lambda: [0, 0])  # samples, beyond the limit
    backwards_s: list[float] = field(default_factory=list)  # told seconds' ends, elapsed_s

    def __post_init__(self) -> None:
        spans = sorted((o.start_s, o.end_s) for o in self.outages)
        for (_, end), (start, _) in zip(spans, spans[1:], strict=False):
            if start < end:
                raise InputError(
                    [Problem("--outage", None, None, "outages that do not overlap", f"{spans}")],
                    "bad --outage",
                )
        self.totals = {o.label: _Totals() for o in self.outages}
        radii = tuple(self.model.meta.source_radii)
        self.calibration = PositionCalibration.from_meta(self.model.meta.navigation)
        if self.nav is None:
            track = {} if self.track_rear_m is None else {"track_rear_m": float(self.track_rear_m)}
            wheels = WheelSpec(radius_m=float(np.mean(radii)), **track)
            self.nav = self.calibration.nav_config(NavConfig(wheels=wheels))

    @property
    def control(self) -> str:
        """The navigation filter's yaw so far: ``fused`` (gyro and wheels), or ``wheels``
        alone (no yaw-rate column, or none with a value: the filter cannot fuse a gyro it
        never had)."""
        return "fused" if self._gyro_seen else "wheels"

    def push(self, first_row: int, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Add rows (data rows ``first_row ..``); return the seconds they complete (maybe none).

        A row that repeats an earlier row in every channel (a sample written again), and
        a row with an empty wheel speed (a lost sample), are dropped, as ingest drops them
        (:class:`rwhonet.data.droprows.RowFilter`, which lists them in ``dropped``); every
        message still names the file's rows.
        """
        parts = [self._push(f, cols) for f, cols in self.dropped.blocks([(first_row, columns)])]
        if len(parts) == 1:
            return parts[0]
        parts = [p for p in parts if len(p["t_s"])]
        if not parts:
            return empty_block()
        return {name: np.concatenate([p[name] for p in parts]) for name in COLUMNS}

    def _push(self, first_row: int, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Add rows that are consecutive rows of the file; return the seconds they complete."""
        self._check(first_row, columns)
        raw, columns = columns, self._repair_glitches(first_row, columns)
        if self.unit_check is not None:
            self.unit_check.push(columns, raw, first_row)
        columns = self._repair_yaw(first_row, columns)
        # each row's data row in the file, carried with the rows (the messages' rows)
        n = len(columns[c.T_S])
        columns = dict(columns) | {FILE_ROW: first_row + np.arange(n, dtype=np.float64)}
        if self._rows is None:
            self._keys = (
                *c.REQUIRED,
                *(k for k in (c.YAW_RATE_RAD_S, STAMP_LEAN) if k in columns),
                FILE_ROW,
            )
            self._navigator = StreamNavigator(
                self.nav,
                tuple(self.model.meta.source_radii),
                c.YAW_RATE_RAD_S in self._keys,
                self.calibration,
            )
            self._rows = {k: columns[k] for k in self._keys}
            self._t0 = float(columns[c.T_S][0])
        else:
            self._rows = {k: np.concatenate([self._rows[k], columns[k]]) for k in self._keys}
        if not self._gyro_seen and c.YAW_RATE_RAD_S in self._keys:
            self._gyro_seen = bool(np.isfinite(columns[c.YAW_RATE_RAD_S]).any())
        return self._emit()

    def finish(self) -> dict[str, np.ndarray]:
        """The drive has ended: the seconds held for the row after their end fix (which
        leans toward the next slot; :func:`rwhonet.data.timebase.leans_into_drop`), which
        no dropped sample follows now."""
        self._final = True
        if self._rows is None:
            return empty_block()
        return self._emit()

    def _leans(self, i: int, later: bool) -> bool:
        """Whether row ``i`` of the rows in hand is stamped more than
        :func:`rwhonet.data.timebase.lean_limit_s` after its placed time (``later``) or
        before it."""
        if STAMP_LEAN not in self._keys:
            return False
        lean = float(self._rows[STAMP_LEAN][i])
        limit = lean_limit_s(self.period_s)
        return lean > limit if later else lean < -limit

    def _leans_across_end(self) -> bool:
        """Whether the last row before the split (``self._across``'s) is stamped more than
        :func:`rwhonet.data.timebase.lean_limit_s` after its placed time."""
        if self._across is None or STAMP_LEAN not in self._across:
            return False
        return float(self._across[STAMP_LEAN][-1]) > lean_limit_s(self.period_s)

    def _emit(self) -> dict[str, np.ndarray]:
        """The seconds the rows in hand complete (the rows before them dropped)."""
        parts = []
        while True:
            t = self._rows[c.T_S]
            if not self._anchored:
                after_drop = self._across is not None and bool(self._gap["dropped"])
                if (
                    after_drop
                    and _first_slot(float(t[0]), self.period_s)
                    # the row before the drop, stamped toward it, is no start fix
                    and not self._leans_across_end()
                ):
                    # A sample dropped just before this second's first slot: the second
                    # is whole, and its start fix is the last row before the drop (the
                    # label stage's start fix: the last row of the cut second before it).
                    before = {k: v[-1:] for k, v in self._across.items()}
                    self._across = {k: v[:-1] for k, v in self._across.items()}
                    self._rows = {k: np.concatenate([before[k], self._rows[k]]) for k in self._keys}
                    self._bridge({k: v[:1] for k, v in self._rows.items()})
                    self._anchored, self._history = True, None
                    self._fix_skips_slot = True  # the step from that fix skips the slot
                    continue
                whole = math.ceil(t[0])
                later = np.flatnonzero(t > whole)
                if len(later) and later[0] == 1 and after_drop and self._leans(0, later=False):
                    # the start fix, the first row after the drop, stamped toward it: the
                    # run starts a second later
                    later = np.flatnonzero(t > whole + 1)
                if not len(later):
                    break  # the anchor is not in yet
                anchor = int(later[0]) - 1
                if self._across is not None:  # a gap behind: the filter across it
                    self._bridge({k: v[: anchor + 1] for k, v in self._rows.items()})
                self._drop(anchor)
                self._anchored, self._history = True, None
                continue
            steps = np.diff(t)
            # A step longer than max_gap_s is a logger's gap; one that skips a slot of the
            # sample grid (more than a period and its tolerance: the clock has placed
            # jittered stamps on their slots already) is a dropped sample, whose second
            # the label stage cuts (rwhonet.data.quality, partial_second). Either ends the
            # run; the next starts at the next whole second.
            skips = (steps > self.max_gap_s) | (steps > self.period_s + self.period_tol_s)
            if self._fix_skips_slot and len(skips):
                skips[0] = False  # the dropped slot before this run's start fix, known
            split = np.flatnonzero(skips)
            usable = int(split[0]) + 1 if len(split) else len(t)  # rows before the split
            n_sec = (usable - 1) // ROWS_PER_SECOND
            end = n_sec * ROWS_PER_SECOND  # the last second's end fix
            if n_sec and end == usable - 1 and self._leans(end, later=True):
                # stamped toward the next slot: no end fix if a sample was dropped there
                # (the next row not in yet: held until it is)
                if len(split) and steps[end] <= self.max_gap_s:
                    n_sec -= 1
                elif not len(split) and not self._final:
                    n_sec -= 1
            if n_sec:
                parts.append(self._seconds(n_sec))
                self._drop(n_sec * ROWS_PER_SECOND)
                self._fix_skips_slot = False
                continue
            if len(split):
                # the next run starts after the split; the filter goes on across it (or
                # starts afresh) when the next run's first second is found
                i = int(split[0])
                self._gap = {
                    "from_s": float(t[i] - self._t0),
                    "gap_s": float(steps[i]),
                    "dropped": bool(steps[i] <= self.max_gap_s),
                }
                self._across = {k: v[: i + 1] for k, v in self._rows.items()}
                self._drop(i + 1)
                self._anchored, self._fix_skips_slot = False, False
                continue
            break
        if not parts:
            return empty_block()
        return {name: np.concatenate([p[name] for p in parts]) for name in COLUMNS}

    def _bridge(self, after: dict[str, np.ndarray]) -> None:
        """The filter across a split of the rows: ``self._across`` (from the last second's
        end to the split) and ``after`` (from the split to the next run's first second).

        A gap or dropped sample whose rows span at most :data:`BRIDGE_MAX_S` while an
        outage is still to come is bridged
        (:meth:`rwhonet.serve.navigation.StreamNavigator.bridge`); a longer one, or one
        before the filter has started, starts it afresh (it waits for a GNSS course, so
        inside an outage it gives no position until the outage ends). Each split is listed
        in ``self.gaps`` (``dropped``: a step of at most ``max_gap_s``, a sample or a few
        missing; else a logger's gap).
        """
        before, self._across = self._across, None
        rows = {k: np.concatenate([before[k], after[k]]) for k in self._keys}
        t = rows[c.T_S]
        elapsed = float(t[-1] - self._t0)
        ahead = bool(self.outages) and elapsed <= max(o.end_s for o in self.outages)
        bridged = False
        if len(t) < 2:
            # nothing between the filter's last step and the next run's start fix (a drop
            # right after a start fix the last split had already reached)
            bridged = ahead and self._navigator.started
        elif ahead and float(t[-1] - t[0]) <= BRIDGE_MAX_S:
            inside = any(o.start_s < elapsed <= o.end_s for o in self.outages)
            bridged = self._navigator.bridge(
                t,
                rows[c.OMEGA_RL],
                rows[c.OMEGA_RR],
                rows.get(c.YAW_RATE_RAD_S),
                (float(rows[c.LAT_DEG][-1]), float(rows[c.LON_DEG][-1])),
                inside,
            )
        else:
            self._navigator.reset()
        self.gaps.append(self._gap | {"bridged": bridged, "filtering": ahead})

    def _repair_glitches(
        self, first_row: int, columns: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """The block with its wheel glitches replaced, each one listed in ``self.glitches``.

        The screen validate runs (:func:`rwhonet.data.glitches.glitch_mask`: a wheel's
        speed rising more than ``WHEEL_GLITCH_G`` g above the other wheels' within a row),
        on the new rows with the rows still held before them (screened and repaired
        already) as context. A glitched sample is replaced by that wheel's own speed
        interpolated in time across it, so a one-row CAN glitch moves neither the WPM nor
        the prediction of its second (validate cuts such a second; a stream cannot leave
        it out without breaking the run), and the command says which rows it repaired.
        A stream drive's rows come with the resampler's flags too (``canonical.GLITCH_FLAG`` +
        wheel: the rows whose mean of that wheel used a glitched sample, which validate
        cuts): those are repaired the same way, whether or not the 10 Hz screen sees them.
        """
        held = 0 if self._rows is None else len(self._rows[c.T_S])
        keys = (c.T_S, *c.WHEELS)
        both = (
            {k: np.asarray(columns[k], dtype=np.float64) for k in keys}
            if not held
            else {k: np.concatenate([self._rows[k], columns[k]]) for k in keys}
        )
        mask = glitch_mask(
            both[c.T_S], [both[w] for w in c.WHEELS], self.nav.wheels.radius_m, WHEEL_GLITCH_G
        )
        for k, w in enumerate(c.WHEELS):
            flagged = columns.get(c.GLITCH_FLAG + w)
            if flagged is not None:
                mask[k, held:] |= np.asarray(flagged, dtype=bool)
        if not mask[:, held:].any():
            return columns
        columns = dict(columns)
        t = both[c.T_S]
        for k, w in enumerate(c.WHEELS):
            bad = np.flatnonzero(mask[k, held:]) + held
            if not bad.size:
                continue
            good = ~mask[k]
            fixed = both[w].copy()
            fixed[bad] = np.interp(t[bad], t[good], both[w][good])
            columns[w] = fixed[held:]
            self.glitches += [
                {
                    "row": first_row + int(i) - held,
                    "t_s": float(t[i]),
                    "channel": self.names.get(w, w),
                    "found_rad_s": float(both[w][i]),
                    "replaced_rad_s": float(fixed[i]),
                }
                for i in bad
            ]
        return columns

    def _repair_yaw(self, first_row: int, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The block with its yaw-rate glitches replaced, each one listed in ``self.glitches``.

        A sample beyond any car's yaw rate (:func:`rwhonet.data.glitches.repaired_yaw_rate`,
        as the label takes it) is interpolated in time across, with the rows still held
        before it as context, while such samples are at most ``YAW_GLITCH_SHARE`` of the
        channel's so far (more: a channel in the wrong unit, left for the yaw-rate check).
        """
        rate = columns.get(c.YAW_RATE_RAD_S)
        if rate is None:
            return columns
        rate = np.asarray(rate, dtype=np.float64)
        mask = yaw_rate_glitches(rate)
        self._yaw_counts[0] += int(np.isfinite(rate).sum())
        self._yaw_counts[1] += int(mask.sum())
        if not mask.any() or self._yaw_counts[1] > YAW_GLITCH_SHARE * self._yaw_counts[0]:
            return columns
        held = 0 if self._rows is None else len(self._rows[c.T_S])
        t = np.asarray(columns[c.T_S], dtype=np.float64)
        if held:
            t = np.concatenate([self._rows[c.T_S], t])
            rate = np.concatenate([self._rows[c.YAW_RATE_RAD_S], rate])
        fixed, replaced = repaired_yaw_rate(t, rate, max_share=1.0)
        name = self.names.get(c.YAW_RATE_RAD_S, c.YAW_RATE_RAD_S)
        self.glitches += [
            {
                "row": first_row + int(i) - held,
                "t_s": float(t[i]),
                "channel": name,
                "found_rad_s": float(rate[i]),
                "replaced_rad_s": float(fixed[i]),
                "yaw": True,
            }
            for i in np.flatnonzero(replaced[held:]) + held
        ]
        return dict(columns) | {c.YAW_RATE_RAD_S: fixed[held:]}

    def _drop(self, n: int) -> None:
        self._rows = {k: v[n:] for k, v in self._rows.items()}

    def _check(self, first_row: int, columns: dict[str, np.ndarray]) -> None:
        problems = []
        t = columns[c.T_S]
        for name in (c.T_S, *c.WHEELS):
            bad = np.flatnonzero(~np.isfinite(columns[name]))
            problems += [
                Problem(
                    self.file,
                    first_row + int(i),
                    self.names.get(name, name),
                    "a number (time and wheel speeds cannot be missing)",
                    _found(columns[name][i]),
                )
                for i in bad[:5]
            ]
        for name, limit, what in ((c.LAT_DEG, 90.0, "latitude"), (c.LON_DEG, 180.0, "longitude")):
            # a missing fix (NaN) is no fix; a value out of range is a broken one
            bad = np.flatnonzero(np.abs(columns[name]) > limit)
            problems += [
                Problem(
                    self.file,
                    first_row + int(i),
                    self.names.get(name, name),
                    f"a {what} in [-{limit:g}, {limit:g}] deg, or no value",
                    repr(float(columns[name][i])),
                    "give the coordinates in decimal degrees (not swapped, not radians); "
                    "leave a broken fix empty",
                )
                for i in bad[:5]
            ]
        before = self._rows[c.T_S][-1:] if self._rows is not None else np.zeros(0)
        joined = np.concatenate([before, t])
        with np.errstate(invalid="ignore"):  # inf - inf: a time the reader names
            back = np.flatnonzero(np.diff(joined) <= 0)
        problems += [
            _time_problem(
                self.file,
                first_row + int(i) - len(before) + 1,
                # the row before: in this block, or the last row held (the file's number)
                first_row + int(i) - len(before)
                if i >= len(before)
                else int(self._rows[FILE_ROW][-1]),
                self.names,
                joined,
                i,
            )
            for i in back[:5]
        ]
        if problems:
            raise InputError(problems, f"{self.file}: rows that cannot be cut into seconds")

    def _seconds(self, n_sec: int) -> dict[str, np.ndarray]:
        rows = {k: v[: n_sec * ROWS_PER_SECOND + 1] for k, v in self._rows.items()}
        # which way a logger that signs its wheel speeds says the car went (the filter's)
        backwards = backwards_per_second(rows[c.T_S], rows[c.OMEGA_RL], rows[c.OMEGA_RR])
        for w in c.WHEELS:  # magnitudes, as the label stage takes them (a signing logger)
            rows[w] = np.abs(rows[w])
        t = rows[c.T_S]
        spans = span_s(t)
        off = np.flatnonzero(np.abs(spans - 1.0) > SPAN_TOLERANCE_S)
        if len(off):
            k = int(off[0])
            raise InputError(
                [
                    Problem(
                        self.file,
                        int(rows[FILE_ROW][k * ROWS_PER_SECOND]),
                        self.names.get(c.T_S, c.T_S),
                        f"{ROWS_PER_SECOND} rows spanning 1 +/- {SPAN_TOLERANCE_S} s (10 Hz data)",
                        f"{spans[k]:.3f} s",
                    )
                ],
                f"{self.file} cannot be cut into 10 Hz seconds",
            )
        meta, model = self.model.meta, self.model
        angles = [
            wheel_angle_rad(integrate_per_second(t, rows[w]), end_of_second(rows[w]), meta.wpm_mode)
            for w in (c.OMEGA_RL, c.OMEGA_RR)
        ]
        disp_wpm = wpm_displacement_m(*angles, *meta.source_radii)
        feats = model.scaler.transform(
            wheel_features_rad_s([rows[w] for w in c.FEATURE_WHEEL_ORDER])
        )
        if meta.seq_len == 1:
            pred = model.predict_label(feats[:, None, :], *angles)
        else:
            # Windows of the run's last seq_len seconds, oldest first; at the run's start
            # padded with its first second, as the pipeline pads a segment's
            # (rwhonet.features.sequences): the same windows, the same predictions.
            past = self._history
            if past is None:
                past = np.repeat(feats[:1], meta.seq_len - 1, axis=0)
            run = np.concatenate([past, feats])
            x = sliding_window_view(run, meta.seq_len, axis=0).transpose(0, 2, 1)
            pred = model.predict_label(np.ascontiguousarray(x), *angles)
            self._history = run[len(run) - (meta.seq_len - 1) :]
        with np.errstate(invalid="ignore"):
            gnss = gnss_displacement_m(rows[c.LAT_DEG], rows[c.LON_DEG])
        t_end = end_of_second(t)
        self.backwards_s += (t_end[backwards] - self._t0).tolist()
        out = {
            "t_s": t_end,
            "elapsed_s": t_end - self._t0,
            "disp_wpm_m": disp_wpm,
            "pred_error_m": pred,
            "disp_corrected_m": disp_wpm + pred,
            "disp_gnss_m": gnss,
        }
        fix = {"lat": end_of_second(rows[c.LAT_DEG]), "lon": end_of_second(rows[c.LON_DEG])}
        gyro = gyro_yaw_rad(t, rows.get(c.YAW_RATE_RAD_S))  # NaN: a second without a gyro
        nav = None
        # the filter runs while an outage is still to come (its positions are the outages')
        if self.outages and out["elapsed_s"][0] <= max(o.end_s for o in self.outages):
            withheld = np.zeros(n_sec, bool)
            for o in self.outages:
                withheld |= (out["elapsed_s"] > o.start_s) & (out["elapsed_s"] <= o.end_s)
            nav = self._navigator.step(
                {
                    "disp_corrected_m": out["disp_corrected_m"],
                    "disp_gnss_m": gnss,
                    "angle_rl_rad": angles[0],
                    "angle_rr_rad": angles[1],
                    "gyro_yaw_rad": gyro,
                    "backwards": backwards,
                    "lat_deg": fix["lat"],
                    "lon_deg": fix["lon"],
                },
                withheld,
            )
        out.update(self._outage_columns(out, nav, fix, np.isfinite(gyro)))
        return out

    def _outage_columns(
        self,
        sec: dict[str, np.ndarray],
        nav: dict[str, np.ndarray] | None,
        fix: dict[str, np.ndarray],
        gyro: np.ndarray,
    ) -> dict[str, np.ndarray]:
        n = len(sec["t_s"])
        out: dict[str, np.ndarray] = {"outage": np.full(n, "", dtype=object)}
        out.update({name: np.full(n, np.nan) for name in OUTAGE_COLUMNS})
        for o in self.outages:
            rows = np.flatnonzero((sec["elapsed_s"] > o.start_s) & (sec["elapsed_s"] <= o.end_s))
            if not len(rows):
                continue
            tot = self.totals[o.label]
            wpm, corr, gnss = (
                sec[k][rows] for k in ("disp_wpm_m", "disp_corrected_m", "disp_gnss_m")
            )
            has = np.isfinite(gnss)
            g = np.where(has, gnss, 0.0)
            e_wpm, e_corr = np.where(has, wpm - g, 0.0), np.where(has, corr - g, 0.0)
            per_second = {
                "dist_wpm_m": wpm,
                "dist_corrected_m": corr,
                "dist_gnss_m": g,
                "err_wpm_m": e_wpm,
                "err_corrected_m": e_corr,
                "crse_wpm_m": np.abs(e_wpm),
                "crse_corrected_m": np.abs(e_corr),
            }
            cum = {name: tot.sums[name] + np.cumsum(v) for name, v in per_second.items()}
            out["outage"][rows] = o.label
            gnss_so_far = tot.gnss_s + np.cumsum(has)
            for name, values in cum.items():
                # distances and errors against GNSS only where GNSS has been there throughout
                keep = (gnss_so_far == tot.n + np.arange(1, len(rows) + 1)) | (
                    name in ("dist_wpm_m", "dist_corrected_m")
                )
                out[name][rows] = np.where(keep, values, np.nan)
            tot.n += len(rows)
            tot.gnss_s = int(gnss_so_far[-1])
            tot.gyro_s += int(gyro[rows].sum())
            tot.sums = {name: float(values[-1]) for name, values in cum.items()}
            if nav is not None:
                self._position(tot, rows, nav, fix, out)
        return out

    def _position(self, tot: _Totals, rows: np.ndarray, nav: dict, fix: dict, out: dict) -> None:
        """The filter's position in an outage's seconds, east/north of the last fix before it."""
        if tot.origin is None:  # the outage's first second: where it starts from
            i = rows[0]
            start = (nav["start_lat"][i], nav["start_lon"][i])
            if not np.isfinite(start).all():
                start = (nav["start_pred_lat"][i], nav["start_pred_lon"][i])
            tot.origin = (float(start[0]), float(start[1]))
        n = len(rows)
        east, north, fix_e, fix_n = (np.full(n, np.nan) for _ in range(4))
        if np.isfinite(tot.origin).all():
            for (lat, lon), (e, nn) in (
                ((nav["pred_lat"][rows], nav["pred_lon"][rows]), (east, north)),
                ((fix["lat"][rows], fix["lon"][rows]), (fix_e, fix_n)),
            ):
                ok = np.isfinite(lat) & np.isfinite(lon)
                if ok.any():
                    e[ok], nn[ok] = offsets_m(*tot.origin, lat[ok], lon[ok])
        cov = nav["cov"][rows]
        err = np.hypot(east - fix_e, north - fix_n)
        out["east_m"][rows], out["north_m"][rows] = east, north
        # the same position as WGS-84 coordinates, for a map
        seen = np.isfinite(east) & np.isfinite(north)
        out["lat_deg"][rows] = np.where(seen, nav["pred_lat"][rows], np.nan)
        out["lon_deg"][rows] = np.where(seen, nav["pred_lon"][rows], np.nan)
        out["cov_ee_m2"][rows] = cov[:, 0, 0]
        out["cov_en_m2"][rows] = cov[:, 0, 1]
        out["cov_nn_m2"][rows] = cov[:, 1, 1]
        elapsed = tot.n - len(rows) + np.arange(1, len(rows) + 1)  # seconds into the outage
        out["r68_m"][rows], out["r95_m"][rows] = self.calibration.semi_axis(
            cov, elapsed, SIGMA_CONTENT
        )
        out["pos_err_m"][rows] = err
        tot.r68, tot.r95 = float(out["r68_m"][rows[-1]]), float(out["r95_m"][rows[-1]])
        tot.east, tot.north, tot.pos_err = float(east[-1]), float(north[-1]), float(err[-1])
        tot.lat, tot.lon = float(out["lat_deg"][rows[-1]]), float(out["lon_deg"][rows[-1]])
        last = cov[-1]
        tot.pos_sd = (
            float(np.sqrt(np.linalg.eigvalsh(last)[-1])) if np.isfinite(last).all() else math.nan
        )

    def summary(self) -> list[dict[str, float | str]]:
        """Per outage: seconds seen, distances, CRSE / CTE of WPM and corrected, and position.

        ``east_end_m``, ``north_end_m``: the filter's position at the outage's last
        second from the fix before it, ``lat_end_deg``, ``lon_end_deg`` the same as
        WGS-84 coordinates; ``pos_sd_end_m``: its 1-sigma ellipse's major
        semi-axis (the filter's own); ``r68_end_m``, ``r95_end_m``: the major semi-axes
        of the regions holding 68.27 % and 95.45 % (``calibrated``: by the evaluation's
        calibration the model carries, else the filter's own normal); ``pos_err_end_m``:
        its distance to the GNSS fix there (NaN when the file has none); ``control``: the
        filter's yaw in the outage (``fused``: the gyro's in ``gyro_s`` of its seconds, the
        others' the wheels' alone; ``wheels``: in none).
        """
        rows = []
        for label, tot in self.totals.items():
            full = tot.n > 0 and tot.gnss_s == tot.n
            sums = tot.sums
            rows.append(
                {
                    "outage": label,
                    "seconds": tot.n,
                    "dist_gnss_m": sums["dist_gnss_m"] if full else math.nan,
                    "dist_wpm_m": sums["dist_wpm_m"],
                    "dist_corrected_m": sums["dist_corrected_m"],
                    "crse_wpm_m": sums["crse_wpm_m"] if full else math.nan,
                    "cte_wpm_m": abs(sums["err_wpm_m"]) if full else math.nan,
                    "crse_corrected_m": sums["crse_corrected_m"] if full else math.nan,
                    "cte_corrected_m": abs(sums["err_corrected_m"]) if full else math.nan,
                    "east_end_m": tot.east,
                    "north_end_m": tot.north,
                    "lat_end_deg": tot.lat,
                    "lon_end_deg": tot.lon,
                    "pos_sd_end_m": tot.pos_sd,
                    "r68_end_m": tot.r68,
                    "r95_end_m": tot.r95,
                    "calibrated": self.calibration.calibrated,
                    "pos_err_end_m": tot.pos_err,
                    "control": "fused" if tot.gyro_s else "wheels",
                    "gyro_s": tot.gyro_s,
                }
            )
        return rows


def _first_slot(t_s: float, period_s: float) -> bool:
    """Whether a row's time is the first slot of its second ``(k - 1, k]``: one period
    after the whole second before it (within the clock's allowance)."""
    return t_s - period_s <= math.ceil(t_s - TIME_EPS_S) - 1 + TIME_EPS_S


def _time_problem(
    file: str, row: int, before: int, names: dict[str, str], t: np.ndarray, i: int
) -> Problem:
    """Row ``row`` (time ``t[i + 1]``) is not after the row before it (row ``before``, time
    ``t[i]``), as validate says it (``rwhonet.data.schema``): two samples at one time, or
    a clock going back. (A row that repeats an earlier row in every channel, a sample
    written twice, was dropped before: :class:`rwhonet.data.droprows.RowFilter`.)"""
    now, prev = float(t[i + 1]), float(t[i])
    if now == prev:
        found = f"t = {now!r} s again (as in row {before})"
        fix = (
            "two samples at one time, their values not the same: a clock that stuck, or "
            "stamps rounded too coarsely (a drive given as a file, not from a pipe, whose "
            "stamps to the second each hold their second's rows is placed); delete one of "
            "the two rows, or re-export the drive with finer time stamps"
        )
    else:
        found = f"time goes backwards: t = {_found(now)} s after t = {_found(prev)} s"
        fix = (
            "sort the rows by time (a drive given as a file, not from a pipe, has rows out of "
            "order put in order where sorting is safe, and a clock set back while the car "
            "drove on put right where the fixes show it), or split the file into one drive "
            "per recording where the clock restarts; a clock set back an hour is summer "
            "time ending: write the times in UTC or with their zone offset (ISO 8601, "
            "+01:00)"
        )
    return Problem(
        file, row, names.get(c.T_S, c.T_S), "a time after the previous row's", found, fix
    )


def _found(value: float) -> str:
    """A cell's value as a message shows it: the number (not numpy's repr), or empty."""
    value = float(value)  # to the µs: the clock's arithmetic leaves 37803.200000000004
    return "an empty cell (or NaN)" if math.isnan(value) else repr(round(value, 6))


def empty_block() -> dict[str, np.ndarray]:
    """An output block without seconds."""
    return {name: np.zeros(0, dtype=object if name == "outage" else np.float64) for name in COLUMNS}
