"""``rwhonet check``: a drive read and checked as ingest and validate would, before a run.

A user with drives of their own reads each through the format they declare and sees, in
a few seconds and without ``dvc repro``, what validate would say of it: refused (exit 2,
the problems as validate reports them, naming the file, row and column), or accepted,
with what it kept (the valid seconds and segments, the cuts by rule) and what each of
validate's checks against GNSS told: the tyre radius the wheels imply (their unit), the
yaw rate's unit and sign, each axle's left and right wheels, the front and rear wheels
(the records of ``reports/validation.json``, :mod:`rwhonet.data.drivechecks`). A check
that could not tell (a highway that never turns tightly, a drive without a yaw rate) says
why, so a column map's mistake it could not see is not taken as ruled out.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from rwhonet.cli.drive import check_drive_file
from rwhonet.config import Params
from rwhonet.data.drivechecks import TOLD_CHECKS


def run(
    params: Params,
    drive: Path,
    fmt: str,
    vehicle: str,
    part: str | None = None,
    split: tuple[Path, str] | None = None,
) -> dict[str, Any]:
    """Read and check ``drive`` as the car ``vehicle`` of ``params`` (``part``: in a file of
    many drives, the drive; ``split``: its rows' own CSV where the file was split already,
    :attr:`rwhonet.data.drivefile.DriveFile.split`).

    Returns:
        ``file``, ``vehicle``, ``rows`` (of the drive, or its 10 Hz grid), ``seconds``,
        ``seconds_kept``, ``segments``, ``cut_seconds_by_rule`` (the rules that cut),
        validate's records (``radius``, ``yaw_rate``, ``wheel_sides``, ``wheel_axles``),
        ``columns`` (canonical -> the drive's own) and the ``notes`` of the reader and
        the resampler (for a stream drive: where its fixes were placed, their lag); where
        the drive has its receiver's stated accuracy, ``gnss_accuracy`` (validate's
        report's, with ``validate.gnss.max_h_acc_m``).

    Raises:
        InputError: the drive's problems (validate would refuse it).
    """
    checked = check_drive_file(drive, params, vehicle, fmt, part, split)
    a = checked.assessment
    stated = (
        {}
        if a.accuracy is None
        else {"gnss_accuracy": a.accuracy | {"max_h_acc_m": params.validate.gnss.max_h_acc_m}}
    )
    return {
        "file": checked.file,
        "vehicle": vehicle,
        "rows": checked.table.num_rows,
        "seconds": a.n_seconds,
        "seconds_kept": a.seconds_kept,
        "segments": len(a.segments),
        "cut_seconds_by_rule": {r: n for r, n in a.cut_seconds_by_rule.items() if n},
        **checked.checks,
        "columns": checked.columns,
        "notes": list(dict.fromkeys([*checked.reader_notes, *checked.notes])),
        **stated,
    }


def _accuracy(acc: dict[str, Any]) -> str:
    """The receiver's stated accuracy, and what validate does with it."""
    bound = acc["max_h_acc_m"]
    does = (
        "validate.gnss.max_h_acc_m not set: not screened"
        if bound is None
        else f"validate.gnss.max_h_acc_m {bound:g} m: a fix stated worse, or stating none, "
        "is cut as low_sats"
    )
    if not acc["stated_rows"]:
        return f"none stated on its {acc['fix_rows']} fixes ({does})"
    return (
        f"median {acc['median_m']:g} m, 95th percentile {acc['p95_m']:g} m, largest "
        f"{acc['max_m']:g} m, stated on {acc['stated_rows']} of {acc['fix_rows']} fixes ({does})"
    )


def _gain(record: dict[str, Any]) -> str:
    return f"{record['gain']:.3g} ± {record['gain_se']:.2g}"


# what each check against GNSS says when told, by its record's key (the checks and
# their names: TOLD_CHECKS)
_TOLD: dict[str, Callable[[dict[str, Any], str], str]] = {
    "radius": lambda r, car: (
        f"{r['implied_m']:.4g} m implied over {r['moving_s']} moving s against "
        f"{car}'s nominal {r['nominal_m']:.4g} m: the wheel speeds' unit fits"
    ),
    "yaw_rate": lambda r, _: (
        f"turns as the GNSS course turns (gain {_gain(r)} over {r['seconds']} pairs of seconds)"
    ),
    "wheel_sides": lambda r, _: (
        f"in their columns (rear gain {_gain(r['rear'])}, front {_gain(r['front'])}"
        + (f"; diagonal {_gain(r['diagonal'])}" if r["diagonal"]["gain"] is not None else "")
        + ")"
    ),
    "wheel_axles": lambda r, _: (
        f"in their columns (gain {_gain(r)}, {r['tight_turns']} pairs of seconds in tight turns)"
    ),
}


def render(out: dict[str, Any]) -> str:
    """What :func:`run` found, as lines for a person."""
    cut = ", ".join(f"{rule} {n} s" for rule, n in out["cut_seconds_by_rule"].items())
    lines = [
        f"{out['file']}: {out['rows']} rows, {out['seconds']} s; {out['seconds_kept']} s "
        f"valid in {out['segments']} segment(s)" + (f" (cut: {cut})" if cut else ""),
        *(f"  note: {n}" for n in out["notes"]),
    ]
    if "gnss_accuracy" in out:
        lines.append(f"  stated horizontal accuracy: {_accuracy(out['gnss_accuracy'])}")
    for key, name in TOLD_CHECKS:
        record = out[key]
        said = (
            _TOLD[key](record, out["vehicle"])
            if record.get("checked")
            else f"not told: {record.get('note', 'no reason given')}"
        )
        lines.append(f"  {name}: {said}")
    lines.append(f"{out['file']}: validate would accept it as {out['vehicle']}'s drive")
    return "\n".join(lines)
