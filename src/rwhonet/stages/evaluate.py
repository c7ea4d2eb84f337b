"""DVC stage ``evaluate``: WPM, G, S and R (every m) on the same test seconds (paper §3.2, §3.5).

Every model is scored on the part of each test drive that comes after the
largest m of the grid, so no R-WhONet is scored on seconds it was adapted on,
and all models (and all m) see exactly the same windows. Outage windows are
consecutive and non-overlapping within a GNSS-valid segment; a trailing
remainder shorter than the outage is dropped.

One source of truth: the tidy summary computed here feeds ``metrics/eval.json``,
``reports/tables.md`` and the MLflow runs.
"""

from __future__ import annotations

import json
import platform
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet import contracts, paths
from rwhonet.config import Params, flatten
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_outputs, read_json
from rwhonet.metrics.outage import summarise, window_evolution, window_metrics
from rwhonet.report.tables import render_report
from rwhonet.stages.samples import load_role
from rwhonet.tracking.store import RunRecord

PREDICTIONS, RUN_RECORD = contracts.PREDICTIONS, contracts.RUN_RECORD

STAT_KEYS = ("max", "min", "mean", "std")
_SHORT = {"crse_m_": "crse_", "cte_m_": "cte_", "distance_m_": "dist_"}


def _stats(windows: pd.DataFrame) -> dict:
    """:func:`summarise` with the short keys of the summary table (crse_mean, dist_std...)."""
    out = {}
    for k, v in summarise(windows).items():
        for long, short in _SHORT.items():
            k = k.replace(long, short)
        out[k] = v
    return out


@dataclass
class Evaluation:
    """What the evaluation computed."""

    summary: pd.DataFrame  # tidy: drive (or 'all'), model, outage_s, stats, n_windows
    scenarios: pd.DataFrame  # per scenario tag: seconds and mean |e| per second per model
    per_second: pd.DataFrame  # test drives, one row per second, every model's prediction
    evolution: pd.DataFrame  # mean cumulative |e| and e per second of a window
    eval_json: dict


def model_columns(m_grid: list[int], chosen_m: int) -> dict[str, str]:
    """Model key -> prediction column (WPM predicts no error)."""
    cols = {"WPM": "", "G": "pred_g_m", "S": "pred_s_m", "R": f"pred_r{chosen_m}_m"}
    cols.update({f"R@{m}": f"pred_r{m}_m" for m in m_grid})
    return cols


def collect_predictions(
    params: Params, samples_dir: Path, g_dir: Path, s_dir: Path, r_root: Path
) -> pd.DataFrame:
    """The test drives' per-second samples with every model's prediction joined on."""
    test = load_role(samples_dir, contracts.TARGET_TEST, params.model.seq_len)
    frame = test.frame.drop(columns=["group"]).copy()
    frame.insert(3, "group", test.frame["group"].to_numpy())
    sources = {"pred_g_m": g_dir, "pred_s_m": s_dir}
    sources.update({f"pred_r{m}_m": r_root / f"m{m}" for m in params.adapt.m_grid})
    keys = ["drive", "segment", "t_s"]
    for col, folder in sources.items():
        f = folder / PREDICTIONS
        if not f.is_file():
            raise InputError(
                [Problem(paths.rel(f), None, None, "a model's predictions", "no file")]
            )
        pred = pd.read_parquet(f).rename(columns={"pred_m": col})
        frame = frame.merge(pred[[*keys, col]], on=keys, how="left", validate="one_to_one")
        if frame[col].isna().any():
            n = int(frame[col].isna().sum())
            raise InputError(
                [
                    Problem(
                        paths.rel(f),
                        None,
                        col,
                        "a prediction for every test second",
                        f"{n} missing",
                    )
                ],
                "predictions are stale: re-run the model stages (dvc repro)",
            )
    return frame


