"""DVC stage ``adapt@<seed>``: R-WhONet by every recipe at every m (paper §2.6, §3.3.3, §3.4).

Every target test drive gets its own R-WhONet per recipe and m (the paper
recalibrates per drive): G-WhONet of the same training seed recalibrated on
the drive's first m seconds (:mod:`rwhonet.models.adapt`). The ``continuous``
recipe instead recalibrates before every outage window the evaluation scores,
on the drive's seconds before that window only.

The same stage gathers the evidence the recipe, m and ridge penalty are chosen
on, never on a target test drive: every recipe on the target *training* drives
(first m seconds to recalibrate, the rest for ``evaluate`` to score), and
``ridge_head`` with every ``adapt.ridge_penalty_grid`` value on the held-out
*source* drives.

One process per seed does all of it (a process costs more to start than all
its recalibrations take); the recalibrations, independent of one another and
each seeded on its own, run on every core (a fork pool). Each is a
:class:`Job` carrying every input it reads (G, its drive's arrays, the recipe
settings) to :func:`run_job`, and torch runs on one thread wherever it runs,
so the results are identical whatever the number of workers.

The ``shrink`` recipes size their update by evidence measured here, never on a
target test drive (:func:`rwhonet.models.adapt.evidence_terms`): how well the first
k seconds of a drive fix its radius, on the target car's training drives (its own
receiver; each training drive scored for the selection is left out of its own
evidence), else on the source car's drives with ``adapt.shrink.unknown_car_sd``
added to the prior.

Outputs, all in ``models/r/seed<seed>/`` (one atomic folder):
``<recipe>/m<m>/`` with ``<drive>.pt`` (the model file; ``radius+G`` and ``shrink``
record their radii there), ``predictions.parquet`` (label predictions for every
second of each drive) and ``run.json``; ``continuous/`` (and ``continuous_shrink/``)
with ``predictions.parquet`` (``pred_m_<L>s`` on the seconds of each outage
length's windows) and ``run.json``; ``selection/target_train.parquet`` and
``selection/ridge_source.parquet`` (one ``pred_m__<model>`` column per recipe and m,
or per penalty and m); ``evidence.json``: the shrink recipes' evidence, from the
target car's and from the source car's drives (what a model bundle carries for
``rwhonet recalibrate``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import pandas as pd

from rwhonet import contracts, paths
from rwhonet.config import AdaptParams, Params
from rwhonet.contracts import CONTINUOUS, CONTINUOUS_RECIPES, drive_keys, recipe_model
from rwhonet.errors import InputError, Problem
from rwhonet.evaluation.windows import outage_windows
from rwhonet.features.calibration import calibration_from_dict
from rwhonet.features.samples import SampleSet
from rwhonet.io import atomic_dir, read_json, write_json
from rwhonet.progress import track
from rwhonet.stages.cores import cores_for, map_on_cores, one_thread_here, workers_for
from rwhonet.stages.model_outputs import history_rows, model_params, predictions_frame
from rwhonet.stages.sample_files import load_role
from rwhonet.tracking.records import RunRecord, Timing, now_ms
from rwhonet.tracking.timings import write_timing

if TYPE_CHECKING:  # annotations only: the models (torch) are imported when the stage runs
    from rwhonet.models.adapt import AdaptData, AdaptResult, EvidenceTerms, ShrinkEvidence
    from rwhonet.models.whonet import WhONet

T = TypeVar("T")
R = TypeVar("R")

SELECTION = "selection"
MAX_WORKERS = 4
# the source car's drives the shrink evidence for an unknown car is measured on
SOURCE_ROLES = (contracts.SOURCE_TRAIN, contracts.SOURCE_CALIBRATION, contracts.SOURCE_TEST)


def r_dir(root: Path, recipe: str, m: int | None = None) -> Path:
    """Folder of one recipe (and m) under a seed's ``models/r/seed<seed>``."""
    return Path(root) / recipe if m is None else Path(root) / recipe / f"m{m}"


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


@dataclass(frozen=True)
class Task:
    """One recalibration: a recipe (or a ridge penalty) on one drive's first m seconds."""

    role: str  # which sample set
    recipe: str
    m: int
    drive: str
    penalty: float | None = None  # ridge_head with this penalty (the source-drive study)


