"""The bad-input corpus (tests/support/corpus.py) through the real data stages.

One parametrised test runs every case as a user's target test drive among good
drives: ingest, validate and, for what they let through, label. A refusal must
name the file, the row (where there is one), the column, what was expected and
what was found, and say what to do; a repair must be listed in the validation
report; an accepted drive must be labelled as it is. The stage scripts are run
end to end on a few cases (slow: fresh interpreters), and docs/reliability.md's
counts are checked against the corpus.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import ConfigError
from rwhonet.data.drivechecks import target_test_min_s
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from rwhonet.stages.label import label
from rwhonet.stages.validate import validate
from support.corpus import (
    CASES,
    DRIVE,
    SCRIPT_CASES,
    Accept,
    Refuse,
    Repair,
    counts,
    good_target,
    write_good_fleet,
    write_target,
)
from support.drives import make_params, write_iovnbd, write_params_yaml
from support.store import copy_store

REPO = paths.ROOT


def _check_refusal(err: InputError, expect: Refuse) -> None:
    problems = err.problems
    named = {Path(p.file).name for p in problems}
    assert named == {expect.file}, f"problems name {named}, not only {expect.file}:\n{err}"
    match = [
        p
        for p in problems
        if p.row == expect.row
        and p.column == expect.column
        and expect.expected in p.expected
        and expect.found in p.found
    ]
    assert match, f"no problem matches {expect}:\n{err}"
    assert all(p.fix for p in problems), f"a problem says nothing to do:\n{err}"
    text = str(err)
    assert expect.file in text and "What to do:" in text


@pytest.mark.parametrize("case", CASES, ids=[x.name for x in CASES])
def test_case(case, tmp_path):
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    case.write(raw)
    expect = case.expect
    failed = tmp_path / "failed"
    if isinstance(expect, Refuse) and expect.stage == "params":
        with pytest.raises(ConfigError) as config_err:
            make_params(raw, **case.overrides)
        assert expect.expected in str(config_err.value) and expect.found in str(config_err.value)
        return
    params = make_params(raw, **case.overrides)

    drives = tmp_path / "drives"
    if isinstance(expect, Refuse) and expect.stage == "ingest":
        with pytest.raises(InputError) as err:
            ingest(params, drives, failed / "ingest.json")
        _check_refusal(err.value, expect)
        kept = json.loads((failed / "ingest.json").read_text())
        assert kept["problems"] == [p.to_dict() for p in err.value.problems]
        assert "full report:" in err.value.summary and not drives.exists()
        return
    ingest(params, drives, failed / "ingest.json")
    assert not (failed / "ingest.json").exists()

    segments, report_path = tmp_path / "segments", tmp_path / "validation.json"
    if isinstance(expect, Refuse):
        assert expect.stage == "validate"
        with pytest.raises(InputError) as err:
            validate(params, drives, segments, report_path, failed / "validation.json")
        _check_refusal(err.value, expect)
        kept = json.loads((failed / "validation.json").read_text())
        assert kept["status"] == "failed"
        assert kept["problems"] == [p.to_dict() for p in err.value.problems]
        refused = [d for d in kept["drives"] if d.get("status") == "refused"]
        assert [d["drive"] for d in refused] == [DRIVE]
        assert not segments.exists() and not report_path.exists()
        return

    (failed / "validation.json").parent.mkdir(parents=True, exist_ok=True)
    (failed / "validation.json").write_text("{}")  # a previous failure...
    report = validate(params, drives, segments, report_path, failed / "validation.json")
    assert not (failed / "validation.json").exists()  # ...is over
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    rules = {cut["rule"] for cut in drive["cuts"]}
    if isinstance(expect, Repair):
        assert drive["cut_seconds_by_rule"][expect.rule] >= expect.seconds, drive["cuts"]
        assert drive["seconds_kept"] >= target_test_min_s(params)
    else:
        assert isinstance(expect, Accept)
        # A signing logger's reversing is read as magnitudes, and the report counts its rows.
        assert (drive["signed_reversing_rows"] > 0) == (case.name == "signed_wheel_speeds")
        # Only the drive's first lone row (its start fix) is cut, and a last second a row
        # lost at the end left short.
        cut = drive["cut_seconds_by_rule"]["partial_second"]
        assert rules <= {"partial_second"} and cut <= expect.partial_seconds
    summary = label(
        params, segments, tmp_path / "samples", tmp_path / "cal.json", tmp_path / "scaler.json"
    )
    assert summary["roles"]["target_test"]["seconds"] == drive["seconds_kept"]
    samples = pd.concat(
        pd.read_parquet(p) for p in (tmp_path / "samples").glob(f"{DRIVE}__s*.parquet")
    )
    # Exact GNSS, wheels at the true radius: the labels stay near zero (a sign error or a
    # stuck rear wheel would make them as large as the distance travelled).
    assert np.abs(samples["label_m"]).max() < 0.2


REFUSED_BY_A_STAGE = [
    x for x in CASES if isinstance(x.expect, Refuse) and x.expect.stage != "params"
]


@pytest.mark.parametrize("case", REFUSED_BY_A_STAGE, ids=[x.name for x in REFUSED_BY_A_STAGE])
def test_case_left_out(case, tmp_path):
    """With ``data.refused_drives: leave_out`` every refused drive is left out by the stage
    that refuses it, with the problem the refusal names, and a good target test drive beside
    it carries the run; where the case's params make every drive of the role unreadable (a
    column map, a size limit), or the roles find no file, the stage still fails."""
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    case.write(raw)
    write_iovnbd(good_target(), raw / "target_test" / "C-G1.csv")
    params = make_params(raw, **case.overrides, **{"data.refused_drives": "leave_out"})
    drives, segments = tmp_path / "drives", tmp_path / "segments"
    try:
        ingest(params, drives)
        report = validate(params, drives, segments, tmp_path / "validation.json")
    except InputError as err:
        assert case.overrides, f"refused though one target test drive is good:\n{err}"
        assert f"{DRIVE}" in str(err)
        return
    expect = case.expect
    [left] = report["left_out"]
    assert (left["drive"], left["stage"]) == (DRIVE, expect.stage)
    assert any(
        p["row"] == expect.row
        and p["column"] == expect.column
        and expect.expected in p["expected"]
        and expect.found in p["found"]
        for p in left["problems"]
    ), left["problems"]
    kept = [d["drive"] for d in report["drives"]]
    assert "C-G1" in kept and DRIVE not in kept
    assert not list(segments.glob(f"{DRIVE}__*"))


def test_corpus_covers_the_issue():
    names = {x.name for x in CASES}
    assert len(CASES) == len(names)
    tally = counts()
    assert tally["tried"] - tally["accepted"] >= 30  # at least 30 bad files
    assert {
        "stuck_wheel_whole_drive",
        "negated_wheel_speeds",
        "target_test_60s",
        "latlon_swapped",
        "reversing",
        "windows_line_endings_and_bom",
        "no_valid_segment",
        "role_glob_matches_no_file",
        "column_map_names_a_missing_column",
        "params_unknown_key",
        "params_wrong_type",
    } <= names


def test_reliability_doc_counts_come_from_the_corpus():
    """docs/reliability.md's "Counts" section holds the corpus's counts (it cannot drift)."""
    doc = (REPO / "docs" / "reliability.md").read_text(encoding="utf-8")
    section = doc.split("## Counts", 1)[1]
    found = {
        key: int(n)
        for key, n in re.findall(r"^- (tried|refused|repaired|accepted)\D*?(\d+)", section, re.M)
    }
    assert found == counts()
    for x in CASES:  # every case has its row in the table
        assert f"`{x.name}`" in doc, x.name


# ------------------------------------------------------------------ the stage scripts


def _project(tmp_path: Path, case, store: Path) -> Path:
    """A project root (params.yaml, dvc.yaml, data/raw) holding the case, as a user's.

    Its MLflow store, where a refusal is logged, is a copy of ``store`` (``migrated_store``
    in tests/conftest.py), not a new file to migrate.
    """
    root = tmp_path / "project"
    copy_store(store, root / "mlruns" / "mlflow.db")
    write_good_fleet(root / "data" / "raw")
    case.write(root / "data" / "raw")
    (root / "dvc.yaml").write_text((REPO / "dvc.yaml").read_text())
    write_params_yaml(
        root / "params.yaml",
        **{"data.source": "files", "data.root": "data/raw", **case.overrides},
    )
    return root


def _stage(root: Path, stage: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(REPO / "pipelines" / f"{stage}.py")],
        cwd=REPO,
        env={**os.environ, "RWHONET_ROOT": str(root)},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


@pytest.mark.slow
@pytest.mark.parametrize("name", SCRIPT_CASES)
def test_stage_scripts(name, tmp_path, migrated_store):
    """`python pipelines/ingest.py` then `validate.py`: exit 2 and the message, no traceback."""
    (case,) = [x for x in CASES if x.name == name]
    root = _project(tmp_path, case, migrated_store)
    expect = case.expect
    for stage in ("ingest", "validate"):
        proc = _stage(root, stage)
        assert "Traceback" not in proc.stderr, proc.stderr
        fails_here = isinstance(expect, Refuse) and expect.stage in (stage, "params")
        if not fails_here:
            assert proc.returncode == 0, proc.stderr
            continue
        assert proc.returncode == 2, proc.stdout + proc.stderr
        assert f"ERROR in stage {stage} ({stage}.py)" in proc.stderr
        assert expect.expected in proc.stderr and expect.found in proc.stderr
        if expect.stage == "params":
            return
        name = {"ingest": "ingest.json", "validate": "validation.json"}[stage]
        assert f"full report: reports/failed/{name}" in proc.stderr
        kept = json.loads((root / "reports" / "failed" / name).read_text())
        assert kept["status"] == "failed" and kept["problems"][0]["fix"]
        return
    assert (root / "reports" / "validation.json").is_file()


@pytest.mark.slow
def test_stage_scripts_leave_out_a_refused_drive(tmp_path, migrated_store):
    """`pipelines/ingest.py` then `validate.py` with ``data.refused_drives: leave_out``: exit 0,
    the drive named with its first problem, and in reports/validation.json."""
    (case,) = [x for x in CASES if x.name == "target_test_60s"]
    root = _project(tmp_path, case, migrated_store)
    write_iovnbd(good_target(), root / "data" / "raw" / "target_test" / "C-G1.csv")
    write_params_yaml(
        root / "params.yaml",
        **{"data.source": "files", "data.root": "data/raw", "data.refused_drives": "leave_out"},
    )
    assert _stage(root, "ingest").returncode == 0
    proc = _stage(root, "validate")
    assert proc.returncode == 0, proc.stderr
    assert f"warning: left out {DRIVE} (target_test, refused by validate): " in proc.stdout
    assert "1 drive(s) left out (refused, data.refused_drives: leave_out)" in proc.stdout
    report = json.loads((root / "reports" / "validation.json").read_text())
    assert [d["drive"] for d in report["left_out"]] == [DRIVE]


@pytest.mark.slow
def test_a_failed_validation_report_stays_until_the_next_success(tmp_path, migrated_store):
    (case,) = [x for x in CASES if x.name == "stuck_wheel_whole_drive"]
    root = _project(tmp_path, case, migrated_store)
    assert _stage(root, "ingest").returncode == 0
    proc = _stage(root, "validate")
    assert proc.returncode == 2 and "stuck or disconnected wheel-speed sensor" in proc.stderr
    failed = root / "reports" / "failed" / "validation.json"
    report = json.loads(failed.read_text())
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    assert drive["status"] == "refused" and drive["problems"][0]["row"] == 1
    assert not (root / "reports" / "validation.json").exists()
    # The user repairs the drive: the next run succeeds and the failure report goes.
    write_target(root / "data" / "raw", good_target())
    assert _stage(root, "ingest").returncode == 0
    proc = _stage(root, "validate")
    assert proc.returncode == 0, proc.stderr
    assert not failed.exists() and (root / "reports" / "validation.json").is_file()


def test_samples_dropped_often_are_named_in_the_refusal(tmp_path):
    """A sample dropped every 10 s cuts its second and splits the drive each time: no
    stretch reaches min_segment_s. The refusal says that is why, not only 'repair its GNSS
    data' (the first rule it names is short_segment, whose cause is the drops)."""
    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = good_target()
    write_target(raw, df.drop(index=list(range(55, len(df), 100))).reset_index(drop=True))
    params = make_params(raw)
    ingest(params, tmp_path / "drives", tmp_path / "failed" / "ingest.json")
    with pytest.raises(InputError) as err:
        validate(
            params,
            tmp_path / "drives",
            tmp_path / "segments",
            tmp_path / "validation.json",
            tmp_path / "failed" / "validation.json",
        )
    (problem,) = err.value.problems
    assert problem.expected.startswith("at least one GNSS-valid stretch")
    # 15 seconds that lost a sample and the drive's first (its start fix alone)
    assert "partial_second 16 s" in problem.found
    assert "16 s were cut as partial_second (a second that lost a sample" in problem.fix
    assert "validate.gnss.min_segment_s, 30 s" in problem.fix
