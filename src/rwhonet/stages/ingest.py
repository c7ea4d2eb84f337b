"""DVC stage ``ingest``: raw drive files -> one canonical Parquet per drive + ``manifest.json``.

Reads every drive listed by ``data.roles`` (IO-VNBD layout or a column map),
converts it to canonical names in SI units, adds the ``scenario`` column from
an optional ``<drive>.scenarios.json`` sidecar, and writes everything at once
(:func:`rwhonet.io.atomic_dir`): after a failure the previous output is left
as it was. Rows are kept exactly as in the file, in order (row ``i`` is data
row ``i + 1`` of the source file), so ``validate`` can point at the file's rows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from rwhonet import contracts, paths
from rwhonet.config import ConfigError, DataParams, Params
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import check_column_map, read_columnmap
from rwhonet.data.csvio import RawDrive
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.scenarios import (
    ScenarioInterval,
    read_scenarios,
    scenario_codes,
    sidecar_path,
)
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_dir, system_memory_pool, write_json, write_parquet
from rwhonet.progress import track

IOVNBD = "iovnbd"


@dataclass(frozen=True)
class DriveFile:
    """One raw drive file and what params say about it."""

    drive: str  # drive id = file stem
    role: str
    vehicle: str
    format: str  # "iovnbd" or a column map name
    path: Path


def check_data_params(data: DataParams) -> None:
    """Check what ``load_params`` cannot: the source/root pairing, role names, column maps.

    Args:
        data: the ``data`` section.

    Raises:
        ConfigError: listing every issue, with the dotted key to change.
    """
    issues = []
    if data.source == "sim" and paths.resolve(data.root).resolve() != paths.SIM.resolve():
        issues.append(
            f"data.source=sim reads the simulator's drives in {paths.rel(paths.SIM)}, but "
            f"data.root={data.root!r}: set data.root={paths.rel(paths.SIM)} (or data.source=files "
            "to read real drives from data.root)"
        )
    issues += [
        f"data.roles.{role}: unknown role; expected some of {list(contracts.ROLES)}"
        for role in data.roles
        if role not in contracts.ROLES
    ]
    issues += [
        f"data.roles.{role}: missing (required role)"
        for role in contracts.REQUIRED_ROLES
        if role not in data.roles
    ]
    if issues:
        raise ConfigError("\n".join(issues))
    for name in sorted({spec.format for spec in data.roles.values()} - {IOVNBD}):
        check_column_map(name, data.column_maps[name])


def discover(data: DataParams) -> list[DriveFile]:
    """List the drive files of every role, sorted by role (in ``ROLES`` order) and name.

    Args:
        data: the ``data`` section (globs are relative to ``data.root``).

    Returns:
        The drive files.

    Raises:
        InputError: a required role matches no file (naming the folder and glob), or a drive
            id (file stem) appears twice.
    """
    root = paths.resolve(data.root)
    problems: list[Problem] = []
    files: list[DriveFile] = []
    for role in (r for r in contracts.ROLES if r in data.roles):
        spec = data.roles[role]
        found = sorted(p for p in root.glob(spec.glob) if p.is_file())
        if not found and spec.required:
            folder = (root / spec.glob).parent
            near = sorted(p.name for p in folder.iterdir())[:5] if folder.is_dir() else []
            problems.append(
                Problem(
                    paths.rel(folder),
                    None,
                    None,
                    f"at least one drive file matching {spec.glob!r} under {paths.rel(root)} "
                    f"(data.roles.{role}, required)",
                    ("no matching file" + (f"; the folder holds {near}" if near else ""))
                    if folder.is_dir()
                    else "no such folder",
                    f"put the {role} drives in {paths.rel(folder)}, or correct "
                    f"data.roles.{role}.glob (and data.root)",
                )
            )
        files += [DriveFile(p.stem, role, spec.vehicle, spec.format, p) for p in found]
    first_seen: dict[str, DriveFile] = {}
    for f in files:
        other = first_seen.setdefault(f.drive, f)
        if other is not f:
            problems.append(
                Problem(
                    paths.rel(f.path),
                    None,
                    None,
                    "drive ids (file stems) unique across all roles",
                    f"{f.drive!r} ({f.role}) is also {paths.rel(other.path)} ({other.role})",
                    "rename one of the two files (a drive belongs to one role)",
                )
            )
    if problems:
        hint = " (data.source=sim: run the simulate stage first)" if data.source == "sim" else ""
        raise InputError(problems, summary=f"the drives listed in params.yaml data.roles{hint}")
    return files


def read_drive(f: DriveFile, data: DataParams) -> RawDrive:
    """Read one drive file with the reader its format names, if it is not too large.

    The readers stream the file, but the drive is then held in memory (here and in
    validate), so a file above ``data.max_file_mb`` is refused before it is read, and
    running out of memory while reading is reported as a problem of that file.

    Args:
        f: the drive file.
        data: the ``data`` section (for column maps and the size limit).

    Returns:
        The drive's channels, canonical names, SI units.

    Raises:
        InputError: the file is too large, runs out of memory, or its reader refuses it.
    """
    file = paths.rel(f.path)
    try:
        size_mb = f.path.stat().st_size / 2**20
    except OSError as err:  # gone since it was listed, or unreadable
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a readable file",
                    f"{type(err).__name__}: {err.strerror}",
                    "check that the file is there and readable (permissions), then run again",
                )
            ]
        ) from None
    if size_mb > data.max_file_mb:
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    f"a drive file of at most {data.max_file_mb:g} MB (data.max_file_mb)",
                    _mb(size_mb),
                    f"{SPLIT_DRIVE}, or raise data.max_file_mb on a machine with the memory "
                    "(validate holds about 3x the file's size)",
                )
            ]
        )
    try:
        if f.format == IOVNBD:
            return read_iovnbd(f.path, file)
        return read_columnmap(f.path, data.column_maps[f.format], f.format, file)
    except MemoryError:
        raise _out_of_memory(f) from None


SPLIT_DRIVE = "split the drive into several files (one per trip)"


def _mb(size_mb: float) -> str:
    return f"{size_mb:,.0f} MB" if size_mb >= 10 else f"{size_mb:.3g} MB"


def _out_of_memory(f: DriveFile) -> InputError:
    size_mb = f.path.stat().st_size / 2**20 if f.path.exists() else float("nan")
    return InputError(
        [
            Problem(
                paths.rel(f.path),
                None,
                None,
                "a drive that fits in this machine's memory",
                f"out of memory on its {_mb(size_mb)}",
                f"{SPLIT_DRIVE}, or run on a machine with more memory (ingest holds about "
                "1.5x the file's size, validate about 3x), and lower data.max_file_mb to what "
                "fits",
            )
        ]
    )


def canonical_table(raw: RawDrive, scenario: np.ndarray | pa.Array) -> pa.Table:
    """Assemble the canonical drive table: required, then optional channels, then ``scenario``.

    Every column is declared non-nullable: channels are float64 with missing values as NaN
    (never Arrow nulls), and a row without tags has ``""``. Parquet then stores no
    definition levels, which halves the time to write and to read the channels.

    Args:
        raw: the channels read from the file.
        scenario: per-row scenario labels (strings, or an Arrow string array).

    Returns:
        An Arrow table with float64 channels and a string ``scenario`` column.
    """
    order = [name for name in (*c.REQUIRED, *c.OPTIONAL) if name in raw.columns]
    arrays = [pa.array(raw.columns[name], type=pa.float64()) for name in order]
    arrays.append(scenario if isinstance(scenario, pa.Array) else pa.array(scenario, pa.string()))
    schema = pa.schema(
        [pa.field(name, pa.float64(), nullable=False) for name in order]
        + [pa.field(c.SCENARIO, pa.string(), nullable=False)]
    )
    return pa.Table.from_arrays(arrays, schema=schema)


def scenario_array(t_s: np.ndarray, intervals: list[ScenarioInterval]) -> pa.Array:
    """Return a drive's ``scenario`` column as an Arrow string array.

    Args:
        t_s: row times, s.
        intervals: the drive's tagged intervals (:func:`rwhonet.data.scenarios.read_scenarios`).

    Returns:
        One ';'-joined tag string per row (:func:`rwhonet.data.scenarios.scenario_column`).
    """
    labels, codes = scenario_codes(t_s, intervals)
    # Arrow copies the few distinct labels per row in C++, rather than building one
    # Python string per row and converting them.
    return pa.array(labels, type=pa.string()).take(pa.array(codes))


@system_memory_pool()
def ingest(params: Params, out_dir: Path, failed_report_path: Path | None = None) -> dict[str, Any]:
    """Read every drive of ``data.roles`` and write the canonical drives with their manifest.

    Args:
        params: the project parameters (``data`` section used).
        out_dir: output folder (``rwhonet.paths.DRIVES``); replaced only on success.
        failed_report_path: where the problems of a failed run go as JSON
            (``rwhonet.paths.INGEST_FAILED_REPORT``); removed by a successful run. None:
            not written.

    Returns:
        The manifest written to ``out_dir/manifest.json``:
        ``{"drives": [{"drive", "role", "vehicle", "format", "source_file", "n_rows",
        "header_match", "columns", "scenarios_file", "calibrates"}], "calibration": {...}}``,
        where ``columns`` maps each canonical channel to the file's column name.

    Raises:
        ConfigError: inconsistent ``data`` parameters.
        InputError: one report of every problem in every drive file; nothing is written.
    """
    try:
        manifest = _ingest(params, out_dir)
    except InputError as err:
        if failed_report_path is not None:
            write_json(
                failed_report_path,
                {
                    "status": "failed",
                    "note": f"ingest refused the drives: nothing was written to "
                    f"{paths.rel(out_dir)}; a successful run removes this file",
                    "summary": err.summary,
                    "problems": [p.to_dict() for p in err.problems],
                },
            )
            summary = f"{err.summary} (full report: {paths.rel(failed_report_path)})"
            raise InputError(err.problems, summary=summary) from None
        raise
    if failed_report_path is not None:
        Path(failed_report_path).unlink(missing_ok=True)  # that failure is over
    return manifest


def _ingest(params: Params, out_dir: Path) -> dict[str, Any]:
    """The body of :func:`ingest`."""
    data = params.data
    check_data_params(data)
    files = discover(data)
    calibration = _calibration(files)
    problems: list[Problem] = []
    entries: list[dict[str, Any]] = []
    with atomic_dir(out_dir) as tmp:
        for f in track(files, desc="ingest", unit="drive", label=lambda f: f.drive):
            try:
                # One drive in memory at a time: _write_drive's locals go when it returns.
                entry = _write_drive(f, data, tmp, write=not problems)
            except InputError as err:
                problems += err.problems  # keep reading: one report covers every file
                continue
            entry["calibrates"] = f.drive in calibration["drives"]
            entries.append(entry)
        if problems:
            files_bad = len({p.file for p in problems})
            raise InputError(
                problems, summary=f"ingest: {len(problems)} problem(s) in {files_bad} file(s)"
            )
        manifest = {
            "source": data.source,
            "root": paths.rel(paths.resolve(data.root)),
            "drives": entries,
            "calibration": calibration,
        }
        write_json(tmp / contracts.MANIFEST, manifest)
    return manifest


def _write_drive(f: DriveFile, data: DataParams, tmp: Path, write: bool) -> dict[str, Any]:
    """Read one drive (and its sidecar); write its canonical Parquet unless ``write`` is False.

    Returns:
        Its manifest entry (without ``calibrates``).

    Raises:
        InputError: the file's problems, or running out of memory on it.
    """
    raw = read_drive(f, data)
    sidecar = sidecar_path(f.path)
    intervals = read_scenarios(sidecar, paths.rel(sidecar)) if sidecar.is_file() else []
    if write:  # else the stage will fail: don't spend time writing
        try:
            write_parquet(
                canonical_table(raw, scenario_array(raw.columns[c.T_S], intervals)),
                tmp / f"{f.drive}.parquet",
            )
        except MemoryError:
            raise _out_of_memory(f) from None
    return {
        "drive": f.drive,
        "role": f.role,
        "vehicle": f.vehicle,
        "format": f.format,
        "source_file": paths.rel(f.path),
        "n_rows": raw.n_rows,
        "header_match": raw.header_match,
        "columns": raw.source_columns,
        "scenarios_file": paths.rel(sidecar) if sidecar.is_file() else None,
    }


def _calibration(files: list[DriveFile]) -> dict[str, Any]:
    """Which drives calibrate the wheel radii: source_calibration, else the first source_train."""
    own = [f.drive for f in files if f.role == contracts.SOURCE_CALIBRATION]
    if own:
        return {"role": contracts.SOURCE_CALIBRATION, "drives": own, "fallback": False}
    fallback = sorted(f.drive for f in files if f.role == contracts.CALIBRATION_FALLBACK_ROLE)
    if not fallback:
        raise InputError(
            [
                Problem(
                    "params.yaml data.roles",
                    None,
                    None,
                    f"a {contracts.SOURCE_CALIBRATION} or {contracts.CALIBRATION_FALLBACK_ROLE} "
                    "drive to calibrate the wheel radii",
                    "neither role has a drive",
                    "add a source_train drive (data.roles.source_train)",
                )
            ]
        )
    first = fallback[0]
    return {
        "role": contracts.CALIBRATION_FALLBACK_ROLE,
        "drives": [first],
        "fallback": True,
        "note": f"no {contracts.SOURCE_CALIBRATION} drive: the first "
        f"{contracts.CALIBRATION_FALLBACK_ROLE} drive (sorted by name) calibrates",
    }


def summary_table(manifest: dict[str, Any]) -> str:
    """Return a short text table of the ingested drives (for the stage's output).

    Args:
        manifest: what :func:`ingest` returned.

    Returns:
        One line per drive and a total line.
    """
    lines = [f"{'drive':<24} {'role':<18} {'vehicle':<8} {'rows':>9}  columns by"]
    for d in manifest["drives"]:
        mark = "  (calibrates)" if d["calibrates"] else ""
        lines.append(
            f"{d['drive']:<24} {d['role']:<18} {d['vehicle']:<8} {d['n_rows']:>9}  "
            f"{d['header_match']}{mark}"
        )
    total = sum(d["n_rows"] for d in manifest["drives"])
    lines.append(f"{len(manifest['drives'])} drive(s), {total} rows")
    return "\n".join(lines)


def main(params: Params) -> None:
    """The ``ingest`` stage: every drive of ``data.roles`` -> ``data/interim/drives``."""
    start = time.perf_counter()
    manifest = ingest(params, paths.DRIVES, paths.INGEST_FAILED_REPORT)
    seconds = time.perf_counter() - start
    rows = sum(d["n_rows"] for d in manifest["drives"])
    print(summary_table(manifest))
    cal = manifest["calibration"]
    print(f"calibration: {', '.join(cal['drives'])} ({cal.get('note', cal['role'])})")
    print(
        f"{rows} rows in {seconds:.2f} s ({rows / max(seconds, 1e-9) / 1e6:.2f} M rows/s) "
        f"-> {paths.rel(paths.DRIVES)}"
    )
