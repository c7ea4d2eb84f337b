"""The label stage end to end on a small synthetic segments folder."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import LabelParams
from rwhonet.contracts import SAMPLE_COLUMNS
from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.features.calibration import calibration_from_dict
from rwhonet.features.scaling import scaler_from_dict
from rwhonet.io import read_json, write_json
from rwhonet.stages.label import label
from support.synthetic import R_RL_M, R_RR_M, build_drive, piecewise_linear_speed, wavy_speed

REPO = Path(__file__).resolve().parents[2]
TARGET_RADIUS_M = 0.316  # the target vehicle's tyres are bigger than the source's


def params(**label_overrides):
    """Params with only the section the label stage reads (the others are not its business)."""
    cfg = {"wpm_mode": "integrated", "calibration_min_speed_m_s": 2.0, "scaler": "global"}
    cfg.update(label_overrides)
    return SimpleNamespace(label=LabelParams(**cfg))


def write_segments(root: Path, with_calibration: bool, record: dict | None = None) -> Path:
    """Write segments/manifest.json and Parquets: source V-B (2 segments), V-A; target C-T1."""
    seg_dir = root / "data" / "interim" / "segments"
    seg_dir.mkdir(parents=True)
    tags = np.full(601, "", dtype=object)
    tags[55:80] = "roundabout"
    specs = [
        # (segment, drive, role, vehicle, frame)
        (
            "V-B__s0",
            "V-B",
            "source_train",
            "source",
            build_drive(wavy_speed(60, 12.0, 4.0, 9.0), gnss_sigma_m=0.05, seed=1, scenario=tags),
        ),
        (
            "V-B__s1",
            "V-B",
            "source_train",
            "source",
            build_drive(wavy_speed(40, 10.0, 3.0, 7.0, t0_s=1100.0), seed=2),
        ),
        (
            "V-A__s0",
            "V-A",
            "source_train",
            "source",
            build_drive(piecewise_linear_speed([0, 5, 15, 50], [0, 0, 14, 14]), seed=3),
        ),
        (
            "C-T1__s0",
            "C-T1",
            "target_test",
            "target",
            build_drive(
                wavy_speed(30, 22.0, 3.0, 8.0),
                r_rl_m=TARGET_RADIUS_M,
                r_rr_m=TARGET_RADIUS_M,
                r_front_m=TARGET_RADIUS_M,
                seed=4,
            ),
        ),
    ]
    if with_calibration:
        specs.append(
            (
                "V-cal__s0",
                "V-cal",
                "source_calibration",
                "source",
                build_drive(wavy_speed(120, 15.0, 5.0, 11.0), r_rl_m=0.305, r_rr_m=0.303, seed=5),
            )
        )
    entries = []
    for segment, drive, role, vehicle, frame in specs:
        frame.to_feather(seg_dir / f"{segment}.arrow")
        entries.append(
            {
                "segment": segment,
                "drive": drive,
                "role": role,
                "vehicle": vehicle,
                "t_start_s": float(frame[c.T_S].iloc[0]),
                "t_end_s": float(frame[c.T_S].iloc[-1]),
                "n_rows": len(frame),
            }
        )
    if record is None:  # ingest's rule: source_calibration, else the first source_train drive
        record = (
            {"role": "source_calibration", "drives": ["V-cal"], "fallback": False}
            if with_calibration
            else {"role": "source_train", "drives": ["V-A"], "fallback": True}
        )
    manifest = {"segments": entries, "calibration": record}  # passed on by validate
    write_json(seg_dir / "manifest.json", manifest)
    return seg_dir


def run_label(tmp_path: Path, with_calibration: bool = False, record=None, **label_overrides):
    seg_dir = write_segments(tmp_path, with_calibration, record)
    out = tmp_path / "data" / "processed"
    summary = label(
        params(**label_overrides),
        seg_dir,
        out / "samples",
        out / "calibration.json",
        out / "scaler.json",
    )
    return summary, out


def test_outputs_follow_the_data_contract(tmp_path):
    summary, out = run_label(tmp_path)
    manifest = read_json(out / "samples" / "manifest.json")
    assert [e["segment"] for e in manifest["segments"]] == [
        "V-B__s0",
        "V-B__s1",
        "V-A__s0",
        "C-T1__s0",
    ]
    assert manifest["segments"][0] == {
        "segment": "V-B__s0",
        "drive": "V-B",
        "role": "source_train",
        "vehicle": "source",
        "n_seconds": 60,
    }
    table = pd.read_parquet(out / "samples" / "V-B__s0.parquet")
    assert tuple(table.columns) == SAMPLE_COLUMNS
    assert len(table) == 60
    assert (table[[f"x_{i:02d}" for i in range(40)]].dtypes == np.float32).all()
    assert table["t_s"].dtype == np.float64 and table["label_m"].dtype == np.float64
    np.testing.assert_allclose(table["t_s"], 1001.0 + np.arange(60))
    np.testing.assert_allclose(table["label_m"], table["disp_gnss_m"] - table["disp_wpm_m"])
    # Rows 55..79 are tagged: seconds 5 (rows 51-60) to 7 (rows 71-80).
    assert table["scenario"].tolist()[4:9] == ["", "roundabout", "roundabout", "roundabout", ""]
    source = summary["roles"]["source_train"]
    assert (source["segments"], source["rows"], source["seconds"]) == (3, 601 + 401 + 501, 150)
    # Source drives with their own calibrated radii: labels are only noise, mean ~0.
    assert abs(source["label_mean_m"]) < 0.01
    assert summary["roles"]["target_test"]["seconds"] == 30


def test_the_first_source_train_drive_calibrates_when_ingest_says_so(tmp_path):
    summary, out = run_label(tmp_path)
    calib = calibration_from_dict(read_json(out / "calibration.json"), "calibration.json")
    assert (
        calib.role == "source_train" and calib.drives == ["V-A"] and calib.segments == ["V-A__s0"]
    )
    assert calib.r_rl_m == pytest.approx(R_RL_M, rel=1e-6)  # noise-free drive
    assert calib.r_rr_m == pytest.approx(R_RR_M, rel=1e-6)
    # V-A stands still for 5 s: the authors' estimator is undefined there (JSON null).
    assert calib.comparison["mean_of_ratios"]["r_rl_m"] is None
    assert summary["r_rl_m"] == calib.r_rl_m


def test_the_calibration_drive_calibrates_when_ingest_says_so(tmp_path):
    _, out = run_label(tmp_path, with_calibration=True)
    calib = calibration_from_dict(read_json(out / "calibration.json"), "calibration.json")
    assert calib.role == "source_calibration" and calib.drives == ["V-cal"]
    assert calib.r_rl_m == pytest.approx(0.305, rel=1e-4)
    assert calib.r_rr_m == pytest.approx(0.303, rel=1e-4)


def test_the_calibration_drives_ingest_recorded_are_used(tmp_path):
    record = {"role": "source_train", "drives": ["V-B"], "fallback": True}
    _, out = run_label(tmp_path, record=record)
    calib = calibration_from_dict(read_json(out / "calibration.json"), "calibration.json")
    assert (calib.role, calib.drives, calib.segments) == (
        "source_train",
        ["V-B"],
        ["V-B__s0", "V-B__s1"],
    )
    assert calib.r_rl_m == pytest.approx(R_RL_M, rel=1e-3)


@pytest.mark.parametrize(
    ("record", "expected"),
    [
        ({"role": "source_calibration", "drives": ["V-gone"]}, "calibration drive"),
        ({"role": "source_train", "drives": []}, "drive ids"),
    ],
)
def test_a_calibration_record_without_usable_drives_is_refused(tmp_path, record, expected):
    with pytest.raises(InputError, match=expected):
        run_label(tmp_path, record=record)


def test_target_labels_carry_the_radius_mismatch(tmp_path):
    _, out = run_label(tmp_path)
    target = pd.read_parquet(out / "samples" / "C-T1__s0.parquet")
    # Bigger true tyres than the source-calibrated radius: WPM under-reads, label > 0,
    # by the fraction 1 - r_cal / r_true of the distance (GNSS - WPM sign).
    mean_r_cal = 0.5 * (R_RL_M + R_RR_M)
    ratio = target["label_m"] / target["disp_gnss_m"]
    np.testing.assert_allclose(ratio, 1 - mean_r_cal / TARGET_RADIUS_M, atol=1e-3)


def test_scaler_is_fitted_on_source_train_only(tmp_path):
    _, out = run_label(tmp_path, with_calibration=True)
    scaler = scaler_from_dict(read_json(out / "scaler.json"), "scaler.json")
    assert scaler.fitted_on == ("V-A", "V-B")
    train = pd.concat(
        pd.read_parquet(out / "samples" / f"{s}.parquet") for s in ("V-B__s0", "V-B__s1", "V-A__s0")
    )
    x_train = train[[f"x_{i:02d}" for i in range(40)]].to_numpy()
    assert x_train.min() == pytest.approx(0.0, abs=1e-6) and x_train.max() == pytest.approx(
        1.0, abs=1e-6
    )
    # The faster target drive and the calibration drive did not widen the range: not clipped either.
    target = pd.read_parquet(out / "samples" / "C-T1__s0.parquet")
    assert target[[f"x_{i:02d}" for i in range(40)]].to_numpy().max() > 1.0


def test_reference_mode_and_per_wheel_scaler_are_honoured(tmp_path):
    summary, out = run_label(tmp_path, wpm_mode="reference", scaler="per_wheel")
    assert (
        summary["wpm_mode"] == "reference"
        and scaler_from_dict(read_json(out / "scaler.json"), "scaler.json").kind == "per_wheel"
    )
    table = pd.read_parquet(out / "samples" / "V-B__s1.parquet")
    # Reference WPM = end-of-second speed x 1 s; on a wavy speed it differs from the distance.
    assert np.abs(table["label_m"]).max() > 0.05


def test_a_bad_segment_is_reported_and_nothing_is_written(tmp_path):
    seg_dir = write_segments(tmp_path, with_calibration=False)
    bad = pd.read_feather(seg_dir / "V-B__s1.arrow")
    bad.loc[12, c.LON_DEG] = np.inf
    bad.to_feather(seg_dir / "V-B__s1.arrow")
    (seg_dir / "V-A__s0.arrow").unlink()
    out = tmp_path / "processed"
    with pytest.raises(InputError) as err:
        label(params(), seg_dir, out / "samples", out / "calibration.json", out / "scaler.json")
    problems = err.value.problems
    assert any(
        p.file.endswith("V-B__s1.arrow") and p.row == 13 and p.column == c.LON_DEG for p in problems
    )
    assert any(p.file.endswith("V-A__s0.arrow") and p.found == "no file" for p in problems)
    assert not out.exists()


def test_a_segment_whose_seconds_disagree_with_validate_is_refused(tmp_path):
    seg_dir = write_segments(tmp_path, with_calibration=False)
    manifest = read_json(seg_dir / "manifest.json")
    for entry in manifest["segments"]:
        entry["n_seconds"] = (entry["n_rows"] - 1) // 10
    manifest["segments"][1]["n_seconds"] += 1
    write_json(seg_dir / "manifest.json", manifest)
    out = tmp_path / "processed"
    with pytest.raises(InputError) as err:
        label(params(), seg_dir, out / "samples", out / "calibration.json", out / "scaler.json")
    (problem,) = err.value.problems
    assert problem.file.endswith("V-B__s1.arrow") and "41 seconds" in problem.expected


def test_manifest_problems_are_reported(tmp_path):
    seg_dir = tmp_path / "segments"
    seg_dir.mkdir()
    write_json(
        seg_dir / "manifest.json", {"segments": [{"segment": "a", "drive": "d", "role": "r"}]}
    )
    with pytest.raises(InputError) as err:
        label(params(), seg_dir, tmp_path / "s", tmp_path / "c.json", tmp_path / "x.json")
    # no vehicle, and no record of the drives that calibrate (validate passes it on)
    assert [(p.row, p.column) for p in err.value.problems] == [
        (1, "vehicle"),
        (None, "calibration"),
    ]


def test_stage_script_runs_from_the_repo_root(tmp_path):
    """``python pipelines/label.py`` in a project whose root is a temporary copy."""
    (tmp_path / "params.yaml").write_text((REPO / "params.yaml").read_text())
    (tmp_path / "dvc.yaml").write_text((REPO / "dvc.yaml").read_text())
    write_segments(tmp_path, with_calibration=False)
    env = {**os.environ, "RWHONET_ROOT": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, str(REPO / "pipelines" / "label.py")],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "rear radii r_rl = 0.30100 m, r_rr = 0.29700 m (source_train: V-A)" in proc.stdout
    assert "source_train" in proc.stdout and "target_test" in proc.stdout
    assert (tmp_path / "data" / "processed" / "samples" / "C-T1__s0.parquet").is_file()
    assert (tmp_path / "data" / "processed" / "scaler.json").is_file()


def test_unreadable_manifest_is_an_input_error(tmp_path):
    (tmp_path / "manifest.json").write_text('{"segments": [\n  {"segment": ,}\n]}')
    with pytest.raises(InputError) as err:
        label(params(), tmp_path, tmp_path / "s", tmp_path / "c.json", tmp_path / "x.json")
    assert err.value.problems[0].row == 2
    with pytest.raises(InputError, match="no file"):
        label(
            params(), tmp_path / "nowhere", tmp_path / "s", tmp_path / "c.json", tmp_path / "x.json"
        )


def test_a_segment_that_is_not_an_arrow_file_is_reported(tmp_path):
    seg_dir = write_segments(tmp_path, with_calibration=False)
    (seg_dir / "V-B__s1.arrow").write_bytes(b"t_s,lat_deg\n1,2\n")  # not what validate writes
    out = tmp_path / "processed"
    with pytest.raises(InputError) as err:
        label(params(), seg_dir, out / "samples", out / "calibration.json", out / "scaler.json")
    (problem,) = err.value.problems
    assert problem.file.endswith("V-B__s1.arrow") and "Arrow IPC file" in problem.expected
    assert "dvc repro validate" in problem.fix
    assert not out.exists()
