"""The selection rule: which recipe and m the tables call R-WhONet, and on what evidence.

Never the target test drives: every recipe at every m is scored on the target
car's *training* drives (their first m s to recalibrate, the rest scored, the
same windows as the test drives), every ridge penalty on held-out *source*
drives (:func:`selection_scores`). :func:`recommend` applies the documented rule
to those scores; :func:`choose` turns it, or ``params.yaml``'s fixed values, into
a :class:`Choice`, the value every table, alias and MLflow record of R-WhONet is
given. ``params`` keep what the user set (``adapt.recipe: auto`` stays ``auto``).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import AUTO, Params
from rwhonet.contracts import CONTINUOUS_RECIPES, recipe_model
from rwhonet.evaluation.intervals import over_seeds
from rwhonet.evaluation.scoring import Errors, score_seed
from rwhonet.evaluation.windows import evaluated_rows

SELECTION_TOLERANCE = 0.05  # a candidate within 5 % of the best longest-outage CRSE
ChosenBy = Literal["params", "rule", "fallback"]


@dataclass(frozen=True)
class Choice:
    """R-WhONet: the recipe and m the evaluation reports as ``R``, and why.

    Attributes:
        recipe: one of ``adapt.recipes``.
        m: seconds of each drive recalibrated on (``continuous``: max(m_grid), the
            seconds it has before the first scored window).
        ridge_penalty: ``adapt.ridge_penalty``, the penalty the recipes ran with
            (the rule's own recommendation is in ``evidence``).
        chosen_by: ``params`` (fixed in params.yaml), ``rule`` (``auto``, the
            rule's pick) or ``fallback`` (``auto``, the rule had no candidate).
        evidence: what :func:`recommend` found (the rule, params, recommended...).
    """

    recipe: str
    m: int
    ridge_penalty: float
    chosen_by: ChosenBy
    evidence: Mapping[str, Any] = field(default_factory=dict, hash=False)

    @property
    def model(self) -> str:
        """The chosen recipe's model name at m (``R[head]@70``, ``R[continuous]``)."""
        return recipe_model(self.recipe, self.m)

    def as_selection(self) -> dict[str, Any]:
        """The ``selection`` block of eval.json: the evidence, ``chosen_by`` and ``chosen``."""
        out = copy.deepcopy(dict(self.evidence))
        out["chosen_by"] = self.chosen_by
        out["chosen"] = {"recipe": self.recipe, "m": self.m}
        return out


@dataclass(frozen=True)
class SelectionPredictions:
    """One role's selection evidence as read: its samples and, per seed, the predictions.

    Attributes:
        frame: the role's samples (``drive, segment, t_s, k, group, label_m...``).
        per_seed: per seed, ``(recipes, g)``: the adapt stage's selection file
            (``drive, segment, t_s`` and ``pred_m__<model>`` columns; the continuous
            recipe as ``pred_m__R[continuous]/<L>s``) and G's ``predictions.parquet``.
    """

    frame: pd.DataFrame
    per_seed: Mapping[int, tuple[pd.DataFrame, pd.DataFrame]]


def selection_scores(inputs: Mapping[str, SelectionPredictions], params: Params) -> pd.DataFrame:
    """Every recipe on the target training drives, and every ridge penalty on the source drives.

    The same scoring as the test drives (after each drive's first max(m)
    seconds, the same windows for every model), per seed, then the mean over
    seeds with its interval; one ``all`` row per role, model and outage.

    Args:
        inputs: per role (in the order to report them), its samples and predictions.
        params: ``adapt.m_grid``, ``evaluate.outages_s``, ``seeds``.

    Returns:
        ``role, model, outage_s, crse_mean, crse_mean_ci95, ..., n_windows``;
        empty when there are no target training or held-out source drives.
    """
    out = []
    keys = ["drive", "segment", "t_s"]
    for read in inputs.values():
        frame = read.frame
        evaluated = evaluated_rows(frame, params.adapt.m_grid)
        label = frame[k.LABEL_M].to_numpy(np.float64)
        rows = []
        for seed in params.seeds:
            sel, g = read.per_seed[seed]
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
            scored, _, _ = score_seed(
                frame[evaluated].reset_index(drop=True), errors, params.evaluate.outages_s
            )
            rows += [{"seed": seed, **r} for r in scored if r["drive"] == "all"]
        per_seed = pd.DataFrame(rows)
        summary = over_seeds(per_seed, ["role", "model", "outage_s"], ["crse_mean", "cte_mean"])
        n = per_seed.groupby(["role", "model", "outage_s"], sort=False)["n_windows"].first()
        out.append(summary.join(n, on=["role", "model", "outage_s"]))
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


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
            for m in [None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid:
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


def choose(params: Params, evidence: Mapping[str, Any]) -> Choice:
    """R-WhONet's recipe and m: params.yaml's, or with ``auto`` the rule's (else the fallback).

    Args:
        params: ``adapt`` (``recipe``, ``chosen_m``, ``fallback``, ``m_grid``,
            ``ridge_penalty``); left as they are.
        evidence: :func:`recommend`'s output.

    Returns:
        The choice; the rule's ``continuous`` is reported at m = max(m_grid), the
        seconds it has before the first scored window.
    """
    adapt = params.adapt
    if not adapt.auto:
        recipe, m, by = adapt.recipe, int(adapt.chosen_m), "params"
    elif evidence.get("recommended"):
        got = evidence["recommended"]
        recipe, m, by = got["recipe"], got["m"] or max(adapt.m_grid), "rule"
    else:
        recipe, m, by = adapt.fallback.recipe, adapt.fallback.m, "fallback"
    return Choice(recipe, m, adapt.ridge_penalty, by, copy.deepcopy(dict(evidence)))


def selection_disagreements(selection: Mapping[str, Any]) -> list[str]:
    """Where params.yaml's adapt choices differ from what the selection rule recommends."""
    p, notes = selection.get("params", {}), []
    got = selection.get("recommended")
    if got and p["recipe"] != AUTO and (got["recipe"], got["m"]) != (p["recipe"], p["chosen_m"]):
        same_recipe_continuous = got["recipe"] == p["recipe"] and p["recipe"] in CONTINUOUS_RECIPES
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
