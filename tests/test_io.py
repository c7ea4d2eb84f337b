"""Atomic outputs: all or nothing."""

import pytest

from rwhonet.io import atomic_dir, atomic_file, atomic_outputs, read_json, write_json


def test_atomic_dir_replaces_on_success(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with atomic_dir(out) as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == ["new.txt"]
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_atomic_dir_leaves_nothing_on_failure(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), atomic_dir(out) as tmp:
        (tmp / "half.txt").write_text("half")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_atomic_file_keeps_old_on_failure(tmp_path):
    f = tmp_path / "a.json"
    write_json(f, {"v": 1})
    with pytest.raises(ValueError), atomic_file(f) as tmp:
        tmp.write_text("partial")
        raise ValueError
    assert read_json(f) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


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
