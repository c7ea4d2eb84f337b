"""Pandera schema of a canonical drive, and its failures as :class:`Problem` entries.

The schema is built from ``params.yaml: validate`` (ranges and sample period are
parameters). Validation is lazy so one run reports every failing check, and
``SchemaErrors.failure_cases`` (one row per failing cell, possibly millions) is
turned into a short list of problems: per column and check, the first few rows
(numbered as in the source file) and a count of the rest.

Several drives can be validated in one pandera call, stacked in one frame
(:func:`schema_problems_batch`): pandera's fixed cost is about half a millisecond
per column and call, which for 48 drives of 16 columns was most of the
validation time. The checks that compare a row with the previous one (time
steps) never pair rows of different drives, the median time step is taken per
drive, and every failure is reported in its own drive's file and rows, exactly
as if each drive had been validated alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pandera.pandas as pa
from pandera.errors import SchemaErrors

from rwhonet.config import ValidateParams
from rwhonet.data import canonical as c
from rwhonet.data.droprows import FileRows
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.data.timebase import run_slots
from rwhonet.errors import Problem

# Float noise on decimal time stamps (45123.1 - 45123.0 = 0.10000000000291) must not fail a
# step that is exactly at the tolerance.
_STEP_SLACK_S = 1e-9
# A median step this many times the period: the time written in another unit than seconds.
_TIME_UNITS = {round(1.0 / f): unit for unit, f in c.TIME_UNITS.items() if f < 1.0}


@dataclass(frozen=True)
class _Explain:
    """How to word one check's failures: what was expected, what was found, what to do."""

    expected: str
    # (the drive, its 0-based row, the failing value, the file's numbering of its rows)
    found: Callable[[pd.DataFrame, int, object, FileRows], str]
    fix: str | None = None


def _num(x: object) -> str:
    """A cell as the user wrote it: plain Python repr, not ``np.float64(...)``."""
    return repr(x.item()) if isinstance(x, np.generic) else repr(x)


def _value(df: pd.DataFrame, i: int, case: object, rows: FileRows) -> str:
    return _num(case)


def _time_step(df: pd.DataFrame, i: int, case: object, rows: FileRows) -> str:
    t = df[c.T_S].to_numpy()
    said = (
        f"t = {_num(t[i])} s after t = {_num(t[i - 1])} s in row {rows(i - 1)} "
        f"(step {t[i] - t[i - 1]:+.6g} s)"
    )
    if (header := rows.header_between(i)) is not None and t[i] <= t[i - 1]:
        said += (
            f", the header's line again in row {header} between them: a logger whose clock "
            f"started again, or two drives joined (split the file at row {header}, one "
            "drive each)"
        )
    return said


def _jitter_hint(df: pd.DataFrame, i: int, period: float) -> str:
    """What a step back of under half a sample says: stamps jittered past what the rows'
    order places (:func:`rwhonet.data.timebase.run_slots`)."""
    t = df[c.T_S].to_numpy()
    if not 0 < t[i - 1] - t[i] < 0.5 * period:
        return ""
    return (
        "; a step back of under half a sample is the stamps' jitter, here too wide for each "
        "row to be placed within reach of its stamp (a bell curve's of up to about "
        f"{0.2 * period:.3g} s is): stamp each row when its sample is taken, not when it "
        "is written"
    )


