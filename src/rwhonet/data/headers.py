"""Header names as users write them: case, spaces, punctuation and unit suffixes aside.

A header cell is matched by its *key*: lower case, letters and digits only, its unit
suffix taken off (``" Wheel Speed Front Left (rad/sec)"``, ``"wheel_speed_front_left"``,
``"WheelSpeedFrontLeft [rad/s]"``, ``"wheel_speed_front_left_rad_s"`` all give
``"wheelspeedfrontleft"``). The unit it
declares is kept apart, spelled as :data:`UNIT_ALIASES` names it. The readers
(:mod:`rwhonet.data.iovnbd`, :mod:`rwhonet.data.columnmap`, the stream readers) decide
which key means which channel; this module knows no column name.
"""

from __future__ import annotations

import re

# How units are written (lower case, no spaces) -> the one name the readers use for the unit.
UNIT_ALIASES: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millisecond", "milliseconds"), "ms"),
    # microseconds and nanoseconds: a microcontroller's micros(), ROS's and CAN tools' stamps
    **dict.fromkeys(("us", "µs", "μs", "usec", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanosecond", "nanoseconds"), "ns"),
    **dict.fromkeys(("deg", "degs", "degree", "degrees", "°"), "deg"),
    **dict.fromkeys(("km/h", "kmh", "kph", "km/hr", "kmph"), "km/h"),
    **dict.fromkeys(("m/s", "mps", "m/sec"), "m/s"),
    "mph": "mph",
    "km": "km",
    "m": "m",
    **dict.fromkeys(("rad/s", "rad/sec", "rads", "radps", "rad/s^-1"), "rad/s"),
    **dict.fromkeys(("rpm", "rev/min", "revs/min", "1/min"), "rpm"),
    **dict.fromkeys(("deg/s", "deg/sec", "°/s", "degs/s", "dps"), "deg/s"),
    **dict.fromkeys(("g",), "g"),
    **dict.fromkeys(("m/s2", "m/s^2", "m/s²", "m/s/s", "ms-2", "ms^-2"), "m/s2"),
    **dict.fromkeys(("count", "#", "n"), "count"),
    # an angle in minutes of arc; degrees and minutes run together, NMEA's ddmm.mmmm; a time
    # of day as hhmmss.ss (rwhonet.data.packed)
    **dict.fromkeys(("min", "mins", "arcmin", "'"), "min"),
    **dict.fromkeys(
        ("ddmm", "dddmm", *(f"{d}mm.{'m' * k}" for d in ("dd", "ddd") for k in range(1, 6))),
        "ddmm",
    ),
    **dict.fromkeys(("hhmmss", *(f"hhmmss.{'s' * k}" for k in range(1, 4))), "hhmmss"),
}
# Units a header may end with without brackets (" Velocity kmh", "time_s", "lat_deg").
TRAILING_UNITS = frozenset(
    {
        "s",
        "sec",
        "ms",
        "us",
        "ns",
        "deg",
        "kmh",
        "kph",
        "mps",
        "mph",
        "rpm",
        "rads",
        "radps",
        "g",
        "km",
        "m",
    }
)


def header_key(cell: str) -> tuple[str, str | None]:
    """Split a header cell into its matching key and the unit it declares.

    Args:
        cell: the header cell as written.

    Returns:
        ``(key, unit)``: the name in lower case, letters and digits only, without its unit;
        the unit as written (brackets and spaces removed, lower case), or None when the cell
        declares none.
    """
    text = cell.strip().lower()
    unit = None
    bracket = re.fullmatch(r"(.*?)[\s_]*[(\[{]([^)\]}]*)[)\]}]\s*", text)
    if bracket:
        text, unit = bracket.group(1), bracket.group(2).replace(" ", "")
    else:
        tokens = re.split(r"[\s_]+", text)
        # A unit written in snake case ("wheel_speed_fl_rad_s", "acc_lon_m_s2"): its last
        # two or three tokens joined by "/" spell a known unit. Else one trailing token.
        n = next(
            (n for n in (3, 2) if len(tokens) > n and unit_name("/".join(tokens[-n:]))),
            1 if len(tokens) > 1 and tokens[-1] in TRAILING_UNITS else 0,
        )
        if n:
            text, unit = " ".join(tokens[:-n]), "/".join(tokens[-n:])
    return re.sub(r"[^a-z0-9]", "", text), unit or None


def unit_name(unit: str | None) -> str | None:
    """The unit's name in :data:`UNIT_ALIASES` (None when unknown or not given)."""
    return None if unit is None else UNIT_ALIASES.get(unit.replace(" ", "").lower())


def map_unit_name(unit: str) -> str | None:
    """The name of a unit a column or signal map declares, without the direction it may add
    (``deg/s cw``: a gyro positive clockwise; ``min W``: a longitude positive west), which a
    header does not name: ``deg/s cw`` and ``deg/s`` are both the header's ``(deg/s)``."""
    return unit_name(unit.removesuffix(" cw").removesuffix(" W"))
