"""DVC stage ``train``: G-WhONet (source car) and S-WhONet (target car), every seed.

Paper §2.4-2.5, §3.3.1-3.3.2: a WhONet trained from scratch with Lightning on one
role's drives, then run on every target test second; one per model and seed
(``models/g/seed<seed>/``, ``models/s/seed<seed>/``, each written atomically).

The fits share nothing, and one fit keeps one core busy (at this size a second
thread only adds synchronisation), so on one CPU process per fit
(``train.trainer`` at its default) they run on every core, the longest first
(:mod:`rwhonet.stages.cores`); each fit is seeded and single-threaded wherever it
runs, so its model file is the same bytes whatever the number of cores.

With ``train.trainer.strategy: ddp`` (or a GPU) the fits run one after the
other in this process: Lightning starts this script once per device
(docs/scaling.md), every process trains, and only global rank 0 predicts and
writes the outputs.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Literal

from rwhonet import contracts, paths
from rwhonet.config import Params
from rwhonet.features.samples import split_tail
from rwhonet.io import atomic_dir, write_json
from rwhonet.progress import interactive
from rwhonet.stages.cores import map_on_cores, workers_for
from rwhonet.stages.model_outputs import history_rows, model_params, predictions_frame
from rwhonet.stages.sample_files import load_role
from rwhonet.tracking.records import RunRecord, Timing, now_ms
from rwhonet.tracking.timings import write_timing

WHICH = {
    "G": (contracts.SOURCE_TRAIN, "source", "G-WhONet"),
    "S": (contracts.TARGET_TRAIN, "target", "S-WhONet"),
}


def train_model(
    params: Params,
    which: Literal["G", "S"],
    seed: int,
    samples_dir: Path,
    out_dir: Path,
    bar: bool | None = None,
) -> tuple[RunRecord, float] | None:
    """Train one WhONet on its role's drives and predict every test drive.

    Args:
        params: resolved parameters.
        which: ``G`` (source vehicle's training drives) or ``S`` (target vehicle's).
        seed: the training seed (weights, shuffling, dropout).
        samples_dir: the label stage's samples folder.
        out_dir: ``models/<g|s>/seed<seed>``; receives the model file, the per-second
            predictions on every test drive (target and held-out source) and on the
            target training drives (where the recipes are selected), and the run record.
        bar: Lightning's progress bar (default: for a person at a terminal, else plain
            epoch lines); fits that run side by side print lines.

    Returns:
        The run record (also written to ``out_dir/run.json``) and the seconds
        the fit took. Timings stay out of ``run.json`` so that every output of the
        stage is byte-reproducible from its inputs (dvc.lock does not change on
        a re-run): the record's ``timing`` (the fit's start and end) goes to a
        sidecar beside the MLflow store (:mod:`rwhonet.tracking.timings`).
        None in a distributed training process other than rank 0, which
        writes nothing.
    """
    from rwhonet.models.checkpoint import save_whonet
    from rwhonet.models.epoch_log import EpochLog
    from rwhonet.models.train import fit, predict

    role, vehicle, name = WHICH[which]
    data = load_role(samples_dir, role, params.model.seq_len)
    train, val = split_tail(data, params.train.val_fraction)
    started = now_ms()
    # Lightning draws its bar on stdout for a person at a terminal; logs get plain lines.
    bar = interactive(sys.stdout) if bar is None else bar
    epoch_log = [] if bar else [EpochLog(f"{name} seed {seed}", params.train.epochs)]
    result = fit(
        train.x,
        train.y,
        val.x,
        val.y,
        model=params.model,
        train=params.train,
        seed=seed,
        callbacks=epoch_log,
        progress=bar,
    )
    timing = Timing(started, now_ms())
    if result.global_rank != 0:
        return None
    test = load_role(samples_dir, contracts.PREDICTED_ROLES, params.model.seq_len)
    pred = predict(result.module, test.x)
    record = RunRecord(
        name=f"{name} seed {seed}",
        tags={
            "model": which,
            "vehicle": vehicle,
            "seed": str(seed),
            "dvc_stage": "train",
            "trained_on": role,
        },
        params=model_params(params, seed, "train"),
        history=history_rows(result.history),
        metrics={
            "n_train_samples": len(train),
            "n_val_samples": len(val),
            "n_drives": len(data.drives),
            "n_trainable_params": result.n_trainable,
            "n_total_params": result.n_total,
        },
        artifacts=[paths.rel(out_dir / contracts.MODEL_FILE)],
        timing=timing,
    )
    with atomic_dir(out_dir) as tmp:
        save_whonet(result.module.net, result.module.hparams, tmp / contracts.MODEL_FILE)
        predictions_frame(test, pred).to_parquet(tmp / contracts.PREDICTIONS, index=False)
        write_json(tmp / contracts.RUN_RECORD, record.to_dict())
    write_timing(out_dir, timing, stage=f"train ({which} seed {seed})")
    return record, result.seconds


# G's fits take several times S's (the source car has more training drives): G first,
# so that the last fit to start is a short one.
MODELS: tuple[Literal["G", "S"], ...] = ("G", "S")
MAX_WORKERS = 8


def main(params: Params, which: Literal["G", "S"] | None = None, seed: int | None = None) -> None:
    """The ``train`` stage: every model of ``MODELS`` at every seed of ``params.seeds``.

    Args:
        params: the stage's params.
        which: only this model (a run by hand; the stage trains both).
        seed: only this seed (a run by hand; the stage trains every seed).
    """
    models = [m for m in MODELS if which in (None, m)]
    seeds = params.seeds if seed is None else [seed]
    trainer = params.train.trainer
    one_process_each = trainer.world_size == 1 and trainer.accelerator == "cpu"
    # a fit runs on train.num_threads threads (models.train.fit): that many cores each
    threads = params.train.num_threads
    workers = workers_for(len(models) * len(seeds), MAX_WORKERS, threads) if one_process_each else 1
    bar = None if workers == 1 else False  # side by side, the fits print plain lines
    jobs = [(params, m, s, bar) for m in models for s in seeds]
    map_on_cores(_train_one, jobs, workers, show=_printed)


def _printed(lines: Iterator[str]) -> Iterator[str]:
    """Each fit's line, in the jobs' order, as soon as it and those before it are done."""
    for line in lines:
        print(line, flush=True)
        yield line


def _train_one(job: tuple[Params, Literal["G", "S"], int, bool | None]) -> str:
    """Train one model (in a pool's worker or here); the line that reports it."""
    params, which, seed, bar = job
    out = paths.model_dir(which.lower(), seed)
    done = train_model(params, which, seed, paths.SAMPLES, out, bar)
    if done is None:
        return f"train {which}@{seed}: a training process other than rank 0, writes nothing"
    rec, seconds = done
    last = rec.history[-1] if rec.history else {}
    nan = float("nan")
    m = rec.metrics
    return (
        f"{rec.name}: {int(m['n_train_samples'])} training seconds from {int(m['n_drives'])} "
        f"drives, {params.train.epochs} epochs in {seconds:.1f} s "
        f"({m['n_train_samples'] * params.train.epochs / seconds:,.0f} samples/s); final train MAE "
        f"{last.get('train/loss', nan):.4f} m, val MAE {last.get('val/loss', nan):.4f} m "
        f"-> {paths.rel(out)}"
    )
