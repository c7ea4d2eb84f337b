"""One drive file: the reader its format names, the size it may have, its canonical table.

The ``ingest`` stage reads every drive of the fleet with these, and
``rwhonet recalibrate`` a new car's drive (``cli/drive.py``), so both refuse
and convert a file alike. Rows are kept exactly as in the file, in order (row
``i`` is data row ``i + 1`` of the source file), so ``validate`` can point at
the file's rows. Messages name a file as the caller's ``rel`` shows it (the
stage: relative to the project root).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from rwhonet.config import DataParams
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.csvio import RawDrive
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.problems import unreadable_file
from rwhonet.data.scenarios import ScenarioInterval, read_scenarios, scenario_codes, sidecar_path
from rwhonet.errors import InputError, Problem

IOVNBD = "iovnbd"
SPLIT_DRIVE = "split the drive into several files (one per trip)"


@dataclass(frozen=True)
class DriveFile:
    """One raw drive file and what params say about it."""

    drive: str  # drive id = file stem
    role: str
    vehicle: str
    format: str  # "iovnbd" or a column map name
    path: Path


def read_drive(f: DriveFile, data: DataParams, rel: Callable[[Path], str] = str) -> RawDrive:
    """Read one drive file with the reader its format names, if it is not too large.

    The readers stream the file, but the drive is then held in memory (by ingest and
    validate), so a file above ``data.max_file_mb`` is refused before it is read, and
    running out of memory while reading is reported as a problem of that file.

    Args:
        f: the drive file.
        data: the ``data`` section (for column maps and the size limit).
        rel: how messages name a file.

    Returns:
        The drive's channels, canonical names, SI units.

    Raises:
        InputError: the file is too large, runs out of memory, or its reader refuses it.
    """
    file = rel(f.path)
    try:
        size_mb = f.path.stat().st_size / 2**20
    except OSError as err:  # gone since it was listed, or unreadable
        raise InputError([unreadable_file(file, err)]) from None
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
        raise out_of_memory(f, rel) from None


def _mb(size_mb: float) -> str:
    return f"{size_mb:,.0f} MB" if size_mb >= 10 else f"{size_mb:.3g} MB"


def out_of_memory(f: DriveFile, rel: Callable[[Path], str] = str) -> InputError:
    """The report of a drive that did not fit in memory (reading it, or writing its table)."""
    size_mb = f.path.stat().st_size / 2**20 if f.path.exists() else float("nan")
    return InputError(
        [
            Problem(
                rel(f.path),
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


@dataclass
class CanonicalDrive:
    """A drive file read, with the scenario tags of its sidecar.

    Attributes:
        raw: the channels, canonical names, SI units.
        intervals: the tagged intervals of ``<drive>.scenarios.json`` (none without one).
        sidecar: that sidecar, when the drive has one.
    """

    raw: RawDrive
    intervals: list[ScenarioInterval]
    sidecar: Path | None

    def table(self) -> pa.Table:
        """The canonical drive table (:func:`canonical_table`) with its ``scenario`` column."""
        return canonical_table(self.raw, scenario_array(self.raw.columns[c.T_S], self.intervals))


def read_canonical(
    f: DriveFile, data: DataParams, rel: Callable[[Path], str] = str
) -> CanonicalDrive:
    """Read one drive file (:func:`read_drive`) and its optional scenario sidecar.

    Args:
        f: the drive file.
        data: the ``data`` section.
        rel: how messages name a file.

    Returns:
        The drive and its scenario intervals.

    Raises:
        InputError: the problems of the file or of its sidecar.
    """
    raw = read_drive(f, data, rel)
    sidecar = sidecar_path(f.path)
    if not sidecar.is_file():
        return CanonicalDrive(raw, [], None)
    return CanonicalDrive(raw, read_scenarios(sidecar, rel(sidecar)), sidecar)


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
