"""The shrink recipes (rwhonet.models.adapt): a radius update sized by its evidence.

Known values of the shrinkage (τ → ∞: the plain refit, radius+G; τ → 0: G; a hand-computed
weight), its properties (more seconds, more weight), and the evidence measured on drives
whose answer is known.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.errors import InputError
from rwhonet.models.adapt import (
    SHRINK_RIDGE,
    AdaptData,
    ShrinkEvidence,
    continuous_predictions,
    evidence_terms,
    label_prediction,
    posterior_sd,
    prior_sd,
    radius_g,
    recalibrate,
    relative_scale,
    shrink,
    shrink_evidence,
    shrink_weight,
)
from rwhonet.models.loop import predict

from .test_adapt import R_SRC, constant_g, data_of


def evidence(prior: float, v_per_s: float = 0.01) -> ShrinkEvidence:
    """Evidence with V(k) = v_per_s · k on k = 1..200 and prior sd ``prior``."""
    ks = tuple(range(1, 201))
    return ShrinkEvidence("test", ("a", "b"), prior, ks, tuple(v_per_s * k for k in ks), (2,) * 200)


# --------------------------------------------------------------------------- the weight


def test_the_weight_of_known_values():
    # τ = 0.5 %, V = 0.25 m², D = 50 m: V / D² = 1e-4, τ² = 2.5e-5 -> w = 2.5e-5 / 1.25e-4
    assert shrink_weight(0.005, 0.25, 50.0) == pytest.approx(0.2, rel=1e-12)
    assert shrink_weight(0.01, 1.0, 100.0) == pytest.approx(0.5, rel=1e-12)
    assert shrink_weight(math.inf, 5.0, 10.0) == 1.0  # no prior: the refit
    assert shrink_weight(0.0, 5.0, 10.0) == 0.0  # a certain prior: G
    assert shrink_weight(0.01, 5.0, 0.0) == 0.0  # nothing refitted on: G
    assert shrink_weight(0.01, 0.0, 10.0) == 1.0  # noise-free seconds: the refit
    # posterior sd = √(τ² s² / (τ² + s²)) = √(w) · s
    assert posterior_sd(0.005, 0.25, 50.0) == pytest.approx(math.sqrt(0.2) * 0.01, rel=1e-12)
    assert posterior_sd(math.inf, 0.25, 50.0) == pytest.approx(0.01, rel=1e-12)
    assert posterior_sd(0.004, 0.25, 0.0) == 0.004  # no seconds: the prior


@settings(max_examples=200, deadline=None)
@given(
    tau=st.floats(1e-4, 0.2),
    v=st.floats(1e-4, 100.0),
    d=st.floats(1.0, 5000.0),
    more=st.floats(1.0, 10.0),
)
def test_the_weight_grows_with_distance_and_falls_with_noise(tau, v, d, more):
    w = shrink_weight(tau, v, d)
    assert 0.0 <= w <= 1.0
    assert shrink_weight(tau, v, d * more) >= w
    assert shrink_weight(tau, v * more, d) <= w
    assert shrink_weight(tau * more, v, d) >= w
    assert posterior_sd(tau, v, d) <= min(tau, math.sqrt(v) / d) * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(
    tau=st.floats(1e-4, 0.05),
    c=st.floats(1e-3, 1.0),
    speed=st.floats(2.0, 30.0),
    m=st.integers(1, 150),
)
def test_the_weight_grows_with_m(tau, c, speed, m):
    """Seconds whose errors add like V(k) = c k, over D = v k: more seconds, more weight."""
    ev = evidence(tau, c)
    assert ev.weight(m + 10, speed * (m + 10)) >= ev.weight(m, speed * m)


def test_v_interpolates_and_grows_like_k_outside_its_grid():
    ev = ShrinkEvidence("t", ("a", "b"), 0.01, (10, 20, 40), (1.0, 3.0, 4.0), (2, 2, 2))
    assert ev.sum_var(15) == pytest.approx(2.0)
    assert ev.sum_var(40) == 4.0
    assert ev.sum_var(80) == pytest.approx(8.0)  # beyond: independent stretches add
    assert ev.sum_var(5) == pytest.approx(0.5)  # below: proportional too (errs towards G)


def test_evidence_round_trips_and_a_malformed_one_is_refused():
    ev = evidence(0.004)
    assert ShrinkEvidence.from_dict(ev.to_dict(), "x") == ev
    bad = {**ev.to_dict(), "k_s": [3, 2] + list(ev.k_s[2:])}
    with pytest.raises(InputError, match="evidence is malformed"):
        ShrinkEvidence.from_dict(bad, "x")
    with pytest.raises(InputError, match="evidence is malformed"):
        ShrinkEvidence.from_dict({**ev.to_dict(), "prior_sd": -1}, "x")


def test_the_prior_is_the_offset_and_the_pooled_spread():
    own = np.array([0.01, 0.03])  # mean 0.02, sample variance 2e-4
    assert prior_sd(own) == pytest.approx(math.sqrt(0.02**2 + 2e-4))
    others = np.array([0.0, 0.04, -0.04])  # sum of squares about the mean: 3.2e-3
    pooled = (2e-4 + 3.2e-3) / (1 + 2)
    assert prior_sd(own, others) == pytest.approx(math.sqrt(0.02**2 + pooled))
    assert prior_sd(own, extra=0.01) == pytest.approx(math.sqrt(0.02**2 + 2e-4 + 1e-4))


# --------------------------------------------------------------------------- the recipe


def test_an_infinite_prior_is_radius_g_and_a_certain_one_is_g(g, linear_data):
    net, hp = g
    x, y = linear_data
    d = data_of(x[:40], y[:40], r_true=0.29 * 1.02)
    scored = data_of(x[40:90], y[40:90], r_true=0.29 * 1.02, seed=3)
    plain = radius_g(net, hp, d, min_speed_m_s=2.0)
    free = shrink(net, hp, d, evidence=evidence(math.inf), min_speed_m_s=2.0, source_radii=R_SRC)
    assert free.radii == plain.radii and free.info["shrink_weight"] == 1.0
    np.testing.assert_array_equal(
        label_prediction(free, scored, R_SRC), label_prediction(plain, scored, R_SRC)
    )
    sure = shrink(net, hp, d, evidence=evidence(0.0), min_speed_m_s=2.0, source_radii=R_SRC)
    assert sure.radii is None and sure.info["shrink_weight"] == 0.0
    np.testing.assert_array_equal(
        label_prediction(sure, scored, R_SRC), predict(net, scored.x).astype(np.float64)
    )


def test_the_radius_moves_the_hand_computed_share_of_the_way(g, linear_data):
    net, hp = g
    x, y = linear_data
    silent = constant_g(net, 0.0)  # G explains nothing: the refit is the GNSS ratio, +2 %
    d = data_of(x[:40], y[:40], r_true=0.29 * 1.02)
    ev = evidence(0.01, v_per_s=0.05)  # V(40) = 2 m²
    distance = float(d.disp_gnss_m.sum())  # every second moves: the refit rests on them all
    w = 1e-4 / (1e-4 + 2.0 / distance**2)
    r = shrink(silent, hp, d, evidence=ev, min_speed_m_s=2.0, source_radii=R_SRC)
    assert r.info["shrink_weight"] == pytest.approx(w, rel=1e-9)
    assert r.info["fit_distance_m"] == pytest.approx(distance, rel=1e-12)
    assert r.radii == pytest.approx((0.29 * (1 + 0.02 * w),) * 2, rel=1e-9)
    assert relative_scale(r.radii, R_SRC) == pytest.approx(0.02 * w, rel=1e-6)
    assert r.info["refit_scale"] == pytest.approx(0.02, rel=1e-6)
    # more seconds of the same car: more of the refit is kept
    longer = shrink(
        silent,
        hp,
        data_of(x[:160], y[:160], r_true=0.29 * 1.02),
        evidence=ev,
        min_speed_m_s=2.0,
        source_radii=R_SRC,
    )
    assert longer.info["shrink_weight"] > r.info["shrink_weight"]


def test_shrink_with_no_moving_second_is_g_and_needs_its_evidence(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    standing = AdaptData(x[:5], y[:5], np.zeros(5), np.zeros(5), np.zeros(5))
    r = shrink(net, hp, standing, evidence=evidence(0.01), min_speed_m_s=2.0, source_radii=R_SRC)
    assert r.radii is None and r.info["radius_refit"] is False
    d = data_of(x[:20], y[:20])
    with pytest.raises(ValueError, match="evidence"):
        recalibrate("shrink", net, hp, d, adapt=adapt_params, seed=1, min_speed_m_s=2.0)
    r = recalibrate(
        "shrink",
        net,
        hp,
        d,
        adapt=adapt_params,
        seed=1,
        min_speed_m_s=2.0,
        evidence=evidence(0.01),
        source_radii=R_SRC,
    )
    assert 0.0 < r.info["shrink_weight"] < 1.0


def test_a_prior_centred_off_g_moves_the_radius_from_there(g, linear_data):
    """A car of another tyre size (rwhonet recalibrate on a car the pipeline has no drives
    of): the prior's centre is that car's size; w = 0 gives the centre, w = 1 the refit."""
    net, hp = g
    x, y = linear_data
    silent = constant_g(net, 0.0)
    d = data_of(x[:40], y[:40], r_true=0.29 * 1.25)  # a car with 25 % larger tyres
    centre = (0.29 * 1.2, 0.29 * 1.2)  # its nominal size: 5 % off what it drives on
    sure = shrink(
        silent,
        hp,
        d,
        evidence=evidence(0.0),
        min_speed_m_s=2.0,
        source_radii=R_SRC,
        prior_radii=centre,
    )
    assert sure.radii == centre and sure.info["shrink_weight"] == 0.0
    assert sure.info["prior_scale"] == pytest.approx(0.2, rel=1e-9)
    free = shrink(
        silent,
        hp,
        d,
        evidence=evidence(math.inf),
        min_speed_m_s=2.0,
        source_radii=R_SRC,
        prior_radii=centre,
    )
    assert free.radii == pytest.approx((0.29 * 1.25,) * 2, rel=1e-9)
    ev = evidence(0.01, v_per_s=0.05)
    part = shrink(
        silent, hp, d, evidence=ev, min_speed_m_s=2.0, source_radii=R_SRC, prior_radii=centre
    )
    w = part.info["shrink_weight"]
    assert 0.0 < w < 1.0
    assert part.radii == pytest.approx((0.29 * (1.2 + 0.05 * w),) * 2, rel=1e-6)
    # the same evidence centred on G (0.29) keeps the same share of a 25 % refit
    on_g = shrink(silent, hp, d, evidence=ev, min_speed_m_s=2.0, source_radii=R_SRC)
    assert on_g.info["shrink_weight"] == pytest.approx(w) and "prior_scale" not in on_g.info
    assert on_g.radii == pytest.approx((0.29 * (1 + 0.25 * w),) * 2, rel=1e-6)
    standing = AdaptData(x[:5], y[:5], np.zeros(5), np.zeros(5), np.zeros(5))
    still = shrink(
        silent,
        hp,
        standing,
        evidence=ev,
        min_speed_m_s=2.0,
        source_radii=R_SRC,
        prior_radii=centre,
    )
    assert still.radii == centre  # no second to refit on: the car's own size


# --------------------------------------------------------------------------- the evidence


def drives_with(scales_first, scales_rest, n=300, k_change=30, seed=0):
    """Drives at 10 m/s whose radius is ``1 + first`` of the source's before ``k_change``
    and ``1 + rest`` after; exact GNSS, G predicting 0."""
    rng = np.random.default_rng(seed)
    cols = {c: [] for c in ("drive", "k", "gnss", "a")}
    for i, (a, b) in enumerate(zip(scales_first, scales_rest, strict=True)):
        angle = rng.uniform(8, 12, n) / 0.29
        scale = np.where(np.arange(n) < k_change, 1 + a, 1 + b)
        cols["drive"].append(np.full(n, f"D{i}"))
        cols["k"].append(np.arange(n))
        cols["gnss"].append(0.29 * scale * angle)
        cols["a"].append(angle)
    return {c: np.concatenate(v) for c, v in cols.items()}


def test_the_evidence_measures_the_first_seconds_against_the_rest():
    d = drives_with([0.01, -0.02, 0.0], [0.0, 0.0, 0.0])
    terms = evidence_terms(
        d["drive"],
        d["k"],
        d["gnss"],
        d["a"],
        d["a"],
        np.zeros(len(d["k"])),
        source_radii=R_SRC,
        min_speed_m_s=2.0,
        min_rest_s=60,
    )
    assert terms.drives == ("D0", "D1", "D2")
    at = {int(k): j for j, k in enumerate(terms.k_s)}
    # before the change: the first k s say 1 + a, the rest says about 1 (+ a share of a)
    first = d["k"] < 20
    for i, a in enumerate([0.01, -0.02, 0.0]):
        mine = first & (d["drive"] == f"D{i}")
        dist = d["gnss"][mine].sum()
        rest = (d["k"] >= 20) & (d["drive"] == f"D{i}")
        # the rest's scale: the GNSS over the source WPM of the rest (exact data)
        rest_scale = d["gnss"][rest].sum() / (0.29 * d["a"][rest]).sum() - 1
        want = ((a - rest_scale) * dist) ** 2
        assert terms.sq_error_m2[i, at[20]] == pytest.approx(want, rel=1e-9, abs=1e-18)
    # from the change on the first k s hold every changed second: the error stops growing
    # in scale terms; drives stop counting where fewer than 60 s follow
    assert terms.k_s.max() == 300 - 60
    ev = shrink_evidence(terms, "t")
    assert ev is not None and ev.n_drives[0] == 3
    assert ev.sum_var(20) == pytest.approx(terms.sq_error_m2[:, at[20]].mean(), rel=1e-12)
    for i in range(3):  # each drive's whole-drive scale: its GNSS over its source WPM
        mine = d["drive"] == f"D{i}"
        want = d["gnss"][mine].sum() / (0.29 * d["a"][mine]).sum() - 1
        assert terms.scale[i] == pytest.approx(want, rel=1e-9)
    assert ev.prior_sd == pytest.approx(prior_sd(terms.scale), rel=1e-12)


def test_leaving_a_drive_out_and_too_few_drives():
    d = drives_with([0.01, -0.02, 0.0], [0.0, 0.0, 0.0])
    args = (d["drive"], d["k"], d["gnss"], d["a"], d["a"], np.zeros(len(d["k"])))
    terms = evidence_terms(*args, source_radii=R_SRC, min_speed_m_s=2.0, min_rest_s=60)
    without = shrink_evidence(terms, "t", exclude="D1")
    assert without.drives == ("D0", "D2") and without.n_drives[0] == 2
    assert without.sum_var(20) < shrink_evidence(terms, "t").sum_var(20)  # D1 errs most
    two = evidence_terms(
        *(a[d["drive"] != "D2"] for a in args),
        source_radii=R_SRC,
        min_speed_m_s=2.0,
        min_rest_s=60,
    )
    assert shrink_evidence(two, "t", exclude="D0") is None  # one drive says nothing
    short = evidence_terms(*args, source_radii=R_SRC, min_speed_m_s=2.0, min_rest_s=400)
    assert shrink_evidence(short, "t") is None  # no drive is long enough


# --------------------------------------------------------------------------- continuous


def test_continuous_shrink_never_uses_a_second_at_or_after_its_window(g, linear_data):
    net, hp = g
    x, _ = linear_data
    n = 300
    g_pred = predict(net, x[:n]).astype(np.float64)
    windows = np.array([np.arange(s, s + 30) for s in (100, 130, 200, 250)])
    y = g_pred.copy()
    y[windows.ravel()] += 100.0
    gnss = np.full(n, 10.0) + g_pred  # before the windows: the source radius exactly, under G
    gnss[windows.ravel()] += 100.0  # inside: GNSS 100 m off
    d = AdaptData(x[:n], y.astype(np.float32), gnss, np.full(n, 10.0 / 0.29), np.full(n, 10 / 0.29))
    pred = continuous_predictions(
        net,
        hp,
        d,
        np.arange(n),
        windows,
        inner=SHRINK_RIDGE,
        penalty=0.5,
        window_s=0,
        min_speed_m_s=2.0,
        source_radii=R_SRC,
        evidence=evidence(0.01),
    )
    np.testing.assert_allclose(pred[0], g_pred[windows[0]], atol=1e-3)
    assert np.abs(pred[3] - g_pred[windows[3]]).mean() > 1.0  # earlier windows were seen


def test_continuous_shrink_is_radius_g_then_the_ridge_head(g, linear_data):
    """τ → 0 gives the continuous ridge head; an infinite penalty and τ → ∞, radius+G."""
    net, hp = g
    x, y = linear_data
    n = 200
    d = data_of(x[:n], y[:n] + 0.3, r_true=0.29 * 1.02)
    k, windows = np.arange(n), np.array([np.arange(s, s + 30) for s in (0, 60, 150)])
    kw = dict(window_s=0, min_speed_m_s=2.0, source_radii=R_SRC)
    ridge = continuous_predictions(net, hp, d, k, windows, inner="ridge_head", penalty=0.5, **kw)
    sure = continuous_predictions(
        net, hp, d, k, windows, inner=SHRINK_RIDGE, penalty=0.5, evidence=evidence(0.0), **kw
    )
    np.testing.assert_array_equal(sure, ridge)
    radius = continuous_predictions(net, hp, d, k, windows, inner="radius+G", penalty=0.0, **kw)
    free = continuous_predictions(
        net,
        hp,
        d,
        k,
        windows,
        inner=SHRINK_RIDGE,
        penalty=math.inf,
        evidence=evidence(math.inf),
        **kw,
    )
    # G's head in float64 on its hidden features against G's float32 forward pass
    np.testing.assert_allclose(free, radius, rtol=0, atol=1e-5)
    with pytest.raises(ValueError, match="evidence"):
        continuous_predictions(net, hp, d, k, windows, inner=SHRINK_RIDGE, penalty=0.5, **kw)
