"""A stream a logger split across files in time, joined back into one.

Loggers rotate their files: a Raspberry Pi logger script or an in-car PC writes an hour
of wheel speeds to ``wheels_000.csv``, the next to ``wheels_001.csv``; ``candump -l``
under a log rotator, Vector's loggers and CANedge split their CAN logs by size or time.
Each file holds the same stream for a stretch of the drive. The stream folder reader
(:mod:`rwhonet.data.streamcsv`) reads each file as its own group of channels
(:class:`~rwhonet.data.signalmap.Group`), and :func:`join_parts` joins the groups of
different files that hold the same channels into one, in time order. Every sample keeps
its own file and row (:attr:`rwhonet.data.streams.Stream.parts`), so a refusal of a
joined stream still names the file and row a user opens.

The rules:

1. Each file's samples are put in their own time order first
   (:func:`~rwhonet.data.signalmap.in_time_order`: copies dropped, a reordering sorted).
2. The files are taken in the order of their first samples; each must start after the
   previous one's last sample. A logger that writes the sample at the rotation into both
   files leaves the later file's first samples at or before the earlier one's last: such
   samples at one of the earlier file's times with its values (where both have one: a
   receiver's epoch whose sentences the rotation split) are taken as that sample, and said
   (a file given twice under two names is all such samples: left out, and said). Any other
   overlap is refused, naming both files (two loggers recording the same bus, a file of
   another drive): the reader cannot tell which to believe.
3. Midnight: files on a time of day (or a GPS time of week) that pass midnight (the week's
   end) are put on one clock by the rule of :func:`rwhonet.data.timebase.unwrap_midnight`:
   the files' empty stretch on the day's circle longer than the one that contains
   midnight is where the drive is not, and the files before it get a day added, where the
   files on the two sides of midnight are at most :data:`MIDNIGHT_WINDOW_S` apart.
4. Groups whose channels overlap without being equal (the wheel speeds with the yaw rate
   in one file, without it in the next) are refused: what the stream is differs between
   files.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rwhonet.data.signalmap import Group, in_time_order
from rwhonet.data.timebase import MIDNIGHT_WINDOW_S, SECONDS_PER_DAY, SECONDS_PER_WEEK
from rwhonet.errors import InputError, Problem

FILES_NAMED = 3  # a joined stream's files named one by one in its name, the rest counted


def join_parts(groups: Sequence[Group], notes: list[str], changed: list[str]) -> list[Group]:
    """Groups of different files that hold the same channels, joined into one each.

    Args:
        groups: the drive's groups, one file's each (as the readers make them).
        notes: what the reader says; the joins and days added are added.
        changed: what the reader changed of the samples; each file's copies dropped and
            samples put in order, and the rotation's samples dropped, are added.

    Returns:
        The groups, those of one stream split across files joined (in the place of the
        first of them), the others as they were.

    Raises:
        InputError: two files of one stream overlap in time with other samples; groups of
            different files whose channels overlap without being equal.
    """
    by_keys: dict[frozenset[str], list[Group]] = {}
    for g in groups:
        by_keys.setdefault(frozenset(g.channels), []).append(g)
    _refuse_unequal(by_keys)
    joined: dict[frozenset[str], Group] = {}
    problems: list[Problem] = []
    for keys, parts in by_keys.items():
        if len(parts) < 2:
            continue
        try:
            joined[keys] = _joined(parts, notes, changed)
        except InputError as err:
            problems += err.problems
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in the stream files")
    out = []
    for g in groups:
        keys = frozenset(g.channels)
        if keys not in joined:
            out.append(g)
        elif by_keys[keys][0] is g:
            out.append(joined[keys])
    return out


def files_label(files: Sequence[str]) -> str:
    """How messages name files of one stream together."""
    if len(files) <= FILES_NAMED:
        return " + ".join(files)
    return f"{files[0]} + ... + {files[-1]} ({len(files)} files)"


def _refuse_unequal(by_keys: dict[frozenset[str], list[Group]]) -> None:
    """Groups whose channels overlap without being equal: no one stream, refused."""
    sets = list(by_keys)
    problems = []
    for i, a in enumerate(sets):
        for b in sets[i + 1 :]:
            both = a & b
            if not both:
                continue
            ga, gb = by_keys[a][0], by_keys[b][0]
            key = sorted(both)[0]
            problems.append(
                Problem(
                    f"{ga.where}, {gb.where}",
                    None,
                    ga.sources.get(key, key),
                    "each channel in one stream: in one file, or in files that each hold the "
                    "same channels (a stream a logger split across files in time)",
                    f"{ga.where} holds {_shown(ga)}; {gb.where} holds {_shown(gb)}",
                    "give each file of a split stream the same columns, or leave the file "
                    "that is not the stream's out",
                )
            )
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in the stream files")


def _shown(g: Group) -> str:
    return ", ".join(g.sources.get(k, k) for k in sorted(g.channels))


def _joined(parts: Sequence[Group], notes: list[str], changed: list[str]) -> Group:
    """One group of several files' (each in time order, on one clock, end to end)."""
    ordered = []
    for g in parts:
        g, said = in_time_order(g)
        changed.extend(said)
        ordered.append(g)
    ordered = _on_one_clock(ordered, notes)
    ordered.sort(key=_start)
    files = [g.file for g in ordered]
    label = files_label(files)
    t_parts: list[np.ndarray] = []
    rows_parts: list[np.ndarray] = []
    values: list[dict[str, np.ndarray]] = []  # each file's kept samples' values
    problems: list[Problem] = []
    for k, g in enumerate(ordered):
        t = np.asarray(g.t_s, dtype=np.float64)
        rows = np.arange(1, t.size + 1) if g.rows is None else np.asarray(g.rows)
        mine = {key: np.array(v, dtype=np.float64) for key, v in g.channels.items()}
        keep = np.ones(t.size, dtype=bool)
        before = [q for q in range(k) if t_parts[q].size]
        if before and t.size:
            q = before[-1]  # the last file before with samples
            last = float(t_parts[q][-1])
            # the file's first samples up to its first after the previous file's last (a
            # time gone back later in the file is the stream checks' to name)
            after = np.flatnonzero(t > last)
            early = np.arange(after[0] if after.size else t.size)
            if early.size:
                at = _same_samples(t_parts[q], values[q], t, mine, early)
                if (at < 0).any():
                    first = int(early[np.argmax(at < 0)])
                    problems.append(_overlap(ordered[q], g, first, rows, last))
                    keep[:] = False  # the file's problem said; the next compared with the last kept
                else:
                    for key, v in values[q].items():  # one sample's sentences in both files
                        v[at] = np.where(np.isnan(v[at]), mine[key][early], v[at])
                    keep[early] = False
                    changed.append(
                        f"{g.where}: a copy of {ordered[q].where} (every sample repeats one of "
                        "its): left out"
                        if early.size == t.size
                        else f"{g.where}: its first {early.size} sample(s) at the times of the "
                        f"last of {ordered[q].where} (the samples at the files' rotation, written "
                        "into both): taken as one"
                    )
        t_parts.append(t[keep])
        rows_parts.append(rows[keep])
        values.append({key: v[keep] for key, v in mine.items()})
    if problems:
        raise InputError(problems, summary=f"{len(problems)} problem(s) in {label}")
    first = ordered[0]
    name = _joined_name(ordered)
    t = np.concatenate(t_parts)
    gaps = [
        float(t_parts[k + 1][0] - t_parts[k][-1])
        for k in range(len(t_parts) - 1)
        if t_parts[k].size and t_parts[k + 1].size
    ]
    widest = f"; the longest step between two files {max(gaps):.3g} s" if gaps else ""
    notes.append(
        f"{label}: one stream split across {len(ordered)} files, joined in time order{widest}"
    )
    return Group(
        name,
        label,
        np.ascontiguousarray(t),
        {key: np.concatenate([v[key] for v in values]) for key in first.channels},
        dict(first.sources),
        np.concatenate(rows_parts),
        tuple((g.file, g.name) for g in ordered),
        np.concatenate([np.full(r.size, k, dtype=np.int64) for k, r in enumerate(rows_parts)]),
    )


