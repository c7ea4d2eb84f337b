"""Finding things in a text log's bytes all at once (numpy), for the line-oriented
readers that parse a whole file without a Python loop a line: NMEA (:mod:`~rwhonet.data.nmea`),
candump (:mod:`~rwhonet.data.canlog`), ASC (:mod:`~rwhonet.data.asc`), TRC
(:mod:`~rwhonet.data.trc`) and GnssLogger's Status records
(:mod:`~rwhonet.data.gnsslogger`)."""

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


class Fields:
    """A chunk of whole lines split into whitespace-separated fields (their starts and
    ends, each line's first field and count), the bytes at once: white space is every byte
    up to the space (an ASC's other control characters go to python-can:
    :func:`rwhonet.data.asc.asc_frames`)."""

    def __init__(self, c: np.ndarray) -> None:
        self.c = c
        edge = np.ones(c.size + 2, bool)
        edge[1:-1] = c <= 32
        bounds = np.flatnonzero(edge[1:] != edge[:-1])  # a field's start, its end, ...
        self.start, self.end = bounds[0::2], bounds[1::2]
        self.newlines = np.flatnonzero(c == 10)
        begins = np.concatenate([[0], self.newlines + 1])
        if begins[-1] == c.size:
            begins = begins[:-1]
        self.lines = begins.size
        self.first = np.searchsorted(self.start, begins)
        self.count = np.diff(np.concatenate([self.first, [self.start.size]]))

    def field(self, k: int | np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, ...]:
        """Field ``k`` (0-based; a number or one a row) of the lines ``rows``: whether the
        line has it, its start and its end (both 0 where it has none)."""
        has = self.count[rows] > k
        if not self.start.size:
            return has, np.zeros(rows.size, np.int64), np.zeros(rows.size, np.int64)
        i = np.minimum(self.first[rows] + k, self.start.size - 1)
        return has, np.where(has, self.start[i], 0), np.where(has, self.end[i], 0)

    def chars(self, s: np.ndarray, e: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
        """The first ``width`` bytes of each field (a row each), and which are inside it."""
        j = np.arange(width)
        m = self.c[np.minimum(s[:, None] + j, max(self.c.size - 1, 0))] if self.c.size else None
        inside = j < (e - s)[:, None]
        return (m if m is not None else np.zeros(inside.shape, np.uint8)), inside

    def number(self, s: np.ndarray, e: np.ndarray, width: int, base: int) -> tuple:
        """Whether each field is 1 to ``width`` digits of ``base`` (10 or 16), and its
        value (0 where not): read a column at a time, as far as the longest field goes."""
        n = e - s
        ok = (n >= 1) & (n <= width)
        value = np.zeros(n.size, np.int64)
        table = DEC if base == 10 else HEX
        for j in range(min(width, int(n.max(initial=0)))):
            inside = j < n
            d = table[self.byte(s + j)]
            ok &= ~inside | (d >= 0)
            value = np.where(inside, value * base + d, value)
        return ok, np.where(ok, value, 0)

    def byte(self, at: np.ndarray) -> np.ndarray:
        """The byte at each of ``at`` (at most the chunk's last; -1, where a field that
        is not there ends, reads the last byte too: the callers mask it)."""
        return self.c[np.minimum(at, self.c.size - 1)] if self.c.size else at * 0

    def is_(self, s: np.ndarray, e: np.ndarray, word: bytes, fold: bool = False) -> np.ndarray:
        """Whether each field is ``word`` (``fold``: any case of its letters, and a field
        that starts with it counts): its first byte compared for every field, the rest for
        those that start so."""
        n = len(word)
        fold_bit = 32 if fold else 0
        ok = ((e - s >= n) if fold else (e - s == n)) & (self.byte(s) | fold_bit == word[0])
        at = np.flatnonzero(ok)
        for j in range(1, n):
            at = at[(self.byte(s[at] + j) | fold_bit) == word[j]]
        ok[:] = False
        ok[at] = True
        return ok


def small_hex(f: Fields, has: np.ndarray, s: np.ndarray, e: np.ndarray) -> tuple:
    """Whether each field is 1-2 hex digits, and its value."""
    n = e - s
    hi, lo = HEX[f.byte(s)], HEX[f.byte(s + 1)]
    one = n == 1
    ok = has & (hi >= 0) & (one | ((n == 2) & (lo >= 0)))
    return ok, np.where(one, hi, hi * 16 + lo)


class CommaFields:
    """The comma-separated fields of many lines (NMEA sentences, GnssLogger records), held
    as one byte buffer: field ``j`` of every line is taken at once (:meth:`column`),
    without a Python object a field."""

    def __init__(self, bodies: list[bytes]) -> None:
        n = len(bodies)
        self.buf = np.frombuffer(b"\n".join(bodies) + b"\n", np.uint8)
        self.sep = np.flatnonzero((self.buf == ord(",")) | (self.buf == ord("\n")))
        ends = self.buf[self.sep] == ord("\n")
        line = np.concatenate([[0], np.cumsum(ends)[:-1]])  # each separator's sentence
        self.first = np.searchsorted(line, np.arange(n))  # each sentence's first separator
        self.count = np.bincount(line, minlength=n)[:n]  # its fields (none: no sentence)
        self.start = np.concatenate([[0], self.sep[ends][:-1] + 1])

    def column(self, j: int, of: np.ndarray | None = None) -> np.ndarray:
        """Field ``j`` of each sentence (of the sentences ``of``), stripped (``b""`` where
        one has fewer fields)."""
        of = np.arange(self.count.size) if of is None else of
        has = self.count[of] > j
        k = np.where(has, self.first[of] + j, 0)
        end = np.where(has, self.sep[k], 0)
        start = self.start[of] if j == 0 else np.where(has, self.sep[np.maximum(k - 1, 0)] + 1, 0)
        length = end - start
        width = max(int(length.max(initial=0)), 1)
        at = start[:, None] + np.arange(width)
        chars = self.buf[np.minimum(at, self.buf.size - 1)]
        chars[np.arange(width) >= length[:, None]] = 0
        return np.char.strip(np.ascontiguousarray(chars).view(f"S{width}").ravel())
