"""A headless Chromium for browser tests: Debian's, driven by Playwright, and an MLflow UI to open.

Playwright's own browser downloads are never used (they come from a CDN a CI
machine may not reach): the tests launch the system's ``/usr/bin/chromium``,
which CI (``CI=true``, root) installs with ``apt-get`` when it is missing.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
INSTALL_TIMEOUT_S = 900


def system_chromium() -> Path:
    """Debian's Chromium; installed by apt-get on CI (root, ``CI=true``), else a skip.

    Returns:
        The browser's executable.
    """
    if CHROMIUM.is_file():
        return CHROMIUM
    if os.environ.get("CI") != "true" or os.geteuid() != 0:
        pytest.skip(
            f"no {CHROMIUM}: install Debian's chromium (`apt-get install chromium`); "
            "on CI (CI=true, root) the test installs it itself"
        )
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    # recommends included: the fonts the UI's text needs come with them
    for cmd in (["apt-get", "update", "-q"], ["apt-get", "install", "-y", "-q", "chromium"]):
        out = subprocess.run(
            cmd, env=env, capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S
        )
        if out.returncode != 0:
            pytest.fail(f"{' '.join(cmd)} failed ({out.returncode}):\n{out.stderr[-2000:]}")
    if not CHROMIUM.is_file():
        pytest.fail(f"apt-get installed chromium but there is no {CHROMIUM}")
    return CHROMIUM


def free_port() -> int:
    """A TCP port nobody listens on right now (127.0.0.1)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def mlflow_ui(repo: Path, *, timeout_s: float = 180) -> Iterator[str]:
    """``mlflow ui`` on a project's store (as ``make ui`` starts it), on a free local port.

    Yields:
        The UI's base URL; the server (and its workers) stop on exit.
    """
    port = free_port()
    cmd = [
        str(Path(sys.executable).parent / "mlflow"),
        "ui",
        "--backend-store-uri",
        f"sqlite:///{repo}/mlruns/mlflow.db",
        "--default-artifact-root",
        str(repo / "mlruns" / "artifacts"),
        "--host",
        "127.0.0.1",
        "--port",
        str(port),
        "--workers",
        "1",
    ]
    # no job runner (seven worker processes on a 2-core CI machine, and nothing to run)
    env = {
        **os.environ,
        "MLFLOW_DISABLE_TELEMETRY": "true",
        "DO_NOT_TRACK": "true",
        "MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false",
    }
    log = open(repo / "mlflow-ui.log", "w")  # noqa: SIM115 - closed below
    # its own process group: the server's workers stop with it
    server = subprocess.Popen(
        cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                with urllib.request.urlopen(f"{url}/health", timeout=2) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            if server.poll() is not None or time.monotonic() > deadline:
                log.flush()
                said = (repo / "mlflow-ui.log").read_text()[-3000:]
                pytest.fail(f"mlflow ui did not start:\n{said}")
            time.sleep(0.5)
        yield url
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGTERM)
            try:
                server.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(server.pid, signal.SIGKILL)
                server.wait()
        log.close()
