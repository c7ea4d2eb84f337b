"""Outage metrics: CRSE / CTE per GNSS-outage window and their summaries (pure numpy/pandas)."""

from rwhonet.metrics.outage import (
    outage_table,
    summarise,
    window_evolution,
    window_metrics,
    window_starts,
)

__all__ = ["outage_table", "summarise", "window_evolution", "window_metrics", "window_starts"]
