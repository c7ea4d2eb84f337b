"""Each model's distance variance: its fit, its CRSE calibration and the check on test windows."""

import numpy as np
import pandas as pd
import pytest
from scipy.stats import foldnorm

from rwhonet.evaluation.uncertainty import (
    ASSUMED,
    HALF_NORMAL_MEAN,
    MIN_BEFORE_M,
    DistanceVariance,
    FitEvidence,
    Seen,
    complete_windows,
    crse_check,
    fit_conditioned_crse,
    fit_crse,
    fit_model,
    fit_scale_sd,
    fit_variance,
    fit_window_model,
    folded_moments,
    gaussian_nll,
    held_out_tail,
    masked_windows,
    scale_before,
    scale_left,
    training_errors,
)
from rwhonet.stages.sample_files import load_role


def test_the_variance_fit_recovers_a_known_floor_and_share_of_the_distance():
    rng = np.random.default_rng(0)
    d = rng.uniform(0.0, 30.0, 40_000)
    a, b = 0.03**2, 0.008**2
    e = rng.normal(0.0, np.sqrt(a + b * d * d))
    fa, fb = fit_variance(e, d)
    assert fa == pytest.approx(a, rel=0.05) and fb == pytest.approx(b, rel=0.05)
    # the maximum of the likelihood: no nearby (a, b) explains the errors better
    best = gaussian_nll(e, fa + fb * d * d)
    for da, db in ((1.1, 1.0), (0.9, 1.0), (1.0, 1.1), (1.0, 0.9)):
        assert gaussian_nll(e, fa * da + fb * db * d * d) > best


def test_a_distance_free_error_fits_a_floor_and_too_few_seconds_fit_nothing():
    rng = np.random.default_rng(1)
    d = rng.uniform(0.0, 30.0, 5000)
    a, b = fit_variance(rng.normal(0.0, 0.05, 5000), d)
    assert a == pytest.approx(0.05**2, rel=0.1) and b * 30.0**2 < 0.15 * a
    with pytest.raises(ValueError, match="30 seconds"):
        fit_variance(np.zeros(29), np.ones(29))
    e = np.r_[np.full(20, np.nan), rng.normal(0.0, 0.05, 40)]  # NaN seconds left out
    assert fit_variance(e, np.ones(60))[0] == pytest.approx(0.05**2, rel=0.5)


def test_the_crse_calibration_by_hand():
    # CRSE = 2 Σσ exactly on every window: alpha 2, kappa 0, no lasting part
    fitted = fit_crse(np.array([2.0, 4.0, 6.0]), np.array([1.0, 2.0, 3.0]), np.ones(3))
    assert fitted == pytest.approx((2.0, 0.0, 0.0))
    # c = (1, 3), m = (1, 1), v = (1, 1): alpha = mean 2, kappa² = mean((±1)²) = 1; with
    # m² = v on every window the two parts cannot be told apart: the closed form is kept
    fitted = fit_crse(np.array([1.0, 3.0]), np.ones(2), np.ones(2))
    assert fitted == pytest.approx((2.0, 1.0, 0.0))


def _crse_windows(rng, kappa, lasting, n=400):
    """Windows of 30 to 180 one-metre seconds (m = L, v = L) with CRSE ~ N(0.8 m, κ² v + λ² m²)."""
    m = rng.choice([30.0, 60.0, 120.0, 180.0], n)
    sd = np.sqrt(kappa**2 * m + (lasting * m) ** 2)
    return 0.8 * m + rng.normal(0.0, 1.0, n) * sd, m, m


def test_the_crse_calibration_recovers_a_lasting_part():
    rng = np.random.default_rng(3)
    alpha, kappa, lasting = fit_crse(*_crse_windows(rng, 1.5, 0.1))
    assert alpha == pytest.approx(0.8, abs=0.02)
    assert kappa == pytest.approx(1.5, rel=0.2) and lasting == pytest.approx(0.1, rel=0.2)
    # the spread grows as the length itself, not its square root: the long windows' spread
    fit = DistanceVariance(1.0, 0.0, crse_scale=alpha, crse_spread=kappa, crse_lasting=lasting)
    _, sd = fit.crse(np.zeros((1, 180)))
    assert sd[0] == pytest.approx(np.sqrt(1.5**2 * 180 + (0.1 * 180) ** 2), rel=0.2)


