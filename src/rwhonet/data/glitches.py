"""Wheel speeds that change faster than any tyre can: a logger's glitch, to cut, never to learn.

One wheel read at ten times its speed for one 0.1 s row moves that second's
label by about a metre, and nothing else in validate notices it. A wheel's
speed can fall fast (the brakes lock it, and ABS lets it lock briefly, down to
zero) and regain the road speed fast (the tyre's friction spins it back up), so
neither a fall nor a recovery says anything. What no tyre can do is turn
markedly *faster than the road under it* within a sample: the only torque that
can drive a wheel past the road speed is the engine's, and the engine has to
spin up the whole driveline with it.

The bound
    The rotating parts of the driveline, seen at the wheels, weigh about
    ``0.04 + 0.0025 N^2`` times the car's mass (N the overall gear ratio;
    Gillespie, *Fundamentals of Vehicle Dynamics*, SAE 1992, Sec. 2, the "mass
    factor"): about 0.46 M in first gear (N = 13). Even if the driven wheels lost
    all grip at once, the most an engine puts at the wheels in first gear (about
    1 g of the car's weight: a traction-limited launch) would spin them up at
    about 1 / 0.46 ≈ 2.2 g, and one wheel of an open differential at twice that
    (a car with half as much again at its wheels: 6.5 g).
    :data:`WHEEL_GLITCH_G` = 10 g of circumferential acceleration *above the road
    speed* is well beyond that, and beyond the tyre-road friction limit (about
    1 g) ten times over.

The check (:func:`glitch_mask`), per wheel and sample
    The road speed a wheel is compared with is the median of the *other* three
    wheels' speeds (so one bad wheel cannot move it), at its largest within
    ±``WINDOW_S`` (so the other wheels' own ABS dips cannot make a wheel that
    rolls at road speed look fast). The wheel's *excess* is how much it exceeds
    that, zero when it does not. A sample whose excess rose faster than the
    bound (``r |Δω| / Δt > bound``, ``r`` the nominal radius) opens a glitch,
    and the glitch lasts until the excess falls as fast (at most ``MAX_RUN_S``).
    ABS lockups are falls and recoveries below the road speed: their excess
    stays zero and they are never flagged. A one-row spike to ten times the
    speed rises by ``9 v`` in one period: at 10 Hz it is found above about
    1.1 m/s. A glitch in all four wheels at once (a logger scaling a whole
    message) moves the reference with it and is not found by this check.
"""

from __future__ import annotations

import numpy as np

from rwhonet.data import canonical as c

G_M_S2 = c.G_M_S2
WHEEL_GLITCH_G = 10.0  # circumferential acceleration above the road speed no wheel reaches
WINDOW_S = 0.5  # the road speed is the others' largest speed within +- this
MAX_RUN_S = 1.0  # a glitch lasts at most this long
# A drive with glitches in more than this share of its seconds is refused, not cut: a wheel
# channel that misbehaves throughout (a wrong signal mapped, one wheel on another scale) is
# no glitch, and cutting it would leave a drive of holes.
REFUSE_SHARE = 0.5


