"""A wheel's pulse counter as its angular speed: what the wheel-speed sensor itself counts.

A wheel-speed sensor sees the teeth of a tone wheel go by; the ABS/ESC unit counts them
and, on many cars, puts the running count on the bus beside (or in place of) the speed
it derives: a counter per wheel that goes up by one a tooth edge and wraps to 0 at its
width (Volkswagen's ESP_10 ``ESP_VL_Radimpulszaehler`` and its siblings, 10 bits, wrap at
1024; other makers' "wheel pulse" or "wheel tick" signals likewise). A logger that
records the counters records the sensor's own measurement, without the unit's speed
filter and its resolution (0.01 km/h steps are 0.03 % at 30 km/h, but 1-2 % while
creeping).

A signal map names such a channel with the unit ``pulses/N`` (``N`` the pulses a wheel
turn, the tone wheel's teeth as the unit counts them: twice the teeth where it counts
both edges) and, where the counter wraps, ``pulses/N mod M`` (``M`` the count after
which it starts at 0 again, 2 to the counter's bits): ``omega_fl: {channel:
ESP_VL_Radimpulszaehler, unit: pulses/96 mod 1024}``. Its samples, once in time order
(:func:`rwhonet.data.signalmap.in_time_order`), become rad/s here
(:func:`pulses_to_rad_s`):

- each step's pulses are the difference of two counts, modulo ``M``, and its angle
  ``2 pi pulses / N``: the wheel's angle, counted, at each sample;
- a sample's speed is the angle it turned through in :data:`SPAN_S` (0.2 s) centred on
  it, the angle linear between samples, over that time (no lag; near a stretch's ends,
  the part of the span inside it). A pulse is a coarse step: 96 a turn on a 0.36 m tyre
  are 2.4 cm, which over one 12 ms step of an 83 Hz message would be 2 m/s, and a speed
  that jumps so from sample to sample is what the glitch check
  (:mod:`rwhonet.data.glitches`, 10 g) cuts as no tyre's. Over 0.2 s a pulse is 0.12 m/s,
  under a tenth of that bound even at 100 Hz, and the wheel's distance over any second is
  still the counted angle within a pulse at each end; the grid's 0.1 s rows average
  the samples anyway;
- a step is **none** where a count is missing, where it is too long to tell the
  counter's wraps apart (the wheel could have turned ``M / N`` turns in it: at most
  :data:`MAX_WHEEL_RAD_S`, a car's 300 km/h on a 0.25 m tyre; 0.20 s for 96 pulses a
  turn and a 10-bit counter: 10 frames of a 50 Hz message lost), or, for a counter
  that does not wrap, where its count goes back (the unit restarted). Such a step ends
  a stretch: no span reaches across it. A sample with no step either side has no speed,
  a hole the wheel stream's rules then take as any other.

A count that is no whole number from 0 to ``M - 1`` (a map that names another signal, a
DBC whose scale is not the counter's) is refused with its row. The counter gives no
direction: as a speed signal's magnitude, the wheels' distance is what is measured.
Column maps (a 10 Hz logger's rows) take no pulse unit: a difference needs the samples
as the bus carried them.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from rwhonet.errors import InputError, Problem

# a car's top speed over a small tyre's rolling radius: 300 km/h on 0.25 m, rad/s; the
# most a wheel can turn in a step, which a wrapping counter's steps must stay below
MAX_WHEEL_RAD_S = (300.0 / 3.6) / 0.25
# the time a sample's speed is the angle over, centred on it: two 0.1 s grid rows
SPAN_S = 0.2
PULSE_UNIT_FORM = "pulses/N or pulses/N mod M (a pulse counter: N a wheel turn, wrapping at M)"
_PULSES = re.compile(r"^\s*pulses\s*/\s*(\d+)(?:\s+mod\s+(\d+))?\s*$", re.IGNORECASE)
MAX_LISTED = 20  # rows of bad counts a problem lists


@dataclass(frozen=True)
class PulseUnit:
    """A pulse counter's unit: pulses a wheel turn, and the count it wraps at (None: none)."""

    per_turn: int
    modulus: int | None

    def said(self) -> str:
        return f"{self.per_turn} a turn" + (f", wrapping at {self.modulus}" if self.modulus else "")


def pulse_unit(unit: str) -> PulseUnit | None:
    """The pulse counter a unit names (``pulses/96 mod 1024``), or None where it names none
    (or a count of 0)."""
    m = _PULSES.match(unit)
    if m is None:
        return None
    per_turn, modulus = int(m.group(1)), None if m.group(2) is None else int(m.group(2))
    if per_turn < 1 or (modulus is not None and modulus < 2):
        return None
    return PulseUnit(per_turn, modulus)


def is_pulse_unit(unit: str) -> bool:
    """Whether a unit names a pulse counter (:func:`pulse_unit`)."""
    return pulse_unit(unit) is not None


