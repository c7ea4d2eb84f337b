"""The headline comparison of one execution, from ``metrics/eval.json``: rows, Markdown, HTML/SVG.

What a person opening the MLflow UI should see first, on the execution's parent
run: mean CRSE and CTE per model (WPM, G, S, R-WhONet and the controls) and
outage length, each a mean over training seeds with the half-width of its 95 %
interval. Everything is read from the evaluation's ``eval.json`` (the same
numbers as ``reports/tables.md``), never recomputed.
"""

from __future__ import annotations

import html
import math
from typing import Any

# Bar colours of the SVG chart (CRSE, CTE).
COLOURS = ("#1f77b4", "#ff7f0e")


def headline_models(ev: dict[str, Any]) -> list[tuple[str, str]]:
    """``(eval.json model key, display name)`` of the models compared, in table order.

    WPM, the other WPM mode, G, S, R-WhONet (the chosen recipe at the chosen m),
    the network-free radius refit at that m, every other recipe at that m and the
    continuous recipe; models ``eval.json`` does not have are left out.
    """
    overall = ev["overall"]
    m = ev["chosen_m"]
    alt = next((name for name in overall if name.startswith("WPM-") and "@" not in name), None)
    rows = [
        ("WPM", "WPM (wheel odometry)"),
        *([(alt, f"{alt} (the other WPM mode)")] if alt else []),
        ("G", "G-WhONet (source car)"),
        ("S", "S-WhONet (target car)"),
        ("R", f"R-WhONet ({ev['recipe']}, m = {m} s)"),
        (f"WPM-m@{m}", f"WPM-m@{m} (radius refit only)"),
    ]
    chosen = f"R[{ev['recipe']}]@{m}"
    for name in overall:
        if name.startswith("R[") and name != chosen:
            if name.endswith(f"]@{m}"):
                rows.append((name, f"{name} (recipe)"))
            elif "@" not in name:
                rows.append((name, f"{name} (before every outage)"))
    return [(key, label) for key, label in rows if key in overall]


def outages(ev: dict[str, Any]) -> list[int]:
    """The outage lengths of the evaluation, in seconds, shortest first."""
    return sorted({int(o.removesuffix("s")) for cells in ev["overall"].values() for o in cells})


def comparison_rows(ev: dict[str, Any]) -> list[dict[str, Any]]:
    """One tidy row per model and outage: ``model, name, outage_s, crse_mean, crse_ci95, ...``.

    Args:
        ev: the content of ``metrics/eval.json``.
    """
    rows = []
    for key, label in headline_models(ev):
        for length in outages(ev):
            cell = ev["overall"][key].get(f"{length}s")
            if cell is None:
                continue
            rows.append(
                {
                    "model": key,
                    "name": label,
                    "outage_s": length,
                    "crse_mean": cell["crse_mean"],
                    "crse_ci95": cell["crse_ci95"],
                    "cte_mean": cell["cte_mean"],
                    "cte_ci95": cell["cte_ci95"],
                    "n_windows": cell.get("n_windows"),
                }
            )
    return rows


def _pm(mean: float | None, ci: float | None) -> str:
    if mean is None:
        return "–"
    return f"{mean:.2f}" if ci is None or ci == 0 else f"{mean:.2f} ± {ci:.2f}"


def caption(ev: dict[str, Any]) -> str:
    """What the numbers are (one sentence), and the drives refused and left out of them
    (``data.refused_drives: leave_out``), where there are any."""
    text = (
        f"Mean CRSE / CTE (m) over the outage windows of the target test drives, "
        f"{ev['evaluated_on']}; mean over {ev['n_seeds']} training seed(s) ± the half-width "
        f"of its 95 % interval. Source: metrics/eval.json."
    )
    if left := ev.get("left_out"):
        names = ", ".join(f"{d['drive']} ({d['role']})" for d in left)
        text += (
            f" {len(left)} drive(s) refused and left out (data.refused_drives: leave_out), "
            f"not in these numbers: {names}; why: left_out in metrics/eval.json."
        )
    return text


def comparison_markdown(ev: dict[str, Any]) -> str:
    """A Markdown table (a model per row, CRSE and CTE per outage length) with its caption."""
    lengths = outages(ev)
    head = "| model | " + " | ".join(f"CRSE {L} s | CTE {L} s" for L in lengths) + " |"
    rule = "|---|" + "---:|---:|" * len(lengths)
    cells = {(r["model"], r["outage_s"]): r for r in comparison_rows(ev)}
    body = []
    for key, label in headline_models(ev):
        parts = []
        for L in lengths:
            r = cells.get((key, L), {})
            parts += [
                _pm(r.get("crse_mean"), r.get("crse_ci95")),
                _pm(r.get("cte_mean"), r.get("cte_ci95")),
            ]
        body.append(f"| {label} | " + " | ".join(parts) + " |")
    return "\n".join([caption(ev), "", head, rule, *body]) + "\n"


