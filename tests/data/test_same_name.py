"""Two columns of one name (a tool's export with a ``Time`` in s and a lap ``Time`` in min):
a column map takes the one whose header or row of units names the unit it declares, and
refuses a name it cannot tell apart saying how many columns carry it."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import column_matches, find_column, read_columnmap
from rwhonet.errors import InputError

SPEC = {
    "t": ("Time", "s"),
    "lat": ("Lat", "deg"),
    "lon": ("Lon", "deg"),
    "omega_fl": ("WS FL", "rad/s"),
    "omega_fr": ("WS FR", "rad/s"),
    "omega_rl": ("WS RL", "rad/s"),
    "omega_rr": ("WS RR", "rad/s"),
}


def _write(path, units: bool, n: int = 300) -> None:
    header = "Time,Lat,Lon,WS FL,WS FR,WS RL,WS RR,Time"
    lines = [header] + (["s,deg,deg,rad/s,rad/s,rad/s,rad/s,min"] if units else [])
    for i in range(n):
        t = 45000.0 + 0.1 * i
        lines.append(f"{t:.1f},{52.4 + 1e-5 * i:.7f},-1.5,50,50,50,50,{(t - 45000.0) / 60:.5f}")
    path.write_text("\n".join(lines) + "\n")


def _map(**changes: tuple[str, str]) -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(col, unit) for k, (col, unit) in (SPEC | changes).items()}


def test_the_unit_the_map_declares_tells_two_columns_of_one_name_apart(tmp_path):
    path = tmp_path / "motec.csv"
    _write(path, units=True)
    raw = read_columnmap(path, _map(), "motec")
    np.testing.assert_allclose(raw.columns[c.T_S][:3], [45000.0, 45000.1, 45000.2])
    assert raw.source_columns[c.T_S] == "Time (s)"  # the first, under its row of units


@pytest.mark.parametrize(("units", "declared"), [(False, "s"), (True, "ms")])
def test_two_columns_of_one_name_not_told_apart_are_refused_as_two(tmp_path, units, declared):
    path = tmp_path / "motec.csv"
    _write(path, units=units)
    with pytest.raises(InputError) as err:
        read_columnmap(path, _map(t=("Time", declared)), "motec")
    (problem,) = err.value.problems
    assert problem.column == "Time" and problem.found.startswith("2: ['Time")
    assert "data.column_maps.motec.t.unit" in problem.fix


def test_a_name_matches_its_own_columns_first():
    header = ["Time (s)", "Lat", "time_s", "Time (min)"]
    assert column_matches(header, "Lat") == [1]
    assert column_matches(header, "Time") == [0, 2, 3]  # by key: all three
    assert find_column(header, "Time", "min") == 3
    assert find_column(header, "Time", "s") is None  # two name s: not told apart
    assert find_column(header, "time_s") == 2  # its exact name
