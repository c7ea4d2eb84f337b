"""Benchmark geodesics and the label computation (run: python benchmarks/bench_geo.py).

Prints the best and median of several repeats: this is a shared, noisy VM.
Budget: the raw-CSV-to-samples chain should reach >= 0.4 M rows/s, so the label
part should manage several M rows/s.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

from rwhonet.config import LabelParams
from rwhonet.data import canonical as c
from rwhonet.features.calibration import fit_radii_ratio_of_sums
from rwhonet.features.samples import label, sample_table
from rwhonet.features.scaling import fit_scaler
from rwhonet.features.seconds import segment_seconds
from rwhonet.geo import (
    destination_deg,
    geodesic_distance_m,
    geodesic_distance_reference_m,
    latlon_from_offsets_deg,
)
from rwhonet.io import write_json


def timed(fn, repeats: int) -> tuple[float, float]:
    """Return (best, median) wall seconds of ``fn()`` over ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times), statistics.median(times)


def drive(n_rows: int, seed: int) -> pd.DataFrame:
    """A 10 Hz drive with varying speed and heading, GNSS noise and a few scenario tags."""
    rng = np.random.default_rng(seed)
    t = 36000.0 + np.arange(n_rows) / 10.0
    v = np.clip(12 + np.cumsum(rng.normal(0, 0.05, n_rows)), 0, 30)
    heading = np.cumsum(rng.normal(0, 0.002, n_rows))
    east = np.cumsum(v * np.sin(heading)) / 10 + rng.normal(0, 0.3, n_rows)
    north = np.cumsum(v * np.cos(heading)) / 10 + rng.normal(0, 0.3, n_rows)
    lat, lon = latlon_from_offsets_deg(52.4, -1.5, east, north)
    tags = np.full(n_rows, "", dtype=object)
    tags[1000:1300] = "roundabout"
    tags[5000:5100] = "hard_brake;wet"
    frame = {c.T_S: t, c.LAT_DEG: lat, c.LON_DEG: lon, c.SCENARIO: tags}
    for k, col in enumerate(c.WHEELS):
        frame[col] = v / (0.30 + 0.002 * k) + rng.normal(0, 0.05, n_rows)
    return pd.DataFrame(frame)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--drives", type=int, default=8, help="drives of 36,000 rows for the stage run")
    args = ap.parse_args()

    rng = np.random.default_rng(0)
    n = 150_000
    lat1, lon1 = rng.uniform(-70, 70, n), rng.uniform(-180, 180, n)
    # Pairs 1-40 m apart, as consecutive fixes of a drive (stack-facts.md's setup).
    lat2, lon2 = destination_deg(lat1, lon1, rng.uniform(-180, 180, n), rng.uniform(1, 40, n))
    best, med = timed(lambda: geodesic_distance_m(lat1, lon1, lat2, lon2), args.repeats)
    us = 1e6 / n
    print(f"pyproj Geod.inv, {n:,} pairs: best {best * us:.2f} us/pair (median {med * us:.2f})")
    m = 10_000
    best, med = timed(
        lambda: geodesic_distance_reference_m(lat1[:m], lon1[:m], lat2[:m], lon2[:m]), 2
    )
    print(f"geographiclib Inverse loop, {m:,} pairs: best {best * 1e6 / m:.1f} us/pair")

    frame = drive(36_000, 1)
    sec = segment_seconds(frame, "bench")
    fit = fit_radii_ratio_of_sums(
        sec.disp_gnss_m, sec.angle_rl_rad, sec.angle_rr_rad, sec.span_s, 2.0
    )
    calib = SimpleNamespace(r_rl_m=fit.r_rl_m, r_rr_m=fit.r_rr_m)
    scaler = fit_scaler(sec.wheels_rad_s, "global", ["bench"])

    def label_one_drive() -> None:
        sample_table(segment_seconds(frame, "bench"), calib, scaler, "integrated")

    best, med = timed(label_one_drive, args.repeats)
    print(
        f"per-second label computation, 36,000 rows (in memory): best {best * 1e3:.1f} ms = "
        f"{36_000 / best / 1e6:.2f} M rows/s (median {36_000 / med / 1e6:.2f})"
    )

    with tempfile.TemporaryDirectory() as tmp:
        seg_dir = Path(tmp) / "segments"
        seg_dir.mkdir()
        entries = []
        for i in range(args.drives):
            role = "source_train" if i < args.drives // 2 else "target_test"
            drive(36_000, 10 + i).to_parquet(seg_dir / f"D{i}__s0.parquet", index=False)
            entries.append({"segment": f"D{i}__s0", "drive": f"D{i}", "role": role, "vehicle": "v"})
        write_json(seg_dir / "manifest.json", {"segments": entries})
        params = SimpleNamespace(label=LabelParams("integrated", 2.0, "global"))
        out = Path(tmp) / "processed"

        def stage() -> None:
            label(params, seg_dir, out / "samples", out / "calibration.json", out / "scaler.json")

        rows = 36_000 * args.drives
        best, med = timed(stage, max(args.repeats // 2, 1))
        print(
            f"label stage with Parquet I/O, {args.drives} drives x 36,000 rows: "
            f"best {best:.2f} s = "
            f"{rows / best / 1e6:.2f} M rows/s (median {rows / med / 1e6:.2f})"
        )


if __name__ == "__main__":
    main()
