"""2D position at the end of each outage: the filter's windows and their summaries."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from rwhonet.evaluation.position import (
    GNSS_DISTANCE,
    WINDOW_COLUMNS,
    Calibration2D,
    Odometry,
    ReceiverFit,
    _spaced,
    calibrate_2d,
    calibrated_nll,
    filter_windows,
    fit_noise,
    position_per_seed,
    target_windows,
    window_stats,
)
from rwhonet.evaluation.selection import choose
from rwhonet.evaluation.study import evaluate, navigation_plan
from rwhonet.stages.sample_files import load_role


def test_window_stats_of_a_hand_computed_case():
    # three windows: errors 3, 4 and 10 m east/north, unit covariances (1 m²) except the
    # last (100 m²): squared Mahalanobis 9+0, 0+16, and (36+64)/100 = 1
    w = pd.DataFrame(
        {
            "counted": [True, True, True, False],
            "err_e_m": [3.0, 0.0, 6.0, np.nan],
            "err_n_m": [0.0, 4.0, 8.0, np.nan],
            "cov_ee_m2": [1.0, 1.0, 100.0, np.nan],
            "cov_en_m2": [0.0, 0.0, 0.0, np.nan],
            "cov_nn_m2": [1.0, 1.0, 100.0, np.nan],
            "horizontal_m": [3.0, 4.0, 10.0, np.nan],
            "distance_m": [100.0, 100.0, 200.0, 300.0],
        }
    )
    s = window_stats(w)
    assert s["n_windows"] == 3
    assert s["pos_mean"] == pytest.approx(17.0 / 3.0) and s["pos_max"] == 10.0
    assert s["pos_pct"] == pytest.approx(100.0 * 17.0 / 400.0)  # sums over counted windows
    assert s["pos_pct_max"] == pytest.approx(5.0)  # the worst window: 10 m of 200 m
    # inside the 68.27 % ellipse (d² <= 2.296): the last only; the 95.45 % (6.180): the last
    assert s["cover_1sigma"] == pytest.approx(1 / 3) and s["cover_2sigma"] == pytest.approx(1 / 3)
    d2 = np.array([9.0, 16.0, 1.0])
    logdet = np.log([1.0, 1.0, 1e4])
    assert s["nll"] == pytest.approx(np.mean(0.5 * (d2 + logdet) + np.log(2 * np.pi)))
    assert window_stats(w.assign(counted=False))["n_windows"] == 0
    # calibrated with c = 2 (a normal twice as wide): 68.27 % inside d² <= 4.59, 95.45 %
    # inside d² <= 12.36 -> d² 1 inside both, 9 inside the second; the filter's own unchanged
    cal = window_stats(w, Calibration2D(2.0, np.inf, 50))
    assert cal["cover_1sigma"] == pytest.approx(1 / 3)
    assert cal["cover_2sigma"] == pytest.approx(2 / 3)
    assert cal["cover_1sigma_filter"] == s["cover_1sigma"] and cal["nll_filter"] == s["nll"]
    assert cal["calib_scale"] == 2.0 and np.isnan(cal["calib_dof"])  # NaN: a normal
    assert cal["nll"] == pytest.approx(np.mean(np.log(2 * np.pi * 2.0) + 0.5 * logdet + d2 / 4.0))


def test_calibrate_2d_fits_each_run_and_leaves_a_run_of_few_windows_normal():
    rng = np.random.default_rng(3)
    n = 20000
    z = rng.normal(size=(n, 2)) * np.sqrt(1.5) / np.sqrt(rng.chisquare(3.0, n) / 3.0)[:, None]
    cov = rng.uniform(1.0, 9.0, n)  # isotropic covariances of several sizes
    many = pd.DataFrame(
        {
            "model": "G",
            "seed": 7,
            "control": "fused",
            "counted": True,
            "err_e_m": z[:, 0] * np.sqrt(cov),
            "err_n_m": z[:, 1] * np.sqrt(cov),
            "cov_ee_m2": cov,
            "cov_en_m2": 0.0,
            "cov_nn_m2": cov,
            "outage_s": 30,
        }
    )
    few = many.head(5).assign(model="WPM", seed=None)
    got = calibrate_2d(pd.concat([many, few], ignore_index=True))
    g = got[("G", 7, "fused")]
    assert g.n_windows == n and g.scale == pytest.approx(1.5, rel=0.1)
    assert g.dof == pytest.approx(3.0, rel=0.15)
    assert g.scales == {30: pytest.approx(g.scale, rel=1e-3)}  # one length: the same
    assert got[("WPM", None, "fused")] == Calibration2D(1.0, np.inf, 5)


def _t_windows(
    rng, lengths: np.ndarray, dof_of: dict[int, float], c: float = 1.5, grown=None
) -> pd.DataFrame:
    """Isotropic filter covariances and bivariate-t ends (scale c Σ, ν per length); the
    filter's covariance of a length in ``grown`` that many times too large."""
    n = len(lengths)
    cov = rng.uniform(1.0, 9.0, n)
    nu = np.array([dof_of[int(L)] for L in lengths])
    finite = np.where(np.isfinite(nu), nu, 1.0)
    shrink = np.where(np.isfinite(nu), np.sqrt(rng.chisquare(finite) / finite), 1.0)
    z = rng.normal(size=(n, 2)) * np.sqrt(c) / shrink[:, None]
    too_large = np.array([(grown or {}).get(int(L), 1.0) for L in lengths])
    w = pd.DataFrame(
        {
            "model": "G",
            "seed": 7,
            "control": "fused",
            "counted": True,
            "outage_s": lengths,
            "err_e_m": z[:, 0] * np.sqrt(cov),
            "err_n_m": z[:, 1] * np.sqrt(cov),
            "cov_ee_m2": cov * too_large,
            "cov_en_m2": 0.0,
            "cov_nn_m2": cov * too_large,
        }
    )
    w["horizontal_m"] = np.hypot(w["err_e_m"], w["err_n_m"])
    w["distance_m"] = 1000.0
    return w


