"""Markdown tables in the layout of the paper's Tables 2-10, from the evaluation's tidy summary."""

from __future__ import annotations

import pandas as pd

STATS = (("max", "Max"), ("min", "Min"), ("mean", "μ"), ("std", "σ"))
MODEL_COLUMNS = (("WPM", "WPM"), ("R", "R-WhONet"), ("G", "G-WhONet"), ("S", "S-WhONet"))


def _fmt(v: float) -> str:
    return f"{v:.2f}"


def outage_table(summary: pd.DataFrame, outage_s: int, metric: str, chosen_m: int) -> str:
    """One of the paper's Tables 3-10: ``metric`` (crse|cte) for one outage length.

    Args:
        summary: tidy rows ``drive, model, outage_s, crse_max ... dist_std, n_windows``.
        outage_s: outage length in seconds.
        metric: ``crse`` or ``cte``.
        chosen_m: the m reported as R-WhONet.

    Returns:
        A markdown table: per drive, Max/Min/μ/σ of the metric per model, the
        distance travelled per window and the number of windows.
    """
    label = {"crse": "CRSE (m)", "cte": "CTE (m)"}[metric]
    heads = [f"{name} (m={chosen_m})" if key == "R" else name for key, name in MODEL_COLUMNS]
    lines = [
        f"| Drive | | {' | '.join(h + ' ' + label for h in heads)} | Distance (m) | Windows |",
        "|---|---|" + "---:|" * (len(heads) + 2),
    ]
    rows = summary[(summary["outage_s"] == outage_s) & (summary["drive"] != "all")]
    for drive in dict.fromkeys(rows["drive"]):
        per_model = rows[rows["drive"] == drive].set_index("model")
        for i, (stat, stat_label) in enumerate(STATS):
            cells = [_fmt(per_model.loc[key, f"{metric}_{stat}"]) for key, _ in MODEL_COLUMNS]
            dist = _fmt(per_model.iloc[0][f"dist_{stat}"])
            n = str(int(per_model.iloc[0]["n_windows"])) if i == 0 else ""
            lines.append(
                f"| {drive if i == 0 else ''} | {stat_label} | {' | '.join(cells)} | {dist} | {n} |"
            )
    return "\n".join(lines)


def m_grid_table(summary: pd.DataFrame, outage_s: int, m_grid: list[int]) -> str:
    """The paper's Table 2: R-WhONet's CRSE for every m (one outage length)."""
    lines = [
        "| Drive | | " + " | ".join(f"m={m} s" for m in m_grid) + " |",
        "|---|---|" + "---:|" * len(m_grid),
    ]
    rows = summary[(summary["outage_s"] == outage_s) & (summary["drive"] != "all")]
    for drive in dict.fromkeys(rows["drive"]):
        per_model = rows[rows["drive"] == drive].set_index("model")
        for i, (stat, stat_label) in enumerate(STATS):
            cells = [_fmt(per_model.loc[f"R@{m}", f"crse_{stat}"]) for m in m_grid]
            lines.append(f"| {drive if i == 0 else ''} | {stat_label} | {' | '.join(cells)} |")
    return "\n".join(lines)


def overall_table(summary: pd.DataFrame, outages_s: list[int], chosen_m: int) -> str:
    """Mean CRSE / CTE over all evaluation windows of all test drives (the CI gate's numbers)."""
    heads = [f"{name} (m={chosen_m})" if key == "R" else name for key, name in MODEL_COLUMNS]
    lines = [
        "| Outage | " + " | ".join(f"{h} CRSE / CTE" for h in heads) + " | Windows |",
        "|---|" + "---:|" * (len(heads) + 1),
    ]
    rows = summary[summary["drive"] == "all"].set_index(["model", "outage_s"])
    for L in outages_s:
        cells = [
            f"{_fmt(rows.loc[(k, L), 'crse_mean'])} / {_fmt(rows.loc[(k, L), 'cte_mean'])}"
            for k, _ in MODEL_COLUMNS
        ]
        n = int(rows.loc[("WPM", L), "n_windows"])
        lines.append(f"| {L} s | {' | '.join(cells)} | {n} |")
    return "\n".join(lines)


def scenario_table(scenarios: pd.DataFrame, chosen_m: int) -> str:
    """Mean |e| per second on each scenario tag's seconds (the paper's short-term scenarios)."""
    heads = [f"{name} (m={chosen_m})" if key == "R" else name for key, name in MODEL_COLUMNS]
    lines = [
        "| Scenario | Seconds | " + " | ".join(heads) + " |",
        "|---|---:|" + "---:|" * len(heads),
    ]
    for r in scenarios.itertuples(index=False):
        cells = [_fmt(getattr(r, key)) for key, _ in MODEL_COLUMNS]
        lines.append(f"| {r.tag} | {r.n_seconds} | {' | '.join(cells)} |")
    return "\n".join(lines)


def render_report(
    summary: pd.DataFrame,
    *,
    outages_s: list[int],
    m_grid: list[int],
    chosen_m: int,
    eval_note: str,
    provenance: str,
    scenarios: pd.DataFrame | None = None,
) -> str:
    """The whole ``reports/tables.md``."""
    longest = max(outages_s)
    parts = [
        "# R-WhONet evaluation",
        "",
        provenance,
        "",
        eval_note,
        "",
        "CRSE = Σ|e| and CTE = |Σe| per outage window (paper Eqs. 16-17), e = label − prediction "
        "(WPM alone: e = label); Max/Min/μ/σ over the windows of a drive (σ: population, Eq. 19).",
        "",
        "## Mean over all windows of all test drives",
        "",
        overall_table(summary, outages_s, chosen_m),
        "",
        f"## Table 2 — R-WhONet CRSE (m) for every m, {longest} s outages",
        "",
        m_grid_table(summary, longest, m_grid),
    ]
    if scenarios is not None and len(scenarios):
        parts += [
            "",
            "## Scenarios — mean absolute error per second (m) on the evaluated seconds",
            "",
            "A second carries every tag of its rows (tags overlap). Sorted by seconds.",
            "",
            scenario_table(scenarios, chosen_m),
        ]
    n = 3
    for L in outages_s:
        for metric in ("crse", "cte"):
            parts += [
                "",
                f"## Table {n} — {metric.upper()}, {L} s GNSS outages",
                "",
                outage_table(summary, L, metric, chosen_m),
            ]
            n += 1
    return "\n".join(parts) + "\n"
