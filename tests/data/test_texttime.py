"""Time columns written as text (ISO 8601, hh:mm:ss): parsed to seconds by every reader."""

import contextlib
import io
import sys
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rwhonet.config import ColumnSpec
from rwhonet.data import canonical as c
from rwhonet.data.columnmap import read_columnmap
from rwhonet.data.incremental import read_rows
from rwhonet.data.iovnbd import read_iovnbd
from rwhonet.data.texttime import (
    CLOCK,
    ISO8601,
    parse_text_times,
    text_time_note,
    text_time_unit,
)
from rwhonet.errors import InputError
from support.drives import (
    CUPAC_MAP,
    as_hhmmss,
    column_map_params,
    write_columnmap,
    write_iovnbd,
)
from support.serving import wavy_drive

DAY = datetime(2019, 3, 11, tzinfo=UTC)
DAY_S = DAY.timestamp()  # 2019-03-11 00:00 UTC, s since 1970


def iso(t_s: np.ndarray, day: datetime = DAY, fmt: str = "{d}T{clock}Z") -> list[str]:
    """Times of day (s, from ``day``'s midnight) as ISO 8601 text, to the millisecond."""
    out = []
    for t in np.asarray(t_s):
        ms = round(t * 1000)
        when = day + timedelta(milliseconds=ms)
        clock = f"{when:%H:%M:%S}.{when.microsecond // 1000:03d}"
        out.append(fmt.format(d=f"{when:%Y-%m-%d}", clock=clock))
    return out


def clock(t_s: np.ndarray) -> list[str]:
    """Times (s) as h:mm:ss.sss text, hours past 24 allowed."""
    out = []
    for t in np.asarray(t_s):
        ms = round(t * 1000)
        h, rest = divmod(ms, 3_600_000)
        m, rest = divmod(rest, 60_000)
        out.append(f"{h}:{m:02d}:{rest / 1000:06.3f}")
    return out


def summer_time_ending(t_s, offsets: bool) -> list[str]:
    """Times (s from 10 s before 01:00 UTC on 2019-10-27) as Central European local ISO
    text, summer time ending at 01:00 UTC (03:00 CEST -> 02:00 CET), with or without the
    offsets."""
    start = datetime(2019, 10, 27, 0, 59, 50, tzinfo=UTC)
    cells = []
    for t in np.asarray(t_s):
        when = start + timedelta(milliseconds=round(t * 1000))
        local = when.astimezone(timezone(timedelta(hours=2 if when.hour < 1 else 1)))
        local = local if offsets else local.replace(tzinfo=None)
        cells.append(local.isoformat(timespec="milliseconds"))
    return cells


def with_time_text(path, column: int, cells: list[str]):
    """A CSV with one column's cells replaced by text (the others as written)."""
    lines = path.read_text().splitlines()
    for i, cell in enumerate(cells, start=1):
        parts = lines[i].split(",")
        parts[column] = cell
        lines[i] = ",".join(parts)
    path.write_text("\n".join(lines) + "\n")
    return path


# -- the parser: known values ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("cell", "expected"),
    [
        ("2019-03-11T14:22:05.123Z", datetime(2019, 3, 11, 14, 22, 5, 123000, UTC)),
        ("2019-03-11 14:22:05.123", datetime(2019, 3, 11, 14, 22, 5, 123000, UTC)),
        ("2019-03-11T14:22:05", datetime(2019, 3, 11, 14, 22, 5, tzinfo=UTC)),
        ("2019-03-11T14:22:05,5+01:00", datetime(2019, 3, 11, 13, 22, 5, 500000, UTC)),
        ("2019-03-11T14:22:05.5+0130", datetime(2019, 3, 11, 12, 52, 5, 500000, UTC)),
        ("2019-03-11T09:22:05.25-05", datetime(2019, 3, 11, 14, 22, 5, 250000, UTC)),
        (' "2020-02-29t23:59:59.9z" ', datetime(2020, 2, 29, 23, 59, 59, 900000, UTC)),
        ("1970-01-01T00:00:00Z", datetime(1970, 1, 1, tzinfo=UTC)),
    ],
)
def test_iso_8601_times_are_seconds_since_1970_utc(cell, expected):
    parsed = parse_text_times([cell], ISO8601)
    assert parsed.bad == [] and parsed.mixed is None
    assert parsed.seconds[0] == pytest.approx(expected.timestamp(), abs=1e-6)
    assert text_time_unit(cell) == ISO8601


