"""``reports/tables.md``: the paper's Tables 2-10 and the controls, from the evaluation.

Rendered from the typed result of the evaluation package
(:class:`rwhonet.evaluation.result.Evaluation`, whose ``eval_json`` is
``metrics/eval.json``'s content), never from a stage; R-WhONet is the result's
:class:`~rwhonet.evaluation.selection.Choice`. Every number is a mean over
training seeds; ``±`` gives the half-width of its 95 % t interval (omitted with
one seed, and 0 for the WPMs, which do not depend on the seed).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import pandas as pd

from rwhonet import contracts as k
from rwhonet.config import Params
from rwhonet.contracts import (
    CONTINUOUS,
    CONTINUOUS_RECIPES,
    CONTINUOUS_SHRINK,
    SHRINK,
    alt_wpm,
    recipe_model,
)
from rwhonet.evaluation.intervals import COVER_BANDS, band_chance
from rwhonet.evaluation.position import GNSS_DISTANCE
from rwhonet.evaluation.result import Evaluation
from rwhonet.evaluation.scenarios import PROTOCOL_OUTAGE_S

STATS = (("max", "Max"), ("min", "Min"), ("mean", "μ"), ("std", "σ"))


CHOSEN_BY = {
    "params": "fixed in params.yaml before evaluation",
    "rule": "picked by the selection rule (adapt.recipe: auto) on the target *training* drives "
    "only (see 'Selection')",
    "fallback": "adapt.fallback: the selection rule had no candidate (see 'Selection')",
}


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


def _drive_stats(
    ev: Evaluation, outage_s: int
) -> Iterator[tuple[str, bool, str, str, pd.DataFrame]]:
    """Each target test drive's rows of a per-drive table for one outage length.

    Yields:
        ``(drive, first, stat, label, per_model)`` for every drive and every statistic of
        :data:`STATS` in turn: ``first`` on a drive's first row, ``per_model`` the drive's
        summary indexed by model.
    """
    rows = ev.summary[
        (ev.summary["outage_s"] == outage_s)
        & (ev.summary["drive"] != "all")
        & (ev.summary["role"] == k.TARGET_TEST)
    ]
    for drive in dict.fromkeys(rows["drive"]):
        per_model = rows[rows["drive"] == drive].set_index("model")
        for i, (stat, label) in enumerate(STATS):
            yield drive, i == 0, stat, label, per_model


def _stat_cell(per_model: pd.DataFrame, model: str, metric: str, stat: str, digits: int = 2) -> str:
    """``metric``'s ``stat`` for ``model``; the mean with its 95 % interval."""
    return _fmt(
        per_model.loc[model, f"{metric}_{stat}"],
        per_model.loc[model, f"{metric}_mean_ci95"] if stat == "mean" else None,
        digits,
    )


def overall_table(ev: Evaluation, params: Params, metric: str, models: list[str]) -> str:
    """Mean CRSE or CTE over all windows of all target test drives, per outage."""
    rows = ev.summary[(ev.summary["role"] == k.TARGET_TEST) & (ev.summary["drive"] == "all")]
    rows = rows.set_index(["model", "outage_s"])
    lines = [
        "| Outage | " + " | ".join(_head(models, ev.choice.m)) + " | Windows |",
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
    d = ev.differences.set_index(["pair", "outage_s"])
    outages = params.evaluate.outages_s
    lines = [
        "| Pair | " + " | ".join(f"{L} s: CRSE (rel.) / CTE" for L in outages) + " |",
        "|---|" + "---:|" * len(outages),
    ]
    for p in dict.fromkeys(ev.differences["pair"]):
        cells = []
        for L in outages:
            r = d.loc[(p, L)]
            cells.append(
                f"{_fmt(r.crse_mean, r.crse_ci95)} ({100 * r.crse_rel:+.1f} %) / "
                f"{_fmt(r.cte_mean, r.cte_ci95)}"
            )
        lines.append(f"| {p} | {' | '.join(cells)} |")
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
            name = _head([m], ev.choice.m)[0]
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
        "| Outage | "
        + " | ".join(f"{m} on {r} CRSE / CTE" for m, r in cols)
        + " | G / WPM on source_test | G / WPM on target_test |",
        "|---|" + "---:|" * (len(cols) + 2),
    ]
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


def md_cell(text: object) -> str:
    """Text in a Markdown table's cell: a ``|`` in it (a comma2k19 route's drive id,
    ``dongle|start``) escaped, so it does not end the cell."""
    return str(text).replace("|", "\\|")


def m_grid_table(ev: Evaluation, params: Params, outage_s: int) -> str:
    """The paper's Table 2: R-WhONet's CRSE for every m, per drive (μ with its interval)."""
    grid = params.adapt.m_grid
    lines = [
        "| Drive | | " + " | ".join(f"m={m} s" for m in grid) + " |",
        "|---|---|" + "---:|" * len(grid),
    ]
    for drive, first, stat, label, per_model in _drive_stats(ev, outage_s):
        cells = [_stat_cell(per_model, f"R@{m}", "crse", stat, 1) for m in grid]
        lines.append(f"| {md_cell(drive) if first else ''} | {label} | {' | '.join(cells)} |")
    return "\n".join(lines)


