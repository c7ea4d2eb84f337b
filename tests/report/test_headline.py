"""The parent run's comparison: read from eval.json, never recomputed; table, Markdown, HTML/SVG."""

import pytest

from rwhonet.report.headline import (
    comparison_html,
    comparison_markdown,
    comparison_rows,
    headline_metrics,
    view_metrics,
)


def cell(crse, cte, ci=0.1):
    return {"crse_mean": crse, "crse_ci95": ci, "cte_mean": cte, "cte_ci95": ci, "n_windows": 9}


@pytest.fixture
def ev():
    lengths = ("30s", "180s")
    overall = {
        "WPM": {L: cell(2.0 * i, 1.5 * i, 0.0) for i, L in enumerate(lengths, 1)},
        "WPM-ref": {L: cell(2.5 * i, 2.0 * i, 0.0) for i, L in enumerate(lengths, 1)},
        "G": {L: cell(1.9 * i, 1.4 * i) for i, L in enumerate(lengths, 1)},
        "S": {L: cell(1.8 * i, 1.3 * i) for i, L in enumerate(lengths, 1)},
        "R[head]@20": {L: cell(1.1 * i, 0.8 * i) for i, L in enumerate(lengths, 1)},
        "R[radius+G]@20": {L: cell(1.0 * i, 0.7 * i) for i, L in enumerate(lengths, 1)},
        "R[radius+G]@10": {L: cell(1.6 * i, 1.2 * i) for i, L in enumerate(lengths, 1)},
        "R[continuous]": {L: cell(0.9 * i, 0.6 * i) for i, L in enumerate(lengths, 1)},
        "WPM-m@20": {L: cell(1.05 * i, 0.75 * i, 0.0) for i, L in enumerate(lengths, 1)},
        "WPM-m@10": {L: cell(1.7 * i, 1.3 * i, 0.0) for i, L in enumerate(lengths, 1)},
        "R@20": {L: cell(1.0 * i, 0.7 * i) for i, L in enumerate(lengths, 1)},
        "R": {L: cell(1.0 * i, 0.7 * i) for i, L in enumerate(lengths, 1)},
    }
    return {
        "overall": overall,
        "chosen_m": 20,
        "recipe": "radius+G",
        "n_seeds": 2,
        "evaluated_on": "test seconds after the first 20 s of each drive",
    }


def test_rows_are_eval_json_cells_of_the_headline_models_at_the_chosen_m(ev):
    rows = comparison_rows(ev)
    models = list(dict.fromkeys(r["model"] for r in rows))
    assert models == ["WPM", "WPM-ref", "G", "S", "R", "WPM-m@20", "R[head]@20", "R[continuous]"]
    g180 = next(r for r in rows if r["model"] == "G" and r["outage_s"] == 180)
    g = ev["overall"]["G"]["180s"]
    assert (g180["crse_mean"], g180["cte_mean"]) == (g["crse_mean"], g["cte_mean"])
    assert {r["outage_s"] for r in rows} == {30, 180}


def test_markdown_and_html_show_every_model_and_number(ev):
    md = comparison_markdown(ev)
    assert "| model | CRSE 30 s | CTE 30 s | CRSE 180 s | CTE 180 s |" in md
    assert "| R-WhONet (radius+G, m = 20 s) | 1.00 ± 0.10 | 0.70 ± 0.10 | 2.00 ± 0.10 |" in md
    assert "| WPM (wheel odometry) | 2.00 | 1.50 | 4.00 | 3.00 |" in md  # no ± for the WPM
    page = comparison_html(ev)
    assert page.count("<svg") == 2 and "S-WhONet (target car)" in page and "3.80" in page
    assert "R[head]@20 (recipe)" in page and "R[radius+G]@10" not in page


def test_headline_metrics_have_names_mlflow_accepts(ev):
    mlflow = pytest.importorskip("mlflow")
    from mlflow.utils.validation import _validate_metric_name

    metrics = headline_metrics(ev)
    assert metrics["R/crse/180s/mean"] == 2.0 and metrics["WPM-m/cte/30s/mean"] == 0.75
    assert metrics["R-continuous/crse/30s/ci95"] == 0.1
    assert not any(k.startswith(("WPM-ref", "R[")) for k in metrics)
    models = ("WPM", "G", "S", "R", "WPM-m", "R-continuous")
    assert view_metrics(ev) == [f"{m}/{q}/180s/mean" for q in ("crse", "cte") for m in models]
    for name in metrics:
        _validate_metric_name(name)
    assert mlflow


def test_the_caption_names_the_drives_left_out_where_there_are_any(ev):
    assert "left out" not in comparison_markdown(ev)
    ev["left_out"] = [{"drive": "C-X1", "role": "target_test", "stage": "validate"}]
    said = "1 drive(s) refused and left out (data.refused_drives: leave_out), not in these "
    assert said in comparison_markdown(ev) and "C-X1 (target_test)" in comparison_markdown(ev)
    assert said in comparison_html(ev)
