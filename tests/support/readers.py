"""Ingest's reader and predict's side by side, for tests that expect them to agree."""

from __future__ import annotations

import io
from pathlib import Path

from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.errors import InputError


def refusals(path: Path) -> list[InputError]:
    """What ingest's IO-VNBD reader and predict's (the file read block by block) refuse
    the file with; each must refuse it."""
    out = []
    for read in (
        lambda: read_iovnbd(path),
        lambda: list(read_rows(io.BytesIO(path.read_bytes()), path.name)[1]),
    ):
        try:
            read()
        except InputError as err:
            out.append(err)
        else:
            raise AssertionError(f"{path.name} was read without a refusal")
    return out
