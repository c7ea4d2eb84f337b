"""Model-ready arrays from labelled per-second samples: stacked, windowed, split.

The label stage writes one table per GNSS-valid segment (docs/architecture.md,
"Samples"; :func:`rwhonet.features.labels.sample_table`). :func:`stack_segments`
stacks the segments of one or more roles into the arrays the models take,
keeping a per-sample frame (drive, segment, time, GNSS and WPM displacement,
label, scenario) so predictions can be joined back and scored; the model stages
read the tables (``stages/sample_files.py``), ``rwhonet recalibrate`` labels a new
car's drive and stacks it here too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.features.sequences import LabelledWindows, sequences

FRAME_COLUMNS = [*k.SAMPLE_VALUE_COLUMNS, k.SCENARIO]


@dataclass
class SampleSet(LabelledWindows):
    """Samples of one or more roles, in role → drive → segment → time order.

    Attributes:
        x: (N, seq_len, 40) float32 scaled wheel-speed windows (paper Eqs. 14-15).
        y: (N,) float32 labels in metres (GNSS − WPM per second, Eq. 11).
        frame: per-sample columns ``drive, segment, group, k, role`` and the samples'
            value columns (:data:`rwhonet.contracts.SAMPLE_VALUE_COLUMNS`) and
            ``scenario``; ``group`` is an integer segment id (windows never cross
            it) and ``k`` the sample's 0-based rank within its drive (so "the
            first m seconds of a drive" is ``k < m``).
    """

    frame: pd.DataFrame

    def take(self, mask: np.ndarray) -> SampleSet:
        """Return the samples where ``mask`` is true (order kept)."""
        idx = np.flatnonzero(mask)
        return SampleSet(self.x[idx], self.y[idx], self.frame.iloc[idx].reset_index(drop=True))

    @property
    def drives(self) -> list[str]:
        return list(dict.fromkeys(self.frame["drive"]))


def stack_segments(segments: list[tuple[dict, pd.DataFrame]], seq_len: int) -> SampleSet:
    """Stack labelled segments, in the order given, into model inputs.

    Args:
        segments: ``(entry, samples)`` per segment: ``entry`` names its ``drive``,
            ``segment`` and ``role``; ``samples`` is the label stage's table of it.
        seq_len: number of one-second steps per input sequence.

    Returns:
        The samples, one per second; a window reaches back at most to its
        segment's first second (:func:`rwhonet.features.sequences.sequences`).
        Empty when there are none.
    """
    frames = []
    for group, (entry, seg) in enumerate(segments):
        seg = seg.copy()
        seg.insert(0, "role", entry["role"])
        seg.insert(0, "group", group)
        seg.insert(0, "segment", entry["segment"])
        seg.insert(0, "drive", entry["drive"])
        frames.append(seg)
    if sum(len(f) for f in frames) == 0:
        frames = [pd.DataFrame(columns=["drive", "segment", "group", "role", *k.SAMPLE_COLUMNS])]
    table = pd.concat(frames, ignore_index=True)
    # Segment names sort by start time within a drive (<drive>__s<k>), so this is time order.
    table = table.sort_values(["group", "t_s"], kind="stable").reset_index(drop=True)
    x2 = table[list(k.FEATURE_COLUMNS)].to_numpy(np.float32)
    x = sequences(x2, seq_len, table["group"].to_numpy())
    columns = ["drive", "segment", "group", "role", *FRAME_COLUMNS]
    frame = table[columns].reset_index(drop=True)
    frame.insert(3, "k", frame.groupby("drive", sort=False).cumcount().to_numpy())
    y = frame[k.LABEL_M].to_numpy(np.float32)
    return SampleSet(np.ascontiguousarray(x, dtype=np.float32), y, frame)


def split_tail(data: SampleSet, fraction: float) -> tuple[SampleSet, SampleSet]:
    """Hold out the last ``fraction`` of every segment for validation.

    A contiguous tail (rather than random seconds) keeps neighbouring, strongly
    correlated seconds from sitting on both sides of the split.

    Returns:
        ``(train, val)``; ``val`` is empty when ``fraction`` is 0.
    """
    group = data.frame["group"].to_numpy()
    rank = data.frame.groupby("group", sort=False).cumcount().to_numpy()
    size = np.bincount(group)[group]
    n_val = np.floor(size * fraction).astype(int)
    is_val = rank >= size - n_val
    return data.take(~is_val), data.take(is_val)
