"""What the model stages record beside their models: predictions and run records.

A model stage writes its test predictions (:data:`rwhonet.contracts.PREDICTIONS`)
and a run record (:class:`rwhonet.tracking.store.RunRecord`, what ``evaluate``
logs to MLflow) in the same atomic output folder as the model.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from rwhonet.config import Params, flatten
from rwhonet.features.samples import SampleSet


def model_params(params: Params, seed: int, *sections: str) -> dict[str, object]:
    """Flat, resolved parameters a model run depends on (for MLflow and run.json)."""
    d = {"seed": seed, "sim.profile": params.sim.profile, "data.source": params.data.source}
    for s in ("label", "model", *sections):
        d.update(flatten(params.section(s), s + "."))
    return d


def history_rows(history: list[dict]) -> list[dict[str, float]]:
    """Per-epoch losses under stage-prefixed metric names (``train/loss``, ``val/loss``)."""
    return [
        {"epoch": h["epoch"]}
        | {
            k.replace("_loss", "/loss"): float(v)
            for k, v in h.items()
            if k != "epoch" and v is not None
        }
        for h in history
    ]


def predictions_frame(test: SampleSet, pred: np.ndarray) -> pd.DataFrame:
    """Per-second predictions keyed like the samples (drive, segment, t_s)."""
    out = test.frame[["drive", "segment", "t_s"]].copy()
    out["pred_m"] = pred.astype(np.float64)
    return out
