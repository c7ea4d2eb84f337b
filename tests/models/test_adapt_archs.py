"""Every recalibration recipe on the networks with temporal context (model.arch gru, tcn)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from rwhonet.config import ModelParams, TrainParams
from rwhonet.features.sequences import sequences
from rwhonet.models.adapt import (
    AdaptData,
    continuous_predictions,
    hidden_features,
    label_prediction,
    recalibrate,
)
from rwhonet.models.checkpoint import load_whonet, save_whonet
from rwhonet.models.loop import predict
from rwhonet.models.train import fit

R_SRC = (0.29, 0.29)
SEQ_LEN = 6
ARCHS = ("gru", "tcn")


@pytest.fixture(scope="module")
def windows() -> tuple[np.ndarray, np.ndarray]:
    """600 seconds in two segments, as windows of SEQ_LEN; the label needs the past second."""
    rng = np.random.default_rng(11)
    group = np.repeat([0, 1], [350, 250])
    per_second = rng.uniform(0, 1, (600, 40)).astype(np.float32)
    previous = np.concatenate([per_second[:1, 1], per_second[:-1, 1]])
    y = (0.5 * per_second[:, 0] - 0.3 * previous + 0.1).astype(np.float32)
    return sequences(per_second, SEQ_LEN, group), y


@pytest.fixture(scope="module", params=ARCHS)
def g(request, windows):
    """G of each network, briefly trained on the windows."""
    x, y = windows
    model = ModelParams(hidden=12, layers=1, dropout=0.05, seq_len=SEQ_LEN, arch=request.param)
    train = TrainParams(epochs=3, batch_size=64, lr=0.01, val_fraction=0.1, num_threads=1)
    result = fit(x, y, model=model, train=train, seed=1)
    return result.module.net, dict(result.module.hparams)


def data_of(x, y, r_true=0.29 * 1.03):
    angle = np.random.default_rng(0).uniform(20, 40, len(y))
    return AdaptData(x, y, r_true * angle, angle, angle)


@pytest.mark.parametrize("recipe", ["paper", "head", "ridge_head", "radius+G", "steps"])
def test_every_recipe_recalibrates_the_network_and_its_file_rebuilds_it(
    g, windows, adapt_params, recipe, tmp_path
):
    net, hp = g
    x, y = windows
    before = {k: v.clone() for k, v in net.state_dict().items()}
    fit_on = data_of(x[:50], y[:50] + 0.4)  # the new car: 40 cm more per second
    r = recalibrate(recipe, net, hp, fit_on, adapt=adapt_params, seed=3, min_speed_m_s=2.0)
    assert all(torch.equal(v, before[k]) for k, v in net.state_dict().items())  # G untouched
    assert type(r.net) is type(net) and not r.net.training
    scored = data_of(x, y + 0.4)
    pred = label_prediction(r, scored, R_SRC)
    assert pred.shape == (600,) and np.isfinite(pred).all()
    changed = {k for k, v in r.net.state_dict().items() if not torch.equal(v, before[k])}
    if recipe == "radius+G":
        g_sum = predict(net, fit_on.x).astype(np.float64).sum()
        expected = (fit_on.disp_gnss_m.sum() - g_sum) / fit_on.angle_rl_rad.sum()
        assert not changed and r.radii == pytest.approx((expected, expected), rel=1e-6)
    elif recipe in ("head", "ridge_head"):
        assert changed == {"head.weight", "head.bias"}
    else:
        assert changed - {"head.weight", "head.bias"}  # the body learns too
    if recipe != "radius+G":  # every recipe that learns moves G towards the new car
        g_err = np.abs(predict(net, x[:50]) - (y[:50] + 0.4)).mean()
        assert np.abs(predict(r.net, x[:50]) - (y[:50] + 0.4)).mean() < g_err
    save_whonet(r.net, r.hparams, tmp_path / "r.pt", wpm_radii=r.radii)
    loaded, hp2 = load_whonet(tmp_path / "r.pt")
    assert hp2["arch"] == hp["arch"] and hp2["seq_len"] == SEQ_LEN
    np.testing.assert_array_equal(predict(loaded, x), predict(r.net, x))


def test_ridge_head_refits_on_the_networks_own_head_inputs(g, windows, adapt_params):
    net, hp = g
    x, y = windows
    h = hidden_features(net, x[:80])
    net.eval()
    with torch.no_grad():
        np.testing.assert_allclose(h, net.features(torch.from_numpy(x[:80])).numpy(), rtol=1e-6)
    assert h.shape == (80, 12)
    least_squares = replace(adapt_params, ridge_penalty=0.0)
    d = data_of(x[:80], y[:80] + 0.2)
    r = recalibrate("ridge_head", net, hp, d, adapt=least_squares, seed=0, min_speed_m_s=2.0)
    a = np.hstack([h, np.ones((80, 1))])
    ols = np.linalg.lstsq(a, d.y.astype(np.float64), rcond=None)[0]
    np.testing.assert_allclose(r.net.head.weight.detach().numpy()[0], ols[:-1], atol=1e-4)
    np.testing.assert_allclose(predict(r.net, x[:80]), a @ ols, atol=1e-4)


@pytest.mark.parametrize("inner", ["ridge_head", "radius+G"])
def test_continuous_never_uses_a_second_at_or_after_its_window(g, windows, inner):
    net, hp = g
    x, _ = windows
    n = 300
    g_pred = predict(net, x[:n]).astype(np.float64)
    wins = np.array([np.arange(s, s + 30) for s in (100, 200, 250)])
    y = g_pred.copy()
    y[wins.ravel()] += 100.0  # one leaked second would move the windows' predictions
    d = AdaptData(x[:n], y.astype(np.float32), np.full(n, 10.0), np.full(n, 34.0), np.full(n, 34.0))
    d.disp_gnss_m[:] = 0.29 * 34.0 + g_pred  # GNSS says: the WPM plus G, exactly
    pred = continuous_predictions(
        net,
        hp,
        d,
        np.arange(n),
        wins,
        inner=inner,
        penalty=0.0,
        window_s=0,
        min_speed_m_s=2.0,
        source_radii=R_SRC,
    )
    np.testing.assert_allclose(pred[0], g_pred[wins[0]], atol=1e-3)
    if inner == "ridge_head":  # later windows fit on the earlier windows' 100 m labels
        assert np.abs(pred[2] - g_pred[wins[2]]).mean() > 1.0
