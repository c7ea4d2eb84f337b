"""Scenario sidecars: ``<drive>.scenarios.json`` -> the per-row ``scenario`` column.

A sidecar (written by the simulator; real drives may have none) lists tagged
time intervals in the drive's own clock, in seconds::

    {"intervals": [{"start_s": 812.0, "end_s": 826.5, "tag": "roundabout"}, ...]}

An interval covers ``start_s <= t_s < end_s`` (half-open, so back-to-back
intervals do not share a row). A row's ``scenario`` is the ';'-joined set of
tags covering it, in sorted (alphabetical) order so that the same set always
gives the same string; ``""`` when no interval covers it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rwhonet.data.compressed import drive_stem
from rwhonet.errors import InputError, Problem

SEPARATOR = ";"
SUFFIX = ".scenarios.json"


@dataclass(frozen=True)
class ScenarioInterval:
    """One tagged interval ``[start_s, end_s)`` of a drive's clock."""

    start_s: float
    end_s: float
    tag: str


def sidecar_path(drive_file: Path) -> Path:
    """Return the sidecar path of a drive file (``V-S1.csv`` -> ``V-S1.scenarios.json``;
    ``V-S1.csv.gz`` too: :func:`rwhonet.data.compressed.drive_stem`)."""
    return drive_file.with_name(drive_stem(drive_file) + SUFFIX)


SIDECAR_FIX = (
    'correct the sidecar ({"intervals": [{"start_s": .., "end_s": .., "tag": ".."}]}, in the '
    "drive's own clock), or delete it: scenario tags are optional"
)


def read_scenarios(path: Path, display: str | None = None) -> list[ScenarioInterval]:
    """Read and check a scenario sidecar (see :func:`_read_scenarios`).

    Raises:
        InputError: as :func:`_read_scenarios`, every problem saying what to do.
    """
    try:
        return _read_scenarios(path, display)
    except InputError as err:
        raise InputError(
            [replace(p, fix=p.fix or SIDECAR_FIX) for p in err.problems], summary=err.summary
        ) from None


def _read_scenarios(path: Path, display: str | None = None) -> list[ScenarioInterval]:
    """Read and check a scenario sidecar.

    Args:
        path: the ``.scenarios.json`` file.
        display: how the file is named in error reports (default: ``path`` as given).

    Returns:
        The intervals, in file order.

    Raises:
        InputError: invalid JSON, or intervals with a missing/non-numeric bound, an end not
            after the start, or a tag that is empty or contains ';' (all listed).
    """
    file = display or str(path)
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise InputError([Problem(file, None, None, "valid JSON", str(err))]) from None
    except OSError as err:
        raise InputError([Problem(file, None, None, "a readable file", str(err))]) from None
    items = doc.get("intervals") if isinstance(doc, dict) else None
    if not isinstance(items, list):
        raise InputError(
            [Problem(file, None, "intervals", 'an object {"intervals": [...]}', repr(doc)[:80])]
        )
    problems: list[Problem] = []
    out: list[ScenarioInterval] = []
    for i, item in enumerate(items):
        where = f"intervals[{i}]"
        if not isinstance(item, dict):
            problems.append(
                Problem(file, None, where, "an object with start_s, end_s, tag", repr(item))
            )
            continue
        bounds = {}
        for key in ("start_s", "end_s"):
            value = item.get(key)
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not math.isfinite(value)
            ):
                problems.append(
                    Problem(file, None, f"{where}.{key}", "a finite number of seconds", repr(value))
                )
            else:
                bounds[key] = float(value)
        tag = item.get("tag")
        if not isinstance(tag, str) or not tag.strip() or SEPARATOR in tag:
            problems.append(
                Problem(
                    file, None, f"{where}.tag", f"a non-empty tag without {SEPARATOR!r}", repr(tag)
                )
            )
        if len(bounds) == 2 and bounds["end_s"] <= bounds["start_s"]:
            problems.append(
                Problem(
                    file,
                    None,
                    f"{where}.end_s",
                    f"a time after start_s={bounds['start_s']}",
                    repr(bounds["end_s"]),
                )
            )
        if len(bounds) == 2 and isinstance(tag, str):
            out.append(ScenarioInterval(bounds["start_s"], bounds["end_s"], tag.strip()))
    if problems:
        raise InputError(
            problems, summary=f"{len(problems)} problem(s) in the scenario sidecar {file}"
        )
    return out


