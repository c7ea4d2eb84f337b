"""What counts as a GNSS fix: one definition for validate, the resampler and ``predict``.

Apart from :mod:`rwhonet.data.quality` (which also needs geodesics), so a reader can
ask it without importing the GNSS policy.
"""

from __future__ import annotations

import numpy as np


def no_fix_rows(
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    n_sats: np.ndarray | None = None,
    min_sats: float = 0.0,
    h_acc_m: np.ndarray | None = None,
    max_h_acc_m: float | None = None,
) -> np.ndarray:
    """Rows whose fix the GNSS policy does not use as a fix.

    A fix is missing where latitude or longitude has no value; where both are exactly 0
    (a receiver without a fix writes zeros, and the Gulf of Guinea's null island is no
    place a car drives); and, for a drive that counts its satellites, where it has fewer
    than ``min_sats`` (or no count); and, for a drive whose receiver states its accuracy,
    where that is worse than ``max_h_acc_m`` metres (or not stated), when a bound is set.
    ``low_sats`` cuts these rows in validate, and ``rwhonet predict`` takes them as rows
    without a fix.

    Args:
        lat_deg: latitudes, deg.
        lon_deg: longitudes, deg.
        n_sats: satellites per row, or None when the drive has no such column.
        min_sats: ``validate.gnss.min_sats``.
        h_acc_m: the receiver's horizontal accuracy per row (``h_acc_m``), or None when the
            drive has no such column.
        max_h_acc_m: ``validate.gnss.max_h_acc_m`` (None: accuracy is not screened).

    Returns:
        Boolean mask, True for rows without a usable fix.
    """
    lat = np.asarray(lat_deg, dtype=np.float64)
    lon = np.asarray(lon_deg, dtype=np.float64)
    bad = ~(np.isfinite(lat) & np.isfinite(lon)) | ((lat == 0.0) & (lon == 0.0))
    if n_sats is not None:
        bad |= ~(np.asarray(n_sats, dtype=np.float64) >= min_sats)  # NaN: no count
    if h_acc_m is not None and max_h_acc_m is not None:
        bad |= ~(np.asarray(h_acc_m, dtype=np.float64) <= max_h_acc_m)  # NaN: not stated
    return bad