def _drive_checks(
    vp: ValidateParams, drive_starts: np.ndarray | None = None
) -> dict[str, tuple[pa.Check, _Explain]]:
    """Named checks of the schema with the words used to report their failures.

    Args:
        vp: the ``validate`` section.
        drive_starts: first row of each drive when several are stacked in one frame with a
            RangeIndex (None: one drive).
    """
    period, tol, gap = vp.sample_period_s, vp.sample_period_tol_s, vp.gnss.max_gap_s
    w_max = vp.max_abs_wheel_speed_rad_s
    starts = np.zeros(1, np.int64) if drive_starts is None else np.asarray(drive_starts, np.int64)

    def first_rows(s: pd.Series) -> np.ndarray:
        # Position in s of each drive's first row. From the index, not the position:
        # pandera drops the NaN rows of a column before running a check on it (ignore_na),
        # so positions in s are not rows of the frame; a drive whose first rows were
        # dropped starts at its first row left.
        return np.searchsorted(s.index.to_numpy(), starts)

    def step(s: pd.Series) -> pd.Series:
        t = s.to_numpy(np.float64)
        d = np.full(t.size, np.nan)
        d[1:] = t[1:] - t[:-1]
        first = first_rows(s)
        d[first[first < t.size]] = np.nan  # a drive's first row has no previous row
        return pd.Series(d, index=s.index)

    def slot_step(s: pd.Series) -> np.ndarray:
        # Each row's slot on its drive's sample grid less the previous row's
        # (rwhonet.data.timebase.grid_slots: stamps jittered by up to half a period sit in
        # their own slots, rows jittered further are given rising ones where that keeps
        # each within a period of its stamp; a row after a dropped sample skips one). One
        # phase per run of a drive (timebase.run_slots: a logger's restart starts a run),
        # not per row; NaN at a drive's first row and beside a time that is not finite.
        t = s.to_numpy(np.float64)
        slot = np.full(t.size, np.nan)
        bounds = np.r_[first_rows(s), t.size]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            finite = np.flatnonzero(np.isfinite(t[a:b])) + a
            if finite.size:
                slot[finite] = run_slots(t[finite], period)[0]
        out = np.full(t.size, np.nan)
        out[1:] = slot[1:] - slot[:-1]
        first = first_rows(s)
        out[first[first < t.size]] = np.nan
        return out

    def next_slot(s: pd.Series) -> np.ndarray:
        return slot_step(s) == 1

    def in_order(s: pd.Series, ok: pd.Series) -> pd.Series:
        # a step the stamps' jitter turned back (or to none) is in order where the row
        # still has a slot after the previous row's (the slots placed only where needed)
        if ok.all():
            return ok
        return ok | pd.Series(slot_step(s) >= 1, index=s.index)

    def regular(s: pd.Series) -> pd.Series:
        d = step(s)
        # Non-positive steps are reported by the two time-order checks, NaN ones by not_nullable;
        # a step longer than max_gap_s is a gap, which the GNSS policy splits the drive at; a
        # longer step up to it skips a slot of the grid (a dropped sample: the GNSS policy
        # cuts its second, partial_second, and the drive is split there too). What is left
        # to refuse is a step too short for the grid (a sample too many, an irregular clock).
        steady = (d - period).abs() <= tol + _STEP_SLACK_S
        dropped = d > period + tol + _STEP_SLACK_S
        return d.isna() | (d <= 0) | steady | next_slot(s) | dropped

    def median_period(s: pd.Series) -> pd.Series:
        # One verdict per drive, put on its first row (reported without a row: _DRIVE_WIDE).
        # The check sees every row (ignore_na=False): the steps are those between the
        # drive's non-missing times, as a one-drive check given the NaN-free column took them.
        t = s.to_numpy(np.float64)
        ok = np.ones(t.size, dtype=bool)
        bounds = np.r_[first_rows(s), t.size]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):  # per drive, not per row
            if a == b:
                continue
            steps = np.diff(t[a:b][~np.isnan(t[a:b])])
            steps = steps[~np.isnan(steps)]  # inf - inf
            ok[a] = steps.size == 0 or abs(float(np.median(steps)) - period) <= tol
        return pd.Series(ok, index=s.index)

    def median_found(df: pd.DataFrame, i: int, case: object, rows: FileRows) -> str:
        median = float(df[c.T_S].diff().median())
        hint = ""
        scale = next((k for k in _TIME_UNITS if abs(median / k - period) <= tol), None)
        if scale is not None:
            hint = f"; time in {_TIME_UNITS[scale]} instead of s?"
        elif median > 0 and np.isfinite(median):
            hint = f": the drive is sampled at {1.0 / median:.3g} Hz, not {1.0 / period:.3g} Hz"
        return f"median step {median:.6g} s{hint}"

    increasing = "a time after the previous row's (time strictly increasing)"
    checks = {
        "time_finite": (
            pa.Check(lambda s: np.isfinite(s), name="time_finite"),
            _Explain(
                "a finite time in seconds",
                _value,
                "give every row its time in seconds (fill the cell or delete the row)",
            ),
        ),
        "time_not_repeated": (
            pa.Check(lambda s: in_order(s, step(s) != 0), name="time_not_repeated"),
            _Explain(
                increasing,
                lambda df, i, case, rows: f"t = {_num(case)} s again (as in row {rows(i - 1)})",
                "two samples at one time, their values not the same (an exact copy of the "
                "row before is dropped at ingest): a clock that stuck, or stamps rounded "
                "too coarsely (stamps to the second, every one holding its second's rows "
                "and most all of them, are placed at ingest); delete one of the two rows, "
                "or re-export the drive with finer time stamps",
            ),
        ),
        "time_not_backwards": (
            pa.Check(lambda s: in_order(s, ~(step(s) < 0)), name="time_not_backwards"),
            _Explain(
                increasing,
                lambda df, i, case, rows: (
                    "time goes backwards: "
                    + _time_step(df, i, case, rows)
                    + _jitter_hint(df, i, period)
                ),
                "sort the rows by time, or split the file into one drive per recording where "
                "the clock restarts (a clock set back while the car drove on is put right at "
                "ingest where 20 rows either side run on a period apart and a fix within 10 "
                "rows either side shows the car going on); a clock set back an hour is "
                "summer time ending: write the times in UTC or with their zone offset "
                "(ISO 8601, +01:00)",
            ),
        ),
        "sample_period": (
            pa.Check(regular, name="sample_period"),
            _Explain(
                f"a step of {period} ± {tol} s from the previous row (validate.sample_period_s), "
                f"or the next slot of the drive's {period} s grid (time stamps jittered by "
                f"less than half a sample), or a longer one (a dropped sample, whose second is "
                f"cut; a gap > {gap} s, validate.gnss.max_gap_s: the drive is split there)",
                _time_step,
                f"the pipeline needs one row every {period} s: re-export the drive at "
                f"{1.0 / period:.3g} Hz; where the logger wrote a sample twice or off its "
                "clock, delete that row",
            ),
        ),
        "median_sample_period": (
            # ignore_na=False: the verdict sits on a drive's first row, even a NaN one.
            pa.Check(median_period, name="median_sample_period", ignore_na=False),
            _Explain(
                f"a median step of {period} ± {tol} s (validate.sample_period_s)",
                median_found,
                f"resample the drive to {1.0 / period:.3g} Hz and give its time in seconds (a "
                "column map can read ms: unit ms)",
            ),
        ),
        "latitude_range": (
            pa.Check(lambda s: s.between(-90.0, 90.0), name="latitude_range"),
            _Explain(
                "a latitude in [-90, 90] deg",
                _value,
                "give the latitude in decimal degrees in this column (not swapped with the "
                "longitude, not in radians or degrees-minutes); delete corrupt rows",
            ),
        ),
        "longitude_range": (
            pa.Check(lambda s: s.between(-180.0, 180.0), name="longitude_range"),
            _Explain(
                "a longitude in [-180, 180] deg",
                _value,
                "give the longitude in decimal degrees in this column (not swapped with the "
                "latitude, not in radians or degrees-minutes); delete corrupt rows",
            ),
        ),
        "wheel_speed_range": (
            pa.Check(lambda s: s.abs() < w_max, name="wheel_speed_range"),
            _Explain(
                f"|wheel speed| < {w_max} rad/s (validate.max_abs_wheel_speed_rad_s)",
                _value,
                "give wheel speeds in rad/s (a column map can read rpm or deg/s) and delete "
                "corrupt rows",
            ),
        ),
        "satellites_non_negative": (
            pa.Check(lambda s: s >= 0, name="satellites_non_negative"),
            _Explain("a satellite count >= 0", _value, "check the export of the satellite column"),
        ),
        "accuracy_non_negative": (
            pa.Check(lambda s: s >= 0, name="accuracy_non_negative"),
            _Explain(
                "a stated horizontal accuracy >= 0 m",
                _value,
                "check the accuracy column's unit and scale in the map",
            ),
        ),
    }
    return checks


