"""validate's per-drive checks, and its wheel-unit check on a drive that arrives in blocks."""

import numpy as np
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.drivechecks import StreamRadiusCheck, radius_problems, wheel_problems
from rwhonet.data.plausibility import SignTally, sign_tallies
from rwhonet.data.quality import assess
from rwhonet.errors import InputError
from support.synthetic import build_drive, wavy_speed

R_M = 0.362
ENTRY = {"source_file": "V-Car.csv", "columns": {}, "vehicle": "car"}


def _drive(factor: float = 1.0) -> dict[str, np.ndarray]:
    df = build_drive(
        wavy_speed(300.0, 12.0, 4.0, 60.0), r_rl_m=R_M, r_rr_m=R_M, r_front_m=R_M, seed=3
    )
    out = {k: df[k].to_numpy(np.float64) for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    for w in c.WHEELS:
        out[w] = out[w] * factor
    return out


def _push(drive, size, vp):
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    n = drive[c.T_S].size
    for a in range(0, n, size):
        if check.push({k: v[a : a + size] for k, v in drive.items()}):
            return check, a + size
    check.finish()
    return check, n


@pytest.mark.parametrize("size", [7, 100, 1000])
def test_the_stream_check_decides_early_and_as_validate_on_the_whole_drive(size):
    vp = load_params().validate
    for factor, unit in (
        (1.0, None),
        (R_M * 3.6, "km/h"),
        (60 / (2 * np.pi), "rpm"),
    ):
        drive = _drive(factor)
        whole, _ = radius_problems(
            ENTRY, drive, assess(drive, vp.gnss, vp.sample_period_s).segments, R_M, vp
        )
        if unit is None:
            check, at = _push(drive, size, vp)
            assert whole == [] and check.decided and check.note is None
            # decided on its first GNSS-valid stretch with enough moving seconds, not the end
            assert at <= max(size, 90 / vp.sample_period_s)
            continue
        with pytest.raises(InputError) as err:
            _push(drive, size, vp)
        (p,) = err.value.problems
        assert f"look like {unit}" in p.found and f"look like {unit}" in whole[0].found
        assert p.file == "V-Car.csv" and p.expected.startswith("rear wheel speeds in rad/s")


def test_without_a_fix_or_moving_seconds_the_check_says_why_it_did_not_run():
    vp = load_params().validate
    drive = _drive()
    drive[c.LAT_DEG] = np.full(drive[c.T_S].size, np.nan)
    check, _ = _push(drive, 500, vp)
    assert check.decided and "has no GNSS fix" in check.note
    short = {k: v[:200] for k, v in _drive().items()}  # 20 s: no valid stretch of 30 s
    check, _ = _push(short, 50, vp)
    assert "only 0 moving s" in check.note


def test_the_stream_check_of_a_drive_without_rows_ends_undecided_with_a_note():
    check = StreamRadiusCheck(ENTRY, R_M, load_params().validate)
    assert check.finish() == (
        "V-Car.csv: wheel speeds' unit not checked against GNSS (validate's tyre-radius "
        "check): the drive has no GNSS fix; make sure they are rad/s"
    )
    assert check.decided and check.yaw_decided


def _all_rows(check: StreamRadiusCheck, drive, size: int) -> int:
    """Push every row of ``drive`` in blocks of ``size``; return the rows pushed."""
    n = drive[c.T_S].size
    for a in range(0, n, size):
        check.push({k: v[a : a + size] for k, v in drive.items()})
    return n


@pytest.mark.parametrize("size", [7, 100, 1000])
def test_a_stuck_wheel_is_refused_as_the_rows_come(size):
    """The stuck-wheel check runs while the drive streams (once the unit check decided)
    and names validate's first row of the stretch."""
    vp = load_params().validate
    stuck = _drive()
    stuck[c.OMEGA_RL] = np.where(stuck[c.T_S] - stuck[c.T_S][0] > 100.0, 0.0, stuck[c.OMEGA_RL])
    whole = wheel_problems(
        vp, R_M, ENTRY | {"drive": "V-Car"}, stuck, [], assess(stuck, vp.gnss, vp.sample_period_s)
    )
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    with pytest.raises(InputError) as err:
        _all_rows(check, stuck, size)
    # within the next 60 s of rows (and the block that brought them), not at the drive's end
    assert check.n_wheel_rows <= (100.0 + 60.0 + 3.0) / vp.sample_period_s + size
    assert [(p.row, p.column) for p in err.value.problems] == [(whole[0].row, whole[0].column)]
    assert err.value.problems[0].expected == whole[0].expected


def _whole(vp, drive):
    return wheel_problems(
        vp, R_M, ENTRY | {"drive": "V-Car"}, drive, [], assess(drive, vp.gnss, vp.sample_period_s)
    )


@pytest.mark.parametrize("size", [7, 100, 1000])
def test_one_negative_wheel_is_refused_as_it_comes_four_negated_at_the_end(size):
    """validate refuses a wheel negative while another turns forwards whatever its share:
    the stream refuses it once the unit check has decided, with validate's first row. Four
    wheels negative together are a signing logger's reversing up to signed_max_share of the
    moving rows, a share of the whole drive: the stream refuses them at its end, with the
    report validate gives on the whole drive, word for word."""
    vp = load_params().validate
    one = _drive()
    t = one[c.T_S] - one[c.T_S][0]
    one[c.OMEGA_RR] = np.where((t > 150.0) & (t < 160.0), -one[c.OMEGA_RR], one[c.OMEGA_RR])
    (whole,) = _whole(vp, one)
    assert "not reversing" in whole.found
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    with pytest.raises(InputError) as err:
        _all_rows(check, one, size)
    assert check.n_wheel_rows <= 160.0 / vp.sample_period_s + size  # not at the end (300 s)
    (p,) = err.value.problems
    assert (p.row, p.column, p.expected) == (whole.row, whole.column, whole.expected)
    assert "so far) while GNSS moved" in p.found and "not reversing" in p.found

    negated = _drive()
    for w in c.WHEELS:
        negated[w] = -negated[w]
    whole = _whole(vp, negated)
    assert len(whole) == 4 and "looks negated" in whole[0].found
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    _all_rows(check, negated, size)  # no refusal while it streams: a share of the whole drive
    with pytest.raises(InputError) as err:
        check.finish()
    assert err.value.problems == whole


def test_the_sign_tallies_of_blocks_add_up_to_the_whole_drive_s():
    """A stream keeps the sign check's tallies, not its rows: the tallies of any split of a
    drive into blocks (each with the row before it as its lead) add up to the whole
    drive's, field by field."""
    vp = load_params().validate
    drive = _drive()
    t = drive[c.T_S] - drive[c.T_S][0]
    reverse = (t > 40.0) & (t < 45.0)  # all four together: reversing
    alone = (t > 200.0) & (t < 201.0)  # the rear right alone
    for w in c.WHEELS:
        drive[w] = np.where(reverse | (alone & (w == c.OMEGA_RR)), -drive[w], drive[w])
    args = (vp.wheels.negative_tol_rad_s, vp.gnss.moving_wheel_speed_rad_s)
    whole = sign_tallies(drive, *args)
    assert whole[c.OMEGA_RR].negative > whole[c.OMEGA_RL].negative > 0
    assert not whole[c.OMEGA_RR].reversing and whole[c.OMEGA_RL].reversing
    rng = np.random.default_rng(0)
    n = drive[c.T_S].size
    cuts = np.unique(np.r_[0, rng.integers(1, n, 40), 1, n - 1, n])
    summed = dict.fromkeys(c.WHEELS, SignTally())
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        lead = 1 if a else 0
        block = {k: v[a - lead : b] for k, v in drive.items()}
        part = sign_tallies(block, *args, row0=int(a), lead=lead)
        summed = {k: summed[k].add(part[k]) for k in c.WHEELS}
    for w in c.WHEELS:
        got, want = summed[w], whole[w]
        assert got.gnss_m == pytest.approx(want.gnss_m, rel=1e-12)
        assert got == SignTally(**{**want.__dict__, "gnss_m": got.gnss_m})


@pytest.mark.parametrize("size", [7, 1000])
def test_a_stream_keeps_a_minute_or_two_of_rows_once_decided_not_the_whole_drive(size, monkeypatch):
    """Every row was kept for the wheel checks at the drive's end (2 MB an hour, without
    bound on a live stream); once the unit check has decided, the rows kept are the ones
    not checked yet and the minute before them, and, while the wheels' sides are not told
    (this drive never turns), the last ten minutes."""
    vp = load_params().validate
    drive = _drive()
    n = drive[c.T_S].size
    monkeypatch.setattr(StreamRadiusCheck, "SIDES_WINDOW_S", 30.0)  # of the 300 s drive
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    kept = []
    for a in range(0, n, size):
        check.push({k: v[a : a + size] for k, v in drive.items()})
        if check.decided and check.yaw_decided:
            kept.append(sum(p[c.T_S].size for p in check.wheel_parts + check.parts))
    assert check.finish() is None and check.wheel_parts == []
    sides = int(np.ceil(check.SIDES_WINDOW_S / vp.sample_period_s))
    bound = check.sensor_rows + check.sensor_context + sides + check.step_rows + size
    assert kept and max(kept) <= bound < n and "wheels not told" in check.sides_note


def test_the_real_rav4_minute_s_rear_wheels_are_told_in_their_columns():
    """The one real drive: a highway minute that hardly turns (its yaw rate cannot be told,
    the course swung through about a degree), yet its rear wheels' difference follows the
    course's small turns (gain 0.70 ± 0.10, 58 pairs of seconds): told in their columns;
    exchanged, refused. Its front pair is not told (0.33 ± 0.09). Its diagonal gain is 0.00
    ± 0.02; with the front right and rear left exchanged, -0.76 ± 0.10: refused as that
    diagonal pair."""
    from rwhonet.data.comma2k19 import read_comma2k19
    from rwhonet.data.drivechecks import side_problems
    from rwhonet.data.streams import resample
    from support.realminute import RAV4_RADIUS_M, REAL, real_minute

    real_minute()  # skipped where the segment is not on this machine
    vp = load_params().validate
    res = resample(read_comma2k19(REAL, radius_m=RAV4_RADIUS_M), nominal_radius_m=RAV4_RADIUS_M)
    drive = {k: np.asarray(v) for k, v in res.drive.columns.items() if k != c.SCENARIO}
    segments = assess(drive, vp.gnss, vp.sample_period_s).segments
    entry = {"source_file": "rav4", "columns": {}}
    found, record = side_problems(entry, drive, segments, vp, RAV4_RADIUS_M, 1.6)
    assert found == [] and record["rear"]["seconds"] == 58
    assert record["rear"]["gain"] == pytest.approx(0.70, abs=0.01)
    assert record["rear"]["gain"] > 7 * record["rear"]["gain_se"]
    assert not record["checked"] and "front gain 0.333" in record["note"]
    assert abs(record["diagonal"]["gain"]) < 0.05 and "misplaced" not in record
    rear = dict(drive)
    rear[c.OMEGA_RL], rear[c.OMEGA_RR] = drive[c.OMEGA_RR], drive[c.OMEGA_RL]
    found, record = side_problems(entry, rear, segments, vp, RAV4_RADIUS_M, 1.6)
    assert [p.column for p in found] == [f"{c.OMEGA_RL} / {c.OMEGA_RR}"] and record["checked"]
    # one diagonal pair exchanged: each axle's sides then untold, the diagonal told
    diagonal = dict(drive)
    diagonal[c.OMEGA_FR], diagonal[c.OMEGA_RL] = drive[c.OMEGA_RL], drive[c.OMEGA_FR]
    found, record = side_problems(entry, diagonal, segments, vp, RAV4_RADIUS_M, 1.6)
    assert [p.column for p in found] == [f"{c.OMEGA_FR} / {c.OMEGA_RL}"]
    assert record["diagonal"]["gain"] == pytest.approx(-0.76, abs=0.01)
    assert record["diagonal"]["gain"] < -7 * record["diagonal"]["gain_se"]


def _axles_drive(exchanged: bool = False) -> dict[str, np.ndarray]:
    """A car weaving through tight turns (8 m/s, ±0.6 rad/s), its front wheels on the front
    axle's wider arc; ``exchanged``: the front and rear columns written to each other's."""
    from support.corpus import weaving_drive

    df = weaving_drive(300, 8.0, 0.6, radius_m=R_M, fix_noise_m=0.3, track_m=1.5, wheelbase_m=2.7)
    out = {k: df[k].to_numpy(np.float64) for k in (c.T_S, c.LAT_DEG, c.LON_DEG, *c.WHEELS)}
    if exchanged:
        for front, rear in ((c.OMEGA_FL, c.OMEGA_RL), (c.OMEGA_FR, c.OMEGA_RR)):
            out[front], out[rear] = out[rear], out[front]
    return out


def test_the_front_and_rear_columns_exchanged_are_refused_naming_all_four():
    """validate's wheel-axles check: in their columns the axles pass, told (the record's
    gain, its standard error, the pairs and the tight turns); exchanged, one problem names
    the four columns as the map calls them and says to exchange front with rear."""
    from rwhonet.data.drivechecks import axle_problems

    vp = load_params().validate
    names = {w: f"Wheel_{i}" for i, w in enumerate(c.WHEELS, start=1)}
    entry = {"source_file": "V-Car.csv", "columns": names}
    drive = _axles_drive()
    segments = assess(drive, vp.gnss, vp.sample_period_s).segments
    found, record = axle_problems(entry, drive, segments, vp, R_M)
    assert found == [] and record["checked"] and "note" not in record
    assert record["gain"] > 4 * record["gain_se"] and record["tight_turns"] >= 10
    found, record = axle_problems(entry, _axles_drive(exchanged=True), segments, vp, R_M)
    assert record["checked"] and record["gain"] < -4 * record["gain_se"]
    (p,) = found
    assert p.file == "V-Car.csv" and p.row is None
    assert p.column == "Wheel_1 / Wheel_2 / Wheel_3 / Wheel_4"
    assert "front wheels' speeds in 'Wheel_1' and 'Wheel_2'" in p.expected
    assert "the front and rear columns look exchanged" in p.found
    assert "exchange the front and rear columns (left with left" in p.fix
    # front wheels a little slower in the turns (brakes or drive slip): no exchange's gain
    slower = _axles_drive()
    t = slower[c.T_S]
    arc = 0.5 * (2.7 * 0.6 * np.sin(2.0 * np.pi * (t - t[0]) / 40.0) / 8.0) ** 2
    for front, rear in ((c.OMEGA_FL, c.OMEGA_RL), (c.OMEGA_FR, c.OMEGA_RR)):
        slower[front] = slower[rear] * (1.0 - 0.1 * arc)
    found, record = axle_problems(entry, slower, segments, vp, R_M)
    assert found == [] and not record["checked"]
    assert record["note"].startswith("the front wheels ran slower in the turns, by less than")


def _diagonal_drive() -> dict[str, np.ndarray]:
    """:func:`_axles_drive` with its front left and rear right columns exchanged."""
    out = _axles_drive()
    out[c.OMEGA_FL], out[c.OMEGA_RR] = out[c.OMEGA_RR], out[c.OMEGA_FL]
    return out


def test_one_diagonal_pair_exchanged_is_refused_as_one_exchange_and_the_axles_not_fitted():
    """validate's wheel-sides check: in their columns the record holds the diagonal gain
    near 0 and no problem; the front left and rear right exchanged, one problem names the
    two columns as the map calls them and says to exchange them, in the place of any
    axle's own (each axle's columns then hold two wheels of one side), and the axles check
    is not fitted on such columns."""
    from rwhonet.data.drivechecks import axle_problems, side_problems

    vp = load_params().validate
    names = {w: f"Wheel_{i}" for i, w in enumerate(c.WHEELS, start=1)}
    entry = {"source_file": "V-Car.csv", "columns": names}
    drive = _axles_drive()
    segments = assess(drive, vp.gnss, vp.sample_period_s).segments
    found, record = side_problems(entry, drive, segments, vp, R_M, 1.5)
    assert found == [] and record["checked"] and "misplaced" not in record
    assert abs(record["diagonal"]["gain"]) < 4 * record["diagonal"]["gain_se"]
    found, record = side_problems(entry, _diagonal_drive(), segments, vp, R_M, 1.5)
    (p,) = found
    assert record["misplaced"] == [c.OMEGA_FL, c.OMEGA_RR] and record["diagonal"]["gain"] > 0.5
    assert p.file == "V-Car.csv" and p.row is None and p.column == "Wheel_1 / Wheel_4"
    assert "the front left wheel's speed in 'Wheel_1' and the rear right wheel's in" in p.expected
    assert "as if the front columns held both right wheels" in p.found
    assert p.found.endswith("(a diagonal pair: front left for rear right)")
    assert p.fix.startswith("exchange the two columns")
    found, axles = axle_problems(
        entry, _diagonal_drive(), segments, vp, R_M, misplaced=record["misplaced"]
    )
    assert found == [] and not axles["checked"]
    assert axles["note"] == (
        "not fitted: 'Wheel_1', 'Wheel_4' look exchanged (a diagonal pair: the wheel-sides check)"
    )


def _stream_refusal(drive) -> InputError:
    """What predict's check refuses a drive with, its rows pushed 100 at a time."""
    check = StreamRadiusCheck(ENTRY, R_M, load_params().validate)
    with pytest.raises(InputError) as err:
        for a in range(0, drive[c.T_S].size, 100):
            check.push({k: v[a : a + 100] for k, v in drive.items()})
        check.finish()
    return err.value


def test_the_stream_check_refuses_one_diagonal_pair_exchanged():
    """predict's check refuses it as validate does, naming the wheel-sides check."""
    err = _stream_refusal(_diagonal_drive())
    assert "validate's wheel-sides check" in err.summary
    assert "(a diagonal pair: front left for rear right)" in str(err)


def test_the_stream_check_refuses_the_axles_exchanged_once_told_and_keeps_a_note_otherwise():
    """predict's check tells the axles as the rows come, and refuses them exchanged as
    validate does; a drive that never turns tightly ends with a note saying why."""
    vp = load_params().validate
    err = _stream_refusal(_axles_drive(exchanged=True))
    assert "validate's wheel-axles check" in err.summary
    assert "look exchanged" in str(err)

    def streamed(drive):
        check = StreamRadiusCheck(ENTRY, R_M, vp)
        for a in range(0, drive[c.T_S].size, 100):
            check.push({k: v[a : a + 100] for k, v in drive.items()})
        check.finish()
        return check

    check = streamed(_axles_drive())
    assert check.axles_decided and check.axles_note is None
    straight = streamed(_drive())
    assert straight.axles_decided
    assert "front and rear wheels not told" in straight.axles_note
    assert "the front and rear wheels never differed" in straight.axles_note


def test_the_real_rav4_minute_s_axles_are_not_told_on_a_highway():
    """The one real drive turns through about a degree: no tight turn, nothing told."""
    from rwhonet.data.comma2k19 import read_comma2k19
    from rwhonet.data.drivechecks import axle_problems
    from rwhonet.data.streams import resample
    from support.realminute import RAV4_RADIUS_M, REAL, real_minute

    real_minute()  # skipped where the segment is not on this machine
    vp = load_params().validate
    res = resample(read_comma2k19(REAL, radius_m=RAV4_RADIUS_M), nominal_radius_m=RAV4_RADIUS_M)
    drive = {k: np.asarray(v) for k, v in res.drive.columns.items() if k != c.SCENARIO}
    segments = assess(drive, vp.gnss, vp.sample_period_s).segments
    found, record = axle_problems(
        {"source_file": "rav4", "columns": {}}, drive, segments, vp, RAV4_RADIUS_M
    )
    assert found == [] and not record["checked"] and record["tight_turns"] == 0
    assert record["note"].startswith("only 0 pairs of seconds in a tight turn")


def test_the_wheel_sides_check_integrates_each_axle_s_yaw_once(monkeypatch):
    """validate's wheel-sides check fits each axle's yaw (its sides' gains) and the two
    axles' yaws again beside the front less the rear (the diagonal gain): each is
    integrated over the course's pairs once, three integrals in all, and the record is
    what the axles' and diagonal fits give on their own."""
    from rwhonet.data import plausibility
    from rwhonet.data.drivechecks import side_problems

    step_m = plausibility.YAW_MIN_STEP_M
    vp = load_params().validate
    drive = _axles_drive()
    segments = assess(drive, vp.gnss, vp.sample_period_s).segments
    alone = plausibility.wheel_side_gains(drive, segments, step_m, vp.sample_period_s, R_M, 1.5)
    diagonal = plausibility.diagonal_gain(drive, segments, step_m, vp.sample_period_s, R_M, 1.5)
    integrals = []
    pair_angles = plausibility._pair_angles
    monkeypatch.setattr(
        plausibility, "_pair_angles", lambda *a: integrals.append(1) or pair_angles(*a)
    )
    entry = {"source_file": "V-Car.csv", "columns": {}}
    _, record = side_problems(entry, drive, segments, vp, R_M, 1.5)
    assert len(integrals) == 3
    assert record["rear"]["gain"] == alone["rear"].gain
    assert record["front"]["gain_se"] == alone["front"].gain_se
    assert record["diagonal"]["gain"] == diagonal.gain
