"""Ingest: drive discovery, roles, formats, manifest, and all-or-nothing output."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.feather as feather
import pytest

from rwhonet import paths
from rwhonet.config import ConfigError
from rwhonet.data import canonical as c
from rwhonet.errors import InputError
from rwhonet.io import system_memory_pool
from rwhonet.stages.ingest import ingest
from support.drives import (
    CUPAC_MAP,
    TARGET_RADIUS_M,
    column_map_params,
    make_params,
    straight_drive,
    write_columnmap,
    write_fleet,
    write_iovnbd,
)

FIXTURES = Path(__file__).parents[1] / "fixtures"


def test_round_trip_manifest_and_canonical_file(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=5.0)
    shutil.copy(
        FIXTURES / "iovnbd" / "V-T1.scenarios.json", raw / "source_train" / "V-S1.scenarios.json"
    )
    out = tmp_path / "drives"
    manifest = ingest(make_params(raw), out)

    assert json.loads((out / "manifest.json").read_text()) == manifest
    by_drive = {d["drive"]: d for d in manifest["drives"]}
    assert list(by_drive) == ["V-S1", "C-A1", "C-B1"]  # role order, then name
    s1 = by_drive["V-S1"]
    keys = ("role", "vehicle", "format", "n_rows", "header_match", "calibrates")
    assert [s1[k] for k in keys] == ["source_train", "source", "iovnbd", 51, "name", True]
    assert s1["source_file"] == paths.rel(files["source_train"])
    assert s1["columns"][c.OMEGA_RL] == " Wheel Speed Rear Left (rad/sec)"
    assert s1["scenarios_file"].endswith("V-S1.scenarios.json")
    assert by_drive["C-A1"]["scenarios_file"] is None
    # No source_calibration drive: the first source_train drive calibrates, as recorded.
    assert manifest["calibration"]["fallback"] is True
    assert manifest["calibration"]["drives"] == ["V-S1"]

    df = pd.read_feather(out / "V-S1.arrow")
    assert list(df.columns[:7]) == list(c.REQUIRED) and df.columns[-1] == c.SCENARIO
    expected = straight_drive(5.0)
    np.testing.assert_allclose(df[c.LAT_DEG], expected[c.LAT_DEG], rtol=0, atol=1e-12)
    np.testing.assert_allclose(df[c.OMEGA_RR], expected[c.OMEGA_RR], rtol=1e-12)
    assert df.loc[df[c.T_S].between(45000.3, 45000.45), c.SCENARIO].tolist() == ["roundabout"] * 2
    assert df.loc[df[c.T_S] == 45000.5, c.SCENARIO].item() == "roundabout;wet_road"


def test_macos_appledouble_and_hidden_files_are_no_drives(tmp_path):
    """A fleet copied from a Mac to an exFAT disk has a ``._V-S1.csv`` (binary resource
    data) beside every file; pathlib's glob matched it and ingest refused the fleet."""
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=5.0)
    for path in files.values():
        (path.parent / f"._{path.name}").write_bytes(b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X")
    (raw / "source_train" / ".DS_Store").write_bytes(b"\x00\x00\x00\x01Bud1")
    hidden = raw / "source_train" / ".trash"
    hidden.mkdir()
    (hidden / "V-Old.csv").write_bytes(files["source_train"].read_bytes())
    manifest = ingest(make_params(raw), tmp_path / "drives")
    assert [d["drive"] for d in manifest["drives"]] == ["V-S1", "C-A1", "C-B1"]


def test_source_calibration_role_and_column_map_format(tmp_path):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=3.0)
    write_iovnbd(straight_drive(3.0), raw / "source_calibration" / "V-Cal.csv")
    write_columnmap(straight_drive(3.0, radius_m=TARGET_RADIUS_M), raw / "target_test" / "C-Z9.csv")
    params = make_params(
        raw,
        **{
            "data.column_maps.cupac": column_map_params(CUPAC_MAP),
            "data.roles.target_test": {
                "glob": "target_test/C-Z*.csv",
                "format": "cupac",
                "vehicle": "target",
                "required": True,
            },
        },
    )
    manifest = ingest(params, tmp_path / "drives")
    assert manifest["calibration"] == {
        "role": "source_calibration",
        "drives": ["V-Cal"],
        "fallback": False,
    }
    z9 = next(d for d in manifest["drives"] if d["drive"] == "C-Z9")
    assert (z9["format"], z9["header_match"], z9["columns"][c.T_S]) == (
        "cupac",
        "column_map",
        "Time",
    )
    df = pd.read_feather(tmp_path / "drives" / "C-Z9.arrow")
    np.testing.assert_allclose(df[c.OMEGA_RL], 15.0 / TARGET_RADIUS_M, rtol=1e-9)
    np.testing.assert_allclose(np.diff(df[c.T_S]), 0.1, atol=1e-9)