def _svg_panel(rows: list[dict[str, Any]], length: int, width: int = 640) -> str:
    """Horizontal bars of CRSE and CTE per model for one outage length, with CI whiskers."""
    mine = [r for r in rows if r["outage_s"] == length]
    label_w, bar_h, gap, top = 250, 9, 8, 24
    top_value = (
        max((r[f"{q}_mean"] or 0) + (r[f"{q}_ci95"] or 0) for r in mine for q in ("crse", "cte"))
        or 1.0
    )
    scale = (width - label_w - 60) / top_value
    height = top + len(mine) * (2 * bar_h + gap) + 8
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'font-family="sans-serif" font-size="11" role="img" '
        f'aria-label="CRSE and CTE per model, {length} s outage">',
        f'<text x="0" y="14" font-weight="bold">{length} s outage</text>',
        f'<rect x="{label_w}" y="4" width="10" height="10" fill="{COLOURS[0]}"/>'
        f'<text x="{label_w + 14}" y="13">CRSE</text>'
        f'<rect x="{label_w + 60}" y="4" width="10" height="10" fill="{COLOURS[1]}"/>'
        f'<text x="{label_w + 74}" y="13">CTE</text>',
    ]
    y = top
    for r in mine:
        out.append(
            f'<text x="{label_w - 6}" y="{y + bar_h + 3}" text-anchor="end">'
            f"{html.escape(r['name'])}</text>"
        )
        for i, q in enumerate(("crse", "cte")):
            mean, ci = r[f"{q}_mean"], r[f"{q}_ci95"]
            if mean is None or not math.isfinite(mean):
                continue
            by = y + i * bar_h
            w = mean * scale
            tip = f"<title>{q.upper()} {_pm(mean, ci)} m</title>"
            out.append(
                f'<rect x="{label_w}" y="{by}" width="{w:.1f}" height="{bar_h - 1}" '
                f'fill="{COLOURS[i]}">{tip}</rect>'
            )
            if ci:
                lo, hi = label_w + (mean - ci) * scale, label_w + (mean + ci) * scale
                mid = by + (bar_h - 1) / 2
                out.append(
                    f'<line x1="{lo:.1f}" x2="{hi:.1f}" y1="{mid:.1f}" y2="{mid:.1f}" '
                    'stroke="black" stroke-width="1"/>'
                )
            out.append(
                f'<text x="{label_w + w + (ci or 0) * scale + 4:.1f}" y="{by + bar_h - 1}">'
                f"{mean:.2f}</text>"
            )
        y += 2 * bar_h + gap
    out.append("</svg>")
    return "".join(out)


def comparison_html(ev: dict[str, Any]) -> str:
    """A self-contained HTML page: the Markdown table's numbers and a bar chart per outage."""
    lengths = outages(ev)
    rows = comparison_rows(ev)
    cells = {(r["model"], r["outage_s"]): r for r in rows}
    head = "".join(f"<th>CRSE {L} s</th><th>CTE {L} s</th>" for L in lengths)
    body = []
    for key, label in headline_models(ev):
        tds = "".join(
            f"<td>{_pm(cells.get((key, L), {}).get(f'{q}_mean'), cells.get((key, L), {}).get(f'{q}_ci95'))}</td>"  # noqa: E501
            for L in lengths
            for q in ("crse", "cte")
        )
        body.append(f"<tr><th scope='row'>{html.escape(label)}</th>{tds}</tr>")
    charts = "".join(f"<figure>{_svg_panel(rows, L)}</figure>" for L in lengths)
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>CRSE / CTE per model</title>"
        "<style>body{font-family:sans-serif;font-size:13px}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:3px 8px}td{text-align:right}"
        "th[scope=row]{text-align:left;font-weight:normal}figure{margin:12px 0}</style>"
        f"</head><body><h3>CRSE / CTE per model and outage</h3><p>{html.escape(caption(ev))}</p>"
        f"<table><thead><tr><th>model</th>{head}</tr></thead><tbody>{''.join(body)}</tbody>"
        f"</table>{charts}</body></html>\n"
    )


def headline_metrics(ev: dict[str, Any]) -> dict[str, float]:
    """The parent run's own metrics: ``<model>/crse/<L>s/mean`` (and ``…/ci95``) per headline model.

    Models by short names that MLflow accepts as metric keys: ``WPM``, ``G``, ``S``,
    ``R``, ``WPM-m`` (at the chosen m) and ``R-continuous``.
    """
    short = {
        "WPM": "WPM",
        "G": "G",
        "S": "S",
        "R": "R",
        f"WPM-m@{ev['chosen_m']}": "WPM-m",
        "R[continuous]": "R-continuous",
    }
    out = {}
    for r in comparison_rows(ev):
        name = short.get(r["model"])
        if name is None:
            continue
        for q in ("crse", "cte"):
            for stat in ("mean", "ci95"):
                value = r[f"{q}_{stat}"]
                if value is not None:
                    out[f"{name}/{q}/{r['outage_s']}s/{stat}"] = float(value)
    return out


def view_metrics(ev: dict[str, Any]) -> list[str]:
    """The parent-run metrics a saved runs-table view shows: CRSE then CTE at the longest outage."""
    longest = f"/{max(outages(ev))}s/mean"
    names = list(headline_metrics(ev))
    return [n for q in ("/crse/", "/cte/") for n in names if q in n and n.endswith(longest)]
