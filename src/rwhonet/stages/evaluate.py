"""DVC stage ``evaluate``: every model and control, every seed, on the same test seconds.

Paper §3.2, §3.5. Every model is scored on the part of each test drive that
comes after the largest m of the grid, so no R-WhONet is scored on seconds it
was adapted on, and all models (and all m) see exactly the same windows.
Outage windows are consecutive and non-overlapping within a GNSS-valid
segment; a trailing remainder shorter than the outage is dropped.

Models (per-second error ``e``; CRSE = Σ|e|, CTE = |Σe| per window):

- ``WPM``: the wheel-odometry physics model of ``label.wpm_mode`` (e = label);
  ``WPM-ref`` / ``WPM-int``: the same radii in the other WPM mode (the
  authors' one-sample-per-second WPM, or the integrated one);
- ``G``, ``S``: the networks trained on the source and on the target car;
- ``R[<recipe>]@m``: G recalibrated on each drive's first m seconds by every
  recipe of ``adapt.recipes`` (``R[radius+G]@m`` is the G+radius control: G on
  the WPM refitted on those seconds); ``R[continuous]``: recalibrated before
  every window on the seconds before it; ``R@m`` and ``R`` are ``adapt.recipe``
  at every m and at ``adapt.chosen_m`` (what the tables call R-WhONet);
- ``WPM-m@m``: the WPM with its rear radii refitted on the drive's first m
  seconds, the network-free control.

Each trained model is scored once per training seed; a cell of the summary is
the mean over seeds with a 95 % t interval (:mod:`rwhonet.metrics.intervals`).
The WPMs do not depend on the seed (interval 0). Paired differences and gains
over the WPMs are computed per seed, then averaged; "do no harm" counts the
(drive, seed) pairs where a recalibrated model is worse than G. G and the WPM
are also scored on held-out drives of the source car (role ``source_test``,
when there are any): the domain gap.

One source of truth: this evaluation feeds ``metrics/eval.json``,
``reports/tables.md``, the plots and the MLflow runs.
"""

from __future__ import annotations

import json
import math
import platform
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.config import AUTO, Params, flatten, with_adapt_choice
from rwhonet.contracts import CONTINUOUS, PAPER, alt_wpm, recipe_model
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import refit_radii
from rwhonet.features.wpm import wpm_displacement_m
from rwhonet.io import atomic_outputs, read_json
from rwhonet.metrics.intervals import mean_ci95, over_seeds
from rwhonet.metrics.outage import summarise, window_evolution, window_metrics
from rwhonet.report.comparison import (
    comparison_html,
    comparison_markdown,
    comparison_rows,
    headline_metrics,
    view_metrics,
)
from rwhonet.report.tables import render_report
from rwhonet.stages.limits import radius_limits
from rwhonet.stages.outages import evaluated_rows
from rwhonet.stages.position import HEADING_ONLY, position_errors, window_tracks
from rwhonet.stages.samples import load_role
from rwhonet.tracking.records import Timing, now_ms
from rwhonet.tracking.store import RunRecord
from rwhonet.tracking.timings import read_timing

STAT_KEYS = ("max", "min", "mean", "std")
SEED_VALUES = [f"{q}_{s}" for q in ("crse", "cte") for s in STAT_KEYS]
_SHORT = {"crse_m_": "crse_", "cte_m_": "cte_", "distance_m_": "dist_"}
CURVE_MODELS = ("WPM", "G", "S", "R")
TIME_BINS_S = (0, 300, 600, 1200, 2400, 3600, math.inf)  # seconds into the drive


def recipe_models(params: Params) -> list[str]:
    """Every recipe's R-WhONet at every m."""
    return [
        recipe_model(r, m)
        for r in params.adapt.recipes
        for m in ([None] if r == CONTINUOUS else params.adapt.m_grid)
    ]


def aliases(params: Params) -> dict[str, str]:
    """``R@m`` and ``R``: the chosen recipe at every m and at the chosen m."""
    recipe, grid = params.adapt.recipe, params.adapt.m_grid
    out = {f"R@{m}": recipe_model(recipe, m) for m in grid}
    out["R"] = recipe_model(recipe, params.adapt.chosen_m)
    return out


def model_names(params: Params) -> list[str]:
    """Every model and control the evaluation reports, in table order."""
    alt, _ = alt_wpm(params.label.wpm_mode)
    return [
        "WPM",
        alt,
        "G",
        "S",
        *aliases(params),
        *recipe_models(params),
        *(f"WPM-m@{m}" for m in params.adapt.m_grid),
    ]


def pairs(params: Params) -> list[tuple[str, str]]:
    """The paired differences reported (first minus second, per seed)."""
    chosen = params.adapt.chosen_m
    out = [("R", "G"), ("R", "S"), ("R", f"WPM-m@{chosen}")]
    out += [
        ("R", recipe_model(r, chosen))
        for r in params.adapt.recipes
        if recipe_model(r, chosen) != aliases(params)["R"]
    ]
    return out


@dataclass
class Evaluation:
    """What the evaluation computed."""

    per_seed: pd.DataFrame  # seed, role, drive (or 'all'), model, outage_s, stats, n_windows
    summary: pd.DataFrame  # the same cells, mean over seeds and *_ci95 half-widths
    differences: pd.DataFrame  # pair, outage_s, crse/cte mean and ci95 of the per-seed gap
    gains: pd.DataFrame  # model, baseline, outage_s, 1 - CRSE(model) / CRSE(baseline)
    harm: pd.DataFrame  # per recalibrated model and outage: how often worse than G, by how much
    over_time: pd.DataFrame  # mean window CRSE against seconds into the drive
    scenarios: pd.DataFrame  # per scenario tag: seconds and mean |e| per second per model
    refits: pd.DataFrame  # per drive and m: the refitted rear radii (NaN when not moving)
    per_second: pd.DataFrame  # test drives, one row per second, every model's prediction
    evolution: pd.DataFrame  # mean cumulative |e| and e per second of a window
    eval_json: dict
    selection: pd.DataFrame = field(default_factory=pd.DataFrame)  # the selection evidence
    limits: pd.DataFrame = field(default_factory=pd.DataFrame)  # stages.limits.radius_limits
    position: pd.DataFrame = field(default_factory=pd.DataFrame)  # 2D error at window ends


# --------------------------------------------------------------------------- inputs


