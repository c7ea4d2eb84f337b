"""``reports/tables.md``: the paper's Tables 2-10 and the controls, from the evaluation.

Every number is a mean over training seeds; ``±`` gives the half-width of its
95 % t interval (omitted with one seed, and 0 for the WPMs, which do not
depend on the seed).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params

if TYPE_CHECKING:  # the stage module imports this one
    from rwhonet.stages.evaluate import Evaluation

STATS = (("max", "Max"), ("min", "Min"), ("mean", "μ"), ("std", "σ"))


def _fmt(v: float, ci: float | None = None, digits: int = 2) -> str:
    if v is None or not math.isfinite(v):
        return "–"
    text = f"{v:.{digits}f}"
    if ci is not None and math.isfinite(ci):
        text += f" ± {ci:.{digits}f}"
    return text


def _head(models: list[str], chosen_m: int) -> list[str]:
    names = {"R": f"R-WhONet (m={chosen_m})", "G": "G-WhONet", "S": "S-WhONet"}
    return [names.get(m, m) for m in models]


def overall_table(ev: Evaluation, params: Params, metric: str, models: list[str]) -> str:
    """Mean CRSE or CTE over all windows of all target test drives, per outage."""
    rows = ev.summary[(ev.summary["role"] == k.TARGET_TEST) & (ev.summary["drive"] == "all")]
    rows = rows.set_index(["model", "outage_s"])
    lines = [
        "| Outage | " + " | ".join(_head(models, params.adapt.chosen_m)) + " | Windows |",
        "|---|" + "---:|" * (len(models) + 1),
    ]
    for L in params.evaluate.outages_s:
        cells = [
            _fmt(rows.loc[(m, L), f"{metric}_mean"], rows.loc[(m, L), f"{metric}_mean_ci95"])
            for m in models
        ]
        n = int(rows.loc[("WPM", L), "n_windows"])
        lines.append(f"| {L} s | {' | '.join(cells)} | {n} |")
    return "\n".join(lines)


def differences_table(ev: Evaluation, params: Params) -> str:
    """Per-seed paired differences of mean CRSE and CTE (m), and relative to the second model."""
    d = ev.differences
    pairs = list(dict.fromkeys(d["pair"]))
    lines = [
        "| Outage | " + " | ".join(f"{p}: CRSE (rel.) / CTE" for p in pairs) + " |",
        "|---|" + "---:|" * len(pairs),
    ]
    rows = d.set_index(["pair", "outage_s"])
    for L in params.evaluate.outages_s:
        cells = []
        for p in pairs:
            r = rows.loc[(p, L)]
            cells.append(
                f"{_fmt(r.crse_mean, r.crse_ci95)} ({100 * r.crse_rel:+.1f} %) / "
                f"{_fmt(r.cte_mean, r.cte_ci95)}"
            )
        lines.append(f"| {L} s | {' | '.join(cells)} |")
    return "\n".join(lines)


def gains_table(ev: Evaluation, params: Params) -> str:
    """1 − CRSE(model) / CRSE(baseline) per outage (per seed, then mean ± interval), in %."""
    g = ev.gains
    baselines = list(dict.fromkeys(g["baseline"]))
    models = list(dict.fromkeys(g["model"]))
    lines = [
        "| Outage | Model | " + " | ".join(f"gain over {b}" for b in baselines) + " |",
        "|---|---|" + "---:|" * len(baselines),
    ]
    rows = g.set_index(["model", "baseline", "outage_s"])
    for L in params.evaluate.outages_s:
        for i, m in enumerate(models):
            cells = [
                _fmt(100 * rows.loc[(m, b, L), "gain"], 100 * rows.loc[(m, b, L), "gain_ci95"], 1)
                + " %"
                for b in baselines
            ]
            name = _head([m], params.adapt.chosen_m)[0]
            lines.append(f"| {f'{L} s' if i == 0 else ''} | {name} | {' | '.join(cells)} |")
    return "\n".join(lines)


def domain_gap_table(ev: Evaluation, params: Params) -> str | None:
    """G's and the WPM's mean CRSE on held-out source drives and on the target test drives."""
    s = ev.summary[(ev.summary["drive"] == "all") & ev.summary["model"].isin(["WPM", "G"])]
    roles = [r for r in (k.SOURCE_TEST, k.TARGET_TEST) if r in set(s["role"])]
    if k.SOURCE_TEST not in roles:
        return None
    rows = s.set_index(["model", "role", "outage_s"])
    cols = [(m, r) for m in ("WPM", "G") for r in roles]
    lines = [
        "| Outage | " + " | ".join(f"{m} on {r} CRSE / CTE" for m, r in cols)
        + " | G / WPM on source_test | G / WPM on target_test |",
        "|---|" + "---:|" * (len(cols) + 2),
    ]  # fmt: skip
    for L in params.evaluate.outages_s:
        cells = [
            f"{_fmt(rows.loc[(m, r, L), 'crse_mean'], rows.loc[(m, r, L), 'crse_mean_ci95'])} / "
            f"{_fmt(rows.loc[(m, r, L), 'cte_mean'], rows.loc[(m, r, L), 'cte_mean_ci95'])}"
            for m, r in cols
        ]
        ratios = [
            f"{rows.loc[('G', r, L), 'crse_mean'] / rows.loc[('WPM', r, L), 'crse_mean']:.2f}"
            for r in (k.SOURCE_TEST, k.TARGET_TEST)
        ]
        lines.append(f"| {L} s | {' | '.join(cells + ratios)} |")
    return "\n".join(lines)


def m_grid_table(ev: Evaluation, params: Params, outage_s: int) -> str:
    """The paper's Table 2: R-WhONet's CRSE for every m, per drive (μ with its interval)."""
    grid = params.adapt.m_grid
    lines = [
        "| Drive | | " + " | ".join(f"m={m} s" for m in grid) + " |",
        "|---|---|" + "---:|" * len(grid),
    ]
    rows = ev.summary[(ev.summary["outage_s"] == outage_s) & (ev.summary["drive"] != "all")
                      & (ev.summary["role"] == k.TARGET_TEST)]  # fmt: skip
    for drive in dict.fromkeys(rows["drive"]):
        per_model = rows[rows["drive"] == drive].set_index("model")
        for i, (stat, label) in enumerate(STATS):
            cells = [
                _fmt(per_model.loc[f"R@{m}", f"crse_{stat}"],
                     per_model.loc[f"R@{m}", "crse_mean_ci95"] if stat == "mean" else None, 1)
                for m in grid
            ]  # fmt: skip
            lines.append(f"| {drive if i == 0 else ''} | {label} | {' | '.join(cells)} |")
    return "\n".join(lines)


def controls_table(ev: Evaluation, params: Params) -> str:
    """R against its controls at every m: mean CRSE, shortest and longest outage."""
    outages = sorted({min(params.evaluate.outages_s), max(params.evaluate.outages_s)})
    rows = ev.summary[(ev.summary["role"] == k.TARGET_TEST) & (ev.summary["drive"] == "all")]
    rows = rows.set_index(["model", "outage_s"])
    names = ("R", "WPM-m", "G+radius")
    lines = [
        "| m | " + " | ".join(f"{n} {L} s CRSE" for L in outages for n in names) + " |",
        "|---:|" + "---:|" * (len(names) * len(outages)),
    ]
    for m in params.adapt.m_grid:
        cells = [
            _fmt(*rows.loc[(f"{n}@{m}", L), ["crse_mean", "crse_mean_ci95"]])
            for L in outages
            for n in names
        ]
        lines.append(f"| {m} | {' | '.join(cells)} |")
    ref = [
        f"{n} {_fmt(rows.loc[(n, L), 'crse_mean'], rows.loc[(n, L), 'crse_mean_ci95'])} m ({L} s)"
        for L in outages
        for n in ("G", "S", "WPM")
    ]
    return "\n".join(lines) + "\n\nReferences: " + "; ".join(ref) + "."


def refit_table(ev: Evaluation, params: Params) -> str:
    """The WPM-m control's rear radii per drive and m (mm), with the source calibration's."""
    r = ev.refits
    lines = [
        "| Drive | " + " | ".join(f"m={m} s" for m in params.adapt.m_grid) + " |",
        "|---|" + "---:|" * len(params.adapt.m_grid),
    ]
    for d, g in r.groupby("drive", sort=False):
        g = g.set_index("m")
        cells = [
            "–" if math.isnan(g.loc[m, "r_rl_m"])
            else f"{1e3 * g.loc[m, 'r_rl_m']:.1f} / {1e3 * g.loc[m, 'r_rr_m']:.1f}"
            for m in params.adapt.m_grid
        ]  # fmt: skip
        lines.append(f"| {d} | {' | '.join(cells)} |")
    return "\n".join(lines)


def outage_table(ev: Evaluation, params: Params, outage_s: int, metric: str) -> str:
    """One of the paper's Tables 3-10: ``metric`` for one outage length, per drive."""
    models = ["WPM", "R", "G", "S"]
    label = {"crse": "CRSE (m)", "cte": "CTE (m)"}[metric]
    lines = [
        "| Drive | | " + " | ".join(f"{h} {label}" for h in _head(models, params.adapt.chosen_m))
        + " | Distance (m) | Windows |",
        "|---|---|" + "---:|" * (len(models) + 2),
    ]  # fmt: skip
    rows = ev.summary[(ev.summary["outage_s"] == outage_s) & (ev.summary["drive"] != "all")
                      & (ev.summary["role"] == k.TARGET_TEST)]  # fmt: skip
    for drive in dict.fromkeys(rows["drive"]):
        per_model = rows[rows["drive"] == drive].set_index("model")
        for i, (stat, stat_label) in enumerate(STATS):
            cells = [
                _fmt(per_model.loc[m, f"{metric}_{stat}"],
                     per_model.loc[m, f"{metric}_mean_ci95"] if stat == "mean" else None)
                for m in models
            ]  # fmt: skip
            dist = _fmt(per_model.iloc[0][f"dist_{stat}"])
            n = str(int(per_model.iloc[0]["n_windows"])) if i == 0 else ""
            lines.append(
                f"| {drive if i == 0 else ''} | {stat_label} | {' | '.join(cells)} | {dist} | {n} |"
            )
    return "\n".join(lines)


