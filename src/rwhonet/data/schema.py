"""Pandera schema of a canonical drive, and its failures as :class:`Problem` entries.

The schema is built from ``params.yaml: validate`` (ranges and sample period are
parameters). Validation is lazy so one run reports every failing check, and
``SchemaErrors.failure_cases`` (one row per failing cell, possibly millions) is
turned into a short list of problems: per column and check, the first few rows
(numbered as in the source file) and a count of the rest.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pandera.pandas as pa
from pandera.errors import SchemaErrors

from rwhonet.config import ValidateParams
from rwhonet.data import canonical as c
from rwhonet.data.problems import ROWS_LISTED, row_problems
from rwhonet.errors import Problem

# Float noise on decimal time stamps (45123.1 - 45123.0 = 0.10000000000291) must not fail a
# step that is exactly at the tolerance.
_STEP_SLACK_S = 1e-9


@dataclass(frozen=True)
class _Explain:
    """How to word one check's failures: what was expected, and what was found in a row."""

    expected: str
    found: Callable[[pd.DataFrame, int, object], str]


def _num(x: object) -> str:
    """A cell as the user wrote it: plain Python repr, not ``np.float64(...)``."""
    return repr(x.item()) if isinstance(x, np.generic) else repr(x)


def _value(df: pd.DataFrame, i: int, case: object) -> str:
    return _num(case)


def _time_step(df: pd.DataFrame, i: int, case: object) -> str:
    t = df[c.T_S].to_numpy()
    return (
        f"t = {_num(t[i])} s after t = {_num(t[i - 1])} s in row {i} "
        f"(step {t[i] - t[i - 1]:+.6g} s)"
    )


def _drive_checks(vp: ValidateParams) -> dict[str, tuple[pa.Check, _Explain]]:
    """Named checks of the schema with the words used to report their failures."""
    period, tol, gap = vp.sample_period_s, vp.sample_period_tol_s, vp.gnss.max_gap_s
    w_max = vp.max_abs_wheel_speed_rad_s

    def step(s: pd.Series) -> pd.Series:
        return s.diff()

    def regular(s: pd.Series) -> pd.Series:
        d = step(s)
        # Non-positive steps are reported by the two time-order checks, NaN ones by not_nullable;
        # a step longer than max_gap_s is a gap, which the GNSS policy splits the drive at.
        return d.isna() | (d <= 0) | ((d - period).abs() <= tol + _STEP_SLACK_S) | (d > gap)

    def median_period(s: pd.Series) -> bool:
        d = step(s).dropna()
        return d.empty or abs(float(d.median()) - period) <= tol

    def median_found(df: pd.DataFrame, i: int, case: object) -> str:
        median = float(df[c.T_S].diff().median())
        hint = "; time in ms instead of s?" if abs(median / 1000.0 - period) <= tol else ""
        return f"median step {median:.6g} s{hint}"

    increasing = "a time after the previous row's (time strictly increasing)"
    checks = {
        "time_finite": (
            pa.Check(lambda s: np.isfinite(s), name="time_finite"),
            _Explain("a finite time in seconds", _value),
        ),
        "time_not_repeated": (
            pa.Check(lambda s: step(s) != 0, name="time_not_repeated"),
            _Explain(increasing, lambda df, i, case: f"t = {_num(case)} s again (as in row {i})"),
        ),
        "time_not_backwards": (
            pa.Check(lambda s: ~(step(s) < 0), name="time_not_backwards"),
            _Explain(
                increasing, lambda df, i, case: "time goes backwards: " + _time_step(df, i, case)
            ),
        ),
        "sample_period": (
            pa.Check(regular, name="sample_period"),
            _Explain(
                f"a step of {period} ± {tol} s from the previous row (validate.sample_period_s), "
                f"or a gap > {gap} s (validate.gnss.max_gap_s; the drive is split there)",
                _time_step,
            ),
        ),
        "median_sample_period": (
            pa.Check(median_period, name="median_sample_period"),
            _Explain(f"a median step of {period} ± {tol} s", median_found),
        ),
        "latitude_range": (
            pa.Check(lambda s: s.between(-90.0, 90.0), name="latitude_range"),
            _Explain("a latitude in [-90, 90] deg", _value),
        ),
        "longitude_range": (
            pa.Check(lambda s: s.between(-180.0, 180.0), name="longitude_range"),
            _Explain("a longitude in [-180, 180] deg", _value),
        ),
        "wheel_speed_range": (
            pa.Check(lambda s: s.abs() < w_max, name="wheel_speed_range"),
            _Explain(f"|wheel speed| < {w_max} rad/s (validate.max_abs_wheel_speed_rad_s)", _value),
        ),
        "satellites_non_negative": (
            pa.Check(lambda s: s >= 0, name="satellites_non_negative"),
            _Explain("a satellite count >= 0", _value),
        ),
    }
    return checks