def evaluate(params: Params, frame: pd.DataFrame) -> Evaluation:
    """Score every model on every outage length, per drive and over all drives.

    Args:
        params: resolved parameters (``evaluate.outages_s``, ``adapt``).
        frame: :func:`collect_predictions` output.

    Returns:
        The evaluation (summary, per-second table, evolution curves, eval.json content).
    """
    grid, chosen = params.adapt.m_grid, params.adapt.chosen_m
    skip = max(grid)
    frame = frame.copy()
    frame["evaluated"] = frame["k"].to_numpy() >= skip
    short = frame.groupby("drive", sort=False)["evaluated"].sum()
    need = max(params.evaluate.outages_s)
    too_short = [
        Problem(d, None, None, f"at least {need} s after the first {skip} s", f"{int(n)} s")
        for d, n in short.items()
        if n < need
    ]
    if too_short:
        raise InputError(too_short, "target test drives too short to evaluate every outage length")
    ev = frame[frame["evaluated"]]
    label = ev["label_m"].to_numpy(np.float64)
    gnss = ev["disp_gnss_m"].to_numpy(np.float64)
    group = ev["group"].to_numpy()
    drive = ev["drive"].to_numpy()
    rows, curves = [], []
    for model, col in model_columns(grid, chosen).items():
        err = label - (ev[col].to_numpy(np.float64) if col else 0.0)
        for L in params.evaluate.outages_s:
            windows = window_metrics(err, gnss, group, L)
            w_drive = drive[windows["start"].to_numpy()]
            for name, mask in [("all", np.ones(len(windows), bool))] + [
                (d, w_drive == d) for d in dict.fromkeys(drive)
            ]:
                rows.append({"drive": name, "model": model, "outage_s": L, **_stats(windows[mask])})
            if model in ("WPM", "G", "S", "R"):
                evo = window_evolution(err, group, L)
                evo["cte_m"] = evo["cte_signed_m"].abs()
                mean = evo.groupby("second")[["crse_m", "cte_m"]].mean().reset_index()
                curves.append(mean.assign(outage_s=L, model=model))
    summary = pd.DataFrame(rows)
    return Evaluation(
        summary,
        scenario_errors(ev, model_columns(grid, chosen)),
        frame,
        pd.concat(curves, ignore_index=True),
        eval_json(summary, params),
    )


def scenario_errors(ev: pd.DataFrame, columns: dict[str, str]) -> pd.DataFrame:
    """Mean absolute per-second error of each model on the seconds of each scenario tag.

    The paper's short-term scenarios (roundabouts, hard brakes, wet roads, sharp
    turns...) read per second here, on the evaluated seconds of the test drives
    (a second carries every tag of its rows, so tags overlap).
    """
    models = ("WPM", "R", "G", "S")
    label = ev["label_m"]
    err = pd.DataFrame({m: (label - ev[columns[m]] if columns[m] else label).abs() for m in models})
    err["tag"] = ev["scenario"].fillna("").str.split(";")
    long = err.explode("tag")
    long = long[long["tag"] != ""]
    out = long.groupby("tag").agg(n_seconds=("WPM", "size"), **{m: (m, "mean") for m in models})
    return out.reset_index().sort_values("n_seconds", ascending=False, ignore_index=True)


def eval_json(summary: pd.DataFrame, params: Params) -> dict:
    """Small, diffable metrics: mean CRSE and CTE per model x outage, overall and per drive."""

    def block(rows: pd.DataFrame, full: bool) -> dict:
        out: dict = {}
        for r in rows.itertuples():
            cell = {"crse_mean": round(r.crse_mean, 4), "cte_mean": round(r.cte_mean, 4)}
            if full:
                cell["n_windows"] = int(r.n_windows)
            out.setdefault(r.model, {})[f"{r.outage_s}s"] = cell
        return out

    overall = summary[summary["drive"] == "all"]
    per_drive = summary[(summary["drive"] != "all") & ~summary["model"].str.startswith("R@")]
    return {
        "evaluated_on": (
            f"target test seconds after the first {max(params.adapt.m_grid)} s of each drive"
        ),
        "chosen_m": params.adapt.chosen_m,
        "overall": block(overall, True),
        "per_drive": {d: block(g, False) for d, g in per_drive.groupby("drive", sort=False)},
    }


def stat_metrics(summary: pd.DataFrame, model: str, drive: str = "all") -> dict[str, float]:
    """MLflow metrics of one model: ``crse/30s/mean`` ... (also per drive on the overall run)."""
    out = {}
    rows = summary[(summary["model"] == model) & (summary["drive"] == drive)]
    for r in rows.itertuples():
        for metric in ("crse", "cte"):
            for s in STAT_KEYS:
                out[f"{metric}/{r.outage_s}s/{s}"] = float(getattr(r, f"{metric}_{s}"))
        out[f"windows/{r.outage_s}s"] = float(r.n_windows)
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
    """Write eval.json, tables.md, per-drive predictions and DVC plot data (atomically)."""
    grid, chosen = params.adapt.m_grid, params.adapt.chosen_m
    note = (
        f"Every model is scored on the same seconds: those after the first {max(grid)} s "
        f"(the largest m) of each target test drive, so no R-WhONet is scored on seconds it "
        f"was adapted on. R-WhONet is reported at m = {chosen} s (adapt.chosen_m, fixed in "
        f"params before evaluation, as the paper's Table 2 choice)."
    )
    outputs = (predictions_dir, plots_dir, tables_path, eval_path)
    with atomic_outputs(*outputs, folders=(True, True, False, False)) as tmps:
        tmp_predictions, tmp_plots, tmp_tables, tmp_eval = tmps
        for d, g in ev.per_second.groupby("drive", sort=False):
            g.drop(columns=["group"]).to_parquet(tmp_predictions / f"{d}.parquet", index=False)
        for L, g in ev.evolution.groupby("outage_s"):
            for metric in ("crse", "cte"):
                wide = g.pivot(index="second", columns="model", values=f"{metric}_m")
                wide = wide[["WPM", "G", "S", "R"]].reset_index()
                wide.to_csv(
                    tmp_plots / f"{metric}_evolution_{L}s.csv", index=False, float_format="%.4f"
                )
        mg = ev.summary[(ev.summary["drive"] == "all") & ev.summary["model"].str.startswith("R@")]
        mg = mg.assign(m=mg["model"].str[2:].astype(int)).pivot(
            index="m", columns="outage_s", values="crse_mean"
        )
        mg.columns = [f"crse_mean_{c}s" for c in mg.columns]
        mg.reset_index().to_csv(tmp_plots / "r_m_grid.csv", index=False, float_format="%.4f")
        tmp_tables.write_text(
            render_report(
                ev.summary,
                outages_s=params.evaluate.outages_s,
                m_grid=grid,
                chosen_m=chosen,
                eval_note=note,
                provenance=provenance,
                scenarios=ev.scenarios,
            ),
            encoding="utf-8",
        )
        tmp_eval.write_text(json.dumps(ev.eval_json, indent=2) + "\n", encoding="utf-8")


