"""The MLflow Model Registry: G, S and R as registered ``pyfunc`` models, by name and version.

Names (:func:`registered_name`): ``whonet-G`` (trained on the source car),
``whonet-S`` (trained on the target car), ``whonet-R-<vehicle>`` (G recalibrated
on one car: the pipeline's chosen R-WhONet and every ``rwhonet recalibrate``).
Each version is a model bundle (:mod:`rwhonet.serve.bundle`:
``model.safetensors``, ``model.onnx``, ``rwhonet.json``) logged as an MLflow ``pyfunc`` model with a
signature and an input example (:mod:`rwhonet.serve.pyfunc`), so
:func:`load_pyfunc` (``mlflow.pyfunc.load_model`` once the files are checked)
predicts the label from the feature window, and ``rwhonet predict --model
models:/...`` runs its ONNX graph.

A version carries no code to run and no pickle: its ``pyfunc`` is a model from
code (:data:`rwhonet.serve.pyfunc.MODEL_CODE` names the installed package's
class), and the SHA-256 of each of its files is a version tag
(:data:`FILES_TAG`), written in the same call that creates the version.
:func:`fetch_model`, which ``rwhonet predict``, ``export`` and ``recalibrate
--base`` load every registered model through, downloads the version's files
and refuses them (:class:`~rwhonet.errors.InputError`, exit status 2) unless
they are exactly the recorded ones; only then is anything in them read. The
weights travel as ``model.safetensors`` (converted from the pipeline's
``model.pt`` at registration, :func:`rwhonet.models.checkpoint.to_safetensors`),
which ``export`` and ``recalibrate --base`` read without ``torch.load``; a
version registered with a ``model.pt`` by an older rwhonet is refused by them
(:func:`rwhonet.serve.bundle.bundle_parts`), never unpickled.

A pipeline execution registers one version per model (:func:`register_execution`,
called by :func:`rwhonet.tracking.store.log_execution`): the first training
seed's G and S, and R-WhONet's chosen recipe and m (the run tagged
``chosen=true``) of the first seed, for the first of its target test drives (R
is recalibrated per drive). Version tags say which.
"""

from __future__ import annotations

import json
import logging
import os
import tempfile
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet import contracts as k
from rwhonet import paths
from rwhonet.errors import InputError, Problem
from rwhonet.io import scratch_dir, scratch_prefix
from rwhonet.serve.bundle import sha256_file  # noqa: F401 - the drive's digest (recalibrate)
from rwhonet.tracking.client import retrying
from rwhonet.tracking.credentials import access_error

MODEL_PATH = "model"  # the artifact folder of a registered model in its run
PIP_REQUIREMENTS = ["onnxruntime==1.30.0", "numpy==2.4.6", "pandas==3.1.1"]
EXAMPLE_ROWS = 5
FILES_TAG = "rwhonet.files_sha256"  # version tag: {path in the model folder: SHA-256}
MLFLOW_NOTE = "registered_model_meta"  # what MLflow adds to a model folder it downloads


def registered_name(model: str, vehicle: str | None = None) -> str:
    """``whonet-G``, ``whonet-S`` or ``whonet-R-<vehicle>``."""
    if model == "R":
        return f"whonet-R-{vehicle or 'target'}"
    return f"whonet-{model}"


def input_example(frame: Any, n: int = EXAMPLE_ROWS) -> Any:
    """The first ``n`` rows of a samples frame as a pyfunc input (features and angles)."""
    cols = [*k.FEATURE_COLUMNS, k.ANGLE_RL_RAD, k.ANGLE_RR_RAD]
    example = frame[cols].head(n).reset_index(drop=True)
    return example.astype({c: np.float32 for c in k.FEATURE_COLUMNS})


