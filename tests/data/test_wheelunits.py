"""Wheel-speed units: angular ones by their factor, circumferential ones by the radius."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data.wheelunits import WHEEL_UNITS, wheel_factor, wheel_speed_rad_s
from rwhonet.errors import InputError

R = 0.3


@pytest.mark.parametrize(
    ("unit", "factor"),
    [
        ("rad/s", 1.0),
        ("rpm", 2 * np.pi / 60),
        ("deg/s", np.pi / 180),
        ("km/h", 1 / 3.6 / R),
        ("m/s", 1 / R),
        ("mph", 1609.344 / 3600 / R),
    ],
)
def test_wheel_units(unit, factor):
    assert wheel_speed_rad_s(np.array([10.0]), unit, R)[0] == pytest.approx(10.0 * factor)
    assert wheel_factor(unit, R) == pytest.approx(factor)


def test_a_car_at_36_km_h_on_a_30_cm_tyre_turns_its_wheels_at_100_over_3_rad_s():
    # 36 km/h = 10 m/s; 10 m/s / 0.3 m = 33.3 rad/s, whichever unit the logger chose
    speeds = {"km/h": 36.0, "m/s": 10.0, "mph": 36.0 / 1.609344, "rad/s": 100 / 3}
    for unit, value in speeds.items():
        assert value * wheel_factor(unit, R) == pytest.approx(100 / 3)


def test_rad_s_is_not_copied():
    values = np.arange(3.0)
    assert wheel_speed_rad_s(values, "rad/s", None) is values


@pytest.mark.parametrize("radius", [None, 0.0, -0.3, float("nan")])
def test_a_linear_wheel_speed_needs_a_radius(radius):
    with pytest.raises(InputError, match="tyre radius") as err:
        wheel_factor("km/h", radius, "data.column_maps.can.omega_rl.unit")
    assert err.value.problems[0].file == "data.column_maps.can.omega_rl.unit"


def test_an_angular_wheel_speed_needs_no_radius():
    assert wheel_factor("rpm", None) == pytest.approx(2 * np.pi / 60)


def test_an_unknown_unit_is_refused_with_the_units_known():
    with pytest.raises(InputError) as err:
        wheel_factor("knots", R)
    assert all(u in err.value.problems[0].expected for u in WHEEL_UNITS)
