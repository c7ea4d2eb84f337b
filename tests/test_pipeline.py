"""Integration: the real DVC stages on the `ci` profile, in a scratch copy of the working tree.

Slow (a couple of minutes): run with `make test`; `make test-fast` skips it.
"""

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from rwhonet import paths
from support.project import CI_PIPELINE, dvc

pytestmark = pytest.mark.slow

OVERRIDES = CI_PIPELINE  # small but complete: every stage, two seeds, two m, two outages


@pytest.fixture(scope="module")
def repo(ci_pipeline):
    """The session's ci-profile project (tests/conftest.py), which the MLflow UI test reuses."""
    return ci_pipeline


def test_data_stages(repo):
    out = dvc(repo, "repro", "label")
    assert out.returncode == 0, out.stdout + out.stderr
    manifest = json.loads((repo / "data/processed/samples/manifest.json").read_text())
    roles = {s["role"] for s in manifest["segments"]}
    assert {"source_train", "target_train", "target_test"} <= roles
    report = json.loads((repo / "reports/validation.json").read_text())
    assert report  # what was cut, per drive
    calib = json.loads((repo / "data/processed/calibration.json").read_text())
    # the source car's nominal radius is 0.294 m; pressure, wear and slip move it by a few %
    assert 0.28 < calib["r_rl_m"] < 0.31 and 0.28 < calib["r_rr_m"] < 0.31
    scaler = json.loads((repo / "data/processed/scaler.json").read_text())
    assert scaler


def test_full_pipeline_then_noop(repo, ci_repro):
    out = ci_repro  # the session's first whole run (whichever module asked for it first)
    ev = json.loads((repo / "metrics/eval.json").read_text())
    recipes = {
        f"R[{r}]@{m}"
        for r in ("paper", "head", "ridge_head", "radius+G", "steps", "shrink")
        for m in (10, 20)
    }
    assert set(ev["overall"]) >= {"WPM", "G", "S", "R", "R@10", "R@20", "WPM-m@10", "R[continuous]"}
    assert "R[continuous_shrink]" in ev["overall"]
    assert set(ev["overall"]) >= recipes
    # the ci profile's target training drives are too short for a 180 s window after 20 s:
    # the rule has no candidate and auto falls back to adapt.fallback (shrink)
    assert ev["selection"]["params"]["recipe"] == "auto" and "no_recommendation" in ev["selection"]
    assert ev["selection"]["chosen_by"] == "fallback"
    assert (ev["recipe"], ev["chosen_m"]) == ("shrink", 20)
    assert ev["overall"]["R"] == ev["overall"]["R[shrink]@20"] == ev["overall"]["R@20"]
    # shrink's evidence: the target car's training drives, measured on each seed's G
    evidence = json.loads((repo / "models/r/seed1/evidence.json").read_text())
    assert evidence["target"]["role"] == "target_train" and evidence["source"]["role"] == "source"
    assert set(ev["overall"]["WPM"]) == {"30s", "180s"} and ev["n_seeds"] == 2
    assert ev["overall"]["G"]["30s"]["crse_ci95"] is not None
    assert set(ev["domain_gap"]["G"]) == {"target_test", "source_test"}
    assert ev["overall"]["WPM"]["180s"]["n_windows"] >= 4 * 2
    # 2D: the navigation filter on the simulated ESC gyro and the rear wheels (issue 17)
    assert ev["position"]["R"]["180s"]["pos_mean"] > 0 and ev["position"]["R"]["180s"]["n_windows"]
    assert set(ev["position_controls"]["rows"]) == {
        "wheels",
        "gyro",
        "fused",
        "fused, GNSS distance",
    }
    assert ev["uncertainty"]["models"]["R"]["n_seconds"] > 0
    tables = (repo / "reports/tables.md").read_text()
    assert "Table 2" in tables and "R-WhONet (m=20)" in tables
    assert "## Where is the car when GNSS returns" in tables
    assert "adapt.fallback: the selection rule had no candidate" in tables
    preds = list((repo / "reports/predictions").glob("*.parquet"))
    assert len(preds) == 4 + 2  # target test and held-out source drives
    assert (repo / "mlruns" / "mlflow.db").is_file()
    # every curve dvc.yaml declares is there to draw
    shown = dvc(repo, "plots", "show", "--json")
    warnings = [ln for ln in (shown.stdout + shown.stderr).splitlines() if "could not find" in ln]
    assert shown.returncode == 0 and not warnings, warnings or shown.stderr  # a missing column
    plots = json.loads(shown.stdout[shown.stdout.index("{") :])
    assert not plots.get("errors"), plots["errors"]
    for title, curves in plots["data"].items():
        assert curves and curves[0]["content"]["data"]["values"], title

    # every training and adaptation run is logged with its real times (tracking.timings)
    runs = execution_runs(repo)
    stage = {r.info.run_id: r.data.tags.get("dvc_stage", "") for r in runs}
    model_runs = [r for r in runs if stage[r.info.run_id].startswith(("train", "adapt@"))]
    # G, S, 6 recipes x 2 m and the 2 continuous recipes, per seed
    assert len(model_runs) == 2 * (2 + 6 * 2 + 2)
    assert {r.data.tags["rwhonet.timing"] for r in model_runs} == {"measured"}
    fit_s = float(re.search(r"G-WhONet seed 1: .* epochs in ([0-9.]+) s", out.stdout).group(1))
    [g1] = [r for r in model_runs if r.info.run_name == "G-WhONet seed 1"]
    parent = next(r for r in runs if r.data.tags.get("model") == "pipeline")
    assert fit_s - 0.06 <= (g1.info.end_time - g1.info.start_time) / 1000 <= fit_s + 1.5
    assert g1.info.end_time <= parent.info.start_time  # trained before evaluate ran

    again = dvc(repo, "repro")
    assert again.returncode == 0 and "Data and pipelines are up to date" in again.stdout
    status = dvc(repo, "status")
    assert status.returncode == 0 and "up to date" in status.stdout, status.stdout


