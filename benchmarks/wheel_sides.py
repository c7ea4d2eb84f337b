"""The wheel-sides and wheel-axles checks on every built-in drive of each profile, and with
its rear wheels' columns exchanged (sides) or its front and rear columns (axles).

For each profile named: the simulator's fleet (``rwhonet.sim.simulate_fleet``) to a
scratch folder, each drive read back as ingest reads it (the IO-VNBD reader), validate's
GNSS policy (``quality.assess``) and the check itself
(``rwhonet.data.drivechecks.side_problems``, with the car's nominal radius and rear
track as validate takes them). It prints per profile: the drives, those refused as they
are (none expected), those the check could not tell and why, the range and median of
each axle's gain, and how many are refused with the rear wheels' columns exchanged;
the diagonal gain's range as the drives are (``plausibility.diagonal_gain``) and, with
each diagonal pair of columns exchanged in turn (the front left with the rear right, the
front right with the rear left), how many drives the sides and axles checks together
refuse as that exchange, how many they refuse otherwise (a wrong fix), and the told
gains' sizes. Then the same for the wheel-axles check (``axle_problems``): refused as they are, not
told (the count), the gain's range and median over the drives told, and how many are
refused with the front and rear columns exchanged (left with left, right with right).
Nothing is written outside the scratch folder. ``docs/readers.md`` ("An axle's left
and right wheels", "Front and rear") reports what this gave.

Usage: python benchmarks/wheel_sides.py [profile ...]   (default: the four worlds and ci)
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.drivechecks import axle_problems, side_problems
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.quality import assess
from rwhonet.sim import simulate_fleet

# one diagonal pair of columns exchanged, each way
DIAGONALS = {
    "front_left_for_rear_right": (c.OMEGA_FL, c.OMEGA_RR),
    "front_right_for_rear_left": (c.OMEGA_FR, c.OMEGA_RL),
}
PROFILES = ("paper", "large_target", "paper_consumer", "large_target_consumer", "ci")


def profile_sides(profile: str) -> dict:
    """The check's verdicts on one profile's fleet (see the module docstring)."""
    params = load_params(overrides={"sim.profile": profile})
    vp = params.validate
    gains: dict[str, list[float]] = {"rear": [], "front": []}
    refused, untold, exchanged_refused = [], [], 0
    axles = {"refused": [], "untold": 0, "gains": [], "exchanged_refused": 0}
    columns: dict = {"gains": []} | {
        name: {"refused_as_diagonal": 0, "refused_otherwise": 0, "gains": []} for name in DIAGONALS
    }
    with tempfile.TemporaryDirectory() as tmp:
        summary = simulate_fleet(params, Path(tmp) / "sim")
        for d in summary["drives"]:
            path = Path(tmp) / "sim" / d["role"] / f"{d['drive']}.csv"
            drive = read_iovnbd(path).columns
            segments = assess(drive, vp.gnss, vp.sample_period_s).segments
            vehicle = d["vehicle"]
            radius, track = params.nominal_radius_m(vehicle), params.track_rear_m(vehicle)
            entry = {"source_file": path.name, "columns": {}}
            problems, record = side_problems(entry, drive, segments, vp, radius, track)
            if problems:
                refused.append(d["drive"])
            if not record["checked"]:
                untold.append([d["drive"], record["note"]])
            for axle, g in gains.items():
                if record[axle]["gain"] is not None:
                    g.append(record[axle]["gain"])
            swapped = dict(drive)
            swapped[c.OMEGA_RL], swapped[c.OMEGA_RR] = drive[c.OMEGA_RR], drive[c.OMEGA_RL]
            exchanged_refused += bool(side_problems(entry, swapped, segments, vp, radius, track)[0])
            problems, record = axle_problems(entry, drive, segments, vp, radius)
            if problems:
                axles["refused"].append(d["drive"])
            if record["checked"]:
                axles["gains"].append(record["gain"])
            else:
                axles["untold"] += 1
            swapped = dict(drive)
            for front, rear in ((c.OMEGA_FL, c.OMEGA_RL), (c.OMEGA_FR, c.OMEGA_RR)):
                swapped[front], swapped[rear] = drive[rear], drive[front]
            axles["exchanged_refused"] += bool(
                axle_problems(entry, swapped, segments, vp, radius)[0]
            )
            diagonal = side_problems(entry, drive, segments, vp, radius, track)[1]["diagonal"]
            if diagonal["gain"] is not None:
                columns["gains"].append(diagonal["gain"])
            for name, (a, b) in DIAGONALS.items():
                swapped = dict(drive)
                swapped[a], swapped[b] = drive[b], drive[a]
                said, record = _sides_and_axles(entry, swapped, segments, vp, radius, track)
                told = record.get("misplaced") == [a, b]
                columns[name]["refused_as_diagonal"] += told
                columns[name]["refused_otherwise"] += bool(said) and not told
                if told:
                    columns[name]["gains"].append(record["diagonal"]["gain"])
    g = axles.pop("gains")
    return {
        "drives": len(summary["drives"]),
        "refused": refused,
        "untold": untold,
        "rear_exchanged_refused": exchanged_refused,
        **{
            f"{axle}_gain_min_max_median": [
                round(min(g), 3),
                round(max(g), 3),
                round(float(np.median(g)), 3),
            ]
            for axle, g in gains.items()
        },
        "diagonal": {
            "gain_min_max": _span(columns.pop("gains")),
            **{
                name: v | {"gain_min_max": _span(v.pop("gains"), absolute=True)}
                for name, v in columns.items()
            },
        },
        "axles": axles
        | {
            "gain_min_max_median": [
                round(min(g), 3),
                round(max(g), 3),
                round(float(np.median(g)), 3),
            ]
            if g
            else None
        },
    }


def _span(values: list[float], absolute: bool = False) -> list[float] | None:
    """The least and the greatest (of their sizes where ``absolute``), to 3 places."""
    if not values:
        return None
    v = np.abs(values) if absolute else np.asarray(values)
    return [round(float(v.min()), 3), round(float(v.max()), 3)]


def _sides_and_axles(entry, drive, segments, vp, radius, track) -> tuple[list, dict]:
    """The sides' and the axles' problems, as validate finds them together, and the sides'
    record."""
    sided, record = side_problems(entry, drive, segments, vp, radius, track)
    misplaced = record.get("misplaced", ())
    return sided + axle_problems(entry, drive, segments, vp, radius, None, misplaced)[0], record


def main(argv: list[str]) -> None:
    for profile in argv or PROFILES:
        print(profile, json.dumps(profile_sides(profile)), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