def log_bundle(
    client: Any,
    run_id: str,
    name: str,
    bundle: Mapping[str, Path],
    example: Any,
    tags: Mapping[str, Any],
    description: str | None = None,
) -> str:
    """Log a bundle as a ``pyfunc`` model from code into a run; register it as a new version.

    The model folder is MLflow's ``pyfunc`` layout: ``MLmodel``, the environment
    files, the input example, the code file (:data:`rwhonet.serve.pyfunc.MODEL_CODE`)
    and ``artifacts/`` (the bundle). Its files' SHA-256 go into the version's tag
    :data:`FILES_TAG` as the version is created.

    Args:
        client: an ``MlflowClient`` of the store.
        run_id: the run the model belongs to (its artifacts get ``model/``).
        name: the registered model's name (created when missing, where the user may).
        bundle: :func:`rwhonet.serve.bundle.write_bundle`'s artifacts.
        example: the input example (a DataFrame, :func:`input_example`).
        tags: version tags (stringified).
        description: the version's description.

    Returns:
        The new version number, as a string.

    Raises:
        InputError: the server refused the login or the registration (docs/team.md).
    """
    import mlflow.pyfunc

    from rwhonet.serve.bundle import digests_to_text, file_digests
    from rwhonet.serve.model import ServedModel
    from rwhonet.serve.pyfunc import MODEL_CODE, signature

    meta = ServedModel(bundle["model_onnx"]).meta
    with scratch_dir("model") as tmp, _quiet_mlflow():
        local = Path(tmp) / MODEL_PATH
        mlflow.pyfunc.save_model(
            local,
            python_model=str(MODEL_CODE),  # a model from code: nothing is pickled
            artifacts={key: str(p) for key, p in bundle.items()},
            signature=signature(meta),
            input_example=example,
            pip_requirements=PIP_REQUIREMENTS,
            metadata={"rwhonet": json.loads(meta.to_json())},
        )
        digests = file_digests(local)
        pickled = [f for f in digests if f.endswith((".pkl", ".pt"))]
        if pickled:  # what stays true of every registered version: no file in pickle's format
            raise RuntimeError(f"a pickle in the model: {pickled}")
        retrying(lambda: client.log_artifacts(run_id, str(local), MODEL_PATH))
    _ensure_registered_model(client, name)
    run = retrying(lambda: client.get_run(run_id))
    version_tags = {str(key): str(v) for key, v in tags.items() if v is not None}
    version_tags[FILES_TAG] = digests_to_text(digests)
    with _quiet_mlflow():  # a server's registry says it waits for each version to be READY
        version = retrying(
            lambda: client.create_model_version(
                name,
                source=f"{run.info.artifact_uri}/{MODEL_PATH}",
                run_id=run_id,
                tags=version_tags,
                description=description,
            )
        )
    return str(version.version)


def _ensure_registered_model(client: Any, name: str) -> None:
    """Create the registered model ``name`` unless it exists.

    On a team server only the admin creates registered models (docs/team.md);
    an editor registers versions of the ones the admin set up for the team, and
    a server that hides ``name`` from the user (403) or lacks it and refuses to
    create it is an :class:`~rwhonet.errors.InputError` that names the command
    to give the admin.

    Raises:
        InputError: as above.
    """
    from mlflow.exceptions import MlflowException

    try:
        try:
            retrying(lambda: client.get_registered_model(name))
            return
        except MlflowException as err:
            if err.error_code != "RESOURCE_DOES_NOT_EXIST":
                raise
        try:
            retrying(lambda: client.create_registered_model(name))
        except MlflowException as err:
            if err.error_code != "RESOURCE_ALREADY_EXISTS":  # created meanwhile by another writer
                raise
    except InputError as refused:
        if not any(p.found.startswith("403") for p in refused.problems):
            raise
        raise InputError(
            [
                Problem(
                    name,
                    None,
                    None,
                    "a registered model the user may add versions to",
                    "not registered on the server for this user, and this user may not create it",
                    "the server's admin creates it and grants EDIT on it: "
                    f"python -m rwhonet.tracking team setup {name} (docs/team.md)",
                ),
                *refused.problems,
            ],
            f"cannot register a version of {name}",
        ) from None


