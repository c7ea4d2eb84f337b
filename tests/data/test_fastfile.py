"""A 10 Hz layout logged faster (20, 50 Hz; the fix held from a slower receiver or in every
row): read as streams and resampled onto the grid, by ingest and by predict alike, giving
the drive the 10 Hz file gives."""

from __future__ import annotations

import io

import numpy as np
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.drivefile import DriveFile, read_any
from rwhonet.data.fastfile import (
    FAST_FACTOR,
    is_faster_than_grid,
    is_off_the_grid_rate,
    rate_ratio,
)
from rwhonet.data.incremental import read_rows
from rwhonet.errors import InputError
from support.corpus import faster, good_target
from support.drives import TARGET_RADIUS_M, make_params, write_iovnbd
from support.pipes import piped

NOTE = "read as streams and resampled onto it"


def _read(path, root):
    data = make_params(root).data
    f = DriveFile(path.stem, "target_test", "target", "iovnbd", path)
    return read_any(f, data, lambda p: p.name, None, 0.1, 0.5)


@pytest.mark.parametrize(
    ("step", "fast"),
    [
        (0.1, False),
        (0.05, True),
        (0.02, True),
        (0.01, True),
        (0.1 / FAST_FACTOR, True),
        (0.2, False),
        (0.002, True),  # 500 Hz: a logger's table (up to 1 kHz is taken)
        (0.0001, False),  # 10 kHz: a time column in another unit (found by the stage fuzz)
    ],
)
def test_a_table_is_faster_than_the_grid_by_its_median_step(step, fast):
    rng = np.random.default_rng(0)
    t = 100.0 + step * np.arange(600) + rng.uniform(-0.2, 0.2, 600) * step
    assert is_faster_than_grid(t, 0.1) is fast


def test_a_time_column_scaled_down_a_thousand_times_is_refused_with_its_rate(tmp_path):
    """Found by the stage fuzz test: a 10 Hz file's times scaled by 0.001 (rows 0.1 ms
    apart) were taken for a table logged faster than the grid and refused for streams with
    "no common stretch"; read as a 10 Hz file, validate names the rate."""
    from rwhonet.stages.ingest import ingest
    from rwhonet.stages.validate import validate
    from support.corpus import write_good_fleet, write_target

    raw = tmp_path / "raw"
    write_good_fleet(raw)
    df = good_target()
    write_target(raw, df.assign(**{c.T_S: df[c.T_S] * 0.001}))
    params = make_params(raw)
    ingest(params, tmp_path / "drives")
    with pytest.raises(InputError) as err:
        validate(params, tmp_path / "drives", tmp_path / "segments", tmp_path / "report.json")
    assert any("sampled at 1e+04 Hz, not 10 Hz" in p.found for p in err.value.problems)


def test_a_10_hz_file_with_dropped_rows_is_not_faster():
    t = 0.1 * np.delete(np.arange(1000), np.arange(0, 1000, 7))
    assert not is_faster_than_grid(t, 0.1)


def _stamps(hz: float, n: int = 3000, **jitter: float) -> np.ndarray:
    """``n`` stamps of a logger at ``hz``, to the ms, jittered (``bell``, ``uniform``: s)."""
    rng = np.random.default_rng(int(hz * 1000) + n)
    t = 45000.0 + np.arange(n) / hz
    t = t + rng.normal(0.0, jitter.get("bell", 0.0), n)
    t = t + rng.uniform(-1.0, 1.0, n) * jitter.get("uniform", 0.0)
    return np.round(t, 3)


@pytest.mark.parametrize("hz", [9.98, 9.9, 9.995, 10.05])
def test_the_rate_of_a_logger_of_its_own_is_told_from_its_stamps(hz):
    off, se = rate_ratio(_stamps(hz), 0.1)
    assert off == pytest.approx(10.0 / hz - 1.0, abs=2e-5) and se < 1e-5
    assert is_off_the_grid_rate(_stamps(hz), 0.1) is (abs(10.0 / hz - 1.0) >= 3e-4)


