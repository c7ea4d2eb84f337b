"""A receiver's fix status in a column of its own (a map's ``fix`` key).

A logger writes the receiver's position beside its status (GGA quality, u-blox
``fixType``, a NavSatStatus, a flag); a position the status says is no fix (the
receiver's own dead reckoning, GGA 6 or ``fixType`` 1) is taken as none, by ingest's and
predict's column-map readers and by every signal-map reader (stream CSVs, MDF4, ROS
bags). A code the unit does not have is refused with its row.
"""

from __future__ import annotations

import io
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rwhonet.config import ColumnSpec, ConfigError
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import check_column_map, read_columnmap
from rwhonet.data.fixstatus import (
    FIX_STATUS,
    NO_STATUS,
    POSITIONS,
    is_fix,
    note,
    refuse_bad_codes,
    screen,
)
from rwhonet.data.incremental import read_rows
from rwhonet.data.signalmap import check_signal_map
from rwhonet.errors import InputError
from support.drives import CUPAC_MAP, TARGET_RADIUS_M, straight_drive, write_columnmap

T0 = 45000.0


def _specs(cmap: dict) -> dict[str, ColumnSpec]:
    return {k: ColumnSpec(col, unit) for k, (col, unit) in cmap.items()}


@pytest.mark.parametrize(
    ("unit", "codes", "fixes"),
    [
        ("gga", [0, 1, 2, 3, 4, 5, 6, 7, 8, 9], [0, 1, 1, 1, 1, 1, 0, 0, 0, 1]),
        ("ubx", [0, 1, 2, 3, 4, 5], [0, 0, 1, 1, 1, 0]),
        ("navsat", [-2, -1, 0, 1, 2, 18, 33], [0, 0, 1, 1, 1, 1, 1]),
        ("flag", [0, 1], [0, 1]),
        # Septentrio's Mode: bits 0-3 (bit 7: 2D; bit 6: a fixed position's) say it
        (
            "sbf",
            [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 15, 129, 131, 196],
            [0, 1, 1, 0, 1, 1, 1, 1, 1, 0, 1, 0, 1, 0, 1],
        ),
        ("gpsd", [0, 1, 2, 3], [0, 0, 1, 1]),
    ],
)
def test_each_unit_s_codes_that_are_a_fix(unit, codes, fixes):
    x = np.array([*codes, np.nan], dtype=np.float64)
    refuse_bad_codes(x, unit, "f.csv", "Q")  # every code of the unit, and an empty cell
    assert is_fix(x, unit).tolist() == [*map(bool, fixes), False]


@pytest.mark.parametrize(
    ("unit", "bad"),
    [
        ("gga", 10.0),
        ("gga", -1.0),
        ("gga", 1.5),
        ("ubx", 6.0),
        ("navsat", 0.5),
        ("flag", 2.0),
        ("sbf", 256.0),
        ("sbf", -1.0),
        ("gpsd", 4.0),
    ],
)
def test_a_code_the_unit_does_not_have_is_refused_with_its_row(unit, bad):
    x = np.array([1.0, 1.0, bad, 1.0, np.inf])
    with pytest.raises(InputError) as err:
        refuse_bad_codes(x, unit, "f.csv", "Quality", rows=np.array([7, 8, 9, 10, 11]))
    problems = err.value.problems
    assert [(p.file, p.row, p.column) for p in problems] == [
        ("f.csv", 9, "Quality"),
        ("f.csv", 11, "Quality"),
    ]
    assert problems[0].found == repr(bad)
    assert unit in problems[0].fix