@contextmanager
def _quiet_mlflow() -> Iterator[None]:
    """Hide MLflow's notes on saving and registering a model (pickling advice, progress...)."""
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
    names = ("mlflow.pyfunc", "mlflow.models", "mlflow.utils", "mlflow.store.model_registry")
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            # MLflow 3.17 checks an example's columns in a way pandas 3 deprecates.
            warnings.filterwarnings("ignore", message="Operation with range is deprecated")
            yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def resolve_model(spec: str, tracking_uri: str, dest: Path | None = None) -> Path:
    """A local folder or file for a model given as a registry URI or a path.

    A registry URI is fetched and verified (:func:`fetch_model`).

    Args:
        spec: ``models:/<name>/<version|latest>``, ``models:/<name>@<alias>``,
            ``runs:/<run>/<path>`` of a registered version, or a local path.
        tracking_uri: the store to resolve registry URIs in.
        dest: where to download (when None, a temporary folder named with this process's
            id, which :func:`rwhonet.io.remove_stale_scratch` removes once it has ended).

    Returns:
        The local path (``spec`` itself when it is not a URI).

    Raises:
        InputError: no such model or version, or its files are not the registered ones.
    """
    return fetch_model(spec, tracking_uri, dest)[0]


def fetch_model(spec: str, tracking_uri: str, dest: Path | None = None) -> tuple[Path, Any]:
    """Download a registered version and check its files against its :data:`FILES_TAG`.

    The version is pinned first (``latest`` and aliases resolve to a number), so
    the files downloaded, the record they are checked against and the version
    reported are one and the same. Nothing in the files is read before the check.

    Args:
        spec: as for :func:`resolve_model`.
        tracking_uri: the store.
        dest: where to download (when None, a temporary folder named with this process's
            id, which :func:`rwhonet.io.remove_stale_scratch` removes once it has ended).

    Returns:
        ``(local folder, ModelVersion)``; ``(Path(spec), None)`` for a local path.

    Raises:
        InputError: the registry has no such version; the server refused the
            credentials; the version's files are not the ones recorded, or no record.
    """
    if not spec.startswith(("models:/", "runs:/")):
        return Path(spec), None
    import mlflow
    from mlflow import MlflowClient
    from mlflow.exceptions import MlflowException

    from rwhonet.serve.bundle import digests_from_text, verify_digests

    mlflow.set_tracking_uri(tracking_uri)
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
    try:
        version = model_version(spec, tracking_uri)
        if version is None:
            raise _unknown(spec, tracking_uri, "no registered version")
        # The version's own folder, not models:/..., to which MLflow's download adds a
        # file of its own (registered_model_meta): the files checked are the files stored.
        source = retrying(
            lambda: MlflowClient(tracking_uri).get_model_version_download_uri(
                version.name, version.version
            )
        )
        local = Path(
            retrying(
                lambda: mlflow.artifacts.download_artifacts(
                    artifact_uri=source,
                    dst_path=str(dest or tempfile.mkdtemp(prefix=scratch_prefix("model"))),
                )
            )
        )
    except (MlflowException, OSError) as err:
        refused = access_error(err)
        if refused is not None:
            raise refused from None
        if not isinstance(err, MlflowException):
            raise
        raise _unknown(
            spec,
            tracking_uri,
            str(err.message if hasattr(err, "message") else err).split("\n")[0][:200],
        ) from None
    # MLflow's client writes a note (name and version, YAML) into a model folder it fetches
    # by models:/... -- in a local store into the stored folder itself. It is no part of the
    # model, nothing here reads it, and it is not in the record: it goes before the check.
    (local / MLFLOW_NOTE).unlink(missing_ok=True)
    label = version_label(version)
    record = (version.tags or {}).get(FILES_TAG)
    if not record:
        raise InputError(
            [
                Problem(
                    label,
                    None,
                    None,
                    f"the SHA-256 of its files in the version tag {FILES_TAG}",
                    "no such tag (registered before files were hashed, or not by rwhonet)",
                    "its files cannot be checked, so they are not used: register the model "
                    "again (dvc repro -f evaluate, or rwhonet recalibrate)",
                )
            ],
            f"{label} cannot be verified",
        )
    verify_digests(local, digests_from_text(record, f"{label} ({FILES_TAG})"), label)
    return local, version


