"""A small labelled-samples folder in the label stage's layout (docs/architecture.md), and an
evaluation of it."""

import numpy as np
import pandas as pd
import pytest

from rwhonet import paths
from rwhonet.config import load_params
from rwhonet.contracts import FEATURE_COLUMNS
from rwhonet.evaluation.selection import choose, recommend
from rwhonet.evaluation.study import evaluate
from rwhonet.io import write_json
from rwhonet.stages.sample_files import load_role

R_CAL_M = 0.29  # the source calibration the samples' WPM uses (both rear wheels)


def write_samples(folder, segments, seed=0, true_radius_m=None):
    """segments: list of (segment, drive, role, n_seconds).

    The car's true rear radius is ``true_radius_m`` (default: 2 % above the
    calibration); GNSS is exact, so the label is the WPM's scale error plus noise.
    """
    rng = np.random.default_rng(seed)
    r_true = true_radius_m or 1.02 * R_CAL_M
    folder.mkdir(parents=True, exist_ok=True)
    manifest = []
    for seg, drive, role, n in segments:
        x = rng.uniform(0, 1, (n, 40)).astype(np.float32)
        angle = rng.uniform(5, 15, n) / r_true  # rad per second, both rear wheels
        gnss = r_true * angle + rng.normal(0, 0.05, n)
        wpm = R_CAL_M * angle
        df = pd.DataFrame(x, columns=FEATURE_COLUMNS)
        df.insert(0, "t_s", 1000.0 + np.arange(1, n + 1))
        df.insert(1, "disp_gnss_m", gnss)
        df.insert(2, "disp_wpm_m", wpm)
        df.insert(3, "label_m", gnss - wpm)
        df.insert(4, "disp_wpm_integrated_m", wpm)
        df.insert(5, "disp_wpm_reference_m", wpm * 1.01)  # a different, fixed WPM
        df.insert(6, "angle_rl_rad", angle)
        df.insert(7, "angle_rr_rad", angle)
        # due north from 52.4 N along the true odometry: 1 m is about 9e-6 degrees
        df.insert(8, "lat_deg", 52.4 + np.cumsum(r_true * angle) / 111_250.0)
        df.insert(9, "lon_deg", np.full(n, -1.5))
        df.insert(10, "gyro_yaw_rad", np.zeros(n))  # straight: the gyro sees no turn
        df.insert(11, "backwards", np.zeros(n))  # forwards throughout
        df["scenario"] = ""
        df.to_parquet(folder / f"{seg}.parquet", index=False)
        manifest.append(
            {"segment": seg, "drive": drive, "role": role, "vehicle": "v", "n_seconds": n}
        )
    write_json(folder / "manifest.json", {"segments": manifest})
    return folder


def small_samples(folder):
    """Three target test segments of two drives and one target training segment."""
    return write_samples(
        folder,
        [
            ("A__s0", "A", "target_test", 300),
            ("A__s1", "A", "target_test", 200),
            ("B__s0", "B", "target_test", 400),
            ("T__s0", "T", "target_train", 100),
        ],
    )


@pytest.fixture
def samples_dir(tmp_path):
    return small_samples(tmp_path / "samples")


# An evaluation of the samples above whose rule fell back (no selection evidence).
FALLBACK_OVERRIDES = {
    "adapt.m_grid": [10, 20],
    "adapt.fallback.m": 20,
    "evaluate.outages_s": [30, 60],
    "adapt.recipes": ["paper", "radius+G", "continuous"],
    "adapt.fallback.recipe": "radius+G",  # shrink is not among these recipes
    "seeds": [1, 2],
}


@pytest.fixture
def evaluated(samples_dir):
    """An evaluation with ``adapt.recipe: auto`` that fell back to radius+G at 20 s."""
    return fallback_evaluation(samples_dir)


@pytest.fixture(scope="module")
def evaluated_once(tmp_path_factory):
    """:func:`evaluated`, made once for a module whose tests only read it (a few seconds)."""
    return fallback_evaluation(small_samples(tmp_path_factory.mktemp("samples")))


def fallback_evaluation(samples_dir):
    """The evaluation of :func:`evaluated` on the samples in ``samples_dir``."""
    params = load_params(paths.PARAMS, overrides=FALLBACK_OVERRIDES)
    frame = load_role(samples_dir, ("target_test", "source_test"), seq_len=1).frame
    frame.loc[frame.index[frame["drive"] == "B"][100:103], "scenario"] = "hard_brake"
    label = frame["label_m"].to_numpy()
    cols = {"G": label - 0.1, "S": label}
    cols |= {f"R[{r}]@{m}": label for r in ("paper", "radius+G") for m in (10, 20)}
    cols |= {f"R[continuous]/{n}s": label for n in (30, 60)}
    preds = {seed: pd.DataFrame(cols, index=frame.index) for seed in (1, 2)}
    choice = choose(params, recommend(pd.DataFrame(), params))  # no evidence: the fallback
    return params, evaluate(params, choice, frame, preds)


@pytest.fixture(autouse=True)
def timings_in_tmp(tmp_path, monkeypatch):
    """Model stages write their timing sidecars under tmp_path, not the project's mlruns/."""
    folder = tmp_path / "mlruns" / "timings"
    monkeypatch.setattr("rwhonet.tracking.timings.timings_dir", lambda root=None: folder)
    return folder
