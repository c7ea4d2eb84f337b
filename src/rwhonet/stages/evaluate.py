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
  ``R@m``: G recalibrated on each drive's first m seconds; ``R`` = ``R@chosen_m``;
- controls at every m: ``WPM-m@m``, the WPM with its rear radii refitted on the
  drive's first m seconds (the one-parameter alternative to R), and
  ``G+radius@m``, G's correction on top of that WPM.

Each trained model is scored once per training seed; a cell of the summary is
the mean over seeds with a 95 % t interval (:mod:`rwhonet.metrics.intervals`).
The WPMs do not depend on the seed (interval 0). Paired differences (R − G,
R − S, R − WPM-m, R − G+radius) and gains over the WPMs are computed per seed,
then averaged. G and the WPM are also scored on held-out drives of the source
car (role ``source_test``, when there are any): the domain gap.

One source of truth: this evaluation feeds ``metrics/eval.json``,
``reports/tables.md``, the plots and the MLflow runs.
"""

from __future__ import annotations

import json
import math
import platform
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.config import Params, flatten
from rwhonet.errors import InputError, Problem
from rwhonet.features.calibration import refit_radii
from rwhonet.features.wpm import wpm_displacement_m
from rwhonet.io import atomic_outputs, read_json
from rwhonet.metrics.intervals import mean_ci95, over_seeds
from rwhonet.metrics.outage import summarise, window_evolution, window_metrics
from rwhonet.report.tables import render_report
from rwhonet.stages.samples import load_role
from rwhonet.tracking.store import RunRecord

STAT_KEYS = ("max", "min", "mean", "std")
SEED_VALUES = [f"{q}_{s}" for q in ("crse", "cte") for s in STAT_KEYS]
_SHORT = {"crse_m_": "crse_", "cte_m_": "cte_", "distance_m_": "dist_"}
CURVE_MODELS = ("WPM", "G", "S", "R")


def alt_wpm(wpm_mode: str) -> tuple[str, str]:
    """The other WPM mode's model name and samples column."""
    if wpm_mode == "integrated":
        return "WPM-ref", k.DISP_WPM_REFERENCE_M
    return "WPM-int", k.DISP_WPM_INTEGRATED_M


def model_names(params: Params) -> list[str]:
    """Every model and control the evaluation scores, in table order."""
    grid = params.adapt.m_grid
    alt, _ = alt_wpm(params.label.wpm_mode)
    return [
        "WPM", alt, "G", "S", "R",
        *(f"R@{m}" for m in grid), *(f"WPM-m@{m}" for m in grid), *(f"G+radius@{m}" for m in grid),
    ]  # fmt: skip


def pairs(chosen_m: int) -> list[tuple[str, str]]:
    """The paired differences reported (first minus second, per seed)."""
    return [("R", "G"), ("R", "S"), ("R", f"WPM-m@{chosen_m}"), ("R", f"G+radius@{chosen_m}")]


@dataclass
class Evaluation:
    """What the evaluation computed."""

    per_seed: pd.DataFrame  # seed, role, drive (or 'all'), model, outage_s, stats, n_windows
    summary: pd.DataFrame  # the same cells, mean over seeds and *_ci95 half-widths
    differences: pd.DataFrame  # pair, outage_s, crse/cte mean and ci95 of the per-seed gap
    gains: pd.DataFrame  # model, baseline, outage_s, 1 - CRSE(model) / CRSE(baseline)
    scenarios: pd.DataFrame  # per scenario tag: seconds and mean |e| per second per model
    refits: pd.DataFrame  # per drive and m: the refitted rear radii (NaN when not moving)
    per_second: pd.DataFrame  # test drives, one row per second, every model's prediction
    evolution: pd.DataFrame  # mean cumulative |e| and e per second of a window
    eval_json: dict


# --------------------------------------------------------------------------- inputs