@pytest.mark.parametrize(
    ("cell", "expected"),
    [
        ("14:22:05.123", 14 * 3600 + 22 * 60 + 5.123),
        ("0:05:03.1", 303.1),
        ("123:00:00", 123 * 3600.0),
        ("23:59:59,95", 86399.95),
    ],
)
def test_clock_times_are_h_3600_plus_m_60_plus_s(cell, expected):
    parsed = parse_text_times([cell], CLOCK)
    assert parsed.bad == [] and parsed.seconds[0] == pytest.approx(expected, abs=1e-9)
    assert text_time_unit(cell) == CLOCK


@settings(max_examples=200, deadline=None)
@given(
    when=st.datetimes(
        min_value=datetime(1980, 1, 1), max_value=datetime(2099, 12, 31), timezones=st.none()
    ),
    offset_min=st.integers(-14 * 4, 14 * 4).map(lambda q: 15 * q),
    sep=st.sampled_from(["T", " "]),
)
def test_any_iso_time_is_the_timestamp_python_gives(when, offset_min, sep):
    aware = when.replace(tzinfo=timezone(timedelta(minutes=offset_min)))
    parsed = parse_text_times([aware.isoformat(sep=sep)], ISO8601)
    assert parsed.bad == []
    assert parsed.seconds[0] == pytest.approx(aware.timestamp(), abs=1e-6)


def test_missing_times_are_nan_and_bad_ones_are_listed_with_why():
    cells = ["2019-03-11T00:00:00", None, "NaN", "", "2019-02-30T00:00:00", "24:00", "x",
             "2019-03-11T24:00:00", "2019-03-11T10:60:00", "2019-03-11T10:00:00+25:00"]  # fmt: skip
    parsed = parse_text_times(cells, ISO8601)
    assert np.isnan(parsed.seconds[1:]).all() and np.isfinite(parsed.seconds[0])
    assert [i for i, _ in parsed.bad] == [4, 5, 6, 7, 8, 9]
    assert "no such date" in parsed.bad[0][1] and "offset" in parsed.bad[5][1]
    assert [i for i, _ in parse_text_times(["1:00:00", "1:60:00", "1:00:60"], CLOCK).bad] == [1, 2]


def test_a_zone_in_some_rows_only_is_found_across_blocks():
    assert parse_text_times(["2019-03-11T10:00:00", "2019-03-11T10:00:01Z"], ISO8601).mixed == 1
    first = parse_text_times(["2019-03-11T10:00:00Z"], ISO8601)
    assert first.zoned is True
    assert parse_text_times(["2019-03-11T10:00:01"], ISO8601, first.zoned).mixed == 0
    assert parse_text_times(["2019-03-11T10:00:01+00:00"], ISO8601, first.zoned).mixed is None


# -- the readers ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def drive():
    return wavy_drive(120.0, t0_s=86340.0)  # passes midnight a minute in


def test_an_iovnbd_file_with_iso_times_reads_as_the_same_drive(drive, tmp_path):
    """Every channel as the seconds file's, the time 1970's seconds of its day (continuous
    across midnight), and a note that says so."""
    ref = read_iovnbd(write_iovnbd(drive, tmp_path / "V-S.csv"))
    path = with_time_text(write_iovnbd(drive, tmp_path / "V-I.csv"), 1, iso(drive[c.T_S]))
    got = read_iovnbd(path)
    np.testing.assert_allclose(got.columns[c.T_S], ref.columns[c.T_S] + DAY_S, rtol=0, atol=1e-6)
    for k in c.REQUIRED[1:]:
        np.testing.assert_array_equal(got.columns[k], ref.columns[k])
    assert any("written as text (iso8601)" in n for n in got.notes)
    assert not any("midnight" in n for n in got.notes)  # ISO carries its date


