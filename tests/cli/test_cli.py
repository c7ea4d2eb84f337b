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
from support.serving import base_bundle, predict_args, write_drive

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
def own_store(store_uri, monkeypatch):
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store_uri)


def cli(*args, stdin=None, code=None):
    """Run the installed console script's code in a fresh interpreter."""
    env = dict(os.environ, PYTHONPATH=str(paths.ROOT / "src"))
    script = code or "from rwhonet.cli.main import entry; entry()"  # the console script's
    return subprocess.run(
        [sys.executable, "-c", script, *args],
        input=stdin,
        env=env,
        capture_output=True,
        cwd=paths.ROOT,
        timeout=300,
    )


@pytest.mark.parametrize("command", ["recalibrate", "predict", "check", "export", "gate"])
def test_every_command_has_help(command, capsys):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    assert "usage:" in capsys.readouterr().out
    assert command in parser().format_help()


def test_the_console_script_ends_by_the_command_s_status():
    """Through rwhonet.libraries.exit_process: help 0, a usage error 2, output flushed."""
    done = cli("predict", "--help")
    assert done.returncode == 0 and b"usage: rwhonet predict" in done.stdout
    done = cli("no-such-command")
    assert done.returncode == 2 and b"invalid choice" in done.stderr


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
    # what the resampler changed of a stream drive, under the drive's line, as predict says it
    moved = "d/gnss.csv: the fix stamps scatter 3.7 ms about a regular 5 Hz grid; ..."
    lines = render({**out, "drive_notes": [moved]}).splitlines()
    assert lines[:2] == ["d.csv: 300 valid s", moved]
    assert render(out).splitlines()[1].startswith("recalibrated whonet-G v1")


def test_a_stream_drive_s_moved_fixes_reach_recalibrate(tmp_path):
    """load_drive hands recalibrate what the resampler changed (fixes stamped on arrival
    moved to the receiver's epochs)."""
    from rwhonet.cli.drive import calibration_of, load_drive
    from rwhonet.config import load_params
    from rwhonet.data import canonical as c
    from rwhonet.features.scaling import MinMaxScaler
    from rwhonet.sim.streams import SIGNAL_MAP, StreamTables
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    late = good.gnss[c.T_S] + 0.02 + np.random.default_rng(1).uniform(-0.005, 0.005, len(good.gnss))
    drive, _ = _stream_drive(tmp_path, StreamTables(good.wheels, good.gnss.assign(**{c.T_S: late})))
    smap = {k: {"column": col, "unit": u} for k, (col, u) in SIGNAL_MAP.items()}
    params = load_params(
        overrides={"data.signal_maps": {"logger_csv": {"reader": "stream_csv", "signals": smap}}}
    )
    data = load_drive(
        drive,
        params,
        vehicle="car",
        fmt="logger_csv",
        calibration=calibration_of((RADIUS_M, RADIUS_M), "test"),
        scaler=MinMaxScaler("global", (0.0,) * 4, (60.0,) * 4, (), 0),
        wpm_mode="integrated",
        seq_len=1,
    )
    assert len(data.notes) == 1 and "placed at the grid's epochs" in data.notes[0]


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


def test_a_recalibrated_model_keeps_the_filter_s_calibration_only_on_the_car_it_was_measured():
    from rwhonet.cli.recalibrate import inherited_navigation

    nav = {"vehicle": "target", "receiver_sigma_m": 2.7, "calibration": {"scales": {"30": 0.7}}}
    got = inherited_navigation(nav, "target", "whonet-G v1")
    assert got["receiver_sigma_m"] == 2.7 and got["calibration"] == nav["calibration"]
    assert got["from"].startswith("whonet-G v1's")
    assert inherited_navigation(nav, "rav4", "whonet-G v1") is None  # another car: not measured
    assert inherited_navigation(None, "target", "whonet-G v1") is None


