"""A team server's credentials: from the environment or a file outside the repository; never logged.

MLflow's client finds a user's credentials itself (docs/team.md):
``MLFLOW_TRACKING_USERNAME`` / ``MLFLOW_TRACKING_PASSWORD`` in the environment,
else ``~/.mlflow/credentials`` (section ``[mlflow]``, keys
``mlflow_tracking_username`` / ``mlflow_tracking_password``), and the server's
certificate from ``MLFLOW_TRACKING_SERVER_CERT_PATH``. Nothing of the project
holds them: ``params.yaml`` refuses a tracking URI with a password
(:func:`rwhonet.config.tracking_uri_problem`). What stays true here:

- A tracking URI given with a user and password in it
  (``MLFLOW_TRACKING_URI=https://alice:pw@host``) is taken apart once, where the
  project resolves its store (:func:`adopt_uri_credentials`): the credentials
  move to the environment variables MLflow reads, and every URI the project
  prints, logs or passes on is the bare one. (MLflow puts the URI it was given
  into its own error messages, so a URI with a password would end up in a failed
  stage's logged traceback.)
- :func:`redact` removes what is left to chance from any text the project logs
  on failure (message, traceback, command line, ``params.yaml``): a password in
  any URI, and the value of every environment variable whose name says it holds
  a secret (``*PASSWORD*``, ``*SECRET*``, ``*TOKEN*``, ``*_KEY``...: a DVC
  remote's or a bucket's key, the admin's bootstrap password).
- A password is never sent in clear text to another machine
  (:func:`transport_problem`): ``http://`` is for a server on this machine;
  a team server sits behind TLS (``https://``), and its certificate is verified
  (``MLFLOW_TRACKING_INSECURE_TLS=true``, which turns verification off, is
  refused there: whoever answers in the server's place would get the password).
- A server that refuses the credentials (401) or the action (403) is an
  :class:`~rwhonet.errors.InputError` naming the user and what to do
  (:func:`access_error`), not a traceback.
"""

from __future__ import annotations

import configparser
import ipaddress
import os
import re
from collections.abc import Mapping, MutableMapping
from pathlib import Path
from urllib.parse import unquote, urlsplit, urlunsplit

from rwhonet.errors import InputError, Problem

USERNAME = "MLFLOW_TRACKING_USERNAME"
PASSWORD = "MLFLOW_TRACKING_PASSWORD"
TOKEN = "MLFLOW_TRACKING_TOKEN"
CERT = "MLFLOW_TRACKING_SERVER_CERT_PATH"
INSECURE_TLS = "MLFLOW_TRACKING_INSECURE_TLS"  # MLflow's switch that skips certificate checks
TRACKING_URI = "MLFLOW_TRACKING_URI"
CREDENTIALS_FILE = Path("~/.mlflow/credentials")  # MLflow's own, outside any repository
MASK = "***"
# Names of environment variables that hold secrets (AWS_SECRET_ACCESS_KEY, PGPASSWORD,
# MLFLOW_TRACKING_TOKEN, MLFLOW_AUTH_ADMIN_PASSWORD, MLFLOW_FLASK_SERVER_SECRET_KEY...).
SECRET_NAME = re.compile(
    r"PASSWORD|PASSWD|SECRET|TOKEN|CREDENTIAL|(^|_)(ACCESS_)?KEY$|PRIVATE_KEY|API_KEY", re.I
)
MIN_SECRET_CHARS = 6  # shorter values are not masked: they would mask ordinary words
# scheme://user:password@ -- the password stops at the first '@', '/' or blank.
URI_PASSWORD = re.compile(r"(?P<head>[A-Za-z][A-Za-z0-9+.\-]*://[^\s/:@]*):(?P<pw>[^\s/@]+)@")
LOOPBACK_NAMES = ("localhost", "localhost.localdomain", "ip6-localhost")


def split_userinfo(uri: str) -> tuple[str, str | None, str | None]:
    """``(uri without user and password, user, password)``, both percent-decoded.

    A URI without ``user[:password]@`` comes back as it is, with ``(None, None)``.
    """
    if "://" not in uri:
        return uri, None, None
    parts = urlsplit(uri)
    if parts.username is None and parts.password is None:
        return uri, None, None
    host = parts.netloc.rpartition("@")[2]
    bare = urlunsplit((parts.scheme, host, parts.path, parts.query, parts.fragment))
    user = unquote(parts.username) if parts.username is not None else None
    password = unquote(parts.password) if parts.password is not None else None
    return bare, user, password


def adopt_uri_credentials(uri: str, environ: MutableMapping[str, str] | None = None) -> str:
    """The URI without its credentials; they go to the environment variables MLflow reads.

    Credentials already in the environment win, as MLflow's client lets them win
    over a URI's. ``$MLFLOW_TRACKING_URI`` is rewritten to the bare URI, so MLflow
    and every process started from here see the bare one.

    Args:
        uri: a tracking URI, perhaps ``https://user:password@host``.
        environ: the environment to update (``os.environ``).

    Returns:
        The bare URI.
    """
    environ = os.environ if environ is None else environ
    bare, user, password = split_userinfo(uri)
    if user is None and password is None:
        return uri
    if not (environ.get(USERNAME) or environ.get(PASSWORD)):
        if user:
            environ[USERNAME] = user
        if password is not None:
            environ[PASSWORD] = password
    if environ.get(TRACKING_URI) == uri:
        environ[TRACKING_URI] = bare
    return bare