def prediction_sources(params: Params, models_root: Path) -> dict[tuple[int, str], Path]:
    """``(seed, model) -> predictions.parquet`` for every trained model and recipe."""
    out = {}
    for seed in params.seeds:
        folder = {name: models_root / name / f"seed{seed}" for name in ("g", "s", "r")}
        out[(seed, "G")] = folder["g"] / k.PREDICTIONS
        out[(seed, "S")] = folder["s"] / k.PREDICTIONS
        for r in params.adapt.recipes:
            for m in [None] if r == CONTINUOUS else params.adapt.m_grid:
                sub_dir = folder["r"] / r if m is None else folder["r"] / r / f"m{m}"
                out[(seed, recipe_model(r, m))] = sub_dir / k.PREDICTIONS
    return out


def collect_predictions(
    params: Params, samples_dir: Path, models_root: Path
) -> tuple[pd.DataFrame, dict[int, pd.DataFrame]]:
    """The test drives' per-second samples, and every seed's predictions aligned to them.

    Returns:
        ``(frame, predictions)``: the samples of every test role, and per seed a
        frame of prediction columns, one per model (``G``, ``S``, ``R[paper]@50``...;
        ``R[continuous]/<L>s`` per outage length) row-aligned with ``frame`` (R: NaN on
        source-car drives, it is not adapted there; continuous: outside its windows).

    Raises:
        InputError: a model's predictions are missing or do not cover the test seconds.
    """
    test = load_role(samples_dir, k.TEST_ROLES, params.model.seq_len)
    frame = test.frame
    keys = ["drive", "segment", "t_s"]
    preds = {seed: pd.DataFrame(index=frame.index) for seed in params.seeds}
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    for (seed, model), f in prediction_sources(params, models_root).items():
        if not f.is_file():
            raise InputError(
                [Problem(paths.rel(f), None, None, "a model's predictions", "no file")],
                "run the model stages first (dvc repro)",
            )
        pred = pd.read_parquet(f)
        cols = [c for c in pred.columns if c.startswith("pred_m")]
        merged = frame[keys].merge(pred[[*keys, *cols]], on=keys, how="left", validate="one_to_one")
        for col in cols:
            values = merged[col].to_numpy(np.float64)
            name = model if col == "pred_m" else f"{model}/{col.removeprefix('pred_m_')}"
            if col == "pred_m":  # a continuous column is NaN outside its windows
                needed = target if model.startswith("R") else np.ones(len(frame), bool)
                missing = int(np.isnan(values[needed]).sum())
                if missing:
                    raise InputError(
                        [
                            Problem(
                                paths.rel(f),
                                None,
                                col,
                                "a prediction for every test second",
                                f"{missing} missing",
                            )
                        ],
                        "predictions are stale: re-run the model stages (dvc repro)",
                    )
            preds[seed][name] = values
    return frame, preds


