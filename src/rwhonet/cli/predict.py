"""``rwhonet predict``: a drive streamed through a served model, one corrected second at a time.

Reads the drive (a file, or ``-`` for stdin) block by block as it arrives
(:func:`rwhonet.data.incremental.read_rows`), cuts whole seconds and corrects them
(:class:`rwhonet.serve.stream.SecondStream`), and writes each block of seconds
as soon as it is complete: CSV (``-`` for stdout, flushed after every block,
so the command can sit in a pipe) or Parquet (one row group per block). Runs
the model's ONNX graph in ONNX Runtime: neither torch nor Lightning is imported;
MLflow only to fetch a registered model. During each ``--outage`` the navigation
filter (:mod:`rwhonet.serve.navigation`) gives the car's position and its
covariance each second; the summary gives the position at the outage's end and
its distance to the GNSS fix there, where the file has one.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterable
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from rwhonet.data.glitches import WHEEL_GLITCH_G, YAW_RATE_LIMIT_RAD_S
from rwhonet.errors import InputError, Problem
from rwhonet.serve.stream import BRIDGE_MAX_S, COLUMNS, Outage, SecondStream

STDIO = "-"
# Seconds held back, at most, while the wheel-unit check waits for GNSS: a live stream that
# starts without a fix (a tunnel, a car park) is not held to its end. Validate's check
# needs radius_min_moving_s (30) moving seconds with GNSS; 120 s leaves room for stops.
HOLD_MAX_S = 120
STEPS_KEPT = 100  # time steps kept from the first rows, to say why a drive made no second
DEFAULTS = "validate_defaults.yaml"  # validate's settings outside a project
# times to the millisecond, degrees to 1e-8 (about a millimetre), metres to 0.1 mm
DECIMALS = {"t_s": 3, "elapsed_s": 3, "lat_deg": 8, "lon_deg": 8}


def output_file(path: str, what: str, option: str = "--output") -> Path:
    """The file a command is to write, its folder made where missing (as ``export`` did).

    Raises:
        InputError: the path is a folder, or its folder cannot be made (named with the
            option and what it was expected to be).
    """
    out = Path(path)
    if out.is_dir():
        raise InputError(
            [Problem(option, None, None, f"{what} to write", f"{path}: a folder")],
            f"bad {option}",
        )
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        found = f"{path}: its folder cannot be made ({getattr(err, 'strerror', None) or err})"
        problem = Problem(option, None, None, f"{what} to write", found)
        raise InputError([problem], f"bad {option}") from None
    return out


def no_seconds_problem(
    name: str, names: dict[str, str], steps: list[float], period_s: float
) -> Problem:
    """Why a drive with rows made no whole second: its time steps, named with the column
    (``predict`` refuses such a drive when its median step is not within a factor of two
    of the sample period; one shorter than a second passes with 0 seconds)."""
    step = float(np.median(steps))
    return Problem(
        name,
        None,
        names.get("t_s", "t_s"),
        f"rows {period_s:g} s apart (validate.sample_period_s), in seconds, that make whole "
        "seconds without a gap",
        f"a median time step of {step:.6g} s over the first {len(steps) + 1} rows: no second "
        "was made",
        "a time in milliseconds needs a column map that says so (t: {column: ..., unit: ms}); "
        "a drive logged at another rate is resampled by the stream formats (--format "
        "stream_csv)",
    )


class CsvSink:
    """CSV rows as they come; empty cells for missing values; flushed after every block."""

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        out.write(",".join(COLUMNS) + "\n")
        out.flush()

    def write(self, block: dict[str, np.ndarray]) -> None:
        n = len(block["t_s"])
        if not n:
            return
        cells = [
            block[name].tolist()
            if name == "outage"
            else _format(block[name], DECIMALS.get(name, 4))
            for name in COLUMNS
        ]
        self.out.write("".join(",".join(row) + "\n" for row in zip(*cells, strict=True)))
        self.out.flush()

    def close(self) -> None:
        self.out.flush()


def _format(values: np.ndarray, decimals: int) -> list[str]:
    # Python's own formatting, not np.char.mod: that C loop ran a signal's handler and
    # lost the exception it raised (rwhonet.libraries.raise_if_interrupted)
    spec = f".{decimals}f"
    return ["" if v != v else format(v, spec) for v in values.tolist()]


class ParquetSink:
    """One Parquet row group per block (``pyarrow.parquet.ParquetWriter``)."""

    def __init__(self, path: Path) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.pa = pa
        self.schema = pa.schema(
            [(name, pa.string() if name == "outage" else pa.float64()) for name in COLUMNS]
        )
        self.writer = pq.ParquetWriter(str(path), self.schema)

    def write(self, block: dict[str, np.ndarray]) -> None:
        if len(block["t_s"]):
            arrays = [
                self.pa.array(
                    block[name].tolist() if name == "outage" else block[name], type=field.type
                )
                for name, field in zip(COLUMNS, self.schema, strict=True)
            ]
            self.writer.write_table(self.pa.Table.from_arrays(arrays, schema=self.schema))

    def close(self) -> None:
        self.writer.close()


def model_path(spec: str, tracking_uri: str | None, dest: Path | None = None) -> Path:
    """The local path of ``--model``: a registry URI fetched from the project's MLflow
    store (into ``dest``, a temporary folder when None), else the path as given.

    Raises:
        InputError: a registry URI with no project store, or one the store cannot give.
    """
    if not spec.startswith(("models:/", "runs:/")):
        return Path(spec)
    from rwhonet.tracking.registry import resolve_model

    if tracking_uri is None:
        raise InputError(
            [
                Problem(
                    "--model",
                    None,
                    None,
                    "a project (params.yaml) whose MLflow store holds the model",
                    "none found",
                )
            ]
        )
    return resolve_model(spec, tracking_uri, dest)


def open_model(spec: str, tracking_uri: str | None) -> Any:
    """A served model from a path (``.onnx``, bundle or MLflow model folder) or a registry URI
    (fetched into a scratch folder, removed once the model is loaded: a session holds it)."""

    from rwhonet.io import scratch_dir
    from rwhonet.serve.model import load_served

    if not spec.startswith(("models:/", "runs:/")):
        return load_served(model_path(spec, tracking_uri))
    with scratch_dir("model") as scratch:
        return load_served(model_path(spec, tracking_uri, Path(scratch) / "model"))


def run(
    model: Any,
    drive: str,
    output: str,
    outages: list[Outage],
    *,
    fmt: str = "iovnbd",
    column_map: Any = None,
    max_gap_s: float = 0.5,
    stdin: IO[bytes] | None = None,
    stdout: IO[str] | None = None,
    period_s: float = 0.1,
    drive_blocks: tuple[dict[str, str], Iterable[tuple[int, dict[str, np.ndarray]]]] | None = None,
    unit_check: UnitCheck | None = None,
    stream_glitches: list[tuple[str, int, float, str]] | None = None,
    drive_notes: Iterable[str] = (),
    gnss_lag: str | float = "report",
) -> dict[str, Any]:
    """Stream ``drive`` through ``model`` into ``output``; return counts and the outage summary.

    A CSV drive (IO-VNBD, a column map) is read as it arrives; a drive in a stream format
    comes read and resampled already (``drive_blocks``: the source's channel names and the
    row blocks, :func:`rwhonet.cli.drive.canonical_blocks`, with the resampler's glitch
    flags, which the stream repairs; ``stream_glitches``: the glitched samples the
    resampler found, for the summary; ``drive_notes``: what the resampler left out, for
    the summary too). A CSV table logged faster than the grid is resampled as ingest
    resamples it, its fixes' lag as ``gnss_lag`` says (``data.gnss_lag``). A file output
    is written beside its name and put in place when the drive is through: a refused drive
    leaves no half-written output.

    A row that repeats an earlier row in every column, the time included (a sample
    written twice), and a row with an empty wheel speed (a lost sample: its second gives no
    output and ends a run of seconds, as a dropped row's) are dropped as ingest drops them
    (:class:`rwhonet.data.droprows.RowFilter`; ``drive_notes`` says which); messages still
    name the file's rows. Fixes held from a slower receiver (the last fix written into
    every row until the next) are placed along the wheels' path as ingest places them
    (:class:`rwhonet.data.heldfixes.HeldFixGate`: such a drive is read to its end before
    its first second is written; ``drive_notes`` says so). A row whose fix
    validate's GNSS policy would not use (latitude = longitude = 0, fewer than
    ``validate.gnss.min_sats`` satellites where the drive counts them) is taken as a row
    without a fix (:class:`rwhonet.data.incremental.FixScreen`; ``fix_note`` says how many).
    The wheel speeds' unit is checked as validate checks it (the tyre radius they imply
    against the GNSS distance, :class:`rwhonet.data.drivechecks.StreamRadiusCheck`), as
    ``unit_check`` says (:class:`UnitCheck`; None: its defaults), and a yaw rate's unit and
    sign as validate checks them (the GNSS course's turn against it). No second is written
    before the checks have decided: a drive whose wheel speeds do not fit, or whose yaw rate
    turns the wrong way, is refused with nothing written, also on stdout. At most
    :data:`HOLD_MAX_S` seconds are held: a drive still undecided then (no fix yet) is
    written on, unchecked, with a note on stderr, and still refused (exit 2) if the check
    fails later.
    """
    from rwhonet.data.columnar import is_table_folder, open_as_csv, table_kind
    from rwhonet.data.compressed import compressed_note, compression_of, open_decompressed
    from rwhonet.data.drivechecks import DEFAULT_TRACK_M, StreamRadiusCheck
    from rwhonet.data.droprows import RowFilter
    from rwhonet.data.heldfixes import HeldFixGate
    from rwhonet.data.incremental import FixScreen, read_rows
    from rwhonet.libraries import raise_if_interrupted

    packed = table = None  # a compressed drive file's kind, a table file's
    with ExitStack() as stack:
        if drive_blocks is not None:
            source, name = None, drive
        elif drive == STDIO:
            source, name = stdin or sys.stdin.buffer, "<stdin>"
        else:
            path = Path(drive)
            if not path.is_file() and not is_table_folder(path):  # Spark's part files: a table
                raise InputError(
                    [
                        Problem(
                            drive,
                            None,
                            None,
                            "a drive file (IO-VNBD CSV), or - for stdin",
                            "a folder (give its --format)" if path.is_dir() else "no such file",
                        )
                    ]
                )
            # a Racelogic VBOX file (here or on stdin): read_rows reads it as the CSV it
            # stands for; a compressed file as the text it holds, decompressed as it is read
            # a Parquet or Feather table as the CSV it holds, a record batch at a time
            packed, table = compression_of(path), table_kind(path)
            if table is not None:
                opened, held = open_as_csv(path, table, drive)
            elif packed is None:
                opened = open(path, "rb")
            else:
                opened = open_decompressed(path, packed, drive)
            source, name = stack.enter_context(opened), drive
        final = None if output == STDIO else output_file(output, "a CSV or .parquet file")
        partial = None if final is None else final.with_name(f".{final.name}.partial")
        if final is None:
            sink: Any = CsvSink(stdout or sys.stdout)
        elif output.endswith(".parquet"):
            sink = ParquetSink(partial)
        else:
            sink = CsvSink(open(partial, "w", encoding="utf-8", newline=""))  # closed below
        seconds = rows = 0
        done = False
        try:
            read_notes: list[str] = []  # how the rows were read (text times, ';'), as filled
            uc = unit_check or UnitCheck()
            vp = uc.validate or default_validate()
            # the car's radius: the wheel-unit check's, and a column map's km/h divided by it
            nominal = uc.nominal_radius_m or float(np.mean(model.meta.source_radii))
            if drive_blocks is not None:
                names, blocks = drive_blocks
            else:
                lay, blocks = read_rows(
                    source,
                    name,
                    fmt,
                    column_map,
                    period_s=period_s,
                    radius_m=nominal,
                    split_gap_s=vp.gnss.max_gap_s,
                    gnss_lag=gnss_lag,
                )
                names, read_notes = lay.names, lay.notes
                if table is not None:
                    read_notes.insert(0, held.note)
                elif packed is not None:
                    read_notes.insert(0, compressed_note(packed))
            # a row written twice, or without a wheel speed, is dropped, as ingest drops
            # it (before the fix screen, which would take a copy's fix as one that did not
            # move)
            dropped = RowFilter()
            blocks = dropped.blocks(iter(blocks))
            # fixes held from a slower receiver are placed along the path, as ingest places
            # them (such a drive is read to its end first: a row's place needs the next fix)
            held_fixes = HeldFixGate(period_s)
            blocks = held_fixes.blocks(blocks)
            # a fix validate would not use (satellites, a jump, a frozen receiver) is none
            fixes = FixScreen(vp.gnss.min_sats, vp.gnss, vp.sample_period_s)
            blocks = fixes.blocks(blocks)
            check = StreamRadiusCheck(
                {"source_file": name, "columns": names, "vehicle": "the car"},
                nominal,
                vp,
                uc.radius_from
                or f"--nominal-radius (without it: the model's source radius, {nominal:.4g} m)",
                track_m=uc.track_rear_m or DEFAULT_TRACK_M,
            )
            stream = SecondStream(
                model,
                outages,
                file=name,
                names=names,
                max_gap_s=max_gap_s,
                period_s=period_s,
                period_tol_s=vp.sample_period_tol_s,
                unit_check=check,
                track_rear_m=uc.track_rear_m,
            )
            held: list[dict[str, np.ndarray]] = []  # seconds not written before the check
            n_held, released = 0, False
            steps: list[float] = []  # the first rows' time steps, to say why no second came
            for first, columns in blocks:
                raise_if_interrupted()  # a stop a C library's signal check lost
                if len(steps) < STEPS_KEPT:
                    with np.errstate(invalid="ignore"):  # inf - inf: NaN, told by the checks
                        steps += np.diff(columns["t_s"][: STEPS_KEPT + 1]).tolist()
                held.append(stream.push(first, columns))
                n_held += len(held[-1]["t_s"])
                # the file's last data row (rows put in time order come in runs of the file's)
                rows = max(rows, first + len(columns["t_s"]) - 1)
                if not check.decided and not released and n_held >= HOLD_MAX_S:
                    released = True  # the check goes on; a later refusal still exits 2
                    print(released_note(name, HOLD_MAX_S), file=sys.stderr)
                if check.decided or released:
                    for block in held:
                        sink.write(block)
                        seconds += len(block["t_s"])
                    held, n_held = [], 0
            held.append(stream.finish())  # a last second held for a row after it
            unit_note = check.finish()
            for block in held:
                sink.write(block)
                seconds += len(block["t_s"])
            if dropped.problems(name, names):  # a wheel channel empty, or at its own rate
                raise InputError(dropped.problems(name, names))
            if not seconds and steps and not 0.5 <= np.median(steps) / period_s <= 2.0:
                raise InputError([no_seconds_problem(name, names, steps, period_s)])
            done = True
        finally:
            sink.close()
            if final is not None:
                if isinstance(sink, CsvSink):
                    sink.out.close()
                if done:
                    os.replace(partial, final)
                else:
                    partial.unlink(missing_ok=True)
    return {
        "rows": rows,
        "seconds": seconds,
        "outages": stream.summary(),
        "file": name,
        "glitches": stream.glitches,
        "backwards_s": list(stream.backwards_s),
        "gaps": list(stream.gaps),
        "max_gap_s": max_gap_s,
        "stream_glitches": list(stream_glitches or []),
        "drive_notes": [
            *drive_notes,
            *(f"{name}: {note}" for note in read_notes),
            *dropped.notes(name),
            *([f"{name}: {held_fixes.note}"] if held_fixes.note else []),
        ],
        "unit_note": unit_note,
        "yaw_note": check.yaw_note,
        "sides_note": check.sides_note,
        "axles_note": check.axles_note,
        "fix_note": fixes.note(name),
    }


@dataclass(frozen=True)
class UnitCheck:
    """How :func:`run` checks the wheel speeds' unit.

    Attributes:
        validate: validate's settings (``params.validate``; None: :func:`default_validate`).
        nominal_radius_m: the car's nominal tyre radius (None: the model's source radius).
        radius_from: where that radius came from, for the report (``--nominal-radius``...).
        track_rear_m: the car's rear track (``--track-rear``, ``--vehicle-file``): the
            scale of the wheels' yaw in 2D dead reckoning and in the wheel-sides check
            (None: the navigation filter's default and the check's
            :data:`~rwhonet.data.drivechecks.DEFAULT_TRACK_M`).
    """

    validate: Any = None
    nominal_radius_m: float | None = None
    radius_from: str | None = None
    track_rear_m: float | None = None


def released_note(name: str, hold_s: int) -> str:
    """What predict says when it stops holding seconds back for the wheel-unit check."""
    return (
        f"{name}: the wheel-unit check has not decided after {hold_s} s (no GNSS fix yet, or "
        "too few moving seconds): seconds are written unchecked from here; the check goes on, "
        "and a drive it refuses later still exits 2 (a --output file is then not written; "
        "what went to stdout stays)"
    )


def default_validate() -> Any:
    """``validate`` as the project's params.yaml ships it, for ``predict`` outside a project
    (``validate_defaults.yaml`` beside this module; a test holds the two equal)."""
    from importlib.resources import files

    import yaml

    from rwhonet.config import ValidateParams, parse_value

    text = files("rwhonet.cli").joinpath(DEFAULTS).read_text(encoding="utf-8")
    raw = yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    return parse_value(ValidateParams, raw, f"rwhonet/cli/{DEFAULTS}")


def _position_text(o: dict[str, Any]) -> str:
    """The filter's end-of-outage position, and its error where GNSS is there to compare."""
    if math.isnan(o.get("east_end_m", math.nan)):
        return (
            "; position: none at its end (the filter had no GNSS course yet, or a logger gap "
            f"of more than {BRIDGE_MAX_S:g} s inside the outage started it afresh)"
        )
    yaw = "gyro + wheels" if o["control"] == "fused" else "wheels alone (no yaw rate)"
    if o["control"] == "fused" and o.get("gyro_s", o["seconds"]) < o["seconds"]:
        yaw += f", wheels alone in {o['seconds'] - o['gyro_s']} s without one"
    how = (
        "calibrated on the model's target training drives"
        if o["calibrated"]
        else "the filter's own, not calibrated"
    )
    text = (
        f"; position at the end {o['east_end_m']:.1f} m east, {o['north_end_m']:.1f} m north "
        f"of the last fix before it ({o['lat_end_deg']:.6f}, {o['lon_end_deg']:.6f}; "
        f"68 % / 95 % within {o['r68_end_m']:.1f} / "
        f"{o['r95_end_m']:.1f} m, {how}; yaw: {yaw})"
    )
    if math.isnan(o["pos_err_end_m"]):
        return text + ", no GNSS fix at the end to compare"
    return text + f", {o['pos_err_end_m']:.1f} m from the GNSS fix"


