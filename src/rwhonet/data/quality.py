"""GNSS-quality policy: which whole seconds of a drive can be trusted, and the valid segments.

The dataset notes that GNSS reception was lost at times and that such stretches
must be cut, not trained on (iovnbd-format.md); the authors sliced their drives
by hand. Here the cleaning is data (``validate.gnss``, ``validate.cuts``) applied
by one function, :func:`assess`, and every cut is reported.

Clock convention (shared with the label stage, :mod:`rwhonet.features.seconds`)
    Second ``k`` of a drive is the interval ``(k - 1, k]`` of the drive's own time
    column, ``k`` an integer: the ten 10 Hz rows whose times round *up* to ``k``
    (:func:`second_index`, with a 1 µs allowance for decimal time stamps stored as
    floats). A row's time here is its slot on the drive's sample grid
    (:mod:`rwhonet.data.timebase`): stamps jittered by up to half a sample period stay
    in their second, while a dropped sample still leaves its second a row short.
    Quality is decided per second. A segment covers the consecutive valid
    seconds ``start_s + 1 … end_s`` (whole seconds), each complete
    (``1 / sample_period_s`` rows), and also carries its *start fix*: the last row of
    second ``start_s``, from which the first second's displacement is measured. A
    segment therefore has ``10 n + 1`` rows for ``n`` seconds: row 0 is the start fix
    and rows ``10 k + 1 … 10 k + 10`` are second ``k``, so its seconds end on whole
    seconds of the drive's clock. The start fix must itself be a good row (not
    flagged by a row rule below); when it is not, or the drive starts right there,
    the first valid second is cut as ``start_fix`` and its last row is the start fix.

Rules (a second is cut by the first that applies, in this order)
    manual          a ``validate.cuts`` interval ``[start_s, end_s]`` of this drive holds a row
    gap             it holds no row, or a time step > ``max_gap_s`` ends in it, or it is
                    incomplete next to such a step (the drive is split there)
    partial_second  it holds a number of rows other than ``1 / sample_period_s`` (the drive's
                    first/last second, dropped or extra samples)
    low_sats        a row has fewer than ``min_sats`` satellites (or no count), when the
                    drive has a satellite column; or a horizontal accuracy its receiver
                    states worse than ``max_h_acc_m`` (or none stated), when that is set
                    and the drive has an ``h_acc_m`` column; or no fix at all: latitude
                    or longitude empty, or both exactly 0, what a receiver without a fix
                    writes (:func:`no_fix_rows`)
    jump            the fix-to-fix distance of a row implies a speed > ``max_speed_m_s``
    frozen          the fix stayed identical while the rear wheels turned faster than
                    ``moving_wheel_speed_rad_s`` for ``frozen_min_s`` in all (from the first
                    such row to the end of the identical run)
    wheel_glitch    a row whose wheel speed changed faster than any tyre can, when the
                    caller passes such rows (:func:`rwhonet.data.glitches.wheel_glitch_rows`)
    drop_edge       its end fix, or the start fix of a valid stretch's first second, is a
                    row beside a dropped sample whose stamp lies more than a quarter period
                    toward it: jittered past half a period, the row may be the dropped
                    sample's (:func:`rwhonet.data.timebase.leans_into_drop`)
    start_fix       the first second of a valid stretch whose start fix is missing or cut
    short_segment   a run of valid seconds shorter than ``min_segment_s`` (dropped)

Rows of the ``manual``, ``low_sats``, ``jump``, ``frozen`` and ``wheel_glitch`` rules are
*bad rows* (a bad row is no start fix either: a glitch in the last row of a second also
spoils the next second's first trapezoid step);
the others are properties of whole seconds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rwhonet.config import CutSpec, GnssPolicy
from rwhonet.data import canonical as c
from rwhonet.data.droprows import FileRows
from rwhonet.data.fixes import no_fix_rows
from rwhonet.data.timebase import TIME_EPS_S, leans_into_drop, nominal_times
from rwhonet.geo import geodesic_distance_m, local_step_distance_m

RULES = (
    "manual",
    "gap",
    "partial_second",
    "low_sats",
    "jump",
    "frozen",
    "wheel_glitch",
    "drop_edge",
    "start_fix",
    "short_segment",
)


@dataclass(frozen=True, kw_only=True)
class Span:
    """Seconds ``(start_s, end_s]`` of a drive's own clock, both ends whole seconds.

    The one place a span's length is counted, for the cuts and the segments alike. Keyword
    only, so a subclass's positional fields come first and a call that passes the times
    by position fails instead of filling the wrong fields.
    """

    start_s: float
    end_s: float

    @property
    def n_seconds(self) -> int:
        """Whole seconds in the span (rounded: the ends are whole seconds stored as floats)."""
        return round(self.end_s - self.start_s)


@dataclass(frozen=True)
class Cut(Span):
    """A span of a drive cut by one rule, and the rows it held."""

    rule: str
    detail: str
    n_rows: int


@dataclass(frozen=True)
class Segment(Span):
    """A GNSS-valid span of a drive, in rows ``row_start:row_stop``.

    ``row_start`` is the start fix (the last row of second ``start_s``), so the segment
    has ``n_seconds * rows_per_second + 1`` rows. ``segments.json`` writes its span as
    ``t_start_s`` and ``t_end_s``.
    """

    row_start: int
    row_stop: int

    @property
    def n_rows(self) -> int:
        """Rows in the segment."""
        return self.row_stop - self.row_start


def segment_name(drive: str, k: int) -> str:
    """Return the id of the ``k``-th segment of a drive (``V-S1__s000``; sorts in time order)."""
    return f"{drive}__s{k:03d}"


@dataclass(frozen=True)
class Assessment:
    """The outcome of the GNSS policy on one drive."""

    segments: list[Segment]
    cuts: list[Cut]
    n_rows: int
    n_seconds: int  # whole seconds spanned by the drive, first to last
    cut_seconds_by_rule: dict[str, int] = field(default_factory=dict)
    cut_rows_by_rule: dict[str, int] = field(default_factory=dict)
    # the receiver's stated horizontal accuracy over the drive's fixes (accuracy_summary),
    # None when the drive has no h_acc_m column
    accuracy: dict[str, Any] | None = None

    @property
    def rows_kept(self) -> int:
        """Rows of the kept seconds (start fixes not counted: their seconds were cut)."""
        return sum(s.n_rows - 1 for s in self.segments)

    @property
    def seconds_kept(self) -> int:
        """Seconds inside valid segments."""
        return sum(s.n_seconds for s in self.segments)


def second_index(t_s: np.ndarray, sample_period_s: float | None = None) -> np.ndarray:
    """Return the whole second each row belongs to: ``k`` such that ``k - 1 < t <= k``.

    With ``sample_period_s``, ``t`` is the row's slot instant on the drive's sample grid
    (:func:`rwhonet.data.timebase.nominal_times`), so stamps jittered by less than half a
    period still give every second its ``1 / sample_period_s`` rows; without it, the
    stamp itself.

    Args:
        t_s: times, s (finite and increasing when ``sample_period_s`` is given).
        sample_period_s: the nominal sample period, s, or None for the stamps as they are.

    Returns:
        int64 second numbers.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if sample_period_s is not None and t.size:
        t = nominal_times(t, sample_period_s)
    return np.ceil(t - TIME_EPS_S).astype(np.int64)


