"""What each DVC stage does, one module per stage; the only package that knows ``paths``.

A stage module reads its inputs, calls the domain packages (``sim``, ``data``,
``features``, ``models``, ``metrics``), and writes exactly the outputs
``dvc.yaml`` declares, all at once (:func:`rwhonet.io.atomic_outputs`). Its
``main(params)`` is what ``pipelines/<stage>.py`` runs through
:func:`rwhonet.runner.run`. :mod:`~rwhonet.stages.sample_files` reads the label
stage's samples for the model stages.
"""
