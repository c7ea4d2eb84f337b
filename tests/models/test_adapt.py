"""R-WhONet's recipes (rwhonet.models.adapt): from G, each with its defining property."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest
import torch

from rwhonet.errors import InputError
from rwhonet.features.calibration import refit_radii
from rwhonet.features.wpm import wpm_displacement_m
from rwhonet.models.adapt import (
    AdaptData,
    continuous_predictions,
    fine_tune,
    fine_tune_steps,
    hidden_features,
    label_prediction,
    radius_g,
    recalibrate,
    ridge_head,
    ridge_head_weights,
)
from rwhonet.models.freeze import count_parameters
from rwhonet.models.loop import predict

R_SRC = (0.29, 0.29)


def data_of(x, y, r_true=0.29 * 1.02, seed=0):
    """Samples whose GNSS says the wheels roll ``r_true`` per radian (the WPM: 0.29)."""
    rng = np.random.default_rng(seed)
    angle = rng.uniform(20, 40, len(y))
    gnss = r_true * angle
    return AdaptData(x, y, gnss, angle, angle)


def test_fine_tune_moves_g_towards_the_new_vehicle_and_records_the_recipe(
    g, linear_data, adapt_params
):
    net, hp = g
    x, y = linear_data
    before_w = {k: v.clone() for k, v in net.state_dict().items()}
    shift = 1.5  # the new vehicle's label differs by a constant
    before = np.mean(np.abs(predict(net, x[:50]) - (y[:50] + shift)))
    recipe = replace(adapt_params, epochs=40, lr=0.02, batch_size=16)
    r = fine_tune(net, hp, data_of(x[:50], y[:50] + shift), adapt=recipe, seed=2)
    after = np.mean(np.abs(predict(r.net, x[:50]) - (y[:50] + shift)))
    assert after < 0.5 * before
    assert len(r.history) == 40 and r.history[-1]["train_loss"] < r.history[0]["train_loss"]
    assert r.hparams == {**hp, "lr": 0.02, "batch_size": 16} and r.radii is None
    assert all(torch.equal(v, before_w[k]) for k, v in net.state_dict().items())  # G untouched


def test_fine_tuning_is_deterministic_for_a_seed(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    d = data_of(x[:40], y[:40])
    preds = [predict(fine_tune(net, hp, d, adapt=adapt_params, seed=s).net, x) for s in (5, 5, 6)]
    np.testing.assert_array_equal(preds[0], preds[1])
    assert not np.array_equal(preds[0], preds[2])  # one batch per epoch: dropout differs


def test_inputs_that_do_not_fit_g_are_refused(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    with pytest.raises(InputError, match="39"):
        fine_tune(net, hp, data_of(x[:50, :, :39], y[:50]), adapt=adapt_params, seed=1)
    with pytest.raises(InputError, match="at least one sample"):
        fine_tune(net, hp, data_of(x[:0], y[:0]), adapt=adapt_params, seed=1)


@pytest.mark.parametrize(("policy", "frozen", "moving"), [("head", "rnn", "head")])
def test_the_head_recipe_moves_the_head_only(g, linear_data, adapt_params, policy, frozen, moving):
    net, hp = g
    x, y = linear_data
    before = {k: v.clone() for k, v in net.state_dict().items()}
    r = fine_tune(
        net, hp, data_of(x[:50], y[:50] + 1.0), adapt=adapt_params, seed=2, trainable=policy
    )
    assert r.n_trainable == count_parameters(getattr(r.net, moving))[1] == 17
    for k, v in r.net.state_dict().items():
        if k.startswith(frozen):
            assert torch.equal(v, before[k]), k
        else:
            assert not torch.equal(v, before[k]), k


def test_ridge_with_zero_penalty_is_least_squares_on_the_head(g, linear_data):
    net, hp = g
    x, y = linear_data
    d = data_of(x[:300], y[:300] + 0.7)
    r = ridge_head(net, hp, d, penalty=0.0)
    h = hidden_features(net, x[:300])
    a = np.hstack([h, np.ones((300, 1))])
    ols = np.linalg.lstsq(a, d.y.astype(np.float64), rcond=None)[0]
    np.testing.assert_allclose(r.net.head.weight.detach().numpy()[0], ols[:-1], atol=1e-4)
    assert float(r.net.head.bias.detach()) == pytest.approx(ols[-1], abs=1e-4)
    np.testing.assert_allclose(predict(r.net, x[:300]), a @ ols, atol=1e-4)
    assert torch.equal(r.net.rnn.weight_ih_l0, net.rnn.weight_ih_l0)  # the features stay G's


def test_ridge_with_an_infinite_penalty_returns_g(g, linear_data):
    net, hp = g
    x, y = linear_data
    r = ridge_head(net, hp, data_of(x[:50], y[:50] + 5.0), penalty=float("inf"))
    for (k, a), b in zip(r.net.state_dict().items(), net.state_dict().values(), strict=True):
        assert torch.equal(a, b), k
    # and a growing penalty moves the head monotonically back towards G's
    h, w0, b0 = hidden_features(net, x[:50]), net.head.weight.detach().numpy()[0], 0.0
    dist = [
        np.linalg.norm(ridge_head_weights(h, y[:50] + 5.0, w0, b0, p)[0] - w0)
        for p in (0.01, 0.1, 1.0, 10.0)
    ]
    assert dist == sorted(dist, reverse=True)


def constant_g(net, bias_m):
    """G's network made to predict ``bias_m`` for every second (head weights zero)."""
    out = copy.deepcopy(net)
    with torch.no_grad():
        out.head.weight.zero_()
        out.head.bias.fill_(bias_m)
    return out.eval()


