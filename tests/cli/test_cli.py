"""The command line: help on every command, readable errors, streaming through a pipe, no torch."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.cli.main import main, parser
from support.serving import base_bundle, write_drive

BAD_CELL = "row 9, column ' Wheel Speed Rear Left (rad/sec)': expected a number; found 'oops'"


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    return base_bundle(tmp_path_factory.mktemp("bundle"))


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    return write_drive(tmp_path_factory.mktemp("drive") / "V-Wavy.csv", duration_s=300)


@pytest.fixture
def bad_drive(tmp_path):
    path = write_drive(tmp_path / "V-Bad.csv", duration_s=20)
    lines = path.read_text().splitlines()
    cells = lines[9].split(",")
    cells[12] = "oops"
    lines[9] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(autouse=True)
def own_store(tmp_path, monkeypatch):
    monkeypatch.setenv("MLFLOW_TRACKING_URI", f"sqlite:///{tmp_path}/mlruns/mlflow.db")


def cli(*args, stdin=None, code=None):
    """Run the installed console script's code in a fresh interpreter."""
    env = dict(os.environ, PYTHONPATH=str(paths.ROOT / "src"))
    script = code or "import sys; from rwhonet.cli.main import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        input=stdin,
        env=env,
        capture_output=True,
        cwd=paths.ROOT,
        timeout=300,
    )


@pytest.mark.parametrize("command", ["recalibrate", "predict", "export", "gate"])
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    assert "usage:" in capsys.readouterr().out
    assert command in parser().format_help()


def test_the_gate_is_a_command_and_still_its_own_script(tmp_path):
    baseline = paths.ROOT / "metrics" / "baseline-ci.json"
    assert main(["gate", "--eval", str(baseline), "--baseline", str(baseline)]) == 0
    from rwhonet.report import gate

    assert gate.main(["--eval", str(baseline), "--baseline", str(baseline)]) == 0
    assert main(["gate", "--eval", str(tmp_path / "none.json"), "--baseline", str(baseline)]) == 2


def test_bad_drive_through_the_cli_names_file_row_and_column(bundle, bad_drive):
    out = cli("predict", "--model", str(bundle["model_onnx"]), "--drive", str(bad_drive))
    err = out.stderr.decode()
    assert out.returncode == 2, err
    assert f"{bad_drive}, {BAD_CELL}" in err and "What to do" in err
    assert "Traceback" not in err


def test_recalibrate_refuses_a_drive_too_short_and_a_file_that_is_not_there(
    bundle, tmp_path, capsys
):
    short = write_drive(tmp_path / "V-Short.csv", duration_s=60)
    base = str(bundle["model_onnx"].parent)
    assert main(["recalibrate", "--base", base, "--drive", str(short), "--seconds", "50"]) == 2
    err = capsys.readouterr().err
    assert "at least 80 GNSS-valid seconds: m = 50 s to recalibrate on (adapt.fallback" in err
    assert "found 60 labelled s; 60 valid s of 61 s (cut: partial_second 1 s)" in err
    assert "--seconds" in err
    assert main(["recalibrate", "--base", base, "--drive", str(tmp_path / "none.csv")]) == 2
    assert "none.csv: expected a drive file" in capsys.readouterr().err
    assert (
        main(["recalibrate", "--base", base, "--drive", str(short), "--recipe", "continuous"]) == 2
    )
    assert "no single model to register" in capsys.readouterr().err
    assert main(["predict", "--model", str(tmp_path), "--drive", str(short)]) == 2
    assert "expected an exported .onnx file, or a model folder" in capsys.readouterr().err


def test_the_default_recipe_needs_the_evidence_the_base_model_carries(bundle, drive, capsys):
    base = str(bundle["model_onnx"].parent)  # a bundle registered without evidence
    assert main(["recalibrate", "--base", base, "--drive", str(drive), "--seconds", "30"]) == 2
    err = capsys.readouterr().err
    assert "the base model carries no evidence to size the shrink recipe by" in err
    assert "choose another recipe with --recipe" in err


