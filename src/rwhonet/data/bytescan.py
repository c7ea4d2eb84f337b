"""Finding things in a text log's bytes all at once (numpy), for the line-oriented
readers that parse a whole file without a Python loop a line: NMEA (:mod:`~rwhonet.data.nmea`),
candump (:mod:`~rwhonet.data.canlog`) and ASC (:mod:`~rwhonet.data.asc`)."""

from __future__ import annotations

import math

import numpy as np

HEX = np.full(256, -1, np.int16)  # a hex digit's value by its byte, -1 for none
HEX[np.frombuffer(b"0123456789", np.uint8)] = np.arange(10)
HEX[np.frombuffer(b"ABCDEF", np.uint8)] = np.arange(10, 16)
HEX[np.frombuffer(b"abcdef", np.uint8)] = np.arange(10, 16)
DEC = np.full(256, -1, np.int16)  # a decimal digit's value by its byte, -1 for none
DEC[np.frombuffer(b"0123456789", np.uint8)] = np.arange(10)


def after(positions: np.ndarray, at: np.ndarray, size: int) -> np.ndarray:
    """The first of the sorted ``positions`` at or after each of ``at`` (``size`` where
    none, and where there are no positions)."""
    if not positions.size:
        return np.full(np.shape(at), size, np.int64)
    k = np.searchsorted(positions, at)
    return np.where(k < positions.size, positions[np.minimum(k, positions.size - 1)], size)


def before(positions: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The last of the sorted ``positions`` before each of ``at`` (-1 where none)."""
    if not positions.size:
        return np.full(np.shape(at), -1, np.int64)
    k = np.searchsorted(positions, at) - 1
    return np.where(k >= 0, positions[np.maximum(k, 0)], -1)


def texts(buf: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The bytes ``buf[start:end]`` of each span as one fixed-width byte-string array."""
    length = np.maximum(end - start, 0)
    width = max(int(length.max(initial=0)), 1)
    at = start[:, None] + np.arange(width)
    chars = buf[np.clip(at, 0, max(buf.size - 1, 0))].copy()
    chars[np.arange(width) >= length[:, None]] = 0
    return np.ascontiguousarray(chars).view(f"S{width}").ravel()


def floats_or_nan(cells: np.ndarray) -> np.ndarray:
    """Byte-string cells as floats in one conversion, one by one (NaN where one is no
    number) where any of them is none."""
    try:
        return cells.astype(np.float64)
    except ValueError:
        return np.array([_float(x) for x in cells.tolist()], np.float64)


def _float(cell: bytes) -> float:
    try:
        return float(cell)
    except ValueError:
        return math.nan
