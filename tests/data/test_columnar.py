"""Drive files kept as columnar tables (Parquet, Arrow IPC / Feather): read by ingest's 10 Hz
readers, predict's and the stream-CSV reader as the CSV they hold, a record batch at a time,
every value as the CSV would give it; named as the user named them; damage refused."""

from __future__ import annotations

import gzip
import io
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.feather as feather
import pyarrow.parquet as pq
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.columnar import (
    FEATHER,
    PARQUET,
    csv_copy,
    folder_id,
    is_table_folder,
    is_table_name,
    open_as_csv,
    table_kind,
    table_parts,
)
from rwhonet.data.compressed import drive_stem
from rwhonet.data.drivefile import DriveFile, read_any
from rwhonet.data.incremental import read_rows
from rwhonet.errors import InputError
from support.drives import column_map_params, make_params, write_iovnbd
from support.serving import wavy_drive
from support.stream_fleet import (
    read_target_drive,
    role_drive,
    stream_params,
    tables_from_drive,
    write_drive,
)

WRITE = {
    PARQUET: lambda table, path: pq.write_table(table, path, row_group_size=64),
    FEATHER: lambda table, path: feather.write_feather(table, path, chunksize=64),
}
SUFFIX = {PARQUET: ".parquet", FEATHER: ".feather"}


def _read(path: Path, root: Path, fmt: str = "iovnbd", **overrides):
    data = make_params(root, **overrides).data
    f = DriveFile(drive_stem(path), "target_test", "target", fmt, path)
    return read_any(f, data, lambda p: p.name, None, 0.1, 10.0)[0]


def _as_table(csv: Path, kind: str, name: str = "V-T") -> Path:
    """A CSV drive written as a table file of typed columns (pandas' own dtypes)."""
    path = csv.with_name(name + SUFFIX[kind])
    WRITE[kind](pa.Table.from_pandas(pd.read_csv(csv), preserve_index=False), path)
    return path


def _assert_same(got, want) -> None:
    assert set(got.columns) == set(want.columns)
    for name in want.columns:
        np.testing.assert_array_equal(got.columns[name], want.columns[name], err_msg=name)


@pytest.mark.parametrize("kind", WRITE)
def test_a_table_drive_reads_as_the_csv_it_holds_by_both_readers(tmp_path, kind):
    plain = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv")
    table = _as_table(plain, kind)
    assert table_kind(table) == kind and table_kind(plain) is None
    want, got = _read(plain, tmp_path), _read(table, tmp_path)
    _assert_same(got, want)  # 301 rows in five record batches of 64
    assert got.notes[0] == f"a table file ({kind}), read as CSV: 301 rows"
    source, held = open_as_csv(table, kind, table.name)
    with source:  # predict's path, a block at a time across the batches
        lay, blocks = read_rows(source, table.name, block_bytes=4096)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, want.columns[c.OMEGA_RL])
    assert held.note == got.notes[0]


def test_the_kind_is_told_from_the_bytes_not_the_name(tmp_path):
    plain = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    table = _as_table(plain, PARQUET)
    named_csv = tmp_path / "V-B.csv"
    named_csv.write_bytes(table.read_bytes())
    np.testing.assert_array_equal(
        _read(named_csv, tmp_path).columns[c.T_S], _read(plain, tmp_path).columns[c.T_S]
    )
    assert is_table_name("wheels.parquet") and is_table_name("GPS.Feather")
    assert is_table_name("wheels.parquet.gz") and not is_table_name("wheels.csv")