def version_label(version: Any) -> str:
    """How a registered version is named in reports: ``whonet-G version 3``."""
    return f"{version.name} version {version.version}"


def _unknown(spec: str, tracking_uri: str, found: str) -> InputError:
    names = _registered_names(tracking_uri)
    return InputError(
        [
            Problem(
                spec,
                None,
                None,
                "a model in the MLflow registry",
                found,
                "registered models in "
                + tracking_uri
                + ": "
                + (", ".join(names) or "none")
                + " (the pipeline registers whonet-G, whonet-S and whonet-R-<vehicle>; "
                "run `make run` or `dvc repro` first)",
            )
        ],
        f"cannot resolve {spec}",
    )


def model_version(spec: str, tracking_uri: str) -> Any | None:
    """The registry's ``ModelVersion`` a registry URI names, or None.

    ``models:/<name>/<version>``, ``models:/<name>/latest`` (the highest number),
    ``models:/<name>@<alias>``, or ``runs:/<run>/<path>`` when a version was
    registered from that run's folder. None: ``spec`` is no registry URI, or no
    version matches.
    """
    from mlflow import MlflowClient
    from mlflow.exceptions import MlflowException

    client = MlflowClient(tracking_uri)
    if spec.startswith("runs:/"):
        run_id, _, path = spec.removeprefix("runs:/").strip("/").partition("/")
        versions = retrying(lambda: client.search_model_versions(f"run_id = '{run_id}'"))
        path = path.strip("/") or MODEL_PATH
        found = [v for v in versions if str(v.source).rstrip("/").endswith("/" + path)]
        return max(found, key=lambda v: int(v.version)) if found else None
    if not spec.startswith("models:/"):
        return None
    rest = spec.removeprefix("models:/").strip("/")
    try:
        if "@" in rest:
            name, _, alias = rest.partition("@")
            return retrying(lambda: client.get_model_version_by_alias(name, alias))
        name, _, version = rest.partition("/")
        if version in ("", "latest"):
            versions = retrying(lambda: client.search_model_versions(f"name = '{name}'"))
            return max(versions, key=lambda v: int(v.version)) if versions else None
        return retrying(lambda: client.get_model_version(name, version))
    except MlflowException as err:
        if err.error_code in ("RESOURCE_DOES_NOT_EXIST", "INVALID_PARAMETER_VALUE"):
            return None
        raise


def load_pyfunc(spec: str, tracking_uri: str, dest: Path | None = None) -> Any:
    """``mlflow.pyfunc.load_model`` of a registered version, once its files are verified.

    MLflow runs the version's code file to load it; :func:`fetch_model` has
    checked that file (and every other) against the registered SHA-256 first,
    and MLflow is told to refuse any pickle while it loads.
    """
    import mlflow.pyfunc

    local, _ = fetch_model(spec, tracking_uri, dest)
    key = "MLFLOW_ALLOW_PICKLE_DESERIALIZATION"
    before = os.environ.get(key)
    os.environ[key] = "false"
    try:
        return mlflow.pyfunc.load_model(str(local))
    finally:
        if before is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = before


def _registered_names(tracking_uri: str) -> list[str]:
    from mlflow import MlflowClient

    try:
        return sorted(m.name for m in MlflowClient(tracking_uri).search_registered_models())
    except Exception:  # noqa: BLE001 - only for the message
        return []


# --------------------------------------------------------------------------- pipeline


def chosen_records(records: Sequence[Any]) -> dict[str, Any]:
    """The runs of an execution whose models are registered: ``{"G": rec, "S": rec, "R": rec}``.

    The first G and S record (the first training seed: records come seed by seed)
    and the first R record tagged ``chosen=true``; each only when it carries a model
    file (``.pt``) that exists.
    """
    out: dict[str, Any] = {}
    for rec in records:
        model = rec.tags.get("model")
        if model in out or model not in ("G", "S", "R"):
            continue
        if model == "R" and rec.tags.get("chosen") != "true":
            continue
        if _model_files(rec):
            out[model] = rec
    return out


