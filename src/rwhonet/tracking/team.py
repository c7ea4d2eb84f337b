"""Who may do what on a team's tracking server: two roles, per experiment and registered model.

The server is ``mlflow server --app-name basic-auth --enable-workspaces``
(docs/team.md): every request needs a user's login; with workspaces on, a user
creates nothing (experiment, registered model) without a workspace-wide grant,
which nobody but the admin holds. The admin runs :func:`setup` once, and again
for a new vehicle's ``whonet-R-<vehicle>``; then :func:`add_member` per person:

============================  ========  ========  =======
what                          reader    editor    admin
============================  ========  ========  =======
read runs, metrics, artifacts  yes       yes       yes
load a registered model        yes       yes       yes
log runs (the pipeline)        no (403)  yes       yes
register a version             no (403)  yes       yes
delete runs, versions, models  no (403)  no (403)  yes
create experiments, models     no (403)  no (403)  yes
manage users and permissions   no (403)  no (403)  yes
============================  ========  ========  =======

A role holds one grant per resource (:data:`READER` / :data:`EDITOR` on the
project's experiment and on each registered model by name), so a model the admin
has not set up is nobody's to register into. The admin's own password is set on
the server's first start from a secret (``MLFLOW_AUTH_ADMIN_PASSWORD``); MLflow
3.17 has no default password and refuses the old ``password1234``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from rwhonet.tracking.client import open_store, retrying
from rwhonet.tracking.registry import registered_name

WORKSPACE = "default"  # MLflow's workspace when a client names none
ROLES = {"reader": "rwhonet-readers", "editor": "rwhonet-editors"}
GRANTS = {"reader": "READ", "editor": "EDIT"}  # MLflow's permissions; MANAGE stays the admin's
DEFAULT_VEHICLES = ("target",)


def team_models(vehicles: Iterable[str] = DEFAULT_VEHICLES) -> list[str]:
    """The registered models the pipeline and ``rwhonet recalibrate`` write to."""
    return [registered_name("G"), registered_name("S")] + [
        registered_name("R", v) for v in vehicles
    ]


def auth_client(uri: str) -> Any:
    """MLflow's client of the basic-auth app's REST API (users, roles, grants)."""
    import warnings

    with warnings.catch_warnings():  # the server's own modules, imported for their routes
        warnings.simplefilter("ignore")  # starlette.middleware.wsgi is deprecated (3.17.2)
        from mlflow.server import get_app_client

        return get_app_client("basic-auth", tracking_uri=uri)


def _role(auth: Any, name: str) -> Any:
    for role in retrying(lambda: auth.list_roles(WORKSPACE)):
        if role.name == name:
            return role
    return retrying(
        lambda: auth.create_role(WORKSPACE, name, description=f"rwhonet {name} (docs/team.md)")
    )


def setup(uri: str, experiment: str, models: Iterable[str]) -> dict[str, Any]:
    """Create the experiment, the registered models and the two roles with their grants.

    Idempotent: what exists is kept, what is missing is added. Run as the admin.

    Args:
        uri: the server (``https://...``); the admin's credentials in the environment.
        experiment: ``tracking.experiment``.
        models: registered model names (:func:`team_models`).

    Returns:
        ``{"experiment_id", "models", "roles": {role: role id}, "added": [grants added]}``.
    """
    from mlflow.exceptions import MlflowException

    client, exp_id = open_store(uri, experiment)
    models = list(dict.fromkeys(models))
    for name in models:
        try:
            retrying(lambda name=name: client.create_registered_model(name))
        except MlflowException as err:
            if err.error_code != "RESOURCE_ALREADY_EXISTS":
                raise
    auth = auth_client(uri)
    roles, added = {}, []
    for member, role_name in ROLES.items():
        role = _role(auth, role_name)
        roles[member] = role.id
        have = {
            (p.resource_type, p.resource_pattern, p.permission)
            for p in retrying(lambda role=role: auth.list_role_permissions(role.id))
        }
        want = [("experiment", str(exp_id), GRANTS[member])]
        want += [("registered_model", name, GRANTS[member]) for name in models]
        for grant in want:
            if grant not in have:
                retrying(lambda grant=grant, role=role: auth.add_role_permission(role.id, *grant))
                added.append(f"{role_name}: {grant[2]} on {grant[0]} {grant[1]}")
    return {"experiment_id": str(exp_id), "models": models, "roles": roles, "added": added}


def add_member(uri: str, username: str, password: str | None, role: str) -> str:
    """Create a user (when missing) and give them exactly one of the two roles.

    Args:
        uri: the server; the admin's credentials in the environment.
        username: the member's login.
        password: their first password (at least 12 characters; they change it
            themselves afterwards); None for a user who exists.
        role: ``reader`` or ``editor``.

    Returns:
        What was done, in a sentence.

    Raises:
        ValueError: an unknown role, or a new user without a password.
    """
    from mlflow.exceptions import MlflowException

    if role not in ROLES:
        raise ValueError(f"role must be one of {sorted(ROLES)}, got {role!r}")
    auth = auth_client(uri)
    try:
        retrying(lambda: auth.get_user(username))
        created = False
    except MlflowException as err:
        if err.error_code != "RESOURCE_DOES_NOT_EXIST":
            raise
        if not password:
            raise ValueError(f"user {username!r} does not exist: give a first password") from None
        retrying(lambda: auth.create_user(username, password))
        created = True
    wanted = {_role(auth, name).id: member for member, name in ROLES.items()}
    held = {r.id for r in retrying(lambda: auth.list_user_roles(username))}
    for role_id, member in wanted.items():
        if member == role and role_id not in held:
            retrying(lambda role_id=role_id: auth.assign_role(username, role_id))
        elif member != role and role_id in held:
            retrying(lambda role_id=role_id: auth.unassign_role(username, role_id))
    return f"{'created' if created else 'updated'} user {username!r}: {role} ({ROLES[role]})"
