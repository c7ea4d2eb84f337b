"""The run record: what one MLflow run logs, as plain data the model stages write to JSON.

The model stages (``train``, ``adapt``) write one per model next to
it (``run.json``); the ``evaluate`` stage logs them all
(:func:`rwhonet.tracking.store.log_execution`). This module imports nothing of
MLflow nor of the registry, so the model stages depend on it alone.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Timing:
    """When a run ran, in milliseconds since the epoch (MLflow's run start and end time).

    Attributes:
        start_ms: when it started.
        end_ms: when it ended; None: when its logging ends.
    """

    start_ms: int
    end_ms: int | None = None


def now_ms() -> int:
    """The current time in epoch milliseconds."""
    return int(time.time() * 1000)


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
        timing: when the run ran (None: when it is logged). Never written to
            ``run.json``: the stages' outputs stay byte-reproducible
            (:mod:`rwhonet.tracking.timings` keeps the times beside the store).
    """

    name: str
    tags: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    history: list[dict[str, float]] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    artifacts: list[str] = field(default_factory=list)
    children: list[RunRecord] = field(default_factory=list)
    timing: Timing | None = field(default=None, compare=False)

    def to_dict(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        del d["timing"]
        d["children"] = [c.to_dict() for c in self.children]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RunRecord:
        d = dict(d)
        d["children"] = [cls.from_dict(c) for c in d.get("children", [])]
        d.pop("timing", None)
        return cls(**d)