def test_screen_takes_out_every_gnss_channel_of_a_position_that_is_no_fix():
    columns = {
        c.T_S: np.arange(6.0),
        c.LAT_DEG: np.array([52.0, 52.0, 52.0, np.nan, 52.0, 52.0]),
        c.LON_DEG: np.full(6, -1.5),
        c.N_SATS: np.full(6, 9.0),
        c.SPEED_GNSS_M_S: np.full(6, 10.0),
        c.OMEGA_RL: np.full(6, 30.0),
        FIX_STATUS: np.array([1.0, 6.0, np.nan, 0.0, 6.0, 4.0]),
    }
    counts: Counter = Counter()
    out = screen(columns, "gga", counts)
    assert FIX_STATUS not in out
    none = [False, True, True, False, True, False]  # row 3: no position to take out
    for name in (c.LAT_DEG, c.LON_DEG, c.N_SATS, c.SPEED_GNSS_M_S):
        assert np.isnan(out[name][none]).all(), name
        assert np.isfinite(out[name][[0, 5]]).all(), name
    np.testing.assert_array_equal(out[c.OMEGA_RL], columns[c.OMEGA_RL])  # not a fix's
    np.testing.assert_array_equal(out[c.T_S], columns[c.T_S])
    assert counts == {POSITIONS: 5, 6: 2, NO_STATUS: 1}
    said = note(counts, "gga", "f.csv", " Quality ")
    assert said == (
        "f.csv: 3 of 5 position(s) whose fix status (Quality, gga) says no fix, taken as rows "
        "without a fix: 2 at 6 (estimated (dead reckoning)); 1 with no status"
    )
    assert note(Counter({POSITIONS: 5}), "gga", "f.csv", "Quality") is None


def test_maps_take_the_fix_key_in_its_units_and_refuse_another_or_a_scale():
    required = _specs(CUPAC_MAP)
    for unit in ("gga", "ubx", "navsat", "flag"):
        check_column_map("m", {**required, "fix": ColumnSpec("Quality", unit)})
        check_signal_map("s", {**required, "fix": ColumnSpec("/gps.status", unit)})
    with pytest.raises(ConfigError, match=r"data.column_maps.m.fix.unit: expected one of"):
        check_column_map("m", {**required, "fix": ColumnSpec("Quality", "nmea")})
    with pytest.raises(ConfigError, match=r"m.fix: expected no scale or offset on a fix status"):
        check_column_map("m", {**required, "fix": ColumnSpec("Quality", "gga", scale=2.0)})


def _drive_with_status(tmp_path: Path, status: np.ndarray, name: str = "d.csv") -> Path:
    """A straight drive of ``len(status)`` 10 Hz rows, the status beside its fixes."""
    df = straight_drive((len(status) - 1) / 10.0, radius_m=TARGET_RADIUS_M, lat0_deg=52.41)
    assert len(df) == len(status)
    path = write_columnmap(df, tmp_path / name, CUPAC_MAP)
    table = pd.read_csv(path)
    table["GPS Quality"] = status
    table.to_csv(path, index=False)
    return path


def _predict_rows(path: Path, cmap: dict, name: str | None = None, block_bytes: int = 2048):
    """predict's reader of a column-mapped file, a few KiB at a time: its layout (the
    notes) and the blocks' latitudes, joined."""
    lay, blocks = read_rows(
        io.BytesIO(path.read_bytes()),
        name or path.name,
        "m",
        _specs(cmap),
        block_bytes=block_bytes,
        radius_m=TARGET_RADIUS_M,
    )
    parts = list(blocks)  # each part screened and counted as it is parsed
    assert all(FIX_STATUS not in b for _, b in parts)
    return lay, np.concatenate([b[c.LAT_DEG] for _, b in parts])


def _dead_reckoning_rows(n: int) -> np.ndarray:
    status = np.full(n, 1.0)
    status[50:60] = 6.0  # the receiver's own dead reckoning, 1 s
    status[120] = 0.0
    return status


