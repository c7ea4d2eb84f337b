"""Every project path, derived from one root.

The root is the repository (the folder holding ``params.yaml``), or
``$RWHONET_ROOT`` when set (tests point it at a temporary copy).
"""

from __future__ import annotations

import os
from pathlib import Path


def project_root() -> Path:
    """Return the project root: ``$RWHONET_ROOT`` or the folder holding ``params.yaml``."""
    env = os.environ.get("RWHONET_ROOT")
    if env:
        return Path(env).resolve()
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        if (folder / "params.yaml").is_file() and (folder / "dvc.yaml").is_file():
            return folder
    # Installed in editable mode: src/rwhonet/paths.py -> repo root is parents[2].
    return Path(__file__).resolve().parents[2]


ROOT = project_root()
PARAMS = ROOT / "params.yaml"

DATA = ROOT / "data"
RAW = DATA / "raw"  # real drives, tracked by data.dvc
SIM = DATA / "sim"  # simulated drives (IO-VNBD layout), stage output
INTERIM = DATA / "interim"
DRIVES = INTERIM / "drives"  # ingest: one canonical Arrow file per drive + manifest
SEGMENTS = INTERIM / "segments"  # validate: GNSS-valid segments
PROCESSED = DATA / "processed"
SAMPLES = PROCESSED / "samples"  # label: per-second samples per segment
CALIBRATION = PROCESSED / "calibration.json"
SCALER = PROCESSED / "scaler.json"

MODELS = ROOT / "models"  # <g|s|r>/seed<seed>/: one folder per model and training seed

METRICS = ROOT / "metrics"
EVAL_JSON = METRICS / "eval.json"
REPORTS = ROOT / "reports"
VALIDATION_REPORT = REPORTS / "validation.json"
# Reports of failed data-stage runs: not DVC outputs (DVC deletes those before a stage
# runs), so they survive the failure; the stage's next successful run removes its own.
FAILED_REPORTS = REPORTS / "failed"
VALIDATION_FAILED_REPORT = FAILED_REPORTS / "validation.json"
INGEST_FAILED_REPORT = FAILED_REPORTS / "ingest.json"
TABLES_MD = REPORTS / "tables.md"
PREDICTIONS = REPORTS / "predictions"
PLOTS = REPORTS / "plots"

MLRUNS = ROOT / "mlruns"


def model_dir(model: str, seed: int) -> Path:
    """Folder of one model and training seed: ``models/<g|s|r>/seed<seed>``."""
    return MODELS / model / f"seed{seed}"


def resolve(path: str | Path) -> Path:
    """Return ``path`` as an absolute path; a relative one is relative to the project root."""
    p = Path(path)
    return p if p.is_absolute() else ROOT / p


def rel(path: Path) -> str:
    """Return ``path`` relative to the project root when inside it (for messages and logs)."""
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return str(path)
