"""What resampling costs: per-second label change of multi-rate streams vs the native 10 Hz drive.

For each of a few simulated drives (ci world, urban/country with roundabouts, a
hard brake and a sharp turn), one ground truth integrated at 1 kHz is sampled
as the pipeline's native 10 Hz drive and as a logger's streams: CAN wheel
speeds at 50 and 100 Hz (stamps jittered by up to +-25 % of the period), GNSS
fixes at 1, 5 and 10 Hz (a random phase of the second, +-5 ms). The streams are
written as CSVs, read back (``rwhonet.data.streamcsv``) and resampled
(``rwhonet.data.streams.resample``); both versions are labelled by the
pipeline's own functions with the same radius (tests/support/multirate.py).
Printed per rate pair, over all drives' seconds: the change of the per-second
GNSS displacement, WPM displacement and label (RMS, 99th percentile, largest),
with ideal sensors (the resampling alone) and with the simulator's CAN model
(noise, quantisation, latency, drawn independently at each rate).

Usage: python benchmarks/bench_resample.py [--drives 3] [--duration 300]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # support.multirate

from support.multirate import SPECS, compare, simulated_drive  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--drives", type=int, default=3)
    ap.add_argument("--duration", type=float, default=300.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for noise in (False, True):
            rows = []
            drives = [
                simulated_drive(args.duration, seed=5 + k, can_noise=noise)
                for k in range(args.drives)
            ]
            for spec in SPECS:
                parts, native, inputs = [], 0, 0
                for k, drive in enumerate(drives):
                    comp = compare(drive, spec, Path(tmp) / f"{k}", can_noise=noise)
                    parts.append(comp.seconds)
                    native += comp.native_seconds
                    inputs += comp.input_rows
                both = pd.concat(parts, ignore_index=True)
                row = {"streams": spec.name, "seconds": f"{len(both)}/{native}"}
                for q, short in (
                    ("disp_gnss_m", "GNSS"),
                    ("disp_wpm_m", "WPM"),
                    ("label_m", "label"),
                ):
                    d = np.abs(both[f"{q}_change"].to_numpy())
                    row[f"{short} rms"] = np.sqrt(np.mean(d**2))
                    row[f"{short} p99"] = np.percentile(d, 99)
                    row[f"{short} max"] = d.max()
                row["label rms (native)"] = np.sqrt(np.mean(both["label_m_native"] ** 2))
                rows.append(row)
            title = "simulator's CAN model" if noise else "ideal sensors (resampling alone)"
            print(
                f"\nPer-second change vs the native 10 Hz drive, m ({title}; "
                f"{args.drives} drives of {args.duration:g} s):"
            )
            print(pd.DataFrame(rows).to_string(index=False, float_format=lambda x: f"{x:.4f}"))


if __name__ == "__main__":
    main()
