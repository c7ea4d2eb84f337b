"""Turn many bad cells into a readable list of :class:`~rwhonet.errors.Problem`.

A column that is wrong throughout (a text column mapped by mistake, a whole
drive in the wrong unit) would otherwise produce a million problems; every
report lists the first few rows of each (file, column, check) and one more
line with the count and the row range of the rest. :class:`RowTally` does the
same for rows that arrive block by block (the streaming CSV reader), keeping
only what the report shows.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

import numpy as np

from rwhonet.errors import Problem

ROWS_LISTED = 5  # rows listed per (file, column, check) before the rest is summarised
T = TypeVar("T")


def unreadable_file(file: str, err: OSError) -> Problem:
    """A file that cannot be opened or read (gone, or no permission)."""
    return Problem(
        file,
        None,
        None,
        "a readable file",
        f"{type(err).__name__}: {err.strerror}",
        "check that the file is there and readable (permissions), then run again",
    )


def no_data_rows(file: str) -> Problem:
    """A drive file with a header and nothing after it."""
    return Problem(
        file,
        None,
        None,
        "at least one data row after the header",
        "none",
        "a drive file holds its samples after the header row",
    )


class RowTally:
    """The failing rows of one check, as they arrive: the first few listed, the rest counted.

    Args:
        file: the file as the user knows it.
        column: the file's column name (None when file-wide).
        expected: what the check expected.
        fix: what to do about it.
        limit: how many rows to list one by one.
    """

    def __init__(
        self,
        file: str,
        column: str | None,
        expected: str,
        fix: str | None = None,
        limit: int = ROWS_LISTED,
    ) -> None:
        self.file, self.column, self.expected, self.fix, self.limit = (
            file,
            column,
            expected,
            fix,
            limit,
        )
        self.listed: list[tuple[int, str]] = []
        self.count = 0
        self.rest_min: int | None = None
        self.rest_max: int | None = None

    def add(self, rows: Sequence[int] | np.ndarray, found: Sequence[str]) -> None:
        """Record failing rows (in file order) and what was found in each.

        ``found`` may be shorter than ``rows``: only the rows still to be listed need it.
        """
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size == 0:
            return
        room = max(self.limit - len(self.listed), 0)
        self.listed += [(int(r), str(f)) for r, f in zip(rows[:room], found[:room], strict=False)]
        rest = rows[room:]
        if rest.size:
            lo, hi = int(rest.min()), int(rest.max())
            self.rest_min = lo if self.rest_min is None else min(self.rest_min, lo)
            self.rest_max = hi if self.rest_max is None else max(self.rest_max, hi)
        self.count += int(rows.size)

    def problems(self) -> list[Problem]:
        """The listed rows, plus one summary problem when rows were left out."""
        out = [
            Problem(self.file, r, self.column, self.expected, f, self.fix) for r, f in self.listed
        ]
        rest = self.count - len(self.listed)
        if rest:
            out.append(
                Problem(
                    self.file,
                    None,
                    self.column,
                    self.expected,
                    f"{rest} more row(s) like these, rows {self.rest_min}-{self.rest_max} "
                    f"({self.count} in all)",
                    self.fix,
                )
            )
        return out


def row_problems(
    file: str,
    column: str | None,
    rows: Sequence[int] | np.ndarray,
    found: Sequence[str],
    expected: str,
    limit: int = ROWS_LISTED,
    fix: str | None = None,
) -> list[Problem]:
    """List the first ``limit`` bad rows of one check and summarise the rest.

    Args:
        file: the file as the user knows it.
        column: the file's column name (None when file-wide).
        rows: 1-based data rows that failed, in file order.
        found: what was found in each of ``rows`` (at least the first ``limit``).
        expected: what the check expected.
        limit: how many rows to list one by one.
        fix: what to do about it.

    Returns:
        ``min(len(rows), limit)`` problems, plus one summary problem when rows were left out.
    """
    tally = RowTally(file, column, expected, fix, limit)
    tally.add(rows, found)
    return tally.problems()


def stretch_problems(
    stretches: Sequence[T], problem: Callable[[T], Problem], limit: int = ROWS_LISTED
) -> list[Problem]:
    """The problems of the first ``limit`` stretches of one check, then how many more there are.

    Args:
        stretches: what one check found (runs of rows), in file order.
        problem: the problem of one stretch.
        limit: how many stretches to list one by one.

    Returns:
        A problem per listed stretch and, when there are more, one line counting them
        with the listed ones' file, column, expectation and fix.
    """
    shown = [problem(s) for s in stretches[:limit]]
    if len(stretches) > limit:
        last = shown[-1]
        shown.append(
            Problem(
                last.file,
                None,
                last.column,
                last.expected,
                f"{len(stretches) - limit} more stretch(es) like these",
                last.fix,
            )
        )
    return shown
