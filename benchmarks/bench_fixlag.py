"""The fixes' lag against the wheels (rwhonet.data.fixlag) on simulated drives of known lag.

For each of a few simulated drives (ci world, urban/country with roundabouts, a
hard brake and a sharp turn; tests/support/multirate.py), the ground truth
integrated at 1 kHz is written as a logger's stream CSVs at several rates (CAN
wheel speeds at 50 or 100 Hz, GNSS at 1, 5 or 10 Hz, one with a 50 Hz gyro) and
read back; the fixes are timed as ``resample`` times them
(:func:`rwhonet.data.fixtimes.fix_times`), and the lag is estimated twice: by
:func:`rwhonet.data.fixlag.fix_lag` (tyre slip told apart) and by the same
profile with the lag alone (no slip terms). With ideal sensors the fixes and the
wheels share one clock (true lag 0); with the simulator's CAN model the wheels
are the car's CAN latency late (the ci target: 50 ms, a true lag of -50 ms).
Printed per drive, sensors and rate: both estimates, the standard error, the
slip found, and the decision ``auto`` would take; and the time one estimate takes.
With ``--offset S`` the fixes are stamped S s late besides (a second clock: GPS time
beside UTC is 18 s): the two-clock search's estimate, its standard error and time.

Usage: python benchmarks/bench_fixlag.py [--drives 3] [--duration 600] [--offset 18]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # support.multirate

from rwhonet.data import canonical as c  # noqa: E402
from rwhonet.data import fixlag  # noqa: E402
from rwhonet.data.fixtimes import fix_times  # noqa: E402
from rwhonet.data.streamcsv import read_stream_csvs  # noqa: E402
from rwhonet.data.streams import MAX_WHEEL_GAP_S, _travelled_path  # noqa: E402
from rwhonet.sim.streams import (  # noqa: E402
    StreamSpec,
    signal_map,
    stream_tables,
    write_stream_csvs,
)
from support.multirate import START_S, simulated_drive  # noqa: E402

SPECS = (
    StreamSpec(50.0, 1.0),
    StreamSpec(50.0, 5.0),
    StreamSpec(100.0, 10.0),
    StreamSpec(50.0, 1.0, gyro_hz=50.0),
)


def lag_alone(t, lat, lon, path) -> float:
    """The lag that best fits the wheels' chord with one scale and no slip terms (the
    same pairs, Huber fit and grid as :func:`rwhonet.data.fixlag.fix_lag`)."""
    i, j, _ = fixlag._pairs(t)
    from rwhonet.geo import offsets_m

    east, north = offsets_m(float(lat[0]), float(lon[0]), lat, lon)
    d = np.hypot(east[j] - east[i], north[j] - north[i])
    ok = np.isfinite(d) & (d >= fixlag.MIN_PAIR_SPEED_M_S * (t[j] - t[i]))
    i, j, d = i[ok], j[ok], d[ok]

    def cost(lag: float) -> float:
        w = np.abs(path(t[j] - lag)[0] - path(t[i] - lag)[0])[:, None]
        return fixlag._huber_fit(w, d, 0.01)[1]

    grid = np.arange(-0.3, 0.3 + 1e-9, 0.005)
    return float(grid[int(np.argmin([cost(float(g)) for g in grid]))])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--drives", type=int, default=3)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--offset", type=float, default=0.0, help="fixes stamped this much late")
    args = ap.parse_args()
    print("seed | sensors | streams | lag alone (ms) | fix_lag (ms) | slip +/- (%/m/s^2) | auto")
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.drives):
            for noise in (False, True):
                state, vehicle, sim, ss, _ = simulated_drive(
                    args.duration, seed=5 + k, can_noise=noise
                )
                true = -vehicle.params.can.latency_s * 1000 if noise else 0.0
                for spec in SPECS:
                    tables = stream_tables(state, vehicle, sim, ss, spec, START_S, noise)
                    files = write_stream_csvs(tables, Path(tmp) / f"{k}{noise}{spec.name}")
                    s = read_stream_csvs(
                        list(files.values()),
                        signal_map(gyro=tables.gyro is not None),
                        vehicle.nominal_radius_m,
                    )
                    path = _travelled_path(s, MAX_WHEEL_GAP_S)
                    g = s.gnss
                    lat, lon = g.channels[c.LAT_DEG], g.channels[c.LON_DEG]
                    t = fix_times(g.t_s, lat, lon, path.rolled).t_s
                    t0 = time.perf_counter()
                    found = fixlag.fix_lag(t + args.offset, lat, lon, path)
                    took = time.perf_counter() - t0
                    if args.offset:
                        print(
                            f"{5 + k} | {'CAN model' if noise else 'ideal'} (true "
                            f"{args.offset + true / 1000:+.3f} s) | {spec.name} | two clocks "
                            f"{found.two_clocks}: {found.lag_s:+.3f} ± {found.se_s:.3f} s "
                            f"({took:.2f} s)"
                        )
                        continue
                    slip = found.finding.split("wheel slip ")[1].split(" % per")[0]
                    print(
                        f"{5 + k} | {'CAN model' if noise else 'ideal'} (true {true:+.0f} ms) | "
                        f"{spec.name} | {lag_alone(t, lat, lon, path) * 1000:+.0f} | "
                        f"{found.lag_s * 1000:+.1f} ± {found.se_s * 1000:.1f} | {slip} | "
                        f"{'move' if found.clear else 'keep'} ({took:.2f} s)"
                    )


if __name__ == "__main__":
    main()
