"""The evaluation study: every model and control, every seed, on the same test seconds.

Paper §3.2, §3.5. Every model is scored on the part of each test drive that
comes after the largest m of the grid (:mod:`rwhonet.evaluation.windows`), so no
R-WhONet is scored on seconds it was adapted on, and all models (and all m)
see exactly the same windows. The models are :mod:`rwhonet.evaluation.names`'.

Each trained model is scored once per training seed; a cell of the summary is
the mean over seeds with a 95 % t interval (:mod:`rwhonet.evaluation.intervals`).
The WPMs do not depend on the seed (interval 0). Paired differences and gains
over the WPMs are computed per seed, then averaged; "do no harm" counts the
(drive, seed) pairs where a recalibrated model is worse than G
(:mod:`rwhonet.evaluation.paired`). G and the WPM are also scored on held-out
drives of the source car (role ``source_test``, when there are any): the
domain gap. Beyond the paper: CRSE over time, the limits of recalibrating
from m s, the scenario outages, each model's predicted uncertainty and its
calibration (:mod:`rwhonet.evaluation.uncertainty`), and the 2D position at the
end of every outage from the navigation filter, with its controls and the
earlier dead reckoning (:mod:`rwhonet.evaluation.position`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import ConfigError, Params
from rwhonet.evaluation.intervals import over_seeds
from rwhonet.evaluation.limits import radius_limits
from rwhonet.evaluation.model_errors import model_errors, refit_wpm
from rwhonet.evaluation.names import aliases, position_models, scenario_models
from rwhonet.evaluation.over_time import crse_over_time
from rwhonet.evaluation.paired import no_harm, paired
from rwhonet.evaluation.position import (
    HEADING_ONLY,
    WINDOW_STATS,
    calibrate_on_training,
    filter_models,
    filter_windows,
    fit_geometry,
    fit_noise,
    gnss_run,
    model_runs,
    nav_config,
    position_errors,
    position_per_seed,
    target_windows,
    training_passes,
    window_tracks,
)
from rwhonet.evaluation.result import Evaluation, eval_json
from rwhonet.evaluation.scenarios import (
    PER_SECOND_MODELS,
    scenario_errors,
    scenario_outage_scores,
    scenario_outage_summary,
    scenario_windows,
)
from rwhonet.evaluation.scoring import SEED_VALUES, STATS, score_seed
from rwhonet.evaluation.selection import Choice
from rwhonet.evaluation.uncertainty import (
    ASSUMED,
    FitEvidence,
    crse_check,
    fit_variances,
    training_errors,
)
from rwhonet.evaluation.windows import evaluated_seconds

CRSE_CHECK = (
    "cover_1sigma",
    "cover_2sigma",
    "nll",
    "cover_1sigma_independent",
    "cover_2sigma_independent",
    "second_cover_1sigma",
    "second_cover_2sigma",
)
VARIANCE = (
    "a_m2",
    "b",
    "crse_scale",
    "crse_spread",
    "crse_lasting",
    "scale_sd",
    "n_seconds",
    "n_windows",
)


def _with_aliases(rows: list[dict], params: Params, choice: Choice) -> list[dict]:
    """Copy each aliased recipe model's rows under its alias (``R``, ``R@m``)."""
    by_model: dict[str, list[dict]] = {}
    for r in rows:
        by_model.setdefault(r["model"], []).append(r)
    extra = [
        {**r, "model": alias}
        for alias, model in aliases(params, choice).items()
        for r in by_model.get(model, [])
    ]
    return rows + extra


def shortest_runs(
    errors: Mapping[str, np.ndarray | dict[int, np.ndarray]], outages: Sequence[int]
) -> dict[str, np.ndarray]:
    """One per-second error array per model: a continuous recipe's (one array per outage
    length, predicted inside that length's windows) is its shortest outage's run.

    What the scenario outages and the per-second scenario errors read, whichever recipe
    R-WhONet is (the rule may choose a continuous one).
    """
    return {name: e[min(outages)] if isinstance(e, dict) else e for name, e in errors.items()}