def glitch_lines(
    glitches: list[dict[str, Any]],
    listed: int = 5,
    samples: list[tuple[str, int, float, str]] | None = None,
) -> list[str]:
    """What the stream repaired: wheel samples that changed faster than any tyre can, yaw
    rates beyond any car's.

    ``samples``: a stream drive's glitched samples as the resampler found them (stream,
    sample row, time, channel); the grid rows whose means used them are among the rows
    repaired.
    """
    lines = []
    if samples:
        shown = _first_few(
            samples, listed, lambda x: f"{x[0]} sample row {x[1]} (t = {x[2]:.6g} s), {x[3]!r}"
        )
        lines.append(
            f"stream glitch: {len(samples)} wheel-speed sample(s) of the drive's streams rose "
            f"faster than any tyre can (> {WHEEL_GLITCH_G:g} g above the other wheels): "
            f"{shown}; the grid rows whose means used them were repaired as below"
        )
    wheels = [g for g in glitches if not g.get("yaw")]
    yaws = [g for g in glitches if g.get("yaw")]
    if wheels:
        lines.append(
            f"wheel glitch: {len(wheels)} sample(s) rose faster than any tyre can (> "
            f"{WHEEL_GLITCH_G:g} g above the other wheels) and were replaced by the wheel's own "
            f"speed interpolated across them: {_listed(wheels, listed)}"
        )
    if yaws:
        lines.append(
            f"yaw-rate glitch: {len(yaws)} sample(s) lay beyond any car's yaw rate (|rate| > "
            f"{YAW_RATE_LIMIT_RAD_S:g} rad/s, {math.degrees(YAW_RATE_LIMIT_RAD_S):.0f} deg/s: "
            "a logger's glitch or a signal's invalid code) and were replaced by the rate "
            f"interpolated across them: {_listed(yaws, listed)}"
        )
    return lines


