"""Reports from the evaluation's one source of truth (metrics/eval.json): tables, CI gate."""