def test_predict_streams_stdin_to_stdout_without_torch_pandas_or_scipy(bundle, drive):
    # ONNX Runtime serves (no torch); an IO-VNBD drive is read and checked without pandas
    # and scipy, whose imports took 1 s of a 2 s start (the stream readers import scipy)
    check = (
        "import sys; from rwhonet.cli.main import main; rc = main(sys.argv[1:]); "
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & "
        "{'torch', 'lightning', 'pytorch_lightning', 'mlflow', 'pandas', 'scipy'}); "
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
    position = ["east_m", "north_m", "lat_deg", "lon_deg", "cov_ee_m2", "cov_en_m2", "cov_nn_m2"]
    position += ["r68_m", "r95_m", "pos_err_m"]
    assert frame.loc[inside, position].notna().all().all()
    assert frame.loc[~inside, position].isna().all().all()
    header = out.stdout.decode().splitlines()[0].split(",")
    row = out.stdout.decode().splitlines()[1 + int(np.flatnonzero(inside)[0])].split(",")
    assert len(row[header.index("lat_deg")].split(".")[1]) == 8  # about a millimetre
    end = frame.loc[inside, "pos_err_m"].iloc[-1]
    assert f"{end:.1f} m from the GNSS fix" in err and "position at the end" in err
    lat, lon = frame.loc[inside, ["lat_deg", "lon_deg"]].iloc[-1]
    assert f"of the last fix before it ({lat:.6f}, {lon:.6f}; 68 %" in err
    # a model the evaluation has not measured says its regions are the filter's own
    r68, r95 = frame.loc[inside, ["r68_m", "r95_m"]].iloc[-1]
    assert f"68 % / 95 % within {r68:.1f} / {r95:.1f} m, the filter's own, not calibrated" in err


def test_export_takes_a_pipeline_model_folder_as_its_model_pt(tmp_path, capsys, monkeypatch):
    """``rwhonet export --model models/g/seed42`` (the folder the pipeline writes: model.pt,
    run.json, predictions) exports its model.pt; it said the folder held no model."""
    import json
    import shutil

    from rwhonet.serve.model import load_served
    from support.serving import RADIUS_M, SCALER

    made = base_bundle(tmp_path / "made")
    folder = tmp_path / "models" / "g" / "seed42"
    folder.mkdir(parents=True)
    shutil.copy(tmp_path / "made" / "source.pt", folder / "model.pt")
    (folder / "run.json").write_text("{}")
    for name, content in (
        ("SCALER", SCALER.to_dict()),
        ("CALIBRATION", {"r_rl_m": RADIUS_M, "r_rr_m": RADIUS_M}),
    ):
        monkeypatch.setattr(paths, name, tmp_path / f"{name.lower()}.json")
        getattr(paths, name).write_text(json.dumps(content))
    onnx = tmp_path / "g.onnx"
    assert main(["export", "--model", str(folder), "--output", str(onnx)]) == 0
    assert f"wrote {onnx}" in capsys.readouterr().out
    assert load_served(onnx).meta.source_radii == load_served(made["model_onnx"]).meta.source_radii
    # predict, given the folder, says to export it, naming it
    drive = write_drive(tmp_path / "V-D.csv", duration_s=20)
    out = tmp_path / "p.csv"
    args = ["predict", "--model", str(folder), "--drive", str(drive), "--output", str(out)]
    assert main(args) == 2
    assert f"`rwhonet export --model {folder} --output model.onnx`" in capsys.readouterr().err


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


def test_predict_reads_a_drive_kept_as_parquet_as_the_csv_it_holds(bundle, drive, tmp_path, capsys):
    """A data lake's Parquet of the drive (typed columns, row groups): the same seconds and
    values as its CSV, the table said on stderr; a Parquet in a pipe refused, named."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = tmp_path / "V-Wavy.parquet"
    frame = pd.read_csv(drive)
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), table, row_group_size=500)
    assert main(predict_args(bundle, drive, tmp_path / "csv.csv", "--quiet")) == 0
    capsys.readouterr()
    assert main(predict_args(bundle, table, tmp_path / "pq.csv")) == 0
    err = capsys.readouterr().err
    assert f"a table file (Parquet), read as CSV: {len(frame):,} rows" in err
    got, want = pd.read_csv(tmp_path / "pq.csv"), pd.read_csv(tmp_path / "csv.csv")
    assert len(got) == 300
    pd.testing.assert_frame_equal(got, want)
    done = cli(*predict_args(bundle, "-", "-"), stdin=table.read_bytes())
    assert done.returncode == 2 and b"a table file (Parquet): give its path" in done.stderr
    spark = tmp_path / "V-Wavy.spark"  # as Spark writes it: a folder of part files
    spark.mkdir()
    whole = pq.read_table(table)
    pq.write_table(whole.slice(0, 1000), spark / "part-00000.snappy.parquet")
    pq.write_table(whole.slice(1000), spark / "part-00001.snappy.parquet")
    assert main(predict_args(bundle, spark, tmp_path / "spark.csv", "--quiet")) == 0
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "spark.csv"), want)


def test_predict_reads_a_drive_of_a_file_of_many_by_its_id(bundle, tmp_path, capsys, monkeypatch):
    """A file of two drives told apart by a column (the map's ``drive`` key): ``--drive-id``
    gives the drive's own file's output, read whole; a file of one drive needs none; a
    file of several without it is refused naming them, as is an id with a map of none."""
    from support.drives import CUPAC_MAP, column_map_params, write_columnmap, write_params_yaml
    from support.serving import wavy_drive

    cmap = column_map_params(CUPAC_MAP)
    overrides = {
        "data.column_maps.logger": cmap,
        "data.column_maps.trips": cmap | {"drive": {"column": "trip_id", "unit": "text"}},
    }
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    frames = []
    for k in (1, 2):
        single = write_columnmap(wavy_drive(200.0, seed=k), tmp_path / f"T-{k}.csv")
        args = ["--format", "logger", "--outage", "100:160", "--quiet"]
        assert main(predict_args(bundle, single, tmp_path / f"T-{k}-out.csv", *args)) == 0
        frames.append(pd.read_csv(single).assign(trip_id=f"T-{k}"))
    fleet = tmp_path / "fleet.csv"
    pd.concat(frames).to_csv(fleet, index=False)
    capsys.readouterr()
    args = ["--format", "trips", "--outage", "100:160"]
    assert main(predict_args(bundle, fleet, tmp_path / "two.csv", *args, "--drive-id", "T-2")) == 0
    err = capsys.readouterr().err
    assert "drive 'T-2' of" in err
    pd.testing.assert_frame_equal(
        pd.read_csv(tmp_path / "two.csv"), pd.read_csv(tmp_path / "T-2-out.csv")
    )
    assert main(predict_args(bundle, fleet, tmp_path / "no.csv", *args)) == 2
    assert "expected one drive, or --drive-id naming the one to read" in capsys.readouterr().err
    frames[0].to_csv(tmp_path / "one.csv", index=False)  # a file of one drive
    assert main(predict_args(bundle, tmp_path / "one.csv", tmp_path / "one-out.csv", *args)) == 0
    pd.testing.assert_frame_equal(
        pd.read_csv(tmp_path / "one-out.csv"), pd.read_csv(tmp_path / "T-1-out.csv")
    )
    capsys.readouterr()
    logger = ["--format", "logger", "--drive-id", "T-1"]
    assert main(predict_args(bundle, tmp_path / "one.csv", tmp_path / "x.csv", *logger)) == 2
    assert "whose column map names each row's drive" in capsys.readouterr().err


def _glitched_drive(path: Path, row: int) -> list[str]:
    """A 60 s drive whose rear-left wheel reads ten times its speed in data row ``row``;
    its lines (line 0: the header)."""
    path = write_drive(path, duration_s=60)
    lines = path.read_text().splitlines()
    cells = lines[row].split(",")
    cells[12] = repr(float(cells[12]) * 10.0)  # rear left
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return lines


def test_predict_puts_a_files_rows_in_time_order_and_names_the_file_s_rows(
    bundle, tmp_path, capsys
):
    """Rows 200 and 201 swapped, and the drive's two halves joined the wrong way (its rows
    301-600 first): from a file, predict sorts them as ingest does (the output is the drive
    in order's), and names a glitch by its row in the file; from a pipe, read as it comes,
    it refuses the step back, naming the row."""
    clean = tmp_path / "V-InOrder.csv"
    lines = _glitched_drive(clean, 250)
    moved = tmp_path / "V-Moved.csv"
    rows = lines[1:]
    rows[199], rows[200] = rows[200], rows[199]
    moved.write_text("\n".join([lines[0], *rows[300:], *rows[:300]]) + "\n")
    out = {}
    for path in (clean, moved):
        out[path] = tmp_path / f"{path.stem}.out.csv"
        args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
        assert main([*args, "--output", str(out[path])]) == 0
        err = capsys.readouterr().err
        row = 250 if path == clean else 250 + len(rows) - 300  # its second half first
        assert f"row {row} (t = " in err, err
        assert f"{path.name}: {len(rows)} rows -> 60 seconds" in err, err  # every row read
    assert "put in time order" in err
    assert out[moved].read_text() == out[clean].read_text()
    done = cli(*predict_args(bundle, "-", "-"), stdin=moved.read_bytes())
    assert done.returncode == 2
    assert f"<stdin>, row {len(rows) - 300 + 1}, column ' Time'" in done.stderr.decode()


def test_predict_says_which_wheel_glitch_it_repaired_even_when_quiet(bundle, tmp_path, capsys):
    path = tmp_path / "V-Glitch.csv"
    _glitched_drive(path, 306)
    args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
    for extra in ([], ["--quiet"]):
        assert main([*args, "--output", str(tmp_path / "p.csv"), *extra]) == 0
        err = capsys.readouterr().err
        assert "wheel glitch: 1 sample(s)" in err
        assert "row 306 (t = " in err and "'Wheel Speed Rear Left (rad/sec)'" in err


def test_predict_drops_a_row_written_twice_and_names_the_file_s_rows(bundle, tmp_path, capsys):
    """A row written twice is dropped as ingest drops it: the output is the drive written
    once, stderr says which row was dropped, and a glitch after it is named by its row in
    the file (306), not by its rank among the rows kept (305)."""
    clean = tmp_path / "V-Once.csv"
    lines = _glitched_drive(clean, 305)
    twice = tmp_path / "V-Twice.csv"
    twice.write_text("\n".join([*lines[:101], lines[100], *lines[101:]]) + "\n")  # row 100
    out = {}
    for path in (clean, twice):
        out[path] = tmp_path / f"{path.stem}.csv"
        args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
        assert main([*args, "--output", str(out[path]), "--quiet"]) == 0
        err = capsys.readouterr().err
        assert "wheel glitch: 1 sample(s)" in err
        row = 306 if path == twice else 305
        assert f"row {row} (t = " in err
    assert out[twice].read_text() == out[clean].read_text()
    assert "1 data row(s) repeat an earlier row" in err and "(row(s) 101)" in err


def test_predict_drops_a_row_without_a_wheel_speed_as_a_lost_sample(bundle, tmp_path, capsys):
    """A row with an empty wheel speed streams as the row deleted (a dropped sample), and
    stderr names it by its row in the file; wheel speeds in every other row only, or a
    wheel column with no value, are refused as ingest refuses them, with nothing written."""
    lines = write_drive(tmp_path / "V-W.csv", duration_s=60).read_text().splitlines()

    def emptied(cells_of: dict[int, list[int]]) -> list[str]:
        out = list(lines)
        for row, cols in cells_of.items():
            cells = out[row].split(",")
            for j in cols:
                cells[j] = ""
            out[row] = ",".join(cells)
        return out

    drives = {
        "deleted": [x for i, x in enumerate(lines) if i not in (1, 205)],
        "holes": emptied({1: [12], 205: [10, 13]}),  # before the first frame; inside
        "half": emptied({i: [11] for i in range(2, len(lines), 2)}),
        "none": emptied({i: [13] for i in range(1, len(lines))}),
    }
    out, err = {}, {}
    for name, text in drives.items():
        path = tmp_path / f"V-{name}.csv"
        path.write_text("\n".join(text) + "\n")
        out[name] = tmp_path / f"{name}.out.csv"
        args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
        code = main([*args, "--output", str(out[name]), "--quiet"])
        assert code == (2 if name in ("half", "none") else 0)
        err[name] = capsys.readouterr().err
    assert out["holes"].read_text() == out["deleted"].read_text()
    assert "2 data row(s) have an empty wheel speed (row(s) 1, 205)" in err["holes"]
    assert (
        "300 of the 601 data rows (49.9 %) without all four, the first row(s) 2, 4" in err["half"]
    )
    assert "' Wheel Speed Rear Right (rad/sec)'" in err["none"] and "no value in any" in err["none"]
    assert not out["half"].exists() and not out["none"].exists()


def test_predict_places_fixes_held_from_a_1_hz_receiver_as_ingest_does(bundle, tmp_path, capsys):
    """A 10 Hz file whose fixes are held from a 1 Hz receiver (the fix arriving 0.4 s
    after each whole second) gives each second's GNSS displacement of the file with its
    own fixes, within a centimetre, and says so; read as written it was a second's
    travel 0.6 s off, and its jumps taken for broken fixes."""
    from rwhonet.data import canonical as c
    from support.drives import with_held_fixes, write_iovnbd
    from support.synthetic import build_drive, wavy_speed

    # exact fixes, so that the file's own and the placed ones can be compared
    own = build_drive(wavy_speed(120, 12.0, 4.0, 60.0, t0_s=45000.0), wheel_sigma_rad_s=0.05)
    own[c.N_SATS] = 9.0
    held = with_held_fixes(own, 10, 4)
    out = {}
    for name, df in (("own", own), ("held", held)):
        path = write_iovnbd(df, tmp_path / f"V-{name}.csv")
        out[name] = tmp_path / f"{name}.out.csv"
        args = ["predict", "--model", str(bundle["model_onnx"]), "--drive", str(path)]
        assert main([*args, "--output", str(out[name]), "--outage", "40:100"]) == 0
        err = capsys.readouterr().err
        assert ("from a 1 Hz receiver, each held" in err) == (name == "held"), err
        assert "implying more than" not in err  # no fix taken for a jump
    a, b = (pd.read_csv(out[k]) for k in ("own", "held"))
    both = a.merge(b, on="t_s", suffixes=("", "_held"))
    assert len(both) >= len(a) - 2  # the last second has no fix after it to place by
    gnss = both[["disp_gnss_m", "disp_gnss_m_held"]].dropna()
    assert len(gnss) > 100
    np.testing.assert_allclose(gnss["disp_gnss_m_held"], gnss["disp_gnss_m"], atol=0.01)
    assert c.LAT_DEG in a


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


# --------------------------------------------------------------------------- wheel units

RAV4_M = 0.362  # a car whose tyre tells km/h from rad/s (1 / (3.6 r) = 0.77)


def _rav4_drive(wheel_factor: float = 1.0, fixes: bool = True):
    """A 120 s wavy drive on 0.362 m tyres; wheel speeds x ``wheel_factor``; no fix at all
    with ``fixes`` False."""
    from rwhonet.data import canonical as c
    from support.synthetic import build_drive, wavy_speed

    df = build_drive(
        wavy_speed(120.0, 12.0, 4.0, 60.0, t0_s=45000.0),
        r_rl_m=RAV4_M,
        r_rr_m=RAV4_M,
        r_front_m=RAV4_M,
        gnss_sigma_m=0.2,
        wheel_sigma_rad_s=0.05,
    )
    df[c.N_SATS] = 9.0
    for w in c.WHEELS:
        df[w] *= wheel_factor
    if not fixes:
        df[c.LAT_DEG] = np.nan
        df[c.LON_DEG] = np.nan
    return df


def test_predict_refuses_km_h_labelled_rad_s_as_validate_does_and_writes_nothing(
    bundle, tmp_path, capsys
):
    from support.drives import write_iovnbd

    good = write_iovnbd(_rav4_drive(), tmp_path / "V-Rav4.csv")
    kmh = write_iovnbd(_rav4_drive(RAV4_M * 3.6), tmp_path / "V-Kmh.csv")  # v in km/h
    car = ["--nominal-radius", str(RAV4_M)]
    assert main(predict_args(bundle, good, tmp_path / "good.csv", *car)) == 0
    assert len(pd.read_csv(tmp_path / "good.csv")) == 120
    assert "not checked" not in capsys.readouterr().err
    out = tmp_path / "kmh.csv"
    assert main(predict_args(bundle, kmh, out, *car)) == 2
    err = capsys.readouterr().err
    assert str(kmh) in err and "Wheel Speed Rear Left (rad/sec)" in err
    assert "within ±5% of the car's nominal 0.362 m" in err  # validate's report, its threshold
    assert "radius ≈ 1/3.6 m: the wheel speeds look like km/h" in err
    assert "--nominal-radius" in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []
    # on stdout: the header and no second before the check has decided
    rc = cli(*predict_args(bundle, "-", "-", *car), stdin=kmh.read_bytes())
    assert rc.returncode == 2, rc.stderr.decode()
    assert rc.stdout.decode().splitlines() == [rc.stdout.decode().splitlines()[0]]
    assert "look like km/h" in rc.stderr.decode()


def _mdf4_drive(tmp_path, df, wheel_unit: str, yaw_unit: str | None = None):
    """The drive as an MDF4 file (wheel speeds and a yaw rate in deg/s in one group, the
    fixes in another) and its signal map, which declares the wheels' and yaw rate's units."""
    from asammdf import MDF, Signal

    from rwhonet.data import canonical as c

    t = df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    names = ("WheelSpeed_FL", "WheelSpeed_FR", "WheelSpeed_RL", "WheelSpeed_RR")
    mdf = MDF(version="4.10")
    first = [
        Signal(df[w].to_numpy(), t, name=n, unit=wheel_unit)
        for w, n in zip(c.WHEELS, names, strict=True)
    ]
    if yaw_unit is not None:
        yaw = np.degrees(df[c.YAW_RATE_RAD_S].to_numpy())
        first.append(Signal(yaw, t, name="YawRate", unit="deg/s"))
    mdf.append(first)
    mdf.append(
        [
            Signal(df[c.LAT_DEG].to_numpy(), t, name="Latitude", unit="deg"),
            Signal(df[c.LON_DEG].to_numpy(), t, name="Longitude", unit="deg"),
        ]
    )
    drive = tmp_path / "drive.mf4"
    mdf.save(drive, overwrite=True)
    mdf.close()
    signal_map = tmp_path / "map.yaml"
    signal_map.write_text(
        "".join(
            f"omega_{w}: {{column: WheelSpeed_{w.upper()}, unit: {wheel_unit}}}\n"
            for w in ("fl", "fr", "rl", "rr")
        )
        + "lat: {column: Latitude, unit: deg}\nlon: {column: Longitude, unit: deg}\n"
        + (f"yaw_rate: {{column: YawRate, unit: {yaw_unit}}}\n" if yaw_unit else "")
    )
    return drive, signal_map


def test_predict_refuses_an_mdf4_whose_rad_s_are_labelled_km_h(bundle, tmp_path, capsys):
    drive, signal_map = _mdf4_drive(tmp_path, _rav4_drive(), "km/h")
    out = tmp_path / "p.csv"
    fmt = ["--format", "mdf4", "--signal-map", str(signal_map), "--nominal-radius", str(RAV4_M)]
    assert main(predict_args(bundle, drive, out, *fmt)) == 2
    err = capsys.readouterr().err
    assert "WheelSpeed_RL" in err and "implied radius" in err and "ratio 1.3" in err
    assert not out.exists()


def test_predict_refuses_a_clockwise_yaw_rate_as_validate_does_and_writes_nothing(
    bundle, tmp_path, capsys
):
    """The navigation filter's gyro: a yaw rate that turns the wrong way is refused, one in
    the declared sign passes with nothing said; a straight drive says it could not tell."""
    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, YAW_COLUMN, weaving_target
    from support.drives import write_iovnbd

    car = ["--nominal-radius", str(TARGET_RADIUS_M)]
    df = weaving_target()
    good = write_iovnbd(df, tmp_path / "V-Turns.csv")
    assert main(predict_args(bundle, good, tmp_path / "good.csv", *car)) == 0
    assert "yaw" not in capsys.readouterr().err
    df[c.YAW_RATE_RAD_S] = -df[c.YAW_RATE_RAD_S]
    cw = write_iovnbd(df, tmp_path / "V-Cw.csv")
    out = tmp_path / "cw.csv"
    assert main(predict_args(bundle, cw, out, *car)) == 2
    err = capsys.readouterr().err
    assert str(cw) in err and YAW_COLUMN.strip() in err and "positive turning right" in err
    assert "validate.yaw_gain_tolerance" in err and "deg/s cw" in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []
    straight = write_iovnbd(_rav4_drive(), tmp_path / "V-Straight.csv")  # its yaw rate: 0
    assert main(predict_args(bundle, straight, tmp_path / "s.csv", *car[:1], str(RAV4_M))) == 0
    err = capsys.readouterr().err
    assert err.count("yaw rate's unit and sign not told") == 1 and "not checked" not in err


def test_predict_refuses_an_axle_s_wheels_exchanged_as_validate_does_and_writes_nothing(
    bundle, tmp_path, capsys
):
    """The rear wheels' speeds written to each other's columns turn the wheels' yaw the wrong
    way (2D dead reckoning without a gyro): refused, naming both columns; the front and rear
    columns exchanged, refused naming all four; in their columns they pass with nothing
    said; wheels that never differ say the sides and the axles were not told."""
    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, weaving_drive, weaving_target
    from support.drives import write_iovnbd

    car = ["--nominal-radius", str(TARGET_RADIUS_M)]
    df = weaving_drive(150.0, 8.0, 0.6, track_m=1.5, wheelbase_m=2.7)  # tight turns
    good = write_iovnbd(df, tmp_path / "V-Turns.csv")
    assert main(predict_args(bundle, good, tmp_path / "good.csv", *car)) == 0
    assert "wheels not told" not in capsys.readouterr().err
    df[[c.OMEGA_RL, c.OMEGA_RR]] = df[[c.OMEGA_RR, c.OMEGA_RL]].to_numpy()
    swapped = write_iovnbd(df, tmp_path / "V-Swapped.csv")
    out = tmp_path / "swapped.csv"
    assert main(predict_args(bundle, swapped, out, *car)) == 2
    err = capsys.readouterr().err
    assert "Wheel Speed Rear Left (rad/sec) /  Wheel Speed Rear Right (rad/sec)" in err
    assert "validate's wheel-sides check" in err and "look exchanged (left for right)" in err
    assert "Front" not in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []
    df[[c.OMEGA_RL, c.OMEGA_RR]] = df[[c.OMEGA_RR, c.OMEGA_RL]].to_numpy()  # back in place
    front, rear = [c.OMEGA_FL, c.OMEGA_FR], [c.OMEGA_RL, c.OMEGA_RR]
    df[front + rear] = df[rear + front].to_numpy()
    axles = write_iovnbd(df, tmp_path / "V-Axles.csv")
    assert main(predict_args(bundle, axles, out, *car)) == 2
    err = capsys.readouterr().err
    assert "Wheel Speed Front Left (rad/sec) /  Wheel Speed Front Right (rad/sec) / " in err
    assert "validate's wheel-axles check" in err and "front and rear columns look exchanged" in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []
    same = write_iovnbd(weaving_target(), tmp_path / "V-Same.csv")  # every wheel alike
    assert main(predict_args(bundle, same, tmp_path / "same.csv", *car)) == 0
    err = capsys.readouterr().err
    assert err.count("left and right wheels not told against the GNSS course") == 1
    assert "the rear wheels never differed" in err
    assert err.count("front and rear wheels not told against the GNSS course") == 1
    assert "the front and rear wheels never differed" in err


def test_predict_s_dead_reckoning_turns_the_wheels_yaw_by_the_track_given(bundle, tmp_path):
    """Without a gyro, the wheels' yaw is the rear wheels' travel difference over the rear
    track: the track of --track-rear or --vehicle-file reaches the navigation filter (and
    the wheel-sides check), and without one that of data.vehicles.target, as the help says.
    Before, predict dead-reckoned every car on the filter's own 1.46 m."""
    from rwhonet.config import load_params
    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, weaving_drive
    from support.drives import write_iovnbd

    df = weaving_drive(150.0, track_m=1.7).assign(**{c.YAW_RATE_RAD_S: np.nan})  # no gyro
    drive = write_iovnbd(df, tmp_path / "V-Wide.csv")
    car = ["--nominal-radius", str(TARGET_RADIUS_M), "--outage", "40:140"]
    (tmp_path / "car.yaml").write_text(f"nominal_radius_m: {TARGET_RADIUS_M}\ntrack_rear_m: 1.7\n")
    target = load_params().data.vehicles["target"].track_rear_m
    runs = {
        "default": car,
        "target": [*car, "--track-rear", str(target)],
        "given": [*car, "--track-rear", "1.7"],
        "file": ["--vehicle-file", str(tmp_path / "car.yaml"), "--outage", "40:140"],
    }
    east = {}
    for name, extra in runs.items():
        out = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out, *extra)) == 0
        east[name] = pd.read_csv(out)["east_m"].to_numpy()
    np.testing.assert_array_equal(east["given"], east["file"])
    np.testing.assert_array_equal(east["default"], east["target"])
    moved = np.abs(east["given"] - east["default"])
    assert np.nanmax(moved) > 10.0  # metres: another track, another turn