def running_max(x: np.ndarray, size: int) -> np.ndarray:
    """The maximum over a centred window of odd ``size``, the ends held (scipy's
    ``maximum_filter1d(x, size, mode="nearest")``, which ``rwhonet predict`` would import
    for this alone): van Herk / Gil-Werman, a prefix and a suffix running maximum per
    block of ``size``, O(n). NaN is skipped (``fmax``): NaN only where the whole window is.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return x.copy()
    h = size // 2
    xp = np.pad(x, h, mode="edge")
    n = xp.size
    buf = np.full(-(-n // size) * size, -np.inf)
    buf[:n] = xp
    blocks = buf.reshape(-1, size)
    prefix = np.fmax.accumulate(blocks, axis=1).ravel()
    suffix = np.fmax.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].ravel()
    out = np.fmax(suffix[: n - size + 1], prefix[size - 1 : n])
    return np.where(np.isneginf(out), np.nan, out)


def _magnitude(x: np.ndarray) -> np.ndarray:
    """|x|, without a copy when no value is negative (wheel speeds as ABS sensors give them)."""
    return np.abs(x) if (x < 0).any() else x


def _median3(a: np.ndarray, b: np.ndarray, c3: np.ndarray) -> np.ndarray:
    """Element-wise median of three arrays (exactly the middle value, as ``np.median``;
    NaN anywhere gives NaN), without sorting."""
    return np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c3))


def glitch_mask(
    t_s: np.ndarray,
    wheels_rad_s: np.ndarray,
    radius_m: float,
    bound_g: float = WHEEL_GLITCH_G,
) -> np.ndarray:
    """Flag the samples of each wheel that changed faster than any tyre can.

    Args:
        t_s: sample times (n,), strictly increasing.
        wheels_rad_s: the four wheel speeds (4, n), or four arrays (n,), rad/s (signs
            ignored: magnitudes).
        radius_m: the car's nominal tyre radius, m (turns the bound into rad/s^2).
        bound_g: the bound, in g of circumferential acceleration above the road speed.
            The road speed is the other wheels' largest median within ±``WINDOW_S``; a
            rise that never falls back is flagged for ``MAX_RUN_S``.

    Returns:
        Boolean (4, n): True where a wheel's sample is part of a glitch.
    """
    t = np.asarray(t_s, dtype=np.float64)
    # Four arrays, not one stacked copy: a long stream's wheels are hundreds of MB each.
    w = [_magnitude(np.asarray(x, dtype=np.float64)) for x in wheels_rad_s]
    n = t.size
    out = np.zeros((4, n), dtype=bool)
    if n < 2:
        return out
    dt = np.diff(t)
    limit = bound_g * G_M_S2 / radius_m  # rad/s^2
    # A glitch starts where a wheel's excess over the road rose by more than limit x dt in a
    # step; the excess is at most the spread of the four wheels (the road speed is at least
    # their smallest). A drive whose spread never exceeds that has no glitch (most drives:
    # one pass instead of a dozen per wheel).
    lo = np.minimum(np.minimum(w[0], w[1]), np.minimum(w[2], w[3]))
    hi = np.maximum(np.maximum(w[0], w[1]), np.maximum(w[2], w[3]))
    with np.errstate(invalid="ignore"):
        if not np.any((hi[1:] - lo[1:]) * (1.0 + 1e-9) > limit * dt):
            return out
    del lo, hi
    half = max(int(round(WINDOW_S / float(np.median(dt)))), 0)
    others = [[j for j in range(4) if j != k] for k in range(4)]
    for k in range(4):  # per wheel, not per sample
        road = _median3(*(w[j] for j in others[k]))
        if half:
            road = running_max(road, 2 * half + 1)
        excess = np.maximum(w[k] - road, 0.0)
        rate = np.diff(excess) / dt
        up = np.flatnonzero(rate > limit) + 1  # rows where a glitch starts
        if up.size == 0:
            continue
        down = np.flatnonzero(rate < -limit) + 1  # rows where one has ended
        last_up = np.full(n, -1)
        last_up[up] = up
        last_up = np.maximum.accumulate(last_up)
        last_down = np.full(n, -1)
        last_down[down] = down
        last_down = np.maximum.accumulate(last_down)
        open_ = (last_up >= 0) & (last_up > last_down)
        out[k] = open_ & (t - t[np.maximum(last_up, 0)] < MAX_RUN_S)
        out[k, up] = True
    return out


def wheel_glitch_rows(
    drive: dict[str, np.ndarray],
    radius_m: float,
    bound_g: float = WHEEL_GLITCH_G,
) -> dict[str, np.ndarray]:
    """The rows of a canonical drive where a wheel speed changed faster than any tyre can.

    What validate cuts (rule ``wheel_glitch`` of :func:`rwhonet.data.quality.assess`, whose
    ``wheel_glitch`` argument is :func:`glitch_rows_mask`) and reports with the rows.

    Args:
        drive: canonical columns (``t_s`` and the four wheel speeds), e.g. a DataFrame.
        radius_m: the vehicle's nominal tyre radius, m.
        bound_g: the bound (:data:`WHEEL_GLITCH_G`).

    Returns:
        Wheel (canonical name) -> 0-based rows flagged, for wheels that have any.
    """
    mask = glitch_mask(
        np.asarray(drive[c.T_S], dtype=np.float64),
        np.stack([np.asarray(drive[w], dtype=np.float64) for w in c.WHEELS]),
        radius_m,
        bound_g,
    )
    return {w: np.flatnonzero(mask[k]) for k, w in enumerate(c.WHEELS) if mask[k].any()}


def glitch_rows_mask(
    drive: dict[str, np.ndarray], radius_m: float, bound_g: float = WHEEL_GLITCH_G
) -> np.ndarray:
    """Per row of a canonical drive, whether any wheel glitched there (for ``assess``)."""
    mask = glitch_mask(
        np.asarray(drive[c.T_S], dtype=np.float64),
        np.stack([np.asarray(drive[w], dtype=np.float64) for w in c.WHEELS]),
        radius_m,
        bound_g,
    )
    return mask.any(axis=0)


# A yaw rate no car turns at on its tyres. Turning on a circle of radius R at speed v takes
# v / R, with v^2 / R at most the friction's mu g and R at least the car's tightest:
# v / R <= sqrt(mu g / R_min) = 1.83 rad/s (105 deg/s) for mu = 1.2 (a sports tyre on dry
# asphalt) and R_min = 3.5 m (the rear axle's centre of a small car on full lock, 5 m kerb
# radius, 2.5 m wheelbase). A sample beyond 2 rad/s (115 deg/s) is a logger's glitch or a
# CAN signal's "invalid" code (an int16 at its full scale: 327.67 deg/s at 0.01 deg/s per
# bit), never a turn: one such 0.1 s row turns the dead-reckoned heading by 33 degrees.
# A car spinning beyond it has left its tyres' grip and every odometry with it.
YAW_RATE_LIMIT_RAD_S = 2.0
# A channel with more of its samples beyond the limit is not glitching but wrong (degrees
# per second declared as radians: every turn beyond 2 deg/s): it is left as it is, for the
# yaw-rate check to name (rwhonet.data.drivechecks.yaw_problems).
YAW_GLITCH_SHARE = 0.01


def yaw_rate_glitches(yaw_rate_rad_s: np.ndarray) -> np.ndarray:
    """Per sample, whether the yaw rate lies beyond :data:`YAW_RATE_LIMIT_RAD_S` (NaN: no)."""
    rate = np.asarray(yaw_rate_rad_s, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.abs(rate) > YAW_RATE_LIMIT_RAD_S


def repaired_yaw_rate(
    t_s: np.ndarray, yaw_rate_rad_s: np.ndarray, max_share: float = YAW_GLITCH_SHARE
) -> tuple[np.ndarray, np.ndarray]:
    """The yaw rate with its glitches (:func:`yaw_rate_glitches`) replaced.

    A glitched sample takes the rate interpolated in time between the nearest samples that
    are not glitched (the nearest one's beyond the first or last); with none, it is missing
    (NaN). A missing sample stays missing. A channel with more than ``max_share`` of its
    samples beyond the limit is returned as it is (:data:`YAW_GLITCH_SHARE`).

    Returns:
        ``(rate, mask)``: the repaired rate (a copy where anything was replaced) and the
        samples replaced.
    """
    rate = np.asarray(yaw_rate_rad_s, dtype=np.float64)
    mask = yaw_rate_glitches(rate)
    if not mask.any() or mask.sum() > max_share * np.isfinite(rate).sum():
        return rate, np.zeros_like(mask)
    t = np.asarray(t_s, dtype=np.float64)
    good = np.isfinite(rate) & ~mask
    fixed = rate.copy()
    fixed[mask] = np.interp(t[mask], t[good], rate[good]) if good.any() else np.nan
    return fixed, mask
