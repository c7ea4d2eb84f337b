"""Load the label stage's samples of one or more roles as model inputs.

The label stage writes one Parquet per GNSS-valid segment (docs/architecture.md,
"Samples"); :func:`load_role` reads a role's segments, in order, and stacks them
(:func:`rwhonet.features.samples.stack_segments`).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from rwhonet import contracts as k
from rwhonet.errors import InputError, Problem
from rwhonet.features.samples import SampleSet, stack_segments
from rwhonet.io import read_json


def load_role(
    samples_dir: Path, role: str | tuple[str, ...], seq_len: int, *, required: bool = True
) -> SampleSet:
    """Stack every segment of one or more roles into model inputs.

    Args:
        samples_dir: the label stage's output folder (holds ``manifest.json``).
        role: ``source_train``, ``target_train``, ``target_test``..., or a tuple of
            roles (in that order; ``contracts.TEST_ROLES`` for every test drive).
        seq_len: number of one-second steps per input sequence.
        required: raise when there is no sample at all (else return an empty set).

    Returns:
        The samples, one per second; a window reaches back at most to its
        segment's first second (:func:`rwhonet.features.sequences.sequences`).

    Raises:
        InputError: when a required role has no samples.
    """
    roles = (role,) if isinstance(role, str) else tuple(role)
    manifest = read_json(Path(samples_dir) / k.MANIFEST)
    entries = [e for e in manifest["segments"] if e["role"] in roles]
    entries.sort(key=lambda e: (roles.index(e["role"]), e["drive"], e["segment"]))
    segments = [
        (entry, pd.read_parquet(Path(samples_dir) / f"{entry['segment']}.parquet"))
        for entry in entries
    ]
    if sum(len(f) for _, f in segments) == 0 and required:
        raise InputError(
            [Problem(str(samples_dir), None, None, f"labelled samples for {roles}", "none")]
        )
    return stack_segments(segments, seq_len)
