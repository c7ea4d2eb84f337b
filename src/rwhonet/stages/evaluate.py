"""DVC stage ``evaluate``: every model's predictions in; eval.json, tables, plots, MLflow out.

The evaluation itself (windows, scoring, the selection rule, paired statistics,
limits, 2D position, scenario outages) is the domain package
:mod:`rwhonet.evaluation`. This stage reads what it needs (the test and
selection samples, every seed's predictions), calls it, and writes
``metrics/eval.json``, ``reports/tables.md``, ``reports/predictions/``,
``reports/plots/`` together, then logs the MLflow runs. One source of truth:
the tables, plots and MLflow metrics all come from the same
:class:`~rwhonet.evaluation.result.Evaluation`.
"""

from __future__ import annotations

import json
import platform
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.config import Params, flatten
from rwhonet.contracts import CONTINUOUS_RECIPES, alt_wpm, drive_keys, recipe_model
from rwhonet.errors import InputError, Problem
from rwhonet.evaluation.names import at_chosen_m
from rwhonet.evaluation.result import Evaluation
from rwhonet.evaluation.selection import (
    Choice,
    SelectionPredictions,
    choose,
    recommend,
    selection_disagreements,
    selection_scores,
)
from rwhonet.evaluation.study import evaluate
from rwhonet.evaluation.uncertainty import FitEvidence
from rwhonet.io import atomic_outputs, read_json
from rwhonet.report.headline import (
    comparison_html,
    comparison_markdown,
    comparison_rows,
    headline_metrics,
    view_metrics,
)
from rwhonet.report.plots import plot_frames
from rwhonet.report.run_metrics import position_metrics, scenario_metrics, stat_metrics
from rwhonet.report.tables import render_report
from rwhonet.stages.sample_files import load_role
from rwhonet.tracking.records import Timing, now_ms
from rwhonet.tracking.store import RunRecord
from rwhonet.tracking.timings import read_timing

# The adapt stage's selection files (models/r/seed<seed>/selection/<file>.parquet) per role
SELECTION_FILES = {k.TARGET_TRAIN: "target_train", k.SOURCE_TEST: "ridge_source"}


# --------------------------------------------------------------------------- inputs


