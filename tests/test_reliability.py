"""docs/reliability.md's counts of crash and concurrency tests come from the suite itself.

A test is a crash test or a concurrency test by its marker (``pytest.mark.crash``,
``pytest.mark.concurrency``); ``tests/conftest.py`` counts the marked tests of the
whole suite (every parametrised case), whatever ``-m`` then selects. The bad-input
counts are checked by ``tests/data/bad/test_corpus.py``.
"""

import re

import pytest

from conftest import COUNTED_MARKERS, SUITE_COUNTS
from rwhonet import paths

LINES = {"crash": "crash tests", "concurrency": "concurrency tests"}


def test_reliability_doc_counts_come_from_the_suite(request):
    counts = request.config.stash.get(SUITE_COUNTS, None)
    if counts is None:
        pytest.skip("counts come from a run of the whole suite (make test, make test-fast)")
    section = (paths.ROOT / "docs" / "reliability.md").read_text().split("## Counts", 1)[1]
    found = {
        marker: int(n)
        for marker in COUNTED_MARKERS
        for n in re.findall(rf"^- {LINES[marker]}\D*?(\d+)", section, re.M)
    }
    assert found == counts
