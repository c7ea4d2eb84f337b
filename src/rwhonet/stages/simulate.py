"""DVC stage ``simulate``: params.yaml ``sim`` -> simulated drives in the IO-VNBD layout.

Simulates the fleet of ``sim.profile`` (docs/simulator.md) and writes
``data/sim/<role>/<drive>.csv`` with ``.scenarios.json`` and ``.truth.json``
sidecars, plus ``data/sim/fleet.json``.
"""

from __future__ import annotations

from rwhonet import paths
from rwhonet.config import Params


def main(params: Params) -> None:
    """The ``simulate`` stage: the fleet of ``sim.profile`` -> ``data/sim``."""
    from rwhonet.sim import simulate_fleet

    summary = simulate_fleet(params, paths.SIM)
    roles = ", ".join(
        f"{role} {agg['drives']} drives / {agg['hours']:.2f} h / {agg['km']:.1f} km"
        for role, agg in summary["roles"].items()
    )
    hours = sum(agg["hours"] for agg in summary["roles"].values())
    rows = sum(d["n_rows"] for d in summary["drives"])
    faults = sum(len(d["gnss_faults"]) for d in summary["drives"])
    print(
        f"Simulated profile {summary['profile']!r} (seed {summary['seed']}): {roles}. "
        f"{hours:.2f} h of driving, {rows} rows at 10 Hz, {faults} degraded GNSS stretches, "
        f"in {summary['seconds']:.1f} s -> {paths.rel(paths.SIM)}"
    )