def refit_wpm(frame: pd.DataFrame, params: Params) -> tuple[dict[int, np.ndarray], pd.DataFrame]:
    """The WPM-m control: each drive's rear radii refitted on its first m seconds, per m.

    Returns:
        ``({m: WPM displacement per row}, refits)``; ``refits`` has one row per
        drive and m with the radii, or NaN (and the source calibration kept) when
        the first m seconds never move faster than ``label.calibration_min_speed_m_s``.
    """
    wpm = frame[k.DISP_WPM_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    a_rl = frame[k.ANGLE_RL_RAD].to_numpy(np.float64)
    a_rr = frame[k.ANGLE_RR_RAD].to_numpy(np.float64)
    drive = frame["drive"].to_numpy()
    rank = frame["k"].to_numpy()
    out, rows = {}, []
    for m in params.adapt.m_grid:
        disp = wpm.copy()
        for d in dict.fromkeys(drive):
            on = drive == d
            first = on & (rank < m)
            radii = refit_radii(
                gnss[first], a_rl[first], a_rr[first], params.label.calibration_min_speed_m_s
            )
            if radii is not None:
                disp[on] = wpm_displacement_m(a_rl[on], a_rr[on], *radii)
            r_rl, r_rr = radii if radii is not None else (math.nan, math.nan)
            rows.append({"drive": d, "m": m, "r_rl_m": r_rl, "r_rr_m": r_rr})
        out[m] = disp
    return out, pd.DataFrame(rows)


Errors = dict[str, "np.ndarray | dict[int, np.ndarray]"]


def position_models(params: Params) -> list[str]:
    """The models dead-reckoned in 2D: the WPM, G, S, every recipe at the chosen m, WPM-m."""
    chosen = params.adapt.chosen_m
    return ["WPM", "G", "S", f"WPM-m@{chosen}"] + [
        recipe_model(r, chosen) for r in params.adapt.recipes
    ]


def model_errors(
    frame: pd.DataFrame, pred: pd.DataFrame, wpm_m: dict[int, np.ndarray], params: Params
) -> Errors:
    """Per-second error of every model for one seed (NaN where a model does not apply).

    ``R[continuous]`` has one error array per outage length (its predictions
    depend on which window a second is in); every other model one array.
    Aliases (``R``, ``R@m``) are left out: they are copies of recipe models.
    """
    label = frame[k.LABEL_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    alt, alt_col = alt_wpm(params.label.wpm_mode)
    errors: Errors = {
        "WPM": label,
        alt: gnss - frame[alt_col].to_numpy(np.float64),
        "G": label - pred["G"].to_numpy(),
        "S": label - pred["S"].to_numpy(),
    }
    for model in recipe_models(params):
        if model == recipe_model(CONTINUOUS, None):
            errors[model] = {
                L: label - pred[f"{model}/{L}s"].to_numpy() for L in params.evaluate.outages_s
            }
        else:
            errors[model] = label - pred[model].to_numpy()
    for m in params.adapt.m_grid:
        errors[f"WPM-m@{m}"] = gnss - wpm_m[m]
    return errors


# --------------------------------------------------------------------------- scoring


def _stats(windows: pd.DataFrame) -> dict[str, Any]:
    """:func:`summarise` with the short keys of the summary table (crse_mean, dist_std...)."""
    out = {}
    for key, value in summarise(windows).items():
        for long, short in _SHORT.items():
            key = key.replace(long, short)
        out[key] = value
    return out


def evaluated_seconds(frame: pd.DataFrame, params: Params) -> np.ndarray:
    """Which rows are scored (:func:`rwhonet.stages.outages.evaluated_rows`).

    A drive shorter than an outage length simply has no window of it (validate
    asks every target test drive for max(m) + the shortest outage); but every
    outage length must have a window on some target test drive.

    Raises:
        InputError: a test drive has fewer than the shortest outage left to score,
            or no target test drive is long enough for an outage length.
    """
    skip = max(params.adapt.m_grid)
    evaluated = evaluated_rows(frame, params.adapt.m_grid)
    shortest, longest = min(params.evaluate.outages_s), max(params.evaluate.outages_s)
    left = pd.Series(evaluated).groupby(frame["drive"].to_numpy(), sort=False).sum()
    short = [
        Problem(
            d,
            None,
            None,
            f"at least {shortest} s after the first {skip} s",
            f"{int(n)} s",
            fix="drop the drive, or shorten adapt.m_grid / evaluate.outages_s",
        )
        for d, n in left.items()
        if n < shortest
    ]
    if short:
        raise InputError(short, "test drives too short to evaluate the shortest outage")
    roles = frame["role"].to_numpy()
    target_max = left[pd.unique(frame["drive"].to_numpy()[roles == k.TARGET_TEST])].max()
    if not target_max >= longest:
        raise InputError(
            [
                Problem(
                    "target test drives",
                    None,
                    None,
                    f"one with at least {longest} s after the first {skip} s",
                    f"the longest has {int(target_max) if target_max == target_max else 0} s",
                    fix=f"drop {longest} from evaluate.outages_s, or add longer drives",
                )
            ],
            "no target test drive is long enough for the longest outage",
        )
    return evaluated


def score_seed(
    frame: pd.DataFrame, errors: Errors, params: Params
) -> tuple[list[dict], list[pd.DataFrame], list[dict]]:
    """Windows of every model and outage on the evaluated rows.

    Returns:
        Summary rows (per role and drive, and ``all`` per role), the mean CRSE/CTE
        curves over a window's seconds, and per window its CRSE with the seconds
        into the drive it starts at (target test drives, for CRSE against time).
    """
    rows, curves, timeline = [], [], []
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    group = frame["group"].to_numpy()
    drive = frame["drive"].to_numpy()
    role = frame["role"].to_numpy()
    rank = frame["k"].to_numpy()
    for model, per_model in errors.items():
        for L in params.evaluate.outages_s:
            err = per_model[L] if isinstance(per_model, dict) else per_model
            scored = ~np.isnan(err)
            windows = window_metrics(err[scored], gnss[scored], group[scored], L)
            start = windows["start"].to_numpy()
            w_drive, w_role = drive[scored][start], role[scored][start]
            cells = [(r, "all", w_role == r) for r in dict.fromkeys(role[scored])]
            cells += [
                (r, d, w_drive == d) for r, d in dict.fromkeys(zip(w_role, w_drive, strict=True))
            ]
            for r, d, mask in cells:
                rows.append(
                    {"role": r, "drive": d, "model": model, "outage_s": L, **_stats(windows[mask])}
                )
            target = w_role == k.TARGET_TEST
            timeline += [
                {"model": model, "outage_s": L, "start_s": int(t), "crse": float(c)}
                for t, c in zip(rank[scored][start][target], windows["crse_m"][target], strict=True)
            ]
            if model in CURVE_MODELS:
                on = scored & (role == k.TARGET_TEST)
                evo = window_evolution(err[on], group[on], L)
                evo["cte_m"] = evo["cte_signed_m"].abs()
                mean = evo.groupby("second")[["crse_m", "cte_m"]].mean().reset_index()
                curves.append(mean.assign(outage_s=L, model=model))
    return rows, curves, timeline


def scenario_errors(frame: pd.DataFrame, errors: Errors) -> pd.DataFrame:
    """Mean absolute per-second error on the target test seconds of each scenario tag.

    The paper's short-term scenarios (roundabouts, hard brakes, wet roads, sharp
    turns...) read per second (a second carries every tag of its rows, so tags overlap).
    """
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    models = ("WPM", "R", "G", "S")
    err = pd.DataFrame({m: np.abs(errors[m][target]) for m in models})
    err["tag"] = frame.loc[target, k.SCENARIO].fillna("").str.split(";").to_numpy()
    long = err.explode("tag")
    long = long[long["tag"] != ""]
    out = long.groupby("tag").agg(n_seconds=("WPM", "size"), **{m: (m, "mean") for m in models})
    return out.reset_index()


def _with_aliases(rows: list[dict], params: Params) -> list[dict]:
    """Copy each aliased recipe model's rows under its alias (``R``, ``R@m``)."""
    by_model: dict[str, list[dict]] = {}
    for r in rows:
        by_model.setdefault(r["model"], []).append(r)
    extra = [
        {**r, "model": alias}
        for alias, model in aliases(params).items()
        for r in by_model.get(model, [])
    ]
    return rows + extra


def evaluate(params: Params, frame: pd.DataFrame, preds: dict[int, pd.DataFrame]) -> Evaluation:
    """Score every model and control for every seed; average over seeds with intervals.

    Args:
        params: resolved parameters (``seeds``, ``adapt``, ``evaluate``, ``label``).
        frame: the test drives' samples (:func:`collect_predictions`).
        preds: per seed, the prediction columns row-aligned with ``frame``.

    Returns:
        The evaluation.
    """
    evaluated = evaluated_seconds(frame, params)
    wpm_m, refits = refit_wpm(frame, params)
    ev_frame = frame[evaluated].reset_index(drop=True)
    per_seed, curves, scen, timeline, positions = [], [], [], [], []
    tracks = {L: window_tracks(frame, params, L) for L in params.evaluate.outages_s}
    for seed in params.seeds:
        errors = model_errors(frame, preds[seed], wpm_m, params)
        # The GNSS's own distances dead-reckoned: the error left is the heading's alone.
        in_2d = {HEADING_ONLY: np.zeros(len(frame))} | {
            m: errors[m] for m in position_models(params)
        }
        positions += [{"seed": seed, **r} for r in position_errors(frame, tracks, in_2d)]
        errors = {
            name: {L: v[evaluated] for L, v in e.items()} if isinstance(e, dict) else e[evaluated]
            for name, e in errors.items()
        }
        errors["R"] = errors[aliases(params)["R"]]
        rows, seed_curves, seed_timeline = score_seed(ev_frame, errors, params)
        rows = [r for r in rows if r["model"] != "R"]  # R comes back as an alias below
        per_seed += [{"seed": seed, **r} for r in _with_aliases(rows, params)]
        curves += [c.assign(seed=seed) for c in seed_curves]
        timeline += [{"seed": seed, **t} for t in seed_timeline]
        scen.append(scenario_errors(ev_frame, errors).assign(seed=seed))
    per_seed_df = pd.DataFrame(per_seed)
    keys = ["role", "drive", "model", "outage_s"]
    summary = over_seeds(per_seed_df, keys, SEED_VALUES)
    fixed = per_seed_df.groupby(keys, sort=False)[
        ["n_windows", *(f"dist_{s}" for s in STAT_KEYS)]
    ].first()
    summary = summary.join(fixed, on=keys)
    scenarios = (
        pd.concat(scen)
        .groupby("tag", sort=False)
        .agg(n_seconds=("n_seconds", "first"), **{m: (m, "mean") for m in ("WPM", "R", "G", "S")})
        .reset_index()
        .sort_values("n_seconds", ascending=False, ignore_index=True)
    )
    evolution = (
        pd.concat(curves)
        .groupby(["model", "outage_s", "second"], sort=False)[["crse_m", "cte_m"]]
        .mean()
        .reset_index()
    )
    position = over_seeds(pd.DataFrame(positions), ["model", "outage_s"], ["pos_mean", "pos_max"])
    n_2d = pd.DataFrame(positions).groupby(["model", "outage_s"], sort=False)["n_windows"].first()
    position = position.join(n_2d, on=["model", "outage_s"])
    position["n_windows_all"] = position["outage_s"].map(
        {L: int(t["n_windows"]) for L, t in tracks.items()}
    )
    differences, gains = paired(per_seed_df, params)
    harm = no_harm(per_seed_df, params)
    over_time = crse_over_time(pd.DataFrame(timeline), params)
    per_second = pd.concat(
        [
            frame.assign(evaluated=evaluated),
            *(pred.add_suffix(f"__seed{seed}") for seed, pred in preds.items()),
            pd.DataFrame({f"disp_wpm_m{m}_m": d for m, d in wpm_m.items()}, index=frame.index),
        ],
        axis=1,
    )
    result = Evaluation(
        per_seed_df,
        summary,
        differences,
        gains,
        harm,
        over_time,
        scenarios,
        refits,
        per_second,
        evolution,
        eval_json(summary, differences, gains, harm, refits, params),
        position=position,
    )
    alias = aliases(params)["R"]
    result.eval_json["position"] = {
        "R" if m == alias else m: {
            f"{int(r.outage_s)}s": {
                "pos_mean": round(r.pos_mean, 4),
                "pos_mean_ci95": round(r.pos_mean_ci95, 4),
                "pos_max": round(r.pos_max, 4),
                "n_windows": int(r.n_windows),
                "n_windows_all": int(r.n_windows_all),
            }
            for r in g.itertuples()
        }
        for m, g in position.groupby("model", sort=False)
    }
    return result


def paired(per_seed: pd.DataFrame, params: Params) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-seed differences between models and gains over the WPMs, averaged with intervals.

    Both on the target test drives' overall means (all windows of all drives).
    """
    overall = per_seed[(per_seed["role"] == k.TARGET_TEST) & (per_seed["drive"] == "all")]
    table = overall.set_index(["model", "outage_s", "seed"])
    diff_rows, gain_rows = [], []
    chosen = params.adapt.chosen_m
    gain_models = ["G", "S", "R", f"WPM-m@{chosen}"] + [
        recipe_model(r, chosen)
        for r in params.adapt.recipes
        if recipe_model(r, chosen) != aliases(params)["R"]
    ]
    for L in params.evaluate.outages_s:
        for a, b in pairs(params):
            row: dict[str, Any] = {"pair": f"{a} - {b}", "outage_s": L}
            for metric in ("crse", "cte"):
                d = [
                    table.loc[(a, L, s), f"{metric}_mean"] - table.loc[(b, L, s), f"{metric}_mean"]
                    for s in params.seeds
                ]
                row[f"{metric}_mean"], row[f"{metric}_ci95"] = mean_ci95(d)
            base = float(np.mean([table.loc[(b, L, s), "crse_mean"] for s in params.seeds]))
            row["crse_rel"] = row["crse_mean"] / base if base > 0 else math.nan
            diff_rows.append(row)
        for baseline in ("WPM", alt_wpm(params.label.wpm_mode)[0]):
            for model in gain_models:
                g = [
                    _gain(
                        table.loc[(model, L, s), "crse_mean"],
                        table.loc[(baseline, L, s), "crse_mean"],
                    )
                    for s in params.seeds
                ]
                mean, ci = mean_ci95(g)
                gain_rows.append(
                    {
                        "model": model,
                        "baseline": baseline,
                        "outage_s": L,
                        "gain": mean,
                        "gain_ci95": ci,
                    }
                )
    return pd.DataFrame(diff_rows), pd.DataFrame(gain_rows)


def no_harm(per_seed: pd.DataFrame, params: Params) -> pd.DataFrame:
    """For every recalibrated model: how often, and by how much, it is worse than G.

    Over the (target test drive, seed) pairs: the share where the model's mean
    CRSE on that drive exceeds G's (same seed, same windows), and the mean
    relative excess over those pairs; ``worse_on_average`` when the model's
    mean over seeds and drives is above G's.
    """
    drives = per_seed[(per_seed["role"] == k.TARGET_TEST) & (per_seed["drive"] != "all")]
    table = drives.set_index(["model", "outage_s", "seed", "drive"])["crse_mean"].sort_index()
    rows = []
    for model in recipe_models(params):
        for L in params.evaluate.outages_s:
            r = table.loc[model, L]
            g = table.loc["G", L].reindex(r.index)
            rel = (r / g - 1.0).to_numpy()
            worse = rel > 0
            rows.append(
                {
                    "model": model,
                    "outage_s": L,
                    "pairs": len(rel),
                    "share_worse": float(worse.mean()),
                    "mean_excess": float(rel[worse].mean()) if worse.any() else 0.0,
                    "max_excess": float(rel.max()),
                    "worse_on_average": bool(r.mean() > g.mean()),
                }
            )
    return pd.DataFrame(rows)


def crse_over_time(timeline: pd.DataFrame, params: Params) -> pd.DataFrame:
    """Mean window CRSE against the time into the drive a window starts (target test drives).

    Windows are binned by their start (:data:`TIME_BINS_S`); a bin's value is the
    mean over its windows, per seed, then the mean over seeds with its interval.
    """
    chosen = params.adapt.chosen_m
    models = ["WPM", "G", "S", "R", f"WPM-m@{chosen}"] + [
        m for m in recipe_models(params) if m.endswith(f"@{chosen}") or "@" not in m
    ]
    t = timeline[timeline["model"].isin(models)].copy()
    edges = np.asarray(TIME_BINS_S, dtype=np.float64)
    t["bin"] = np.searchsorted(edges, t["start_s"].to_numpy(), side="right") - 1
    per_seed = (
        t.groupby(["model", "outage_s", "bin", "seed"], sort=False)
        .agg(crse=("crse", "mean"), n_windows=("crse", "size"))
        .reset_index()
    )
    out = over_seeds(per_seed, ["model", "outage_s", "bin"], ["crse"])
    n = per_seed.groupby(["model", "outage_s", "bin"], sort=False)["n_windows"].first()
    out = out.join(n, on=["model", "outage_s", "bin"])
    out["from_s"] = edges[out["bin"]]
    out["to_s"] = edges[out["bin"] + 1]
    return out.sort_values(["outage_s", "model", "bin"], ignore_index=True)


def _gain(value: float, baseline: float) -> float:
    return 1.0 - value / baseline if baseline > 0 else math.nan


# --------------------------------------------------------------------------- outputs


def _num(x: Any) -> float | None:
    """A JSON number rounded to 0.1 mm, or None for NaN."""
    return None if x is None or not math.isfinite(float(x)) else round(float(x), 4)


def _cells(rows: pd.DataFrame, full: bool) -> dict:
    out: dict = {}
    for r in rows.itertuples():
        cell = {
            "crse_mean": _num(r.crse_mean),
            "crse_ci95": _num(r.crse_mean_ci95),
            "cte_mean": _num(r.cte_mean),
            "cte_ci95": _num(r.cte_mean_ci95),
        }
        if full:
            cell["n_windows"] = int(r.n_windows)
        out.setdefault(r.model, {})[f"{r.outage_s}s"] = cell
    return out


def eval_json(
    summary: pd.DataFrame,
    differences: pd.DataFrame,
    gains: pd.DataFrame,
    harm: pd.DataFrame,
    refits: pd.DataFrame,
    params: Params,
) -> dict:
    """Small, diffable metrics: means over seeds with 95 % half-widths, per model and outage."""
    chosen = params.adapt.chosen_m
    target = summary[summary["role"] == k.TARGET_TEST]
    overall = target[target["drive"] == "all"]
    # per drive: the headline models, and the paper recipe at every m (the paper's Table 2)
    headline = {
        "WPM",
        alt_wpm(params.label.wpm_mode)[0],
        "G",
        "S",
        "R",
        f"WPM-m@{chosen}",
        *(recipe_model(r, chosen) for r in params.adapt.recipes),
        *(recipe_model(PAPER, m) for m in params.adapt.m_grid if PAPER in params.adapt.recipes),
    }
    per_drive = target[(target["drive"] != "all") & target["model"].isin(headline)]
    gap = summary[(summary["drive"] == "all") & summary["model"].isin(["WPM", "G"])]
    return {
        "evaluated_on": (
            f"test seconds after the first {max(params.adapt.m_grid)} s of each drive"
        ),
        "seeds": list(params.seeds),
        "n_seeds": len(params.seeds),
        "chosen_m": chosen,
        "wpm_mode": params.label.wpm_mode,
        "recipe": params.adapt.recipe,
        "overall": _cells(overall, True),
        "differences": _nest(
            differences,
            "pair",
            lambda r: {
                "crse_mean": _num(r.crse_mean),
                "crse_ci95": _num(r.crse_ci95),
                "crse_rel": _num(r.crse_rel),
                "cte_mean": _num(r.cte_mean),
                "cte_ci95": _num(r.cte_ci95),
            },
        ),
        "gains": {
            model: _nest(
                g, "baseline", lambda r: {"gain": _num(r.gain), "gain_ci95": _num(r.gain_ci95)}
            )
            for model, g in gains.groupby("model", sort=False)
        },
        "domain_gap": {
            model: {role: _cells(rows, True)[model] for role, rows in g.groupby("role", sort=False)}
            for model, g in gap.groupby("model", sort=False)
        },
        "no_harm": _nest(
            harm,
            "model",
            lambda r: {
                "share_worse_than_g": _num(r.share_worse),
                "mean_excess": _num(r.mean_excess),
                "max_excess": _num(r.max_excess),
                "worse_on_average": bool(r.worse_on_average),
            },
        ),
        "per_drive": {d: _cells(g, False) for d, g in per_drive.groupby("drive", sort=False)},
        "radius_refit_fallbacks": int(refits["r_rl_m"].isna().sum()),
    }


def _nest(rows: pd.DataFrame, key: str, cell) -> dict:
    out: dict = {}
    for r in rows.itertuples():
        out.setdefault(getattr(r, key), {})[f"{r.outage_s}s"] = cell(r)
    return out


def write_outputs(
    params: Params,
    ev: Evaluation,
    *,
    eval_path: Path,
    tables_path: Path,
    predictions_dir: Path,
    plots_dir: Path,
    provenance: str,
) -> None:
    """Write eval.json, tables.md, per-drive predictions and DVC plot data, together."""
    outputs = (predictions_dir, plots_dir, tables_path, eval_path)
    with atomic_outputs(*outputs, folders=(True, True, False, False)) as tmps:
        tmp_predictions, tmp_plots, tmp_tables, tmp_eval = tmps
        for d, g in ev.per_second.groupby("drive", sort=False):
            g.drop(columns=["group"]).to_parquet(tmp_predictions / f"{d}.parquet", index=False)
        for L, g in ev.evolution.groupby("outage_s"):
            for metric in ("crse", "cte"):
                wide = g.pivot(index="second", columns="model", values=f"{metric}_m")
                wide = wide[list(CURVE_MODELS)].reset_index()
                wide.to_csv(
                    tmp_plots / f"{metric}_evolution_{L}s.csv", index=False, float_format="%.4f"
                )
        m_grid_plot(ev.summary, params).to_csv(
            tmp_plots / "m_grid.csv", index=False, float_format="%.4f"
        )
        # the longest outage; models at the chosen m lose their "@m" (stable column names)
        L, at_m = max(params.evaluate.outages_s), f"@{params.adapt.chosen_m}"
        t = ev.over_time[ev.over_time["outage_s"] == L]
        t = t.assign(from_min=t["from_s"] / 60.0, model=t["model"].str.removesuffix(at_m))
        t.pivot(index="from_min", columns="model", values="crse").reset_index().to_csv(
            tmp_plots / "crse_over_time.csv", index=False, float_format="%.4f"
        )
        tmp_tables.write_text(render_report(ev, params, provenance), encoding="utf-8")
        tmp_eval.write_text(json.dumps(ev.eval_json, indent=2) + "\n", encoding="utf-8")


def m_grid_plot(summary: pd.DataFrame, params: Params) -> pd.DataFrame:
    """Mean CRSE of the longest outage against m: every recipe and WPM-m; G, S, WPM flat."""
    L = max(params.evaluate.outages_s)
    rows = summary[
        (summary["role"] == k.TARGET_TEST)
        & (summary["drive"] == "all")
        & (summary["outage_s"] == L)
    ].set_index("model")["crse_mean"]
    grid = params.adapt.m_grid
    lines = {r: [rows[recipe_model(r, m)] for m in grid] for r in params.adapt.recipes}
    lines["WPM-m"] = [rows[f"WPM-m@{m}"] for m in grid]
    return pd.DataFrame({"m": grid, **lines, **{name: rows[name] for name in ("G", "S", "WPM")}})


def stat_metrics(summary: pd.DataFrame, model: str, drive: str = "all") -> dict[str, float]:
    """MLflow metrics of one model on the target test drives: ``crse/30s/mean`` ..."""
    out = {}
    rows = summary[
        (summary["model"] == model)
        & (summary["drive"] == drive)
        & (summary["role"] == k.TARGET_TEST)
    ]
    for r in rows.itertuples():
        for metric in ("crse", "cte"):
            for s in STAT_KEYS:
                value = getattr(r, f"{metric}_{s}")
                if value is not None and math.isfinite(value):
                    out[f"{metric}/{r.outage_s}s/{s}"] = float(value)
            if "seed" not in rows.columns:
                ci = getattr(r, f"{metric}_mean_ci95")
                if math.isfinite(ci):
                    out[f"{metric}/{r.outage_s}s/ci95"] = float(ci)
        out[f"windows/{r.outage_s}s"] = float(r.n_windows)
    return out


def run_records(params: Params, ev: Evaluation, models_root: Path) -> list[RunRecord]:
    """The execution's runs for MLflow.

    Every trained model per seed (G, S, and R for every recipe and m, with its
    per-drive CRSE/CTE as ``drive/<d>/...`` metrics), and the headline models
    as means over seeds with their intervals (tag ``aggregate=seeds``).
    """
    records = []
    chosen = aliases(params)["R"]
    for seed in params.seeds:
        mine = ev.per_seed[ev.per_seed["seed"] == seed]
        folders = {"G": models_root / "g" / f"seed{seed}", "S": models_root / "s" / f"seed{seed}"}
        for r in params.adapt.recipes:
            for m in [None] if r == CONTINUOUS else params.adapt.m_grid:
                sub_dir = models_root / "r" / f"seed{seed}" / r
                folders[recipe_model(r, m)] = sub_dir if m is None else sub_dir / f"m{m}"
        for model, folder in folders.items():
            rec = RunRecord.from_dict(read_json(folder / k.RUN_RECORD))
            rec.timing = read_timing(folder)
            rec.tags["rwhonet.timing"] = "measured" if rec.timing else "not recorded"
            rec.metrics.update(stat_metrics(mine, model))
            if model.startswith("R"):
                drives = mine.loc[
                    (mine["model"] == model)
                    & (mine["drive"] != "all")
                    & (mine["role"] == k.TARGET_TEST),
                    "drive",
                ].unique()
                for d in drives:
                    rec.metrics.update(
                        {f"drive/{d}/{key}": v for key, v in stat_metrics(mine, model, d).items()}
                    )
            if model == chosen:
                rec.tags["chosen"] = "true"
            elif model.startswith("R"):
                rec.artifacts = []  # of the recipes' model files, only R-WhONet's are logged
            records.append(rec)
    alt = alt_wpm(params.label.wpm_mode)[0]
    headline = ["WPM", alt, "G", "S", "R", f"WPM-m@{params.adapt.chosen_m}"] + [
        recipe_model(r, params.adapt.chosen_m) for r in params.adapt.recipes
    ]
    for model in headline:
        tags = {
            "model": model.split("[")[0].split("@")[0],
            "aggregate": "seeds",
            "n_seeds": str(len(params.seeds)),
            "vehicle": "target",
            "dvc_stage": "evaluate",
        }
        if "[" in model:
            tags["recipe"] = model.split("[")[1].split("]")[0]
        if "@" in model or model == "R":
            tags["m"] = str(params.adapt.chosen_m)
        records.append(
            RunRecord(
                name=f"{model} (mean of {len(params.seeds)} seeds)",
                tags=tags,
                params={
                    "seeds": params.seeds,
                    "label.wpm_mode": params.label.wpm_mode if model != alt else alt,
                    "label.calibration_min_speed_m_s": params.label.calibration_min_speed_m_s,
                    **({"adapt.recipe": params.adapt.recipe} if model == "R" else {}),
                },
                metrics={**stat_metrics(ev.summary, model), **position_metrics(ev, params, model)},
            )
        )
    return records


def position_metrics(ev: Evaluation, params: Params, model: str) -> dict[str, float]:
    """MLflow metrics of a model's 2D error at the end of the outage windows: ``pos/180s/mean``."""
    if ev.position is None or ev.position.empty:
        return {}
    name = aliases(params)["R"] if model == "R" else model
    out = {}
    for r in ev.position[ev.position["model"] == name].itertuples():
        out[f"pos/{r.outage_s}s/mean"] = float(r.pos_mean)
        out[f"pos/{r.outage_s}s/max"] = float(r.pos_max)
        if math.isfinite(r.pos_mean_ci95):
            out[f"pos/{r.outage_s}s/ci95"] = float(r.pos_mean_ci95)
    return out


def data_label(params: Params) -> str:
    """The data a run used, in a run name: ``sim, paper`` or ``files, data/raw``."""
    if params.data.source == "sim":
        return f"sim, {params.sim.profile}"
    return f"files, {params.data.root}"


def provenance_line(params: Params) -> str:
    """Where the numbers come from (data source, profile, seeds, machine)."""
    src = (
        f"simulated fleet, profile `{params.sim.profile}`"
        if params.data.source == "sim"
        else f"drive files under `{params.data.root}`"
    )
    return (
        f"Data: {src}; training seeds {params.seeds} (every cell: mean over seeds ± the "
        f"half-width of its 95 % t interval); WPM mode `{params.label.wpm_mode}`; "
        f"{params.train.epochs} training epochs; R-WhONet = recipe `{params.adapt.recipe}` "
        f"at m = {params.adapt.chosen_m} s; computed on {platform.machine()} CPU by `dvc repro`."
    )


def evaluation_record(
    params: Params, ev: Evaluation, artifacts: list[Path], started_ms: int | None = None
) -> RunRecord:
    """The parent run of one pipeline execution (``started_ms``: when ``evaluate`` started)."""
    # the headline numbers as the run's own metrics (columns of the runs table), from eval.json
    metrics = headline_metrics(ev.eval_json)
    return RunRecord(
        name=f"pipeline ({data_label(params)}, {len(params.seeds)} seeds)",
        tags={"model": "pipeline", "dvc_stage": "evaluate", "seeds": str(params.seeds)},
        params={
            **flatten(params.section("evaluate"), "evaluate."),
            **flatten(params.section("adapt"), "adapt."),
            "seeds": params.seeds,
            "data.source": params.data.source,
            "data.root": params.data.root,
            "sim.profile": params.sim.profile,
        },
        metrics=metrics,
        artifacts=[paths.rel(a) for a in artifacts],
        timing=Timing(started_ms) if started_ms else None,
    )


def main(params: Params) -> None:
    """The ``evaluate`` stage: every model's predictions -> metrics, tables, plots, MLflow runs."""
    from rwhonet.tracking.store import (
        log_comparison,
        log_execution,
        resolve_tracking_uri,
        runs_view_url,
    )

    started_ms = now_ms()

    scores = selection_scores(params, paths.SAMPLES, paths.MODELS)
    selection = recommend(scores, params)
    params = resolve_choice(params, selection)
    frame, preds = collect_predictions(params, paths.SAMPLES, paths.MODELS)
    result = evaluate(params, frame, preds)
    result.selection = scores
    result.eval_json["selection"] = selection
    result.limits = radius_limits(frame, params)
    result.eval_json["limits"] = {
        f"{max(params.evaluate.outages_s)}s": [
            {key: round(float(v), 4) if isinstance(v, float) else int(v) for key, v in row.items()}
            for row in result.limits.to_dict("records")
        ]
    }
    write_outputs(
        params,
        result,
        eval_path=paths.EVAL_JSON,
        tables_path=paths.TABLES_MD,
        predictions_dir=paths.PREDICTIONS,
        plots_dir=paths.PLOTS,
        provenance=provenance_line(params),
    )
    records = run_records(params, result, paths.MODELS)
    parent = evaluation_record(
        params,
        result,
        [paths.EVAL_JSON, paths.TABLES_MD, *sorted(paths.PLOTS.glob("*.csv"))],
        started_ms,
    )
    uri = resolve_tracking_uri(params.tracking.tracking_uri)
    run_id = log_execution(
        records, uri=uri, experiment=params.tracking.experiment, execution=parent
    )
    written = read_json(paths.EVAL_JSON)  # what the report shows: one source of truth
    experiment_id = log_comparison(
        uri,
        run_id,
        rows=comparison_rows(written),
        note=comparison_markdown(written),
        page=comparison_html(written),
        view_metrics=view_metrics(written),
    )
    print(
        f"Wrote {paths.rel(paths.EVAL_JSON)} and {paths.rel(paths.TABLES_MD)}; MLflow: experiment "
        f"'{params.tracking.experiment}', parent run {run_id} ({len(records)} child runs) in "
        f"{uri}; `make ui`, then the headline columns of every execution: "
        f"{runs_view_url(experiment_id, base='http://127.0.0.1:5000')}"
    )
    for note in selection_disagreements(result.eval_json["selection"]):
        print(f"Note: {note} (the evidence: 'Selection' in {paths.rel(paths.TABLES_MD)}).")


# --------------------------------------------------------------------------- selection

SELECTION_FILES = {k.TARGET_TRAIN: "target_train", k.SOURCE_TEST: "ridge_source"}
SELECTION_TOLERANCE = 0.05  # a candidate within 5 % of the best longest-outage CRSE


def selection_scores(params: Params, samples_dir: Path, models_root: Path) -> pd.DataFrame:
    """Every recipe on the target training drives, and every ridge penalty on the source drives.

    The same scoring as the test drives (after each drive's first max(m)
    seconds, the same windows for every model), per seed, then the mean over
    seeds with its interval; one ``all`` row per role, model and outage.

    Returns:
        ``role, model, outage_s, crse_mean, crse_mean_ci95, ..., n_windows``;
        empty when there are no target training or held-out source drives.
    """
    out = []
    keys = ["drive", "segment", "t_s"]
    for role, file in SELECTION_FILES.items():
        samples = load_role(samples_dir, role, params.model.seq_len, required=False)
        if not len(samples):
            continue
        frame = samples.frame
        evaluated = evaluated_rows(frame, params.adapt.m_grid)
        label = frame[k.LABEL_M].to_numpy(np.float64)
        rows = []
        for seed in params.seeds:
            sel = pd.read_parquet(
                models_root / "r" / f"seed{seed}" / "selection" / f"{file}.parquet"
            )
            g = pd.read_parquet(models_root / "g" / f"seed{seed}" / k.PREDICTIONS)
            merged = (
                frame[keys]
                .merge(sel, on=keys, how="left")
                .merge(g.rename(columns={"pred_m": "G"})[[*keys, "G"]], on=keys, how="left")
            )
            errors: Errors = {"WPM": label, "G": label - merged["G"].to_numpy(np.float64)}
            for col in (c for c in merged.columns if c.startswith("pred_m__")):
                name = col.removeprefix("pred_m__")
                e = label - merged[col].to_numpy(np.float64)
                if "/" in name:  # the continuous recipe: one column per outage length
                    model, length = name.split("/")
                    errors.setdefault(model, {})[int(length.removesuffix("s"))] = e
                else:
                    errors[name] = e
            errors = {
                n: {L: v[evaluated] for L, v in e.items()} if isinstance(e, dict) else e[evaluated]
                for n, e in errors.items()
            }
            scored, _, _ = score_seed(frame[evaluated].reset_index(drop=True), errors, params)
            rows += [{"seed": seed, **r} for r in scored if r["drive"] == "all"]
        per_seed = pd.DataFrame(rows)
        summary = over_seeds(per_seed, ["role", "model", "outage_s"], ["crse_mean", "cte_mean"])
        n = per_seed.groupby(["role", "model", "outage_s"], sort=False)["n_windows"].first()
        out.append(summary.join(n, on=["role", "model", "outage_s"]))
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


def resolve_choice(params: Params, selection: dict[str, Any]) -> Params:
    """R-WhONet's recipe and m: params.yaml's, or with ``auto`` the rule's (else the fallback).

    Records how in ``selection["chosen_by"]`` (``params``, ``rule``, ``fallback``)
    and the result in ``selection["chosen"]``. The rule's ``continuous`` is
    reported at m = max(m_grid), the seconds it has before the first scored window.
    """
    adapt = params.adapt
    if not adapt.auto:
        selection["chosen_by"] = "params"
        selection["chosen"] = {"recipe": adapt.recipe, "m": adapt.chosen_m}
        return params
    got = selection.get("recommended")
    if got:
        recipe, m, by = got["recipe"], got["m"] or max(adapt.m_grid), "rule"
    else:
        recipe, m, by = adapt.fallback.recipe, adapt.fallback.m, "fallback"
    selection["chosen_by"], selection["chosen"] = by, {"recipe": recipe, "m": m}
    return with_adapt_choice(params, recipe, m)


def selection_disagreements(selection: dict[str, Any]) -> list[str]:
    """Where params.yaml's adapt choices differ from what the selection rule recommends."""
    p, notes = selection.get("params", {}), []
    got = selection.get("recommended")
    if got and p["recipe"] != AUTO and (got["recipe"], got["m"]) != (p["recipe"], p["chosen_m"]):
        same_recipe_continuous = got["recipe"] == p["recipe"] == CONTINUOUS
        if not same_recipe_continuous:
            notes.append(
                f"the selection rule picks adapt.recipe {got['recipe']}"
                + ("" if got["m"] is None else f" at adapt.chosen_m {got['m']}")
                + f"; params.yaml has {p['recipe']} at {p['chosen_m']}"
            )
    ridge = selection.get("ridge", {}).get("recommended_penalty")
    if ridge is not None and ridge != p.get("ridge_penalty"):
        notes.append(
            f"held-out source drives favour adapt.ridge_penalty {ridge:g}; params.yaml has "
            f"{p['ridge_penalty']:g}"
        )
    return notes


def recommend(scores: pd.DataFrame, params: Params) -> dict[str, Any]:
    """The recipe, m and ridge penalty the selection evidence points to (the documented rule).

    Recipe and m, on the target training drives: among every recipe at every m
    (and the continuous recipe) that is not worse than G on average at any
    outage length, those within :data:`SELECTION_TOLERANCE` of the best mean
    CRSE at the longest outage; of these, the one needing the fewest seconds,
    then the lowest CRSE. ``continuous`` counts as needing max(m_grid) seconds:
    that is what it has fitted on before the first scored window. The ridge
    penalty, on the held-out source drives: the lowest mean CRSE at the longest
    outage, averaged over m.
    """
    L = max(params.evaluate.outages_s)
    out: dict[str, Any] = {
        "rule": (
            "target training drives: not worse than G at any outage; within "
            f"{SELECTION_TOLERANCE:.0%} of the best mean {L} s CRSE; then the smallest m "
            f"(continuous: {max(params.adapt.m_grid)} s, the seconds it has before the first "
            "scored window), then the lowest CRSE. Ridge penalty (first, the recipes use it): "
            "lowest mean CRSE on held-out source drives over m."
        ),
        "params": {
            "recipe": params.adapt.recipe,
            "chosen_m": params.adapt.chosen_m,
            "ridge_penalty": params.adapt.ridge_penalty,
        },
    }
    if scores.empty:
        return out
    train = scores[scores["role"] == k.TARGET_TRAIN].set_index(["model", "outage_s"])
    if len(train):
        g = train.xs("G", level="model")["crse_mean"]
        candidates = []
        for r in params.adapt.recipes:
            for m in [None] if r == CONTINUOUS else params.adapt.m_grid:
                name = recipe_model(r, m)
                if name not in train.index.get_level_values(0):
                    continue
                mine = train.xs(name, level="model")["crse_mean"]
                if (mine > g.reindex(mine.index)).any() or not np.isfinite(mine.get(L, np.nan)):
                    continue  # worse than G somewhere, or no window of the longest outage
                candidates.append((r, m, float(mine[L])))
        if not candidates:
            out["no_recommendation"] = (
                f"no recipe has a {L} s window on the target training drives after their first "
                f"{max(params.adapt.m_grid)} s, or every one is worse than G somewhere"
            )
        else:
            best = min(c[2] for c in candidates)
            near = [c for c in candidates if c[2] <= best * (1 + SELECTION_TOLERANCE)]
            longest_m = max(params.adapt.m_grid)
            r, m, crse = min(near, key=lambda c: (longest_m if c[1] is None else c[1], c[2]))
            out["recommended"] = {
                "recipe": r,
                "m": m,
                f"crse_{L}s": round(crse, 4),
                f"best_crse_{L}s": round(best, 4),
            }
    source = scores[(scores["role"] == k.SOURCE_TEST) & (scores["outage_s"] == L)]
    ridge = source[source["model"].str.startswith("ridge_head lambda=")]
    if len(ridge):
        penalty = ridge["model"].str.extract(r"lambda=([^@]+)@")[0].astype(float)
        by_penalty = ridge.groupby(penalty.to_numpy())["crse_mean"].mean()
        out["ridge"] = {
            "recommended_penalty": float(by_penalty.idxmin()),
            f"mean_crse_{L}s_by_penalty": {f"{p:g}": round(v, 4) for p, v in by_penalty.items()},
        }
    return out