@pytest.mark.parametrize(
    "t",
    [
        _stamps(10.0),
        _stamps(10.0 / (1 + 50e-6)),  # a clock 50 ppm off: stamps and sampling alike
        0.1 * np.delete(np.arange(3000), np.arange(0, 3000, 7)) + 45000.0,  # dropped rows
        _stamps(10.0, 300, bell=0.02),
        _stamps(10.0, 36_000, bell=0.02),
        _stamps(10.0, 3000, uniform=0.04),
        _stamps(10.0, 200, bell=0.015),
    ],
    ids=["exact", "50ppm", "dropped", "bell300", "bell36000", "uniform40", "bell200"],
)
def test_a_10_hz_logger_jittered_or_dropping_rows_keeps_the_grid(t):
    """Jitter moves the rate's estimate by nothing on average, and its standard error says
    by how much: a 10 Hz drive is not taken for a logger of its own rate."""
    off, se = rate_ratio(t, 0.1)
    assert abs(off) < 4.0 * se or abs(off) < 3e-4
    assert not is_off_the_grid_rate(t, 0.1)


def _logged(rng, hz: float, n: int, kind: str, size_s: float, drop: float) -> np.ndarray:
    """``n`` samples of a logger at ``hz``, a share ``drop`` of them lost, stamped to the ms
    with a jitter of ``kind`` (bell, uniform, a delay) and size, in time order."""
    k = np.arange(n)[rng.uniform(size=n) >= drop]
    t = 45000.0 + k / hz
    noise = {
        "bell": lambda: rng.normal(0.0, size_s, k.size),
        "uniform": lambda: rng.uniform(-1.5 * size_s, 1.5 * size_s, k.size),
        "delay": lambda: rng.exponential(size_s, k.size) if size_s else np.zeros(k.size),
    }[kind]()
    return np.sort(np.round(t + noise, 3))


def test_jittered_10_hz_drives_dropping_samples_are_never_taken_for_a_rate_of_their_own():
    """600 simulated 10 Hz drives: 200 to 36,000 rows, a bell curve, uniform jitter or a
    one-sided delay of up to 30 ms, up to 10 % of samples lost. Before the band was narrowed
    and irregular stamps kept on the grid, 235 of 3,000 such drives were taken for a logger
    of its own rate (a jittered dropout passing for an even step pulled the slope up)."""
    rng = np.random.default_rng(68)
    for _ in range(600):
        kind = str(rng.choice(["bell", "uniform", "delay"]))
        n = int(rng.choice([200, 1000, 5000, 36_000]))
        t = _logged(rng, 10.0, n, kind, rng.uniform(0.0, 0.03), rng.uniform(0.0, 0.1))
        assert not is_off_the_grid_rate(t, 0.1), (kind, n)


def test_a_sleeping_loop_s_rate_is_found_through_its_own_jitter_and_dropouts():
    """A loop at 9.9-9.99 or 10.01-10.1 Hz, its stamps jittered by up to 3 ms and 5 % of
    its samples lost: taken for a rate of its own, the rate within four standard errors."""
    rng = np.random.default_rng(9)
    for _ in range(200):
        hz = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 0.1) + 10.0)
        kind = str(rng.choice(["bell", "uniform", "delay"]))
        n = int(rng.choice([1000, 5000, 36_000]))
        t = _logged(rng, hz, n, kind, rng.uniform(0.0, 0.003), rng.uniform(0.0, 0.05))
        off, se = rate_ratio(t, 0.1)
        assert is_off_the_grid_rate(t, 0.1), (hz, kind, n)
        assert abs(off - (10.0 / hz - 1.0)) <= 4.0 * se + 1e-6, (hz, kind, n, off, se)