def test_an_iovnbd_file_with_clock_times_passes_midnight_as_seconds_do(drive, tmp_path):
    ref = read_iovnbd(write_iovnbd(drive, tmp_path / "V-S.csv"))
    day_clock = clock(np.mod(drive[c.T_S], 86400.0))
    got = read_iovnbd(with_time_text(write_iovnbd(drive, tmp_path / "V-C.csv"), 1, day_clock))
    np.testing.assert_allclose(got.columns[c.T_S], ref.columns[c.T_S], rtol=0, atol=1e-6)
    assert any("hh:mm:ss" in n for n in got.notes) and any("midnight" in n for n in got.notes)


def test_a_summer_time_change_with_offsets_stays_continuous(tmp_path):
    """Local clock 02:59:59.9+02:00 then 02:00:00.0+01:00: 0.1 s later, not an hour back."""
    df = wavy_drive(20.0, t0_s=0.0)
    cells = summer_time_ending(df[c.T_S], offsets=True)
    assert cells[99].startswith("2019-10-27T02:59:59.900+02:00")
    assert cells[100].startswith("2019-10-27T02:00:00.000+01:00")
    got = read_iovnbd(with_time_text(write_iovnbd(df, tmp_path / "V-D.csv"), 1, cells))
    np.testing.assert_allclose(np.diff(got.columns[c.T_S]), np.diff(df[c.T_S]), atol=1e-6)


def test_bad_text_times_are_named_with_file_row_and_column(drive, tmp_path):
    cells = iso(drive[c.T_S][:20])
    cells[6] = "2019-03-11T25:00:00Z"
    cells[11] = "2019-03-11T23:59:01"  # no zone, where the first has one
    path = with_time_text(write_iovnbd(drive.iloc[:20], tmp_path / "V-B.csv"), 1, cells)
    with pytest.raises(InputError) as err:
        read_iovnbd(path, "V-B.csv")
    text = str(err.value)
    assert "V-B.csv, row 7, column ' Time': expected an ISO 8601 date" in text
    assert "'2019-03-11T25:00:00Z' (hours below 24" in text
    assert "row 12" in text and "zone offset" in text and "has one" in text
    with open(path, "rb") as f, pytest.raises(InputError) as streamed:
        list(read_rows(f, "V-B.csv")[1])
    assert "row 7" in str(streamed.value) and "row 12" in str(streamed.value)


def test_the_streaming_reader_gives_the_ingest_reader_s_times(drive, tmp_path):
    """predict's reader, a few rows per block: the times of the seconds file, shifted."""
    seconds = write_iovnbd(drive, tmp_path / "V-S.csv")
    text = with_time_text(write_iovnbd(drive, tmp_path / "V-I.csv"), 1, iso(drive[c.T_S]))
    got = {}
    for name, path in (("s", seconds), ("iso", text)):
        with open(path, "rb") as f:
            lay, blocks = read_rows(f, path.name, block_bytes=2048)
            got[name] = np.concatenate([cols[c.T_S] for _, cols in blocks])
        # what the reader did, for predict's stderr
        assert lay.notes == ([] if name == "s" else [text_time_note(" Time", ISO8601)])
    np.testing.assert_allclose(got["iso"], got["s"] + DAY_S, rtol=0, atol=1e-5)
    # a quoted cell with a decimal comma (ISO 8601 allows it) goes through csv's quoting
    comma = with_time_text(
        write_iovnbd(drive, tmp_path / "V-Q.csv"),
        1,
        [f'"{x.replace(".", ",")}"' for x in iso(drive[c.T_S], fmt="{d} {clock}")],
    )
    with open(comma, "rb") as f:
        quoted = np.concatenate([cols[c.T_S] for _, cols in read_rows(f, "q", block_bytes=2048)[1]])
    np.testing.assert_allclose(quoted, got["iso"], rtol=0, atol=1e-5)


def _cmap(unit: str) -> dict:
    params = column_map_params(CUPAC_MAP | {"t": ("Time", unit)})
    return {k: ColumnSpec(**v) for k, v in params.items()}


