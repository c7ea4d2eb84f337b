"""``rwhonet``: the project's command line (``rwhonet <command> --help`` for each).

Commands: ``recalibrate`` (G recalibrated on a new car's drive, registered as a
new version of ``whonet-R-<vehicle>``), ``predict`` (a drive streamed through a
model, second by second), ``export`` (a model as one ``.onnx`` file), ``gate``
(the CI regression gate, also installed as ``rwhonet-gate``).

Bad input ends a command with the project's report (file, row, column,
expected, found, what to do) on stderr and exit status 2; a bug with its
traceback and status 1; SIGTERM, SIGINT or SIGHUP with status 128 + the signal's
number, after the command has unwound (:func:`rwhonet.libraries.interruptible`:
``predict``'s half-written output and ``recalibrate``'s temporary files removed). Each
command imports only what it needs: ``predict`` never imports torch or Lightning.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from rwhonet import contracts
from rwhonet.config import ConfigError
from rwhonet.errors import InputError

EXIT_INPUT = 2
PROG = "rwhonet"


def _project(required: bool) -> tuple[Any, str | None]:
    """The project's params and resolved tracking URI (None, None outside a project)."""
    from rwhonet import paths

    if not paths.PARAMS.is_file():
        if required:
            raise InputError([_no_project(paths.PARAMS)], "no project here")
        return None, None
    from rwhonet.config import load_params
    from rwhonet.tracking.client import resolve_tracking_uri

    params = load_params(paths.PARAMS)
    return params, resolve_tracking_uri(params.tracking.tracking_uri)


def _params_here() -> Any:
    """The project's params when the command runs in one (None outside a project)."""
    from rwhonet import paths

    if not paths.PARAMS.is_file():
        return None
    from rwhonet.config import load_params

    return load_params(paths.PARAMS)


def _no_project(path: Path) -> Any:
    from rwhonet.errors import Problem

    return Problem(
        str(path),
        None,
        None,
        "a project folder (params.yaml, dvc.yaml)",
        "none here",
        "run the command inside the project (or set RWHONET_ROOT to it)",
    )


def _drive_params(params: Any, args: argparse.Namespace, vehicle: str) -> Any:
    """The params with the car and the format the command line gives (cli.drive)."""
    from rwhonet.cli.drive import with_car, with_format

    params = with_car(params, vehicle, args.nominal_radius, args.track_rear, args.vehicle_file)
    return with_format(params, args.format, args.signal_map)


def _recalibrate(args: argparse.Namespace) -> int:
    from rwhonet.cli import recalibrate

    params, uri = _project(required=True)
    source_nominal = recalibrate.car_nominal_m(
        params, params.data.roles[contracts.SOURCE_TRAIN].vehicle
    )
    params = _drive_params(params, args, args.vehicle)
    out = recalibrate.run(
        params,
        base=args.base,
        drive=Path(args.drive),
        seconds=args.seconds,
        recipe=args.recipe,
        fmt=args.format,
        vehicle=args.vehicle,
        seed=args.seed,
        tracking_uri=uri,
        evidence=args.evidence,
        source_nominal_m=source_nominal,
        drive_id=args.drive_id,
    )
    print(recalibrate.render(out))
    return 0


