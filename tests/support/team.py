"""A throwaway team tracking server for tests: PostgreSQL, ``mlflow server`` and nginx on localhost.

:func:`postgres_bin` finds Debian's PostgreSQL binaries
(``/usr/lib/postgresql/<version>/bin``) and :func:`nginx_bin` Debian's nginx;
on a CI machine where they are missing, each installs its package
(``apt-get``, as root with ``CI=true``). :func:`postgres` initialises a
cluster in a temporary folder whose role ``mlflow`` logs in with a password
(SCRAM), and serves it on a free localhost port; PostgreSQL refuses to run as
root, so under root the cluster belongs to the ``postgres`` system user the
package creates. :func:`mlflow_server` runs ``mlflow server`` on that
database, with artifacts proxied by the server into a local folder, as
docs/team.md sets a team up (S3 there, a folder here); given an
:class:`Auth`, it runs MLflow's basic-auth app with workspaces on, its users
in a second database, the admin's password from a secret. :func:`tls_proxy`
puts nginx in front: HTTPS with a self-signed certificate made by
``openssl``, and a plain-HTTP port that only redirects. Everything stops, and
its folders go, when the ``with`` block ends, whatever happened in it.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import ssl
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

BIN = Path(sys.executable).parent
PG_ROOT = Path("/usr/lib/postgresql")
PG_USER = "postgres"  # the system user Debian's package creates
DB_USER = DB_NAME = "mlflow"
AUTH_DB = "mlflow_auth"  # the basic-auth app's users and grants
NGINX = Path("/usr/sbin/nginx")


class Unavailable(RuntimeError):
    """A server is not installed and cannot be installed here (the reason is the message)."""


@dataclass(frozen=True)
class Auth:
    """The basic-auth app's settings: the admin's login, from secrets the test makes."""

    admin_password: str
    flask_secret: str
    admin_user: str = "admin"


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
    _apt_install("postgresql", "/usr/lib/postgresql/*/bin/initdb", install_timeout_s)
    found = _installed_bin()
    if found is None:
        raise Unavailable("apt-get installed postgresql, but no /usr/lib/postgresql/*/bin/initdb")
    return found


def nginx_bin(install_timeout_s: float = 600) -> Path:
    """Debian's nginx, installed first on a CI machine; ``openssl`` too (the certificate).

    Raises:
        Unavailable: as :func:`postgres_bin`.
    """
    needed = (
        ("nginx", str(NGINX), NGINX.is_file),
        ("openssl", "openssl on PATH", lambda: shutil.which("openssl") is not None),
    )
    for package, looked_for, found in needed:
        if not found():
            _apt_install(package, looked_for, install_timeout_s)
        if not found():
            raise Unavailable(f"apt-get installed {package}, but it is not there")
    return NGINX


def _apt_install(package: str, looked_for: str, timeout_s: float) -> None:
    """``apt-get install package`` as root on a CI machine (``CI=true``); else Unavailable."""
    if os.geteuid() != 0 or os.environ.get("CI", "").lower() != "true":
        raise Unavailable(
            f"{package} is not installed (no {looked_for}); CI installs it as root "
            f"(apt-get install {package}), elsewhere install it yourself"
        )
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    install = ["apt-get", "install", "-y", "-q", "--no-install-recommends", package]
    for cmd in (["apt-get", "update", "-q"], install):
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout_s)
        if out.returncode != 0:
            raise Unavailable(f"{' '.join(cmd)} failed: {(out.stdout + out.stderr)[-2000:]}")


def free_port() -> int:
    """A TCP port nobody listens on at 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _as_owner(cmd: list[str]) -> list[str]:
    """Run a PostgreSQL server binary as the ``postgres`` user when we are root."""
    return ["runuser", "-u", PG_USER, "--", *cmd] if os.geteuid() == 0 else cmd


def _run(cmd: list[str], timeout: float = 120, env: dict | None = None) -> str:
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {out.returncode}: {out.stdout}{out.stderr}")
    return out.stdout