def implied_speed_m_s(
    t_s: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, exact_above_m_s: float = 0.0
) -> np.ndarray:
    """Speed implied by each fix and the one before it, m/s (0 for the first row).

    Args:
        t_s: strictly increasing times, s.
        lat_deg: latitudes, deg.
        lon_deg: longitudes, deg.
        exact_above_m_s: steps whose tangent-plane speed exceeds this are recomputed with
            the exact geodesic (all of them with the default 0), so a threshold applied to
            the result is decided on geodesic distances.

    Returns:
        One speed per row.
    """
    lat_deg = np.asarray(lat_deg, dtype=np.float64)
    lon_deg = np.asarray(lon_deg, dtype=np.float64)
    dt = np.diff(t_s)
    speed = np.zeros(np.size(t_s))
    speed[1:] = local_step_distance_m(lat_deg, lon_deg) / dt
    exact = np.flatnonzero(speed[1:] >= exact_above_m_s)
    if exact.size:
        speed[exact + 1] = (
            geodesic_distance_m(
                lat_deg[exact], lon_deg[exact], lat_deg[exact + 1], lon_deg[exact + 1]
            )
            / dt[exact]
        )
    return speed


def frozen_rows(
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    wheel_speed_rad_s: np.ndarray,
    sample_period_s: float,
    frozen_min_s: float,
    moving_wheel_speed_rad_s: float,
) -> np.ndarray:
    """Flag rows whose GNSS fix is frozen while the vehicle moves.

    A run of identical consecutive fixes is frozen when the wheels turned faster than
    ``moving_wheel_speed_rad_s`` for at least ``frozen_min_s`` in all during it (counted as
    moving rows × sample period). Its rows from the first moving one to the end of the run
    are flagged: before that the vehicle stood still and an unchanged fix was right.

    Args:
        lat_deg: latitudes, deg.
        lon_deg: longitudes, deg.
        wheel_speed_rad_s: a non-negative wheel speed per row (mean |rear wheel speed|).
        sample_period_s: nominal sample period, s.
        frozen_min_s: moving time with an unchanged fix that makes a run frozen, s.
        moving_wheel_speed_rad_s: wheel speed above which the vehicle counts as moving.

    Returns:
        Boolean mask, True for frozen rows.
    """
    lat_deg, lon_deg = np.asarray(lat_deg), np.asarray(lon_deg)
    n = lat_deg.size
    if n == 0:
        return np.zeros(0, dtype=bool)
    same = (lat_deg[1:] == lat_deg[:-1]) & (lon_deg[1:] == lon_deg[:-1])
    run = np.cumsum(np.r_[True, ~same]) - 1  # run id of identical fixes, per row
    moving = np.asarray(wheel_speed_rad_s) > moving_wheel_speed_rad_s
    moving_s = np.bincount(run, weights=moving.astype(float)) * sample_period_s
    row = np.arange(n)
    first_moving = np.full(run[-1] + 1, n)
    np.minimum.at(first_moving, run[moving], row[moving])
    frozen_run = moving_s >= frozen_min_s - TIME_EPS_S
    return frozen_run[run] & (row >= first_moving[run])


