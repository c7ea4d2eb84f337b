"""Team mode: the pipeline and ``rwhonet`` on a tracking server that lets in only the team.

On localhost (:mod:`support.team`; PostgreSQL and nginx are installed from
Debian's packages on a CI machine that lacks them): PostgreSQL whose role logs
in with a password, ``mlflow server --app-name basic-auth --enable-workspaces``
on it (the admin's password from a secret, artifacts uploaded through the
server), and nginx in front with TLS (a self-signed certificate the clients
verify) and a plain-HTTP port that only redirects. The admin sets the team up
with ``python -m rwhonet.tracking team`` (docs/team.md): a reader and an
editor. The editor runs the pipeline with the password in
``$MLFLOW_TRACKING_URI``; a stage fails there; ``rwhonet recalibrate`` /
``predict`` / ``export`` use the registered models. Then every refusal: no
credentials (401), the old default admin password (401), a reader's and an
editor's writes and deletes (403), a tampered model file (``rwhonet predict``
exit 2), a wrong password (nothing half-written). Last, every logged value
(PostgreSQL's dump), every artifact and every file the project wrote is
searched for the secrets. Slow: a few minutes (docs/team.md).
"""

from __future__ import annotations

import io
import json
import math
import os
import secrets
import ssl
import subprocess
import sys
import time
import urllib.error
import urllib.request
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pytest
import yaml

from support.project import BIN, commit, dvc, env, scratch_project
from support.team import (
    Auth,
    Unavailable,
    mlflow_server,
    nginx_bin,
    postgres,
    postgres_bin,
    self_signed_certificate,
    tls_proxy,
)

pytestmark = pytest.mark.slow

OVERRIDES = {
    ("seeds",): [1],
    ("sim", "profile"): "ci",
    ("train", "epochs"): 3,
    ("adapt", "epochs"): 5,
    ("adapt", "m_grid"): [10, 20],
    ("adapt", "recipes"): ["paper", "radius+G"],
    ("adapt", "fallback", "recipe"): "radius+G",
    ("adapt", "fallback", "m"): 20,
    ("evaluate", "outages_s"): [30, 180],
}
EXPERIMENT = "rwhonet"
# Registry to prediction in a fresh interpreter that refuses every unpickling: Python raises
# the audit event pickle.find_class whenever any unpickler (pickle, _pickle, cloudpickle,
# torch's) resolves a class or function by name, which is how a pickle runs code.
LOAD_AND_PREDICT = """
import sys
unpickled = []
def no_pickle(event, args):
    if event == "pickle.find_class":
        unpickled.append(list(args))
        raise RuntimeError(f"unpickling {args}")
sys.addaudithook(no_pickle)
import json, tempfile
from pathlib import Path
from mlflow.models import Model
from rwhonet.cli.main import main
from rwhonet.tracking.registry import fetch_model, load_pyfunc
uri, spec, drive, out = sys.argv[1], f"models:/{sys.argv[2]}/1", sys.argv[3], sys.argv[4]
said = main(["predict", "--model", spec, "--drive", drive, "--output", out])
local, _ = fetch_model(spec, uri, Path(tempfile.mkdtemp()))
example = Model.load(str(local)).load_input_example(str(local))
pred = load_pyfunc(spec, uri).predict(example)["pred_m"].tolist()
print(json.dumps({"predict": said, "pred": pred, "unpickled": unpickled}))
"""
COST: dict[str, float] = {}  # seconds, printed at the end (pytest -s)


def _secret() -> str:
    return secrets.token_urlsafe(18)


