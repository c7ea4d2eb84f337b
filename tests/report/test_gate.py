"""The CI gate fails on a worse mean CRSE or CTE and passes on an equal or better one."""

import copy
import json

import pytest

from rwhonet.report.gate import compare, main, render

BASE = {
    "overall": {
        "WPM": {
            "30s": {"crse_mean": 8.0, "cte_mean": 3.0},
            "180s": {"crse_mean": 45.0, "cte_mean": 9.0},
        },
        "G": {
            "30s": {"crse_mean": 2.0, "cte_mean": 1.0},
            "180s": {"crse_mean": 10.0, "cte_mean": 5.0},
        },
        "S": {
            "30s": {"crse_mean": 1.5, "cte_mean": 0.5},
            "180s": {"crse_mean": 8.0, "cte_mean": 1.0},
        },
        "R": {
            "30s": {"crse_mean": 1.6, "cte_mean": 0.4},
            "180s": {"crse_mean": 8.5, "cte_mean": 1.2},
        },
        "R@10": {"30s": {"crse_mean": 99.0, "cte_mean": 0.4}},
    }
}


def _run(tmp_path, now, rel_tol=0.1, abs_tol=0.0, base=None):
    e, b = tmp_path / "eval.json", tmp_path / "base.json"
    e.write_text(json.dumps(now))
    b.write_text(json.dumps(BASE if base is None else base))
    return main(
        [
            "--eval",
            str(e),
            "--baseline",
            str(b),
            "--rel-tol",
            str(rel_tol),
            "--abs-tol",
            str(abs_tol),
        ]
    )


def test_equal_passes(tmp_path, capsys):
    assert _run(tmp_path, BASE) == 0
    assert "PASS" in capsys.readouterr().out


def test_better_passes_and_says_so(tmp_path, capsys):
    now = copy.deepcopy(BASE)
    now["overall"]["R"]["180s"]["crse_mean"] = 5.0
    assert _run(tmp_path, now) == 0
    out = capsys.readouterr().out
    line = next(
        ln for ln in out.splitlines() if ln.startswith("R ") and "180s" in ln and "CRSE" in ln
    )
    assert "better" in line and "ok" in line
    assert "1 better" in out


def test_within_tolerance_passes(tmp_path):
    now = copy.deepcopy(BASE)
    now["overall"]["G"]["30s"]["crse_mean"] = 2.0 * 1.09
    assert _run(tmp_path, now) == 0


@pytest.mark.parametrize(
    "model,outage,metric",
    [("R", "180s", "crse"), ("WPM", "30s", "crse"), ("S", "30s", "cte"), ("R@10", "30s", "crse")],
)
def test_worse_fails_with_table(tmp_path, capsys, model, outage, metric):
    now = copy.deepcopy(BASE)
    now["overall"][model][outage][f"{metric}_mean"] *= 1.25
    assert _run(tmp_path, now) == 1
    out = capsys.readouterr()
    line = next(
        ln for ln in out.out.splitlines() if ln.split()[:3] == [model, outage, metric.upper()]
    )
    assert "REGRESSION" in line and "+25.0%" in line and "worse" in line
    assert "FAIL" in out.err


def test_the_absolute_tolerance_spares_near_zero_cte(tmp_path):
    now = copy.deepcopy(BASE)
    now["overall"]["R"]["30s"]["cte_mean"] = 0.4 + 0.3  # +75 %, but 0.3 m
    assert _run(tmp_path, now) == 1
    assert _run(tmp_path, now, abs_tol=0.5) == 0


def test_missing_model_fails(tmp_path):
    now = copy.deepcopy(BASE)
    del now["overall"]["S"]
    assert _run(tmp_path, now) == 1


def test_every_model_and_both_metrics_are_compared():
    rows = compare(BASE, BASE)
    assert {r.model for r in rows} == {"WPM", "G", "S", "R", "R@10"}
    assert {r.metric for r in rows} == {"crse", "cte"}
    assert len(rows) == 2 * (4 * 2 + 1)
    assert "REGRESSION" not in render(rows, 0.1, 0.0)


def _with_filter(base):
    """An eval.json of the navigation filter: position per model, the controls' key."""
    out = copy.deepcopy(base)
    out["position"] = {
        "WPM": {"30s": {"pos_mean": 9.0}, "180s": {"pos_mean": 60.0}},
        "R": {"30s": {"pos_mean": 8.0}, "180s": {"pos_mean": 40.0}},
    }
    out["position_controls"] = {"control": "fused", "rows": {}}
    return out


def test_the_filter_position_after_the_longest_outage_is_gated(tmp_path, capsys):
    base = _with_filter(BASE)
    rows = compare(base, base)
    assert {(r.model, r.outage) for r in rows if r.metric == "pos"} == {
        ("WPM", "180s"),
        ("R", "180s"),
    }
    assert _run(tmp_path, base, base=base) == 0
    capsys.readouterr()
    worse = copy.deepcopy(base)
    worse["position"]["R"]["180s"]["pos_mean"] = 40.0 * 1.25
    assert _run(tmp_path, worse, base=base) == 1
    line = next(
        ln for ln in capsys.readouterr().out.splitlines() if ln.split()[:3] == ["R", "180s", "POS"]
    )
    assert "REGRESSION" in line and "+25.0%" in line
    gone = copy.deepcopy(base)
    del gone["position"]["WPM"]
    assert _run(tmp_path, gone, base=base) == 1  # a model's position missing fails


def test_a_baseline_from_before_the_filter_gates_crse_and_cte_only(tmp_path, capsys):
    old = copy.deepcopy(BASE)
    # the earlier dead reckoning's block: another quantity under the same key
    old["position"] = {"R": {"180s": {"pos_mean": 400.0}}}
    assert not [r for r in compare(_with_filter(BASE), old) if r.metric == "pos"]
    assert _run(tmp_path, _with_filter(BASE), base=old) == 0
    assert "predates the navigation filter" in capsys.readouterr().out
