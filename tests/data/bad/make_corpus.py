"""Write the bad-input corpus out, and say what the data stages do with each case.

Usage (from the repository root):

    .venv/bin/python tests/data/bad/make_corpus.py [OUT] [--run]

writes ``OUT/<case>/raw/...`` (default ``build/bad-corpus``): the good drives and
the case's ``target_test/C-X1.csv``, with ``params-overrides.json`` for cases
that change params. With ``--run`` it also runs ingest, validate and label on
each case and prints the outcome: the first problem and what to do, or the cuts.
With ``--table`` it prints the table of docs/reliability.md.
The cases and their expected behaviour live in ``tests/support/corpus.py``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # tests/: `support` importable

from rwhonet.config import ConfigError  # noqa: E402
from rwhonet.errors import InputError  # noqa: E402
from rwhonet.stages.ingest import ingest  # noqa: E402
from rwhonet.stages.label import label  # noqa: E402
from rwhonet.stages.validate import validate  # noqa: E402
from support.corpus import (  # noqa: E402
    CASES,
    DRIVE,
    SCRIPT_CASES,
    Case,
    Refuse,
    Repair,
    counts,
    write_good_fleet,
)
from support.drives import make_params  # noqa: E402


def run_case(folder: Path, overrides: dict) -> str:
    """Run the data stages on one written case; return what happened, in one paragraph."""
    raw = folder / "raw"
    try:
        params = make_params(raw, **overrides)
        ingest(params, folder / "drives")
        report = validate(params, folder / "drives", folder / "segments", folder / "report.json")
        label(params, folder / "segments", folder / "samples", folder / "c.json", folder / "s.json")
    except ConfigError as err:
        return f"refused (params): {err}"
    except InputError as err:
        first = err.problems[0]
        return f"refused: {first}\n    what to do: {first.fix}"
    (drive,) = [d for d in report["drives"] if d["drive"] == DRIVE]
    cuts = [f"{x['rule']} {x['start_s']:.0f}-{x['end_s']:.0f} s" for x in drive["cuts"]]
    return f"kept {drive['seconds_kept']} of {drive['seconds']} s; cuts: {', '.join(cuts)}"


def behaviour(case: Case) -> str:
    """The expected behaviour in words, for the docs table."""
    x = case.expect
    if isinstance(x, Refuse):
        if x.stage == "params":
            return f"refused when params.yaml is loaded: `{x.found}: {x.expected} ...`"
        where = ", ".join(
            part
            for part in (
                f"`{x.file}`",
                f"row {x.row}" if x.row is not None else "",
                f"column `{x.column.strip()}`" if x.column else "",
            )
            if part
        )
        return f"refused at {x.stage}: {where}: expected ...{x.expected}...; found ...{x.found}..."
    if isinstance(x, Repair):
        return f"repaired: rule `{x.rule}` cuts >= {x.seconds} s (validation report); rest kept"
    return f"accepted: {x.note}"


def table() -> str:
    """The corpus as a markdown table: case, what is wrong, behaviour, test."""
    lines = ["| case | what is wrong | behaviour | test |", "|---|---|---|---|"]
    for case in CASES:
        test = f"`test_case[{case.name}]`"
        if case.name in SCRIPT_CASES:
            test += f", `test_stage_scripts[{case.name}]`"
        cells = [f"`{case.name}`", case.corruption, behaviour(case), test]
        lines.append("| " + " | ".join(x.replace("|", "\\|") for x in cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="build/bad-corpus", type=Path)
    parser.add_argument("--run", action="store_true", help="run the data stages on each case")
    parser.add_argument("--table", action="store_true", help="print the docs table and stop")
    args = parser.parse_args()
    if args.table:
        print(table())
        return
    for case in CASES:
        folder = args.out / case.name
        shutil.rmtree(folder, ignore_errors=True)
        write_good_fleet(folder / "raw")
        case.write(folder / "raw")
        if case.overrides:
            (folder / "params-overrides.json").write_text(json.dumps(case.overrides, indent=1))
        line = f"{case.name}: {case.corruption} -> expected {case.expect.kind}"
        print(line + (f"\n    {run_case(folder, case.overrides)}" if args.run else ""))
    print(f"{counts()} -> {args.out}")


if __name__ == "__main__":
    main()
