"""DVC stage ``simulate``: params.yaml ``sim`` -> simulated drives in the IO-VNBD layout.

Simulates the fleet of ``sim.profile`` (docs/simulator.md) and writes
``data/sim/<role>/<drive>.csv`` with ``.scenarios.json`` and ``.truth.json``
sidecars, plus ``data/sim/fleet.json``.

With ``data.source: files`` nothing reads the simulated drives (ingest reads
``data.root``), so the stage writes only :data:`NOT_SIMULATED`, a one-line note:
``data/sim`` stays a declared output, so DVC's DAG and caching are the same
in both modes, and switching ``data.source`` back re-runs the simulation.
"""

from __future__ import annotations

from rwhonet import paths
from rwhonet.config import Params
from rwhonet.io import atomic_dir

NOT_SIMULATED = "NOT_SIMULATED.txt"  # the only file of data/sim when data.source is files


def main(params: Params) -> None:
    """The ``simulate`` stage: the fleet of ``sim.profile`` -> ``data/sim``."""
    if params.data.source == "files":
        with atomic_dir(paths.SIM) as tmp:
            (tmp / NOT_SIMULATED).write_text(
                "data.source is files: the pipeline reads data.root, nothing was simulated.\n",
                encoding="utf-8",
            )
        print(f"data.source=files: no drives simulated -> {paths.rel(paths.SIM / NOT_SIMULATED)}")
        return

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