def run_records(
    params: Params, ev: Evaluation, g_dir: Path, s_dir: Path, r_root: Path
) -> list[RunRecord]:
    """The execution's runs for MLflow, each carrying its CRSE/CTE on the evaluation windows."""
    s = ev.summary
    records = []
    for key, folder in (("G", g_dir), ("S", s_dir)):
        rec = RunRecord.from_dict(read_json(folder / RUN_RECORD))
        rec.metrics.update(stat_metrics(s, key))
        records.append(rec)
    for m in params.adapt.m_grid:
        rec = RunRecord.from_dict(read_json(r_root / f"m{m}" / RUN_RECORD))
        rec.metrics.update(stat_metrics(s, f"R@{m}"))
        if m == params.adapt.chosen_m:
            rec.tags["chosen"] = "true"
        for child in rec.children:
            child.metrics.update(stat_metrics(s, f"R@{m}", child.tags["drive"]))
        records.append(rec)
    records.append(
        RunRecord(
            name="WPM",
            tags={"model": "WPM", "vehicle": "target", "dvc_stage": "evaluate"},
            params={
                "label.wpm_mode": params.label.wpm_mode,
                "label.calibration_min_speed_m_s": params.label.calibration_min_speed_m_s,
            },
            metrics=stat_metrics(s, "WPM"),
        )
    )
    return records


def provenance_line(params: Params) -> str:
    """Where the numbers come from (data source, profile, seed, machine)."""
    src = (
        f"simulated fleet, profile `{params.sim.profile}`"
        if params.data.source == "sim"
        else f"drive files under `{params.data.root}`"
    )
    return (
        f"Data: {src}; seed {params.seed}; WPM mode `{params.label.wpm_mode}`; "
        f"{params.train.epochs} training epochs, {params.adapt.epochs} adaptation epochs "
        f"(trainable: {params.adapt.trainable}); computed on {platform.machine()} "
        f"CPU by `dvc repro`."
    )


def evaluation_record(params: Params, ev: Evaluation, artifacts: list[Path]) -> RunRecord:
    """The parent run of one pipeline execution."""
    return RunRecord(
        name=f"pipeline ({params.data.source}, {params.sim.profile}, seed {params.seed})",
        tags={"model": "pipeline", "dvc_stage": "evaluate", "seed": str(params.seed)},
        params={
            **flatten(params.section("evaluate"), "evaluate."),
            **flatten(params.section("adapt"), "adapt."),
            "seed": params.seed,
            "data.source": params.data.source,
            "sim.profile": params.sim.profile,
        },
        metrics={
            f"{k}/{m}": v
            for m in ("WPM", "G", "S", "R")
            for k, v in stat_metrics(ev.summary, m).items()
            if k.endswith("/mean")
        },
        artifacts=[paths.rel(a) for a in artifacts],
    )


def main(params: Params) -> None:
    """The ``evaluate`` stage: every model's predictions -> metrics, tables, plots, MLflow runs."""
    from rwhonet.tracking.store import log_execution, resolve_tracking_uri

    frame = collect_predictions(params, paths.SAMPLES, paths.MODEL_G, paths.MODEL_S, paths.MODELS_R)
    result = evaluate(params, frame)
    write_outputs(
        params,
        result,
        eval_path=paths.EVAL_JSON,
        tables_path=paths.TABLES_MD,
        predictions_dir=paths.PREDICTIONS,
        plots_dir=paths.PLOTS,
        provenance=provenance_line(params),
    )
    records = run_records(params, result, paths.MODEL_G, paths.MODEL_S, paths.MODELS_R)
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
