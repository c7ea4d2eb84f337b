"""A model bundle: one folder with everything a WhONet needs to run anywhere.

``model.pt`` (the model file, :mod:`rwhonet.models.checkpoint`), ``model.onnx``
(:func:`rwhonet.models.onnx.export_onnx`, the metadata in its
``metadata_props``) and ``rwhonet.json`` (the same metadata,
:class:`~rwhonet.serve.model.ServedMeta`). The registry logs a bundle as an
MLflow ``pyfunc`` model; ``rwhonet export`` writes its ``.onnx`` alone. This
module imports torch (lazily, to export).

A model folder's files are fingerprinted by their SHA-256
(:func:`file_digests`) when it is registered, and checked against that
record before anything of it is used (:func:`verify_digests`): a file changed,
added (a ``python_model.pkl``) or removed after registration is refused.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rwhonet.errors import InputError, Problem
from rwhonet.serve.model import (
    META_FILE,
    META_KEY,
    MLFLOW_ARTIFACTS,
    ONNX_FILE,
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
    """
    return ServedMeta(
        hparams=dict(hparams),
        scaler=dict(scaler),
        source_radii=(float(calibration["r_rl_m"]), float(calibration["r_rr_m"])),
        wpm_mode=wpm_mode,
        wpm_radii=None if wpm_radii is None else (float(wpm_radii[0]), float(wpm_radii[1])),
        info={str(k): str(v) for k, v in info.items() if v is not None},
        evidence=None if evidence is None else dict(evidence),
    )


def export_model(model_pt: Path, meta: ServedMeta, onnx_path: Path) -> Path:
    """Export a model file to ONNX with ``meta`` in its ``metadata_props``.

    The model file's own radii (``wpm_radii``) win over ``meta``'s, so a
    ``radius+G`` model always carries the radii it was recalibrated with.
    """
    from rwhonet.models.checkpoint import load_whonet, load_wpm_radii
    from rwhonet.models.onnx import export_onnx

    net, hparams = load_whonet(model_pt)
    own = load_wpm_radii(model_pt)
    meta = dataclasses.replace(
        meta, hparams=dict(hparams), wpm_radii=own if own is not None else meta.wpm_radii
    )
    return export_onnx(net, hparams, onnx_path, {META_KEY: meta.to_json()})


def write_bundle(model_pt: Path, meta: ServedMeta, folder: Path) -> dict[str, Path]:
    """Write a bundle folder: ``model.pt``, ``model.onnx``, ``rwhonet.json``.

    Returns:
        Artifact name -> file (what the MLflow pyfunc model's ``artifacts`` are).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    onnx_path = export_model(Path(model_pt), meta, folder / ONNX_FILE)
    from rwhonet.serve.model import ServedModel

    meta = ServedModel(onnx_path).meta  # what the export embedded (radii resolved)
    shutil.copyfile(model_pt, folder / TORCH_FILE)
    (folder / META_FILE).write_text(meta.to_json() + "\n", encoding="utf-8")
    return {"model_onnx": onnx_path, "model_pt": folder / TORCH_FILE, "meta": folder / META_FILE}


def bundle_parts(path: Path) -> tuple[Path, ServedMeta]:
    """The model file and metadata of a bundle or MLflow model folder.

    Raises:
        InputError: the folder holds no ``model.pt`` and ``rwhonet.json``.
    """
    path = Path(path)
    for folder in (path, path / MLFLOW_ARTIFACTS):
        if (folder / TORCH_FILE).is_file() and (folder / META_FILE).is_file():
            meta_file = folder / META_FILE
            return folder / TORCH_FILE, ServedMeta.from_json(
                meta_file.read_text(encoding="utf-8"), str(meta_file)
            )
    raise InputError(
        [
            Problem(
                str(path),
                None,
                None,
                f"a model folder holding {TORCH_FILE} and {META_FILE}",
                "no such folder" if not path.exists() else "neither",
                "give a registered model (models:/whonet-G/latest), a model folder, or a "
                "model.pt of the pipeline (models/g/seed42/model.pt)",
            )
        ],
        f"no model at {path}",
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