def prediction_sources(params: Params, models_root: Path) -> dict[tuple[int, str], Path]:
    """``(seed, model) -> predictions.parquet`` for every trained model and recipe."""
    out = {}
    for seed in params.seeds:
        folder = {name: models_root / name / f"seed{seed}" for name in ("g", "s", "r")}
        out[(seed, "G")] = folder["g"] / k.PREDICTIONS
        out[(seed, "S")] = folder["s"] / k.PREDICTIONS
        for r in params.adapt.recipes:
            for m in [None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid:
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


def read_selection(
    params: Params, samples_dir: Path, models_root: Path
) -> dict[str, SelectionPredictions]:
    """The selection evidence as written: per role with samples, every seed's predictions.

    Target training drives (every recipe at every m) and held-out source drives
    (every ridge penalty), each with G's predictions of the same seed.
    """
    out = {}
    for role, file in SELECTION_FILES.items():
        samples = load_role(samples_dir, role, params.model.seq_len, required=False)
        if not len(samples):
            continue
        out[role] = SelectionPredictions(
            samples.frame,
            {
                seed: (
                    pd.read_parquet(
                        models_root / "r" / f"seed{seed}" / "selection" / f"{file}.parquet"
                    ),
                    pd.read_parquet(models_root / "g" / f"seed{seed}" / k.PREDICTIONS),
                )
                for seed in params.seeds
            },
        )
    return out


def fit_evidence(
    params: Params, selection: dict[str, SelectionPredictions], models_root: Path
) -> FitEvidence | None:
    """The target training drives and every seed's predictions of them (variance fits).

    G's and S's from their ``predictions.parquet`` (the model stages predict every
    target training second), every recipe's at every m from the adapt stage's
    selection file (a continuous recipe's one column per outage length,
    ``R[continuous]/<L>s``, inside its windows); one column per model,
    row-aligned with the drives' samples.
    None without target training samples.
    """
    read = selection.get(k.TARGET_TRAIN)
    if read is None or not len(read.frame):
        return None
    keys = ["drive", "segment", "t_s"]
    frame = read.frame
    per_seed = {}
    for seed, (sel, g) in read.per_seed.items():
        s = pd.read_parquet(models_root / "s" / f"seed{seed}" / k.PREDICTIONS)
        merged = (
            frame[keys]
            .merge(g.rename(columns={"pred_m": "G"})[[*keys, "G"]], on=keys, how="left")
            .merge(s.rename(columns={"pred_m": "S"})[[*keys, "S"]], on=keys, how="left")
            .merge(sel, on=keys, how="left")
        )
        cols = {"G": merged["G"].to_numpy(np.float64), "S": merged["S"].to_numpy(np.float64)}
        for col in merged.columns:  # a continuous recipe's per outage length, "<model>/<L>s"
            if col.startswith("pred_m__"):
                cols[col.removeprefix("pred_m__")] = merged[col].to_numpy(np.float64)
        per_seed[seed] = pd.DataFrame(cols, index=frame.index)
    return FitEvidence(frame, per_seed)


# --------------------------------------------------------------------------- outputs


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
        for name, frame in plot_frames(ev, params).items():
            frame.to_csv(tmp_plots / name, index=False, float_format="%.4f")
        tmp_tables.write_text(render_report(ev, params, provenance), encoding="utf-8")
        tmp_eval.write_text(json.dumps(ev.eval_json, indent=2) + "\n", encoding="utf-8")


# --------------------------------------------------------------------------- MLflow


def run_records(params: Params, ev: Evaluation, models_root: Path) -> list[RunRecord]:
    """The execution's runs for MLflow.

    Every trained model per seed (G, S, and R for every recipe and m, with its
    per-drive CRSE/CTE as ``drive/<d>/...`` metrics, ``<d>`` as MLflow allows a name:
    :func:`rwhonet.contracts.drive_keys`), and the headline models as means over seeds
    with their intervals (tag ``aggregate=seeds``), with their 2D and scenario-outage
    metrics.
    """
    records = []
    choice = ev.choice
    for seed in params.seeds:
        mine = ev.per_seed[ev.per_seed["seed"] == seed]
        folders = {"G": models_root / "g" / f"seed{seed}", "S": models_root / "s" / f"seed{seed}"}
        for r in params.adapt.recipes:
            for m in [None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid:
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
                names = drive_keys(sorted(drives))  # as adapt names them
                for d in drives:
                    rec.metrics.update(
                        {
                            f"drive/{names[d]}/{key}": v
                            for key, v in stat_metrics(mine, model, d).items()
                        }
                    )
            if model == choice.model:
                rec.tags["chosen"] = "true"
            elif model.startswith("R"):
                # of the recipes' model files, only R-WhONet's are logged (their curves are)
                rec.artifacts = [a for a in rec.artifacts if not str(a).endswith(".pt")]
            records.append(rec)
    alt = alt_wpm(params.label.wpm_mode)[0]
    headline = ["WPM", alt, "G", "S", "R", f"WPM-m@{choice.m}", *at_chosen_m(params, choice)]
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
            tags["m"] = str(choice.m)
        records.append(
            RunRecord(
                name=f"{model} ({seeds_label(params.seeds, 'mean of ')})",
                tags=tags,
                params={
                    "seeds": params.seeds,
                    "label.wpm_mode": params.label.wpm_mode if model != alt else alt,
                    "label.calibration_min_speed_m_s": params.label.calibration_min_speed_m_s,
                    **({"adapt.recipe": choice.recipe} if model == "R" else {}),
                },
                metrics={
                    **stat_metrics(ev.summary, model),
                    **position_metrics(ev, model),
                    **scenario_metrics(ev, model),
                },
            )
        )
    return records


def data_label(params: Params) -> str:
    """The data a run used, in a run name: ``sim, paper`` or ``files, data/raw``."""
    if params.data.source == "sim":
        return f"sim, {params.sim.profile}"
    return f"files, {params.data.root}"


def provenance_line(
    params: Params, choice: Choice, left_out: list[dict[str, Any]] | None = None
) -> str:
    """Where the numbers come from (data source, profile, seeds, machine), and the drives
    refused and left out (``data.refused_drives: leave_out``), which they do not cover."""
    src = (
        f"simulated fleet, profile `{params.sim.profile}`"
        if params.data.source == "sim"
        else f"drive files under `{params.data.root}`"
    )
    line = (
        f"Data: {src}; training seeds {params.seeds} (every cell: mean over seeds ± the "
        f"half-width of its 95 % t interval); WPM mode `{params.label.wpm_mode}`; "
        f"{params.train.epochs} training epochs; R-WhONet = recipe `{choice.recipe}` "
        f"at m = {choice.m} s; computed on {platform.machine()} CPU by `dvc repro`."
    )
    if left_out:
        names = ", ".join(f"`{d['drive']}` ({d['role']}, by {d['stage']})" for d in left_out)
        line += (
            f" **{len(left_out)} drive(s) refused and left out** (`data.refused_drives: "
            f"leave_out`), not in any number here: {names}; their problems: `left_out` in "
            f"{paths.rel(paths.EVAL_JSON)} and {paths.rel(paths.VALIDATION_REPORT)}."
        )
    return line


def note_left_out(ev: Evaluation, samples_dir: Path) -> list[dict[str, Any]]:
    """The drives left out (:func:`left_out_drives`), put in ``ev``'s eval.json as
    ``left_out`` where there are any: a run without refusals writes what it always did."""
    left_out = left_out_drives(samples_dir)
    if left_out:
        ev.eval_json["left_out"] = left_out
    return left_out


def left_out_drives(samples_dir: Path) -> list[dict[str, Any]]:
    """The drives ingest or validate left out, as the label stage's manifest carries them
    (:func:`rwhonet.data.leftout.brief`; empty: none, or no manifest)."""
    path = Path(samples_dir) / k.MANIFEST
    return list(read_json(path).get("left_out") or []) if path.is_file() else []


def seeds_label(seeds: list[int], many: str = "") -> str:
    """``3 seeds`` (``many`` before it: ``mean of 3 seeds``), or ``1 seed``: no mean of one."""
    return "1 seed" if len(seeds) == 1 else f"{many}{len(seeds)} seeds"


def evaluation_record(
    params: Params, ev: Evaluation, artifacts: list[Path], started_ms: int | None = None
) -> RunRecord:
    """The parent run of one pipeline execution (``started_ms``: when ``evaluate`` started).

    Its params are what params.yaml set (``adapt.recipe: auto`` stays ``auto``) and,
    as ``chosen.*``, R-WhONet's recipe and m and how they were chosen.
    """
    # the headline numbers as the run's own metrics (columns of the runs table), from eval.json
    metrics = headline_metrics(ev.eval_json)
    return RunRecord(
        name=f"pipeline ({data_label(params)}, {seeds_label(params.seeds)})",
        tags={"model": "pipeline", "dvc_stage": "evaluate", "seeds": str(params.seeds)},
        params={
            **flatten(params.section("evaluate"), "evaluate."),
            **flatten(params.section("adapt"), "adapt."),
            "chosen.recipe": ev.choice.recipe,
            "chosen.m": ev.choice.m,
            "chosen.by": ev.choice.chosen_by,
            "seeds": params.seeds,
            "data.source": params.data.source,
            "data.root": params.data.root,
            "sim.profile": params.sim.profile,
            **(
                {"data.drives_left_out": len(left)}  # which: eval.json's left_out
                if (left := ev.eval_json.get("left_out"))
                else {}
            ),
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

    selection = read_selection(params, paths.SAMPLES, paths.MODELS)
    scores = selection_scores(selection, params)
    choice = choose(params, recommend(scores, params))
    frame, preds = collect_predictions(params, paths.SAMPLES, paths.MODELS)
    evidence = fit_evidence(params, selection, paths.MODELS)
    result = evaluate(params, choice, frame, preds, scores, evidence)
    left_out = note_left_out(result, paths.SAMPLES)
    write_outputs(
        params,
        result,
        eval_path=paths.EVAL_JSON,
        tables_path=paths.TABLES_MD,
        predictions_dir=paths.PREDICTIONS,
        plots_dir=paths.PLOTS,
        provenance=provenance_line(params, choice, left_out),
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
