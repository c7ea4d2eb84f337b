"""The README's "Your own drives" path end to end, as a user with real drive files takes it.

Drive files go under ``data/raw/<role>/``, ``dvc add data/raw``, then
``dvc exp run -S data.source=files -S data.root=data/raw``. The files here are the
ci profile's simulated drives as a user would have them: CSVs only (no
scenario or truth sidecars), no calibration drive (the first source_train
drive calibrates) and no held-out source drives. Code paths that only files
mode takes (the raw folder in the evaluation's provenance, no simulation) run
here and nowhere else in the suite.

Slow (a fresh pipeline); ``make test-fast`` skips it.
"""

import json
import shutil

import pytest
import yaml

from support.project import CI_PIPELINE, dvc, scratch_project

pytestmark = pytest.mark.slow

ROLES = ("source_train", "target_train", "target_test")
# The ci pipeline with one seed and two recipes: what only files mode takes is before
# training (ingest from data/raw, no simulation) and in the evaluation's provenance.
OVERRIDES = {
    **CI_PIPELINE,
    ("seeds",): [1],
    ("adapt", "recipes"): ["paper", "radius+G"],
    ("adapt", "fallback", "recipe"): "radius+G",
}

# Test drives under names real files have: a comma2k19 route's (dongle|start) and a copy's.
# MLflow allows neither in a metric's name, and a "|" ends a Markdown table's cell.
RENAMED = {
    "V-Charlie3.csv": "b0c9d2329ad1606b|2018-08-02--08-34-47.csv",
    "V-Delta2.csv": "V-Delta2 (2).csv",
}


@pytest.fixture(scope="module")
def own(tmp_path_factory, ci_data):
    """A scratch project whose data/raw holds the ci drives, after the README's commands.

    The drives are those ``simulate`` wrote in the session's project of the ci data
    stages (``tests/conftest.py``: ``ci_data``); nothing else of that project is taken.
    """
    repo = scratch_project(tmp_path_factory.mktemp("own") / "repo", OVERRIDES)
    for role in ROLES:
        dest = repo / "data" / "raw" / role
        dest.mkdir(parents=True)
        for csv in sorted((ci_data / "data" / "sim" / role).glob("*.csv")):
            shutil.copy2(csv, dest / RENAMED.get(csv.name, csv.name))
    added = dvc(repo, "add", "data/raw")
    assert added.returncode == 0, added.stdout + added.stderr
    run = dvc(repo, "exp", "run", "-S", "data.source=files", "-S", "data.root=data/raw")
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    return repo


def test_the_pipeline_runs_on_drive_files_and_simulates_nothing(own):
    params = yaml.safe_load((own / "params.yaml").read_text())
    assert (params["data"]["source"], params["data"]["root"]) == ("files", "data/raw")
    assert [p.name for p in (own / "data" / "sim").iterdir()] == ["NOT_SIMULATED.txt"]
    manifest = json.loads((own / "data/interim/drives/manifest.json").read_text())
    files = {d["source_file"] for d in manifest["drives"]}
    assert files and all(f.startswith("data/raw/") for f in files)
    assert {d["role"] for d in manifest["drives"]} == set(ROLES)


def test_every_model_is_evaluated_on_the_user_s_test_drives(own):
    ev = json.loads((own / "metrics/eval.json").read_text())
    assert {"WPM", "G", "S", "R", "R[paper]@10", "R[radius+G]@20"} <= set(ev["overall"])
    assert ev["overall"]["R"]["180s"]["n_windows"] > 0
    tested = {p.stem for p in (own / "data/raw/target_test").glob("*.csv")}
    assert set(ev["per_drive"]) >= tested
    assert "source_test" not in ev["domain_gap"]["G"]  # no held-out source drives were given
    tables = (own / "reports/tables.md").read_text()
    assert "Data: drive files under `data/raw`" in tables


def test_the_mlflow_parent_run_names_the_drive_files(own):
    import mlflow

    mlflow.set_tracking_uri(f"sqlite:///{own}/mlruns/mlflow.db")
    runs = mlflow.search_runs(
        experiment_names=["rwhonet"], filter_string="tags.model = 'pipeline'", output_format="list"
    )
    assert [r.info.run_name for r in runs] == ["pipeline (files, data/raw, 1 seed)"]
    assert runs[0].data.params["data.source"] == "files"


def test_drives_named_as_real_files_are_logged_and_tabled(own):
    """A test drive's id is its file's stem, whatever it holds: every run's per-drive
    metrics carry it as MLflow allows a name, and the tables escape the "|" of a route."""
    import mlflow

    tested = {p.stem for p in (own / "data/raw/target_test").glob("*.csv")}
    assert {"b0c9d2329ad1606b|2018-08-02--08-34-47", "V-Delta2 (2)"} <= tested
    mlflow.set_tracking_uri(f"sqlite:///{own}/mlruns/mlflow.db")
    runs = mlflow.search_runs(
        experiment_names=["rwhonet"], filter_string="tags.model = 'R'", output_format="list"
    )
    per_drive = [
        {k.split("/")[1] for k in run.data.metrics if k.startswith("drive/")} for run in runs
    ]
    per_drive = [names for names in per_drive if names]  # the runs of one recipe at one m
    assert len(per_drive) >= 2
    for names in per_drive:
        assert {"b0c9d2329ad1606b_2018-08-02--08-34-47", "V-Delta2 _2_"} <= names
    tables = (own / "reports/tables.md").read_text()
    assert "| b0c9d2329ad1606b\\|2018-08-02--08-34-47 |" in tables