def _need(find):
    try:
        return find()
    except Unavailable as why:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI must run team mode: {why}")  # a skip would hide it there
        pytest.skip(str(why))


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """The team server behind TLS, its secrets, and where it keeps things; stopped afterwards."""
    pg_bin, nginx = _need(postgres_bin), _need(nginx_bin)
    artifacts = tmp_path_factory.mktemp("team-server") / "artifacts"
    auth = Auth(admin_password=_secret(), flask_secret=_secret())
    db_password = _secret()
    start = time.monotonic()
    with (
        postgres(pg_bin, db_password) as db,
        mlflow_server(db, artifacts, auth) as direct,
        tls_proxy(nginx, direct) as proxy,
    ):
        COST["servers up (PostgreSQL, mlflow server, nginx)"] = time.monotonic() - start
        yield {
            "uri": proxy.https,
            "http": proxy.http,
            "cert": proxy.cert,
            "direct": direct,
            "db": db,
            "pg_bin": pg_bin,
            "db_password": db_password,
            "auth": auth,
            "artifacts": artifacts,
            "users": {"admin": auth.admin_password},
        }
        stop = time.monotonic()
    COST["servers stopped"] = time.monotonic() - stop
    print("\nteam server test costs (s): " + ", ".join(f"{k}: {v:.1f}" for k, v in COST.items()))


def login(server, user: str | None, password: str | None = None, **extra: str) -> dict:
    """The environment of a client of the server: its address, certificate, login."""
    out = {
        "MLFLOW_TRACKING_URI": server["uri"],
        "MLFLOW_TRACKING_SERVER_CERT_PATH": str(server["cert"]),
        "MLFLOW_HTTP_REQUEST_MAX_RETRIES": "0",
    }
    if user is not None:
        out["MLFLOW_TRACKING_USERNAME"] = user
        out["MLFLOW_TRACKING_PASSWORD"] = password or server["users"][user]
    return out | extra


@contextmanager
def acting_as(server, user: str | None, password: str | None = None):
    """This process's MLflow clients log in as ``user`` for the block."""
    names = [
        "MLFLOW_TRACKING_URI",
        "MLFLOW_TRACKING_SERVER_CERT_PATH",
        "MLFLOW_HTTP_REQUEST_MAX_RETRIES",
        "MLFLOW_TRACKING_USERNAME",
        "MLFLOW_TRACKING_PASSWORD",
    ]
    saved = {n: os.environ.get(n) for n in names}
    for n in names:
        os.environ.pop(n, None)
    os.environ.update(login(server, user, password))
    try:
        yield
    finally:
        for n, v in saved.items():
            if v is None:
                os.environ.pop(n, None)
            else:
                os.environ[n] = v


