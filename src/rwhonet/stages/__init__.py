"""What each DVC stage does, one module per stage; the only package that knows ``paths``.

A stage module reads its inputs, calls the domain packages (``sim``, ``data``,
``features``, ``models``, ``evaluation``, ``nav``), and writes exactly the outputs
``dvc.yaml`` declares, all at once (:func:`rwhonet.io.atomic_outputs`). Its
``main(params)`` is what ``pipelines/<stage>.py`` runs through
:func:`rwhonet.runner.run`.

- ``simulate``, ``ingest``, ``validate``, ``label``: the data stages;
- ``train``: G- and S-WhONet at every seed; ``adapt``: R-WhONet by every recipe and m;
- ``evaluate``: every model's predictions -> eval.json, tables, plots, MLflow;
- ``sample_files``: the label stage's samples read back for the model stages;
- ``model_outputs``: what the model stages write beside a model (predictions, run records);
- ``cores``: the model stages' independent jobs on every core (a fork pool).
"""
