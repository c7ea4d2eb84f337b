"""CRSE / CTE per outage window (paper Eqs. 16-19): known values and properties."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rwhonet.errors import InputError
from rwhonet.evaluation.scoring import summarise, window_evolution, window_metrics
from rwhonet.evaluation.windows import window_starts


def test_hand_computed_windows_and_dropped_remainder() -> None:
    e = [1.0, -2.0, 3.0, 4.0, -5.0, 6.0, 7.0]
    d = [10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0]
    w = window_metrics(e, d, np.zeros(7), 3)
    assert list(w["start"]) == [0, 3]  # the 7th second is a remainder: dropped
    assert list(w["window"]) == [0, 1]
    assert list(w["crse_m"]) == [6.0, 15.0]  # Σ|e|
    assert list(w["cte_m"]) == [2.0, 5.0]  # |Σe|, absolute as in the paper's tables
    assert list(w["distance_m"]) == [33.0, 42.0]


def test_windows_restart_at_every_group() -> None:
    g = np.array(["a", "a", "a", "a", "a", "b", "b", "b"])
    e = np.arange(8.0)
    w = window_metrics(e, np.ones(8), g, 2)
    assert list(w["start"]) == [0, 2, 5]  # a: 0-1, 2-3 (4 dropped); b: 5-6 (7 dropped)
    assert list(w["group"]) == ["a", "a", "b"]
    assert list(w["crse_m"]) == [1.0, 5.0, 11.0]


@pytest.mark.parametrize("seed", range(5))
def test_properties_on_random_drives(seed: int) -> None:
    rng = np.random.default_rng(seed)
    lengths = rng.integers(0, 400, size=12)
    g = np.repeat(np.arange(12), lengths)
    e = rng.normal(0.0, 2.0, len(g))
    d = rng.uniform(0.0, 30.0, len(g))
    L = int(rng.integers(1, 90))
    w = window_metrics(e, d, g, L)
    assert len(w) == (lengths // L).sum()  # remainder of every group dropped
    idx = w["start"].to_numpy()[:, None] + np.arange(L)
    assert (g[idx] == w["group"].to_numpy()[:, None]).all()  # never across groups
    assert (w["crse_m"] >= w["cte_m"] - 1e-12).all()  # triangle inequality
    if len(w):
        assert (w["crse_m"] > w["cte_m"]).any()  # mixed signs: the two really differ
    covered = np.zeros(len(g), dtype=int)
    np.add.at(covered, idx.ravel(), 1)
    assert covered.max(initial=0) <= 1  # non-overlapping
    # Reference: the per-window sums computed one window at a time.
    for i in rng.choice(len(w), size=min(5, len(w)), replace=False):
        sl = slice(w["start"].iat[i], w["start"].iat[i] + L)
        assert w["crse_m"].iat[i] == pytest.approx(np.abs(e[sl]).sum())
        assert w["cte_m"].iat[i] == pytest.approx(abs(e[sl].sum()))
        assert w["distance_m"].iat[i] == pytest.approx(d[sl].sum())


def test_crse_equals_cte_when_errors_keep_one_sign() -> None:
    e = -np.linspace(0.1, 3.0, 60)
    w = window_metrics(e, np.ones(60), np.zeros(60), 30)
    np.testing.assert_allclose(w["crse_m"], w["cte_m"])


def test_summary_uses_population_std() -> None:
    w = window_metrics([1.0, -2.0, 3.0, 4.0, -5.0, 6.0], [1.0] * 6, [0] * 6, 3)
    s = summarise(w)
    assert s["n_windows"] == 2
    assert (s["crse_m_max"], s["crse_m_min"], s["crse_m_mean"]) == (15.0, 6.0, 10.5)
    assert s["crse_m_std"] == pytest.approx(4.5)  # ddof=0; ddof=1 would give 6.36
    assert (s["cte_m_mean"], s["cte_m_std"]) == (3.5, 1.5)
    assert (s["distance_m_mean"], s["distance_m_std"]) == (3.0, 0.0)


def test_summary_without_windows() -> None:
    s = summarise(window_metrics([1.0, 2.0], [1.0, 1.0], [0, 0], 30))
    assert s["n_windows"] == 0
    assert s["crse_m_mean"] is None and s["distance_m_std"] is None


def test_evolution_builds_up_to_the_window_values() -> None:
    rng = np.random.default_rng(1)
    g = np.repeat([0, 1], [70, 50])
    e = rng.normal(size=len(g))
    L = 20
    ev = window_evolution(e, g, L)
    w = window_metrics(e, np.ones(len(g)), g, L)
    assert len(ev) == len(w) * L
    assert list(ev["second"].iloc[:L]) == list(range(1, L + 1))
    last = ev[ev["second"] == L].reset_index(drop=True)
    np.testing.assert_allclose(last["crse_m"], w["crse_m"])
    np.testing.assert_allclose(last["cte_signed_m"].abs(), w["cte_m"])
    assert (ev.groupby("window")["crse_m"].diff().dropna() >= 0).all()  # cumulative |e|
    first = ev[ev["second"] == 1].reset_index(drop=True)
    np.testing.assert_allclose(first["cte_signed_m"], e[w["start"]])  # signed


def test_bad_inputs_raise_input_error() -> None:
    with pytest.raises(InputError) as err:
        window_metrics([1.0, np.nan, 2.0], [1.0, 1.0, np.inf], [0, 0, 0], 2, source="V-Vw12")
    assert [(p.row, p.column) for p in err.value.problems] == [(2, "e_m"), (3, "disp_gnss_m")]
    assert err.value.problems[0].file == "V-Vw12"
    with pytest.raises(InputError, match="disp_gnss_m"):
        window_metrics([1.0, 2.0], [1.0], [0, 0], 1)
    with pytest.raises(InputError) as err:
        window_metrics([1.0] * 5, [1.0] * 5, ["a", "a", "b", "a", "a"], 2)
    assert err.value.problems[0].row == 4  # where group "a" starts again
    with pytest.raises(ValueError):
        window_starts([0, 0], 0)
    with pytest.raises(ValueError):
        window_starts([0, 0], 1.5)
    for stride in (0, 1.5, True):
        with pytest.raises(ValueError, match="stride_s"):
            window_starts([0, 0], 1, stride)


def test_overlapping_windows_start_every_stride_within_each_group() -> None:
    g = np.repeat(["a", "b", "c"], [10, 5, 3])
    start, run = window_starts(g, 4, 2)
    # a: 0, 2, 4, 6 (8 would end past the group); b: 10 (12 would too); c: too short
    assert list(start) == [0, 2, 4, 6, 10] and list(run) == [0, 0, 0, 0, 1]
    for L in (1, 3, 4):  # the stride of the window's own length: the consecutive windows
        np.testing.assert_array_equal(window_starts(g, L, L)[0], window_starts(g, L)[0])


def test_accepts_pandas_columns_and_empty_input() -> None:
    df = pd.DataFrame({"e": [1.0, 2.0, 3.0, 4.0], "d": 1.0, "segment": ["s1", "s1", "s2", "s2"]})
    w = window_metrics(df["e"], df["d"], df["segment"], 2)
    assert list(w["group"]) == ["s1", "s2"]
    assert len(window_metrics([], [], [], 30)) == 0
