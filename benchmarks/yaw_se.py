"""The yaw-rate check's standard error on a straight: white noise's, as the check takes it,
against Newey-West's, on growing first stretches of a drive as ``rwhonet predict`` tries
them.

For each drive named (the built-in fleet's, ``data/sim/<role>/<drive>.csv``: run
``make run`` or ``dvc repro simulate`` first), its first 1,200 to 3,000 rows in steps of
150, read as ingest reads them (the IO-VNBD reader) and through validate's GNSS policy:
the course's turns (``plausibility.course_turns``), the yaw rate's angle over each pair
(``plausibility._pair_angles``) and the fit with an intercept per block (the check's own
``_without_lone_pairs`` and demeaning). It prints the pairs, the course's span, the gain,
white noise's standard error (the check's) and Newey-West's (Bartlett kernel; 3, 10 and
30 pairs of lags; products only within a block; the same degrees-of-freedom correction).
It writes nothing. ``YAW_TELL_SPAN_RAD``'s comment in ``rwhonet.data.plausibility``
reports what it gave for V-Delta1.

Usage: python benchmarks/yaw_se.py [drive ...]   (default: V-Delta1)
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data import plausibility as p
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.quality import assess

LAGS = (3, 10, 30)


def newey_west_se(xc: np.ndarray, resid: np.ndarray, sxx: float, lags: int, block) -> float:
    """The slope's Newey-West standard error (Bartlett weights), lagged products within a
    block only."""
    u = xc * resid
    s = float(u @ u)
    for lag in range(1, lags + 1):
        same = block[lag:] == block[:-lag]
        s += 2.0 * (1.0 - lag / (lags + 1)) * float(u[lag:][same] @ u[:-lag][same])
    return math.sqrt(max(s, 0.0)) / sxx


def fit(x: np.ndarray, y: np.ndarray, block: np.ndarray) -> tuple[float, float, list[float], int]:
    """The gain, white noise's standard error, Newey-West's per LAGS, and the pairs."""
    x, y, block = p._without_lone_pairs(x, y, block)
    count = np.bincount(block)
    xc = x - (np.bincount(block, x) / count)[block]
    yc = y - (np.bincount(block, y) / count)[block]
    sxx = float(xc @ xc)
    gain = float(xc @ yc) / sxx
    resid = yc - gain * xc
    dof = max(x.size - count.size - 1, 1)
    white = math.sqrt(float(resid @ resid) / dof / sxx)
    scale = math.sqrt(x.size / dof)
    hac = [scale * newey_west_se(xc, resid, sxx, lags, block) for lags in LAGS]
    return gain, white, hac, x.size


def main(drives: list[str]) -> None:
    vp = load_params().validate
    for name in drives:
        path = next((paths.ROOT / "data" / "sim").glob(f"*/{name}.csv"), None)
        if path is None:
            sys.exit(f"{name}: no data/sim/*/{name}.csv (run make run first)")
        drive = read_iovnbd(Path(path)).columns
        for rows in range(1200, 3001, 150):
            d = {k: np.asarray(v)[:rows] for k, v in drive.items() if k != c.SCENARIO}
            segments = assess(d, vp.gnss, vp.sample_period_s).segments
            turns = p.course_turns(d, segments, p.YAW_MIN_STEP_M, vp.sample_period_s)
            if turns is None:
                continue
            x, keep = p._pair_angles(turns, d[c.YAW_RATE_RAD_S])
            if keep.sum() < p.YAW_MIN_SECONDS:
                continue
            gain, white, hac, pairs = fit(x[keep], turns.y[keep], turns.block[keep])
            span = math.degrees(float(np.ptp(np.r_[0.0, np.cumsum(turns.y[keep])])))
            lagged = " ".join(f"{lag}: {se:.3f}" for lag, se in zip(LAGS, hac, strict=True))
            print(
                f"{name} rows {rows:>5} pairs {pairs:>4} span {span:5.1f} deg  gain {gain:7.3f}"
                f"  white {white:.3f}  Newey-West (lags {lagged})"
            )


if __name__ == "__main__":
    main(sys.argv[1:] or ["V-Delta1"])