def test_predict_repairs_a_yaw_rate_s_invalid_code_and_says_so(bundle, tmp_path, capsys):
    """One row of 327.67 deg/s (an int16 at full scale) turned the dead-reckoned track by
    33 degrees; it is interpolated across, as the label does, and named even when quiet."""
    import numpy as np
    import pandas as pd

    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, weaving_target
    from support.drives import write_iovnbd

    car = ["--nominal-radius", str(TARGET_RADIUS_M), "--outage", "60:140"]
    df = weaving_target()
    clean = write_iovnbd(df, tmp_path / "V-Turns.csv")
    df.loc[704, c.YAW_RATE_RAD_S] = np.radians(327.67)  # data row 705, inside the outage
    spiked = write_iovnbd(df, tmp_path / "V-Spike.csv")
    assert main(predict_args(bundle, clean, tmp_path / "clean.csv", *car)) == 0
    capsys.readouterr()
    for extra in ([], ["--quiet"]):
        assert main(predict_args(bundle, spiked, tmp_path / "spiked.csv", *car, *extra)) == 0
        err = capsys.readouterr().err
        assert "yaw-rate glitch: 1 sample(s)" in err and "row 705 (t = " in err
        assert "5.719 -> " in err
    a, b = pd.read_csv(tmp_path / "clean.csv"), pd.read_csv(tmp_path / "spiked.csv")
    moved = np.hypot(a["east_m"] - b["east_m"], a["north_m"] - b["north_m"])
    assert moved.notna().sum() >= 80 and moved.max() < 0.05  # metres


@pytest.mark.parametrize("unit, refused", [("deg/s cw", False), ("deg/s", True)])
def test_predict_takes_a_stream_drive_s_yaw_rate_to_its_check_and_filter(
    bundle, tmp_path, capsys, unit, refused
):
    """An MDF4 drive read whole: its yaw rate reaches predict as a 10 Hz file's does (the
    unit check, and the filter: fused, not wheels alone). The gyro is positive clockwise."""
    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, weaving_target

    df = weaving_target()
    df[c.YAW_RATE_RAD_S] = -df[c.YAW_RATE_RAD_S]  # positive clockwise
    drive, signal_map = _mdf4_drive(tmp_path, df, "rad/s", unit)
    out = tmp_path / "p.csv"
    args = ["--format", "mdf4", "--signal-map", str(signal_map)]
    args += ["--nominal-radius", str(TARGET_RADIUS_M), "--outage", "60:120"]
    assert main(predict_args(bundle, drive, out, *args)) == (2 if refused else 0)
    err = capsys.readouterr().err
    if refused:
        assert "YawRate" in err and "positive turning right" in err and not out.exists()
    else:
        assert "yaw rate's unit and sign not told" not in err
        assert "yaw: gyro + wheels" in err  # the outage's summary: the gyro was used


def test_predict_takes_a_dead_reckoning_receiver_s_yaw_rate_from_its_ubx_log(
    bundle, tmp_path, capsys
):
    """A weaving drive's folder: wheels.csv, and the u-blox ADR receiver's gps.ubx with
    NAV-PVT and ESF-INS (its z angular rate, z down). The map names yaw_rate, which no CSV
    has: predict's filter is fused (gyro + wheels) through an outage, and its positions are
    those of the same yaw rate in gyro.csv within 5 cm."""
    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import SIGNAL_MAP, StreamTables, write_stream_csvs
    from support.corpus import TARGET_RADIUS_M, weaving_target
    from support.ubx import esf_ins, ubx_messages, write_ubx

    df = weaving_target()
    wheels = df[[c.T_S, *c.WHEELS]]
    gnss = df[[c.T_S, c.LAT_DEG, c.LON_DEG, c.N_SATS]]
    gyro = df[[c.T_S, c.YAW_RATE_RAD_S]]
    smap = tmp_path / "map.yaml"
    signals = {**SIGNAL_MAP, "yaw_rate": ("YawRate", "rad/s")}
    smap.write_text(
        "\n".join(f"{k}: {{column: {col}, unit: {u}}}" for k, (col, u) in signals.items())
    )
    write_stream_csvs(StreamTables(wheels, gnss, gyro), tmp_path / "csv")
    adr = write_stream_csvs(StreamTables(wheels, gnss.iloc[:0]), tmp_path / "adr")
    adr["gnss"].unlink()
    day = 1_552_262_400.0  # 2019-03-11 UTC
    t = day + df[c.T_S].to_numpy()
    log = [*ubx_messages(gnss, t), *esf_ins(t, df[c.YAW_RATE_RAD_S].to_numpy())]
    write_ubx(tmp_path / "adr" / "gps.ubx", log)
    args = ["--format", "stream_csv", "--signal-map", str(smap), "--outage", "60:120"]
    args += ["--nominal-radius", str(TARGET_RADIUS_M)]
    frames = {}
    for name in ("csv", "adr"):
        out = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, tmp_path / name, out, *args)) == 0
        err = capsys.readouterr().err
        assert "yaw: gyro + wheels" in err, name  # the outage's summary: the gyro was used
        frames[name] = pd.read_csv(out)
    a, b = frames["adr"], frames["csv"]
    assert len(a) == len(b) > 100
    moved = np.hypot(a["east_m"] - b["east_m"], a["north_m"] - b["north_m"])
    assert moved.notna().sum() >= 50 and moved.max() < 0.05  # metres