def test_a_column_map_declares_a_text_time_and_a_number_unit_is_refused(drive, tmp_path):
    path = write_columnmap(drive, tmp_path / "cupac.csv", CUPAC_MAP | {"t": ("Time", "s")})
    ref = read_columnmap(path, _cmap("s"), "cupac")
    with_time_text(path, 1, clock(drive[c.T_S]))  # Extra, Time, ...
    got = read_columnmap(path, _cmap(CLOCK), "cupac")
    np.testing.assert_allclose(got.columns[c.T_S], ref.columns[c.T_S], rtol=0, atol=1e-6)
    for declared, where in ((_cmap("s"), "ingest"), (_cmap("ms"), "predict")):
        with pytest.raises(InputError) as err:
            if where == "ingest":
                read_columnmap(path, declared, "cupac")
            else:
                with open(path, "rb") as f:
                    list(read_rows(f, "cupac.csv", "cupac", declared)[1])
        text = str(err.value)
        assert "column 'Time'" in text and "times written as text: '23:59:00.000'" in text
        assert "set data.column_maps.cupac.t.unit to 'hh:mm:ss'" in text
    with open(path, "rb") as f:
        _, blocks = read_rows(f, "cupac.csv", "cupac", _cmap(CLOCK), block_bytes=1024)
        streamed = np.concatenate([cols[c.T_S] for _, cols in blocks])
    np.testing.assert_allclose(streamed, got.columns[c.T_S], rtol=0, atol=1e-5)


def test_stream_csvs_with_iso_times_read_as_seconds_files_do(tmp_path):
    """A wheels file at 50 Hz and a GNSS file at 10 Hz, each with ISO times: the streams of
    the same files in seconds, 1970's seconds of the day later; a number unit is refused."""
    from rwhonet.data.streamcsv import read_stream_csvs

    t_w, t_g = np.arange(0.0, 30.0, 0.02) + 3600.0, np.arange(0.0, 30.0, 0.1) + 3600.0
    wheels = pd.DataFrame({"Time": t_w, **{f"w{k}": np.full(t_w.size, 40.0) for k in range(4)}})
    gnss = pd.DataFrame({"Time": t_g, "lat": 52.0 + 12.0 * (t_g - 3600.0) / 111_000.0, "lon": -1.5})
    for name, text in (("s", None), ("iso", iso)):
        folder = tmp_path / name
        folder.mkdir()
        for file, df in (("can.csv", wheels), ("gps.csv", gnss)):
            out = df.copy()
            if text is not None:
                out["Time"] = text(df["Time"].to_numpy())
            out.to_csv(folder / file, index=False)
    wheel_keys = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
    smap = {key: ColumnSpec(f"w{k}", "rad/s") for k, key in enumerate(wheel_keys)}
    smap |= {"t": ColumnSpec("Time", "s"), "lat": ColumnSpec("lat", "deg")}
    smap |= {"lon": ColumnSpec("lon", "deg")}
    ref = read_stream_csvs(sorted((tmp_path / "s").glob("*.csv")), smap, 0.3)
    files = sorted((tmp_path / "iso").glob("*.csv"))
    got = read_stream_csvs(files, smap | {"t": ColumnSpec("Time", ISO8601)}, 0.3)
    assert [s.name for s in got.streams] == [s.name for s in ref.streams]
    for a, b in zip(got.streams, ref.streams, strict=True):
        np.testing.assert_allclose(a.t_s, b.t_s + DAY_S, rtol=0, atol=1e-6)
    with pytest.raises(InputError, match=r"set the signal map\.t\.unit to 'iso8601'"):
        read_stream_csvs(files, smap, 0.3)


def test_predict_writes_the_seconds_of_a_drive_with_text_times(drive, tmp_path):
    """``rwhonet predict`` on the same drive with ISO times: the same seconds and figures;
    only the time column differs, by 1970's seconds of the day."""
    from rwhonet.cli.main import main
    from support.serving import base_bundle, predict_args

    bundle = base_bundle(tmp_path / "bundle")
    outs = {}
    for name, cells in (("s", None), ("iso", iso(drive[c.T_S]))):
        path = write_iovnbd(drive, tmp_path / f"V-{name}.csv")
        if cells is not None:
            with_time_text(path, 1, cells)
        outs[name] = tmp_path / f"{name}.out.csv"
        assert main(predict_args(bundle, path, outs[name], "--outage", "30:90")) == 0
    a, b = pd.read_csv(outs["iso"]), pd.read_csv(outs["s"])
    assert len(a) == len(b) > 100
    t = next(col for col in a.columns if col.startswith("t"))
    np.testing.assert_allclose(a[t], b[t] + DAY_S, rtol=0, atol=1e-3)
    pd.testing.assert_frame_equal(a.drop(columns=[t]), b.drop(columns=[t]))


