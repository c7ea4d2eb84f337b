"""Fixtures shared across the suite; folder conftests add their own.

The tests mirror the package (tests/<package>/ for src/rwhonet/<package>/);
``support/`` holds drive writers and synthetic drives several folders use.
Tests marked ``slow`` run real DVC stages or fresh interpreters (``make
test-fast`` skips them).
"""

from __future__ import annotations

import os
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from rwhonet import paths
from rwhonet.config import Params, load_params
from rwhonet.libraries import quiet

# The suite runs on a UTC clock, wherever it runs. python-can's BLF writer writes a log's
# start on the writing machine's local clock (and its reader reads it on the reading
# machine's), while the project reads a BLF's start as UTC, or in the map's local_zone
# (rwhonet.data.blf.blf_start): the logs python-can writes here are a UTC logger's. Tests
# of other zones set TZ themselves.
os.environ["TZ"] = "UTC"
time.tzset()

quiet()

# What the whole suite holds, by marker (docs/reliability.md counts crash and concurrency
# tests): counted before `-m` deselects anything, and only when the run collects all of tests/.
SUITE_COUNTS = pytest.StashKey[dict[str, int]]()
COUNTED_MARKERS = ("crash", "concurrency")
TESTS = Path(__file__).resolve().parent


# The modules that take the session's ci pipeline (:func:`ci_pipeline`). ``make test``
# (pytest-xdist, --dist loadfile) runs each test module whole on one worker, so its module
# fixtures, most of them a whole DVC pipeline in a scratch project, are built once; these
# modules run together as one unit (:func:`pytest_xdist_make_scheduler`), so the ci
# pipeline is built and run once in the suite, not once on each worker.
CI_PIPELINE_MODULES = frozenset(
    {
        "tests/test_pipeline.py",
        "tests/test_outputs_unchanged.py",
        "tests/test_real_drive.py",
        "tests/stages/test_train.py",
        "tests/tracking/test_ui.py",
    }
)
CI_PIPELINE_UNIT = "the ci pipeline's modules"

# The work units that take longest, longest first (seconds of one CI run, junit, of
# 8859a25): a worker that is free takes the next unit in this order, then the rest, most
# tests first (pytest-xdist's own order). Without it the units with a whole pipeline and
# few tests (crash, concurrency) came last, and one worker ran one of them alone at the
# end. Only the order: a unit missing here runs all the same.
LONGEST_FIRST = (
    CI_PIPELINE_UNIT,  # 545 s
    "tests/tracking/test_team_server.py",  # 201 s
    "tests/test_pipeline_crash.py",  # 172 s
    "tests/tracking/test_concurrency.py",  # 164 s
    "tests/test_own_drives.py",  # 85 s
    "tests/test_pipeline_arch.py",  # 82 s
    "tests/cli/test_cli_corpus.py",  # 56 s
    "tests/evaluation/test_study.py",  # 44 s
    "tests/data/bad/test_corpus.py",  # 35 s
    "tests/cli/test_round_trip.py",  # 33 s
)


def work_unit(module: str) -> str:
    """The pytest-xdist work unit a test module belongs to (``--dist loadfile``)."""
    return CI_PIPELINE_UNIT if module in CI_PIPELINE_MODULES else module