def _model_files(rec: Any) -> list[Path]:
    files = [paths.resolve(a) for a in rec.artifacts if str(a).endswith(".pt")]
    return sorted(f for f in files if f.is_file())


def register_execution(
    client: Any,
    logged: Sequence[tuple[Any, str]],
    *,
    common_tags: Mapping[str, str],
    scaler_path: Path | None = None,
    calibration_path: Path | None = None,
    samples_dir: Path | None = None,
    models_root: Path | None = None,
    eval_path: Path | None = None,
) -> list[dict[str, str]]:
    """Register G, S and the chosen R of one pipeline execution (one version each).

    Args:
        client: an ``MlflowClient`` of the store.
        logged: ``(record, run_id)`` of every run the execution logged, in order.
        common_tags: tags every version gets (the execution id, the git commit).
        scaler_path: the label stage's ``scaler.json`` (default: the project's).
        calibration_path: its ``calibration.json``.
        samples_dir: its samples folder (the input examples).
        models_root: its ``models`` folder: each model carries the shrink recipe's evidence
            its seed's adapt stage measured (``r/seed<seed>/evidence.json``), if any.
        eval_path: its ``eval.json`` (default: the project's): each model carries what
            the evaluation measured of the navigation filter with it
            (:func:`navigation_meta`), if the file is there.

    Returns:
        One ``{"name", "version", "run_id", "model_file"}`` per registered model;
        empty when the execution has no model files (or no scaler and calibration).
    """
    from rwhonet.features.scaling import scaler_from_dict
    from rwhonet.io import read_json
    from rwhonet.serve.bundle import make_meta, write_bundle

    scaler_path = Path(scaler_path or paths.SCALER)
    calibration_path = Path(calibration_path or paths.CALIBRATION)
    samples_dir = Path(samples_dir or paths.SAMPLES)
    models_root = Path(models_root or paths.MODELS)
    picked = chosen_records([rec for rec, _ in logged])
    if not picked or not (scaler_path.is_file() and calibration_path.is_file()):
        return []
    run_of = {id(rec): rid for rec, rid in logged}
    scaler = read_json(scaler_path)
    scaler_from_dict(scaler, paths.rel(scaler_path))
    calibration = read_json(calibration_path)
    example = _example_frame(samples_dir)
    eval_path = Path(eval_path or paths.EVAL_JSON)
    evaluated = read_json(eval_path) if eval_path.is_file() else {}
    target_car = picked["R"].tags.get("vehicle") if "R" in picked else None  # where 2D ran
    out = []
    for model, rec in picked.items():
        model_file = _model_files(rec)[0]
        tags = {
            **common_tags,
            **{
                key: rec.tags[key]
                for key in ("model", "vehicle", "seed", "recipe", "m", "chosen", "dvc_stage")
                if key in rec.tags
            },
        }
        tags["source"] = "pipeline"
        tags["seed_note"] = f"the first training seed's model ({rec.tags.get('seed')})"
        if model == "R":
            tags["drive"] = model_file.stem
            tags["base_model"] = registered_name("G")
        name = registered_name(model, rec.tags.get("vehicle"))
        # the shrink recipe's evidence, measured on this seed's G by its adapt stage
        evidence = models_root / "r" / f"seed{rec.tags.get('seed')}" / k.SHRINK_EVIDENCE
        meta = make_meta(
            {},
            scaler,
            calibration,
            str(rec.params.get("label.wpm_mode", "integrated")),
            None,
            {"name": name, **{key: v for key, v in tags.items() if key != "seed_note"}},
            read_json(evidence) if "seed" in rec.tags and evidence.is_file() else None,
            navigation_meta(evaluated, model, target_car),
        )
        with scratch_dir("bundle") as tmp:
            bundle = write_bundle(model_file, meta, Path(tmp))
            version = log_bundle(
                client,
                run_of[id(rec)],
                name,
                bundle,
                input_example(example),
                tags,
                description=f"{rec.name}: {paths.rel(model_file)}",
            )
        out.append(
            {
                "name": name,
                "version": version,
                "run_id": run_of[id(rec)],
                "model_file": paths.rel(model_file),
            }
        )
    return out


