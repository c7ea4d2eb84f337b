"""A receiver's stated accuracy (``h_acc_m``): read through a map, carried, reported, screened.

A receiver states how far off it thinks each fix is (u-blox ``hAcc``, NovAtel's σ, a
NavSatFix's covariance, Android's ``AccuracyMeters``); a column or signal map reads it as
``h_acc`` (m, cm, mm). Validate reports each drive's stated accuracy and, with
``validate.gnss.max_h_acc_m`` set, takes a fix stated worse than that (or stated not at
all, in a drive that has the column) as no fix: ``low_sats``, as too few satellites are.
``rwhonet predict`` takes such a row as one without a fix, as validate cuts it.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from rwhonet.config import ConfigError, GnssPolicy, load_params
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import check_column_map, read_columnmap
from rwhonet.data.fixes import no_fix_rows
from rwhonet.data.incremental import FixScreen, read_rows
from rwhonet.data.quality import accuracy_summary, assess
from rwhonet.data.signalmap import check_signal_map
from rwhonet.data.streams import interpolate_fixes
from rwhonet.stages.ingest import ingest
from rwhonet.stages.label import _per_second_all, read_segment_manifest
from rwhonet.stages.validate import summary_table, validate
from support.drives import (
    CUPAC_MAP,
    SHORT,
    TARGET_RADIUS_M,
    column_map_params,
    make_params,
    straight_drive,
    write_columnmap,
    write_fleet,
)

T0 = 45000.0
POLICY = dataclasses.replace(load_params().validate.gnss, min_segment_s=5.0)  # as shipped


def _policy(bound: float | None = None) -> GnssPolicy:
    return dataclasses.replace(POLICY, max_h_acc_m=bound)


def _row(t_s: float) -> int:
    return round((t_s - T0) / 0.1)


def _drive(duration_s: float = 40.0, **kw):
    """A straight drive whose receiver states 1.2 m, 12 m over seconds T0+10..T0+13 and
    nothing at one row of second T0+31."""
    df = straight_drive(duration_s, **kw)
    df[c.H_ACC_M] = 1.2
    df.loc[_row(T0 + 10) : _row(T0 + 12.9), c.H_ACC_M] = 12.0
    df.loc[_row(T0 + 30.5), c.H_ACC_M] = np.nan
    return df


def test_no_fix_rows_takes_an_accuracy_worse_than_the_bound_or_none_stated():
    lat = np.full(5, 52.0)
    lon = np.full(5, -1.0)
    acc = np.array([0.5, 5.0, 5.01, np.nan, np.inf])
    assert no_fix_rows(lat, lon, None, 0, acc, 5.0).tolist() == [0, 0, 1, 1, 1]
    assert not no_fix_rows(lat, lon, None, 0, acc, None).any()  # no bound: not screened
    assert not no_fix_rows(lat, lon, None, 0, None, 5.0).any()  # no column: not screened
    sats = np.array([9.0, 3.0, 9.0, 9.0, 9.0])
    assert no_fix_rows(lat, lon, sats, 4, acc, 5.0).tolist() == [0, 1, 1, 1, 1]


def test_validate_cuts_seconds_stated_worse_than_the_bound_and_says_so():
    result = assess(_drive(), _policy(5.0), 0.1)
    low = [(x.start_s, x.end_s, x.detail) for x in result.cuts if x.rule == "low_sats"]
    assert low == [
        (T0 + 9, T0 + 13, "stated horizontal accuracy up to 12 m (min_sats 4, max_h_acc_m 5)"),
        (T0 + 30, T0 + 31, "no stated accuracy (min_sats 4, max_h_acc_m 5)"),
    ]
    assert [(s.start_s, s.end_s) for s in result.segments] == [
        (T0, T0 + 9),
        (T0 + 13, T0 + 30),
        (T0 + 31, T0 + 40),
    ]
    # 12 m within a bound of 15 m: only the row that states none
    loose = assess(_drive(), _policy(15.0), 0.1)
    assert [(x.start_s, x.rule) for x in loose.cuts if x.rule == "low_sats"] == [
        (T0 + 30, "low_sats")
    ]


def test_without_a_bound_the_accuracy_is_reported_not_screened():
    drive = _drive()
    result = assess(drive, _policy(), 0.1)
    assert [(s.start_s, s.end_s) for s in result.segments] == [(T0, T0 + 40)]
    assert result.accuracy == {
        "fix_rows": 401,
        "stated_rows": 400,
        "median_m": 1.2,
        "p95_m": 12.0,
        "max_m": 12.0,
    }
    assert assess(drive.drop(columns=[c.H_ACC_M]), _policy(), 0.1).accuracy is None


def test_the_accuracy_summary_counts_only_rows_with_a_fix():
    lat = np.array([52.0, 0.0, np.nan, 52.0, 52.0])
    lon = np.array([-1.0, 0.0, -1.0, -1.0, -1.0])
    acc = np.array([2.0, 99.0, 99.0, np.nan, 4.0])
    assert accuracy_summary(lat, lon, acc) == {
        "fix_rows": 3,
        "stated_rows": 2,
        "median_m": 3.0,
        "p95_m": 3.9,
        "max_m": 4.0,
    }
    none = accuracy_summary(lat, lon, np.full(5, np.nan))
    assert none == {"fix_rows": 3, "stated_rows": 0, "median_m": None, "p95_m": None, "max_m": None}


@pytest.mark.parametrize("bound", [0.0, -1.0, math.nan])
def test_a_bound_that_is_not_a_positive_distance_is_refused(bound):
    with pytest.raises(ConfigError, match=r"validate.gnss.max_h_acc_m must be > 0 m"):
        _policy(bound)


def test_params_take_the_bound_as_a_number_or_null():
    ten = make_params(Path("x"), **{"validate.gnss.max_h_acc_m": "1e1"})
    assert ten.validate.gnss.max_h_acc_m == 10.0  # YAML 1.2's 1e1
    assert make_params(Path("x")).validate.gnss.max_h_acc_m is None
    with pytest.raises(ConfigError, match="validate.gnss.max_h_acc_m: expected a number"):
        make_params(Path("x"), **{"validate.gnss.max_h_acc_m": "ten"})


def test_a_map_reads_the_accuracy_in_its_unit_and_refuses_another():
    check_column_map("m", {"h_acc": _spec("HAcc", "cm"), **_required()})
    check_signal_map("s", {"h_acc": _spec("/fix.hacc", "mm"), **_required()})
    with pytest.raises(ConfigError, match=r"data.column_maps.m.h_acc.unit: expected one of"):
        check_column_map("m", {"h_acc": _spec("HAcc", "ft"), **_required()})


def _spec(column: str, unit: str):
    from rwhonet.config import ColumnSpec

    return ColumnSpec(column, unit)


def _required() -> dict:
    return {k: _spec(col, unit) for k, (col, unit) in CUPAC_MAP.items()}


def test_ingest_s_and_predict_s_readers_give_the_accuracy_in_metres(tmp_path):
    df = _drive(20.0, radius_m=TARGET_RADIUS_M)
    cmap = CUPAC_MAP | {"h_acc": ("HAccCm", "cm")}
    path = write_columnmap(df, tmp_path / "d.csv", cmap)
    specs = {k: _spec(col, unit) for k, (col, unit) in cmap.items()}
    got = read_columnmap(path, specs, "m", radius_m=TARGET_RADIUS_M).columns
    np.testing.assert_allclose(got[c.H_ACC_M], df[c.H_ACC_M], rtol=1e-12)
    _, blocks = read_rows(
        io.BytesIO(path.read_bytes()),
        path.name,
        "m",
        specs,
        block_bytes=4096,
        radius_m=TARGET_RADIUS_M,
    )
    rows = np.concatenate([b[c.H_ACC_M] for _, b in blocks])
    np.testing.assert_array_equal(rows, got[c.H_ACC_M])


def test_on_a_fix_its_own_accuracy_and_count_between_two_the_worse():
    t = np.array([0.0, 1.0, 2.0])
    fixes = {
        c.LAT_DEG: np.array([52.0, 52.0001, 52.0002]),
        c.LON_DEG: np.array([-1.0, -1.0, -1.0]),
        c.H_ACC_M: np.array([1.0, 3.0, np.nan]),
        c.N_SATS: np.array([9.0, 5.0, 3.0]),
    }
    at = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    out, valid = interpolate_fixes(t, fixes, at, max_gap_s=2.0)
    assert valid.all()  # on a fix, its own; between two, the worse, none where one has none
    np.testing.assert_array_equal(out[c.H_ACC_M], [1.0, 3.0, 3.0, np.nan, np.nan])
    # satellites alike (before stop 88, a row on a fix had the next fix's count if smaller)
    np.testing.assert_array_equal(out[c.N_SATS], [9.0, 5.0, 5.0, 3.0, 3.0])


def test_predict_takes_a_fix_stated_worse_than_the_bound_as_none():
    cols = {
        c.LAT_DEG: np.array([52.0, 52.0, 52.0, 0.0, np.nan]),
        c.LON_DEG: np.array([-1.0, -1.0, -1.0, 0.0, np.nan]),
        c.H_ACC_M: np.array([1.0, 8.0, np.nan, 1.0, 9.0]),
    }
    screen = FixScreen(4, _policy(5.0))
    screen._jumps_and_frozen = lambda cols: (np.zeros(5, bool), np.zeros(5, bool))
    out = screen.screen(cols)
    assert np.isnan(out[c.LAT_DEG]).tolist() == [False, True, True, True, True]
    assert (screen.zeros, screen.low_sats, screen.poor_accuracy) == (1, 0, 2)
    assert screen.note("V.csv") == (
        "V.csv: 3 row(s) taken as without a GNSS fix, as validate cuts them: 1 at latitude = "
        "longitude = 0 (what a receiver without a fix writes); 2 whose receiver states a "
        "horizontal accuracy worse than validate.gnss.max_h_acc_m 5 m or none"
    )
    unbounded = FixScreen(4, _policy())
    unbounded._jumps_and_frozen = screen._jumps_and_frozen
    assert np.isnan(unbounded.screen(cols)[c.LAT_DEG]).tolist() == [0, 0, 0, 1, 1]


@pytest.mark.parametrize("bound", [None, 5.0])
def test_the_validation_report_gives_a_drive_s_stated_accuracy(tmp_path, bound):
    raw = tmp_path / "raw"
    write_fleet(raw, duration_s=40.0)
    cmap = CUPAC_MAP | {"h_acc": ("HAcc", "mm")}
    df = _drive(40.0, radius_m=TARGET_RADIUS_M, lat0_deg=52.41)
    write_columnmap(df, raw / "target_test" / "C-B1.csv", cmap)
    (raw / "target_test" / "C-B1.csv").rename(raw / "target_test" / "C-B1.acc.csv")
    params = make_params(
        raw,
        **SHORT,
        **{
            "validate.gnss.max_h_acc_m": bound,
            "data.column_maps.acc": column_map_params(cmap),
            "data.roles.target_test": {
                "glob": "target_test/*.acc.csv",
                "format": "acc",
                "vehicle": "target",
                "required": True,
            },
        },
    )
    ingest(params, tmp_path / "drives")
    report = validate(params, tmp_path / "drives", tmp_path / "seg", tmp_path / "report.json")
    assert json.loads((tmp_path / "report.json").read_text()) == report
    by = {d["drive"]: d for d in report["drives"]}
    test_drive = next(d for name, d in by.items() if name.startswith("C-B1"))
    assert test_drive["gnss_accuracy"] == {
        "fix_rows": 401,
        "stated_rows": 400,
        "median_m": 1.2,
        "p95_m": 12.0,
        "max_m": 12.0,
    }
    assert all("gnss_accuracy" not in d for d in report["drives"] if d is not test_drive)
    assert summary_table(report).splitlines()[-1] == (
        "stated horizontal accuracy on 1 drive(s) (gnss_accuracy in the report): the highest "
        "95th percentile 12 m (C-B1.acc, median 1.2 m, max 12 m)"
    )
    better = dict(test_drive, drive="X", gnss_accuracy=dict(test_drive["gnss_accuracy"], p95_m=2))
    two = dict(report, drives=[better, *report["drives"]])
    assert (
        summary_table(two)
        .splitlines()[-1]
        .startswith(
            "stated horizontal accuracy on 2 drive(s) (gnss_accuracy in the report): the highest "
            "95th percentile 12 m (C-B1.acc, "
        )
    )
    low = [x["detail"] for x in test_drive["cuts"] if x["rule"] == "low_sats"]
    # the segments carry the column on; the label stage's per-second samples take them
    # as any other (the constant-speed fleet has no scaler to fit: the stage stops there)
    entries = read_segment_manifest(tmp_path / "seg" / "manifest.json").entries
    seconds = _per_second_all(entries, tmp_path / "seg")
    kept = sum(len(seconds[e.segment]) for e in entries if e.drive == test_drive["drive"])
    assert kept == test_drive["seconds_kept"]
    if bound is None:
        assert low == []
    else:
        assert low == [
            "stated horizontal accuracy up to 12 m (min_sats 4, max_h_acc_m 5)",
            "no stated accuracy (min_sats 4, max_h_acc_m 5)",
        ]


def test_stream_csvs_carry_the_accuracy_onto_the_grid(tmp_path):
    """One CSV per stream, the receiver's accuracy in cm beside its fixes at 1 Hz: on the
    10 Hz grid, each row between two fixes has the worse of their two."""
    import pandas as pd

    from rwhonet.config import ColumnSpec
    from rwhonet.data.streamcsv import read_stream_csvs
    from rwhonet.data.streams import resample

    v, r = 12.0, TARGET_RADIUS_M
    t_w = np.arange(0.0, 30.0, 0.0125) + 5000.0
    t_g = np.arange(0.0, 30.0, 1.0) + 5000.3
    acc_cm = np.where(np.arange(t_g.size) == 10, 900.0, 150.0)
    wheels = {f"w{k}": v / r for k in ("fl", "fr", "rl", "rr")}
    pd.DataFrame({"t": t_w, **wheels}).to_csv(tmp_path / "can.csv", index=False)
    lat = -33.9 + v * (t_g - 5000.0) / 110_900.0
    pd.DataFrame({"t": t_g, "lat": lat, "lon": 151.2, "hacc": acc_cm}).to_csv(
        tmp_path / "gps.csv", index=False
    )
    smap = {
        "t": ColumnSpec("t", "s"),
        **{f"omega_{k}": ColumnSpec(f"w{k}", "rad/s") for k in ("fl", "fr", "rl", "rr")},
        "lat": ColumnSpec("lat", "deg"),
        "lon": ColumnSpec("lon", "deg"),
        "h_acc": ColumnSpec("hacc", "cm"),
    }
    streams = read_stream_csvs(sorted(tmp_path.glob("*.csv")), smap, r)
    d = resample(streams, max_fix_gap_s=1.5).drive.columns
    t = d[c.T_S]
    worse = (t > t_g[9] + 1e-6) & (t < t_g[11] - 1e-6)  # beside the 9 m fix
    np.testing.assert_allclose(d[c.H_ACC_M][worse], 9.0)
    np.testing.assert_allclose(d[c.H_ACC_M][~worse], 1.5)


def test_a_negative_stated_accuracy_is_refused_naming_its_row_and_column():
    from rwhonet.config import load_params
    from rwhonet.data.schema import schema_problems

    df = straight_drive(5.0)
    df[c.H_ACC_M] = 1.5
    df[c.SCENARIO] = ""
    df.loc[7, c.H_ACC_M] = -0.2
    df.loc[9, c.H_ACC_M] = np.nan  # none stated: no refusal
    found = schema_problems(df, load_params().validate, "d.csv", {c.H_ACC_M: "HAcc"})
    assert [(p.file, p.row, p.column) for p in found] == [("d.csv", 8, "HAcc")]
    assert found[0].expected.startswith("a stated horizontal accuracy >= 0 m")


def test_fixes_held_from_a_slower_receiver_carry_their_own_accuracy():
    """A 10 Hz file holding a 1 Hz receiver's fixes and their accuracy in the rows between:
    placed back along the path, a row between two fixes has the worse of the two (as a
    stream drive's grid has), not the earlier one held."""
    from rwhonet.data.csvio import RawDrive
    from rwhonet.data.heldfixes import place_held_fixes
    from support.drives import with_held_fixes

    truth = straight_drive(120.0)
    truth[c.H_ACC_M] = np.where((truth[c.T_S].to_numpy() - T0) % 20 < 10, 1.0, 4.0)
    df = with_held_fixes(truth, 10, 0, False)
    raw = RawDrive({k: df[k].to_numpy(np.float64) for k in df if k != c.SCENARIO}, {}, "d")
    out = place_held_fixes(raw).columns[c.H_ACC_M]
    t = df[c.T_S].to_numpy() - T0
    between = (t % 20 > 9.0 + 1e-6) & (t % 20 < 10.0 - 1e-6)  # after a 1 m fix, a 4 m next
    assert between.sum() > 50
    np.testing.assert_array_equal(out[between], 4.0)
    np.testing.assert_array_equal(df[c.H_ACC_M].to_numpy()[between], 1.0)  # as held
