"""Concurrency: three pipeline executions writing to one MLflow store at the same time.

Two clones of the project (scratch copies, ``ci`` profile, small): clone A
queues two named experiments of a sweep (``dvc exp run --queue -n <name> -S
seeds=... -S adapt.recipe=... -S adapt.chosen_m=... -S adapt.lr=...``) and runs
them with a 2-worker ``dvc queue``, in temporary copies under
``.dvc/tmp/exps/`` whose relative store URI must still reach A's ``mlruns/``;
clone B (another seed) points ``tracking.tracking_uri`` at A's store by its
absolute path and runs ``dvc repro``, all at once, on a store nobody
initialised. Every execution must be in the store exactly once, with its own
children, none RUNNING or FAILED, and the SQLite file sound; every run of a
queued experiment carries its DVC name and baseline commit and the seed,
recipe and m it was queued with. Slow: about two minutes.
"""

from __future__ import annotations

import json
import subprocess
import time
from collections import Counter

import pytest

from support.project import BIN, dvc, env, scratch_project
from support.store import integrity, store_runs

pytestmark = [pytest.mark.slow, pytest.mark.concurrency]

OVERRIDES = {
    ("seeds",): [1],
    ("sim", "profile"): "ci",
    ("train", "epochs"): 3,
    ("adapt", "epochs"): 5,
    ("adapt", "m_grid"): [10, 20],
    ("adapt", "recipes"): ["paper", "radius+G"],
    ("adapt", "fallback", "recipe"): "radius+G",
    ("adapt", "fallback", "m"): 20,
    ("evaluate", "outages_s"): [30, 180],
}
# Clone A's two queued experiments: a sweep over seed x recipe x m (and the adaptation lr).
QUEUED = {
    "sweep-a": {
        "seeds": "[3]",
        "adapt.recipe": "paper",
        "adapt.chosen_m": "10",
        "adapt.lr": "0.001",
    },
    "sweep-b": {
        "seeds": "[4]",
        "adapt.recipe": "radius+G",
        "adapt.chosen_m": "20",
        "adapt.lr": "0.0014",
    },
}
QUEUED_LR = tuple(q["adapt.lr"] for q in QUEUED.values())
CLONE_B_SEEDS = "[2]"


def _queue_done(repo, timeout_s: float = 900) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        status = dvc(repo, "queue", "status").stdout
        if "Queued" not in status and "Running" not in status:
            return status
        time.sleep(3)
    dvc(repo, "queue", "kill", "--all")
    pytest.fail("the queue did not finish")


@pytest.fixture(scope="module")
def store(tmp_path_factory, ci_data):
    base = tmp_path_factory.mktemp("concurrency")
    a = scratch_project(base / "a", OVERRIDES, ci_data)
    uri = f"sqlite:///{a}/mlruns/mlflow.db"
    b_overrides = {**OVERRIDES, ("seeds",): [2], ("tracking", "tracking_uri"): uri}
    b = scratch_project(base / "b", b_overrides, ci_data)
    # The data stages first, as a user's sweep starts from a reproduced workspace: two
    # workers running the same stage at once race on DVC's run cache (one worker's
    # temporary run-cache file vanished: treeverse/dvc#10673), which no sweep need meet.
    data = dvc(a, "repro", "label")
    assert data.returncode == 0, data.stdout + data.stderr
    for name, settings in QUEUED.items():
        sets = [arg for k, v in settings.items() for arg in ("-S", f"{k}={v}")]
        out = dvc(a, "exp", "run", "--queue", "-n", name, *sets)
        assert out.returncode == 0, out.stderr
    assert not (a / "mlruns" / "mlflow.db").exists()  # no `python -m rwhonet.tracking init`
    clone_b = subprocess.Popen(
        [str(BIN / "dvc"), "repro"],
        cwd=b,
        env=env(b),
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    started = dvc(a, "queue", "start", "-j", "2")
    assert started.returncode == 0, started.stderr
    queue = _queue_done(a)
    clone_b_output, _ = clone_b.communicate(timeout=900)
    assert clone_b.returncode == 0, clone_b_output
    shown = dvc(a, "exp", "show", "--json")
    assert shown.returncode == 0, shown.stderr
    return {
        "a": a,
        "b": b,
        "uri": uri,
        "queue": queue,
        "runs": store_runs(uri),
        "baseline": subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=a, capture_output=True, text=True, check=True
        ).stdout.strip(),
        "exp_show": json.loads(shown.stdout),
    }