def _typed_drive(n_s: float):
    """One drive twice: a CSV of numbers and ISO text, and the typed table a data lake keeps
    (a zoned timestamp, the wheels in a struct, a boolean fix flag, categories, a camera
    frame and a list no CSV cell holds)."""
    df = wavy_drive(n_s)
    unix = 1_552_300_000.0 + df[c.T_S].to_numpy() - df[c.T_S].iloc[0]
    ms = np.round(unix * 1e3).astype(np.int64)
    stamps = pd.to_datetime(ms, unit="ms", utc=True)
    fix = np.arange(len(df)) % 50 != 7  # a fix the receiver says is none, each 5 s
    wheels = {k: df[w].to_numpy() for k, w in zip(("fl", "fr", "rl", "rr"), c.WHEELS, strict=True)}
    csv = pd.DataFrame(
        {
            "time": stamps.strftime("%Y-%m-%dT%H:%M:%S.%fZ"),
            "lat": df[c.LAT_DEG],
            "lon": df[c.LON_DEG],
            **{f"wheel.{k}": v for k, v in wheels.items()},
            "fix": fix,  # pandas writes True and False
            "sats": df[c.N_SATS].astype(int),
        }
    )
    table = pa.table(
        {
            "time": pa.array(ms, pa.timestamp("ms", "Europe/Berlin")),
            "lat": df[c.LAT_DEG].to_numpy(),
            "lon": df[c.LON_DEG].to_numpy(),
            "wheel": pa.StructArray.from_arrays(
                [pa.array(v) for v in wheels.values()], names=list(wheels)
            ),
            "fix": pa.array(fix),
            "sats": pa.array(df[c.N_SATS].to_numpy().astype(np.uint8)),
            "receiver": pa.array(["ublox"] * len(df)).dictionary_encode(),
            "frame": pa.array([b"\xff\xd8"] * len(df), pa.binary()),
            "history": pa.array([[1.0, 2.0]] * len(df)),
        }
    )
    cmap = {
        "t": ("time", "iso8601"),
        "lat": ("lat", "deg"),
        "lon": ("lon", "deg"),
        **{f"omega_{k}": (f"wheel.{k}", "rad/s") for k in wheels},
        "fix": ("fix", "bool"),
        "n_sats": ("sats", "count"),
    }
    return csv, table, {"data.column_maps": {"lake": column_map_params(cmap)}}


@pytest.mark.parametrize("kind", WRITE)
def test_typed_columns_read_as_the_csv_a_user_would_have_written(tmp_path, kind):
    csv, table, maps = _typed_drive(30.0)
    csv.to_csv(tmp_path / "V-A.csv", index=False)
    WRITE[kind](table, path := tmp_path / f"V-A{SUFFIX[kind]}")
    want = _read(tmp_path / "V-A.csv", tmp_path, "lake", **maps)
    got = _read(path, tmp_path, "lake", **maps)
    _assert_same(got, want)
    assert np.isnan(got.columns[c.LAT_DEG][7]) and not np.isnan(got.columns[c.LAT_DEG][8])
    assert got.notes[0] == (
        f"a table file ({kind}), read as CSV: 301 rows; column(s) no CSV cell holds left out: "
        "frame, history"
    )


@pytest.mark.parametrize("kind", WRITE)  # Feather keeps a dictionary of booleans; Parquet not
def test_each_kind_of_cell_as_the_readers_read_it(tmp_path, kind):
    import datetime as dt

    table = pa.table(
        {
            "utc": pa.array([0, 1_500], pa.timestamp("ms", "America/Detroit")),
            "naive": pa.array([0, 1_500_000], pa.timestamp("us")),
            "day": pa.array([dt.date(2019, 3, 11)] * 2),
            "clock": pa.array([dt.time(14, 22, 5, 123000)] * 2),
            "lag": pa.array([1_500, -2], pa.duration("ms")),
            "x": [0.1, float("nan")],
            "third": [1 / 3, None],
            "f16": pa.array([1.5, 2.0], pa.float16()),
            "ok": [True, None],
            "s": ["a,b", "c"],
            "none": pa.array([None, None]),  # a channel the logger never filled
            "flag": pa.array([False, True]).dictionary_encode(),  # its values' own rules
            "imu": pa.array([{"gyro": {"z": 0.5}}, {"gyro": {"z": -0.25}}]),
        }
    )
    WRITE[kind](table, path := tmp_path / f"cells{SUFFIX[kind]}")
    csv_copy(path, kind, out := tmp_path / "cells.csv", None, path.name)
    assert out.read_text().splitlines() == [
        '"utc","naive","day","clock","lag","x","third","f16","ok","s","none","flag","imu.gyro.z"',
        "1970-01-01 00:00:00.000Z,1970-01-01 00:00:00.000000,2019-03-11,14:22:05.123000,1.5,"
        '0.1,0.3333333333333333,1.5,true,"a,b",,false,0.5',
        "1970-01-01 00:00:01.500Z,1970-01-01 00:00:01.500000,2019-03-11,14:22:05.123000,"
        '-0.002,nan,,2,,"c",,true,-0.25',
    ]


def test_a_problem_names_the_table_file_and_its_own_row(tmp_path):
    plain = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    frame = pd.read_csv(plain, dtype=str)  # every column text, as a lake's raw export
    wheel = frame.columns[12]
    frame.loc[39, wheel] = "fast"  # the table's row 40
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path := tmp_path / "V-T.pq")
    with pytest.raises(InputError) as err:
        _read(path, tmp_path)
    (problem,) = err.value.problems
    assert (problem.file, problem.row, problem.column, problem.found) == (
        "V-T.pq",
        40,
        wheel,
        "'fast'",
    )