def test_the_stream_of_a_clock_time_file_is_the_seconds_file_s(drive, tmp_path):
    """From a pipe too: the form is decided on the first line that arrives."""
    seconds = write_iovnbd(drive, tmp_path / "V-S.csv")
    data = with_time_text(write_iovnbd(drive, tmp_path / "V-C.csv"), 1, clock(drive[c.T_S]))
    with open(seconds, "rb") as f:
        ref = np.concatenate([cols[c.T_S] for _, cols in read_rows(f, "s")[1]])
    got = np.concatenate(
        [cols[c.T_S] for _, cols in read_rows(io.BytesIO(data.read_bytes()), "<stdin>")[1]]
    )
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    "header", [" Time (hh:mm:ss)", " Time (HH:MM:SS.FFF)", " Time [ISO 8601]", " Time (UTC)"]
)
def test_a_time_header_naming_a_text_form_or_a_zone_is_not_an_unknown_unit(header, tmp_path):
    from rwhonet.data.iovnbd import HEADERS

    df = wavy_drive(20.0)
    headers = (HEADERS[0], header, *HEADERS[2:])
    path = with_time_text(write_iovnbd(df, tmp_path / "V-H.csv", headers), 1, iso(df[c.T_S]))
    got = read_iovnbd(path)
    np.testing.assert_allclose(got.columns[c.T_S], df[c.T_S] + DAY_S, rtol=0, atol=1e-6)
    with open(path, "rb") as f:
        lay, blocks = read_rows(f, "V-H.csv")
        streamed = np.concatenate([cols[c.T_S] for _, cols in blocks])
    assert lay.names[c.T_S] == header
    np.testing.assert_allclose(streamed, got.columns[c.T_S], rtol=0, atol=1e-5)


# -- strptime patterns ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pattern", "cell", "expected"),
    [
        ("%d.%m.%Y %H:%M:%S.%f", "11.03.2019 14:22:05.123", DAY_S + 51725.123),
        ("%d.%m.%Y %H:%M:%S,%f", "11.03.2019 14:22:05,5", DAY_S + 51725.5),
        ("%m/%d/%Y %I:%M:%S.%f %p", "03/11/2019 02:22:05.25 PM", DAY_S + 51725.25),
        ("%Y-%m-%d %H:%M:%S.%f%z", "2019-03-11 15:22:05.0+0100", DAY_S + 51725.0),
        ("%H:%M:%S.%f", "23:59:59.9", 86399.9),  # no date: a time of day
    ],
)
def test_a_strptime_pattern_reads_what_the_two_forms_do_not(pattern, cell, expected):
    from rwhonet.data.texttime import pattern_problem

    assert pattern_problem(pattern) is None
    parsed = parse_text_times([cell, "", "x"], pattern)
    assert parsed.seconds[0] == pytest.approx(expected, abs=1e-6)
    assert np.isnan(parsed.seconds[1:]).all() and [i for i, _ in parsed.bad] == [2]


def test_a_pattern_without_a_time_or_that_cannot_read_itself_is_refused():
    from rwhonet.config import ConfigError
    from rwhonet.data.columnmap import check_column_map
    from rwhonet.data.signalmap import check_signal_map
    from rwhonet.data.texttime import pattern_problem

    assert "%H (or %I and %p), %M and %S" in pattern_problem("%d.%m.%Y")
    assert pattern_problem("%H:%M:%S %Q") is not None  # no such directive
    with pytest.raises(ConfigError, match=r"cupac\.t\.unit: expected a strptime pattern with"):
        check_column_map("cupac", _cmap("%d.%m.%Y"))
    with pytest.raises(ConfigError, match=r"or a strptime pattern .*got 'minutes'"):
        check_column_map("cupac", _cmap("minutes"))
    check_column_map("cupac", _cmap("%d.%m.%Y %H:%M:%S.%f"))
    signals = {k: ColumnSpec(v.column, v.unit) for k, v in _cmap("%H:%M").items()}
    with pytest.raises(ConfigError, match="strptime pattern with"):
        check_signal_map("m", signals, with_time=True)


