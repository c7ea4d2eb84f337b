"""Fixes a 10 Hz file holds from a slower receiver (rwhonet.data.heldfixes)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rwhonet.data import canonical as c
from rwhonet.data.csvio import RawDrive
from rwhonet.data.heldfixes import HeldFixGate, held_fixes, place_held_fixes
from rwhonet.geo import local_distance_m
from rwhonet.stages.ingest import ingest
from rwhonet.stages.validate import validate
from support.corpus import DRIVE, good_target, write_good_fleet, write_target
from support.drives import make_params, with_held_fixes
from support.synthetic import build_drive, piecewise_linear_speed

# 20 m/s down to a 20 s stop and back up to 15 m/s, then 9 m/s: 260 s
KNOTS = ([0, 60, 80, 100, 120, 180, 200, 260], [20, 20, 0, 0, 15, 15, 9, 9])


def _drive(gnss_sigma_m: float = 0.0) -> pd.DataFrame:
    df = build_drive(piecewise_linear_speed(*KNOTS), gnss_sigma_m=gnss_sigma_m, seed=3)
    df[c.N_SATS] = 9.0
    return df


def raw_of(df: pd.DataFrame) -> RawDrive:
    return RawDrive({k: df[k].to_numpy(np.float64) for k in df if k != c.SCENARIO}, {}, "name")


def per_second_m(df: pd.DataFrame) -> np.ndarray:
    """The GNSS displacement of each whole second, as the labels take it."""
    t = df[c.T_S].to_numpy()
    whole = np.flatnonzero(np.abs((t - t[0]) - np.round(t - t[0])) < 1e-6)
    lat, lon = df[c.LAT_DEG].to_numpy()[whole], df[c.LON_DEG].to_numpy()[whole]
    return local_distance_m(lat[:-1], lon[:-1], lat[1:], lon[1:])


def test_a_drive_with_its_own_10_hz_fixes_is_left_as_it_is():
    for sigma in (0.0, 0.5):
        raw = raw_of(_drive(sigma))
        assert held_fixes(raw.columns) is None
        assert place_held_fixes(raw) is raw


@pytest.mark.parametrize("empty", [False, True], ids=["held", "empty_between"])
@pytest.mark.parametrize(("every", "phase"), [(10, 0), (10, 3), (10, 9), (5, 2), (2, 1)])
def test_held_fixes_are_found_and_placed_back_along_the_path(every, phase, empty):
    """Held in every row until the next, or written only in the row they came in."""
    truth = _drive()
    df = with_held_fixes(truth, every, phase, empty)
    found = held_fixes(raw_of(df).columns)
    assert found is not None and found.period_rows == every
    # the receiver's fixes: each row where the fix came, and in the stop every period
    # (held, the first row's fix came before the log began: its time is unknown)
    came = set(np.flatnonzero((np.arange(len(df)) - phase) % every == 0)) - (
        set() if empty else {0}
    )
    assert came <= set(found.fresh)
    out = place_held_fixes(raw_of(df))
    assert out.held_fix_period_rows == every
    assert found.empty_between == empty
    assert ("the cells between empty" in out.notes[-1]) == empty
    for name in c.WHEELS:  # the wheels are the file's, row for row
        np.testing.assert_array_equal(out.columns[name], df[name].to_numpy())
    placed = pd.DataFrame(out.columns)
    ok = np.isfinite(placed[c.LAT_DEG].to_numpy())
    # only the rows before the first fix and after the last have none
    assert (~ok).sum() < 2 * every and ok[every:-every].all()
    err = local_distance_m(
        placed[c.LAT_DEG].to_numpy()[ok],
        placed[c.LON_DEG].to_numpy()[ok],
        truth[c.LAT_DEG].to_numpy()[ok],
        truth[c.LON_DEG].to_numpy()[ok],
    )
    # a straight road: exact along the path; where the wheels rolled under a radian between
    # two fixes (coming to the stop), linear in time: at most a T^2 / 8 at 1 m/s^2
    assert err.max() < 0.125 * (every / 10) ** 2 + 0.005
    d_truth, d_held, d_placed = per_second_m(truth), per_second_m(df), per_second_m(placed)
    good = np.isfinite(d_placed)
    assert np.nanmax(np.abs(d_placed - d_truth)[good]) < 2 * (0.125 * (every / 10) ** 2 + 0.005)
    if phase and not empty:  # held, each second's displacement was another second's
        assert np.sqrt(np.mean((d_held - d_truth) ** 2)) > 0.1


def test_a_coordinate_written_too_coarsely_is_not_taken_for_held_fixes():
    """1e-5 deg (about 1 m): a 10 Hz fix changes every one to six rows, not at one period."""
    df = _drive()
    df[c.LAT_DEG], df[c.LON_DEG] = df[c.LAT_DEG].round(5), df[c.LON_DEG].round(5)
    assert held_fixes(raw_of(df).columns) is None


def test_ingest_places_held_fixes_and_validate_keeps_the_drive(tmp_path):
    """The drive with 1 Hz fixes held gives validate the seconds and cuts of the drive
    with its own fixes (before, each fix's jump was cut: 72 m/s between two rows)."""
    kept = {}
    for name, df in {"own": good_target(), "held": with_held_fixes(good_target(), 10, 4)}.items():
        raw = tmp_path / name / "raw"
        write_good_fleet(raw)
        write_target(raw, df)
        params = make_params(raw)
        manifest = ingest(params, tmp_path / name / "drives", tmp_path / name / "failed.json")
        (entry,) = [d for d in manifest["drives"] if d["drive"] == DRIVE]
        report = validate(
            params, tmp_path / name / "drives", tmp_path / name / "seg", tmp_path / name / "v.json"
        )
        (kept[name],) = [d for d in report["drives"] if d["drive"] == DRIVE]
        if name == "held":
            assert entry["held_fix_period_rows"] == 10
            assert any("from a 1 Hz receiver, each held" in n for n in entry["notes"])
            assert kept[name]["held_fix_period_rows"] == 10
    assert "held_fix_period_rows" not in kept["own"]
    assert kept["held"]["cut_seconds_by_rule"].get("jump", 0) == 0
    # the first row's fix came before the log began (when, unknown) and the last rows have
    # no fix after them: their seconds are cut
    assert 0 <= kept["own"]["seconds_kept"] - kept["held"]["seconds_kept"] <= 2


@pytest.mark.parametrize("sizes", [[100_000], [7] * 500, [301, 1, 999]])
def test_predict_s_gate_places_them_as_ingest_does_whatever_the_blocks(sizes):
    """rwhonet predict's rows come in blocks: a drive with its own fixes is handed on block
    for block as it came; one with held fixes is read to its end and placed as the whole
    file is, in blocks that keep the file's rows (split where a row was dropped)."""
    own = _drive()
    df = with_held_fixes(own, 10, 6)
    for frame, is_held in ((own, False), (df, True)):
        cols = {k: frame[k].to_numpy(np.float64) for k in frame if k != c.SCENARIO}
        keep = np.ones(len(frame), dtype=bool)
        keep[[500, 501, 1700]] = False  # rows dropped before the gate (rows 501, 502, 1701)
        file_row = np.flatnonzero(keep) + 1
        blocks, i = [], 0
        kept = {k: v[keep] for k, v in cols.items()}
        for n in [*sizes, len(file_row)]:
            part = slice(i, i + n)
            rows = file_row[part]
            while rows.size:  # consecutive file rows per block, as the row filter hands on
                cut = np.flatnonzero(np.diff(rows) != 1)
                m = int(cut[0]) + 1 if cut.size else rows.size
                a = i
                blocks.append((int(rows[0]), {k: v[a : a + m] for k, v in kept.items()}))
                i += m
                rows = rows[m:]
            if i >= len(file_row):
                break
        gate = HeldFixGate()
        out = list(gate.blocks(blocks))
        if not is_held:
            assert out == blocks and gate.note is None
            continue
        assert "from a 1 Hz receiver, each held" in gate.note
        whole = place_held_fixes(raw_of(pd.DataFrame(kept)))
        got = {k: np.concatenate([b[k] for _, b in out]) for k in whole.columns}
        for k, v in whole.columns.items():
            np.testing.assert_array_equal(got[k], v)
        rows_out = np.concatenate([f + np.arange(len(b[c.T_S])) for f, b in out])
        np.testing.assert_array_equal(rows_out, file_row)


@pytest.mark.parametrize("latency_s", [0.3, 0.32, 0.35])
def test_fixes_reaching_the_logger_a_row_early_or_late_go_on_the_receiver_s_epochs(latency_s):
    """A 1 Hz fix taken on the whole second reaches the logger ``latency_s`` later, give or
    take 30 ms: about a row's boundary it lands 9, 10 or 11 rows after the last (at 0.3 s
    half of them off the period, and the fixes were not found). Found now, and each taken
    at the receiver's regular epoch, not at its row's time: each second's displacement is
    the truth's a constant latency later, where at the rows' times it jumped by the car's
    travel in 0.1 s from fix to fix."""
    truth = _drive()
    n = len(truth)
    rng = np.random.default_rng(0)
    epochs = np.arange(n // 10 + 1)
    arrive = np.ceil((epochs + latency_s + rng.normal(0.0, 0.03, epochs.size)) * 10 - 1e-9)
    src = np.zeros(n, dtype=int)
    for e, row in zip(epochs, arrive.astype(int), strict=True):
        if row < n:
            src[row:] = 10 * e  # the fix taken at the second, from its arrival on
    df = truth.copy()
    for name in (c.LAT_DEG, c.LON_DEG, c.N_SATS):
        df[name] = truth[name].to_numpy()[src]
    found = held_fixes(raw_of(df).columns)
    assert found is not None and found.period_rows == 10
    out = place_held_fixes(raw_of(df))
    assert "regular epochs" in out.notes[-1], out.notes
    placed = pd.DataFrame(out.columns)
    # the truth a latency later: the fixes' mean delay to the rows they landed in
    came = arrive < n
    delay = float(np.mean(arrive[came] / 10 - epochs[came]))
    t = truth[c.T_S].to_numpy()
    late = truth.copy()
    for name in (c.LAT_DEG, c.LON_DEG):
        late[name] = np.interp(t - delay, t, truth[name].to_numpy(), left=np.nan)
    err = np.abs(per_second_m(placed) - per_second_m(late))
    # within a centimetre or two; coming to the stop, where the wheels cannot tell, the
    # linear interpolation's a T^2 / 8 at 1 m/s^2 at either end of the second
    assert np.nanmedian(err) < 0.02 and np.nanmax(err) < 2 * 0.125 + 0.01, err
