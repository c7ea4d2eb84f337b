"""Fixes a 10 Hz file holds from a slower receiver: found, and placed along the wheels' path.

(The same for a logger that writes the receiver's fix only into the row it came in and
leaves the cells between empty: each empty row was "no fix", and a 1 Hz receiver's drive
was cut whole. An empty row counts as holding no new fix below, and ``empty_between``
says which layout a file has.)

A logger that writes a fixed-rate table (one row every 0.1 s) while its receiver gives a
fix once a second (or five times) writes the last fix it has into every row until the
next comes: the latitude and longitude stay the same for ten rows (or two) while the
wheels turn, then jump. Read as they are, the position at a whole second is the fix
from up to 0.9 s before it, so a second's GNSS displacement, the label the models
learn from and the truth they are scored against, is the car's travel over another
second: on the built-in target drive V-Charlie3 written with 1 Hz fixes held (the
receiver's fix arriving 0.1-0.9 s after the whole second), the per-second GNSS
displacement moved by 0.08-0.68 m RMS (up to 5.5 m), against labels of about 5 cm RMS;
validate's ``frozen`` rule (``validate.gnss.frozen_min_s``, 2 s) does not see a fix held
for 0.9 s, and the radius check over 30 s does not either. And ``rwhonet predict``'s
filter was updated ten times a second by a fix up to 0.9 s old.

:func:`held_fixes` finds such a file: among the rows where the rear wheels turn faster
than :data:`MOVING_RAD_S` (about 3 m/s: a 10 Hz receiver's fix moves 0.3 m a row, far
beyond any logged coordinate's resolution), at least :data:`HELD_SHARE` of them hold no
new fix, and the fixes change at one period of whole rows (at least :data:`REGULAR_SHARE`
of the changes while moving within a row of ``k >= 2`` rows apart, their mean within
:data:`MEAN_OFF` rows of ``k``: a fix reaching the logger near a row's boundary lands a
row early or late now and then; a coordinate written with too few decimals changes at
intervals that follow the speed instead). The receiver's fixes are then the rows where
the fix changed, and while the car stands, every ``k``-th row of the run (a receiver
repeats its fix when the car does not move); held, the first row's fix came before the
log began and is left out. Each is taken at the receiver's regular epoch
(:func:`receiver_epochs_of`), not at its row's time, which a fix landing a row late
would put 0.1 s off the others.

:func:`place_held_fixes` puts the position of every row back from those fixes, as the
stream resampler places a slower receiver's fixes on the 10 Hz grid
(:func:`rwhonet.data.streams.interpolate_fixes`): along the path the wheels and the gyro
trace between two fixes (docs/readers.md, "Positions"), linearly in time where the path
cannot tell; the other GNSS channels (satellites, course, speed, height) linearly, as
there. The wheel speeds and every other channel stay the file's, row for row. Rows
before the first fix or after the last, or between fixes further apart than the
resampler interpolates across, have no fix (empty), which validate's GNSS policy cuts
as it cuts an empty fix. Measured on V-Charlie3 with 1 Hz fixes held at 0.3 s past the
second: positions within 1.8 cm RMS of its own 10 Hz fixes, per-second displacements
within 1.3 cm RMS.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.streams import default_fix_gap_s, interpolate_fixes, travelled_path

# The rear wheels' mean speed above which a row counts as moving for the test, rad/s
# (about 3 m/s on a 0.3 m tyre: 0.3 m between 10 Hz rows).
MOVING_RAD_S = 10.0
# Below this rear wheels' speed the car stands (0.15 m/s on a 0.3 m tyre): an unchanged
# fix each period is then the receiver's, repeated.
STANDING_RAD_S = 0.5
# Moving rows (with a fix in them and the row before) needed to tell: 30 s at 10 Hz.
MIN_MOVING_ROWS = 300
# The share of moving rows whose fix equals the row before's from which the fixes are held
# (a 5 Hz receiver held: 0.5; 1 Hz: 0.9; a 10 Hz receiver: about 0).
HELD_SHARE = 0.4
# The share of the changes while moving that must lie within a row of the period apart,
# and how far (rows) their mean may lie off it.
REGULAR_SHARE = 0.8
MEAN_OFF = 0.2
# The rows ``rwhonet predict`` holds back at most to tell (5 min at 10 Hz); a drive still
# undecided then (parked, or no fix yet) is handed on as it came.
HOLD_ROWS = 3000


@dataclass(frozen=True)
class HeldFixes:
    """A file's fixes held from a slower receiver (:func:`held_fixes`).

    Attributes:
        period_rows: the receiver's period in rows (10: a 1 Hz receiver in a 10 Hz file).
        fresh: the rows (0-based) holding a new fix of the receiver.
        held_share: the share of moving rows without a new fix (the row before's, or none).
        moving_rows: the moving rows the test looked at.
        empty_between: the rows between the receiver's fixes are mostly empty rather than
            holding the last fix (a logger that writes a fix only in the row it came in).
    """

    period_rows: int
    fresh: np.ndarray
    held_share: float
    moving_rows: int
    empty_between: bool = False


@np.errstate(invalid="ignore", over="ignore")  # inf - inf in a corrupt row: NaN, not a warning
def _rear_speed(columns: dict[str, np.ndarray]) -> np.ndarray:
    return 0.5 * np.abs(columns[c.OMEGA_RL] + columns[c.OMEGA_RR])


def held_fixes(columns: dict[str, np.ndarray]) -> HeldFixes | None:
    """Whether a 10 Hz drive's fixes are held from a slower receiver, and its fixes.

    Args:
        columns: the drive's channels (canonical names), one element per row.

    Returns:
        The receiver's period and fixes, or None: the fixes are the rows' own (or too few
        moving rows to tell).
    """
    return tell_held(columns)[1]


def tell_held(columns: dict[str, np.ndarray]) -> tuple[bool, HeldFixes | None]:
    """:func:`held_fixes`, and whether the rows were enough to tell (False: fewer than
    :data:`MIN_MOVING_ROWS` moving rows, or too few changes of the fix among them)."""
    lat, lon = columns[c.LAT_DEG], columns[c.LON_DEG]
    n = lat.size
    if n < 2:
        return False, None
    has = np.isfinite(lat) & np.isfinite(lon)
    # a fix that repeats the row before's (held); a row without one is no new fix either
    # (a logger that leaves the cells empty between the receiver's fixes)
    repeat = has & np.r_[False, has[:-1] & (lat[1:] == lat[:-1]) & (lon[1:] == lon[:-1])]
    fast = _rear_speed(columns) > MOVING_RAD_S
    moving = fast & np.r_[False, fast[:-1]]
    n_moving = int(moving.sum())
    if n_moving < MIN_MOVING_ROWS:
        return False, None
    old = ~has[moving] | repeat[moving]
    share = float(old.mean())
    if share < HELD_SHARE:
        return True, None
    change = np.flatnonzero(has & ~repeat)
    gaps = np.diff(change)[moving[change[1:]]]  # changes while moving: rows since the last
    if gaps.size < 2:
        return False, None
    k = int(np.bincount(gaps).argmax())
    # A fix that reaches the logger near a row's boundary lands a row early or late now
    # and then (9 or 11 rows after the last about a 1 Hz receiver's 10): the changes lie
    # within a row of the period, their mean on it. A coordinate written too coarsely
    # changes at intervals that follow the speed, their mean off any whole row.
    near = np.abs(gaps - k) <= 1
    if k < 2 or float(np.mean(near)) < REGULAR_SHARE or abs(np.mean(gaps[near]) - k) > MEAN_OFF:
        return True, None
    rows = np.arange(n)
    last_change = np.maximum.accumulate(np.where(~repeat, rows, 0))
    # standing: the receiver repeats its fix each period; moving, an unchanged fix is old
    standing = _rear_speed(columns) < STANDING_RAD_S
    fresh = has & (~repeat | (standing & ((rows - last_change) % k == 0)))
    empty_between = bool((~has[moving]).sum() > repeat[moving].sum())
    if not empty_between:
        fresh[0] = False  # held: the first row's fix came before the log began, when unknown
    return True, HeldFixes(k, np.flatnonzero(fresh), share, n_moving, empty_between)


def held_note(held: HeldFixes, period_s: float) -> str:
    """What a reader says of held fixes it placed."""
    hz = 1.0 / (held.period_rows * period_s)
    how = (
        "written only in the row it came in, the cells between empty"
        if held.empty_between
        else "held: written into every row until the next"
    )
    return (
        f"the fixes come from a {hz:.3g} Hz receiver, each {how} ({100 * held.held_share:.0f} % "
        f"of the {held.moving_rows} rows where the wheels turn hold no new fix, and a new one "
        f"comes every {held.period_rows} rows); each row's position is placed between the "
        f"receiver's {held.fresh.size} fixes along the wheels' "
        "path, as a slower GNSS stream's (rwhonet.data.heldfixes), rows outside them left "
        "without a fix"
    )


def receiver_epochs_of(t_s: np.ndarray, period_s: float, row_s: float) -> tuple[np.ndarray, float]:
    """The receiver's epochs of fixes stamped by the rows they reached the logger in.

    A fix lands in the first row after it reached the logger, so one that arrives near a
    row's boundary lands a row early or late now and then, its row's time ``row_s`` off
    the others' latency, and the second's displacement around it jumps by the car's
    travel in a row's time. In each run of fixes at most 1.5 periods apart, each fix's
    epoch count is its time over the period from the run's first, rounded; the epochs
    are the least-squares line through the times by count (the receiver's clock, drifting
    against the logger's or not; its offset, the mean latency), fitted again on the fixes
    within 1.5 rows of the first line (a row early or late, not a fix from before the log
    began). Those fixes take their epoch; the others, the
    fixes of a run whose counts repeat, and runs of fewer than three fixes keep their times.

    Returns:
        The times, and the most any was moved (s).
    """
    t = np.asarray(t_s, np.float64)
    out = t.copy()
    for run in np.split(np.arange(t.size), np.flatnonzero(np.diff(t) > 1.5 * period_s) + 1):
        if run.size < 3:
            continue
        count = np.round((t[run] - t[run[0]]) / period_s)
        if np.any(np.diff(count) < 1):
            continue
        line = np.polyfit(count, t[run], 1)
        inliers = np.abs(t[run] - np.polyval(line, count)) <= 1.5 * row_s
        if inliers.sum() < 3:
            continue
        line = np.polyfit(count[inliers], t[run][inliers], 1)
        epochs = np.polyval(line, count)
        ok = np.abs(t[run] - epochs) <= 1.5 * row_s
        out[run[ok]] = epochs[ok]
    return out, float(np.max(np.abs(out - t))) if t.size else 0.0


def place_held_fixes(raw: RawDrive, period_s: float = 0.1) -> RawDrive:
    """A 10 Hz drive whose held fixes are placed along the path (``raw`` itself if none).

    Args:
        raw: the drive as read (its copies and rows without a wheel speed dropped).
        period_s: the file's sample period (for the note's rate).

    Returns:
        The drive with every GNSS channel placed from the receiver's fixes, and a note.
    """
    held = held_fixes(raw.columns)
    if held is None:
        return raw
    cols = raw.columns
    t = cols[c.T_S]
    fresh = held.fresh
    gnss = {k: cols[k][fresh] for k in c.FIX_CHANNELS if k in cols}  # held with it, placed with it
    yaw = cols.get(c.YAW_RATE_RAD_S)
    gyro = yaw is not None and np.isfinite(yaw).any()
    path = travelled_path(
        t,
        [cols[c.OMEGA_RL], cols[c.OMEGA_RR]],
        yaw_t_s=t if gyro else None,
        yaw_rad_s=yaw if gyro else None,
    )
    t_fix, moved = receiver_epochs_of(t[fresh], held.period_rows * period_s, period_s)
    values, valid = interpolate_fixes(t_fix, gnss, t, default_fix_gap_s(t_fix), path)
    placed = {k: np.where(valid, values[k], np.nan) for k in gnss}
    notes = [held_note(held, period_s)]
    if moved > 1e-6:
        notes.append(
            "the receiver's fixes are taken at its regular epochs (the line through their "
            f"rows' times by epoch count), moved by at most {moved * 1000:.0f} ms (a fix "
            "that reached the logger a row early or late, or a row's jittered stamp)"
        )
    return replace(
        raw,
        columns=cols | placed,
        notes=(*raw.notes, *notes),
        held_fix_period_rows=held.period_rows,
    )


class HeldFixGate:
    """``rwhonet predict``'s rows as they arrive, their held fixes placed as ingest places them.

    The blocks ``(first_row, columns)`` (data rows ``first_row ..`` of the file, consecutive
    within a block) are held until :func:`tell_held` can tell, at most :data:`HOLD_ROWS`
    rows. A drive whose fixes are its rows' own is then handed on as it came, block for
    block. One whose fixes are held is read to its end (placing a row needs the receiver's
    next fix), its fixes placed (:func:`place_held_fixes`), and handed on in blocks that
    keep the file's rows. ``note`` says what was done (None: nothing).
    """

    def __init__(self, period_s: float = 0.1, rows: int = 600) -> None:
        self.period_s = period_s
        self.rows = rows
        self.note: str | None = None

    def blocks(
        self, blocks: Iterable[tuple[int, dict[str, np.ndarray]]]
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """The blocks, their fixes placed where they are held."""
        blocks = iter(blocks)
        held: list[tuple[int, dict[str, np.ndarray]]] = []
        n = 0
        for first, columns in blocks:
            held.append((first, columns))
            n += len(columns[c.T_S])
            told, found = tell_held(_joined([b for _, b in held]))
            if found is not None:
                held.extend(blocks)  # to the end: each row's place needs the next fix
                yield from self._placed(held)
                return
            if told or n >= HOLD_ROWS:
                break
        yield from held
        yield from blocks

    def _placed(
        self, held: list[tuple[int, dict[str, np.ndarray]]]
    ) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        held = [(f, b) for f, b in held if len(b[c.T_S])]
        columns = _joined([b for _, b in held])
        file_row = np.concatenate([f + np.arange(len(b[c.T_S])) for f, b in held])
        raw = place_held_fixes(RawDrive(columns, {}, "stream"), self.period_s)
        self.note = "; ".join(raw.notes) or None  # the held fixes, and their epochs
        n = file_row.size
        starts = np.union1d(np.arange(0, n, self.rows), np.flatnonzero(np.diff(file_row) != 1) + 1)
        bounds = np.r_[starts, n]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            yield int(file_row[a]), {k: v[a:b] for k, v in raw.columns.items()}


def _joined(blocks: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    if len(blocks) == 1:
        return blocks[0]
    return {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}