def test_a_german_export_reads_through_a_column_map_with_its_pattern(drive, tmp_path):
    """';'-separated, decimal commas, times as 11.03.2019 23:59:00,000 through midnight:
    the drive in seconds, 1970's seconds of the day later, in ingest's reader and
    predict's."""
    path = write_columnmap(drive, tmp_path / "cupac.csv", CUPAC_MAP | {"t": ("Time", "s")})
    ref = read_columnmap(path, _cmap("s"), "cupac")
    text = path.read_text().replace(",", "\0").replace(".", ",").replace("\0", ";")
    lines = text.splitlines()
    for i, x in enumerate(iso(drive[c.T_S]), start=1):  # 2019-03-11T23:59:00.000Z
        cells = lines[i].split(";")
        cells[1] = f"{x[8:10]}.{x[5:7]}.{x[:4]} {x[11:19]},{x[20:23]}"
        lines[i] = ";".join(cells)
    path.write_text("\n".join(lines) + "\n")
    assert path.read_text().splitlines()[1].split(";")[1] == "11.03.2019 23:59:00,000"
    pattern = "%d.%m.%Y %H:%M:%S.%f"  # a ',' in a ';' file is read as '.'
    got = read_columnmap(path, _cmap(pattern), "cupac")
    np.testing.assert_allclose(got.columns[c.T_S], ref.columns[c.T_S] + DAY_S, rtol=0, atol=1e-6)
    with open(path, "rb") as f:
        _, blocks = read_rows(f, "cupac.csv", "cupac", _cmap(pattern), block_bytes=1024)
        streamed = np.concatenate([cols[c.T_S] for _, cols in blocks])
    np.testing.assert_allclose(streamed, got.columns[c.T_S], rtol=0, atol=1e-5)


def test_local_times_without_offsets_through_summer_time_s_end_are_one_clock(tmp_path, monkeypatch):
    """02:59:59.9 then 02:00:00.0 written without offsets: an hour back, the car driving
    on. Until stop 68 predict refused it at that row ("time goes backwards", "summer
    time"); now the hour's rows are put 3601 s on (rwhonet.data.sampleorder.clock_set_back)
    and the note says so. From a pipe it stays refused, naming the row."""
    from rwhonet.cli.main import main
    from support.pipes import piped
    from support.serving import base_bundle, predict_args

    df = wavy_drive(40.0, t0_s=0.0)
    cells = summer_time_ending(df[c.T_S], offsets=False)
    path = with_time_text(write_iovnbd(df, tmp_path / "V-D.csv"), 1, cells)
    out = tmp_path / "out.csv"
    bundle = base_bundle(tmp_path / "bundle")
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(predict_args(bundle, path, out)) == 0
    said = err.getvalue()
    assert "the clock set back" in said and "row 101 (3600 s back, its rows 3601 s later)" in said
    t = pd.read_csv(out)["t_s"].to_numpy()
    assert (np.diff(t) > 0).all() and t[-1] > 3600.0
    piped_out = tmp_path / "piped.csv"
    with piped(path.read_bytes()) as pipe, contextlib.redirect_stderr(err := io.StringIO()):
        monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(pipe))
        assert main(predict_args(bundle, "-", piped_out)) == 2
    said = err.getvalue()
    assert "row 101" in said and "time goes backwards" in said and "summer time" in said
    assert not piped_out.exists()


# -- a date in a column of its own ------------------------------------------------------------


@pytest.mark.parametrize(
    ("unit", "cell", "expected"),
    [
        ("%d/%m/%Y", "11/03/2019", DAY),
        ("%Y-%m-%d", " 2019-03-11 ", DAY),
        ("%m/%d/%y", '"03/11/19"', DAY),
        ("ddmmyy", "110319", DAY),
        ("ddmmyy", "50319", datetime(2019, 3, 5, tzinfo=UTC)),  # the leading zero dropped
        ("ddmmyy", "311299", datetime(1999, 12, 31, tzinfo=UTC)),
        ("ddmmyy", "010180", datetime(1980, 1, 1, tzinfo=UTC)),
        ("ddmmyy", "110319.0", DAY),  # a spreadsheet's number
    ],
)
def test_a_date_column_gives_each_row_s_midnight_in_seconds_since_1970(unit, cell, expected):
    from rwhonet.data.texttime import parse_dates

    parsed = parse_dates([cell, None, "nan"], unit)
    assert parsed.seconds[0] == expected.timestamp() and parsed.bad == []
    assert np.isnan(parsed.seconds[1:]).all()