def test_predict_says_once_that_a_drive_without_gnss_was_not_unit_checked(bundle, tmp_path, capsys):
    from support.drives import write_iovnbd

    drive = write_iovnbd(_rav4_drive(fixes=False), tmp_path / "V-NoFix.csv")
    for quiet in ([], ["--quiet"]):
        assert main(predict_args(bundle, drive, tmp_path / "p.csv", *quiet)) == 0
        err = capsys.readouterr().err
        assert err.count("not checked against GNSS") == 1 and "has no GNSS fix" in err
    assert len(pd.read_csv(tmp_path / "p.csv")) == 120


def test_predict_holds_seconds_for_the_unit_check_no_longer_than_hold_max_s(
    bundle, tmp_path, capsys, monkeypatch
):
    """A stream starting without a fix is written on after HOLD_MAX_S, and still refused
    when its wheel speeds turn out, once fixes come, to be in km/h."""
    from rwhonet.cli import predict
    from rwhonet.data import canonical as c
    from support.drives import write_iovnbd

    monkeypatch.setattr(predict, "HOLD_MAX_S", 30)
    car = ["--nominal-radius", str(RAV4_M)]
    nofix = write_iovnbd(_rav4_drive(fixes=False), tmp_path / "V-NoFix.csv")
    assert main(predict_args(bundle, nofix, tmp_path / "p.csv", *car)) == 0
    err = capsys.readouterr().err
    assert err.count("has not decided after 30 s") == 1 and "written unchecked" in err
    assert len(pd.read_csv(tmp_path / "p.csv")) == 120  # every second, none lost
    late = _rav4_drive(RAV4_M * 3.6)  # km/h, and no fix in the first 40 s
    late.loc[late[c.T_S] < late[c.T_S].iloc[0] + 40.0, [c.LAT_DEG, c.LON_DEG]] = np.nan
    drive = write_iovnbd(late, tmp_path / "V-Late.csv")
    out = tmp_path / "late.csv"
    assert main(predict_args(bundle, drive, out, *car)) == 2
    err = capsys.readouterr().err
    assert "has not decided after 30 s" in err and "look like km/h" in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []


def test_a_clean_drive_s_output_is_the_unchecked_stream_s_byte_for_byte(bundle, drive, tmp_path):
    """The unit check holds seconds back until it decides; what is written stays the same."""
    from io import StringIO

    from rwhonet.cli import predict
    from rwhonet.data.incremental import read_rows
    from rwhonet.serve.model import load_served
    from rwhonet.serve.stream import Outage, SecondStream

    model = load_served(bundle["model_onnx"])
    outages = [Outage(100.0, 220.0)]
    out = tmp_path / "p.csv"
    got = predict.run(model, str(drive), str(out), outages)
    assert got["unit_note"] is None
    text = StringIO()
    sink = predict.CsvSink(text)
    stream = SecondStream(model, outages, file=str(drive))
    with open(drive, "rb") as f:
        _, blocks = read_rows(f, str(drive))
        for first, cols in blocks:
            sink.write(stream.push(first, cols))
        sink.write(stream.finish())
    assert out.read_text() == text.getvalue()


def test_predict_s_default_validate_is_the_project_s():
    import dataclasses

    from rwhonet.cli.predict import default_validate
    from rwhonet.config import load_params

    assert default_validate() == dataclasses.replace(load_params().validate, cuts=[])


def test_predict_repairs_and_reports_a_glitched_sample_of_a_100_hz_wheel_stream(
    bundle, tmp_path, capsys
):
    """A x3 one-sample glitch in a 100 Hz wheel stream: validate cuts its rows (the
    resampler's flags); predict repairs them and says so, with the stream's sample row."""
    import yaml

    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import SIGNAL_MAP, StreamTables
    from support.stream_corpus import RADIUS_M, good_tables, write_good

    signals = {k: {"column": col, "unit": unit} for k, (col, unit) in SIGNAL_MAP.items()}
    smap = tmp_path / "map.yaml"
    smap.write_text(yaml.safe_dump(signals))
    good = good_tables()
    wheels = good.wheels.copy()
    wheels.loc[2000, c.OMEGA_RL] *= 3.0  # t = 1020.00 s
    frames = {}
    for name, tables in (("clean", good), ("glitch", StreamTables(wheels, good.gnss))):
        (tmp_path / name).mkdir()
        drive = write_good("csv", tmp_path / name, tables)
        out = tmp_path / f"{name}.csv"
        extra = ["--format", "stream_csv", "--signal-map", str(smap)]
        extra += ["--nominal-radius", str(RADIUS_M), "--quiet"]
        assert main(predict_args(bundle, drive, out, *extra)) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    (clean, said_clean), (fixed, said) = frames["clean"], frames["glitch"]
    assert "glitch" not in said_clean
    assert "stream glitch: 1 wheel-speed sample(s)" in said
    assert "wheels.csv" in said and "sample row 2001 (t = 1020 s)" in said
    assert "wheel glitch: " in said  # the grid rows repaired, listed
    assert len(fixed) == len(clean) > 30
    for q in ("disp_wpm_m", "pred_error_m", "disp_corrected_m"):
        np.testing.assert_allclose(fixed[q], clean[q], atol=0.01)


def test_predict_reads_a_stream_written_twice_and_out_of_order_as_the_clean_one(
    bundle, tmp_path, capsys
):
    """The good stream drive's wheel samples 500-519 written after 520-529 and 880-899
    written again: predict's seconds are the clean drive's, and stderr says what was
    dropped and put in order (--quiet too), naming the file's rows."""
    from rwhonet.sim.streams import StreamTables
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    order = [*range(500), *range(520, 530), *range(500, 520), *range(530, len(good.wheels))]
    order[900:900] = range(880, 900)
    messy = StreamTables(good.wheels.iloc[order], good.gnss)
    frames = _predicted_streams(bundle, tmp_path, capsys, RADIUS_M, clean=good, messy=messy)
    (clean, said_clean), (messy, said) = frames["clean"], frames["messy"]
    assert "order" not in said_clean and "repeat" not in said_clean
    assert "20 sample(s) repeat an earlier sample" in said and "row(s) 901, 902" in said
    assert "20 sample(s) written after a later one" in said and "row(s) 511, 512" in said
    pd.testing.assert_frame_equal(messy, clean)


def test_predict_says_it_placed_fixes_stamped_on_arrival_at_the_receiver_s_epochs(
    bundle, tmp_path, capsys
):
    """The good stream drive's 10 Hz fixes stamped 20 ± 5 ms late, as a logger stamping
    them on arrival would: predict moves them to the receiver's grid, says so on stderr
    (--quiet too), and its seconds are those of the fixes stamped at their epochs."""
    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import StreamTables
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    late = good.gnss[c.T_S] + 0.02 + np.random.default_rng(0).uniform(-0.005, 0.005, len(good.gnss))
    frames = _predicted_streams(
        bundle,
        tmp_path,
        capsys,
        RADIUS_M,
        epochs=StreamTables(good.wheels, good.gnss.assign(**{c.T_S: good.gnss[c.T_S] + 0.02})),
        arrival=StreamTables(good.wheels, good.gnss.assign(**{c.T_S: late})),
    )
    (at_epochs, said_epochs), (arrived, said) = frames["epochs"], frames["arrival"]
    assert "grid" not in said_epochs
    assert "about a regular 10 Hz grid" in said and "placed at the grid's epochs" in said
    assert len(arrived) == len(at_epochs) > 30
    np.testing.assert_allclose(arrived["disp_gnss_m"], at_epochs["disp_gnss_m"], atol=1e-3)


def test_predict_reads_wheel_speeds_a_logger_split_across_files_as_the_one_file(
    bundle, tmp_path, capsys
):
    """The good stream drive's wheels.csv rotated into three files (the last kept gzipped,
    the rotation's sample written into both of the second pair): predict's seconds are the
    one file's, exactly, and stderr says the sample dropped."""
    import gzip

    from support.stream_corpus import RADIUS_M, good_tables

    frames = {}
    for name in ("one", "split"):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, good_tables())
        if name == "split":
            header, *rows = (drive / "wheels.csv").read_text().splitlines()
            (drive / "wheels_000.csv").write_text("\n".join([header, *rows[:700]]) + "\n")
            (drive / "wheels_001.csv").write_text("\n".join([header, *rows[700:2100]]) + "\n")
            last = "\n".join([header, *rows[2099:]]) + "\n"
            (drive / "wheels_002.csv.gz").write_bytes(gzip.compress(last.encode()))
            (drive / "wheels.csv").unlink()
        out = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out, *fmt, "--nominal-radius", str(RADIUS_M))) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    (one, said_one), (split, said) = frames["one"], frames["split"]
    assert "rotation" not in said_one
    assert (
        "wheels_002.csv.gz [wheels_002.csv.gz]: its first 1 sample(s) at the times of the last "
        in said
    )
    pd.testing.assert_frame_equal(split, one)


def test_predict_reads_a_folder_of_files_logrotate_numbered(bundle, tmp_path, capsys):
    """A Linux logger under logrotate: wheels.csv.1 then wheels.csv, the receiver's log as
    gps.nmea.2.gz, gps.nmea.1 and gps.nmea (oldest first): predict's seconds are those of
    the one wheels.csv beside the one gps.nmea, exactly."""
    import gzip

    from support.nmea import nmea_lines
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    t = good.gnss["t_s"].to_numpy()
    lines = nmea_lines(good.gnss, 1_552_262_400.0 + t, stamps=t)
    frames = {}
    for name in ("one", "rotated"):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, good)
        (drive / "gnss.csv").unlink()
        if name == "one":
            (drive / "gps.nmea").write_text("\r\n".join(lines) + "\r\n")
        else:
            header, *rows = (drive / "wheels.csv").read_text().splitlines()
            (drive / "wheels.csv.1").write_text("\n".join([header, *rows[:1500]]) + "\n")
            (drive / "wheels.csv").write_text("\n".join([header, *rows[1500:]]) + "\n")
            old = "\r\n".join(lines[:300]) + "\r\n"
            (drive / "gps.nmea.2.gz").write_bytes(gzip.compress(old.encode()))
            (drive / "gps.nmea.1").write_text("\r\n".join(lines[300:901]) + "\r\n")
            (drive / "gps.nmea").write_text("\r\n".join(lines[901:]) + "\r\n")
        out = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out, *fmt, "--nominal-radius", str(RADIUS_M))) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    (one, _), (rotated, said) = frames["one"], frames["rotated"]
    assert "38 seconds" in said
    pd.testing.assert_frame_equal(rotated, one)


