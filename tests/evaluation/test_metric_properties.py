"""Properties of the outage metrics and the seed intervals (hypothesis).

CRSE (sum of |e|) and CTE (|sum of e|) per outage window: CRSE >= CTE >= 0, the
CRSE of a sum of errors is at most the sum of their CRSEs, a window never spans
two groups, and the windows of groups laid end to end are the windows of each
group. The 95 % interval over seeds moves and scales with the values, is
symmetric, and narrows as more seeds agree.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rwhonet.evaluation.intervals import mean_ci95
from rwhonet.evaluation.scoring import window_metrics

PROPERTY = settings(max_examples=40, deadline=None, database=None)
error = st.floats(-20.0, 20.0, allow_nan=False)
outage = st.integers(1, 12)


@st.composite
def grouped_errors(draw, n_series: int = 1):
    """Group ids (contiguous runs) and ``n_series`` error series of the same length."""
    lengths = draw(st.lists(st.integers(0, 40), min_size=1, max_size=5))
    group = np.repeat(np.arange(len(lengths)), lengths)
    series = [
        np.asarray(draw(st.lists(error, min_size=group.size, max_size=group.size)))
        for _ in range(n_series)
    ]
    return group, series


@PROPERTY
@given(data=grouped_errors(), L=outage)
def test_crse_bounds_cte(data, L):
    group, (e,) = data
    w = window_metrics(e, np.ones(e.size), group, L)
    assert (w["cte_m"] >= 0).all()
    assert (w["crse_m"] >= w["cte_m"] - 1e-9).all()
    pd.testing.assert_frame_equal(window_metrics(-e, np.ones(e.size), group, L), w)


@PROPERTY
@given(data=grouped_errors(n_series=2), L=outage)
def test_crse_of_a_sum_is_at_most_the_sum_of_crses(data, L):
    group, (e1, e2) = data
    d = np.ones(e1.size)
    crse = [window_metrics(e, d, group, L)["crse_m"].to_numpy() for e in (e1, e2, e1 + e2)]
    assert (crse[2] <= crse[0] + crse[1] + 1e-9).all()


@PROPERTY
@given(data=grouped_errors(), L=outage)
def test_windows_never_cross_groups_and_drop_each_remainder(data, L):
    group, (e,) = data
    w = window_metrics(e, np.ones(e.size), group, L)
    idx = w["start"].to_numpy()[:, None] + np.arange(L)
    assert (group[idx] == w["group"].to_numpy()[:, None]).all()
    assert len(w) == sum(np.bincount(group) // L) if group.size else len(w) == 0


@PROPERTY
@given(a=grouped_errors(), b=grouped_errors(), L=outage)
def test_groups_laid_end_to_end_keep_their_windows(a, b, L):
    (ga, (ea,)), (gb, (eb,)) = a, b
    gb = gb + (ga.max() + 1 if ga.size else 0)  # b's groups after a's
    da, db = np.abs(ea) + 1.0, np.abs(eb) + 2.0
    wa = window_metrics(ea, da, ga, L)
    wb = window_metrics(eb, db, gb, L)
    both = window_metrics(np.r_[ea, eb], np.r_[da, db], np.r_[ga, gb], L)
    wb = wb.assign(window=wb["window"] + len(wa), start=wb["start"] + ea.size)
    expected = pd.concat([wa, wb], ignore_index=True)
    pd.testing.assert_frame_equal(both, expected, check_dtype=False)


values = st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=8)


@PROPERTY
@given(v=values, shift=st.floats(-1e3, 1e3), k=st.floats(0.01, 100.0))
def test_interval_moves_and_scales_with_the_values(v, shift, k):
    mean, half = mean_ci95(v)
    mean2, half2 = mean_ci95(shift + k * np.asarray(v))
    assert np.isclose(mean2, shift + k * mean, rtol=1e-9, atol=1e-6)
    assert np.isclose(half2, k * half, rtol=1e-9, atol=1e-6)


@PROPERTY
@given(v=values)
def test_interval_is_symmetric(v):
    mean, half = mean_ci95(v)
    mean_neg, half_neg = mean_ci95(-np.asarray(v))
    assert np.isclose(mean_neg, -mean) and np.isclose(half_neg, half)
    assert half >= 0


@PROPERTY
@given(v=values, repeat=st.integers(2, 4))
def test_interval_narrows_as_more_seeds_agree(v, repeat):
    assume(np.ptp(v) > 1e-6)
    _, half = mean_ci95(v)
    _, half_more = mean_ci95(np.tile(v, repeat))
    assert half_more < half
    assert mean_ci95(np.full(5, 3.5)) == (3.5, 0.0)