@dataclass(frozen=True)
class Pulses:
    """A counter's samples as speeds (:func:`pulses_to_rad_s`).

    Attributes:
        rad_s: each sample's speed, rad/s (NaN: no step either side had one).
        steps: the steps between samples.
        no_step: steps without a speed, by why: ``missing`` (a count missing either side),
            ``long`` (too long to tell the wraps apart), ``back`` (a counter that does not
            wrap went back).
    """

    rad_s: np.ndarray
    steps: int
    no_step: dict[str, int]

    def said(self, channel: str, unit: PulseUnit) -> str:
        """The note on how the counter became a speed."""
        gone = [f"{n} {why}" for why, n in self.no_step.items() if n]
        return (
            f"{channel}: a pulse counter ({unit.said()}) as wheel speed, the angle its "
            f"counts turned over {SPAN_S:g} s about each sample ({self.steps} steps)"
            + (f"; steps without a speed: {', '.join(gone)}" if gone else "")
        )


def pulses_to_rad_s(
    t_s: np.ndarray,
    counts: np.ndarray,
    unit: PulseUnit,
    where: str,
    channel: str,
    rows: np.ndarray | None = None,
) -> Pulses:
    """A pulse counter's counts at strictly increasing times as the wheel's speed.

    Args:
        t_s: the samples' times, s, in order.
        counts: the counter's values (NaN: a sample without one).
        unit: its pulses a turn and wrap.
        where: the stream, for messages.
        channel: the logger's channel, for messages.
        rows: each sample's row in its file, 1-based (None: sample ``i`` is row ``i + 1``).

    Raises:
        InputError: a count that is no whole number from 0 to the wrap less one (or, for
            a counter that does not wrap, below 0), naming the rows.
    """
    t = np.asarray(t_s, np.float64)
    n = np.asarray(counts, np.float64)
    has = np.isfinite(n)
    top = math.inf if unit.modulus is None else unit.modulus
    with np.errstate(invalid="ignore"):
        bad = has & ((n < 0) | (n >= top) | (n != np.round(n)))
    if bad.any():
        at = np.flatnonzero(bad)
        row = at + 1 if rows is None else np.asarray(rows)[at]
        listed = ", ".join(
            f"row {int(r)}: {float(n[i]):g}"
            for r, i in zip(row[:MAX_LISTED], at[:MAX_LISTED], strict=True)
        )
        raise InputError(
            [
                Problem(
                    where,
                    int(row[0]),
                    channel,
                    "a pulse count, a whole number from 0"
                    + (f" to {unit.modulus - 1}" if unit.modulus else ""),
                    f"{at.size} count(s) not so ({listed})",
                    "map the wheel's pulse counter, with the pulses a turn and the count "
                    "it wraps at (pulses/96 mod 1024), or its speed in a speed unit",
                )
            ]
        )
    if t.size == 0:
        return Pulses(np.zeros(0), 0, {})
    dt = np.diff(t)
    step = np.diff(n)
    missing = ~(has[1:] & has[:-1])
    back = np.zeros(dt.size, bool)
    long = np.zeros(dt.size, bool)
    if unit.modulus is not None:
        step = np.mod(step, unit.modulus)
        most = MAX_WHEEL_RAD_S / (2.0 * math.pi) * unit.per_turn * dt
        long = ~missing & (most >= unit.modulus)
    else:
        with np.errstate(invalid="ignore"):
            back = ~missing & (step < 0)
    ok = ~missing & ~long & ~back & (dt > 0)
    rad_s = _over_span(t, np.where(ok, 2.0 * math.pi * step / unit.per_turn, 0.0), ok)
    no_step = {
        "missing": int(missing.sum()),
        "long": int(long.sum()),
        "back": int(back.sum()),
    }
    names = {
        "missing": "a count missing",
        "long": "too long to tell the wraps",
        "back": "went back",
    }
    return Pulses(rad_s, int(dt.size), {names[k]: v for k, v in no_step.items()})


def _over_span(t: np.ndarray, angle: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Each sample's speed: the angle turned in :data:`SPAN_S` centred on it over that
    time, within its stretch of steps that have one (``ok``; ``angle`` each step's); NaN
    for a sample of no such step."""
    stretch = np.concatenate([[0], np.cumsum(~ok)])  # a step without a speed ends one
    theta = np.concatenate([[0.0], np.cumsum(angle)])  # flat across such a step
    first = np.searchsorted(stretch, stretch, side="left")
    last = np.searchsorted(stretch, stretch, side="right") - 1
    lo = np.maximum(t - 0.5 * SPAN_S, t[first])
    hi = np.minimum(t + 0.5 * SPAN_S, t[last])
    with np.errstate(invalid="ignore", divide="ignore"):
        rad_s = (np.interp(hi, t, theta) - np.interp(lo, t, theta)) / (hi - lo)
    return np.where(last > first, rad_s, np.nan)