def evaluate(
    params: Params,
    choice: Choice,
    frame: pd.DataFrame,
    preds: dict[int, pd.DataFrame],
    selection: pd.DataFrame | None = None,
    evidence: FitEvidence | None = None,
) -> Evaluation:
    """Score every model and control for every seed; average over seeds with intervals.

    Args:
        params: ``seeds``, ``adapt``, ``evaluate``, ``label``, the target car
            (``data.roles``, its nominal radius and track, for dead reckoning).
        choice: R-WhONet (:func:`rwhonet.evaluation.selection.choose`).
        frame: the test drives' samples (every test role; ``drive, segment,
            group, k, role``, the sample columns and ``scenario``).
        preds: per seed, one prediction column per model row-aligned with
            ``frame`` (``G``, ``S``, ``R[paper]@50``...; ``R[continuous]/<L>s`` per
            outage length; R: NaN on source-car drives).
        selection: the selection evidence's scores
            (:func:`rwhonet.evaluation.selection.selection_scores`), to report.
        evidence: the target training drives and every seed's predictions of them,
            where each model's variance is fitted (none: every model gets
            :data:`rwhonet.evaluation.uncertainty.ASSUMED`, and says so).

    Returns:
        The evaluation, its ``eval_json`` filled in.
    """
    outages = params.evaluate.outages_s
    evaluated = evaluated_seconds(frame, params.adapt.m_grid, outages)
    wpm_m, refits = refit_wpm(frame, params)
    ev_frame = frame[evaluated].reset_index(drop=True)
    per_seed, curves, scen, timeline, positions, scen_out = [], [], [], [], [], []
    tracks = {L: window_tracks(frame, params, L) for L in outages}
    scenario = scenario_windows(frame, params.adapt.m_grid, params.evaluate.scenario_outage_s)
    alias = aliases(params, choice)["R"]
    # 2D: the navigation filter on every model's distances and the controls' (position)
    nav = navigation_plan(params, choice, frame)
    # the continuous recipes: no filter run (no distance before a window), a CRSE prediction
    continuous = [m for m in position_models(params, choice) if m not in nav["models"]]
    train_errors = (
        training_errors(evidence, nav["models"] + continuous, params)
        if evidence is not None
        else []
    )
    fits = fit_variances(evidence, train_errors, params) if evidence is not None else {}
    cfg = nav_config(params)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    group = frame["group"].to_numpy()
    test_windows = {L: target_windows(frame, params, L) for L in outages}
    drive_of = frame["drive"].to_numpy()
    runs, checks, variances, drive_checks = [], [], [], []
    for seed in params.seeds:
        errors = model_errors(frame, preds[seed], wpm_m, params)
        # The GNSS's own distances dead-reckoned: the error left is the heading's alone.
        in_2d = {HEADING_ONLY: np.zeros(len(frame))} | {
            m: errors[m] for m in position_models(params, choice)
        }
        positions += [{"seed": seed, **r} for r in position_errors(frame, tracks, in_2d)]
        for model in nav["models"]:
            fixed = model == "WPM" or model.startswith("WPM-m@")
            fit = fits.get((None if fixed else seed, model), ASSUMED)
            dist = gnss - errors[model]
            variances.append({"seed": seed, "model": model, **_variance_row(fit)})
            for L, rows in test_windows.items():
                checks.append(
                    {"seed": seed, "model": model, "outage_s": L}
                    | crse_check(errors[model], dist, rows, fit, group)
                )
                if model == alias:  # R-WhONet on each test drive's windows apart
                    drive_checks += [
                        {"seed": seed, "drive": d, "outage_s": L}
                        | crse_check(errors[model], dist, part, fit, group)
                        for d, part in _windows_by_drive(rows, drive_of)
                    ]
            if fixed and seed != params.seeds[0]:
                continue  # the same run for every seed
            runs += model_runs(model, None if fixed else seed, dist, fit, nav, outages)
        for model in continuous:  # each window's own distances, refitted before it
            fit = fits.get((seed, model), ASSUMED)
            variances.append({"seed": seed, "model": model, **_variance_row(fit)})
            for L, rows in test_windows.items():
                e = errors[model][L]
                checks.append(
                    {"seed": seed, "model": model, "outage_s": L}
                    | crse_check(e, gnss - e, rows, fit)
                )
                if model == alias:
                    drive_checks += [
                        {"seed": seed, "drive": d, "outage_s": L}
                        | crse_check(e, gnss - e, part, fit)
                        for d, part in _windows_by_drive(rows, drive_of)
                    ]
        if seed == params.seeds[0]:
            runs.append(gnss_run(gnss, nav, cfg))
        flat = shortest_runs(errors, outages)
        flat["R"] = flat[alias]
        scen_out += [
            {"seed": seed, **r}
            for r in scenario_outage_scores(
                scenario, {m: flat[m] for m in scenario_models(params, choice)}
            )
        ]
        errors = {
            name: {L: v[evaluated] for L, v in e.items()} if isinstance(e, dict) else e[evaluated]
            for name, e in errors.items()
        }
        errors["R"] = errors[alias]
        rows, seed_curves, seed_timeline = score_seed(ev_frame, errors, outages)
        rows = [r for r in rows if r["model"] != "R"]  # R comes back as an alias below
        per_seed += [{"seed": seed, **r} for r in _with_aliases(rows, params, choice)]
        curves += [c.assign(seed=seed) for c in seed_curves]
        timeline += [{"seed": seed, **t} for t in seed_timeline]
        scen.append(scenario_errors(ev_frame, shortest_runs(errors, outages)).assign(seed=seed))
    per_seed_df = pd.DataFrame(per_seed)
    keys = ["role", "drive", "model", "outage_s"]
    summary = over_seeds(per_seed_df, keys, SEED_VALUES)
    fixed = per_seed_df.groupby(keys, sort=False)[
        ["n_windows", *(f"dist_{s}" for s in STATS)]
    ].first()
    summary = summary.join(fixed, on=keys)
    scenarios = (
        pd.concat(scen)
        .groupby("tag", sort=False)
        .agg(n_seconds=("n_seconds", "first"), **{m: (m, "mean") for m in PER_SECOND_MODELS})
        .reset_index()
        .sort_values("n_seconds", ascending=False, ignore_index=True)
    )
    evolution = (
        pd.concat(curves)
        .groupby(["model", "outage_s", "second"], sort=False)[["crse_m", "cte_m"]]
        .mean()
        .reset_index()
    )
    dead = over_seeds(pd.DataFrame(positions), ["model", "outage_s"], ["pos_mean", "pos_max"])
    n_2d = pd.DataFrame(positions).groupby(["model", "outage_s"], sort=False)["n_windows"].first()
    dead = dead.join(n_2d, on=["model", "outage_s"])
    dead["n_windows_all"] = dead["outage_s"].map(
        {L: int(t["n_windows"]) for L, t in tracks.items()}
    )
    # the antenna and the gyro's latency fitted on the target training drives' fixes; the
    # receiver's drift and the gyro's bias instability, and the filter's covariance
    # calibrated (scale, tails), on their windows; then the test windows with those figures
    training = evidence.frame if evidence is not None else None
    filtered = [t for t in train_errors if not t.per_window]
    passes = (
        training_passes(evidence, filtered, params, nav, fits, outages, cfg)
        if training is not None and len(training)
        else []
    )
    geometry = fit_geometry(training, params, passes, nav, cfg)  # none: as configured
    cfg = geometry.apply(cfg)
    receiver, gyro = fit_noise(training, params, passes, nav, outages, cfg)  # or as configured
    cfg = gyro.apply(cfg.with_receiver(receiver.sigma_m))  # the runs stay: they do not read it
    calibrations = calibrate_on_training(training, params, passes, outages, cfg)[0]
    windows_2d = filter_windows(frame, params, runs, outages, cfg)
    nav_seed = position_per_seed(windows_2d, params.seeds, calibrations)
    counted = ["n_windows", "n_windows_all"]
    position = _seed_means(nav_seed, ["model", "control", "outage_s"], WINDOW_STATS, counted)
    # the controls' distance model, fused, each test drive's windows apart: the drives
    # differ (a leaking tyre, a heavy load, rain), and windows of one drive share them
    mine = (windows_2d["model"] == nav["control_model"]) & (windows_2d["control"] == nav["control"])
    by_drive = position_per_seed(windows_2d[mine], params.seeds, calibrations, by=("drive",))
    position_drives = _seed_means(by_drive, ["drive", "outage_s"], WINDOW_STATS, counted)
    uncertainty = _seed_means(pd.DataFrame(checks), ["model", "outage_s"], CRSE_CHECK)
    uncertainty_drives = _seed_means(pd.DataFrame(drive_checks), ["drive", "outage_s"], CRSE_CHECK)
    variance_df = pd.DataFrame(variances)
    gammas = [c for c in variance_df.columns if c.startswith("gamma_")]
    variance = over_seeds(variance_df, ["model"], [*VARIANCE, *gammas])
    differences, gains = paired(per_seed_df, params, choice)
    per_second = pd.concat(
        [
            frame.assign(evaluated=evaluated),
            *(pred.add_suffix(f"__seed{seed}") for seed, pred in preds.items()),
            pd.DataFrame({f"disp_wpm_m{m}_m": d for m, d in wpm_m.items()}, index=frame.index),
        ],
        axis=1,
    )
    result = Evaluation(
        choice=choice,
        per_seed=per_seed_df,
        summary=summary,
        differences=differences,
        gains=gains,
        harm=no_harm(per_seed_df, params),
        over_time=crse_over_time(pd.DataFrame(timeline), params, choice),
        scenarios=scenarios,
        refits=refits,
        per_second=per_second,
        evolution=evolution,
        selection=pd.DataFrame() if selection is None else selection,
        limits=radius_limits(frame, params),
        position=position,
        position_windows=windows_2d,
        position_drives=position_drives,
        position_dead_reckoning=dead,
        position_plan={key: v for key, v in nav.items() if key != "models"}
        | {"receiver": receiver.as_dict(), "geometry": geometry.as_dict(), "gyro": gyro.as_dict()},
        uncertainty=uncertainty,
        uncertainty_drives=uncertainty_drives,
        variance=variance.assign(fitted=evidence is not None),
        scenario_outages=scenario_outage_summary(pd.DataFrame(scen_out), scenario.counts),
        scenario_counts=scenario.counts,
        scenario_outage_s=scenario.outage_s,
    )
    return dataclasses.replace(result, eval_json=eval_json(result, params))


