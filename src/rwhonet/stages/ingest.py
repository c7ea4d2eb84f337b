"""DVC stage ``ingest``: raw drive files -> one canonical Arrow file per drive + ``manifest.json``.

Reads every drive listed by ``data.roles`` (IO-VNBD layout, a column map, a
comma2k19 folder, or an MDF4 file or a folder of stream CSVs through a signal map;
docs/architecture.md, "Raw drives"), converts it to canonical names in SI units
(stream drives resampled onto the ``validate.sample_period_s`` grid), adds the
``scenario`` column from an optional ``<drive>.scenarios.json`` sidecar, and
writes everything at once (:func:`rwhonet.io.atomic_dir`): after a failure the
previous output is left as it was. Reading one file (its reader, size limit and canonical table) is
:mod:`rwhonet.data.drivefile`'s, which ``rwhonet recalibrate`` uses too; rows
are kept exactly as in the file, in order (row ``i`` is data row ``i + 1`` of
the source file), so ``validate`` can point at the file's rows. A drive the
readers refuse fails the stage, or with ``data.refused_drives: leave_out`` is left
out and named in the manifest's ``left_out`` (:mod:`rwhonet.data.leftout`).
"""

from __future__ import annotations

import fnmatch
import time
from pathlib import Path
from typing import Any

from rwhonet import contracts, paths
from rwhonet.config import ConfigError, DataParams, Params, RoleSpec
from rwhonet.data import leftout
from rwhonet.data.columnar import folder_id, is_table_folder
from rwhonet.data.columnmap import check_column_map
from rwhonet.data.compressed import drive_stem
from rwhonet.data.drivefile import (
    COLUMN_MAP,
    IOVNBD,
    MDF4,
    STREAM_CSV,
    DriveFile,
    fleet_column,
    fleet_drives,
    is_folder_format,
    out_of_memory,
    read_canonical,
    reader_kind,
    source_name,
)
from rwhonet.data.droprows import manifest_rows
from rwhonet.data.rosbag import is_rosbag2_folder
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_dir, map_in_order, scratch_dir, write_arrow, write_json
from rwhonet.progress import track


def check_data_params(data: DataParams) -> None:
    """Check what ``load_params`` cannot: the source/root pairing, role names, the maps used.

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
    for name in sorted({spec.format for spec in data.roles.values()}):
        kind = reader_kind(name, data)
        if kind == COLUMN_MAP:
            check_column_map(name, data.column_maps[name])
        elif name in data.signal_maps:
            # imported here: a 10 Hz fleet never needs the stream readers
            from rwhonet.data.signalmap import check_signal_map

            check_signal_map(name, data.signal_maps[name].signals, with_time=kind == STREAM_CSV)


def _hidden(path: Path, root: Path) -> bool:
    """A name starting with a dot on the path below ``root``: macOS's AppleDouble files
    (``._V-A.csv``, written beside every file copied to a FAT or exFAT disk), ``.DS_Store``,
    an editor's swap file. pathlib's glob matches them, the shell's does not."""
    try:
        parts = path.relative_to(root).parts
    except ValueError:  # a glob that leaves the root: its own name only
        parts = (path.name,)
    return any(part.startswith(".") and part not in (".", "..") for part in parts)


def _sqlite_companion(path: Path) -> bool:
    """SQLite's own file beside a ROS 2 bag's ``.db3`` given alone (``drive_0.db3-wal``,
    its write-ahead log, read with it; ``-shm``, ``-journal``): part of that drive, no
    drive of its own."""
    for suffix in ("-wal", "-shm", "-journal"):
        if path.name.lower().endswith(".db3" + suffix):
            return path.with_name(path.name[: -len(suffix)]).is_file()
    return False


def _table_folder(path: Path, spec: RoleSpec, data: DataParams) -> bool:
    """Whether a 10 Hz role's match is a folder of Parquet part files (a drive Spark or
    Dask wrote as a folder: ``C-B1.parquet/part-00000-...parquet``), read as one table."""
    return reader_kind(spec.format, data) in (IOVNBD, COLUMN_MAP) and is_table_folder(path)


