"""Quiet third-party libraries: telemetry, import tips and deprecation noise a user cannot act on.

Below every layer (like ``io.py``): the stage runner, the ``rwhonet`` command,
``python -m rwhonet.tracking`` and the tests call :func:`quiet` before the
libraries speak.
"""

from __future__ import annotations

import logging
import os
import warnings


def quiet() -> None:
    """Silence library noise that says nothing to a user (telemetry, tips, deprecations)."""
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    os.environ.setdefault("DO_NOT_TRACK", "true")
    os.environ.setdefault("DISABLE_PANDERA_IMPORT_WARNING", "True")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\).*")
    logging.getLogger("lightning.pytorch.utilities.rank_zero").setLevel(logging.WARNING)
    logging.getLogger("lightning.fabric.utilities.rank_zero").setLevel(logging.WARNING)