def prediction_sources(params: Params, models_root: Path) -> dict[tuple[int, str], Path]:
    """``(seed, prediction column) -> predictions.parquet`` for every trained model."""
    out = {}
    for seed in params.seeds:
        folder = {name: models_root / name / f"seed{seed}" for name in ("g", "s", "r")}
        out[(seed, "pred_g_m")] = folder["g"] / k.PREDICTIONS
        out[(seed, "pred_s_m")] = folder["s"] / k.PREDICTIONS
        for m in params.adapt.m_grid:
            out[(seed, f"pred_r{m}_m")] = folder["r"] / f"m{m}" / k.PREDICTIONS
    return out


def collect_predictions(
    params: Params, samples_dir: Path, models_root: Path
) -> tuple[pd.DataFrame, dict[int, pd.DataFrame]]:
    """The test drives' per-second samples, and every seed's predictions aligned to them.

    Returns:
        ``(frame, predictions)``: the samples of every test role, and per seed a
        frame of prediction columns (``pred_g_m``, ``pred_s_m``, ``pred_r<m>_m``)
        row-aligned with ``frame`` (R: NaN on source-car drives, it is not adapted there).

    Raises:
        InputError: a model's predictions are missing or do not cover the test seconds.
    """
    test = load_role(samples_dir, k.TEST_ROLES, params.model.seq_len)
    frame = test.frame
    keys = ["drive", "segment", "t_s"]
    preds = {seed: pd.DataFrame(index=frame.index) for seed in params.seeds}
    target = (frame["role"] == k.TARGET_TEST).to_numpy()
    for (seed, col), f in prediction_sources(params, models_root).items():
        if not f.is_file():
            raise InputError(
                [Problem(paths.rel(f), None, None, "a model's predictions", "no file")]
            )
        pred = pd.read_parquet(f).rename(columns={"pred_m": col})
        merged = frame[keys].merge(pred[[*keys, col]], on=keys, how="left", validate="one_to_one")
        values = merged[col].to_numpy(np.float64)
        needed = target if col.startswith("pred_r") else np.ones(len(frame), bool)
        missing = int(np.isnan(values[needed]).sum())
        if missing:
            raise InputError(
                [Problem(paths.rel(f), None, col, "a prediction for every test second",
                         f"{missing} missing")],
                "predictions are stale: re-run the model stages (dvc repro)",
            )  # fmt: skip
        preds[seed][col] = values
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


def model_errors(
    frame: pd.DataFrame, pred: pd.DataFrame, wpm_m: dict[int, np.ndarray], params: Params
) -> dict[str, np.ndarray]:
    """Per-second error of every model for one seed (NaN where a model does not apply)."""
    label = frame[k.LABEL_M].to_numpy(np.float64)
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    alt, alt_col = alt_wpm(params.label.wpm_mode)
    g = pred["pred_g_m"].to_numpy()
    errors = {
        "WPM": label,
        alt: gnss - frame[alt_col].to_numpy(np.float64),
        "G": label - g,
        "S": label - pred["pred_s_m"].to_numpy(),
    }
    for m in params.adapt.m_grid:
        errors[f"R@{m}"] = label - pred[f"pred_r{m}_m"].to_numpy()
    errors["R"] = errors[f"R@{params.adapt.chosen_m}"]
    for m in params.adapt.m_grid:
        errors[f"WPM-m@{m}"] = gnss - wpm_m[m]
        errors[f"G+radius@{m}"] = gnss - wpm_m[m] - g
    return {name: errors[name] for name in model_names(params)}


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
    """Which rows are scored: those after the first max(m) seconds of each drive.

    Raises:
        InputError: a test drive has fewer than the longest outage left to score.
    """
    skip = max(params.adapt.m_grid)
    evaluated = frame["k"].to_numpy() >= skip
    need = max(params.evaluate.outages_s)
    left = pd.Series(evaluated).groupby(frame["drive"].to_numpy(), sort=False).sum()
    short = [
        Problem(d, None, None, f"at least {need} s after the first {skip} s", f"{int(n)} s")
        for d, n in left.items()
        if n < need
    ]
    if short:
        raise InputError(short, "test drives too short to evaluate every outage length")
    return evaluated