def execution_runs(repo: Path) -> list:
    """The MLflow runs of the newest pipeline execution in ``repo``'s store."""
    import mlflow

    client = mlflow.MlflowClient(f"sqlite:///{repo}/mlruns/mlflow.db")
    exp = client.get_experiment_by_name("rwhonet").experiment_id
    [latest] = client.search_runs(
        [exp], "tags.model = 'pipeline'", max_results=1, order_by=["attributes.start_time DESC"]
    )
    execution = latest.data.tags["rwhonet.execution"]
    return client.search_runs([exp], f"tags.`rwhonet.execution` = '{execution}'", max_results=5000)


def test_the_gyro_figures_benchmark_scores_a_grid_on_the_reproduced_project(repo, ci_repro):
    # benchmarks/gyro_figures.py reads the reproduced project (samples, models, the
    # receiver drift in eval.json) and prints one line per grid point and the per-window pick
    from support.project import BIN, env

    out = subprocess.run(
        [str(BIN / "python"), "benchmarks/gyro_figures.py", "--outage", "30", "--per-window"]
        + ["--grid", "bias_instability=0.0025,0.04"],
        cwd=repo,
        env=env(repo),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    lines = re.findall(
        r"^bias_instability=(\S+) \| train score +(\S+) \| test fused (\S+) % gyro (\S+) %$",
        out.stdout,
        re.M,
    )
    assert [b for b, *_ in lines] == ["0.0025", "0.04"], out.stdout
    for _, score, fused, gyro in lines:
        assert all(np.isfinite(float(v)) for v in (score, fused, gyro))
        assert float(fused) > 0 and float(gyro) > 0
    assert lines[0][1] != lines[1][1]  # the figure changes the score
    assert re.search(r"^per window, .*: fused \d+\.\d+ %$", out.stdout, re.M), out.stdout
    bad = subprocess.run(
        [str(BIN / "python"), "benchmarks/gyro_figures.py", "--grid", "no_such_field=1"],
        cwd=repo,
        env=env(repo),
        capture_output=True,
        text=True,
    )
    assert bad.returncode != 0 and "GyroSpec field" in bad.stderr


def test_touching_any_imported_module_makes_its_stages_stale(repo):
    """dvc status reports every stage whose import closure holds a changed module."""
    from test_architecture import closure, entry_script, stages

    wanted = {
        name: {f.relative_to(paths.ROOT) for f in closure(entry_script(st))}
        for name, st in stages().items()
    }
    touched = set().union(*wanted.values())
    for rel in touched:
        with open(repo / rel, "a") as f:
            f.write("\n# touched by test_pipeline\n")
    try:
        out = dvc(repo, "status", "--json")
        assert out.returncode == 0, out.stderr
        report = json.loads(out.stdout)
        # matrix stages report once per item (adapt@1, adapt@2...)
        assert {key.split("@")[0] for key in report} == set(wanted)
        for key, entries in report.items():
            changed = {Path(dep) for entry in entries for dep in entry.get("changed deps", {})}
            stale = sorted(
                str(f)
                for f in wanted[key.split("@")[0]]
                if not any(d == f or d in f.parents for d in changed)
            )
            assert not stale, f"stage {key}: dvc status does not see changes to {stale}"
    finally:
        subprocess.run(["git", "checkout", "--", *map(str, touched)], cwd=repo, check=True)
    assert dvc(repo, "status", "--json").stdout.strip() in ("{}", "")


def ran(out: subprocess.CompletedProcess) -> list[str]:
    """The stages a ``dvc repro`` ran (not skipped, not restored from the run cache)."""
    return sorted(line.split("'")[1] for line in out.stdout.splitlines() if "Running stage" in line)


def test_adding_a_seed_recalibrates_only_that_seed(repo):
    """train fits every seed's G and S again, to the same bytes; adapt runs for the new seed."""
    before = {p: p.read_bytes() for p in (repo / "models").glob("[gs]/seed*/*") if p.is_file()}
    before_eval = (repo / "metrics/eval.json").read_text()
    params = yaml.safe_load((repo / "params.yaml").read_text())
    params["seeds"] = [1, 2, 3]
    (repo / "params.yaml").write_text(yaml.safe_dump(params, sort_keys=False))
    try:
        out = dvc(repo, "repro")
    finally:
        subprocess.run(["git", "checkout", "--", "params.yaml"], cwd=repo, check=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert ran(out) == ["adapt@3", "evaluate", "train"]
    assert {p: p.read_bytes() for p in before} == before
    assert json.loads((repo / "metrics/eval.json").read_text())["n_seeds"] == 3
    back = dvc(repo, "repro")  # two seeds again: no model is trained again
    assert back.returncode == 0 and ran(back) == ["evaluate"], back.stdout
    assert (repo / "metrics/eval.json").read_text() == before_eval


def test_same_params_and_seed_give_identical_results(repo):
    """Re-running a training stage from scratch reproduces its predictions and the metrics.

    The evaluate run here also meets a model folder without its timing sidecar (a
    cache from elsewhere): that model still logs, untimed, at evaluate's time.
    """
    from rwhonet.tracking.timings import fingerprint

    def outputs() -> dict[str, bytes]:  # every recipe, m, the continuous and selection files
        return {str(p): p.read_bytes() for p in (repo / "models/r/seed1").rglob("*.parquet")}

    before_pred, before_eval = outputs(), (repo / "metrics/eval.json").read_text()
    assert len(before_pred) >= 5 * 2 + 3  # 5 recipes x 2 m, continuous, 2 selection files
    out = dvc(repo, "repro", "--force", "--single-item", "adapt@1")
    assert out.returncode == 0, out.stdout + out.stderr
    assert outputs() == before_pred
    sidecar = repo / "mlruns" / "timings" / f"{fingerprint(repo / 'models/s/seed2')}.json"
    assert sidecar.is_file()
    sidecar.unlink()
    out = dvc(repo, "repro", "--force", "--single-item", "evaluate")
    assert out.returncode == 0, out.stdout + out.stderr
    assert (repo / "metrics/eval.json").read_text() == before_eval
    runs = {r.info.run_name: r for r in execution_runs(repo)}
    s2, s1 = runs["S-WhONet seed 2"], runs["S-WhONet seed 1"]
    parent = next(r for r in runs.values() if r.data.tags.get("model") == "pipeline")
    assert s2.data.tags["rwhonet.timing"] == "not recorded"
    assert s2.info.start_time >= parent.info.start_time  # logged by evaluate, when it logged
    assert s1.data.tags["rwhonet.timing"] == "measured"
    assert s1.info.end_time <= parent.info.start_time


def corrupt(drive: Path, row: int, column: int, value: str) -> str:
    """Write ``value`` into one cell (row: 1-based data row); return the original text."""
    original = drive.read_text()
    lines = original.splitlines()
    cells = lines[row].split(",")
    cells[column] = value
    lines[row] = ",".join(cells)
    drive.write_text("\n".join(lines) + "\n")
    return original


def test_bad_drive_fails_cleanly(repo):
    """A corrupted drive stops ingest with file, row and column; nothing half-written."""
    drive = next((repo / "data/sim/target_test").glob("*.csv"))
    original = corrupt(drive, 5, 12, "oops")
    before = sorted(p.name for p in (repo / "data/interim/drives").iterdir())
    try:
        out = dvc(repo, "repro", "ingest", "--single-item", "--force")
    finally:
        drive.write_text(original)
    assert out.returncode != 0
    msg = out.stdout + out.stderr
    assert drive.name in msg and "row 5" in msg and "Wheel Speed Rear Left" in msg
    drives = repo / "data/interim/drives"
    assert not drives.exists() or sorted(p.name for p in drives.iterdir()) in ([], before)


def test_a_drive_validate_refuses_stops_the_stage_with_file_row_and_column(repo):
    drive = next((repo / "data/sim/target_test").glob("*.csv"))
    original = corrupt(drive, 100, 2, "-95.0")  # latitude of data row 100
    try:
        assert dvc(repo, "repro", "ingest", "--single-item", "--force").returncode == 0
        out = dvc(repo, "repro", "validate", "--single-item", "--force")
    finally:
        drive.write_text(original)
    assert out.returncode != 0
    assert "ERROR in stage validate (validate.py)" in out.stderr
    assert f"{drive.name}, row 100, column ' Lat': expected a latitude in [-90, 90]" in out.stderr
