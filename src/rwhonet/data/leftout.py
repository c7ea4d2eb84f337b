"""Drives refused by ingest or validate, left out of a run where ``data.refused_drives`` says so.

A fleet's recordings hold a broken file now and then: a logger that lost power in its
first minute, a drive whose wheel sensor died, an export cut short. By default
(``stop``) one such file fails the stage with one report of every problem, and nothing
is written: the user mends the file or moves it out of the role's glob. With
``leave_out`` the stage goes on without it, and says so everywhere a result is read:

- the drive's entry, with every problem as the refusal would have listed it, is kept
  under ``left_out`` in the ingest manifest, the segments manifest,
  ``reports/validation.json``, the label stage's samples manifest and ``metrics/eval.json``
  (and a line above ``reports/tables.md``'s tables), and the stages print it;
- a required role (``data.roles.<role>.required``) left without a drive fails the stage
  still, with the problems of the drives it lost: a systematic mistake (a column map's
  wrong unit) refuses every drive of a format, and a run on nothing is no result;
- the drives that calibrate the wheel radii are chosen again among those kept
  (:func:`calibration`): the ``source_calibration`` drives, else the first
  ``source_train`` drive by name.

A drive left out is not scored: the results describe the drives kept, and a test drive
refused for what it recorded (its GNSS lost for most of it, a wheel sensor stuck) is a
drive the tables do not speak for. The tables say how many were left out.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from rwhonet import contracts
from rwhonet.errors import Problem

LEAVE_OUT = "leave_out"  # data.refused_drives: go on without a refused drive ("stop": fail)


def left_out_entry(drive: Mapping[str, Any], stage: str, problems: Sequence[Problem]) -> dict:
    """A drive left out, as the manifests and reports keep it.

    Args:
        drive: the drive's ``drive``, ``role``, ``vehicle``, ``format`` and ``source_file``
            (an ingest manifest entry, or the same keys for a drive ingest refused).
        stage: the stage that refused it (``ingest`` or ``validate``).
        problems: why, every problem as the refusal would have listed it.

    Returns:
        ``{"drive", "role", "vehicle", "format", "source_file", "stage", "problems"}``.
    """
    return {
        **{key: drive.get(key) for key in ("drive", "role", "vehicle", "format", "source_file")},
        "stage": stage,
        "problems": [p.to_dict() for p in problems],
    }


def brief(entry: Mapping[str, Any]) -> dict[str, Any]:
    """A drive left out as the label stage's manifest and ``metrics/eval.json`` carry it:
    its names and problems, without validate's cuts."""
    keys = ("drive", "role", "vehicle", "source_file", "stage", "problems")
    return {key: entry.get(key) for key in keys}


def emptied_roles(
    required: Iterable[str],
    kept_roles: Iterable[str],
    left_out: Sequence[Mapping[str, Any]],
    setting: str = "data.refused_drives",
) -> list[Problem]:
    """The problems of every required role that has drives only among those left out.

    Args:
        required: the roles a run needs (``data.roles.<role>.required``).
        kept_roles: the role of every drive kept.
        left_out: the drives left out (:func:`left_out_entry`).
        setting: the parameter that left them out, for the messages.

    Returns:
        For each such role, the problems of its drives, each saying the role was emptied
        (empty: every required role keeps a drive).
    """
    kept = set(kept_roles)
    out: list[Problem] = []
    for role in required:
        lost = [d for d in left_out if d["role"] == role]
        if role in kept or not lost:
            continue
        note = (
            f" [every {role} drive was refused ({len(lost)}), and the role is required: "
            f"{setting}: leave_out leaves out a drive, not a role]"
        )
        for d in lost:
            for p in map(Problem.from_dict, d["problems"]):
                out.append(replace(p, found=p.found + note))
    return out


def calibration(drives: Iterable[tuple[str, str]]) -> dict[str, Any] | None:
    """Which drives calibrate the wheel radii: the ``source_calibration`` drives, else the
    first ``source_train`` drive by name.

    Args:
        drives: (drive id, role) of every drive kept.

    Returns:
        ``{"role", "drives", "fallback"}`` (and ``note`` for the fallback); None where
        neither role has a drive.
    """
    drives = list(drives)
    own = [d for d, role in drives if role == contracts.SOURCE_CALIBRATION]
    if own:
        return {"role": contracts.SOURCE_CALIBRATION, "drives": own, "fallback": False}
    fallback = sorted(d for d, role in drives if role == contracts.CALIBRATION_FALLBACK_ROLE)
    if not fallback:
        return None
    return {
        "role": contracts.CALIBRATION_FALLBACK_ROLE,
        "drives": [fallback[0]],
        "fallback": True,
        "note": f"no {contracts.SOURCE_CALIBRATION} drive: the first "
        f"{contracts.CALIBRATION_FALLBACK_ROLE} drive (sorted by name) calibrates",
    }


def summary_lines(left_out: Sequence[Mapping[str, Any]]) -> list[str]:
    """What a stage prints of the drives left out: one line each, its first problem."""
    lines = []
    for d in left_out:
        first = d["problems"][0] if d["problems"] else None
        why = "" if first is None else f": {Problem.from_dict(first)}"
        more = len(d["problems"]) - 1
        lines.append(
            f"left out {d['drive']} ({d['role']}, refused by {d['stage']}){why}"
            + (f" (and {more} more problem(s))" if more > 0 else "")
        )
    return lines
