"""The run record: what one MLflow run logs, as plain data the model stages write to JSON.

The model stages (``train_g``, ``train_s``, ``adapt``) write one per model next to
it (``run.json``); the ``evaluate`` stage logs them all
(:func:`rwhonet.tracking.store.log_execution`). This module imports nothing of
MLflow nor of the registry, so the model stages depend on it alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class RunRecord:
    """Everything one run logs, as plain data (written to JSON by the stages).

    Attributes:
        name: run name shown in the UI (``G``, ``R m=50 V-Charlie3``...).
        tags: model (G/S/R/WPM), m, seed, drive, vehicle, stage...
        params: flat parameters (resolved config).
        history: per-epoch rows ``{"epoch": e, "train/loss": .., "val/loss": ..}``.
        metrics: final metrics (``crse/30s/mean``...).
        artifacts: files to attach.
        children: nested runs (e.g. one per test drive under an R run).
    """

    name: str
    tags: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    history: list[dict[str, float]] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    artifacts: list[str] = field(default_factory=list)
    children: list[RunRecord] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        d["children"] = [c.to_dict() for c in self.children]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RunRecord:
        d = dict(d)
        d["children"] = [cls.from_dict(c) for c in d.get("children", [])]
        return cls(**d)