@pytest.mark.parametrize(
    ("hz", "fix_hz"),
    [(20, None), (50, 10), (100, 10), (50, None), (9.98, None), (9.9, None), (10.05, None)],
)
def test_a_faster_table_gives_the_10_hz_files_drive(tmp_path, hz, fix_hz):
    """Logged faster, or at a rate of the logger's own (a loop that sleeps a period between
    samples: 9.98, 9.9 Hz; its stamps right): read as streams and resampled, the 10 Hz
    file's drive. On the grid, before stop 68, the 9.98 Hz drive's rows slipped a slot
    every 500 rows (a second cut as partial) and its wheels covered 0.2 % less time than
    its fixes (the labels 2 cm a second off); the 9.9 Hz one was refused."""
    df = good_target(200.0)
    ten, _ = _read(write_iovnbd(df, tmp_path / "V-A.csv"), tmp_path)
    table = faster(df, hz, fix_hz)
    if hz < 20:  # a software logger's stamps, to the ms
        table[c.T_S] = np.round(table[c.T_S], 3)
    path = write_iovnbd(table, tmp_path / "V-F.csv")
    got, facts = _read(path, tmp_path)
    assert got.header_match == "streams" and facts is not None
    assert any(NOTE in note for note in got.notes)
    if hz < 20:
        assert any(f"rows at {hz:g} Hz by their stamps" in note for note in got.notes)
    t = got.columns[c.T_S]
    # every grid row but the edges, on the 10 Hz file's times
    assert (
        t.size >= ten.n_rows - 2 * 10
        and np.isin(np.round(t, 6), np.round(ten.columns[c.T_S], 6)).all()
    )
    at = np.searchsorted(np.round(ten.columns[c.T_S], 6), np.round(t, 6))
    # a window's mean of a signal linear between the 10 Hz rows is the row's value but for
    # its curvature over 0.1 s (the wheel speeds swing 2 m/s over 40 s)
    for w in c.WHEELS:
        np.testing.assert_allclose(got.columns[w], ten.columns[w][at], rtol=2e-4)
    # the fixes where the 10 Hz file has them: each second's position within a millimetre
    whole = np.isclose(t % 1.0, 0.0, atol=1e-6) | np.isclose(t % 1.0, 1.0, atol=1e-6)
    for k in (c.LAT_DEG, c.LON_DEG):
        np.testing.assert_allclose(got.columns[k][whole], ten.columns[k][at][whole], atol=1e-8)
    # predict, from the file or a pipe, hands on the same grid rows
    for source in (lambda: io.BytesIO(path.read_bytes()), lambda: piped(path.read_bytes())):
        with source() as stream:
            lay, blocks = read_rows(stream, path.name, block_bytes=1 << 14)
            blocks = list(blocks)
        streamed = {k: np.concatenate([b[k] for _, b in blocks]) for k in (c.T_S, c.OMEGA_RL)}
        np.testing.assert_allclose(streamed[c.T_S], t)
        np.testing.assert_array_equal(streamed[c.OMEGA_RL], got.columns[c.OMEGA_RL])
        assert any(NOTE in note for note in lay.notes)


def test_a_row_written_twice_in_a_faster_table_is_dropped_first(tmp_path):
    df = faster(good_target(200.0), 20)
    path = write_iovnbd(df, tmp_path / "V-F.csv")
    want, _ = _read(path, tmp_path)
    lines = path.read_text().splitlines()
    lines.insert(500, lines[499])
    path.write_text("\n".join(lines) + "\n")
    got, _ = _read(path, tmp_path)
    assert any("(row(s) 500)" in note and "repeat" in note for note in got.notes)
    np.testing.assert_array_equal(got.columns[c.OMEGA_RL], want.columns[c.OMEGA_RL])
    with io.BytesIO(path.read_bytes()) as stream:
        lay, blocks = read_rows(stream, path.name)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, want.columns[c.OMEGA_RL])


def test_a_10_hz_file_is_read_row_for_row(tmp_path):
    raw, facts = _read(write_iovnbd(good_target(), tmp_path / "V-A.csv"), tmp_path)
    assert facts is None and raw.header_match == "name"


