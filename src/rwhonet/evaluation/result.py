"""What an evaluation computed (:class:`Evaluation`), and its ``metrics/eval.json`` content.

The report (:mod:`rwhonet.report.tables`) renders from this typed result, the
evaluate stage writes :func:`eval_json` and the MLflow runs from it: one source
of truth. Numbers in the JSON are rounded to 0.1 mm (4 decimals), NaN as null.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import PAPER, alt_wpm, recipe_model
from rwhonet.evaluation.position import GNSS_DISTANCE
from rwhonet.evaluation.scenarios import protocol_note
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
    position: pd.DataFrame = field(default_factory=_empty)  # the filter: per model, control, L
    position_windows: pd.DataFrame = field(default_factory=_empty)  # ... per window and seed
    position_drives: pd.DataFrame = field(default_factory=_empty)  # fused, per test drive, L
    position_dead_reckoning: pd.DataFrame = field(default_factory=_empty)  # the earlier 2D
    position_plan: dict = field(default_factory=dict)  # study.navigation_plan, less the models
    uncertainty: pd.DataFrame = field(default_factory=_empty)  # CRSE calibration per model, L
    uncertainty_drives: pd.DataFrame = field(default_factory=_empty)  # R's, per test drive, L
    variance: pd.DataFrame = field(default_factory=_empty)  # each model's variance fit
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
    ``radius_refit_fallbacks``, ``position`` (the navigation filter's end-of-outage
    error per model), ``selection``, ``limits``, ``scenario_outages``,
    ``position_controls`` (the filter's own controls), ``position_dead_reckoning``
    (the earlier 2D dead reckoning) and ``uncertainty`` (each model's variance and
    its calibration).
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
        "position": _filter_position(ev),
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
        "position_controls": _position_controls(ev),
        "position_dead_reckoning": _position(ev.position_dead_reckoning, ev.choice),
        "uncertainty": _uncertainty(ev),
    }


def _filter_cell(r: Any) -> dict:
    return {
        "pos_mean": _num(r.pos_mean),
        "pos_mean_ci95": _num(r.pos_mean_ci95),
        "pos_max": _num(r.pos_max),
        "pos_pct": _num(r.pos_pct),
        "pos_pct_ci95": _num(r.pos_pct_ci95),
        "pos_pct_max": _num(r.pos_pct_max),
        "cover_1sigma": _num(r.cover_1sigma),
        "cover_2sigma": _num(r.cover_2sigma),
        "nll": _num(r.nll),
        # the filter's own normal, before the calibration on the training windows
        "cover_1sigma_filter": _num(r.cover_1sigma_filter),
        "cover_2sigma_filter": _num(r.cover_2sigma_filter),
        "nll_filter": _num(r.nll_filter),
        "calib_scale": _num(r.calib_scale),
        "calib_dof": _num(r.calib_dof),
        "n_windows": int(r.n_windows),
        "n_windows_all": int(r.n_windows_all),
    }


def _filter_position(ev: Evaluation) -> dict:
    """Per model (the chosen recipe's as ``R``) and outage: the filter's end-of-outage error.

    The control is ``position_controls.control`` (fused; the wheels without a gyro).
    """
    plan, pos = ev.position_plan, ev.position
    if pos is None or pos.empty:
        return {}
    rows = pos[(pos["control"] == plan["control"]) & (pos["model"] != GNSS_DISTANCE)]
    return {
        "R" if m == ev.choice.model else m: {
            f"{int(r.outage_s)}s": _filter_cell(r) for r in g.itertuples()
        }
        for m, g in rows.groupby("model", sort=False)
    }


def _position_controls(ev: Evaluation) -> dict:
    """The filter's controls on one model's distances, and fused on the GNSS's distances.

    ``by_drive``: the control row (``control`` on ``distance``'s distances) on each
    target test drive's windows apart, under the same calibration.
    """
    plan, pos = ev.position_plan, ev.position
    if pos is None or pos.empty:
        return {}
    cm = plan["control_model"]
    out: dict = {
        "control": plan["control"],
        "distance": "R" if cm == ev.choice.model else cm,
        "unavailable": list(plan["unavailable"]),
        "receiver": dict(plan.get("receiver", {})),
        "geometry": dict(plan.get("geometry", {})),
        "gyro": dict(plan.get("gyro", {})),
        "rows": {},
    }
    for (model, control), g in pos.groupby(["model", "control"], sort=False):
        if model == cm:
            name = control
        elif model == GNSS_DISTANCE:
            name = f"{control}, {GNSS_DISTANCE}"
        else:
            continue
        out["rows"][name] = {f"{int(r.outage_s)}s": _filter_cell(r) for r in g.itertuples()}
    by_drive = _by_drive(ev.position_drives, _filter_cell)  # the control row, each drive apart
    if by_drive:
        out["by_drive"] = by_drive
    return out


def _by_drive(drives: pd.DataFrame | None, cell: Any) -> dict:
    """Cells per test drive and outage length (``{drive: {"<L>s": cell(row)}}``)."""
    if drives is None or drives.empty:
        return {}
    return {
        str(d): {f"{int(r.outage_s)}s": cell(r) for r in g.itertuples()}
        for d, g in drives.groupby("drive", sort=False)
    }


def _uncertainty(ev: Evaluation) -> dict:
    """Each model's distance variance (means over seeds) and its CRSE calibration per outage.

    ``by_drive``: R-WhONet's CRSE calibration on each target test drive's windows apart.
    """
    if ev.variance is None or ev.variance.empty:
        return {}
    fitted = bool(ev.variance["fitted"].iloc[0])
    models: dict = {}
    for r in ev.variance.itertuples():
        models["R" if r.model == ev.choice.model else r.model] = {
            "a_m2": _num(r.a_m2),
            "b": round(float(r.b), 8),
            "crse_scale": _num(r.crse_scale),
            "crse_spread": _num(r.crse_spread),
            "crse_lasting": _num(r.crse_lasting),
            "scale_sd": round(float(r.scale_sd), 6),
            "n_seconds": int(r.n_seconds),
            "n_windows": int(r.n_windows),
        }
        # gamma_L: the distance variance's factor inside an outage of L s (errors that last)
        gammas = {
            c.removeprefix("gamma_"): round(float(getattr(r, c)), 4)
            for c in ev.variance.columns
            if re.fullmatch(r"gamma_\d+s", c) and math.isfinite(getattr(r, c))
        }
        if gammas:
            models["R" if r.model == ev.choice.model else r.model]["outage_scale"] = gammas
    for r in ev.uncertainty.itertuples():
        name = "R" if r.model == ev.choice.model else r.model
        models[name][f"{int(r.outage_s)}s"] = _crse_cell(r)
    by_drive = _by_drive(ev.uncertainty_drives, _crse_cell)
    return {
        "variance": "sigma_t^2 = a + b d_t^2 per second (d_t: the model's distance)",
        "fitted_on": (
            "target training drives: their seconds after the first max(m) s (S: the "
            "segment tails it was validated on; a continuous recipe: its seconds inside "
            "its training windows)"
            if fitted
            else "nothing (no target training drives): assumed a = 0.05^2 m^2, b = 0.01^2"
        ),
        "models": models,
        **({"by_drive": by_drive} if by_drive else {}),
    }


def _crse_cell(r: Any) -> dict:
    """One CRSE calibration cell (a row of :attr:`Evaluation.uncertainty`, means over seeds)."""
    return {
        "crse_cover_1sigma": _num(r.cover_1sigma),
        "crse_cover_2sigma": _num(r.cover_2sigma),
        "crse_nll": _num(r.nll),
        "crse_cover_1sigma_independent": _num(r.cover_1sigma_independent),
        "crse_cover_2sigma_independent": _num(r.cover_2sigma_independent),
        "second_cover_1sigma": _num(r.second_cover_1sigma),
        "second_cover_2sigma": _num(r.second_cover_2sigma),
        "n_windows": int(r.n_windows),
    }


def _position(position: pd.DataFrame, choice: Choice) -> dict:
    """Per model (the chosen recipe's as ``R``) and outage: the dead-reckoned 2D error."""
    return {
        "R" if m == choice.model else m: {
            f"{int(r.outage_s)}s": {
                "pos_mean": _num(r.pos_mean),
                "pos_mean_ci95": _num(r.pos_mean_ci95),
                "pos_max": _num(r.pos_max),
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
            f"windows covering it ({protocol_note(ev.scenario_outage_s)}), in the scored seconds"
        ),
        "tags": by_tag,
    }
