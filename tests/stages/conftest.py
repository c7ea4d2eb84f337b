"""A small labelled-samples folder in the label stage's layout (docs/architecture.md)."""

import numpy as np
import pandas as pd
import pytest

from rwhonet.contracts import FEATURE_COLUMNS
from rwhonet.io import write_json


def write_samples(folder, segments, seed=0):
    """segments: list of (segment, drive, role, n_seconds)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    manifest = []
    for seg, drive, role, n in segments:
        x = rng.uniform(0, 1, (n, 40)).astype(np.float32)
        gnss = rng.uniform(5, 15, n)
        label = 0.02 * gnss + rng.normal(0, 0.05, n)
        df = pd.DataFrame(x, columns=FEATURE_COLUMNS)
        df.insert(0, "t_s", 1000.0 + np.arange(1, n + 1))
        df.insert(1, "disp_gnss_m", gnss)
        df.insert(2, "disp_wpm_m", gnss - label)
        df.insert(3, "label_m", label)
        df["scenario"] = ""
        df.to_parquet(folder / f"{seg}.parquet", index=False)
        manifest.append(
            {"segment": seg, "drive": drive, "role": role, "vehicle": "v", "n_seconds": n}
        )
    write_json(folder / "manifest.json", {"segments": manifest})
    return folder


@pytest.fixture
def samples_dir(tmp_path):
    return write_samples(
        tmp_path / "samples",
        [
            ("A__s0", "A", "target_test", 300),
            ("A__s1", "A", "target_test", 200),
            ("B__s0", "B", "target_test", 400),
            ("T__s0", "T", "target_train", 100),
        ],
    )