def test_radius_g_recovers_a_known_radius_change(g, linear_data):
    net, hp = g
    x, y = linear_data
    silent = constant_g(net, 0.0)  # a G that explains nothing: the radius is the GNSS ratio
    r = radius_g(silent, hp, data_of(x[:50], y[:50], r_true=0.29 * 1.02), min_speed_m_s=2.0)
    assert r.radii == pytest.approx((0.29 * 1.02, 0.29 * 1.02), rel=1e-6)
    d = data_of(x[50:60], y[50:60], r_true=0.29 * 1.02, seed=3)
    # G's correction plus the WPM with the refitted radii minus the source WPM
    extra = wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, *r.radii)
    extra -= wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, *R_SRC)
    np.testing.assert_allclose(
        label_prediction(r, d, R_SRC), predict(silent, d.x) + extra, atol=1e-9
    )
    standing = AdaptData(x[:5], y[:5], np.zeros(5), np.zeros(5), np.zeros(5))
    assert radius_g(net, hp, standing, min_speed_m_s=2.0).radii is None  # nothing to fit on


def test_radius_g_fits_the_radius_to_what_g_leaves(g, linear_data):
    """WPM + G adds up to the GNSS distance over the m seconds: G's share is not counted twice."""
    net, hp = g
    x, y = linear_data
    d = data_of(x[:50], y[:50], r_true=0.29 * 1.02)
    biased = constant_g(net, 0.15)  # G says: 15 cm more per second than the source WPM
    r = radius_g(biased, hp, d, min_speed_m_s=2.0)
    expected = (d.disp_gnss_m.sum() - 0.15 * len(d)) / d.angle_rl_rad.sum()
    assert r.radii == pytest.approx((expected, expected), rel=1e-6)
    wpm_src = wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, *R_SRC)
    corrected = wpm_src + label_prediction(r, d, R_SRC)
    assert corrected.sum() == pytest.approx(d.disp_gnss_m.sum(), rel=1e-6)
    # refitting to GNSS alone and adding G would overshoot by G's total
    naive = wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, 0.29 * 1.02, 0.29 * 1.02) + 0.15
    assert naive.sum() - d.disp_gnss_m.sum() == pytest.approx(0.15 * len(d), rel=1e-4)