# What pandera's own checks report, worded for a user.
_BUILTIN = {
    "not_nullable": _Explain(
        "a value (this channel is required)", lambda df, i, case: "no value (empty or NaN)"
    ),
    "column_in_dataframe": _Explain("this required channel", lambda df, i, case: "no such column"),
    "column_in_schema": _Explain(
        f"only the canonical columns ({', '.join((*c.REQUIRED, *c.OPTIONAL, c.SCENARIO))})",
        lambda df, i, case: f"column {case!r}",
    ),
}


def drive_schema(vp: ValidateParams) -> pa.DataFrameSchema:
    """Build the pandera schema of a canonical drive from the validate parameters.

    Required channels must be present and complete (no NaN); latitude and longitude in
    range; |wheel speed| below ``max_abs_wheel_speed_rad_s``; time finite, strictly
    increasing, every step ``sample_period_s ± sample_period_tol_s`` or a gap longer than
    ``gnss.max_gap_s``, and the median step near the nominal period (catches time in ms).

    Args:
        vp: the ``validate`` section.

    Returns:
        The schema (strict: columns other than the canonical ones are an error).
    """
    checks = _drive_checks(vp)

    def pick(*names: str) -> list[pa.Check]:
        return [checks[n][0] for n in names]

    columns = {
        c.T_S: pa.Column(
            float,
            pick(
                "time_finite",
                "time_not_repeated",
                "time_not_backwards",
                "sample_period",
                "median_sample_period",
            ),
        ),
        c.LAT_DEG: pa.Column(float, pick("latitude_range")),
        c.LON_DEG: pa.Column(float, pick("longitude_range")),
        **{w: pa.Column(float, pick("wheel_speed_range")) for w in c.WHEELS},
        c.N_SATS: pa.Column(float, pick("satellites_non_negative"), nullable=True, required=False),
        **{
            name: pa.Column(float, nullable=True, required=False)
            for name in c.OPTIONAL
            if name != c.N_SATS
        },
        c.SCENARIO: pa.Column(str),
    }
    return pa.DataFrameSchema(columns, strict=True, coerce=False, name="canonical_drive")


def schema_problems(
    df: pd.DataFrame,
    vp: ValidateParams,
    source_file: str,
    source_columns: Mapping[str, str],
) -> list[Problem]:
    """Validate a canonical drive and describe every failure in the source file's terms.

    Args:
        df: the canonical drive (row ``i`` is data row ``i + 1`` of the source file).
        vp: the ``validate`` section.
        source_file: the drive's source file, as the user knows it.
        source_columns: canonical name -> the file's column name (from the ingest manifest).

    Returns:
        Problems (empty when the drive is valid): per column and check, the first
        ``ROWS_LISTED`` failing rows and a summary of the rest.
    """
    df = df.reset_index(drop=True)  # failure indices are then positions: row = index + 1
    try:
        drive_schema(vp).validate(df, lazy=True)
    except SchemaErrors as err:
        cases = err.failure_cases
    else:
        return []
    explain = {name: how for name, (_, how) in _drive_checks(vp).items()} | _BUILTIN
    problems: list[Problem] = []
    # One group per (column, check), in the order pandera found them.
    groups = cases.groupby(["column", "check"], sort=False, dropna=False)
    for (column, check), group in groups:
        how = explain.get(str(check), _Explain(f"to pass the check {check}", _value))
        # Table-wide failures have no column (None or NaN, depending on pandas).
        column_name = source_columns.get(column, column) if isinstance(column, str) else None
        index = pd.to_numeric(group["index"], errors="coerce").to_numpy()
        if np.isnan(index).all():  # a column- or file-wide failure: no row to point at
            for case in group["failure_case"]:
                if check in ("column_in_schema", "column_in_dataframe"):
                    column_name = source_columns.get(str(case), str(case))
                found = how.found(df, 0, case)
                problems.append(Problem(source_file, None, column_name, how.expected, found))
            continue
        order = np.argsort(index, kind="stable")
        rows = index[order].astype(np.int64)
        shown = group["failure_case"].to_numpy()[order][:ROWS_LISTED]
        found = [how.found(df, int(i), case) for i, case in zip(rows, shown, strict=False)]
        problems += row_problems(source_file, column_name, rows + 1, found, how.expected)
    return problems
