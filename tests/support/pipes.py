"""A drive fed through an OS pipe, as a logger's process pipes it to ``rwhonet predict -``."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import BinaryIO


@contextmanager
def piped(data: bytes, piece: int = 3001) -> Iterator[BinaryIO]:
    """The read end of a pipe a thread writes ``data`` into, ``piece`` bytes at a time
    (pieces that cut lines, as a logger's pipe does); the writer is joined on exit."""
    r, w = os.pipe()

    def feed() -> None:
        with os.fdopen(w, "wb", buffering=0) as out:
            for i in range(0, len(data), piece):
                out.write(data[i : i + piece])

    writer = threading.Thread(target=feed)
    writer.start()
    try:
        with os.fdopen(r, "rb") as pipe:
            yield pipe
    finally:
        writer.join()
