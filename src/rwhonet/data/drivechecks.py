"""The checks ``validate`` runs on one drive, as problems a user can act on.

After its schema (:mod:`rwhonet.data.schema`), a drive goes through the
GNSS-quality policy (:mod:`rwhonet.data.quality`, with the seconds where a wheel
speed changed faster than any tyre can cut as ``wheel_glitch``:
:mod:`rwhonet.data.glitches`), then the wheel-sensor and
plausibility checks (:mod:`rwhonet.data.plausibility`): wheel speeds are
magnitudes, no wheel sensor stuck, silent or stale while the car moves,
latitude and longitude not swapped, wheel speeds in rad/s (the tyre radius
they imply), a yaw rate in its declared unit and sign (the GNSS course's turn
against it); and a target test drive keeps enough valid seconds to adapt on
``max(adapt.m_grid)`` s and score the shortest outage. The ``validate`` stage
runs them on every ingested drive, ``rwhonet recalibrate`` on a new car's drive.
Each :class:`~rwhonet.errors.Problem` names the file, row and column, what was
expected, what was found and what to do.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from rwhonet import contracts
from rwhonet.config import CutSpec, Params, ValidateParams
from rwhonet.data import canonical as c
from rwhonet.data.droprows import FILE_ROW, FileRows
from rwhonet.data.glitches import (
    REFUSE_SHARE,
    WHEEL_GLITCH_G,
    YAW_RATE_LIMIT_RAD_S,
    glitch_mask,
    repaired_yaw_rate,
)
from rwhonet.data.plausibility import (
    AXLE_EXCHANGED_GAIN,
    AXLE_MIN_TIGHT,
    AXLE_TIGHT_TERM,
    AXLE_WHEELBASE_M,
    AXLES,
    YAW_EVIDENCE_SE,
    YAW_MIN_SECONDS,
    YAW_MIN_STEP_M,
    CourseTurns,
    DiagonalEstimate,
    SignTally,
    YawEstimate,
    axle_mistake,
    axle_order_gain,
    course_turns,
    diagonal_gain,
    diagonal_mistake,
    gnss_path_m,
    implied_radius,
    latlon_swapped_by_range,
    minutes_radius,
    radians_radius,
    side_mistake,
    side_yaws,
    sign_tallies,
    stuck_wheel_runs,
    swapped_radius,
    unit_mistake,
    wheel_gnss_runs,
    wheel_side_gains,
    yaw_gain,
    yaw_mistake,
)
from rwhonet.data.problems import stretch_problems
from rwhonet.data.quality import Assessment, Segment, assess, manual_rows, second_index
from rwhonet.data.timebase import label_times
from rwhonet.errors import InputError, Problem

YAW_GLITCHES_LISTED = 10  # yaw-rate glitches listed one by one in the record (all counted)
# A car's rear track where none is known (predict's wheel-sides check, a car with no
# data.vehicles entry): the check tells a sign whatever the track (it scales the gain).
DEFAULT_TRACK_M = 1.5
# The checks against the GNSS course whose records a drive's report carries, each as its
# record's key and the name a summary gives it: a check that could not tell on a drive
# (too few turns, no yaw rate) rules no mistake out there. validate's summary and
# ``rwhonet check`` both list them from here.
TOLD_CHECKS = (
    ("radius", "tyre radius"),
    ("yaw_rate", "yaw rate"),
    ("wheel_sides", "left and right wheels"),
    ("wheel_axles", "front and rear wheels"),
)


def _few_pairs_note(seconds: int) -> str:
    """Why the yaw-rate or wheel-sides check could not tell: too few pairs of seconds."""
    return (
        f"only {seconds} pairs of seconds at >= {YAW_MIN_STEP_M:g} m/s in valid segments "
        f"(< {YAW_MIN_SECONDS})"
    )


def target_test_min_s(params: Params) -> int:
    """Valid seconds a target test drive needs: adapt on max(m), then score the shortest outage."""
    return max(params.adapt.m_grid) + min(params.evaluate.outages_s)


def check_drive(
    params: Params,
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    schema_found: list[Problem],
    drive_cuts: list[CutSpec],
) -> tuple[list[Problem], Assessment | None, dict[str, Any] | None, dict[str, Any] | None]:
    """Everything validate checks on one drive after its schema, and its GNSS-valid segments.

    The GNSS-quality policy runs on a drive that passed the schema (wheel speeds out of
    range alone don't stop it, so the unit check can tell rpm or deg/s apart), cutting
    the seconds of wheel glitches (:func:`wheel_glitches`) with the GNSS rules; then the
    wheel-sensor and plausibility checks. ``rwhonet recalibrate`` checks a new car's
    drive with this too.

    Args:
        params: the project parameters (``validate``, the vehicle's nominal radius).
        entry: the drive as the ingest manifest lists it (``drive``, ``role``, ``vehicle``,
            ``source_file``, ``columns``; a stream drive's ``streams`` record with the grid
            rows whose wheel-speed mean used a glitched sample).
        df: the canonical drive.
        schema_found: its schema problems (:func:`rwhonet.data.schema.schema_problems`).
        drive_cuts: its manual cuts (``validate.cuts``).

    Returns:
        ``(problems, assessment, unit checks, wheel glitches)``; the unit checks are
        ``{"radius": ..., "yaw_rate": ..., "wheel_sides": ..., "wheel_axles": ...}``
        (:func:`radius_problems`', :func:`yaw_problems`', :func:`side_problems`' and
        :func:`axle_problems`' records); the assessment and unit checks are None when the
        schema problems stopped the drive before the GNSS policy; the glitches
        (:func:`wheel_glitches`' report) None when no row glitched.
    """
    vp = params.validate
    # Plain arrays, taken from the frame once: the checks read every column many times.
    df = {name: np.asarray(df[name]) for name in df if name != c.SCENARIO}
    found = _swapped_by_range(schema_found, df, entry)
    result = units = glitches = None
    if not found or _only_wheel_ranges(found, df, entry["columns"]):
        nominal = params.nominal_radius_m(entry["vehicle"])
        glitch, glitches = wheel_glitches(df, entry, nominal, period_s=vp.sample_period_s)
        found = _glitches_out_of_range(found, df, glitch, entry["columns"], vp)
        result = assess(
            df,
            vp.gnss,
            vp.sample_period_s,
            drive_cuts,
            wheel_glitch=glitch,
            file_rows=FileRows.of(entry),
        )
        wheels = wheel_problems(vp, nominal, entry, df, drive_cuts, result)
        wheels += _glitch_problems(entry, df, glitch, glitches, vp.sample_period_s)
        more, units = _drive_problems(params, entry, df, result, check_units=not wheels)
        found = found + wheels + more
    return found, result, units, glitches


@np.errstate(invalid="ignore", over="ignore")
def wheel_glitches(
    df: Mapping[str, np.ndarray],
    entry: dict[str, Any],
    radius_m: float,
    listed: int = 50,
    period_s: float | None = None,
) -> tuple[np.ndarray, dict[str, Any] | None]:
    """The rows where a wheel speed changed faster than any tyre can, and their report.

    Two screens (:func:`rwhonet.data.glitches.glitch_mask`, bound
    :data:`~rwhonet.data.glitches.WHEEL_GLITCH_G`): the drive's own 10 Hz rows, and for
    a stream drive the raw samples the resampler screened (the manifest's
    ``streams.glitch_rows``: grid rows whose mean used a glitched sample).

    Args:
        df: the canonical drive.
        entry: its manifest entry.
        radius_m: the vehicle's nominal tyre radius, m.
        listed: glitches listed one by one in the report (all are counted).
        period_s: the sample period: jittered stamps are screened at their slots' instants,
            as ``label`` and ``predict`` take them (:func:`rwhonet.data.timebase.label_times`;
            None: the stamps).

    Returns:
        ``(mask, report)``: per row whether it glitched, and None when no row did, else
        ``{"rows", "listed": [{"row", "t_s", "channel"} or the stream's samples
        {"stream", "row", "t_s", "channel"}], "rows_are"}``.
    """
    t = np.asarray(df[c.T_S], dtype=np.float64)  # the report gives the stamps
    placed = t
    if period_s is not None and np.isfinite(t).all():
        placed = label_times(t, period_s)
    by_wheel = glitch_mask(
        placed, np.stack([np.asarray(df[w], dtype=np.float64) for w in c.WHEELS]), radius_m
    )
    mask = by_wheel.any(axis=0)
    streams = entry.get("streams") or {}
    grid_rows = np.asarray(streams.get("glitch_rows", []), dtype=np.int64)
    grid_rows = grid_rows[(grid_rows >= 0) & (grid_rows < t.size)]
    mask[grid_rows] = True
    if not mask.any():
        return mask, None
    columns, file_rows = entry["columns"], FileRows.of(entry)
    own = [
        {"row": file_rows(int(i)), "t_s": float(t[i]), "channel": columns.get(w, w)}
        for i in np.flatnonzero(by_wheel.any(axis=0))[:listed]
        for w in (c.WHEELS[int(np.argmax(by_wheel[:, i]))],)
    ]
    samples = list(streams.get("glitch_samples", []))[:listed]
    return mask, {
        "rows": int(mask.sum()),
        "listed": samples + own[: max(listed - len(samples), 0)],
        "rows_are": (
            "samples of the drive's streams (1-based), then rows of its 10 Hz grid"
            if streams
            else "data rows of the file (1-based)"
        ),
        "bound_g": WHEEL_GLITCH_G,
    }


def _glitch_problems(
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    glitch: np.ndarray,
    glitches: dict[str, Any] | None,
    sample_period_s: float,
) -> list[Problem]:
    """A drive glitched in most of its seconds is refused (rule: REFUSE_SHARE of them)."""
    if glitches is None:
        return []
    sec = second_index(np.asarray(df[c.T_S], dtype=np.float64), sample_period_s)
    n_sec = int(sec[-1] - sec[0]) + 1
    hit = np.unique(sec[glitch]).size
    if hit <= REFUSE_SHARE * n_sec:
        return []
    first = glitches["listed"][0]
    where = (
        f"first at {first['stream']} sample row {first['row']}"
        if "stream" in first
        else f"first in row {first['row']}"
    )
    return [
        Problem(
            entry["source_file"],
            None if "stream" in first else first["row"],
            first["channel"],
            f"wheel speeds that never rise faster than {WHEEL_GLITCH_G:g} g above the road "
            f"speed (a glitch's seconds are cut) in at least {1 - REFUSE_SHARE:.0%} of the "
            "drive's seconds",
            f"glitches in {hit} of {n_sec} s ({where}, t = {first['t_s']:.6g} s): a wheel "
            "channel that misbehaves throughout",
            "check the wheel-speed channels (the signal each wheel is mapped to, its unit and "
            "scale) and export the drive again",
        )
    ]


# Wheel speeds out of range (inf included) reach these checks on purpose (the unit check
# tells rpm from deg/s): arithmetic on them must not warn, the problems say it.
@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def _drive_problems(
    params: Params,
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    result: Assessment,
    check_units: bool = True,
) -> tuple[list[Problem], dict[str, Any]]:
    """Problems of a schema-valid drive after the GNSS policy, and its radius check.

    ``check_units`` False skips the radius check (a stuck or negated wheel already
    explains a wrong radius, and the unit message would only confuse).
    """
    vp = params.validate
    file = entry["source_file"]
    problems = []
    t0, t1 = float(df[c.T_S][0]), float(df[c.T_S][-1])
    for i, cut in enumerate(params.validate.cuts):
        if cut.drive == entry["drive"] and (cut.end_s < t0 or cut.start_s > t1):
            problems.append(
                Problem(
                    "params.yaml",
                    None,
                    f"validate.cuts[{i}]",
                    f"an interval overlapping {entry['drive']}'s time span {t0}-{t1} s (its "
                    "own clock)",
                    f"{cut.start_s}-{cut.end_s} s",
                    "give start_s and end_s in the drive's own time column (seconds of the "
                    "day for IO-VNBD), not seconds from its start",
                )
            )
    if not result.segments:
        by_rule = sorted(result.cut_seconds_by_rule.items(), key=lambda kv: -kv[1])
        problems.append(
            Problem(
                file,
                None,
                None,
                f"at least one GNSS-valid stretch of >= {vp.gnss.min_segment_s} s",
                f"none: all {result.n_seconds} s cut, "
                + ", ".join(f"{rule} {s} s" for rule, s in by_rule if s)
                + f" (rule {by_rule[0][0]}: {_first_detail(result, by_rule[0][0])})",
                "leave this drive out, repair its GNSS data, or relax the rule that cut it "
                "(validate.gnss) if it is too strict for this receiver" + _dropped_hint(result, vp),
            )
        )
        none = {"checked": False, "note": "no valid segment"}
        return problems, {
            "radius": none,
            "yaw_rate": dict(none),
            "wheel_sides": dict(none),
            "wheel_axles": dict(none),
        }

    need = target_test_min_s(params)
    if entry["role"] == contracts.TARGET_TEST and result.seconds_kept < need:
        cut = ", ".join(f"{r} {n} s" for r, n in result.cut_seconds_by_rule.items() if n)
        problems.append(
            Problem(
                file,
                None,
                None,
                f"a target test drive with at least {need} GNSS-valid seconds: "
                f"max(adapt.m_grid) = {max(params.adapt.m_grid)} s to adapt on, then "
                f"min(evaluate.outages_s) = {min(params.evaluate.outages_s)} s to score",
                f"{entry['drive']} keeps {result.seconds_kept} valid s of its "
                f"{result.n_seconds} s" + (f" (cut: {cut})" if cut else ""),
                "use a longer drive as target test drive (this one can serve as target_train), "
                "or lower adapt.m_grid" + _dropped_hint(result, vp),
            )
        )

    nominal = params.nominal_radius_m(entry["vehicle"])
    more, radius = radius_problems(entry, df, result.segments, nominal, vp, check_units)
    # the course's turns, which the yaw rate and each axle's wheels are fitted against
    turns = course_turns(df, result.segments, YAW_MIN_STEP_M, vp.sample_period_s)
    yawed, yaw = yaw_problems(entry, df, result.segments, vp, turns)
    track = params.track_rear_m(entry["vehicle"])
    sided, sides = side_problems(entry, df, result.segments, vp, nominal, track, turns)
    misplaced = sides.get("misplaced", ())
    axled, axles = axle_problems(entry, df, result.segments, vp, nominal, turns, misplaced)
    checks = {"radius": radius, "yaw_rate": yaw, "wheel_sides": sides, "wheel_axles": axles}
    return problems + more + yawed + sided + axled, checks


def yaw_problems(
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    vp: ValidateParams,
    turns: CourseTurns | None = None,
) -> tuple[list[Problem], dict[str, Any]]:
    """The yaw-rate check: the GNSS course's turn against the gyro's, and what it says.

    The gain of the course's turn on the yaw rate's over the valid segments
    (:func:`rwhonet.data.plausibility.yaw_gain`) must lie within
    ``validate.yaw_gain_tolerance`` of 1; a gain told apart from that band
    (:func:`~rwhonet.data.plausibility.yaw_mistake`: 4 standard errors) is refused, naming
    the mistake it fits (a clockwise gyro, degrees for radians or the other way round, a
    channel that never changes or does not follow the car). A drive without a yaw rate,
    or one that turned too little to tell, passes with a note in the record. The yaw rate
    is the navigation filter's gyro: a wrong sign turns every dead-reckoned track the
    wrong way (about 75 % of the distance off at the end of a 180 s outage on the
    built-in drives, against 1.1 %).

    Args:
        entry: ``source_file``, ``columns`` (canonical -> the file's name).
        df: the canonical drive.
        segments: its GNSS-valid segments.
        vp: ``validate``.
        turns: the course's turns over them
            (:func:`rwhonet.data.plausibility.course_turns`), where already computed.

    Returns:
        ``(problems, record)``: the record as validate reports it (``checked``, the gain
        and its standard error, the pairs of seconds, the span the course swung through,
        a note when not checked, and ``glitches`` where samples lay beyond any car's yaw
        rate: :func:`rwhonet.data.glitches.repaired_yaw_rate`, which the check and the
        label take interpolated across).
    """
    if c.YAW_RATE_RAD_S not in df or not np.isfinite(np.asarray(df[c.YAW_RATE_RAD_S])).any():
        return [], {"checked": False, "note": "no yaw rate"}
    est = yaw_gain(df, segments, YAW_MIN_STEP_M, vp.sample_period_s, turns)
    # the samples the check and the label take interpolated across (none where too many)
    glitched = np.flatnonzero(repaired_yaw_rate(df[c.T_S], df[c.YAW_RATE_RAD_S])[1])
    checked, mistake = yaw_mistake(est, vp.yaw_gain_tolerance)
    record: dict[str, Any] = {
        "checked": checked,
        "gain": None if np.isnan(est.gain) else est.gain,
        "gain_se": None if not np.isfinite(est.gain_se) else est.gain_se,
        "seconds": est.seconds,
        "course_span_deg": float(np.degrees(est.course_span_rad)),
    }
    if not checked and est.seconds < YAW_MIN_SECONDS:
        record["note"] = _few_pairs_note(est.seconds)
    elif not checked and np.isfinite(est.gain_se):
        record["note"] = f"turned too little to tell (gain {est.gain:.3g} ± {est.gain_se:.2g})"
    elif not checked:
        record["note"] = "the yaw rate never changed, nor did the course turn enough to tell"
    if glitched.size:
        t, rate = np.asarray(df[c.T_S]), np.asarray(df[c.YAW_RATE_RAD_S])
        file_rows = FileRows.of(entry)
        record["glitches"] = {
            "rows": int(glitched.size),
            "listed": [
                {"row": file_rows(int(i)), "t_s": float(t[i]), "rad_s": float(rate[i])}
                for i in glitched[:YAW_GLITCHES_LISTED]
            ],
            "rows_are": (
                "rows of the drive's 10 Hz grid (1-based)"
                if entry.get("streams")
                else "data rows of the file (1-based)"
            ),
            "limit_rad_s": YAW_RATE_LIMIT_RAD_S,
            "repair": "interpolated in time across (the check and the label)",
        }
    if mistake is None:
        return [], record
    swapped = swapped_fixes_gain(df, segments, vp)
    # Exchanged, the fixes mirror the track (east for north, each axis scaled as the
    # meridians converge), which a clockwise gyro mimics: a swap is named only where it
    # explains the turns better than a clockwise gyro does (a clockwise gyro on a drive
    # near Coventry gave -0.999 as the columns are, 0.83 exchanged; swapped fixes there
    # -0.74 as they are, 1.003 exchanged).
    if swapped is not None and abs(swapped.gain - 1.0) < abs(est.gain + 1.0):
        record["swapped_gain"] = swapped.gain
        evidence = (
            f"the GNSS course turned {est.gain:.4g} ± {est.gain_se:.2g} times what the yaw "
            f"rate says as the columns are, and {swapped.gain:.4g} ± {swapped.gain_se:.2g} "
            "times with the two exchanged (exchanged, they mirror the track: every turn goes "
            "the other way)"
        )
        return [_swapped_problem(entry, None, None, None, evidence)], record
    column = entry["columns"].get(c.YAW_RATE_RAD_S, c.YAW_RATE_RAD_S)
    gain = (
        "it never changes"
        if np.isnan(est.gain)
        else f"the course turned {est.gain:.4g} ± {est.gain_se:.2g} times what it says"
    )
    return [
        Problem(
            entry["source_file"],
            None,
            column,
            "a yaw rate in the declared unit, positive turning left (ISO 8855): the GNSS "
            f"course turning 1 ± {vp.yaw_gain_tolerance:g} times as far "
            "(validate.yaw_gain_tolerance)",
            f"over {est.seconds} pairs of moving seconds in valid segments (the course swung "
            f"through {np.degrees(est.course_span_rad):.0f} deg) {gain}: the yaw rate {mistake}",
            "declare the yaw rate's unit and sign in a column map or signal map (yaw_rate: "
            "{column: ..., unit: deg/s cw} for a gyro positive clockwise; units "
            f"{', '.join(c.YAW_RATE_UNITS)}), or leave the column empty if the log has no "
            "yaw rate",
        )
    ], record


def swapped_fixes_gain(
    df: Mapping[str, Any], segments: Sequence[Segment], vp: ValidateParams
) -> YawEstimate | None:
    """The yaw estimate with latitude and longitude exchanged, where that one passes.

    Asked when the yaw rate disagrees with the course: latitude and longitude written
    the other way round mirror the track (east for north), so every turn of the course
    goes the other way and the yaw check takes the gyro for a clockwise one. None: the
    exchanged values are no latitudes, or the course exchanged does not agree either.
    """
    lat = np.asarray(df[c.LAT_DEG], dtype=np.float64)
    lon = np.asarray(df[c.LON_DEG], dtype=np.float64)
    with np.errstate(invalid="ignore"):
        if not np.isfinite(lon).any() or np.nanmax(np.abs(lon)) > 90.0:
            return None
    exchanged = {k: df[k] for k in (c.T_S, c.YAW_RATE_RAD_S)} | {c.LAT_DEG: lon, c.LON_DEG: lat}
    est = yaw_gain(exchanged, segments, YAW_MIN_STEP_M, vp.sample_period_s)
    checked, mistake = yaw_mistake(est, vp.yaw_gain_tolerance)
    return est if checked and mistake is None else None


def side_problems(
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    vp: ValidateParams,
    radius_m: float,
    track_m: float,
    turns: CourseTurns | None = None,
) -> tuple[list[Problem], dict[str, Any]]:
    """The wheel-sides check: each axle's left and right wheel speeds in their columns,
    and no diagonal pair of wheel columns exchanged.

    The GNSS course turns with the right wheel's speed less the left's
    (:func:`rwhonet.data.plausibility.wheel_side_gains`); an axle whose gain is told
    negative (:func:`~rwhonet.data.plausibility.side_mistake`: 4 standard errors from 0)
    has its two columns exchanged, a mistake of a column map, a signal map or a DBC's
    signal names that no other check sees: a wheel's speed is the same whichever side it
    is written to, so the distance and the label do not change, but the wheels' yaw,
    which 2D dead reckoning turns by where there is no gyro, turns every track the wrong
    way (the built-in V-Charlie3's rear wheels exchanged, without its yaw rate: 2,493 m
    off at the end of a 180 s outage of 2,166 m, against 67 m; docs/readers.md). One
    diagonal pair exchanged (front left for rear right, or front right for rear left)
    puts each axle's two columns on one side, which the axles' gains cannot tell (they
    scatter either side of 0, and a refusal of theirs would name the wrong fix): it is
    told by :func:`~rwhonet.data.plausibility.diagonal_gain` and refused as one exchange of
    the two columns, in the place of the axles' refusals. A drive that turned too little
    to tell passes, with a note in the record.

    Args:
        entry: ``source_file``, ``columns`` (canonical -> the file's name).
        df: the canonical drive.
        segments: its GNSS-valid segments.
        vp: ``validate``.
        radius_m: the car's nominal tyre radius.
        track_m: its rear track (the gains' scale; only their signs are told).
        turns: the course's turns, where already computed (as :func:`yaw_problems`).

    Returns:
        ``(problems, record)``: the record as validate reports it: ``checked`` (both
        axles told, or a problem), per axle its gain, standard error and pairs of seconds,
        ``diagonal`` (the diagonal gain and its standard error), a note when not checked,
        and ``misplaced`` (the two canonical columns of a diagonal pair told exchanged),
        only where they are.
    """
    if turns is None:
        turns = course_turns(df, segments, YAW_MIN_STEP_M, vp.sample_period_s)
    # each axle's yaw integrated once, for the axles' gains and the diagonal's
    sides = None if turns is None else side_yaws(df, turns, radius_m, track_m)
    gains = wheel_side_gains(
        df, segments, YAW_MIN_STEP_M, vp.sample_period_s, radius_m, track_m, turns, sides
    )
    record: dict[str, Any] = {}
    problems, told = [], []
    for axle, est in gains.items():
        checked, exchanged = side_mistake(est)
        told.append(checked)
        record[axle] = _gain_record(est) | {"seconds": est.seconds}
        if not exchanged:
            continue
        left, right = (entry["columns"].get(k, k) for k in AXLES[axle])
        problems.append(
            Problem(
                entry["source_file"],
                None,
                f"{left} / {right}",
                f"the {axle} left wheel's speed in {left!r} and the {axle} right wheel's in "
                f"{right!r}: the GNSS course turning with the right wheel's speed less the "
                "left's, as the outer wheel runs faster",
                f"over {est.seconds} pairs of moving seconds in valid segments the course "
                f"turned {est.gain:.3g} ± {est.gain_se:.2g} times the turn the {axle} wheels "
                "say: against them, so the two columns look exchanged (left for right)",
                "exchange the two columns (their names in the header, or the two keys in the "
                "column map or signal map)",
            )
        )
    diagonal = diagonal_gain(
        df, segments, YAW_MIN_STEP_M, vp.sample_period_s, radius_m, track_m, turns, sides
    )
    record["diagonal"] = _gain_record(diagonal)
    pair = diagonal_mistake(diagonal)
    if pair is not None:
        record["misplaced"] = list(pair)
        problems = [_diagonal_problem(entry, pair, diagonal)]
    record["checked"] = all(told) or bool(problems)
    if not record["checked"]:
        axle, est = next((a, e) for (a, e), t in zip(gains.items(), told, strict=True) if not t)
        if est.seconds < YAW_MIN_SECONDS:
            record["note"] = _few_pairs_note(est.seconds)
        elif np.isnan(est.gain):
            record["note"] = f"the {axle} wheels never differed (one speed written to both?)"
        else:
            record["note"] = (
                f"turned too little to tell ({axle} gain {est.gain:.3g} ± {est.gain_se:.2g})"
            )
    return problems, record


def _gain_record(est: YawEstimate | DiagonalEstimate) -> dict[str, float | None]:
    """An estimate's gain and standard error as a record holds them (None where not told)."""
    return {
        "gain": None if np.isnan(est.gain) else est.gain,
        "gain_se": None if not np.isfinite(est.gain_se) else est.gain_se,
    }


# Each wheel column as a person names it.
_WHEEL_PLACES: dict[str, str] = {
    c.OMEGA_FL: "front left",
    c.OMEGA_FR: "front right",
    c.OMEGA_RL: "rear left",
    c.OMEGA_RR: "rear right",
}


def _diagonal_problem(
    entry: dict[str, Any], pair: tuple[str, str], est: DiagonalEstimate
) -> Problem:
    """One diagonal pair of wheel columns told exchanged (:func:`side_problems`)."""
    front, rear = pair
    fname, rname = (entry["columns"].get(k, k) for k in pair)
    side = "right" if est.gain > 0.0 else "left"
    return Problem(
        entry["source_file"],
        None,
        f"{fname} / {rname}",
        f"the {_WHEEL_PLACES[front]} wheel's speed in {fname!r} and the {_WHEEL_PLACES[rear]} "
        f"wheel's in {rname!r}: the GNSS course turning with each axle's right wheel's speed "
        "less its left's, not with the front wheels' less the rear's",
        f"over {est.seconds} pairs of moving seconds in valid segments the course turned "
        f"{est.gain:.3g} ± {est.gain_se:.2g} times the turn the front columns' speeds less "
        f"the rear columns' say, as if the front columns held both {side} wheels: the two "
        f"columns look exchanged (a diagonal pair: {_WHEEL_PLACES[front]} for "
        f"{_WHEEL_PLACES[rear]})",
        "exchange the two columns (their names in the header, or the two keys in the column "
        "map or signal map)",
    )


def axle_problems(
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    vp: ValidateParams,
    radius_m: float,
    turns: CourseTurns | None = None,
    misplaced: Sequence[str] = (),
) -> tuple[list[Problem], dict[str, Any]]:
    """The wheel-axles check: the front wheels' speeds in the front columns, the rear's in
    the rear.

    In a tight turn the front axle runs on a wider arc than the rear, so the front wheels
    turn faster (:func:`rwhonet.data.plausibility.axle_order_gain`); where the rear columns
    run faster in the turns (the gain told negative, as an exchange makes it:
    :func:`~rwhonet.data.plausibility.axle_mistake`, 4 standard errors from 0 over at least
    :data:`~rwhonet.data.plausibility.AXLE_MIN_TIGHT` tight turns and below
    :data:`~rwhonet.data.plausibility.AXLE_EXCHANGED_GAIN`), the front and rear
    columns are exchanged: a mistake of a column map, a signal map or a DBC's signal names
    (wheel speeds numbered 1 to 4, or a message's front and rear signals in another order).
    The distance then rolls on the front wheels, which slip as they drive and steer and
    run wider in every turn: the WPM on the built-in test drives' front wheels, each axle
    with its own best radius, misses by 0.70 m a 30 s window against 0.56 m on the rear
    wheels (docs/readers.md). A drive with too few tight turns passes, with a note in the
    record.

    Args:
        entry: ``source_file``, ``columns`` (canonical -> the file's name).
        df: the canonical drive.
        segments: its GNSS-valid segments.
        vp: ``validate``.
        radius_m: the car's nominal tyre radius (the curvature's distance).
        turns: the course's turns, where already computed (as :func:`yaw_problems`).
        misplaced: the two wheel columns the wheel-sides check told exchanged as a
            diagonal pair (:func:`side_problems`' ``misplaced``): each axle's mean then
            mixes a front and a rear wheel, so the axles are not fitted.

    Returns:
        ``(problems, record)``: the record as validate reports it: ``checked``, the gain,
        its standard error, the pairs of seconds and the tight turns among them, and a note
        when not checked.
    """
    if misplaced:
        named = ", ".join(repr(entry["columns"].get(k, k)) for k in misplaced)
        note = f"not fitted: {named} look exchanged (a diagonal pair: the wheel-sides check)"
        return [], {"checked": False, "note": note}
    est = axle_order_gain(df, segments, YAW_MIN_STEP_M, vp.sample_period_s, radius_m, turns)
    checked, exchanged = axle_mistake(est)
    record: dict[str, Any] = {
        "checked": checked,
        "gain": None if np.isnan(est.gain) else est.gain,
        "gain_se": None if not np.isfinite(est.gain_se) else est.gain_se,
        "seconds": est.seconds,
        "tight_turns": est.tight,
    }
    if not checked:
        if est.seconds < YAW_MIN_SECONDS:
            record["note"] = _few_pairs_note(est.seconds)
        elif np.isnan(est.gain):
            record["note"] = "the front and rear wheels never differed (one speed written to all?)"
        elif est.tight < AXLE_MIN_TIGHT:
            record["note"] = (
                f"only {est.tight} pairs of seconds in a tight turn (a radius under "
                f"{AXLE_WHEELBASE_M / np.sqrt(2 * AXLE_TIGHT_TERM):.0f} m; < {AXLE_MIN_TIGHT})"
            )
        elif est.gain < 0.0 and abs(est.gain) > YAW_EVIDENCE_SE * est.gain_se:
            record["note"] = (
                f"the front wheels ran slower in the turns, by less than an exchange would "
                f"(gain {est.gain:.3g} ± {est.gain_se:.2g}, above {AXLE_EXCHANGED_GAIN:g}): "
                "brakes or drive slip, not told"
            )
        else:
            record["note"] = f"turned too little to tell (gain {est.gain:.3g} ± {est.gain_se:.2g})"
        return [], record
    if not exchanged:
        return [], record
    columns = [entry["columns"].get(k, k) for k in (*AXLES["front"], *AXLES["rear"])]
    front, rear = " and ".join(map(repr, columns[:2])), " and ".join(map(repr, columns[2:]))
    problem = Problem(
        entry["source_file"],
        None,
        " / ".join(columns),
        f"the front wheels' speeds in {front} and the rear wheels' in {rear}: the front "
        "axle runs on the wider arc in a turn, so its wheels turn faster the tighter the turn",
        f"over {est.seconds} pairs of moving seconds in valid segments ({est.tight} in tight "
        f"turns) the front columns' excess over the rear was {est.gain:.3g} ± "
        f"{est.gain_se:.2g} times a front axle's: slower than the rear in the turns, so the "
        "front and rear columns look exchanged",
        "exchange the front and rear columns (left with left, right with right: their names "
        "in the header, or the keys in the column map or signal map)",
    )
    return [problem], record


@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def radius_problems(
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    nominal: float,
    vp: ValidateParams,
    check_units: bool = True,
    radius_from: str | None = None,
) -> tuple[list[Problem], dict[str, Any]]:
    """The wheel-unit check: the tyre radius the wheels imply against GNSS, and what it says.

    GNSS distance / rear wheel angle over the moving seconds of ``segments``
    (:func:`rwhonet.data.plausibility.implied_radius`) must lie within
    ``validate.radius_tolerance`` of ``nominal``; otherwise the problem says which unit
    mix-up fits (:func:`~rwhonet.data.plausibility.unit_mistake`), or that latitude and
    longitude are swapped or in radians. Skipped (reported in the returned record) with
    fewer than ``validate.radius_min_moving_s`` moving seconds. ``validate`` runs it on a
    whole drive, ``rwhonet predict`` on the drive's first stretch that has enough
    (:class:`StreamRadiusCheck`).

    Args:
        entry: ``source_file``, ``columns`` (canonical -> the file's name) and ``vehicle``.
        df: the canonical drive (or its first rows).
        segments: its GNSS-valid segments (:func:`rwhonet.data.quality.assess`).
        nominal: the car's nominal tyre radius, m.
        vp: ``validate``.
        check_units: False skips the check (a wheel sensor problem explains the radius).
        radius_from: where the nominal radius comes from, for the fix (default
            ``data.vehicles.<vehicle>.nominal_radius_m``).

    Returns:
        ``(problems, record)``: the record as validate reports it (implied, nominal,
        moving seconds, whether checked, and why not).
    """
    file, columns = entry["source_file"], entry["columns"]
    problems: list[Problem] = []
    est = implied_radius(df, segments, vp.gnss.moving_wheel_speed_rad_s)
    radius = {
        "implied_m": None if np.isnan(est.radius_m) else est.radius_m,
        "nominal_m": nominal,
        "moving_s": est.moving_s,
        "checked": est.moving_s >= vp.radius_min_moving_s and check_units,
    }
    if not check_units:
        radius["note"] = "unit check skipped: a wheel sensor problem explains the radius"
        return problems, radius
    if not radius["checked"]:
        radius["note"] = (
            f"only {est.moving_s} moving s in valid segments (< validate.radius_min_moving_s "
            f"{vp.radius_min_moving_s}): unit check skipped"
        )
        return problems, radius
    radius["ratio"] = est.radius_m / nominal
    mistake = unit_mistake(est.radius_m, nominal, vp.radius_tolerance)
    if mistake:
        swapped = swapped_radius(df, segments, vp.gnss.moving_wheel_speed_rad_s)
        if unit_mistake(swapped.radius_m, nominal, vp.radius_tolerance) is None:
            problems.append(_swapped_problem(entry, est.radius_m, swapped.radius_m, nominal))
            return problems, radius
        lat, lon = (columns.get(x, x) for x in (c.LAT_DEG, c.LON_DEG))
        moving = vp.gnss.moving_wheel_speed_rad_s
        in_degrees = radians_radius(df, segments, moving)
        from_minutes = minutes_radius(df, segments, moving)
        # The two readings differ by 4.7 % in scale, about what a tyre's radius may differ
        # from its nominal: where both fit, both are named.
        readings = (  # (estimate, what they look like, how it was read, the fix)
            (
                in_degrees,
                "radians",
                "in degrees from radians",
                "convert both columns to degrees (x 180/π) if they are radians",
            ),
            (
                from_minutes,
                "degrees read as minutes of arc",
                "with the coordinates times 60",
                "declare the columns' unit 'deg' where a column or signal map declares 'min' "
                "or 'ddmm' (NMEA's ddmm.mmmm): those are for columns written so",
            ),
        )
        fit = [
            (est_if, looks, said, fix)
            for est_if, looks, said, fix in readings
            if est_if is not None
            and unit_mistake(est_if.radius_m, nominal, vp.radius_tolerance) is None
        ]
        if fit:
            looks = " or ".join(looks for _, looks, _, _ in fit)
            implied = ", ".join(f"{e.radius_m:.4g} m {said}" for e, _, said, _ in fit)
            problems.append(
                Problem(
                    file,
                    None,
                    f"{lat} / {lon}",
                    "latitude and longitude in decimal degrees",
                    f"latitude and longitude look like {looks}: every value within ±π, and "
                    f"the wheels imply a tyre radius of {est.radius_m:.4g} m as they are, "
                    f"{implied} (nominal {nominal} m)",
                    "; ".join(fix for *_, fix in fit),
                )
            )
            return problems, radius
        problems.append(
            Problem(
                file,
                None,
                f"{columns.get(c.OMEGA_RL, c.OMEGA_RL)} / {columns.get(c.OMEGA_RR, c.OMEGA_RR)}",
                f"rear wheel speeds in rad/s implying an effective radius within "
                f"±{vp.radius_tolerance:.0%} of {entry['vehicle']}'s nominal {nominal} m "
                f"(GNSS distance / wheel angle over {est.moving_s} moving s)",
                mistake,
                "convert the wheel speeds to rad/s (a column map can declare rpm or deg/s), "
                "or correct "
                + (radius_from or f"data.vehicles.{entry['vehicle']}.nominal_radius_m"),
            )
        )
    return problems, radius


class StreamRadiusCheck:
    """validate's unit checks on a drive that arrives block by block (``rwhonet predict``).

    The rows (canonical channels, the time on the drive's continuous clock, wheel glitches
    already repaired) are kept until validate's GNSS policy (:func:`assess`, the same
    ``validate.gnss`` and sample period) finds ``validate.radius_min_moving_s`` moving
    seconds in valid segments; then :func:`radius_problems` decides, once: wheel speeds
    that do not fit the nominal radius against the GNSS distance are refused with the
    report validate gives. The rows of a drive with a yaw rate (in its first block) are
    kept on until :func:`yaw_problems` can tell too (the course has turned enough),
    without holding the wheel check's decision: a yaw rate that turns the wrong way is
    refused as validate refuses it, when that is told; so are an axle's left and right
    wheels exchanged (:func:`side_problems`) and the front and rear axles'
    (:func:`axle_problems`), on every drive, until told (a track that turned too little
    keeps them to its end). Rows without a fix are bad rows for
    the policy (a stream may miss fixes; validate's schema refuses them). A drive that
    ends undecided (no GNSS, or too few moving seconds) leaves :attr:`note` saying why
    the wheels were not checked, and :attr:`yaw_note` why the yaw rate was not. The
    policy runs when the rows have grown by half since the last try (at least 30 s), so
    the work stays within a few times one pass over the rows kept.

    Once the unit check has decided, validate's wheel-sensor checks (:func:`wheel_problems`:
    a stuck or silent wheel, stale values) run every :attr:`SENSOR_STEP_S` of rows on those
    rows and the :attr:`SENSOR_CONTEXT_S` before them, so a live stream is stopped within
    about a minute of such a stretch rather than at its end (the work stays one pass
    over the rows, a few times over), and at the drive's end on the rows not checked yet.
    The sign check tallies each wheel's negative and moving rows as they come
    (:class:`~rwhonet.data.plausibility.SignTally`): a wheel negative while another turns
    forwards is refused when seen (validate refuses it whatever its share), a column
    negative on more than ``validate.wheels.signed_max_share`` of the moving rows at the
    drive's end (a share of the whole drive). Only those tallies and the last
    :attr:`SENSOR_CONTEXT_S` of rows are kept once the unit check has decided, and for the
    wheel-sides check the last :attr:`SIDES_WINDOW_S`, so the memory of a live stream does
    not grow with its length (before that decision, which takes GNSS, every row is kept;
    and while a yaw rate is not told).

    Attributes:
        decided: True once the wheel check has run (or the drive ended).
        yaw_decided: True once the yaw-rate check has told (or there is no yaw rate, or
            the drive ended).
        note: why the wheel check could not run (None: it ran, or not decided yet).
        yaw_note: why the yaw-rate check could not tell (None: it did, the drive has no
            yaw rate, or not decided yet).
        sides_decided: True once the wheel-sides check has told (or the drive ended).
        sides_note: why the wheel-sides check could not tell (None: it did, or not
            decided yet).
        axles_decided: True once the wheel-axles check has told (or the drive ended).
        axles_note: why the wheel-axles check could not tell (None: it did, or not
            decided yet).
    """

    KEYS = (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)
    # the wheel-sensor checks while the drive streams: every 60 s of rows, on those rows and
    # the 60 s before them (at least validate.gnss.min_segment_s + validate.wheels.stuck_min_s
    # + 5 s: a stretch too short to tell at the last check, or in a GNSS segment too short
    # to count then, started within that time before it; a longer one was told then)
    SENSOR_STEP_S = 60.0  # 30 s: about twice the cost (+0.13-0.23 s an hour of rows)
    SENSOR_CONTEXT_S = 60.0
    # the wheel-sides and wheel-axles checks, once the others have decided, on the last 10
    # min of rows (a motorway that never turns enough to tell is not kept whole; the sides
    # are told on ~30 s of turns, the axles on 10 pairs of seconds in tight turns)
    SIDES_WINDOW_S = 600.0

    def __init__(
        self,
        entry: dict[str, Any],
        nominal_m: float,
        vp: ValidateParams,
        radius_from: str | None = None,
        track_m: float = DEFAULT_TRACK_M,
    ) -> None:
        self.entry, self.nominal_m, self.vp, self.radius_from = entry, nominal_m, vp, radius_from
        self.track_m = track_m
        self.parts: list[dict[str, np.ndarray]] = []
        self.keys: tuple[str, ...] | None = None  # KEYS, and the yaw rate if the drive has one
        self.n_rows = 0
        per_s = 1.0 / vp.sample_period_s
        self.next_try = int(np.ceil((vp.radius_min_moving_s + 2.0) * per_s))
        self.step_rows = int(np.ceil(30.0 * per_s))
        self.decided = self.yaw_decided = self.sides_decided = self.axles_decided = False
        self.note: str | None = None
        self.yaw_note: str | None = None
        self.sides_note: str | None = None
        self.axles_note: str | None = None
        self.wheel_parts: list[dict[str, np.ndarray]] = []  # the rows not checked, and context
        self.n_wheel_rows = 0  # rows pushed (the range check's row numbers)
        self.range_problems: list[Problem] = []  # each wheel's first row out of range
        self.sensor_rows = int(np.ceil(self.SENSOR_STEP_S * per_s))
        context_s = max(self.SENSOR_CONTEXT_S, vp.gnss.min_segment_s + vp.wheels.stuck_min_s + 5.0)
        self.sensor_context = int(np.ceil(context_s * per_s))
        self.sensor_checked = 0  # rows the last wheel-sensor check reached
        self.signs = dict.fromkeys(c.WHEELS, SignTally())  # validate's sign check so far
        self.last_row: dict[str, np.ndarray] | None = None  # the GNSS step into a block

    def push(
        self,
        columns: Mapping[str, np.ndarray],
        raw: Mapping[str, np.ndarray] | None = None,
        first_row: int | None = None,
    ) -> bool:
        """Add rows; return whether the checks have decided.

        Args:
            columns: the rows (their wheel glitches repaired).
            raw: the same rows as the file has them, for the range check's report (None:
                ``columns``).
            first_row: the file's data row of the first of them, the others following it
                (None: the row after the last one pushed). Rows written twice may have
                been dropped between two blocks (:class:`rwhonet.data.droprows.RowFilter`).

        Raises:
            InputError: a wheel speed beyond ``validate.max_abs_wheel_speed_rad_s``, the
                wheel speeds do not fit the nominal radius against GNSS, or the yaw rate
                does not turn as the GNSS course does, or an axle's wheels turn against it.
        """
        block = {k: np.asarray(columns[k], dtype=np.float64) for k in self.KEYS}
        first = self.n_wheel_rows + 1 if first_row is None else int(first_row)
        block[FILE_ROW] = first + np.arange(block[c.T_S].size, dtype=np.float64)
        self.wheel_parts.append(block)
        self._tally_signs(block)
        self._in_range(block, columns if raw is None else raw)
        if not self._all_decided():
            if self.keys is None:
                self.keys = self.KEYS + ((c.YAW_RATE_RAD_S,) if c.YAW_RATE_RAD_S in columns else ())
            self.parts.append({k: np.asarray(columns[k], dtype=np.float64) for k in self.keys})
            self.n_rows += self.parts[-1][c.T_S].size
            if self.n_rows >= self.next_try:
                self._try(final=False)
        # the wheel-sensor checks once the unit check has decided (a wrong unit is named
        # first, as at the drive's end: wheel speeds in m/s read as rad/s look silent)
        if self.decided and self.n_wheel_rows - self.sensor_checked >= self.sensor_rows:
            n = min(
                self.n_wheel_rows, self.n_wheel_rows - self.sensor_checked + self.sensor_context
            )
            self._refuse_sensors(self._tail(n))
            self.sensor_checked = self.n_wheel_rows
            self.wheel_parts = [self._tail(min(self.n_wheel_rows, self.sensor_context))]
        if self.decided:
            self._sensor_refusal(self._sign_problems(final=False))
        return self.decided

    def finish(self) -> str | None:
        """At the drive's end: decide on the rows that came; return :attr:`note`.

        Raises:
            InputError: as :meth:`push`.
        """
        if not self._all_decided():
            self._try(final=True)
        self._refuse_range()
        self._wheel_sensors(self._sign_problems(final=True))
        return self.note

    def _tally_signs(self, block: dict[str, np.ndarray]) -> None:
        """Add a block's rows to the sign check's tallies (the GNSS step into its first row
        from the block before's last)."""
        if block[c.T_S].size == 0:
            return
        lead = 0 if self.last_row is None else 1
        rows = block if lead == 0 else {k: np.r_[self.last_row[k], block[k]] for k in self.KEYS}
        w = self.vp.wheels
        tallies = sign_tallies(
            rows,
            w.negative_tol_rad_s,
            self.vp.gnss.moving_wheel_speed_rad_s,
            row0=int(block[FILE_ROW][0]) - 1 if block[c.T_S].size else 0,  # the file's rows
            lead=lead,
        )
        self.signs = {k: self.signs[k].add(tallies[k]) for k in c.WHEELS}
        self.last_row = {k: v[-1:] for k, v in block.items()}

    def _sign_problems(self, final: bool) -> list[Problem]:
        """validate's sign check on the tallies: at the drive's end (``final``), or, while
        it streams, of a wheel negative while another turns forwards, which validate
        refuses whatever its share."""
        columns = self.entry["columns"]
        problems = [
            sign_problem(self.vp, self.entry["source_file"], columns.get(k, k), t, not final)
            for k, t in self.signs.items()
            if final or not t.reversing
        ]
        return [p for p in problems if p is not None]

    def _in_range(self, rows: Mapping[str, np.ndarray], raw: Mapping[str, np.ndarray]) -> None:
        """validate's range check of the wheel speeds, on the rows as they come.

        The stream has repaired its glitches (a one-row spike) before; what is left out
        of range (a CAN signal's invalid code held for seconds, 655.35 rad/s at full
        scale, which the stream's glitch repair can only interpolate towards) is refused
        as validate refuses it.

        Raises:
            InputError: naming each wheel's first row beyond the limit after the repair,
                with the value the file has there.
        """
        limit = self.vp.max_abs_wheel_speed_rad_s
        self.n_wheel_rows += rows[c.T_S].size
        problems = []
        for w in c.WHEELS:
            with np.errstate(invalid="ignore"):
                bad = np.flatnonzero(np.abs(rows[w]) >= limit)
            problems += [
                Problem(
                    self.entry["source_file"],
                    int(rows[FILE_ROW][i]),
                    self.entry["columns"].get(w, w),
                    f"|wheel speed| < {limit:g} rad/s (validate.max_abs_wheel_speed_rad_s)",
                    f"{float(raw[w][i]):.6g} rad/s",
                    "a value a wheel cannot turn at: a signal's invalid code or a unit mistake; "
                    "export the wheel speeds without it (an empty cell stops predict too)",
                )
                for i in bad[:1]
            ]
        # a unit mistake (rpm for rad/s) puts whole drives out of range: the unit check
        # names it, so the range refusal waits for its decision as validate's report has it
        seen = {p.column for p in self.range_problems}
        self.range_problems += [p for p in problems if p.column not in seen]
        if self.decided:
            self._refuse_range()

    def _refuse_range(self) -> None:
        if self.range_problems:
            raise InputError(
                self.range_problems,
                f"{self.entry['source_file']}: wheel speeds beyond any tyre's (validate's "
                "range check)",
            )

    def _tail(self, n: int) -> dict[str, np.ndarray]:
        """The last ``n`` rows kept."""
        parts, got = [], 0
        for part in reversed(self.wheel_parts):
            parts.append(part)
            got += part[c.T_S].size
            if got >= n:
                break
        keys = (*self.KEYS, FILE_ROW)
        return {k: np.concatenate([p[k] for p in reversed(parts)])[got - n :] for k in keys}

    def _wheel_sensors(self, signs: list[Problem]) -> None:
        """validate's wheel-sensor checks at the drive's end: the stuck, silent and stale
        checks on the rows not checked yet and the context before them, refused with the
        sign check's ``signs``.

        Raises:
            InputError: as validate refuses the drive.
        """
        if self.wheel_parts and self.n_wheel_rows > self.sensor_checked:
            n = min(
                self.n_wheel_rows, self.n_wheel_rows - self.sensor_checked + self.sensor_context
            )
            self._refuse_sensors(self._tail(n), signs=signs)
            self.sensor_checked = self.n_wheel_rows
        self._sensor_refusal(signs)
        self.wheel_parts = []

    def _refuse_sensors(self, rows: dict[str, np.ndarray], signs: Sequence[Problem] = ()) -> None:
        """validate's stuck, silent and stale checks (:func:`wheel_problems` without the
        sign check, which the tallies make) on ``rows``, the drive's (each with its data
        row in the file, ``FILE_ROW``); refused with ``signs``, the sign check's problems,
        before them.

        Raises:
            InputError: as validate refuses the drive.
        """
        fix = np.isfinite(rows[c.LAT_DEG]) & np.isfinite(rows[c.LON_DEG])
        result = assess(rows, self.vp.gnss, self.vp.sample_period_s, wheel_glitch=~fix)
        entry = {"drive": self.entry["source_file"]} | self.entry
        found = wheel_problems(
            self.vp,
            self.nominal_m,
            entry,
            rows,
            [],
            result,
            False,
            numbering=lambda i: int(rows[FILE_ROW][i]),
        )
        self._sensor_refusal([*signs, *found])

    def _sensor_refusal(self, problems: list[Problem]) -> None:
        if problems:
            raise InputError(
                problems,
                f"{self.entry['source_file']}: wheel speeds validate refuses (validate's "
                "wheel-sensor checks: sign, stuck or silent wheels)",
            )

    def _all_decided(self) -> bool:
        return self.decided and self.yaw_decided and self.sides_decided and self.axles_decided

    def _try(self, final: bool) -> None:
        if not self.parts:  # a drive that ended without a row: nothing to tell
            self.decided = self.yaw_decided = self.sides_decided = self.axles_decided = True
            self.note = self._why_not(False, {})
            return
        keys = self.keys or self.KEYS
        rows = {k: np.concatenate([p[k] for p in self.parts]) for k in keys}
        self.parts = [rows]
        fix = np.isfinite(rows[c.LAT_DEG]) & np.isfinite(rows[c.LON_DEG])
        problems, record = [], {"checked": self.decided}
        yaw_record = {
            "checked": self.yaw_decided or c.YAW_RATE_RAD_S not in rows,
            "note": "no GNSS-valid stretch",
        }
        sides_record: dict[str, Any] = {"checked": False, "note": "no GNSS-valid stretch"}
        axles_record: dict[str, Any] = dict(sides_record)
        if rows[c.T_S].size > 1 and fix.any():
            result = assess(rows, self.vp.gnss, self.vp.sample_period_s, wheel_glitch=~fix)
            if result.segments and not self.decided:
                problems, record = radius_problems(
                    self.entry,
                    rows,
                    result.segments,
                    self.nominal_m,
                    self.vp,
                    radius_from=self.radius_from,
                )
            turns = None
            if result.segments and not (
                yaw_record["checked"] and self.sides_decided and self.axles_decided
            ):
                turns = course_turns(rows, result.segments, YAW_MIN_STEP_M, self.vp.sample_period_s)
            if result.segments and not yaw_record["checked"]:
                yawed, yaw_record = yaw_problems(self.entry, rows, result.segments, self.vp, turns)
                if yawed:
                    raise InputError(
                        yawed,
                        f"{self.entry['source_file']}: a yaw rate and a GNSS course that do "
                        "not turn alike (validate's yaw-rate check)",
                    )
            if result.segments and not self.sides_decided:
                sided, sides_record = side_problems(
                    self.entry, rows, result.segments, self.vp, self.nominal_m, self.track_m, turns
                )
                if sided:
                    raise InputError(
                        sided,
                        f"{self.entry['source_file']}: wheel speeds that turn the car "
                        "against the GNSS course (validate's wheel-sides check)",
                    )
            if result.segments and not self.axles_decided:
                axled, axles_record = axle_problems(
                    self.entry, rows, result.segments, self.vp, self.nominal_m, turns
                )
                if axled:
                    raise InputError(
                        axled,
                        f"{self.entry['source_file']}: front wheels slower than the rear in "
                        "the turns (validate's wheel-axles check)",
                    )
        if problems:
            raise InputError(
                problems,
                f"{self.entry['source_file']}: wheel speeds that do not fit the car's tyre "
                "radius against the GNSS distance (validate's unit check)",
            )
        if not self.decided and (record["checked"] or final):
            self.decided = True
            self._refuse_range()
            if not record["checked"]:
                self.note = self._why_not(fix.any(), record)
        if not self.yaw_decided and (yaw_record["checked"] or final):
            self.yaw_decided = True
            if not yaw_record["checked"]:
                self.yaw_note = (
                    f"{self.entry['source_file']}: yaw rate's unit and sign not told against "
                    "the GNSS course (validate's yaw-rate check): " + yaw_record["note"]
                )
        if not self.sides_decided and (sides_record["checked"] or final):
            self.sides_decided = True
            if not sides_record["checked"]:
                self.sides_note = (
                    f"{self.entry['source_file']}: left and right wheels not told against the "
                    "GNSS course (validate's wheel-sides check): " + sides_record["note"]
                )
        if not self.axles_decided and (axles_record["checked"] or final):
            self.axles_decided = True
            if not axles_record["checked"]:
                self.axles_note = (
                    f"{self.entry['source_file']}: front and rear wheels not told against the "
                    "GNSS course (validate's wheel-axles check): " + axles_record["note"]
                )
        if self._all_decided():
            self.parts = []
            return
        if self.decided and self.yaw_decided:  # only the wheels' places: the last stretch
            keep = int(np.ceil(self.SIDES_WINDOW_S / self.vp.sample_period_s))
            if rows[c.T_S].size > keep:
                self.parts = [{k: v[-keep:] for k, v in rows.items()}]
                self.n_rows = keep
        self.next_try = max(int(1.5 * self.n_rows), self.n_rows + self.step_rows)

    def _why_not(self, any_fix: bool, record: dict[str, Any]) -> str:
        file, vp = self.entry["source_file"], self.vp
        what = "wheel speeds' unit not checked against GNSS (validate's tyre-radius check)"
        if not any_fix:
            return f"{file}: {what}: the drive has no GNSS fix; make sure they are rad/s"
        moving = record.get("moving_s", 0)
        return (
            f"{file}: {what}: only {moving} moving s in GNSS-valid stretches of >= "
            f"{vp.gnss.min_segment_s:g} s (validate.radius_min_moving_s "
            f"{vp.radius_min_moving_s:g})"
        )


def _swapped_problem(
    entry: dict[str, Any],
    radius_m: float | None,
    swapped_m: float | None,
    nominal_m: float | None,
    evidence: str | None = None,
) -> Problem:
    """Latitude and longitude look swapped (by the radius they imply, by their ranges, or
    by the way the course turns against the yaw rate: ``evidence``)."""
    columns = entry["columns"]
    lat, lon = columns.get(c.LAT_DEG, c.LAT_DEG), columns.get(c.LON_DEG, c.LON_DEG)
    if evidence is None and radius_m is None:
        evidence = (
            f"most values of {lat!r} lie beyond ±90 deg and every value of {lon!r} within ±90 deg"
        )
    elif evidence is None:
        evidence = (
            f"the wheels imply a tyre radius of {radius_m:.4g} m as the columns are, and "
            f"{swapped_m:.4g} m (nominal {nominal_m} m) with the two exchanged"
        )
    return Problem(
        entry["source_file"],
        None,
        f"{lat} / {lon}",
        f"the latitude in {lat!r} and the longitude in {lon!r}",
        f"latitude and longitude look swapped: {evidence}",
        "exchange the two columns (their names in the header, or lat and lon in the column map)",
    )


def _swapped_by_range(
    found: list[Problem], df: Mapping[str, np.ndarray], entry: dict[str, Any]
) -> list[Problem]:
    """Replace the latitude range failures of a drive with swapped columns by one problem."""
    lat = entry["columns"].get(c.LAT_DEG, c.LAT_DEG)
    if not any(p.column == lat and "latitude in [-90, 90]" in p.expected for p in found):
        return found
    if not latlon_swapped_by_range(df[c.LAT_DEG], df[c.LON_DEG]):
        return found
    rest = [p for p in found if not (p.column == lat and "latitude in [-90, 90]" in p.expected)]
    return [_swapped_problem(entry, None, None, None), *rest]


@np.errstate(invalid="ignore", over="ignore", divide="ignore")
def sign_problem(
    vp: ValidateParams,
    file: str,
    column: str,
    tally: SignTally,
    so_far: bool = False,
    file_rows: Callable[[int], int] | None = None,
) -> Problem | None:
    """validate's sign check of one wheel from its :class:`SignTally`.

    Wheel speeds are magnitudes; a signing logger's reversing (all four wheels negative
    together) passes on at most ``validate.wheels.signed_max_share`` of the moving rows.

    Args:
        vp: ``validate``.
        file: the drive's file.
        column: the wheel's column as the file names it.
        tally: the wheel's tally over the drive (or a stream's rows so far).
        so_far: the tally is of a stream's first rows (the report says so).
        file_rows: the file's data row of each of the tally's rows (None: row ``i`` is
            data row ``i + 1``; :mod:`rwhonet.data.droprows`).

    Returns:
        The problem, or None when the wheel passes.
    """
    if tally.negative == 0:
        return None
    share = tally.share
    if share <= vp.wheels.signed_max_share and tally.reversing:
        return None  # a signing logger's reversing: label takes the magnitudes
    what = (
        "the column looks negated (a sign error in the export)"
        if share > vp.wheels.signed_max_share
        else "one wheel negative while another turns forwards (not reversing)"
    )
    numbering = file_rows if file_rows is not None else FileRows()
    first = numbering(tally.first_row)
    rows = f"{first}-{numbering(tally.last_row)}"
    return Problem(
        file,
        first,
        column,
        "wheel speeds as magnitudes >= 0 (as ABS sensors give them), or all four "
        "negative together while reversing on at most "
        f"{vp.wheels.signed_max_share:.0%} of the moving rows "
        f"(validate.wheels.negative_tol_rad_s {vp.wheels.negative_tol_rad_s}, "
        "signed_max_share)",
        f"{tally.first_value:.6g} rad/s, negative in {tally.negative} row(s) (rows {rows}; "
        f"{share:.0%} of the moving rows{' so far' if so_far else ''}) while "
        f"GNSS moved {tally.gnss_m:.0f} m: {what}",
        "export the absolute wheel speeds (|value|), or negate this column: the "
        "pipeline takes the direction from GNSS, never from the wheel speed's sign",
    )


def wheel_problems(
    vp: ValidateParams,
    nominal_m: float,
    entry: dict[str, Any],
    df: Mapping[str, np.ndarray],
    drive_cuts: list[CutSpec],
    result: Assessment,
    signs: bool = True,
    numbering: Callable[[int], int] | None = None,
) -> list[Problem]:
    """Negative wheel speeds (a sign error), stuck wheel sensors and no wheel data at all.

    Args:
        vp: ``validate``.
        nominal_m: the car's nominal tyre radius, m.
        entry: ``source_file``, ``columns`` (canonical -> the file's name), ``drive``.
        df: the canonical drive.
        drive_cuts: its manual cuts (``validate.cuts``).
        result: validate's GNSS assessment of it.
        signs: False leaves out the sign check, whose verdict (the share of the moving rows
            that are negative) needs the whole drive: a stream's checks before its end. A
            stuck, silent or stale stretch is one wherever the drive goes on.
        numbering: the file's data row (1-based) of ``df``'s row ``i`` (0-based), for the
            rows the problems name (a stream's window of its rows); None: the entry's
            (:meth:`rwhonet.data.droprows.FileRows.of`: a 10 Hz file may have lost rows
            written twice).
    """
    file, columns = entry["source_file"], entry["columns"]
    row_of = FileRows.of(entry) if numbering is None else numbering
    ignore = manual_rows(np.asarray(df[c.T_S], dtype=np.float64), drive_cuts)
    problems = []
    t = np.asarray(df[c.T_S], dtype=np.float64)
    if signs:
        tallies = sign_tallies(
            df, vp.wheels.negative_tol_rad_s, vp.gnss.moving_wheel_speed_rad_s, ignore
        )
        for wheel, tally in tallies.items():
            problem = sign_problem(vp, file, columns.get(wheel, wheel), tally, file_rows=row_of)
            if problem is not None:
                problems.append(problem)
    runs = stuck_wheel_runs(df, vp.wheels, vp.sample_period_s, ignore)
    by_wheel: dict[str, list] = {}
    for run in runs:
        by_wheel.setdefault(run.wheel, []).append(run)

    def stretch(run) -> tuple[float, float, str]:
        """The run's first and last time, and its length and rows as the messages say them."""
        start, end = t[run.row_start], t[run.row_stop - 1]
        return (
            start,
            end,
            f"{(run.row_stop - run.row_start) * vp.sample_period_s:.4g} s (rows "
            f"{row_of(run.row_start)}-{row_of(run.row_stop - 1)}, "
            f"t = {start:.6g}-{end:.6g} s)",
        )

    def cut_it(start: float, end: float, reason: str) -> str:
        return (
            f"validate.cuts: [{{drive: {entry['drive']}, start_s: {np.floor(start):.0f}, "
            f"end_s: {np.ceil(end):.0f}, reason: {reason}}}]"
        )

    def stuck(run) -> Problem:
        start, end, where = stretch(run)
        return Problem(
            file,
            row_of(run.row_start),
            columns.get(run.wheel, run.wheel),
            "each wheel turning with the others while the car moves (at least "
            f"{vp.wheels.stuck_ratio} x the median of the four wheels for any "
            f"{vp.wheels.stuck_min_s} s; validate.wheels)",
            f"at most {run.reading_max_rad_s:.3g} rad/s for {where} while the median wheel "
            f"turned at {run.others_median_rad_s:.3g} rad/s and GNSS moved "
            f"{gnss_path_m(df, np.arange(run.row_start, run.row_stop)):.0f} m: a stuck or "
            "disconnected wheel-speed sensor",
            "check this wheel's sensor and channel in the export; to keep the rest of the "
            f"drive, cut the stretch: {cut_it(start, end, 'stuck wheel sensor')}",
        )

    for wheel_runs in by_wheel.values():
        problems += stretch_problems(wheel_runs, stuck)
    wheels = " / ".join(columns.get(w, w).strip() for w in c.WHEELS)

    def all_four(run, expected: str, found: Callable[[str], str], reason: str) -> Problem:
        """A stretch where the four wheel speeds together disagree with GNSS."""
        start, end, where = stretch(run)
        return Problem(
            file,
            row_of(run.row_start),
            wheels,
            expected,
            found(where),
            "export the wheel speeds of this stretch; to keep the rest of the drive, cut "
            f"it: {cut_it(start, end, reason)}",
        )

    def silent(run) -> Problem:
        return all_four(
            run,
            "wheel speeds that follow the GNSS speed (the median of the four at least "
            f"{vp.wheels.stuck_ratio} x GNSS speed / nominal radius, whenever that exceeds "
            f"{vp.wheels.stuck_moving_rad_s} rad/s for {vp.wheels.stuck_min_s} s; "
            "validate.wheels)",
            lambda where: (
                f"all four at most {run.wheels_max_rad_s:.3g} rad/s for {where} "
                f"while GNSS moved {run.gnss_m:.0f} m at up to {run.gnss_max_m_s:.3g} m/s: no "
                "wheel data (a CAN channel that stopped logging, or wheel columns left as zeros?)"
            ),
            "no wheel data",
        )

    def stale(run) -> Problem:
        return all_four(
            run,
            "wheel speeds that change with the car's speed (never all four repeating one "
            f"value for {vp.wheels.stuck_min_s} s while GNSS speed changes by more than "
            f"{vp.wheels.stuck_moving_rad_s} rad/s x the nominal radius; validate.wheels)",
            lambda where: (
                f"the same values (median {run.wheels_rad_s:.4g} rad/s) in every row "
                f"for {where} while the GNSS speed went between {run.gnss_min_m_s:.3g} and "
                f"{run.gnss_max_m_s:.3g} m/s: stale wheel data (a logger repeating the last CAN "
                "value?)"
            ),
            "stale wheel data",
        )

    runs = wheel_gnss_runs(df, result.segments, nominal_m, vp.wheels, vp.sample_period_s, ignore)
    for found, problem in zip(runs, (silent, stale), strict=True):
        problems += stretch_problems(found, problem)
    return problems


def _glitches_out_of_range(
    found: list[Problem],
    df: Mapping[str, np.ndarray],
    glitch: np.ndarray,
    columns: dict[str, str],
    vp: ValidateParams,
) -> list[Problem]:
    """The schema's problems, less wheel speeds out of range that are all glitches.

    A one-row CAN glitch at speed (a wheel at ten times 40 rad/s) is beyond
    ``validate.max_abs_wheel_speed_rad_s`` as well as beyond what a tyre can do; when
    every out-of-range wheel speed lies in a row the glitch screen flagged, those rows are
    cut as ``wheel_glitch`` (and listed) like any glitch, rather than the drive refused. A
    value out of range in a row that did not glitch (a wrong unit throughout, a stuck
    counter) is still a problem.
    """
    if not found or not glitch.any():
        return found
    with np.errstate(invalid="ignore"):
        out = np.zeros(glitch.size, dtype=bool)
        for w in c.WHEELS:
            out |= ~(np.abs(np.asarray(df[w], dtype=np.float64)) < vp.max_abs_wheel_speed_rad_s)
    if not out.any() or not glitch[out].all():
        return found
    wheels = {columns.get(w, w) for w in c.WHEELS}
    return [
        p
        for p in found
        if not (p.column in wheels and "validate.max_abs_wheel_speed_rad_s" in p.expected)
    ]


def _only_wheel_ranges(
    found: list[Problem], df: Mapping[str, np.ndarray], columns: dict[str, str]
) -> bool:
    """Whether a drive's only schema problems are wheel speeds out of range (no NaN)."""
    wheels = {columns.get(w, w) for w in c.WHEELS}
    return all(p.column in wheels for p in found) and not any(
        np.isnan(np.asarray(df[w], dtype=np.float64)).any() for w in c.WHEELS
    )


def _dropped_hint(result: Assessment, vp: ValidateParams) -> str:
    """What to do when dropped samples cut a drive into pieces (more than its first and
    last partial second cut as ``partial_second``), for a refusal's fix."""
    n = result.cut_seconds_by_rule.get("partial_second", 0)
    if n <= 2:
        return ""
    return (
        f"; {n} s were cut as partial_second (a second that lost a sample is cut and splits "
        "the drive there, so a logger that drops samples often leaves stretches shorter than "
        f"validate.gnss.min_segment_s, {vp.gnss.min_segment_s:g} s): export the drive again "
        "without the drops where the logger can"
    )


def _first_detail(result: Assessment, rule: str) -> str:
    return next(cut.detail for cut in result.cuts if cut.rule == rule)
