"""Simulated drives as a logger's streams: rates, jitter, one truth behind both samplings."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.features.seconds import integrate_per_second
from rwhonet.sim.streams import StreamSpec, fine_truth, native_drive, stream_tables

from .conftest import drive_spec


@pytest.fixture(scope="module")
def truths(params, target):
    from rwhonet.sim import generate_route

    spec = drive_spec(duration_s=120.0, events={"hard_brake": 1, "roundabout": 1})
    rng = np.random.default_rng(np.random.SeedSequence(4, spawn_key=(0,)))
    route = generate_route(spec, params.sim, target, rng)
    ss = np.random.SeedSequence(4)
    return route, ss, {hz: fine_truth(target, "B", route, ss, params.sim, hz) for hz in (50, 1000)}


def test_streams_have_their_rates_jitter_and_phase(params, target, truths):
    _, ss, states = truths
    spec = StreamSpec(100.0, 5.0)
    tables = stream_tables(states[1000], target, params.sim, ss, spec, start_s=100.0)
    t_w, t_g = tables.wheels[c.T_S].to_numpy(), tables.gnss[c.T_S].to_numpy()
    assert np.all(np.diff(t_w) > 0) and np.all(np.diff(t_g) > 0)
    assert np.median(np.diff(t_w)) == pytest.approx(0.01, abs=2e-4)
    assert np.diff(t_w).min() >= 0.005 - 1e-9 and np.diff(t_w).max() <= 0.015 + 1e-9  # +-25 %
    assert np.median(np.diff(t_g)) == pytest.approx(0.2, abs=0.011)
    again = stream_tables(states[1000], target, params.sim, ss, spec, start_s=100.0)
    assert again.wheels.equals(tables.wheels) and again.gnss.equals(tables.gnss)  # seeded


def test_the_fine_truth_is_the_same_drive_as_the_simulators(params, target, truths):
    """Integrated at 1 kHz instead of 50 Hz, each second's wheel angle moves by < 1 mm."""
    _, ss, states = truths
    native = {hz: native_drive(s, target, params.sim, ss) for hz, s in states.items()}
    angle = {
        hz: integrate_per_second(d[c.T_S].to_numpy(), d[c.OMEGA_RL].to_numpy())
        for hz, d in native.items()
    }
    assert angle[50].size == angle[1000].size >= 119
    assert np.abs(angle[1000] - angle[50]).max() * target.nominal_radius_m < 1e-3
    lat = {hz: d[c.LAT_DEG].to_numpy() for hz, d in native.items()}
    assert np.abs(lat[1000] - lat[50]).max() * 111_000 < 0.05  # the path within 5 cm
