"""Min-max scaling of the 40 wheel-speed features to about [0, 1] (paper Sec. 3.2).

The statistics are fitted on the source_train drives only, never on a drive
that is later evaluated: the scaler is part of the trained model, and fitting
it on test data would leak that data's range into training. (The authors' code
takes one min/max from a calibration drive's rear-right wheel.)

Kinds (``label.scaler``):

- ``global``: one min and one max over all four wheels. The same affine map
  for every wheel keeps the *differences* between wheels, which carry the turn,
  slip and tyre-radius information the model is to learn.
- ``per_wheel``: a min and max per wheel (each wheel's ten columns share them).

``transform`` clips nothing. A target vehicle whose wheels turn faster than
the source's ever did (smaller tyres, higher speeds), or that reverses, gives
values above 1 or below 0. Clipping would flatten exactly the speeds that
differ, so out-of-range values are passed on; the model extrapolates from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from rwhonet.contracts import N_FEATURES, ROWS_PER_SECOND
from rwhonet.data import canonical as c
from rwhonet.errors import InputError, Problem

ScalerKind = Literal["global", "per_wheel"]
SCALER_KINDS: tuple[str, ...] = ("global", "per_wheel")
N_WHEELS = len(c.FEATURE_WHEEL_ORDER)


@dataclass(frozen=True)
class MinMaxScaler:
    """Min-max statistics per wheel, in feature order RR, RL, FR, FL.

    Attributes:
        kind: ``global`` (all four entries equal) or ``per_wheel``.
        min_rad_s: per-wheel minimum wheel speed, rad/s.
        max_rad_s: per-wheel maximum wheel speed, rad/s.
        fitted_on: drive ids the statistics come from.
        n_seconds: seconds the statistics come from.
    """

    kind: str
    min_rad_s: tuple[float, ...]
    max_rad_s: tuple[float, ...]
    fitted_on: tuple[str, ...]
    n_seconds: int

    def _per_column(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.repeat(np.asarray(self.min_rad_s, np.float64), ROWS_PER_SECOND)
        hi = np.repeat(np.asarray(self.max_rad_s, np.float64), ROWS_PER_SECOND)
        return lo, hi - lo

    def transform(self, wheels_rad_s: np.ndarray) -> np.ndarray:
        """Scale raw features to about [0, 1] (no clipping; see the module docstring).

        Args:
            wheels_rad_s: ``(N, 40)`` raw wheel speeds, rad/s.

        Returns:
            ``(N, 40)`` float32 scaled features.
        """
        x = _check_features(wheels_rad_s)
        lo, width = self._per_column()
        return ((x - lo) / width).astype(np.float32)

    def to_dict(self) -> dict[str, Any]:
        """Return JSON-ready data (what ``scaler.json`` holds)."""
        return {
            "kind": self.kind,
            "wheels": list(c.FEATURE_WHEEL_ORDER),
            "min_rad_s": list(self.min_rad_s),
            "max_rad_s": list(self.max_rad_s),
            "fitted_on": list(self.fitted_on),
            "n_seconds": self.n_seconds,
        }


def _check_features(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, np.float64)
    if x.ndim != 2 or x.shape[1] != N_FEATURES:
        raise ValueError(f"expected features of shape (N, {N_FEATURES}), got {x.shape}")
    return x


def fit_scaler(
    parts: Sequence[np.ndarray], kind: ScalerKind, fitted_on: Sequence[str]
) -> MinMaxScaler:
    """Fit min-max statistics on raw features given in blocks (e.g. one per segment).

    Min and max are exact, so reducing block by block gives what one reduction over
    the blocks concatenated would, without making that copy.

    Args:
        parts: ``(N_i, 40)`` raw feature blocks, rad/s.
        kind: ``global`` or ``per_wheel``.
        fitted_on: the drive ids the features come from (recorded, not used).

    Returns:
        The fitted scaler.

    Raises:
        ValueError: for an unknown kind, no rows, non-finite values, or a wheel
            whose speed never changes (max == min would divide by zero).
    """
    if kind not in SCALER_KINDS:
        raise ValueError(f"scaler kind must be one of {SCALER_KINDS}, got {kind!r}")
    blocks = [x for x in (_check_features(p) for p in parts) if x.shape[0]]
    if not blocks:
        raise ValueError("cannot fit a scaler on zero seconds")
    if not all(np.isfinite(x).all() for x in blocks):
        raise ValueError("cannot fit a scaler on non-finite wheel speeds")
    # Per feature column, then per wheel (its ten columns): min and max are exact, so
    # reducing block by block gives what one reduction over all rows gives.
    column_lo = np.min([x.min(axis=0) for x in blocks], axis=0).reshape(N_WHEELS, -1)
    column_hi = np.max([x.max(axis=0) for x in blocks], axis=0).reshape(N_WHEELS, -1)
    if kind == "global":
        lo = np.full(N_WHEELS, column_lo.min())
        hi = np.full(N_WHEELS, column_hi.max())
    else:
        lo = column_lo.min(axis=1)
        hi = column_hi.max(axis=1)
    if np.any(hi <= lo):
        raise ValueError(f"wheel speeds are constant (min {lo.tolist()}, max {hi.tolist()})")
    return MinMaxScaler(
        kind=kind,
        min_rad_s=tuple(float(v) for v in lo),
        max_rad_s=tuple(float(v) for v in hi),
        fitted_on=tuple(fitted_on),
        n_seconds=sum(x.shape[0] for x in blocks),
    )


def scaler_from_dict(raw: Any, source: str) -> MinMaxScaler:
    """Rebuild a :class:`MinMaxScaler` from what :meth:`MinMaxScaler.to_dict` gave.

    Args:
        raw: the parsed ``scaler.json``.
        source: where it came from, for error reports.

    Returns:
        The scaler.

    Raises:
        InputError: when fields are missing or malformed.
    """
    raw = raw if isinstance(raw, dict) else {}
    file = source
    problems: list[Problem] = []
    if raw.get("kind") not in SCALER_KINDS:
        problems.append(
            Problem(file, None, "kind", f"one of {SCALER_KINDS}", repr(raw.get("kind")))
        )
    if raw.get("wheels") != list(c.FEATURE_WHEEL_ORDER):
        problems.append(
            Problem(
                file, None, "wheels", repr(list(c.FEATURE_WHEEL_ORDER)), repr(raw.get("wheels"))
            )
        )
    for key in ("min_rad_s", "max_rad_s"):
        value = raw.get(key)
        ok = isinstance(value, list) and len(value) == N_WHEELS
        if not ok or not all(isinstance(v, int | float) for v in value):
            problems.append(Problem(file, None, key, f"{N_WHEELS} numbers", repr(value)))
    if problems:
        raise InputError(problems, f"{file} is not a valid scaler file")
    return MinMaxScaler(
        kind=raw["kind"],
        min_rad_s=tuple(float(v) for v in raw["min_rad_s"]),
        max_rad_s=tuple(float(v) for v in raw["max_rad_s"]),
        fitted_on=tuple(raw.get("fitted_on", [])),
        n_seconds=int(raw.get("n_seconds", 0)),
    )
