"""A model's network as an ONNX graph: what ``rwhonet predict`` runs without torch.

:func:`export_onnx` traces the network in eval mode (no dropout) with the
legacy TorchScript exporter (``dynamo=False``): it needs only ``onnx``, and
for a WhONet with one time step it records the fast path of
:meth:`rwhonet.models.whonet.WhONet.features` (``tanh(W_x x + b) -> head``); a
longer ``seq_len`` records ``nn.RNN``, a ``gru`` ``nn.GRU``, a ``tcn`` its
matrix products (:mod:`rwhonet.models.network`). The graph takes ``x`` of shape
``(batch, seq_len, n_features)`` float32 and returns ``pred_m`` of shape
``(batch,)``, the network's output in metres. Whatever else a user needs to
run it (the input scaler, the WPM's radii) goes into the file's
``metadata_props`` (:mod:`rwhonet.serve.model` reads them), so one ``.onnx``
file is a complete model.
"""

from __future__ import annotations

import io
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from rwhonet.models.network import Network

INPUT = "x"
OUTPUT = "pred_m"
OPSET = 17


def export_onnx(
    net: Network,
    hparams: Mapping[str, Any],
    path: Path | str,
    metadata: Mapping[str, str] | None = None,
) -> Path:
    """Write ``net`` as an ONNX model with a dynamic batch dimension.

    Args:
        net: the network (put in eval mode; its weights are not changed).
        hparams: its hyperparameters (``seq_len`` and ``n_features`` fix the input shape).
        path: the ``.onnx`` file to write (replaced whole, never half-written).
        metadata: strings stored in the model's ``metadata_props``.

    Returns:
        ``path``.
    """
    import onnx

    net.eval()
    x = torch.zeros(1, int(hparams["seq_len"]), int(hparams["n_features"]))
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        # The legacy exporter announces its deprecation, and the tracer notes that
        # forward's branch on the (fixed) number of time steps is taken as traced.
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", torch.jit.TracerWarning)
        # nn.RNN / nn.GRU without h0 as an input: the batch stays dynamic (tests/models).
        warnings.filterwarnings("ignore", message=".*batch_size other than 1.*")
        torch.onnx.export(
            net,
            (x,),
            buffer,
            dynamo=False,
            input_names=[INPUT],
            output_names=[OUTPUT],
            dynamic_axes={INPUT: {0: "batch"}, OUTPUT: {0: "batch"}},
            opset_version=OPSET,
        )
    model = onnx.load_from_string(buffer.getvalue())
    for key, value in (metadata or {}).items():
        prop = model.metadata_props.add()
        prop.key, prop.value = key, value
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        onnx.save(model, tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
