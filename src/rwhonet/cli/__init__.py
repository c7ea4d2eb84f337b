"""The ``rwhonet`` command line: recalibrate, predict, export, gate (:mod:`rwhonet.cli.main`).

An entry point like ``pipelines/``: it drives the stages' own data code
(:mod:`rwhonet.cli.drive`), the models, the serving package and the registry.
"""