def test_a_glitched_sample_flags_the_same_grid_rows_for_ingest_and_predict(tmp_path):
    from rwhonet.data.canonical import GLITCH_FLAG

    df = faster(good_target(200.0), 50)
    df.loc[3001, c.OMEGA_RL] *= 4.0  # one 50 Hz sample of one wheel at 4x its speed
    path = write_iovnbd(df, tmp_path / "V-F.csv")
    data = make_params(tmp_path).data
    f = DriveFile(path.stem, "target_test", "target", "iovnbd", path)
    raw, facts = read_any(f, data, lambda p: p.name, TARGET_RADIUS_M, 0.1, 0.5)
    assert facts is not None and facts.glitch_rows.size >= 1
    with io.BytesIO(path.read_bytes()) as stream:
        lay, blocks = read_rows(stream, path.name, radius_m=TARGET_RADIUS_M)
        blocks = list(blocks)
    flagged = np.concatenate([b[GLITCH_FLAG + c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(flagged, facts.glitch_wheels[c.OMEGA_RL])
    assert flagged.sum() == 1


@pytest.mark.parametrize("lag", [0.2, "auto"])
def test_predict_moves_a_faster_tables_fixes_by_the_projects_lag_as_ingest(tmp_path, lag):
    """A project that sets data.gnss_lag (a number, or auto): predict's reader moves a
    20 Hz table's fixes as ingest's does; before, it took the default ("report") and its
    positions were the stamps' where ingest's were moved."""
    path = write_iovnbd(faster(good_target(200.0), 20), tmp_path / "V-F.csv")
    data = make_params(tmp_path, **{"data.gnss_lag": lag}).data
    f = DriveFile(path.stem, "target_test", "target", "iovnbd", path)
    raw, _ = read_any(f, data, lambda p: p.name, None, 0.1, 0.5)
    report, _ = _read(path, tmp_path)
    with io.BytesIO(path.read_bytes()) as stream:
        lay, blocks = read_rows(stream, path.name, gnss_lag=lag)
        blocks = list(blocks)
    lat = np.concatenate([b[c.LAT_DEG] for _, b in blocks])
    np.testing.assert_array_equal(lat, raw.columns[c.LAT_DEG])
    if lag == 0.2:  # moved: 0.2 s of driving, about 3 m, on the rows both have
        t = np.round(np.concatenate([b[c.T_S] for _, b in blocks]), 6)
        _, mine, theirs = np.intersect1d(t, np.round(report.columns[c.T_S], 6), True, True)
        assert mine.size > 1900
        assert np.nanmax(np.abs(lat[mine] - report.columns[c.LAT_DEG][theirs])) > 1e-5


def test_a_glitched_sample_of_a_faster_table_is_named_by_its_file_row(tmp_path):
    """Rows dropped before the table is read as streams (a row written twice, a row
    without a wheel speed): the resampler's messages still name the file's rows."""
    from rwhonet.data.droprows import drop_rows
    from rwhonet.data.fastfile import as_streams
    from rwhonet.data.iovnbd import read_iovnbd
    from rwhonet.data.streams import resample

    df = faster(good_target(200.0), 50)
    df.loc[3001, c.OMEGA_RL] *= 4.0  # data row 3002 of the file as written
    path = write_iovnbd(df, tmp_path / "V-F.csv")
    lines = path.read_text().splitlines()
    lines.insert(500, lines[499])  # data row 499 written twice: the glitch is now row 3003
    cells = lines[1001].split(",")  # data row 1001: its rear-left wheel speed lost
    cells[[k.strip() for k in lines[0].split(",")].index("Wheel Speed Rear Left (rad/sec)")] = ""
    lines[1001] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    raw = drop_rows(read_iovnbd(path, path.name), path.name)
    res = resample(as_streams(raw, path.name), nominal_radius_m=TARGET_RADIUS_M)
    assert [(row, w) for _, row, _, w in res.glitch_samples] == [(3003, c.OMEGA_RL)]


def test_a_faster_tables_rows_out_of_order_are_put_in_order_as_a_streams(tmp_path):
    """A 50 Hz CAN table whose logger wrote a buffer's rows backwards: read as the table in
    order, as a stream's samples are (rwhonet.data.sampleorder); its clock set back (the
    rows of two stretches overlapping) stays refused, naming the file's row."""
    df = faster(good_target(200.0), 50)
    want, _ = _read(write_iovnbd(df, tmp_path / "V-A.csv"), tmp_path)
    path = write_iovnbd(df, tmp_path / "V-F.csv")
    lines = path.read_text().splitlines()
    lines[1001:1011] = lines[1001:1011][::-1]  # data rows 1001-1010 written backwards
    path.write_text("\n".join(lines) + "\n")
    got, _ = _read(path, tmp_path)
    for k in want.columns:
        np.testing.assert_array_equal(got.columns[k], want.columns[k])
    assert any("9 sample(s) written after a later one" in n for n in got.notes)
    with io.BytesIO(path.read_bytes()) as stream:  # predict's reader: the same grid rows
        _, blocks = read_rows(stream, path.name)
        streamed = np.concatenate([b[c.OMEGA_RL] for _, b in blocks])
    np.testing.assert_array_equal(streamed, want.columns[c.OMEGA_RL])
    back = df.copy()
    back.loc[3000:, c.T_S] -= 0.517  # a clock set back half a second at data row 3001 ...
    back.loc[3000:, c.LAT_DEG] += 0.27  # ... on a recording 30 km away: no car going on
    path = write_iovnbd(back, tmp_path / "V-B.csv")
    with pytest.raises(InputError) as err:
        _read(path, tmp_path)
    assert {(p.row, "strictly increasing" in p.expected) for p in err.value.problems} >= {
        (3001, True)
    }


@pytest.mark.parametrize(("hz", "back_s"), [(50, 0.517), (20, 3.0), (100, 3600.0)])
def test_a_faster_tables_clock_set_back_while_the_car_drove_on_is_put_on_one_clock(
    tmp_path, hz, back_s
):
    """A 20-100 Hz table whose logger's clock was set back (an NTP step, summer time
    ending) at data row 3001, the car driving on: its rows from there put on by whole
    seconds (sampleorder.clock_steps, judged at the table's own rate), read as streams
    and resampled: the grid of the table logged on one clock so moved, ingest and predict
    from a file alike; the seconds around the step cut. Refused until stop 69."""
    df = faster(good_target(200.0), hz)
    t = df[c.T_S].to_numpy()
    shift = np.ceil(round(back_s - t[1] + t[0] + 1.0, 6))  # whole seconds, at least 1 s on
    moved = df.copy()
    moved.loc[3000:, c.T_S] = t[3000:] - back_s + shift  # the table on one clock
    want, _ = _read(write_iovnbd(moved, tmp_path / "V-A.csv"), tmp_path)
    back = df.copy()
    back.loc[3000:, c.T_S] = t[3000:] - back_s
    path = write_iovnbd(back, tmp_path / "V-B.csv")
    got, _ = _read(path, tmp_path)
    for k in (c.T_S, c.OMEGA_RL, c.LAT_DEG):
        np.testing.assert_allclose(got.columns[k], want.columns[k], rtol=0, atol=1e-9)
    said = f"row 3001 ({round(back_s, 3):g} s back, its rows {shift:g} s later)"
    assert any(said in n for n in got.notes), got.notes
    with io.BytesIO(path.read_bytes()) as stream:  # predict's reader: the same grid rows
        lay, blocks = read_rows(stream, path.name)
        blocks = list(blocks)
    streamed = {k: np.concatenate([b[k] for _, b in blocks]) for k in (c.T_S, c.OMEGA_RL)}
    np.testing.assert_allclose(streamed[c.T_S], got.columns[c.T_S], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(streamed[c.OMEGA_RL], got.columns[c.OMEGA_RL])
    assert any(said in n for n in lay.notes), lay.notes
