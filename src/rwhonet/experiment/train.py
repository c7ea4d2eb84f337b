"""Train G-WhONet (source vehicle) or S-WhONet (target vehicle): paper §2.4-2.5, §3.3.1-3.3.2."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from rwhonet import paths
from rwhonet.config import Params, flatten
from rwhonet.experiment.samples import SampleSet, load_role, split_tail
from rwhonet.io import atomic_dir, write_json
from rwhonet.tracking.store import RunRecord

CHECKPOINT = "model.ckpt"
PREDICTIONS = "predictions.parquet"
RUN_RECORD = "run.json"

WHICH = {
    "G": ("source_train", "source", "G-WhONet"),
    "S": ("target_train", "target", "S-WhONet"),
}


def model_params(params: Params, *sections: str) -> dict[str, object]:
    """Flat, resolved parameters a model run depends on (for MLflow and run.json)."""
    d = {"seed": params.seed, "sim.profile": params.sim.profile, "data.source": params.data.source}
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


def train_model(
    params: Params, which: Literal["G", "S"], samples_dir: Path, out_dir: Path
) -> tuple[RunRecord, float]:
    """Train one WhONet on its role's drives and predict the target test drives.

    Args:
        params: resolved parameters.
        which: ``G`` (source vehicle's training drives) or ``S`` (target vehicle's).
        samples_dir: the label stage's samples folder.
        out_dir: ``models/g`` or ``models/s``; receives the Lightning checkpoint,
            the test drives' per-second predictions and the run record.

    Returns:
        The run record (also written to ``out_dir/run.json``) and the seconds
        the fit took. Timings stay out of the record so that every output of the
        stage is byte-reproducible from its inputs (dvc.lock does not change on
        a re-run).
    """
    from rwhonet.models.train import fit, predict, save_checkpoint

    role, vehicle, name = WHICH[which]
    data = load_role(samples_dir, role, params.model.seq_len)
    train, val = split_tail(data, params.train.val_fraction)
    result = fit(
        train.x, train.y, val.x, val.y, model=params.model, train=params.train, seed=params.seed
    )
    test = load_role(samples_dir, "target_test", params.model.seq_len)
    pred = predict(result.module, test.x)
    record = RunRecord(
        name=name,
        tags={
            "model": which,
            "vehicle": vehicle,
            "seed": str(params.seed),
            "dvc_stage": f"train_{which.lower()}",
            "trained_on": role,
        },
        params=model_params(params, "train"),
        history=history_rows(result.history),
        metrics={
            "n_train_samples": len(train),
            "n_val_samples": len(val),
            "n_drives": len(data.drives),
            "n_trainable_params": result.n_trainable,
            "n_total_params": result.n_total,
        },
        artifacts=[paths.rel(out_dir / CHECKPOINT)],
    )
    with atomic_dir(out_dir) as tmp:
        save_checkpoint(result, tmp / CHECKPOINT)
        predictions_frame(test, pred).to_parquet(tmp / PREDICTIONS, index=False)
        write_json(tmp / RUN_RECORD, record.to_dict())
    return record, result.seconds
