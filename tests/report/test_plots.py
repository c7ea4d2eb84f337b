"""The DVC plots' tables: one per file dvc.yaml draws, with the columns it names."""

import numpy as np
import pytest
import yaml

from rwhonet import paths
from rwhonet.report.plots import plot_frames
from stages.conftest import evaluated_once

__all__ = ["evaluated_once"]


def test_every_outage_gets_its_curves_and_g_s_error_grows_by_its_offset(evaluated_once):
    params, ev = evaluated_once
    out = plot_frames(ev, params)
    assert set(out) == {
        *(f"{m}_evolution_{L}s.csv" for m in ("crse", "cte") for L in (30, 60)),
        "m_grid.csv",
        "crse_over_time.csv",
    }
    for L in (30, 60):
        crse = out[f"crse_evolution_{L}s.csv"]
        assert list(crse.columns) == ["second", "WPM", "G", "S", "R"]
        assert crse["second"].tolist() == list(range(1, L + 1))
        # G is 0.1 m short every second, the same sign: its error adds up, 0.1 m a second
        np.testing.assert_allclose(crse["G"], 0.1 * crse["second"], rtol=1e-9)
        assert (crse["R"] == 0).all() and (crse["S"] == 0).all()


def test_the_m_grid_reads_the_longest_outage_s_mean_crse(evaluated_once):
    params, ev = evaluated_once
    grid = plot_frames(ev, params)["m_grid.csv"]
    assert grid["m"].tolist() == [10, 20]
    s = ev.summary
    row = s[(s["model"] == "WPM-m@20") & (s["drive"] == "all") & (s["outage_s"] == 60)]
    assert grid["WPM-m"].iloc[1] == pytest.approx(row[row["role"] == "target_test"]["crse_mean"])
    assert grid["G"].nunique() == 1 and grid["G"].iloc[0] == pytest.approx(6.0)  # 60 s x 0.1 m


def test_over_time_columns_drop_the_chosen_m_so_they_match_dvc_yaml(evaluated_once):
    params, ev = evaluated_once
    columns = set(plot_frames(ev, params)["crse_over_time.csv"].columns) - {"from_min"}
    assert not any("@" in c for c in columns)
    plots = yaml.safe_load((paths.ROOT / "dvc.yaml").read_text())["plots"]
    file = "reports/plots/crse_over_time.csv"
    named = next(y[file] for y in (next(iter(p.values()))["y"] for p in plots) if file in y)
    # every column dvc.yaml draws, but the recipe this evaluation does not have
    assert set(named) - {"R[continuous_shrink]"} <= columns
