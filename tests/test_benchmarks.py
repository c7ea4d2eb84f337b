"""The benchmark scripts' own set-up on a fresh clone, where no pipeline has run yet.

A benchmark prints figures, and its figures are checked by reading them, not by tests;
but a script that cannot start on a fresh clone prints none. ``bench_serve.py`` serves
the workspace's G when ``make run`` has made one, else a freshly initialised WhONet:
that second path refused its own bundle from the start (its scaler named the wheels
``rr`` ... instead of the feature columns) and went unseen, since the workspace where
the figures were measured always had a G.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_serve_serves_a_fresh_whonet_where_no_pipeline_ran(tmp_path):
    shutil.copy(ROOT / "params.yaml", tmp_path / "params.yaml")  # a project without models/
    code = (
        "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]); "
        "import bench_serve; from rwhonet.cli.predict import open_model; "
        "bundle, which = bench_serve.base_bundle(Path(sys.argv[2])); "
        "model = open_model(str(bundle['model_onnx']), None); "
        "print(which, type(model).__name__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(ROOT / "benchmarks"), str(tmp_path)],
        cwd=tmp_path,
        env={**os.environ, "RWHONET_ROOT": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.startswith("a fresh WhONet"), out.stdout
