"""``rwhonet recalibrate``: G recalibrated on a new car's first m seconds, scored and registered.

The drive goes through the pipeline's own data code (:mod:`rwhonet.cli.drive`).
Its first ``m`` valid seconds recalibrate the base model by one of the adapt
stage's recipes (:func:`rwhonet.models.adapt.recalibrate`, with ``adapt:`` from
params.yaml); the rest of the drive is cut into the evaluation's outage windows
(``evaluate.outages_s``, :func:`rwhonet.evaluation.scoring.window_metrics`) and
scored for the WPM, the base model and the recalibrated one. The result is a
model bundle registered as a new version of ``whonet-R-<vehicle>``, with the
base model, m, recipe, seed and the drive's SHA-256 as version tags.

The default recipe (``adapt.fallback``: ``shrink``) sizes its update by the evidence
the base model's bundle carries (:class:`rwhonet.models.adapt.ShrinkEvidence`), and
the printout says how sure it is: the refitted radius' 95 % interval, how far the
m seconds alone fix it, and how much of the refit it kept.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet import contracts
from rwhonet.config import AUTO, Params, flatten
from rwhonet.errors import InputError, Problem
from rwhonet.io import scratch_dir

ONE_SHOT_RECIPES = ("paper", "head", "ridge_head", "radius+G", "steps", contracts.SHRINK)
Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile


@dataclass(frozen=True)
class Choice:
    """The recipe and m of a recalibration, and where they came from."""

    recipe: str
    m: int
    why: str


def choose(params: Params, recipe: str | None, seconds: int | None) -> Choice:
    """``--recipe`` and ``--seconds``, else params' ``adapt.recipe`` and ``adapt.chosen_m``.

    With ``auto`` in params (the pipeline's selection rule picks on a fleet's
    training drives, which a single drive does not have), ``adapt.fallback``.

    Raises:
        InputError: a recipe that is not a one-shot recalibration, or m < 1.
    """
    adapt = params.adapt
    auto = adapt.recipe == AUTO
    why = (
        "--recipe"
        if recipe
        else ("adapt.fallback (adapt.recipe: auto)" if auto else "adapt.recipe")
    )
    recipe = recipe or (adapt.fallback.recipe if auto else adapt.recipe)
    m = seconds or (adapt.fallback.m if auto else int(adapt.chosen_m))
    if recipe not in ONE_SHOT_RECIPES:
        fix = (
            "`continuous` recalibrates before every outage, so it is no single model to register; "
            if recipe == contracts.CONTINUOUS
            else ""
        )
        raise InputError(
            [
                Problem(
                    "--recipe",
                    None,
                    None,
                    f"one of {', '.join(ONE_SHOT_RECIPES)}",
                    repr(recipe),
                    fix + "choose a recipe with --recipe",
                )
            ],
            "unknown recalibration recipe",
        )
    if m < 1:
        raise InputError(
            [Problem("--seconds", None, None, "a whole number of seconds >= 1", str(m))]
        )
    return Choice(recipe, int(m), why)


def run(
    params: Params,
    *,
    base: str,
    drive: Path,
    seconds: int | None,
    recipe: str | None,
    fmt: str,
    vehicle: str,
    seed: int | None,
    tracking_uri: str,
    evidence: str | None = None,
    source_nominal_m: float | None = None,
    drive_id: str | None = None,
) -> dict[str, Any]:
    """Recalibrate, score and register; return what was done (for the printout).

    Args:
        drive_id: in a file of many drives, the drive (``--drive-id``; None: its one).
        evidence: ``shrink`` only: ``target`` or ``source`` (:func:`shrink_evidence_of`;
            by default the pipeline's target car's for that car, the source car's for
            any other).
        source_nominal_m: the source car's nominal tyre radius as the pipeline took it.
            ``shrink`` on a car with evidence from the source car's drives centres its
            prior on the source calibration scaled by the car's nominal radius over
            this (:func:`prior_radii_of`): a car of another tyre size starts from its
            own size, not the source car's.

    Raises:
        InputError: a base model that cannot be found, a drive the pipeline refuses,
            too few valid seconds to recalibrate on and score, or (``shrink``) a base
            model that carries no evidence.
    """
    from rwhonet.cli.drive import calibration_of, drive_sha256, load_drive
    from rwhonet.data.fleetfile import shown
    from rwhonet.features.scaling import scaler_from_dict
    from rwhonet.models.adapt import adapt_data, label_prediction, recalibrate
    from rwhonet.models.checkpoint import load_whonet, save_whonet
    from rwhonet.models.loop import predict
    from rwhonet.serve.bundle import bundle_parts, make_meta, write_bundle
    from rwhonet.serve.model import SAFETENSORS_FILE
    from rwhonet.tracking.registry import fetch_model, registered_name, version_label

    start = time.perf_counter()
    choice = choose(params, recipe, seconds)
    seed = params.seeds[0] if seed is None else seed
    with scratch_dir("recalibrate") as tmp:
        base_path, base_version = fetch_model(base, tracking_uri, Path(tmp) / "base")
        base_file, base_meta = bundle_parts(
            base_path, version_label(base_version) if base_version is not None else base
        )
        net, hparams = load_whonet(base_file)  # a registered version's: model.safetensors
        data = load_drive(
            drive,
            params,
            vehicle=vehicle,
            fmt=fmt,
            calibration=calibration_of(base_meta.source_radii, base),
            scaler=scaler_from_dict(base_meta.scaler, base),
            wpm_mode=base_meta.wpm_mode,
            seq_len=int(hparams["seq_len"]),
            part=drive_id,
        )
        shortest = min(params.evaluate.outages_s)
        n = len(data.samples)
        if n < choice.m + shortest:
            raise InputError(
                [
                    Problem(
                        data.file,
                        None,
                        None,
                        f"at least {choice.m + shortest} GNSS-valid seconds: m = {choice.m} s "
                        f"to recalibrate on ({choice.why}), then {shortest} s (the shortest of "
                        "evaluate.outages_s) to score",
                        f"{n} labelled s; {data.kept_summary()}",
                        "record a longer drive of the car, or recalibrate on fewer seconds "
                        "(--seconds)",
                    )
                ],
                "not enough valid seconds to recalibrate and score",
            )
        new_car = vehicle != params.data.roles[contracts.TARGET_TRAIN].vehicle
        shrink_ev = (
            shrink_evidence_of(base_meta.evidence, evidence, base, new_car=new_car)
            if choice.recipe == contracts.SHRINK
            else None
        )
        prior = prior_radii_of(
            shrink_ev, base_meta.source_radii, car_nominal_m(params, vehicle), source_nominal_m
        )
        k = data.samples.frame["k"].to_numpy()
        first, rest = k < choice.m, k >= choice.m
        fit_start = time.perf_counter()
        result = recalibrate(
            choice.recipe,
            net,
            hparams,
            adapt_data(data.samples, first),
            adapt=params.adapt,
            seed=seed,
            min_speed_m_s=params.label.calibration_min_speed_m_s,
            evidence=shrink_ev,
            source_radii=base_meta.source_radii,
            prior_radii=prior,
        )
        fit_s = time.perf_counter() - fit_start
        scored = data.samples.take(rest)
        label = scored.frame[contracts.LABEL_M].to_numpy(np.float64)
        errors = {
            "WPM": label,
            "base": label - predict(net, scored.x, seq_len=hparams["seq_len"]).astype(np.float64),
            "R": label
            - label_prediction(
                result, adapt_data(scored, np.ones(len(scored), bool)), base_meta.source_radii
            ),
        }
        scores = score(errors, scored, params.evaluate.outages_s)

        name = registered_name("R", vehicle)
        digest = drive_sha256(Path(drive))  # a file's bytes, or a folder drive's files
        base_label = (
            f"{base_version.name} v{base_version.version}"
            if base_version is not None
            else str(base)
        )
        tags = {
            "model": "R",
            "vehicle": vehicle,
            "recipe": choice.recipe,
            "m": choice.m,
            "seed": seed,
            "base_model": base,
            "base_version": base_label,
            "drive": Path(drive).name if drive_id is None else shown(Path(drive).name, drive_id),
            "drive_sha256": digest,
            "source": "rwhonet recalibrate",
            "n_adapt_seconds": int(first.sum()),
        }
        # written in the registry's pickle-free form: nothing here is read back with torch.load
        model_file = Path(tmp) / SAFETENSORS_FILE
        save_whonet(result.net, result.hparams, model_file, wpm_radii=result.radii)
        meta = make_meta(
            hparams,
            base_meta.scaler,
            {"r_rl_m": base_meta.source_radii[0], "r_rr_m": base_meta.source_radii[1]},
            base_meta.wpm_mode,
            result.radii,
            {"name": name, **tags},
            base_meta.evidence,
            inherited_navigation(base_meta.navigation, vehicle, base_label),
        )
        bundle = write_bundle(model_file, meta, Path(tmp) / "bundle")
        run_id, version = _log(
            params, tracking_uri, name, bundle, scored, tags, choice, scores, result
        )
    return {
        "name": name,
        "version": version,
        "run_id": run_id,
        "choice": choice,
        "base": base_label,
        "file": data.file,
        "kept": data.kept_summary(),
        "drive_notes": list(data.notes),
        "n_adapt": int(first.sum()),
        "n_scored": int(rest.sum()),
        "scores": scores,
        "radii": result.radii,
        "certainty": certainty(result, base_meta.source_radii, shrink_ev),
        "prior_radii": prior,
        "fit_s": fit_s,
        "seconds": time.perf_counter() - start,
        "digest": digest,
        "seed": seed,
    }


def inherited_navigation(navigation: dict | None, vehicle: str, base: str) -> dict | None:
    """The base model's navigation calibration, for a model of the car it was measured on.

    The evaluation measured the filter (its receiver drift, its 2D calibration) on the
    target car with the base model's distances; on that car the recalibrated model
    keeps it (the filter learns the distance's scale from GNSS before an outage,
    and the position error is the heading's: docs/positioning.md). Another car's
    receiver and driving have not been measured: None, the generic filter.
    """
    if not navigation or navigation.get("vehicle") != vehicle:
        return None
    return {**navigation, "from": f"{base}'s: {navigation.get('from', 'evaluate')}"}


def car_nominal_m(params: Params, vehicle: str) -> float | None:
    """The car's nominal tyre radius as params know it (None: a car they do not name)."""
    from rwhonet.config import ConfigError

    try:
        return params.nominal_radius_m(vehicle)
    except ConfigError:
        return None


def prior_radii_of(
    evidence: Any,
    source_radii: tuple[float, float],
    car_nominal: float | None,
    source_nominal: float | None,
) -> tuple[float, float] | None:
    """Where ``shrink``'s prior is centred for a car, when not on G's radii (None).

    With evidence from the source car's drives (a car the pipeline has no drives of)
    and a nominal radius for the car that is not the source car's, the prior is the
    source calibration scaled by the two nominal radii: the car's size, with the
    source car's calibrated-to-nominal ratio. The target car's own evidence measures
    its offset from G already (τ), so there the prior stays on G.
    """
    if evidence is None or evidence.role == contracts.TARGET_TRAIN:
        return None
    if car_nominal is None or source_nominal is None or car_nominal == source_nominal:
        return None
    ratio = car_nominal / source_nominal
    return (source_radii[0] * ratio, source_radii[1] * ratio)


def shrink_evidence_of(
    carried: dict[str, Any] | None, which: str | None, base: str, *, new_car: bool = False
) -> Any:
    """The shrink recipe's evidence from a base model's metadata.

    Args:
        carried: :attr:`rwhonet.serve.model.ServedMeta.evidence`.
        which: ``target`` (the pipeline's target car's training drives), ``source``
            (the source car's, for a car the pipeline has no drives of), or None: for the
            pipeline's target car its own when carried, else the source car's; for any
            other car (``new_car``) the source car's when carried, else the target's.
        base: the base model as the user named it (for messages).
        new_car: the car is not the pipeline's target car.

    Raises:
        InputError: the model carries no such evidence.
    """
    from rwhonet.models.adapt import ShrinkEvidence

    carried = carried or {}
    order = [which] if which else (["source", "target"] if new_car else ["target", "source"])
    for key in order:
        if carried.get(key) is not None:
            return ShrinkEvidence.from_dict(carried[key], f"{base} (evidence.{key})")
    raise InputError(
        [
            Problem(
                base,
                None,
                "evidence" + (f".{which}" if which else ""),
                "the shrink recipe's evidence (registered by a pipeline run with shrink in "
                "adapt.recipes)",
                "none" if not carried else f"only {sorted(k for k, v in carried.items() if v)}",
                "use a model the pipeline registered after `dvc repro`, or choose another "
                "recipe with --recipe",
            )
        ],
        "the base model carries no evidence to size the shrink recipe by",
    )


def certainty(result: Any, source_radii: tuple[float, float], evidence: Any) -> dict | None:
    """How sure a ``shrink`` recalibration is (None for other recipes, or no refit).

    Returns:
        ``{"radius_m", "low_m", "high_m", "kept", "fit_sd", "prior_sd", "role", "n_drives"}``:
        the mean rear radius, its 95 % interval (posterior sd of the relative radius
        change around it), the share of the refit kept (w), the sd of the refit from the
        m seconds alone (√V / D) and the prior's, relative; what the evidence was
        measured on.
    """
    info = result.info
    if evidence is None or "shrink_weight" not in info:
        return None
    radii = result.radii if result.radii is not None else source_radii
    mean = 0.5 * (radii[0] + radii[1])
    base = 0.5 * (source_radii[0] + source_radii[1])
    half = Z95 * info["posterior_sd"] * base
    return {
        "radius_m": mean,
        "low_m": mean - half,
        "high_m": mean + half,
        "kept": info["shrink_weight"],
        "fit_sd": info["fit_sd"],
        "prior_sd": info["prior_sd"],
        "role": evidence.role,
        "n_drives": len(evidence.drives),
    }


def score(errors: dict[str, np.ndarray], scored: Any, outages_s: list[int]) -> list[dict]:
    """Mean CRSE and CTE per model and outage length over the scored seconds' windows."""
    from rwhonet.evaluation.scoring import summarise, window_metrics

    disp = scored.frame[contracts.DISP_GNSS_M].to_numpy(np.float64)
    group = scored.frame["group"].to_numpy()
    rows = []
    for L in outages_s:
        for model, e in errors.items():
            s = summarise(window_metrics(e, disp, group, L, source=model))
            rows.append(
                {
                    "model": model,
                    "outage_s": L,
                    "n_windows": s["n_windows"],
                    "crse_m": s["crse_m_mean"],
                    "cte_m": s["cte_m_mean"],
                }
            )
    return rows


def _log(params, uri, name, bundle, scored, tags, choice, scores, result) -> tuple[str, str]:
    """One MLflow run for the recalibration, its model registered as a new version."""
    from rwhonet.tracking.client import git_commit, open_store, retrying
    from rwhonet.tracking.registry import input_example, log_bundle

    client, exp_id = open_store(uri, params.tracking.experiment)
    run_tags = {str(k): str(v) for k, v in tags.items()}
    run_tags["git_commit"] = git_commit()
    run = retrying(
        lambda: client.create_run(
            exp_id,
            run_name=f"R-WhONet {choice.recipe} m={choice.m} {tags['drive']} (recalibrate)",
            tags=run_tags,
        )
    )
    rid = run.info.run_id
    try:
        from mlflow.entities import Metric, Param

        now = int(time.time() * 1000)
        metrics = [
            Metric(
                f"{'R' if r['model'] == 'R' else r['model']}/{q}/{r['outage_s']}s/mean",
                float(r[f"{q}_m"]),
                now,
                0,
            )
            for r in scores
            for q in ("crse", "cte")
            if r[f"{q}_m"] is not None
        ]
        metrics.append(Metric("fit_seconds", result.seconds, now, 0))
        prm = {
            **flatten(params.section("adapt"), "adapt."),
            "adapt.recipe": choice.recipe,
            "adapt.m": choice.m,
        }
        retrying(
            lambda: client.log_batch(
                rid, metrics=metrics, params=[Param(k, str(v)[:6000]) for k, v in prm.items()][:100]
            )
        )
        version = log_bundle(
            client,
            rid,
            name,
            bundle,
            input_example(_features_frame(scored)),
            run_tags,
            description=f"recalibrated by `rwhonet recalibrate` on {tags['drive']} "
            f"(sha256 {tags['drive_sha256'][:12]}...)",
        )
    except BaseException:
        retrying(lambda: client.set_terminated(rid, "FAILED"))
        raise
    retrying(lambda: client.set_terminated(rid))
    return rid, version


def _features_frame(samples: Any) -> Any:
    """Samples as the pyfunc input: the last step's 40 features and the rear wheel angles."""
    import pandas as pd

    frame = pd.DataFrame(samples.x[:, -1, :], columns=list(contracts.FEATURE_COLUMNS))
    for col in (contracts.ANGLE_RL_RAD, contracts.ANGLE_RR_RAD):
        frame[col] = samples.frame[col].to_numpy(np.float64)
    return frame


def render(out: dict[str, Any]) -> str:
    """What ``rwhonet recalibrate`` prints."""
    c = out["choice"]
    moved = "shrunk to" if c.recipe == contracts.SHRINK else "refitted to"
    radii = (
        ""
        if out["radii"] is None
        else f"; rear radii {moved} {out['radii'][0]:.5f} / {out['radii'][1]:.5f} m"
    )
    lines = [
        f"{out['file']}: {out['kept']}",
        *out.get("drive_notes", []),
        f"recalibrated {out['base']} by `{c.recipe}` ({c.why}) on the first {out['n_adapt']} s, "
        f"seed {out['seed']}, in {out['fit_s']:.2f} s{radii}",
    ]
    sure = out.get("certainty")
    prior = out.get("prior_radii")
    if prior is not None:
        lines.append(
            f"  prior centred on {prior[0]:.5f} / {prior[1]:.5f} m: the source calibration "
            "scaled by the car's nominal tyre radius over the source car's"
        )
    if sure is None and c.recipe == contracts.SHRINK:
        lines.append(f"  no second of the {out['n_adapt']} moved fast enough: the base model kept")
    if sure is not None:
        lines.append(
            f"  mean rear radius {sure['radius_m']:.5f} m (95 % interval {sure['low_m']:.5f}-"
            f"{sure['high_m']:.5f} m); the {out['n_adapt']} s alone fix it to "
            f"±{100 * sure['fit_sd']:.2f} % (1 sd), the prior to ±{100 * sure['prior_sd']:.2f} %, "
            f"so {100 * sure['kept']:.0f} % of the refit is kept and "
            f"{100 * (1 - sure['kept']):.0f} % shrunk towards "
            f"{'the prior' if prior is not None else 'the base model'} "
            f"(evidence: {sure['n_drives']} drives, {sure['role']})"
        )
    lines += [
        f"registered {out['name']} version {out['version']} (run {out['run_id']})",
        f"scored on the remaining {out['n_scored']} s (mean over outage windows, metres):",
        f"  {'outage':>7} {'windows':>7}  {'WPM CRSE/CTE':>15}  {'base CRSE/CTE':>15}  "
        f"{'R CRSE/CTE':>15}",
    ]
    by = {(r["model"], r["outage_s"]): r for r in out["scores"]}

    def cell(model: str, L: int) -> str:
        r = by[(model, L)]
        if r["crse_m"] is None:
            return f"{'-':>15}"
        return f"{r['crse_m']:>7.2f}/{r['cte_m']:<7.2f}"

    for L in sorted({r["outage_s"] for r in out["scores"]}):
        n = by[("R", L)]["n_windows"]
        lines.append(f"  {L:>6}s {n:>7}  {cell('WPM', L)}  {cell('base', L)}  {cell('R', L)}")
    lines.append(
        f"done in {out['seconds']:.1f} s; use it: rwhonet predict --model "
        f"models:/{out['name']}/{out['version']} --drive <drive.csv>"
    )
    return "\n".join(lines)
