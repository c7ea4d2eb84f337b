"""Serving a WhONet outside the training code: ONNX Runtime, no torch, no Lightning.

- :mod:`~rwhonet.serve.model`: a served model (an exported ``.onnx`` file, a model
  bundle folder or an MLflow model folder) and the metadata it carries: input
  scaler, the WPM's radii, what it was trained and recalibrated on.
- :mod:`~rwhonet.serve.stream`: 10 Hz rows in, whole seconds out (the label stage's
  grid), each with the WPM displacement, the predicted error and the corrected
  displacement; cumulative distances and errors through outages.
- :mod:`~rwhonet.serve.navigation`: the navigation filter on the stream: east/north and
  its covariance through an outage, calibrated on the GNSS seconds before it.
- :mod:`~rwhonet.serve.bundle`: writes a model bundle (``model.safetensors``, ``model.onnx``,
  ``rwhonet.json``) from a model file; the only module here that imports torch.
- :mod:`~rwhonet.serve.pyfunc`: the MLflow ``pyfunc`` flavour of a bundle, and
  :mod:`~rwhonet.serve.pyfunc_model`, the code MLflow runs to load it (a model from
  code: no pickle in a registered model).

Submodules are imported explicitly, so ``rwhonet predict`` loads neither torch
nor MLflow when it runs a local model.
"""