def _listed(glitches: list[dict[str, Any]], listed: int) -> str:
    return _first_few(
        glitches,
        listed,
        lambda g: (
            f"row {g['row']} (t = {g['t_s']:.6g} s), {g['channel'].strip()!r}: "
            f"{g['found_rad_s']:.4g} -> {g['replaced_rad_s']:.4g} rad/s"
        ),
    )


def _first_few(items: list[Any], listed: int, say: Callable[[Any], str]) -> str:
    """The first ``listed`` items as ``say`` words each, then how many more there are."""
    more = f"; and {len(items) - listed} more" if len(items) > listed else ""
    return "; ".join(say(x) for x in items[:listed]) + more


def reversing_lines(elapsed_s: list[float]) -> list[str]:
    """A line naming the seconds a logger that signs its wheel speeds told as reversing.

    Args:
        elapsed_s: each such second's end, s after the drive's first row (as ``--outage``
            counts; :attr:`rwhonet.serve.stream.SecondStream.backwards_s`).
    """
    if not elapsed_s:
        return []
    return [
        f"reversing: the signed wheel speeds say the car went backwards in {len(elapsed_s)} s "
        f"(the seconds ending {elapsed_s[0]:.6g} ... {elapsed_s[-1]:.6g} s into the drive); "
        "the position moves backwards there, the distances are magnitudes"
    ]