def test_independent_windows_get_no_lasting_part():
    rng = np.random.default_rng(4)
    alpha, kappa, lasting = fit_crse(*_crse_windows(rng, 1.5, 0.0))
    assert kappa == pytest.approx(1.5, rel=0.1) and lasting < 0.02


def test_the_crse_check_of_a_hand_computed_case():
    # one second per window, sigma 1 m (a = 1, b = 0): the calibrated prediction is
    # N(alpha, kappa²) = N(1, 0.5²) for CRSE = |e|: |e| of 1.2, 0.3, 2.2, 1.0 are 0.4, 1.4,
    # 2.4 and 0 sigma from it: 2 of 4 within 1 sigma, 3 of 4 within 2
    fit = DistanceVariance(1.0, 0.0, crse_scale=1.0, crse_spread=0.5)
    e = np.array([1.2, -0.3, 2.2, -1.0])
    out = crse_check(e, np.zeros(4), np.arange(4)[:, None], fit)
    assert out["cover_1sigma"] == 0.5 and out["cover_2sigma"] == 0.75
    z = (np.abs(e) - 1.0) / 0.5
    assert out["nll"] == pytest.approx(np.mean(0.5 * np.log(2 * np.pi * 0.25) + 0.5 * z * z))
    # per second: |e| within 1 sigma (1 m): 1.2 no, 0.3 yes, 2.2 no, 1.0 yes
    assert out["second_cover_1sigma"] == 0.5 and out["second_cover_2sigma"] == 0.75
    assert out["n_windows"] == 4


def test_a_window_with_a_missing_second_is_not_checked():
    fit = DistanceVariance(1.0, 0.0)
    e = np.array([0.1, np.nan, 0.2, 0.3])
    assert crse_check(e, np.ones(4), np.array([[0, 1], [2, 3]]), fit)["n_windows"] == 1


def _frame(sizes):
    group = np.repeat(np.arange(len(sizes)), sizes)
    return pd.DataFrame({"group": group})


def test_windows_over_a_mask_and_the_held_out_tail():
    frame = _frame([100, 50])
    tail = held_out_tail(frame, 0.1)
    assert tail.sum() == 10 + 5 and tail[90:100].all() and tail[145:].all() and not tail[:90].any()
    mask = np.r_[np.zeros(20, bool), np.ones(80, bool), np.ones(50, bool)]
    rows = masked_windows(frame, mask, 30)
    # 80 masked seconds of the first segment: 2 windows from row 20; 50 of the second: 1
    np.testing.assert_array_equal(rows[:, 0], [20, 50, 100])
    every_10 = masked_windows(frame, mask, 30, 10)  # the 2D calibration's overlapping windows
    np.testing.assert_array_equal(every_10[:, 0], [20, 30, 40, 50, 60, 70, 100, 110, 120])
    np.testing.assert_array_equal(every_10[1], np.arange(30, 60))


def test_the_scale_a_filter_learns_before_a_window_is_taken_out():
    # 1 % short on every second: once the scale is learnt from the seconds before, nothing is
    # left; the first window of a segment has no seconds before it and keeps its 1 %
    d = np.full(200, 10.0)
    e = 0.01 * d
    group = np.repeat([0, 1], 100)
    rows = np.array([np.arange(50, 80), np.arange(100, 130)])
    left = scale_left(e, d, group, rows)
    assert left == pytest.approx([0.0, 3.0])