def run(repo: Path, who: dict, *cmd: str, stdin: str | None = None, timeout: float = 900):
    """A command in the scratch project as a client ``who`` (:func:`login`)."""
    return subprocess.run(
        list(cmd),
        cwd=repo,
        env=env(repo, **who),
        input=stdin,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.fixture(scope="module")
def repo(tmp_path_factory, ci_data):
    return scratch_project(tmp_path_factory.mktemp("team") / "repo", OVERRIDES, ci_data)


@pytest.fixture(scope="module")
def team(server, repo):
    """The admin's set-up (docs/team.md): experiment, models, roles; a reader and an editor."""
    start = time.monotonic()
    admin = login(server, "admin")
    said = run(repo, admin, sys.executable, "-m", "rwhonet.tracking", "team", "setup")
    assert said.returncode == 0, said.stdout + said.stderr
    for user in ("reader", "editor"):
        server["users"][user] = _secret()
        added = run(
            repo,
            admin,
            sys.executable,
            "-m",
            "rwhonet.tracking",
            "team",
            "user",
            user,
            user,
            stdin=server["users"][user] + "\n",
        )
        assert added.returncode == 0, added.stdout + added.stderr
        assert f"created user '{user}'" in added.stdout
    COST["team set-up (3 commands)"] = time.monotonic() - start
    return said.stdout


@pytest.fixture(scope="module")
def project(server, repo, team):
    """The editor's pipeline run, with the password in the URI and other secrets around."""
    vault_key = _secret()
    for args in (
        ("remote", "add", "--local", "vault", "s3://rwhonet-vault/cache"),
        # "--": a URL-safe token starts with "-" one time in 64, which DVC's parser
        # would take for an option (it did once, in CI)
        ("remote", "modify", "--local", "vault", "secret_access_key", "--", vault_key),
    ):
        assert dvc(repo, *args).returncode == 0
    host = server["uri"].removeprefix("https://")
    editor = {
        "MLFLOW_TRACKING_URI": f"https://editor:{server['users']['editor']}@{host}",
        "MLFLOW_TRACKING_SERVER_CERT_PATH": str(server["cert"]),
        "AWS_SECRET_ACCESS_KEY": _secret(),  # an environment credential of the machine
    }
    start = time.monotonic()
    init = run(repo, editor, sys.executable, "-m", "rwhonet.tracking", "init")
    assert init.returncode == 0, init.stdout + init.stderr
    repro = run(repo, editor, str(BIN / "dvc"), "repro")
    assert repro.returncode == 0, repro.stdout + repro.stderr
    COST["editor's init and dvc repro"] = time.monotonic() - start
    return {
        "repo": repo,
        "init": init.stdout,
        "repro": repro.stdout,
        "repro_err": repro.stderr,
        "secrets": [vault_key, editor["AWS_SECRET_ACCESS_KEY"]],
    }


@pytest.fixture(scope="module")
def client(server):
    from mlflow import MlflowClient

    return MlflowClient(server["uri"])


def runs(server, client, filter_string: str = "") -> list:
    with acting_as(server, "admin"):
        exp = client.get_experiment_by_name(EXPERIMENT)
        return list(client.search_runs([exp.experiment_id], filter_string, max_results=5000))


def status_of(url: str, *, cert: Path | None = None, auth: tuple[str, str] | None = None):
    """``(HTTP status, headers)`` of a GET (headers: case-insensitive), redirects not followed."""
    import base64

    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *args, **kwargs):
            return None

    handlers = [NoRedirect()]
    if cert is not None:
        handlers.append(
            urllib.request.HTTPSHandler(context=ssl.create_default_context(cafile=str(cert)))
        )
    request = urllib.request.Request(url)
    if auth is not None:
        token = base64.b64encode(f"{auth[0]}:{auth[1]}".encode()).decode()
        request.add_header("Authorization", f"Basic {token}")
    try:
        with urllib.request.build_opener(*handlers).open(request, timeout=30) as r:
            return r.status, r.headers
    except urllib.error.HTTPError as err:
        return err.code, err.headers


SEARCH = "/api/2.0/mlflow/experiments/search?max_results=10"


# --------------------------------------------------------------------------- the front door


def test_plain_http_to_the_proxy_only_redirects_to_https(server):
    for path in ("/health", SEARCH):
        code, headers = status_of(server["http"] + path)
        assert code == 301 and headers["Location"] == server["uri"] + path


def test_clients_verify_the_servers_certificate(server, client, tmp_path):
    from mlflow.exceptions import MlflowException

    # another self-signed certificate for the same name: what a machine in the middle shows
    other, _ = self_signed_certificate(tmp_path)
    for cert in (None, other):
        with pytest.raises(urllib.error.URLError, match="CERTIFICATE_VERIFY_FAILED"):
            status_of(server["uri"] + "/health", cert=cert)
    with acting_as(server, "admin"):
        os.environ.pop("MLFLOW_TRACKING_SERVER_CERT_PATH")
        with pytest.raises(MlflowException, match="CERTIFICATE_VERIFY_FAILED"):
            client.search_experiments()
        os.environ["MLFLOW_TRACKING_SERVER_CERT_PATH"] = str(other)
        with pytest.raises(MlflowException, match="CERTIFICATE_VERIFY_FAILED"):
            client.search_experiments()
    assert status_of(server["uri"] + "/health", cert=server["cert"])[0] == 200


def test_no_credentials_or_the_old_default_password_get_401(server):
    url = server["uri"] + SEARCH
    code, headers = status_of(url, cert=server["cert"])
    assert code == 401 and headers.get("WWW-Authenticate", "").startswith("Basic")
    for password in ("password1234", "not-the-password"):
        assert status_of(url, cert=server["cert"], auth=("admin", password))[0] == 401
    admin = ("admin", server["auth"].admin_password)
    assert status_of(url, cert=server["cert"], auth=admin)[0] == 200


