"""Outage metrics: CRSE / CTE per GNSS-outage window and their summaries (pure numpy/pandas)."""

from rwhonet.metrics.outage import (
    summarise,
    window_evolution,
    window_metrics,
    window_starts,
)

__all__ = ["summarise", "window_evolution", "window_metrics", "window_starts"]
