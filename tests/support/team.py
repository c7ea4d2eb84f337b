"""A throwaway team tracking server for tests: PostgreSQL and ``mlflow server`` on localhost.

:func:`postgres_bin` finds Debian's PostgreSQL binaries
(``/usr/lib/postgresql/<version>/bin``) and, on a CI machine where they are
missing, installs the ``postgresql`` package (``apt-get``, as root with
``CI=true``). :func:`postgres` initialises a cluster in a temporary folder and
serves it on a free localhost port; PostgreSQL refuses to run as root, so
under root the cluster belongs to the ``postgres`` system user the package
creates. :func:`mlflow_server` runs ``mlflow server`` on that database, with
artifacts proxied by the server into a local folder, as docs/team.md sets a
team up (S3 there, a folder here). Both stop, and their folders go, when the
``with`` block ends, whatever happened in it.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

BIN = Path(sys.executable).parent
PG_ROOT = Path("/usr/lib/postgresql")
PG_USER = "postgres"  # the system user Debian's package creates
DB_USER = DB_NAME = "mlflow"


class Unavailable(RuntimeError):
    """PostgreSQL is not installed and cannot be installed here (the reason is the message)."""


def _installed_bin() -> Path | None:
    versions = sorted(
        (p.parent for p in PG_ROOT.glob("*/bin/initdb")),
        key=lambda b: int(b.parent.name) if b.parent.name.isdigit() else 0,
    )
    return versions[-1] if versions else None


def postgres_bin(install_timeout_s: float = 600) -> Path:
    """The newest installed PostgreSQL's ``bin`` folder, installed first on a CI machine.

    Returns:
        ``/usr/lib/postgresql/<version>/bin``.

    Raises:
        Unavailable: not installed, and this is not root on a CI machine (``CI=true``),
            or the installation failed.
    """
    found = _installed_bin()
    if found is not None:
        return found
    if os.geteuid() != 0 or os.environ.get("CI", "").lower() != "true":
        raise Unavailable(
            "PostgreSQL is not installed (no /usr/lib/postgresql/*/bin/initdb); CI installs it "
            "as root (apt-get install postgresql), elsewhere install it yourself"
        )
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    install = ["apt-get", "install", "-y", "-q", "--no-install-recommends", "postgresql"]
    for cmd in (["apt-get", "update", "-q"], install):
        out = subprocess.run(
            cmd, env=env, capture_output=True, text=True, timeout=install_timeout_s
        )
        if out.returncode != 0:
            raise Unavailable(f"{' '.join(cmd)} failed: {(out.stdout + out.stderr)[-2000:]}")
    found = _installed_bin()
    if found is None:
        raise Unavailable("apt-get installed postgresql, but no /usr/lib/postgresql/*/bin/initdb")
    return found


def free_port() -> int:
    """A TCP port nobody listens on at 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _as_owner(cmd: list[str]) -> list[str]:
    """Run a PostgreSQL server binary as the ``postgres`` user when we are root."""
    return ["runuser", "-u", PG_USER, "--", *cmd] if os.geteuid() == 0 else cmd


def _run(cmd: list[str], timeout: float = 120) -> str:
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {out.returncode}: {out.stdout}{out.stderr}")
    return out.stdout


@contextmanager
def postgres(pg_bin: Path) -> Iterator[str]:
    """A fresh PostgreSQL cluster on a free localhost port, with an empty database ``mlflow``.

    Args:
        pg_bin: :func:`postgres_bin`.

    Yields:
        The database's SQLAlchemy URI, ``postgresql://mlflow@127.0.0.1:<port>/mlflow``.
    """
    # Not under pytest's tmp_path: its parents are closed to the postgres user.
    home = Path(tempfile.mkdtemp(prefix="rwhonet-pg-"))
    data, log = home / "data", home / "server.log"
    if os.geteuid() == 0:
        shutil.chown(home, PG_USER)
    port = free_port()
    started = False
    try:
        # trust: a cluster that lives for one test, reachable from localhost only
        _run(
            _as_owner(
                [
                    str(pg_bin / "initdb"),
                    "-D",
                    str(data),
                    "-U",
                    DB_USER,
                    "--auth=trust",
                    "-E",
                    "UTF8",
                    "--no-sync",
                ]
            )
        )
        started = True
        _run(
            _as_owner(
                [
                    str(pg_bin / "pg_ctl"),
                    "-D",
                    str(data),
                    "-l",
                    str(log),
                    "-w",
                    "-t",
                    "60",
                    "-o",
                    f"-h 127.0.0.1 -p {port} -k {home}",
                    "start",
                ]
            )
        )
        _run([str(pg_bin / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", DB_USER, DB_NAME])
        yield f"postgresql://{DB_USER}@127.0.0.1:{port}/{DB_NAME}"
    finally:
        if started:
            subprocess.run(
                _as_owner([str(pg_bin / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"]),
                capture_output=True,
                timeout=60,
            )
        shutil.rmtree(home, ignore_errors=True)


def _healthy(url: str) -> bool:
    try:
        with urllib.request.urlopen(f"{url}/health", timeout=5) as r:
            return r.status == 200
    except (urllib.error.URLError, OSError):
        return False


@contextmanager
def mlflow_server(backend_uri: str, artifacts: Path, start_timeout_s: float = 240) -> Iterator[str]:
    """``mlflow server`` on ``backend_uri``, artifacts served by it from ``artifacts``.

    Args:
        backend_uri: the backend store (``postgresql://...``).
        artifacts: the folder the server writes artifacts to (``--artifacts-destination``).
        start_timeout_s: how long to wait for ``/health``.

    Yields:
        The tracking URI, ``http://127.0.0.1:<port>``.
    """
    artifacts.mkdir(parents=True, exist_ok=True)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    log = artifacts.parent / "mlflow-server.log"
    cmd = [
        str(BIN / "mlflow"),
        "server",
        "--backend-store-uri",
        backend_uri,
        "--serve-artifacts",
        "--artifacts-destination",
        str(artifacts),
        "--host",
        "127.0.0.1",
        "--port",
        str(port),
        "--workers",
        "1",
    ]
    env = {
        **os.environ,
        "MLFLOW_DISABLE_TELEMETRY": "true",
        "DO_NOT_TRACK": "true",
        # the job runner (GenAI scorers, trace archival) is eight more Python processes
        # nothing here uses: on two cores they slow the pipeline under test
        "MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false",
    }
    env.pop("MLFLOW_TRACKING_URI", None)
    with open(log, "w") as out:
        # its own session: the CLI starts uvicorn and a job runner, stopped with it as a group
        proc = subprocess.Popen(
            cmd,
            cwd=artifacts.parent,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        deadline = time.monotonic() + start_timeout_s
        while not _healthy(url):
            if proc.poll() is not None or time.monotonic() > deadline:
                why = "exited" if proc.poll() is not None else f"no /health in {start_timeout_s} s"
                raise RuntimeError(f"mlflow server {why}:\n{log.read_text()[-3000:]}")
            time.sleep(0.5)
        yield url
    finally:
        _stop_group(proc)


def _stop_group(proc: subprocess.Popen, grace_s: float = 20) -> None:
    """SIGTERM the process group ``proc`` leads, SIGKILL what is left of it after ``grace_s``."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        return
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline:
        proc.poll()  # reaps the leader, so an empty group reads as gone
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.2)
    with suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10)
