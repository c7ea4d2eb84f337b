"""``rwhonet export``: a model (registered, a folder, a pipeline ``model.pt``) -> one ONNX file.

The file carries the input scaler and the WPM's radii in its ``metadata_props``
(:mod:`rwhonet.serve.model`), so ``rwhonet predict --model file.onnx`` needs
nothing else. The export is checked against PyTorch on windows spread over the
scaler's range before the command reports success.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rwhonet import paths
from rwhonet.errors import InputError, Problem
from rwhonet.io import scratch_dir

PARITY_TOL = 1e-5  # metres: |ONNX - PyTorch| on the check windows
N_CHECK = 1000


def model_parts(spec: str, tracking_uri: str | None, dest: Path, wpm_mode: str) -> tuple:
    """``(model file, metadata)`` of a registry URI, a model folder, or a pipeline ``model.pt``.

    A registered version's model file is its ``model.safetensors``, read without
    pickle once its files are verified (:func:`rwhonet.tracking.registry.fetch_model`);
    one that holds only a ``model.pt`` is refused. A bare model file of this
    project (``model.pt``, read with ``torch.load(weights_only=True)``, or a
    ``.safetensors``, or a pipeline model folder holding a ``model.pt``: ``models/g/seed42``)
    takes its scaler and source radii from the project's
    ``data/processed/scaler.json`` and ``calibration.json`` (the label stage's).
    """
    from rwhonet.cli.predict import model_path
    from rwhonet.serve.bundle import bundle_parts, make_meta
    from rwhonet.serve.model import META_FILE, TORCH_FILE

    if spec.startswith(("models:/", "runs:/")):
        if tracking_uri is None:
            return bundle_parts(model_path(spec, tracking_uri, dest))  # refused: no store
        from rwhonet.tracking.registry import fetch_model, version_label

        local, version = fetch_model(spec, tracking_uri, dest)
        return bundle_parts(local, version_label(version))
    path = Path(spec)
    if path.is_dir() and (path / TORCH_FILE).is_file() and not (path / META_FILE).is_file():
        path = path / TORCH_FILE  # a pipeline model folder (models/g/seed42): its model file
    if path.is_file() and path.suffix in (".pt", ".safetensors"):
        from rwhonet.io import read_json

        missing = [p for p in (paths.SCALER, paths.CALIBRATION) if not p.is_file()]
        if missing:
            raise InputError(
                [
                    Problem(
                        paths.rel(p),
                        None,
                        None,
                        "the label stage's output (the model's scaler and source radii)",
                        "no such file",
                        "run the pipeline (make run) in this project first, or export a "
                        "registered model (models:/whonet-G/latest)",
                    )
                    for p in missing
                ],
            )
        meta = make_meta(
            {},
            read_json(paths.SCALER),
            read_json(paths.CALIBRATION),
            wpm_mode,
            None,
            {"name": path.stem, "model_file": paths.rel(path)},
        )
        return path, meta
    return bundle_parts(path)


def run(spec: str, output: str | None, tracking_uri: str | None, wpm_mode: str) -> dict[str, Any]:
    """Export and check; return the file, its size and the parity error."""
    from rwhonet.cli.predict import output_file
    from rwhonet.models.checkpoint import load_whonet
    from rwhonet.models.loop import predict
    from rwhonet.serve.bundle import export_model
    from rwhonet.serve.model import load_served

    with scratch_dir("export") as tmp:
        model_file, meta = model_parts(spec, tracking_uri, Path(tmp), wpm_mode)
        default = meta.info.get("name") or Path(model_file).stem
        if meta.info.get("version"):
            default += f"-v{meta.info['version']}"
        out = output_file(output or f"{default}.onnx", "an .onnx file")
        export_model(Path(model_file), meta, out)
        net, hparams = load_whonet(model_file)
    served = load_served(out)
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.1, 1.1, (N_CHECK, served.meta.seq_len, served.meta.n_features))
    x = x.astype(np.float32)
    diff = float(np.max(np.abs(served.predict(x) - predict(net, x, seq_len=hparams["seq_len"]))))
    if not diff <= PARITY_TOL:
        out.unlink(missing_ok=True)  # a model that does not reproduce is not left behind
        raise InputError(
            [
                Problem(
                    str(out),
                    None,
                    None,
                    f"ONNX output within {PARITY_TOL} m of PyTorch's",
                    f"max |difference| {diff:.3g} m over {N_CHECK} windows",
                )
            ],
            "the export does not reproduce the model",
        )
    return {"file": out, "bytes": out.stat().st_size, "diff": diff, "meta": served.meta}
