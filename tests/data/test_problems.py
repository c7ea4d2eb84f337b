"""Readable problem lists: a few stretches one by one, then how many more."""

from __future__ import annotations

import pytest

from rwhonet.data.problems import ROWS_LISTED, stretch_problems
from rwhonet.errors import Problem


def _problem(row: int) -> Problem:
    return Problem("V-S1.csv", row, "WheelSpeed_RL", "turning", f"stuck from row {row}", "cut it")


@pytest.mark.parametrize("n", [0, 1, ROWS_LISTED, ROWS_LISTED + 1, 40])
def test_the_first_stretches_are_listed_and_the_rest_counted(n):
    found = stretch_problems([10 * i + 1 for i in range(n)], _problem)
    listed = min(n, ROWS_LISTED)
    assert [p.row for p in found[:listed]] == [10 * i + 1 for i in range(listed)]
    if n <= ROWS_LISTED:
        assert len(found) == n
        return
    (more,) = found[listed:]
    assert more == Problem(
        "V-S1.csv",
        None,
        "WheelSpeed_RL",
        "turning",
        f"{n - ROWS_LISTED} more stretch(es) like these",
        "cut it",
    )