def test_the_evidence_is_the_target_car_s_unless_asked_and_the_printout_says_how_sure():
    from rwhonet.cli.recalibrate import Choice, render, shrink_evidence_of
    from rwhonet.errors import InputError
    from rwhonet.models.adapt import ShrinkEvidence

    def ev(role, n):
        return ShrinkEvidence(
            role, tuple(f"D{i}" for i in range(n)), 0.004, (1, 9), (0.1, 1.0), (n, n)
        )

    carried = {"target": ev("target_train", 3).to_dict(), "source": ev("source", 5).to_dict()}
    assert shrink_evidence_of(carried, None, "m").role == "target_train"
    assert shrink_evidence_of(carried, "source", "m").role == "source"
    assert shrink_evidence_of({**carried, "target": None}, None, "m").role == "source"
    with pytest.raises(InputError, match="carries no evidence"):
        shrink_evidence_of({"target": None, "source": None}, None, "m")
    with pytest.raises(InputError, match="carries no evidence"):
        shrink_evidence_of({"source": carried["source"]}, "target", "m")
    sure = {
        "radius_m": 0.29312,
        "low_m": 0.29201,
        "high_m": 0.29423,
        "kept": 0.62,
        "fit_sd": 0.0052,
        "prior_sd": 0.004,
        "role": "target_train",
        "n_drives": 3,
    }
    out = {
        "file": "d.csv",
        "kept": "300 valid s",
        "choice": Choice("shrink", 30, "adapt.fallback (adapt.recipe: auto)"),
        "base": "whonet-G v1",
        "n_adapt": 30,
        "seed": 42,
        "fit_s": 0.01,
        "radii": (0.2932, 0.2930),
        "certainty": sure,
        "name": "whonet-R-target",
        "version": "2",
        "run_id": "abc",
        "n_scored": 270,
        "scores": [],
        "seconds": 1.0,
    }
    text = render(out)
    assert (
        "mean rear radius 0.29312 m (95 % interval 0.29201-0.29423 m); the 30 s alone fix it "
        "to ±0.52 % (1 sd), the prior to ±0.40 %, so 62 % of the refit is kept and 38 % shrunk "
        "towards the base model (evidence: 3 drives, target_train)" in text
    )
    assert "no second" not in text
    assert "the base model kept" in render({**out, "certainty": None})
    # a car the pipeline has no drives of: the source car's evidence, the prior on its size
    assert shrink_evidence_of(carried, None, "m", new_car=True).role == "source"
    assert shrink_evidence_of({**carried, "source": None}, None, "m", new_car=True).role == (
        "target_train"
    )
    centred = render({**out, "prior_radii": (0.36, 0.3599)})
    assert "prior centred on 0.36000 / 0.35990 m" in centred
    assert "38 % shrunk towards the prior" in centred


def test_the_prior_is_centred_on_the_car_s_size_only_for_another_car():
    from rwhonet.cli.recalibrate import prior_radii_of
    from rwhonet.models.adapt import ShrinkEvidence

    def ev(role):
        return ShrinkEvidence(role, ("D0",), 0.004, (1, 9), (0.1, 1.0), (1, 1))

    src = (0.292, 0.293)
    scaled = prior_radii_of(ev("source"), src, 0.362, 0.294)
    assert scaled == pytest.approx((0.292 * 0.362 / 0.294, 0.293 * 0.362 / 0.294), rel=1e-12)
    assert prior_radii_of(ev("target_train"), src, 0.362, 0.294) is None  # τ has its offset
    assert prior_radii_of(ev("source"), src, 0.294, 0.294) is None  # the source car's size
    assert prior_radii_of(ev("source"), src, None, 0.294) is None  # no size given
    assert prior_radii_of(None, src, 0.362, 0.294) is None  # not shrink


