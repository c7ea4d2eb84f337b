"""``python -m rwhonet.tracking init``: create the MLflow store and experiment before any writer.

A fresh SQLite store races on its schema migration when two processes create
it at once (two runs of alembic's ALTER TABLE collide), e.g. under
`dvc queue start -j 2`.
"""

import sys

from rwhonet.libraries import quiet


def main(argv: list[str]) -> int:
    if argv != ["init"]:
        print("usage: python -m rwhonet.tracking init", file=sys.stderr)
        return 2
    quiet()
    from rwhonet.config import load_params
    from rwhonet.tracking.store import ensure_experiment, resolve_tracking_uri

    params = load_params()
    uri = resolve_tracking_uri(params.tracking.tracking_uri)
    exp_id = ensure_experiment(uri, params.tracking.experiment)
    print(f"MLflow store {uri}, experiment '{params.tracking.experiment}' (id {exp_id})")
    view = headline_view(uri, exp_id)
    if view:
        print(f"Headline numbers of every execution (make ui): {view}")
    return 0


def headline_view(uri: str, exp_id: str, base: str = "http://127.0.0.1:5000") -> str | None:
    """The address of the shared runs view ``evaluate`` saves, once it has saved one."""
    import mlflow

    from rwhonet.tracking.store import HEADLINE_VIEW, SHARED_VIEW_TAG, runs_view_url

    tags = mlflow.MlflowClient(tracking_uri=uri).get_experiment(exp_id).tags
    return runs_view_url(exp_id, base=base) if SHARED_VIEW_TAG + HEADLINE_VIEW in tags else None


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