@dataclass(frozen=True)
class Job:
    """A task with every input it needs: what a worker process receives, and all it reads.

    Attributes:
        task: what to do.
        base: G-WhONet's network.
        hparams: its hyperparameters.
        fit: the drive's first m seconds (recalibrated on).
        scored: every second of the drive (predicted).
        adapt: the recipes' settings.
        seed: the training seed (shuffling and dropout).
        min_speed_m_s: the radius refit's moving-second threshold.
        source_radii: the WPM's source calibration.
        evidence: the shrink recipe's evidence for this drive (None for other recipes).
    """

    task: Task
    base: WhONet
    hparams: dict[str, Any]
    fit: AdaptData
    scored: AdaptData
    adapt: AdaptParams
    seed: int
    min_speed_m_s: float
    source_radii: tuple[float, float]
    evidence: ShrinkEvidence | None = None


def run_job(job: Job) -> tuple[np.ndarray, AdaptResult | None]:
    """Recalibrate one drive and predict it all; the model comes back for target test drives.

    A function of its argument alone, so the same job gives the same weights and
    predictions in whichever process runs it.

    Returns:
        ``(label predictions of job.scored, the AdaptResult or None)``.
    """
    from rwhonet.models.adapt import label_prediction, recalibrate

    task = job.task
    # A penalty task (the source-drive study) is the ridge_head recipe with its own penalty.
    adapt = job.adapt if task.penalty is None else replace(job.adapt, ridge_penalty=task.penalty)
    result = recalibrate(
        task.recipe,
        job.base,
        job.hparams,
        job.fit,
        adapt=adapt,
        seed=job.seed,
        min_speed_m_s=job.min_speed_m_s,
        evidence=job.evidence,
        source_radii=job.source_radii,
    )
    pred = label_prediction(result, job.scored, job.source_radii)
    result.info["n_adapt_samples"] = len(job.fit)
    keep = task.role == contracts.TARGET_TEST and task.penalty is None
    return pred, result if keep else None


def _timed(function: Callable[[T], R], item: T) -> tuple[R, tuple[int, int]]:
    """``function(item)`` and when it ran (epoch ms): a run's time spans its drives' tasks."""
    start = now_ms()
    done = function(item)
    return done, (start, now_ms())


