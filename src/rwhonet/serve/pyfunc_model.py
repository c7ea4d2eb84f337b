"""The code MLflow runs to load a registered WhONet: a "model from code" (MLflow 3).

:func:`rwhonet.tracking.registry.log_bundle` hands this file's path to
``mlflow.pyfunc.save_model(python_model=...)``; MLflow copies it into every
registered version and runs it on ``mlflow.pyfunc.load_model``. It names the
class of the installed ``rwhonet`` package and no more, so a version's
artifacts hold no pickled object: this file, the ONNX graph and its metadata
(:mod:`rwhonet.serve.bundle`), each with its SHA-256 in the version's tags.
"""

from mlflow.models import set_model

from rwhonet.serve.pyfunc import WhONetPyfunc

set_model(WhONetPyfunc())
