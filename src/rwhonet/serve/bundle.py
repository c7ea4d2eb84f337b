"""A model bundle: one folder with everything a WhONet needs to run anywhere.

``model.safetensors`` (the model file in its pickle-free form,
:mod:`rwhonet.models.checkpoint`), ``model.onnx``
(:func:`rwhonet.models.onnx.export_onnx`, the metadata in its
``metadata_props``) and ``rwhonet.json`` (the same metadata,
:class:`~rwhonet.serve.model.ServedMeta`). The registry logs a bundle as an
MLflow ``pyfunc`` model; ``rwhonet export`` writes its ``.onnx`` alone. This
module imports torch (lazily, to export).

A bundle never holds a ``model.pt``: whoever can write to a model store could
put a pickle there, and ``rwhonet export`` / ``recalibrate --base`` would read
it. :func:`bundle_parts` refuses a folder that has only a ``model.pt`` (a version
registered by an older rwhonet) rather than read it.

A model folder's files are fingerprinted by their SHA-256
(:func:`file_digests`) when it is registered, and checked against that
record before anything of it is used (:func:`verify_digests`): a file changed,
added (a ``python_model.pkl``) or removed after registration is refused.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rwhonet.errors import InputError, Problem
from rwhonet.serve.model import (
    META_FILE,
    META_KEY,
    MLFLOW_ARTIFACTS,
    ONNX_FILE,
    SAFETENSORS_FILE,
    TORCH_FILE,
    ServedMeta,
)


def make_meta(
    hparams: Mapping[str, Any],
    scaler: Mapping[str, Any],
    calibration: Mapping[str, Any],
    wpm_mode: str,
    wpm_radii: tuple[float, float] | None,
    info: Mapping[str, Any],
    evidence: Mapping[str, Any] | None = None,
    navigation: Mapping[str, Any] | None = None,
) -> ServedMeta:
    """The metadata of a model from the label stage's ``scaler.json`` and ``calibration.json``.

    Args:
        hparams: the network's hyperparameters.
        scaler: the parsed ``scaler.json``.
        calibration: the parsed ``calibration.json`` (``r_rl_m``, ``r_rr_m``).
        wpm_mode: ``label.wpm_mode``.
        wpm_radii: the model file's own radii (``radius+G``, ``shrink``), or None.
        info: provenance (stringified).
        evidence: the adapt stage's ``evidence.json`` (the ``shrink`` recipe's), or None.
        navigation: what the evaluation measured of the filter with this model
            (:attr:`ServedMeta.navigation`), or None.
    """
    return ServedMeta(
        hparams=dict(hparams),
        scaler=dict(scaler),
        source_radii=(float(calibration["r_rl_m"]), float(calibration["r_rr_m"])),
        wpm_mode=wpm_mode,
        wpm_radii=None if wpm_radii is None else (float(wpm_radii[0]), float(wpm_radii[1])),
        info={str(k): str(v) for k, v in info.items() if v is not None},
        evidence=None if evidence is None else dict(evidence),
        navigation=None if navigation is None else dict(navigation),
    )


def export_model(model_file: Path, meta: ServedMeta, onnx_path: Path) -> Path:
    """Export a model file (``.pt`` or ``.safetensors``) to ONNX with ``meta`` in its metadata.

    The model file's own radii (``wpm_radii``) win over ``meta``'s, so a
    ``radius+G`` model always carries the radii it was recalibrated with.
    """
    from rwhonet.models.checkpoint import load_whonet, load_wpm_radii
    from rwhonet.models.onnx import export_onnx

    net, hparams = load_whonet(model_file)
    own = load_wpm_radii(model_file)
    meta = dataclasses.replace(
        meta, hparams=dict(hparams), wpm_radii=own if own is not None else meta.wpm_radii
    )
    return export_onnx(net, hparams, onnx_path, {META_KEY: meta.to_json()})


def write_bundle(model_file: Path, meta: ServedMeta, folder: Path) -> dict[str, Path]:
    """Write a bundle folder: ``model.safetensors``, ``model.onnx``, ``rwhonet.json``.

    Args:
        model_file: the model (a pipeline's ``model.pt``, or a ``.safetensors``).
        meta: its metadata (the model file's own radii win, :func:`export_model`).
        folder: the bundle folder (created).

    Returns:
        Artifact name -> file (what the MLflow pyfunc model's ``artifacts`` are).
    """
    from rwhonet.models.checkpoint import to_safetensors
    from rwhonet.serve.model import ServedModel

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    weights = to_safetensors(model_file, folder / SAFETENSORS_FILE)
    onnx_path = export_model(weights, meta, folder / ONNX_FILE)
    meta = ServedModel(onnx_path).meta  # what the export embedded (radii resolved)
    (folder / META_FILE).write_text(meta.to_json() + "\n", encoding="utf-8")
    return {"model_onnx": onnx_path, "model_safetensors": weights, "meta": folder / META_FILE}


def bundle_parts(path: Path, source: str | None = None) -> tuple[Path, ServedMeta]:
    """The model file (``model.safetensors``) and metadata of a bundle or MLflow model folder.

    Args:
        path: the folder (a fetched registered version, or a bundle on disk).
        source: the model as the user named it (``whonet-G version 3``), for the report.

    Raises:
        InputError: the folder holds no ``model.safetensors`` and ``rwhonet.json``;
            or only a ``model.pt`` (registered by an older rwhonet), which is not read.
    """
    path = Path(path)
    label = source or str(path)
    for folder in (path, path / MLFLOW_ARTIFACTS):
        if not (folder / META_FILE).is_file():
            continue
        if (folder / SAFETENSORS_FILE).is_file():
            meta_file = folder / META_FILE
            return folder / SAFETENSORS_FILE, ServedMeta.from_json(
                meta_file.read_text(encoding="utf-8"), str(meta_file)
            )
        if (folder / TORCH_FILE).is_file():
            raise InputError(
                [
                    Problem(
                        f"{label}: {(folder / TORCH_FILE).relative_to(path).as_posix()}",
                        None,
                        None,
                        f"{SAFETENSORS_FILE} (the weights, read without pickle)",
                        f"{TORCH_FILE} only (torch's pickle format: a model registered by an "
                        "older rwhonet), which is not read",
                        "register the model again with this rwhonet (dvc repro -f evaluate, "
                        "or rwhonet recalibrate); `rwhonet predict` still runs this version "
                        "(its ONNX file)",
                    )
                ],
                f"{label} holds no pickle-free model file",
            )
    raise InputError(
        [
            Problem(
                label,
                None,
                None,
                f"a model folder holding {SAFETENSORS_FILE} and {META_FILE}",
                "no such folder" if not path.exists() else "neither",
                "give a registered model (models:/whonet-G/latest), a model folder, or a "
                "model.pt of the pipeline (models/g/seed42/model.pt)",
            )
        ],
        f"no model at {label}",
    )


def sha256_file(path: Path) -> str:
    """The SHA-256 of a file, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_digests(folder: Path) -> dict[str, str]:
    """``{relative POSIX path: SHA-256}`` of every file under ``folder``, sorted by path."""
    folder = Path(folder)
    files = sorted(p for p in folder.rglob("*") if p.is_file() or p.is_symlink())
    return {p.relative_to(folder).as_posix(): sha256_file(p) for p in files}


def digests_to_text(digests: Mapping[str, str]) -> str:
    """The digests as compact JSON with sorted keys (what a version's tag holds)."""
    return json.dumps(dict(sorted(digests.items())), separators=(",", ":"))


def digests_from_text(text: str, source: str) -> dict[str, str]:
    """Parse :func:`digests_to_text`'s JSON.

    Raises:
        InputError: not a JSON object of path -> 64 hex digits.
    """
    try:
        raw = json.loads(text)
    except json.JSONDecodeError:
        raw = None
    ok = isinstance(raw, dict) and all(
        isinstance(k, str) and isinstance(v, str) and len(v) == 64 for k, v in raw.items()
    )
    if not ok or not raw:
        raise InputError(
            [
                Problem(
                    source,
                    None,
                    None,
                    "a JSON object of file path -> SHA-256",
                    repr(text[:80]),
                    "re-register the model, or ask the registry's admin",
                )
            ],
            f"{source}: the record of the model's files is unreadable",
        )
    return dict(raw)


def verify_digests(folder: Path, expected: Mapping[str, str], source: str) -> None:
    """Refuse a model folder whose files are not exactly the ones recorded.

    Args:
        folder: the downloaded model folder.
        expected: :func:`file_digests` of the folder when it was registered.
        source: the model as the user named it (``whonet-G version 3``), for the report.

    Raises:
        InputError: one problem per file changed, missing or not recorded.
    """
    found = file_digests(folder)
    problems = []
    for rel in sorted(set(expected) | set(found)):
        want, got = expected.get(rel), found.get(rel)
        if want == got:
            continue
        if got is None:
            what = "no such file"
        elif want is None:
            what = f"a file that was not registered (sha256 {got[:16]}...)"
        else:
            what = f"sha256 {got[:16]}..."
        problems.append(
            Problem(
                f"{source}: {rel}",
                None,
                None,
                "no such file" if want is None else f"sha256 {want[:16]}... (as registered)",
                what,
                "do not use this version: its files were changed after it was registered; "
                "tell the registry's admin, and use another version",
            )
        )
    if problems:
        summary = f"{source}: the model's files do not match the SHA-256 recorded at registration"
        raise InputError(problems, summary)