def discover(data: DataParams, scratch: Path | None = None) -> list[DriveFile]:
    """List the drives of every role, sorted by role (in ``ROLES`` order) and name.

    A role's glob matches files for the formats that read one file per drive (IO-VNBD,
    column maps, MDF4; and a ROS 2 bag's folder for MDF4's reader) and folders for those
    that read one folder per drive (comma2k19, stream CSVs); the drive id is the file's
    stem or the folder's name. Hidden files and folders (a name starting with a dot, as
    macOS's ``._`` files) are no drives, nor SQLite's files beside a ``.db3``
    (``-wal``: read with it). A file of many drives (a column map with a ``drive`` column:
    :mod:`rwhonet.data.fleetfile`) is its drives, each named by its id.

    Args:
        data: the ``data`` section (globs are relative to ``data.root``).
        scratch: a folder where each file of many drives is split into its drives' own
            CSVs as it is listed (None: listed only; read later, each drive's rows alone).

    Returns:
        The drives.

    Raises:
        InputError: a required role matches no file (naming the folder and glob), or a drive
            id (file stem) appears twice.
    """
    root = paths.resolve(data.root)
    problems: list[Problem] = []
    files: list[DriveFile] = []
    for role in (r for r in contracts.ROLES if r in data.roles):
        spec = data.roles[role]
        folders = is_folder_format(spec.format, data)
        bags = reader_kind(spec.format, data) == MDF4  # a ROS 2 bag is a folder
        found = sorted(
            p
            for p in root.glob(spec.glob)
            if not _hidden(p, root)
            and not _sqlite_companion(p)
            and (
                p.is_dir()
                if folders
                else p.is_file() or (bags and is_rosbag2_folder(p)) or _table_folder(p, spec, data)
            )
        )
        if not found and spec.required:
            folder = (root / spec.glob).parent
            near = sorted(p.name for p in folder.iterdir())[:5] if folder.is_dir() else []
            problems.append(
                Problem(
                    paths.rel(folder),
                    None,
                    None,
                    f"at least one drive {'folder' if folders else 'file'} matching "
                    f"{spec.glob!r} under {paths.rel(root)} (data.roles.{role}, required, "
                    f"format {spec.format})",
                    ("no matching file" + (f"; the folder holds {near}" if near else ""))
                    if folder.is_dir()
                    else "no such folder",
                    f"put the {role} drives in {paths.rel(folder)}, or correct "
                    f"data.roles.{role}.glob (and data.root)",
                )
            )
        found_files = [
            DriveFile(
                folder_id(p) if p.is_dir() else drive_stem(p), role, spec.vehicle, spec.format, p
            )
            for p in found
        ]
        if fleet_column(spec.format, data) is not None:  # files of many drives: their drives
            found_files = _fleet_drives(found_files, data, role, scratch, problems)
        if spec.drives is not None and found_files:
            found_files = _chosen(found_files, spec, role, paths.rel(root / spec.glob), problems)
        files += found_files
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


def _fleet_drives(
    found: list[DriveFile],
    data: DataParams,
    role: str,
    scratch: Path | None,
    problems: list[Problem],
) -> list[DriveFile]:
    """The drives of a role's files of many drives, each file split into them; a file
    that cannot be split adds its problems."""
    drives: list[DriveFile] = []
    patterns = data.roles[role].drives
    keep = None if patterns is None else (lambda d: _matches(d, patterns))
    for k, f in enumerate(found):
        dest = None
        if scratch is not None:
            dest = scratch / f"{role}-{k}"
            dest.mkdir()
        try:
            drives += fleet_drives(f, data, paths.rel, dest, keep)
        except InputError as err:
            problems += err.problems
    return drives


def _matches(drive: str, patterns: list[str]) -> bool:
    """Whether a drive id matches one of a role's ``drives`` patterns (case-sensitive)."""
    return any(fnmatch.fnmatchcase(drive, p) for p in patterns)