def _predicted_streams(bundle, tmp_path, capsys, radius_m, **drives):
    """``rwhonet predict --quiet`` on each stream drive (name -> its tables, written as
    stream CSVs): name -> (the output, stderr)."""
    frames = {}
    for name, tables in drives.items():
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, tables)
        out = tmp_path / f"{name}.csv"
        fmt += ["--nominal-radius", str(radius_m), "--quiet"]
        assert main(predict_args(bundle, drive, out, *fmt)) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    return frames


def test_predict_reads_the_receiver_s_nmea_log_beside_the_wheels_csv(bundle, tmp_path, capsys):
    """The good stream drive with its fixes as the receiver's NMEA log (each line after
    the logger's stamp, kept gzipped: gps.nmea.gz) in place of gnss.csv: predict's seconds
    are those of the CSV fixes, within the log's ddmm.mmmmmm rounding. One RMC sentence's
    checksum is broken: the epoch keeps its GGA, and stderr says what was passed over."""
    import gzip

    from support.nmea import nmea_lines
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    frames = {}
    for name in ("csv", "nmea"):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, good)
        if name == "nmea":
            t = good.gnss["t_s"].to_numpy()
            lines = nmea_lines(good.gnss, 1_552_262_400.0 + t, stamps=t)
            lines[302] = lines[302][:-2] + ("00" if lines[302][-2:] != "00" else "01")
            (drive / "gps.nmea.gz").write_bytes(gzip.compress("\r\n".join(lines).encode()))
            (drive / "gnss.csv").unlink()
        out = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out, *fmt, "--nominal-radius", str(RADIUS_M))) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    (csv, _), (nmea, said) = frames["csv"], frames["nmea"]
    assert "38 seconds" in said
    assert "gps.nmea.gz: passed over: 1 sentence(s) with a checksum that does not match " in said
    assert "(first at line 303)" in said
    assert len(nmea) == len(csv) > 30
    for q in ("t_s", "disp_wpm_m", "pred_error_m", "disp_corrected_m"):
        np.testing.assert_allclose(nmea[q], csv[q], atol=0.01)
    np.testing.assert_allclose(nmea["disp_gnss_m"], csv["disp_gnss_m"], atol=0.01)


@pytest.mark.parametrize(
    ("log", "receiver"),
    [
        ("candump", "nmea"),
        ("canedge", "nmea"),
        ("candump", "ubx"),
        ("candump", "u-blox 6"),
        ("candump", "gpx"),
        ("candump", "novatel"),
    ],
)
def test_predict_reads_a_candump_log_beside_the_receiver_s_log(
    bundle, tmp_path, capsys, log, receiver
):
    """A Linux logger's folder: the wheel speeds as raw CAN frames in can0.log on the
    computer's Unix clock (or a CANedge's MDF4 bus log split into three files, each on its
    start time: 00000001.MF4 ...), the fixes as the receiver's unstamped NMEA log
    (gps.nmea.gz) or its u-blox binary log (gps.ubx.gz: NAV-PVT among other messages, or
    a u-blox 6's NAV-POSLLH, NAV-SOL, NAV-VELNED and NAV-TIMEUTC), or a phone logger's GPX
    track (track.gpx.gz, one point written twice), or a NovAtel receiver's ASCII logs
    (drive.gps.gz: TIMEA and BESTPOSA, one CRC broken), a
    map file with the DBC, the signals and a ``t``: predict's seconds are those of the
    stream CSVs within the DBC's 0.01 km/h and the log's rounding (ddmm.mmmmmm; NAV-PVT's
    1e-7 degrees, 1.1 cm a coordinate, so 0.02 m a second's GNSS displacement)."""
    import gzip

    from rwhonet.sim.streams import StreamTables
    from support.canlog import DBC, stream_frames, write_candump, write_mdf_bus_log
    from support.nmea import nmea_lines
    from support.stream_corpus import RADIUS_M, good_tables

    day = 1_552_262_400.0  # 2019-03-11 UTC
    good = good_tables()
    (tmp_path / "csv").mkdir()
    drive, fmt = _stream_drive(tmp_path / "csv", good)
    car = ["--nominal-radius", str(RADIUS_M)]
    assert main(predict_args(bundle, drive, tmp_path / "csv.csv", *fmt, *car)) == 0
    folder = tmp_path / "bus"
    folder.mkdir()
    wheels_only = StreamTables(good.wheels, good.gnss.iloc[:0])
    stamps, ids, data = stream_frames(wheels_only, RADIUS_M, day)
    if log == "candump":
        write_candump(stamps, ids, data, folder / "can0.log")
    else:
        for k, i in enumerate(np.array_split(np.arange(stamps.size), 3)):
            write_mdf_bus_log(stamps[i], ids[i], data[i], folder / f"0000000{k + 1}.MF4")
    t = good.gnss["t_s"].to_numpy()
    if receiver == "nmea":
        lines = nmea_lines(good.gnss, day + t)
        (folder / "gps.nmea.gz").write_bytes(gzip.compress("\r\n".join(lines).encode()))
    elif receiver == "gpx":
        from support.gpx import track

        text = track(good.gnss, day + t).to_xml("1.0").splitlines(keepends=True)
        at = [i for i, line in enumerate(text) if "<trkpt" in line][300]
        end = next(i for i in range(at, len(text)) if "</trkpt>" in text[i])
        text[at:at] = text[at : end + 1]  # the 301st point written twice
        (folder / "track.gpx.gz").write_bytes(gzip.compress("".join(text).encode()))
    elif receiver == "novatel":
        from support.novatel import novatel_lines

        lines = novatel_lines(good.gnss, day + t)
        lines[601] = lines[601][:-1] + ("0" if lines[601][-1] != "0" else "1")  # a TIMEA
        (folder / "drive.gps.gz").write_bytes(gzip.compress("\r\n".join(lines).encode()))
    else:
        from support.ubx import u6_messages, ubx_messages

        messages = (ubx_messages if receiver == "ubx" else u6_messages)(good.gnss, day + t)
        if receiver == "ubx":  # the epoch's last message, NAV-PVT: its checksum broken
            messages[300] = messages[300][:-1] + bytes([messages[300][-1] ^ 1])
        (folder / "gps.ubx.gz").write_bytes(gzip.compress(b"".join(messages)))
    (tmp_path / "v.dbc").write_text(DBC)
    wheels = [
        f"  omega_{w}: {{column: WhlSpd_{w.upper()}, unit: km/h}}" for w in "fl fr rl rr".split()
    ]
    smap = tmp_path / "bus.yaml"
    smap.write_text("dbc: v.dbc\nsignals:\n  t: {column: t, unit: s}\n" + "\n".join(wheels) + "\n")
    fmt = ["--format", "stream_csv", "--signal-map", str(smap)]
    capsys.readouterr()
    assert main(predict_args(bundle, folder, tmp_path / "bus.csv", *fmt, *car)) == 0
    said = capsys.readouterr().err
    assert "38 seconds" in said
    csv, bus = pd.read_csv(tmp_path / "csv.csv"), pd.read_csv(tmp_path / "bus.csv")
    assert len(bus) == len(csv) > 30
    np.testing.assert_allclose(bus["t_s"] - day, csv["t_s"], atol=1e-6)
    for q in ("disp_wpm_m", "pred_error_m", "disp_corrected_m"):
        np.testing.assert_allclose(bus[q], csv[q], atol=0.01)
    gnss_m = 0.01 if receiver == "nmea" else 0.02  # NAV-PVT's, NAV-POSLLH's 1e-7 deg
    np.testing.assert_allclose(bus["disp_gnss_m"], csv["disp_gnss_m"], atol=gnss_m)
    if receiver == "ubx":
        assert "gps.ubx.gz: passed over: 1 NAV-PVT message(s) with a checksum" in said
    if receiver == "gpx":
        assert "track.gpx.gz: passed over: 1 track point(s) at an earlier one's time" in said
    if receiver == "novatel":
        assert (
            "drive.gps.gz: passed over: 1 log(s) whose CRC does not match (first at line 602)"
            in said
        )
    # the map's database given to the log's one bus (can0; a CANedge's bus channel 1)
    one_bus = "{can0: v.dbc}" if log == "candump" else "{1: [v.dbc]}"
    smap.write_text(smap.read_text().replace("dbc: v.dbc", f"dbc: {one_bus}"))
    assert main(predict_args(bundle, folder, tmp_path / "bus1.csv", *fmt, *car)) == 0
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "bus1.csv"), bus)


def _stream_drive(tmp_path, tables):
    """A folder of stream CSVs and its signal map file, for --format stream_csv."""
    import yaml

    from rwhonet.sim.streams import SIGNAL_MAP
    from support.stream_corpus import write_good

    smap = tmp_path / "map.yaml"
    smap.write_text(
        yaml.safe_dump({k: {"column": c, "unit": u} for k, (c, u) in SIGNAL_MAP.items()})
    )
    return write_good("csv", tmp_path, tables), [
        "--format",
        "stream_csv",
        "--signal-map",
        str(smap),
    ]


def test_predict_and_recalibrate_refuse_wheels_logged_too_slowly_for_the_grid(
    bundle, tmp_path, capsys
):
    """Wheel speeds at 4 Hz: every grid row would span a longer step than the resampler
    allows. Both commands refuse with the stream, its channels and its steps (not a
    traceback, not an empty output); predict writes nothing."""
    from rwhonet.sim.streams import StreamTables
    from support.stream_corpus import RADIUS_M, good_tables

    good = good_tables()
    slow = StreamTables(good.wheels.iloc[::25].reset_index(drop=True), good.gnss)
    drive, fmt = _stream_drive(tmp_path, slow)
    fmt += ["--nominal-radius", str(RADIUS_M)]
    out = tmp_path / "p.csv"
    assert main(predict_args(bundle, drive, out, *fmt)) == 2
    err = capsys.readouterr().err
    assert "wheels.csv" in err and "WheelSpeed_RL" in err and "steps of 0.25 s" in err
    assert "max_wheel_gap_s" in err and "Traceback" not in err
    assert not out.exists() and list(tmp_path.glob(".*partial")) == []
    base = str(bundle["model_onnx"].parent)
    assert main(["recalibrate", "--base", base, "--drive", str(drive), *fmt]) == 2
    err = capsys.readouterr().err
    assert "wheels.csv" in err and "steps of 0.25 s" in err