def scenario_table(scenarios: pd.DataFrame, chosen_m: int) -> str:
    """Mean |e| per second on each scenario tag's seconds (the paper's short-term scenarios)."""
    models = ["WPM", "R", "G", "S"]
    lines = [
        "| Scenario | Seconds | " + " | ".join(_head(models, chosen_m)) + " |",
        "|---|---:|" + "---:|" * len(models),
    ]
    for r in scenarios.itertuples(index=False):
        cells = [_fmt(getattr(r, m), digits=3) for m in models]
        lines.append(f"| {r.tag} | {r.n_seconds} | {' | '.join(cells)} |")
    return "\n".join(lines)


def render_report(ev: Evaluation, params: Params, provenance: str) -> str:
    """The whole ``reports/tables.md``."""
    from rwhonet.stages.evaluate import alt_wpm

    chosen, grid = params.adapt.chosen_m, params.adapt.m_grid
    longest = max(params.evaluate.outages_s)
    headline = ["WPM", alt_wpm(params.label.wpm_mode)[0], "G", "S", "R",
                f"WPM-m@{chosen}", f"G+radius@{chosen}"]  # fmt: skip
    parts = [
        "# R-WhONet evaluation",
        "",
        provenance,
        "",
        f"Every model is scored on the same seconds: those after the first {max(grid)} s (the "
        f"largest m) of each test drive, so no R-WhONet is scored on seconds it was adapted on. "
        f"R-WhONet is reported at m = {chosen} s (adapt.chosen_m, fixed in params before "
        "evaluation). CRSE = Σ|e| and CTE = |Σe| per outage window (paper Eqs. 16-17), "
        "e = label − prediction (a WPM alone: e = GNSS − WPM). WPM-m@m: the WPM with its "
        "rear radii refitted on each drive's first m s; G+radius@m: G on top of it.",
        "",
        "## Mean CRSE (m) over all windows of the target test drives",
        "",
        overall_table(ev, params, "crse", headline),
        "",
        "## Mean CTE (m) over all windows of the target test drives",
        "",
        overall_table(ev, params, "cte", headline),
        "",
        "## Paired differences of mean CRSE / CTE (m), per seed then averaged",
        "",
        "Negative: the first model has the smaller error. Relative: to the second model's CRSE.",
        "",
        differences_table(ev, params),
        "",
        "## Gains over the wheel-odometry physics models (1 − CRSE / CRSE of the WPM)",
        "",
        gains_table(ev, params),
    ]
    gap = domain_gap_table(ev, params)
    if gap:
        parts += [
            "",
            "## Domain gap: G-WhONet on held-out source-car drives and on the target car",
            "",
            gap,
        ]
    parts += [
        "",
        f"## Table 2 — R-WhONet CRSE (m) for every m, {longest} s outages",
        "",
        m_grid_table(ev, params, longest),
        "",
        "## R-WhONet against its controls at every m (mean CRSE, m)",
        "",
        controls_table(ev, params),
        "",
        "## The WPM-m control's refitted rear radii, left / right (mm)",
        "",
        "– : the first m s never moved fast enough to fit; the source calibration is kept.",
        "",
        refit_table(ev, params),
    ]
    if len(ev.scenarios):
        parts += [
            "",
            "## Scenarios — mean absolute error per second (m) on the evaluated target seconds",
            "",
            "A second carries every tag of its rows (tags overlap). Sorted by seconds.",
            "",
            scenario_table(ev.scenarios, chosen),
        ]
    n = 3
    for L in params.evaluate.outages_s:
        for metric in ("crse", "cte"):
            parts += [
                "",
                f"## Table {n} — {metric.upper()}, {L} s GNSS outages",
                "",
                outage_table(ev, params, L, metric),
            ]
            n += 1
    return "\n".join(parts) + "\n"
