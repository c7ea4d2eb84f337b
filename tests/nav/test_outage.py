"""One filter run per outage window: cutting windows, withholding the outage's fixes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rwhonet.nav import NavConfig, NavInputs, NavStart, run, run_outage, window_inputs

from .conftest import model_drives


def _segment(rng, n=900):
    inputs, truth = model_drives(rng, NavConfig(), 1, n)
    per_second = {
        "dist_m": inputs.dist_m[0],
        "dist_var_m2": inputs.dist_var_m2[0],
        "wheel_yaw_rad": inputs.wheel_yaw_rad[0],
        "gyro_yaw_rad": inputs.gyro_yaw_rad[0],
    }
    return per_second, inputs.fix_e_m[0], inputs.fix_n_m[0]


def test_windows_are_cut_from_the_segment():
    per_second, fe, fn = _segment(np.random.default_rng(0))
    starts = np.array([300, 480, 700])
    w = window_inputs(per_second, fe, fn, starts, 300, 180)
    assert w.dist_m.shape == (3, 480) and w.fix_e_m.shape == (3, 481)
    # outage second 0 of window 1 is second 480 of the segment; its fixes 480 and 481
    assert w.dist_m[1, 300] == per_second["dist_m"][480]
    assert w.fix_e_m[1, 300] == fe[480] and w.fix_e_m[1, 301] == fe[481]
    assert w.gyro_yaw_rad[2, -1] == per_second["gyro_yaw_rad"][879]
    with pytest.raises(ValueError, match="windows must start"):
        window_inputs(per_second, fe, fn, np.array([200]), 300, 180)
    with pytest.raises(ValueError, match="windows must start"):
        window_inputs(per_second, fe, fn, np.array([800]), 300, 180)


def test_the_outage_fixes_are_withheld_and_the_last_is_the_truth():
    per_second, fe, fn = _segment(np.random.default_rng(1))
    w = window_inputs(per_second, fe, fn, np.array([300, 600]), 300, 180)
    out = run_outage(w, 300)
    assert out.calibrated.all()
    assert np.allclose(out.truth_m, np.stack([w.fix_e_m[:, -1], w.fix_n_m[:, -1]], axis=1))
    assert np.allclose(out.horizontal_m, np.hypot(*(out.end_m - out.truth_m).T))
    chords = np.hypot(np.diff(w.fix_e_m[:, 300:]), np.diff(w.fix_n_m[:, 300:])).sum(axis=1)
    assert out.distance_m == pytest.approx(chords)
    # fixes inside the outage change nothing but the truth at its end
    moved = dataclasses.replace(w, fix_e_m=w.fix_e_m.copy())
    moved.fix_e_m[:, 301:-1] += 500.0
    again = run_outage(moved, 300)
    assert np.array_equal(again.end_m, out.end_m) and np.array_equal(again.cov_m2, out.cov_m2)
    # the covariance is a covariance
    assert np.all(np.linalg.eigvalsh(out.cov_m2) > 0)
    with pytest.raises(ValueError, match="outage_start"):
        run_outage(w, 480)


def test_a_window_without_a_course_before_its_outage_is_not_calibrated():
    per_second, fe, fn = _segment(np.random.default_rng(2))
    w = window_inputs(per_second, fe, fn, np.array([300]), 300, 180)
    blind = dataclasses.replace(w, fix_e_m=np.full_like(w.fix_e_m, np.nan))
    out = run_outage(blind, 300)
    assert not out.calibrated[0] and np.isnan(out.end_m).all()


def test_a_snapshot_handed_over_dead_reckons_as_one_run_through_the_outage():
    """A run over the segment, snapshotted where each outage begins, then each window
    dead-reckoned from its snapshot, ends where one run with the outage's fixes withheld ends."""
    per_second, fe, fn = _segment(np.random.default_rng(3))
    starts = np.array([300, 480, 700])
    # each window calibrated on every second of the segment before it
    direct = [
        run_outage(window_inputs(per_second, fe, fn, np.array([s]), s, 180), s) for s in starts
    ]
    segment = NavInputs(
        **{key: values[None] for key, values in per_second.items()},
        fix_e_m=fe[None],
        fix_n_m=fn[None],
    )
    pass1 = run(segment, snapshots=starts - 1)  # the state at the end of the second before
    # the windows begin with each snapshot as the last calibration second; the other rows
    # of the start are ignored until the outage
    outage = window_inputs(per_second, fe, fn, starts, 0, 180)
    blind = dataclasses.replace(
        outage,
        fix_e_m=np.full_like(outage.fix_e_m, np.nan),
        fix_n_m=np.full_like(outage.fix_n_m, np.nan),
    )
    start = NavStart(pass1.snapshot_x[0], pass1.snapshot_cov[0], np.ones(3, bool))
    handed = run(blind, start=start)
    end = np.concatenate([d.end_m for d in direct])
    cov = np.concatenate([d.cov_m2 for d in direct])
    np.testing.assert_allclose(handed.fix_pred[:, -1], end, rtol=0, atol=1e-6)
    np.testing.assert_allclose(handed.fix_cov[:, -1], cov, rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="snapshots"):
        run(segment, snapshots=np.array([len(per_second["dist_m"])]))
    with pytest.raises(ValueError, match="start"):
        run(blind, start=NavStart(start.x[:2], start.p[:2], start.on[:2]))
