"""Errors a user can act on: which file, which row, which column, what was expected, what to do."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Problem:
    """One problem found in an input file.

    Attributes:
        file: path of the offending file (as the user knows it).
        row: 1-based data row (header excluded), or None when the problem is file-wide.
        column: the file's column name, or None.
        expected: what was expected.
        found: what was found.
        fix: what the user can do about it (None when the expected value says it all).
    """

    file: str
    row: int | None
    column: str | None
    expected: str
    found: str
    fix: str | None = None

    def __str__(self) -> str:
        where = self.file
        if self.row is not None:
            where += f", row {self.row}"
        if self.column is not None:
            where += f", column {self.column!r}"
        return f"{where}: expected {self.expected}; found {self.found}"

    @classmethod
    def unreadable(
        cls, file: str, expected: str, err: BaseException, fix: str, column: str | None = None
    ) -> Problem:
        """A file (or one of its columns) a library could not read: the error is what was found.

        Args:
            file: the file, as the user knows it.
            expected: what it should have been.
            err: the library's exception (its type and the start of its message are shown).
            fix: what to do.
            column: the column or signal, where the failure is one of its.

        Returns:
            The problem.
        """
        return cls(file, None, column, expected, f"{type(err).__name__}: {str(err)[:160]}", fix)

    @classmethod
    def from_dict(cls, d: dict[str, object]) -> Problem:
        """A problem from :meth:`to_dict`'s plain data (a report or manifest read back)."""
        row, column, fix = d.get("row"), d.get("column"), d.get("fix")
        return cls(
            str(d["file"]),
            None if row is None else int(row),  # type: ignore[call-overload]
            None if column is None else str(column),
            str(d["expected"]),
            str(d["found"]),
            None if fix is None else str(fix),
        )

    def to_dict(self) -> dict[str, object]:
        """The problem as plain data (for JSON reports)."""
        return {
            "file": self.file,
            "row": self.row,
            "column": self.column,
            "expected": self.expected,
            "found": self.found,
            "fix": self.fix,
        }


class InputError(Exception):
    """Bad input data; carries every problem found so one report lists them all."""

    def __init__(self, problems: list[Problem], summary: str | None = None) -> None:
        self.problems = list(problems)
        self.summary = summary or f"{len(self.problems)} problem(s) in the input data"
        super().__init__(self.report())

    def fixes(self) -> list[str]:
        """What to do, once per distinct advice, in the order the problems give it."""
        return list(dict.fromkeys(p.fix for p in self.problems if p.fix))

    def report(self, limit: int = 50) -> str:
        """Return a readable multi-line report (at most ``limit`` problems listed).

        The problems come first, one per line; then, under "What to do", each distinct
        piece of advice once (many rows of one check share one).
        """
        lines = [self.summary + ":"]
        lines += [f"  - {p}" for p in self.problems[:limit]]
        if len(self.problems) > limit:
            lines.append(f"  ... and {len(self.problems) - limit} more")
        fixes = self.fixes()
        if fixes:
            lines.append("What to do:")
            lines += [f"  - {fix}" for fix in fixes]
        return "\n".join(lines)
