"""The per-second grid: which 10 Hz rows make up a second, and what is measured in it.

Definition (the data contract of docs/architecture.md, "Samples"): a segment
with rows ``0 .. N-1`` at 10 Hz has ``n = (N - 1) // 10`` seconds. Second ``k``
(0-based) runs from the fix at row ``a = 10 k`` to the fix at row
``b = 10 k + 10``; it *owns* the ten rows ``a+1 .. b``, i.e. the rows with
times in ``(t_a, t_b]``, which is the ``(t - 1, t]`` of the contract with
``t = t_b``. Row 0 only serves as the first second's starting fix, and trailing
rows that do not complete a second are dropped. The validate stage cuts every
segment so that row 0 is the last row of a whole second of the drive's clock
(``rwhonet.data.quality``: ``10 n + 1`` rows for ``n`` seconds), so these are the
whole seconds ``(k - 1, k]`` of the clock; this module itself relies only on the
row structure and counts seconds from row 0 of whatever segment it is given.

Per second we take

- the GNSS displacement: the geodesic distance between the fixes at rows ``a``
  and ``b`` (paper Eq. 11's ``x_GNSS``; WGS84, see :mod:`rwhonet.geo`);
- wheel angles: the trapezoid integral of a wheel speed over ``[t_a, t_b]``,
  exactly the interval of the GNSS displacement (see :func:`integrate_per_second`);
- the once-per-second wheel-speed sample of the authors' code (row ``b``);
- the 40 input features: the ten samples of rows ``a+1 .. b`` of each wheel,
  wheel-major in the authors' order RR, RL, FR, FL, oldest first;
- the yaw-rate gyro's angle over the second (the trapezoid integral of
  ``yaw_rate_rad_s`` over ``[t_a, t_b]``, as the wheel angles), where the drive has
  the channel (NaN otherwise, and for a second with a missing rate): what the
  navigation filter (:mod:`rwhonet.nav`) fuses with the rear wheels;
- the scenario tags of rows ``a+1 .. b``, merged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa
from numpy.typing import ArrayLike

from rwhonet.contracts import ROWS_PER_SECOND
from rwhonet.data import canonical as c
from rwhonet.data.glitches import repaired_yaw_rate
from rwhonet.data.timebase import label_times
from rwhonet.errors import InputError, Problem
from rwhonet.geo import geodesic_distance_m

if TYPE_CHECKING:
    import pandas as pd

# Ten rows must span about one second. This is a gross check (it catches 1 Hz or
# 100 Hz data, or a gap that validate failed to split on); the fine sample-period
# rule belongs to the validate stage.
SPAN_TOLERANCE_S = 0.5
# Problems listed per column before the report says "and N more".
_MAX_PROBLEMS_PER_CHECK = 5
# The canonical columns the per-second computation reads (the yaw rate where a drive has it).
SEGMENT_COLUMNS = (*c.REQUIRED, c.YAW_RATE_RAD_S, c.SCENARIO)


def n_seconds(n_rows: int) -> int:
    """Return the number of whole seconds in a segment of ``n_rows`` 10 Hz rows.

    Args:
        n_rows: number of rows in the segment.

    Returns:
        ``(n_rows - 1) // 10``, never negative.
    """
    return max((int(n_rows) - 1) // ROWS_PER_SECOND, 0)


def anchor_rows(n_sec: int) -> np.ndarray:
    """Return the rows of the fixes that bound the seconds: ``0, 10, ..., 10 n_sec``.

    Args:
        n_sec: number of seconds.

    Returns:
        int64 array of ``n_sec + 1`` row indices; second ``k`` runs from entry ``k`` to ``k + 1``.
    """
    return np.arange(n_sec + 1, dtype=np.int64) * ROWS_PER_SECOND


def rows_of_seconds(values: np.ndarray) -> np.ndarray:
    """Group a per-row array into the ten rows each second owns.

    Args:
        values: per-row array of length N (any dtype).

    Returns:
        View of shape ``(n_seconds(N), 10)``; row ``k`` holds ``values[10k+1 .. 10k+10]``.
    """
    n_sec = n_seconds(len(values))
    return values[1 : 1 + n_sec * ROWS_PER_SECOND].reshape(n_sec, ROWS_PER_SECOND)


def end_of_second(values: np.ndarray) -> np.ndarray:
    """Return the value at the last row of each second (row ``10k + 10``).

    Args:
        values: per-row array of length N.

    Returns:
        Array of length ``n_seconds(N)``.
    """
    return values[anchor_rows(n_seconds(len(values)))[1:]]


def span_s(t_s: np.ndarray) -> np.ndarray:
    """Return the duration of each second, ``t_b - t_a`` (1 s at an exact 10 Hz).

    Args:
        t_s: per-row time, seconds.

    Returns:
        float64 array of length ``n_seconds(len(t_s))``.
    """
    t = t_s[anchor_rows(n_seconds(len(t_s)))]
    return np.diff(t)


def gnss_displacement_m(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Return the GNSS displacement per second (paper Eq. 11's ``x_GNSS``).

    The geodesic (WGS84) distance between the fixes that bound each second. It
    is the chord of the path, shorter than the arc the wheels roll by a relative
    ``(L / R)^2 / 24`` (L the arc length in that second, R the turn radius):
    1 % (0.1 m) for 10 m on a 20 m-radius roundabout, negligible on straights.
    That part of the label is kept on purpose: it is the model's to learn, from
    the left/right wheel-speed difference the features carry.

    Args:
        lat_deg: per-row latitude, degrees.
        lon_deg: per-row longitude, degrees.

    Returns:
        float64 metres, length ``n_seconds(len(lat_deg))``.
    """
    idx = anchor_rows(n_seconds(len(lat_deg)))
    return geodesic_distance_m(
        lat_deg[idx[:-1]], lon_deg[idx[:-1]], lat_deg[idx[1:]], lon_deg[idx[1:]]
    )


