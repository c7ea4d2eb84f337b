"""The units a wheel speed may be logged in, and their conversion to rad/s.

A wheel-speed sensor counts the teeth of a tone wheel; what reaches the log is either
the wheel's angular speed (``rad/s``, ``rpm``, ``deg/s``) or, as many cars put it on the
bus, its circumferential speed (``m/s``, ``km/h``, ``mph``): the angular speed times the
car's own assumed tyre radius. A circumferential speed is divided by the car's nominal
tyre radius (``data.vehicles.<car>.nominal_radius_m``, predict's ``--nominal-radius``),
which undoes that scaling where the two radii agree; where they do not, the difference is
a wheel scale validate's radius check sees and the models learn, as a worn tyre's.
Every reader that takes a unit from a map (column maps, signal maps, comma2k19) converts
through :func:`wheel_factor`. A signal map may also give a wheel as its pulse counter, the
count itself (:mod:`rwhonet.data.wheelpulses`).
"""

from __future__ import annotations

import math

import numpy as np

from rwhonet.data import canonical as c
from rwhonet.errors import InputError, Problem

# unit -> factor to rad/s
ANGULAR_WHEEL_UNITS = {"rad/s": 1.0, "rpm": 2.0 * math.pi / 60.0, "deg/s": math.pi / 180.0}
# unit -> factor to m/s (then divided by the tyre radius)
LINEAR_WHEEL_UNITS = {"m/s": 1.0, "km/h": c.KMH_M_S, "mph": 0.44704}
WHEEL_UNITS = (*ANGULAR_WHEEL_UNITS, *LINEAR_WHEEL_UNITS)


def wheel_factor(unit: str, radius_m: float | None, where: str = "wheel speed") -> float:
    """The factor from a wheel-speed unit to rad/s.

    Args:
        unit: one of :data:`WHEEL_UNITS`.
        radius_m: the tyre radius a circumferential speed is divided by (the car's
            nominal radius); unused for an angular unit.
        where: the channel or the map's setting, for messages.

    Returns:
        rad/s per unit.

    Raises:
        InputError: an unknown unit, or a circumferential unit without a positive radius.
    """
    if unit in ANGULAR_WHEEL_UNITS:
        return ANGULAR_WHEEL_UNITS[unit]
    if unit in LINEAR_WHEEL_UNITS:
        if radius_m is None or not radius_m > 0:
            raise InputError(
                [
                    Problem(
                        where,
                        None,
                        None,
                        f"the tyre radius to turn a wheel speed in {unit} into rad/s",
                        f"radius {radius_m!r}",
                        "give the car's nominal tyre radius (data.vehicles.<car>."
                        "nominal_radius_m, or --nominal-radius)",
                    )
                ]
            )
        return LINEAR_WHEEL_UNITS[unit] / radius_m
    raise InputError(
        [
            Problem(
                where,
                None,
                None,
                f"a wheel-speed unit among {list(WHEEL_UNITS)}",
                f"{unit!r}",
                "name the unit the logger wrote (in the column map or signal map)",
            )
        ]
    )


def wheel_speed_rad_s(
    values: np.ndarray, unit: str, radius_m: float | None, where: str = "wheel speed"
) -> np.ndarray:
    """Convert wheel speeds to rad/s (:func:`wheel_factor`).

    Args:
        values: the wheel speeds as logged.
        unit: one of :data:`WHEEL_UNITS`.
        radius_m: the tyre radius a circumferential speed is divided by.
        where: the channel, for messages.

    Returns:
        float64 rad/s (``values`` itself when they are float64 rad/s already).

    Raises:
        InputError: as :func:`wheel_factor`.
    """
    factor = wheel_factor(unit, radius_m, where)
    values = np.asarray(values, dtype=np.float64)
    return values if factor == 1.0 else values * factor
