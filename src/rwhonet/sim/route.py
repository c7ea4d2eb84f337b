"""Routes: road geometry, speed caps and manoeuvres along the travelled distance.

A :class:`Route` is sampled on a regular grid of travelled distance ``s`` (every
``ds_m`` metres, counted forwards and backwards alike). At each node it holds the
path curvature, the speed the driver would like to drive, the acceleration and
deceleration the driver uses, stops (and how long the car stands), the direction
of travel (reversing) and whether the road is wet. :mod:`rwhonet.sim.motion`
turns a route into a speed profile and a time series.

Random routes are built from *legs* (a stretch of one road type driven at a
leg cruise speed) filled with *events* (:data:`rwhonet.config.SIM_EVENTS`): a
handful of Python objects per kilometre, rasterised onto the grid with array
slices; nothing here loops over grid nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from rwhonet.config import SIM_EVENTS, ConfigError, SimDrive, SimDriver, SimParams, SimRoad
from rwhonet.sim.motion import plan_speed
from rwhonet.sim.roadgrid import Route
from rwhonet.sim.vehicle import Vehicle

DS_M = 0.5  # grid step of the travelled distance (at 31 m/s: 62 nodes per second)

# Driving-time to distance: a leg of duration T at cruise speed v is about
# eta * v * T long (stops, curves and events slow the car). Deliberately low, so
# the legs that carry a drive's explicit events end before the drive does and
# the extension legs (see generate_route) absorb the remainder.
_ETA = {"urban": 0.45, "country": 0.7, "motorway": 0.85}
_ETA_DEFAULT = 0.6
_WET_SPEED_FACTOR = 0.9  # drivers slow down on wet roads
_WET_STRETCH_M = 3000.0  # typical length of one wet stretch


@dataclass
class Block:
    """One event, in metres from its own start.

    Attributes:
        length_m: length of the block along the travelled distance.
        turns: ``(s0, angle_rad, radius_m, ramp_m)``: a turn of signed heading
            change (left +) with clothoid ramps (linear curvature change).
        caps: ``(s0, s1, v_max_m_s)`` speed caps.
        stops: ``(s, dwell_s)``: the car stops and stands ``dwell_s``.
        accel: ``(s0, s1, a_m_s2)`` acceleration the driver uses there.
        decel: ``(s0, s1, d_m_s2)`` deceleration the driver uses there (> 0).
        reverse: ``(s0, s1)`` travelled backwards.
        tags: ``(s0, s1, tag)`` scenario intervals.
    """

    length_m: float
    turns: list[tuple[float, float, float, float]] = field(default_factory=list)
    caps: list[tuple[float, float, float]] = field(default_factory=list)
    stops: list[tuple[float, float]] = field(default_factory=list)
    accel: list[tuple[float, float, float]] = field(default_factory=list)
    decel: list[tuple[float, float, float]] = field(default_factory=list)
    reverse: list[tuple[float, float]] = field(default_factory=list)
    tags: list[tuple[float, float, str]] = field(default_factory=list)


def _uniform_route(
    length_m: float,
    speed_m_s: float,
    curvature_1_m: float,
    accel_m_s2: float,
    duration_s: float | None,
    tags: tuple[tuple[float, float, str], ...] = (),
) -> Route:
    n = int(math.ceil(length_m / DS_M)) + 1
    stop = np.zeros(n, dtype=bool)
    stop[[0, -1]] = True
    return Route(
        ds_m=DS_M,
        curvature_1_m=np.full(n, curvature_1_m),
        v_max_m_s=np.full(n, speed_m_s),
        accel_m_s2=np.full(n, accel_m_s2),
        decel_m_s2=np.full(n, accel_m_s2),
        stop=stop,
        dwell_s=np.zeros(n),
        direction=np.ones(n, dtype=np.int8),
        wet=np.zeros(n, dtype=bool),
        tags=tags,
        duration_s=duration_s,
    )


def straight_route(speed_m_s: float, duration_s: float, accel_m_s2: float = 2.0) -> Route:
    """A straight, dry road driven at a constant speed for about ``duration_s``.

    The car starts from rest and accelerates at ``accel_m_s2``; the route is long
    enough that the recording (``duration_s``) ends while it still cruises.

    Args:
        speed_m_s: cruise speed.
        duration_s: recording length, s.
        accel_m_s2: acceleration from rest.

    Returns:
        The route.
    """
    length = speed_m_s * duration_s + speed_m_s**2 / accel_m_s2
    return _uniform_route(length, speed_m_s, 0.0, accel_m_s2, duration_s)


def steady_turn_route(
    radius_m: float, speed_m_s: float, duration_s: float, left: bool = True
) -> Route:
    """A circle of constant radius driven at a constant speed (a steady turn).

    Args:
        radius_m: radius of the rear-axle-centre path, m.
        speed_m_s: cruise speed (the planner lowers it if ``v^2 / R`` exceeds the
            lateral-acceleration limit).
        duration_s: recording length, s.
        left: turn left (counter-clockwise) or right.

    Returns:
        The route, tagged ``steady_turn`` throughout.
    """
    length = speed_m_s * duration_s + speed_m_s**2
    kappa = (1.0 if left else -1.0) / radius_m
    return _uniform_route(
        length, speed_m_s, kappa, 1.0, duration_s, tags=((0.0, length, "steady_turn"),)
    )


# --------------------------------------------------------------------------- events


def _turn_length(angle_rad: float, radius_m: float, ramp_m: float) -> tuple[float, float]:
    """Return (total length, effective ramp) of a clothoid-arc-clothoid turn."""
    arc = abs(angle_rad) * radius_m
    ramp = min(ramp_m, arc)
    return arc + ramp, ramp


def _uniform(rng: np.random.Generator, pair: list[float] | tuple[float, float]) -> float:
    return float(rng.uniform(pair[0], pair[1]))


def _event_stop(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """Traffic lights, give-way and stop junctions: stop, stand 3-40 s."""
    return Block(10.0, stops=[(5.0, _uniform(rng, (3.0, 40.0)))])


def _event_standstill(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """A long standstill (parked with the engine on, queue): 60-240 s."""
    dwell = _uniform(rng, (60.0, 240.0))
    return Block(10.0, stops=[(5.0, dwell)], tags=[(5.0, 5.0, "standstill")])


def _event_traffic(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """Congestion: 15-50 % of the leg speed over 80-400 m (x2 on motorways), maybe stop-and-go."""
    length = _uniform(rng, (80.0, 400.0)) * (2.0 if v > 25.0 else 1.0)
    block = Block(length, caps=[(0.0, length, v * _uniform(rng, (0.15, 0.5)))])
    if rng.random() < 0.3:  # stop-and-go
        block.stops.append((length / 2.0, _uniform(rng, (2.0, 15.0))))
    block.tags.append((0.0, length, "traffic"))
    return block


def _event_curve(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """A road curve of the leg's radius and angle ranges, with clothoid transitions."""
    radius = _uniform(rng, road.curve_radius_m)
    angle = math.radians(_uniform(rng, road.curve_angle_deg)) * rng.choice([-1.0, 1.0])
    # Clothoid length from a comfortable rate of change of lateral acceleration
    # (~0.5 m/s^3 at the leg speed), as in road design.
    ramp = float(np.clip(v**3 / (0.5 * radius), 10.0, 150.0))
    length, ramp = _turn_length(angle, radius, ramp)
    return Block(length, turns=[(0.0, angle, radius, ramp)])


