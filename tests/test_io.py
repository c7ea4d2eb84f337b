"""Atomic outputs: all or nothing."""

import pyarrow as pa
import pytest

from rwhonet.errors import Problem
from rwhonet.io import (
    atomic_dir,
    atomic_file,
    atomic_outputs,
    read_arrow,
    read_json,
    write_arrow,
    write_json,
)


def test_atomic_dir_replaces_on_success(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with atomic_dir(out) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["new.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


@pytest.mark.crash
def test_atomic_dir_leaves_nothing_on_failure(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), atomic_dir(out) as tmp:
        (tmp / "half.txt").write_text("half")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.crash
def test_atomic_file_keeps_old_on_failure(tmp_path):
    f = tmp_path / "a.json"
    write_json(f, {"v": 1})
    with pytest.raises(ValueError), atomic_file(f) as tmp:
        tmp.write_text("partial")
        raise ValueError
    assert read_json(f) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


@pytest.mark.crash
def test_a_stage_s_outputs_are_replaced_together_or_not_at_all(tmp_path):
    folder, report = tmp_path / "segments", tmp_path / "report.json"
    with atomic_outputs(folder, report, folders=(True, False)) as (tmp_dir, tmp_report):
        (tmp_dir / "a.parquet").write_text("1")
        write_json(tmp_report, {"run": 1})
    with (
        pytest.raises(KeyboardInterrupt),
        atomic_outputs(folder, report, folders=(True, False)) as (
            tmp_dir,
            tmp_report,
        ),
    ):
        (tmp_dir / "b.parquet").write_text("2")
        write_json(tmp_report, {"run": 2})
        raise KeyboardInterrupt  # after every output was written, before the swap
    assert [p.name for p in folder.iterdir()] == ["a.parquet"] and read_json(report) == {"run": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json", "segments"]


def test_outputs_get_the_usual_permissions(tmp_path):
    import os

    mask = os.umask(0o022)
    try:
        write_json(tmp_path / "a.json", {})
        with atomic_dir(tmp_path / "d") as tmp:
            (tmp / "x").write_text("x")
    finally:
        os.umask(mask)
    assert (tmp_path / "a.json").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "d").stat().st_mode & 0o777 == 0o755


def _dead_pid() -> int:
    import subprocess

    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


@pytest.mark.crash
def test_temporaries_of_a_killed_writer_go_with_the_next_write(tmp_path):
    import os

    out = tmp_path / "seed1"
    dead, alive = _dead_pid(), os.getppid()
    stale = [tmp_path / f".seed1.tmp-{dead}-abc", tmp_path / f".seed1.tmp-{dead}-abc.old"]
    for folder in stale:
        folder.mkdir()
        (folder / "model.pt").write_bytes(b"half")
    busy = tmp_path / f".seed1.tmp-{alive}-xyz"  # another process still writing
    busy.mkdir()
    other = tmp_path / f".seed2.tmp-{dead}-abc"  # not this output's
    other.mkdir()
    with atomic_dir(out) as tmp:
        (tmp / "model.pt").write_bytes(b"whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["seed1", busy.name, other.name])


@pytest.mark.crash
def test_a_signal_during_the_swap_is_handled_after_it_and_nothing_is_left(tmp_path, monkeypatch):
    import os
    import signal

    class Stop(BaseException):
        pass

    def stop(signum, frame):
        raise Stop

    out, report = tmp_path / "segments", tmp_path / "report.json"
    with atomic_outputs(out, report, folders=(True, False)) as (tmp_dir, tmp_report):
        write_json(tmp_report, {"run": 1})
    real_replace = os.replace

    def replace_then_signal(src, dst):  # SIGTERM arrives between the renames
        real_replace(src, dst)
        os.kill(os.getpid(), signal.SIGTERM)

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        with pytest.raises(Stop):  # raised once the renames are done
            with atomic_outputs(out, report, folders=(True, False)) as (tmp_dir, tmp_report):
                (tmp_dir / "b.parquet").write_text("2")
                write_json(tmp_report, {"run": 2})
                monkeypatch.setattr(os, "replace", replace_then_signal)
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert [p.name for p in out.iterdir()] == ["b.parquet"] and read_json(report) == {"run": 2}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json", "segments"]


@pytest.mark.crash
@pytest.mark.slow
def test_sigkill_while_writing_leaves_the_old_outputs(tmp_path):
    """A writer killed outright mid-write: the old outputs stay whole, its leftovers go later."""
    import signal
    import subprocess
    import sys

    out = tmp_path / "seed1"
    with atomic_dir(out) as tmp:
        (tmp / "model.pt").write_bytes(b"old model")
    code = (
        "import sys, time; from pathlib import Path; from rwhonet.io import atomic_dir\n"
        f"with atomic_dir(Path({str(out)!r})) as tmp:\n"
        "    (tmp / 'model.pt').write_bytes(b'new, half written')\n"
        "    print('writing', flush=True); time.sleep(60)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "writing"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert (out / "model.pt").read_bytes() == b"old model"
    assert len(list(tmp_path.iterdir())) == 2  # the output and the dead writer's temporary
    with atomic_dir(out) as tmp:
        (tmp / "model.pt").write_bytes(b"new model")
    assert [p.name for p in tmp_path.iterdir()] == ["seed1"]


# ------------------------------------------------------------------ map_in_order


@pytest.mark.parametrize("workers", [1, 2, 4])
def test_map_in_order_yields_every_item_in_order_with_its_outcome(workers):
    import threading

    from rwhonet.io import map_in_order

    seen = set()

    def work(i):
        seen.add(threading.current_thread().name)
        if i == 3:
            raise ValueError("three")
        return i * i

    out = list(map_in_order(work, range(8), workers=workers))
    assert [item for item, _ in out] == list(range(8))
    assert [f.result() for i, f in out if i != 3] == [i * i for i in range(8) if i != 3]
    with pytest.raises(ValueError, match="three"):
        out[3][1].result()
    if workers == 1:  # in the caller's thread, item by item
        assert seen == {threading.main_thread().name}
    else:
        assert threading.main_thread().name not in seen


def test_map_in_order_holds_at_most_workers_items_ahead():
    from rwhonet.io import map_in_order

    started = []
    gen = map_in_order(lambda i: started.append(i) or i, range(20), workers=2)
    next(gen)
    assert max(started) <= 2  # the item handed out and two in flight
    gen.close()


def test_arrow_files_round_trip_and_read_the_columns_they_have(tmp_path):
    table = pa.table({"t_s": [0.0, 0.1], "lat_deg": [52.4, 52.5], "scenario": ["", "town"]})
    write_arrow(table, tmp_path / "d.arrow")
    assert read_arrow(tmp_path / "d.arrow").equals(table)
    # the columns asked for that the file has, in its order; absent ones left out
    some = read_arrow(tmp_path / "d.arrow", ["scenario", "yaw_rate_rad_s", "t_s"])
    assert some.column_names == ["t_s", "scenario"]
    (tmp_path / "bad.arrow").write_text("t_s\n0.0\n")
    with pytest.raises(pa.ArrowInvalid):
        read_arrow(tmp_path / "bad.arrow")


def test_an_unreadable_file_names_the_library_s_error():
    p = Problem.unreadable("a.arrow", "an Arrow file", ValueError("x" * 500), "run it again", "t_s")
    assert p.found == "ValueError: " + "x" * 160 and p.column == "t_s" and p.fix == "run it again"
    assert str(p) == "a.arrow, column 't_s': expected an Arrow file; found ValueError: " + "x" * 160


def test_a_killed_process_s_scratch_folder_is_removed_by_the_next_one(tmp_path, monkeypatch):
    """A command killed by SIGKILL leaves its scratch folder (a decompressed drive, a
    downloaded model) in the system's temp directory; the next command removes it once
    it is over an hour old. A folder of a process that still runs, a young one, another
    program's and a file are left alone."""
    import os
    import subprocess
    import sys
    import tempfile
    import time

    from rwhonet.io import scratch_dir

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    child = subprocess.Popen(
        [sys.executable, "-c", "import time; time.sleep(60)"], stdin=subprocess.DEVNULL
    )
    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    dead = int(gone.stdout)
    old = time.time() - 7200.0
    killed = tmp_path / f"rwhonet-unpacked-{dead}-abc123"
    (killed / "drive.csv").parent.mkdir()
    (killed / "drive.csv").write_text("t_s\n")
    young = tmp_path / f"rwhonet-model-{dead}-def456"
    young.mkdir()
    running = tmp_path / f"rwhonet-unpacked-{child.pid}-ghi789"
    running.mkdir()
    other = tmp_path / "rwhonet-notes"
    other.mkdir()
    a_file = tmp_path / f"rwhonet-vbo-{dead}-x"
    a_file.write_text("")
    for p in (killed, running, other, a_file):
        os.utime(p, (old, old))
    try:
        with scratch_dir("unpacked") as mine:
            assert mine.is_dir() and mine.parent == tmp_path
            assert mine.name.startswith(f"rwhonet-unpacked-{os.getpid()}-")
            assert not killed.exists()
            assert young.exists() and running.exists() and other.exists() and a_file.exists()
        assert not mine.exists()
    finally:
        child.kill()
        child.wait()
