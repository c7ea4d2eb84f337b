"""Write a simulated drive: the IO-VNBD CSV and its two JSON sidecars.

The CSV goes through ``pyarrow.csv`` (about 10x faster than ``DataFrame.to_csv``;
measured in docs/simulator.md). pyarrow writes the shortest decimal that
round-trips each float, so the values the simulator rounded come out exactly
as rounded, and the same frame always gives the same bytes. The header row is
written by hand because pyarrow quotes column names.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv

from rwhonet.data.iovnbd import HEADERS


def write_csv(frame: pd.DataFrame, path: Path) -> None:
    """Write a frame in the IO-VNBD layout: header with the leading spaces, 29 columns.

    Args:
        frame: columns exactly :data:`rwhonet.data.iovnbd.HEADERS`, in order.
        path: the CSV file.

    Raises:
        ValueError: if the columns are not the IO-VNBD layout.
    """
    if tuple(frame.columns) != HEADERS:
        raise ValueError(
            f"columns must be the IO-VNBD layout {HEADERS}, got {tuple(frame.columns)}"
        )
    table = pa.Table.from_arrays(
        [pa.array(frame[c].to_numpy()) for c in HEADERS],
        names=[f"c{i}" for i in range(len(HEADERS))],
    )
    with open(path, "wb") as f:
        f.write((",".join(HEADERS) + "\n").encode("utf-8"))
        pa_csv.write_csv(table, f, pa_csv.WriteOptions(include_header=False))


def write_json(path: Path, obj: Any) -> None:
    """Write a small JSON sidecar (inside the stage's atomic output folder).

    Args:
        path: the file.
        obj: JSON-serialisable data.
    """
    path.write_text(json.dumps(obj, indent=1) + "\n", encoding="utf-8")


def write_drive(folder: Path, name: str, frame: pd.DataFrame, scenarios: dict, truth: dict) -> Path:
    """Write ``<folder>/<name>.csv``, ``<name>.scenarios.json`` and ``<name>.truth.json``.

    Args:
        folder: the role folder (created if missing).
        name: the drive name (file stem).
        frame: the IO-VNBD frame.
        scenarios: ``{"intervals": [...]}``.
        truth: the truth dict.

    Returns:
        The CSV path.
    """
    folder.mkdir(parents=True, exist_ok=True)
    csv_path = folder / f"{name}.csv"
    write_csv(frame, csv_path)
    write_json(folder / f"{name}.scenarios.json", scenarios)
    write_json(folder / f"{name}.truth.json", truth)
    return csv_path