def test_ingest_s_and_predict_s_readers_take_a_position_that_is_no_fix_as_none(tmp_path):
    n = 201
    status = _dead_reckoning_rows(n)
    path = _drive_with_status(tmp_path, status)
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "gga")}
    raw = read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    got = raw.columns
    none = status != 1.0
    assert FIX_STATUS not in got and FIX_STATUS not in raw.source_columns
    for name in (c.LAT_DEG, c.LON_DEG, c.N_SATS):
        assert np.isnan(got[name][none]).all() and np.isfinite(got[name][~none]).all()
    assert np.isfinite(got[c.OMEGA_RL]).all() and got[c.T_S].size == n
    said = [x for x in raw.notes if "fix status" in x]
    assert said == [
        f"{path}: 11 of 201 position(s) whose fix status (GPS Quality, gga) says no fix, "
        "taken as rows without a fix: 1 at 0 (invalid); 10 at 6 (estimated (dead reckoning))"
    ]
    # predict's reader, in blocks of a few dozen rows: the same rows, one note for them all
    lay, lat = _predict_rows(path, cmap)
    np.testing.assert_array_equal(lat, got[c.LAT_DEG])
    assert [x for x in lay.notes if "fix status" in x] == [said[0].replace(str(path), path.name)]


def test_a_column_map_s_status_that_is_no_code_is_refused_naming_file_row_and_column(tmp_path):
    status = np.full(201, 1.0)
    status[33] = 12.0
    path = _drive_with_status(tmp_path, status)
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "gga")}
    for read in (
        lambda: read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M),
        lambda: _predict_rows(path, cmap, str(path)),
    ):
        with pytest.raises(InputError) as err:
            read()
        (p,) = err.value.problems
        assert (p.file, p.row, p.column, p.found) == (str(path), 34, "GPS Quality", "12.0")
        assert "data.column_maps.m.fix declares 'gga'" in p.fix


def _stream_csvs(tmp_path: Path, status: np.ndarray, status_file: str | None = None) -> dict:
    """A wheel CSV at 80 Hz and a 1 Hz receiver CSV whose u-blox fixType says 1 (dead
    reckoning only) at fixes 10 and 11; the status in the receiver's file, or in one of its
    own (``status_file``) logged 0.05 s before each fix (the last at or before a fix is
    its)."""
    v, r = 12.0, TARGET_RADIUS_M
    t_w = np.arange(0.0, 30.0, 0.0125) + 5000.0
    t_g = np.arange(0.0, 30.0, 1.0) + 5000.3
    wheels = {f"w{k}": v / r for k in ("fl", "fr", "rl", "rr")}
    pd.DataFrame({"t": t_w, **wheels}).to_csv(tmp_path / "can.csv", index=False)
    lat = -33.9 + v * (t_g - 5000.0) / 110_900.0
    gps = pd.DataFrame({"t": t_g, "lat": lat, "lon": 151.2})
    if status_file is None:
        gps["fixType"] = status
    else:
        pd.DataFrame({"t": t_g - 0.05, "fixType": status}).to_csv(
            tmp_path / status_file, index=False
        )
    gps.to_csv(tmp_path / "gps.csv", index=False)
    return {
        "t": ColumnSpec("t", "s"),
        **{f"omega_{k}": ColumnSpec(f"w{k}", "rad/s") for k in ("fl", "fr", "rl", "rr")},
        "lat": ColumnSpec("lat", "deg"),
        "lon": ColumnSpec("lon", "deg"),
        "fix": ColumnSpec("fixType", "ubx"),
    }


@pytest.mark.parametrize("status_file", [None, "status.csv"])
def test_stream_csvs_take_a_fix_their_status_says_is_none_as_none(tmp_path, status_file):
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample

    status = np.full(30, 3.0)
    status[[10, 11]] = 1.0
    smap = _stream_csvs(tmp_path, status, status_file)
    streams = read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, TARGET_RADIUS_M)
    lat = streams.gnss.channels[c.LAT_DEG]
    assert np.isnan(lat[[10, 11]]).all() and np.isfinite(np.delete(lat, [10, 11])).all()
    assert FIX_STATUS not in streams.gnss.channels and FIX_STATUS not in streams.gnss.sources
    assert any(
        "2 of 30 position(s) whose fix status" in x and "2 at 1 (dead reckoning only)" in x
        for x in streams.notes
    )
    # onto the grid: no position between the fixes before and after the two
    d = resample(streams, max_fix_gap_s=1.5).drive.columns
    t, gap = d[c.T_S], (d[c.T_S] > 5009.3 + 1e-6) & (d[c.T_S] < 5012.3 - 1e-6)
    assert (
        np.isnan(d[c.LAT_DEG][gap]).all() and np.isfinite(d[c.LAT_DEG][~gap & (t > 5000.3)]).all()
    )