def test_steps_stops_early_and_keeps_the_best_held_back_weights(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    cfg = replace(
        adapt_params,
        lr=0.05,
        batch_size=8,
        steps=replace(adapt_params.steps, max_steps=500, patience=10),
    )
    r = fine_tune_steps(net, hp, data_of(x[:40], y[:40] + 2.0), adapt=cfg, seed=4)
    held = [h["val_loss"] for h in r.history]
    assert r.info["held_back_s"] == 10 and r.info["steps"] < 500  # stopped by patience
    assert r.info["steps"] - r.info["best_step"] == 10
    best = min(held)
    got = float(np.mean(np.abs(predict(r.net, x[30:40]) - (y[30:40] + 2.0))))
    assert got == pytest.approx(best, rel=1e-5)  # the best step's weights were restored


def test_recalibrate_dispatches_every_recipe_but_continuous(g, linear_data, adapt_params):
    net, hp = g
    x, y = linear_data
    d = data_of(x[:20], y[:20])
    for recipe in ("paper", "head", "ridge_head", "radius+G", "steps"):
        r = recalibrate(recipe, net, hp, d, adapt=adapt_params, seed=1, min_speed_m_s=2.0)
        assert label_prediction(r, d, R_SRC).shape == (20,)
    with pytest.raises(ValueError, match="continuous"):
        recalibrate("continuous", net, hp, d, adapt=adapt_params, seed=1, min_speed_m_s=2.0)


@pytest.mark.parametrize("window_s", [0, 40])
@pytest.mark.parametrize("penalty", [0.0, 0.5])
def test_continuous_never_uses_a_second_at_or_after_its_window(g, linear_data, window_s, penalty):
    net, hp = g
    x, _ = linear_data
    n = 300
    g_pred = predict(net, x[:n]).astype(np.float64)
    # Before a window the labels are G's own predictions (a refit changes nothing), inside
    # every window they are 100 m off: one leaked second would move the window's predictions.
    windows = np.array([np.arange(s, s + 30) for s in (100, 130, 200, 250)])
    y = g_pred.copy()
    y[windows.ravel()] += 100.0
    d = AdaptData(x[:n], y.astype(np.float32), np.full(n, 10.0), np.full(n, 34.0), np.full(n, 34.0))
    # Give the first window's earlier seconds no leak at all, the last ones plenty of leaked
    # labels before them (windows 1-3 precede window 4): only strictly earlier seconds count.
    pred = continuous_predictions(
        net,
        hp,
        d,
        np.arange(n),
        windows,
        inner="ridge_head",
        penalty=penalty,
        window_s=window_s,
        min_speed_m_s=2.0,
        source_radii=R_SRC,
    )
    np.testing.assert_allclose(pred[0], g_pred[windows[0]], atol=1e-3)
    assert np.all(np.abs(pred[0] - 100.0) > 50.0)
    # windows after earlier windows do see those windows' (100 m) labels: they move
    assert np.abs(pred[3] - g_pred[windows[3]]).mean() > 1.0


def test_the_leak_check_catches_a_single_leaked_second(g, linear_data):
    """One second carrying a window's label in the fit moves the predictions well past 1e-3."""
    net, hp = g
    x, _ = linear_data
    n = 200
    g_pred = predict(net, x[:n]).astype(np.float64)
    y = g_pred.copy()
    y[100:130] += 100.0  # the window's labels, as above
    d = AdaptData(x[:n], y.astype(np.float32), np.full(n, 10.0), np.full(n, 34.0), np.full(n, 34.0))
    kw = dict(inner="ridge_head", penalty=0.0, window_s=0, min_speed_m_s=2.0, source_radii=R_SRC)
    clean = continuous_predictions(net, hp, d, np.arange(n), np.array([np.arange(100, 130)]), **kw)
    # What an off-by-one (k <= k0) would fit on: the same window, one second later.
    leaky = continuous_predictions(net, hp, d, np.arange(n), np.array([np.arange(101, 131)]), **kw)
    np.testing.assert_allclose(clean[0], g_pred[100:130], atol=1e-3)
    assert np.abs(leaky[0] - g_pred[101:131]).max() > 0.1


# One ridge solve and one radius correction serve every caller (issue 14). The old code is
# written out here, as it stood in models/adapt.py, and the callers must still give its
# numbers: bit for bit where the operations are the same, to 1e-12 where the old code summed
# the normal equations in another order.


def _old_ridge_head_weights(h, y, w0, b0, penalty):
    if np.isinf(penalty):
        return np.asarray(w0, np.float64).copy(), float(b0)
    a = np.hstack([np.asarray(h, np.float64), np.ones((len(h), 1))])
    y = np.asarray(y, np.float64)
    theta0 = np.append(np.asarray(w0, np.float64), b0)
    if penalty == 0:
        theta = np.linalg.lstsq(a, y, rcond=None)[0]
    else:
        lam = len(y) * penalty
        theta = np.linalg.solve(a.T @ a + lam * np.eye(a.shape[1]), a.T @ y + lam * theta0)
    return theta[:-1], float(theta[-1])


@pytest.mark.parametrize("penalty", [0.0, 1e-3, 0.5, 100.0, float("inf")])
@pytest.mark.parametrize("n", [5, 60])  # fewer seconds than weights, and more
def test_ridge_head_weights_give_the_old_formula_s_numbers(penalty, n):
    rng = np.random.default_rng(n)
    h, y = rng.normal(size=(n, 16)), rng.normal(size=n)
    w0, b0 = rng.normal(size=16).astype(np.float32), float(rng.normal())
    w, b = ridge_head_weights(h, y, w0, b0, penalty)
    w_old, b_old = _old_ridge_head_weights(h, y, w0, b0, penalty)
    assert np.array_equal(w, w_old) and b == b_old


def _old_continuous_one_window(a, y, theta0, before, penalty):
    """The old continuous ridge fit of one window, on the rows ``before`` it (direct sums)."""
    rows = np.flatnonzero(before)
    if penalty == 0:
        return np.linalg.lstsq(a[rows], y[rows], rcond=None)[0]
    if np.isinf(penalty):
        return theta0
    lam = len(rows) * penalty
    ata, aty = a[rows].T @ a[rows], a[rows].T @ y[rows]
    return np.linalg.solve(ata + lam * np.eye(len(theta0)), aty + lam * theta0)


@pytest.mark.parametrize("window_s", [0, 40])
@pytest.mark.parametrize("penalty", [0.0, 0.5, float("inf")])
def test_continuous_ridge_gives_the_old_formula_s_numbers(g, linear_data, penalty, window_s):
    net, hp = g
    x, y = linear_data
    n = 300
    d = data_of(x[:n], y[:n] + 0.3)
    k = np.arange(n)
    windows = np.array([np.arange(s, s + 30) for s in (0, 100, 130, 250)])
    kw = dict(penalty=penalty, window_s=window_s, min_speed_m_s=2.0, source_radii=R_SRC)
    pred = continuous_predictions(net, hp, d, k, windows, inner="ridge_head", **kw)
    a = np.hstack([hidden_features(net, d.x), np.ones((n, 1))])
    theta0 = np.append(net.head.weight.detach().numpy()[0], float(net.head.bias.detach()[0]))
    g_pred = predict(net, d.x).astype(np.float64)
    for w, rows in enumerate(windows):
        k0 = k[rows[0]]
        before = (k < k0) & ((k >= k0 - window_s) if window_s else True)
        if not before.any():
            assert np.array_equal(pred[w], g_pred[rows])
            continue
        theta = _old_continuous_one_window(a, d.y.astype(np.float64), theta0, before, penalty)
        np.testing.assert_allclose(pred[w], a[rows] @ theta, rtol=0, atol=1e-12)


def test_a_refitted_radius_restates_the_prediction_as_the_old_code_did(g, linear_data):
    net, hp = g
    x, y = linear_data
    d = data_of(x[:80], y[:80], r_true=0.29 * 1.03, seed=5)
    r = radius_g(net, hp, d.take(np.arange(40)), min_speed_m_s=2.0)
    assert r.radii is not None
    old = predict(r.net, d.x).astype(np.float64)
    old += wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, *r.radii)
    old -= wpm_displacement_m(d.angle_rl_rad, d.angle_rr_rad, *R_SRC)
    assert np.array_equal(label_prediction(r, d, R_SRC), old)
    # continuous radius+G: the window's G prediction, corrected the same way
    windows = np.array([np.arange(50, 80)])
    kw = dict(inner="radius+G", penalty=0.0, window_s=0, min_speed_m_s=2.0, source_radii=R_SRC)
    pred = continuous_predictions(net, hp, d, np.arange(80), windows, **kw)
    g_pred, rows = predict(net, d.x).astype(np.float64), windows[0]
    fit = slice(0, 50)  # every second before the window
    radii = refit_radii(
        d.disp_gnss_m[fit], d.angle_rl_rad[fit], d.angle_rr_rad[fit], 2.0, explained_m=g_pred[fit]
    )
    old = g_pred[rows]
    old += wpm_displacement_m(d.angle_rl_rad[rows], d.angle_rr_rad[rows], *radii)
    old -= wpm_displacement_m(d.angle_rl_rad[rows], d.angle_rr_rad[rows], *R_SRC)
    assert np.array_equal(pred[0], old)
