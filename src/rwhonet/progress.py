"""Progress of a stage's long loops: a bar for a person at a terminal, plain lines for logs.

A bar (tqdm, redrawn in place with carriage returns) is drawn only when a
person watches: stderr is a terminal and ``$CI`` is not set. Otherwise (CI,
output piped or captured, ``dvc repro > log``) a loop prints at most
:data:`LINES` plain lines to stdout, ``simulate: 12/40 drives (V-Vta1), 3.1 s``,
so logs stay readable and hold no carriage return. Lightning's own training
bar follows the same rule (:func:`interactive`; ``stages/train.py``).

Everyone may use this module (like ``io.py``): the domain packages take a
``track`` argument rather than deciding how to report.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from typing import TextIO, TypeVar

T = TypeVar("T")
LINES = 10  # plain lines per loop at most (and the last item always)


def in_ci() -> bool:
    """Whether ``$CI`` says this is a CI run (``true``, ``1``, ``yes``; any case)."""
    return os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


def interactive(stream: TextIO | None = None) -> bool:
    """Whether to draw bars: ``stream`` (default stderr) is a terminal and this is not CI."""
    stream = stream if stream is not None else sys.stderr
    try:
        return stream.isatty() and not in_ci()
    except (AttributeError, ValueError):  # a replaced or closed stream
        return False


def track(
    items: Iterable[T],
    *,
    desc: str,
    unit: str,
    total: int | None = None,
    label: Callable[[T], str] | None = None,
) -> Iterator[T]:
    """Yield ``items``, showing how far the loop has got.

    Args:
        items: what the loop goes through.
        desc: what the loop does (the stage: ``simulate``).
        unit: one item, singular (``drive``); plain lines add an ``s``.
        total: the number of items (default ``len(items)`` when it has one).
        label: names an item (a drive's id) in the plain lines.

    Yields:
        The items, unchanged.
    """
    if total is None:
        total = len(items) if hasattr(items, "__len__") else None  # type: ignore[arg-type]
    if interactive():
        from tqdm import tqdm

        yield from tqdm(
            items,
            desc=desc,
            total=total,
            unit=f" {unit}",
            file=sys.stderr,
            dynamic_ncols=True,
            leave=False,
        )
        return
    every = max(1, -(-total // LINES)) if total else 1
    start = time.perf_counter()
    done = 0
    for item in items:
        yield item
        done += 1
        if done % every == 0 or done == total:
            what = f" ({label(item)})" if label is not None else ""
            of = f"/{total}" if total else ""
            print(
                f"{desc}: {done}{of} {unit}s{what}, {time.perf_counter() - start:.1f} s", flush=True
            )
