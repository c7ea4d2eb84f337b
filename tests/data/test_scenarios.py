"""Scenario sidecars -> the per-row scenario column."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data.scenarios import (
    ScenarioInterval,
    read_scenarios,
    scenario_column,
    sidecar_path,
)
from rwhonet.errors import InputError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "iovnbd" / "V-T1.scenarios.json"


def test_sidecar_path_is_next_to_the_drive():
    assert sidecar_path(Path("raw/V-S1.csv")) == Path("raw/V-S1.scenarios.json")
    assert sidecar_path(Path("raw/a.b.csv")) == Path("raw/a.b.scenarios.json")


def test_tags_half_open_sorted_and_joined():
    intervals = read_scenarios(FIXTURE)  # roundabout [.3, .6), wet_road [.5, 1.0)
    t = np.round(45000.0 + 0.1 * np.arange(12), 6)
    tags = scenario_column(t, intervals)
    assert list(tags) == [
        "",
        "",
        "",
        "roundabout",
        "roundabout",
        "roundabout;wet_road",
        "wet_road",
        "wet_road",
        "wet_road",
        "wet_road",
        "",  # 45001.0: end is exclusive
        "",
    ]


def test_fixed_order_does_not_depend_on_file_order():
    a = [ScenarioInterval(0, 10, "z_tag"), ScenarioInterval(0, 10, "a_tag")]
    assert scenario_column(np.array([5.0]), a)[0] == "a_tag;z_tag"
    assert scenario_column(np.array([5.0]), a[::-1])[0] == "a_tag;z_tag"


def test_no_intervals_gives_empty_tags():
    assert list(scenario_column(np.arange(3.0), [])) == ["", "", ""]


def test_bad_sidecar_lists_every_problem(tmp_path):
    path = tmp_path / "V-S1.scenarios.json"
    path.write_text(
        json.dumps(
            {
                "intervals": [
                    {"start_s": 5, "end_s": 3, "tag": "roundabout"},
                    {"start_s": "x", "end_s": 9, "tag": "a;b"},
                ]
            }
        ),
        encoding="utf-8",
    )
    with pytest.raises(InputError) as err:
        read_scenarios(path)
    columns = {p.column for p in err.value.problems}
    assert columns == {"intervals[0].end_s", "intervals[1].start_s", "intervals[1].tag"}


def test_invalid_json(tmp_path):
    path = tmp_path / "V-S1.scenarios.json"
    path.write_text("{not json", encoding="utf-8")
    with pytest.raises(InputError, match="valid JSON"):
        read_scenarios(path)
