"""Properties of the label maths (hypothesis): WPM, label and the per-second integral.

On a straight road with zero slip, GNSS and the wheels measure the same distance:
with the true radii the label is zero whatever the speed profile, and a radius
error of a fraction ``eps`` leaves a label of ``-eps`` times the distance. The
trapezoid integral of a rate over each second is exact for a linear rate, on any
(jittered) time stamps.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.features.seconds import integrate_per_second, segment_seconds
from rwhonet.features.wpm import label_m, wheel_angle_rad, wpm_displacement_m
from support.synthetic import build_drive, piecewise_linear_speed

PROPERTY = settings(max_examples=30, deadline=None, database=None)
radius = st.floats(0.25, 0.35)


@st.composite
def speed_profiles(draw):
    """Speeds linear between knots on whole seconds, 0-40 m/s, over 5-20 s."""
    n = draw(st.integers(5, 20))
    speeds = draw(st.lists(st.floats(0.0, 40.0), min_size=n + 1, max_size=n + 1))
    return piecewise_linear_speed([float(k) for k in range(n + 1)], speeds)


def _seconds_and_wpm(profile, true_rl, true_rr, cal_rl, cal_rr):
    frame = build_drive(profile, r_rl_m=true_rl, r_rr_m=true_rr)
    sec = segment_seconds(frame, "synthetic")
    wpm = wpm_displacement_m(
        wheel_angle_rad(sec.angle_rl_rad, sec.omega_end_rl_rad_s, "integrated"),
        wheel_angle_rad(sec.angle_rr_rad, sec.omega_end_rr_rad_s, "integrated"),
        cal_rl,
        cal_rr,
    )
    return sec, wpm


@PROPERTY
@given(profile=speed_profiles(), r_rl=radius, r_rr=radius)
def test_zero_slip_and_the_true_radius_give_a_zero_label(profile, r_rl, r_rr):
    sec, wpm = _seconds_and_wpm(profile, r_rl, r_rr, r_rl, r_rr)
    np.testing.assert_allclose(label_m(sec.disp_gnss_m, wpm), 0.0, atol=1e-6)


@PROPERTY
@given(profile=speed_profiles(), r=radius, eps=st.floats(-0.1, 0.1))
def test_the_label_scales_linearly_with_a_radius_error(profile, r, eps):
    sec, wpm = _seconds_and_wpm(profile, r, r, r * (1.0 + eps), r * (1.0 + eps))
    np.testing.assert_allclose(label_m(sec.disp_gnss_m, wpm), -eps * sec.disp_gnss_m, atol=1e-6)


@PROPERTY
@given(
    # no subnormals: below 2.2e-308 a product keeps fewer digits than rtol=1e-12 asks
    angles=st.lists(st.floats(0.0, 200.0, allow_subnormal=False), min_size=1, max_size=30),
    r_rl=radius,
    r_rr=radius,
    k=st.floats(0.0, 10.0),
)
def test_wpm_is_linear_in_the_wheel_angles_and_the_mean_of_the_two_wheels(angles, r_rl, r_rr, k):
    a = np.asarray(angles)
    both = wpm_displacement_m(a, a, r_rl, r_rr)
    np.testing.assert_allclose(wpm_displacement_m(k * a, k * a, r_rl, r_rr), k * both, atol=1e-9)
    np.testing.assert_allclose(both, 0.5 * (r_rl + r_rr) * a, rtol=1e-12)
    np.testing.assert_array_equal(
        wpm_displacement_m(a, 2 * a, r_rl, r_rr), wpm_displacement_m(2 * a, a, r_rr, r_rl)
    )


@PROPERTY
@given(
    steps=st.lists(st.floats(0.05, 0.15), min_size=10, max_size=60),
    a=st.floats(-50.0, 50.0),
    b=st.floats(-5.0, 5.0),
)
def test_per_second_integral_is_exact_for_a_linear_rate_on_any_time_stamps(steps, a, b):
    t = np.r_[0.0, np.cumsum(steps)]
    rate = a + b * t
    got = integrate_per_second(t, rate)
    ta, tb = t[0 : 10 * len(got) : 10], t[10 : 10 * len(got) + 1 : 10]
    np.testing.assert_allclose(got, a * (tb - ta) + 0.5 * b * (tb**2 - ta**2), atol=1e-9)