def test_a_stream_s_status_that_is_no_code_is_refused_with_its_file_and_row(tmp_path):
    from rwhonet.data.streamcsv import read_stream_csvs

    status = np.full(30, 3.0)
    status[7] = 9.0
    smap = _stream_csvs(tmp_path, status)
    with pytest.raises(InputError) as err:
        read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, TARGET_RADIUS_M)
    (p,) = err.value.problems
    assert (p.row, p.column, p.found) == (8, "fixType", "9.0")
    assert "gps.csv" in p.file and "the map's fix.unit declares 'ubx'" in p.fix


def test_an_mdf4_signal_of_the_receiver_s_fix_type_takes_its_dead_reckoning_out(tmp_path):
    from asammdf import MDF, Signal

    from rwhonet.data.mdf4 import read_mdf4

    r, v = TARGET_RADIUS_M, 14.0
    mdf = MDF(version="4.10")
    t_w = np.arange(0.0, 20.0, 0.02)
    mdf.append([Signal(np.full(t_w.size, v / r), t_w, name=f"W{k}") for k in range(4)])
    t_g = np.arange(0.05, 20.0, 0.2)  # a 5 Hz receiver, its fixType in the same message
    fix_type = np.where((t_g > 8.0) & (t_g < 9.0), 1, 3).astype(np.uint8)
    lat = 48.1 + v * t_g / 111_200.0
    mdf.append(
        [
            Signal(lat, t_g, name="Lat", unit="deg"),
            Signal(np.full(t_g.size, 11.5), t_g, name="Lon", unit="deg"),
            Signal(fix_type, t_g, name="FixType"),
        ]
    )
    path = tmp_path / "log.mf4"
    mdf.save(path, overwrite=True)
    mdf.close()
    smap = {
        **{
            f"omega_{w}": ColumnSpec(f"W{k}", "rad/s")
            for k, w in enumerate(("fl", "fr", "rl", "rr"))
        },
        "lat": ColumnSpec("Lat", "deg"),
        "lon": ColumnSpec("Lon", "deg"),
        "fix": ColumnSpec("FixType", "ubx"),
    }
    streams = read_mdf4(path, smap, r)
    got = streams.gnss.channels[c.LAT_DEG]
    none = fix_type == 1
    assert none.sum() == 5
    assert np.isnan(got[none]).all() and np.isfinite(got[~none]).all()
    assert any("5 of 100 position(s) whose fix status (FixType, ubx)" in x for x in streams.notes)


def test_a_bag_s_fix_type_on_a_topic_of_its_own_is_taken_at_the_fixes_times(tmp_path):
    from rwhonet.data.mdf4 import read_mdf4
    from support.rosbag import bag_map, typestore, write_bag

    r, v = TARGET_RADIUS_M, 14.0
    t_w = np.arange(0.0, 20.0, 0.02) + 100.0
    wheels = (t_w, np.full((t_w.size, 4), v / r))
    t_g = np.arange(0.0, 20.0, 1.0) + 100.05
    fixes = (t_g, 48.1 + v * (t_g - 100.0) / 111_200.0, np.full(t_g.size, 11.5))
    codes = np.where(np.isin(np.arange(t_g.size), [6, 7, 8]), 6, 1)  # GGA 6: estimated
    u8 = typestore().types["std_msgs/msg/UInt8"]
    quality = [
        (int(round((t - 0.01) * 1e9)), u8(data=int(q))) for t, q in zip(t_g, codes, strict=True)
    ]
    bag = write_bag(
        tmp_path / "q.bag", wheels, fixes, extra=[("/gps/quality", "std_msgs/msg/UInt8", quality)]
    )
    smap = bag_map() | {"fix": ColumnSpec("/gps/quality.data", "gga")}
    streams = read_mdf4(bag, smap, r, "m", "q.bag")
    got = streams.gnss.channels[c.LAT_DEG]
    assert np.isnan(got[6:9]).all() and np.isfinite(np.delete(got, [6, 7, 8])).all()
    assert any("3 of 20 position(s)" in x and "3 at 6 (estimated" in x for x in streams.notes)


