"""One drive file -> labelled samples, through the domain code the pipeline's stages call.

``rwhonet recalibrate`` reads a new car's drive exactly as the DVC stages read
the fleet's: the reader of its format with the file-size limit and the scenario
sidecar (:func:`rwhonet.data.drivefile.read_canonical`, as ``ingest``), the
schema and the per-drive checks (:func:`rwhonet.data.schema.schema_problems`,
:func:`rwhonet.data.drivechecks.check_drive`: GNSS quality, wheel sensors,
plausibility, as ``validate``), the per-second grid and samples of each valid
segment (:func:`rwhonet.features.seconds.segment_seconds`,
:func:`rwhonet.features.labels.sample_table`, as ``label``) with the base
model's scaler and source radii; the samples are stacked as the model stages
stack theirs (:func:`rwhonet.features.samples.stack_segments`). Bad input stops
with the same report (file, row, column, expected, found, what to do).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rwhonet import contracts, paths
from rwhonet.config import ConfigError, Params, VehicleSpec
from rwhonet.data.columnmap import check_column_map
from rwhonet.data.quality import Assessment
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import Calibration
from rwhonet.features.samples import SampleSet
from rwhonet.features.scaling import MinMaxScaler

ROLE = "recalibration"  # not a pipeline role: validate's role-specific checks do not apply


@dataclass
class DriveSamples:
    """A drive's labelled samples and what validation kept.

    Attributes:
        samples: the samples, in time order (``frame["k"]``: rank of the second in the drive).
        file: the drive file as the user named it.
        assessment: validate's GNSS-quality assessment (segments, cuts).
    """

    samples: SampleSet
    file: str
    assessment: Assessment

    def kept_summary(self) -> str:
        """``"540 valid s of 560 s (cut: low_sats 20 s)"``."""
        a = self.assessment
        cut = ", ".join(f"{r} {n} s" for r, n in a.cut_seconds_by_rule.items() if n)
        return f"{a.seconds_kept} valid s of {a.n_seconds} s" + (f" (cut: {cut})" if cut else "")


def with_vehicle(params: Params, vehicle: str, nominal_radius_m: float) -> Params:
    """``params`` that know ``vehicle``: as they are, or with it added to ``data.vehicles``.

    A vehicle the params do not name (a new car) is checked against ``nominal_radius_m``
    (the base model's source calibration) as a real drive's vehicle.
    """
    try:
        params.nominal_radius_m(vehicle)
        return params
    except ConfigError:
        data = dataclasses.replace(
            params.data,
            source="files",
            vehicles={**params.data.vehicles, vehicle: VehicleSpec(nominal_radius_m)},
        )
        return dataclasses.replace(params, data=data)


def load_drive(
    path: Path,
    params: Params,
    *,
    vehicle: str,
    fmt: str,
    calibration: Calibration,
    scaler: MinMaxScaler,
    wpm_mode: str,
    seq_len: int,
) -> DriveSamples:
    """Read, validate and label one drive file.

    Args:
        path: the drive (IO-VNBD CSV, or a CSV read through a column map).
        params: the project parameters (``data``, ``validate``).
        vehicle: the car (``data.vehicles``; an unknown name is checked against the
            calibration's radius).
        fmt: ``iovnbd`` or the name of a column map (``data.column_maps``).
        calibration: the WPM's source radii.
        scaler: the input scaler.
        wpm_mode: ``label.wpm_mode`` of the model.
        seq_len: the model's time steps.

    Returns:
        The samples of every GNSS-valid second.

    Raises:
        InputError: every problem of the file, as the ingest and validate stages report them.
    """
    from rwhonet.data.drivechecks import check_drive
    from rwhonet.data.drivefile import IOVNBD, DriveFile, read_canonical
    from rwhonet.data.quality import segment_name
    from rwhonet.data.schema import schema_problems
    from rwhonet.features.labels import sample_table
    from rwhonet.features.samples import stack_segments
    from rwhonet.features.seconds import segment_arrays, segment_seconds

    path = Path(path)
    file = paths.rel(path)
    if not path.is_file():
        raise InputError(
            [
                Problem(
                    file,
                    None,
                    None,
                    "a drive file (IO-VNBD CSV or a column-mapped CSV)",
                    "no such file" if not path.exists() else "not a file",
                    "give the path of the new car's drive (--drive)",
                )
            ],
        )
    if fmt != IOVNBD:
        if fmt not in params.data.column_maps:
            raise InputError(
                [
                    Problem(
                        "--format",
                        None,
                        None,
                        f"iovnbd or a column map of params.yaml "
                        f"data.column_maps ({', '.join(sorted(params.data.column_maps))})",
                        repr(fmt),
                        "add the file's column map to data.column_maps",
                    )
                ],
            )
        check_column_map(fmt, params.data.column_maps[fmt])
    nominal = 0.5 * (calibration.r_rl_m + calibration.r_rr_m)
    params = with_vehicle(params, vehicle, nominal)
    drive = read_canonical(DriveFile(path.stem, ROLE, vehicle, fmt, path), params.data, paths.rel)
    raw, table = drive.raw, drive.table()
    df = table.to_pandas(split_blocks=True)
    entry: dict[str, Any] = {
        "drive": path.stem,
        "role": ROLE,
        "vehicle": vehicle,
        "source_file": file,
        "columns": raw.source_columns,
    }
    cuts = [cut for cut in params.validate.cuts if cut.drive == path.stem]
    found = schema_problems(df, params.validate, file, raw.source_columns)
    problems, result, _, _ = check_drive(params, entry, df, found, cuts)
    if problems:
        raise InputError(problems, f"{file}: {len(problems)} problem(s) (validate)")
    assert result is not None  # no problem: the GNSS policy ran
    segments = []
    for j, seg in enumerate(result.segments):
        name = segment_name(path.stem, j)
        sec = segment_seconds(segment_arrays(table.slice(seg.row_start, seg.n_rows)), name)
        samples = sample_table(sec, calibration, scaler, wpm_mode).to_pandas()
        segments.append(({"drive": path.stem, "segment": name, "role": ROLE}, samples))
    return DriveSamples(stack_segments(segments, seq_len), file, result)


def calibration_of(radii: tuple[float, float], source: str) -> Calibration:
    """A :class:`Calibration` holding the source radii a served model carries."""
    return Calibration(
        r_rl_m=radii[0],
        r_rr_m=radii[1],
        estimator="ratio_of_sums",
        min_speed_m_s=0.0,
        n_seconds_used=0,
        n_seconds_total=0,
        distance_m=0.0,
        role=contracts.SOURCE_CALIBRATION,
        drives=[],
        segments=[],
        comparison={"note": f"the source radii of {source}"},
    )
