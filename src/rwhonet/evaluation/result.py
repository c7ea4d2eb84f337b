"""What an evaluation computed (:class:`Evaluation`), and its ``metrics/eval.json`` content.

The report (:mod:`rwhonet.report.tables`) renders from this typed result, the
evaluate stage writes :func:`eval_json` and the MLflow runs from it: one source
of truth. Numbers in the JSON are rounded to 0.1 mm (4 decimals), NaN as null.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import PAPER, alt_wpm, recipe_model
from rwhonet.evaluation.selection import Choice


def _empty() -> pd.DataFrame:
    return pd.DataFrame()


@dataclass(frozen=True)
class Evaluation:
    """Every table the evaluation computed, as frames, and R-WhONet's :class:`Choice`."""

    choice: Choice
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
    selection: pd.DataFrame = field(default_factory=_empty)  # the selection evidence's scores
    limits: pd.DataFrame = field(default_factory=_empty)  # evaluation.limits.radius_limits
    position: pd.DataFrame = field(default_factory=_empty)  # 2D error at window ends
    scenario_outages: pd.DataFrame = field(default_factory=_empty)  # per tag and model
    scenario_counts: pd.DataFrame = field(default_factory=_empty)  # per tag: events, windows...
    scenario_outage_s: int = 0
    eval_json: dict = field(default_factory=dict)  # :func:`eval_json` of the above


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


def _nest(rows: pd.DataFrame, key: str, cell) -> dict:
    out: dict = {}
    for r in rows.itertuples():
        out.setdefault(getattr(r, key), {})[f"{r.outage_s}s"] = cell(r)
    return out


def eval_json(ev: Evaluation, params: Params) -> dict:
    """Small, diffable metrics: means over seeds with 95 % half-widths, per model and outage.

    Keys: the scored seconds, seeds, R-WhONet's recipe and m, ``overall``,
    ``differences``, ``gains``, ``domain_gap``, ``no_harm``, ``per_drive``,
    ``radius_refit_fallbacks``, ``position``, ``selection``, ``limits`` and
    ``scenario_outages``.
    """
    chosen = ev.choice.m
    summary = ev.summary
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
        "recipe": ev.choice.recipe,
        "overall": _cells(overall, True),
        "differences": _nest(
            ev.differences,
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
            for model, g in ev.gains.groupby("model", sort=False)
        },
        "domain_gap": {
            model: {role: _cells(rows, True)[model] for role, rows in g.groupby("role", sort=False)}
            for model, g in gap.groupby("model", sort=False)
        },
        "no_harm": _nest(
            ev.harm,
            "model",
            lambda r: {
                "share_worse_than_g": _num(r.share_worse),
                "mean_excess": _num(r.mean_excess),
                "max_excess": _num(r.max_excess),
                "worse_on_average": bool(r.worse_on_average),
            },
        ),
        "per_drive": {d: _cells(g, False) for d, g in per_drive.groupby("drive", sort=False)},
        "radius_refit_fallbacks": int(ev.refits["r_rl_m"].isna().sum()),
        "position": _position(ev.position, ev.choice),
        "selection": ev.choice.as_selection(),
        "limits": {
            f"{max(params.evaluate.outages_s)}s": [
                {
                    key: round(float(v), 4) if isinstance(v, float) else int(v)
                    for key, v in row.items()
                }
                for row in ev.limits.to_dict("records")
            ]
        },
        "scenario_outages": _scenario_outages(ev),
    }


def _position(position: pd.DataFrame, choice: Choice) -> dict:
    """Per model (the chosen recipe's as ``R``) and outage: the 2D error at the windows' ends."""
    return {
        "R" if m == choice.model else m: {
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


def _scenario_outages(ev: Evaluation) -> dict:
    """Per scenario tag: how its events were handled, and each model's mean CRSE and CTE."""
    scores = ev.scenario_outages
    by_tag = {}
    for c in ev.scenario_counts.sort_values(["windows", "tag"], ascending=[False, True]).itertuples(
        index=False
    ):
        cells = scores[scores["tag"] == c.tag] if len(scores) else scores
        by_tag[c.tag] = {
            **{key: int(v) for key, v in c._asdict().items() if key != "tag"},
            "models": {
                r.model: {
                    "crse_mean": _num(r.crse),
                    "crse_ci95": _num(r.crse_ci95),
                    "cte_mean": _num(r.cte),
                    "cte_ci95": _num(r.cte_ci95),
                    "n_windows": int(r.n_windows),
                }
                for r in cells.itertuples()
            },
        }
    return {
        "outage_s": ev.scenario_outage_s,
        "windows": (
            f"per tagged event of the target test drives, {ev.scenario_outage_s} s outage "
            "windows covering it (the WhONet scenario protocol), in the scored seconds"
        ),
        "tags": by_tag,
    }
