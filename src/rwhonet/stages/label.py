"""DVC stage ``label``: GNSS-valid segments -> calibrated, labelled, scaled per-second samples.

Reads ``data/interim/segments`` (manifest + one Arrow file per segment), and writes
(docs/architecture.md, "Samples"):

- ``data/processed/samples/<segment>.parquet``: one row per second with
  ``t_s, disp_gnss_m, disp_wpm_m, label_m`` (float64), ``x_00 .. x_39``
  (float32, scaled) and ``scenario`` (str), plus ``manifest.json``;
- ``data/processed/calibration.json``: the rear radii the WPM used;
- ``data/processed/scaler.json``: min-max statistics from source_train.

The rear radii are fitted on the segments of the calibration drives that
ingest chose and recorded in the manifests (``"calibration": {"role", "drives"}``:
the ``source_calibration`` drives, else the first ``source_train`` drive by
name); ``calibration.json`` says what was used. The same radii serve every vehicle:
the WPM of the target vehicle is deliberately the source-calibrated one, so
its radius mismatch is part of the target labels, which is what R-WhONet's
adaptation is to learn (paper Sec. 3).
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from rwhonet import contracts, paths
from rwhonet.config import Params
from rwhonet.data import leftout
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import (
    Calibration,
    fit_radii_mean_of_ratios,
    fit_radii_ratio_of_sums,
    fit_summary,
)
from rwhonet.features.labels import sample_table
from rwhonet.features.scaling import fit_scaler
from rwhonet.features.seconds import (
    SEGMENT_COLUMNS,
    SegmentSeconds,
    segment_arrays,
    segment_seconds,
)
from rwhonet.io import (
    atomic_outputs,
    map_in_order,
    read_arrow,
    read_json,
    write_json,
    write_parquet,
)
from rwhonet.progress import track

TRAIN_ROLE = contracts.SOURCE_TRAIN
MANIFEST_KEYS = ("segment", "drive", "role", "vehicle")


@dataclass(frozen=True)
class SegmentEntry:
    """One line of the segments manifest (the fields label uses)."""

    segment: str
    drive: str
    role: str
    vehicle: str
    n_seconds: int | None = None  # validate's count, cross-checked against the rows
    source_file: str | None = None  # the drive file it was cut from (for messages)


@dataclass(frozen=True)
class SegmentManifest:
    """The validate stage's manifest: segments in order, and ingest's calibration record.

    Attributes:
        entries: the segments.
        calibration_drives: the drives ingest chose to calibrate the radii.
        calibration_role: the role of those drives.
        left_out: the drives ingest or validate left out (``data.refused_drives:
            leave_out``), as :func:`rwhonet.data.leftout.brief` gives them.
    """

    entries: list[SegmentEntry]
    calibration_drives: list[str]
    calibration_role: str
    left_out: list[dict[str, Any]] = field(default_factory=list)


def read_segment_manifest(path: Path) -> SegmentManifest:
    """Read and check ``segments/manifest.json``.

    Args:
        path: the manifest written by the validate stage.

    Returns:
        The segments in manifest order, and the calibration record if present.

    Raises:
        InputError: if the file is missing, an entry lacks a field, or a segment id repeats.
    """
    file = paths.rel(path)
    if not Path(path).is_file():
        raise InputError([Problem(file, None, None, "the validate stage's manifest", "no file")])
    try:
        raw = read_json(path)
    except json.JSONDecodeError as err:
        raise InputError([Problem(file, err.lineno, None, "valid JSON", err.msg)]) from err
    entries = raw.get("segments") if isinstance(raw, dict) else None
    if not isinstance(entries, list):
        raise InputError([Problem(file, None, "segments", "a list of segments", repr(raw)[:80])])
    problems: list[Problem] = []
    seen: set[str] = set()
    for i, entry in enumerate(entries):  # row = 1-based entry number
        if not isinstance(entry, dict):
            problems.append(Problem(file, i + 1, None, "an object", repr(entry)[:80]))
            continue
        problems += [
            Problem(file, i + 1, key, "a non-empty string", repr(entry.get(key)))
            for key in MANIFEST_KEYS
            if not (isinstance(entry.get(key), str) and entry.get(key))
        ]
        n_sec = entry.get("n_seconds")
        if n_sec is not None and not (isinstance(n_sec, int) and n_sec >= 0):
            problems.append(Problem(file, i + 1, "n_seconds", "a count >= 0", repr(n_sec)))
        if entry.get("segment") in seen:
            problems.append(Problem(file, i + 1, "segment", "a unique id", repr(entry["segment"])))
        seen.add(entry.get("segment"))
    record = raw.get("calibration")
    drives = record.get("drives") if isinstance(record, dict) else None
    if not (isinstance(drives, list) and drives and all(isinstance(d, str) for d in drives)):
        problems.append(
            Problem(file, None, "calibration", '{"role": ..., "drives": [drive ids]}', repr(record))
        )
    if problems:
        raise InputError(problems, f"{file} is not a valid segments manifest")
    return SegmentManifest(
        entries=[
            SegmentEntry(
                *(entry[key] for key in MANIFEST_KEYS),
                entry.get("n_seconds"),
                entry.get("source_file") if isinstance(entry.get("source_file"), str) else None,
            )
            for entry in entries
        ],
        calibration_drives=list(drives),
        calibration_role=str(record.get("role")),
        left_out=[leftout.brief(d) for d in raw.get("left_out") or []],
    )


def read_segment(path: Path) -> dict[str, np.ndarray | pa.ChunkedArray]:
    """Read the columns of a segment file the label stage needs.

    Args:
        path: ``<segments>/<segment>.arrow``.

    Returns:
        The canonical columns present among ``t_s, lat_deg, lon_deg, omega_*,
        yaw_rate_rad_s, scenario`` (a missing required column is reported by the
        per-second check; the yaw rate is optional): float64 numpy arrays, and
        ``scenario`` as the file's Arrow string column (no Python string per row).

    Raises:
        InputError: if the file does not exist or is not an Arrow IPC file.
    """
    if not Path(path).is_file():
        raise InputError(
            [Problem(paths.rel(path), None, None, "a segment listed in the manifest", "no file")]
        )
    try:
        table = read_arrow(path, list(SEGMENT_COLUMNS))
    except (OSError, pa.ArrowException) as err:
        expected = "a segment as the validate stage writes it (an Arrow IPC file)"
        fix = "run the validate stage again (dvc repro validate)"
        raise InputError([Problem.unreadable(paths.rel(path), expected, err, fix)]) from None
    return segment_arrays(table)


def calibrate(
    manifest: SegmentManifest, seconds: dict[str, SegmentSeconds], min_speed_m_s: float
) -> Calibration:
    """Fit the rear radii on the calibration segments.

    Args:
        manifest: the segments manifest (its calibration record names the drives).
        seconds: per-second quantities by segment id.
        min_speed_m_s: moving-second threshold.

    Returns:
        The calibration (ratio-of-sums radii, the authors' estimate alongside).

    Raises:
        InputError: when the calibration drives have no GNSS-valid segment left, or
            never move fast enough to fit.
    """
    role = manifest.calibration_role
    chosen = [e for e in manifest.entries if e.drive in manifest.calibration_drives]
    if not chosen:
        raise InputError(
            [
                Problem(
                    "segments manifest",
                    None,
                    "calibration",
                    "GNSS-valid segments of the calibration drive(s)",
                    f"none for {manifest.calibration_drives} (all cut by validate?)",
                )
            ]
        )
    parts = [seconds[e.segment] for e in chosen]

    def cat(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts])

    disp = cat("disp_gnss_m")
    try:
        fit = fit_radii_ratio_of_sums(
            disp, cat("angle_rl_rad"), cat("angle_rr_rad"), cat("span_s"), min_speed_m_s
        )
    except ValueError as err:
        raise InputError(
            [
                Problem(
                    ", ".join(e.segment for e in chosen), None, None, "a drive that moves", str(err)
                )
            ],
            "the rear wheel radii cannot be calibrated",
        ) from err
    authors = fit_radii_mean_of_ratios(disp, cat("omega_end_rl_rad_s"), cat("omega_end_rr_rad_s"))
    return Calibration(
        r_rl_m=fit.r_rl_m,
        r_rr_m=fit.r_rr_m,
        estimator=fit.estimator,
        min_speed_m_s=min_speed_m_s,
        n_seconds_used=fit.n_seconds,
        n_seconds_total=len(disp),
        distance_m=fit.distance_m,
        role=role,
        drives=sorted({e.drive for e in chosen}),
        segments=[e.segment for e in chosen],
        comparison={"mean_of_ratios": fit_summary(authors)},
    )


def _per_second_all(
    entries: Iterable[SegmentEntry], segments_dir: Path
) -> dict[str, SegmentSeconds]:
    seconds: dict[str, SegmentSeconds] = {}
    problems: list[Problem] = []
    entries = list(entries)

    def per_second(entry: SegmentEntry) -> SegmentSeconds:
        path = Path(segments_dir) / f"{entry.segment}{contracts.TABLE_SUFFIX}"
        return segment_seconds(read_segment(path), paths.rel(path))

    # A few segments at once (rwhonet.io.map_in_order): reading and the per-second arrays
    # run outside Python's lock.
    done = map_in_order(per_second, entries)
    for entry, sec_of in track(
        done, desc="label", unit="segment", total=len(entries), label=lambda x: x[0].segment
    ):
        path = Path(segments_dir) / f"{entry.segment}{contracts.TABLE_SUFFIX}"
        try:
            sec = sec_of.result()
        except InputError as err:  # report every bad segment at once
            problems += err.problems
            continue
        if entry.n_seconds is not None and entry.n_seconds != len(sec):
            # validate and label must cut the same seconds (data/quality.py's convention)
            problems.append(
                Problem(
                    paths.rel(path),
                    None,
                    None,
                    f"{entry.n_seconds} seconds as the manifest says (10 n + 1 rows)",
                    f"{sec.n_rows} rows = {len(sec)} seconds",
                )
            )
        seconds[entry.segment] = sec
    if problems:
        raise InputError(problems, "segments that cannot be labelled")
    return seconds


def label(
    params: Params, segments_dir: Path, out_dir: Path, calibration_path: Path, scaler_path: Path
) -> dict[str, Any]:
    """Run the label stage: per-second samples, rear-radius calibration and input scaler.

    Args:
        params: the pipeline parameters (``label`` section used).
        segments_dir: the validate stage's output folder (``manifest.json``, a file per segment).
        out_dir: the samples folder to (re)write, replaced atomically.
        calibration_path: where ``calibration.json`` goes.
        scaler_path: where ``scaler.json`` goes.

    Returns:
        Summary: radii, calibration drives, WPM mode, scaler kind, and per role the
        number of segments, rows, seconds and the mean label (m).

    Raises:
        InputError: for a bad manifest or segment, no source_train seconds, or a
            calibration drive that never moves.
    """
    cfg = params.label
    manifest = read_segment_manifest(Path(segments_dir) / contracts.MANIFEST)
    entries = manifest.entries
    seconds = _per_second_all(entries, Path(segments_dir))
    calibration = calibrate(manifest, seconds, cfg.calibration_min_speed_m_s)

    train = [e for e in entries if e.role == TRAIN_ROLE and len(seconds[e.segment])]
    if not train:
        raise InputError(
            [
                Problem(
                    paths.rel(Path(segments_dir) / "manifest.json"),
                    None,
                    "role",
                    f"{TRAIN_ROLE} seconds",
                    "none",
                )
            ],
            "the input scaler must be fitted on source_train seconds",
        )
    try:
        scaler = fit_scaler(
            [seconds[e.segment].wheels_rad_s for e in train],
            cfg.scaler,
            sorted({e.drive for e in train}),
        )
    except ValueError as err:
        raise InputError(
            [
                Problem(
                    ", ".join(dict.fromkeys(e.source_file or e.segment for e in train)),
                    None,
                    None,
                    "varying, finite wheel speeds over the source_train drives",
                    str(err),
                    fix="check the wheel-speed columns of these files (validate.wheels) or "
                    "add source_train drives with moving wheels",
                )
            ]
        ) from err

    tables = {
        e.segment: sample_table(seconds[e.segment], calibration, scaler, cfg.wpm_mode)
        for e in entries
    }
    with atomic_outputs(out_dir, calibration_path, scaler_path, folders=(True, False, False)) as (
        tmp,
        tmp_calibration,
        tmp_scaler,
    ):
        written = map_in_order(
            lambda kv: write_parquet(kv[1], tmp / f"{kv[0]}.parquet"), tables.items()
        )
        for _, done in written:
            done.result()
        write_json(
            tmp / contracts.MANIFEST,
            {
                "segments": [
                    {
                        "segment": e.segment,
                        "drive": e.drive,
                        "role": e.role,
                        "vehicle": e.vehicle,
                        "n_seconds": tables[e.segment].num_rows,
                    }
                    for e in entries
                ],
                # only where a drive was left out: the manifest a run without is unchanged
                **({"left_out": manifest.left_out} if manifest.left_out else {}),
            },
        )
        write_json(tmp_calibration, calibration.to_dict())
        write_json(tmp_scaler, scaler.to_dict())

    roles: dict[str, dict[str, Any]] = {}
    for role in dict.fromkeys(e.role for e in entries):
        mine = [e for e in entries if e.role == role]
        labels = np.concatenate([tables[e.segment]["label_m"].to_numpy() for e in mine])
        roles[role] = {
            "segments": len(mine),
            "rows": sum(seconds[e.segment].n_rows for e in mine),
            "seconds": len(labels),
            "label_mean_m": float(labels.mean()) if len(labels) else None,
        }
    return {
        "r_rl_m": calibration.r_rl_m,
        "r_rr_m": calibration.r_rr_m,
        "calibration_role": calibration.role,
        "calibration_drives": calibration.drives,
        "wpm_mode": cfg.wpm_mode,
        "scaler": scaler.kind,
        "roles": roles,
    }


def main(params: Params) -> None:
    """The ``label`` stage: segments -> samples, ``calibration.json`` and ``scaler.json``."""
    start = time.perf_counter()
    summary = label(params, paths.SEGMENTS, paths.SAMPLES, paths.CALIBRATION, paths.SCALER)
    elapsed_s = time.perf_counter() - start
    print(
        f"rear radii r_rl = {summary['r_rl_m']:.5f} m, r_rr = {summary['r_rr_m']:.5f} m "
        f"({summary['calibration_role']}: {', '.join(summary['calibration_drives'])}); "
        f"WPM {summary['wpm_mode']}, scaler {summary['scaler']} (source_train)"
    )
    rows = 0
    for role, info in summary["roles"].items():
        rows += info["rows"]
        mean = info["label_mean_m"]
        print(
            f"  {role:<20} {info['segments']:>4} segments {info['seconds']:>8} seconds"
            + (f"  mean label {mean:+.3f} m" if mean is not None else "")
        )
    print(f"{rows:,} rows in {elapsed_s:.1f} s -> {paths.rel(paths.SAMPLES)}")