def test_dates_that_are_none_are_listed_with_why():
    from rwhonet.data.texttime import parse_dates

    parsed = parse_dates(["110319", "320319", "1103190", "11.5", "x", "110319"], "ddmmyy")
    assert [i for i, _ in parsed.bad] == [1, 2, 3, 4]
    assert "day is out of range" in parsed.bad[0][1] and "six digits" in parsed.bad[1][1]
    assert parsed.seconds[5] == DAY_S
    parsed = parse_dates(["11/03/2019", "2019-03-11"], "%d/%m/%Y")
    assert [i for i, _ in parsed.bad] == [1] and "does not match format" in parsed.bad[0][1]


def test_a_date_unit_and_the_time_beside_it_are_checked_with_the_params():
    from rwhonet.config import ConfigError
    from rwhonet.data.columnmap import check_column_map
    from rwhonet.data.texttime import date_problem

    assert date_problem("ddmmyy") is None and date_problem("%d.%m.%Y") is None
    assert "a date alone" in date_problem("%d.%m.%Y %H:%M")
    assert "with a day, a month and a year" in date_problem("%m/%Y")
    assert date_problem("dd/mm/yyyy") is not None
    cmap = _cmap("hh:mm:ss") | {"date": ColumnSpec("Date", "%d/%m/%Y")}
    check_column_map("cupac", cmap)
    with pytest.raises(ConfigError, match=r"cupac\.t\.unit: expected a time of day beside"):
        check_column_map("cupac", _cmap("iso8601") | {"date": ColumnSpec("Date", "ddmmyy")})
    with pytest.raises(ConfigError, match=r"cupac\.date\.unit: expected 'ddmmyy' or a strptime"):
        check_column_map("cupac", _cmap("s") | {"date": ColumnSpec("Date", "yyyy-mm-dd")})


def _with_date_column(path, cells: list[str], time: list[str] | None = None):
    """The CSV at ``path`` with a 'Date' column first (and the 'Time' cells replaced)."""
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    if time is not None:
        frame["Time"] = time
    frame.insert(0, "Date", cells)
    frame.to_csv(path, index=False)
    return path


@pytest.mark.parametrize("nmea", [False, True], ids=["dd/mm/yyyy and hh:mm:ss", "NMEA"])
def test_a_date_and_a_time_of_day_in_two_columns_read_as_one_clock(drive, tmp_path, nmea):
    """'Date' and 'Time' columns through midnight (the date turning over with the time of
    day): seconds since 1970 as written, continuous, in ingest's reader and predict's, with
    a note; a date that is none is refused with its row."""
    path = write_columnmap(drive, tmp_path / "cupac.csv", CUPAC_MAP | {"t": ("Time", "s")})
    ref = read_columnmap(path, _cmap("s"), "cupac")
    t = ref.columns[c.T_S]
    day = np.where(t >= 86400.0, 12, 11)
    if nmea:  # RMC's ddmmyy and hhmmss.ss, as numbers
        dates = [f"{d}0319" for d in day]
        time = [f"{v:.3f}" for v in as_hhmmss(t)]
        cmap = _cmap("hhmmss") | {"date": ColumnSpec("Date", "ddmmyy")}
    else:
        dates = [f"{d}/03/2019" for d in day]
        time = clock(t % 86400.0)
        cmap = _cmap("hh:mm:ss") | {"date": ColumnSpec("Date", "%d/%m/%Y")}
    _with_date_column(path, dates, time)
    got = read_columnmap(path, cmap, "cupac")
    np.testing.assert_allclose(got.columns[c.T_S], t + DAY_S, rtol=0, atol=1e-6)
    assert any("dates of column 'Date'" in note for note in got.notes)
    assert not any("midnight" in note for note in got.notes)  # the date carries the day
    assert got.source_columns[c.T_S] == "Time" and "Date" not in got.source_columns.values()
    with open(path, "rb") as f:
        lay, blocks = read_rows(f, "cupac.csv", "cupac", cmap, block_bytes=1024)
        streamed = np.concatenate([cols[c.T_S] for _, cols in blocks])
    np.testing.assert_allclose(streamed, got.columns[c.T_S], rtol=0, atol=1e-6)
    assert any("dates of column 'Date'" in note for note in lay.notes)
    frame = pd.read_csv(path, dtype=str, keep_default_na=False)
    frame.loc[4, "Date"] = "31/02/2019" if not nmea else "310219"
    frame.to_csv(path, index=False)
    for read in (
        lambda: read_columnmap(path, cmap, "cupac"),
        lambda: list(read_rows(open(path, "rb"), "cupac.csv", "cupac", cmap)[1]),  # noqa: SIM115
    ):
        with pytest.raises(InputError) as err:
            read()
        (problem,) = err.value.problems
        assert (problem.row, problem.column) == (
            5,
            "Date",
        ) and "day is out of range" in problem.found
        assert "data.column_maps.cupac.date" in (problem.fix or "")