def _event_roundabout(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """UK roundabout: left deflection in, clockwise circulation, left deflection out."""
    # Net heading change by exit: left, ahead, right, back.
    net_deg = float(rng.choice([90.0, 0.0, -90.0, -180.0], p=[0.3, 0.35, 0.25, 0.1]))
    deflect = math.radians(40.0)
    circulate = -math.radians(max(80.0 - net_deg, 20.0))
    s = 10.0
    block = Block(0.0)
    if rng.random() < 0.35:  # give way to circulating traffic
        block.stops.append((s, _uniform(rng, (1.0, 8.0))))
    for angle, radius in (
        (deflect, _uniform(rng, (15.0, 25.0))),
        (circulate, _uniform(rng, (12.0, 25.0))),
        (deflect, _uniform(rng, (15.0, 25.0))),
    ):
        length, ramp = _turn_length(angle, radius, 6.0)
        block.turns.append((s, angle, radius, ramp))
        s += length
    block.length_m = s + 10.0
    block.caps.append((0.0, block.length_m, _uniform(rng, (5.5, 8.5))))
    block.tags.append((0.0, block.length_m, "roundabout"))
    return block


def _event_sharp_turn(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """A junction turn or U-turn (80-180 deg, radius 5.5-9 m)."""
    # Radius >= 5.5 m: a small car's turning circle.
    angle = math.radians(_uniform(rng, (80.0, 180.0))) * rng.choice([-1.0, 1.0])
    radius = _uniform(rng, (5.5, 9.0))
    length, ramp = _turn_length(angle, radius, 4.0)
    return Block(
        length + 20.0,
        turns=[(10.0, angle, radius, ramp)],
        tags=[(10.0, 10.0 + length, "sharp_turn")],
    )


def _event_successive_turns(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """2-4 alternating left/right turns of about 90 deg, 20-60 m apart."""
    n = int(rng.integers(2, 5))
    sign = rng.choice([-1.0, 1.0])
    block = Block(0.0)
    s = 10.0
    for i in range(n):
        angle = math.radians(_uniform(rng, (70.0, 100.0))) * sign * (-1.0) ** i
        radius = _uniform(rng, (8.0, 14.0))
        length, ramp = _turn_length(angle, radius, 5.0)
        block.turns.append((s, angle, radius, ramp))
        s += length + (_uniform(rng, (20.0, 60.0)) if i < n - 1 else 0.0)
    block.tags.append((10.0, s, "successive_turns"))
    block.length_m = s + 10.0
    return block


def _event_hard_brake(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """Cruise, then an emergency brake at 0.5-0.7 g to a stop or a much lower speed."""
    decel = _uniform(rng, (5.0, 7.0))
    v_hi = 1.1 * v  # leg speed with its slow fluctuation
    lead = v_hi**2 / (2.0 * road.accel_m_s2) + 30.0
    window = v_hi**2 / (2.0 * decel) + 10.0
    s_event = lead + window
    block = Block(s_event + 40.0, decel=[(lead, s_event, decel)])
    if rng.random() < 0.6:
        block.stops.append((s_event, _uniform(rng, (1.0, 6.0))))
    else:
        block.caps.append((s_event, s_event + 30.0, v * _uniform(rng, (0.2, 0.5))))
    block.tags.append((lead, s_event, "hard_brake"))
    return block


def _event_quick_acceleration(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """Pull away from a stop at 3-4 m/s^2 (0.3-0.4 g)."""
    accel = _uniform(rng, (3.0, 4.0))
    length = (1.1 * v) ** 2 / (2.0 * accel) + 20.0
    return Block(
        5.0 + length + 10.0,
        stops=[(5.0, _uniform(rng, (2.0, 10.0)))],
        accel=[(5.0, 5.0 + length, accel)],
        tags=[(5.0, 5.0 + length, "quick_acceleration")],
    )


def _event_reversing(rng: np.random.Generator, road: SimRoad, v: float) -> Block:
    """Parking or a three-point turn: stop, reverse 5-20 m (maybe steering), stop."""
    length = _uniform(rng, (5.0, 20.0))
    block = Block(5.0 + length + 10.0)
    block.stops += [(5.0, _uniform(rng, (1.0, 4.0))), (5.0 + length, _uniform(rng, (1.0, 4.0)))]
    block.reverse.append((5.0, 5.0 + length))
    block.caps.append((5.0, 5.0 + length, _uniform(rng, (1.5, 2.5))))
    radius = _uniform(rng, (6.0, 10.0))
    ramp = 2.0
    angle = min(math.radians(_uniform(rng, (0.0, 60.0))), (length - ramp - 1.0) / radius)
    if angle > 0.0:
        turn_len, ramp = _turn_length(angle, radius, ramp)
        block.turns.append(
            (5.0 + 0.5 * (length - turn_len), angle * rng.choice([-1, 1]), radius, ramp)
        )
    block.tags.append((5.0, 5.0 + length, "reversing"))
    return block


_EVENTS = {
    "stop": _event_stop,
    "standstill": _event_standstill,
    "traffic": _event_traffic,
    "curve": _event_curve,
    "roundabout": _event_roundabout,
    "sharp_turn": _event_sharp_turn,
    "successive_turns": _event_successive_turns,
    "hard_brake": _event_hard_brake,
    "quick_acceleration": _event_quick_acceleration,
    "reversing": _event_reversing,
}
assert set(_EVENTS) == set(SIM_EVENTS)


# --------------------------------------------------------------------------- random routes


@dataclass
class _Leg:
    road: str
    duration_s: float
    speed_m_s: float
    length_m: float
    events: dict[str, int] = field(default_factory=dict)


def _legs(
    drive: SimDrive,
    roads: dict[str, SimRoad],
    driver: SimDriver,
    duration_s: float,
    rng: np.random.Generator,
    eta_scale: float = 1.0,
) -> list[_Leg]:
    """Split ``duration_s`` of driving into legs, by road type, in random order."""
    total = sum(drive.roads.values())
    legs: list[_Leg] = []
    for name in sorted(drive.roads):
        share = drive.roads[name] / total if total > 0 else 0.0
        road = roads[name]
        remaining = share * duration_s
        while remaining > 1.0:
            dur = min(_uniform(rng, road.leg_s), remaining)
            remaining -= dur
            speed = _uniform(rng, road.speed_m_s) * driver.speed_factor
            length = dur * speed * _ETA.get(name, _ETA_DEFAULT) * eta_scale
            legs.append(_Leg(name, dur, speed, length))
    order = rng.permutation(len(legs))
    return [legs[i] for i in order]


def _assign_events(
    legs: list[_Leg],
    roads: dict[str, SimRoad],
    explicit: dict[str, int],
    scale: float,
    rng: np.random.Generator,
) -> None:
    """Give each leg its event counts: Poisson by road rate, or the drive's explicit counts."""
    lengths_km = np.array([leg.length_m for leg in legs]) / 1000.0
    for kind in SIM_EVENTS:
        if kind in explicit:
            # Spread the drive's count over legs whose road has this event at all.
            rates = np.array([roads[leg.road].per_km.get(kind, 0.0) for leg in legs])
            weight = lengths_km * (rates > 0) if rates.any() else lengths_km.copy()
            counts = rng.multinomial(explicit[kind], weight / weight.sum())
        else:
            rates = np.array([roads[leg.road].per_km.get(kind, 0.0) for leg in legs])
            counts = rng.poisson(rates * lengths_km * scale)
        for leg, count in zip(legs, counts, strict=True):
            if count:
                leg.events[kind] = int(count)


@dataclass
class _Layout:
    """Blocks placed along the travelled distance, plus per-leg ranges."""

    blocks: list[tuple[float, Block]] = field(default_factory=list)
    legs: list[tuple[float, float, _Leg]] = field(default_factory=list)
    length_m: float = 0.0
    main_end_m: float = 0.0  # where the legs carrying the drive's explicit events end


def _lay_out(legs: list[_Leg], roads: dict[str, SimRoad], rng, layout: _Layout) -> None:
    """Place each leg's events, separated by straight gaps, after ``layout.length_m``."""
    for leg in legs:
        road = roads[leg.road]
        kinds = [k for k in SIM_EVENTS for _ in range(leg.events.get(k, 0))]
        kinds = [kinds[i] for i in rng.permutation(len(kinds))]
        blocks = [_EVENTS[k](rng, road, leg.speed_m_s) for k in kinds]
        used = sum(b.length_m for b in blocks)
        free = max(leg.length_m - used, 0.0)
        gaps = 20.0 + free * rng.dirichlet(np.ones(len(blocks) + 1))
        start = layout.length_m
        s = start + gaps[0]
        for block, gap in zip(blocks, gaps[1:], strict=True):
            layout.blocks.append((s, block))
            s += block.length_m + gap
        layout.legs.append((start, s, leg))
        layout.length_m = s


def _rasterise(
    layout: _Layout,
    roads: dict[str, SimRoad],
    driver: SimDriver,
    wet_m: list[tuple[float, float]],
    rng,
) -> Route:
    """Turn placed legs and blocks into grid arrays (slices per block, no loop over nodes)."""
    n = int(math.ceil(layout.length_m / DS_M)) + 1
    s_nodes = np.arange(n) * DS_M
    kappa = np.zeros(n)
    v_max = np.zeros(n)
    accel = np.zeros(n)
    decel = np.zeros(n)
    stop = np.zeros(n, dtype=bool)
    dwell = np.zeros(n)
    direction = np.ones(n, dtype=np.int8)
    wet = np.zeros(n, dtype=bool)
    tags: list[tuple[float, float, str]] = []

    def span(s0: float, s1: float) -> slice:
        return slice(int(math.ceil(s0 / DS_M - 1e-9)), int(math.floor(s1 / DS_M + 1e-9)) + 1)

    for s0, s1, leg in layout.legs:
        road = roads[leg.road]
        sl = span(s0, s1)
        v_max[sl] = leg.speed_m_s
        accel[sl] = road.accel_m_s2 * driver.accel_factor
        decel[sl] = road.decel_m_s2 * driver.decel_factor
        tags.append((s0, s1, leg.road))
    # Drivers do not hold a speed exactly: a slow +-4..8 % wander every few hundred metres.
    knots = np.cumsum(rng.uniform(300.0, 800.0, size=int(layout.length_m / 300.0) + 2))
    knots = np.concatenate([[0.0], knots])
    v_max *= np.interp(s_nodes, knots, rng.uniform(0.92, 1.06, size=knots.size))

    for offset, b in layout.blocks:
        for t0, angle, radius, ramp in b.turns:
            length = abs(angle) * radius + ramp
            sl = span(offset + t0, offset + t0 + length)
            local = s_nodes[sl] - (offset + t0)
            k = math.copysign(1.0 / radius, angle)
            kappa[sl] += np.interp(local, [0.0, ramp, length - ramp, length], [0.0, k, k, 0.0])
        for c0, c1, cap in b.caps:
            sl = span(offset + c0, offset + c1)
            v_max[sl] = np.minimum(v_max[sl], cap)
        for a0, a1, a in b.accel:
            accel[span(offset + a0, offset + a1)] = a
        for d0, d1, d in b.decel:
            decel[span(offset + d0, offset + d1)] = d
        for r0, r1 in b.reverse:
            # Same rounding as the stops that bracket the reverse piece, so the
            # direction only ever changes where the car stands.
            direction[int(round((offset + r0) / DS_M)) : int(round((offset + r1) / DS_M))] = -1
        for st, dw in b.stops:
            i = int(round((offset + st) / DS_M))
            stop[i] = True
            dwell[i] = max(dwell[i], dw)
        tags.extend((offset + t0, offset + t1, tag) for t0, t1, tag in b.tags)
    for w0, w1 in wet_m:
        sl = span(w0, w1)
        wet[sl] = True
        v_max[sl] *= _WET_SPEED_FACTOR
        tags.append((w0, w1, "wet_road"))
    stop[[0, -1]] = True
    dwell[0] = rng.uniform(2.0, 10.0)  # engine on, standing, before pulling away
    # Two stops on neighbouring nodes would mean moving 0.5 m at zero speed.
    adjacent = stop[1:] & stop[:-1]
    if adjacent.any():
        j = np.flatnonzero(adjacent) + 1
        dwell[j - 1] += dwell[j]
        stop[j] = False
        dwell[j] = 0.0
        stop[-1] = True
    return Route(
        ds_m=DS_M,
        curvature_1_m=kappa,
        v_max_m_s=v_max,
        accel_m_s2=accel,
        decel_m_s2=decel,
        stop=stop,
        dwell_s=dwell,
        direction=direction,
        wet=wet,
        tags=tuple(sorted(tags)),
    )


def _wet_stretches(length_m: float, fraction: float, rng) -> list[tuple[float, float]]:
    """Non-overlapping wet stretches covering ``fraction`` of ``length_m``."""
    if fraction <= 0.0 or length_m <= 0.0:
        return []
    wet_total = min(fraction, 1.0) * length_m
    k = max(1, int(math.ceil(wet_total / _WET_STRETCH_M)))
    each = wet_total / k
    # k stretches in random order in the dry remainder: sorted cut points.
    cuts = np.sort(rng.uniform(0.0, length_m - wet_total, size=k))
    starts = cuts + each * np.arange(k)
    return [(float(a), float(a + each)) for a in starts]


def _build(
    drive: SimDrive,
    sim: SimParams,
    driver: SimDriver,
    rng: np.random.Generator,
    extension: int,
    eta_scale: float,
) -> tuple[Route, float]:
    """Lay out a random route for ``drive`` (no speed planning, no duration cut).

    The legs for ``drive.duration_s`` carry the drive's explicit event counts;
    ``extension`` further sets of legs (each for half the duration, road rates
    only) make sure the route outlasts the recording.

    Returns:
        The route and where the legs with the explicit events end (m).
    """
    for kind in drive.events:
        if kind not in SIM_EVENTS:
            raise ConfigError(f"drive {drive.name}: unknown event {kind!r}; expected {SIM_EVENTS}")
    main = _legs(drive, sim.roads, driver, drive.duration_s, rng, eta_scale)
    _assign_events(main, sim.roads, drive.events, drive.event_scale, rng)
    layout = _Layout()
    _lay_out(main, sim.roads, rng, layout)
    main_end = layout.length_m
    wet = _wet_stretches(main_end, drive.wet_fraction, rng)
    for _ in range(extension):
        extra = _legs(drive, sim.roads, driver, 0.5 * drive.duration_s, rng, eta_scale)
        _assign_events(extra, sim.roads, {}, drive.event_scale, rng)
        _lay_out(extra, sim.roads, rng, layout)
    return _rasterise(layout, sim.roads, driver, wet, rng), main_end


def _fit(route: Route, vehicle: Vehicle, sim: SimParams, target: float) -> Route | None:
    """Cut ``route`` so the car stops at a node it reaches before ``target``, then stands.

    Returns:
        The cut route lasting exactly ``target`` seconds, or None if the route is
        too short.
    """
    plan = plan_speed(route, vehicle, sim)
    margin = 20.0
    while margin < 2.0 * target:
        # The last node reached ``margin`` before the end (maybe a long standstill).
        last = int(np.searchsorted(plan.arrival_s, max(target - margin, 0.0), side="right")) - 1
        if last >= route.n - 1:
            return None
        short = route.truncated(max(last + 1, 3))
        arrive = plan_speed(short, vehicle, sim).arrival_s[-1]
        if arrive <= target:
            tags = short.tags
            s_end = (short.n - 1) * short.ds_m
            tagged = any(t == "standstill" and s_end - s0 < short.ds_m for s0, _, t in tags)
            if target - arrive >= 20.0 and not tagged:
                tags = (*tags, (s_end, s_end, "standstill"))
            return replace(
                short.truncated(short.n, end_dwell_s=target - arrive),
                tags=tags,
                duration_s=target,
            )
        margin *= 2.0
    return None


def generate_route(
    drive: SimDrive, sim: SimParams, vehicle: Vehicle, rng: np.random.Generator
) -> Route:
    """A random route for ``drive`` that lasts exactly ``drive.duration_s``.

    The laid-out route is planned, cut at a node reached shortly before the end
    of the drive (the car brakes to a stop there) and the remaining time is
    spent standing (engine on), so the recording ends with the car at rest. If
    the cut would drop some of the drive's explicit events (``drive.events``),
    the legs carrying them are laid out shorter and the route rebuilt; counts
    that cannot fit the duration at all are kept as far as they fit.

    Args:
        drive: the drive spec.
        sim: simulator settings.
        vehicle: the vehicle (traction limits of the speed plan; its driver's
            speed and acceleration factors).
        rng: random generator.

    Returns:
        The route, with ``duration_s`` set.
    """
    base_seed = int(rng.integers(2**63))
    target = float(drive.duration_s)
    best = None
    for eta_scale in (1.0, 0.7, 0.5, 0.35):
        for extension in (1, 2, 4, 8, 16):
            # Same seed each attempt: the layout only changes where asked to.
            rng_layout = np.random.default_rng(base_seed)
            driver = vehicle.params.driver
            route, main_end = _build(drive, sim, driver, rng_layout, extension, eta_scale)
            fitted = _fit(route, vehicle, sim, target)
            if fitted is not None:
                break
        else:
            continue
        best = fitted
        if not drive.events or (fitted.n - 1) * fitted.ds_m >= main_end:
            return fitted
    if best is None:
        raise RuntimeError(f"could not lay out a route of {target} s for drive {drive.name}")
    return best