def _parents(runs) -> list:
    return [r for r in runs if r.data.tags.get("model") == "pipeline"]


def _descendants(runs, parent_id: str) -> list:
    children = [r for r in runs if r.data.tags.get("mlflow.parentRunId") == parent_id]
    return children + [d for c in children for d in _descendants(runs, c.info.run_id)]


def test_a_two_worker_queue_logs_both_experiments_into_the_repository_store(store):
    assert store["queue"].count("Success") == 2, store["queue"]
    lrs = Counter(p.data.params.get("adapt.lr") for p in _parents(store["runs"]))
    assert all(lrs[lr] == 1 for lr in QUEUED_LR), lrs
    # the temporary copies logged through the relative URI into A's mlruns/, not their own
    assert not list((store["a"] / ".dvc" / "tmp" / "exps").rglob("mlflow.db"))


def test_a_clone_logging_to_the_shared_store_keeps_its_runs(store):
    (parent,) = [p for p in _parents(store["runs"]) if p.data.params["seeds"] == CLONE_B_SEEDS]
    family = _descendants(store["runs"], parent.info.run_id)
    seeds = {d.data.tags["seed"] for d in family if "seed" in d.data.tags}
    assert seeds == {"2"}
    assert not (store["b"] / "mlruns" / "mlflow.db").exists()


def test_no_run_is_lost_mixed_up_or_left_running(store):
    runs = store["runs"]
    parents = _parents(runs)
    assert len(parents) == 3  # two queued experiments and clone B
    assert len({p.data.tags["rwhonet.execution"] for p in parents}) == 3
    families = {p.info.run_id: _descendants(runs, p.info.run_id) for p in parents}
    for p in parents:
        family = families[p.info.run_id]
        assert {r.data.tags["rwhonet.execution"] for r in family} == {
            p.data.tags["rwhonet.execution"]
        }
        lrs = {r.data.params["adapt.lr"] for r in family if "adapt.lr" in r.data.params}
        assert lrs <= {p.data.params["adapt.lr"]}, lrs
    sizes = {len(f) for f in families.values()}
    assert len(sizes) == 1 and sizes.pop() > 10  # the same pipeline: the same runs
    assert len(runs) == sum(1 + len(f) for f in families.values())  # no stray run
    assert Counter(r.info.status for r in runs) == {"FINISHED": len(runs)}
    assert integrity(store["uri"]) == "ok"


def _named(node, names: set[str]) -> dict[str, dict]:
    """The entries of ``dvc exp show --json`` named one of ``names``, by name."""
    found = {}
    if isinstance(node, dict):
        if node.get("name") in names and "rev" in node:
            found[node["name"]] = node
        for v in node.values():
            found.update(_named(v, names))
    elif isinstance(node, list):
        for v in node:
            found.update(_named(v, names))
    return found


def test_every_run_of_a_queued_experiment_carries_its_name_baseline_seed_recipe_and_m(store):
    shown = _named(store["exp_show"], set(QUEUED))
    assert set(shown) == set(QUEUED)  # dvc exp show lists the sweep by the names it was given
    runs = store["runs"]
    for name, settings in QUEUED.items():
        (parent,) = [p for p in _parents(runs) if p.data.tags.get("dvc_exp_name") == name]
        family = [parent, *_descendants(runs, parent.info.run_id)]
        for run in family:
            assert run.data.tags["dvc_exp_name"] == name
            assert run.data.tags["dvc_exp_baseline_rev"] == store["baseline"]
        for key in ("seeds", "adapt.recipe", "adapt.chosen_m"):
            assert parent.data.params[key] == settings[key], key
        seed = settings["seeds"].strip("[]")
        assert {r.data.tags["seed"] for r in family if "seed" in r.data.tags} == {seed}
        (chosen,) = [r for r in family if r.data.tags.get("chosen") == "true"]
        assert chosen.data.tags["recipe"] == settings["adapt.recipe"]
        assert chosen.data.tags["m"] == settings["adapt.chosen_m"]
    # clone B ran `dvc repro`, not an experiment: its runs say so by having no such tag
    (b,) = [p for p in _parents(runs) if p.data.params["seeds"] == CLONE_B_SEEDS]
    assert "dvc_exp_name" not in b.data.tags
