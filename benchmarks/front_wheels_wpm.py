"""What the front and rear wheels' columns exchanged cost the WPM: its distance rolled on the
front wheels instead of the rear.

On the test drives of the project's last ``dvc repro`` (``data/sim/source_test`` and
``target_test``; their canonical drives in ``data/interim/drives`` and labelled seconds in
``data/processed/samples``), each segment's per-second GNSS distance is compared with the
wheel angle of each axle (the mean of its two wheels, integrated over the same second as
the label's) times that axle's own least-squares radius over the segment: the best
constant radius either axle could have, so what is left is what a radius cannot take
(the front wheels' drive slip and their wider arc in the turns). It prints, for
non-overlapping 30 s and 180 s windows, the mean |sum of the per-second errors| (the
window's CRSE with an oracle radius) on the rear axle, as the WPM rolls (paper Eqs. 6-10),
and on the front axle, as it would with the two axles' columns exchanged. Nothing is
written. ``docs/readers.md`` ("Front and rear") reports what this gave.

Usage: python benchmarks/front_wheels_wpm.py   (after dvc repro)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.feather as feather

from rwhonet.data import canonical as c
from rwhonet.data.robust import cumulative_trapezoid

ROOT = Path(__file__).resolve().parents[1]
WINDOWS_S = (30, 180)


def main() -> None:
    names = sorted(
        p.stem
        for role in ("source_test", "target_test")
        for p in (ROOT / "data/sim" / role).glob("*.csv")
    )
    errors: dict[int, dict[str, list[float]]] = {w: {"rear": [], "front": []} for w in WINDOWS_S}
    for name in names:
        drive = feather.read_table(ROOT / "data/interim/drives" / f"{name}.arrow").to_pandas()
        t = drive[c.T_S].to_numpy()
        angle = {
            axle: cumulative_trapezoid(0.5 * (drive[a].abs() + drive[b].abs()).to_numpy(), t)
            for axle, (a, b) in {
                "rear": (c.OMEGA_RL, c.OMEGA_RR),
                "front": (c.OMEGA_FL, c.OMEGA_FR),
            }.items()
        }
        for path in sorted((ROOT / "data/processed/samples").glob(f"{name}__s*.parquet")):
            seconds = pd.read_parquet(path, columns=[c.T_S, "disp_gnss_m"])
            end, gnss = seconds[c.T_S].to_numpy(), seconds["disp_gnss_m"].to_numpy()
            for axle, whole in angle.items():
                turned = np.interp(end, t, whole) - np.interp(end - 1.0, t, whole)
                radius = float(turned @ gnss) / float(turned @ turned)
                error = gnss - radius * turned
                for w in WINDOWS_S:
                    n = error.size // w
                    errors[w][axle] += np.abs(error[: n * w].reshape(n, w).sum(axis=1)).tolist()
    print(f"{len(names)} test drives: {', '.join(names)}")
    for w in WINDOWS_S:
        rear, front = errors[w]["rear"], errors[w]["front"]
        print(
            f"{w:4d} s windows ({len(rear)}): rear axle {np.mean(rear):.3f} m, "
            f"front axle {np.mean(front):.3f} m (x{np.mean(front) / np.mean(rear):.2f})"
        )


if __name__ == "__main__":
    main()