# Checks about a whole drive: one problem per failing drive, without a row.
_DRIVE_WIDE = ("median_sample_period",)

# What pandera's own checks report, worded for a user.
_BUILTIN = {
    "not_nullable": _Explain(
        "a value (this channel is required)",
        lambda df, i, case, rows: "no value (empty or NaN)",
        "fill the empty cells, or delete the rows (a gap longer than validate.gnss.max_gap_s "
        "splits the drive there)",
    ),
    "column_in_dataframe": _Explain(
        "this required channel", lambda df, i, case, rows: "no such column"
    ),
    "column_in_schema": _Explain(
        f"only the canonical columns ({', '.join((*c.REQUIRED, *c.OPTIONAL, c.SCENARIO))})",
        lambda df, i, case, rows: f"column {case!r}",
    ),
}


def drive_schema(vp: ValidateParams, drive_starts: np.ndarray | None = None) -> pa.DataFrameSchema:
    """Build the pandera schema of a canonical drive from the validate parameters.

    Required channels must be present and complete (no NaN); latitude and longitude in
    range; |wheel speed| below ``max_abs_wheel_speed_rad_s``; time finite, strictly
    increasing, every step ``sample_period_s ± sample_period_tol_s``, or into the next slot
    of the drive's sample grid (stamps jittered by less than half a period,
    :mod:`rwhonet.data.timebase`), or longer (a dropped sample, whose second the GNSS policy
    cuts as ``partial_second``; a gap longer than ``gnss.max_gap_s``, where it splits the
    drive); and the median step near the nominal period (catches time in ms). A step too
    short for the grid (a sample written twice, an irregular clock) fails.

    Args:
        vp: the ``validate`` section.
        drive_starts: for several drives stacked in one frame (same columns), the first row
            of each; the time-step checks then never pair rows of different drives. None
            for one drive.

    Returns:
        The schema (strict: columns other than the canonical ones are an error).
    """
    checks = _drive_checks(vp, drive_starts)

    def pick(*names: str) -> list[pa.Check]:
        return [checks[n][0] for n in names]

    columns = {
        c.T_S: pa.Column(
            float,
            pick(
                "time_finite",
                "time_not_repeated",
                "time_not_backwards",
                # The drive-wide verdict first: at 5 Hz or in ms every row fails the next.
                "median_sample_period",
                "sample_period",
            ),
        ),
        # an empty fix is no fix (as (0, 0) is): the GNSS policy cuts its seconds (low_sats,
        # rwhonet.data.fixes.no_fix_rows), as rwhonet predict takes it as a row without one
        c.LAT_DEG: pa.Column(float, pick("latitude_range"), nullable=True),
        c.LON_DEG: pa.Column(float, pick("longitude_range"), nullable=True),
        **{w: pa.Column(float, pick("wheel_speed_range")) for w in c.WHEELS},
        c.N_SATS: pa.Column(float, pick("satellites_non_negative"), nullable=True, required=False),
        c.H_ACC_M: pa.Column(float, pick("accuracy_non_negative"), nullable=True, required=False),
        **{
            name: pa.Column(float, nullable=True, required=False)
            for name in c.OPTIONAL
            if name not in (c.N_SATS, c.H_ACC_M)
        },
        c.SCENARIO: pa.Column(str),
    }
    return pa.DataFrameSchema(columns, strict=True, coerce=False, name="canonical_drive")


