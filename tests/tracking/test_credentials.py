"""Credentials: taken from the URI into the environment, never logged, never sent in clear text."""

from __future__ import annotations

import pytest

from rwhonet.config import ConfigError, TrackingParams, tracking_uri_problem
from rwhonet.errors import InputError
from rwhonet.tracking import credentials as c
from rwhonet.tracking.client import resolve_tracking_uri, retrying

PASSWORD = "s3cret-Pa55word"


@pytest.fixture
def clean_env(monkeypatch, tmp_path):
    """No credentials in the environment, and a home without ~/.mlflow/credentials.

    What the code under test writes into ``os.environ`` goes with the test: set
    first, the variables are restored (or removed) afterwards.
    """
    for var in (c.USERNAME, c.PASSWORD, c.TOKEN, c.TRACKING_URI):
        monkeypatch.setenv(var, "")
        monkeypatch.delenv(var)
    monkeypatch.setenv("HOME", str(tmp_path))
    return monkeypatch


def test_a_uri_is_taken_apart_into_bare_uri_user_and_password():
    assert c.split_userinfo("https://alice:p%40ss@mlflow.example:8443/x?y=1") == (
        "https://mlflow.example:8443/x?y=1",
        "alice",
        "p@ss",
    )
    assert c.split_userinfo("sqlite:////tmp/m.db") == ("sqlite:////tmp/m.db", None, None)
    assert c.split_userinfo("https://h:1") == ("https://h:1", None, None)


def test_resolving_moves_the_uris_credentials_to_the_environment(clean_env):
    import os

    clean_env.setenv(c.TRACKING_URI, f"https://alice:{PASSWORD}@127.0.0.1:8443")
    assert resolve_tracking_uri("sqlite:///mlruns/mlflow.db") == "https://127.0.0.1:8443"
    assert os.environ[c.TRACKING_URI] == "https://127.0.0.1:8443"  # what children inherit
    assert (os.environ[c.USERNAME], os.environ[c.PASSWORD]) == ("alice", PASSWORD)


def test_credentials_already_in_the_environment_win_over_the_uris(clean_env):
    env = {c.USERNAME: "bob", c.PASSWORD: "bobs-password"}
    assert c.adopt_uri_credentials(f"https://alice:{PASSWORD}@h", env) == "https://h"
    assert env == {c.USERNAME: "bob", c.PASSWORD: "bobs-password"}


def test_redact_masks_uri_passwords_and_the_environments_secrets():
    env = {
        "AWS_SECRET_ACCESS_KEY": "wJalrXUtnFEMIEXAMPLEKEY",
        "PGPASSWORD": "db-password-1",
        "DATABASE": f"postgresql://mlflow:{PASSWORD}@db:5432/mlflow",
        "MLFLOW_TRACKING_TOKEN": "tok",  # too short to mask: it would mask words
        "HOME": "/home/alice-wJalr",
    }
    text = (
        f"connect postgresql://mlflow:{PASSWORD}@db:5432/mlflow failed; key wJalrXUtnFEMIEXAMPLEKEY"
        f" pw db-password-1 at https://u:other-pass@h/x, home /home/alice-wJalr, tok"
    )
    out = c.redact(text, env)
    for secret in (PASSWORD, "wJalrXUtnFEMIEXAMPLEKEY", "db-password-1", "other-pass"):
        assert secret not in out
    assert "postgresql://mlflow:***@db:5432/mlflow" in out and "https://u:***@h/x" in out
    assert "/home/alice-wJalr" in out and out.endswith("tok")  # not secrets


def test_params_refuse_a_tracking_uri_with_a_password_without_repeating_it():
    problem = tracking_uri_problem(f"https://alice:{PASSWORD}@mlflow.example")
    assert problem and "password" in problem and PASSWORD not in problem
    with pytest.raises(ConfigError) as err:
        TrackingParams(experiment="rwhonet", tracking_uri=f"http://a:{PASSWORD}@h:5000")
    assert PASSWORD not in str(err.value)
    assert tracking_uri_problem("https://alice@mlflow.example") is None  # a user alone is fine


