"""Fuzzing the field commands: ``rwhonet predict`` and ``recalibrate`` on randomly corrupted drives.

The stages' fuzz tests (``tests/data/bad/test_stage_fuzz.py``,
``tests/data/test_stream_fuzz.py``) check that ingest, validate and the stream
readers end in a drive or a clear refusal whatever the edits. ``predict`` reads a
10 Hz drive by its own, incremental reader (block by block, as a pipe delivers it),
so the same random edits (:mod:`support.fuzz`) go through both commands here, in
this process: each must exit 0, or 2 with the report on stderr, and a refused
``predict`` leaves no output behind; any other exception fails the test.

Slow (a few seconds an example); ``make test-fast`` skips it. More examples:
``FUZZ_EXAMPLES=300``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings

from rwhonet.cli.main import main
from rwhonet.sim.streams import SIGNAL_MAP
from support.drives import write_iovnbd
from support.fuzz import corrupted_frames, edited_stream_drives
from support.serving import base_bundle, predict_args
from support.stream_corpus import RADIUS_M

pytestmark = pytest.mark.slow

FUZZ = settings(
    max_examples=int(os.environ.get("FUZZ_EXAMPLES", 8)),
    deadline=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.function_scoped_fixture,
    ],
    derandomize=True,
    database=None,
)


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    return base_bundle(tmp_path_factory.mktemp("bundle"))


@pytest.fixture(autouse=True)
def own_store(store_uri, monkeypatch):
    monkeypatch.setenv("MLFLOW_TRACKING_URI", store_uri)


def ends_well(bundle, drive: Path, extra: list[str], folder: Path, capfd) -> None:
    """predict and recalibrate on ``drive``: exit 0, or 2 with the report; nothing half-written."""
    out = folder / "out.csv"
    recalibrate = ["recalibrate", "--base", str(bundle["model_onnx"].parent), "--drive"]
    commands = {
        "predict": predict_args(bundle, drive, out, "--quiet"),
        "recalibrate": [*recalibrate, str(drive), "--seconds", "20", "--recipe", "radius+G"],
    }
    for name, argv in commands.items():
        capfd.readouterr()
        code = main(argv + extra)
        said = capfd.readouterr()
        assert code in (0, 2), f"{name}: exit {code}\n{said.err}"
        if code == 2:
            assert f"rwhonet {name}: error:" in said.err and "expected" in said.err, said.err
        if name == "predict":  # its seconds go to --output; stdout holds nothing (no C
            # library's message either: capfd reads the file descriptor)
            assert said.out == "", said.out[:2000]
            assert out.exists() == (code == 0), said.err
            assert not any(p.name.endswith(".partial") for p in folder.iterdir())
            out.unlink(missing_ok=True)


@FUZZ
@given(df=corrupted_frames())
def test_a_corrupted_10hz_drive(df, bundle, tmp_path_factory, capfd):
    folder = tmp_path_factory.mktemp("drive")
    drive = write_iovnbd(df, folder / "C-X1.csv")
    ends_well(bundle, drive, ["--nominal-radius", "0.294"], folder, capfd)


@FUZZ
@given(files=edited_stream_drives())
def test_an_edited_stream_drive(files, bundle, tmp_path_factory, capfd):
    folder = tmp_path_factory.mktemp("drive")
    streams = folder / "streams"
    streams.mkdir()
    for name, data in files.items():
        (streams / name).write_bytes(data)
    signals = {k: {"column": col, "unit": unit} for k, (col, unit) in SIGNAL_MAP.items()}
    signal_map = folder / "map.yaml"
    signal_map.write_text(yaml.safe_dump(signals))
    extra = ["--format", "stream_csv", "--signal-map", str(signal_map)]
    ends_well(bundle, streams, [*extra, "--nominal-radius", str(RADIUS_M)], folder, capfd)
