"""The filter's sensor models: the gyro's latency, and what the fixes say of it and the antenna."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rwhonet import contracts as k
from rwhonet.config import SimDrive
from rwhonet.evaluation.position import ascend, climb, ridge_s_per_m
from rwhonet.features.deadreckoning import wheel_yaw_rad
from rwhonet.nav import GnssSpec, GyroSpec, NavConfig, NavInputs, WheelSpec, run
from rwhonet.nav.sensors import lag_compensated
from rwhonet.sim import vehicles_from_params
from support.navsim import Gyro, drive_seconds


def test_no_latency_leaves_the_yaws_as_read():
    y = np.array([[0.1, np.nan, -0.2]])
    np.testing.assert_array_equal(lag_compensated(y, 0.0), y)


def test_the_compensation_adds_the_latency_times_the_change_of_rate_by_hand():
    y = np.array([[0.0, 0.1, 0.3, 0.3, np.nan, 0.2]])
    out = lag_compensated(y, 0.2, np.array([0.05]))
    # y_k + 0.2 (y_k - y_(k-1)); a second after a missing one, or without one before, as read
    want = [0.0 + 0.2 * (0.0 - 0.05), 0.1 + 0.02, 0.3 + 0.04, 0.3, np.nan, 0.2]
    np.testing.assert_allclose(out[0], want)
    np.testing.assert_array_equal(lag_compensated(y, 0.2)[0, 0], 0.0)  # nothing before


def test_summed_the_compensated_heading_stays_near_the_car_s_where_the_read_one_falls_behind():
    # a channel L late integrates the turn of [k-1-L, k-L]. On a turn whose rate rises
    # by a each second, the heading as read falls behind by L times the rate (growing
    # with it); compensated, the latest second's mean rate is half a second old, so it
    # stays behind by a L (1 + L) / 2 however fast the car turns, by hand
    L, a = 0.15, 0.02  # s; rad/s per s
    k = np.arange(1, 31)

    def turned(t):  # heading of a rate a*t from 0 (the car stood before t = 0)
        return 0.5 * a * np.maximum(t, 0.0) ** 2

    read = turned(k - L) - turned(k - 1 - L)
    heading = np.cumsum(lag_compensated(read[None], L, np.array([0.0]))[0])
    np.testing.assert_allclose((turned(k) - heading)[1:], a * L * (1 + L) / 2, atol=1e-12)
    behind = turned(k) - np.cumsum(read)
    np.testing.assert_allclose(behind, L * a * k - a * L * L / 2, atol=1e-12)


def test_the_compensated_yaw_s_noise_grows_with_the_latency():
    g = GyroSpec()
    late = dataclasses.replace(g, latency_s=0.1)
    assert late.yaw_sd_rad() == pytest.approx(g.yaw_sd_rad() * np.sqrt(1.1**2 + 0.1**2))


def test_ascend_finds_a_parabola_s_vertex_on_either_side_and_stops_at_the_range():
    for vertex in (3.3, -2.6):
        assert ascend(lambda i, v=vertex: -((i - v) ** 2), -10, 10) == pytest.approx(vertex)
    assert ascend(lambda i: float(i), -10, 4) == 4.0  # rising to the end of the range
    assert ascend(lambda i: -abs(i), -5, 5) == 0.0  # the start is the peak


def _ridge(x: dict[str, float]) -> float:
    # a score with a narrow ridge along a / 10 + L = 0.19 (10 m/s), whose top lies at
    # a = 0.95, L = 0.095: what the fixes tell of a lever arm ahead and a late gyro
    lag = x["ahead"] / 10.0 + x["latency"] - 0.19
    return -1e4 * lag**2 - (x["ahead"] - 0.95) ** 2 - (x["left"] + 0.2) ** 2


def test_climbing_along_the_ridge_reaches_its_top_where_the_axes_alone_stop_short():
    bounds = {"ahead": (-2.0, 5.0), "left": (-2.0, 2.0), "latency": (0.0, 0.5)}
    axes = {
        "ahead": ({"ahead": 0.25}, bounds),
        "latency": ({"latency": 0.025}, bounds),
        "left": ({"left": 0.25}, bounds),
    }
    start = {"ahead": 0.0, "left": 0.0, "latency": 0.0}
    alone = climb(_ridge, start, axes, 6)
    assert alone["ahead"] > 1.5  # up to the ridge by the lever arm alone, and stuck there
    ridged = climb(_ridge, start, axes | {"ridge": ({"ahead": 0.25, "latency": -0.025}, bounds)}, 6)
    assert _ridge(ridged) > _ridge(alone) + 0.3
    assert ridged["ahead"] == pytest.approx(0.95, abs=0.1)
    assert ridged["latency"] == pytest.approx(0.095, abs=0.01)
    assert ridged["left"] == pytest.approx(-0.2, abs=0.01)
    # the ranges hold, also along a direction that moves two values at once
    top = climb(lambda x: x["ahead"] - 10 * x["latency"], start | {"latency": 0.3}, axes, 1)
    assert top == pytest.approx({"ahead": 5.0, "left": 0.0, "latency": 0.0}, abs=1e-12)
    diag = {"ridge": ({"ahead": 0.25, "latency": -0.025}, bounds)}
    stop = climb(lambda x: x["ahead"], start | {"latency": 0.1}, diag, 1)
    assert stop == pytest.approx({"ahead": 1.0, "left": 0.0, "latency": 0.0}, abs=1e-12)


def test_the_ridge_s_ratio_weights_each_second_s_one_over_speed_by_its_turn_squared():
    frame = pd.DataFrame(
        {
            k.DISP_GNSS_M: [10.0, 5.0, 1.0, 20.0, np.nan],
            k.GYRO_YAW_RAD: [0.1, 0.2, 0.5, 0.0, 0.3],  # 1 m/s: too slow; NaN: no fix
        }
    )
    want = (0.01 / 10 + 0.04 / 5) / (0.01 + 0.04)
    assert ridge_s_per_m(frame, np.arange(5)) == pytest.approx(want)
    assert ridge_s_per_m(frame, np.array([2, 3])) is None  # no turn fast enough to tell
    assert ridge_s_per_m(frame.drop(columns=k.GYRO_YAW_RAD), np.arange(5)) is None


def test_the_fixes_log_score_is_highest_at_the_drive_s_antenna_and_gyro_latency(project_params):
    # A simulated drive (the target car: its antenna 0.95 m ahead and 0.2 m right of the
    # rear axle) with a gyro 0.12 s late, filtered fused on the true travel: the fixes'
    # log score is higher at the car's antenna and latency than at the unknown's
    # (0, 0, 0), and the score's peak along each lies near the car's own.
    car = vehicles_from_params(project_params)["target"]
    gyro = Gyro(latency_s=0.12, instability=np.radians(0.005), scale_error=0.0)
    spec = SimDrive(
        name="L-1",
        role="target_test",
        vehicle="target",
        tyre="B",
        duration_s=900.0,
        roads={"urban": 0.7, "country": 0.3},
    )
    ds = drive_seconds(project_params, car, spec, 7, gyro=gyro)
    p, r = car.params, car.nominal_radius_m
    base = NavConfig(
        wheels=WheelSpec(radius_m=r, track_rear_m=p.track_rear_m),
        gnss=GnssSpec(sigma_m=p.gnss.sigma_m, tau_s=p.gnss.tau_s, white_m=0.05),
    )
    inputs = NavInputs(
        ds.odo_true_m[None],
        np.full((1, len(ds)), 0.05**2),
        wheel_yaw_rad(ds.angle_rl_rad, ds.angle_rr_rad, r, r, p.track_rear_m)[None],
        ds.gyro_rad[None],
        np.r_[ds.start_e_m, ds.fix_e_m][None],
        np.r_[ds.start_n_m, ds.fix_n_m][None],
    )

    def score(ahead, left, late):
        cfg = dataclasses.replace(
            base, antenna_m=(ahead, left), gyro=dataclasses.replace(base.gyro, latency_s=late)
        )
        return float(run(inputs, cfg, "fused").fix_logpdf.sum())

    ahead, left = ds.antenna_m
    truth = score(ahead, left, 0.12)
    assert truth > score(0.0, 0.0, 0.0) + 100.0
    assert truth > max(score(ahead, left, 0.0), score(0.0, 0.0, 0.12))
    late = ascend(lambda i: score(ahead, left, 0.02 * i), 0, 15) * 0.02
    assert late == pytest.approx(0.12, abs=0.04)
    fitted = ascend(lambda i: score(0.25 * i, left, 0.12), -8, 20) * 0.25
    assert fitted == pytest.approx(ahead, abs=0.3)
