"""An evaluation as MLflow metrics: the names the evaluate stage's runs carry.

Per model on the target test drives, ``crse/<L>s/mean`` ... (:func:`stat_metrics`);
the 2D error at the end of the outages, ``pos/<L>s/...`` (:func:`position_metrics`);
the scenario outages, ``scenario/<tag>/crse/mean`` ... (:func:`scenario_metrics`).
Read from the evaluation package's typed result
(:class:`rwhonet.evaluation.result.Evaluation`), the same numbers as
``metrics/eval.json`` and ``reports/tables.md``; non-finite values are left out.
"""

from __future__ import annotations

import math

import pandas as pd

from rwhonet import contracts as k
from rwhonet.contracts import drive_keys
from rwhonet.evaluation.position import WINDOW_STATS
from rwhonet.evaluation.result import Evaluation
from rwhonet.evaluation.scoring import STATS


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
            for s in STATS:
                value = getattr(r, f"{metric}_{s}")
                if value is not None and math.isfinite(value):
                    out[f"{metric}/{r.outage_s}s/{s}"] = float(value)
            if "seed" not in rows.columns:
                ci = getattr(r, f"{metric}_mean_ci95")
                if math.isfinite(ci):
                    out[f"{metric}/{r.outage_s}s/ci95"] = float(ci)
        out[f"windows/{r.outage_s}s"] = float(r.n_windows)
    return out


def position_metrics(ev: Evaluation, model: str) -> dict[str, float]:
    """MLflow metrics of a model's 2D error at the end of the outage windows.

    The navigation filter on the model's distances (``evaluate.navigation``'s
    control, fused): ``pos/180s/mean`` (m), ``pos/180s/pct`` (% of the distance
    driven), ``pos/180s/max``, ``pos/180s/cover_1sigma`` / ``cover_2sigma`` / ``nll``
    (the calibrated prediction; the filter's own normal as ``..._filter``, the
    calibration as ``calib_scale`` / ``calib_dof``, absent for a normal),
    the ``ci95`` of the means; on the run whose distances the filter's controls
    use, every control as ``pos/<control>/180s/mean``, ``.../pct``, and each test
    drive's windows apart as ``pos/drive/<drive>/180s/mean``, ``pct``, ``cover_1sigma``,
    ``cover_2sigma``, ``windows`` (eval.json's ``position_controls.by_drive``); and the
    model's CRSE calibration: ``uncertainty/180s/crse_cover_1sigma``, ``..._2sigma``,
    ``crse_nll``, on R's run also per test drive (``uncertainty/drive/<drive>/180s/...``,
    eval.json's ``uncertainty.by_drive``), and the filter's figures the evaluation
    fitted on the target training drives (``pos/receiver_sigma_m``,
    ``pos/antenna_ahead_m``, ``pos/antenna_left_m``, ``pos/gyro_latency_s``,
    ``pos/gyro_instability_deg_s``; each where fitted). A drive's name is kept where
    MLflow allows it in a metric's name (:func:`drive_keys`).
    """
    if ev.position is None or ev.position.empty:
        return {}
    name = ev.choice.model if model == "R" else model
    plan = ev.position_plan
    out = {}
    pos = ev.position[ev.position["model"] == name]
    for r in pos.itertuples():
        if r.control == plan["control"]:
            prefix, columns = "pos", WINDOW_STATS
        elif name == plan["control_model"]:
            prefix, columns = f"pos/{r.control}", ("pos_mean", "pos_pct")
        else:
            continue
        for column in columns:
            value = getattr(r, column)
            if math.isfinite(value):
                out[f"{prefix}/{r.outage_s}s/{column.removeprefix('pos_')}"] = float(value)
        for stat in ("mean", "pct"):
            ci = getattr(r, f"pos_{stat}_ci95")
            if prefix == "pos" and math.isfinite(ci):
                out[f"pos/{r.outage_s}s/{stat}_ci95"] = float(ci)
    receiver = plan.get("receiver", {})
    if name == plan["control_model"] and receiver.get("fitted"):
        out["pos/receiver_sigma_m"] = float(receiver["sigma_m"])
    geometry = plan.get("geometry", {})
    if name == plan["control_model"] and geometry.get("fitted"):
        out["pos/antenna_ahead_m"] = float(geometry["antenna_m"][0])
        out["pos/antenna_left_m"] = float(geometry["antenna_m"][1])
        out["pos/gyro_latency_s"] = float(geometry["gyro_latency_s"])
    gyro = plan.get("gyro", {})
    if name == plan["control_model"] and gyro.get("fitted"):
        out["pos/gyro_instability_deg_s"] = float(gyro["instability_deg_s"])
    crse = (
        ("crse_cover_1sigma", "cover_1sigma"),
        ("crse_cover_2sigma", "cover_2sigma"),
        ("crse_nll", "nll"),
    )
    for r in ev.uncertainty[ev.uncertainty["model"] == name].itertuples():
        for stat, col in crse:
            value = getattr(r, col)
            if math.isfinite(value):
                out[f"uncertainty/{r.outage_s}s/{stat}"] = float(value)
    by_drive = (
        ("mean", "pos_mean"),
        ("pct", "pos_pct"),
        ("cover_1sigma", "cover_1sigma"),
        ("cover_2sigma", "cover_2sigma"),
        ("windows", "n_windows"),
    )
    if name == plan["control_model"]:
        out |= _per_drive(ev.position_drives, "pos/drive", by_drive)
    if name == ev.choice.model:
        out |= _per_drive(
            ev.uncertainty_drives, "uncertainty/drive", (*crse, ("windows", "n_windows"))
        )
    return out


def _per_drive(table: pd.DataFrame, prefix: str, stats: tuple) -> dict[str, float]:
    if table is None or table.empty:
        return {}
    keys = drive_keys(sorted(set(table["drive"])))  # as adapt and evaluate name them
    out = {}
    for r in table.itertuples():
        for stat, col in stats:
            value = float(getattr(r, col))
            if math.isfinite(value):
                out[f"{prefix}/{keys[r.drive]}/{int(r.outage_s)}s/{stat}"] = value
    return out


def scenario_metrics(ev: Evaluation, model: str) -> dict[str, float]:
    """MLflow metrics of a model on the scenario outages: ``scenario/roundabout/crse/mean``..."""
    scores = ev.scenario_outages
    name = "R" if model == ev.choice.model else model
    out = {}
    for r in scores[scores["model"] == name].itertuples() if len(scores) else ():
        for metric in ("crse", "cte"):
            mean, ci = getattr(r, metric), getattr(r, f"{metric}_ci95")
            if math.isfinite(mean):
                out[f"scenario/{r.tag}/{metric}/mean"] = float(mean)
            if math.isfinite(ci):
                out[f"scenario/{r.tag}/{metric}/ci95"] = float(ci)
        out[f"scenario/{r.tag}/windows"] = float(r.n_windows)
    return out
