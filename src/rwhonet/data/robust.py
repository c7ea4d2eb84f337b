"""A robust scale and a running integral, in numpy: what the stream readers took from scipy.

``scipy.stats`` and ``scipy.integrate`` cost 0.4-0.5 s each to import, more than the
stream readers' whole work on a minute of a real log, and ``rwhonet predict`` on a
stream folder (comma2k19, MDF4, stream CSVs) paid both at every start. Each function
here is the scipy function's own arithmetic, operation for operation, so the results are
the same to the bit (``tests/data/test_robust.py`` holds them to scipy's). The running
integral is also the wheel angle of validate's radius check and of predict's gap bridge.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

# Phi^-1(3/4): the median absolute deviation of a normal sample, divided by this, estimates
# its standard deviation (scipy.stats.median_abs_deviation's scale="normal").
NORMAL_MAD_SCALE = 0.6744897501960817


def mad_normal(x: ArrayLike) -> float:
    """The median absolute deviation from the median, scaled to a normal's sigma.

    ``scipy.stats.median_abs_deviation(x, scale="normal")``: NaN where ``x`` holds a NaN
    or is empty.
    """
    v = np.asarray(x, dtype=np.float64).ravel()
    if v.size == 0:
        return float("nan")
    return float(np.median(np.abs(v - np.median(v))) / NORMAL_MAD_SCALE)


def cumulative_trapezoid(y: ArrayLike, x: ArrayLike) -> np.ndarray:
    """The running trapezoid integral of ``y`` over ``x``, starting at 0.

    ``scipy.integrate.cumulative_trapezoid(y, x, initial=0)`` for 1-D arrays of one
    length: element ``i`` is the integral from ``x[0]`` to ``x[i]``.
    """
    yv, xv = np.asarray(y, dtype=np.float64), np.asarray(x, dtype=np.float64)
    if yv.shape != xv.shape or yv.ndim != 1:
        raise ValueError(f"y and x must be 1-D of one length, got {yv.shape} and {xv.shape}")
    out = np.zeros(yv.size)
    if yv.size > 1:
        np.cumsum(np.diff(xv) * (yv[1:] + yv[:-1]) / 2.0, out=out[1:])
    return out
