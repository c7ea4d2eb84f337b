"""The MLflow Model Registry: G, S and R as registered ``pyfunc`` models, by name and version.

Names (:func:`registered_name`): ``whonet-G`` (trained on the source car),
``whonet-S`` (trained on the target car), ``whonet-R-<vehicle>`` (G recalibrated
on one car: the pipeline's chosen R-WhONet and every ``rwhonet recalibrate``).
Each version is a model bundle (:mod:`rwhonet.serve.bundle`: ``model.pt``,
``model.onnx``, ``rwhonet.json``) logged as an MLflow ``pyfunc`` model with a
signature and an input example (:mod:`rwhonet.serve.pyfunc`), so
``mlflow.pyfunc.load_model("models:/whonet-G/latest")`` predicts the label from
the feature window, and ``rwhonet predict --model models:/...`` runs its ONNX
graph.

A pipeline execution registers one version per model (:func:`register_execution`,
called by :func:`rwhonet.tracking.store.log_execution`): the first training
seed's G and S, and R-WhONet's chosen recipe and m (the run tagged
``chosen=true``) of the first seed, for the first of its target test drives (R
is recalibrated per drive). Version tags say which.
"""

from __future__ import annotations

import hashlib
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
from rwhonet.tracking.client import retrying

MODEL_PATH = "model"  # the artifact folder of a registered model in its run
PIP_REQUIREMENTS = ["onnxruntime==1.30.0", "numpy==2.4.6", "pandas==3.1.1"]
EXAMPLE_ROWS = 5


def registered_name(model: str, vehicle: str | None = None) -> str:
    """``whonet-G``, ``whonet-S`` or ``whonet-R-<vehicle>``."""
    if model == "R":
        return f"whonet-R-{vehicle or 'target'}"
    return f"whonet-{model}"


def sha256_file(path: Path) -> str:
    """The SHA-256 of a file (the drive a model was recalibrated on)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


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
    """Log a bundle as a ``pyfunc`` model into a run and register it as a new version.

    Args:
        client: an ``MlflowClient`` of the store.
        run_id: the run the model belongs to (its artifacts get ``model/``).
        name: the registered model's name (created when missing).
        bundle: :func:`rwhonet.serve.bundle.write_bundle`'s artifacts.
        example: the input example (a DataFrame, :func:`input_example`).
        tags: version tags (stringified).
        description: the version's description.

    Returns:
        The new version number, as a string.
    """
    import mlflow.pyfunc
    from mlflow.exceptions import MlflowException

    from rwhonet.serve.model import ServedModel
    from rwhonet.serve.pyfunc import WhONetPyfunc, signature

    meta = ServedModel(bundle["model_onnx"]).meta
    with tempfile.TemporaryDirectory(prefix="rwhonet-model-") as tmp, _quiet_mlflow():
        local = Path(tmp) / MODEL_PATH
        mlflow.pyfunc.save_model(
            local,
            python_model=WhONetPyfunc(),
            artifacts={key: str(p) for key, p in bundle.items()},
            signature=signature(meta),
            input_example=example,
            pip_requirements=PIP_REQUIREMENTS,
            metadata={"rwhonet": json.loads(meta.to_json())},
        )
        retrying(lambda: client.log_artifacts(run_id, str(local), MODEL_PATH))
    try:
        retrying(lambda: client.create_registered_model(name))
    except MlflowException as err:
        if err.error_code != "RESOURCE_ALREADY_EXISTS":
            raise
    run = retrying(lambda: client.get_run(run_id))
    with _quiet_mlflow():  # a server's registry says it waits for each version to be READY
        version = retrying(
            lambda: client.create_model_version(
                name,
                source=f"{run.info.artifact_uri}/{MODEL_PATH}",
                run_id=run_id,
                tags={str(key): str(v) for key, v in tags.items() if v is not None},
                description=description,
            )
        )
    return str(version.version)


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

    Args:
        spec: ``models:/<name>/<version|latest>``, ``runs:/<run>/<path>``, or a local path.
        tracking_uri: the store to resolve registry URIs in.
        dest: where to download (a temporary folder when None).

    Returns:
        The local path (``spec`` itself when it is not a URI).

    Raises:
        InputError: the registry has no such model or version.
    """
    if not spec.startswith(("models:/", "runs:/")):
        return Path(spec)
    import mlflow
    from mlflow.exceptions import MlflowException

    mlflow.set_tracking_uri(tracking_uri)
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
    try:
        local = mlflow.artifacts.download_artifacts(
            artifact_uri=spec, dst_path=str(dest or tempfile.mkdtemp(prefix="rwhonet-model-"))
        )
    except MlflowException as err:
        names = _registered_names(tracking_uri)
        raise InputError(
            [
                Problem(
                    spec,
                    None,
                    None,
                    "a model in the MLflow registry",
                    str(err.message if hasattr(err, "message") else err).split("\n")[0][:200],
                    "registered models in "
                    + tracking_uri
                    + ": "
                    + (", ".join(names) or "none")
                    + " (the pipeline registers whonet-G, whonet-S and whonet-R-<vehicle>; "
                    "run `make run` or `dvc repro` first)",
                )
            ],
            f"cannot resolve {spec}",
        ) from None
    return Path(local)


def model_version(spec: str, tracking_uri: str) -> Any | None:
    """The registry's ``ModelVersion`` a ``models:/<name>/<version|latest>`` URI names, or None."""
    if not spec.startswith("models:/"):
        return None
    from mlflow import MlflowClient

    name, _, version = spec.removeprefix("models:/").partition("/")
    client = MlflowClient(tracking_uri)
    if version in ("", "latest"):
        versions = retrying(lambda: client.search_model_versions(f"name = '{name}'"))
        return max(versions, key=lambda v: int(v.version)) if versions else None
    if "@" in spec:
        return None
    return retrying(lambda: client.get_model_version(name, version))


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
) -> list[dict[str, str]]:
    """Register G, S and the chosen R of one pipeline execution (one version each).

    Args:
        client: an ``MlflowClient`` of the store.
        logged: ``(record, run_id)`` of every run the execution logged, in order.
        common_tags: tags every version gets (the execution id, the git commit).
        scaler_path: the label stage's ``scaler.json`` (default: the project's).
        calibration_path: its ``calibration.json``.
        samples_dir: its samples folder (the input examples).

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
    picked = chosen_records([rec for rec, _ in logged])
    if not picked or not (scaler_path.is_file() and calibration_path.is_file()):
        return []
    run_of = {id(rec): rid for rec, rid in logged}
    scaler = read_json(scaler_path)
    scaler_from_dict(scaler, paths.rel(scaler_path))
    calibration = read_json(calibration_path)
    example = _example_frame(samples_dir)
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
        meta = make_meta(
            {},
            scaler,
            calibration,
            str(rec.params.get("label.wpm_mode", "integrated")),
            None,
            {"name": name, **{key: v for key, v in tags.items() if key != "seed_note"}},
        )
        with tempfile.TemporaryDirectory(prefix="rwhonet-bundle-") as tmp:
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
