"""``data.refused_drives: leave_out``: a refused drive left out of the run, and named in every
manifest and report, through ingest, validate, label and evaluate's report line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.stages.evaluate import left_out_drives, provenance_line
from rwhonet.stages.ingest import ingest
from rwhonet.stages.ingest import summary_table as ingest_table
from rwhonet.stages.label import label
from rwhonet.stages.validate import summary_table, validate
from support.corpus import speed_profile_drive
from support.drives import (
    SHORT,
    SOURCE_RADIUS_M,
    TARGET_RADIUS_M,
    make_params,
    straight_drive,
    write_fleet,
    write_iovnbd,
)

LEAVE_OUT = {"data.refused_drives": "leave_out"}


def fleet(raw: Path) -> None:
    """The three required roles' drives (20 s each; the source car's speed varies, for the
    label stage's scaler) and a second good target test drive."""
    write_fleet(raw, duration_s=20.0)
    speed = 15.0 + 2.0 * np.sin(2.0 * np.pi * 0.1 * np.arange(201) / 8.0)
    varying = speed_profile_drive(speed, SOURCE_RADIUS_M, 52.40, 30.0)
    write_iovnbd(varying, raw / "source_train" / "V-S1.csv")
    good = straight_drive(20.0, radius_m=TARGET_RADIUS_M, lat0_deg=52.43)
    write_iovnbd(good, raw / "target_test" / "C-B2.csv")


def unreadable(raw: Path, role: str = "target_test", name: str = "C-X1") -> Path:
    """A drive file ingest refuses: a header no reader knows."""
    path = raw / role / f"{name}.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("exported by,a tool\nnot,a drive\n", encoding="utf-8")
    return path


def too_short(raw: Path, name: str = "C-X2") -> Path:
    """A target test drive validate refuses: 6 s, less than the 10 s it must hold."""
    df = straight_drive(6.0, radius_m=TARGET_RADIUS_M, lat0_deg=52.44)
    return write_iovnbd(df, raw / "target_test" / f"{name}.csv")


def run(tmp_path: Path, raw: Path, **overrides) -> dict:
    params = make_params(raw, **(SHORT | overrides))
    ingest(params, tmp_path / "drives")
    return validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "report.json")