def _start(g: Group) -> float:
    t = np.asarray(g.t_s, dtype=np.float64)
    finite = t[np.isfinite(t)]
    return float(finite[0]) if finite.size else np.inf


def _end(g: Group) -> float:
    t = np.asarray(g.t_s, dtype=np.float64)
    finite = t[np.isfinite(t)]
    return float(finite[-1]) if finite.size else -np.inf


def _on_one_clock(parts: list[Group], notes: list[str]) -> list[Group]:
    """Files on a time of day (time of week) across midnight (the week's end): the files
    after it get a day (a week) added (rule 3 of the module's).

    On the clock's circle, the drive is not in the longest stretch between its files. Where
    that stretch is not the one that holds midnight, and the files on midnight's two sides
    are at most :data:`MIDNIGHT_WINDOW_S` apart, the files before the stretch (from the
    clock's start) are the next day's.
    """
    spans = sorted((_start(g), _end(g), i) for i, g in enumerate(parts))
    starts = np.array([s for s, _, _ in spans])
    ends = np.maximum.accumulate([e for _, e, _ in spans])
    if not (np.isfinite(starts).all() and np.isfinite(ends).all()) or starts[0] < 0:
        return parts
    window = MIDNIGHT_WINDOW_S
    period = next((p for p in (SECONDS_PER_DAY, SECONDS_PER_WEEK) if ends[-1] < p + window), None)
    if period is None or starts[-1] >= period:
        return parts
    across = starts[0] + period - ends[-1]  # the stretch that holds midnight
    gaps = starts[1:] - ends[:-1]
    if across < 0 or across > window or max(gaps) <= across:
        return parts
    before = int(np.argmax(gaps))  # files up to the longest stretch: past midnight
    out = list(parts)
    added, what = (
        ("a day", "midnight") if period == SECONDS_PER_DAY else ("a week", "the week's end")
    )
    for _, _, i in spans[: before + 1]:
        g = parts[i]
        out[i] = Group(
            g.name, g.file, g.t_s + period, g.channels, g.sources, g.rows, g.parts, g.part
        )
        notes.append(f"{g.file}: starts past {what}, after the stream's other files: {added} added")
    return out


