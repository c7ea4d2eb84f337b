"""validate's per-drive checks, and its wheel-unit check on a drive that arrives in blocks."""

import numpy as np
import pytest

from rwhonet.config import load_params
from rwhonet.data import canonical as c
from rwhonet.data.drivechecks import StreamRadiusCheck, radius_problems, wheel_problems
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
def test_a_stuck_wheel_is_refused_as_the_rows_come_a_negated_one_at_the_end(size):
    """The stuck-wheel check runs while the drive streams (once the unit check decided)
    and names validate's first row of the stretch; the sign check, a share of the whole
    drive's moving rows, runs at its end only."""
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

    negated = _drive()
    negated[c.OMEGA_RR] = -negated[c.OMEGA_RR]
    assert not wheel_problems(
        vp, R_M, ENTRY | {"drive": "V-Car"}, negated, [], assess(negated, vp.gnss, 0.1), signs=False
    )
    check = StreamRadiusCheck(ENTRY, R_M, vp)
    _all_rows(check, negated, size)  # no refusal while it streams
    with pytest.raises(InputError) as err:
        check.finish()
    assert ">= 0" in err.value.problems[0].expected