def test_predict_takes_a_fix_stated_worse_than_the_bound_as_no_fix(
    bundle, tmp_path, capsys, monkeypatch
):
    """Stream CSVs whose receiver states 1 m, and 9 m over 5 s: without
    validate.gnss.max_h_acc_m, predict writes what it writes with 1 m throughout; with a
    bound of 5 m, those rows are rows without a fix (the output differs) and stderr says
    how many and why."""
    import pandas as pd
    import yaml

    from rwhonet import paths
    from rwhonet.sim.streams import SIGNAL_MAP
    from support.drives import write_params_yaml
    from support.stream_corpus import RADIUS_M

    out = {}
    for name, poor_m in (("good", 1.0), ("poor", 9.0)):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, None)
        gnss = drive / "gnss.csv"
        df = pd.read_csv(gnss)
        t = df.iloc[:, 0].to_numpy(np.float64)
        df["HAcc"] = np.where((t > t[0] + 20.0) & (t < t[0] + 25.0), poor_m, 1.0)
        df.to_csv(gnss, index=False)
        smap = {k: {"column": col, "unit": u} for k, (col, u) in SIGNAL_MAP.items()}
        smap["h_acc"] = {"column": "HAcc", "unit": "m"}
        (tmp_path / name / "map.yaml").write_text(yaml.safe_dump(smap))
        fmt += ["--nominal-radius", str(RADIUS_M)]
        for bound in (None, 5.0):
            params = write_params_yaml(
                tmp_path / f"params-{name}-{bound}.yaml", **{"validate.gnss.max_h_acc_m": bound}
            )
            monkeypatch.setattr(paths, "PARAMS", params)
            out[name, bound] = tmp_path / f"{name}-{bound}.csv"
            assert main(predict_args(bundle, drive, out[name, bound], *fmt)) == 0
            err = capsys.readouterr().err
            said = "whose receiver states a horizontal accuracy worse than validate.gnss"
            assert (said in err) == (name == "poor" and bound == 5.0), err
    text = {k: v.read_text() for k, v in out.items()}
    assert text["poor", None] == text["good", None] == text["good", 5.0]
    assert text["poor", 5.0] != text["good", 5.0]


def test_predict_takes_a_fix_validate_would_not_use_as_no_fix(bundle, tmp_path, capsys):
    """Fixes at latitude = longitude = 0 (a receiver without a fix) and fixes with fewer than
    validate.gnss.min_sats satellites give predict exactly what empty fix cells give, in a
    10 Hz file and in stream CSVs, and stderr says how many rows it took out."""
    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import StreamTables
    from support.drives import write_iovnbd
    from support.serving import wavy_drive
    from support.stream_corpus import RADIUS_M, good_tables

    df = wavy_drive(200.0)
    no_fix = (df[c.T_S] > df[c.T_S].iloc[0] + 60) & (df[c.T_S] < df[c.T_S].iloc[0] + 75)
    low = (df[c.T_S] > df[c.T_S].iloc[0] + 120) & (df[c.T_S] < df[c.T_S].iloc[0] + 130)
    empty = df.copy()
    empty.loc[no_fix | low, [c.LAT_DEG, c.LON_DEG]] = np.nan
    bad = df.copy()
    bad.loc[no_fix, [c.LAT_DEG, c.LON_DEG]] = 0.0
    bad.loc[low, c.N_SATS] = 3.0
    out = {}
    for name, frame in (("empty", empty), ("bad", bad)):
        drive = write_iovnbd(frame, tmp_path / f"V-{name}.csv")
        out[name] = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out[name], "--outage", "100:160")) == 0
    err = capsys.readouterr().err
    assert out["bad"].read_text() == out["empty"].read_text()
    assert "248 row(s) taken as without a GNSS fix, as validate cuts them: 149 at latitude " in err
    assert "99 with fewer than validate.gnss.min_sats 4 satellites" in err
    # stream CSVs: the fixes at (0, 0) are left out as the deleted ones are
    good = good_tables()
    zeros = good.gnss.copy()
    gap = (zeros[c.T_S] > 1010.0) & (zeros[c.T_S] < 1012.0)
    zeros.loc[gap, [c.LAT_DEG, c.LON_DEG]] = 0.0
    for name, gnss in (("deleted", good.gnss[~gap]), ("zeros", zeros)):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, StreamTables(good.wheels, gnss))
        out[name] = tmp_path / f"{name}.csv"
        fmt += ["--nominal-radius", str(RADIUS_M)]
        assert main(predict_args(bundle, drive, out[name], *fmt)) == 0
    err = capsys.readouterr().err
    assert out["zeros"].read_text() == out["deleted"].read_text()
    assert "gnss.csv]: 20 fix(es) at latitude = longitude = 0 left out" in err


def test_predict_takes_a_position_its_fix_status_says_is_none_as_no_fix(
    bundle, tmp_path, capsys, monkeypatch
):
    """A column-mapped 10 Hz file whose GGA quality column says 6 (the receiver's own dead
    reckoning) for 15 s: predict writes what the same file with those fix cells empty
    gives, and stderr says how many positions its status took out and by which code."""
    from rwhonet.data import canonical as c
    from support.drives import CUPAC_MAP, column_map_params, write_columnmap, write_params_yaml
    from support.serving import wavy_drive

    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "gga")}
    overrides = {"data.column_maps.logger": column_map_params(cmap)}
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    df = wavy_drive(200.0)
    dead = ((df[c.T_S] > df[c.T_S].iloc[0] + 60) & (df[c.T_S] < df[c.T_S].iloc[0] + 75)).to_numpy()
    out = {}
    for name in ("status", "empty"):
        frame = df.copy()
        if name == "empty":
            frame.loc[dead, [c.LAT_DEG, c.LON_DEG, c.N_SATS]] = np.nan
        path = write_columnmap(frame, tmp_path / f"{name}.csv", CUPAC_MAP)
        table = pd.read_csv(path)
        table["GPS Quality"] = np.where(dead, 6, 1) if name == "status" else 1
        table.to_csv(path, index=False)
        out[name] = tmp_path / f"{name}-out.csv"
        args = ["--format", "logger", "--outage", "100:160"]
        assert main(predict_args(bundle, path, out[name], *args)) == 0
    err = capsys.readouterr().err
    assert out["status"].read_text() == out["empty"].read_text()
    said = f"{int(dead.sum())} of {len(df)} position(s) whose fix status (GPS Quality, gga) says"
    assert said in err and f"{int(dead.sum())} at 6 (estimated (dead reckoning))" in err


def test_predict_drives_a_stream_drive_through_a_gnss_outage(bundle, tmp_path, capsys):
    """No fix for 10 s in gnss.csv (a tunnel): predict keeps the wheel rows, as it keeps a
    10 Hz file's rows with empty fix cells, and dead-reckons through the outage; the
    seconds and their WPM are the whole drive's."""
    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import StreamTables
    from support.stream_corpus import RADIUS_M, T0_S, good_tables

    good = good_tables()
    tunnel = good.gnss[(good.gnss[c.T_S] < T0_S + 15.0) | (good.gnss[c.T_S] > T0_S + 25.0)]
    frames = {}
    for name, gnss in (("whole", good.gnss), ("tunnel", tunnel)):
        (tmp_path / name).mkdir()
        drive, fmt = _stream_drive(tmp_path / name, StreamTables(good.wheels, gnss))
        out = tmp_path / f"{name}.csv"
        fmt += ["--nominal-radius", str(RADIUS_M), "--outage", "15:25"]
        assert main(predict_args(bundle, drive, out, *fmt)) == 0
        frames[name] = (pd.read_csv(out), capsys.readouterr().err)
    (whole, _), (tunnel, said) = frames["whole"], frames["tunnel"]
    assert len(tunnel) == len(whole) == 38
    np.testing.assert_array_equal(tunnel["disp_wpm_m"], whole["disp_wpm_m"])
    inside = tunnel["outage"] == "15:25"
    assert inside.sum() == 10 and tunnel["disp_gnss_m"][inside].isna().all()
    assert np.isfinite(tunnel["east_m"][inside]).all()
    assert "grid rows have the wheel speeds but no fix" in said and "kept without" in said
    assert "no second of the drive falls in it" not in said


@pytest.mark.crash
@pytest.mark.parametrize("signum", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_a_signal_mid_predict_leaves_no_half_written_output(bundle, drive, tmp_path, signum):
    """predict stopped while it streams a drive from a pipe: its hidden .partial output is
    removed (rwhonet.libraries.interruptible, the stage runner's mechanism), nothing is
    put in place, and the status says which signal."""
    import signal
    import time

    out = tmp_path / "live.csv"
    partial = tmp_path / ".live.csv.partial"
    env = dict(os.environ, PYTHONPATH=str(paths.ROOT / "src"))
    proc = subprocess.Popen(
        [sys.executable, "-c", "from rwhonet.cli.main import entry; entry()"]
        + predict_args(bundle, "-", out),
        stdin=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        cwd=paths.ROOT,
    )
    lines = drive.read_bytes().splitlines(keepends=True)
    proc.stdin.write(b"".join(lines[:1500]))  # 150 s: more than the unit check holds back
    proc.stdin.flush()
    deadline = time.monotonic() + 120
    while not (partial.exists() and partial.stat().st_size > 1000):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.05)
    proc.send_signal(getattr(signal, signum))
    # stdin stays open until the process has ended: closing it at once (communicate) gave
    # a loaded machine's predict its end of input before the signal's handler ran, and it
    # finished the drive normally (exit 0) instead of stopping
    proc.wait(timeout=60)
    err = proc.stderr.read()
    proc.stdin.close()
    number = int(getattr(signal, signum))
    assert proc.returncode == 128 + number, err.decode()
    assert f"interrupted by {signum}; stopped, nothing half-written left" in err.decode()
    assert "Traceback" not in err.decode()
    assert not out.exists() and not partial.exists()
    assert list(tmp_path.iterdir()) == []


def test_a_signal_mid_recalibrate_leaves_no_temporary_folder_and_no_running_run(
    bundle, drive, tmp_path, monkeypatch, capsys
):
    """recalibrate stopped while it fits: its temporary folder goes, and the command ends
    by the signal's status (the MLflow run, if one was opened, is ended FAILED)."""
    import glob
    import signal
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))

    def stopped(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)  # as `kill` would, mid-fit
        raise AssertionError("the signal did not interrupt")

    import rwhonet.models.checkpoint

    monkeypatch.setattr(rwhonet.models.checkpoint, "load_whonet", stopped)  # in its temp folder
    base = str(bundle["model_onnx"].parent)

    def unhandled(signum, frame):  # the command did not take it: fail here, not die
        raise AssertionError("SIGTERM reached no handler of the command")

    before = signal.signal(signal.SIGTERM, unhandled)
    try:
        code = main(["recalibrate", "--base", base, "--drive", str(drive), "--recipe", "radius+G"])
    finally:
        signal.signal(signal.SIGTERM, before)
    assert code == 128 + signal.SIGTERM, capsys.readouterr().err
    assert "interrupted by SIGTERM" in capsys.readouterr().err
    assert glob.glob(str(tmp_path / "rwhonet-recalibrate-*")) == []