@contextmanager
def postgres(pg_bin: Path, password: str) -> Iterator[str]:
    """A fresh PostgreSQL cluster on a free localhost port, with empty databases.

    The role ``mlflow`` logs in with ``password`` (SCRAM), as a team's database
    would; the databases are ``mlflow`` (the tracking store) and ``mlflow_auth``
    (the basic-auth app's users).

    Args:
        pg_bin: :func:`postgres_bin`.
        password: the role's password.

    Yields:
        The tracking database's URI, ``postgresql://mlflow:<password>@127.0.0.1:<port>/mlflow``.
    """
    # Not under pytest's tmp_path: its parents are closed to the postgres user.
    home = Path(tempfile.mkdtemp(prefix="rwhonet-pg-"))
    data, log, pwfile = home / "data", home / "server.log", home / "pw"
    pwfile.write_text(password + "\n")
    if os.geteuid() == 0:
        shutil.chown(home, PG_USER)
        shutil.chown(pwfile, PG_USER)
    port = free_port()
    started = False
    try:
        _run(
            _as_owner(
                [
                    str(pg_bin / "initdb"),
                    "-D",
                    str(data),
                    "-U",
                    DB_USER,
                    "--auth=scram-sha-256",
                    f"--pwfile={pwfile}",
                    "-E",
                    "UTF8",
                    "--no-sync",
                ]
            )
        )
        pwfile.unlink()
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
        for db in (DB_NAME, AUTH_DB):
            _run(
                [str(pg_bin / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", DB_USER, db],
                env={**os.environ, "PGPASSWORD": password},
            )
        yield f"postgresql://{DB_USER}:{quote(password, safe='')}@127.0.0.1:{port}/{DB_NAME}"
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
def mlflow_server(
    backend_uri: str, artifacts: Path, auth: Auth | None = None, start_timeout_s: float = 240
) -> Iterator[str]:
    """``mlflow server`` on ``backend_uri``, artifacts served by it from ``artifacts``.

    With ``auth``: ``--app-name basic-auth --enable-workspaces``, its settings in
    a ``basic_auth.ini`` only the server's user can read (``MLFLOW_AUTH_CONFIG_PATH``;
    the users in the ``mlflow_auth`` database beside ``backend_uri``'s), the
    admin's password given once, from the environment, for the first start. The
    database URI reaches the server through the environment, never its command
    line (which every user of the machine can read).

    Args:
        backend_uri: the backend store (``postgresql://...``).
        artifacts: the folder the server writes artifacts to (``--artifacts-destination``).
        auth: the basic-auth app's secrets; None: no login at all.
        start_timeout_s: how long to wait for ``/health``.

    Yields:
        The server's own address, ``http://127.0.0.1:<port>`` (loopback only).
    """
    artifacts.mkdir(parents=True, exist_ok=True)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    log = artifacts.parent / "mlflow-server.log"
    cmd = [
        str(BIN / "mlflow"),
        "server",
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
        "MLFLOW_BACKEND_STORE_URI": backend_uri,
        "MLFLOW_DISABLE_TELEMETRY": "true",
        "DO_NOT_TRACK": "true",
        # the job runner (GenAI scorers, trace archival) is eight more Python processes
        # nothing here uses: on two cores they slow the pipeline under test
        "MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false",
    }
    for var in ("MLFLOW_TRACKING_URI", "MLFLOW_TRACKING_USERNAME", "MLFLOW_TRACKING_PASSWORD"):
        env.pop(var, None)
    if auth is not None:
        ini = artifacts.parent / "basic_auth.ini"
        ini.touch(mode=0o600)
        ini.write_text(
            "[mlflow]\n"
            "default_permission = NO_PERMISSIONS\n"
            f"database_uri = {backend_uri.rsplit('/', 1)[0]}/{AUTH_DB}\n"
            f"admin_username = {auth.admin_user}\n"
            "authorization_function = mlflow.server.auth:authenticate_request_basic_auth\n"
            # a password checked once a minute per worker, not on every request: PBKDF2
            # costs 330 ms a request here, and the pipeline makes hundreds (docs/team.md)
            "auth_cache_ttl_seconds = 60\n"
        )
        cmd += ["--app-name", "basic-auth", "--enable-workspaces"]
        env |= {
            "MLFLOW_AUTH_CONFIG_PATH": str(ini),
            "MLFLOW_AUTH_ADMIN_PASSWORD": auth.admin_password,
            "MLFLOW_FLASK_SERVER_SECRET_KEY": auth.flask_secret,
        }
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
        _wait(lambda: _healthy(url), proc, log, "mlflow server: no /health", start_timeout_s)
        yield url
    finally:
        _stop_group(proc)


def _wait(ready, proc: subprocess.Popen, log: Path, what: str, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not ready():
        if proc.poll() is not None or time.monotonic() > deadline:
            why = "exited" if proc.poll() is not None else f"{what} in {timeout_s} s"
            raise RuntimeError(f"{why}:\n{log.read_text()[-3000:]}")
        time.sleep(0.3)


def self_signed_certificate(folder: Path, days: int = 2) -> tuple[Path, Path]:
    """``(cert.pem, key.pem)`` for ``localhost`` and ``127.0.0.1``, made by ``openssl``."""
    cert, key = folder / "cert.pem", folder / "key.pem"
    _run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-days",
            str(days),
            "-subj",
            "/CN=localhost",
            "-addext",
            "subjectAltName=DNS:localhost,IP:127.0.0.1",
            "-keyout",
            str(key),
            "-out",
            str(cert),
        ]
    )
    key.chmod(0o600)
    return cert, key


NGINX_CONF = """\
{user}worker_processes 1;
pid {home}/nginx.pid;
error_log {home}/error.log warn;
events {{ worker_connections 256; }}
http {{
  access_log {home}/access.log;
  client_body_temp_path {tmp}/body;
  proxy_temp_path {tmp}/proxy;
  fastcgi_temp_path {tmp}/fastcgi;
  uwsgi_temp_path {tmp}/uwsgi;
  scgi_temp_path {tmp}/scgi;
  server_tokens off;
  # plain HTTP answers nothing but a redirect to HTTPS
  server {{
    listen 127.0.0.1:{http_port};
    return 301 https://localhost:{https_port}$request_uri;
  }}
  server {{
    listen 127.0.0.1:{https_port} ssl;
    server_name localhost;
    ssl_certificate {cert};
    ssl_certificate_key {key};
    ssl_protocols TLSv1.2 TLSv1.3;
    add_header Strict-Transport-Security "max-age=31536000" always;
    client_max_body_size 0;  # model files and artifacts of any size
    location / {{
      proxy_pass {upstream};
      proxy_set_header Host $host;
      proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
      proxy_set_header X-Forwarded-Proto https;
      proxy_read_timeout 600s;
    }}
  }}
}}
"""


@dataclass(frozen=True)
class Proxy:
    """What a client of :func:`tls_proxy` needs."""

    https: str  # https://localhost:<port>
    http: str  # http://127.0.0.1:<port>: redirects only
    cert: Path  # the certificate clients verify (MLFLOW_TRACKING_SERVER_CERT_PATH)


@contextmanager
def tls_proxy(nginx: Path, upstream: str, start_timeout_s: float = 60) -> Iterator[Proxy]:
    """nginx on two free localhost ports: HTTPS to ``upstream``, and plain HTTP redirecting.

    Args:
        nginx: :func:`nginx_bin`.
        upstream: the server behind it (``http://127.0.0.1:<port>``).
        start_timeout_s: how long to wait for the HTTPS port.
    """
    home = Path(tempfile.mkdtemp(prefix="rwhonet-nginx-"))
    tmp = home / "tmp"
    tmp.mkdir()
    user = ""
    if os.geteuid() == 0:  # nginx's workers drop to an unprivileged user; they buffer uploads
        user = "user nobody nogroup;\n"
        home.chmod(0o711)
        shutil.chown(tmp, "nobody", "nogroup")
    cert, key = self_signed_certificate(home)
    http_port, https_port = free_port(), free_port()
    conf = home / "nginx.conf"
    conf.write_text(
        NGINX_CONF.format(
            user=user,
            home=home,
            tmp=tmp,
            http_port=http_port,
            https_port=https_port,
            cert=cert,
            key=key,
            upstream=upstream,
        )
    )
    log = home / "error.log"
    cmd = [str(nginx), "-c", str(conf), "-p", str(home), "-e", str(log), "-g", "daemon off;"]
    proxy = Proxy(f"https://localhost:{https_port}", f"http://127.0.0.1:{http_port}", cert)
    with open(home / "stdout.log", "w") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        _wait(lambda: _tls_answers(proxy), proc, log, "nginx: no TLS answer", start_timeout_s)
        yield proxy
    finally:
        _stop_group(proc)
        shutil.rmtree(home, ignore_errors=True)


def _tls_answers(proxy: Proxy) -> bool:
    context = ssl.create_default_context(cafile=str(proxy.cert))
    try:
        with urllib.request.urlopen(f"{proxy.https}/health", timeout=5, context=context) as r:
            return r.status == 200
    except (urllib.error.URLError, OSError):
        return False


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