@pytest.mark.parametrize(
    ("uri", "secret", "refused"),
    [
        ("http://mlflow.example:5000", {c.PASSWORD: PASSWORD}, True),
        (f"http://alice:{PASSWORD}@10.0.0.7:5000", {}, True),
        ("http://mlflow.example:5000", {c.TOKEN: "a-token-1234"}, True),
        ("https://mlflow.example", {c.PASSWORD: PASSWORD}, False),
        ("http://127.0.0.1:5000", {c.PASSWORD: PASSWORD}, False),  # this machine
        ("http://localhost:5000", {c.PASSWORD: PASSWORD}, False),
        ("http://mlflow.example:5000", {}, False),  # nothing secret to send
    ],
)
def test_a_password_is_never_sent_over_plain_http_to_another_machine(
    clean_env, uri, secret, refused
):
    problem = c.transport_problem(uri, secret)
    assert (problem is not None) == refused
    if problem:
        assert PASSWORD not in str(problem) and "https://" in problem.expected


@pytest.mark.parametrize(
    ("uri", "insecure", "refused"),
    [
        ("https://mlflow.example", "true", True),
        ("https://mlflow.example", "1", True),
        ("https://mlflow.example", "false", False),
        ("https://127.0.0.1:8443", "true", False),  # this machine
    ],
)
def test_a_password_is_never_sent_to_a_server_whose_certificate_is_not_checked(
    clean_env, uri, insecure, refused
):
    clean_env.setenv(c.INSECURE_TLS, insecure)
    clean_env.setenv(c.PASSWORD, PASSWORD)
    clean_env.setenv(c.TRACKING_URI, uri)
    if not refused:
        assert resolve_tracking_uri("sqlite:///mlruns/mlflow.db") == uri
        return
    with pytest.raises(InputError, match="without checking the server's certificate") as err:
        resolve_tracking_uri("sqlite:///mlruns/mlflow.db")
    assert PASSWORD not in str(err.value) and c.CERT in str(err.value)
    clean_env.delenv(c.PASSWORD)  # nothing secret to send: nothing to refuse
    assert resolve_tracking_uri("sqlite:///mlruns/mlflow.db") == uri


def test_the_credentials_file_counts_as_a_password(clean_env, tmp_path):
    (tmp_path / ".mlflow").mkdir()
    (tmp_path / ".mlflow" / "credentials").write_text(
        f"[mlflow]\nmlflow_tracking_username = alice\nmlflow_tracking_password = {PASSWORD}\n"
    )
    clean_env.setenv(c.TRACKING_URI, "http://mlflow.example:5000")
    with pytest.raises(InputError, match="plain HTTP"):
        resolve_tracking_uri("sqlite:///mlruns/mlflow.db")


@pytest.mark.parametrize(
    ("code", "user", "words"),
    [
        ("UNAUTHENTICATED", "alice", ["401", "'alice'", "MLFLOW_TRACKING_PASSWORD"]),
        ("UNAUTHENTICATED", None, ["no credentials given", "~/.mlflow/credentials"]),
        ("PERMISSION_DENIED", "reader", ["403", "/api/2.0/mlflow/runs/create", "admin"]),
    ],
)
def test_a_servers_refusal_is_a_readable_input_error(clean_env, code, user, words):
    from mlflow.exceptions import MlflowException
    from mlflow.protos import databricks_pb2

    if user:
        clean_env.setenv(c.USERNAME, user)
    clean_env.setenv(c.TRACKING_URI, "https://mlflow.example")

    def refused():
        raise MlflowException(
            "API request to endpoint /api/2.0/mlflow/runs/create failed with error code 4xx",
            error_code=getattr(databricks_pb2, code),
        )

    with pytest.raises(InputError) as err:
        retrying(refused)  # every store call of the project goes through it
    for word in words:
        assert word in str(err.value)
    assert c.access_error(ValueError("other")) is None