def longest_first(items: list) -> list:
    """``items`` with the work units in :data:`LONGEST_FIRST` order, then most tests first.

    A stable sort: the tests of one unit keep their order (the ci pipeline's modules
    share one project, in collection order).
    """
    modules = [item.nodeid.split("::", 1)[0] for item in items]
    size = Counter(map(work_unit, modules))
    first = {unit: i for i, unit in enumerate(LONGEST_FIRST)}
    seen = {unit: i for i, unit in enumerate(dict.fromkeys(map(work_unit, modules)))}

    def rank(module: str) -> tuple[int, int, int]:
        unit = work_unit(module)
        return (first.get(unit, len(first)), -size[unit], seen[unit])

    order = sorted(range(len(items)), key=lambda i: rank(modules[i]))
    return [items[i] for i in order]


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session, config, items):
    targets = {Path(str(a).split("::")[0]).resolve() for a in config.args}
    if targets <= {TESTS, TESTS.parent}:
        config.stash[SUITE_COUNTS] = {
            m: sum(1 for item in items if item.get_closest_marker(m)) for m in COUNTED_MARKERS
        }
    strays = sorted(
        {
            item.nodeid.split("::", 1)[0]
            for item in items
            if "ci_pipeline" in getattr(item, "fixturenames", ())
            and item.nodeid.split("::", 1)[0] not in CI_PIPELINE_MODULES
        }
    )
    if strays:
        raise pytest.UsageError(
            f"{', '.join(strays)} use(s) the ci_pipeline fixture: add it to "
            "CI_PIPELINE_MODULES in tests/conftest.py (or each pytest-xdist worker that "
            "runs one builds the whole pipeline again)"
        )
    items[:] = longest_first(items)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile``, but :data:`CI_PIPELINE_MODULES` are one work unit, longest first."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class CiPipelineTogether(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(super()._split_scope(nodeid))

    # the units in the order the workers collected them (:func:`longest_first`), not
    # re-sorted by their number of tests
    config.option.loadscopereorder = False
    return CiPipelineTogether(config, log)


@pytest.fixture(scope="session")
def ci_data(tmp_path_factory) -> Path:
    """A ci-pipeline project whose data stages ran, once for the whole session.

    Every scratch project on the ci profile's drives starts from it
    (``support.project.scratch_project(..., stages_from=ci_data)``): the data stages
    (about half a minute) run once in the suite, not in each of the six projects.
    Under pytest-xdist the workers share it (their temporary folders' parent).
    """
    from support.project import data_stages_done

    base = tmp_path_factory.getbasetemp()
    return data_stages_done(base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base)


@pytest.fixture(scope="session")
def ci_pipeline(tmp_path_factory, ci_data) -> Path:
    """A scratch copy of the project on the small ci pipeline (``support.project.CI_PIPELINE``).

    One per session: under ``make test`` the modules asking for it run on one
    pytest-xdist worker (:data:`CI_PIPELINE_MODULES`). ``test_pipeline.py`` runs and
    probes its stages, the MLflow UI test browses the store its runs leave (each runs
    ``dvc repro`` first, a no-op when the other already did).
    """
    from support.project import CI_PIPELINE, scratch_project

    return scratch_project(tmp_path_factory.mktemp("pipeline") / "repo", CI_PIPELINE, ci_data)


@pytest.fixture(scope="session")
def ci_repro(ci_pipeline):
    """The first whole ``dvc repro`` of :func:`ci_pipeline`, whichever test asks first.

    Every module that needs the pipeline run takes this (not a ``dvc repro`` of its own,
    which is a no-op when another module ran first), so ``tests/test_pipeline.py`` reads
    what the stages printed when they ran.
    """
    from support.project import dvc

    out = dvc(ci_pipeline, "repro")
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
    return out


@pytest.fixture(scope="session")
def migrated_store(tmp_path_factory) -> Path:
    """One new MLflow SQLite store per pytest process, migrated (``support.store``)."""
    from support.store import migrated_store

    return migrated_store(tmp_path_factory.mktemp("store") / "mlflow.db")


@pytest.fixture
def store_uri(tmp_path_factory, migrated_store) -> str:
    """The URI of a new store of the test's own, in a folder of its own beside ``tmp_path``.

    A copy of :func:`migrated_store`: what MLflow makes of a new SQLite file, without
    its 2 s of migrations in every test that logs. The tests of a store's creation
    itself (several processes migrating one new file at once) start from no file.
    """
    from support.store import copy_store

    return copy_store(migrated_store, tmp_path_factory.mktemp("mlruns") / "mlflow.db")


@pytest.fixture(scope="session")
def project_params() -> Params:
    """The repository's params.yaml, typed."""
    return load_params(paths.PARAMS)


@pytest.fixture(scope="session")
def linear_data() -> tuple[np.ndarray, np.ndarray]:
    """1,200 windows (seq_len 1, 40 features in [0, 1]) with a known linear label in metres."""
    rng = np.random.default_rng(7)
    x = rng.random((1200, 1, 40), dtype=np.float32)
    w = rng.normal(0.0, 0.5, 40)
    y = (x[:, 0, :] @ w - 0.2).astype(np.float32)
    return x, y