def score_seed(
    frame: pd.DataFrame, errors: dict[str, np.ndarray], params: Params
) -> tuple[list[dict], list[pd.DataFrame]]:
    """Windows of every model and outage on the evaluated rows: summary rows and curves."""
    rows, curves = [], []
    gnss = frame[k.DISP_GNSS_M].to_numpy(np.float64)
    group = frame["group"].to_numpy()
    drive = frame["drive"].to_numpy()
    role = frame["role"].to_numpy()
    for model, err in errors.items():
        scored = ~np.isnan(err)
        for L in params.evaluate.outages_s:
            windows = window_metrics(err[scored], gnss[scored], group[scored], L)
            start = windows["start"].to_numpy()
            w_drive, w_role = drive[scored][start], role[scored][start]
            cells = [(r, "all", w_role == r) for r in dict.fromkeys(role[scored])]
            cells += [
                (r, d, w_drive == d) for r, d in dict.fromkeys(zip(w_role, w_drive, strict=True))
            ]
            for r, d, mask in cells:
                rows.append({"role": r, "drive": d, "model": model, "outage_s": L,
                             **_stats(windows[mask])})  # fmt: skip
            if model in CURVE_MODELS:
                target = scored & (role == k.TARGET_TEST)
                evo = window_evolution(err[target], group[target], L)
                evo["cte_m"] = evo["cte_signed_m"].abs()
                mean = evo.groupby("second")[["crse_m", "cte_m"]].mean().reset_index()
                curves.append(mean.assign(outage_s=L, model=model))
    return rows, curves


def scenario_errors(frame: pd.DataFrame, errors: dict[str, np.ndarray]) -> pd.DataFrame:
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
    per_seed, curves, scen = [], [], []
    for seed in params.seeds:
        errors = model_errors(frame, preds[seed], wpm_m, params)
        errors = {name: e[evaluated] for name, e in errors.items()}
        rows, seed_curves = score_seed(ev_frame, errors, params)
        per_seed += [{"seed": seed, **r} for r in rows]
        curves += [c.assign(seed=seed) for c in seed_curves]
        scen.append(scenario_errors(ev_frame, errors).assign(seed=seed))
    per_seed_df = pd.DataFrame(per_seed)
    keys = ["role", "drive", "model", "outage_s"]
    summary = over_seeds(per_seed_df, keys, SEED_VALUES)
    fixed = per_seed_df.groupby(keys, sort=False)[
        ["n_windows", *(f"dist_{s}" for s in STAT_KEYS)]
    ].first()
    summary = summary.join(fixed, on=keys)
    scenarios = (
        pd.concat(scen).groupby("tag", sort=False)
        .agg(n_seconds=("n_seconds", "first"), **{m: (m, "mean") for m in ("WPM", "R", "G", "S")})
        .reset_index().sort_values("n_seconds", ascending=False, ignore_index=True)
    )  # fmt: skip
    evolution = (
        pd.concat(curves).groupby(["model", "outage_s", "second"], sort=False)[["crse_m", "cte_m"]]
        .mean().reset_index()
    )  # fmt: skip
    differences, gains = paired(per_seed_df, params)
    per_second = frame.assign(evaluated=evaluated)
    for seed, pred in preds.items():
        per_second = per_second.join(pred.add_suffix(f"__seed{seed}"))
    for m, disp in wpm_m.items():
        per_second[f"disp_wpm_m{m}_m"] = disp
    return Evaluation(
        per_seed_df, summary, differences, gains, scenarios, refits, per_second, evolution,
        eval_json(summary, differences, gains, refits, params),
    )  # fmt: skip