def gap_lines(gaps: list[dict[str, Any]], max_gap_s: float, listed: int = 5) -> list[str]:
    """Lines on the splits in the rows (``SecondStream.gaps``): the logger's gaps and its
    dropped samples, where, how long, and whether the navigation filter went on across each."""
    if not gaps:
        return []

    def one(g: dict[str, Any]) -> str:
        text = f"{g['gap_s']:.3g} s after {g['from_s']:.6g} s"
        if g["bridged"]:
            return text + " (the position carried across)"
        if g["filtering"]:
            return text + " (the position filter started afresh)"
        return text

    lines = []
    long = [g for g in gaps if not g.get("dropped")]
    dropped = [g for g in gaps if g.get("dropped")]
    if long:
        lines.append(
            f"logger gap: {len(long)} time step(s) longer than {max_gap_s:g} s, each ending a "
            f"run of seconds (the rows up to the next whole second give no second): "
            f"{_first_few(long, listed, one)}"
        )
    if dropped:
        lines.append(
            f"dropped samples: {len(dropped)} time step(s) that skip a slot of the sample "
            f"grid (at most {max_gap_s:g} s), each cutting its second as validate does "
            f"(partial_second) and ending a run of seconds: {_first_few(dropped, listed, one)}"
        )
    if any(g["bridged"] for g in gaps):
        lines.append(
            "  across a gap of at most "
            f"{BRIDGE_MAX_S:g} s the filter takes the wheel speeds and the yaw rate as "
            "changing linearly and widens its spread by how fast they changed on this drive"
        )
    if any(g["filtering"] and not g["bridged"] for g in gaps):
        lines.append(
            "  after a longer gap (or one before the filter had a GNSS course) it waits for "
            "the next course: inside an outage, no position until the outage ends"
        )
    return lines


