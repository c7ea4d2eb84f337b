"""Turn many bad cells into a readable list of :class:`~rwhonet.errors.Problem`.

A column that is wrong throughout (a text column mapped by mistake, a whole
drive in the wrong unit) would otherwise produce a million problems; every
report lists the first few rows of each (file, column, check) and one more
line with the count and the row range of the rest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rwhonet.errors import Problem

ROWS_LISTED = 5  # rows listed per (file, column, check) before the rest is summarised


def row_problems(
    file: str,
    column: str | None,
    rows: Sequence[int] | np.ndarray,
    found: Sequence[str],
    expected: str,
    limit: int = ROWS_LISTED,
) -> list[Problem]:
    """List the first ``limit`` bad rows of one check and summarise the rest.

    Args:
        file: the file as the user knows it.
        column: the file's column name (None when file-wide).
        rows: 1-based data rows that failed, in file order.
        found: what was found in each of ``rows`` (same length).
        expected: what the check expected.
        limit: how many rows to list one by one.

    Returns:
        ``min(len(rows), limit)`` problems, plus one summary problem when rows were left out.
    """
    rows = np.asarray(rows, dtype=np.int64)
    out = [
        Problem(file, int(r), column, expected, str(f))
        for r, f in zip(rows[:limit], found[:limit], strict=True)
    ]
    rest = rows[limit:]
    if rest.size:
        out.append(
            Problem(
                file,
                None,
                column,
                expected,
                f"{rest.size} more row(s) like these, rows {int(rest.min())}-{int(rest.max())} "
                f"({rows.size} in all)",
            )
        )
    return out
