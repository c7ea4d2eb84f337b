"""R-WhONet: G-WhONet fine-tuned on each test drive's first m seconds (paper §2.6, §3.3.3, §3.4)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from rwhonet import paths
from rwhonet.config import Params
from rwhonet.errors import InputError, Problem
from rwhonet.experiment.samples import load_role
from rwhonet.experiment.train import (
    CHECKPOINT,
    PREDICTIONS,
    RUN_RECORD,
    history_rows,
    model_params,
    predictions_frame,
)
from rwhonet.io import atomic_dir, write_json
from rwhonet.tracking.store import RunRecord


def adapt_m(
    params: Params, m: int, samples_dir: Path, g_dir: Path, out_dir: Path
) -> tuple[RunRecord, float]:
    """Fine-tune G on the first ``m`` seconds of every target test drive.

    Every test drive gets its own R-WhONet (the paper recalibrates per drive),
    saved as ``out_dir/<drive>.ckpt``; its predictions cover the whole drive,
    and the evaluation scores only the seconds after the largest m of the grid.

    Args:
        params: resolved parameters (``adapt`` holds the fine-tuning recipe).
        m: adaptation length in seconds (one point of ``adapt.m_grid``).
        samples_dir: the label stage's samples folder.
        g_dir: G-WhONet's folder (its checkpoint is the starting point).
        out_dir: ``models/r/m<m>``.

    Returns:
        The run record (one R run for this m with a child run per drive) and
        the seconds of fitting, kept out of the record as in ``train_model``.
    """
    # The lean path: the same fine-tuning as rwhonet.models.train.fine_tune, bit for bit,
    # without importing Lightning (5-7 s per stage process against < 1 s of fitting).
    # Imported here so that importing this module (for r_dir) does not load torch.
    from rwhonet.models.core import fine_tune_lean, predict, save_checkpoint_lean

    test = load_role(samples_dir, "target_test", params.model.seq_len)
    # Only this m matters here (the stage does not depend on the rest of the grid);
    # evaluate checks that every drive is long enough beyond the largest m.
    k = test.frame["k"].to_numpy()
    drive = test.frame["drive"].to_numpy()
    short = [
        Problem(d, None, None, f"more than m = {m} labelled seconds", f"{n} seconds")
        for d, n in test.frame.groupby("drive", sort=False).size().items()
        if n <= m
    ]
    if short:
        raise InputError(short, f"target test drives too short to adapt on their first {m} s")

    children, preds, results = [], [], {}
    for d in test.drives:
        first = (drive == d) & (k < m)
        result = fine_tune_lean(
            g_dir / CHECKPOINT, test.x[first], test.y[first], adapt=params.adapt, seed=params.seed
        )
        results[d] = result
        on_drive = test.take(drive == d)
        pred = predict(result.net, on_drive.x, seq_len=result.hparams["seq_len"])
        preds.append(predictions_frame(on_drive, pred))
        children.append(
            RunRecord(
                name=f"R m={m} {d}",
                tags={
                    "model": "R",
                    "m": str(m),
                    "drive": d,
                    "vehicle": "target",
                    "seed": str(params.seed),
                    "dvc_stage": f"adapt@{m}",
                },
                params={**model_params(params, "adapt"), "adapt.m": m, "drive": d},
                history=history_rows(result.history),
                metrics={
                    "n_adapt_samples": int(first.sum()),
                    "n_trainable_params": result.n_trainable,
                    "n_total_params": result.n_total,
                },
                artifacts=[paths.rel(out_dir / f"{d}.ckpt")],
            )
        )
    record = RunRecord(
        name=f"R-WhONet m={m}",
        tags={
            "model": "R",
            "m": str(m),
            "vehicle": "target",
            "seed": str(params.seed),
            "dvc_stage": f"adapt@{m}",
        },
        params={**model_params(params, "adapt"), "adapt.m": m},
        metrics={
            "n_trainable_params": next(iter(results.values())).n_trainable,
            "n_total_params": next(iter(results.values())).n_total,
        },
        children=children,
    )
    with atomic_dir(out_dir) as tmp:
        for d, result in results.items():
            save_checkpoint_lean(result, tmp / f"{d}.ckpt")
        pd.concat(preds, ignore_index=True).to_parquet(tmp / PREDICTIONS, index=False)
        write_json(tmp / RUN_RECORD, record.to_dict())
    return record, float(sum(r.seconds for r in results.values()))


def r_dir(m: int) -> Path:
    """Folder of R-WhONet for one m."""
    return paths.MODELS_R / f"m{m}"


__all__ = ["adapt_m", "r_dir", "CHECKPOINT", "PREDICTIONS", "RUN_RECORD"]