def test_a_role_of_parquet_drives_is_ingested_as_their_csvs_would_be(tmp_path):
    """A fleet's drives kept in a data lake as Parquet: the role's glob names them, the
    drive is its file's name without the suffix, the canonical table the CSV's, the
    manifest names the user's file and says how it was read."""
    import pyarrow.parquet as pq

    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=5.0)
    kept = raw / "lake" / "C-B1.parquet"
    kept.parent.mkdir()
    pq.write_table(pa.Table.from_pandas(pd.read_csv(files["target_test"])), kept)
    role = {"glob": "lake/*.parquet", "format": "iovnbd", "vehicle": "target", "required": True}
    out = tmp_path / "drives"
    manifest = ingest(make_params(raw, **{"data.roles.target_test": role}), out)
    b1 = next(d for d in manifest["drives"] if d["drive"] == "C-B1")
    assert b1["source_file"] == paths.rel(kept)
    assert b1["notes"][0] == "a table file (Parquet), read as CSV: 51 rows"
    want = ingest(make_params(raw), tmp_path / "csv")
    assert [d["n_rows"] for d in manifest["drives"]] == [d["n_rows"] for d in want["drives"]]
    pd.testing.assert_frame_equal(
        pd.read_feather(out / "C-B1.arrow"), pd.read_feather(tmp_path / "csv" / "C-B1.arrow")
    )
    # ... and as Spark writes a drive: a folder of part files, its name the drive's
    kept.unlink()
    spark = raw / "lake" / "C-B1.parquet"
    spark.mkdir()
    frame = pa.Table.from_pandas(pd.read_csv(files["target_test"]))
    pq.write_table(frame.slice(0, 20), spark / "part-00000-a1b2.snappy.parquet")
    pq.write_table(frame.slice(20), spark / "part-00001-a1b2.snappy.parquet")
    (spark / "_SUCCESS").write_bytes(b"")
    manifest = ingest(make_params(raw, **{"data.roles.target_test": role}), tmp_path / "spark")
    b1 = next(d for d in manifest["drives"] if d["drive"] == "C-B1")
    assert b1["source_file"] == paths.rel(spark)
    assert b1["notes"][0].startswith("a folder of 2 Parquet part file(s)")
    pd.testing.assert_frame_equal(
        pd.read_feather(tmp_path / "spark" / "C-B1.arrow"),
        pd.read_feather(tmp_path / "csv" / "C-B1.arrow"),
    )


def test_a_lake_partitioned_by_drive_gives_a_drive_a_partition(tmp_path):
    """A fleet table written partitioned by its drive column (``partitionBy("drive_id")``:
    a ``drive_id=<value>`` folder of part files each): the role's glob matches the
    partitions, each a drive named by its value."""
    import pyarrow.parquet as pq

    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=5.0)
    for drive in ("C-B1", "C-B2"):
        part = raw / "lake" / f"drive_id={drive}"
        part.mkdir(parents=True)
        pq.write_table(pa.Table.from_pandas(pd.read_csv(files["target_test"])), part / "p0.parquet")
    files["target_test"].unlink()
    role = {"glob": "lake/drive_id=*", "format": "iovnbd", "vehicle": "target", "required": True}
    manifest = ingest(make_params(raw, **{"data.roles.target_test": role}), tmp_path / "d")
    tests = [d["drive"] for d in manifest["drives"] if d["role"] == "target_test"]
    assert tests == ["C-B1", "C-B2"]
    assert (tmp_path / "d" / "C-B2.arrow").is_file()


def test_required_role_without_files_names_folder_and_glob(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=2.0)
    files["target_train"].unlink()
    shutil.rmtree(raw / "target_test")
    with pytest.raises(InputError) as err:
        ingest(make_params(raw), tmp_path / "drives")
    found = {(Path(p.file).name, p.found) for p in err.value.problems}
    assert found == {("target_train", "no matching file"), ("target_test", "no such folder")}
    assert "'target_train/*.csv'" in err.value.problems[0].expected
    assert not (tmp_path / "drives").exists()