def test_ingest_notes_the_receiver_s_dead_reckoning_and_validate_cuts_its_seconds(tmp_path):
    import json

    from rwhonet.stages.ingest import ingest
    from rwhonet.stages.validate import validate
    from support.drives import SHORT, column_map_params, make_params, write_fleet

    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=40.0)
    status = np.full(401, 1.0)
    status[100:130] = 6.0  # 3 s of the receiver's own dead reckoning, from T0 + 10
    path = _drive_with_status(tmp_path, status)
    (raw / "target_test").mkdir(parents=True, exist_ok=True)
    path.rename(raw / "target_test" / "C-B1.q.csv")
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "gga")}
    params = make_params(
        raw,
        **SHORT,
        **{
            "data.column_maps.q": column_map_params(cmap),
            "data.roles.target_test": {
                "glob": "target_test/*.q.csv",
                "format": "q",
                "vehicle": "target",
                "required": True,
            },
        },
    )
    ingest(params, tmp_path / "drives")
    manifest = (tmp_path / "drives" / "manifest.json").read_text()
    assert "30 of 401 position(s) whose fix status (GPS Quality, gga) says no fix" in manifest
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "report.json")
    assert json.loads((tmp_path / "report.json").read_text()) == report
    drive = next(d for d in report["drives"] if d["drive"] == "C-B1.q")
    # the second before the first such row ends without a fix: a label needs both ends
    assert [(x["start_s"], x["end_s"]) for x in drive["cuts"] if x["rule"] == "low_sats"] == [
        (T0 + 9, T0 + 13)
    ]
    assert [(s["t_start_s"], s["t_end_s"]) for s in drive["segments"]] == [
        (T0, T0 + 9),
        (T0 + 13, T0 + 40),
    ]


def test_with_the_fixes_from_a_receiver_s_log_a_status_column_no_stream_has_is_refused(
    tmp_path,
):
    from rwhonet.sim.streams import signal_map, write_stream_csvs
    from support.multirate import receiver_drive, receiver_labels
    from support.nmea import nmea_lines, write_nmea

    tables, _ = receiver_drive()
    t = tables.gnss[c.T_S].to_numpy()
    folder = tmp_path / "d"
    folder.mkdir()
    files = [write_stream_csvs(tables, folder)["wheels"]]
    files.append(
        write_nmea(folder / "gps.nmea", nmea_lines(tables.gnss, 1_552_262_400.0 + t, stamps=t))
    )
    smap = signal_map() | {"fix": ColumnSpec("Quality", "gga")}
    with pytest.raises(InputError) as err:
        receiver_labels(files, smap)
    said = str(err.value)
    assert "fix in a stream file or in the receiver log's messages" in said


def test_a_status_header_s_unit_suffix_is_not_taken_against_its_codes(tmp_path):
    """A header that names a unit beside the status (``Fix (count)``) is no contradiction of
    the map's code unit: the codes have none."""
    status = np.full(201, 1.0)
    status[10] = 0.0
    path = _drive_with_status(tmp_path, status)
    table = pd.read_csv(path).rename(columns={"GPS Quality": "Fix (count)"})
    table.to_csv(path, index=False)
    cmap = CUPAC_MAP | {"fix": ("Fix", "flag")}
    got = read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M).columns
    assert np.isnan(got[c.LAT_DEG][10]) and np.isfinite(np.delete(got[c.LAT_DEG], 10)).all()