def paired(per_seed: pd.DataFrame, params: Params) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per-seed differences between models and gains over the WPMs, averaged with intervals.

    Both on the target test drives' overall means (all windows of all drives).
    """
    overall = per_seed[(per_seed["role"] == k.TARGET_TEST) & (per_seed["drive"] == "all")]
    table = overall.set_index(["model", "outage_s", "seed"])
    diff_rows, gain_rows = [], []
    for L in params.evaluate.outages_s:
        for a, b in pairs(params.adapt.chosen_m):
            row: dict[str, Any] = {"pair": f"{a} - {b}", "outage_s": L}
            for metric in ("crse", "cte"):
                d = [table.loc[(a, L, s), f"{metric}_mean"] - table.loc[(b, L, s), f"{metric}_mean"]
                     for s in params.seeds]  # fmt: skip
                row[f"{metric}_mean"], row[f"{metric}_ci95"] = mean_ci95(d)
            base = float(np.mean([table.loc[(b, L, s), "crse_mean"] for s in params.seeds]))
            row["crse_rel"] = row["crse_mean"] / base if base > 0 else math.nan
            diff_rows.append(row)
        for baseline in ("WPM", alt_wpm(params.label.wpm_mode)[0]):
            for model in ("G", "S", "R", f"WPM-m@{params.adapt.chosen_m}",
                          f"G+radius@{params.adapt.chosen_m}"):  # fmt: skip
                g = [
                    _gain(table.loc[(model, L, s), "crse_mean"],
                          table.loc[(baseline, L, s), "crse_mean"])
                    for s in params.seeds
                ]  # fmt: skip
                mean, ci = mean_ci95(g)
                gain_rows.append({"model": model, "baseline": baseline, "outage_s": L,
                                  "gain": mean, "gain_ci95": ci})  # fmt: skip
    return pd.DataFrame(diff_rows), pd.DataFrame(gain_rows)


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
            "crse_mean": _num(r.crse_mean), "crse_ci95": _num(r.crse_mean_ci95),
            "cte_mean": _num(r.cte_mean), "cte_ci95": _num(r.cte_mean_ci95),
        }  # fmt: skip
        if full:
            cell["n_windows"] = int(r.n_windows)
        out.setdefault(r.model, {})[f"{r.outage_s}s"] = cell
    return out


def eval_json(
    summary: pd.DataFrame,
    differences: pd.DataFrame,
    gains: pd.DataFrame,
    refits: pd.DataFrame,
    params: Params,
) -> dict:
    """Small, diffable metrics: means over seeds with 95 % half-widths, per model and outage."""
    chosen = params.adapt.chosen_m
    target = summary[summary["role"] == k.TARGET_TEST]
    overall = target[target["drive"] == "all"]
    headline = {"WPM", alt_wpm(params.label.wpm_mode)[0], "G", "S", "R",
                f"WPM-m@{chosen}", f"G+radius@{chosen}"}  # fmt: skip
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
        ),  # fmt: skip
        "gains": {
            model: _nest(
                g, "baseline", lambda r: {"gain": _num(r.gain), "gain_ci95": _num(r.gain_ci95)}
            )
            for model, g in gains.groupby("model", sort=False)
        },  # fmt: skip
        "domain_gap": {
            model: {role: _cells(rows, True)[model] for role, rows in g.groupby("role", sort=False)}
            for model, g in gap.groupby("model", sort=False)
        },
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
        tmp_tables.write_text(render_report(ev, params, provenance), encoding="utf-8")
        tmp_eval.write_text(json.dumps(ev.eval_json, indent=2) + "\n", encoding="utf-8")


def m_grid_plot(summary: pd.DataFrame, params: Params) -> pd.DataFrame:
    """Mean 180 s CRSE against m: R, the two controls, and G, S and WPM as flat references."""
    L = max(params.evaluate.outages_s)
    rows = summary[(summary["role"] == k.TARGET_TEST) & (summary["drive"] == "all")
                   & (summary["outage_s"] == L)].set_index("model")["crse_mean"]  # fmt: skip
    return pd.DataFrame(
        {
            "m": params.adapt.m_grid,
            **{name: [rows[f"{name}@{m}"] for m in params.adapt.m_grid]
               for name in ("R", "WPM-m", "G+radius")},
            **{name: rows[name] for name in ("G", "S", "WPM")},
        }
    )  # fmt: skip


def stat_metrics(summary: pd.DataFrame, model: str, drive: str = "all") -> dict[str, float]:
    """MLflow metrics of one model on the target test drives: ``crse/30s/mean`` ..."""
    out = {}
    rows = summary[(summary["model"] == model) & (summary["drive"] == drive)
                   & (summary["role"] == k.TARGET_TEST)]  # fmt: skip
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
    """The execution's runs for MLflow: each model per seed, and each model over the seeds."""
    records = []
    for seed in params.seeds:
        mine = ev.per_seed[ev.per_seed["seed"] == seed]
        for key, folder in (("G", "g"), ("S", "s")):
            rec = RunRecord.from_dict(
                read_json(models_root / folder / f"seed{seed}" / k.RUN_RECORD)
            )
            rec.metrics.update(stat_metrics(mine, key))
            records.append(rec)
        for m in params.adapt.m_grid:
            folder = models_root / "r" / f"seed{seed}" / f"m{m}"
            rec = RunRecord.from_dict(read_json(folder / k.RUN_RECORD))
            rec.metrics.update(stat_metrics(mine, f"R@{m}"))
            if m == params.adapt.chosen_m:
                rec.tags["chosen"] = "true"
            for child in rec.children:
                child.metrics.update(stat_metrics(mine, f"R@{m}", child.tags["drive"]))
            records.append(rec)
    alt = alt_wpm(params.label.wpm_mode)[0]
    for model in model_names(params):
        kind = model.split("@")[0]
        tags = {"model": kind, "aggregate": "seeds", "n_seeds": str(len(params.seeds)),
                "vehicle": "target", "dvc_stage": "evaluate"}  # fmt: skip
        if "@" in model:
            tags["m"] = model.split("@")[1]
        wpm = {"label.wpm_mode": params.label.wpm_mode if model != alt else alt}
        records.append(
            RunRecord(
                name=f"{model} (mean of {len(params.seeds)} seeds)",
                tags=tags,
                params={
                    "seeds": params.seeds,
                    **wpm,
                    "label.calibration_min_speed_m_s": params.label.calibration_min_speed_m_s,
                },
                metrics=stat_metrics(ev.summary, model),
            )  # fmt: skip
        )
    return records


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
        f"{params.train.epochs} training epochs, {params.adapt.epochs} adaptation epochs "
        f"(trainable: {params.adapt.trainable}); computed on {platform.machine()} CPU by "
        f"`dvc repro`."
    )


