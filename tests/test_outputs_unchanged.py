"""The evaluation's refactor into ``rwhonet.evaluation`` (issue 14) changed no number.

``tests/evaluation/fixtures/ci_pipeline_before/`` holds ``metrics/eval.json``
and ``reports/tables.md`` of the ci pipeline (``support.project.CI_PIPELINE``)
run on the code before the refactor. The same pipeline on this code must give
the same eval.json, byte for byte, on every key the fixture has (the scenario
outages, added since, are the only new key), and the same tables.md apart from
the scenario-outage section and the two modules the text names, which moved.
Deterministic on one architecture (the fixture's: skipped on others). When a
change is meant to move the numbers, this test has served its purpose: delete it
with the fixture rather than refreshing them.

Slow (the whole ci pipeline, shared with ``tests/test_pipeline.py``).
"""

import json
import platform
import re
from pathlib import Path

import pytest

from support.project import dvc

pytestmark = pytest.mark.slow

BEFORE = Path(__file__).parent / "evaluation" / "fixtures" / "ci_pipeline_before"
NEW_KEYS = {"scenario_outages"}
SECTION = "\n## Scenario outages"
MOVED = {
    "(rwhonet.stages.position)": "(rwhonet.evaluation.position)",
    "(rwhonet.stages.limits)": "(rwhonet.evaluation.limits)",
}


@pytest.fixture(scope="module")
def repo(ci_pipeline):
    before = (BEFORE / "tables.md").read_text(encoding="utf-8")
    machine = re.search(r"computed on (\S+) CPU", before).group(1)
    if platform.machine() != machine:
        pytest.skip(f"the fixture is a {machine} run; bit-for-bit numbers need the same machine")
    out = dvc(ci_pipeline, "repro")
    assert out.returncode == 0, out.stdout + out.stderr
    return ci_pipeline


def test_eval_json_is_unchanged_apart_from_the_scenario_outages(repo):
    text = (BEFORE / "eval.json").read_text(encoding="utf-8")
    before = json.loads(text)
    now = json.loads((repo / "metrics" / "eval.json").read_text(encoding="utf-8"))
    assert set(now) - set(before) == NEW_KEYS and set(before) <= set(now)
    for key, value in before.items():
        assert now[key] == value, key
    # byte for byte: the same keys in the same order, the same numbers as written
    assert json.dumps({key: now[key] for key in before}, indent=2) + "\n" == text
    assert list(now)[-len(NEW_KEYS) :] == sorted(NEW_KEYS)  # the new keys come last


def test_tables_are_unchanged_apart_from_the_scenario_outage_section(repo):
    before = (BEFORE / "tables.md").read_text(encoding="utf-8")
    for old, new in MOVED.items():
        assert old in before
        before = before.replace(old, new)
    now = (repo / "reports" / "tables.md").read_text(encoding="utf-8")
    start = now.index(SECTION)
    end = now.index("\n## ", start + 1)
    assert SECTION not in before and "| roundabout |" in now[start:end]
    assert now[:start] + now[end:] == before
