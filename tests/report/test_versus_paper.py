"""The comparison renders ours next to the paper's from a hand-made eval.json."""

from __future__ import annotations

import json

import pytest

from rwhonet.report import paper
from rwhonet.report.versus_paper import comparison_markdown, main, paper_drive


def _cell(crse: float, cte: float, ci: float = 0.0) -> dict:
    return {"crse_mean": crse, "crse_ci95": ci, "cte_mean": cte, "cte_ci95": ci}


EVAL = {
    "chosen_m": 50,
    "overall": {
        "WPM": {"30s": _cell(8.0, 3.0)},
        "G": {"30s": _cell(2.0, 1.0, 0.1)},
        "S": {"30s": _cell(1.6, 0.8, 0.2)},
        "R": {"30s": _cell(1.0, 0.5, 0.05), "180s": _cell(6.0, 2.0, 0.3)},
        "R@10": {"180s": _cell(12.0, 4.0)},
        "R@50": {"180s": _cell(6.0, 2.0)},
    },
    "per_drive": {
        "V-Charlie3": {
            "R": {"30s": _cell(1.25, 0.5, 0.01)},
            "R@10": {"180s": _cell(9.0, 3.0)},
            "R@50": {"180s": _cell(6.0, 2.0)},
        },
        "V-Echo1": {"G": {"30s": _cell(1.5, 0.7, 0.2)}},
    },
}


def _rows(md: str, caption_start: str) -> list[list[str]]:
    """The body rows of the table whose bold caption starts with ``caption_start``."""
    lines = md.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"**{caption_start}"))
    rows = []
    for line in lines[start + 4 :]:  # caption, blank, head, rule
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return rows


def _head(md: str, caption_start: str) -> list[str]:
    lines = md.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"**{caption_start}"))
    return [c.strip() for c in lines[start + 2].strip("|").split("|")]


@pytest.fixture(scope="module")
def md() -> str:
    return comparison_markdown(EVAL)


def test_drive_names_map_to_the_paper():
    assert paper_drive("V-Charlie3") == "Charlie 3"
    assert paper_drive("V-Delta2") == "Delta 2"
    assert paper_drive("Charlie 3") == "Charlie 3"
    assert paper_drive("V-S1-extra") == "V-S1-extra"


def test_overall_means_ours_next_to_pooled_paper(md):
    rows = {(r[0], r[1]): r[2:] for r in _rows(md, "Overall mean")}
    # Paper, 30 s, R-WhONet CRSE: (45·1.34 + 22·1.89 + 16·1.22 + 38·1.53) / 121 = 1.4838.
    assert rows[("30 s", "R-WhONet")] == ["1.00 ± 0.05", "1.48", "0.50 ± 0.05", "0.59"]
    assert rows[("30 s", "WPM")][1] == f"{paper.pooled_mean('crse', 30, 'WPM'):.2f}"
    # Outages and models eval.json lacks: a dash on our side, the paper's still shown.
    assert rows[("60 s", "G-WhONet")][0] == "–"
    assert rows[("60 s", "G-WhONet")][1] == f"{paper.pooled_mean('crse', 60, 'G'):.2f}"
    assert len(rows) == len(paper.OUTAGES_S) * 4


def test_ratios_of_overall_means(md):
    head = _head(md, "Ratios")
    rows = {r[0]: dict(zip(head[1:], r[1:], strict=True)) for r in _rows(md, "Ratios")}
    assert rows["30 s"]["R/G ours"] == "0.50"
    assert rows["30 s"]["R/S ours"] == "0.62"
    assert rows["30 s"]["G/WPM ours"] == "0.25"
    expected = paper.pooled_mean("crse", 30, "R") / paper.pooled_mean("crse", 30, "G")
    assert rows["30 s"]["R/G paper"] == f"{expected:.2f}"
    assert rows["180 s"]["R/G ours"] == "–"


