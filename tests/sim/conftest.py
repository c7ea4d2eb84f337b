"""Shared fixtures of the simulator tests: the project's params and small drives."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rwhonet.config import Params, SimDrive, load_params
from rwhonet.sim import Vehicle, generate_route, simulate_drive, vehicles_from_params
from rwhonet.sim.drive import SimulatedDrive


@pytest.fixture(scope="session")
def params() -> Params:
    return load_params()


@pytest.fixture(scope="session")
def vehicles(params: Params) -> dict[str, Vehicle]:
    return vehicles_from_params(params)


@pytest.fixture(scope="session")
def source(vehicles: dict[str, Vehicle]) -> Vehicle:
    return vehicles["source"]


@pytest.fixture(scope="session")
def target(vehicles: dict[str, Vehicle]) -> Vehicle:
    return vehicles["target"]


@pytest.fixture(scope="session")
def cars(params: Params) -> dict[str, Vehicle]:
    """Every simulated car of every profile, by its sim.vehicles key, with its own receiver."""
    return {
        car.name: car
        for profile in params.sim.profiles
        for car in vehicles_from_params(params, profile).values()
        if car.receiver is None
    }


def drive_spec(**kw) -> SimDrive:
    """A drive spec with test defaults (urban/country mix, 5 min)."""
    base = dict(
        name="T-1",
        role="source_train",
        vehicle="source",
        tyre="A",
        duration_s=300.0,
        roads={"urban": 0.6, "country": 0.4},
    )
    base.update(kw)
    return SimDrive(**base)


def simulate_spec(
    params: Params, vehicle: Vehicle, spec: SimDrive, seed: int = 7, **kw
) -> SimulatedDrive:
    """Lay out a route for ``spec`` and simulate it (seed child 0 lays out the route)."""
    ss = np.random.SeedSequence(seed)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0,)))
    route = generate_route(spec, params.sim, vehicle, rng)
    return simulate_drive(
        vehicle,
        spec.tyre,
        route,
        ss,
        params.sim,
        gnss_faults=spec.gnss_faults,
        name=spec.name,
        **kw,
    )


def with_params(vehicle: Vehicle, **changes) -> Vehicle:
    """The same vehicle with some physical parameters changed."""
    return dataclasses.replace(vehicle, params=dataclasses.replace(vehicle.params, **changes))


@pytest.fixture(scope="session")
def urban_drive(params: Params, source: Vehicle) -> SimulatedDrive:
    """Ten minutes of eventful urban/country driving with every GNSS fault."""
    spec = drive_spec(
        duration_s=600.0,
        events={"roundabout": 2, "hard_brake": 2, "reversing": 1, "sharp_turn": 2},
        wet_fraction=0.3,
        gnss_faults=["low_sats", "frozen", "jump", "gap"],
    )
    return simulate_spec(params, source, spec)
