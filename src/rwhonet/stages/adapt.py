"""DVC stage ``adapt``: R-WhONet at every m of the grid (paper §2.6, §3.3.3, §3.4).

Every target test drive gets its own R-WhONet per m (the paper recalibrates per
drive): G-WhONet of the same training seed fine-tuned on the drive's first m
seconds (:func:`rwhonet.models.adapt.fine_tune`). One process per seed covers
the whole grid, because a process costs more to start than all its fine-tunes
take (``benchmarks/bench_train.py``); the outputs are still one folder per m,
``models/r/seed<seed>/m<m>/`` with ``<drive>.pt``, the drives' per-second
predictions and the run record. The evaluation scores only the seconds after
the largest m.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from rwhonet import contracts, paths
from rwhonet.config import Params
from rwhonet.errors import InputError, Problem
from rwhonet.io import atomic_dir, write_json
from rwhonet.stages.records import history_rows, model_params, predictions_frame
from rwhonet.stages.samples import SampleSet, load_role
from rwhonet.tracking.store import RunRecord


def r_dir(root: Path, m: int) -> Path:
    """Folder of R-WhONet for one m."""
    return Path(root) / f"m{m}"


def check_lengths(test: SampleSet, m_grid: list[int]) -> None:
    """Refuse target test drives that are not longer than the largest m.

    Raises:
        InputError: naming every drive with at most ``max(m_grid)`` labelled seconds.
    """
    m = max(m_grid)
    short = [
        Problem(d, None, None, f"more than m = {m} labelled seconds", f"{n} seconds")
        for d, n in test.frame.groupby("drive", sort=False).size().items()
        if n <= m
    ]
    if short:
        raise InputError(short, f"target test drives too short to adapt on their first {m} s")


def adapt_grid(
    params: Params, seed: int, samples_dir: Path, g_dir: Path, out_root: Path
) -> tuple[list[RunRecord], float]:
    """Fine-tune G on the first m seconds of every target test drive, for every m.

    Args:
        params: resolved parameters (``adapt`` holds the grid and the fine-tuning recipe).
        seed: the training seed (shuffling and dropout of every fine-tune).
        samples_dir: the label stage's samples folder.
        g_dir: G-WhONet's folder for this seed (its model file is the starting point).
        out_root: ``models/r/seed<seed>``; replaced as a whole, one ``m<m>`` folder per m.

    Returns:
        One run record per m (with a child run per drive) and the seconds of
        fine-tuning, kept out of the records so outputs stay byte-reproducible.
    """
    from rwhonet.models.adapt import fine_tune
    from rwhonet.models.checkpoint import load_whonet, save_whonet
    from rwhonet.models.loop import predict

    g_net, g_hparams = load_whonet(g_dir / contracts.MODEL_FILE)
    test = load_role(samples_dir, contracts.TARGET_TEST, params.model.seq_len)
    check_lengths(test, params.adapt.m_grid)
    k = test.frame["k"].to_numpy()
    drive = test.frame["drive"].to_numpy()
    records, seconds = [], 0.0
    with atomic_dir(out_root) as tmp_root:
        for m in params.adapt.m_grid:
            out = r_dir(tmp_root, m)
            out.mkdir()
            children, preds, results = [], [], {}
            for d in test.drives:
                first = (drive == d) & (k < m)
                result = fine_tune(
                    g_net, g_hparams, test.x[first], test.y[first],
                    adapt=params.adapt, seed=seed,
                )  # fmt: skip
                results[d] = result
                seconds += result.seconds
                save_whonet(result.net, result.hparams, out / f"{d}.pt")
                on_drive = test.take(drive == d)
                pred = predict(result.net, on_drive.x, seq_len=result.hparams["seq_len"])
                preds.append(predictions_frame(on_drive, pred))
                children.append(
                    RunRecord(
                        name=f"R m={m} {d}",
                        tags=_tags(seed, m) | {"drive": d},
                        params={**model_params(params, seed, "adapt"), "adapt.m": m, "drive": d},
                        history=history_rows(result.history),
                        metrics={
                            "n_adapt_samples": int(first.sum()),
                            "n_trainable_params": result.n_trainable,
                            "n_total_params": result.n_total,
                        },
                        artifacts=[paths.rel(r_dir(out_root, m) / f"{d}.pt")],
                    )
                )
            any_result = next(iter(results.values()))
            record = RunRecord(
                name=f"R-WhONet m={m}",
                tags=_tags(seed, m),
                params={**model_params(params, seed, "adapt"), "adapt.m": m},
                metrics={
                    "n_trainable_params": any_result.n_trainable,
                    "n_total_params": any_result.n_total,
                },
                children=children,
            )
            pd.concat(preds, ignore_index=True).to_parquet(out / contracts.PREDICTIONS, index=False)
            write_json(out / contracts.RUN_RECORD, record.to_dict())
            records.append(record)
    return records, seconds


def _tags(seed: int, m: int) -> dict[str, str]:
    return {"model": "R", "m": str(m), "vehicle": "target", "seed": str(seed), "dvc_stage": "adapt"}


def main(params: Params, seed: int) -> None:
    """The ``adapt@<seed>`` stage: G of that seed -> ``models/r/seed<seed>/m<m>`` for every m."""
    out = paths.model_dir("r", seed)
    records, seconds = adapt_grid(params, seed, paths.SAMPLES, paths.model_dir("g", seed), out)
    counts = records[0].metrics
    n_drives = len(records[0].children)
    print(
        f"R-WhONet: {n_drives} drives x {len(records)} m values "
        f"({', '.join(str(m) for m in params.adapt.m_grid)} s), trainable "
        f"{int(counts['n_trainable_params'])} of {int(counts['n_total_params'])} parameters "
        f"({params.adapt.trainable}), {params.adapt.epochs} epochs, {seconds:.1f} s of "
        f"fine-tuning -> {paths.rel(out)}"
    )