def test_predict_makes_a_missing_folder_and_refuses_a_folder_as_output(bundle, tmp_path, capsys):
    """A folder given as --output was a traceback after the whole drive (its .partial
    left beside it); a missing folder was a traceback before the first row. Now the
    folder is made, as export makes its own, and a folder is refused before any work."""
    drive = write_drive(tmp_path / "V-A.csv", duration_s=30)
    nested = tmp_path / "out" / "day1" / "p.csv"
    assert main(predict_args(bundle, drive, nested)) == 0
    assert nested.is_file() and len(nested.read_text().splitlines()) == 31
    capsys.readouterr()
    folder = tmp_path / "out"
    assert main(predict_args(bundle, drive, folder)) == 2
    err = capsys.readouterr().err
    assert f"--output: expected a CSV or .parquet file to write; found {folder}: a folder" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.rglob("*partial*")) == []
    blocked = tmp_path / "V-A.csv" / "p.csv"  # its folder would be a file
    assert main(predict_args(bundle, drive, blocked)) == 2
    assert "its folder cannot be made" in capsys.readouterr().err


def test_predict_refuses_a_time_in_milliseconds_that_made_no_second(bundle, tmp_path, capsys):
    """Every step 100 "s": each row was a gap, and predict said "1501 rows -> 0 seconds",
    exit 0, an empty output. Now it names the time column and its step, and writes nothing;
    a drive shorter than a second still passes with 0 seconds."""
    import pandas as pd

    df = pd.read_csv(write_drive(tmp_path / "V-A.csv", duration_s=30))
    time = df.columns[1]
    df[time] = (df[time] - df[time].iloc[0]) * 1000.0
    ms = tmp_path / "V-Ms.csv"
    df.to_csv(ms, index=False)
    out = tmp_path / "p.csv"
    assert main(predict_args(bundle, ms, out)) == 2
    err = capsys.readouterr().err
    assert f"{ms}, column '{time}'" in err and "a median time step of 100 s" in err
    assert "unit: ms" in err and not out.exists() and not list(tmp_path.glob(".*partial"))
    short = tmp_path / "V-Short.csv"
    pd.read_csv(tmp_path / "V-A.csv").head(6).to_csv(short, index=False)
    assert main(predict_args(bundle, short, out)) == 0
    assert "6 rows -> 0 seconds" in capsys.readouterr().err


def test_predict_takes_a_jumped_or_frozen_fix_as_no_fix_as_validate_cuts_it(
    bundle, tmp_path, capsys
):
    """A fix 500 m off for one row, and a receiver that held its fix for 5 s while the car
    drove on, give predict what empty fix cells in the rows validate's rules take out give:
    the outage's GNSS reference and the filter's updates never see them."""
    from rwhonet.data import canonical as c
    from support.drives import write_iovnbd
    from support.serving import wavy_drive

    df = wavy_drive(200.0)
    bad = df.copy()
    bad.loc[300, c.LAT_DEG] += 500.0 / 111_000.0
    bad.loc[600:649, [c.LAT_DEG, c.LON_DEG]] = df.loc[600, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    empty = df.copy()
    empty.loc[[300, 301, *range(619, 651)], [c.LAT_DEG, c.LON_DEG]] = np.nan
    empty.loc[600:618, [c.LAT_DEG, c.LON_DEG]] = df.loc[600, [c.LAT_DEG, c.LON_DEG]].to_numpy()
    out = {}
    for name, frame in (("empty", empty), ("bad", bad)):
        drive = write_iovnbd(frame, tmp_path / f"V-{name}.csv")
        out[name] = tmp_path / f"{name}.csv"
        assert main(predict_args(bundle, drive, out[name], "--outage", "30:150")) == 0
    err = capsys.readouterr().err
    assert out["bad"].read_text() == out["empty"].read_text()
    assert "34 row(s) taken as without a GNSS fix, as validate cuts them: 3 implying" in err


WHEEL_SENSOR_RULES = ("each wheel turning", "follow the GNSS speed", "change with", ">= 0")


def _wheel_sensor_cases():
    from support.corpus import CASES, Accept, Refuse

    refused = [
        x
        for x in CASES
        if isinstance(x.expect, Refuse)
        and x.expect.stage == "validate"
        and any(rule in x.expect.expected for rule in WHEEL_SENSOR_RULES)
        and not x.overrides
    ]
    signed = [x for x in CASES if x.name in ("signed_wheel_speeds", "reversing")]
    assert len(refused) >= 5 and all(isinstance(x.expect, Accept) for x in signed)
    return refused + signed


@pytest.mark.parametrize("case", _wheel_sensor_cases(), ids=lambda x: x.name)
def test_predict_refuses_the_wheel_sensors_validate_refuses(case, bundle, tmp_path, capsys):
    """A negated column, a stuck or silent wheel, stale values: predict wrote them on
    (a negated drive driven backwards, 2 km off at the end of a 60 s outage; a stuck wheel
    made the corrected CRSE ten times the WPM's) where validate refuses them; now it exits
    2 naming what validate names, and writes nothing. A signing logger's reverse passes."""
    from support.corpus import TARGET_RADIUS_M, Refuse, target_path

    raw = tmp_path / "raw"
    case.write(raw)
    out = tmp_path / "out.csv"
    args = predict_args(bundle, target_path(raw), out, "--nominal-radius", str(TARGET_RADIUS_M))
    code = main(args)
    err = capsys.readouterr().err
    if not isinstance(case.expect, Refuse):
        assert code == 0 and out.exists(), err
        return
    assert code == 2 and not out.exists() and list(tmp_path.glob(".*partial")) == []
    assert "validate's wheel-sensor checks" in err, err
    assert f"row {case.expect.row}, column '{case.expect.column}'" in err, err
    assert case.expect.expected in err and case.expect.found in err, err


def test_a_wheel_that_sticks_stops_a_stream_within_minutes_not_at_its_end(bundle, tmp_path, capsys):
    """The wheel-sensor checks ran at the drive's end, so a live stream to stdout went on
    for as long as the drive with a dead wheel, then exited 2. Now a stuck wheel (from
    200 s into a 1,200 s drive) stops it at the next check (every 60 s of rows, on them
    and the 60 s before): exit 2, validate's report, and the seconds written on stdout end
    within about a minute of the wheel's. The sign check still waits for the whole
    drive: a signing logger's reversing is a share of it."""
    from support.drives import write_iovnbd
    from support.serving import wavy_drive

    df = wavy_drive(1200)
    el = df["t_s"] - df["t_s"].iloc[0]
    df.loc[el > 200.0, "omega_rl_rad_s"] = 0.0
    path = write_iovnbd(df, tmp_path / "V-Stuck.csv")
    assert main(predict_args(bundle, path, "-")) == 2
    cap = capsys.readouterr()
    assert "validate's wheel-sensor checks" in cap.err and "each wheel turning" in cap.err
    assert "Wheel Speed Rear Left" in cap.err and "row 2002," in cap.err, cap.err
    seconds = [line for line in cap.out.splitlines()[1:] if line]
    assert 200 <= len(seconds) <= 200 + 75, len(seconds)  # the next check, within 60 s


def test_predict_refuses_a_wheel_s_invalid_code_held_for_seconds(bundle, tmp_path, capsys):
    """655.35 rad/s (a 16-bit signal's full scale at 0.01 rad/s) held 5 s on the rear-left
    wheel: the glitch repair interpolates only towards it, and predict wrote the rest on
    (the WPM's CRSE 405 m over a 60 s outage). Now validate's range check refuses it, naming
    the file's value; a one-row spike of it is still repaired."""
    from support.drives import write_iovnbd
    from support.serving import wavy_drive

    df = wavy_drive(120)
    held = df.copy()
    held.loc[700:749, "omega_rl_rad_s"] = 655.35
    out = tmp_path / "held.csv"
    assert main(predict_args(bundle, write_iovnbd(held, tmp_path / "V-Held.csv"), out)) == 2
    err = capsys.readouterr().err
    assert "validate.max_abs_wheel_speed_rad_s" in err and "found 655.35 rad/s" in err, err
    assert "Wheel Speed Rear Left" in err and not out.exists()
    spike = df.copy()
    spike.loc[700, "omega_rl_rad_s"] = 655.35
    path = write_iovnbd(spike, tmp_path / "V-Spike.csv")
    assert main(predict_args(bundle, path, tmp_path / "spike.csv")) == 0
    assert "wheel glitch: 1 sample(s)" in capsys.readouterr().err


def test_predict_takes_a_vbox_file_on_stdin_as_from_its_file(bundle, tmp_path, monkeypatch):
    """`rwhonet predict --drive - --format vbox` with a VBOX file on a pipe: told by its
    first line, read as the CSV it stands for; the same seconds as from the file."""
    import io

    from support.corpus import good_target
    from support.drives import VBO_MAP, column_map_params, write_params_yaml, write_vbo
    from support.pipes import piped

    overrides = {"data.column_maps.vbox": column_map_params(VBO_MAP)}
    monkeypatch.setattr(paths, "PARAMS", write_params_yaml(tmp_path / "params.yaml", **overrides))
    drive = write_vbo(good_target(), tmp_path / "drive.vbo", crlf=True, flags=128)
    args = ["--format", "vbox", "--outage", "40:100"]
    assert main(predict_args(bundle, drive, tmp_path / "file.csv", *args)) == 0
    with piped(drive.read_bytes(), 4093) as pipe:
        monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(pipe))
        assert main(predict_args(bundle, "-", tmp_path / "pipe.csv", *args)) == 0
    from_file, from_pipe = pd.read_csv(tmp_path / "file.csv"), pd.read_csv(tmp_path / "pipe.csv")
    assert len(from_file) > 100 and from_file["outage"].notna().sum() == 60
    pd.testing.assert_frame_equal(from_pipe, from_file)


def test_predict_refuses_fixes_on_another_clock_and_takes_them_moved(
    bundle, tmp_path, monkeypatch, capsys
):
    """A stream drive whose GNSS is stamped in GPS time, its wheels in UTC (18 s apart):
    predict refuses it naming the offset and the setting, and writes nothing; with
    data.gnss_lag: auto it predicts the seconds of the drive logged on one clock."""
    from rwhonet.data import canonical as c
    from rwhonet.sim.streams import StreamSpec, stream_tables
    from support.drives import write_params_yaml
    from support.multirate import START_S, simulated_drive

    state, vehicle, sim, ss, _ = simulated_drive(300.0, seed=6)
    tables = stream_tables(state, vehicle, sim, ss, StreamSpec(100.0, 5.0), START_S)
    car = ["--nominal-radius", str(vehicle.nominal_radius_m), "--quiet"]
    (tmp_path / "one").mkdir()
    drive, fmt = _stream_drive(tmp_path / "one", tables)
    assert main(predict_args(bundle, drive, tmp_path / "one.csv", *fmt, *car)) == 0
    capsys.readouterr()
    tables.gnss[c.T_S] += 18.0
    (tmp_path / "two").mkdir()
    drive, fmt = _stream_drive(tmp_path / "two", tables)
    out = tmp_path / "two.csv"
    assert main(predict_args(bundle, drive, out, *fmt, *car)) == 2
    err = capsys.readouterr().err
    assert "stamped by two clocks (GPS time runs 18 s ahead of UTC since 2017?)" in err
    assert "set data.gnss_lag: 18.0" in err and not out.exists()
    params = write_params_yaml(tmp_path / "params.yaml", **{"data.gnss_lag": "auto"})
    monkeypatch.setattr(paths, "PARAMS", params)
    assert main(predict_args(bundle, drive, out, *fmt, *car)) == 0
    one, two = pd.read_csv(tmp_path / "one.csv"), pd.read_csv(out)
    assert len(two) == len(one) > 250
    np.testing.assert_allclose(two["disp_gnss_m"], one["disp_gnss_m"], atol=0.05)