# A start on a local clock put on UTC (rwhonet.data.texttime.local_to_unix)
@pytest.mark.parametrize(
    ("wall", "zone", "unix"),
    [
        (datetime(2024, 6, 1, 12, 0), "Europe/Berlin", 1717236000.0),  # CEST, UTC+2
        (datetime(2024, 1, 15, 9, 30, 0, 250000), "America/Detroit", 1705329000.25),  # EST
        (datetime(2024, 10, 27, 3, 0), "Europe/Berlin", 1729994400.0),  # just after the hour
        (datetime(2024, 10, 27, 1, 59, 59), "Europe/Berlin", 1729987199.0),  # just before
        (datetime(2024, 4, 7, 14, 0), "Australia/Adelaide", 1712464200.0),  # +9:30 after
        (datetime(2024, 3, 31, 2, 30), "Asia/Kolkata", 1711832400.0),  # no summer time
    ],
)
def test_a_local_wall_time_is_the_instant_its_zone_kept(wall, zone, unix):
    from rwhonet.data.texttime import local_to_unix

    assert local_to_unix(wall, zone) == unix


@pytest.mark.parametrize(
    ("wall", "zone", "found", "fix"),
    [
        (
            datetime(2024, 10, 27, 2, 30),
            "Europe/Berlin",
            "2024-10-27T02:30:00 in Europe/Berlin, in the hour its clocks went back: UTC+2 "
            "or UTC+1",
            "give local_zone as the fixed offset the logger's clock kept then: Etc/GMT-2 "
            "(UTC+2) or Etc/GMT-1 (UTC+1)",
        ),
        (
            datetime(2024, 3, 10, 2, 15),
            "America/Detroit",
            "2024-03-10T02:15:00 in America/Detroit, in the hour its clocks skipped: no such "
            "time there",
            "give local_zone as the fixed offset the logger's clock kept then: Etc/GMT+5 "
            "(UTC-5) or Etc/GMT+4 (UTC-4)",
        ),
        (
            datetime(2024, 4, 7, 2, 45),
            "Australia/Adelaide",
            "2024-04-07T02:45:00 in Australia/Adelaide, in the hour its clocks went back: "
            "UTC+10:30 or UTC+9:30",
            "give the log with its start on UTC",
        ),
    ],
)
def test_a_wall_time_a_change_of_summer_time_repeats_or_skips_is_refused(wall, zone, found, fix):
    """Two instants an hour apart, or none: neither is guessed. The fixed zones it names
    (POSIX's sign: Etc/GMT-2 is UTC+2) read it as each offset."""
    from rwhonet.data.texttime import LocalTimeUnclear, local_to_unix

    with pytest.raises(LocalTimeUnclear) as err:
        local_to_unix(wall, zone)
    assert (err.value.found, err.value.fix) == (found, fix)
    if zone == "Europe/Berlin":
        first, second = local_to_unix(wall, "Etc/GMT-2"), local_to_unix(wall, "Etc/GMT-1")
        assert second - first == 3600.0
        assert datetime.fromtimestamp(first, UTC) == datetime(2024, 10, 27, 0, 30, tzinfo=UTC)
