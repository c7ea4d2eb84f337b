"""The ``rwhonet`` command line: recalibrate, predict, check, export, gate.

An entry point like ``pipelines/``, beside the stage layer rather than on it:
it calls the domain code the stages call, the models, the serving package and
the registry, and never imports the stage layer (``stages/``, ``runner.py``).

- ``main``: the argument parser and the dispatch (``rwhonet <command> --help``);
- ``drive``: one drive file -> labelled samples, through the data and features code;
- ``check``: one drive read and checked as ingest and validate would, before a run;
- ``recalibrate``: G recalibrated on a new car's first m seconds, scored and registered;
- ``predict``: a drive streamed through a served model, one corrected second at a time;
- ``export``: a model (registered, a folder, a ``model.pt``) -> one ONNX file.
"""
