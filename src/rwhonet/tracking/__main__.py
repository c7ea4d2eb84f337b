"""``python -m rwhonet.tracking``: the MLflow store's set-up.

``init``: create the store and experiment before any writer. A fresh SQLite
store races on its schema migration when two processes create it at once (two
runs of alembic's ALTER TABLE collide), e.g. under `dvc queue start -j 2`.

``team setup [MODEL ...]`` and ``team user NAME reader|editor``: the admin of a
team server gives the team its experiment, registered models and permissions
(:mod:`rwhonet.tracking.team`, docs/team.md). A new user's first password is
read from stdin, never from the command line (which other users of the machine
can read, and shells keep).
"""

import getpass
import sys

from rwhonet.libraries import quiet

USAGE = (
    "usage: python -m rwhonet.tracking init\n"
    "       python -m rwhonet.tracking team setup [MODEL ...]\n"
    "       python -m rwhonet.tracking team user NAME reader|editor   (first password on stdin)"
)


def main(argv: list[str]) -> int:
    if argv == ["init"]:
        return init()
    if argv[:2] == ["team", "setup"]:
        return team_setup(argv[2:])
    if argv[:2] == ["team", "user"] and len(argv) == 4 and argv[3] in ("reader", "editor"):
        return team_user(argv[2], argv[3])
    print(USAGE, file=sys.stderr)
    return 2


def _store() -> tuple:
    from rwhonet.config import load_params
    from rwhonet.tracking.store import resolve_tracking_uri

    params = load_params()
    return params, resolve_tracking_uri(params.tracking.tracking_uri)


def init() -> int:
    quiet()
    from rwhonet.tracking.store import ensure_experiment

    params, uri = _store()
    exp_id = ensure_experiment(uri, params.tracking.experiment)
    print(f"MLflow store {uri}, experiment '{params.tracking.experiment}' (id {exp_id})")
    view = headline_view(uri, exp_id)
    if view:
        print(f"Headline numbers of every execution (make ui): {view}")
    return 0


def team_setup(models: list[str]) -> int:
    quiet()
    from rwhonet.tracking.team import setup, team_models

    params, uri = _store()
    done = setup(uri, params.tracking.experiment, [*team_models(), *models])
    print(
        f"{uri}: experiment '{params.tracking.experiment}' (id {done['experiment_id']}), "
        f"registered models {', '.join(done['models'])}; roles {done['roles']}"
    )
    for line in done["added"]:
        print(f"  granted {line}")
    return 0


def team_user(name: str, role: str) -> int:
    quiet()
    from rwhonet.tracking.team import add_member

    _, uri = _store()
    if sys.stdin.isatty():
        password = getpass.getpass(f"first password for {name} (empty: the user exists): ")
    else:
        password = sys.stdin.readline().rstrip("\r\n")
    print(add_member(uri, name, password or None, role))
    return 0


def headline_view(uri: str, exp_id: str, base: str = "http://127.0.0.1:5000") -> str | None:
    """The address of the shared runs view ``evaluate`` saves, once it has saved one."""
    import mlflow

    from rwhonet.tracking.store import HEADLINE_VIEW, SHARED_VIEW_TAG, runs_view_url

    tags = mlflow.MlflowClient(tracking_uri=uri).get_experiment(exp_id).tags
    return runs_view_url(exp_id, base=base) if SHARED_VIEW_TAG + HEADLINE_VIEW in tags else None


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