def test_the_csv_is_bounded_by_max_file_mb(tmp_path):
    plain = write_iovnbd(wavy_drive(60.0), tmp_path / "V-A.csv")
    table = tmp_path / "V-T.parquet"
    pq.write_table(pa.Table.from_pandas(pd.read_csv(plain), preserve_index=False), table)
    limit_mb = (table.stat().st_size + plain.stat().st_size) / 2 / 2**20  # above the file
    assert table.stat().st_size < limit_mb * 2**20 < plain.stat().st_size
    with pytest.raises(InputError) as err:
        _read(table, tmp_path, **{"data.max_file_mb": limit_mb})
    assert "as CSV text (data.max_file_mb)" in err.value.problems[0].expected
    assert err.value.problems[0].file == table.name


@pytest.mark.parametrize("kind", WRITE)
@pytest.mark.parametrize("damage", ["cut", "flipped"])
def test_a_damaged_table_is_refused_by_both_readers(tmp_path, kind, damage):
    plain = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv")
    table = _as_table(plain, kind)
    data = bytearray(table.read_bytes())
    if damage == "cut":  # a copy that stopped half way: no footer
        data = data[: len(data) // 2]
    else:  # a disk's error in the footer's metadata
        for i in range(len(data) - 400, len(data) - 360):
            data[i] ^= 0x5A
    table.write_bytes(bytes(data))
    with pytest.raises(InputError) as err:
        _read(table, tmp_path)
    assert err.value.problems[0].expected == f"a whole {kind} file"
    assert err.value.problems[0].file == table.name
    with pytest.raises(InputError) as err:
        source, _ = open_as_csv(table, kind, "V-T")
        with source:
            list(read_rows(source, "V-T", block_bytes=4096)[1])
    assert err.value.problems[0].expected == f"a whole {kind} file"


def test_a_table_of_no_column_a_csv_holds_is_refused(tmp_path):
    pq.write_table(pa.table({"frame": pa.array([b"\xff"], pa.binary())}), p := tmp_path / "x.pq")
    with pytest.raises(InputError) as err:
        _read(p, tmp_path)
    assert err.value.problems[0].found == "only columns no CSV cell holds: frame"


def test_a_table_in_a_pipe_is_named(tmp_path):
    table = _as_table(write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv"), PARQUET)
    with pytest.raises(InputError) as err:
        read_rows(io.BytesIO(table.read_bytes()), "<stdin>")
    assert "a table file (Parquet): give its path" in err.value.problems[0].found


def test_stream_files_kept_as_tables_read_as_the_folder_of_their_csvs(tmp_path):
    tables = tables_from_drive(role_drive("target_test", 60.0))
    plain = write_drive("stream_csv", tables, tmp_path / "plain", "C-B1", 0.3)
    kept = write_drive("stream_csv", tables, tmp_path / "kept", "C-B1", 0.3)
    ways = iter(["parquet.gz", "feather"])
    for path in sorted(kept.glob("*.csv")):
        way = next(ways)
        table = pa.Table.from_pandas(pd.read_csv(path), preserve_index=False)
        target = path.with_suffix("." + way.split(".")[0])
        (pq.write_table if way.startswith("parquet") else feather.write_feather)(table, target)
        if way.endswith(".gz"):
            target.with_name(target.name + ".gz").write_bytes(gzip.compress(target.read_bytes()))
            target.unlink()
        path.unlink()
    params = stream_params(tmp_path, "stream_csv")
    want, got = read_target_drive(params, plain), read_target_drive(params, kept)
    _assert_same(got.raw, want.raw)
    (said,) = [n for n in got.raw.notes if n.startswith("stream files kept as tables")]
    assert said.endswith(
        "read as the CSV they hold: gnss.parquet.gz (Parquet, 600 rows); "
        "wheels.feather (Arrow IPC (Feather), 6,000 rows)"
    )
    # each stream named by the file the user has, not by its scratch copy
    assert {s["file"] for s in got.streams.streams} <= {str(p) for p in kept.iterdir()}


TABLES = Path(__file__).parents[1] / "fixtures" / "tables"  # write_tables.py wrote them
_OTHERS = {"t": ("time", "iso8601"), "lat": ("lat", "deg"), "lon": ("lon", "deg")}
_OTHERS |= {"fix": ("fix", "bool"), "n_sats": ("sats", "count")}


@pytest.mark.parametrize(
    ("name", "wheel"),
    [("polars.parquet", "wheel_"), ("polars.arrow", "wheel_"), ("duckdb.parquet", "wheel.")],
)
def test_tables_other_tools_wrote_read_as_the_csv_polars_wrote(tmp_path, name, wheel):
    """Polars' Parquet and Arrow IPC (its text as string_view, its categories a dictionary
    of them) and DuckDB's Parquet (the wheels a struct, its time a TIMESTAMPTZ): every value
    of Polars' own CSV of the same drive, its booleans as true/false."""
    wheels = {f"omega_{k}": (f"{wheel}{k}", "rad/s") for k in ("fl", "fr", "rl", "rr")}
    maps = {"data.column_maps": {"lake": column_map_params(_OTHERS | wheels)}}
    csv_maps = {
        "data.column_maps": {
            "lake": column_map_params(
                _OTHERS | {f"omega_{k}": (f"wheel_{k}", "rad/s") for k in ("fl", "fr", "rl", "rr")}
            )
        }
    }
    want = _read(TABLES / "polars.csv", tmp_path, "lake", **csv_maps)
    got = _read(TABLES / name, tmp_path, "lake", **maps)
    _assert_same(got, want)
    assert np.isnan(got.columns[c.LAT_DEG][7]) and got.n_rows == 301  # fix false: no fix
    assert got.notes[0].endswith("read as CSV: 301 rows")


@pytest.mark.parametrize("kind", WRITE)
def test_a_column_name_damaged_out_of_utf8_is_refused_not_a_traceback(tmp_path, kind):
    """A changed byte in the schema's names (found by fuzzing: Arrow raised
    UnicodeDecodeError as the header was made, outside the reader's refusal)."""
    plain = write_iovnbd(wavy_drive(10.0), tmp_path / "V-A.csv")
    table = pa.Table.from_pandas(pd.read_csv(plain), preserve_index=False)
    WRITE[kind](
        table.append_column("ZZmarker", pa.array(np.zeros(table.num_rows))),
        path := tmp_path / f"V-T{SUFFIX[kind]}",
    )
    data = path.read_bytes()
    assert data.count(b"ZZmarker") >= 1
    path.write_bytes(data.replace(b"ZZmarker", b"\xbeZmarker"))
    with pytest.raises(InputError) as err:
        _read(path, tmp_path)
    assert err.value.problems[0].expected == f"a whole {kind} file"
    assert "UnicodeDecodeError" in err.value.problems[0].found


def _parts(folder: Path, table: pa.Table, names: list[str]) -> Path:
    """``table`` split in ``len(names)`` part files, in that order, as a writer's folder,
    with the summary files older Spark and Dask write beside them (``_metadata``: every
    part's row groups; ``_common_metadata``: the schema), which are Parquet too."""
    folder.mkdir(parents=True)
    edges = np.linspace(0, table.num_rows, len(names) + 1).astype(int)
    collected: list = []
    for name, a, b in zip(names, edges[:-1], edges[1:], strict=True):
        pq.write_table(table.slice(a, b - a), folder / name, metadata_collector=collected)
        collected[-1].set_file_path(name)
    pq.write_metadata(table.schema, folder / "_metadata", metadata_collector=collected)
    pq.write_metadata(table.schema, folder / "_common_metadata")
    return folder


SPARK = [f"part-{k:05d}-0f1e2d3c-4b5a-6978-8796-a5b4c3d2e1f0-c000.snappy.parquet" for k in range(3)]
DASK = [f"part.{k}.parquet" for k in range(12)]  # natural order: part.2 before part.10


@pytest.mark.parametrize("names", [SPARK, DASK], ids=["spark", "dask"])
def test_a_folder_of_part_files_reads_as_one_table_in_their_names_order(tmp_path, names):
    """A drive Spark (``df.write.parquet``: part files, ``_SUCCESS``, hidden ``.crc``
    files) or Dask wrote as a folder: every value of its CSV, the parts in natural order
    of their names."""
    plain = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv")
    table = pa.Table.from_pandas(pd.read_csv(plain), preserve_index=False)
    folder = _parts(tmp_path / "V-T.parquet", table, names)
    (folder / "_SUCCESS").write_bytes(b"")
    (folder / f".{names[0]}.crc").write_bytes(b"crc\x00")
    assert is_table_folder(folder) and table_kind(folder) == PARQUET
    assert table_parts(folder) == [folder / n for n in names]
    got = _read(folder, tmp_path)
    _assert_same(got, _read(plain, tmp_path))
    assert got.notes[0] == (
        f"a folder of {len(names)} Parquet part file(s), read in their names' order, read as "
        "CSV: 301 rows"
    )
    assert folder_id(folder) == "V-T" and folder_id(tmp_path / "C-B1") == "C-B1"
    # a write partitioned by the drive's column: each partition's folder a drive
    partition = _parts(tmp_path / "lake" / "drive_id=C-B1%2F2", table, names[:2])
    assert folder_id(partition) == "C-B1%2F2" and folder_id(tmp_path / "a=b") == "a=b"


def test_a_stream_written_as_a_folder_of_part_files_is_read_as_its_table(tmp_path):
    """A stream folder's stream Spark wrote as a folder (``wheels.parquet/``: part files,
    ``_SUCCESS``, ``.crc`` files) or Dask did (``gnss.parquet/part.0.parquet``, ...): every
    value of the drive whose streams are CSV files; a folder of no Parquet file is no stream
    (left alone, as before)."""
    tables = tables_from_drive(role_drive("target_test", 60.0))
    plain = write_drive("stream_csv", tables, tmp_path / "plain", "C-B1", 0.3)
    kept = write_drive("stream_csv", tables, tmp_path / "kept", "C-B1", 0.3)
    for path, names in zip(sorted(kept.glob("*.csv")), [DASK, SPARK], strict=True):
        table = pa.Table.from_pandas(pd.read_csv(path), preserve_index=False)
        folder = _parts(path.with_suffix(".parquet"), table, names)
        (folder / "_SUCCESS").write_bytes(b"")
        (folder / f".{names[0]}.crc").write_bytes(b"crc\x00")
        path.unlink()
    (kept / "notes").mkdir()
    (kept / "notes" / "trip.txt").write_text("a folder of no table is none of the streams")
    params = stream_params(tmp_path, "stream_csv")
    want, got = read_target_drive(params, plain), read_target_drive(params, kept)
    _assert_same(got.raw, want.raw)
    (said,) = [n for n in got.raw.notes if n.startswith("stream files kept as tables")]
    assert said.endswith(
        "read as the CSV they hold: gnss.parquet (Parquet, 12 part file(s), 600 rows); "
        "wheels.parquet (Parquet, 3 part file(s), 6,000 rows)"
    )
    assert {s["file"] for s in got.streams.streams} == {
        str(kept / "gnss.parquet"),
        str(kept / "wheels.parquet"),
    }
    # a part of other columns is refused naming the folder's part, as a drive's is
    part = kept / "wheels.parquet" / SPARK[1]
    held = pq.read_table(part)
    pq.write_table(held.drop_columns([held.column_names[0]]), part)
    with pytest.raises(InputError) as err:
        read_target_drive(params, kept)
    assert [p.file for p in err.value.problems] == [f"{kept / 'wheels.parquet'}/{SPARK[1]}"]


def test_a_part_of_other_columns_or_damaged_is_refused_naming_it(tmp_path):
    plain = write_iovnbd(wavy_drive(30.0), tmp_path / "V-A.csv")
    table = pa.Table.from_pandas(pd.read_csv(plain), preserve_index=False)
    folder = _parts(tmp_path / "V-T", table, SPARK)
    pq.write_table(table.slice(200).drop_columns([table.column_names[3]]), folder / SPARK[2])
    with pytest.raises(InputError) as err:
        _read(folder, tmp_path)
    (p,) = err.value.problems
    assert p.file == f"V-T/{SPARK[2]}" and p.expected.endswith(SPARK[0])
    assert p.found.startswith("columns Sats,  Time,  Lat,  Velocity kmh")
    pq.write_table(table.slice(200), folder / SPARK[2])
    data = (folder / SPARK[1]).read_bytes()
    (folder / SPARK[1]).write_bytes(data[: len(data) // 2])  # a part a copy cut short
    with pytest.raises(InputError) as err:
        _read(folder, tmp_path)
    assert (err.value.problems[0].file, err.value.problems[0].expected) == (
        f"V-T/{SPARK[1]}",
        "a whole Parquet file",
    )
    (tmp_path / "empty").mkdir()
    assert not is_table_folder(tmp_path / "empty") and table_kind(tmp_path / "empty") is None
