"""DVC stage ``validate``: canonical drives -> GNSS-valid segments + ``reports/validation.json``.

For every ingested drive: the pandera schema (:mod:`rwhonet.data.schema`, run on
several drives stacked at once, each reported on its own), then the per-drive
checks of :mod:`rwhonet.data.drivechecks` (the GNSS-quality policy, the wheel
sensors, the plausibility of units and coordinates, a target test drive's
length), which ``rwhonet recalibrate`` runs on a new car's drive too.

Any problem in any drive fails the stage with one report of all of them and
writes nothing to its outputs (with ``data.refused_drives: leave_out`` the drive is
left out instead, and named in the report's and the segments manifest's ``left_out``,
with the drives ingest left out: :mod:`rwhonet.data.leftout`); the full report of
the failed run (every problem, and what each drive kept and cut) goes to
``reports/failed/validation.json``, a file DVC does not manage (it deletes a
stage's declared outputs before running it), removed by the next successful
run. Otherwise the segments are written at once (atomic folder) and the report
lists, per drive, what was kept and every cut with its rule.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from rwhonet import contracts, paths
from rwhonet.config import ConfigError, CutSpec, Params
from rwhonet.data import leftout
from rwhonet.data.drivechecks import TOLD_CHECKS, check_drive, target_test_min_s
from rwhonet.data.drivefile import with_label_times
from rwhonet.data.droprows import FileRows, report_rows
from rwhonet.data.plausibility import reversing_rows
from rwhonet.data.quality import RULES, Assessment, segment_name
from rwhonet.data.schema import schema_problems_batch
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_outputs, map_in_order, read_arrow, read_json, write_arrow, write_json

CONVENTION = (
    "t_start_s and t_end_s are whole seconds of the drive's own clock; a segment holds its "
    "start fix (the last row with t_s <= t_start_s) and then every row with "
    "t_start_s < t_s <= t_end_s, 1/sample_period_s rows per second (k-1, k], so n_rows = "
    "n_seconds / sample_period_s + 1"
)


def check_cuts(
    params: Params, drives: list[str], left_out: Collection[str] = ()
) -> dict[str, list[CutSpec]]:
    """Check ``validate.cuts`` against the ingested drives and group them by drive.

    Args:
        params: the project parameters.
        drives: ids of the ingested drives.
        left_out: ids of the drives ingest left out (``data.refused_drives: leave_out``):
            a cut of one is no mistake, and has nothing to cut.

    Returns:
        Drive id -> its manual cuts.

    Raises:
        ConfigError: a cut names no ingested drive, or does not end after it starts.
    """
    issues = []
    by_drive: dict[str, list[CutSpec]] = {}
    for i, cut in enumerate(params.validate.cuts):
        if cut.drive in left_out:
            continue
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
    left_out: list[dict[str, Any]] = list(manifest.get("left_out", []))  # by ingest
    cuts = check_cuts(
        params, [d["drive"] for d in manifest["drives"]], [d["drive"] for d in left_out]
    )
    leave_out = params.data.refused_drives == leftout.LEAVE_OUT

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
                [FileRows.of(entry) for entry in batch.entries],
            )

            def check(k: int, batch: _Batch = batch, found_by_drive=found_by_drive) -> tuple:
                """Drive k of the batch: its checks, and its segments written (in a thread)."""
                entry, table = batch.entries[k], batch.tables[k]
                df = batch.drive_frame(k)
                found, result, units, glitches = check_drive(
                    params, entry, df, found_by_drive[k], cuts.get(entry["drive"], [])
                )
                if found:
                    return found, _refused_report(entry, result, found, glitches), []
                report = _drive_report(entry, result, units, glitches)
                # rows a signing logger recorded as reversing (the label takes magnitudes)
                report["signed_reversing_rows"] = int(
                    reversing_rows(df, vp.wheels.negative_tol_rad_s).sum()
                )
                # Written whatever other drives found: a failed stage discards them all.
                return [], report, _write_segments(entry, table, result, tmp, vp.sample_period_s)

            for k, checked in map_in_order(check, range(len(batch.entries))):
                found, report, segments = checked.result()
                if found and leave_out:
                    entry = batch.entries[k]
                    left_out.append(leftout.left_out_entry(entry, "validate", found) | report)
                    continue
                problems += found
                drive_reports.append(report)
                segment_entries += segments
        calibration = manifest.get("calibration")
        if leave_out and left_out:
            required = [role for role, spec in params.data.roles.items() if spec.required]
            kept = [d["role"] for d in drive_reports]
            problems += leftout.emptied_roles(required, kept, left_out)
            calibration = _calibration_kept(calibration, drive_reports, manifest_path)
            if isinstance(calibration, Problem):
                problems.append(calibration)
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
        # left_out only where a drive was: a run without refusals writes what it always did
        also = {"left_out": left_out} if left_out else {}
        write_json(
            tmp / contracts.MANIFEST,
            {
                "convention": CONVENTION,
                "segments": segment_entries,
                "calibration": calibration,
                **also,
            },
        )
        report = {
            "convention": CONVENTION,
            "policy": params.section("validate"),
            "target_test_min_s": target_test_min_s(params),
            "drives": drive_reports,
            "totals": _totals(drive_reports, len(segment_entries)),
            **also,
        }
        if left_out:
            report["totals"]["drives_left_out"] = len(left_out)
        write_json(tmp_report, report)
    if failed_report_path is not None:
        Path(failed_report_path).unlink(missing_ok=True)  # that failure is over
    return report


def _calibration_kept(
    calibration: dict[str, Any] | None, kept: list[dict[str, Any]], manifest_path: Path
) -> dict[str, Any] | Problem | None:
    """Ingest's choice of the drives that calibrate the radii, chosen again among the drives
    kept where validate left out one of them (:func:`rwhonet.data.leftout.calibration`);
    a problem where no drive is left to calibrate."""
    kept_ids = {d["drive"] for d in kept}
    if calibration is None or set(calibration.get("drives", [])) <= kept_ids:
        return calibration
    chosen = leftout.calibration((d["drive"], d["role"]) for d in kept)
    if chosen is None:
        return Problem(
            paths.rel(manifest_path),
            None,
            "calibration",
            f"a {contracts.SOURCE_CALIBRATION} or {contracts.CALIBRATION_FALLBACK_ROLE} drive "
            "to calibrate the wheel radii",
            f"every one was refused ({', '.join(calibration.get('drives', []))} left out)",
            "mend the refused drives named above, or add a source_train drive",
        )
    return chosen | {
        "note": f"{', '.join(calibration['drives'])} left out (refused): "
        + chosen.get("note", f"the {chosen['role']} drives calibrate")
    }


def _write_segments(
    entry: dict[str, Any], table: pa.Table, result: Assessment, folder: Path, period_s: float
) -> list[dict[str, Any]]:
    """Write a drive's segments (slices of its Arrow table); return their manifest entries.

    Where the drive's stamps are jittered, the segments' times are the whole drive's
    slot instants (:func:`rwhonet.data.timebase.drive_label_times`), the slots validate
    cut the seconds on: placed alone, a segment's edge rows could take other slots.
    """
    entries = []
    if result.segments:
        table = with_label_times(table, period_s)
    for j, seg in enumerate(result.segments):
        name = segment_name(entry["drive"], j)
        # A slice of the drive's table, uncopied: its rows as ingested (jittered times placed)
        write_arrow(
            table.slice(seg.row_start, seg.n_rows), folder / f"{name}{contracts.TABLE_SUFFIX}"
        )
        entries.append(
            {
                "segment": name,
                "drive": entry["drive"],
                "role": entry["role"],
                "vehicle": entry["vehicle"],
                "t_start_s": seg.start_s,
                "t_end_s": seg.end_s,
                "n_rows": seg.n_rows,
                "n_seconds": seg.n_seconds,
                "source_file": entry["source_file"],
            }
        )
    return entries


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
    """Read the drives in manifest order, grouped into batches of the same Arrow schema.

    The next drives are read in threads (:func:`rwhonet.io.map_in_order`) while the
    current batch is checked.
    """
    pending: list[tuple[dict[str, Any], pa.Table]] = []
    for entry, read in map_in_order(lambda e: _read_drive(e, drives_dir), entries):
        table = read.result()
        rows = sum(t.num_rows for _, t in pending) + table.num_rows
        if pending and (not table.schema.equals(pending[0][1].schema) or rows > BATCH_ROWS):
            yield _Batch([e for e, _ in pending], [t for _, t in pending])
            pending = []
        pending.append((entry, table))
    if pending:
        yield _Batch([e for e, _ in pending], [t for _, t in pending])


def _read_drive(entry: dict[str, Any], drives_dir: Path) -> pa.Table:
    """One canonical drive the ingest manifest lists."""
    path = drives_dir / f"{entry['drive']}{contracts.TABLE_SUFFIX}"
    try:
        return read_arrow(path)
    except (OSError, pa.ArrowException) as err:
        expected = "the canonical drive the ingest manifest lists"
        fix = "run the ingest stage again (dvc repro ingest)"
        raise InputError(
            [Problem.unreadable(paths.rel(path), expected, err, fix)],
            summary="the ingest output is incomplete",
        ) from None


def _refused_report(
    entry: dict[str, Any],
    result: Assessment | None,
    found: list[Problem],
    glitches: dict[str, Any] | None = None,
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
    if glitches is not None:
        report["wheel_glitches"] = glitches
    return report


def _drive_report(
    entry: dict[str, Any],
    result: Assessment,
    units: dict[str, Any],
    glitches: dict[str, Any] | None = None,
) -> dict:
    report = {
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
                "t_start_s": s.start_s,
                "t_end_s": s.end_s,
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
        "radius": units["radius"],
        "yaw_rate": units["yaw_rate"],
        "wheel_sides": units["wheel_sides"],
        "wheel_axles": units["wheel_axles"],
    }
    if result.accuracy is not None:  # the receiver's stated accuracy, where the drive has it
        report["gnss_accuracy"] = result.accuracy
    # rows written twice or without a wheel speed, dropped by ingest (not in "rows")
    report.update(report_rows(entry))
    if glitches is not None:  # only when a row glitched (its seconds: the wheel_glitch cuts)
        report["wheel_glitches"] = glitches
    return report


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


NAMES_LISTED = 4  # drives named per check in the summary (all in the report)


def summary_table(report: dict[str, Any]) -> str:
    """Return a short text table of what validation kept and cut (for the stage's output).

    Args:
        report: what :func:`validate` returned.

    Returns:
        One line per drive (seconds kept, segments, seconds cut per rule), a total line,
        and where a check against GNSS could not tell on some drives, a line naming them.
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
    left = t.get("drives_left_out", 0)
    out = f"; {left} drive(s) left out (refused, data.refused_drives: leave_out)" if left else ""
    lines.append(
        f"{t['drives']} drive(s): {t['seconds_kept']} of {t['seconds']} s kept ({share:.1%}) "
        f"in {t['segments']} segment(s); cut: {cut}{out}"
    )
    untold = []
    for key, name in TOLD_CHECKS:
        drives = [d["drive"] for d in report["drives"] if not d.get(key, {}).get("checked", True)]
        if drives:
            more = len(drives) - NAMES_LISTED
            shown = ", ".join(drives[:NAMES_LISTED]) + (f", +{more}" if more > 0 else "")
            untold.append(f"{name} on {len(drives)} ({shown})")
    if untold:
        lines.append(
            "not told against the GNSS course (each drive's note in the report says why): "
            + "; ".join(untold)
        )
    stated = [d for d in report["drives"] if d.get("gnss_accuracy", {}).get("stated_rows")]
    if stated:  # what validate.gnss.max_h_acc_m would be set from
        worst = max(stated, key=lambda d: d["gnss_accuracy"]["p95_m"])
        acc = worst["gnss_accuracy"]
        lines.append(
            f"stated horizontal accuracy on {len(stated)} drive(s) (gnss_accuracy in the "
            f"report): the highest 95th percentile {acc['p95_m']:g} m ({worst['drive']}, "
            f"median {acc['median_m']:g} m, max {acc['max_m']:g} m)"
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
    for line in leftout.summary_lines(report.get("left_out", [])):
        print(f"warning: {line}")
    print(f"-> {paths.rel(paths.SEGMENTS)}, {paths.rel(paths.VALIDATION_REPORT)}")
