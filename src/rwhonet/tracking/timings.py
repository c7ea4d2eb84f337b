"""When each training and adaptation run really ran: a sidecar kept out of DVC's outputs.

The model stages' outputs are byte-reproducible (a re-run leaves ``dvc.lock``
unchanged), so their run records (``run.json``) hold no clock time. Instead,
once a model stage has written a run's folder, it writes that run's start and
end time to ``mlruns/timings/<fingerprint>.json`` (gitignored, not a DVC
output), where the fingerprint is the SHA-256 of the folder's run record and
predictions. The ``evaluate`` stage looks every run up by the fingerprint of
the folder it reads and logs the run with those times.

A folder restored from the DVC cache has the bytes of the run that produced
it, so it finds that run's timing when it ran in this project (after a params
change was reverted, say); a folder whose timing was never recorded here (a
cache from elsewhere, a deleted ``mlruns/``) is logged at evaluate's time with
tag ``rwhonet.timing = not recorded``. In a queued DVC experiment the sidecars
go to the owning repository's ``mlruns/``, like the runs.

No MLflow here: the model stages import this module.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from rwhonet import contracts, paths
from rwhonet.tracking.client import main_repo_root
from rwhonet.tracking.records import Timing

TIMINGS = Path("mlruns") / "timings"
# The files that identify a run's output: the record (params, seed, per-epoch losses,
# counts) and what the model predicted.
FINGERPRINTED = (contracts.RUN_RECORD, contracts.PREDICTIONS)


def timings_dir(root: Path | None = None) -> Path:
    """``mlruns/timings`` of the repository that owns the store (see ``main_repo_root``)."""
    return main_repo_root(root or paths.ROOT) / TIMINGS


def fingerprint(folder: Path) -> str:
    """SHA-256 of a run folder's run record and predictions (those present), by name.

    Raises:
        FileNotFoundError: when the folder has none of them.
    """
    h = hashlib.sha256()
    found = 0
    for name in FINGERPRINTED:
        f = Path(folder) / name
        if f.is_file():
            found += 1
            h.update(name.encode() + b"\0" + f.read_bytes() + b"\0")
    if not found:
        raise FileNotFoundError(f"{paths.rel(folder)} has none of {FINGERPRINTED}")
    return h.hexdigest()


def write_timing(folder: Path, timing: Timing, *, stage: str, root: Path | None = None) -> Path:
    """Record when the run whose outputs are in ``folder`` ran (call after writing them).

    Args:
        folder: the run's output folder (``models/g/seed42``, ``models/r/seed42/head/m50``).
        timing: its start and end (epoch milliseconds).
        stage: the DVC stage that ran it (``adapt@42``, ``train (G seed 42)``), for people
            reading the file.
        root: the project root; defaults to :data:`rwhonet.paths.ROOT`.

    Returns:
        The sidecar file.
    """
    out = timings_dir(root) / f"{fingerprint(folder)}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    body = {
        "folder": paths.rel(folder),
        "stage": stage,
        "start_ms": timing.start_ms,
        "end_ms": timing.end_ms,
    }
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(body, indent=1) + "\n", encoding="utf-8")
    tmp.replace(out)  # a reader never sees half a file
    return out


def read_timing(folder: Path, *, root: Path | None = None) -> Timing | None:
    """The recorded start and end of the run in ``folder``, or None when there is none.

    None also when the sidecar cannot be read or makes no sense (end before start):
    a missing time must never stop the evaluation.
    """
    try:
        f = timings_dir(root) / f"{fingerprint(folder)}.json"
        body = json.loads(f.read_text(encoding="utf-8"))
        start, end = int(body["start_ms"]), int(body["end_ms"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return Timing(start, end) if 0 < start <= end else None