def schema_problems(
    df: pd.DataFrame,
    vp: ValidateParams,
    source_file: str,
    source_columns: Mapping[str, str],
    file_rows: FileRows | None = None,
) -> list[Problem]:
    """Validate a canonical drive and describe every failure in the source file's terms.

    Args:
        df: the canonical drive (row ``i`` is data row ``i + 1`` of the source file, unless
            rows written twice were dropped: ``file_rows``).
        vp: the ``validate`` section.
        source_file: the drive's source file, as the user knows it.
        source_columns: canonical name -> the file's column name (from the ingest manifest).
        file_rows: the file's row of each of ``df``'s (None: row ``i`` is data row ``i + 1``).

    Returns:
        Problems (empty when the drive is valid): per column and check, the first
        ``ROWS_LISTED`` failing rows and a summary of the rest.
    """
    rows = None if file_rows is None else [file_rows]
    return schema_problems_batch(df, [0], vp, [source_file], [source_columns], rows)[0]


@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def schema_problems_batch(
    df: pd.DataFrame,
    drive_starts: Sequence[int] | np.ndarray,
    vp: ValidateParams,
    source_files: Sequence[str],
    source_columns: Sequence[Mapping[str, str]],
    file_rows: Sequence[FileRows] | None = None,
) -> list[list[Problem]]:
    """Validate drives stacked in one frame in one pandera call; report per drive.

    Each drive gets the problems :func:`schema_problems` gives it alone, in the same order.
    Arithmetic on the bad values the checks are there to catch (inf - inf in a time
    step) warns nothing: the problems say it.

    Args:
        df: the drives' rows one after the other, all with the same columns and dtypes
            (row ``drive_starts[k] + i`` is data row ``i + 1`` of drive ``k``'s file).
        drive_starts: first row of each drive in ``df``, increasing, starting at 0.
        vp: the ``validate`` section.
        source_files: each drive's source file, as the user knows it.
        source_columns: each drive's map canonical name -> the file's column name.
        file_rows: each drive's numbering of its rows in its file (rows written twice were
            dropped: :mod:`rwhonet.data.droprows`); None: row ``i`` is data row ``i + 1``.

    Returns:
        Per drive, its problems (empty when it is valid).
    """
    starts = np.asarray(drive_starts, dtype=np.int64)
    stops = np.r_[starts[1:], len(df)]
    df = df.reset_index(drop=True)  # failure indices are then positions in the stack
    try:
        # inplace: the schema does not coerce, so nothing is written to df, and pandera's
        # defensive copy of the whole frame (a third of the validation time) is saved.
        drive_schema(vp, starts).validate(df, lazy=True, inplace=True)
    except SchemaErrors as err:
        cases = err.failure_cases
    else:
        return [[] for _ in starts]
    explain = {name: how for name, (_, how) in _drive_checks(vp).items()} | _BUILTIN
    problems: list[list[Problem]] = [[] for _ in starts]
    numbering = list(file_rows) if file_rows is not None else [FileRows() for _ in starts]

    def drive(k: int) -> pd.DataFrame:
        return df.iloc[starts[k] : stops[k]]

    def column_name(k: int, column: object) -> str | None:
        # Table-wide failures have no column (None or NaN, depending on pandas).
        return source_columns[k].get(column, column) if isinstance(column, str) else None

    # One group per (column, check), in the order pandera found them.
    groups = cases.groupby(["column", "check"], sort=False, dropna=False)
    for (column, check), group in groups:
        how = explain.get(str(check), _Explain(f"to pass the check {check}", _value))
        index = pd.to_numeric(group["index"], errors="coerce").to_numpy()
        if np.isnan(index).all():
            # A column- or table-wide failure (a missing or extra column, a dtype): the
            # stacked drives share their columns and dtypes, so each drive has it.
            for k in range(len(starts)):
                for case in group["failure_case"]:
                    name = column_name(k, column)
                    if check in ("column_in_schema", "column_in_dataframe"):
                        name = source_columns[k].get(str(case), str(case))
                    found = how.found(drive(k), 0, case, numbering[k])
                    problems[k].append(
                        Problem(source_files[k], None, name, how.expected, found, how.fix)
                    )
            continue
        order = np.argsort(index, kind="stable")
        rows = index[order].astype(np.int64)
        owner = np.searchsorted(starts, rows, side="right") - 1  # drive of each failing row
        cases_sorted = group["failure_case"].to_numpy()[order]
        for k in np.unique(owner):  # drives with failures, not rows
            k = int(k)
            mine = np.flatnonzero(owner == k)
            local = rows[mine] - starts[k]  # 0-based row of drive k
            if check in _DRIVE_WIDE:
                found = how.found(drive(k), 0, cases_sorted[mine[0]], numbering[k])
                problems[k].append(
                    Problem(
                        source_files[k], None, column_name(k, column), how.expected, found, how.fix
                    )
                )
                continue
            shown = cases_sorted[mine[:ROWS_LISTED]]
            found = [
                how.found(drive(k), int(i), case, numbering[k])
                for i, case in zip(local, shown, strict=False)
            ]
            problems[k] += row_problems(
                source_files[k],
                column_name(k, column),
                numbering[k](local),
                found,
                how.expected,
                fix=how.fix,
            )
    return problems
