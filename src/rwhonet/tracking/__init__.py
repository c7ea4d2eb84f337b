"""MLflow: the project's store, run records, the Model Registry and a team's server.

- ``client``: where the store is and how to open it safely from several processes;
- ``credentials``: a team server's credentials, from the environment or a file, never logged;
- ``records``: the run record the model stages write as JSON (no MLflow import);
- ``store``: logging a pipeline execution's runs, the headline view;
- ``registry``: G, S and R as registered models from code, checked by their files' SHA-256;
- ``failure``: a failed or interrupted stage's FAILED or KILLED run;
- ``timings``: when each training and adaptation run really ran (a sidecar);
- ``team``: a team server's users, roles and permissions.

``python -m rwhonet.tracking init`` creates the store; ``... team`` manages a team server.
"""