def _same_samples(
    prev_t: np.ndarray,
    prev: dict[str, np.ndarray],
    t: np.ndarray,
    mine: dict[str, np.ndarray],
    early: np.ndarray,
) -> np.ndarray:
    """For each of a file's samples ``early``, the previous file's sample it is (the same
    time, and in every channel the same value where both have one: a copy, or one epoch's
    sentences split between the files), or -1."""
    j = np.searchsorted(prev_t, t[early])
    j = np.minimum(j, prev_t.size - 1)
    same = prev_t[j] == t[early]
    for key, v in prev.items():
        a, b = v[j], mine[key][early]
        same &= (a == b) | np.isnan(a) | np.isnan(b)
    return np.where(same, j, -1)


def _overlap(prev: Group, g: Group, first: int, rows: np.ndarray, last: float) -> Problem:
    t = float(np.asarray(g.t_s)[first])
    return Problem(
        g.where,
        int(rows[first]),
        g.sources.get("t", "time"),
        f"a file of a stream split in time starting after the previous file's last sample "
        f"({prev.where}, t = {last!r} s)",
        f"t = {t!r} s with other values: the files overlap by {last - t:.6g} s",
        "two files holding the same stream at the same times with other values (two "
        "loggers on one bus, a file of another drive): leave one out",
    )


def _joined_name(parts: Sequence[Group]) -> str:
    """The joined stream's name: its files' names, with what each file's name adds (a
    message of a CAN log, the columns of one message of a wide CSV)."""
    label = files_label([Path(g.file).name for g in parts])
    rests = set()
    for g in parts:
        own = Path(g.file).name
        rests.add(g.name[len(own) :] if g.name.startswith(own) else f" [{g.name}]")
    if len(rests) != 1:
        return label
    rest = rests.pop()
    if rest.startswith(" ["):
        return rest[2:-1]
    return label + rest
