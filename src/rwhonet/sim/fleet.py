"""Simulate a whole fleet profile (``params.sim.profiles[params.sim.profile]``)."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet.config import ConfigError, Params
from rwhonet.io import atomic_dir
from rwhonet.progress import track
from rwhonet.sim.drive import child_rng, simulate_drive
from rwhonet.sim.route import generate_route
from rwhonet.sim.vehicle import Vehicle
from rwhonet.sim.writer import write_drive, write_json

_RNG_ROUTE = 0  # child stream 0 of a drive's seed lays out its route


def vehicles_from_params(params: Params, profile: str | None = None) -> dict[str, Vehicle]:
    """The simulated cars of a profile, keyed by the pipeline's vehicle names.

    Args:
        params: the project parameters.
        profile: a key of ``sim.profiles``; default: ``sim.profile``.

    Returns:
        ``{pipeline vehicle name (source, target): Vehicle}``; each Vehicle is
        named after its ``sim.vehicles`` key and carries that car's spec-sheet
        nominal radius (``sim.vehicles.<car>.nominal_radius_m``); where the
        profile fits a receiver grade to a vehicle (``receivers``), that grade
        replaces the car's own GNSS receiver and names ``Vehicle.receiver``.

    Raises:
        ConfigError: if the profile does not exist.
    """
    sim = params.sim
    name = sim.profile if profile is None else profile
    if name not in sim.profiles:
        raise ConfigError(f"profile {name!r} is not in sim.profiles {sorted(sim.profiles)}")
    prof = sim.profiles[name]
    cars = {}
    for role, car in prof.vehicles.items():
        spec, grade = sim.vehicles[car], prof.receivers.get(role)
        if grade is not None:
            spec = replace(spec, gnss=sim.receivers[grade])
        cars[role] = Vehicle(car, spec.nominal_radius_m, spec, receiver=grade)
    return cars


def drive_seed(seed: int, index: int) -> np.random.SeedSequence:
    """Seed of drive ``index``: ``SeedSequence(seed).spawn(n)[index]``, statelessly.

    Args:
        seed: ``params.sim.seed``.
        index: position of the drive in its profile.

    Returns:
        The drive's SeedSequence.
    """
    return np.random.SeedSequence(seed, spawn_key=(index,))


def simulate_fleet(params: Params, out_dir: Path) -> dict[str, Any]:
    """Simulate every drive of the selected profile and write them atomically.

    Writes ``<out_dir>/<role>/<drive>.csv`` with ``.scenarios.json`` and
    ``.truth.json`` sidecars, and ``<out_dir>/fleet.json`` (seed, profile, the
    resolved ``sim`` section and the per-drive summary returned here). Either
    all of it replaces ``out_dir`` or nothing does.

    Args:
        params: the project parameters (``sim``).
        out_dir: the output folder (``rwhonet.paths.SIM`` for the stage).

    Returns:
        ``{"profile", "seed", "vehicles", "drives": [{drive, role, vehicle,
        sim_vehicle, tyre_state, duration_s, distance_m, n_rows, gnss_faults}],
        "roles": {role: {"drives", "hours", "km"}}, "seconds"}``.
    """
    sim = params.sim
    vehicles = vehicles_from_params(params)
    drives = sim.profiles[sim.profile].drives
    started = time.perf_counter()
    rows = []
    with atomic_dir(Path(out_dir)) as tmp:
        for i, spec in enumerate(
            track(drives, desc="simulate", unit="drive", label=lambda spec: spec.name)
        ):
            seed = drive_seed(sim.seed, i)
            vehicle = vehicles[spec.vehicle].with_payload(spec.payload_kg, spec.payload_x_m)
            route = generate_route(spec, sim, vehicle, child_rng(seed, _RNG_ROUTE))
            frame, scenarios, truth, _ = simulate_drive(
                vehicle,
                spec.tyre,
                route,
                seed,
                sim,
                gnss_faults=spec.gnss_faults,
                name=spec.name,
                leaks=spec.leaks,
            )
            truth["role"] = spec.role
            truth["pipeline_vehicle"] = spec.vehicle
            write_drive(tmp / spec.role, spec.name, frame, scenarios, truth)
            rows.append(
                {
                    "drive": spec.name,
                    "role": spec.role,
                    "vehicle": spec.vehicle,
                    "sim_vehicle": vehicle.name,
                    "gnss_receiver": vehicle.receiver or "own",
                    "tyre_state": spec.tyre,
                    "duration_s": truth["duration_s"],
                    "distance_m": truth["distance_m"],
                    "n_rows": int(len(frame)),
                    "gnss_faults": [f["kind"] for f in truth["gnss_faults"]],
                }
            )
        roles: dict[str, dict[str, float]] = {}
        for r in rows:
            agg = roles.setdefault(r["role"], {"drives": 0, "hours": 0.0, "km": 0.0})
            agg["drives"] += 1
            agg["hours"] += r["duration_s"] / 3600.0
            agg["km"] += r["distance_m"] / 1000.0
        roles = {
            k: {**v, "hours": round(v["hours"], 3), "km": round(v["km"], 2)}
            for k, v in roles.items()
        }
        summary = {
            "profile": sim.profile,
            "seed": sim.seed,
            "vehicles": dict(sim.profiles[sim.profile].vehicles),
            "receivers": dict(sim.profiles[sim.profile].receivers),
            "drives": rows,
            "roles": roles,
        }
        write_json(tmp / "fleet.json", {**summary, "sim": params.section("sim")})
    summary["seconds"] = round(time.perf_counter() - started, 2)
    return summary