def manual_rows(t_s: np.ndarray, cuts: Sequence[CutSpec]) -> np.ndarray:
    """Rows inside a manual cut: ``start_s <= t_s <= end_s`` of any of ``cuts``.

    Args:
        t_s: row times, s.
        cuts: manual cuts of this drive (``validate.cuts`` entries naming it).

    Returns:
        Boolean mask, True for cut rows.
    """
    t = np.asarray(t_s, dtype=np.float64)
    row = np.zeros(t.size, dtype=bool)
    for cut in cuts:  # params entries, a handful
        row |= (t >= cut.start_s) & (t <= cut.end_s)
    return row


def assess(
    drive: Mapping[str, np.ndarray],
    policy: GnssPolicy,
    sample_period_s: float,
    cuts: Sequence[CutSpec] = (),
    wheel_glitch: np.ndarray | None = None,
    file_rows: FileRows | None = None,
) -> Assessment:
    """Apply the GNSS-quality policy to one drive (see the module docstring for the rules).

    Args:
        drive: canonical columns (``t_s`` strictly increasing, the wheel speeds complete, a
            fix without a value is no fix; ``n_sats``, ``h_acc_m`` optional), e.g. a DataFrame that
            passed the schema.
        policy: ``validate.gnss``.
        sample_period_s: nominal sample period; ``1 / sample_period_s`` must be an integer.
        cuts: manual cuts of this drive (``validate.cuts`` entries naming it).
        wheel_glitch: boolean mask of rows whose wheel speeds changed faster than a tyre
            can (:func:`rwhonet.data.glitches.glitch_mask`), or None (no such rule).
        file_rows: the file's data row of each row, for the cuts' details (None: row ``i``
            is data row ``i + 1``; :mod:`rwhonet.data.droprows`).

    Returns:
        The valid segments and every cut, with per-rule totals.
    """
    t = np.asarray(drive[c.T_S], dtype=np.float64)
    lat = np.asarray(drive[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(drive[c.LON_DEG], dtype=np.float64)
    wheel = 0.5 * (np.abs(np.asarray(drive[c.OMEGA_RL])) + np.abs(np.asarray(drive[c.OMEGA_RR])))
    n_per_s = round(1.0 / sample_period_s)
    n = t.size
    if not n:  # no row, no second: nothing valid and nothing to cut
        return Assessment([], [], 0, 0, dict.fromkeys(RULES, 0), dict.fromkeys(RULES, 0))

    # Jittered stamps are taken at their slots on the drive's sample grid (seconds, and the
    # fix-to-fix speed, whose steps a few ms of jitter would otherwise distort).
    t_grid = nominal_times(t, sample_period_s) if n else t
    sec = second_index(t_grid)
    k0 = int(sec[0])
    s = sec - k0  # second of each row, 0-based from the drive's first second
    n_sec = int(s[-1]) + 1

    def per_second(row_mask: np.ndarray) -> np.ndarray:
        return np.bincount(s[row_mask], minlength=n_sec) > 0

    count = np.bincount(s, minlength=n_sec)
    incomplete = count != n_per_s
    gap_step = np.diff(t) > policy.max_gap_s  # step i -> i + 1
    gap_start, gap_end = np.r_[gap_step, False], np.r_[False, gap_step]
    gap = (count == 0) | per_second(gap_end) | (incomplete & per_second(gap_start))

    manual_row = manual_rows(t, cuts)
    has_sats = c.N_SATS in drive
    sats = np.asarray(drive[c.N_SATS], dtype=np.float64) if has_sats else np.full(n, np.inf)
    h_acc = np.asarray(drive[c.H_ACC_M], dtype=np.float64) if c.H_ACC_M in drive else None
    low_sats_row = no_fix_rows(  # NaN count or accuracy: not trusted
        lat, lon, sats, policy.min_sats, h_acc, policy.max_h_acc_m
    )
    # Jumps are decided on geodesic distances: the tangent-plane screen (1e-6 relative)
    # only spares the geodesic for steps far below the threshold.
    with np.errstate(divide="ignore", invalid="ignore"):  # two rows in one slot: a jump
        speed = implied_speed_m_s(t_grid, lat, lon, exact_above_m_s=0.5 * policy.max_speed_m_s)
    jump_row = speed > policy.max_speed_m_s
    frozen_row = frozen_rows(
        lat,
        lon,
        wheel,
        sample_period_s,
        policy.frozen_min_s,
        policy.moving_wheel_speed_rad_s,
    )
    glitch_row = np.zeros(n, dtype=bool) if wheel_glitch is None else np.asarray(wheel_glitch)
    bad_row = manual_row | low_sats_row | jump_row | frozen_row | glitch_row
    # A row beside a dropped sample stamped toward it may be the dropped sample's: no
    # second ends on it (a complete second's last row is its end fix), none starts on it.
    edge_row = leans_into_drop(t - t_grid, np.diff(t_grid), sample_period_s, policy.max_gap_s)
    ends_second = np.r_[s[1:] != s[:-1], True]

    flags = np.stack(
        [
            per_second(manual_row),
            gap,
            incomplete,
            per_second(low_sats_row),
            per_second(jump_row),
            per_second(frozen_row),
            per_second(glitch_row),
            per_second(edge_row & ends_second),
        ]
    )
    rule = np.where(flags.any(axis=0), flags.argmax(axis=0), -1)  # first rule that applies
    row_at = np.searchsorted(s, np.arange(n_sec + 1))  # first row of each second

    # A valid stretch needs a good start fix: the row just before its first second (a valid
    # second's first step is never a gap, so that row is the last of the previous second).
    v_start, _ = _runs(rule == -1)
    fix = row_at[v_start] - 1
    no_fix = (fix < 0) | bad_row[np.maximum(fix, 0)]
    rule[v_start[no_fix]] = RULES.index("start_fix")
    rule[v_start[~no_fix & edge_row[np.maximum(fix, 0)]]] = RULES.index("drop_edge")

    # Valid runs shorter than min_segment_s are dropped.
    v_start, v_stop = _runs(rule == -1)
    too_short = (v_stop - v_start) < policy.min_segment_s - TIME_EPS_S
    for a, b in zip(v_start[too_short], v_stop[too_short], strict=True):  # per stretch
        rule[a:b] = RULES.index("short_segment")
    segments = [
        Segment(
            int(row_at[a]) - 1, int(row_at[b]), start_s=float(k0 + a - 1), end_s=float(k0 + b - 1)
        )
        for a, b in zip(v_start[~too_short], v_stop[~too_short], strict=True)
    ]

    # Merge consecutive cut seconds with the same rule into reported intervals.
    change = np.flatnonzero(rule[1:] != rule[:-1]) + 1
    starts, stops = np.r_[0, change], np.r_[change, n_sec]
    rows_in = {
        "dt": np.r_[np.nan, np.diff(t)],
        "sats": sats,
        "h_acc": h_acc,
        "zero": (lat == 0.0) & (lon == 0.0),
        "empty": ~(np.isfinite(lat) & np.isfinite(lon)),
        "speed": speed,
        "wheel": wheel,
        "count": count,
        "glitch": glitch_row,
        "edge": edge_row,
        "lean": t - t_grid,
        "file_rows": file_rows if file_rows is not None else FileRows(),
    }
    cut_list = [
        Cut(
            start_s=float(k0 + a - 1),
            end_s=float(k0 + b - 1),
            rule=RULES[rule[a]],
            detail=_detail(RULES[rule[a]], a, b, row_at, rows_in, policy, n_per_s, cuts, k0),
            n_rows=int(row_at[b] - row_at[a]),
        )
        for a, b in zip(starts, stops, strict=True)
        if rule[a] >= 0
    ]
    cut_seconds = {r: 0 for r in RULES}
    cut_rows = {r: 0 for r in RULES}
    for cut in cut_list:
        cut_seconds[cut.rule] += cut.n_seconds
        cut_rows[cut.rule] += cut.n_rows
    accuracy = None if h_acc is None else accuracy_summary(lat, lon, h_acc)
    return Assessment(segments, cut_list, n, n_sec, cut_seconds, cut_rows, accuracy)


def accuracy_summary(lat: np.ndarray, lon: np.ndarray, h_acc_m: np.ndarray) -> dict[str, Any]:
    """The receiver's stated horizontal accuracy over a drive's rows with a fix.

    What ``validate.gnss.max_h_acc_m`` would be set from: the rows with a fix (latitude and
    longitude, not both 0), how many of them state an accuracy, and its median, 95th
    percentile and largest value (m, rounded to the centimetre; None without any).
    """
    fix = ~no_fix_rows(lat, lon)
    stated = h_acc_m[fix & np.isfinite(h_acc_m)]
    out: dict[str, Any] = {"fix_rows": int(fix.sum()), "stated_rows": int(stated.size)}
    for key, q in (("median_m", 50.0), ("p95_m", 95.0), ("max_m", 100.0)):
        out[key] = round(float(np.percentile(stated, q)), 2) if stated.size else None
    return out


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) indices of the runs of True in a boolean array."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return edges[0::2], edges[1::2]


def _detail(
    rule: str,
    a: int,
    b: int,
    row_at: np.ndarray,
    rows: dict[str, Any],
    policy: GnssPolicy,
    n_per_s: int,
    cuts: Sequence[CutSpec],
    k0: int,
) -> str:
    """Say why seconds ``a:b`` (0-based from the drive's first second) were cut."""
    lo, hi = int(row_at[a]), int(row_at[b])
    start_s, end_s = k0 + a - 1, k0 + b - 1
    if rule == "manual":
        reasons = [cut.reason for cut in cuts if cut.start_s <= end_s and cut.end_s > start_s]
        return "manual cut: " + "; ".join(dict.fromkeys(reasons))
    if rule == "gap":
        # The steps into, inside and out of these seconds.
        dt = rows["dt"][lo : min(hi + 1, len(rows["dt"]))]
        longest = np.nanmax(dt) if np.isfinite(dt).any() else float("nan")
        return f"time gap of up to {longest:.3g} s (> max_gap_s {policy.max_gap_s} s)"
    if rule == "partial_second":
        counts = sorted(set(rows["count"][a:b].tolist()))
        return f"seconds with {counts} rows, a whole second has {n_per_s}"
    if rule == "low_sats":
        sats = rows["sats"][lo:hi]
        said = []
        if rows["empty"][lo:hi].any():
            said.append("no fix (latitude or longitude empty)")
        if rows["zero"][lo:hi].any():
            said.append("no fix (latitude = longitude = 0)")
        low = sats[~(sats >= policy.min_sats)]
        if np.isnan(low).any():
            said.append("no count")
        elif low.size:
            said.append(f"{int(np.min(low))} satellites")
        bound = f"min_sats {policy.min_sats}"
        if rows["h_acc"] is not None and policy.max_h_acc_m is not None:
            acc = rows["h_acc"][lo:hi]
            poor = acc[~(acc <= policy.max_h_acc_m)]
            if np.isnan(poor).any():
                said.append("no stated accuracy")
            if np.isfinite(poor).any():
                said.append(f"stated horizontal accuracy up to {np.nanmax(poor):.3g} m")
            bound += f", max_h_acc_m {policy.max_h_acc_m:g}"
        return f"{'; '.join(said)} ({bound})"
    if rule == "jump":
        return (
            f"fix-to-fix speed up to {np.max(rows['speed'][lo:hi]):.4g} m/s "
            f"(> max_speed_m_s {policy.max_speed_m_s})"
        )
    if rule == "wheel_glitch":
        rows_hit = rows["file_rows"](np.flatnonzero(rows["glitch"][lo:hi]) + lo)
        shown = ", ".join(str(r) for r in rows_hit[:5]) + (" ..." if rows_hit.size > 5 else "")
        return f"wheel speed changing faster than any tyre can in row(s) {shown}"
    if rule == "drop_edge":
        edge = np.flatnonzero(rows["edge"][max(lo - 1, 0) : hi]) + max(lo - 1, 0)
        shown = ", ".join(
            f"{r} ({1e3 * lean:+.0f} ms)"
            for r, lean in zip(rows["file_rows"](edge[:3]), rows["lean"][edge[:3]], strict=True)
        )
        return (
            f"a fix beside a dropped sample, stamped more than a quarter period toward it, in "
            f"row(s) {shown}: jittered past half a period, it may be the dropped sample's"
        )
    if rule == "start_fix":
        return (
            "first second of a valid stretch: no usable fix at its start (drive start or a cut row)"
        )
    if rule == "frozen":
        return (
            f"GNSS fix unchanged while the rear wheels turned at up to "
            f"{np.max(rows['wheel'][lo:hi]):.3g} rad/s "
            f"(frozen_min_s {policy.frozen_min_s} s, moving above "
            f"{policy.moving_wheel_speed_rad_s} rad/s)"
        )
    return f"valid stretch of {b - a} s dropped (< min_segment_s {policy.min_segment_s} s)"