def _predict(args: argparse.Namespace) -> int:
    from rwhonet.cli import predict
    from rwhonet.serve.stream import parse_outage

    outages = [parse_outage(o) for o in args.outage]
    params = uri = None
    plain = args.format == "iovnbd" and args.signal_map is None and args.drive_id is None
    if args.model.startswith(("models:/", "runs:/")) or not plain:
        params, uri = _project(required=True)
    else:  # a model file and a 10 Hz CSV: the project's validate and cars, where there is one
        params = _params_here()
    column_map, drive_blocks, stream_glitches, period_s = None, None, None, 0.1
    drive_notes: tuple[str, ...] = ()
    validate, nominal, radius_from = None, args.nominal_radius, None
    if args.vehicle_file is not None:
        radius_from = f"--vehicle-file {args.vehicle_file}"
    elif args.nominal_radius is not None:
        radius_from = "--nominal-radius"
    track = args.track_rear  # the car's rear track: the wheels' yaw in dead reckoning
    if params is None and args.vehicle_file is not None:
        from rwhonet.cli.drive import vehicle_from_file

        car = vehicle_from_file(args.vehicle_file)
        nominal, track = car.nominal_radius_m, car.track_rear_m
    if params is not None:
        from rwhonet.cli.drive import PREDICT_CAR, canonical_blocks
        from rwhonet.data.drivefile import COLUMN_MAP, fleet_column, reader_kind

        params = _drive_params(params, args, PREDICT_CAR)
        period_s = params.validate.sample_period_s
        validate = params.validate
        if radius_from is not None:  # the car of the command line (else the model's radius)
            nominal = params.nominal_radius_m(PREDICT_CAR)
            track = params.track_rear_m(PREDICT_CAR)  # given, or data.vehicles.target's
        kind = reader_kind(args.format, params.data)
        fleet = fleet_column(args.format, params.data) is not None
        if kind == COLUMN_MAP and not fleet and args.drive_id is None:
            column_map = params.data.column_maps[args.format]
        elif kind != "iovnbd" or args.drive_id is not None:
            # a folder or an MDF4 file, a drive of a file of many: read whole, then streamed on
            if args.drive == "-":
                from rwhonet.errors import Problem

                raise InputError(
                    [
                        Problem(
                            "--drive",
                            None,
                            None,
                            f"a path: a {args.format} drive is a folder or a file, not a "
                            "stream on stdin (only CSV formats read stdin)",
                            "-",
                        )
                    ]
                )
            whole = canonical_blocks(
                Path(args.drive), params, PREDICT_CAR, args.format, part=args.drive_id
            )
            drive_blocks = (whole.names, whole.blocks)
            stream_glitches, drive_notes = whole.glitch_samples, whole.notes
    model = predict.open_model(args.model, uri)
    out = predict.run(
        model,
        args.drive if args.drive_id is None else f"{args.drive} (drive {args.drive_id})",
        args.output,
        outages,
        fmt=args.format,
        column_map=column_map,
        max_gap_s=args.max_gap,
        period_s=period_s,
        drive_blocks=drive_blocks,
        unit_check=predict.UnitCheck(validate, nominal, radius_from, track),
        stream_glitches=stream_glitches,
        drive_notes=drive_notes,
        gnss_lag=params.data.gnss_lag if params is not None else "report",
    )
    if not args.quiet:
        print(predict.render_summary(out), file=sys.stderr)
    else:  # repaired or unchecked input is never silent
        said = [
            *out["drive_notes"],
            *predict.glitch_lines(out["glitches"], samples=out["stream_glitches"]),
            *(out[k] for k in ("fix_note", "unit_note") if out[k]),
        ]
        if said:
            print("\n".join(said), file=sys.stderr)
    return 0


def _checked_drives(
    args: argparse.Namespace, params: Any, scratch: Path
) -> list[tuple[str, str | None, tuple[Path, str] | None]]:
    """The drives ``check`` reads: each --drive, and of a file of many drives (its format's
    column map names each row's drive) every one of them, split once into ``scratch``, or
    --drive-id's."""
    from rwhonet.cli.drive import fleet_parts

    out: list[tuple[str, str | None, tuple[Path, str] | None]] = []
    for k, drive in enumerate(args.drive):
        if args.drive_id is not None:
            out.append((drive, args.drive_id, None))
            continue
        parts = None
        if Path(drive).is_file():
            dest = scratch / str(k)
            dest.mkdir()
            try:
                parts = fleet_parts(Path(drive), params, args.format, dest)
            except InputError:
                parts = None  # check.run reads it and says why it cannot
        out += [(drive, None, None)] if not parts else [(drive, p.part, p.split) for p in parts]
    return out