def _chosen(
    found: list[DriveFile], spec: RoleSpec, role: str, where: str, problems: list[Problem]
) -> list[DriveFile]:
    """A role's drives that its ``drives`` patterns name; a pattern that names none of the
    drives its glob finds adds a problem (a mistyped id is no drive left out unsaid)."""
    assert spec.drives is not None
    ids = [f.drive for f in found]
    for pattern in spec.drives:
        if not any(fnmatch.fnmatchcase(d, pattern) for d in ids):
            listed = ", ".join(ids[:10]) + (f" and {len(ids) - 10} more" if len(ids) > 10 else "")
            problems.append(
                Problem(
                    where,
                    None,
                    None,
                    f"a drive whose id matches {pattern!r} among the drives "
                    f"data.roles.{role}.glob ({spec.glob!r}) finds",
                    f"none of its {len(ids)}: {listed}",
                    f"correct data.roles.{role}.drives (an id, or a pattern such as T-04*)",
                )
            )
    return [f for f in found if _matches(f.drive, spec.drives)]


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
        where ``columns`` maps each canonical channel to the file's column name; a drive
        whose reader had something to say has ``notes`` (columns taken by position, the
        clock passing midnight, grid rows without data), and a stream drive ``streams``
        (:meth:`rwhonet.data.drivefile.StreamFacts.to_dict`: each stream's samples and
        step, and the grid rows whose wheel-speed mean used a glitched sample). A
        manifest has ``untracked`` where a CAN database it read lies outside ``data.root``
        (:func:`untracked_inputs`), and ``left_out`` where ``data.refused_drives: leave_out``
        left out a drive the readers refused (:func:`rwhonet.data.leftout.left_out_entry`).

    Raises:
        ConfigError: inconsistent ``data`` parameters.
        InputError: one report of every problem in every drive file (with ``leave_out``: of
            the drives of a required role left without one); nothing is written.
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
    # files of many drives split into their drives' CSVs, read from there
    with scratch_dir("fleet") as scratch:
        return _ingest_files(params, out_dir, discover(data, Path(scratch)))


def _ingest_files(params: Params, out_dir: Path, files: list[DriveFile]) -> dict[str, Any]:
    """:func:`_ingest` once the drives are listed."""
    data = params.data
    leave_out = data.refused_drives == leftout.LEAVE_OUT
    problems: list[Problem] = []
    entries: list[tuple[DriveFile, dict[str, Any]]] = []
    left_out: list[dict[str, Any]] = []
    with atomic_dir(out_dir) as tmp:
        # A few drives at once (rwhonet.io.map_in_order: DATA_THREADS threads), each in
        # memory only while it is read and written: _write_drive's locals go when it returns.
        done = map_in_order(lambda f: _write_drive(f, params, tmp), files)
        for f, entry_of in track(
            done, desc="ingest", unit="drive", total=len(files), label=lambda x: x[0].drive
        ):
            try:
                entries.append((f, entry_of.result()))
            except InputError as err:
                problems += err.problems  # keep reading: one report covers every file
                left_out.append(leftout.left_out_entry(_described(f), "ingest", err.problems))
        if problems and not leave_out:
            files_bad = len({p.file for p in problems})
            raise InputError(
                problems, summary=f"ingest: {len(problems)} problem(s) in {files_bad} file(s)"
            )
        required = [role for role, spec in data.roles.items() if spec.required]
        kept_roles = [f.role for f, _ in entries]
        if emptied := leftout.emptied_roles(required, kept_roles, left_out):
            raise InputError(
                emptied,
                summary=f"ingest: a required role has no drive left ({len(left_out)} "
                "drive(s) refused, data.refused_drives: leave_out)",
            )
        for d in left_out:  # a table written before its drive ran out of memory
            (tmp / f"{d['drive']}{contracts.TABLE_SUFFIX}").unlink(missing_ok=True)
        calibration = _calibration([f for f, _ in entries])
        for f, entry in entries:
            entry["calibrates"] = f.drive in calibration["drives"]
        manifest = {
            "source": data.source,
            "root": paths.rel(paths.resolve(data.root)),
            "drives": [entry for _, entry in entries],
            "calibration": calibration,
        }
        if left_out:  # only then: a run without refusals writes the manifest it always did
            manifest["left_out"] = left_out
        if untracked := untracked_inputs(data, files):
            manifest["untracked"] = untracked
        write_json(tmp / contracts.MANIFEST, manifest)
    return manifest


def _described(f: DriveFile) -> dict[str, Any]:
    """A drive file as the manifest names it (the first keys of its entry; a drive left out's)."""
    return {
        "drive": f.drive,
        "role": f.role,
        "vehicle": f.vehicle,
        "format": f.format,
        "source_file": source_name(f, paths.rel),
    }


