"""Drive simulator: the project's default data, written in the IO-VNBD "V-" layout.

The simulator is physics, not a label generator. A vehicle, driven in its
driver's style, follows a planned 2D trajectory; every wheel turns at its own
ground speed (rigid-body kinematics, steered front wheels) divided by its
effective rolling radius (pressure - which warms up and may leak during the
drive -, tread wear, payload, load and speed dependent) times ``1 + slip``
(traction/braking force and road wetness); sensors then sample that truth (CAN
wheel speeds; the ESC's yaw-rate gyro; a GNSS receiver whose error is a slow drift
smoothed by its navigation filter, with rare degraded stretches). The per-second
label the models learn (GNSS displacement - rear-wheel odometry, paper Eq. 11) is
never computed here: it emerges downstream from these physics. Models, parameters
and their sources: docs/simulator.md.

Modules: ``roadgrid`` (the route type) and ``route`` (building routes from road
types and events); ``motion`` (speed planning, time sampling, pose); ``vehicle``
(tyres, loads, slip, rolling radius); ``sensors`` (CAN wheel speeds, the ESC
gyro, the GNSS receiver); ``channels`` (the other IO-VNBD channels); ``drive``
(one drive); ``fleet`` (a whole profile); ``writer`` (the IO-VNBD CSV and its
sidecars); ``streams`` (a drive written as a real logger's separate streams).

Public API
----------
Fleet (what the DVC stage ``pipelines/simulate.py`` calls)::

    simulate_fleet(params: Params, out_dir: Path) -> dict
        Simulate the fleet of ``params.sim.profile`` and write, atomically,
        ``<out_dir>/<role>/<drive>.csv`` (29 IO-VNBD columns, header with the
        leading spaces of ``rwhonet.data.iovnbd.HEADERS``), ``<drive>.scenarios.json``
        (``{"intervals": [{"start_s", "end_s", "tag"}]}`` in the file's own time
        column) and ``<drive>.truth.json`` (vehicle, tyre state, true radii, seed),
        plus ``<out_dir>/fleet.json`` (resolved settings and a per-drive summary).
        Returns that summary. Drive i is seeded with
        ``SeedSequence(params.sim.seed, spawn_key=(i,))`` (= ``SeedSequence(seed).spawn(n)[i]``)
        and driven by the car its profile maps ``drive.vehicle`` to, carrying the
        drive's payload (``Vehicle.with_payload``) and leaks, and the receiver grade
        the profile fits to it (``sim.profiles.<p>.receivers``), if any.

    vehicles_from_params(params: Params, profile: str | None = None) -> dict[str, Vehicle]
        The cars of a profile (default ``sim.profile``) keyed by the pipeline's
        vehicle names (``source``, ``target``); each is named after its
        ``sim.vehicles`` key and carries that car's spec-sheet nominal radius.

One drive (for tests, and for other packages' tests)::

    simulate_drive(vehicle, tyre_state, route, seed, sim, *, options=SimOptions(),
                   gnss_faults=(), name="sim", start_s_of_day=None, leaks=()) -> SimulatedDrive
        ``route`` is a :class:`Route`; ``SimulatedDrive`` is the named tuple
        ``(frame, scenarios, truth, state)``: the IO-VNBD DataFrame (exactly what
        the CSV holds), the scenario intervals, the truth dict and the 50 Hz
        ground-truth :class:`DriveState` (poses, wheel speeds, radii, slips,
        tyre pressures).

    Routes: ``generate_route(drive: SimDrive, sim, vehicle, rng)`` (a random
    drive of the configured road mix, events and duration),
    ``straight_route(speed_m_s, duration_s)``,
    ``steady_turn_route(radius_m, speed_m_s, duration_s, left=True)``.

    ``SimOptions`` switches physics and sensor effects off for special drives:
    ``SimOptions.ideal()`` gives zero slip, radius independent of load and
    speed, no tyre warm-up, no CAN noise/quantisation/latency, no GNSS error, a
    perfect gyro (the yaw-rate column sums, times 0.1 s, to the heading change):
    on such a drive the calibrated radius must equal ``truth["radius_static_m"]``.

Example: a straight constant-speed drive with perfect sensors::

    from rwhonet.config import load_params
    from rwhonet.sim import SimOptions, simulate_drive, straight_route, vehicles_from_params

    params = load_params()
    car = vehicles_from_params(params)["source"]
    frame, scenarios, truth, state = simulate_drive(
        car, "A", straight_route(15.0, 300.0), seed=0, sim=params.sim,
        options=SimOptions.ideal())
"""

from rwhonet.sim.drive import DriveState, SimOptions, SimulatedDrive, simulate_drive, simulate_truth
from rwhonet.sim.fleet import drive_seed, simulate_fleet, vehicles_from_params
from rwhonet.sim.roadgrid import Route
from rwhonet.sim.route import generate_route, steady_turn_route, straight_route
from rwhonet.sim.vehicle import Vehicle

__all__ = [
    "DriveState",
    "Route",
    "SimOptions",
    "SimulatedDrive",
    "Vehicle",
    "drive_seed",
    "generate_route",
    "simulate_drive",
    "simulate_fleet",
    "simulate_truth",
    "steady_turn_route",
    "straight_route",
    "vehicles_from_params",
]