def test_a_lasting_error_gets_its_outage_factor_and_an_unfitted_model_the_assumed_variance():
    rng = np.random.default_rng(2)
    n = 3000
    frame = _frame([n])
    d = rng.uniform(5.0, 15.0, n)
    # white noise plus a slow wander: summed over 60 s it is far above sqrt(60) sigma
    wander = np.repeat(rng.normal(0.0, 0.05, n // 60), 60)
    e = rng.normal(0.0, 0.03, n) + wander
    windows = {L: masked_windows(frame, np.ones(n, bool), L) for L in (10, 60)}
    fit = fit_model(e, d, np.ones(n, bool), windows, frame["group"].to_numpy())
    assert fit.outage_scale[60] > 5.0 * fit.outage_scale[10] > 5.0
    np.testing.assert_allclose(fit.outage_var(d, 60), fit.outage_scale[60] * fit.var(d))
    np.testing.assert_allclose(fit.outage_var(d, 30), fit.var(d))  # no factor for 30 s
    assert fit.n_windows == len(windows[10]) + len(windows[60])
    assert fit_model(e[:10], d[:10], np.ones(10, bool), {}, np.zeros(10)) is None
    assert ASSUMED.var(np.array([10.0])) == pytest.approx(0.05**2 + 0.1**2)


# ----------------------------------------------------------------- conditioned on the drive so far


def test_the_folded_normal_moments_are_scipys():
    mu = np.array([0.0, 0.3, -1.0, 2.5, 10.0])
    sd = np.array([1.0, 0.5, 2.0, 1.0, 0.1])
    mean, var = folded_moments(mu, sd)
    want_mean, want_var = foldnorm.stats(np.abs(mu) / sd, scale=sd, moments="mv")
    np.testing.assert_allclose(mean, want_mean, rtol=1e-9)
    np.testing.assert_allclose(var, want_var, rtol=1e-6, atol=1e-12)
    # μ = 0: the half normal, σ √(2/π) and σ² (1 − 2/π)
    assert mean[0] == pytest.approx(np.sqrt(2 / np.pi)) and var[0] == pytest.approx(1 - 2 / np.pi)


def test_the_scale_seen_before_a_window_by_hand():
    # 10 m seconds, 1 % short and σ² = 0.04 m² each; segment 0 rows 0-99, segment 1 100-199
    d = np.full(200, 10.0)
    e = 0.01 * d
    e[5] = np.nan  # a second without GNSS counts neither its error nor its distance
    var = np.full(200, 0.04)
    group = np.repeat([0, 1], 100)
    rows = np.array([np.arange(50, 80), np.arange(100, 130)])
    seen = scale_before(e, d, var, group, rows)
    # window 0: 49 seconds before it (row 5 left out): ŝ = 4.9 / 490, v = 49 · 0.04 / 490²
    assert seen.scale[0] == pytest.approx(0.01) and seen.dist_m[0] == pytest.approx(490.0)
    assert seen.var[0] == pytest.approx(49 * 0.04 / 490.0**2)
    # window 1 opens its segment: nothing seen
    assert seen.scale[1] == 0.0 and np.isinf(seen.var[1]) and seen.dist_m[1] == 0.0


def test_the_spread_of_lasting_scales_is_recovered_and_noise_alone_gives_none():
    rng = np.random.default_rng(5)
    n = 4000
    v = rng.uniform(1e-6, 4e-6, n)  # noise sd 0.1-0.2 %
    lasting = rng.normal(0.0, 0.004, n)
    far = np.full(n, 500.0)
    seen = Seen(lasting + rng.normal(0.0, np.sqrt(v)), v, far)
    assert fit_scale_sd(seen) == pytest.approx(0.004, rel=0.05)
    assert fit_scale_sd(Seen(rng.normal(0.0, np.sqrt(v)), v, far)) < 0.0005
    # windows with under MIN_BEFORE_M before them do not count
    assert fit_scale_sd(Seen(seen.scale, v, np.full(n, MIN_BEFORE_M - 1.0))) == 0.0


def test_the_kept_scale_shrinks_with_what_was_seen():
    fit = DistanceVariance(0.01, 0.0, scale_sd=0.005)
    seen = Seen(np.array([0.01, 0.01, 0.01]), np.array([0.0, 0.005**2, np.inf]), np.ones(3))
    # all of a sure one, half of one as uncertain as the spread itself, none of nothing seen
    np.testing.assert_allclose(fit.kept_scale(seen), [0.01, 0.005, 0.0])
    # no spread (τ = 0) or nothing seen: the unconditioned sums Σσ, Σσ²
    d = np.full((3, 30), 10.0)
    for f, s in ((DistanceVariance(0.01, 0.0), seen), (fit, None)):
        total, sq = f.crse_sums(d, s)
        np.testing.assert_allclose(total, 30 * 0.1) and np.testing.assert_allclose(sq, 30 * 0.01)


def _drives_with_their_own_scale(rng, scales, seconds=600):
    """Segments of 10 m seconds, each with its own lasting scale error and 5 cm white noise."""
    group = np.repeat(np.arange(len(scales)), seconds)
    d = np.full(len(group), 10.0) + rng.uniform(-2.0, 2.0, len(group))
    e = np.asarray(scales)[group] * d + rng.normal(0.0, 0.05, len(group))
    return e, d, group


def test_a_drive_with_a_scale_error_no_training_drive_has_is_predicted_from_its_own_seconds():
    rng = np.random.default_rng(6)
    e, d, group = _drives_with_their_own_scale(rng, rng.normal(0.0, 0.003, 40))
    frame = pd.DataFrame({"group": group})
    mask = frame.groupby("group").cumcount().to_numpy() >= 100  # each drive's first 100 s out
    windows = {L: masked_windows(frame, mask, L) for L in (30, 60)}
    fit = fit_model(e, d, mask, windows, group)
    assert fit.scale_sd == pytest.approx(0.003, rel=0.3)
    # a test drive 1.5 % off, five times the training drives' spread
    te, td, tg = _drives_with_their_own_scale(rng, [0.015])
    rows = masked_windows(pd.DataFrame({"group": tg}), np.arange(600) >= 100, 60)
    conditioned = crse_check(te, td, rows, fit, tg)
    assert conditioned["cover_2sigma"] == 1.0 and conditioned["nll"] < 3.0
    # without its own seconds the prediction misses every window
    assert crse_check(te, td, rows, fit)["cover_2sigma"] == 0.0


def test_without_a_spread_of_scales_the_conditioned_fit_is_the_plain_one():
    rng = np.random.default_rng(7)
    c, m, v = _crse_windows(rng, 1.5, 0.1)
    d = np.ones((len(m), 1))
    seen = Seen(np.zeros(len(m)), np.full(len(m), np.inf), np.zeros(len(m)))
    fit = DistanceVariance(1.0, 0.0)  # τ = 0: nothing kept
    # M, V = Σσ, Σσ² = 1, 1 for these one-second windows; c/m scaled back to them
    got = fit_conditioned_crse(fit, c / m, [(d, seen)])
    assert got == pytest.approx(fit_crse(c / m, np.ones(len(m)), np.ones(len(m))))


def test_a_model_off_by_the_same_scale_on_every_drive_gets_a_finite_calibration():
    # the source car's WPM on a larger car: 8 % short on every drive, ± 0.3 % between drives
    rng = np.random.default_rng(8)
    e, d, group = _drives_with_their_own_scale(rng, rng.normal(0.08, 0.003, 40))
    frame = pd.DataFrame({"group": group})
    mask = frame.groupby("group").cumcount().to_numpy() >= 100
    windows = {L: masked_windows(frame, mask, L) for L in (30, 60)}
    fit = fit_model(e, d, mask, windows, group)
    assert fit.scale_sd == pytest.approx(0.08, rel=0.05)
    assert 0.2 < fit.crse_scale < 2.0 and np.isfinite(fit.crse_spread)
    te, td, tg = _drives_with_their_own_scale(rng, [0.081])
    rows = masked_windows(pd.DataFrame({"group": tg}), np.arange(600) >= 100, 30)
    check = crse_check(te, td, rows, fit, tg)
    assert check["cover_2sigma"] >= 0.9 and check["nll"] < 3.0


def test_a_continuous_recipe_is_fitted_on_its_errors_inside_each_length_s_windows():
    """Its distances exist only inside windows, one set per length: a and b on every
    length's window seconds together, the CRSE calibrated on those windows and not
    conditioned on the seconds before them (the recipe refitted on them)."""
    rng = np.random.default_rng(11)
    n = 600
    gnss = rng.uniform(5.0, 15.0, n)
    windows = {30: np.arange(600).reshape(20, 30), 60: np.arange(600).reshape(10, 60)}
    errors = {}
    for L, rows in windows.items():
        e = np.full(n, np.nan)  # each length's own predictions, inside its windows
        e[rows.ravel()] = rng.normal(0.0, 0.05, rows.size)
        errors[L] = e
    errors[60][65] = np.nan  # a second without a prediction: its 60 s window is left out
    fit = fit_window_model(errors, gnss, windows)
    assert fit.n_windows == 20 + 9 and fit.n_seconds == 600 + 540
    assert fit.scale_sd == 0.0 and fit.outage_scale == {}
    kept = {30: windows[30], 60: np.delete(windows[60], 1, axis=0)}
    e_all = np.concatenate([errors[L][r].ravel() for L, r in kept.items()])
    d_all = np.concatenate([(gnss - errors[L])[r].ravel() for L, r in kept.items()])
    assert (fit.a_m2, fit.b) == pytest.approx(fit_variance(e_all, d_all))
    sd = {L: np.sqrt(fit.var((gnss - errors[L])[r])) for L, r in kept.items()}
    by_hand = fit_crse(
        np.concatenate([np.abs(errors[L][r]).sum(axis=1) for L, r in kept.items()]),
        np.concatenate([s.sum(axis=1) for s in sd.values()]),
        np.concatenate([(s * s).sum(axis=1) for s in sd.values()]),
    )
    assert (fit.crse_scale, fit.crse_spread, fit.crse_lasting) == pytest.approx(by_hand)
    assert fit.crse_scale == pytest.approx(HALF_NORMAL_MEAN, rel=0.1)  # independent seconds
    # too few seconds with a prediction: nothing fitted
    few = {30: np.where(np.arange(n) < 20, 0.05, np.nan)}
    assert fit_window_model(few, gnss, {30: windows[30]}) is None


def test_a_continuous_recipe_s_training_errors_are_one_array_per_length(samples_dir, params):
    frame = load_role(samples_dir, "target_train", seq_len=1).frame
    label = frame["label_m"].to_numpy()
    cols = {"G": label - 0.1, **{f"R[continuous]/{L}s": label - 0.01 * L for L in (30, 60)}}
    evidence = FitEvidence(frame, {1: pd.DataFrame(cols, index=frame.index)})
    got = {t.model: t for t in training_errors(evidence, ["G", "R[continuous]"], params)}
    assert not got["G"].per_window and got["G"].error == pytest.approx(np.full(len(label), 0.1))
    assert got["R[continuous]"].per_window and set(got["R[continuous]"].error) == {30, 60}
    assert got["R[continuous]"].error[60] == pytest.approx(np.full(len(label), 0.6))
    assert (got["R[continuous]"].mask == got["G"].mask).all()  # the scored seconds
    # a model with only some of its lengths' columns is not fitted as one
    cols.pop("R[continuous]/60s")
    evidence = FitEvidence(frame, {1: pd.DataFrame(cols, index=frame.index)})
    assert [t.model for t in training_errors(evidence, ["R[continuous]"], params)] == []


def test_complete_windows_keeps_the_windows_with_every_second_finite():
    values = np.array([1.0, 2.0, np.nan, 4.0, 5.0, np.inf])
    rows = np.array([[0, 1], [1, 2], [3, 4], [4, 5]])
    assert complete_windows(values, rows).tolist() == [[0, 1], [3, 4]]
    assert complete_windows(values, rows[:0]).shape == (0, 2)
    assert complete_windows(np.full(6, np.nan), rows).shape == (0, 2)