def scenario_codes(
    t_s: np.ndarray, intervals: Sequence[ScenarioInterval]
) -> tuple[np.ndarray, np.ndarray]:
    """Label every row with the tags of the intervals covering its time, as codes.

    A drive has thousands of rows per distinct tag set, so the labels are built once per
    set and the rows refer to them (``labels[codes]`` is :func:`scenario_column`).

    Args:
        t_s: row times, s, in the clock of the intervals.
        intervals: the drive's tagged intervals.

    Returns:
        ``(labels, codes)``: object array of the distinct ';'-joined sorted tag sets
        (``""`` for rows no interval covers), and per row the int64 index of its label.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    tags = sorted({iv.tag for iv in intervals})
    if not tags:
        return np.array([""], dtype=object), np.zeros(t_s.shape, dtype=np.int64)
    member, piece = _tag_membership(t_s, intervals, tags)
    # Rows with the same tag set share one bit pattern: label each distinct pattern once.
    if len(tags) < 63:
        # The pattern as an int64 (bit j: tags[j]), hashed: much faster than sorting records.
        import pandas as pd  # here: `rwhonet predict` reads drives without importing it

        key = member.view(np.uint8) @ (np.int64(1) << np.arange(len(tags), dtype=np.int64))
        codes, unique_keys = pd.factorize(key)
        patterns = (unique_keys[:, None] >> np.arange(len(tags))) & 1
    else:
        packed = np.ascontiguousarray(np.packbits(member, axis=1))
        keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
        unique_keys, codes = np.unique(keys, return_inverse=True)
        patterns = np.unpackbits(unique_keys.view(np.uint8).reshape(len(unique_keys), -1), axis=1)
    labels = np.array(
        [SEPARATOR.join(t for t, on in zip(tags, row, strict=False) if on) for row in patterns],
        dtype=object,
    )
    return labels, np.asarray(codes, dtype=np.int64).reshape(-1)[piece].reshape(t_s.shape)


def _tag_membership(
    t_s: np.ndarray, intervals: Sequence[ScenarioInterval], tags: Sequence[str]
) -> tuple[np.ndarray, np.ndarray]:
    """Which tags cover which rows, per run of rows with the same tags.

    Returns:
        ``(member, piece)``: boolean ``(pieces, tags)``, whether an interval of that tag
        covers the piece; and per row, the index of its piece.
    """
    column_of = {tag: j for j, tag in enumerate(tags)}
    if t_s.size > 1 and not np.all(t_s[1:] >= t_s[:-1]):  # unsorted or NaN: compare all rows
        member = np.zeros((t_s.size, len(tags)), dtype=bool)
        for iv in intervals:  # a loop over intervals (tens), each a vectorised pass over rows
            member[:, column_of[iv.tag]] |= (t_s >= iv.start_s) & (t_s < iv.end_s)
        return member, np.arange(t_s.size)
    # Sorted times: interval [start, end) holds rows searchsorted(start) .. searchsorted(end) - 1,
    # and the tags can only change where an interval starts or ends: between those rows the
    # drive is cut into pieces. Per tag, +1 at the piece an interval starts in and -1 at the
    # one after its end, cumulated, counts the intervals covering each piece (overlapping
    # intervals of one tag stay covered).
    lo = np.searchsorted(t_s, [iv.start_s for iv in intervals], side="left")
    hi = np.searchsorted(t_s, [iv.end_s for iv in intervals], side="left")
    cuts = np.unique(np.concatenate([[0, t_s.size], lo, hi]))  # first row of each piece
    column = np.array([column_of[iv.tag] for iv in intervals])
    depth = np.zeros((cuts.size, len(tags)), dtype=np.int32)  # last row: after the drive
    np.add.at(depth, (np.searchsorted(cuts, lo), column), 1)
    np.add.at(depth, (np.searchsorted(cuts, hi), column), -1)
    np.cumsum(depth, axis=0, out=depth)
    piece = np.repeat(np.arange(cuts.size - 1), np.diff(cuts))
    return depth[:-1] > 0, piece


def scenario_column(t_s: np.ndarray, intervals: Sequence[ScenarioInterval]) -> np.ndarray:
    """Label every row with the tags of the intervals covering its time.

    Args:
        t_s: row times, s, in the clock of the intervals.
        intervals: the drive's tagged intervals.

    Returns:
        Object array of ';'-joined sorted tags, ``""`` for rows no interval covers.
    """
    labels, codes = scenario_codes(t_s, intervals)
    return labels[codes]
