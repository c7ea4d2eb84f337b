"""The MLflow ``pyfunc`` flavour of a model bundle: ``mlflow.pyfunc.load_model`` works on it.

Input: a DataFrame with one row per second, the scaled features ``x_00 .. x_39``
of the samples contract (one-second windows) and, for a model with its own WPM
radii (``radius+G``), the rear wheel angles ``angle_rl_rad`` and ``angle_rr_rad``
(optional columns otherwise). A model with temporal context (``seq_len`` > 1,
``model.arch`` gru or tcn) takes the rows as consecutive seconds in time order:
each row's window is made of it and the rows before it, never reaching past a
change of the optional ``segment`` column (a GNSS cut, another drive) and
padded there with the segment's first row, as the pipeline cuts its windows
(:func:`rwhonet.features.sequences.sequences`). Output: ``pred_m``, the label prediction (GNSS −
WPM with the source radii, metres), computed by ONNX Runtime
(:class:`~rwhonet.serve.model.ServedModel`). Loading needs the ``rwhonet``
package installed: a registered version is a model from code
(:data:`MODEL_CODE`, which names :class:`WhONetPyfunc`), never a pickled
instance, and its payload is the bundle's ONNX file and metadata.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mlflow.pyfunc
import numpy as np
import pandas as pd

from rwhonet import contracts as k
from rwhonet.errors import InputError, Problem
from rwhonet.features.sequences import sequences
from rwhonet.serve.model import ServedMeta, ServedModel

ANGLES = (k.ANGLE_RL_RAD, k.ANGLE_RR_RAD)
SEGMENT = "segment"  # rows of one stretch of consecutive seconds share it (seq_len > 1)
OUTPUT = "pred_m"
# The file MLflow saves as the model's code (``python_model=``) and runs to load it.
MODEL_CODE = Path(__file__).with_name("pyfunc_model.py")


def signature(meta: ServedMeta) -> Any:
    """The model signature: 40 float features, two optional float64 angles -> ``pred_m``.

    A model with temporal context also takes an optional string ``segment``.
    """
    from mlflow.models import ModelSignature
    from mlflow.types import ColSpec, Schema

    if meta.n_features != k.N_FEATURES:
        raise ValueError(
            "the pyfunc flavour takes one second per row (40 features); got "
            f"{meta.n_features} features"
        )
    inputs = [ColSpec("float", name) for name in k.FEATURE_COLUMNS]
    inputs += [ColSpec("double", name, required=meta.wpm_radii is not None) for name in ANGLES]
    if meta.seq_len > 1:
        inputs.append(ColSpec("string", SEGMENT, required=False))
    return ModelSignature(inputs=Schema(inputs), outputs=Schema([ColSpec("double", OUTPUT)]))


class WhONetPyfunc(mlflow.pyfunc.PythonModel):
    """Predicts the label of each row's feature window with the bundle's ONNX model."""

    def load_context(self, context: Any) -> None:
        self.model = ServedModel(Path(context.artifacts["model_onnx"]))

    def predict(self, context: Any, model_input: pd.DataFrame, params: Any = None) -> pd.DataFrame:
        frame = pd.DataFrame(model_input)
        missing = [c for c in k.FEATURE_COLUMNS if c not in frame.columns]
        if missing:
            raise InputError(
                [
                    Problem(
                        "model input",
                        None,
                        ", ".join(missing[:3]),
                        "the 40 feature columns x_00 .. x_39 (scaled wheel speeds)",
                        "missing",
                    )
                ],
                "inputs do not fit the model",
            )
        x = frame[list(k.FEATURE_COLUMNS)].to_numpy(np.float32)
        seq_len = self.model.meta.seq_len
        if seq_len == 1:
            x = x[:, None, :]
        else:  # each row's window: it and the rows before it within its segment
            segment = frame[SEGMENT].to_numpy() if SEGMENT in frame else np.zeros(len(frame))
            x = sequences(x, seq_len, segment)
        angles = [frame[c].to_numpy(np.float64) if c in frame.columns else None for c in ANGLES]
        return pd.DataFrame({OUTPUT: self.model.predict_label(x, *angles)})