def navigation_meta(evaluated: dict, model: str, vehicle: str | None = None) -> dict | None:
    """What an evaluation measured of the navigation filter with one model, for its bundle.

    From ``eval.json``: the receiver drift the filter used (``position_controls.receiver``,
    fitted on the target training drives or as configured) and the model's 2D
    calibration (``position.<model>.<L>s``: ``calib_scale`` and ``calib_dof`` per
    outage length, null ``ν`` a normal; means over the evaluation's seeds, as eval.json
    keeps them), the antenna, the gyro's latency and bias instability as fitted, and the
    factor ``γ_L`` by which the model's per-second distance variance grows inside an
    outage of ``L`` s (``uncertainty.models.<model>.outage_scale``: its errors last).
    None without a position block for the model.

    Args:
        evaluated: the parsed eval.json (empty: none).
        model: ``G``, ``S`` or ``R`` (eval.json's names).
        vehicle: the car the evaluation's filter ran on (the target car: ``vehicle``
            in the result; ``rwhonet recalibrate`` hands it on to a model of that car).
    """
    cells = (evaluated.get("position") or {}).get(model)
    if not cells:
        return None
    receiver = (evaluated.get("position_controls") or {}).get("receiver") or {}
    geometry = (evaluated.get("position_controls") or {}).get("geometry") or {}
    gyro = (evaluated.get("position_controls") or {}).get("gyro") or {}
    lasting = ((evaluated.get("uncertainty") or {}).get("models") or {}).get(model) or {}
    scales = {
        str(int(L.removesuffix("s"))): float(c["calib_scale"])
        for L, c in cells.items()
        if isinstance(c, dict) and c.get("calib_scale") is not None
    }
    dofs = {
        str(int(L.removesuffix("s"))): None if c.get("calib_dof") is None else float(c["calib_dof"])
        for L, c in cells.items()
        if isinstance(c, dict) and c.get("calib_scale") is not None
    }
    return {
        "vehicle": vehicle,
        "receiver_sigma_m": receiver.get("sigma_m"),
        "receiver_tau_s": receiver.get("tau_s"),
        "antenna_m": geometry.get("antenna_m"),
        "gyro_latency_s": geometry.get("gyro_latency_s"),
        "gyro_instability_deg_s": gyro.get("instability_deg_s"),
        "calibration": {"scales": scales, "dofs": dofs},
        # the distance variance's factor inside an outage (evaluate's gamma_L), per length
        "outage_scale": {
            str(int(L.removesuffix("s"))): float(g)
            for L, g in (lasting.get("outage_scale") or {}).items()
        },
        "from": (
            "evaluate: the filter on the target training drives' windows (receiver drift "
            f"{'fitted' if receiver.get('fitted') else 'as configured'}, antenna and gyro "
            f"latency {'fitted' if geometry.get('fitted') else 'as configured'}, gyro bias "
            f"instability {'fitted' if gyro.get('fitted') else 'as configured'}; the calibration's "
            f"means over seeds {evaluated.get('seeds')})"
        ),
    }


def _example_frame(samples_dir: Path) -> Any:
    """A few seconds of the first target test segment (features and angles)."""
    import pandas as pd

    manifest = Path(samples_dir) / k.MANIFEST
    if manifest.is_file():
        from rwhonet.io import read_json

        entries = read_json(manifest).get("segments", [])
        entries = sorted(entries, key=lambda e: (e.get("role") != k.TARGET_TEST, e["segment"]))
        for entry in entries:
            f = Path(samples_dir) / f"{entry['segment']}.parquet"
            if f.is_file():
                frame = pd.read_parquet(f)
                if len(frame):
                    return frame
    zeros = {c: np.full(EXAMPLE_ROWS, 0.5, np.float32) for c in k.FEATURE_COLUMNS}
    return pd.DataFrame(
        {
            **zeros,
            k.ANGLE_RL_RAD: np.full(EXAMPLE_ROWS, 30.0),
            k.ANGLE_RR_RAD: np.full(EXAMPLE_ROWS, 30.0),
        }
    )
