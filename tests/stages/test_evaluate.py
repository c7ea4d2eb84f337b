"""The evaluate stage's records: R-WhONet's Choice is passed as a value, params stay the user's."""

import json

from rwhonet.io import write_json
from rwhonet.stages.evaluate import (
    evaluation_record,
    note_left_out,
    provenance_line,
    seeds_label,
    write_outputs,
)


def test_the_parent_run_logs_what_the_user_set_and_the_choice_apart(evaluated):
    params, ev = evaluated
    assert (ev.choice.recipe, ev.choice.m, ev.choice.chosen_by) == ("radius+G", 20, "fallback")
    rec = evaluation_record(params, ev, [])
    assert rec.params["adapt.recipe"] == "auto" and rec.params["adapt.chosen_m"] == "auto"
    assert rec.params["chosen.recipe"] == "radius+G" and rec.params["chosen.m"] == 20
    assert rec.params["chosen.by"] == "fallback"
    assert "R-WhONet = recipe `radius+G` at m = 20 s" in provenance_line(params, ev.choice)
    assert (ev.eval_json["recipe"], ev.eval_json["chosen_m"]) == ("radius+G", 20)
    assert ev.eval_json["selection"]["params"]["recipe"] == "auto"


def test_run_names_count_the_seeds_and_take_no_mean_of_one():
    assert seeds_label([1, 2, 3], "mean of ") == "mean of 3 seeds"
    assert seeds_label([42], "mean of ") == "1 seed" and seeds_label([7, 8]) == "2 seeds"


def test_drives_left_out_are_in_eval_json_above_the_tables_and_in_the_parent_run(
    evaluated, tmp_path
):
    params, ev = evaluated
    samples = tmp_path / "samples"
    problem = {"file": "raw/t/C-X1.csv", "row": 3, "column": "Lat", "expected": "a", "found": "b"}
    left = [
        {
            "drive": "C-X1",
            "role": "target_test",
            "vehicle": "target",
            "source_file": "raw/t/C-X1.csv",
            "stage": "validate",
            "problems": [problem | {"fix": None}],
        }
    ]
    write_json(samples / "manifest.json", {"segments": [], "left_out": left})
    assert note_left_out(ev, samples) == left
    assert evaluation_record(params, ev, []).params["data.drives_left_out"] == 1
    out = {name: tmp_path / name for name in ("pred", "plots", "tables.md", "eval.json")}
    write_outputs(
        params,
        ev,
        eval_path=out["eval.json"],
        tables_path=out["tables.md"],
        predictions_dir=out["pred"],
        plots_dir=out["plots"],
        provenance=provenance_line(params, ev.choice, left),
    )
    assert json.loads(out["eval.json"].read_text())["left_out"] == left
    assert "**1 drive(s) refused and left out**" in out["tables.md"].read_text()


def test_without_drives_left_out_nothing_is_added(evaluated, tmp_path):
    params, ev = evaluated
    write_json(tmp_path / "manifest.json", {"segments": []})
    assert note_left_out(ev, tmp_path) == [] and "left_out" not in ev.eval_json
    assert "data.drives_left_out" not in evaluation_record(params, ev, []).params