def evaluation_record(params: Params, ev: Evaluation, artifacts: list[Path]) -> RunRecord:
    """The parent run of one pipeline execution."""
    metrics = {
        f"{model}/{key}": value
        for model in ("WPM", "G", "S", "R")
        for key, value in stat_metrics(ev.summary, model).items()
        if key.endswith(("/mean", "/ci95"))
    }
    return RunRecord(
        name=f"pipeline ({params.data.source}, {params.sim.profile}, {len(params.seeds)} seeds)",
        tags={"model": "pipeline", "dvc_stage": "evaluate", "seeds": str(params.seeds)},
        params={
            **flatten(params.section("evaluate"), "evaluate."),
            **flatten(params.section("adapt"), "adapt."),
            "seeds": params.seeds,
            "data.source": params.data.source,
            "sim.profile": params.sim.profile,
        },
        metrics=metrics,
        artifacts=[paths.rel(a) for a in artifacts],
    )


def main(params: Params) -> None:
    """The ``evaluate`` stage: every model's predictions -> metrics, tables, plots, MLflow runs."""
    from rwhonet.tracking.store import log_execution, resolve_tracking_uri

    frame, preds = collect_predictions(params, paths.SAMPLES, paths.MODELS)
    result = evaluate(params, frame, preds)
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
        params, result, [paths.EVAL_JSON, paths.TABLES_MD, *sorted(paths.PLOTS.glob("*.csv"))]
    )
    uri = resolve_tracking_uri(params.tracking.tracking_uri)
    run_id = log_execution(
        records, uri=uri, experiment=params.tracking.experiment, execution=parent
    )
    print((paths.TABLES_MD.read_text(encoding="utf-8").split("## Table 2")[0]).strip())
    print(
        f"\nMLflow: experiment '{params.tracking.experiment}', parent run {run_id} "
        f"({len(records)} child runs) in {uri}; `make ui` to compare."
    )