@pytest.mark.parametrize(
    ("password", "said"),
    [("", "ships no default admin password"), ("password1234", "insecure default password")],
)
def test_the_server_will_not_start_without_the_admins_secret_or_with_the_default(
    tmp_path, password, said
):
    """The first start creates the admin from MLFLOW_AUTH_ADMIN_PASSWORD, or refuses to start."""
    artifacts = tmp_path / "artifacts"
    auth = Auth(admin_password=password, flask_secret=_secret())
    backend = f"sqlite:///{tmp_path}/mlflow.db"  # an empty user store, as at a team's first start
    with pytest.raises(RuntimeError, match="exited") as err:
        with mlflow_server(backend, artifacts, auth, start_timeout_s=180):
            pass
    assert said in str(err.value)


# --------------------------------------------------------------------------- the editor's run


def test_the_admin_sets_up_the_team_with_per_resource_grants(team):
    assert "registered models whonet-G, whonet-S, whonet-R-target" in team
    for role, grant in (("rwhonet-readers", "READ"), ("rwhonet-editors", "EDIT")):
        assert f"granted {role}: {grant} on registered_model whonet-G" in team
        assert f"granted {role}: {grant} on experiment" in team


def test_init_creates_the_experiment_on_the_server(server, project, client):
    # the URI is printed without the password that came in it
    assert f"MLflow store {server['uri']}, experiment '{EXPERIMENT}'" in project["init"]
    with acting_as(server, "editor"):
        exp = client.get_experiment_by_name(EXPERIMENT)
    assert exp.tags["mlflow.experimentKind"] == "custom_model_development"
    # the server chose where artifacts go (proxied), not the project's mlruns/
    assert exp.artifact_location.startswith("mlflow-artifacts:")
    assert not (project["repo"] / "mlruns" / "mlflow.db").exists()
    # MLflow's per-run links and registry notes stay out of the stage's output
    assert "View run" not in project["repro"] and "Waiting up to" not in project["repro_err"]


def test_the_pipeline_logs_runs_metrics_and_artifacts_through_the_server(server, project, client):
    import psycopg

    (parent,) = runs(server, client, "tags.model = 'pipeline'")
    family = runs(
        server, client, f"tags.`rwhonet.execution` = '{parent.data.tags['rwhonet.execution']}'"
    )
    assert len(family) > 10 and {r.info.status for r in family} == {"FINISHED"}
    children = [r for r in family if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id]
    by_name = {r.info.run_name: r for r in children}
    g = by_name["G-WhONet seed 1"]
    assert g.data.metrics["crse/180s/mean"] > 0 and g.data.params["train.epochs"] == "3"
    with acting_as(server, "reader"):  # a reader reads runs, metrics and artifacts
        history = client.get_metric_history(g.info.run_id, "train/loss")
        listed = {a.path for a in client.list_artifacts(parent.info.run_id)}
        local = client.download_artifacts(
            parent.info.run_id, "eval.json", str(project["repo"] / "dl")
        )
        assert "model.pt" in {a.path for a in client.list_artifacts(g.info.run_id)}
    assert [m.step for m in history] == [0, 1, 2]
    assert parent.data.metrics and parent.data.params["sim.profile"] == "ci"
    assert {"eval.json", "tables.md"} <= listed
    assert Path(local).read_bytes() == (project["repo"] / "metrics" / "eval.json").read_bytes()
    # with workspaces on, the server files artifacts under workspaces/<workspace>/
    stored = server["artifacts"] / "workspaces" / "default" / parent.info.experiment_id
    assert (stored / parent.info.run_id / "artifacts" / "eval.json").is_file()

    # and PostgreSQL is the store the server keeps them in
    with psycopg.connect(server["db"]) as db:
        (n_runs,) = db.execute("SELECT count(*) FROM runs").fetchone()
    assert n_runs == len(runs(server, client)) >= len(family)


