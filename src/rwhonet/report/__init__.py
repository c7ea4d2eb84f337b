"""Reports of an evaluation, from data only (never from the stage layer).

- ``tables``: ``reports/tables.md``, rendered from the evaluation package's
  typed result (:class:`rwhonet.evaluation.result.Evaluation`, whose
  ``eval_json`` is ``metrics/eval.json``'s content);
- ``plots``: the tables of ``reports/plots/`` (the DVC plots), from the same result;
- ``run_metrics``: the same result as the MLflow runs' metrics (``crse/30s/mean``,
  ``pos/...``, ``scenario/...``);
- ``headline``: the headline rows, Markdown and HTML of an execution (the MLflow
  parent run's view), read from ``metrics/eval.json``;
- ``versus_paper``: ``metrics/eval.json`` next to the paper's Tables 2-10;
- ``paper``: the paper's tables and claims, as data;
- ``gate``: the CI regression gate, ``metrics/eval.json`` against a committed baseline;
- ``worlds``: every headline claim marked, world by world, as holding or not (``make worlds``).
"""