def secret_values(environ: Mapping[str, str] | None = None) -> list[str]:
    """Every secret the environment holds, longest first.

    The values of variables named like secrets (:data:`SECRET_NAME`), and the
    password of every URI in any variable's value (a database URI, a tracking URI).
    """
    environ = os.environ if environ is None else environ
    found: set[str] = set()
    for name, value in environ.items():
        if not value:
            continue
        if SECRET_NAME.search(name):
            found.add(value)
        for match in URI_PASSWORD.finditer(value):
            found |= {match["pw"], unquote(match["pw"])}
    return sorted((s for s in found if len(s) >= MIN_SECRET_CHARS), key=len, reverse=True)


def redact(text: str, environ: Mapping[str, str] | None = None) -> str:
    """``text`` with every URI's password and every secret of the environment replaced by ``***``.

    Args:
        text: what is about to be logged (a message, a traceback, a command line, a file).
        environ: where to find the secrets (``os.environ``).
    """
    text = URI_PASSWORD.sub(lambda m: f"{m['head']}:{MASK}@", text)
    for secret in secret_values(environ):
        text = text.replace(secret, MASK)
    return text


def _has_credentials(environ: Mapping[str, str]) -> bool:
    if environ.get(PASSWORD) or environ.get(TOKEN):
        return True
    path = CREDENTIALS_FILE.expanduser()
    if not path.is_file():
        return False
    config = configparser.ConfigParser()
    try:
        config.read(path)
    except configparser.Error:
        return False
    return bool(config.has_section("mlflow") and config["mlflow"].get(PASSWORD.lower()))


def is_loopback(host: str | None) -> bool:
    """Whether ``host`` names this machine (``localhost``, ``127.0.0.0/8``, ``::1``)."""
    if not host:
        return False
    if host.lower() in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def transport_problem(uri: str, environ: Mapping[str, str] | None = None) -> Problem | None:
    """Why using ``uri`` would send a password to another machine unprotected, or None.

    With a password or token set (environment, ``~/.mlflow/credentials`` or the
    URI itself), to a host other than this machine: ``http://`` (clear text), or
    ``https://`` with ``MLFLOW_TRACKING_INSECURE_TLS`` on (any certificate accepted,
    so anyone in the middle reads it).
    """
    environ = os.environ if environ is None else environ
    if "://" not in uri:
        return None
    parts = urlsplit(uri)
    scheme = parts.scheme.lower()
    if scheme not in ("http", "https") or is_loopback(parts.hostname):
        return None
    if not (parts.password or _has_credentials(environ)):
        return None
    bare = split_userinfo(uri)[0]
    if scheme == "https":
        if environ.get(INSECURE_TLS, "").strip().lower() not in ("true", "1"):
            return None
        return Problem(
            INSECURE_TLS,
            None,
            None,
            "the server's certificate verified when a password or token is sent",
            f"{INSECURE_TLS}={environ[INSECURE_TLS]} for {bare} (any certificate accepted)",
            f"unset {INSECURE_TLS}; for a self-signed certificate set {CERT} to it (docs/team.md)",
        )
    return Problem(
        TRACKING_URI,
        None,
        None,
        "https:// for a tracking server on another machine when a password or token is set",
        f"{bare} (plain HTTP: the password would cross the network in clear text)",
        "use the TLS address of the team server (https://...; docs/team.md), with "
        f"{CERT} pointing at its certificate when it is self-signed",
    )


def check_transport(uri: str) -> str:
    """``uri`` itself, once :func:`transport_problem` finds nothing.

    Raises:
        InputError: ``uri`` would send a password in clear text or unverified.
    """
    problem = transport_problem(uri)
    if problem is not None:
        insecure = problem.file == INSECURE_TLS
        what = "without checking the server's certificate" if insecure else "over plain HTTP"
        raise InputError([problem], f"refusing to send credentials {what}")
    return uri


def _status(err: BaseException) -> str | None:
    """``UNAUTHENTICATED`` or ``PERMISSION_DENIED`` when ``err`` is a server's 401 / 403."""
    code = getattr(err, "error_code", None)
    if code in ("UNAUTHENTICATED", "PERMISSION_DENIED"):
        return code
    status = getattr(getattr(err, "response", None), "status_code", None)  # requests' HTTPError
    return {401: "UNAUTHENTICATED", 403: "PERMISSION_DENIED"}.get(status)


def access_error(err: BaseException) -> InputError | None:
    """The readable form of a tracking server's refusal (401 or 403), or None for other errors.

    Args:
        err: an exception from an MLflow client call.
    """
    code = _status(err)
    if code is None:
        return None
    text = str(getattr(err, "message", err))
    endpoint = re.search(r"endpoint (\S+)", text)
    what = endpoint[1] if endpoint else "the request"
    server = redact(os.environ.get(TRACKING_URI, "the tracking server"))
    user = os.environ.get(USERNAME)
    if code == "UNAUTHENTICATED":
        found = (
            f"401 Unauthorized for user {user!r}: wrong password, or no such user"
            if user
            else "401 Unauthorized: no credentials given"
        )
        return InputError(
            [
                Problem(
                    server,
                    None,
                    None,
                    "credentials the tracking server accepts",
                    found,
                    f"set {USERNAME} and {PASSWORD} in the environment, or write them to "
                    "~/.mlflow/credentials (docs/team.md); never into params.yaml",
                )
            ],
            "the tracking server refused the login",
        )
    return InputError(
        [
            Problem(
                server,
                None,
                None,
                f"permission for {what}",
                f"403 Forbidden for user {user!r}" if user else "403 Forbidden",
                "ask the server's admin for the permission (docs/team.md: who may do what); "
                "readers read runs and load models, editors log runs and register versions, "
                "only the admin deletes",
            )
        ],
        "the tracking server refused the request",
    )