def integrate_per_second(t_s: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """Integrate a 10 Hz rate over each second with the trapezoid rule (paper Eq. 10's integral).

    The trapezoid over the eleven samples ``a .. b`` integrates over exactly
    ``[t_a, t_b]``, the interval whose GNSS displacement the label compares
    against. It is exact for a rate that varies linearly (constant acceleration),
    and its error is ``-h^2 / 12`` times the change of the rate's slope over the
    second (``h`` = 0.1 s): about 1 mm at a jerk of 1 m/s^3. The rectangle rule
    on the ten samples ``a+1 .. b`` would be off by ``h / 2`` times the change of
    the rate over the second: 0.1 m per second when braking at 2 m/s^2, as large
    as the labels themselves. The times are the ones given: :func:`segment_seconds`
    passes the rows' grid-slot instants for jittered stamps
    (:func:`rwhonet.data.timebase.label_times`).

    Args:
        t_s: per-row time, seconds, strictly increasing.
        rate: per-row rate (e.g. wheel speed, rad/s).

    Returns:
        float64 integral per second (e.g. wheel angle, rad), length ``n_seconds(len(t_s))``.
    """
    n_sec = n_seconds(len(t_s))
    increments = 0.5 * (rate[:-1] + rate[1:]) * np.diff(t_s)
    return increments[: n_sec * ROWS_PER_SECOND].reshape(n_sec, ROWS_PER_SECOND).sum(axis=1)


def gyro_yaw_rad(t_s: np.ndarray, yaw_rate_rad_s: ArrayLike | None) -> np.ndarray:
    """The gyro's yaw angle over each second: its rate integrated as the wheel speeds are.

    The trapezoid over ``[t_a, t_b]`` (:func:`integrate_per_second`), the interval
    of the second's GNSS displacement and wheel angles, so the wheels' yaw and the
    gyro's measure the same turn. A channel whose rows are means over their
    record period (the simulator's, ``docs/simulator.md`` Section 7) is then read
    half a record period (0.05 s) early; the heading this shifts by that time is
    not an accumulating error (it is undone when the turn ends).

    A sample beyond any car's yaw rate (a logger's glitch, a CAN signal's invalid code:
    :func:`rwhonet.data.glitches.repaired_yaw_rate`) takes the rate interpolated across it.

    Args:
        t_s: per-row time, s.
        yaw_rate_rad_s: per-row yaw rate, rad/s, left turns positive; None when the
            drive has no such channel.

    Returns:
        float64 rad per second (length ``n_seconds(len(t_s))``); NaN for every second
        without the channel and for a second with a missing (NaN) rate in its rows.
    """
    if yaw_rate_rad_s is None:
        return np.full(n_seconds(len(t_s)), np.nan)
    rate, _ = repaired_yaw_rate(t_s, np.asarray(yaw_rate_rad_s, dtype=np.float64))
    return integrate_per_second(t_s, rate)


def backwards_per_second(
    t_s: np.ndarray, omega_rl_rad_s: np.ndarray, omega_rr_rad_s: np.ndarray
) -> np.ndarray:
    """Seconds a logger that signs its wheel speeds recorded as driven backwards.

    Wheel speeds are magnitudes, as ABS sensors give them, and the pipeline takes
    them so; but a logger that signs them (validate lets four wheels negative
    together through: :func:`rwhonet.data.plausibility.reversing_rows`) also says
    which way the car went. A second is driven backwards when the rear wheels'
    signed mean angle over it (:func:`integrate_per_second`) is negative. The
    navigation filter then moves the car backwards through it (:mod:`rwhonet.nav.filter`,
    Reversing). A logger of magnitudes
    never gives one: its reverses are told by their turns alone.

    Args:
        t_s: per-row time, s.
        omega_rl_rad_s: the rear-left wheel's speed as logged (signed or not), rad/s.
        omega_rr_rad_s: the rear right's.

    Returns:
        bool per second (length ``n_seconds(len(t_s))``).
    """
    mean = 0.5 * (np.asarray(omega_rl_rad_s, np.float64) + np.asarray(omega_rr_rad_s, np.float64))
    with np.errstate(invalid="ignore"):
        return integrate_per_second(np.asarray(t_s, np.float64), mean) < 0.0


def wheel_features_rad_s(wheels_rad_s: Sequence[np.ndarray]) -> np.ndarray:
    """Stack the ten samples per second of each wheel into the 40 raw input features.

    Args:
        wheels_rad_s: per-row wheel speeds (rad/s) in feature order RR, RL, FR, FL
            (``canonical.FEATURE_WHEEL_ORDER``).

    Returns:
        float64 array ``(n_seconds, 40)``: columns ``10 w .. 10 w + 9`` are wheel
        ``w``'s samples, oldest first (the paper's input X_t, Sec. 2.3).
    """
    return np.concatenate(
        [rows_of_seconds(np.asarray(w, np.float64)) for w in wheels_rad_s], axis=1
    )


def _unique_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(unique_rows, inverse)`` of a 2-D integer array.

    Same result as ``np.unique(a, axis=0, return_inverse=True)``, faster: that
    sorts rows as opaque void records, this lexsorts the columns.
    """
    order = np.lexsort(a.T[::-1])
    ordered = a[order]
    starts = np.concatenate([[True], (ordered[1:] != ordered[:-1]).any(axis=1)])
    inverse = np.empty(len(a), dtype=np.int64)
    inverse[order] = np.cumsum(starts) - 1
    return ordered[starts], inverse


def _factorize_tags(
    row_tags: Sequence[str] | np.ndarray | pd.Series | pa.Array | pa.ChunkedArray,
) -> tuple[np.ndarray, list[str]]:
    """Return ``(codes, values)``: per row the index of its tag string, -1 when missing."""
    if isinstance(row_tags, pa.ChunkedArray):
        row_tags = row_tags.combine_chunks()  # dictionary chunks: onto one dictionary
    if isinstance(row_tags, pa.Array):  # a Parquet column read with pyarrow
        # Read as a dictionary, the codes come straight from the file; else encode in C++.
        encoded = (
            row_tags if isinstance(row_tags, pa.DictionaryArray) else row_tags.dictionary_encode()
        )
        codes = encoded.indices.fill_null(-1).to_numpy(zero_copy_only=False)
        return codes.astype(np.int64), [v or "" for v in encoded.dictionary.to_pylist()]
    import pandas as pd  # here, not at the top: `rwhonet predict` starts without it (0.4 s)

    # A Parquet string column read with pandas is Arrow-backed: factorize it as is.
    values = row_tags if isinstance(row_tags, pd.Series) else np.asarray(row_tags, dtype=object)
    codes, uniques = pd.factorize(values)
    return codes.astype(np.int64), [str(u) for u in uniques]


def scenario_per_second(
    row_tags: Sequence[str] | np.ndarray | pd.Series | pa.Array | pa.ChunkedArray,
) -> np.ndarray:
    """Merge the scenario tags of the ten rows each second owns.

    Args:
        row_tags: per-row ``;``-joined tags (``''`` or missing for none).

    Returns:
        object array of length ``n_seconds``: the sorted union of the rows' tags,
        ``;``-joined, ``''`` when none (so a second that touches a roundabout for
        a single row counts as a roundabout second).
    """
    codes, values = _factorize_tags(row_tags)
    tag_sets = [set(v.split(";")) - {""} for v in values]  # per distinct row value
    per_second = rows_of_seconds(codes)  # code -1: missing tag
    if per_second.shape[0] == 0:
        return np.empty(0, dtype=object)
    # Tag strings differ only between distinct combinations of row values, and a
    # drive has few of those: merge once per combination, then map back.
    if len(values) < 63:
        # A combination as a bit mask over the row values (bit k: some row has value k).
        import pandas as pd

        bit = np.where(per_second >= 0, np.int64(1) << np.maximum(per_second, 0), 0)
        inverse, masks = pd.factorize(np.bitwise_or.reduce(bit, axis=1))
        combos = [np.flatnonzero((int(m) >> np.arange(len(values))) & 1) for m in masks]
    else:
        unique_rows, inverse = _unique_rows(np.sort(per_second, axis=1))
        combos = [combo[combo >= 0] for combo in unique_rows]
    merged = np.array(
        [";".join(sorted(set().union(*(tag_sets[k] for k in combo)))) for combo in combos],
        dtype=object,
    )
    return merged[inverse]


@dataclass(frozen=True)
class SegmentSeconds:
    """The raw (unscaled, uncalibrated) per-second quantities of one segment.

    Attributes:
        t_s: end time of each second (row ``10k + 10``; its slot's instant when the
            stamps are jittered, :func:`rwhonet.data.timebase.label_times`), seconds.
        span_s: duration of each second, seconds.
        disp_gnss_m: GNSS displacement per second, metres.
        lat_deg: GNSS latitude of the fix ending each second (row ``10k + 10``), degrees.
        lon_deg: its longitude, degrees.
        angle_rl_rad: trapezoid-integrated rear-left wheel angle per second, rad.
        angle_rr_rad: same for the rear right wheel.
        omega_end_rl_rad_s: rear-left wheel speed at the end of each second (authors' sample).
        omega_end_rr_rad_s: same for the rear right wheel.
        gyro_yaw_rad: the yaw-rate gyro's angle over each second (left turns
            positive), rad; NaN where the drive has no yaw rate.
        backwards: seconds a logger that signs its wheel speeds recorded as driven
            backwards (:func:`backwards_per_second`; a magnitude logger: none).
        wheels_rad_s: ``(n, 40)`` raw wheel-speed features, rad/s.
        scenario: merged scenario tags per second.
        n_rows: rows in the segment.
    """

    t_s: np.ndarray
    span_s: np.ndarray
    disp_gnss_m: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    angle_rl_rad: np.ndarray
    angle_rr_rad: np.ndarray
    omega_end_rl_rad_s: np.ndarray
    omega_end_rr_rad_s: np.ndarray
    gyro_yaw_rad: np.ndarray
    backwards: np.ndarray
    wheels_rad_s: np.ndarray
    scenario: np.ndarray
    n_rows: int

    def __len__(self) -> int:
        return len(self.t_s)


def segment_arrays(table: pa.Table) -> dict[str, np.ndarray | pa.ChunkedArray]:
    """The columns of a segment (an Arrow table) the per-second computation takes.

    Args:
        table: a segment in canonical columns (validate's output, or a slice of a drive).

    Returns:
        ``t_s, lat_deg, lon_deg, omega_*`` and, where present, ``yaw_rate_rad_s`` as
        float64 numpy arrays (wheel speeds as logged, signed or not; missing values
        NaN) and ``scenario`` as it is (Arrow), for :func:`segment_seconds`.
    """
    return {
        name: table[name] if name == c.SCENARIO else np.asarray(table[name], dtype=np.float64)
        for name in table.column_names
        if name in SEGMENT_COLUMNS
    }


def check_segment(frame: Mapping[str, ArrayLike], file: str, t_s: np.ndarray | None = None) -> None:
    """Check what the per-second computation relies on; raise one report of all problems.

    Args:
        frame: a segment in canonical columns: a DataFrame, or a mapping of column name to
            array (what the label stage's ``read_segment`` returns).
        file: the segment's file name, for the report.
        t_s: its times as the per-second computation takes them (:func:`_placed`; None:
            placed here).

    Raises:
        InputError: missing columns, non-finite values, a latitude out of range,
            time not strictly increasing, or ten rows not spanning about one second.
    """
    missing = [col for col in c.REQUIRED if col not in frame]
    if missing:
        raise InputError(
            [Problem(file, None, col, "a canonical column", "missing") for col in missing]
        )
    problems: list[Problem] = []
    for col in c.REQUIRED:
        values = np.asarray(frame[col], dtype=np.float64)
        bad = np.flatnonzero(~np.isfinite(values))
        problems += [
            Problem(file, int(i) + 1, col, "a finite number", repr(values[i]))
            for i in bad[:_MAX_PROBLEMS_PER_CHECK]
        ]
    lat = np.asarray(frame[c.LAT_DEG], dtype=np.float64)
    problems += [
        Problem(file, int(i) + 1, c.LAT_DEG, "a latitude in [-90, 90] deg", repr(lat[i]))
        for i in np.flatnonzero(np.abs(lat) > 90.0)[:_MAX_PROBLEMS_PER_CHECK]
    ]
    # jittered stamps in order by their slots, as they are used (placed by the caller, or
    # here where every time is finite)
    t = _placed(frame) if t_s is None else t_s
    back = np.flatnonzero(np.diff(t) <= 0)
    problems += [
        Problem(file, int(i) + 2, c.T_S, f"time after the previous row's {t[i]!r}", repr(t[i + 1]))
        for i in back[:_MAX_PROBLEMS_PER_CHECK]
    ]
    if not problems:
        spans = span_s(t)
        off = np.flatnonzero(np.abs(spans - 1.0) > SPAN_TOLERANCE_S)
        problems += [
            Problem(
                file,
                int(k) * ROWS_PER_SECOND + 1,
                c.T_S,
                f"{ROWS_PER_SECOND} rows spanning 1 +/- {SPAN_TOLERANCE_S} s (10 Hz data)",
                f"{spans[k]:.3f} s to row {int(k + 1) * ROWS_PER_SECOND + 1}",
            )
            for k in off[:_MAX_PROBLEMS_PER_CHECK]
        ]
    if problems:
        raise InputError(problems, f"segment {file} cannot be cut into 10 Hz seconds")


def _placed(frame: Mapping[str, ArrayLike]) -> np.ndarray:
    """A segment's times at their slots' instants (:func:`rwhonet.data.timebase.label_times`)
    where every time is finite; else as they are (the check names those that are not)."""
    t = np.asarray(frame[c.T_S], dtype=np.float64)
    return label_times(t, 1.0 / ROWS_PER_SECOND) if np.isfinite(t).all() else t


def segment_seconds(frame: Mapping[str, ArrayLike], file: str = "<segment>") -> SegmentSeconds:
    """Compute the raw per-second quantities of one segment.

    Args:
        frame: a segment in canonical columns (``rwhonet.data.canonical``), rows at 10 Hz:
            a DataFrame, or a mapping of column name to array (numpy, or Arrow for
            ``scenario``); the ``scenario`` and ``yaw_rate_rad_s`` columns are optional.
        file: the segment's file name, for error reports.

    Returns:
        The segment's per-second quantities (empty when it has fewer than 11 rows).

    Raises:
        InputError: see :func:`check_segment`.
    """
    # Jittered stamps are taken at their slots' instants (rwhonet.data.timebase): the samples
    # were taken there, the stamps only say when the logger wrote them. A clean drive's
    # stamps are kept as they are.
    t = _placed(frame) if c.T_S in frame else None
    check_segment(frame, file, t)  # a missing column, named there
    assert t is not None
    # Wheel speeds are magnitudes; validate lets negative ones through only where a logger
    # that signs its speeds recorded reversing (all four wheels together), which says
    # which way the car went (the navigation filter's, not the distance's).
    signed = {w: np.asarray(frame[w], dtype=np.float64) for w in c.WHEELS}
    omega = {w: np.abs(v) for w, v in signed.items()}
    tags = frame[c.SCENARIO] if c.SCENARIO in frame else np.full(t.size, "")
    lat = np.asarray(frame[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(frame[c.LON_DEG], dtype=np.float64)
    return SegmentSeconds(
        t_s=end_of_second(t),
        span_s=span_s(t),
        disp_gnss_m=gnss_displacement_m(lat, lon),
        lat_deg=end_of_second(lat),
        lon_deg=end_of_second(lon),
        angle_rl_rad=integrate_per_second(t, omega[c.OMEGA_RL]),
        angle_rr_rad=integrate_per_second(t, omega[c.OMEGA_RR]),
        omega_end_rl_rad_s=end_of_second(omega[c.OMEGA_RL]),
        omega_end_rr_rad_s=end_of_second(omega[c.OMEGA_RR]),
        gyro_yaw_rad=gyro_yaw_rad(t, frame.get(c.YAW_RATE_RAD_S)),
        backwards=backwards_per_second(t, signed[c.OMEGA_RL], signed[c.OMEGA_RR]),
        wheels_rad_s=wheel_features_rad_s([omega[w] for w in c.FEATURE_WHEEL_ORDER]),
        scenario=scenario_per_second(tags),
        n_rows=t.size,
    )