def render_summary(out: dict[str, Any]) -> str:
    """The outage summary printed on stderr."""
    lines = [f"{out['file']}: {out['rows']} rows -> {out['seconds']} seconds"]
    lines += out.get("drive_notes", [])
    lines += glitch_lines(out.get("glitches", []), samples=out.get("stream_glitches"))
    lines += [
        out[k]
        for k in ("fix_note", "unit_note", "yaw_note", "sides_note", "axles_note")
        if out.get(k)
    ]
    lines += reversing_lines(out.get("backwards_s", []))
    lines += gap_lines(out.get("gaps", []), out.get("max_gap_s", math.nan))
    for o in out["outages"]:
        if not o["seconds"]:
            lines.append(f"outage {o['outage']} s: no second of the drive falls in it")
            continue
        if math.isnan(o["dist_gnss_m"]):
            lines.append(
                f"outage {o['outage']} s ({o['seconds']} s): WPM {o['dist_wpm_m']:.1f} m, "
                f"corrected {o['dist_corrected_m']:.1f} m (no GNSS to compare)" + _position_text(o)
            )
            continue
        lines.append(
            f"outage {o['outage']} s ({o['seconds']} s, GNSS {o['dist_gnss_m']:.1f} m): "
            f"WPM CRSE {o['crse_wpm_m']:.2f} m, CTE {o['cte_wpm_m']:.2f} m; corrected CRSE "
            f"{o['crse_corrected_m']:.2f} m, CTE {o['cte_corrected_m']:.2f} m" + _position_text(o)
        )
    return "\n".join(lines)
