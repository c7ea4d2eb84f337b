"""Simulate a whole fleet profile (``params.sim.profiles[params.sim.profile]``)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet.config import ConfigError, Params
from rwhonet.io import atomic_dir
from rwhonet.sim.drive import child_rng, simulate_drive
from rwhonet.sim.route import generate_route
from rwhonet.sim.vehicle import Vehicle
from rwhonet.sim.writer import write_drive, write_json

_RNG_ROUTE = 0  # child stream 0 of a drive's seed lays out its route


def vehicles_from_params(params: Params) -> dict[str, Vehicle]:
    """The simulated vehicles, with nominal radii from ``data.vehicles``.

    Args:
        params: the project parameters.

    Returns:
        Vehicles by name.

    Raises:
        ConfigError: if a simulated vehicle has no ``data.vehicles`` entry (the
            pipeline would not know its nominal radius).
    """
    out = {}
    for name, spec in params.sim.vehicles.items():
        if name not in params.data.vehicles:
            raise ConfigError(
                f"sim.vehicles.{name} has no data.vehicles.{name}.nominal_radius_m; "
                f"expected one of {sorted(params.data.vehicles)}"
            )
        out[name] = Vehicle(name, params.data.vehicles[name].nominal_radius_m, spec)
    return out


def drive_seed(seed: int, index: int) -> np.random.SeedSequence:
    """Seed of drive ``index``: ``SeedSequence(seed).spawn(n)[index]``, statelessly.

    Args:
        seed: ``params.seed``.
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
        params: the project parameters (``seed``, ``sim``, ``data.vehicles``).
        out_dir: the output folder (``rwhonet.paths.SIM`` for the stage).

    Returns:
        ``{"profile", "seed", "drives": [{drive, role, vehicle, tyre_state,
        duration_s, distance_m, n_rows, gnss_faults}], "roles": {role: {"drives",
        "hours", "km"}}, "seconds"}``.
    """
    sim = params.sim
    vehicles = vehicles_from_params(params)
    drives = sim.profiles[sim.profile].drives
    started = time.perf_counter()
    rows = []
    with atomic_dir(Path(out_dir)) as tmp:
        for i, spec in enumerate(drives):
            seed = drive_seed(params.seed, i)
            vehicle = vehicles[spec.vehicle]
            route = generate_route(spec, sim, vehicle, child_rng(seed, _RNG_ROUTE))
            frame, scenarios, truth, _ = simulate_drive(
                vehicle, spec.tyre, route, seed, sim, gnss_faults=spec.gnss_faults, name=spec.name
            )
            truth["role"] = spec.role
            write_drive(tmp / spec.role, spec.name, frame, scenarios, truth)
            rows.append(
                {
                    "drive": spec.name,
                    "role": spec.role,
                    "vehicle": spec.vehicle,
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
        summary = {"profile": sim.profile, "seed": params.seed, "drives": rows, "roles": roles}
        write_json(tmp / "fleet.json", {**summary, "sim": params.section("sim")})
    summary["seconds"] = round(time.perf_counter() - started, 2)
    return summary
