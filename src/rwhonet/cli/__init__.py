"""The ``rwhonet`` command line: recalibrate, predict, export, gate (:mod:`rwhonet.cli.main`).

An entry point like ``pipelines/``, beside the stage layer rather than on it:
it calls the domain code the stages call (reading, checking and labelling a
drive: :mod:`rwhonet.cli.drive`), the models, the serving package and the
registry, and never imports the stage layer (``stages/``, ``stage.py``).
"""