def test_the_pipeline_registers_models_without_code_that_a_reader_loads(
    project, server, client, tmp_path
):
    from rwhonet.tracking.registry import FILES_TAG

    with acting_as(server, "reader"):
        names = {m.name for m in client.search_registered_models()}
        r = client.get_model_version("whonet-R-target", "1")
        chosen = client.get_run(r.run_id).data.tags["chosen"]
    assert {"whonet-G", "whonet-S", "whonet-R-target"} <= names
    assert (r.tags["recipe"], r.tags["m"], r.tags["seed"]) == ("radius+G", "20", "1")
    assert r.status == "READY" and chosen == "true"
    files = json.loads(r.tags[FILES_TAG])
    assert {"artifacts/model.onnx", "artifacts/model.safetensors"} <= set(files)
    assert not [f for f in files if f.endswith((".pkl", ".pt"))], files  # weights without pickle
    stored = list(server["artifacts"].rglob("*.pkl"))
    assert not stored, stored  # no pickle anywhere in the artifact store
    # A reader loads it by name, logged in from MLflow's credentials file in a home folder
    # outside the repository (no password in the environment): downloaded through the
    # server, checked, served by `rwhonet predict` and as a pyfunc, and nothing unpickled.
    home = tmp_path / "home"
    (home / ".mlflow").mkdir(parents=True)
    credentials = home / ".mlflow" / "credentials"
    credentials.touch(mode=0o600)
    credentials.write_text(
        "[mlflow]\nmlflow_tracking_username = reader\n"
        f"mlflow_tracking_password = {server['users']['reader']}\n"
    )
    reader = login(server, None, HOME=str(home))
    drive = sorted((project["repo"] / "data" / "sim" / "target_test").glob("*.csv"))[0]
    out_csv = tmp_path / "predicted.csv"
    load = run(
        project["repo"],
        reader,
        sys.executable,
        "-c",
        LOAD_AND_PREDICT,
        server["uri"],
        "whonet-G",
        str(drive),
        str(out_csv),
    )
    assert load.returncode == 0, load.stderr
    said = json.loads(load.stdout.splitlines()[-1])
    assert said["unpickled"] == [] and said["predict"] == 0, load.stderr
    assert len(pd.read_csv(out_csv)) > 280
    assert len(said["pred"]) == 5 and all(math.isfinite(p) for p in said["pred"])


# --------------------------------------------------------------------------- who may do what


def refused(call) -> int:
    """The HTTP status a refused MLflow call got (401 / 403), or 0 when it went through.

    Artifact uploads go to the server's artifact proxy, whose refusal is an HTTP error.
    """
    from mlflow.exceptions import MlflowException
    from requests.exceptions import HTTPError

    try:
        call()
    except MlflowException as err:
        return {"UNAUTHENTICATED": 401, "PERMISSION_DENIED": 403}.get(err.error_code, -1)
    except HTTPError as err:
        return err.response.status_code if err.response is not None else -1
    return 0


