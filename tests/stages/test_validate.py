"""Validate: ingest -> validate round trip, one report of every problem, nothing half-written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.feather as feather
import pytest

from rwhonet.config import ConfigError
from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import summary_table, validate
from support.drives import (
    SHORT,
    SOURCE_RADIUS_M,
    TARGET_RADIUS_M,
    make_params,
    straight_drive,
    write_fleet,
    write_iovnbd,
)


def run(tmp_path: Path, raw: Path, **overrides):
    params = make_params(raw, **(SHORT | overrides))
    ingest(params, tmp_path / "drives")
    return validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "report.json")


def test_round_trip(tmp_path):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=20.0)
    df = straight_drive(20.0)
    df.loc[df[c.T_S].between(45010.0, 45011.55), c.N_SATS] = 2.0  # cuts seconds 45010..45012
    write_iovnbd(df, raw / "source_train" / "V-S1.csv")
    report = run(tmp_path, raw)

    seg_dir = tmp_path / "segments"
    manifest = json.loads((seg_dir / "manifest.json").read_text())
    names = [s["segment"] for s in manifest["segments"]]
    assert names == ["V-S1__s000", "V-S1__s001", "C-A1__s000", "C-B1__s000"]
    assert sorted(p.stem for p in seg_dir.glob("*.arrow")) == sorted(names)
    first = manifest["segments"][0]
    assert (first["t_start_s"], first["t_end_s"], first["n_seconds"], first["n_rows"]) == (
        45000.0,
        45009.0,
        9,
        91,
    )
    assert manifest["calibration"]["drives"] == ["V-S1"]
    # A segment is the canonical drive's rows, untouched: start fix + ten rows per second.
    seg = pd.read_feather(seg_dir / "V-S1__s001.arrow")
    drive = pd.read_feather(tmp_path / "drives" / "V-S1.arrow")
    assert seg[c.T_S].iloc[0] == 45012.0 and seg[c.T_S].iloc[-1] == 45020.0
    pd.testing.assert_frame_equal(
        seg, drive[drive[c.T_S].between(45012.0, 45020.0)].reset_index(drop=True)
    )
    assert (
        feather.read_table(seg_dir / "V-S1__s001.arrow")
        .schema.remove_metadata()
        .equals(feather.read_table(tmp_path / "drives" / "V-S1.arrow").schema.remove_metadata())
    )

    assert json.loads((tmp_path / "report.json").read_text()) == report
    s1 = report["drives"][0]
    assert [(cut["start_s"], cut["end_s"], cut["rule"]) for cut in s1["cuts"]] == [
        (44999.0, 45000.0, "partial_second"),
        (45009.0, 45012.0, "low_sats"),
    ]
    assert s1["cuts"][1]["detail"] == "2 satellites (min_sats 4)"
    assert s1["rows_kept"] + sum(cut["n_rows"] for cut in s1["cuts"]) == s1["rows"] == 201
    assert s1["radius"]["ratio"] == pytest.approx(1.0, abs=1e-9)
    totals = report["totals"]
    assert (totals["drives"], totals["segments"], totals["seconds"]) == (3, 4, 63)
    assert totals["cut_seconds_by_rule"]["low_sats"] == 3
    table = summary_table(report)
    assert "V-S1" in table and "low_sats 3" in table and "57 of 63 s kept" in table
    # straight drives without a yaw rate: the checks against the course cannot tell
    last = table.splitlines()[-1]
    assert last.startswith("not told against the GNSS course (each drive's note in the")
    assert "front and rear wheels on 3 (V-S1, " in last and "tyre radius" not in last


def test_bad_drives_give_one_report_in_file_terms_and_no_partial_output(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=10.0)
    run(tmp_path, raw)
    before = {p.name: p.read_bytes() for p in (tmp_path / "segments").iterdir()}
    report_before = (tmp_path / "report.json").read_bytes()

    df = straight_drive(10.0)
    df.loc[6, c.T_S] = np.nan  # data row 7 (an empty wheel speed is a lost sample, dropped)
    df.loc[40, c.LAT_DEG] = 91.0  # data row 41
    write_iovnbd(df, files["source_train"])
    df = straight_drive(10.0)
    df.loc[30, c.T_S] = df.loc[29, c.T_S]  # data row 31: duplicated timestamp
    df.loc[60, c.T_S] = 45000.5  # data row 61: back in time
    write_iovnbd(df, files["target_test"])

    with pytest.raises(InputError) as err:
        run(tmp_path, raw)
    found = {(Path(p.file).name, p.row, p.column) for p in err.value.problems}
    assert {
        ("V-S1.csv", 7, " Time"),
        ("V-S1.csv", 41, " Lat"),
        ("C-B1.csv", 31, " Time"),
        ("C-B1.csv", 61, " Time"),
    } <= found
    text = str(err.value)
    assert (
        "V-S1.csv, row 41, column ' Lat': expected a latitude in [-90, 90] deg; found 91.0" in text
    )
    assert "C-B1.csv, row 31, column ' Time'" in text and "again" in text
    assert "time goes backwards" in text
    assert {p.name: p.read_bytes() for p in (tmp_path / "segments").iterdir()} == before
    assert (tmp_path / "report.json").read_bytes() == report_before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_wheel_speeds_in_kmh_by_mistake(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=20.0)
    df = straight_drive(20.0)
    for wheel in c.WHEELS:
        df[wheel] = 15.0 * 3.6  # the linear wheel speed in km/h instead of rad/s
    write_iovnbd(df, files["source_train"])
    with pytest.raises(InputError) as err:
        run(tmp_path, raw)
    (p,) = err.value.problems
    assert Path(p.file).name == "V-S1.csv"
    assert p.column == " Wheel Speed Rear Left (rad/sec) /  Wheel Speed Rear Right (rad/sec)"
    assert f"within ±5% of source's nominal {SOURCE_RADIUS_M} m" in p.expected
    assert "radius ≈ 1/3.6 m" in p.found and "look like km/h" in p.found


@pytest.mark.parametrize(
    ("factor", "hint"),
    [(60.0 / (2.0 * math.pi), "ratio ≈ 2π/60"), (180.0 / math.pi, "ratio ≈ π/180")],
)
def test_wheel_speeds_in_rpm_or_deg_per_s_by_mistake(tmp_path, factor, hint):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=20.0)
    df = straight_drive(20.0)
    for wheel in c.WHEELS:
        df[wheel] = df[wheel] * factor  # 481 rpm / 2884 deg/s: beyond the range check too
    write_iovnbd(df, files["source_train"])
    with pytest.raises(InputError) as err:
        run(tmp_path, raw)
    assert any("max_abs_wheel_speed_rad_s" in p.expected for p in err.value.problems)
    (unit,) = [p for p in err.value.problems if "effective radius" in p.expected]
    unit_name = "rpm" if "60" in hint else "deg/s"
    assert f"{hint}: the wheel speeds look like {unit_name}" in unit.found


def test_frozen_gnss_throughout_fails_naming_file_and_rule(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=20.0)
    df = straight_drive(20.0)
    df[[c.LAT_DEG, c.LON_DEG]] = df.loc[0, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    write_iovnbd(df, files["target_train"])
    with pytest.raises(InputError) as err:
        run(tmp_path, raw)
    (p,) = err.value.problems
    assert Path(p.file).name == "C-A1.csv" and "at least one GNSS-valid stretch" in p.expected
    assert p.found.startswith("none: all 21 s cut, frozen 20 s, partial_second 1 s (rule frozen:")


def test_frozen_stretch_is_cut_and_reported(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=30.0)
    df = straight_drive(30.0, radius_m=TARGET_RADIUS_M)
    stuck = df[c.T_S].between(45010.0, 45014.0)
    df.loc[stuck, [c.LAT_DEG, c.LON_DEG]] = df.loc[
        stuck.idxmax(), [c.LAT_DEG, c.LON_DEG]
    ].to_numpy()
    write_iovnbd(df, files["target_test"])
    report = run(tmp_path, raw)
    b1 = next(d for d in report["drives"] if d["drive"] == "C-B1")
    assert b1["cut_seconds_by_rule"]["frozen"] == 5
    assert [s["t_end_s"] for s in b1["segments"]] == [45009.0, 45030.0]


def test_manual_cuts_checked_against_drives(tmp_path):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=10.0)
    cut = {"drive": "V-S9", "start_s": 1.0, "end_s": 2.0, "reason": "typo"}
    with pytest.raises(ConfigError, match="validate.cuts\\[0\\].drive='V-S9': no such drive"):
        run(tmp_path, raw, **{"validate.cuts": [cut]})
    cut = {"drive": "V-S1", "start_s": 1.0, "end_s": 2.0, "reason": "relative clock by mistake"}
    with pytest.raises(InputError, match="overlapping V-S1's time span 45000.0-45010.0 s"):
        run(tmp_path, raw, **{"validate.cuts": [cut]})
    cut = {"drive": "V-S1", "start_s": 45003.5, "end_s": 45004.0, "reason": "roadworks"}
    report = run(tmp_path, raw, **{"validate.cuts": [cut]})
    cuts = [(x["start_s"], x["end_s"], x["rule"]) for x in report["drives"][0]["cuts"]]
    # The row at 45004.0 is cut too, so the next second has no start fix; what is left
    # before the cut (3 s) is shorter than min_segment_s.
    assert cuts == [
        (44999.0, 45000.0, "partial_second"),
        (45000.0, 45003.0, "short_segment"),
        (45003.0, 45004.0, "manual"),
        (45004.0, 45005.0, "start_fix"),
    ]
    assert report["drives"][0]["cuts"][2]["detail"] == "manual cut: roadworks"


def _labelled_target(out, df):
    """The corpus's good fleet with ``df`` as its target test drive, through ingest,
    validate and label under ``out``: (the drive's validation report, its samples)."""
    from rwhonet.stages.label import label
    from support.corpus import DRIVE, write_good_fleet, write_target

    raw = out / "raw"
    write_good_fleet(raw)
    write_target(raw, df)
    params = make_params(raw)
    ingest(params, out / "drives")
    validate(params, out / "drives", out / "segments", out / "report.json")
    label(params, out / "segments", out / "samples", out / "c.json", out / "s.json")
    report = json.loads((out / "report.json").read_text())
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    samples = pd.concat(
        pd.read_parquet(p) for p in sorted((out / "samples").glob(f"{DRIVE}__s*.parquet"))
    )
    return drive, samples


def test_seconds_on_rows_leaning_into_lost_samples_are_cut_not_labelled_off(tmp_path):
    """Four rows beside a lost sample stamped 60 ms toward it, each placed a slot off at a
    second's edge (tests/support/corpus.py): the four seconds that would start or end on
    them were labelled a row's travel off (1.3-1.7 m). validate now cuts them as
    ``drop_edge``, naming the row and its lean; every label left stays near zero."""
    from support.corpus import rows_leaning_into_lost_samples

    drive, samples = _labelled_target(tmp_path, rows_leaning_into_lost_samples())
    edges = [(cut["end_s"], cut["detail"]) for cut in drive["cuts"] if cut["rule"] == "drop_edge"]
    assert [end for end, _ in edges] == [45001.0, 45050.0, 45101.0, 45151.0]
    assert "row(s) 501 (+40 ms)" in edges[1][1] and "row(s) 999 (-40 ms)" in edges[2][1]
    assert len(samples) == 193
    assert np.abs(samples["label_m"]).max() < 0.2


@pytest.mark.parametrize("habit", ["hiccups", "stalls"])
def test_a_logger_s_hiccups_and_stalls_label_the_drive_as_its_grid_stamps(tmp_path, habit):
    """Stamps within 2 ms of their grid, with three rows in the first 20 s written 40-45
    ms late (hiccups), or by a logger stamping rows when it writes them that stalled three
    times and wrote the 2-4 rows it held at once (0.1-0.3 s late): the drive's seconds and
    labels are those of the same drive stamped on its grid. The hiccups once set the
    grid's phase 21.5 ms late (every second of the drive ended on an x.9 s row, one second
    fewer); the stalls' rows, two or more in a slot, were refused."""
    from support.corpus import (
        good_target,
        hiccups_on_a_clean_logger,
        rows_written_at_once_after_stalls,
    )

    logged = {"hiccups": hiccups_on_a_clean_logger, "stalls": rows_written_at_once_after_stalls}
    _, got = _labelled_target(tmp_path / habit, logged[habit]())
    _, grid = _labelled_target(tmp_path / "grid", good_target(150.0))
    assert len(got) == len(grid) == 150
    for k in ("t_s", "label_m", "disp_gnss_m"):
        np.testing.assert_allclose(got[k], grid[k], rtol=0, atol=1e-9)


def test_missing_ingest_output(tmp_path):
    params = make_params(tmp_path)
    with pytest.raises(InputError, match="run the ingest stage first"):
        validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "r.json")


def test_a_segment_ended_by_a_restart_keeps_the_drive_s_slots_and_its_labels(tmp_path):
    """Stamps jittered by a bell curve of 10 ms, the two rows before a logger's restart
    80 and 25 ms late: validate cuts the segment at the restart, on the whole drive's
    slots. The label stage once placed the segment's rows again, alone, and its last two
    rows, with no row after them, took the slots a period late: the last second was
    labelled 1.7 m off (a 20 ms bell curve with a restart did so in 4 of 100 drives).
    The segments now carry the drive's times; every label stays near zero."""
    from support.corpus import DRIVE, late_rows_before_a_restart

    _, samples = _labelled_target(tmp_path, late_rows_before_a_restart())
    first = feather.read_table(tmp_path / "segments" / f"{DRIVE}__s000.arrow")
    assert first.column(c.T_S)[-1].as_py() == pytest.approx(45047.0, abs=1e-9)
    assert len(samples) >= 140
    assert np.abs(samples["label_m"]).max() < 0.2
