"""The CI gate fails on a worse mean CRSE and passes on an equal or better one."""

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


def _run(tmp_path, now, rel_tol=0.1):
    e, b = tmp_path / "eval.json", tmp_path / "base.json"
    e.write_text(json.dumps(now))
    b.write_text(json.dumps(BASE))
    return main(["--eval", str(e), "--baseline", str(b), "--rel-tol", str(rel_tol)])


def test_equal_passes(tmp_path, capsys):
    assert _run(tmp_path, BASE) == 0
    assert "PASS" in capsys.readouterr().out


def test_better_passes(tmp_path):
    now = copy.deepcopy(BASE)
    now["overall"]["R"]["180s"]["crse_mean"] = 5.0
    assert _run(tmp_path, now) == 0


def test_within_tolerance_passes(tmp_path):
    now = copy.deepcopy(BASE)
    now["overall"]["G"]["30s"]["crse_mean"] = 2.0 * 1.09
    assert _run(tmp_path, now) == 0


@pytest.mark.parametrize("model,outage", [("R", "180s"), ("WPM", "30s"), ("S", "30s")])
def test_worse_fails_with_table(tmp_path, capsys, model, outage):
    now = copy.deepcopy(BASE)
    now["overall"][model][outage]["crse_mean"] *= 1.25
    assert _run(tmp_path, now) == 1
    out = capsys.readouterr()
    line = next(ln for ln in out.out.splitlines() if ln.startswith(model) and outage in ln)
    assert "REGRESSION" in line and "+25.0%" in line
    assert "FAIL" in out.err


def test_missing_model_fails(tmp_path):
    now = copy.deepcopy(BASE)
    del now["overall"]["S"]
    assert _run(tmp_path, now) == 1


def test_only_gated_models_compared():
    rows = compare(BASE, BASE)
    assert {r.model for r in rows} == {"WPM", "G", "S", "R"}
    assert len(rows) == 8
    assert "REGRESSION" not in render(rows, 0.1)
