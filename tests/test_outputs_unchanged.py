"""The evaluation's refactor into ``rwhonet.evaluation`` (issue 14) changed no number.

``tests/evaluation/fixtures/ci_pipeline_before/`` holds ``metrics/eval.json``
and ``reports/tables.md`` of the ci pipeline (``support.project.CI_PIPELINE``)
run on the code before the refactor. The same pipeline on this code must give
the same eval.json, byte for byte, on every key the fixture has (the scenario
outages, the navigation filter's controls, the earlier dead reckoning and the
models' uncertainty, added since, are the only new keys), and the same tables.md
apart from the scenario-outage and 2D sections and the two modules the text
names, which moved. One key changed on purpose: ``position`` (issue 17) held the
2D dead reckoning's end-of-outage errors (the fixture's numbers come from the
dead reckoning of that time); it now holds the navigation filter's, another
quantity, so it is left out of the comparison, as is the tables' 2D section.
Bit for bit on the fixture's machine (``machine.json``: the CPU and the kernels
torch picks for it). On another CPU the trained models' last bits move (README,
"What reproduces bit for bit"), so there only what no network touches is
compared exactly: the wheel-odometry models (WPM, its other mode, WPM-m@m), the
windows and distances, and the set of keys. When a change is meant to move the
numbers, this test has served its purpose: delete it with the fixture rather
than refreshing them.

Slow (the whole ci pipeline, shared with ``tests/test_pipeline.py``).
"""

import json
import platform
from pathlib import Path

import pytest
import torch

from support.project import dvc

pytestmark = pytest.mark.slow

BEFORE = Path(__file__).parent / "evaluation" / "fixtures" / "ci_pipeline_before"
NEW_KEYS = {"scenario_outages", "position_controls", "position_dead_reckoning", "uncertainty"}
# Replaced on purpose (issue 17): the 2D position is the navigation filter's now, not the
# rear wheels' dead reckoning the fixture's numbers and section come from.
CHANGED_KEYS = {"position"}
SECTION = "\n## Scenario outages"
SECTION_2D_BEFORE = "\n## 2D dead reckoning"
SECTION_2D_NOW = "\n## Where is the car when GNSS returns"
MOVED = {
    "(rwhonet.stages.position)": "(rwhonet.evaluation.position)",
    "(rwhonet.stages.limits)": "(rwhonet.evaluation.limits)",
}


def this_machine() -> dict[str, str]:
    """What decides the trained models' last bits: architecture, CPU, torch and its kernels."""
    cpu = ""
    if Path("/proc/cpuinfo").is_file():
        lines = Path("/proc/cpuinfo").read_text().splitlines()
        cpu = next((ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")), "")
    return {
        "machine": platform.machine(),
        "cpu": cpu,
        "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "torch": torch.__version__,
    }


SAME_MACHINE = json.loads((BEFORE / "machine.json").read_text()) == this_machine()
NETWORK_FREE = ("WPM", "WPM-ref", "WPM-int", "WPM-m@")


@pytest.fixture(scope="module")
def repo(ci_pipeline):
    out = dvc(ci_pipeline, "repro")
    assert out.returncode == 0, out.stdout + out.stderr
    return ci_pipeline


def test_network_free_numbers_are_unchanged_on_any_machine(repo):
    before = json.loads((BEFORE / "eval.json").read_text(encoding="utf-8"))
    now = json.loads((repo / "metrics" / "eval.json").read_text(encoding="utf-8"))
    assert set(now) - set(before) == NEW_KEYS and set(before) <= set(now)
    for scope, cells in (("overall", before["overall"]), *before["per_drive"].items()):
        got = now["overall"] if scope == "overall" else now["per_drive"][scope]
        assert set(got) == set(cells), scope
        for model, by_outage in cells.items():
            for outage, stats in by_outage.items():
                # window counts: overall cells have them, per-drive cells never did
                assert got[model][outage].get("n_windows") == stats.get("n_windows"), (
                    scope,
                    model,
                )
                if model.startswith(NETWORK_FREE):
                    assert got[model][outage] == stats, (scope, model, outage)
    assert now["limits"] == before["limits"]


@pytest.mark.skipif(not SAME_MACHINE, reason="bit for bit needs the fixture's machine.json")
def test_eval_json_is_unchanged_apart_from_the_new_keys_and_the_2d_position(repo):
    text = (BEFORE / "eval.json").read_text(encoding="utf-8")
    before = json.loads(text)
    now = json.loads((repo / "metrics" / "eval.json").read_text(encoding="utf-8"))
    assert set(now) - set(before) == NEW_KEYS and set(before) <= set(now)
    kept = [key for key in before if key not in CHANGED_KEYS]
    for key in kept:
        assert now[key] == before[key], key
    # byte for byte: the same keys in the same order, the same numbers as written (the
    # fixture's text re-dumped without the changed key is its text: every float round-trips)
    assert (
        json.dumps({key: before[key] for key in kept}, indent=2) + "\n"
        == json.dumps({key: now[key] for key in kept}, indent=2) + "\n"
    )
    assert json.dumps(before, indent=2) + "\n" == text
    assert set(list(now)[-len(NEW_KEYS) :]) == NEW_KEYS  # the new keys come last


def _without(text: str, heading: str) -> str:
    """``text`` less the section that starts with ``heading`` (to the next ``## ``)."""
    start = text.index(heading)
    return text[:start] + text[text.index("\n## ", start + 1) :]


@pytest.mark.skipif(not SAME_MACHINE, reason="bit for bit needs the fixture's machine.json")
def test_tables_are_unchanged_apart_from_the_scenario_outage_and_2d_sections(repo):
    before = (BEFORE / "tables.md").read_text(encoding="utf-8")
    for old, new in MOVED.items():
        assert old in before
        before = before.replace(old, new)
    now = (repo / "reports" / "tables.md").read_text(encoding="utf-8")
    start = now.index(SECTION)
    end = now.index("\n## ", start + 1)
    assert SECTION not in before and "| roundabout |" in now[start:end]
    assert "| gyro + wheels fused |" in now[now.index(SECTION_2D_NOW) :]
    assert _without(_without(now, SECTION), SECTION_2D_NOW) == _without(before, SECTION_2D_BEFORE)