def test_predict_streams_stdin_to_stdout_without_torch(bundle, drive):
    check = (
        "import sys; from rwhonet.cli.main import main; rc = main(sys.argv[1:]); "
        "heavy = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('torch', 'lightning', 'pytorch_lightning', 'mlflow')); "
        "print('IMPORTED', heavy, file=sys.stderr); sys.exit(rc)"
    )
    out = cli(
        "predict",
        "--model",
        str(bundle["model_onnx"]),
        "--drive",
        "-",
        "--output",
        "-",
        "--outage",
        "100:220",
        stdin=Path(drive).read_bytes(),
        code=check,
    )
    err = out.stderr.decode()
    assert out.returncode == 0, err
    assert "IMPORTED []" in err
    assert "<stdin>: 3001 rows -> 300 seconds" in err and "outage 100:220 s (120 s" in err
    from io import StringIO

    frame = pd.read_csv(StringIO(out.stdout.decode()))
    assert len(frame) == 300 and frame["outage"].notna().sum() == 120
    np.testing.assert_allclose(
        frame["disp_corrected_m"], frame["disp_wpm_m"] + frame["pred_error_m"], atol=2e-4
    )
    # where the car is through the outage, and how far that is from GNSS at its end
    inside = frame["outage"].notna()
    position = ["east_m", "north_m", "cov_ee_m2", "cov_en_m2", "cov_nn_m2", "pos_err_m"]
    assert frame.loc[inside, position].notna().all().all()
    assert frame.loc[~inside, position].isna().all().all()
    end = frame.loc[inside, "pos_err_m"].iloc[-1]
    assert f"{end:.1f} m from the GNSS fix" in err and "position at the end" in err


def test_export_then_predict_a_file_to_parquet(bundle, drive, tmp_path, capsys):
    onnx = tmp_path / "g.onnx"
    assert main(["export", "--model", str(bundle["model_onnx"].parent), "--output", str(onnx)]) == 0
    said = capsys.readouterr().out
    assert f"wrote {onnx}" in said and "max |ONNX - PyTorch|" in said
    out = tmp_path / "p.parquet"
    assert (
        main(
            [
                "predict",
                "--model",
                str(onnx),
                "--drive",
                str(drive),
                "--output",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    frame = pd.read_parquet(out)
    assert len(frame) == 300 and list(frame.columns)[:3] == ["t_s", "elapsed_s", "disp_wpm_m"]
    assert capsys.readouterr().err == ""


def test_predict_says_which_wheel_glitch_it_repaired_even_when_quiet(bundle, tmp_path, capsys):
    path = write_drive(tmp_path / "V-Glitch.csv", duration_s=60)
    lines = path.read_text().splitlines()
    cells = lines[306].split(",")  # data row 306
    cells[12] = repr(float(cells[12]) * 10.0)  # rear left, ten times its speed
    lines[306] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
    for extra in ([], ["--quiet"]):
        assert main([*args, "--output", str(tmp_path / "p.csv"), *extra]) == 0
        err = capsys.readouterr().err
        assert "wheel glitch: 1 sample(s)" in err
        assert "row 306 (t = " in err and "'Wheel Speed Rear Left (rad/sec)'" in err


@pytest.mark.parametrize("arch", ["tcn", "gru"])
def test_a_model_with_context_exports_and_predicts_every_second(arch, drive, tmp_path, capsys):
    """model.arch tcn / gru: the stream feeds each second's window of 32 s to ONNX Runtime."""
    context = base_bundle(tmp_path / "bundle", arch=arch, seq_len=32)
    onnx = tmp_path / "m.onnx"
    assert (
        main(["export", "--model", str(context["model_onnx"].parent), "--output", str(onnx)]) == 0
    )
    said = capsys.readouterr().out
    assert "(batch, 32, 40)" in said and "max |ONNX - PyTorch|" in said
    out = tmp_path / "p.parquet"
    args = ["predict", "--model", str(onnx), "--drive", str(drive), "--output", str(out)]
    assert main([*args, "--quiet"]) == 0
    frame = pd.read_parquet(out)
    assert len(frame) == 300 and frame["pred_error_m"].notna().all()