def recipes_table(ev: Evaluation, params: Params) -> str:
    """Every recipe (and WPM-m) at every m: mean CRSE/CTE ± interval; ▲ marks worse than G.

    Shortest and longest outage; the last column is the share of (drive, seed)
    pairs where the model is worse than G at the longest outage.
    """
    outages = sorted({min(params.evaluate.outages_s), max(params.evaluate.outages_s)})
    longest = outages[-1]
    rows = ev.summary[(ev.summary["role"] == k.TARGET_TEST) & (ev.summary["drive"] == "all")]
    rows = rows.set_index(["model", "outage_s"])
    harm = ev.harm.set_index(["model", "outage_s"])

    def cell(model: str, L: int, metric: str) -> str:
        text = _fmt(*rows.loc[(model, L), [f"{metric}_mean", f"{metric}_mean_ci95"]])
        worse = rows.loc[(model, L), "crse_mean"] > rows.loc[("G", L), "crse_mean"]
        return text + (" ▲" if metric == "crse" and worse else "")

    head = [f"CRSE {L} s" for L in outages] + [f"CTE {longest} s", f"worse than G ({longest} s)"]
    lines = ["| Recipe | m | " + " | ".join(head) + " |", "|---|---:|" + "---:|" * len(head)]
    models = [
        (r, m, recipe_model(r, m))
        for r in params.adapt.recipes
        for m in ([None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid)
    ]
    models += [("WPM-m (no network)", m, f"WPM-m@{m}") for m in params.adapt.m_grid]
    for recipe, m, model in models:
        share = (
            f"{100 * harm.loc[(model, longest), 'share_worse']:.0f} %"
            if (model, longest) in harm.index
            else "–"
        )
        cells = [cell(model, L, "crse") for L in outages] + [cell(model, longest, "cte"), share]
        label = "every window" if m is None else str(m)
        lines.append(f"| {recipe} | {label} | {' | '.join(cells)} |")
    ref = [
        f"{n} {_fmt(*rows.loc[(n, L), ['crse_mean', 'crse_mean_ci95']])} m ({L} s)"
        for L in outages
        for n in ("G", "S", "WPM")
    ]
    return "\n".join(lines) + "\n\nReferences: " + "; ".join(ref) + "."


def harm_table(ev: Evaluation, params: Params) -> str:
    """Do no harm: per recalibrated model, how often and how much it is worse than G."""
    longest = max(params.evaluate.outages_s)
    h = ev.harm[ev.harm["outage_s"] == longest]
    lines = [
        "| Model | (drive, seed) pairs | worse than G | mean excess when worse | largest excess "
        "| worse on average |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for r in h.itertuples():
        lines.append(
            f"| {r.model} | {r.pairs} | {100 * r.share_worse:.0f} % | {100 * r.mean_excess:+.1f} % "
            f"| {100 * r.max_excess:+.1f} % | {'**yes**' if r.worse_on_average else 'no'} |"
        )
    return "\n".join(lines)


def over_time_table(ev: Evaluation, params: Params) -> str:
    """Mean window CRSE against minutes into the drive (longest outage), per model."""
    longest = max(params.evaluate.outages_s)
    t = ev.over_time[ev.over_time["outage_s"] == longest]
    models = list(dict.fromkeys(t["model"]))
    lines = [
        "| Window starts (min into the drive) | Windows | " + " | ".join(models) + " |",
        "|---|---:|" + "---:|" * len(models),
    ]
    for _, g in t.groupby("bin", sort=True):
        g = g.set_index("model")
        first = g.iloc[0]
        span = f"{first.from_s / 60:.0f}–" + (
            "end" if math.isinf(first.to_s) else f"{first.to_s / 60:.0f}"
        )
        cells = [
            _fmt(g.loc[m, "crse"], g.loc[m, "crse_ci95"]) if m in g.index else "–" for m in models
        ]
        lines.append(f"| {span} | {int(first.n_windows)} | {' | '.join(cells)} |")
    return "\n".join(lines)


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
            "–"
            if math.isnan(g.loc[m, "r_rl_m"])
            else f"{1e3 * g.loc[m, 'r_rl_m']:.1f} / {1e3 * g.loc[m, 'r_rr_m']:.1f}"
            for m in params.adapt.m_grid
        ]
        lines.append(f"| {d} | {' | '.join(cells)} |")
    return "\n".join(lines)


def outage_table(ev: Evaluation, params: Params, outage_s: int, metric: str) -> str:
    """One of the paper's Tables 3-10: ``metric`` for one outage length, per drive."""
    models = ["WPM", "R", "G", "S"]
    label = {"crse": "CRSE (m)", "cte": "CTE (m)"}[metric]
    lines = [
        "| Drive | | "
        + " | ".join(f"{h} {label}" for h in _head(models, ev.choice.m))
        + " | Distance (m) | Windows |",
        "|---|---|" + "---:|" * (len(models) + 2),
    ]
    for drive, first, stat, stat_label, per_model in _drive_stats(ev, outage_s):
        cells = [_stat_cell(per_model, m, metric, stat) for m in models]
        dist = _fmt(per_model.iloc[0][f"dist_{stat}"])
        n = str(int(per_model.iloc[0]["n_windows"])) if first else ""
        lines.append(
            f"| {md_cell(drive) if first else ''} | {stat_label} | {' | '.join(cells)} | {dist} "
            f"| {n} |"
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


COUNT_HEAD = {
    "events": "Events",
    "scored_events": "Scored",
    "windows": "Windows",
    "longer_than_outage": "Longer than the outage",
    "merged": "Merged",
    "not_fully_covered": "Not fully covered",
    "in_adaptation_seconds": "In the first max(m) s",
    "segment_too_short": "Segment too short",
    "split_by_gnss_gap": "Cut by a GNSS gap",
}


def scenario_outage_tables(ev: Evaluation) -> str | None:
    """The scenario outages: how each tag's events were covered, then CRSE and CTE per model."""
    counts = ev.scenario_counts
    if counts is None or counts.empty:
        return None
    counts = counts.sort_values(["windows", "tag"], ascending=[False, True])
    lines = [
        "| Scenario | " + " | ".join(COUNT_HEAD.values()) + " |",
        "|---|" + "---:|" * len(COUNT_HEAD),
    ]
    for c in counts.itertuples(index=False):
        lines.append(f"| {c.tag} | " + " | ".join(str(getattr(c, x)) for x in COUNT_HEAD) + " |")
    parts = ["\n".join(lines)]
    scores = ev.scenario_outages
    if len(scores):
        models = list(dict.fromkeys(scores["model"]))
        cells = scores.set_index(["tag", "model"])
        windows = counts.set_index("tag")["windows"]
        for metric, label in (("crse", "CRSE"), ("cte", "CTE")):
            lines = [
                "| Scenario | Windows | " + " | ".join(_head(models, ev.choice.m)) + " |",
                "|---|---:|" + "---:|" * len(models),
            ]
            for tag in dict.fromkeys(scores["tag"]):
                row = []
                for m in models:
                    r = cells.loc[(tag, m)]
                    text = _fmt(r[metric], r[f"{metric}_ci95"])
                    if int(r["n_windows"]) < windows[tag]:
                        text += f" ({int(r['n_windows'])} of {windows[tag]})"
                    row.append(text)
                lines.append(f"| {tag} | {windows[tag]} | {' | '.join(row)} |")
            parts.append(f"Mean {label} (m) over a tag's windows:\n\n" + "\n".join(lines))
    return "\n\n".join(parts)


def _calibration(params: Params) -> str:
    cal = params.evaluate.dead_reckoning.calibration_s
    return "the whole drive segment" if cal == 0 else f"the {cal} s"


def _model_label(m: str, ev: Evaluation) -> str:
    name = {"G": "G-WhONet", "S": "S-WhONet"}.get(m, m)
    return f"**R-WhONet** ({m})" if m == ev.choice.model else name


def _pos_cell(r) -> str:
    if r is None or not r.n_windows:
        return "–"
    return (
        f"{_fmt(r.pos_mean, r.pos_mean_ci95, 1)} ({r.pos_max:.0f}); {_fmt(r.pos_pct, digits=2)} %"
    )


def _cover_cell(r) -> str:
    if r is None or not r.n_windows:
        return "–"
    return (
        f"{100 * r.cover_1sigma:.0f} / {100 * r.cover_2sigma:.0f} %; {r.nll:.2f} "
        f"({100 * r.cover_1sigma_filter:.0f} / {100 * r.cover_2sigma_filter:.0f} %; "
        f"{r.nll_filter:.2f})"
    )


def _calib_cell(rows: list) -> str:
    """A model's calibration over its outage lengths (rows in length order)."""
    rows = [r for r in rows if r.n_windows]
    if not rows:
        return "–"
    dofs = ["∞" if not math.isfinite(r.calib_dof) else f"{r.calib_dof:.1f}" for r in rows]
    return "c " + " / ".join(f"{r.calib_scale:.2f}" for r in rows) + ", ν " + " / ".join(dofs)


def _per_model_table(
    ev: Evaluation, rows: pd.DataFrame, heading: str, cell: Callable[[Any], str]
) -> str:
    """A row per model in ``rows``, a column per outage length (``"{L} s"`` and ``heading``).

    ``cell`` turns the model's row for that length, or None where there is none, into text.
    """
    return _per_length_table(
        rows,
        ("model", "Model"),
        heading,
        cell,
        lambda m: "fused, GNSS's own distances" if m == GNSS_DISTANCE else _model_label(m, ev),
    )


def _per_length_table(
    rows: pd.DataFrame,
    key: tuple[str, str],
    heading: str,
    cell: Callable[[Any], str],
    label: Callable[[Any], str] = str,
) -> str:
    """A row per value of ``rows[key[0]]`` (named by ``label``, under the header ``key[1]``),
    a column per outage length (``"{L} s"`` and ``heading``); ``cell`` as in
    :func:`_per_model_table`."""
    column, header = key
    outages = sorted(rows["outage_s"].unique())
    cells = rows.set_index([column, "outage_s"])
    lines = [
        f"| {header} | " + " | ".join(f"{L} s{heading}" for L in outages) + " |",
        "|---|" + "---:|" * len(outages),
    ]
    for v in dict.fromkeys(rows[column]):
        row = [cell(cells.loc[(v, L)] if (v, L) in cells.index else None) for L in outages]
        lines.append(f"| {md_cell(label(v))} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def _counts(rows: pd.DataFrame) -> str:
    first = rows.drop_duplicates("outage_s").sort_values("outage_s")
    return ", ".join(
        f"{int(r.outage_s)} s: {int(r.n_windows)} of {int(r.n_windows_all)}"
        for r in first.itertuples()
    )


def nav_position_table(ev: Evaluation) -> str | None:
    """The navigation filter: end-of-outage error per model (mean ± CI (max); % of distance)."""
    pos, plan = ev.position, ev.position_plan
    if pos is None or pos.empty:
        return None
    rows = pos[(pos["control"] == plan["control"]) & (pos["model"] != GNSS_DISTANCE)]
    table = _per_model_table(ev, rows, "", _pos_cell)
    return table + f"\n\nWindows counted (of the target test windows): {_counts(rows)}."


def nav_controls_table(ev: Evaluation) -> str | None:
    """The filter's own controls on one model's distances, and fused on GNSS distances."""
    pos, plan = ev.position, ev.position_plan
    if pos is None or pos.empty:
        return None
    cm = plan["control_model"]
    rows = pos[(pos["model"] == cm) | (pos["model"] == GNSS_DISTANCE)]
    outages = sorted(rows["outage_s"].unique())
    cells = rows.set_index(["model", "control", "outage_s"])
    lines = [
        "| Yaw from | Distances | " + " | ".join(f"{L} s" for L in outages) + " |",
        "|---|---|" + "---:|" * len(outages),
    ]
    label = {"wheels": "rear wheels alone", "gyro": "gyro alone", "fused": "gyro + wheels fused"}
    for (model, control), _ in rows.groupby(["model", "control"], sort=False):
        row = [
            _pos_cell(
                cells.loc[(model, control, L)] if (model, control, L) in cells.index else None
            )
            for L in outages
        ]
        dist = "GNSS's own" if model == GNSS_DISTANCE else _model_label(model, ev)
        lines.append(f"| {label[control]} | {dist} | " + " | ".join(row) + " |")
    for control in plan["unavailable"]:
        lines.append(
            f"| {label[control]} | – | "
            + " | ".join("unavailable (no yaw rate)" for _ in outages)
            + " |"
        )
    return "\n".join(lines)


def nav_calibration_table(ev: Evaluation) -> str | None:
    """Is the predicted uncertainty honest: windows inside its 68.27 / 95.45 % regions, NLL."""
    pos, plan = ev.position, ev.position_plan
    if pos is None or pos.empty:
        return None
    rows = pos[pos["control"] == plan["control"]]
    table = _per_model_table(ev, rows, ": 1σ / 2σ; NLL (the filter's own)", _cover_cell)
    lengths = sorted(rows["outage_s"].unique())
    calib = "; ".join(
        f"{_model_label(model, ev)} {_calib_cell(list(g.sort_values('outage_s').itertuples()))}"
        for model, g in rows.groupby("model", sort=False)
        if model != GNSS_DISTANCE
    )
    at = " / ".join(f"{int(L)}" for L in lengths)
    head = (
        f"The calibration (mean over seeds; c and ν at {at} s: a length's own ν where "
        "Akaike's criterion took it, else the one fitted over every length; ∞: a normal)"
    )
    receiver = _receiver_line(plan.get("receiver", {})) + _gyro_line(plan.get("gyro", {}))
    control = rows[rows["model"] == plan["control_model"]]
    windows = {int(r.outage_s): int(r.n_windows) for r in control.itertuples() if r.n_windows}
    chance = chance_line(windows).strip()
    return f"{table}\n\n{head}: {calib}.{_geometry_line(plan.get('geometry', {}))}{receiver}" + (
        f"\n\n{chance}" if chance else ""
    )


def chance_line(windows: dict[int, int]) -> str:
    """How often chance alone puts an honest prediction's share inside issue 17's bands,
    on these numbers of windows (:func:`rwhonet.evaluation.intervals.band_chance`)."""
    if not windows:
        return ""
    lengths = sorted(windows)
    (p1, tol1), (p2, tol2) = COVER_BANDS
    one = " / ".join(f"{100 * band_chance(windows[L], p1, tol1)[0]:.0f}" for L in lengths)
    two = " / ".join(f"{100 * band_chance(windows[L], p2, tol2)[0]:.0f}" for L in lengths)
    at = " / ".join(str(L) for L in lengths)
    n = " / ".join(str(windows[L]) for L in lengths)
    return (
        f"How far chance scatters the shares: on these {n} windows of {at} s an honest "
        f"prediction's 1σ share lands inside {100 * p1:.0f} ± {100 * tol1:.0f} % with "
        f"probability {one} %, its 2σ share inside {100 * p2:.0f} ± {100 * tol2:.0f} % with "
        f"{two} % (binomial, the windows taken as independent; a drive's windows miss "
        "together, so less)."
    )


def _drive_part(ev: Evaluation, plan: dict) -> list[str]:
    """The coverage by test drive, with what it is for; nothing without windows."""
    table = nav_drive_table(ev)
    if not table:
        return []
    return [
        "",
        f"The same calibration on each target test drive's windows apart ({plan['control']}, "
        f"{_model_label(plan['control_model'], ev)}'s distances; mean over seeds): the drives "
        "differ (a tyre losing air, a heavy load, a wet road), and the windows of one drive "
        "share its conditions, so the share over all windows is nearer a few drives' verdict "
        "than that of as many independent windows.",
        "",
        table,
    ]


def nav_drive_table(ev: Evaluation) -> str | None:
    """The control row's coverage on each target test drive's windows apart.

    A cell: the share of the drive's windows inside the calibrated 1σ / 2σ regions
    (mean over seeds), its windows, and its end-of-outage error as a share of the
    distance driven.
    """
    return _drive_table(ev.position_drives, "error", lambda r: f"{r.pos_pct:.2f} %")


def _drive_table(drives: pd.DataFrame | None, what: str, value: Callable[[Any], str]) -> str | None:
    """Coverage by test drive: a row per drive, a column per outage length, each cell the
    shares inside 1σ / 2σ, the windows and ``value`` of the cell (headed ``what``)."""
    if drives is None or drives.empty:
        return None

    def cell(r) -> str:
        if r is None or not r.n_windows:
            return "–"
        return (
            f"{100 * r.cover_1sigma:.0f} / {100 * r.cover_2sigma:.0f} % "
            f"({int(r.n_windows)}); {value(r)}"
        )

    return _per_length_table(drives, ("drive", "Test drive"), f": 1σ / 2σ (windows); {what}", cell)


def _geometry_line(geometry: dict) -> str:
    """Where the filter took the antenna to sit and how late the gyro, and where from."""
    if not geometry:
        return ""
    ahead, left = geometry["antenna_m"]
    late = geometry["gyro_latency_s"]
    if not geometry["fitted"]:
        return (
            f"\n\nThe antenna {ahead:g} m ahead of and {left:g} m left of the rear axle, the "
            f"gyro {late:g} s late: as configured."
        )
    c_ahead, c_left = geometry["configured_antenna_m"]
    return (
        f"\n\nThe antenna and the gyro's latency, fitted on the target training drives by the "
        f"fixes' log score: the antenna {ahead:.2f} m ahead of and {left:.2f} m left of the "
        f"rear axle, the gyro {1000 * late:.0f} ms late (configured {c_ahead:g} m, {c_left:g} m, "
        f"{1000 * geometry['configured_gyro_latency_s']:g} ms; score {geometry['score']:.1f} "
        f"against {geometry['configured_score']:.1f} nats over {geometry['n_seconds']} s, "
        f"{geometry['tried']} settings tried)."
    )


def _receiver_line(receiver: dict) -> str:
    """What the filter took for the receiver's drift, and where it came from."""
    if not receiver:
        return ""
    held = f"τ = {receiver['tau_s']:g} s held"
    if not receiver["fitted"]:
        return f"\n\nThe receiver's drift: σ = {receiver['sigma_m']:g} m as configured ({held})."
    tried = ", ".join(f"{s} m: {v:.3f}" for s, v in receiver["nll"].items())
    configured = receiver["configured_sigma_m"]
    return (
        f"\n\nThe receiver's drift, fitted on the target training windows by maximum "
        f"likelihood: σ = {receiver['sigma_m']:.2f} m (configured {configured:g} m; {held}; "
        f"{receiver['n_windows']} windows; mean NLL per window, nats: {tried})."
    )


def _gyro_line(gyro: dict) -> str:
    """What the filter took for the gyro's bias instability, and where it came from."""
    if not gyro:
        return ""
    if not gyro["fitted"]:
        return f" The gyro's bias instability: B = {gyro['instability_deg_s']:g} °/s as configured."
    tried = ", ".join(f"{b} °/s: {v:.3f}" for b, v in gyro["nll"].items())
    return (
        f" The gyro's bias instability, fitted on the target training windows by maximum "
        f"likelihood (with the receiver's drift, where that is fitted): B = "
        f"{gyro['instability_deg_s']:.4f} °/s (configured {gyro['configured_instability_deg_s']:g}"
        f" °/s; its correlation time held; {gyro['n_windows']} windows; mean NLL per window at "
        f"the drift taken, nats: {tried})."
    )


def crse_calibration_table(ev: Evaluation) -> str | None:
    """Each model's distance variance, and its CRSE inside the predicted 1σ / 2σ."""
    var, unc = ev.variance, ev.uncertainty
    if var is None or var.empty:
        return None
    outages = sorted(unc["outage_s"].unique())
    cells = unc.set_index(["model", "outage_s"])
    lines = [
        "| Model | σ² = a + b d²: a (cm²), √b (%) | α, κ, λ; τ (%) | "
        + " | ".join(f"{L} s: 1σ / 2σ (independent); NLL" for L in outages)
        + " |",
        "|---|---:|---:|" + "---:|" * len(outages),
    ]
    for r in var.itertuples():
        row = []
        for L in outages:
            c = cells.loc[(r.model, L)] if (r.model, L) in cells.index else None
            row.append(
                "–"
                if c is None or not c.n_windows
                else f"{100 * c.cover_1sigma:.0f} / {100 * c.cover_2sigma:.0f} % "
                f"({100 * c.cover_1sigma_independent:.0f} / "
                f"{100 * c.cover_2sigma_independent:.0f} %); {c.nll:.2f}"
            )
        lines.append(
            f"| {_model_label(r.model, ev)} | {1e4 * r.a_m2:.1f}, {100 * math.sqrt(r.b):.2f} | "
            f"{r.crse_scale:.2f}, {r.crse_spread:.2f}, {r.crse_lasting:.3f}; "
            f"{100 * r.scale_sd:.2f} | " + " | ".join(row) + " |"
        )
    return "\n".join(lines)


def _crse_chance_part(ev: Evaluation) -> list[str]:
    """Chance's scatter on the CRSE prediction's test windows (the control model's)."""
    unc = ev.uncertainty
    if unc is None or unc.empty:
        return []
    mine = unc[unc["model"] == ev.position_plan.get("control_model")]
    windows = {int(r.outage_s): int(r.n_windows) for r in mine.itertuples() if r.n_windows}
    line = chance_line(windows)
    return ["", line] if line else []


def _crse_drive_part(ev: Evaluation) -> list[str]:
    """R-WhONet's CRSE calibration by test drive, with what it is for; nothing without it."""
    table = crse_drive_table(ev)
    if not table:
        return []
    return [
        "",
        f"The same CRSE prediction of {_model_label(ev.choice.model, ev)} on each target test "
        "drive's windows apart (mean over seeds): as for the 2D coverage above, a drive's "
        "windows share its tyres, load and road, and miss together.",
        "",
        table,
    ]


def crse_drive_table(ev: Evaluation) -> str | None:
    """R-WhONet's CRSE within its calibrated 1σ / 2σ on each target test drive's windows.

    A cell: the share of the drive's windows (mean over seeds), their number and the
    mean negative log-likelihood.
    """
    return _drive_table(ev.uncertainty_drives, "NLL", lambda r: f"{r.nll:.2f}")


def position_table(ev: Evaluation, params: Params) -> str | None:
    """The earlier 2D dead reckoning (a control): the horizontal error at each window's end."""
    pos = ev.position_dead_reckoning
    if pos is None or pos.empty:
        return None
    outages = sorted(pos["outage_s"].unique())
    models = list(dict.fromkeys(pos["model"]))
    cells = pos.set_index(["model", "outage_s"])
    lines = [
        "| Model | " + " | ".join(f"{L} s: mean (max)" for L in outages) + " |",
        "|---|" + "---:|" * len(outages),
    ]
    for m in models:
        row = []
        for L in outages:
            r = cells.loc[(m, L)] if (m, L) in cells.index else None
            row.append(
                "–" if r is None else f"{_fmt(r.pos_mean, r.pos_mean_ci95)} ({r.pos_max:.1f})"
            )
        lines.append(f"| {_model_label(m, ev)} | " + " | ".join(row) + " |")
    counts = ", ".join(
        f"{L} s: {int(cells.loc[(models[0], L), 'n_windows'])} of "
        f"{int(cells.loc[(models[0], L), 'n_windows_all'])}"
        for L in outages
        if (models[0], L) in cells.index
    )
    return "\n".join(lines) + f"\n\nWindows dead-reckoned (of the target test windows): {counts}."


def limits_table(ev: Evaluation, params: Params) -> str | None:
    """The WPM's radius from m s (first / any / whole drive) next to every recipe at m."""
    lim = ev.limits
    if lim is None or lim.empty:
        return None
    L = max(params.evaluate.outages_s)
    rows = ev.summary[
        (ev.summary["role"] == k.TARGET_TEST)
        & (ev.summary["drive"] == "all")
        & (ev.summary["outage_s"] == L)
    ].set_index("model")["crse_mean"]
    recipes = [r for r in params.adapt.recipes if r not in CONTINUOUS_RECIPES]
    lines = [
        "| m | radius from the first m s (WPM-m) | from any m s | sd of that radius | "
        "from the whole drive (in-sample) | best recipe at m |",
        "|---:|---:|---:|---:|---:|---|",
    ]
    for r in lim.itertuples():
        at_m = {x: rows.get(recipe_model(x, int(r.m)), math.nan) for x in recipes}
        best = min(at_m, key=lambda x: (not math.isfinite(at_m[x]), at_m[x]))
        lines.append(
            f"| {int(r.m)} | {_fmt(r.first)} | {_fmt(r.any)} | {r.radius_sd_pct:.2f} % | "
            f"{_fmt(r.whole)} | {best} {_fmt(at_m[best])} |"
        )
    cont = rows.get(recipe_model(CONTINUOUS, None))
    tail = (
        (
            f"\n\nThe continuous recipe (radius and head re-fitted before every window): "
            f"{_fmt(cont)} m."
        )
        if cont is not None
        else ""
    )
    cont_shrink = rows.get(recipe_model(CONTINUOUS_SHRINK, None))
    if cont_shrink is not None:
        tail += (
            f"\n\ncontinuous_shrink (the shrink recipe's radius, then the head, re-fitted "
            f"before every window, each moving as far as the seconds so far support): "
            f"{_fmt(cont_shrink)} m."
        )
    return "\n".join(lines) + tail


def selection_tables(ev: Evaluation, params: Params) -> str | None:
    """The selection evidence: every recipe on the target training drives, ridge on the source's."""
    sel = ev.selection
    if sel.empty:
        return None
    rec = ev.choice.as_selection()
    outages = sorted({min(params.evaluate.outages_s), max(params.evaluate.outages_s)})
    parts = []
    train = sel[sel["role"] == k.TARGET_TRAIN].set_index(["model", "outage_s"])
    if len(train):
        chosen = rec.get("recommended", {})
        lines = [
            "| Recipe | m | " + " | ".join(f"CRSE {L} s" for L in outages) + " |",
            "|---|---:|" + "---:|" * len(outages),
        ]
        ref = ["G", "WPM"]
        entries = [(n, None, n) for n in ref] + [
            (r, m, recipe_model(r, m))
            for r in params.adapt.recipes
            for m in ([None] if r in CONTINUOUS_RECIPES else params.adapt.m_grid)
        ]

        def cell(model: str, L: float) -> tuple[float, float]:
            # Short training drives give no window of the longer outages: show a dash.
            if (model, L) not in train.index:
                return float("nan"), float("nan")
            row = train.loc[(model, L)]
            return float(row["crse_mean"]), float(row["crse_mean_ci95"])

        for recipe, m, model in entries:
            cells = []
            for L in outages:
                mean, ci = cell(model, L)
                if mean != mean:
                    cells.append("–")
                    continue
                text = _fmt(mean, ci)
                if model not in ref and mean > cell("G", L)[0]:
                    text += " ▲"
                cells.append(text)
            mark = " ◆" if (recipe, m) == (chosen.get("recipe"), chosen.get("m")) else ""
            label = "–" if m is None else str(m)
            lines.append(f"| {recipe}{mark} | {label} | {' | '.join(cells)} |")
        n = (
            int(train.loc[("G", outages[-1]), "n_windows"])
            if ("G", outages[-1]) in train.index
            else 0
        )
        parts.append(
            f"Target training drives ({n} windows of {outages[-1]} s after each drive's first "
            f"{max(params.adapt.m_grid)} s; ▲ worse than G; ◆ the rule's choice):\n\n"
            + "\n".join(lines)
        )
    if "ridge" in rec:
        by = rec["ridge"][f"mean_crse_{outages[-1]}s_by_penalty"]
        lines = ["| ridge_penalty | " + " | ".join(by) + " |", "|---|" + "---:|" * len(by)]
        values = " | ".join(f"{v:.2f}" for v in by.values())
        lines.append(f"| mean {outages[-1]} s CRSE over m | {values} |")
        parts.append(
            "ridge_head on the held-out source-car drives (mean over m and seeds; recommended "
            f"{rec['ridge']['recommended_penalty']:g}):\n\n" + "\n".join(lines)
        )
    p = rec.get("params", {})
    got = rec.get("recommended")

    def choice(recipe: str, m: int | None) -> str:
        return f"**{recipe}**" + ("" if recipe in CONTINUOUS_RECIPES else f" at m = {m} s")

    ridge = rec.get("ridge", {}).get("recommended_penalty")
    chosen = rec.get("chosen", {})
    if p.get("recipe") == "auto":
        used = (
            f"params use auto, so R-WhONet is {choice(chosen.get('recipe'), chosen.get('m'))}"
            f" ({rec.get('chosen_by')})"
        )
    else:
        used = f"params use {choice(p.get('recipe'), p.get('chosen_m'))}"
    used += f", and ridge_penalty {p.get('ridge_penalty'):g}."
    picked = (
        f"The rule picks {choice(got['recipe'], got['m'])}"
        if got
        else f"No recipe passes the rule's conditions ({rec.get('no_recommendation', '')})"
    )
    ridge_text = f" and ridge_penalty {ridge:g}" if ridge is not None else ""
    verdict = f"{picked}{ridge_text}; {used}"
    return f"Rule: {rec.get('rule', '')}\n\n{verdict}\n\n" + "\n\n".join(parts)


def render_report(ev: Evaluation, params: Params, provenance: str) -> str:
    """The whole ``reports/tables.md``."""
    chosen, grid = ev.choice.m, params.adapt.m_grid
    longest = max(params.evaluate.outages_s)
    headline = ["WPM", alt_wpm(params.label.wpm_mode)[0], "G", "S", "R", f"WPM-m@{chosen}"]
    if "radius+G" in params.adapt.recipes and ev.choice.recipe != "radius+G":
        headline.append(recipe_model("radius+G", chosen))
    parts = [
        "# R-WhONet evaluation",
        "",
        provenance,
        "",
        f"Every model is scored on the same seconds: those after the first {max(grid)} s (the "
        f"largest m) of each test drive, so no R-WhONet is scored on seconds it was adapted on. "
        f"R-WhONet is recipe `{ev.choice.recipe}` at m = {chosen} s, "
        f"{CHOSEN_BY[ev.choice.chosen_by]}"
        ". CRSE = Σ|e| and CTE = |Σe| per "
        "outage window (paper Eqs. 16-17), e = label − prediction (a WPM alone: e = GNSS − "
        "WPM). WPM-m@m: the WPM with its rear radii refitted on each drive's first m s; "
        "R[radius+G]@m: G on top of a WPM whose rear radii are refitted on the same m s to "
        "what G leaves (the G+radius control); R[continuous]: recalibrated "
        "before every window on the drive's seconds before it."
        + (
            " R[shrink]@m: R[radius+G]@m's radii moved from the source calibration only as far "
            "as the m s can tell (w = τ² / (τ² + V(m) / D²), measured on the target car's "
            "training drives: models/r/seed<seed>/evidence.json); R[continuous_shrink]: that "
            "radius, then G's head, refitted before every window."
            if SHRINK in params.adapt.recipes
            else ""
        ),
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
        f"## Table 2 — R-WhONet (recipe `{ev.choice.recipe}`) CRSE (m) for every m, "
        f"{longest} s outages",
        "",
        m_grid_table(ev, params, longest),
        "",
        "## Every recipe at every m, and the radius-only control (mean over all windows, m)",
        "",
        "▲: the mean over seeds is worse than G (not recalibrating).",
        "",
        recipes_table(ev, params),
        "",
        f"## Do no harm: recalibrated models against G, {longest} s outages",
        "",
        "Over every (target test drive, seed) pair: how often the drive's mean CRSE is above "
        "G's, and by how much (relative to G).",
        "",
        harm_table(ev, params),
        "",
        "## The WPM-m control's refitted rear radii, left / right (mm)",
        "",
        "– : the first m s never moved fast enough to fit; the source calibration is kept.",
        "",
        refit_table(ev, params),
    ]
    nav = nav_position_table(ev)
    if nav:
        plan = ev.position_plan
        control = (
            "the ESC's yaw-rate gyro fused with the rear wheels' yaw"
            if plan["control"] == "fused"
            else "the rear wheels' yaw alone (the drives have no yaw rate)"
        )
        parts += [
            "",
            "## Where is the car when GNSS returns: 2D position error at the end of each outage",
            "",
            "Beyond the paper (its CRSE and CTE are distances). A navigation filter (an extended "
            "Kalman filter over position, heading, the gyro's bias and scale, the odometry's "
            "scale and the wheel yaw's errors: rwhonet.nav) runs over each target test segment "
            f"with GNSS, propagated by the model's distance of each second and by {control}; "
            "through each outage window it dead-reckons without GNSS. The error is the "
            "horizontal distance to the GNSS fix at the window's end: mean over windows and "
            "seeds ± 95 % interval (largest window, mean over seeds); then the errors' sum over "
            "the distances driven (%). Sensor figures: params.yaml evaluate.navigation "
            "(generic automotive values; rwhonet.evaluation.position).",
            "",
            nav,
            "",
            "### The filter's own controls",
            "",
            "The same windows: the yaw of one sensor alone or both fused, on "
            f"{_model_label(plan['control_model'], ev)}'s distances; and fused on the GNSS's "
            "own distance of each second, where the error left is the heading's alone.",
            "",
            nav_controls_table(ev),
            "",
            "### Is the predicted uncertainty honest?",
            "",
            "The share of windows whose end-of-outage error lies inside the predicted "
            "68.27 % and 95.45 % regions (an honest prediction: about 68 and 95 %), and the "
            "mean negative log-likelihood of the errors (nats; lower is better). The "
            "prediction is the filter's covariance calibrated on the target training drives' "
            "windows (never a test drive) as a bivariate Student t: the covariance times a "
            "scale c, with ν degrees of freedom for the heavy tails, c per outage length "
            "and ν too where Akaike's criterion takes it (ν = ∞: a normal; fewer "
            "than 20 training windows: the filter's own normal); in brackets the filter's own "
            "normal ellipses (rwhonet.nav.coverage, rwhonet.evaluation.position).",
            "",
            nav_calibration_table(ev),
            *_drive_part(ev, plan),
            "",
            "Each model's per-second distance variance σ² = a + b d² (fitted by Gaussian "
            "likelihood on the target training drives, never a test drive; S on the segment "
            "tails it was validated on; a continuous recipe on its seconds inside its "
            "training windows, its prediction not conditioned: it refits before each "
            "window), and its windows' CRSE against the prediction "
            "N(α M, κ² V + λ² M²) calibrated on the same training windows (λ: the "
            "part that lasts through the window, 0 where Akaike's criterion leaves it out), "
            "conditioned on the scale error the drive showed before the window: ŝ = Σe/Σd "
            "over its seconds with GNSS, kept in the proportion τ²/(τ² + var ŝ), τ the "
            "training windows' spread of it; each second's |e| a folded normal about that "
            "kept scale times d with spread ρσ, ρ = α/√(2/π), M and V its summed mean and "
            "variance over ρ√(2/π) and ρ²(1 − 2/π) (Σσ and Σσ² where nothing is kept): "
            "the share of test windows within 1σ and 2σ of it (in brackets: the prediction "
            "that takes the seconds as independent, α = √(2/π), κ = √(1 − 2/π), λ = 0), "
            "and its mean negative "
            "log-likelihood (rwhonet.evaluation.uncertainty).",
            "",
            crse_calibration_table(ev),
            *_crse_chance_part(ev),
            *_crse_drive_part(ev),
        ]
    position = position_table(ev, params)
    if position:
        parts += [
            "",
            "### Control: the earlier 2D dead reckoning (rear wheels, fitted heading)",
            "",
            "From the GNSS fix before each window, heading from the rear wheels' travel "
            "difference fitted to the GNSS course over "
            f"{_calibration(params)} before the window "
            "(rwhonet.features.deadreckoning); each second's distance is the model's; the "
            "first row dead-reckons the GNSS's own distances (m).",
            "",
            position,
        ]
    limits = limits_table(ev, params)
    if limits:
        parts += [
            "",
            f"## What m seconds can tell: the WPM's rear radius from m s, {longest} s outages",
            "",
            "Mean CRSE (m) of the WPM alone with its rear radii fitted on the drive's first m s, "
            "on every non-overlapping m-s block of it (mean over blocks; the radius' standard "
            "deviation over blocks, median over drives), and on the whole drive, the scored "
            "seconds included (not a usable model: the best one radius per drive can do). "
            "first − any: what the start of a drive costs (tyres still cold, pulling away); "
            "any − whole: what m seconds of GNSS cost (identifiability); whole: the floor of a "
            "radius, made of the label's own GNSS noise and what one radius cannot follow "
            "(rwhonet.evaluation.limits).",
            "",
            limits,
        ]
    selection = selection_tables(ev, params)
    if selection:
        parts += [
            "",
            "## Selection: the evidence recipe, m and ridge penalty are chosen on",
            "",
            "Never the target test drives: recipes on the target *training* drives (their first "
            "m s to recalibrate, the rest scored), ridge penalties on held-out *source* drives.",
            "",
            selection,
        ]
    if len(ev.over_time):
        parts += [
            "",
            f"## Mean CRSE against the time into the drive, {longest} s outages",
            "",
            "Windows binned by the minute of the drive they start at; the continuous recipe "
            "has more of the drive to recalibrate on as it goes.",
            "",
            over_time_table(ev, params),
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
    scenario_outages = scenario_outage_tables(ev)
    if scenario_outages:
        L = ev.scenario_outage_s
        parts += [
            "",
            f"## Scenario outages — a {L} s GNSS outage over every tagged event of the target "
            "test drives",
            "",
            "The paper's short-term complex scenarios (roundabouts, sharp cornering, hard "
            f"braking, wet roads): per tagged event, {L} s outage windows centred on it, as many "
            "as cover it, within the seconds every model is scored on (WhONet's scenario "
            "protocol: the authors' code scores each scenario recording in consecutive "
            f"{PROTOCOL_OUTAGE_S} s outages"
            + ("" if L == PROTOCOL_OUTAGE_S else f"; {L} s here, evaluate.scenario_outage_s")
            + "). Events touching a drive's first max(m) s are left out (R-WhONet is "
            "adapted there); events of one tag whose windows would overlap are merged; a GNSS "
            "gap splits an event. CRSE and CTE per window, mean over a tag's windows, then over "
            "seeds ± 95 % interval. R[continuous]: recalibrated before each window of the "
            f"shortest outage ({min(params.evaluate.outages_s)} s), so a scenario window outside "
            "those is not scored for it ('n of W'). Rules: rwhonet.evaluation.scenarios.",
            "",
            scenario_outages,
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