def test_a_reader_is_refused_logging_registering_deleting_and_managing(
    project, server, client, tmp_path
):
    from rwhonet.tracking.team import auth_client

    (parent,) = runs(server, client, "tags.model = 'pipeline'")
    rid, exp_id = parent.info.run_id, parent.info.experiment_id
    g = "whonet-G"
    auth = auth_client(server["uri"])
    note = tmp_path / "note.txt"
    note.write_text("a reader's file")
    graph = tmp_path / "model.onnx"  # named as a registered version's graph
    graph.write_bytes(b"not the registered graph")
    with acting_as(server, "reader"):
        g1 = client.get_model_version(g, "1")
        source = g1.source
        assert refused(lambda: client.get_run(rid)) == 0  # reads
        attempts = {
            "create a run": lambda: client.create_run(exp_id),
            "log a param": lambda: client.log_param(rid, "sneaky", "1"),
            "log a metric": lambda: client.log_metric(rid, "sneaky", 1.0),
            "log an artifact": lambda: client.log_artifact(rid, str(note)),
            "overwrite a version's file": lambda: client.log_artifact(
                g1.run_id, str(graph), "model/artifacts"
            ),
            "register a version": lambda: client.create_model_version(g, source, rid),
            "delete a run": lambda: client.delete_run(rid),
            "delete a version": lambda: client.delete_model_version(g, "1"),
            "delete a model": lambda: client.delete_registered_model(g),
            "create a model": lambda: client.create_registered_model("whonet-R-squatter"),
            "create an experiment": lambda: client.create_experiment("readers-own"),
            "create a user": lambda: auth.create_user("mallory", _secret()),
            "grant itself EDIT": lambda: auth.grant_user_permission(
                "reader", "experiment", exp_id, "EDIT"
            ),
        }
        got = {what: refused(call) for what, call in attempts.items()}
    assert got == {what: 403 for what in attempts}
    assert "sneaky" not in runs(server, client, f"attributes.run_id = '{rid}'")[0].data.params
    assert not list(server["artifacts"].rglob(note.name))


def test_an_editor_is_refused_deleting_creating_and_managing(project, server, client):
    from rwhonet.tracking.team import auth_client

    (parent,) = runs(server, client, "tags.model = 'pipeline'")
    auth = auth_client(server["uri"])
    with acting_as(server, "editor"):
        got = {
            "delete a run": refused(lambda: client.delete_run(parent.info.run_id)),
            "delete a version": refused(lambda: client.delete_model_version("whonet-G", "1")),
            "delete a model": refused(lambda: client.delete_registered_model("whonet-S")),
            "create a model": refused(lambda: client.create_registered_model("whonet-R-car7")),
            "create an experiment": refused(lambda: client.create_experiment("editors-own")),
            "create a user": refused(lambda: auth.create_user("mallory", _secret())),
            "grant a reader EDIT": refused(
                lambda: auth.grant_user_permission(
                    "reader", "experiment", parent.info.experiment_id, "EDIT"
                )
            ),
        }
    assert got == dict.fromkeys(got, 403)


def test_team_setup_is_idempotent_and_a_member_changes_role(server, team):
    from rwhonet.tracking.team import ROLES, add_member, auth_client, setup, team_models

    with acting_as(server, "admin"):
        again = setup(server["uri"], EXPERIMENT, team_models())
        assert again["added"] == []  # nothing twice
        said = add_member(server["uri"], "reader", None, "editor")
        roles = {r.name for r in auth_client(server["uri"]).list_user_roles("reader")}
        add_member(server["uri"], "reader", None, "reader")
        back = {r.name for r in auth_client(server["uri"]).list_user_roles("reader")}
    assert said == "updated user 'reader': editor (rwhonet-editors)"
    assert ROLES["editor"] in roles and ROLES["reader"] not in roles
    assert ROLES["reader"] in back and ROLES["editor"] not in back


def test_an_editor_registers_only_into_models_the_admin_set_up(server, team, client):
    from rwhonet.errors import InputError
    from rwhonet.tracking.registry import _ensure_registered_model

    with acting_as(server, "editor"), pytest.raises(InputError) as err:
        _ensure_registered_model(client, "whonet-R-car7")  # what log_bundle does first
    assert "python -m rwhonet.tracking team setup whonet-R-car7" in str(err.value)


# --------------------------------------------------------------------------- the team's work