def test_each_outage_length_with_enough_windows_gets_its_own_scale():
    """Long outages whose covariance grew twice as fast as their errors: their own c."""
    rng = np.random.default_rng(4)
    n = 20000
    length = np.where(np.arange(n) < n // 2, 30, 180)
    length[:10] = 60  # too few windows of their own: the pooled scale
    # the filter's covariance at 180 s twice too large
    windows = _t_windows(rng, length, dict.fromkeys((30, 60, 180), 5.0), grown={180: 2.0})
    g = calibrate_2d(windows)[("G", 7, "fused")]
    assert set(g.scales) == {30, 180}
    assert g.scales[30] == pytest.approx(1.5, rel=0.1)
    assert g.scales[180] == pytest.approx(0.75, rel=0.1)
    assert g.scale_at(60) == g.scale and g.scale_at(None) == g.scale
    # and the coverage of each length is then at its nominal contents
    for L in (30, 180):
        stats = window_stats(windows[windows["outage_s"] == L], g, L)
        assert stats["calib_scale"] == g.scales[L]
        assert stats["cover_1sigma"] == pytest.approx(0.6827, abs=0.02)
        assert stats["cover_2sigma"] == pytest.approx(0.9545, abs=0.02)


def test_a_length_whose_tails_differ_gets_its_own_dof():
    """Heavy-tailed short outages, normal long ones: each length's ν where it is likelier."""
    rng = np.random.default_rng(6)
    lengths = np.repeat([30, 180], 6000)
    windows = _t_windows(rng, lengths, {30: 4.0, 180: np.inf})
    g = calibrate_2d(windows)[("G", 7, "fused")]
    assert set(g.dofs) == {30, 180}
    assert g.dof_at(30) == pytest.approx(4.0, rel=0.2)
    assert g.dof_at(180) > 50.0  # a normal, or near one
    assert g.dof_at(60) == g.dof and g.dof_at(None) == g.dof
    for L in (30, 180):
        stats = window_stats(windows[windows["outage_s"] == L], g, L)
        assert stats["cover_2sigma"] == pytest.approx(0.9545, abs=0.01)
        want = g.dofs[L] if np.isfinite(g.dofs[L]) else np.nan
        assert stats["calib_dof"] == pytest.approx(want, nan_ok=True)
    # the pooled ν is then wrong at both ends: too light at 30 s, too heavy at 180 s
    pooled = replace(g, dofs={})
    assert window_stats(windows[windows["outage_s"] == 30], pooled, 30)["cover_2sigma"] < 0.94


def test_lengths_with_the_same_tails_keep_the_pooled_dof():
    rng = np.random.default_rng(7)
    windows = _t_windows(rng, np.repeat([30, 180], 3000), {30: 5.0, 180: 5.0})
    g = calibrate_2d(windows)[("G", 7, "fused")]
    assert g.dofs == {} and g.dof == pytest.approx(5.0, rel=0.2)


def test_calibrated_nll_is_each_run_s_windows_under_its_own_calibration():
    rng = np.random.default_rng(5)
    rows = []
    for model, sd in (("G", 2.0), ("S", 0.5)):
        n = 400
        err = rng.normal(size=(n, 2)) * sd
        rows.append(
            pd.DataFrame(
                {
                    "model": model,
                    "seed": 1,
                    "control": "fused",
                    "counted": True,
                    "outage_s": np.where(np.arange(n) % 2, 30, 60),
                    "err_e_m": err[:, 0],
                    "err_n_m": err[:, 1],
                    "cov_ee_m2": 1.0,
                    "cov_en_m2": 0.0,
                    "cov_nn_m2": 1.0,
                    "horizontal_m": np.hypot(err[:, 0], err[:, 1]),
                    "distance_m": 500.0,
                }
            )
        )
    windows = pd.concat(rows, ignore_index=True)
    cals = calibrate_2d(windows)
    want = []
    for (model, L), g in windows.groupby(["model", "outage_s"]):
        want.append(window_stats(g, cals[(model, 1, "fused")], L)["nll"] * len(g))
    got, n = calibrated_nll(windows)
    assert n == 800 and got == pytest.approx(sum(want) / 800)
    assert calibrated_nll(windows.assign(counted=False)) == (pytest.approx(np.nan, nan_ok=True), 0)
    none = pd.DataFrame(columns=list(WINDOW_COLUMNS))  # no window at all (a tiny profile)
    assert calibrated_nll(none) == (pytest.approx(np.nan, nan_ok=True), 0)


class _Navigation:
    def __init__(self, fit_sigma=True, sigma_m=1.5, tau_s=100.0, fit_b=False, b_deg_s=0.01):
        self.gnss = type("G", (), {"sigma_m": sigma_m, "tau_s": tau_s, "fit_sigma": fit_sigma})
        self.gyro = type("Y", (), {"instability_deg_s": b_deg_s, "fit_instability": fit_b})


def _noise_case(monkeypatch, nll_of, fit_sigma=True, fit_b=False, n_windows=500, control="fused"):
    """fit_noise with the filter's training windows replaced by a known likelihood of
    (sigma m, B deg/s)."""
    import rwhonet.evaluation.position as position
    from rwhonet.nav import NavConfig

    tried = []

    def windows(frame, params, passes, outages_s, cfg):
        tried.append((cfg.gnss.sigma_m, float(np.degrees(cfg.gyro.bias_instability))))
        return tried[-1]

    monkeypatch.setattr(position, "_training_windows", windows)
    monkeypatch.setattr(position, "calibrated_nll", lambda st: (nll_of(*st), n_windows))
    params = type("P", (), {})()
    params.evaluate = type("E", (), {"navigation": _Navigation(fit_sigma, fit_b=fit_b)})()
    plan = {"control_model": "G", "control": control}
    run = Odometry("G", 1, control, np.zeros(1), np.zeros(1))
    passes = [([run], {30: np.zeros((0, 30), int)})]
    cfg = NavConfig().with_receiver(1.5)
    assert np.degrees(cfg.gyro.bias_instability) == pytest.approx(0.01)
    return fit_noise(None, params, passes, plan, [30], cfg), tried


def _receiver_case(monkeypatch, nll_of_sigma, fit_sigma=True, n_windows=500):
    """The receiver's drift alone (the gyro's B held)."""
    (fit, gyro), tried = _noise_case(
        monkeypatch, lambda s, b: nll_of_sigma(s), fit_sigma, n_windows=n_windows
    )
    assert not gyro.fitted and not gyro.nll and all(b == pytest.approx(0.01) for _, b in tried)
    return fit, [s for s, _ in tried]


@pytest.mark.parametrize("truth", [0.4, 1.5, 2.5, 7.0])
def test_the_receiver_fit_finds_the_likeliest_spread(monkeypatch, truth):
    # a likelihood quadratic in ln sigma: the parabola's vertex is its minimum exactly
    fit, tried = _receiver_case(monkeypatch, lambda s: (np.log(s) - np.log(truth)) ** 2)
    assert fit.fitted and fit.sigma_m == pytest.approx(truth, rel=1e-6)
    assert fit.configured_m == 1.5 and fit.tau_s == 100.0 and fit.n_windows == 500
    assert len(tried) == len(set(tried))  # each spread once
    # reported: the fit, a step either side, and what else was tried at least half a
    # step from those (nearest the fit first)
    reported = sorted(fit.nll)
    assert set(reported) <= set(tried) and fit.sigma_m in fit.nll
    steps = np.log(reported) / np.log(np.sqrt(2.0))
    assert (np.diff(steps) >= 0.5 - 1e-9).all()
    at = np.log(fit.sigma_m) / np.log(np.sqrt(2.0))
    assert np.isclose(steps, at - 1).any() and np.isclose(steps, at + 1).any()
    # it walks from the configured spread towards the likelier side only
    assert all(s <= 1.5 * np.sqrt(2.0) for s in tried) or all(s >= 1.5 / np.sqrt(2) for s in tried)


def test_the_receiver_fit_stays_in_its_range_and_keeps_what_it_is_told(monkeypatch):
    fit, _ = _receiver_case(monkeypatch, lambda s: -s)  # likelier without end: the bound
    assert fit.fitted and fit.sigma_m <= 30.0 and fit.sigma_m > 30.0 / np.sqrt(2.0)
    fit, tried = _receiver_case(monkeypatch, lambda s: s, fit_sigma=False)
    assert fit == ReceiverFit(1.5, 100.0, 1.5) and not tried
    fit, tried = _receiver_case(monkeypatch, lambda s: s, n_windows=3)  # too few windows
    assert not fit.fitted and fit.sigma_m == 1.5 and fit.n_windows == 3 and tried == [1.5]
    assert fit.as_dict()["fitted"] is False


def _coupled(sigma_truth, b_truth):
    """A likelihood quadratic in (ln sigma, ln B) whose two figures trade off (a tilted
    bowl): one pass over each axis does not reach its minimum; rounds do."""

    def nll(sigma, b):
        u, v = np.log(sigma / sigma_truth), np.log(b / b_truth)
        return u * u + v * v + 1.2 * u * v

    return nll


@pytest.mark.parametrize("b_truth", [0.0025, 0.01, 0.03])
def test_the_receiver_drift_and_the_gyro_s_instability_are_fitted_together(monkeypatch, b_truth):
    (receiver, gyro), tried = _noise_case(monkeypatch, _coupled(2.2, b_truth), fit_b=True)
    assert receiver.fitted and gyro.fitted
    # to within half a step of each (a round that moves neither by more ends the climb)
    half = 2.0**0.25
    assert 1.0 / half < receiver.sigma_m / 2.2 < half
    assert 1.0 / half < np.degrees(gyro.instability_rad_s) / b_truth < half
    # and the likeliest setting scored
    nll = _coupled(2.2, b_truth)
    b_fit = float(np.degrees(gyro.instability_rad_s))
    assert nll(receiver.sigma_m, b_fit) == pytest.approx(min(nll(*t) for t in tried))
    assert gyro.configured_rad_s == pytest.approx(np.radians(0.01))
    assert len(tried) == len(set(tried))  # each setting scored once
    # each reports the fit and a step either side of it, scored at the other's fit
    for fit, value in ((receiver.nll, receiver.sigma_m), (gyro.nll, gyro.instability_rad_s)):
        tried_here = sorted(fit)
        assert value in fit and tried_here[0] < value < tried_here[-1]
        assert min(fit.values()) == fit[value]
        steps = np.log(sorted(fit)) / np.log(np.sqrt(2.0))
        assert (np.diff(steps) >= 0.5 - 1e-9).all()  # no two a hair apart
    for sigma, v in receiver.nll.items():
        assert v == pytest.approx(nll(sigma, b_fit))
    for b, v in gyro.nll.items():
        assert v == pytest.approx(nll(receiver.sigma_m, np.degrees(b)))
    out = gyro.as_dict()
    assert out["fitted"] is True and out["instability_deg_s"] == pytest.approx(b_fit, abs=1e-6)
    assert out["configured_instability_deg_s"] == 0.01 and out["n_windows"] == 500


def test_the_gyro_s_instability_alone_and_where_it_is_not_fitted(monkeypatch):
    (receiver, gyro), tried = _noise_case(
        monkeypatch, _coupled(1.5, 0.004), fit_sigma=False, fit_b=True
    )
    assert not receiver.fitted and receiver.sigma_m == 1.5 and {s for s, _ in tried} == {1.5}
    assert gyro.fitted and gyro.instability_rad_s > 0
    # without a gyro in the control (the wheels alone), B means nothing: held
    (receiver, gyro), tried = _noise_case(
        monkeypatch, _coupled(2.2, 0.004), fit_b=True, control="wheels"
    )
    assert receiver.fitted and not gyro.fitted
    assert all(b == pytest.approx(0.01) for _, b in tried)
    # likelier without end: B stops at its bound
    (_, gyro), _ = _noise_case(monkeypatch, lambda s, b: -b, fit_sigma=False, fit_b=True)
    assert 0.2 / np.sqrt(2.0) < np.degrees(gyro.instability_rad_s) <= 0.2
    # too few windows: both as configured, said so
    (receiver, gyro), tried = _noise_case(
        monkeypatch, _coupled(2.2, 0.004), fit_b=True, n_windows=3
    )
    assert not receiver.fitted and not gyro.fitted and len(tried) == 1
    assert gyro.n_windows == 3 and gyro.as_dict()["fitted"] is False
    # and the fit goes into the filter's settings
    from rwhonet.nav import NavConfig

    assert replace(gyro, instability_rad_s=1e-5).apply(NavConfig()).gyro.bias_instability == 1e-5


def _frame(samples_dir):
    return load_role(samples_dir, ("target_test", "source_test"), seq_len=1).frame


def test_the_filter_s_windows_on_a_straight_drive(samples_dir, params):
    frame = _frame(samples_dir)
    gnss = frame["disp_gnss_m"].to_numpy()
    n = len(frame)
    runs = [
        Odometry("exact", 1, "fused", gnss, np.full(n, 0.05**2)),
        Odometry("short", None, "wheels", 0.97 * gnss, np.full(n, 0.05**2)),
    ]
    w = filter_windows(frame, params, runs, [30, 60])
    rows = target_windows(frame, params, 30)
    assert len(w) == 2 * (len(rows) + len(target_windows(frame, params, 60)))
    mine = w[(w["model"] == "exact") & (w["outage_s"] == 30)]
    np.testing.assert_allclose(mine["distance_m"], gnss[rows].sum(axis=1))
    counted = mine[mine["counted"]]
    # due north at constant heading, exact distances: the end of every window is where the
    # GNSS puts it (its distances carry 5 cm of noise a second, its fixes none)
    assert counted["horizontal_m"].max() < 1.0
    assert np.isnan(mine.loc[~mine["counted"], "horizontal_m"]).all()
    # 3 % short: the filter learns the scale from GNSS before each outage
    short = w[(w["model"] == "short") & (w["outage_s"] == 30) & w["counted"]]
    assert short["horizontal_m"].mean() < 0.1 * 0.03 * short["distance_m"].mean()
    per_seed = position_per_seed(w, [1, 2])
    # a run the same for every seed appears once per seed; a seed's own run once
    assert set(per_seed.loc[per_seed["model"] == "short", "seed"]) == {1, 2}
    assert set(per_seed.loc[per_seed["model"] == "exact", "seed"]) == {1}
    row = per_seed[(per_seed["model"] == "exact") & (per_seed["outage_s"] == 30)].iloc[0]
    assert row["n_windows_all"] == len(rows) and row["n_windows"] == len(counted)
    # each window names the drive it starts on; split by it, the cells add up
    np.testing.assert_array_equal(mine["drive"], frame["drive"].to_numpy()[rows[:, 0]])
    drives = position_per_seed(w, [1, 2], by=("drive",))
    exact = drives[(drives["model"] == "exact") & (drives["outage_s"] == 30)]
    assert set(exact["drive"]) == set(mine["drive"])
    assert exact["n_windows"].sum() == len(counted)
    assert exact["n_windows_all"].sum() == len(rows)


def test_without_a_yaw_rate_the_gyro_and_fused_rows_are_unavailable(samples_dir, params):
    frame = _frame(samples_dir).copy()
    frame["gyro_yaw_rad"] = np.nan  # real drives without a yaw-rate channel
    choice = choose(params, {})
    plan = navigation_plan(params, choice, frame)
    assert plan["control"] == "wheels" and plan["unavailable"] == ["gyro", "fused"]
    label = frame["label_m"].to_numpy()
    preds = {
        seed: pd.DataFrame(
            {
                "G": label,
                "S": label,
                **{
                    m: label
                    for m in ("R[paper]@10", "R[paper]@20", "R[radius+G]@10", "R[radius+G]@20")
                },
                **{f"R[continuous]/{L}s": label for L in (30, 60)},
            },
            index=frame.index,
        )
        for seed in params.seeds
    }
    ev = evaluate(params, choice, frame, preds)
    assert set(ev.position["control"]) == {"wheels"}
    out = ev.eval_json
    assert out["position_controls"]["unavailable"] == ["gyro", "fused"]
    assert set(out["position_controls"]["rows"]) == {"wheels", f"wheels, {GNSS_DISTANCE}"}
    assert out["position"]["R"]["30s"]["n_windows"] > 0
    # without target training drives the variance is assumed, and says so
    assert out["uncertainty"]["fitted_on"].startswith("nothing")


def test_the_reported_settings_keep_the_fit_its_neighbours_and_the_likeliest_not_near_copies():
    # steps from the fit -> (figure, mean NLL); earlier rounds left points a hair away
    tried = {
        0.0: (1.0, 4.138),
        -1.0: (0.7, 4.142),
        -0.9: (0.72, 4.1415),  # a hair from the step below: dropped
        0.2: (1.07, 4.1379),  # a hair from the fit but likelier: kept
        1.0: (1.41, 4.142),
        1.1: (1.45, 4.143),  # dropped
        2.0: (2.0, 4.16),  # far from all: kept
        -3.0: (0.35, float("nan")),  # nothing counted there: kept, never the likeliest
    }
    got = _spaced(tried)
    assert list(got) == [0.35, 0.7, 1.0, 1.07, 1.41, 2.0]
    assert got[1.07] == 4.1379 and np.isnan(got[0.35])
