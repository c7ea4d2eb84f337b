"""The evaluate stage's records: R-WhONet's Choice is passed as a value, params stay the user's."""

from rwhonet.stages.evaluate import evaluation_record, provenance_line, seeds_label


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