def test_a_teammate_pulls_the_pipeline_outputs_from_a_dvc_remote(project, tmp_path):
    repo, clone = project["repo"], tmp_path / "clone"
    commit(repo, "pipeline outputs")
    added = dvc(repo, "remote", "add", "-d", "team", str(tmp_path / "dvc-remote"))
    assert added.returncode == 0, added.stderr
    commit(repo, "team remote")  # .dvc/config: a clone finds the remote
    pushed = dvc(repo, "push")
    assert pushed.returncode == 0, pushed.stdout + pushed.stderr
    subprocess.run(["git", "clone", "-q", str(repo), str(clone)], check=True)
    pulled = dvc(clone, "pull")
    assert pulled.returncode == 0, pulled.stdout + pulled.stderr
    status = dvc(clone, "status")
    assert "Data and pipelines are up to date" in status.stdout, status.stdout + status.stderr
    assert (clone / "models").is_dir()
    for f in ("metrics/eval.json", "models/g/seed1/model.pt"):
        assert (clone / f).read_bytes() == (repo / f).read_bytes(), f


def test_a_failed_stage_logs_its_run_and_artifacts_on_the_server(project, server, client):
    repo = project["repo"]
    params = repo / "params.yaml"
    original = params.read_text()
    broken = yaml.safe_load(original)
    broken["evaluate"]["no_such_key"] = 1  # the typed loader stops on it
    params.write_text(yaml.safe_dump(broken, sort_keys=False))
    try:
        out = run(repo, login(server, "editor"), sys.executable, "pipelines/evaluate.py")
    finally:
        params.write_text(original)
    assert out.returncode == 2, out.stdout + out.stderr
    assert "MLflow: FAILED run" in out.stderr and server["uri"] in out.stderr
    (failed,) = runs(server, client, "tags.`rwhonet.failure` = 'true'")
    assert failed.info.status == "FAILED" and failed.data.tags["dvc_stage"] == "evaluate"
    with acting_as(server, "reader"):
        listed = {a.path for a in client.list_artifacts(failed.info.run_id, "failure")}
    assert {"failure/error.txt", "failure/params.yaml"} <= listed


def test_rwhonet_recalibrates_predicts_and_exports_from_the_servers_registry(
    project, server, client
):
    from rwhonet.serve.model import load_served

    repo = project["repo"]
    drive = sorted((repo / "data" / "sim" / "target_test").glob("*.csv"))[0]
    cli = [str(BIN / "rwhonet")]
    said = run(
        repo,
        login(server, "editor"),
        *cli,
        "recalibrate",
        "--base",
        "models:/whonet-G/latest",
        "--drive",
        str(drive),
        "--seconds",
        "50",
    )
    assert said.returncode == 0, said.stdout + said.stderr
    assert "registered whonet-R-target version 2" in said.stdout
    with acting_as(server, "reader"):
        version = client.get_model_version("whonet-R-target", "2")
    assert version.tags["base_version"] == "whonet-G v1" and version.tags["m"] == "50"

    reader = login(server, "reader")  # serving a model needs no more than READ
    out = run(
        repo,
        reader,
        *cli,
        "predict",
        "--model",
        "models:/whonet-R-target/2",
        "--drive",
        str(drive),
        "--outage",
        "100:280",
        "--output",
        "-",
    )
    assert out.returncode == 0, out.stderr
    streamed = pd.read_csv(io.StringIO(out.stdout))  # stdout holds the CSV and nothing else
    assert len(streamed) > 280 and streamed["pred_error_m"].notna().all()
    assert "outage 100:280 s (180 s" in out.stderr

    onnx = project["repo"] / "r2.onnx"
    out = run(
        repo, reader, *cli, "export", "--model", "models:/whonet-R-target/2", "--output", str(onnx)
    )
    assert out.returncode == 0, out.stderr
    assert load_served(onnx).meta.info["recipe"] == version.tags["recipe"]


# --------------------------------------------------------------------------- what is refused


