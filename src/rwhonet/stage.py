"""What every pipeline stage script shares: quiet libraries, readable failures, one exit code."""

from __future__ import annotations

import logging
import os
import sys
import warnings
from collections.abc import Callable

from rwhonet.config import ConfigError
from rwhonet.errors import InputError

EXIT_INPUT = 2


def quiet() -> None:
    """Silence library noise that says nothing to a user (see stack-facts.md)."""
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    os.environ.setdefault("DO_NOT_TRACK", "true")
    os.environ.setdefault("DISABLE_PANDERA_IMPORT_WARNING", "True")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\).*")
    logging.getLogger("lightning.pytorch.utilities.rank_zero").setLevel(logging.WARNING)
    logging.getLogger("lightning.fabric.utilities.rank_zero").setLevel(logging.WARNING)


def run(main: Callable[[], None]) -> None:
    """Run a stage's ``main``; input and config errors exit non-zero with a readable report."""
    quiet()
    try:
        main()
    except (InputError, ConfigError) as err:
        print(f"\nERROR in stage {os.path.basename(sys.argv[0])}:\n{err}", file=sys.stderr)
        sys.exit(EXIT_INPUT)
