"""What every pipeline stage script shares: its params, quiet libraries, readable failures.

A stage script is ``stage.run("train_g", main)``: the runner loads
``params.yaml`` restricted to the params ``dvc.yaml`` declares for that stage
(:func:`declared_params`), so a stage that reads a value it does not declare
stops with an error naming it, rather than leaving DVC to skip it when that
value changes. Input and config errors exit with status 2 and a readable
report, never a traceback.
"""

from __future__ import annotations

import logging
import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

import yaml

from rwhonet import paths
from rwhonet.config import ConfigError, Params, load_params
from rwhonet.errors import InputError

EXIT_INPUT = 2


def quiet() -> None:
    """Silence library noise that says nothing to a user (telemetry, tips, deprecations)."""
    os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")
    os.environ.setdefault("DO_NOT_TRACK", "true")
    os.environ.setdefault("DISABLE_PANDERA_IMPORT_WARNING", "True")
    warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\).*")
    logging.getLogger("lightning.pytorch.utilities.rank_zero").setLevel(logging.WARNING)
    logging.getLogger("lightning.fabric.utilities.rank_zero").setLevel(logging.WARNING)


def declared_params(stage: str, dvc_yaml: Path | None = None) -> list[str]:
    """The params a stage declares in ``dvc.yaml`` (dotted keys of ``params.yaml``).

    Args:
        stage: the stage's name in ``dvc.yaml`` (a matrix stage by its base name).
        dvc_yaml: the pipeline file; defaults to the project's.

    Returns:
        The declared keys.

    Raises:
        ConfigError: when ``dvc.yaml`` has no such stage.
    """
    dvc_yaml = dvc_yaml or paths.ROOT / "dvc.yaml"
    stages = (yaml.safe_load(dvc_yaml.read_text(encoding="utf-8")) or {}).get("stages", {})
    if stage not in stages:
        raise ConfigError(f"{paths.rel(dvc_yaml)} has no stage {stage!r}; stages: {list(stages)}")
    keys: list[str] = []
    for entry in stages[stage].get("params", []):
        if isinstance(entry, str):
            keys.append(entry)
        else:  # {params-file: [keys]}
            for file_keys in entry.values():
                keys += list(file_keys or [])
    return keys


def run(stage: str, main: Callable[[Params], None]) -> None:
    """Run a stage's ``main`` with its declared params; input and config errors exit 2.

    Args:
        stage: the stage's name in ``dvc.yaml``.
        main: the stage body; it receives the restricted params.
    """
    quiet()
    try:
        params = load_params(
            paths.PARAMS, only=declared_params(stage), reader=f"stage {stage} (dvc.yaml)"
        )
        main(params)
    except (InputError, ConfigError) as err:
        print(
            f"\nERROR in stage {stage} ({os.path.basename(sys.argv[0])}):\n{err}", file=sys.stderr
        )
        sys.exit(EXIT_INPUT)