def test_predict_reads_a_candump_log_kept_compressed_through_the_map_file_s_dbc(
    bundle, tmp_path, capsys
):
    """The same frames as candump writes them (``bus.log.gz``, a frame damaged on the way)
    and as an MDF4 bus log: the same seconds and distances; the damaged line said on
    stderr."""
    import gzip

    from support.canlog import DBC, SIGNALS, can_frames, write_bus_log, write_can_log

    df = _rav4_drive()
    mf4 = write_can_log(df, tmp_path / "log" / "drive.mf4", RAV4_M)
    log = write_bus_log(*can_frames(df, RAV4_M, 1_700_000_000.0), tmp_path / "bus.log")
    lines = log.read_text().splitlines()
    lines[5] = lines[5].replace("#", "#Z", 1)  # a byte lost on the way: no hex
    packed = tmp_path / "bus.log.gz"
    packed.write_bytes(gzip.compress(("\n".join(lines) + "\n").encode()))
    maps = tmp_path / "maps"
    maps.mkdir()
    (maps / "v.dbc").write_text(DBC)
    signals = [f"  {k}: {{column: {v['column']}, unit: {v['unit']}}}" for k, v in SIGNALS.items()]
    (maps / "bus.yaml").write_text("dbc: v.dbc\nsignals:\n" + "\n".join(signals) + "\n")
    fmt = ["--format", "mdf4", "--signal-map", str(maps / "bus.yaml")]
    car = ["--nominal-radius", str(RAV4_M)]
    assert main(predict_args(bundle, packed, tmp_path / "log.csv", *fmt, *car)) == 0
    err = capsys.readouterr().err
    assert "bus.log.gz: passed over: 1 lines damaged (first at line 6)" in err
    assert main(predict_args(bundle, mf4, tmp_path / "mf4.csv", *fmt, *car)) == 0
    got, want = pd.read_csv(tmp_path / "log.csv"), pd.read_csv(tmp_path / "mf4.csv")
    assert len(got) == len(want) > 100
    np.testing.assert_allclose(got["disp_corrected_m"], want["disp_corrected_m"], atol=0.02)


def test_predict_reads_a_log_of_raw_can_frames_through_the_map_file_s_dbc(bundle, tmp_path, capsys):
    """An MDF4 of raw CAN frames and a map file naming its DBC relative to the map: the
    same seconds and distances as the drive's decoded signals, within the DBC's 0.01 km/h;
    without the DBC the report says to give it."""
    from support.canlog import SIGNALS, write_can_log

    df = _rav4_drive()
    raw = write_can_log(df, tmp_path / "log" / "drive.mf4", RAV4_M)
    maps = tmp_path / "maps"
    maps.mkdir()
    lines = [f"  {k}: {{column: {v['column']}, unit: {v['unit']}}}" for k, v in SIGNALS.items()]
    with_dbc = maps / "canedge.yaml"
    with_dbc.write_text("dbc: ../log/drive.dbc\nsignals:\n" + "\n".join(lines) + "\n")
    car = ["--nominal-radius", str(RAV4_M)]
    fmt = ["--format", "mdf4", "--signal-map", str(with_dbc), *car]
    assert main(predict_args(bundle, raw, tmp_path / "raw.csv", *fmt)) == 0, capsys.readouterr()
    from rwhonet.data import canonical as c

    kmh = df.assign(**{w: df[w] * RAV4_M * 3.6 for w in c.WHEELS})
    decoded, signal_map = _mdf4_drive(tmp_path, kmh, "km/h")
    ref = ["--format", "mdf4", "--signal-map", str(signal_map), *car]
    assert main(predict_args(bundle, decoded, tmp_path / "dec.csv", *ref)) == 0
    got, want = pd.read_csv(tmp_path / "raw.csv"), pd.read_csv(tmp_path / "dec.csv")
    assert len(got) == len(want) > 100
    np.testing.assert_allclose(got["disp_corrected_m"], want["disp_corrected_m"], atol=0.01)
    without = maps / "bare.yaml"
    without.write_text("signals:\n" + "\n".join(lines) + "\n")
    fmt = ["--format", "mdf4", "--signal-map", str(without), *car]
    capsys.readouterr()
    assert main(predict_args(bundle, raw, tmp_path / "bare.csv", *fmt)) == 2
    assert f"raw CAN frames: give dbc in {without}" in capsys.readouterr().err


def test_recalibrate_s_reader_labels_a_segment_ended_by_a_restart_on_the_drive_s_slots(tmp_path):
    """As validate writes the segments (tests/stages/test_validate.py): the rows before a
    logger's restart, 80 and 25 ms late, keep the whole drive's slots, and every label of
    the drive stays near zero (its last second before the restart was 1.7 m off)."""
    from rwhonet.cli.drive import load_drive
    from support.corpus import late_rows_before_a_restart
    from support.drives import target_drive_args, write_iovnbd

    path = write_iovnbd(late_rows_before_a_restart(), tmp_path / "V-T.csv")
    data = load_drive(path, **target_drive_args())
    label = data.samples.frame["label_m"].to_numpy()
    assert label.size >= 140 and np.abs(label).max() < 0.2


def test_recalibrate_s_reader_cuts_seconds_on_rows_leaning_into_lost_samples(tmp_path):
    """As validate cuts them (tests/stages/test_validate.py): the four seconds that would
    start or end on a row beside a lost sample stamped 60 ms toward it are cut as
    ``drop_edge``; labelled, each was a row's travel off (1.3-1.7 m)."""
    from rwhonet.cli.drive import load_drive
    from support.corpus import rows_leaning_into_lost_samples
    from support.drives import target_drive_args, write_iovnbd

    path = write_iovnbd(rows_leaning_into_lost_samples(), tmp_path / "V-T.csv")
    data = load_drive(path, **target_drive_args())
    label = data.samples.frame["label_m"].to_numpy()
    assert label.size == 193 and np.abs(label).max() < 0.2
    assert data.assessment.cut_seconds_by_rule["drop_edge"] == 4


def test_predict_reads_a_ros_bag_as_the_same_drive_in_an_mdf4_file(bundle, tmp_path, capsys):
    """``--format mdf4 --signal-map`` with a ROS 1 bag (wheel speeds in a drive-by-wire
    kit's report, NavSatFix fixes, an IMU's yaw rate; rwhonet.data.rosbag): the seconds the
    MDF4 file of the same drive gives, on the bag's ROS time; the same drive as a ROS 2
    bag's folder (mcap) writes the same file."""
    from rwhonet.data import canonical as c
    from support.corpus import TARGET_RADIUS_M, weaving_target
    from support.rosbag import FIX_TOPIC, IMU_TOPIC, WHEEL_TOPIC, write_bag

    df = weaving_target()
    t = df[c.T_S].to_numpy()
    for w in c.WHEELS:  # as the report's float32 fields hold them
        df[w] = df[w].to_numpy().astype(np.float32).astype(np.float64)
    drive, mdf_map = _mdf4_drive(tmp_path, df, "rad/s", "deg/s")
    unix = 1_500_000_000.0 + t - t[0]
    streams = (
        (unix, df[list(c.WHEELS)].to_numpy()),
        (unix, df[c.LAT_DEG].to_numpy(), df[c.LON_DEG].to_numpy()),
        (unix, df[c.YAW_RATE_RAD_S].to_numpy()),
    )
    bag = write_bag(tmp_path / "drive.bag", *streams)
    bag2 = write_bag(tmp_path / "ros2_drive", *streams, ros2="mcap")  # a ROS 2 bag's folder
    names = ("front_left", "front_right", "rear_left", "rear_right")
    bag_map = tmp_path / "bag.yaml"
    bag_map.write_text(
        "".join(
            f"omega_{w}: {{column: {WHEEL_TOPIC}.{n}, unit: rad/s}}\n"
            for w, n in zip(("fl", "fr", "rl", "rr"), names, strict=True)
        )
        + f"lat: {{column: {FIX_TOPIC}.latitude, unit: deg}}\n"
        + f"lon: {{column: {FIX_TOPIC}.longitude, unit: deg}}\n"
        + f"yaw_rate: {{column: {IMU_TOPIC}.angular_velocity.z, unit: rad/s}}\n"
    )
    car = ["--nominal-radius", str(TARGET_RADIUS_M)]
    outs = {}
    for name, path, smap in (
        ("mdf", drive, mdf_map),
        ("bag", bag, bag_map),
        ("bag2", bag2, bag_map),
    ):
        out = tmp_path / f"{name}.csv"
        args = predict_args(bundle, path, out, "--format", "mdf4", "--signal-map", str(smap))
        assert main([*args, *car]) == 0, capsys.readouterr().err
        outs[name] = pd.read_csv(out, comment="#")
        capsys.readouterr()
    a, b = outs["mdf"], outs["bag"]
    pd.testing.assert_frame_equal(outs["bag2"], b)
    assert len(a) == len(b) > 100
    time = a.columns[0]
    np.testing.assert_allclose(b[time] - 1_500_000_000.0, a[time], rtol=0, atol=1e-3)
    for k in a.columns[1:]:
        if pd.api.types.is_numeric_dtype(a[k]):
            np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-4, err_msg=k)


def test_recalibrate_s_reader_takes_a_drive_of_a_file_of_many_by_its_id(tmp_path):
    """``recalibrate --drive-id``: load_drive reads the drive of a file of many (its map's
    ``drive`` key) as the drive's own file gives it, its segments named by its id; without
    an id a file of several drives is refused naming them."""
    from rwhonet.cli.drive import load_drive
    from rwhonet.config import load_params
    from rwhonet.errors import InputError
    from support.drives import (
        CUPAC_MAP,
        TARGET_RADIUS_M,
        column_map_params,
        straight_drive,
        target_drive_args,
        write_columnmap,
    )

    cmap = column_map_params(CUPAC_MAP)
    params = load_params(
        overrides={
            "data.column_maps.logger": cmap,
            "data.column_maps.trips": cmap | {"drive": {"column": "trip_id", "unit": "text"}},
        }
    )
    args = target_drive_args() | {"params": params}
    frames, own = [], {}
    for k in (1, 2):
        drive = straight_drive(60.0, radius_m=TARGET_RADIUS_M, azimuth_deg=40.0 * k)
        single = write_columnmap(drive, tmp_path / f"T-{k}.csv")
        own[k] = load_drive(single, **(args | {"fmt": "logger"}))
        frames.append(pd.read_csv(single).assign(trip_id=f"T-{k}"))
    fleet = tmp_path / "fleet.csv"
    pd.concat(frames).to_csv(fleet, index=False)
    got = load_drive(fleet, **(args | {"fmt": "trips"}), part="T-2")
    pd.testing.assert_frame_equal(got.samples.frame, own[2].samples.frame)
    assert set(got.samples.frame["drive"]) == {"T-2"}
    assert got.file == f"{fleet} (drive T-2)"
    with pytest.raises(InputError, match="2 drives: T-1, T-2"):
        load_drive(fleet, **(args | {"fmt": "trips"}))