def test_a_tampered_artifact_is_refused_by_predict(project, server, client):
    repo = project["repo"]
    with acting_as(server, "reader"):
        version = client.get_model_version("whonet-G", "1")
    # mlflow-artifacts:/workspaces/default/<exp>/<run>/artifacts/model: the server's folder
    stored = server["artifacts"] / version.source.removeprefix("mlflow-artifacts:/")
    onnx = stored / "artifacts" / "model.onnx"
    original = onnx.read_bytes()
    onnx.write_bytes(original + b"\0")  # one byte: someone with write access to the store
    out_csv = repo / "tampered.csv"
    drive = sorted((repo / "data" / "sim" / "target_test").glob("*.csv"))[0]
    try:
        said = run(
            repo,
            login(server, "reader"),
            str(BIN / "rwhonet"),
            "predict",
            "--model",
            "models:/whonet-G/1",
            "--drive",
            str(drive),
            "--output",
            str(out_csv),
        )
    finally:
        onnx.write_bytes(original)
    assert said.returncode == 2, said.stdout + said.stderr
    assert "whonet-G version 1" in said.stderr and "artifacts/model.onnx" in said.stderr
    assert "Traceback" not in said.stderr and not out_csv.exists()


def test_a_failed_login_leaves_nothing_half_written(project, server, client):
    repo = project["repo"]
    wrong = login(server, "editor", "not-the-editors-password")
    before_runs = len(runs(server, client))
    with acting_as(server, "admin"):
        before_versions = len(client.search_model_versions("name = 'whonet-R-target'"))
    lock = (repo / "dvc.lock").read_bytes()
    drive = sorted((repo / "data" / "sim" / "target_test").glob("*.csv"))[0]
    out_csv = repo / "wrong-login.csv"
    said = {
        "evaluate": run(repo, wrong, sys.executable, "pipelines/evaluate.py"),
        "recalibrate": run(repo, wrong, str(BIN / "rwhonet"), "recalibrate", "--drive", str(drive)),
        "predict": run(
            repo,
            wrong,
            str(BIN / "rwhonet"),
            "predict",
            "--model",
            "models:/whonet-G/1",
            "--drive",
            str(drive),
            "--output",
            str(out_csv),
        ),
    }
    for what, out in said.items():
        assert out.returncode == 2, (what, out.stdout + out.stderr)
        assert "401" in out.stderr and "'editor'" in out.stderr, (what, out.stderr)
        assert "not-the-editors-password" not in out.stdout + out.stderr
    assert len(runs(server, client)) == before_runs  # no run, not even a FAILED one
    assert not runs(server, client, "attributes.status = 'RUNNING'")
    with acting_as(server, "admin"):
        assert len(client.search_model_versions("name = 'whonet-R-target'")) == before_versions
    assert (repo / "dvc.lock").read_bytes() == lock and not out_csv.exists()


def test_no_secret_is_logged_or_written_anywhere(project, server):
    """Every value in both databases, every artifact, every file and commit of the project."""
    repo = project["repo"]
    found_in = []
    secret_list = [
        *project["secrets"],
        server["db_password"],
        server["auth"].admin_password,
        server["auth"].flask_secret,
        *(server["users"][u] for u in ("reader", "editor")),
    ]
    needles = [s.encode() for s in secret_list]
    for db in ("mlflow", "mlflow_auth"):  # all params, tags, metrics, runs, users (hashed)
        uri = server["db"].rsplit("/", 1)[0] + "/" + db
        dump = subprocess.run(
            [str(server["pg_bin"] / "pg_dump"), "--data-only", uri],
            capture_output=True,
            check=True,
            timeout=120,
        ).stdout
        assert b"whonet-G" in dump or db == "mlflow_auth"
        found_in += [f"database {db}" for n in needles if n in dump]
    files = [p for p in server["artifacts"].rglob("*") if p.is_file()]
    files += [
        p
        for p in repo.rglob("*")
        if p.is_file()
        and p.relative_to(repo).parts[0] != ".git"  # its history is searched below
        and p != repo / ".dvc" / "config.local"  # where the DVC remote's key belongs
    ]
    assert any(p.name == "dvc.lock" for p in files) and len(files) > 100
    for path in files:
        data = path.read_bytes()
        found_in += [str(path) for n in needles if n in data]
    history = subprocess.run(
        ["git", "log", "--all", "-p", "--no-color"], cwd=repo, capture_output=True, check=True
    ).stdout
    found_in += ["git history" for n in needles if n in history]
    assert not found_in, sorted(set(found_in))