def _write_drive(f: DriveFile, params: Params, tmp: Path) -> dict[str, Any]:
    """Read one drive (and its sidecar); write its canonical Arrow file.

    Returns:
        Its manifest entry (without ``calibrates``).

    Raises:
        InputError: the file's problems, or running out of memory on it.
    """
    data, vp = params.data, params.validate
    spec = data.vehicles.get(f.vehicle)
    # the car's radius (wheel speeds logged in km/h, a stream drive's glitch screen) and,
    # for a stream drive, the grid
    drive = read_canonical(
        f,
        data,
        paths.rel,
        radius_m=None if spec is None else spec.nominal_radius_m,
        period_s=vp.sample_period_s,
        split_gap_s=vp.gnss.max_gap_s,
    )
    raw = drive.raw
    try:
        write_arrow(drive.table(), tmp / f"{f.drive}{contracts.TABLE_SUFFIX}")
    except MemoryError:
        raise out_of_memory(f, paths.rel) from None
    return {
        **_described(f),
        "n_rows": raw.n_rows,
        "header_match": raw.header_match,
        "columns": raw.source_columns,
        "scenarios_file": None if drive.sidecar is None else paths.rel(drive.sidecar),
        # only when there is something to say (a 10 Hz drive read as it is has neither)
        **({"notes": list(raw.notes)} if raw.notes else {}),
        # rows written twice or without a wheel speed, dropped: the file's data rows, every
        # one (validate's messages name the file's rows through them: droprows.FileRows)
        **manifest_rows(raw),
        **({"streams": drive.streams.to_dict()} if drive.streams is not None else {}),
    }


def untracked_inputs(data: DataParams, files: list[DriveFile]) -> list[str]:
    """What ingest read that ``dvc repro`` does not track: a CAN database (a signal map's
    ``dbc``) outside ``data.root``, the folder the stage depends on. A change to it alone
    would not rerun the stage, and the drives it decodes would stay as first decoded.

    Returns:
        One line per such file, saying so and what to do (empty: none).
    """
    root = paths.resolve(data.root).resolve()
    used = {f.format for f in files}
    out = []
    for name in sorted(used & set(data.signal_maps)):
        for dbc in data.signal_maps[name].dbc_files:
            if not Path(dbc).resolve().is_relative_to(root):
                out.append(
                    f"{paths.rel(Path(dbc))} (data.signal_maps.{name}.dbc) lies outside "
                    f"data.root ({paths.rel(root)}), which the ingest stage depends on: "
                    "dvc repro does not track it, so a change to it alone does not rerun "
                    f"ingest; keep it under {paths.rel(root)}"
                )
    return out


def _calibration(files: list[DriveFile]) -> dict[str, Any]:
    """Which drives calibrate the wheel radii: source_calibration, else the first source_train."""
    chosen = leftout.calibration((f.drive, f.role) for f in files)
    if chosen is None:
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
    return chosen


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
    left = len(manifest.get("left_out", []))
    out = f" ({left} left out: refused, data.refused_drives: leave_out)" if left else ""
    lines.append(f"{len(manifest['drives'])} drive(s), {total} rows{out}")
    return "\n".join(lines)


def main(params: Params) -> None:
    """The ``ingest`` stage: every drive of ``data.roles`` -> ``data/interim/drives``."""
    start = time.perf_counter()
    manifest = ingest(params, paths.DRIVES, paths.INGEST_FAILED_REPORT)
    seconds = time.perf_counter() - start
    rows = sum(d["n_rows"] for d in manifest["drives"])
    print(summary_table(manifest))
    for d in manifest["drives"]:  # what a reader did that the user should hear about
        for note in d.get("notes", []):
            print(f"{d['drive']}: {note}")
    for line in manifest.get("untracked", []):  # read, but not a dependency of the stage
        print(f"warning: {line}")
    for line in leftout.summary_lines(manifest.get("left_out", [])):
        print(f"warning: {line}")
    cal = manifest["calibration"]
    print(f"calibration: {', '.join(cal['drives'])} ({cal.get('note', cal['role'])})")
    print(
        f"{rows} rows in {seconds:.2f} s ({rows / max(seconds, 1e-9) / 1e6:.2f} M rows/s) "
        f"-> {paths.rel(paths.DRIVES)}"
    )
