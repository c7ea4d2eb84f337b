"""One simulated drive: file layout, determinism, physics seen through the sensors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import SimLeak
from rwhonet.data.canonical import G_M_S2
from rwhonet.data.iovnbd import HEADERS
from rwhonet.features.seconds import gnss_displacement_m, integrate_per_second
from rwhonet.geo import geodesic_distance_m
from rwhonet.sim import SimOptions, simulate_drive, steady_turn_route, straight_route
from rwhonet.sim.sensors import gnss_increment_std_m
from rwhonet.sim.writer import write_csv, write_drive

from .conftest import drive_spec, simulate_spec, with_params

REAR = [" Wheel Speed Rear Left (rad/sec)", " Wheel Speed Rear Right (rad/sec)"]
YAW = " Yaw Rate (deg/sec)"
GNSS_COLUMNS = {
    "Sats",
    " Lat",
    " Long",
    " Velocity kmh",
    " Heading",
    " Height",
    " Vertical velocity kmh",
}
TAGS = {
    "urban",
    "country",
    "motorway",
    "wet_road",
    "roundabout",
    "sharp_turn",
    "successive_turns",
    "hard_brake",
    "quick_acceleration",
    "reversing",
    "standstill",
    "traffic",
    "steady_turn",
    "gnss_low_sats",
    "gnss_frozen",
    "gnss_jump",
    "gnss_gap",
}


def per_second_gnss_m(frame: pd.DataFrame) -> np.ndarray:
    lat, lon = frame[" Lat"].to_numpy()[::10], frame[" Long"].to_numpy()[::10]
    return geodesic_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:])


def test_layout_29_columns_with_the_exact_headers(urban_drive, tmp_path):
    frame = urban_drive.frame
    assert tuple(frame.columns) == HEADERS and len(HEADERS) == 29
    path = write_drive(tmp_path, "T-1", *urban_drive[:3])
    first = path.read_bytes().split(b"\n", 1)[0].decode()
    assert first == ",".join(HEADERS)  # leading spaces kept, nothing quoted
    back = pd.read_csv(path)
    assert tuple(back.columns) == HEADERS
    pd.testing.assert_frame_equal(back, frame, check_dtype=False)  # the file holds the frame
    assert (tmp_path / "T-1.scenarios.json").is_file() and (tmp_path / "T-1.truth.json").is_file()
    with pytest.raises(ValueError, match="IO-VNBD layout"):
        write_csv(frame.iloc[:, :5], tmp_path / "bad.csv")


def test_same_seed_same_bytes_other_seed_other_bytes(params, source, tmp_path):
    spec = drive_spec(duration_s=120.0, gnss_faults=["gap"])
    paths = []
    for k, seed in enumerate((11, 11, 12)):
        d = simulate_spec(params, source, spec, seed=seed)
        paths.append(write_drive(tmp_path / str(k), "T", d.frame, d.scenarios, d.truth))
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert paths[0].read_bytes() != paths[2].read_bytes()
    for suffix in (".scenarios.json", ".truth.json"):
        a, b = (p.with_suffix(suffix) for p in paths[:2])
        assert a.read_bytes() == b.read_bytes()


def test_10_hz_rows_and_time_of_day(urban_drive):
    frame, _, truth, state = urban_drive
    t = frame[" Time"].to_numpy()
    dt = np.round(np.diff(t), 2)
    gap = next(f for f in state.faults if f.kind == "gap")
    assert np.all((dt == 0.1) | (np.arange(dt.size) == gap.i0 - 1))
    assert dt[gap.i0 - 1] == pytest.approx((gap.i1 - gap.i0 + 1) * 0.1)
    assert len(frame) == 6000 - (gap.i1 - gap.i0)
    assert t[0] == truth["start_s_of_day"] and 0 <= t[0] < 86400 - 600
    assert np.all(frame[" Sample Period"] == 0.1)


def test_lateral_acceleration_is_bounded(urban_drive, source):
    state = urban_drive.state
    m = state.motion
    rear = m.speed_m_s**2 * np.abs(m.curvature_1_m) / G_M_S2
    assert rear.max() <= source.params.driver.lat_acc_max_g + 1e-6  # the driver's planning limit
    assert rear.max() > 0.3  # ...and the tight turns do get close to it
    assert np.abs(state.accel_y_cg_m_s2).max() / G_M_S2 <= 0.42  # at the centre of gravity
    assert np.abs(urban_drive.frame[" Indicated Lateral Acceleration (g)"]).max() <= 0.45


def test_hard_brakes_reach_minus_045_g(urban_drive):
    frame, scenarios, _, state = urban_drive
    t = frame[" Time"].to_numpy()
    acc = frame[" Indicated Longitudinal Acceleration (g)"].to_numpy()
    t_true = state.motion.t_s + t[0]
    brakes = [i for i in scenarios["intervals"] if i["tag"] == "hard_brake"]
    assert len(brakes) >= 2
    for b in brakes:
        truth = (t_true >= b["start_s"]) & (t_true <= b["end_s"])
        assert state.accel_x_cg_m_s2[truth].min() / G_M_S2 <= -0.45
        seen = (t >= b["start_s"]) & (t <= b["end_s"])
        assert acc[seen].min() <= -0.45


def test_scenario_intervals(urban_drive):
    frame, scenarios, _, state = urban_drive
    t = frame[" Time"].to_numpy()
    t0 = t[0]
    intervals = scenarios["intervals"]
    assert {i["tag"] for i in intervals} <= TAGS
    for i in intervals:
        assert t0 <= i["start_s"] <= i["end_s"] <= t0 + 600.0
    m = state.motion
    tags = {i["tag"] for i in intervals}
    assert {"roundabout", "reversing", "wet_road", "sharp_turn", "hard_brake"} <= tags
    for i in intervals:
        inside = (m.t_s + t0 >= i["start_s"]) & (m.t_s + t0 <= i["end_s"])
        if i["tag"] == "reversing":
            assert np.all(m.direction[inside & (m.speed_m_s > 0)] < 0)
        if i["tag"] == "roundabout":  # UK: clockwise circulation
            assert m.yaw_rate_rad_s[inside].min() < -0.3
        if i["tag"] == "wet_road":
            assert np.all(m.wet[inside][1:-1])


def test_ideal_straight_drive_calibrates_to_the_true_radius(params, source):
    drive = simulate_drive(
        source, "C", straight_route(15.0, 300.0), 3, params.sim, options=SimOptions.ideal()
    )
    frame, truth = drive.frame, drive.truth
    d_gnss = per_second_gnss_m(frame)
    omega = frame[REAR].to_numpy()[::10][1:]  # wheel speed at the end of each second
    cruise = d_gnss > 14.0  # constant speed: sampled wheel speed x 1 s = distance
    assert cruise.sum() > 250
    for k, wheel in enumerate(("rl", "rr")):
        radius = (d_gnss[cruise] / omega[cruise, k]).mean()
        assert radius == pytest.approx(truth["radius_static_m"][wheel], rel=5e-4)


def test_steady_turn_outer_wheel_turns_faster_by_the_track_ratio(params, source):
    radius, p = 25.0, source.params
    drive = simulate_drive(
        source,
        "E",
        steady_turn_route(radius, 6.0, 120.0),
        1,
        params.sim,
        options=SimOptions.ideal(),
    )
    frame, truth = drive.frame, drive.truth
    rl, rr = frame[REAR].to_numpy()[600:1100].T
    r = truth["radius_static_m"]
    ratio = (rr * r["rr"]) / (rl * r["rl"])
    expected = (radius + p.track_rear_m / 2) / (radius - p.track_rear_m / 2)
    np.testing.assert_allclose(ratio, expected, rtol=2e-3)  # 0.01 rad/s rounding of ~20 rad/s
    w = drive.state.wheels  # ideal: omega * r_e is exactly the wheel's ground speed
    np.testing.assert_allclose(w.omega_rad_s * w.radius_m, w.ground_speed_m_s, rtol=1e-12)


def test_zero_slip_true_radius_and_antenna_on_the_axle_give_zero_label(params, source):
    # The physics of the label: with ideal sensors, no slip, radius at the truth and the
    # antenna above the rear-axle centre, GNSS distance equals rear-wheel odometry even
    # through roundabouts and sharp turns; moving the antenna forward makes GNSS see
    # a longer path in turns (a real effect the model learns).
    spec = drive_spec(
        duration_s=300.0, roads={"urban": 1.0}, events={"roundabout": 2, "sharp_turn": 3}
    )
    labels = {}
    for x_m in (0.0, 1.5):
        car = with_params(source, antenna_x_m=x_m, antenna_y_m=0.0)
        d = simulate_spec(params, car, spec, seed=4, options=SimOptions.ideal())
        lat, lon = d.frame[" Lat"].to_numpy(), d.frame[" Long"].to_numpy()
        gnss_m = geodesic_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:])
        w = d.frame[REAR].to_numpy() * np.array(
            [d.truth["radius_static_m"][k] for k in ("rl", "rr")]
        )
        wpm_m = 0.05 * (w[:-1] + w[1:]).mean(axis=1)  # trapezoid over each 0.1 s
        labels[x_m] = gnss_m - wpm_m
        total = gnss_m.sum()
    # Per 0.1 s step the only error is the trapezoid rule across a jump of the
    # acceleration (braking into a turn, accelerating out): |da| dt^2 / 8 <= 4 mm.
    assert np.abs(labels[0.0]).max() < 5e-3
    assert abs(labels[0.0].sum()) < 1e-4 * total
    assert labels[1.5].sum() > 20 * abs(labels[0.0].sum())
    assert labels[1.5].max() > 0.01


def test_truth_sidecar(urban_drive, source):
    truth = urban_drive.truth
    assert truth["vehicle"] == "fiesta" and truth["tyre_state"] == "A"
    assert truth["pressure_psi"] == {"fl": 15.0, "fr": 16.0, "rl": 14.0, "rr": 14.0}
    for wheel, r in truth["radius_static_m"].items():
        assert abs(r / source.nominal_radius_m - 1) < 0.05, wheel
    assert truth["seed"] == {"entropy": 7, "spawn_key": []}
    assert truth["distance_m"] == pytest.approx(urban_drive.state.motion.s_m[-1], abs=1e-3)


def test_slip_in_a_drive_driven_axle_spins_under_traction_all_lag_under_braking(urban_drive):
    state = urban_drive.state
    m, w = state.motion, state.wheels
    traction = (m.accel_m_s2 > 1.0) & (m.speed_m_s > 3.0)
    braking = (m.accel_m_s2 < -3.0) & (m.speed_m_s > 3.0)
    assert traction.sum() > 100 and braking.sum() > 100
    front, rear = w.slip[:2], w.slip[2:]
    assert np.all(front[:, traction] > 0) and np.all(rear[:, traction] < 0)  # FWD car
    assert np.all(w.slip[:, braking] < 0)
    spin = w.omega_rad_s * w.radius_m / np.maximum(w.ground_speed_m_s, 1e-9)
    assert np.all(spin[:2, traction] > 1.0) and np.all(spin[:, braking] < 1.0)


# Ideal wheels (no slip, static radius, perfect CAN, no warm-up) but a real receiver.
GNSS_ONLY = SimOptions(
    slip=False,
    radius_load=False,
    radius_speed=False,
    can_noise=False,
    gnss_noise=True,
    tyre_warmup=False,
)


def per_second_label_m(drive) -> np.ndarray:
    """The label math of the pipeline: GNSS displacement - rear-wheel odometry, per second.

    Wheel odometry integrates each rear wheel's speed over the second (trapezoid,
    as the pipeline's integrated WPM does) times the wheel's true static radius.
    """
    frame, truth = drive.frame, drive.truth
    t = frame[" Time"].to_numpy()
    gnss = gnss_displacement_m(frame[" Lat"].to_numpy(), frame[" Long"].to_numpy())
    angles = [integrate_per_second(t, frame[c].to_numpy()) for c in REAR]
    radius = truth["radius_static_m"]
    wpm = 0.5 * (angles[0] * radius["rl"] + angles[1] * radius["rr"])
    return gnss - wpm


@pytest.mark.parametrize("name", ["source", "target"])
def test_open_road_label_noise_is_a_few_centimetres_per_second(vehicles, params, name):
    # Real receivers with a Doppler-aided navigation filter: the one-second
    # displacement noise is a few cm (docs/simulator.md, "Label noise"). The
    # paper's S and R reach ~0.035-0.04 m of error per second, so the label
    # noise must stay clearly below that; the old random-walk-like process gave 0.29 m.
    car = with_params(vehicles[name], antenna_x_m=0.0, antenna_y_m=0.0)
    labels = []
    for seed in range(3):  # 3 h of open road at 15 m/s
        drive = simulate_drive(
            car, "E", straight_route(15.0, 3600.0), seed, params.sim, options=GNSS_ONLY
        )
        labels.append(per_second_label_m(drive)[30:])  # after pulling away
    label = np.concatenate(labels)
    analytic = gnss_increment_std_m(car.params.gnss)
    assert label.std() == pytest.approx(analytic, rel=0.12)
    assert 0.015 < label.std() < 0.035
    assert np.abs(label).mean() < 0.03  # the mean |error| a perfect model could reach
    # Without receiver noise the same drive has no label at all: the noise is the receiver's.
    quiet = simulate_drive(
        car, "E", straight_route(15.0, 600.0), 0, params.sim, options=SimOptions.ideal()
    )
    assert np.abs(per_second_label_m(quiet)[30:]).max() < 2e-3


def test_degraded_gnss_stretches_are_much_noisier(source, params):
    car = with_params(source, antenna_x_m=0.0, antenna_y_m=0.0)
    drive = simulate_drive(
        car,
        "E",
        straight_route(15.0, 900.0),
        5,
        params.sim,
        options=GNSS_ONLY,
        gnss_faults=["low_sats"],
    )
    label = per_second_label_m(drive)
    fault = drive.state.faults[0]
    # Whole seconds inside the stretch (rows i0..i1; second k spans rows 10k..10k+10).
    inside = np.arange(label.size)
    inside = (10 * inside >= fault.i0) & (10 * inside + 10 < fault.i1)
    outside = np.ones(label.size, dtype=bool)
    outside[max(fault.i0 // 10 - 1, 0) : fault.i1 // 10 + 2] = False
    outside[:30] = False
    assert inside.sum() >= 8
    assert label[inside].std() > 20 * label[outside].std()
    assert label[inside].std() > 1.0  # metres: multipath with 2-3 satellites


def test_tyre_warmup_raises_the_radius_within_a_drive(source, params):
    spec = drive_spec(duration_s=1500.0, roads={"country": 1.0})
    drive = simulate_spec(params, source, spec, seed=2)
    cold = simulate_spec(params, source, spec, seed=2, options=SimOptions(tyre_warmup=False))
    timeline = drive.truth["tyre_timeline"]
    at_20 = timeline["t_s"].index(1200.0)
    for wheel in ("rl", "rr"):
        p, r = timeline["pressure_psi"][wheel], timeline["radius_static_m"][wheel]
        assert p[at_20] > 1.05 * p[0]  # several percent more pressure after 20 min
        assert 1.0002 < r[at_20] / r[0] < 1.002  # a fraction of a per mille to a few
    # The radius the wheels actually roll on grows against the same drive without warm-up.
    ratio = drive.state.wheels.radius_m[2:] / cold.state.wheels.radius_m[2:]
    t = drive.state.motion.t_s
    assert np.all(ratio[:, t < 1.0] == 1.0)
    assert np.all(ratio[:, t > 600.0].min(axis=1) > 1.0002)


def test_a_slow_leak_shrinks_the_leaking_wheel_over_the_drive(target, params):
    spec = drive_spec(vehicle="target", tyre="C", duration_s=1800.0, roads={"urban": 1.0})
    leaks = [SimLeak("rl", 4.0)]
    options = SimOptions(tyre_warmup=False)
    leaking = simulate_spec(params, target, spec, seed=3, options=options, leaks=leaks)
    sound = simulate_spec(params, target, spec, seed=3, options=options)
    timeline = leaking.truth["tyre_timeline"]
    p, r = timeline["pressure_psi"], timeline["radius_static_m"]
    assert p["rl"][-1] == pytest.approx(p["rl"][0] - 2.0, abs=0.01)  # 4 psi/h for 30 min
    assert np.all(np.diff(r["rl"]) < 0) and r["rr"][-1] == r["rr"][0]
    assert -0.2 < 100 * (r["rl"][-1] / r["rl"][0] - 1) < -0.05  # percent
    assert leaking.truth["leaks"] == [{"wheel": "rl", "psi_per_h": 4.0}]
    w_leak, w_sound = leaking.state.wheels.radius_m, sound.state.wheels.radius_m
    assert np.all(w_leak[3] == w_sound[3]) and np.all(w_leak[2, 1:] < w_sound[2, 1:])


def test_payload_lowers_the_rear_radius_over_a_drive(source, params):
    spec = drive_spec(duration_s=600.0, roads={"country": 1.0})
    empty = simulate_spec(params, source, spec, seed=4)
    laden_car = source.with_payload(170.0, 0.21)  # two rear passengers and luggage
    laden = simulate_spec(params, laden_car, spec, seed=4)
    assert laden.truth["payload_kg"] == 170.0
    for wheel in ("rl", "rr"):
        change = laden.truth["radius_mean_m"][wheel] / empty.truth["radius_mean_m"][wheel] - 1
        assert -0.008 < change < -0.003  # state A: soft, underinflated tyres
        static = laden.truth["radius_static_m"][wheel] / empty.truth["radius_static_m"][wheel]
        assert change == pytest.approx(static - 1, abs=5e-4)


def test_the_yaw_rate_channel_integrates_to_the_heading_that_moves_the_car(params, source):
    # Roundabouts, sharp turns and reversing: a perfect gyro, written to the file (3 decimals),
    # summed over the rows, is the heading change of the pose that moved the car.
    spec = drive_spec(duration_s=900.0, events={"roundabout": 3, "sharp_turn": 2, "reversing": 1})
    drive = simulate_spec(params, source, spec, options=SimOptions(gyro_errors=False))
    heading = drive.state.pose.heading_rad[drive.state.record_index]
    turned = np.degrees(heading - heading[0])
    assert np.abs(turned).max() > 180.0
    integrated = np.cumsum(drive.frame[YAW].to_numpy()) / params.sim.record_hz
    # Only the file's rounding (<= 0.0005 deg/s a row, a random walk over 9000 rows) is left.
    assert np.abs(integrated - turned).max() < 0.02
    assert drive.truth["gyro"]["turn_on_bias_deg_s"] == 0.0


def test_the_gyro_has_a_stream_of_its_own(params, source):
    # Switching the gyro's errors off, or fitting another gyro, changes the yaw rate only.
    spec = drive_spec(
        duration_s=600.0,
        events={"roundabout": 2, "hard_brake": 2, "reversing": 1},
        wet_fraction=0.3,
        gnss_faults=["low_sats", "frozen", "jump", "gap"],
    )
    base = simulate_spec(params, source, spec)
    perfect = simulate_spec(params, source, spec, options=SimOptions(gyro_errors=False))
    other = with_params(source, gyro=params.sim.vehicles["focus"].gyro)
    other_gyro = simulate_spec(params, other, spec)
    for drive in (perfect, other_gyro):
        assert not drive.frame[YAW].equals(base.frame[YAW])
        pd.testing.assert_frame_equal(drive.frame.drop(columns=YAW), base.frame.drop(columns=YAW))
    # The configured errors show: a turn-on bias (truth) and the scale error on the rate.
    truth = base.truth["gyro"]
    assert truth["turn_on_bias_deg_s"] != 0.0
    assert truth["scale_error_pct"] == source.params.gyro.scale_error_pct
    error = base.frame[YAW].to_numpy() - perfect.frame[YAW].to_numpy()
    assert np.abs(error.mean() - truth["mean_bias_deg_s"]) < 0.05


def test_a_receiver_grade_changes_the_gnss_columns_only(params, source):
    # The consumer-receiver worlds replay the same drives: every non-GNSS column is the same.
    consumer = dataclasses.replace(
        source,
        params=dataclasses.replace(source.params, gnss=params.sim.receivers["ublox_m8"]),
        receiver="ublox_m8",
    )
    spec = drive_spec(duration_s=300.0, gnss_faults=["low_sats", "jump"])
    own, swapped = simulate_spec(params, source, spec), simulate_spec(params, consumer, spec)
    assert swapped.truth["gnss_receiver"] == "ublox_m8" and own.truth["gnss_receiver"] == "own"
    others = [c for c in HEADERS if c not in GNSS_COLUMNS]
    pd.testing.assert_frame_equal(own.frame[others], swapped.frame[others])
    for column in (" Lat", " Long"):
        assert not own.frame[column].equals(swapped.frame[column])


def test_consumer_receiver_label_noise_matches_its_analytic_value(params, vehicles):
    # The u-blox M8 class receiver (sim.receivers.ublox_m8): its velocity accuracy sets
    # the one-second displacement noise, sigma / sqrt(tau tau_f) = 7 cm, a few times the
    # logger-grade receivers' 2.6-2.9 cm (docs/simulator.md, Section 5).
    gnss = params.sim.receivers["ublox_m8"]
    car = with_params(vehicles["target"], antenna_x_m=0.0, antenna_y_m=0.0, gnss=gnss)
    labels = []
    for seed in range(3):  # 3 h of open road at 15 m/s
        drive = simulate_drive(
            car, "E", straight_route(15.0, 3600.0), seed, params.sim, options=GNSS_ONLY
        )
        labels.append(per_second_label_m(drive)[30:])
    label = np.concatenate(labels)
    analytic = gnss_increment_std_m(gnss)
    assert analytic == pytest.approx(
        gnss.sigma_m / np.sqrt(gnss.tau_s * gnss.filter_tau_s), rel=0.03
    )
    assert label.std() == pytest.approx(analytic, rel=0.12)
    assert 0.05 < label.std() < 0.1
