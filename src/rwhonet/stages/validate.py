"""DVC stage ``validate``: canonical drives -> GNSS-valid segments + ``reports/validation.json``.

For every ingested drive: the pandera schema (:mod:`rwhonet.data.schema`, run on
several drives stacked at once, each reported on its own), then the GNSS-quality
policy (:mod:`rwhonet.data.quality`), then the plausibility checks
(:mod:`rwhonet.data.plausibility`): wheel speeds are magnitudes, no wheel sensor
stuck while the car moves, latitude and longitude not swapped, wheel speeds in
rad/s (the implied tyre radius); and a target test drive keeps enough valid
seconds to adapt on ``max(adapt.m_grid)`` s and score the shortest outage.

Any problem in any drive fails the stage with one report of all of them and
writes nothing to its outputs; the full report of the failed run (every
problem, and what each drive kept and cut) goes to
``reports/failed/validation.json``, a file DVC does not manage (it deletes a
stage's declared outputs before running it), removed by the next successful
run. Otherwise the segments are written at once (atomic folder) and the report
lists, per drive, what was kept and every cut with its rule.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from rwhonet import contracts, paths
from rwhonet.config import ConfigError, CutSpec, Params
from rwhonet.data import canonical as c
from rwhonet.data.plausibility import (
    gnss_path_m,
    implied_radius,
    latlon_swapped_by_range,
    negative_wheel_rows,
    radians_radius,
    reversing_rows,
    silent_wheel_runs,
    stale_wheel_runs,
    stuck_wheel_runs,
    swapped_radius,
    unit_mistake,
)
from rwhonet.data.problems import ROWS_LISTED
from rwhonet.data.quality import RULES, Assessment, assess, manual_rows
from rwhonet.data.schema import schema_problems_batch
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_outputs, read_json, system_memory_pool, write_json, write_parquet

CONVENTION = (
    "t_start_s and t_end_s are whole seconds of the drive's own clock; a segment holds its "
    "start fix (the last row with t_s <= t_start_s) and then every row with "
    "t_start_s < t_s <= t_end_s, 1/sample_period_s rows per second (k-1, k], so n_rows = "
    "n_seconds / sample_period_s + 1"
)


def segment_name(drive: str, k: int) -> str:
    """Return the id of the ``k``-th segment of a drive (``V-S1__s000``; sorts in time order)."""
    return f"{drive}__s{k:03d}"


def check_cuts(params: Params, drives: list[str]) -> dict[str, list[CutSpec]]:
    """Check ``validate.cuts`` against the ingested drives and group them by drive.

    Args:
        params: the project parameters.
        drives: ids of the ingested drives.

    Returns:
        Drive id -> its manual cuts.

    Raises:
        ConfigError: a cut names no ingested drive, or does not end after it starts.
    """
    issues = []
    by_drive: dict[str, list[CutSpec]] = {}
    for i, cut in enumerate(params.validate.cuts):
        if cut.drive not in drives:
            issues.append(
                f"validate.cuts[{i}].drive={cut.drive!r}: no such drive; ingested: {sorted(drives)}"
            )
        if not cut.end_s > cut.start_s:
            issues.append(
                f"validate.cuts[{i}]: end_s={cut.end_s} is not after start_s={cut.start_s}"
            )
        by_drive.setdefault(cut.drive, []).append(cut)
    if issues:
        raise ConfigError("\n".join(issues))
    return by_drive


def target_test_min_s(params: Params) -> int:
    """Valid seconds a target test drive needs: adapt on max(m), then score the shortest outage."""
    return max(params.adapt.m_grid) + min(params.evaluate.outages_s)


@system_memory_pool()
def validate(
    params: Params,
    drives_dir: Path,
    out_dir: Path,
    report_path: Path,
    failed_report_path: Path | None = None,
) -> dict[str, Any]:
    """Validate every ingested drive and cut it into GNSS-valid segments.

    Args:
        params: the project parameters (``validate`` and ``data.vehicles`` used).
        drives_dir: the ingest output (``rwhonet.paths.DRIVES``).
        out_dir: the segments folder (``rwhonet.paths.SEGMENTS``); replaced only on success.
        report_path: where the validation report goes (``rwhonet.paths.VALIDATION_REPORT``);
            written only on success, together with the segments.
        failed_report_path: where the report of a failed run goes
            (``rwhonet.paths.VALIDATION_FAILED_REPORT``), with every problem; removed by a
            successful run. None: not written.

    Returns:
        The report: ``{"convention", "policy", "drives": [...], "totals": {...}}``; per drive
        the rows and seconds kept, its segments, every cut (``start_s``, ``end_s``, ``rule``,
        ``detail``) and the seconds and rows cut per rule.

    Raises:
        ConfigError: bad ``validate`` parameters.
        InputError: one report of every problem of every drive (schema failures in the
            source file's rows and columns, a drive left without a valid segment, wheel
            speeds in an implausible unit or negated, a stuck wheel sensor, swapped latitude
            and longitude, a target test drive too short); nothing is written but the failed
            run's report.
    """
    vp = params.validate
    n_per_s = 1.0 / vp.sample_period_s
    if abs(n_per_s - round(n_per_s)) > 1e-9:
        raise ConfigError(
            f"validate.sample_period_s={vp.sample_period_s}: whole seconds need an integer "
            "number of samples (1 / sample_period_s)"
        )
    manifest_path = Path(drives_dir) / contracts.MANIFEST
    if not manifest_path.is_file():
        raise InputError(
            [Problem(paths.rel(manifest_path), None, None, "the ingest manifest", "no such file")],
            summary="run the ingest stage first",
        )
    manifest = read_json(manifest_path)
    cuts = check_cuts(params, [d["drive"] for d in manifest["drives"]])

    problems: list[Problem] = []
    drive_reports: list[dict[str, Any]] = []
    segment_entries: list[dict[str, Any]] = []
    with atomic_outputs(out_dir, report_path, folders=(True, False)) as (tmp, tmp_report):
        for batch in _batches(manifest["drives"], Path(drives_dir)):
            found_by_drive = schema_problems_batch(
                batch.frame,
                batch.starts,
                vp,
                [entry["source_file"] for entry in batch.entries],
                [entry["columns"] for entry in batch.entries],
            )
            for k, (entry, table, found) in enumerate(
                zip(batch.entries, batch.tables, found_by_drive, strict=True)
            ):
                df = batch.drive_frame(k)
                found, result, radius = check_drive(
                    params, entry, df, found, cuts.get(entry["drive"], [])
                )
                if found:
                    problems += found
                    drive_reports.append(_refused_report(entry, result, found))
                    continue
                drive_reports.append(_drive_report(entry, result, radius))
                # rows a signing logger recorded as reversing (the label takes magnitudes)
                drive_reports[-1]["signed_reversing_rows"] = int(
                    reversing_rows(df, vp.wheels.negative_tol_rad_s).sum()
                )
                if problems:
                    continue  # the stage will fail: write no more segments
                for j, seg in enumerate(result.segments):
                    name = segment_name(entry["drive"], j)
                    # A slice of the drive's Arrow table: its rows, untouched and uncopied.
                    write_parquet(table.slice(seg.row_start, seg.n_rows), tmp / f"{name}.parquet")
                    segment_entries.append(
                        {
                            "segment": name,
                            "drive": entry["drive"],
                            "role": entry["role"],
                            "vehicle": entry["vehicle"],
                            "t_start_s": seg.t_start_s,
                            "t_end_s": seg.t_end_s,
                            "n_rows": seg.n_rows,
                            "n_seconds": seg.n_seconds,
                            "source_file": entry["source_file"],
                        }
                    )
        if problems:
            n_files = len({p.file for p in problems})
            summary = f"validate: {len(problems)} problem(s) in {n_files} file(s)"
            if failed_report_path is not None:
                write_json(
                    failed_report_path,
                    {
                        "status": "failed",
                        "note": f"validate refused the drives: nothing was written to "
                        f"{paths.rel(out_dir)} nor {paths.rel(report_path)}; a successful run "
                        "removes this file",
                        "problems": [p.to_dict() for p in problems],
                        "convention": CONVENTION,
                        "policy": params.section("validate"),
                        "target_test_min_s": target_test_min_s(params),
                        "drives": drive_reports,
                    },
                )
                summary += f" (full report: {paths.rel(failed_report_path)})"
            raise InputError(problems, summary=summary)
        write_json(
            tmp / contracts.MANIFEST,
            {
                "convention": CONVENTION,
                "segments": segment_entries,
                "calibration": manifest.get("calibration"),
            },
        )
        report = {
            "convention": CONVENTION,
            "policy": params.section("validate"),
            "target_test_min_s": target_test_min_s(params),
            "drives": drive_reports,
            "totals": _totals(drive_reports, len(segment_entries)),
        }
        write_json(tmp_report, report)
    if failed_report_path is not None:
        Path(failed_report_path).unlink(missing_ok=True)  # that failure is over
    return report


def check_drive(
    params: Params,
    entry: dict[str, Any],
    df: pd.DataFrame,
    schema_found: list[Problem],
    drive_cuts: list[CutSpec],
) -> tuple[list[Problem], Assessment | None, dict[str, Any] | None]:
    """Everything validate checks on one drive after its schema, and its GNSS-valid segments.

    The GNSS-quality policy runs on a drive that passed the schema (wheel speeds out of
    range alone don't stop it, so the unit check can tell rpm or deg/s apart), then the
    wheel-sensor and plausibility checks. ``rwhonet recalibrate`` checks a new car's
    drive with this too.

    Args:
        params: the project parameters (``validate``, the vehicle's nominal radius).
        entry: the drive as the ingest manifest lists it (``drive``, ``role``, ``vehicle``,
            ``source_file``, ``columns``).
        df: the canonical drive.
        schema_found: its schema problems (:func:`rwhonet.data.schema.schema_problems`).
        drive_cuts: its manual cuts (``validate.cuts``).

    Returns:
        ``(problems, assessment, radius check)``; the assessment and radius check are
        None when the schema problems stopped the drive before the GNSS policy.
    """
    vp = params.validate
    found = _swapped_by_range(schema_found, df, entry)
    result = radius = None
    if not found or _only_wheel_ranges(found, df, entry["columns"]):
        result = assess(df, vp.gnss, vp.sample_period_s, drive_cuts)
        wheels = _wheel_problems(params, entry, df, drive_cuts, result)
        more, radius = _drive_problems(params, entry, df, result, check_units=not wheels)
        found = found + wheels + more
    return found, result, radius


# Drives stacked for one pandera call hold at most this many rows. pandera has a fixed cost
# per call whatever the rows, so drives are validated in batches rather than one by one;
# bounding a batch bounds the memory held at once (benchmarks/bench_data.py).
BATCH_ROWS = 300_000


@dataclass
class _Batch:
    """Consecutive drives of the manifest with the same columns, stacked in one frame."""

    entries: list[dict[str, Any]]
    tables: list[pa.Table]  # each drive as read (segments are written as slices of it)
    frame: pd.DataFrame = field(init=False)  # the drives' rows one after the other
    starts: np.ndarray = field(init=False)  # first row of each drive in frame

    def __post_init__(self) -> None:
        # One conversion to pandas for the whole batch rather than one per drive.
        # split_blocks: one array per column, no 2-D block to allocate and gather them into.
        self.frame = pa.concat_tables(self.tables).to_pandas(split_blocks=True)
        self.starts = np.r_[0, np.cumsum([t.num_rows for t in self.tables])[:-1]].astype(int)

    def drive_frame(self, k: int) -> pd.DataFrame:
        """Drive ``k``'s rows (a view of the batch frame), indexed from 0."""
        stop = self.starts[k] + self.tables[k].num_rows
        return self.frame.iloc[self.starts[k] : stop].reset_index(drop=True)


def _batches(entries: list[dict[str, Any]], drives_dir: Path) -> Iterator[_Batch]:
    """Read the drives in manifest order, grouped into batches of the same Arrow schema."""
    pending: list[tuple[dict[str, Any], pa.Table]] = []
    for entry in entries:
        # ParquetFile.read: a third of the time of pq.read_table (which goes through the
        # dataset scanner) for these single-file reads.
        path = drives_dir / f"{entry['drive']}.parquet"
        try:
            table = pq.ParquetFile(path).read()
        except (OSError, pa.ArrowException) as err:
            raise InputError(
                [
                    Problem(
                        paths.rel(path),
                        None,
                        None,
                        "the canonical drive the ingest manifest lists",
                        f"{type(err).__name__}: {str(err)[:160]}",
                        "run the ingest stage again (dvc repro ingest)",
                    )
                ],
                summary="the ingest output is incomplete",
            ) from None
        rows = sum(t.num_rows for _, t in pending) + table.num_rows
        if pending and (not table.schema.equals(pending[0][1].schema) or rows > BATCH_ROWS):
            yield _Batch([e for e, _ in pending], [t for _, t in pending])
            pending = []
        pending.append((entry, table))
    if pending:
        yield _Batch([e for e, _ in pending], [t for _, t in pending])


# Wheel speeds out of range (inf included) reach these checks on purpose (the unit check
# tells rpm from deg/s): arithmetic on them must not warn, the problems say it.
@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def _drive_problems(
    params: Params,
    entry: dict[str, Any],
    df: pd.DataFrame,
    result: Assessment,
    check_units: bool = True,
) -> tuple[list[Problem], dict[str, Any]]:
    """Problems of a schema-valid drive after the GNSS policy, and its radius check.

    ``check_units`` False skips the radius check (a stuck or negated wheel already
    explains a wrong radius, and the unit message would only confuse).
    """
    vp = params.validate
    file, columns = entry["source_file"], entry["columns"]
    problems = []
    t0, t1 = float(df[c.T_S].iloc[0]), float(df[c.T_S].iloc[-1])
    for i, cut in enumerate(params.validate.cuts):
        if cut.drive == entry["drive"] and (cut.end_s < t0 or cut.start_s > t1):
            problems.append(
                Problem(
                    "params.yaml",
                    None,
                    f"validate.cuts[{i}]",
                    f"an interval overlapping {entry['drive']}'s time span {t0}-{t1} s (its "
                    "own clock)",
                    f"{cut.start_s}-{cut.end_s} s",
                    "give start_s and end_s in the drive's own time column (seconds of the "
                    "day for IO-VNBD), not seconds from its start",
                )
            )
    if not result.segments:
        by_rule = sorted(result.cut_seconds_by_rule.items(), key=lambda kv: -kv[1])
        problems.append(
            Problem(
                file,
                None,
                None,
                f"at least one GNSS-valid stretch of >= {vp.gnss.min_segment_s} s",
                f"none: all {result.n_seconds} s cut, "
                + ", ".join(f"{rule} {s} s" for rule, s in by_rule if s)
                + f" (rule {by_rule[0][0]}: {_first_detail(result, by_rule[0][0])})",
                "leave this drive out, repair its GNSS data, or relax the rule that cut it "
                "(validate.gnss) if it is too strict for this receiver",
            )
        )
        return problems, {"checked": False, "note": "no valid segment"}

    need = target_test_min_s(params)
    if entry["role"] == contracts.TARGET_TEST and result.seconds_kept < need:
        cut = ", ".join(f"{r} {n} s" for r, n in result.cut_seconds_by_rule.items() if n)
        problems.append(
            Problem(
                file,
                None,
                None,
                f"a target test drive with at least {need} GNSS-valid seconds: "
                f"max(adapt.m_grid) = {max(params.adapt.m_grid)} s to adapt on, then "
                f"min(evaluate.outages_s) = {min(params.evaluate.outages_s)} s to score",
                f"{entry['drive']} keeps {result.seconds_kept} valid s of its "
                f"{result.n_seconds} s" + (f" (cut: {cut})" if cut else ""),
                "use a longer drive as target test drive (this one can serve as target_train), "
                "or lower adapt.m_grid",
            )
        )

    nominal = params.nominal_radius_m(entry["vehicle"])
    est = implied_radius(df, result.segments, vp.gnss.moving_wheel_speed_rad_s)
    radius = {
        "implied_m": None if np.isnan(est.radius_m) else est.radius_m,
        "nominal_m": nominal,
        "moving_s": est.moving_s,
        "checked": est.moving_s >= vp.radius_min_moving_s and check_units,
    }
    if not check_units:
        radius["note"] = "unit check skipped: a wheel sensor problem explains the radius"
        return problems, radius
    if not radius["checked"]:
        radius["note"] = (
            f"only {est.moving_s} moving s in valid segments (< validate.radius_min_moving_s "
            f"{vp.radius_min_moving_s}): unit check skipped"
        )
        return problems, radius
    radius["ratio"] = est.radius_m / nominal
    mistake = unit_mistake(est.radius_m, nominal, vp.radius_tolerance)
    if mistake:
        swapped = swapped_radius(df, result.segments, vp.gnss.moving_wheel_speed_rad_s)
        if unit_mistake(swapped.radius_m, nominal, vp.radius_tolerance) is None:
            problems.append(_swapped_problem(entry, est.radius_m, swapped.radius_m, nominal))
            return problems, radius
        in_degrees = radians_radius(df, result.segments, vp.gnss.moving_wheel_speed_rad_s)
        if (
            in_degrees is not None
            and unit_mistake(in_degrees.radius_m, nominal, vp.radius_tolerance) is None
        ):
            lat, lon = (columns.get(x, x) for x in (c.LAT_DEG, c.LON_DEG))
            problems.append(
                Problem(
                    file,
                    None,
                    f"{lat} / {lon}",
                    "latitude and longitude in decimal degrees",
                    "latitude and longitude look like radians: every value within ±π, and "
                    f"the wheels imply a tyre radius of {est.radius_m:.4g} m as they are, "
                    f"{in_degrees.radius_m:.4g} m (nominal {nominal} m) in degrees",
                    "convert both columns to degrees (x 180/π)",
                )
            )
            return problems, radius
        problems.append(
            Problem(
                file,
                None,
                f"{columns.get(c.OMEGA_RL, c.OMEGA_RL)} / {columns.get(c.OMEGA_RR, c.OMEGA_RR)}",
                f"rear wheel speeds in rad/s implying an effective radius within "
                f"±{vp.radius_tolerance:.0%} of {entry['vehicle']}'s nominal {nominal} m "
                f"(GNSS distance / wheel angle over {est.moving_s} moving s)",
                mistake,
                "convert the wheel speeds to rad/s (a column map can declare rpm or deg/s), "
                f"or correct data.vehicles.{entry['vehicle']}.nominal_radius_m",
            )
        )
    return problems, radius


def _swapped_problem(
    entry: dict[str, Any],
    radius_m: float | None,
    swapped_m: float | None,
    nominal_m: float | None,
) -> Problem:
    """Latitude and longitude look swapped (by the radius they imply, or by their ranges)."""
    columns = entry["columns"]
    lat, lon = columns.get(c.LAT_DEG, c.LAT_DEG), columns.get(c.LON_DEG, c.LON_DEG)
    if radius_m is None:
        evidence = (
            f"most values of {lat!r} lie beyond ±90 deg and every value of {lon!r} within ±90 deg"
        )
    else:
        evidence = (
            f"the wheels imply a tyre radius of {radius_m:.4g} m as the columns are, and "
            f"{swapped_m:.4g} m (nominal {nominal_m} m) with the two exchanged"
        )
    return Problem(
        entry["source_file"],
        None,
        f"{lat} / {lon}",
        f"the latitude in {lat!r} and the longitude in {lon!r}",
        f"latitude and longitude look swapped: {evidence}",
        "exchange the two columns (their names in the header, or lat and lon in the column map)",
    )


def _swapped_by_range(
    found: list[Problem], df: pd.DataFrame, entry: dict[str, Any]
) -> list[Problem]:
    """Replace the latitude range failures of a drive with swapped columns by one problem."""
    lat = entry["columns"].get(c.LAT_DEG, c.LAT_DEG)
    if not any(p.column == lat and "latitude in [-90, 90]" in p.expected for p in found):
        return found
    if not latlon_swapped_by_range(df[c.LAT_DEG].to_numpy(), df[c.LON_DEG].to_numpy()):
        return found
    rest = [p for p in found if not (p.column == lat and "latitude in [-90, 90]" in p.expected)]
    return [_swapped_problem(entry, None, None, None), *rest]


@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def _wheel_problems(
    params: Params,
    entry: dict[str, Any],
    df: pd.DataFrame,
    drive_cuts: list[CutSpec],
    result: Assessment,
) -> list[Problem]:
    """Negative wheel speeds (a sign error), stuck wheel sensors and no wheel data at all."""
    vp = params.validate
    file, columns = entry["source_file"], entry["columns"]
    ignore = manual_rows(df[c.T_S].to_numpy(np.float64), drive_cuts)
    problems = []
    t = df[c.T_S].to_numpy(np.float64)
    negative = negative_wheel_rows(df, vp.wheels.negative_tol_rad_s, ignore)
    reversing = reversing_rows(df, vp.wheels.negative_tol_rad_s) if negative else None
    for wheel, rows in negative.items():
        values = df[wheel].to_numpy(np.float64)
        moving = int((np.abs(values) > vp.gnss.moving_wheel_speed_rad_s).sum())
        share = rows.size / max(moving, 1)
        if share <= vp.wheels.signed_max_share and reversing[rows].all():
            continue  # a signing logger's reversing: label takes the magnitudes
        what = (
            "the column looks negated (a sign error in the export)"
            if share > vp.wheels.signed_max_share
            else "one wheel negative while another turns forwards (not reversing)"
        )
        problems.append(
            Problem(
                file,
                int(rows[0]) + 1,
                columns.get(wheel, wheel),
                "wheel speeds as magnitudes >= 0 (as ABS sensors give them), or all four "
                "negative together while reversing on at most "
                f"{vp.wheels.signed_max_share:.0%} of the moving rows "
                f"(validate.wheels.negative_tol_rad_s {vp.wheels.negative_tol_rad_s}, "
                "signed_max_share)",
                f"{values[rows[0]]:.6g} rad/s, negative in {rows.size} row(s) (rows "
                f"{int(rows[0]) + 1}-{int(rows[-1]) + 1}; {share:.0%} of the moving rows) while "
                f"GNSS moved {gnss_path_m(df, rows):.0f} m: {what}",
                "export the absolute wheel speeds (|value|), or negate this column: the "
                "pipeline takes the direction from GNSS, never from the wheel speed's sign",
            )
        )
    runs = stuck_wheel_runs(df, vp.wheels, vp.sample_period_s, ignore)
    by_wheel: dict[str, list] = {}
    for run in runs:
        by_wheel.setdefault(run.wheel, []).append(run)
    for wheel, wheel_runs in by_wheel.items():
        for run in wheel_runs[:ROWS_LISTED]:
            start, end = t[run.row_start], t[run.row_stop - 1]
            problems.append(
                Problem(
                    file,
                    run.row_start + 1,
                    columns.get(wheel, wheel),
                    "each wheel turning with the others while the car moves (at least "
                    f"{vp.wheels.stuck_ratio} x the median of the four wheels for any "
                    f"{vp.wheels.stuck_min_s} s; validate.wheels)",
                    f"at most {run.reading_max_rad_s:.3g} rad/s for "
                    f"{(run.row_stop - run.row_start) * vp.sample_period_s:.4g} s (rows "
                    f"{run.row_start + 1}-{run.row_stop}, t = {start:.6g}-{end:.6g} s) while "
                    f"the median wheel turned at {run.others_median_rad_s:.3g} rad/s and GNSS "
                    f"moved {gnss_path_m(df, np.arange(run.row_start, run.row_stop)):.0f} m: "
                    "a stuck or disconnected wheel-speed sensor",
                    "check this wheel's sensor and channel in the export; to keep the rest of "
                    "the drive, cut the stretch: validate.cuts: [{drive: "
                    f"{entry['drive']}, start_s: {np.floor(start):.0f}, end_s: "
                    f"{np.ceil(end):.0f}, reason: stuck wheel sensor}}]",
                )
            )
        if len(wheel_runs) > ROWS_LISTED:
            problems.append(
                Problem(
                    file,
                    None,
                    columns.get(wheel, wheel),
                    problems[-1].expected,
                    f"{len(wheel_runs) - ROWS_LISTED} more stretch(es) like these",
                    problems[-1].fix,
                )
            )
    silent = silent_wheel_runs(
        df,
        result.segments,
        params.nominal_radius_m(entry["vehicle"]),
        vp.wheels,
        vp.sample_period_s,
        ignore,
    )
    wheels = " / ".join(columns.get(w, w).strip() for w in c.WHEELS)
    for run in silent[:ROWS_LISTED]:
        start, end = t[run.row_start], t[run.row_stop - 1]
        problems.append(
            Problem(
                file,
                run.row_start + 1,
                wheels,
                "wheel speeds that follow the GNSS speed (the median of the four at least "
                f"{vp.wheels.stuck_ratio} x GNSS speed / nominal radius, whenever that exceeds "
                f"{vp.wheels.stuck_moving_rad_s} rad/s for {vp.wheels.stuck_min_s} s; "
                "validate.wheels)",
                f"all four at most {run.wheels_max_rad_s:.3g} rad/s for "
                f"{(run.row_stop - run.row_start) * vp.sample_period_s:.4g} s (rows "
                f"{run.row_start + 1}-{run.row_stop}, t = {start:.6g}-{end:.6g} s) while GNSS "
                f"moved {run.gnss_m:.0f} m at up to {run.gnss_max_m_s:.3g} m/s: no wheel data "
                "(a CAN channel that stopped logging, or wheel columns left as zeros?)",
                "export the wheel speeds of this stretch; to keep the rest of the drive, cut "
                f"it: validate.cuts: [{{drive: {entry['drive']}, start_s: "
                f"{np.floor(start):.0f}, end_s: {np.ceil(end):.0f}, reason: no wheel data}}]",
            )
        )
    if len(silent) > ROWS_LISTED:
        problems.append(
            Problem(
                file,
                None,
                wheels,
                problems[-1].expected,
                f"{len(silent) - ROWS_LISTED} more stretch(es) like these",
                problems[-1].fix,
            )
        )
    stale = stale_wheel_runs(
        df,
        result.segments,
        params.nominal_radius_m(entry["vehicle"]),
        vp.wheels,
        vp.sample_period_s,
        ignore,
    )
    for run in stale[:ROWS_LISTED]:
        start, end = t[run.row_start], t[run.row_stop - 1]
        problems.append(
            Problem(
                file,
                run.row_start + 1,
                wheels,
                "wheel speeds that change with the car's speed (never all four repeating one "
                f"value for {vp.wheels.stuck_min_s} s while GNSS speed changes by more than "
                f"{vp.wheels.stuck_moving_rad_s} rad/s x the nominal radius; validate.wheels)",
                f"the same values (median {run.wheels_rad_s:.4g} rad/s) in every row for "
                f"{(run.row_stop - run.row_start) * vp.sample_period_s:.4g} s (rows "
                f"{run.row_start + 1}-{run.row_stop}, t = {start:.6g}-{end:.6g} s) while the "
                f"GNSS speed went between {run.gnss_min_m_s:.3g} and {run.gnss_max_m_s:.3g} "
                "m/s: stale wheel data (a logger repeating the last CAN value?)",
                "export the wheel speeds of this stretch; to keep the rest of the drive, cut "
                f"it: validate.cuts: [{{drive: {entry['drive']}, start_s: "
                f"{np.floor(start):.0f}, end_s: {np.ceil(end):.0f}, reason: stale wheel data}}]",
            )
        )
    return problems


def _only_wheel_ranges(found: list[Problem], df: pd.DataFrame, columns: dict[str, str]) -> bool:
    """Whether a drive's only schema problems are wheel speeds out of range (no NaN)."""
    wheels = {columns.get(w, w) for w in c.WHEELS}
    return all(p.column in wheels for p in found) and not df[list(c.WHEELS)].isna().any(axis=None)


def _first_detail(result: Assessment, rule: str) -> str:
    return next(cut.detail for cut in result.cuts if cut.rule == rule)


def _refused_report(
    entry: dict[str, Any], result: Assessment | None, found: list[Problem]
) -> dict[str, Any]:
    """A refused drive in the failed run's report: its problems and, if assessed, its cuts."""
    report: dict[str, Any] = {
        "drive": entry["drive"],
        "role": entry["role"],
        "vehicle": entry["vehicle"],
        "source_file": entry["source_file"],
        "status": "refused",
        "problems": [p.to_dict() for p in found],
    }
    if result is not None:
        report |= {
            "seconds": result.n_seconds,
            "seconds_kept": result.seconds_kept,
            "cuts": [
                {"start_s": x.start_s, "end_s": x.end_s, "rule": x.rule, "detail": x.detail}
                for x in result.cuts
            ],
            "cut_seconds_by_rule": result.cut_seconds_by_rule,
        }
    return report


def _drive_report(entry: dict[str, Any], result: Assessment, radius: dict[str, Any]) -> dict:
    return {
        "drive": entry["drive"],
        "role": entry["role"],
        "vehicle": entry["vehicle"],
        "source_file": entry["source_file"],
        "rows": result.n_rows,
        "rows_kept": result.rows_kept,
        "seconds": result.n_seconds,
        "seconds_kept": result.seconds_kept,
        "segments": [
            {
                "segment": segment_name(entry["drive"], k),
                "t_start_s": s.t_start_s,
                "t_end_s": s.t_end_s,
                "n_seconds": s.n_seconds,
            }
            for k, s in enumerate(result.segments)
        ],
        "cuts": [
            {
                "start_s": cut.start_s,
                "end_s": cut.end_s,
                "rule": cut.rule,
                "detail": cut.detail,
                "n_seconds": cut.n_seconds,
                "n_rows": cut.n_rows,
            }
            for cut in result.cuts
        ],
        "cut_seconds_by_rule": result.cut_seconds_by_rule,
        "cut_rows_by_rule": result.cut_rows_by_rule,
        "radius": radius,
    }


def _totals(drives: list[dict[str, Any]], n_segments: int) -> dict[str, Any]:
    return {
        "drives": len(drives),
        "segments": n_segments,
        "rows": sum(d["rows"] for d in drives),
        "rows_kept": sum(d["rows_kept"] for d in drives),
        "seconds": sum(d["seconds"] for d in drives),
        "seconds_kept": sum(d["seconds_kept"] for d in drives),
        "cut_seconds_by_rule": {r: sum(d["cut_seconds_by_rule"][r] for d in drives) for r in RULES},
        "cut_rows_by_rule": {r: sum(d["cut_rows_by_rule"][r] for d in drives) for r in RULES},
    }


def summary_table(report: dict[str, Any]) -> str:
    """Return a short text table of what validation kept and cut (for the stage's output).

    Args:
        report: what :func:`validate` returned.

    Returns:
        One line per drive (seconds kept, segments, seconds cut per rule) and a total line.
    """
    head = f"{'drive':<24} {'role':<18} {'kept s':>8} {'of s':>8} {'segs':>5}  cut (s by rule)"
    lines = [head]
    for d in report["drives"]:
        cut = ", ".join(f"{r} {s}" for r, s in d["cut_seconds_by_rule"].items() if s) or "-"
        lines.append(
            f"{d['drive']:<24} {d['role']:<18} {d['seconds_kept']:>8} {d['seconds']:>8} "
            f"{len(d['segments']):>5}  {cut}"
        )
    t = report["totals"]
    share = t["seconds_kept"] / t["seconds"] if t["seconds"] else 0.0
    cut = ", ".join(f"{r} {s}" for r, s in t["cut_seconds_by_rule"].items() if s) or "-"
    lines.append(
        f"{t['drives']} drive(s): {t['seconds_kept']} of {t['seconds']} s kept ({share:.1%}) "
        f"in {t['segments']} segment(s); cut: {cut}"
    )
    return "\n".join(lines)


def main(params: Params) -> None:
    """The ``validate`` stage: drives -> segments and ``reports/validation.json``."""
    report = validate(
        params,
        paths.DRIVES,
        paths.SEGMENTS,
        paths.VALIDATION_REPORT,
        paths.VALIDATION_FAILED_REPORT,
    )
    print(summary_table(report))
    print(f"-> {paths.rel(paths.SEGMENTS)}, {paths.rel(paths.VALIDATION_REPORT)}")
