"""Drives left out of a run: their entries, the roles they empty, the calibration chosen again."""

from __future__ import annotations

from rwhonet.data import leftout
from rwhonet.errors import Problem

BAD = Problem("raw/target_test/C-X1.csv", 12, "Time", "a number", "'abc'", "mend the cell")


def entry(drive: str, role: str, stage: str = "ingest", problems=(BAD,)) -> dict:
    described = {
        "drive": drive,
        "role": role,
        "vehicle": "target",
        "format": "iovnbd",
        "source_file": f"raw/{role}/{drive}.csv",
    }
    return leftout.left_out_entry(described, stage, list(problems))


def test_a_problem_survives_plain_data():
    assert Problem.from_dict(BAD.to_dict()) == BAD
    wide = Problem("f.csv", None, None, "x", "y")
    assert Problem.from_dict(wide.to_dict()) == wide


def test_an_entry_keeps_the_drive_and_every_problem():
    e = entry("C-X1", "target_test")
    assert e["stage"] == "ingest" and e["source_file"] == "raw/target_test/C-X1.csv"
    assert e["problems"] == [BAD.to_dict()]
    assert set(leftout.brief(e | {"cuts": []})) == {
        "drive",
        "role",
        "vehicle",
        "source_file",
        "stage",
        "problems",
    }


def test_only_a_required_role_with_no_drive_kept_is_emptied():
    left = [entry("C-X1", "target_test"), entry("V-T1", "source_test")]
    required = ["source_train", "target_train", "target_test"]
    assert (
        leftout.emptied_roles(required, ["source_train", "target_train", "target_test"], left) == []
    )
    emptied = leftout.emptied_roles(required, ["source_train", "target_train"], left)
    [p] = emptied
    assert (p.file, p.row, p.column, p.expected, p.fix) == (
        BAD.file,
        BAD.row,
        BAD.column,
        BAD.expected,
        BAD.fix,
    )
    assert p.found.startswith("'abc' [every target_test drive was refused (1)")
    # an optional role (source_test) may lose every drive
    assert leftout.emptied_roles(["source_train"], ["source_train"], left) == []


def test_the_calibration_drives_are_chosen_among_those_given():
    own = leftout.calibration([("V-S2", "source_train"), ("V-C1", "source_calibration")])
    assert own == {"role": "source_calibration", "drives": ["V-C1"], "fallback": False}
    fallback = leftout.calibration([("V-S2", "source_train"), ("V-S1", "source_train")])
    assert fallback["drives"] == ["V-S1"] and fallback["fallback"] is True
    assert leftout.calibration([("C-A1", "target_train")]) is None


def test_a_stage_prints_one_line_per_drive_with_its_first_problem():
    two = entry("C-X1", "target_test", "validate", [BAD, Problem("f", None, None, "a", "b")])
    [line] = leftout.summary_lines([two])
    assert line == (
        "left out C-X1 (target_test, refused by validate): raw/target_test/C-X1.csv, row 12, "
        "column 'Time': expected a number; found 'abc' (and 1 more problem(s))"
    )
