"""One 10 Hz file of many drives, a column naming each row's drive (a column map's ``drive``
key): split into its drives, each read as a file of its own would be, its rows counted from
its first; through ingest, and the command line's check, predict and recalibrate."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from rwhonet import paths
from rwhonet.config import ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import check_column_map
from rwhonet.data.csvio import units_row_note
from rwhonet.data.drivefile import DriveFile, fleet_drives, read_any, read_canonical
from rwhonet.data.fleetfile import ID_MAX_CHARS, id_problem, split_fleet
from rwhonet.errors import InputError
from rwhonet.stages.ingest import ingest
from support.drives import (
    CUPAC_MAP,
    TARGET_RADIUS_M,
    VBO_MAP,
    column_map_params,
    make_params,
    straight_drive,
    write_columnmap,
    write_fleet,
    write_vbo,
)

IDS = ("T-A1", "T-B1", "T-B2")
FLEET_MAP = column_map_params(CUPAC_MAP) | {"drive": {"column": "trip_id", "unit": "text"}}


def _singles(root: Path, seconds: float = 30.0) -> dict[str, Path]:
    """Three drives of the target car, each a CSV of its own (the cupac layout)."""
    return {
        k: write_columnmap(
            straight_drive(seconds, radius_m=TARGET_RADIUS_M, lat0_deg=52.40 + 0.01 * i),
            root / "single" / f"{k}.csv",
        )
        for i, k in enumerate(IDS)
    }


def _fleet(singles: dict[str, Path], path: Path) -> pd.DataFrame:
    """The drives as one table: the first in a block, the other two row by row among each
    other (a log of two cars sorted by time), a ``trip_id`` column naming each row's."""
    a, b, b2 = (pd.read_csv(singles[k]).assign(trip_id=k) for k in IDS)
    inter = pd.concat([b, b2]).iloc[
        np.argsort(np.r_[2 * np.arange(len(b)), 2 * np.arange(len(b2)) + 1], kind="stable")
    ]
    fleet = pd.concat([a, inter], ignore_index=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    fleet.to_csv(path, index=False)
    return fleet


def _data(root: Path, cmap: dict = FLEET_MAP, **overrides):
    return make_params(root, **{"data.column_maps.cupac": cmap, **overrides}).data


def _read(f: DriveFile, data):
    return read_any(f, data, lambda p: p.name, TARGET_RADIUS_M, 0.1, 10.0)[0]


def _same(got, want) -> None:
    assert set(got.columns) == set(want.columns)
    for name in want.columns:
        np.testing.assert_array_equal(got.columns[name], want.columns[name], err_msg=name)


@pytest.mark.parametrize("table", [False, True], ids=["csv", "parquet"])
def test_each_drive_reads_as_its_own_file_in_a_block_or_among_the_others(tmp_path, table):
    """A file of three drives, one in a block and two row by row among each other, as a
    CSV and as a Parquet table: its drives in the order they first appear, each one's
    values those of its own file; the notes say where its rows lay."""
    singles = _singles(tmp_path)
    path = tmp_path / "fleet.csv"
    fleet = _fleet(singles, path)
    if table:
        path = tmp_path / "fleet.parquet"
        pq.write_table(pa.Table.from_pandas(fleet, preserve_index=False), path, row_group_size=97)
    data = _data(tmp_path)
    f = DriveFile("fleet", "target_test", "target", "cupac", path)
    drives = fleet_drives(f, data, lambda p: p.name)
    assert [(d.drive, d.part, d.split) for d in drives] == [(k, k, None) for k in IDS]
    for d in drives:
        got = _read(d, data)
        _same(got, _read(DriveFile(d.drive, "t", "target", "cupac", singles[d.drive]), data))
    notes = [_read(d, data).notes[0] for d in drives]
    assert notes[0] == (
        f"drive 'T-A1' of {path.name}, whose column 'trip_id' names each row's drive: 301 of "
        "its 903 data rows, its data rows 1-301; rows named in messages are the drive's own, "
        "counted from its first (the file's data row 1)"
    )
    assert "301 of its 903 data rows, in 301 runs between its data rows 303 and 903" in notes[2]


def test_the_split_keeps_the_files_own_ways(tmp_path):
    """A file of ';' with a row of units under its header and comment lines above it, the
    header's line and its units again among its rows (a logger's restart), quoted ids, blank
    lines and a last row cut short by a power loss: each drive reads as its own file so
    written."""
    singles = _singles(tmp_path, 10.0)
    _fleet(singles, tmp_path / "plain.csv")
    lines = (tmp_path / "plain.csv").read_text().splitlines()
    header, rows = lines[0], lines[1:]
    quoted = [r.replace(",T-B2", ',"  T-B2 "') for r in rows]  # spaces in its quotes
    unit_of = {col: unit for col, unit in CUPAC_MAP.values()}
    units = ";".join(unit_of.get(name, "") for name in header.split(","))
    text = ["# logger v2", "# car: test", header.replace(",", ";"), units]
    text += [r.replace(",", ";") for r in quoted[:150]]
    text += ["", header.replace(",", ";"), units]  # its units row again too
    text += [r.replace(",", ";") for r in quoted[150:]]
    cut = text[-1][: len(text[-1]) // 3]  # its drive's cell lost with the rest of the row
    text[-1] = cut
    path = tmp_path / "fleet.csv"
    path.write_bytes(("\n".join(text)).encode())  # no line end after the cut row
    data = _data(tmp_path)
    split = split_fleet(path, "trip_id", "fleet.csv", "data.column_maps.cupac.drive")
    assert [p.drive for p in split.parts] == list(IDS)
    assert (split.rows, split.header_again, split.column) == (305, 2, "trip_id")
    assert [p.rows for p in split.parts] == [101, 101, 100]  # T-B2's last row cut short
    assert split.cut_last == 305
    f = DriveFile("fleet", "target_test", "target", "cupac", path)
    got = {d.drive: _read(d, data) for d in fleet_drives(f, data, lambda p: p.name)}
    for k in IDS:
        want = _read(DriveFile(k, "t", "target", "cupac", singles[k]), data)
        if k == "T-B2":  # its last row is the cut one: lost
            for n, v in want.columns.items():
                np.testing.assert_array_equal(got[k].columns[n], v[:-1], err_msg=n)
        else:
            _same(got[k], want)
    assert units_row_note() in got["T-A1"].notes  # the units row read, in each drive
    said = got["T-A1"].notes[0]
    assert (
        "; the header's line (or its units row) again in 2 of the file's rows, left out; the "
        "file's last row " in said
    )
    assert said.endswith(
        "(305) cut short before its drive's cell (a logger that lost power), left out: its "
        "sample lost"
    )
    # a row too short to hold its drive's id inside the file: refused
    text.insert(10, "1;2;3")
    path.write_bytes(("\n".join(text)).encode())
    with pytest.raises(InputError) as err:
        split_fleet(path, "trip_id", "fleet.csv", "data.column_maps.cupac.drive")
    assert [(p.row, p.found) for p in err.value.problems] == [(7, "a row too short to hold it")]


def test_a_drive_s_rows_are_counted_from_its_first(tmp_path):
    """A message about a drive of the file names it ``fleet.csv (drive T-B2)`` and the
    drive's own row: its fifth row, the file's data row 111 among the others'."""
    singles = _singles(tmp_path, 10.0)
    fleet = _fleet(singles, tmp_path / "fleet.csv")
    at = fleet.index[fleet["trip_id"] == "T-B2"][4]
    fleet["WheelSpeedRL"] = fleet["WheelSpeedRL"].astype(object)
    fleet.loc[at, "WheelSpeedRL"] = "fast"
    fleet.to_csv(tmp_path / "fleet.csv", index=False)
    data = _data(tmp_path)
    f = DriveFile("fleet", "target_test", "target", "cupac", tmp_path / "fleet.csv")
    b2 = fleet_drives(f, data, lambda p: p.name)[2]
    with pytest.raises(InputError) as err:
        _read(b2, data)
    (p,) = err.value.problems
    assert (p.file, p.row, p.column, p.found) == (
        "fleet.csv (drive T-B2)",
        5,
        "WheelSpeedRL",
        "'fast'",
    )
    assert at + 1 == 111  # the file's own data row: the fifth of T-B2 among T-B1's
    _read(fleet_drives(f, data, lambda p: p.name)[0], data)  # the others read


def test_a_file_that_cannot_be_split_is_refused_naming_row_and_column(tmp_path):
    singles = _singles(tmp_path, 5.0)
    fleet = _fleet(singles, tmp_path / "fleet.csv")
    fleet.loc[3, "trip_id"] = ""
    fleet.loc[7, "trip_id"] = "../T-A1"
    fleet.to_csv(tmp_path / "fleet.csv", index=False)
    with pytest.raises(InputError) as err:
        split_fleet(tmp_path / "fleet.csv", "trip_id", "fleet.csv", "s.drive")
    assert [(p.file, p.row, p.column, p.found) for p in err.value.problems] == [
        ("fleet.csv", 4, "trip_id", "an empty cell"),
        ("fleet.csv", 8, "trip_id", "'../T-A1', which cannot name the drive's files"),
    ]
    with pytest.raises(InputError) as err:
        split_fleet(tmp_path / "fleet.csv", "session", "fleet.csv", "data.column_maps.x.drive")
    assert "a column named 'session' (data.column_maps.x.drive)" in str(err.value)
    assert id_problem("x" * ID_MAX_CHARS) is None
    assert id_problem("x" * (ID_MAX_CHARS + 1)) == f"an id of {ID_MAX_CHARS + 1} characters"
    assert id_problem("a\tb") is not None and id_problem("..") is not None
    assert id_problem("T-B1 (2019)") is None


def test_the_map_s_drive_key_is_checked(tmp_path):
    check_column_map("f", {k: v for k, v in _data(tmp_path).column_maps["cupac"].items()})
    bad = column_map_params(CUPAC_MAP) | {"drive": {"column": "trip_id", "unit": "id"}}
    with pytest.raises(ConfigError, match=r"cupac\.drive\.unit: expected 'text'"):
        check_column_map("cupac", _data(tmp_path, bad).column_maps["cupac"])


def test_a_vbox_file_read_by_a_map_of_many_drives_is_refused(tmp_path):
    """A VBOX file holds one drive: a map with a drive key for it is refused, naming it."""
    vbo = write_vbo(straight_drive(10.0), tmp_path / "run.vbo")
    cmap = column_map_params(VBO_MAP) | {"drive": {"column": "trip_id", "unit": "text"}}
    data = make_params(tmp_path, **{"data.column_maps.vbox": cmap}).data
    with pytest.raises(InputError) as err:
        fleet_drives(DriveFile("run", "t", "target", "vbox", vbo), data, lambda p: p.name)
    [problem] = err.value.problems
    assert (problem.file, problem.found) == (
        "run.vbo",
        "a Racelogic VBOX file, which holds one drive",
    )


def test_ingest_reads_a_file_of_many_drives_as_its_drives(tmp_path):
    """A role whose glob names a file of many drives: each one a drive of the manifest,
    named by its id, its canonical table that of its own file, its scenario sidecar
    ``<drive>.scenarios.json`` beside the file; a drive refused names the file's drive."""
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=30.0)
    singles = _singles(tmp_path, 30.0)
    fleet = _fleet(singles, raw / "fleet" / "trips.csv")
    t0 = float(fleet["Time"][fleet["trip_id"] == "T-B1"].iloc[0]) / 1000.0  # ms
    sidecar = {"intervals": [{"start_s": t0 + 2.0, "end_s": t0 + 5.0, "tag": "roundabout"}]}
    (raw / "fleet" / "T-B1.scenarios.json").write_text(json.dumps(sidecar))
    role = {"glob": "fleet/*.csv", "format": "cupac", "vehicle": "target", "required": True}
    params = make_params(
        raw, **{"data.column_maps.cupac": FLEET_MAP, "data.roles.target_test": role}
    )
    out = tmp_path / "drives"
    manifest = ingest(params, out)
    ours = [d for d in manifest["drives"] if d["role"] == "target_test"]
    assert [d["drive"] for d in ours] == list(IDS)
    trips = paths.rel(raw / "fleet" / "trips.csv")
    assert [d["source_file"] for d in ours] == [f"{trips} (drive {k})" for k in IDS]
    assert ours[1]["scenarios_file"].endswith("T-B1.scenarios.json")
    assert ours[0]["scenarios_file"] is None
    assert ours[0]["notes"][0].startswith(f"drive 'T-A1' of {trips}, whose column 'trip_id'")
    one = make_params(
        tmp_path / "single",
        **{
            "data.column_maps.cupac": column_map_params(CUPAC_MAP),
            "data.roles.target_test": role | {"glob": "*.csv"},
        },
    )
    for k in IDS:
        got = pd.read_feather(out / f"{k}.arrow")
        f = DriveFile(k, "target_test", "target", "cupac", singles[k])
        want = read_canonical(f, one.data, radius_m=TARGET_RADIUS_M).raw.columns
        for name in (c.T_S, c.LAT_DEG, c.OMEGA_RL, c.N_SATS):
            np.testing.assert_array_equal(got[name].to_numpy(), want[name], err_msg=name)
    assert (pd.read_feather(out / "T-B1.arrow")[c.SCENARIO] == "roundabout").sum() == 30
    # a drive the readers refuse: named as the file's drive, its own row
    fleet["Time"] = fleet["Time"].astype(object)
    fleet.loc[fleet.index[fleet["trip_id"] == "T-B1"][2], "Time"] = "noon"
    fleet.to_csv(raw / "fleet" / "trips.csv", index=False)
    with pytest.raises(InputError) as err:
        ingest(params, tmp_path / "refused")
    assert [(p.file, p.row) for p in err.value.problems] == [(f"{trips} (drive T-B1)", 3)]
    left = ingest(
        make_params(
            raw,
            **{
                "data.column_maps.cupac": FLEET_MAP,
                "data.roles.target_test": role,
                "data.refused_drives": "leave_out",
            },
        ),
        tmp_path / "left",
    )
    assert [d["drive"] for d in left["drives"] if d["role"] == "target_test"] == ["T-A1", "T-B2"]
    assert [d["drive"] for d in left["left_out"]] == ["T-B1"]
    # a drive id of the file that another role's file has too: refused, both named
    (raw / "target_train" / "C-A1.csv").rename(raw / "target_train" / "T-B2.csv")
    with pytest.raises(InputError, match="'T-B2' \\(target_test\\) is also"):
        ingest(params, tmp_path / "twice")


def test_roles_share_one_file_each_taking_its_drives(tmp_path, monkeypatch):
    """``data.roles.<role>.drives``: two roles read one file of many drives, each the drives
    its patterns name (an id, a pattern), only theirs split out; a pattern that names no
    drive is refused, naming it and the drives there are; the patterns pick among a
    glob's own files too; an empty list is refused as a setting."""
    import rwhonet.data.fleetfile as fleetfile

    raw = tmp_path / "raw"
    written_by = write_fleet(raw, duration_s=30.0)
    written_by["target_train"].unlink()  # the target car's drives: the file's
    written_by["target_test"].unlink()
    _fleet(_singles(tmp_path, 30.0), raw / "lake" / "trips.csv")
    role = {"glob": "lake/trips.csv", "format": "cupac", "vehicle": "target", "required": True}
    roles = {
        "data.roles.target_train": role | {"drives": ["T-A1"]},
        "data.roles.target_test": role | {"drives": ["T-B*"]},
    }
    written: list[str] = []
    split = fleetfile.split_fleet

    def spy(*args, **kwargs):
        got = split(*args, **kwargs)
        written.extend(p.drive for p in got.parts if p.csv is not None)
        return got

    monkeypatch.setattr("rwhonet.data.drivefile.split_fleet", spy)
    params = make_params(raw, **{"data.column_maps.cupac": FLEET_MAP, **roles})
    manifest = ingest(params, tmp_path / "drives")
    by_role = {
        r: [d["drive"] for d in manifest["drives"] if d["role"] == r]
        for r in ("target_train", "target_test")
    }
    assert by_role == {"target_train": ["T-A1"], "target_test": ["T-B1", "T-B2"]}
    assert sorted(written) == ["T-A1", "T-B1", "T-B2"]  # each once: its own role's
    # a pattern that names no drive: refused, not a drive left out unsaid
    typo = roles | {"data.roles.target_test": role | {"drives": ["T-B*", "T-C1"]}}
    with pytest.raises(InputError) as err:
        ingest(make_params(raw, **{"data.column_maps.cupac": FLEET_MAP, **typo}), tmp_path / "x")
    [problem] = err.value.problems
    assert "a drive whose id matches 'T-C1' among the drives" in problem.expected
    assert problem.found == "none of its 3: T-A1, T-B1, T-B2"
    # among a glob's own files
    own = {"glob": "source_train/*.csv", "format": "iovnbd", "vehicle": "source"}
    more = raw / "source_train" / "V-S2.csv"
    more.write_bytes((raw / "source_train" / "V-S1.csv").read_bytes())
    picked = make_params(
        raw,
        **{
            "data.column_maps.cupac": FLEET_MAP,
            **roles,
            "data.roles.source_train": own | {"drives": ["V-S2"]},
        },
    )
    ids = [
        d["drive"] for d in ingest(picked, tmp_path / "p")["drives"] if d["role"] == "source_train"
    ]
    assert ids == ["V-S2"]
    with pytest.raises(ConfigError, match=r"data\.roles\.target_test\.drives: expected a list"):
        make_params(raw, **{"data.roles.target_test": role | {"drives": []}})


def test_validate_cuts_a_file_s_drives_as_it_cuts_their_own_files(tmp_path):
    """Ingest then validate on a role of one file of three drives: each drive's segments
    those its own file gives, value for value; only the file named differs."""
    from rwhonet.stages.validate import validate

    singles = _singles(tmp_path, 140.0)  # a test drive: adapt on 100 s, score 30 s
    outs = {}
    for kind in ("single", "fleet"):
        raw = tmp_path / kind / "raw"
        write_fleet(raw, duration_s=40.0)["target_test"].unlink()
        if kind == "single":
            for k, p in singles.items():
                (raw / "target_test" / f"{k}.csv").write_bytes(p.read_bytes())
            cmap, glob = column_map_params(CUPAC_MAP), "target_test/*.csv"
        else:
            _fleet(singles, raw / "target_test" / "trips.csv")
            cmap, glob = FLEET_MAP, "target_test/trips.csv"
        role = {"glob": glob, "format": "cupac", "vehicle": "target", "required": True}
        params = make_params(
            raw, **{"data.column_maps.cupac": cmap, "data.roles.target_test": role}
        )
        drives, segments = tmp_path / kind / "drives", tmp_path / kind / "segments"
        ingest(params, drives)
        outs[kind] = validate(params, drives, segments, tmp_path / kind / "report.json")
        outs[kind + "_dir"] = segments
    mine = {k: [d for d in outs[k]["drives"] if d["drive"] in IDS] for k in ("single", "fleet")}
    assert [d["drive"] for d in mine["fleet"]] == list(IDS)
    for one, many in zip(mine["single"], mine["fleet"], strict=True):
        assert many["source_file"].endswith(f"trips.csv (drive {one['drive']})")
        for key in ("rows", "rows_kept", "seconds_kept", "segments", "cuts", "radius"):
            assert one[key] == many[key], key
    segs = sorted(p.name for p in outs["single_dir"].glob("T-*"))
    assert segs and segs == sorted(p.name for p in outs["fleet_dir"].glob("T-*"))
    for name in segs:
        pd.testing.assert_frame_equal(
            pd.read_feather(outs["fleet_dir"] / name), pd.read_feather(outs["single_dir"] / name)
        )
