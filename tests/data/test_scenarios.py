"""Scenario sidecars -> the per-row scenario column."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rwhonet.data.scenarios import (
    ScenarioInterval,
    read_scenarios,
    scenario_codes,
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


def _plain_union(t, intervals):
    """Per row, the sorted tags of the intervals covering it: the definition, row by row."""
    return [
        ";".join(sorted({iv.tag for iv in intervals if iv.start_s <= ti < iv.end_s}))
        for ti in t.tolist()
    ]


@pytest.mark.parametrize("n_tags", [1, 5, 62, 63, 140])  # 63+: the packed-bytes path
@pytest.mark.parametrize("order", ["sorted", "shuffled", "with_nan"])
def test_codes_give_the_plain_per_row_union(n_tags, order):
    rng = np.random.default_rng(n_tags)
    t = np.round(np.sort(rng.uniform(0.0, 100.0, 400)), 1)  # ties on a 0.1 s grid
    if order == "shuffled":
        t = rng.permutation(t)
    elif order == "with_nan":
        t[[3, 200]] = np.nan  # no interval covers NaN; times are not sorted any more
    starts = rng.uniform(-5.0, 100.0, 3 * n_tags)
    intervals = [
        ScenarioInterval(s, s + d, f"tag{k % n_tags:03d}")  # tags overlap themselves too
        for k, (s, d) in enumerate(zip(starts, rng.uniform(0.1, 20.0, starts.size), strict=True))
    ]
    intervals.append(ScenarioInterval(float(t[10]), float(t[20]), "edge"))  # ends on a row
    labels, codes = scenario_codes(t, intervals)
    assert codes.dtype == np.int64 and codes.shape == t.shape
    assert len(set(labels.tolist())) == len(labels)  # each tag set labelled once
    assert labels[codes].tolist() == _plain_union(t, intervals)
    assert scenario_column(t, intervals).tolist() == _plain_union(t, intervals)