def _pool_map(
    function: Callable[[T], R], items: list[T], desc: str
) -> list[tuple[R, tuple[int, int]]]:
    """``function`` on every item, on every core, in order, each with when it ran."""

    def shown(results):
        return track(results, desc=desc, unit="recalibration", total=len(items))

    workers = workers_for(len(items), MAX_WORKERS)
    chunk = max(1, len(items) // (8 * workers))
    return map_on_cores(partial(_timed, function), items, workers, chunk, show=shown)


@dataclass(frozen=True)
class Evidence:
    """The shrink recipes' evidence for one seed's G (module docstring).

    Attributes:
        target: measured on the target car's training drives (None: too few of them),
            its prior's drive-to-drive spread pooled with the source car's drives'.
        target_terms: its per-drive terms (to leave a scored training drive out).
        source_scales: the source car's drives' whole-drive scales (None: no drives).
        source: measured on the source car's drives, ``adapt.shrink.unknown_car_sd``
            added to its prior (None: too few of them).
    """

    target: ShrinkEvidence | None
    target_terms: EvidenceTerms | None
    source_scales: np.ndarray | None
    source: ShrinkEvidence | None

    @classmethod
    def measure(
        cls,
        params: Params,
        samples_dir: Path,
        target_train: SampleSet,
        g_net: WhONet,
        g_hparams: dict[str, Any],
        source_radii: tuple[float, float],
    ) -> Evidence:
        """Measure both on G's residuals (the source drives are read here)."""
        from rwhonet.models.adapt import shrink_evidence

        cfg = params.adapt.shrink
        source = load_role(samples_dir, SOURCE_ROLES, params.model.seq_len, required=False)
        terms = {
            role: _evidence_terms(params, s, g_net, g_hparams, source_radii) if len(s) else None
            for role, s in ((contracts.TARGET_TRAIN, target_train), ("source", source))
        }
        t, src = terms[contracts.TARGET_TRAIN], terms["source"]
        spread = None if src is None else src.scale
        return cls(
            None if t is None else shrink_evidence(t, contracts.TARGET_TRAIN, spread_of=spread),
            t,
            spread,
            None
            if src is None
            else shrink_evidence(src, "source", extra_prior_sd=cfg.unknown_car_sd),
        )

    def for_drive(self, role: str, drive: str) -> ShrinkEvidence:
        """What a drive's shrink recipe uses: the target car's (a training drive left out of
        its own), else the source car's.

        Raises:
            InputError: neither could be measured.
        """
        from rwhonet.models.adapt import shrink_evidence

        own = self.target
        if role == contracts.TARGET_TRAIN and self.target_terms is not None:
            own = shrink_evidence(
                self.target_terms,
                contracts.TARGET_TRAIN,
                exclude=drive,
                spread_of=self.source_scales,
            )
        if own is not None:
            return own
        if self.source is not None:
            return self.source
        raise InputError(
            [
                Problem(
                    "data/processed/samples",
                    None,
                    None,
                    "at least two target_train or source drives that move and are longer "
                    "than adapt.shrink.min_rest_s",
                    "none",
                    "add drives, or take shrink and continuous_shrink out of adapt.recipes",
                )
            ],
            "the shrink recipe has no evidence to size its update by",
        )

    def to_dict(self) -> dict[str, Any]:
        """``evidence.json``: the target car's and the source car's (null: not measured)."""
        return {
            "target": None if self.target is None else self.target.to_dict(),
            "source": None if self.source is None else self.source.to_dict(),
        }


def _evidence_terms(
    params: Params, samples: SampleSet, g_net, g_hparams: dict, source_radii: tuple[float, float]
) -> EvidenceTerms:
    """:func:`rwhonet.models.adapt.evidence_terms` on every drive of a sample set, under G."""
    from rwhonet.models.adapt import evidence_terms
    from rwhonet.models.loop import predict

    f = samples.frame
    return evidence_terms(
        f["drive"].to_numpy(),
        f["k"].to_numpy(),
        *(
            f[c].to_numpy(np.float64)
            for c in (contracts.DISP_GNSS_M, contracts.ANGLE_RL_RAD, contracts.ANGLE_RR_RAD)
        ),
        predict(g_net, samples.x, seq_len=g_hparams["seq_len"]).astype(np.float64),
        source_radii=source_radii,
        min_speed_m_s=params.label.calibration_min_speed_m_s,
        min_rest_s=params.adapt.shrink.min_rest_s,
    )


def adapt_grid(
    params: Params,
    seed: int,
    samples_dir: Path,
    calibration_path: Path,
    g_dir: Path,
    out_root: Path,
) -> tuple[list[RunRecord], float]:
    """Recalibrate G on every target test drive by every recipe and m, and gather the evidence.

    Args:
        params: resolved parameters (``adapt``; ``label.calibration_min_speed_m_s``
            for the radius refits; ``evaluate.outages_s`` for the continuous windows).
        seed: the training seed (shuffling and dropout of every fine-tune).
        samples_dir: the label stage's samples folder.
        calibration_path: the label stage's ``calibration.json`` (the source radii).
        g_dir: G-WhONet's folder for this seed (its model file is the starting point).
        out_root: ``models/r/seed<seed>``; replaced as a whole.

    Returns:
        One run record per recipe and m (per recipe for ``continuous``) and the
        wall seconds of recalibration, kept out of the records so outputs stay
        byte-reproducible. Each record's ``timing`` (from the first of its drives'
        recalibrations to start to the last to end; they run interleaved on every
        core) goes to a sidecar beside the MLflow store (:mod:`rwhonet.tracking.timings`).
    """
    from rwhonet.models.checkpoint import load_whonet, save_whonet

    cfg = params.adapt
    cal = calibration_from_dict(read_json(calibration_path), paths.rel(calibration_path))
    g_net, g_hparams = load_whonet(g_dir / contracts.MODEL_FILE)
    seq = params.model.seq_len
    samples = {
        contracts.TARGET_TEST: load_role(samples_dir, contracts.TARGET_TEST, seq),
        contracts.TARGET_TRAIN: load_role(samples_dir, contracts.TARGET_TRAIN, seq, required=False),
        contracts.SOURCE_TEST: load_role(samples_dir, contracts.SOURCE_TEST, seq, required=False),
    }
    check_lengths(samples[contracts.TARGET_TEST], cfg.m_grid)
    radii = (cal.r_rl_m, cal.r_rr_m)
    # G's predictions for the evidence run here, in this process: on one thread, as every
    # job does (cores), so that MKL cannot take fewer threads than asked under load and
    # sum in another order (Intel's reproducibility conditions: a fixed thread count)
    with one_thread_here():
        evidence = Evidence.measure(
            params, samples_dir, samples[contracts.TARGET_TRAIN], g_net, g_hparams, radii
        )
    recipes = [r for r in cfg.recipes if r not in CONTINUOUS_RECIPES]
    tasks = [
        Task(role, r, m, d)
        for role in (contracts.TARGET_TEST, contracts.TARGET_TRAIN)
        for r in recipes
        for m in cfg.m_grid
        for d in samples[role].drives
    ]
    tasks += [
        Task(contracts.SOURCE_TEST, "ridge_head", m, d, penalty)
        for penalty in cfg.ridge_penalty_grid
        for m in cfg.m_grid
        for d in samples[contracts.SOURCE_TEST].drives
    ]
    start = time.perf_counter()
    jobs = _jobs(tasks, samples, g_net, g_hparams, params, seed, radii, evidence)
    timed = _pool_map(run_job, jobs, desc=f"adapt@{seed}")
    done = [(t, pred, result) for t, ((pred, result), _) in zip(tasks, timed, strict=True)]
    spans = {t: span for t, (_, span) in zip(tasks, timed, strict=True)}
    continuous_start = now_ms()
    continuous = {
        (recipe, role): _continuous(
            params, recipe, role, samples[role], g_net, g_hparams, radii, evidence
        )
        for recipe in cfg.recipes
        if recipe in CONTINUOUS_RECIPES
        for role in (contracts.TARGET_TEST, contracts.TARGET_TRAIN)
        if len(samples[role])
    }
    continuous_timing = Timing(continuous_start, now_ms())
    seconds = time.perf_counter() - start
    records = []
    with atomic_dir(out_root) as tmp:
        test = samples[contracts.TARGET_TEST]
        for recipe in recipes:
            for m in cfg.m_grid:
                out = r_dir(tmp, recipe, m)
                out.mkdir(parents=True)
                mine = [
                    (t, p, res)
                    for t, p, res in done
                    if (t.role, t.recipe, t.m, t.penalty)
                    == (contracts.TARGET_TEST, recipe, m, None)
                ]
                preds = []
                for t, pred, result in mine:
                    save_whonet(
                        result.net, result.hparams, out / f"{t.drive}.pt", wpm_radii=result.radii
                    )
                    preds.append(predictions_frame(test.take(test.frame["drive"] == t.drive), pred))
                pd.concat(preds, ignore_index=True).to_parquet(
                    out / contracts.PREDICTIONS, index=False
                )
                curves = fine_tune_curves(mine)
                if len(curves):
                    curves.to_csv(out / contracts.FINE_TUNE_CURVES, index=False)
                record = _record(params, seed, recipe, m, mine, out_root, curves)
                write_json(out / contracts.RUN_RECORD, record.to_dict())
                mine_spans = [spans[t] for t, _, _ in mine]
                record.timing = Timing(min(s for s, _ in mine_spans), max(e for _, e in mine_spans))
                records.append(record)
        for (recipe, role), columns in continuous.items():
            if role != contracts.TARGET_TEST:
                continue
            out = r_dir(tmp, recipe)
            out.mkdir()
            frame = test.frame[["drive", "segment", "t_s"]].assign(
                **{f"pred_m_{L}s": col for L, col in columns.items()}
            )
            frame.to_parquet(out / contracts.PREDICTIONS, index=False)
            record = RunRecord(
                name=f"R-WhONet {recipe} seed {seed}",
                tags=_tags(seed, recipe, None),
                params={**model_params(params, seed, "adapt"), "adapt.recipe": recipe},
                timing=continuous_timing,
            )
            write_json(out / contracts.RUN_RECORD, record.to_dict())
            records.append(record)
        _write_selection(tmp / SELECTION, samples, done, continuous)
        write_json(tmp / contracts.SHRINK_EVIDENCE, evidence.to_dict())
    for record in records:
        write_timing(_record_dir(out_root, record), record.timing, stage=f"adapt@{seed}")
    return records, seconds


def _jobs(
    tasks: list[Task],
    samples: dict[str, SampleSet],
    g_net: WhONet,
    g_hparams: dict[str, Any],
    params: Params,
    seed: int,
    source_radii: tuple[float, float],
    evidence: Evidence,
) -> list[Job]:
    """Every task with its inputs; the jobs of one drive share its arrays (no copy per job)."""
    from rwhonet.models.adapt import adapt_data

    arrays: dict[tuple[str, str, int | None], AdaptData] = {}

    def data_of(role: str, drive: str, m: int | None) -> AdaptData:
        key = (role, drive, m)
        if key not in arrays:
            s = samples[role]
            mask = s.frame["drive"].to_numpy() == drive
            if m is not None:
                mask &= s.frame["k"].to_numpy() < m
            arrays[key] = adapt_data(s, mask)
        return arrays[key]

    return [
        Job(
            task=t,
            base=g_net,
            hparams=g_hparams,
            fit=data_of(t.role, t.drive, t.m),
            scored=data_of(t.role, t.drive, None),
            adapt=params.adapt,
            seed=seed,
            min_speed_m_s=params.label.calibration_min_speed_m_s,
            source_radii=source_radii,
            evidence=evidence.for_drive(t.role, t.drive) if t.recipe == contracts.SHRINK else None,
        )
        for t in tasks
    ]


def _record_dir(out_root: Path, record: RunRecord) -> Path:
    """The folder a recipe's run record was written to (``<recipe>/m<m>`` or ``continuous``)."""
    m = record.tags.get("m")
    return r_dir(out_root, record.tags["recipe"], None if m is None else int(m))


def _write_selection(
    folder: Path, samples: dict[str, SampleSet], done: list, continuous: dict
) -> None:
    """The evidence: predictions on the target training drives and the source-drive ridge study."""
    folder.mkdir()
    for role, file in (
        (contracts.TARGET_TRAIN, "target_train"),
        (contracts.SOURCE_TEST, "ridge_source"),
    ):
        s = samples[role]
        frame = s.frame[["drive", "segment", "t_s"]].copy()
        columns: dict[str, np.ndarray] = {}
        drive = s.frame["drive"].to_numpy()
        for t, pred, _ in done:
            if t.role != role:
                continue
            name = (
                f"ridge_head lambda={t.penalty:g}@{t.m}"
                if t.penalty is not None
                else recipe_model(t.recipe, t.m)
            )
            col = columns.setdefault(name, np.full(len(frame), np.nan))
            col[drive == t.drive] = pred
        for (recipe, of), by_outage in continuous.items():
            if of == role:
                for L, col in by_outage.items():
                    columns[f"{recipe_model(recipe, None)}/{L}s"] = col
        frame = frame.assign(**{f"pred_m__{name}": col for name, col in columns.items()})
        frame.to_parquet(folder / f"{file}.parquet", index=False)


def fine_tune_curves(mine: list) -> pd.DataFrame:
    """Every drive's fine-tuning curve of one recipe at one m: drive, epoch, train/loss, val/loss.

    Empty (no rows) for the recipes that take no optimizer steps (``radius+G``, ``ridge_head``,
    ``shrink``).
    """
    rows = [
        {"drive": t.drive, **row} for t, _, result in mine for row in history_rows(result.history)
    ]
    return pd.DataFrame(rows, columns=None if rows else ["drive", "epoch"])


def _record(
    params: Params,
    seed: int,
    recipe: str,
    m: int,
    mine: list,
    out_root: Path,
    curves: pd.DataFrame,
) -> RunRecord:
    """The run record of one recipe at one m.

    Per-drive facts are ``drive/<d>/...`` metrics (``<d>`` as MLflow allows a name:
    :func:`rwhonet.contracts.drive_keys`). The fine-tuning curves are not: one
    metric per drive and epoch made about 65,000 of an execution's 75,000 MLflow metric rows
    (most of ``evaluate``'s logging time, and a run page of a thousand charts). The run's
    ``train/loss`` / ``val/loss`` history is their mean over the drives still fine-tuning at
    each epoch; every drive's own curve is the run's artifact ``fine_tune.csv``.
    """
    metrics: dict[str, float] = {}
    names = drive_keys(sorted({t.drive for t, _, _ in mine}))  # as MLflow allows a name
    for t, _, result in mine:
        for key, value in result.info.items():
            if isinstance(value, bool | int | float):
                metrics[f"drive/{names[t.drive]}/{key}"] = float(value)
        if result.radii is not None:
            rl, rr = f"drive/{names[t.drive]}/r_rl_m", f"drive/{names[t.drive]}/r_rr_m"
            metrics[rl], metrics[rr] = result.radii
    first = mine[0][2]
    metrics.update(n_trainable_params=first.n_trainable, n_total_params=first.n_total)
    history: list[dict[str, float]] = []
    artifacts = [paths.rel(r_dir(out_root, recipe, m) / f"{t.drive}.pt") for t, _, _ in mine]
    if len(curves):
        means = curves.drop(columns="drive").groupby("epoch", sort=True).mean()
        history = [
            {"epoch": int(e), **{k: float(v) for k, v in row.items() if v == v}}
            for e, row in means.iterrows()
        ]
        artifacts.append(paths.rel(r_dir(out_root, recipe, m) / contracts.FINE_TUNE_CURVES))
    return RunRecord(
        name=f"R-WhONet {recipe} m={m} seed {seed}",
        tags=_tags(seed, recipe, m),
        params={**model_params(params, seed, "adapt"), "adapt.m": m, "adapt.recipe": recipe},
        history=history,
        metrics=metrics,
        # every model file (evaluate keeps them on R-WhONet's run only: the choice may be
        # auto) and the fine-tuning curves
        artifacts=artifacts,
    )


def _continuous(
    params: Params,
    recipe: str,
    role: str,
    samples: SampleSet,
    g_net,
    g_hparams: dict,
    source_radii: tuple[float, float],
    evidence: Evidence,
) -> dict[int, np.ndarray]:
    """A continuous recipe on every drive of a sample set: one prediction column per outage.

    ``continuous`` runs ``adapt.continuous.inner``; ``continuous_shrink`` runs
    ``shrink+ridge_head`` with each drive's shrink evidence.
    """
    from rwhonet.models.adapt import SHRINK_RIDGE, adapt_data, continuous_predictions

    cfg = params.adapt.continuous
    inner = cfg.inner if recipe == CONTINUOUS else SHRINK_RIDGE
    frame = samples.frame
    drive = frame["drive"].to_numpy()
    rank = frame["k"].to_numpy()
    columns = {}
    for L in params.evaluate.outages_s:
        col = np.full(len(frame), np.nan)
        windows = outage_windows(frame, params.adapt.m_grid, L)
        w_drive = drive[windows[:, 0]] if len(windows) else np.array([])
        for d in samples.drives:
            rows = np.flatnonzero(drive == d)  # the drive's seconds, in time order
            mine = windows[w_drive == d]
            if not len(mine):
                continue
            pred = continuous_predictions(
                g_net,
                g_hparams,
                adapt_data(samples, drive == d),
                rank[rows],
                np.searchsorted(rows, mine),
                inner=inner,
                penalty=params.adapt.ridge_penalty,
                window_s=cfg.window_s,
                min_speed_m_s=params.label.calibration_min_speed_m_s,
                source_radii=source_radii,
                evidence=evidence.for_drive(role, d) if inner == SHRINK_RIDGE else None,
            )
            col[mine.ravel()] = pred.ravel()
        columns[L] = col
    return columns


def _tags(seed: int, recipe: str, m: int | None) -> dict[str, str]:
    tags = {
        "model": "R",
        "recipe": recipe,
        "vehicle": "target",
        "seed": str(seed),
        "dvc_stage": f"adapt@{seed}",
    }
    if m is not None:
        tags["m"] = str(m)
    return tags


def main(params: Params, seed: int) -> None:
    """The ``adapt@<seed>`` stage: G of that seed -> ``models/r/seed<seed>`` (every recipe, m)."""
    out = paths.model_dir("r", seed)
    records, seconds = adapt_grid(
        params, seed, paths.SAMPLES, paths.CALIBRATION, paths.model_dir("g", seed), out
    )
    print(
        f"R-WhONet seed {seed}: {len(params.adapt.recipes)} recipes "
        f"({', '.join(params.adapt.recipes)}) x {len(params.adapt.m_grid)} m values, on the test "
        f"drives and (the selection evidence) the target training drives; ridge penalties on "
        f"the held-out source drives; {len(records)} runs, {seconds:.1f} s on "
        f"{cores_for(MAX_WORKERS)} cores -> {paths.rel(out)}"
    )
