"""The navigation filter: its model's derivatives, exactness, bias recovery and consistency."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.stats import chi2, multivariate_normal

from rwhonet.config import SimDrive, SimLeak
from rwhonet.features.deadreckoning import wheel_yaw_rad
from rwhonet.nav import (
    SIGMA_CONTENT,
    GnssSpec,
    GyroSpec,
    NavConfig,
    NavInputs,
    WheelSpec,
    coverage_2d,
    run,
    run_outage,
)
from rwhonet.nav.filter import (
    BD,
    BDW,
    BW,
    CONTROLS,
    DELTA,
    PSI,
    SD,
    S,
    course_model,
    fix_log_score,
    fix_model,
    propagate,
    sinc_half,
)
from rwhonet.sim import vehicles_from_params
from support.navsim import drive_seconds

from .conftest import antenna, model_drives

LEVER = (1.1, -0.3)


def _numeric_jacobian(f, x, eps=1e-6):
    cols = []
    for j in range(x.shape[1]):
        up, down = x.copy(), x.copy()
        up[:, j] += eps
        down[:, j] -= eps
        cols.append((f(up) - f(down)) / (2 * eps))
    return np.stack(cols, axis=-1)


def _random_augmented(rng, w=6):
    xa = rng.normal(0.0, 1.0, (w, S + 1))
    xa[:, PSI] = rng.uniform(-np.pi, np.pi, w)
    xa[:, DELTA] = rng.normal(0.0, 0.3, w)
    xa[:, SD] = 1.0 + rng.normal(0.0, 0.05, w)
    return xa, rng.uniform(0.5, 25.0, w)


def test_the_arc_and_its_jacobian():
    rng = np.random.default_rng(0)
    xa, d = _random_augmented(rng)
    new, jac, ge, gn = propagate(xa, d)
    assert np.allclose(jac, _numeric_jacobian(lambda x: propagate(x, d)[0], xa), atol=1e-6)
    # the distance's noise moves the position along the chord
    assert np.allclose(np.hypot(ge, gn), sinc_half(xa[:, DELTA])[0])
    # a full circle in 36 one-second arcs closes
    x = np.zeros((1, S + 1))
    x[0, SD] = 1.0
    for _ in range(36):
        x[0, DELTA] = np.radians(10.0)
        x = propagate(x, np.array([10.0]))[0]
    assert np.hypot(x[0, 0], x[0, 1]) < 1e-9


def test_the_course_and_fix_models_and_their_jacobians():
    rng = np.random.default_rng(1)
    xa, d = _random_augmented(rng)
    h, jac = course_model(xa, d, LEVER)
    num = _numeric_jacobian(lambda x: course_model(x, d, LEVER)[0], xa)
    assert np.allclose(jac, num, atol=1e-6)
    h2, jac2 = fix_model(xa, LEVER)
    num2 = _numeric_jacobian(lambda x: fix_model(x, LEVER)[0], xa)
    assert np.allclose(jac2, num2, atol=1e-6)
    # without a lever arm the chord points along the arc's middle
    h0, _ = course_model(xa, d, (0.0, 0.0))
    mid = xa[:, PSI] + 0.5 * xa[:, DELTA]
    assert np.allclose(np.cos(h0 - mid), 1.0)


@pytest.mark.parametrize("control", ["wheels", "gyro", "fused"])
def test_perfect_odometry_and_heading_end_where_the_car_is(control):
    # Every sensor exact, the prior means exact: every innovation is zero, so the
    # filter dead-reckons the truth itself, to rounding, through a 180 s outage.
    rng = np.random.default_rng(2)
    cfg = NavConfig(antenna_m=LEVER)
    inputs, truth = model_drives(rng, cfg, 5, 480, exact=True)
    out = run_outage(inputs, 300, cfg, control)
    assert out.calibrated.all()
    assert np.max(out.horizontal_m) < 1e-6, out.horizontal_m
    # ... which is the antenna's place at the end, as the test's own arcs put it
    ant = antenna(truth.e[:, -1], truth.n[:, -1], truth.psi[:, -1], LEVER)
    assert np.allclose(out.end_m, np.stack(ant, axis=1), atol=1e-6)
    assert np.allclose(out.truth_m, out.end_m, atol=1e-6)


def _straight_with_bias(bias_deg_s, rng, w=20, n=600):
    """600 s straight on at 15 m/s; the gyro reads a constant bias plus its noise."""
    gyro = GyroSpec(bias_instability=0.0, temp_drift_per_k=0.0)
    cfg = NavConfig(gyro=gyro, gnss=GnssSpec(sigma_m=1.0, tau_s=120.0, white_m=0.3))
    d = np.full((w, n), 15.0)
    psi0 = rng.uniform(-np.pi, np.pi, w)
    e = np.cumsum(np.tile(np.sin(psi0)[:, None] * 15.0, n), axis=1)
    nn = np.cumsum(np.tile(np.cos(psi0)[:, None] * 15.0, n), axis=1)
    fix_e = np.c_[np.zeros(w), e] + rng.normal(0.0, 0.3, (w, n + 1))
    fix_n = np.c_[np.zeros(w), nn] + rng.normal(0.0, 0.3, (w, n + 1))
    y_g = np.radians(bias_deg_s) + rng.normal(0.0, gyro.yaw_sd_rad(), (w, n))
    y_w = rng.normal(0.0, WheelSpec().yaw_sd_rad(), (w, n))
    return cfg, NavInputs(d, np.full((w, n), 0.01), y_w, y_g, fix_e, fix_n)


@pytest.mark.parametrize("control", ["gyro", "fused"])
def test_a_straight_drive_recovers_a_known_gyro_bias_before_the_outage(control):
    cfg, inputs = _straight_with_bias(0.4, np.random.default_rng(3))
    track = run(inputs, cfg, control, keep_cov=True)
    bias = np.degrees(track.x[:, -1, 3])
    sd = np.degrees(np.sqrt(track.cov[:, -1, 3, 3]))
    assert np.all(sd < 0.01), sd  # known to a hundredth of a degree per second
    assert np.all(np.abs(bias - 0.4) < 4 * sd), (bias, sd)
    assert np.mean(np.abs(bias - 0.4)) < 0.005
    # the wheels alone cannot see a gyro's bias: it stays at its prior
    wheels = run(inputs, cfg, "wheels", keep_cov=True)
    assert np.allclose(wheels.x[:, -1, 3], 0.0)


@pytest.mark.parametrize("control", ["wheels", "gyro", "fused"])
def test_the_filter_is_consistent_on_its_own_model(control):
    # 200 Monte-Carlo drives from the filter's own error model: the normalised
    # estimation error squared of (east, north, heading), averaged over the runs, must lie
    # in the two-sided 99 % chi-square interval at the end of calibration and at the end
    # of the 180 s outage.
    rng = np.random.default_rng(4)
    cfg = NavConfig(
        antenna_m=LEVER,
        load_sd=0.0005,  # keeps 1 + c d² near 1: the linearisation's domain
        load_min=-1.0,  # the model draws c of either sign: no projection onto c >= 0
        wheels=dataclasses.replace(WheelSpec(), model_rel=0.0),
        gnss=GnssSpec(sigma_m=1.2, tau_s=120.0, white_m=0.3),
    )
    m, cal, outage = 200, 300, 180
    inputs, truth = model_drives(rng, cfg, m, cal + outage)
    fe, fn = inputs.fix_e_m.copy(), inputs.fix_n_m.copy()
    fe[:, cal + 1 :] = np.nan
    fn[:, cal + 1 :] = np.nan
    masked = dataclasses.replace(inputs, fix_e_m=fe, fix_n_m=fn)
    track = run(masked, cfg, control, keep_cov=True)
    lo, hi = chi2.ppf([0.005, 0.995], 3 * m) / m
    for k in (cal - 1, cal + 59, cal + outage - 1):
        err = np.stack(
            [
                track.x[:, k, 0] - truth.e[:, k],
                track.x[:, k, 1] - truth.n[:, k],
                np.angle(np.exp(1j * (track.x[:, k, PSI] - truth.psi[:, k]))),
            ],
            axis=1,
        )
        cov = track.cov[:, k][:, [0, 1, PSI]][:, :, [0, 1, PSI]]
        nees = np.einsum("wi,wi->w", err, np.linalg.solve(cov, err[..., None])[..., 0])
        assert lo <= nees.mean() <= hi, (k, nees.mean(), lo, hi)


def test_a_control_and_the_input_shapes_are_checked():
    cfg, inputs = _straight_with_bias(0.0, np.random.default_rng(5), w=2, n=20)
    with pytest.raises(ValueError, match="control"):
        run(inputs, cfg, "compass")
    with pytest.raises(ValueError, match="fix_e_m"):
        NavInputs(
            inputs.dist_m,
            inputs.dist_var_m2,
            inputs.wheel_yaw_rad,
            inputs.gyro_yaw_rad,
            inputs.fix_e_m[:, 1:],
            inputs.fix_n_m,
        )


def test_rows_start_on_their_first_course_and_a_missing_sensor_is_no_measurement():
    cfg, inputs = _straight_with_bias(0.2, np.random.default_rng(6), w=2, n=60)
    fe = inputs.fix_e_m.copy()
    fe[1, :11] = np.nan  # the second drive's first fixes are missing
    y_w = inputs.wheel_yaw_rad.copy()
    y_w[:, 30:] = np.nan  # and the wheels stop reporting
    track = run(dataclasses.replace(inputs, fix_e_m=fe, wheel_yaw_rad=y_w), cfg, "fused")
    assert track.started[0].all()
    assert not track.started[1, :10].any() and track.started[1, 11:].all()
    assert np.isfinite(track.x[:, -1]).all()


def test_a_filter_that_lost_the_car_starts_its_pose_afresh_on_gnss():
    # The wheels alone, exact but for 25 s in which they count every turn the wrong way
    # round (wheel speeds are magnitudes: a reversing manoeuvre). The heading goes wrong,
    # the fixes fall outside the gate one after the other; after reset_after_s refusals the
    # pose restarts on GNSS and the filter tracks the car again.
    rng = np.random.default_rng(7)
    cfg = NavConfig(gnss=GnssSpec(sigma_m=1.0, tau_s=120.0, white_m=0.05))
    inputs, truth = model_drives(rng, cfg, 4, 400, exact=True)
    y_w = inputs.wheel_yaw_rad.copy()
    y_w[:, 200:225] *= -1.0
    track = run(dataclasses.replace(inputs, wheel_yaw_rad=y_w), cfg, "wheels")
    assert track.rejected["reset"] >= 1
    end = np.hypot(track.x[:, -1, 0] - truth.e[:, -1], track.x[:, -1, 1] - truth.n[:, -1])
    assert np.all(end < 0.5), end
    # without the reset the filter never recovers
    stuck = run(
        dataclasses.replace(inputs, wheel_yaw_rad=y_w),
        dataclasses.replace(cfg, reset_after_s=10**6),
        "wheels",
    )
    lost = np.hypot(stuck.x[:, -1, 0] - truth.e[:, -1], stuck.x[:, -1, 1] - truth.n[:, -1])
    assert np.max(lost) > 10.0, lost


def test_a_warming_gyro_s_bias_ramp_is_learnt_before_the_outage_and_carried_through_it():
    """The bias moves at a rate decaying with the warm-up (the simulator's ESC gyro): the
    filter's drift-rate state learns the rate from GNSS and extrapolates it; a filter
    without that state is off by the ramp through the outage, beyond what it predicts."""
    rng = np.random.default_rng(11)
    w, n, outage = 20, 600, 180
    gyro = GyroSpec(
        bias_instability=1e-9,
        temp_drift_per_k=np.radians(0.01),
        warm_rate_k_s=0.025,
        warm_tau_s=600.0,
    )
    cfg = NavConfig(gyro=gyro, gnss=GnssSpec(sigma_m=1.0, tau_s=120.0, white_m=0.3))
    rate0 = gyro.drift_rate_sd() * rng.choice([-1.0, 1.0], w)  # one sigma, either sign
    t = np.arange(n + outage)
    bias = np.radians(0.3) + rate0[:, None] * 600.0 * (1.0 - np.exp(-t / 600.0))
    psi0 = rng.uniform(-np.pi, np.pi, w)
    step_e, step_n = np.sin(psi0)[:, None] * 15.0, np.cos(psi0)[:, None] * 15.0
    e = np.c_[np.zeros(w), np.cumsum(np.tile(step_e, n + outage), axis=1)]
    nn = np.c_[np.zeros(w), np.cumsum(np.tile(step_n, n + outage), axis=1)]
    inputs = NavInputs(
        np.full((w, n + outage), 15.0),
        np.full((w, n + outage), 0.01),
        rng.normal(0.0, WheelSpec().yaw_sd_rad(), (w, n + outage)),
        bias + rng.normal(0.0, gyro.yaw_sd_rad(), (w, n + outage)),
        e + rng.normal(0.0, 0.3, e.shape),
        nn + rng.normal(0.0, 0.3, nn.shape),
    )
    track = run(inputs, cfg, "gyro", keep_cov=True)
    rate = track.x[:, n - 1, BD]
    sd = np.sqrt(track.cov[:, n - 1, BD, BD])
    truth = rate0 * np.exp(-(n - 1) / 600.0)
    assert np.all(np.abs(rate - truth) < 4 * sd) and np.all(sd < 0.2 * np.abs(truth))
    with_ramp = run_outage(inputs, n, cfg, "gyro")
    without = run_outage(
        inputs,
        n,
        dataclasses.replace(cfg, gyro=dataclasses.replace(gyro, warm_rate_k_s=0.0)),
        "gyro",
    )
    assert np.mean(with_ramp.horizontal_m) < 0.5 * np.mean(without.horizontal_m)
    inside = coverage_2d(with_ramp.error_m, with_ramp.cov_m2)[SIGMA_CONTENT[1]]
    outside = coverage_2d(without.error_m, without.cov_m2)[SIGMA_CONTENT[1]]
    assert inside >= 0.85 and outside <= 0.5, (inside, outside)


def test_the_filter_s_defaults_are_the_shipped_generic_sensor_figures():
    """One set of generic automotive figures: params.yaml's evaluate.navigation (what the
    evaluation runs with) and the filter's defaults (what `rwhonet predict` runs with
    outside a project)."""
    from rwhonet import paths
    from rwhonet.config import load_params
    from rwhonet.nav import config_from_params

    nav = load_params(paths.PARAMS).evaluate.navigation
    wheels = WheelSpec()
    shipped = config_from_params(nav, wheels.radius_m, wheels.track_rear_m)
    for field in ("gyro", "wheels", "gnss", "antenna_m"):
        got, default = getattr(shipped, field), getattr(NavConfig(), field)
        if field == "antenna_m":
            assert got == default
            continue
        for name, value in dataclasses.asdict(default).items():
            assert getattr(got, name) == pytest.approx(value), (field, name)


def _reversing_drive(rng, w=8, gps_s=120, straight=False, told=False):
    """Forward S-bends with GNSS, then in the outage a stop, 12 s reversing at 2 m/s
    (4 s straight, then round a bend; ``straight``: straight throughout), a stop and
    forward again; exact sensors, wheel speeds as magnitudes (``told``: the log says
    which seconds went backwards, as a logger that signs its wheel speeds does)."""
    signed = np.r_[
        np.full(gps_s, 10.0),
        np.full(20, 8.0),
        [1.0, 0.0],
        np.full(12, -2.0),
        [0.0, 1.0],
        np.full(30, 8.0),
    ]
    n = signed.size
    turn = 0.04 * np.sin(np.arange(n) / 15.0)
    # reversing: 4 s straight back, then steering (the body turns left)
    turn[gps_s + 22 : gps_s + 26] = 0.0
    turn[gps_s + 26 : gps_s + 34] = 0.0 if straight else 0.08
    delta = np.tile(turn, (w, 1)) * rng.uniform(0.8, 1.2, (w, 1))
    d_signed = np.tile(signed, (w, 1))
    psi = np.empty((w, n + 1))
    psi[:, 0] = rng.uniform(-np.pi, np.pi, w)
    e, nn = np.zeros((w, n + 1)), np.zeros((w, n + 1))
    for k in range(n):
        mid = psi[:, k] - 0.5 * delta[:, k]
        chord = d_signed[:, k] * sinc_half(delta[:, k])[0]
        e[:, k + 1] = e[:, k] + chord * np.sin(mid)
        nn[:, k + 1] = nn[:, k] + chord * np.cos(mid)
        psi[:, k + 1] = psi[:, k] - delta[:, k]
    # the rear wheels' yaw from magnitudes: reversing counts the turn the wrong way round
    wheel = np.where(d_signed >= 0, delta, -delta)
    back = d_signed < 0 if told else None
    inputs = NavInputs(np.abs(d_signed), np.full((w, n), 1e-4), wheel, delta, e, nn, back)
    return inputs, gps_s


def test_a_reversing_turn_is_told_by_the_wheels_against_the_gyro_and_driven_backwards():
    inputs, outage = _reversing_drive(np.random.default_rng(7))
    cfg = NavConfig()
    fused = run_outage(inputs, outage, cfg, "fused")
    gyro = run_outage(inputs, outage, cfg, "gyro")
    # 24 m reversed: driven forwards, the gyro-only track ends about twice that away
    assert np.all(gyro.horizontal_m > 30.0), gyro.horizontal_m
    assert np.all(fused.horizontal_m < 1.0), fused.horizontal_m
    track = run(inputs, cfg, "fused")
    # the 8 turning seconds tell it; the 4 straight ones before are turned round then
    assert track.rejected["reversing"] == 8 * inputs.dist_m.shape[0]


def test_a_straight_reverse_between_two_stops_is_driven_backwards_only_when_the_log_says_so():
    cfg = NavConfig()
    inputs, outage = _reversing_drive(np.random.default_rng(7), straight=True)
    # no turn to tell it by: 24 m reversed counted forwards, about 48 m off
    for control in CONTROLS:
        assert np.all(run_outage(inputs, outage, cfg, control).horizontal_m > 30.0), control
    assert run(inputs, cfg, "fused").rejected["reversing"] == 0
    told, outage = _reversing_drive(np.random.default_rng(7), straight=True, told=True)
    for control in CONTROLS:
        end = run_outage(told, outage, cfg, control).horizontal_m
        assert np.all(end < 1.0), (control, end)


def test_a_told_reversing_turn_is_followed_by_every_control():
    """Told which seconds went backwards, the wheels alone read their yaw from magnitudes
    as the reversed turn and follow a reversing turn too; the fused filter does not
    guess, and leaves those seconds' wheel yaw out (the gyro's turn)."""
    cfg = NavConfig()
    inputs, outage = _reversing_drive(np.random.default_rng(7))
    assert np.all(run_outage(inputs, outage, cfg, "wheels").horizontal_m > 30.0)
    told, outage = _reversing_drive(np.random.default_rng(7), told=True)
    for control in CONTROLS:
        end = run_outage(told, outage, cfg, control).horizontal_m
        assert np.all(end < 1.0), (control, end)
    track = run(told, cfg, "fused")
    assert track.rejected["reversing"] == 0 and track.rejected["wheels"] == 0


def test_the_backwards_seconds_must_match_the_windows():
    inputs, _ = _reversing_drive(np.random.default_rng(7))
    with pytest.raises(ValueError, match="backwards"):
        dataclasses.replace(inputs, backwards=np.zeros((2, 3), bool))


def test_a_straight_drive_with_noisy_sensors_is_never_taken_for_reversing():
    cfg, inputs = _straight_with_bias(0.4, np.random.default_rng(8))
    assert run(inputs, cfg, "fused").rejected["reversing"] == 0


def test_a_fix_s_log_score_is_the_gaussian_density_of_its_innovation():
    rng = np.random.default_rng(11)
    w, m = 6, 4
    a = rng.normal(size=(w, m, m))
    pa = a @ np.swapaxes(a, 1, 2) + np.eye(m)
    h_mat = rng.normal(size=(w, 2, m))
    innov = rng.normal(0.0, 2.0, (w, 2))
    innov[4] = 100.0  # a jump beyond the gate
    r_mat = np.broadcast_to(np.eye(2) * 0.3, (w, 2, 2))
    use = np.array([True, True, True, False, True, True])
    score = fix_log_score(pa, h_mat, innov, r_mat, use, gate=5.0)
    for i in (0, 1, 2, 5):
        cov = h_mat[i] @ pa[i] @ h_mat[i].T + r_mat[i]
        assert np.isclose(score[i], multivariate_normal(np.zeros(2), cov).logpdf(innov[i]))
    assert score[3] == 0.0 and score[4] == 0.0  # not used; beyond the gate


@pytest.mark.parametrize("control", ["gyro", "fused"])
def test_the_fixes_log_score_is_highest_for_the_gyro_figure_the_drives_were_drawn_with(control):
    # Drives from the filter's own model (consistent as in the NEES test above) with a
    # gyro bias instability of 0.02 deg/s: the fixes' log score summed over them
    # (NavTrack.fix_logpdf) is highest for that figure, against half and twice it; the
    # wheels alone do not read the gyro and score the same under every figure.
    rng = np.random.default_rng(12)
    gyro = GyroSpec(bias_instability=float(np.radians(0.02)))
    cfg = NavConfig(
        gyro=gyro,
        load_sd=0.0005,
        load_min=-1.0,
        wheels=dataclasses.replace(WheelSpec(), model_rel=0.0),
        gnss=GnssSpec(sigma_m=1.0, tau_s=60.0, white_m=0.3),
    )
    inputs, _ = model_drives(rng, cfg, 60, 900)
    total, wheels = {}, set()
    for factor in (0.5, 1.0, 2.0):
        b = dataclasses.replace(gyro, bias_instability=gyro.bias_instability * factor)
        track = run(inputs, dataclasses.replace(cfg, gyro=b), control)
        assert np.all(track.fix_logpdf[~track.started] == 0.0)
        total[factor] = track.fix_logpdf.sum()
        wheels.add(run(inputs, dataclasses.replace(cfg, gyro=b), "wheels").fix_logpdf.sum())
    assert total[1.0] > max(total[0.5], total[2.0]) + 50.0, total
    assert len(wheels) == 1


@pytest.mark.parametrize("control", ["wheels", "gyro", "fused"])
def test_a_second_s_added_yaw_variance_widens_the_heading_by_it(control):
    """``yaw_var_rad2`` (a second whose yaw was drawn across a logger's gap): zeros change
    nothing; a variance v on one second's gyro yaw, with no fix to correct it, widens the
    heading's variance by about v (the wheels' yaw is read through their model, scale and
    load term, so there it widens by less; fused, the two sensors share it)."""
    cfg, inputs = _straight_with_bias(0.0, np.random.default_rng(8), w=3, n=200)
    fe, fn = inputs.fix_e_m.copy(), inputs.fix_n_m.copy()
    fe[:, 150:] = fn[:, 150:] = np.nan  # an outage from second 149 on
    inputs = dataclasses.replace(inputs, fix_e_m=fe, fix_n_m=fn)
    plain = run(inputs, cfg, control, keep_cov=True)
    zeros = run(dataclasses.replace(inputs, yaw_var_rad2=np.zeros((3, 200))), cfg, control)
    np.testing.assert_array_equal(zeros.x, plain.x)
    extra = np.zeros((3, 200))
    extra[:, 160] = 0.05**2
    wide = run(dataclasses.replace(inputs, yaw_var_rad2=extra), cfg, control, keep_cov=True)
    np.testing.assert_array_equal(wide.x[:, :160], plain.x[:, :160])
    grown = wide.cov[:, -1, 2, 2] - plain.cov[:, -1, 2, 2]
    if control == "gyro":
        np.testing.assert_allclose(grown, 0.05**2, rtol=0.05)
    assert np.all(grown > 0.1 * 0.05**2) and np.all(grown < 1.05 * 0.05**2)
    with pytest.raises(ValueError, match="yaw_var_rad2"):
        dataclasses.replace(inputs, yaw_var_rad2=np.zeros((3, 5)))


def _leaking(rng, cfg, w, n, ramp):
    """Drives of the filter's own model whose rear wheels' bias per metre also ramps by
    ``ramp`` rad/m per s (a rear tyre losing air: 4 psi/h is about 3e-7)."""
    inputs, _ = model_drives(rng, cfg, w, n)
    t = np.arange(n)
    return dataclasses.replace(
        inputs, wheel_yaw_rad=inputs.wheel_yaw_rad - ramp * t * inputs.dist_m
    )


@pytest.mark.parametrize("control", CONTROLS)
def test_the_leak_rate_state_is_inert_unless_given_a_prior(control):
    cfg = NavConfig(gnss=GnssSpec(sigma_m=1.0, tau_s=60.0, white_m=0.3))
    inputs = _leaking(np.random.default_rng(21), cfg, 6, 300, 3e-7)
    track = run(inputs, cfg, control, keep_cov=True)
    assert np.all(track.x[:, :, BDW][track.started] == 0.0)
    assert np.all(track.cov[:, :, BDW, :][track.started] == 0.0)
    on = run(inputs, dataclasses.replace(cfg, leak_per_h=0.002), control)
    assert (control == "gyro") == np.allclose(on.x[:, -1, BW], track.x[:, -1, BW])


def test_a_leaking_tyre_s_ramp_is_learnt_and_the_wheel_yaw_s_score_tells_it(project_params):
    # A 40 min simulated drive of the target car (tyre state C), with and without its
    # rear-left tyre losing 4 psi/h, filtered fused on the true travel with GNSS
    # throughout. With the leak-rate state the filter's rate of beta at the end is the
    # leak's ramp (the two drives' wheel-yaw difference fitted on d t), and none without
    # the leak; the wheel yaw's log score over the drive (NavTrack.wheel_logpdf) is higher
    # with the state than without it on the leaking drive, lower on the other.
    car = vehicles_from_params(project_params)["target"]
    p, r = car.params, car.nominal_radius_m
    base = NavConfig(
        wheels=WheelSpec(radius_m=r, track_rear_m=p.track_rear_m),
        gnss=GnssSpec(sigma_m=p.gnss.sigma_m, tau_s=p.gnss.tau_s, white_m=0.05),
    )
    state = dataclasses.replace(base, leak_per_h=0.002)
    spec = SimDrive(
        name="K-1",
        role="target_test",
        vehicle="target",
        tyre="C",
        duration_s=2400.0,
        roads={"urban": 0.5, "country": 0.5},
    )
    seen = {}
    for name, leaks in (("steady", ()), ("leaking", (SimLeak("rl", 4.0),))):
        ds = drive_seconds(project_params, car, spec, 7, leaks=leaks)
        yaw = wheel_yaw_rad(ds.angle_rl_rad, ds.angle_rr_rad, r, r, p.track_rear_m)
        inputs = NavInputs(
            ds.odo_true_m[None],
            np.full((1, len(ds)), 0.05**2),
            yaw[None],
            ds.gyro_rad[None],
            np.r_[ds.start_e_m, ds.fix_e_m][None],
            np.r_[ds.start_n_m, ds.fix_n_m][None],
        )
        track = run(inputs, state, "fused", keep_cov=True)
        gain = track.wheel_logpdf.sum() - run(inputs, base, "fused").wheel_logpdf.sum()
        rate, sd = track.x[0, -1, BDW], np.sqrt(track.cov[0, -1, BDW, BDW])
        seen[name] = (yaw, ds.odo_true_m, rate, sd, gain)
        for control in ("wheels", "gyro"):
            assert np.all(run(inputs, state, control).wheel_logpdf == 0.0)
    d, t = seen["leaking"][1], np.arange(len(seen["leaking"][1]))
    moving = d > 0.5
    effect = (seen["leaking"][0] - seen["steady"][0])[moving]
    ramp = -np.linalg.lstsq((d * t)[moving, None], effect, rcond=None)[0][0]
    assert 2e-7 < ramp < 5e-7  # a 4 psi/h leak's, by the simulator's tyre physics
    _, _, rate, sd, gain = seen["leaking"]
    assert abs(rate - ramp) < 2 * sd and sd < 0.6 * ramp, (rate, sd, ramp)
    assert gain > 5.0, gain
    _, _, rate, sd, gain = seen["steady"]
    assert abs(rate) < 2 * sd and gain < 0.0, (rate, sd, gain)