def _windows_by_drive(rows: np.ndarray, drive_of: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """Windows (``rows``: (W, L) row indices) split by the drive their first second is of."""
    first = drive_of[rows[:, 0]] if len(rows) else np.array([], dtype=object)
    return [(str(d), rows[first == d]) for d in dict.fromkeys(first)]


def _seed_means(
    per_seed: pd.DataFrame,
    keys: list[str],
    values: Sequence[str],
    counted: Sequence[str] = ("n_windows",),
) -> pd.DataFrame:
    """Per-seed cells (a row per seed and ``keys``) as means over seeds with their intervals
    (:func:`over_seeds`, the ``values`` present), with ``counted`` as the first seed has
    them (the same windows every seed); empty without cells."""
    if per_seed.empty:
        return pd.DataFrame()
    present = [c for c in values if c in per_seed]
    return over_seeds(per_seed, keys, present).join(
        per_seed.groupby(keys, sort=False)[list(counted)].first(), on=keys
    )


def _variance_row(fit) -> dict[str, float]:
    row = {key: float(getattr(fit, key)) for key in VARIANCE}
    return row | {f"gamma_{L}s": v for L, v in fit.outage_scale.items()}


def navigation_plan(params: Params, choice: Choice, frame: pd.DataFrame) -> dict:
    """Which filter runs the 2D evaluation makes.

    Returns:
        ``models`` (every model the filter runs on, the fused control or the wheels
        without a gyro), ``control`` (that control), ``control_model`` (whose
        distances the controls use, ``evaluate.navigation.control_model`` with ``R``
        resolved; G when R-WhONet is the continuous recipe), ``controls`` (the
        controls available: the gyro's and fused need a yaw rate on the target test
        drives) and ``unavailable`` (those not).

    Raises:
        ConfigError: ``control_model`` is none of the models.
    """
    models = filter_models(position_models(params, choice))
    wanted = params.evaluate.navigation.control_model
    control_model = choice.model if wanted == "R" else wanted
    if wanted == "R" and control_model not in models:
        control_model = "G"  # R[continuous]: no distances before a window; what it builds on
    if control_model not in models:
        raise ConfigError(
            f"evaluate.navigation.control_model: expected R or one of {models}, got {wanted!r}"
        )
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    gyro = frame[k.GYRO_YAW_RAD].to_numpy(np.float64)[target] if k.GYRO_YAW_RAD in frame else []
    has_gyro = bool(np.isfinite(gyro).any())
    controls = ["wheels", "gyro", "fused"] if has_gyro else ["wheels"]
    return {
        "models": models,
        "control": "fused" if has_gyro else "wheels",
        "control_model": control_model,
        "controls": controls,
        "unavailable": [] if has_gyro else ["gyro", "fused"],
    }