def test_a_stream_s_bad_status_is_named_by_its_row_in_the_file(tmp_path):
    """Rows a logger wrote out of time order are put in order; a bad status among them is
    still named by its own row of the file."""
    from rwhonet.data.streamcsv import read_stream_csvs

    status = np.full(30, 3.0)
    status[5] = 7.0  # the 6th fix, written as the file's 7th row
    smap = _stream_csvs(tmp_path, status)
    gps = pd.read_csv(tmp_path / "gps.csv")
    order = np.r_[0:5, 6, 5, 7:30]  # the 6th and 7th fixes written the other way round
    gps.iloc[order].to_csv(tmp_path / "gps.csv", index=False)
    with pytest.raises(InputError) as err:
        read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, TARGET_RADIUS_M)
    (p,) = err.value.problems
    assert (p.row, p.column, p.found) == (7, "fixType", "7.0")


def test_a_septentrio_mode_is_counted_by_its_pvt_mode_bits():
    """Mode 131 is a fixed location (3) in 2D (bit 7): counted as 3, named as it."""
    columns = {
        c.LAT_DEG: np.full(4, 48.0),
        c.LON_DEG: np.full(4, 11.0),
        FIX_STATUS: np.array([4.0, 131.0, 3.0, 0.0]),
    }
    counts: Counter = Counter()
    out = screen(columns, "sbf", counts)
    assert np.isnan(out[c.LAT_DEG]).tolist() == [False, True, True, True]
    assert note(counts, "sbf", "f.csv", "Mode") == (
        "f.csv: 3 of 4 position(s) whose fix status (Mode, sbf) says no fix, taken as rows "
        "without a fix: 1 at 0 (no PVT); 2 at 3 (a fixed location)"
    )


def test_a_status_written_as_text_reads_as_its_words_and_refuses_another():
    from rwhonet.data.fixstatus import text_codes

    cells = ["A", " d ", '"V"', "e", None, "", "NaN", "R", "F", "P", "N", "M", "S"]
    codes = text_codes(cells, "rmc", "f.csv", "Status")
    assert is_fix(codes, "rmc").tolist() == [1, 1, 0, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0]
    assert np.isnan(codes[[4, 5, 6]]).all()
    words = text_codes(["3D", "2d", "none", "dgps", "pps", None], "gpx", "f.csv", "Fix")
    assert is_fix(words, "gpx").tolist() == [1, 1, 0, 1, 1, 0]
    with pytest.raises(InputError) as err:
        text_codes(["A", "A", "X", "3d"], "rmc", "f.csv", "Status", np.array([4, 5, 6, 7]))
    problems = err.value.problems
    assert [(p.row, p.column, p.found) for p in problems] == [
        (6, "Status", "'X'"),
        (7, "Status", "'3d'"),
    ]
    assert "an NMEA status or mode letter" in problems[0].expected


def test_a_column_map_s_status_letters_take_out_what_they_say_is_no_fix(tmp_path):
    """An NMEA-to-CSV logger's RMC status column (A valid, V void) and its mode (E:
    estimated): ingest's and predict's readers take the V and E rows' positions out, and
    the note names the letters."""
    status = np.full(201, "A", dtype=object)
    status[20:30] = "V"
    status[40:45] = "E"
    path = _drive_with_status(tmp_path, status)
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "rmc")}
    raw = read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    none = status != "A"
    lat = raw.columns[c.LAT_DEG]
    assert np.isnan(lat[none]).all() and np.isfinite(lat[~none]).all()
    said = [x for x in raw.notes if "fix status" in x]
    assert said == [
        f"{path}: 15 of 201 position(s) whose fix status (GPS Quality, rmc) says no fix, "
        "taken as rows without a fix: 10 at V (void); 5 at E (estimated (dead reckoning))"
    ]
    lay, got = _predict_rows(path, cmap)
    np.testing.assert_array_equal(got, lat)
    assert [x for x in lay.notes if "fix status" in x] == [said[0].replace(str(path), path.name)]
    status[77] = "Q"
    path = _drive_with_status(tmp_path, status, "bad.csv")
    with pytest.raises(InputError) as err:
        read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    (p,) = err.value.problems
    assert (p.row, p.column, p.found) == (78, "GPS Quality", "'Q'")
    with pytest.raises(InputError) as err:
        _predict_rows(path, cmap)
    (p,) = err.value.problems
    assert (p.row, p.column, p.found) == (78, "GPS Quality", "'Q'")