def read(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def test_by_default_a_refused_drive_stops_the_stage(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    unreadable(raw)
    with pytest.raises(InputError) as err:
        run(tmp_path, raw)
    assert {Path(p.file).name for p in err.value.problems} == {"C-X1.csv"}
    assert not (tmp_path / "drives").exists()


def test_a_drive_ingest_refuses_is_left_out_and_named(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    unreadable(raw)
    report = run(tmp_path, raw, **LEAVE_OUT)

    manifest = read(tmp_path / "drives" / "manifest.json")
    assert [d["drive"] for d in manifest["drives"]] == ["V-S1", "C-A1", "C-B1", "C-B2"]
    [left] = manifest["left_out"]
    assert (left["drive"], left["role"], left["stage"]) == ("C-X1", "target_test", "ingest")
    assert left["source_file"].endswith("target_test/C-X1.csv")
    assert left["problems"] and all(p["file"].endswith("C-X1.csv") for p in left["problems"])
    assert not (tmp_path / "drives" / "C-X1.arrow").exists()
    assert "(1 left out: refused" in ingest_table(manifest)
    # validate carries it on, and keeps the other drives
    assert [d["drive"] for d in report["left_out"]] == ["C-X1"]
    assert report["totals"]["drives_left_out"] == 1
    assert [d["drive"] for d in report["drives"]] == ["V-S1", "C-A1", "C-B1", "C-B2"]
    segments = read(tmp_path / "segments" / "manifest.json")
    assert [d["drive"] for d in segments["left_out"]] == ["C-X1"]
    assert "1 drive(s) left out" in summary_table(report)


def test_a_drive_validate_refuses_is_left_out_with_its_cuts(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    too_short(raw)
    with pytest.raises(InputError) as err:  # the default
        run(tmp_path, raw)
    assert {Path(p.file).name for p in err.value.problems} == {"C-X2.csv"}

    report = run(tmp_path, raw, **LEAVE_OUT)
    [left] = report["left_out"]
    assert (left["drive"], left["stage"], left["status"]) == ("C-X2", "validate", "refused")
    assert any("valid seconds" in p["expected"] for p in left["problems"]), left["problems"]
    assert "seconds" in left and "cuts" in left  # what validate assessed of it
    assert "C-X2" not in [d["drive"] for d in report["drives"]]
    segments = read(tmp_path / "segments" / "manifest.json")
    assert not any(s["drive"] == "C-X2" for s in segments["segments"])
    assert not list((tmp_path / "segments").glob("C-X2*"))
    # ingest had nothing against it
    assert "left_out" not in read(tmp_path / "drives" / "manifest.json")


def test_a_required_role_left_without_a_drive_still_fails(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    (raw / "target_train" / "C-A1.csv").unlink()
    unreadable(raw, "target_train", "C-A9")
    with pytest.raises(InputError) as err:
        run(tmp_path, raw, **LEAVE_OUT)
    assert "required role" in err.value.summary
    assert {Path(p.file).name for p in err.value.problems} == {"C-A9.csv"}
    assert all("every target_train drive was refused" in p.found for p in err.value.problems)
    assert not (tmp_path / "drives").exists()


def test_an_optional_role_may_lose_every_drive(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    unreadable(raw, "source_test", "V-T1")
    report = run(tmp_path, raw, **LEAVE_OUT)
    assert [(d["drive"], d["role"]) for d in report["left_out"]] == [("V-T1", "source_test")]


def test_the_radii_are_calibrated_on_a_drive_kept(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    # the source_calibration drive: validate refuses it (no fix it may use: 2 satellites)
    write_iovnbd(straight_drive(20.0, n_sats=2.0), raw / "source_calibration" / "V-C1.csv")
    with pytest.raises(InputError):
        run(tmp_path, raw)
    report = run(tmp_path, raw, **LEAVE_OUT)
    assert [d["drive"] for d in report["left_out"]] == ["V-C1"]
    assert read(tmp_path / "drives" / "manifest.json")["calibration"]["drives"] == ["V-C1"]
    calibration = read(tmp_path / "segments" / "manifest.json")["calibration"]
    assert calibration["role"] == "source_train" and calibration["drives"] == ["V-S1"]
    assert calibration["note"].startswith("V-C1 left out (refused)")


def test_a_cut_of_a_drive_left_out_is_no_mistake(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    unreadable(raw)
    cut = {"drive": "C-X1", "start_s": 45001.0, "end_s": 45002.0, "reason": "a bump"}
    report = run(tmp_path, raw, **LEAVE_OUT, **{"validate.cuts": [cut]})
    assert [d["drive"] for d in report["left_out"]] == ["C-X1"]


def test_label_and_the_report_carry_the_drives_left_out(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    unreadable(raw)
    too_short(raw)
    params = make_params(raw, **SHORT, **LEAVE_OUT)
    ingest(params, tmp_path / "drives")
    validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "report.json")
    samples = tmp_path / "samples"
    label(params, tmp_path / "segments", samples, tmp_path / "cal.json", tmp_path / "scaler.json")

    left = left_out_drives(samples)
    assert [(d["drive"], d["stage"]) for d in left] == [("C-X1", "ingest"), ("C-X2", "validate")]
    assert set(left[0]) == {"drive", "role", "vehicle", "source_file", "stage", "problems"}
    choice = type("Choice", (), {"recipe": "paper", "m": 5})()
    line = provenance_line(params, choice, left)
    assert "**2 drive(s) refused and left out**" in line
    assert "`C-X1` (target_test, by ingest)" in line and "`C-X2` (target_test, by validate)" in line
    assert "left out" not in provenance_line(params, choice, [])


def test_without_refusals_the_outputs_hold_no_left_out(tmp_path):
    raw = tmp_path / "raw"
    fleet(raw)
    params = make_params(raw, **SHORT, **LEAVE_OUT)
    ingest(params, tmp_path / "drives")
    report = validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "report.json")
    samples = tmp_path / "samples"
    label(params, tmp_path / "segments", samples, tmp_path / "cal.json", tmp_path / "scaler.json")
    assert "left_out" not in read(tmp_path / "drives" / "manifest.json")
    assert "left_out" not in report and "drives_left_out" not in report["totals"]
    assert "left_out" not in read(tmp_path / "segments" / "manifest.json")
    assert "left_out" not in read(samples / "manifest.json")
    assert left_out_drives(samples) == []