def _check(args: argparse.Namespace) -> int:
    from rwhonet.cli import check
    from rwhonet.io import scratch_dir

    params, _ = _project(required=True)
    params = _drive_params(params, args, args.vehicle)
    try:  # the car's radius and track: the checks against GNSS need them
        params.nominal_radius_m(args.vehicle)
    except ConfigError as err:
        raise ConfigError(
            f"--vehicle {args.vehicle}: not a car params.yaml knows ({err}); give its "
            "--nominal-radius (and --track-rear) or --vehicle-file"
        ) from err
    outs, problems, refused = [], [], []
    with scratch_dir("fleet") as scratch:  # files of many drives, split once
        drives = _checked_drives(args, params, Path(scratch))
        for drive, part, split in drives:  # each one's verdict; the refused ones' together
            try:
                outs.append(check.run(params, Path(drive), args.format, args.vehicle, part, split))
            except InputError as err:
                problems += err.problems
                refused.append(drive if part is None else f"{drive} (drive {part})")
    if args.json and (outs or len(drives) > 1):
        print(json.dumps(outs[0] if len(drives) == 1 else outs, indent=1, default=str))
    elif outs:
        print("\n\n".join(check.render(out) for out in outs))
    if refused:
        summary = f"{len(problems)} problem(s)" + (
            f" in {len(refused)} of {len(drives)} drives ({', '.join(refused)})"
            if len(drives) > 1
            else f" in {refused[0]}"
        )
        raise InputError(problems, summary)
    return 0


def _export(args: argparse.Namespace) -> int:
    from rwhonet.cli import export

    params, uri = _project(required=args.model.startswith(("models:/", "runs:/")))
    wpm_mode = params.label.wpm_mode if params is not None else "integrated"
    out = export.run(args.model, args.output, uri, wpm_mode)
    meta = out["meta"]
    radii = f", own WPM radii {meta.wpm_radii}" if meta.wpm_radii else ""
    print(
        f"wrote {out['file']} ({out['bytes'] / 1024:.0f} KiB): ONNX opset 17, input x "
        f"(batch, {meta.seq_len}, {meta.n_features}) float32, output pred_m (batch,); scaler "
        f"and source radii {meta.source_radii} in its metadata{radii}; max |ONNX - PyTorch| "
        f"{out['diff']:.2g} m over 1000 windows"
    )
    return 0


FORMAT_HELP = (
    "the drive's format: iovnbd (an IO-VNBD CSV, 10 Hz), comma2k19 (an openpilot segment "
    "folder; wheel speeds in m/s, so give the car's radius), a column map or a signal map "
    "of params.yaml (data.column_maps, data.signal_maps), or mdf4 (an MDF4 file) / "
    "stream_csv (a folder with one CSV per stream) with --signal-map (default: %(default)s)"
)


def _drive_options(p: argparse.ArgumentParser) -> None:
    """The options that say how to read a drive and which car drove it."""
    p.add_argument("--format", default="iovnbd", help=FORMAT_HELP)
    p.add_argument(
        "--drive-id",
        default=None,
        metavar="ID",
        help="a file of many drives (its --format's column map names each row's drive: "
        "drive: {column: ..., unit: text}): the drive to read, by its id (default: the "
        "file's one drive; check: every drive of the file)",
    )
    p.add_argument(
        "--signal-map",
        default=None,
        metavar="FILE",
        help="for --format mdf4 or stream_csv: a YAML file naming each quantity's logged "
        "channel and unit, e.g. 'omega_fl: {column: WhlSpd_FL, unit: km/h}' (keys and units: "
        "docs/readers.md; stream_csv also needs t, the files' time column)",
    )
    p.add_argument(
        "--nominal-radius",
        type=float,
        default=None,
        metavar="M",
        help="a car not in params.yaml: its nominal tyre radius in metres (e.g. 0.362); "
        "checks the wheel speeds' unit and turns wheel speeds logged in m/s or km/h into "
        "rad/s",
    )
    p.add_argument(
        "--track-rear",
        type=float,
        default=None,
        metavar="M",
        help="with --nominal-radius: the car's rear track in metres (default: "
        "data.vehicles.target's; only 2D dead reckoning uses it)",
    )
    p.add_argument(
        "--vehicle-file",
        default=None,
        metavar="FILE",
        help="a car not in params.yaml, as a YAML file with the keys of data.vehicles: "
        "nominal_radius_m and track_rear_m",
    )


