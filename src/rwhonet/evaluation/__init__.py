"""Evaluation: how every model is scored over GNSS outages (pure: frames and arrays in, values out).

No paths, no files, no MLflow: the evaluate stage (``rwhonet.stages.evaluate``)
reads the predictions, calls :func:`study.evaluate` and writes what it returns.

- ``windows``: which seconds are scored and how they are cut into outage windows;
- ``scoring``: CRSE and CTE of a window and their summaries (paper Eqs. 16-19),
  per model, outage and drive;
- ``intervals``: means over training seeds with 95 % t intervals;
- ``names``: the models and controls reported, and the aliases ``R``, ``R@m``;
- ``model_errors``: every model's per-second error, and the WPM-m control;
- ``selection``: the selection rule and its :class:`~selection.Choice` (R-WhONet's
  recipe and m);
- ``paired``: per-seed differences, gains over the WPMs, "do no harm";
- ``over_time``: CRSE against the time into the drive;
- ``limits``: what m seconds of GNSS can tell about a car's radius;
- ``position``: 2D position at the end of each outage window: the navigation
  filter (``rwhonet.nav``) per model and control, and the earlier dead reckoning;
- ``uncertainty``: each model's per-second distance variance, fitted on the
  target training drives, and how well it predicts the windows' CRSE;
- ``scenarios``: the short-term scenarios: per-second error by tag and the
  scenario outages;
- ``result``: the typed :class:`~result.Evaluation` and its eval.json content;
- ``study``: the whole evaluation, every model and seed.
"""