def test_stream_csvs_read_gpsbabel_s_fix_words(tmp_path):
    """GPSBabel's unicsv ``Fix`` column (GPX's words): ``none`` fixes taken out."""
    from rwhonet.data.streamcsv import read_stream_csvs

    words = np.full(30, "3d", dtype=object)
    words[[10, 11]] = "none"
    smap = _stream_csvs(tmp_path, words) | {"fix": ColumnSpec("fixType", "gpx")}
    streams = read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, TARGET_RADIUS_M)
    lat = streams.gnss.channels[c.LAT_DEG]
    assert np.isnan(lat[[10, 11]]).all() and np.isfinite(np.delete(lat, [10, 11])).all()
    assert any("2 at none (no fix)" in x for x in streams.notes), streams.notes


def test_a_status_as_text_is_refused_for_a_logger_s_signals():
    required = _specs(CUPAC_MAP)
    check_signal_map(
        "s", {**required, "t": ColumnSpec("t", "s"), "fix": ColumnSpec("S", "rmc")}, with_time=True
    )
    with pytest.raises(
        ConfigError, match=r"fix.unit: expected a code unit \(gga, ubx, navsat, sbf, gpsd, flag\)"
    ):
        check_signal_map("s", {**required, "fix": ColumnSpec("/gps.status", "rmc")})


def test_a_column_map_s_gpx_words_read_none_as_a_word_not_a_missing_value(tmp_path):
    words = np.full(201, "3d", dtype=object)
    words[50:55] = "none"
    words[60] = ""  # no status beside a position: not vouched for
    path = _drive_with_status(tmp_path, words)
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "gpx")}
    raw = read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    assert np.isnan(raw.columns[c.LAT_DEG]).sum() == 6
    assert any("5 at none (no fix); 1 with no status" in x for x in raw.notes), raw.notes
    lay, got = _predict_rows(path, cmap, "d.csv", block_bytes=1 << 16)
    np.testing.assert_array_equal(got, raw.columns[c.LAT_DEG])
    assert any("5 at none (no fix); 1 with no status" in x for x in lay.notes), lay.notes


def test_a_boolean_fix_column_as_pandas_excel_and_polars_write_it(tmp_path):
    """A ``fix`` column of booleans written as text (pandas' True/False, Excel's TRUE/FALSE,
    Polars' and Arrow's true/false): unit ``bool``, false taken out by both readers, any
    other word refused naming its row."""
    from rwhonet.data.fixstatus import text_codes

    codes = text_codes(["True", "FALSE", " true ", "false", None, ""], "bool", "f.csv", "Fix")
    assert is_fix(codes, "bool").tolist() == [1, 0, 1, 0, 0, 0]
    words = np.array(["True", "TRUE", "true"] * 67, dtype=object)
    words[[30, 31, 32]] = ["False", "FALSE", "false"]
    path = _drive_with_status(tmp_path, words)
    cmap = CUPAC_MAP | {"fix": ("GPS Quality", "bool")}
    raw = read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    lat = raw.columns[c.LAT_DEG]
    assert np.isnan(lat[30:33]).all() and np.isfinite(np.delete(lat, [30, 31, 32])).all()
    assert any("3 at false (no fix)" in x for x in raw.notes), raw.notes
    lay, got = _predict_rows(path, cmap)
    np.testing.assert_array_equal(got, lat)
    words[99] = "yes"
    path = _drive_with_status(tmp_path, words, "bad.csv")
    with pytest.raises(InputError) as err:
        read_columnmap(path, _specs(cmap), "m", radius_m=TARGET_RADIUS_M)
    (p,) = err.value.problems
    assert (p.row, p.found, p.expected) == (
        100,
        "'yes'",
        "a fix flag written as text, true or false",
    )
