"""How often `rwhonet predict`'s calibrated regions hold the car at the end of an outage.

Run in a reproduced workspace (``make run``): for every target test drive and each
outage length L (30, 60, 120, 180 s), ``rwhonet predict`` with the registered
``whonet-R-target`` and outages of L s every L + 60 s from 130 s on; at each
outage's last second, whether the GNSS fix lies inside the 68.27 % and 95.45 %
regions: the ellipses ``eᵀ Σ⁻¹ e ≤ q`` of the predicted covariance ``Σ`` (``cov_*``)
whose major semi-axes are ``r68_m`` and ``r95_m`` (``q = r² / λ_max(Σ)``), ``e`` the
predicted position's offset from the drive's own fix at that second.

Usage: python benchmarks/predict_coverage.py [--model models:/whonet-R-target/latest]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from rwhonet import paths
from rwhonet.data import canonical as c
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.evaluation.intervals import COVER_BANDS, band_chance
from rwhonet.geo.local import offsets_m

LENGTHS_S = (30, 60, 120, 180)
FIRST_S, GAP_S = 130, 60


def fixes_at(drive: Path, t_s: np.ndarray) -> np.ndarray:
    """The drive's own GNSS fix (lat, lon) at each of ``t_s`` (its rows' nearest stamp)."""
    cols = read_iovnbd(drive).columns
    t = cols[c.T_S]
    k = np.clip(np.searchsorted(t, t_s - 1e-6), 0, len(t) - 1)
    return np.stack([cols[c.LAT_DEG][k], cols[c.LON_DEG][k]], axis=1)


def _inside(ends: pd.DataFrame, fix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether each fix lies inside the predicted 68.27 % and 95.45 % ellipses."""
    lat, lon = ends["lat_deg"].to_numpy(), ends["lon_deg"].to_numpy()
    err = np.array(
        [
            [float(v[0]) for v in offsets_m(f_lat, f_lon, np.array([p_lat]), np.array([p_lon]))]
            for f_lat, f_lon, p_lat, p_lon in zip(fix[:, 0], fix[:, 1], lat, lon, strict=True)
        ]
    )
    cov = np.stack(
        [ends[["cov_ee_m2", "cov_en_m2"]].to_numpy(), ends[["cov_en_m2", "cov_nn_m2"]].to_numpy()],
        axis=1,
    )
    m2 = np.einsum("wi,wij,wj->w", err, np.linalg.inv(cov), err)
    lam = np.linalg.eigvalsh(cov)[:, -1]
    return tuple(m2 <= ends[r].to_numpy() ** 2 / lam for r in ("r68_m", "r95_m"))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="models:/whonet-R-target/latest")
    args = ap.parse_args(argv)
    drives = sorted((paths.ROOT / "data" / "sim" / "target_test").glob("*.csv"))
    if not drives:
        raise SystemExit("no target test drives in data/sim/target_test: run make run first")
    cli = str(Path(sys.executable).with_name("rwhonet"))
    with tempfile.TemporaryDirectory() as tmp:
        out_csv = Path(tmp) / "out.csv"
        for length in LENGTHS_S:
            n = in68 = in95 = 0
            for drive in drives:
                with drive.open() as f:
                    n_seconds = sum(1 for _ in f) // 10
                starts = range(FIRST_S, n_seconds - length - 5, length + GAP_S)
                cmd = [cli, "predict", "--model", args.model, "--drive", str(drive)]
                cmd += ["--output", str(out_csv)]
                for s in starts:
                    cmd += ["--outage", f"{s}:{s + length}"]
                subprocess.run(cmd, check=True, capture_output=True)
                out = pd.read_csv(out_csv)
                ends = out[out["outage"].notna()].groupby("outage").tail(1)
                ends = ends[np.isfinite(ends["pos_err_m"]) & np.isfinite(ends["r68_m"])]
                inside = _inside(ends, fixes_at(drive, ends["t_s"].to_numpy()))
                n += len(ends)
                in68 += int(inside[0].sum())
                in95 += int(inside[1].sum())
            (p1, tol1), (p2, tol2) = COVER_BANDS
            print(
                f"{length} s: {n} outages; in the 68.27 % region {100 * in68 / n:.1f} %, "
                f"in the 95.45 % region {100 * in95 / n:.1f} % (an honest prediction on {n} "
                f"outages lands inside 68 ± 5 % with probability "
                f"{100 * band_chance(n, p1, tol1)[0]:.0f} %, inside 95 ± 3 % with "
                f"{100 * band_chance(n, p2, tol2)[0]:.0f} %)",
                flush=True,
            )


if __name__ == "__main__":
    main()