def test_drive_ids_must_be_unique_across_roles(tmp_path):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=2.0)
    write_iovnbd(straight_drive(2.0), raw / "target_test" / "V-S1.csv")
    with pytest.raises(InputError, match="unique across all roles"):
        ingest(make_params(raw), tmp_path / "drives")


def test_sim_source_requires_the_simulator_folder(tmp_path):
    params = make_params(tmp_path, **{"data.source": "sim"})
    with pytest.raises(ConfigError, match="set data.root=data/sim"):
        ingest(params, tmp_path / "drives")


def test_unknown_role_is_a_config_error(tmp_path):
    params = make_params(
        tmp_path,
        **{"data.roles.validation": {"glob": "v/*.csv", "format": "iovnbd", "vehicle": "source"}},
    )
    with pytest.raises(ConfigError, match="data.roles.validation: unknown role"):
        ingest(params, tmp_path / "drives")


def test_every_bad_file_in_one_report_and_no_partial_output(tmp_path):
    raw = tmp_path / "raw"
    files = write_fleet(raw, duration_s=2.0)
    out = tmp_path / "drives"
    ingest(make_params(raw), out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    files["source_train"].write_text("", encoding="utf-8")  # empty file
    text = files["target_test"].read_text(encoding="utf-8").splitlines()
    text[3] = text[3].replace(",", ",oops,", 1)  # one column too many, in data row 3
    files["target_test"].write_text("\n".join(text) + "\n", encoding="utf-8")
    (raw / "target_train" / "C-A2.csv").write_text(" Time, Lat\n1,2\n", encoding="utf-8")

    with pytest.raises(InputError) as err:
        ingest(make_params(raw), out)
    found = {(Path(p.file).name, p.row, p.column) for p in err.value.problems}
    assert ("V-S1.csv", None, None) in found
    assert ("C-B1.csv", 3, None) in found
    assert {("C-A2.csv", None, col) for col in ("Long", "Wheel Speed Rear Left (rad/sec)")} <= found
    assert "in 3 file(s)" in err.value.summary
    # The previous output is untouched and no temporary folder is left behind.
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drives", "raw"]


def test_canonical_drive_is_an_uncompressed_arrow_file_without_nulls(tmp_path):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=2.0)
    ingest(make_params(raw), tmp_path / "drives")
    path = tmp_path / "drives" / "V-S1.arrow"
    table = feather.read_table(path)
    # NaN, not null, marks a missing value: the columns are declared non-nullable.
    assert [f.nullable for f in table.schema] == [False] * len(table.schema)
    assert table.schema.field(c.SCENARIO).type == pa.string()
    assert table.schema.field(c.T_S).type == pa.float64()
    # uncompressed: the file holds the float columns' bytes as they are
    assert path.stat().st_size > 8 * table.num_rows * (len(table.schema) - 1)


def test_system_memory_pool_is_scoped_and_restored_after_an_error():
    before = pa.default_memory_pool().backend_name

    @system_memory_pool()
    def allocate_then_fail():
        assert pa.default_memory_pool().backend_name == "system"
        pa.array(np.arange(1000.0))
        raise InputError([])

    with pytest.raises(InputError):
        allocate_then_fail()
    assert pa.default_memory_pool().backend_name == before


def test_a_can_database_outside_data_root_is_said_to_be_untracked(tmp_path):
    """ingest depends on data.root: a DBC elsewhere is read, but dvc repro would not rerun
    the stage when it changes; the manifest and the stage's output say so."""
    from rwhonet.data.drivefile import DriveFile
    from rwhonet.stages.ingest import untracked_inputs
    from support.canlog import SIGNALS

    root = tmp_path / "raw"

    def data(dbc):
        maps = {"canedge": {"reader": "mdf4", "signals": SIGNALS, "dbc": dbc}}
        return make_params(root, **{"data.signal_maps": maps}).data

    drive = DriveFile("D1", "target_test", "target", "canedge", root / "d1.mf4")
    inside, outside = str(root / "vehicle.dbc"), str(tmp_path / "elsewhere" / "gnss.dbc")
    assert untracked_inputs(data(inside), [drive]) == []
    (said,) = untracked_inputs(data([inside, outside]), [drive])
    assert "gnss.dbc (data.signal_maps.canedge.dbc) lies outside data.root" in said
    assert "does not rerun ingest" in said
    other = DriveFile("D2", "target_test", "target", "iovnbd", root / "V-A.csv")
    assert untracked_inputs(data(outside), [other]) == []  # a map no drive uses