def test_table2_as_ratios_to_the_chosen_m(md):
    head = _head(md, "Table 2")
    rows = {r[0]: dict(zip(head[1:], r[1:], strict=True)) for r in _rows(md, "Table 2")}
    assert [int(m) for m in rows] == list(paper.M_GRID_S)
    assert rows["10"]["Charlie 3 ours"] == "1.50"
    assert rows["10"]["Charlie 3 paper"] == f"{10.1 / 7.8:.2f}"
    assert rows["50"]["Delta 2 paper"] == "1.00"
    assert rows["10"]["Delta 2 ours"] == "–"
    assert rows["10"]["All ours"] == "2.00"
    pooled = paper.table2_pooled_mean(10) / paper.table2_pooled_mean(50)
    assert rows["10"]["All paper"] == f"{pooled:.2f}"
    # A drive only we have gets a column with no paper value.
    assert rows["10"]["Echo 1 paper"] == "–"


def test_per_drive_means(md):
    head = _head(md, "Mean CRSE per drive")
    assert head[2:6] == ["Charlie 3 ours", "Charlie 3 paper", "Charlie 4 ours", "Charlie 4 paper"]
    assert head[-2:] == ["Echo 1 ours", "Echo 1 paper"]
    rows = {
        (r[0], r[1]): dict(zip(head[2:], r[2:], strict=True))
        for r in _rows(md, "Mean CRSE per drive")
    }
    assert rows[("30 s", "R-WhONet")]["Charlie 3 ours"] == "1.25 ± 0.01"
    assert rows[("30 s", "R-WhONet")]["Charlie 3 paper"] == "1.34"
    assert rows[("30 s", "G-WhONet")]["Echo 1 ours"] == "1.50 ± 0.20"
    assert rows[("30 s", "G-WhONet")]["Echo 1 paper"] == "–"
    assert rows[("180 s", "S-WhONet")]["Delta 3 paper"] == "7.38"


def test_output_is_tables_captions_and_one_formula_line(md):
    lines = [line for line in md.splitlines() if line]
    assert lines[0].startswith("Paper overall: μ_all = Σ_d N_d·μ_d / Σ_d N_d")
    for line in lines[1:]:
        assert line.startswith(("|", "**")), line
    assert sum(line.startswith("**") for line in lines) == 4


def test_empty_eval_json_renders_dashes():
    md = comparison_markdown({})
    rows = _rows(md, "Overall mean")
    assert all(r[2] == "–" and r[4] == "–" for r in rows)


def test_cli_prints_the_comparison(tmp_path, capsys):
    path = tmp_path / "eval.json"
    path.write_text(json.dumps(EVAL), encoding="utf-8")
    assert main([str(path)]) == 0
    assert capsys.readouterr().out == comparison_markdown(EVAL)


def test_cli_names_a_missing_file(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main([str(tmp_path / "nope.json")])
    assert e.value.code == 2
    assert "nope.json: no such file" in capsys.readouterr().err


def test_r_is_the_paper_recipe_at_50_whatever_params_chose():
    from rwhonet.report.versus_paper import as_paper_recipe

    cell = {"180s": {"crse_mean": 6.0, "crse_ci95": 0.1}}
    other = {"180s": {"crse_mean": 9.0, "crse_ci95": 0.1}}
    ev = {
        "overall": {"R": other, "R@50": other, "R[paper]@50": cell, "R[paper]@20": other},
        "per_drive": {"V-Delta3": {"R": other, "R[paper]@50": cell}},
    }
    got = as_paper_recipe({**ev, "recipe": "head", "chosen_m": 70})
    assert (got["recipe"], got["chosen_m"]) == ("paper", 50)  # Table 2's ratios are to m = 50
    assert got["overall"]["R"] is cell and got["overall"]["R@50"] is cell
    assert got["overall"]["R@20"] is other
    assert got["per_drive"]["V-Delta3"]["R"] is cell
    assert ev["overall"]["R"] is other  # the input is left alone
    assert as_paper_recipe({"overall": {"R": other}, "per_drive": {}})["overall"]["R"] is other
