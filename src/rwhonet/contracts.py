"""The data contracts between stages: roles, the per-second samples, the model folders.

One home for the names every stage agrees on (docs/architecture.md describes
each artefact). The canonical drive columns (SI units) are the readers'
contract and live in :mod:`rwhonet.data.canonical`. No imports from the rest
of the package: everything may import this module.
"""

from __future__ import annotations

import re

# --------------------------------------------------------------------------- roles

SOURCE_TRAIN = "source_train"  # drives of the car G is trained on
SOURCE_CALIBRATION = "source_calibration"  # calm drive(s) the WPM radii are fitted on
TARGET_TRAIN = "target_train"  # the new car's training drives (S)
TARGET_TEST = "target_test"  # the new car's test drives (R adapts on each one's first m s)
SOURCE_TEST = "source_test"  # held-out drives of the source car: G's error without a domain gap
ROLES = (SOURCE_TRAIN, SOURCE_CALIBRATION, TARGET_TRAIN, TARGET_TEST, SOURCE_TEST)
TEST_ROLES = (TARGET_TEST, SOURCE_TEST)  # every model is scored on these
# G and S predict every second of these (the target training drives: the selection study)
PREDICTED_ROLES = (TARGET_TEST, SOURCE_TEST, TARGET_TRAIN)
REQUIRED_ROLES = (SOURCE_TRAIN, TARGET_TRAIN, TARGET_TEST)
# Without a source_calibration drive, the first source_train drive (by name) calibrates.
CALIBRATION_FALLBACK_ROLE = SOURCE_TRAIN

# --------------------------------------------------------------------------- samples

ROWS_PER_SECOND = 10  # 10 Hz drives (IO-VNBD, CUPAC)
N_WHEELS = 4
N_FEATURES = ROWS_PER_SECOND * N_WHEELS  # paper Eqs. 14-15: ten samples of each wheel speed
FEATURE_COLUMNS = tuple(f"x_{i:02d}" for i in range(N_FEATURES))
# One row per whole second of a segment (label stage output).
T_S = "t_s"  # end of the second, drive clock, s
DISP_GNSS_M = "disp_gnss_m"  # geodesic distance between the second's bounding fixes
DISP_WPM_M = "disp_wpm_m"  # wheel-odometry displacement (label.wpm_mode), paper Eqs. 6-10
LABEL_M = "label_m"  # disp_gnss_m - disp_wpm_m (Eq. 11, the authors' sign)
# The WPM in both modes (baselines), and the rear wheel angles of label.wpm_mode (what
# refitting the radius on a drive's first m seconds needs: the WPM-m control).
DISP_WPM_INTEGRATED_M = "disp_wpm_integrated_m"
DISP_WPM_REFERENCE_M = "disp_wpm_reference_m"
ANGLE_RL_RAD = "angle_rl_rad"
ANGLE_RR_RAD = "angle_rr_rad"
# The GNSS fix ending the second (2D dead reckoning: course before an outage, truth after).
LAT_DEG = "lat_deg"
LON_DEG = "lon_deg"
# The yaw-rate gyro's angle over the second, rad, left positive; NaN where the drive has no
# yaw rate (2D navigation: fused with the rear wheels' yaw).
GYRO_YAW_RAD = "gyro_yaw_rad"
# 1.0 where a logger that signs its wheel speeds recorded the second as driven backwards
# (the rear wheels' signed angle over it negative), else 0.0; a logger of magnitudes: 0.0
# throughout (2D navigation: which way the car moved).
BACKWARDS = "backwards"
SCENARIO = "scenario"  # ';'-joined scenario tags of the second
SAMPLE_VALUE_COLUMNS = (
    T_S,
    DISP_GNSS_M,
    DISP_WPM_M,
    LABEL_M,
    DISP_WPM_INTEGRATED_M,
    DISP_WPM_REFERENCE_M,
    ANGLE_RL_RAD,
    ANGLE_RR_RAD,
    LAT_DEG,
    LON_DEG,
    GYRO_YAW_RAD,
    BACKWARDS,
)
SAMPLE_COLUMNS = (*SAMPLE_VALUE_COLUMNS, *FEATURE_COLUMNS, SCENARIO)

# --------------------------------------------------------------------------- model names

CONTINUOUS = "continuous"  # the recipe that recalibrates before every outage window (no m)
# continuous with the shrink recipe's radius and a ridge head on top (models.adapt)
CONTINUOUS_SHRINK = "continuous_shrink"
CONTINUOUS_RECIPES = (CONTINUOUS, CONTINUOUS_SHRINK)  # no m: they refit before every window
SHRINK = "shrink"  # radius+G's refit shrunk towards G by its evidence (models.adapt.shrink)
PAPER = "paper"  # the paper's recipe (§3.3.3): every weight, G's optimiser, adapt.epochs passes


def recipe_model(recipe: str, m: int | None) -> str:
    """The name a recipe's R-WhONet at m has in the evaluation (``R[continuous]`` has no m)."""
    return f"R[{recipe}]" if recipe in CONTINUOUS_RECIPES or m is None else f"R[{recipe}]@{m}"


def alt_wpm(wpm_mode: str) -> tuple[str, str]:
    """The other WPM mode's model name and samples column (the second baseline)."""
    if wpm_mode == "integrated":
        return "WPM-ref", DISP_WPM_REFERENCE_M
    return "WPM-int", DISP_WPM_INTEGRATED_M


def drive_keys(drives: list[str]) -> dict[str, str]:
    """Each drive's name as a part of an MLflow metric's name.

    MLflow allows letters, digits, ``_ - .`` and spaces in a name on every platform
    (``:`` not on Windows), and no part that a path would resolve away (``.``, ``..``).
    A name MLflow allows is kept as it is; in any other, every other character becomes
    ``_`` (a comma2k19 route ``b0c9d2329ad1606b|2018-08-02--08-34-47``, a file ``drive
    (2).csv``), a name of dots alone gets a leading ``_``, and one that would meet another
    drive's gets ``_2``, ``_3`` ... So a drive's key does not depend on which other
    drives are named, unless two would meet.
    """
    out: dict[str, str] = {}
    wanted = {d: _metric_part(str(d)) for d in drives}
    taken = {d for d, key in wanted.items() if key == d}
    for drive in drives:
        key = base = wanted[drive]
        if drive not in taken:
            n = 1
            while key in taken or key in out.values():
                n += 1
                key = f"{base}_{n}"
        out[drive] = key
    return out


def _metric_part(name: str) -> str:
    key = re.sub(r"[^\w.\- ]", "_", name, flags=re.ASCII).strip() or "_"
    return "_" + key if set(key) <= {"."} else key


# --------------------------------------------------------------------------- files

TABLE_SUFFIX = ".arrow"  # drives and segments in data/interim: Arrow IPC files (rwhonet.io)
MANIFEST = "manifest.json"  # every data stage's folder lists its contents here
MODEL_FILE = "model.pt"  # a WhONet: weights + hyperparameters (rwhonet.models.checkpoint)
PREDICTIONS = "predictions.parquet"  # per test second: drive, segment, t_s, pred_m
RUN_RECORD = "run.json"  # what evaluate logs to MLflow for this model
# a recalibration's per-drive fine-tuning curves (drive, epoch, train/loss, val/loss), one
# CSV per recipe and m beside its run record; logged as the run's artifact
FINE_TUNE_CURVES = "fine_tune.csv"
# the shrink recipes' evidence, per seed, in models/r/seed<seed>/ (the adapt stage); model
# bundles carry it for `rwhonet recalibrate` (serve.model.ServedMeta.evidence)
SHRINK_EVIDENCE = "evidence.json"