def _command(sub: Any, name: str, func: Any, **kwargs: Any) -> argparse.ArgumentParser:
    """A subcommand's parser, run by ``func`` (its options are added by the caller)."""
    p = sub.add_parser(name, **kwargs)
    p.set_defaults(func=func)
    return p


def parser() -> argparse.ArgumentParser:
    """The argument parser (every command, with its help)."""
    ap = argparse.ArgumentParser(
        prog=PROG,
        description="recalibrate a WhONet on a new car, stream corrected odometry, export ONNX",
    )
    sub = ap.add_subparsers(dest="command", required=True, metavar="COMMAND")

    rc = _command(
        sub,
        "recalibrate",
        _recalibrate,
        help="recalibrate G on a new car's drive and register the result",
        description="Read and validate a drive of a new car (the pipeline's ingest, validate "
        "and label code), recalibrate the base model on its first --seconds valid seconds by "
        "the params' recipe, score WPM, base and recalibrated model on the rest (mean CRSE/CTE "
        "per outage length of evaluate.outages_s), and register the result as a new version "
        "of whonet-R-<vehicle> in the project's MLflow Model Registry.",
    )
    rc.add_argument(
        "--base",
        default="models:/whonet-G/latest",
        help="the model to recalibrate: models:/<name>/<version|latest> or a model "
        "folder (default: %(default)s)",
    )
    rc.add_argument(
        "--drive",
        required=True,
        help="the new car's drive: a file (IO-VNBD or column-mapped CSV, MDF4, CAN log, "
        "ROS bag) or a folder (comma2k19 segment, stream CSVs), in --format",
    )
    rc.add_argument(
        "--seconds",
        type=int,
        default=None,
        help="m: recalibrate on the first m valid seconds (default: adapt.chosen_m, "
        "or adapt.fallback.m when params choose auto)",
    )
    rc.add_argument(
        "--recipe",
        default=None,
        help="shrink, paper, head, ridge_head, radius+G or steps (default: adapt.recipe, or "
        "adapt.fallback.recipe when auto: shrink, the radius refit shrunk towards the base "
        "model by what the seconds can tell)",
    )
    rc.add_argument(
        "--evidence",
        choices=("target", "source"),
        default=None,
        help="shrink only: whose drives size its update, as the base model carries them: the "
        "pipeline's target car's training drives (the default for that car) or the source "
        "car's drives with adapt.shrink.unknown_car_sd added to the prior (the default for "
        "any other car; its prior is then centred on the source calibration scaled by the "
        "car's nominal tyre radius over the source car's)",
    )
    _drive_options(rc)
    rc.add_argument(
        "--vehicle",
        default="target",
        help="the car: names the registered model whonet-R-<vehicle>; its nominal tyre "
        "radius comes from --nominal-radius or --vehicle-file, else data.vehicles, else (a "
        "car params do not know) the base model's source radius (default: %(default)s)",
    )
    rc.add_argument(
        "--seed",
        type=int,
        default=None,
        help="seed of the recalibration (default: the first of params' seeds)",
    )

    pr = _command(
        sub,
        "predict",
        _predict,
        help="stream a drive through a model, second by second",
        description="Stream a drive (10 Hz CSV) through a model: per whole second the WPM "
        "displacement, the predicted error and the corrected displacement; during each "
        "--outage also the cumulative distances of WPM, corrected and GNSS and their errors. "
        "Runs the model's ONNX graph with ONNX Runtime (no torch). A summary per outage goes "
        "to stderr.",
    )
    pr.add_argument(
        "--model",
        required=True,
        help="models:/<name>/<version|latest>, an exported .onnx file, or a model folder",
    )
    pr.add_argument(
        "--drive",
        required=True,
        help="the drive in --format (a CSV file, - to read a CSV on stdin, an MDF4 file, or "
        "a comma2k19 / stream-CSV folder)",
    )
    pr.add_argument(
        "--outage",
        action="append",
        default=[],
        metavar="START:END",
        help="an outage to report on, in seconds since the drive's first row (repeatable)",
    )
    pr.add_argument(
        "--output",
        default="-",
        help="out.csv, out.parquet, or - for CSV on stdout (default: %(default)s)",
    )
    _drive_options(pr)
    pr.add_argument(
        "--max-gap",
        type=float,
        default=0.5,
        help="a time step longer than this (s) starts a new run of seconds "
        "(default: %(default)s, validate.gnss.max_gap_s)",
    )
    pr.add_argument(
        "--quiet",
        action="store_true",
        help="no summary on stderr (repaired wheel glitches are still reported)",
    )

    ex = _command(
        sub,
        "export",
        _export,
        help="export a model as one ONNX file",
        description="Export a model to ONNX (torch.onnx), with its input scaler and WPM radii "
        "in the file's metadata, and check it against PyTorch to 1e-5 m.",
    )
    ex.add_argument(
        "--model",
        required=True,
        help="models:/<name>/<version|latest>, a model folder, or a pipeline "
        "model.pt (its scaler and radii from data/processed/)",
    )
    ex.add_argument("--format", choices=["onnx"], default="onnx", help="only onnx")
    ex.add_argument(
        "--output", default=None, help="the .onnx file (default: <model name>.onnx here)"
    )

    ck = _command(
        sub,
        "check",
        _check,
        help="read a drive and check it as ingest and validate would, before a run",
        description="Read a drive in --format and run validate's checks on it (schema, GNSS "
        "quality, wheel sensors, and against the GNSS: the tyre radius the wheels imply, the "
        "yaw rate's unit and sign, each axle's left and right wheels, the front and rear "
        "wheels). Exit 2 with validate's report where it would refuse the drive; else print "
        "what it would keep and what each check told, or why it could not tell.",
    )
    ck.add_argument(
        "--drive",
        required=True,
        nargs="+",
        help="one or more drives, each a file (IO-VNBD or column-mapped CSV, MDF4, CAN log, "
        "ROS bag) or a folder (comma2k19 segment or route, stream CSVs), in --format; exit 2 when "
        "validate would refuse any of them, after the others' verdicts",
    )
    ck.add_argument(
        "--vehicle",
        default="target",
        help="the car of data.vehicles whose nominal tyre radius and rear track the checks "
        "take, unless --nominal-radius or --vehicle-file gives them (default: %(default)s)",
    )
    _drive_options(ck)
    ck.add_argument("--json", action="store_true", help="print the records as JSON")

    sub.add_parser(
        "gate", help="the CI regression gate on mean CRSE/CTE (rwhonet gate --help)", add_help=False
    )
    return ap


def main(argv: list[str] | None = None) -> int:
    """Run a command; return its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["gate"]:
        from rwhonet.report import gate

        return gate.main(argv[1:])
    args = parser().parse_args(argv)
    from rwhonet.libraries import Interrupted, ignore_interrupts, interruptible, quiet

    quiet()
    try:
        with interruptible():  # a stopped command unwinds: predict's partial output goes
            return args.func(args)
    except (InputError, ConfigError) as err:
        print(f"{PROG} {args.command}: error:\n{err}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:  # `rwhonet predict ... | head`: the reader has what it wanted
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except Interrupted as err:  # SIGTERM, SIGINT, SIGHUP: cleaned up on the way out
        ignore_interrupts()
        print(f"{PROG} {args.command}: {err}; stopped, nothing half-written left", file=sys.stderr)
        return 128 + err.signum
    except KeyboardInterrupt:
        return 130


def entry() -> None:
    """The console script: the command's status, and no native teardown after it
    (:func:`rwhonet.libraries.exit_process`); argparse's ``--help`` and usage errors
    end by their own code."""
    from rwhonet.libraries import exit_with

    exit_with(main)


if __name__ == "__main__":
    entry()
