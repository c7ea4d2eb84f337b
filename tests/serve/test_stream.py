"""Streaming seconds: the label stage's grid, whatever the blocks, with outage cumulatives."""

import numpy as np
import pandas as pd
import pytest

from rwhonet.cli.drive import calibration_of, load_drive
from rwhonet.cli.predict import render_summary
from rwhonet.config import load_params
from rwhonet.data.incremental import read_rows
from rwhonet.errors import InputError
from rwhonet.geo.local import offsets_m
from rwhonet.serve.model import ServedMeta, ServedModel, load_served
from rwhonet.serve.stream import COLUMNS, POSITION_COLUMNS, Outage, SecondStream, parse_outage
from support.drives import straight_drive, written_twice
from support.serving import RADIUS_M, SCALER, base_bundle, wavy_drive


def stream_all(model, blocks, outages=()):
    s = SecondStream(model, list(outages), file="t.csv")
    parts = [*(s.push(first, cols) for first, cols in blocks), s.finish()]
    return {k: np.concatenate([p[k] for p in parts]) for k in COLUMNS}, s


def assert_same_seconds(a, b):
    for k in COLUMNS:
        if k != "outage":
            np.testing.assert_array_equal(a[k], b[k])


def blocks_of(df, sizes):
    cols = {
        k: df[k].to_numpy(np.float64)
        for k in (
            "t_s",
            "lat_deg",
            "lon_deg",
            "omega_fl_rad_s",
            "omega_fr_rad_s",
            "omega_rl_rad_s",
            "omega_rr_rad_s",
            "yaw_rate_rad_s",
        )
        if k in df
    }
    out, i = [], 0
    for n in sizes:
        if i >= len(df):
            break
        out.append((i + 1, {k: v[i : i + n] for k, v in cols.items()}))
        i += n
    if i < len(df):
        out.append((i + 1, {k: v[i:] for k, v in cols.items()}))
    return out


def reference_samples(drive_csv, seq_len: int):
    """The drive's samples as the label code makes them (what the stream must reproduce)."""
    return load_drive(
        drive_csv,
        load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of((RADIUS_M, RADIUS_M), "t"),
        scaler=SCALER,
        wpm_mode="integrated",
        seq_len=seq_len,
    ).samples


def test_seconds_match_the_label_stage_and_the_model(bundle, drive_csv):
    model = load_served(bundle["model_onnx"])
    with open(drive_csv, "rb") as f:
        _, blocks = read_rows(f, "V-Wavy.csv", block_bytes=5000)
        out, _ = stream_all(model, list(blocks))
    ref = reference_samples(drive_csv, seq_len=1)
    t_ref = ref.frame["t_s"].to_numpy()
    common, i, j = np.intersect1d(out["t_s"], t_ref, return_indices=True)
    assert len(common) == len(t_ref) == len(out["t_s"]) == 400
    np.testing.assert_allclose(
        out["disp_wpm_m"][i], ref.frame["disp_wpm_m"].to_numpy()[j], atol=1e-9
    )
    np.testing.assert_allclose(
        out["disp_gnss_m"][i], ref.frame["disp_gnss_m"].to_numpy()[j], atol=1e-9
    )
    np.testing.assert_allclose(out["pred_error_m"][i], model.predict(ref.x[j]), atol=1e-6)
    np.testing.assert_allclose(out["disp_corrected_m"], out["disp_wpm_m"] + out["pred_error_m"])


@pytest.fixture(scope="module", params=["tcn", "gru"])
def context_bundle(request, tmp_path_factory):
    """A model with 32 s of context (model.arch tcn or gru)."""
    return base_bundle(tmp_path_factory.mktemp(request.param), arch=request.param, seq_len=32)


def test_a_model_with_context_gets_the_pipelines_windows(context_bundle, drive_csv):
    """Every second predicted, from the windows the label code cuts (padded at the start)."""
    model = load_served(context_bundle["model_onnx"])
    with open(drive_csv, "rb") as f:
        _, blocks = read_rows(f, "V-Wavy.csv", block_bytes=3000)
        out, _ = stream_all(model, list(blocks))
    ref = reference_samples(drive_csv, seq_len=32)
    common, i, j = np.intersect1d(out["t_s"], ref.frame["t_s"].to_numpy(), return_indices=True)
    assert len(common) == len(out["t_s"]) == 400 and np.isfinite(out["pred_error_m"]).all()
    np.testing.assert_allclose(out["pred_error_m"][i], model.predict(ref.x[j]), atol=1e-6)


def test_context_restarts_after_a_gap_and_never_depends_on_blocking(context_bundle):
    model = load_served(context_bundle["model_onnx"])
    df = wavy_drive(60)
    later = wavy_drive(50, seed=1, t0_s=45100.0)
    both = pd.concat([df, later], ignore_index=True)
    whole, _ = stream_all(model, blocks_of(both, [len(both)]))
    parts, _ = stream_all(model, blocks_of(both, [3, 11, 1, 250, 40] * 20))
    assert_same_seconds(whole, parts)
    alone, _ = stream_all(model, blocks_of(later, [len(later)]))
    after = whole["t_s"] > 45100.0
    assert after.sum() == len(alone["t_s"]) == 50  # nothing from before the gap reaches them
    np.testing.assert_allclose(whole["pred_error_m"][after], alone["pred_error_m"], atol=1e-7)


@pytest.mark.parametrize("sizes", [[7] * 1000, [1] * 35 + [10_000], [3, 11, 1, 250, 40] * 100])
def test_any_blocking_gives_the_same_seconds(bundle, sizes):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(120)
    whole, _ = stream_all(model, blocks_of(df, [len(df)]))
    parts, _ = stream_all(model, blocks_of(df, sizes))
    assert len(whole["t_s"]) == 120
    assert_same_seconds(whole, parts)


def test_signed_wheel_speeds_are_read_as_magnitudes(bundle):
    """A logger that signs its speeds (reversing): the seconds are those of the magnitudes."""
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(60)
    signed = df.copy()
    wheels = ["omega_fl_rad_s", "omega_fr_rad_s", "omega_rl_rad_s", "omega_rr_rad_s"]
    signed.loc[200:260, wheels] *= -1.0
    plain, _ = stream_all(model, blocks_of(df, [len(df)]))
    read, _ = stream_all(model, blocks_of(signed, [len(signed)]))
    assert_same_seconds(plain, read)


def test_a_gap_ends_a_run_and_the_next_starts_on_a_whole_second(bundle):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(60)
    later = wavy_drive(30, t0_s=45100.05)  # starts off the whole second, after a 40 s gap
    both = pd.concat([df, later], ignore_index=True)
    out, _ = stream_all(model, blocks_of(both, [333] * 10))
    t = out["t_s"]
    assert t[0] == 45001.0 and t[59] == 45060.0
    # after the gap: first whole second 45101, first full second ends 45102 (row 45101.95 + 10)
    assert t[60] == pytest.approx(45102.0, abs=0.06) and len(t) == 60 + 29


def test_outage_cumulatives_give_the_papers_crse_and_cte(bundle):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    out, stream = stream_all(model, blocks_of(df, [500] * 5), [Outage(20, 80), Outage(100, 190)])
    inside = out["outage"] == "20:80"
    assert inside.sum() == 60 and (out["outage"] == "100:190").sum() == 90
    e_corr = out["disp_corrected_m"][inside] - out["disp_gnss_m"][inside]
    np.testing.assert_allclose(out["err_corrected_m"][inside], np.cumsum(e_corr), atol=1e-9)
    np.testing.assert_allclose(out["crse_corrected_m"][inside][-1], np.abs(e_corr).sum())
    np.testing.assert_allclose(out["dist_wpm_m"][inside][-1], out["disp_wpm_m"][inside].sum())
    assert np.isnan(out["dist_wpm_m"][~(inside | (out["outage"] == "100:190"))]).all()
    first = stream.summary()[0]
    assert first["cte_corrected_m"] == pytest.approx(abs(np.sum(e_corr)))
    assert first["crse_wpm_m"] >= first["cte_wpm_m"]


def test_a_second_without_a_fix_has_no_gnss_and_the_outage_no_error(bundle):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(60)
    df.loc[300:400, ["lat_deg", "lon_deg"]] = np.nan  # GNSS lost for ten seconds
    out, stream = stream_all(model, blocks_of(df, [len(df)]), [Outage(25, 45)])
    assert np.isnan(out["disp_gnss_m"][29:41]).all() and np.isfinite(out["disp_gnss_m"][:29]).all()
    assert np.isfinite(out["disp_corrected_m"]).all()
    inside = out["outage"] == "25:45"
    assert np.isfinite(out["dist_corrected_m"][inside]).all()
    assert np.isnan(out["err_corrected_m"][inside][-1]) and np.isnan(
        stream.summary()[0]["cte_wpm_m"]
    )


@pytest.mark.parametrize("text", ["300", "a:b", "5:5", "-1:10", "10:inf"])
def test_bad_outages_are_refused(text):
    with pytest.raises(InputError, match="--outage"):
        parse_outage(text)
    assert parse_outage("300:480") == Outage(300.0, 480.0)


def test_missing_time_and_time_going_back_are_named(bundle):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(30)
    df.loc[55, "t_s"] = np.nan
    with pytest.raises(InputError, match="row 56.*found an empty cell"):
        stream_all(model, blocks_of(df, [len(df)]))
    df = wavy_drive(30)
    df.loc[120, "t_s"] = df.loc[118, "t_s"]
    with pytest.raises(InputError, match="row 121.*a time after") as err:
        stream_all(model, blocks_of(df, [100] * 5))
    back, prev = float(df.loc[118, "t_s"]), float(df.loc[119, "t_s"])
    assert f"time goes backwards: t = {back!r} s after t = {prev!r} s" in str(err.value)
    assert "sort the rows by time" in str(err.value)  # not numpy's repr above


# the copies inside a block, at a block's first row, and a block of copies only
@pytest.mark.parametrize("sizes", [[3001], [100] * 31, [200, 1, 1, 2000]])
def test_rows_written_twice_are_dropped_as_ingest_drops_them(bundle, sizes):
    """A row that repeats the row before in every channel streams as the drive written
    once (ingest drops it too: rwhonet.data.droprows), and the stream lists it."""
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(30)
    twice = written_twice(df, 200, 201)  # data row 200 three times: rows 201, 202 copies
    once, _ = stream_all(model, blocks_of(df, [3000]))
    out, stream = stream_all(model, blocks_of(twice, sizes))
    assert_same_seconds(out, once)
    assert stream.dropped.dropped == [201, 202] and stream.dropped.wheelless == []
    (note,) = stream.dropped.notes("t.csv")
    assert "2 data row(s) repeat an earlier row" in note


@pytest.mark.parametrize("sizes", [[3001], [100] * 31, [7] * 500])
def test_after_a_dropped_copy_messages_name_the_file_s_rows(bundle, sizes):
    """A missing time after copies is named by its row in the file, not by its rank
    among the rows kept."""
    model = load_served(bundle["model_onnx"])
    df = written_twice(wavy_drive(30), 100, 150)
    df.loc[249, "t_s"] = np.nan  # data row 250 of the file
    with pytest.raises(InputError) as err:
        stream_all(model, blocks_of(df, sizes))
    assert [p.row for p in err.value.problems] == [250]


@pytest.mark.parametrize("sizes", [[100000], [200, 1000]])
def test_a_row_at_the_time_of_the_row_before_with_other_values_is_not_a_copy(bundle, sizes):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(30)
    df.loc[200, "t_s"] = df.loc[199, "t_s"]  # data row 201 at row 200's time, its own values
    with pytest.raises(InputError, match="row 201") as err:
        stream_all(model, blocks_of(df, sizes))
    t = float(df.loc[199, "t_s"])
    assert f"t = {t!r} s again (as in row 200)" in str(err.value)
    assert "every value the same" not in str(err.value)
    assert "delete one of the two rows" in str(err.value)


def _straight(duration_s=300.0, yaw=True):
    """Straight on at 15 m/s, azimuth 30 deg, exact fixes and wheels (the base model's radius)."""
    df = straight_drive(duration_s, 15.0, RADIUS_M)
    if yaw:  # a gyro reading the straight road's zero turn, with an ESC sensor's noise per row
        df["yaw_rate_rad_s"] = np.random.default_rng(0).normal(0.0, 6e-4, len(df))
    return df


@pytest.mark.parametrize("sizes", [[100000], [333] * 20])
def test_the_outage_s_position_and_covariance_from_the_last_fix_before_it(bundle, sizes):
    model = load_served(bundle["model_onnx"])
    df = _straight()
    out, stream = stream_all(model, blocks_of(df, sizes), [Outage(100, 220)])
    inside = out["outage"] == "100:220"
    assert inside.sum() == 120
    for col in POSITION_COLUMNS:
        assert np.isfinite(out[col][inside]).all() and np.isnan(out[col][~inside]).all(), col
    # the truth: the GNSS fix ending each outage second, from the fix before the outage
    t = df["t_s"].to_numpy()
    ends = np.searchsorted(t, out["t_s"][inside])
    before = ends[0] - 10
    e, n = offsets_m(
        df["lat_deg"][before], df["lon_deg"][before], df["lat_deg"][ends], df["lon_deg"][ends]
    )
    assert e[-1] == pytest.approx(900.0, abs=0.5) and n[-1] == pytest.approx(1558.8, abs=0.5)
    err = np.hypot(out["east_m"][inside] - e, out["north_m"][inside] - n)
    np.testing.assert_allclose(out["pos_err_m"][inside], err, atol=0.01)
    # the same positions as latitude / longitude: back to east / north of the same fix
    back_e, back_n = offsets_m(
        df["lat_deg"][before], df["lon_deg"][before], out["lat_deg"][inside], out["lon_deg"][inside]
    )
    np.testing.assert_allclose(back_e, out["east_m"][inside], atol=1e-6)
    np.testing.assert_allclose(back_n, out["north_m"][inside], atol=1e-6)
    # the model's distances are off (a random network): learnt from GNSS before the outage
    assert err[-1] < 5.0, err[-1]
    cov = np.stack(
        [
            np.stack([out["cov_ee_m2"][inside], out["cov_en_m2"][inside]], -1),
            np.stack([out["cov_en_m2"][inside], out["cov_nn_m2"][inside]], -1),
        ],
        -2,
    )
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert np.trace(cov[-1]) > np.trace(cov[0])  # dead reckoning: the uncertainty grows
    summary = stream.summary()[0]
    assert summary["control"] == "fused"
    assert summary["pos_err_end_m"] == pytest.approx(out["pos_err_m"][inside][-1])
    assert summary["east_end_m"] == pytest.approx(out["east_m"][inside][-1])
    assert summary["lat_end_deg"] == out["lat_deg"][inside][-1]
    assert summary["lon_end_deg"] == out["lon_deg"][inside][-1]
    assert summary["pos_sd_end_m"] == pytest.approx(np.sqrt(np.linalg.eigvalsh(cov[-1])[-1]))
    # an uncalibrated model's regions: the filter's own normal (68.27 %: d² <= 2.296)
    assert summary["calibrated"] is False
    major = np.sqrt(np.linalg.eigvalsh(cov)[:, -1])
    np.testing.assert_allclose(out["r68_m"][inside], major * np.sqrt(2.2957), rtol=1e-3)
    np.testing.assert_allclose(out["r95_m"][inside], major * np.sqrt(6.1801), rtol=1e-3)
    assert summary["r95_end_m"] == pytest.approx(out["r95_m"][inside][-1])


def test_a_model_carrying_the_evaluation_s_calibration_sizes_its_regions_by_it(bundle):
    model = load_served(bundle["model_onnx"])
    nav = {"receiver_sigma_m": 3.0, "receiver_tau_s": 100.0}
    nav["calibration"] = {"scales": {"30": 4.0, "120": 4.0}, "dof": None}  # twice as wide
    calibrated = ServedModel(
        bundle["model_onnx"], ServedMeta(**{**model.meta.__dict__, "navigation": nav})
    )
    df = _straight()
    plain, _ = stream_all(model, blocks_of(df, [100000]), [Outage(100, 160)])
    out, stream = stream_all(calibrated, blocks_of(df, [100000]), [Outage(100, 160)])
    assert stream.nav.gnss.sigma_m == 3.0 and stream.summary()[0]["calibrated"] is True
    inside = out["outage"] == "100:160"
    cov = np.stack(
        [
            np.stack([out["cov_ee_m2"][inside], out["cov_en_m2"][inside]], -1),
            np.stack([out["cov_en_m2"][inside], out["cov_nn_m2"][inside]], -1),
        ],
        -2,
    )
    major = np.sqrt(np.linalg.eigvalsh(cov)[:, -1])  # c = 4 at every length: twice as wide
    np.testing.assert_allclose(out["r68_m"][inside], 2.0 * major * np.sqrt(2.2957), rtol=1e-3)
    # the same car, a filter that trusts the fixes less: another covariance, same columns
    assert not np.allclose(out["cov_ee_m2"][inside], plain["cov_ee_m2"][inside])


def test_without_a_yaw_rate_the_wheels_alone_steer_and_a_missing_end_fix_has_no_error(bundle):
    model = load_served(bundle["model_onnx"])
    df = _straight(260.0, yaw=False)
    df.loc[2480:2510, ["lat_deg", "lon_deg"]] = np.nan  # no GNSS at the outage's end (250 s)
    out, stream = stream_all(model, blocks_of(df, [700] * 5), [Outage(100, 250)])
    inside = out["outage"] == "100:250"
    summary = stream.summary()[0]
    assert summary["control"] == "wheels" and np.isnan(summary["pos_err_end_m"])
    assert np.isfinite(out["east_m"][inside]).all() and np.isnan(out["pos_err_m"][inside][-1])
    # straight ahead on exact wheels: where the car is, without a gyro
    assert abs(summary["east_end_m"] - 150 * 15.0 * 0.5) < 25.0


def test_a_jittered_drive_across_midnight_streams_as_the_clean_one(bundle, tmp_path):
    """``predict`` reads the clock as ingest and label do: midnight continues, jitter goes."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    clean = wavy_drive(120, t0_s=86340.0)  # crosses midnight 60 s in (continuous clock)
    t = clean["t_s"].to_numpy()
    logged = clean.copy()
    jitter = np.random.default_rng(1).uniform(-0.004, 0.004, t.size)
    logged["t_s"] = np.round((t + jitter) % 86400.0, 4)  # seconds of the day, as IO-VNBD
    assert (np.diff(logged["t_s"]) < 0).sum() == 1
    want, _ = stream_all(model, blocks_of(clean, [len(clean)]))
    path = write_iovnbd(logged, tmp_path / "V-Midnight.csv")
    with open(path, "rb") as f:
        _, blocks = read_rows(f, "V-Midnight.csv", block_bytes=3000)
        got, _ = stream_all(model, list(blocks))
    assert len(got["t_s"]) == len(want["t_s"]) == 120
    for k in ("t_s", "disp_wpm_m", "disp_gnss_m", "pred_error_m"):
        np.testing.assert_allclose(got[k], want[k], rtol=0, atol=1e-6)


@pytest.mark.parametrize("first_row", [0, 1500])
@pytest.mark.parametrize("block_bytes", [3000, 150])
def test_a_drive_jittered_past_half_a_period_streams_as_the_clean_one(
    bundle, tmp_path, block_bytes, first_row
):
    """A bell curve's jitter of 20 ms: stamps going back, rows nearest another's slot;
    predict places each row in its own slot, whatever the blocks (150 bytes: a row or two
    at a time, the rows later ones could move held back), across midnight too; and where
    the jitter starts half way (a logger that gets busy), after the first rows, on which
    predict's clock takes its grid, are on their instants."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    clean = wavy_drive(300, t0_s=86340.0)
    t = clean["t_s"].to_numpy()
    logged = clean.copy()
    jitter = np.random.default_rng(2).normal(0.0, 0.02, t.size)
    jitter[:first_row] = 0.0
    stamps = np.round(t + jitter, 3)
    assert (np.diff(stamps) < 0).sum() > 0 and (np.diff(np.rint(stamps / 0.1)) <= 0).sum() > 3
    logged["t_s"] = np.round(stamps % 86400.0, 3)
    want, _ = stream_all(model, blocks_of(clean, [len(clean)]))
    path = write_iovnbd(logged, tmp_path / "V-Bell.csv")
    with open(path, "rb") as f:
        _, blocks = read_rows(f, "V-Bell.csv", block_bytes=block_bytes)
        got, _ = stream_all(model, list(blocks))
    assert len(got["t_s"]) == len(want["t_s"]) == 300
    for k in ("t_s", "disp_wpm_m", "disp_gnss_m", "pred_error_m"):
        np.testing.assert_allclose(got[k], want[k], rtol=0, atol=1e-6)


def _streams_as_labelled(model, path, block_bytes: int = 3000) -> np.ndarray:
    """``predict``'s seconds of a drive file, read in blocks, checked to be the label
    code's second for second (times, displacements, predictions); the label's times."""
    ref = reference_samples(path, seq_len=1)
    with open(path, "rb") as f:
        _, blocks = read_rows(f, path.name, block_bytes=block_bytes)
        out, _ = stream_all(model, list(blocks))
    t_ref = ref.frame["t_s"].to_numpy()
    np.testing.assert_allclose(out["t_s"], t_ref, rtol=0, atol=1e-6)
    for k in ("disp_wpm_m", "disp_gnss_m"):
        np.testing.assert_allclose(out[k], ref.frame[k].to_numpy(), rtol=0, atol=1e-6)
    np.testing.assert_allclose(out["pred_error_m"], model.predict(ref.x), atol=1e-6)
    return t_ref


@pytest.mark.parametrize(("offset_s", "jitter_s"), [(0.03, 0.0), (0.05, 0.0), (0.048, 0.003)])
@pytest.mark.parametrize("block_bytes", [3000, 150])
def test_a_logger_restarted_on_another_phase_streams_as_the_label_stage_labels_it(
    bundle, tmp_path, block_bytes, offset_s, jitter_s
):
    """A logger that stopped for 1.3 s and started again with its stamps on another phase
    of the 0.1 s grid (30 ms, 50 ms, 48 ms jittered by 3 ms): each run on its own phase,
    the stream's seconds are the label code's, second for second. Before, predict placed
    the second run on the first run's phase (the rows moved by 30 ms, or two in a slot
    and refused), and validate counted seconds on a phase between the two runs'."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    t = df["t_s"].to_numpy()
    later = t >= t[0] + 100.0
    jitter = np.random.default_rng(4).uniform(-jitter_s, jitter_s, later.sum())
    df.loc[later, "t_s"] = np.round(t[later] + 1.3 + offset_s + jitter, 3)
    path = write_iovnbd(df, tmp_path / "V-Restarted.csv")
    t_ref = _streams_as_labelled(model, path, block_bytes)
    # the second run's seconds end on its own phase (its last row in the second)
    assert len(t_ref) >= 195 and (np.round(t_ref % 1.0, 3) == round(0.9 + offset_s, 3)).sum() >= 95


@pytest.mark.parametrize(("sigma_s", "seed"), [(0.01, 15), (0.02, 28)])
def test_a_restarted_logger_s_bell_curve_jitter_streams_as_the_label_stage_labels_it(
    bundle, tmp_path, sigma_s, seed
):
    """A logger restarted 1.348 s later on another phase, its stamps jittered by a bell
    curve of 10 or 20 ms: predict's seconds are the label code's to the µs, their times
    too. Before, the label took the second run's phase from all its rows, predict from its
    first 200: the seconds' times 3.9 and 3.2 ms apart (the displacements alike)."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    t = df["t_s"].to_numpy()
    later = t >= t[0] + 100.0
    jitter = np.random.default_rng(seed).normal(0.0, sigma_s, t.size)
    df["t_s"] = np.round(t + jitter + np.where(later, 1.348, 0.0), 3)
    t_ref = _streams_as_labelled(model, write_iovnbd(df, tmp_path / "V-Busy.csv"))
    assert len(t_ref) >= 195


@pytest.mark.parametrize(
    ("back_s", "jitter_s"), [(0.23, 0.0), (3.0, 0.003), (3600.0, 0.0), (0.5, 0.02)]
)
def test_a_clock_set_back_during_the_drive_streams_as_the_label_stage_labels_it(
    bundle, tmp_path, back_s, jitter_s
):
    """The logger's clock set back by NTP (0.23 s; 3 s, its stamps jittered by 3 ms; 0.5 s
    jittered by a bell curve of 20 ms) or
    by summer time ending (an hour) while the car drove on, in a file: predict's seconds
    are the label code's, second for second, the seconds around the step cut. Before,
    both refused the drive ("time goes backwards")."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    t = df["t_s"].to_numpy()
    later = t >= t[0] + 100.0
    jitter = np.random.default_rng(5).normal(0.0, jitter_s, t.size) if jitter_s else 0.0
    df["t_s"] = np.round(t - np.where(later, back_s, 0.0) + jitter, 3)
    t_ref = _streams_as_labelled(model, write_iovnbd(df, tmp_path / "V-SetBack.csv"))
    assert 196 <= len(t_ref) <= 199  # of 200: the seconds around the step cut


@pytest.mark.parametrize("block_bytes", [3000, 150])
def test_rows_late_before_a_restart_stream_as_the_label_stage_labels_them(
    bundle, tmp_path, block_bytes
):
    """The two rows before a logger's restart 80 and 25 ms late, among stamps jittered by
    10 ms: predict gives them the whole drive's slots, as the label code now does, second
    for second (the label code once placed the segment alone: its last second 1.7 m off)."""
    from support.corpus import late_rows_before_a_restart
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    path = write_iovnbd(late_rows_before_a_restart(), tmp_path / "V-Late.csv")
    t_ref = _streams_as_labelled(model, path, block_bytes)
    assert len(t_ref) >= 140 and 45047.0 in np.round(t_ref, 6)


@pytest.mark.parametrize("phase_s", [0.0, -0.052])
@pytest.mark.parametrize("block_bytes", [3000, 150])
def test_rows_leaning_into_lost_samples_stream_as_the_label_stage_labels_them(
    bundle, tmp_path, block_bytes, phase_s
):
    """Four rows beside a lost sample stamped 60 ms toward it, each placed in the slot
    beside its own at a second's edge: predict cuts the seconds that would start or end on
    them, as the label code does (which once labelled each a row's travel off), second for
    second, whatever the blocks; and so on a logger whose grid is 48 ms after whole tenths,
    the rows 52 ms earlier (the seconds' edges then on its x.948 s rows)."""
    from support.corpus import rows_leaning_into_lost_samples
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = rows_leaning_into_lost_samples()
    df["t_s"] = np.round(df["t_s"] + phase_s, 3)
    path = write_iovnbd(df, tmp_path / "V-Leaning.csv")
    t_ref = np.round(_streams_as_labelled(model, path, block_bytes) - phase_s, 6)
    assert len(t_ref) == 193
    assert not np.isin([45001.0, 45050.0, 45051.0, 45101.0, 45151.0], np.round(t_ref, 2)).any()


def test_a_logger_s_hiccups_stream_on_whole_seconds_as_the_label_stage_labels_them(
    bundle, tmp_path
):
    """Three rows in the first 20 s written 40-45 ms late among stamps within 2 ms of
    their grid: predict's clock takes the grid's phase (not 21.5 ms after it), and its
    seconds, on whole seconds, are the label code's."""
    from support.corpus import hiccups_on_a_clean_logger
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    path = write_iovnbd(hiccups_on_a_clean_logger(), tmp_path / "V-Hiccups.csv")
    t_ref = _streams_as_labelled(model, path)
    assert len(t_ref) == 150 and np.array_equal(np.round(t_ref, 6), np.round(t_ref))


@pytest.mark.parametrize("block_bytes", [3000, 150])
def test_rows_written_at_once_after_stalls_stream_as_the_label_stage_labels_them(
    bundle, tmp_path, block_bytes
):
    """The 2-4 rows a logger held through a stall, written at once: predict's clock gives
    each the slot its stall left, as the label code does, second for second, whatever the
    blocks (refused by both before)."""
    from support.corpus import rows_written_at_once_after_stalls
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    path = write_iovnbd(rows_written_at_once_after_stalls(), tmp_path / "V-Stalls.csv")
    t_ref = _streams_as_labelled(model, path, block_bytes)
    assert len(t_ref) == 150 and np.array_equal(np.round(t_ref, 6), np.round(t_ref))


@pytest.mark.parametrize("lean_s", [0.03, 0.02])
def test_a_last_second_ending_on_a_late_stamp_is_streamed_when_the_drive_ends(
    bundle, tmp_path, lean_s
):
    """The drive's last row, a whole second's end fix, stamped 30 ms late: predict holds
    its second until it knows no sample was lost after it, and gives it when the drive
    ends, as the label code labels it (20 ms: not held)."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(60)
    t = df["t_s"].to_numpy().copy()
    t += np.random.default_rng(6).normal(0.0, 0.01, t.size)
    t[-2:] = df["t_s"].to_numpy()[-2:]
    t[-1] += lean_s
    df["t_s"] = np.round(t, 3)
    t_ref = _streams_as_labelled(model, write_iovnbd(df, tmp_path / "V-LateEnd.csv"))
    assert round(t_ref[-1], 6) == round(df["t_s"].iloc[-1] - lean_s, 6)


@pytest.mark.parametrize("lost", [None, 1203])
def test_a_file_stamped_to_the_second_streams_as_the_label_stage_labels_it(bundle, tmp_path, lost):
    """Each row's time cut to the second (hh:mm:ss without its fraction, a spreadsheet's):
    predict from a file gives the label code's seconds, second for second, each second
    the ten rows of its stamp (a lost row's second cut). Before, both refused it."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    if lost is not None:
        df = df.drop(index=lost).reset_index(drop=True)
    df["t_s"] = np.floor(df["t_s"].to_numpy() - 0.1 + 1e-6)
    t_ref = _streams_as_labelled(model, write_iovnbd(df, tmp_path / "V-Whole.csv"))
    assert len(t_ref) >= (198 if lost else 199)


@pytest.mark.parametrize("sizes", [[100_000], [7] * 1000, [405, 1] + [10] * 100])
def test_a_one_row_wheel_glitch_is_repaired_and_listed_whatever_the_blocking(bundle, sizes):
    # A CAN glitch (one rear wheel at ten times its speed for one row) must not move the
    # WPM or the prediction of its second: the stream repairs it from the wheel's own
    # neighbours and lists the row. Row 406 is the last row of a second (a fix row shared
    # by two seconds) and, with the third blocking, the first row of a block.
    model = load_served(bundle["model_onnx"])
    clean = wavy_drive(120)
    glitched = clean.copy()
    glitched.loc[405, "omega_rl_rad_s"] *= 10.0
    plain, _ = stream_all(model, blocks_of(clean, [len(clean)]))
    out, s = stream_all(model, blocks_of(glitched, sizes))
    assert [(g["row"], g["channel"]) for g in s.glitches] == [(406, "omega_rl_rad_s")]
    # the neighbours' interpolation, not the clean value: within the wheel noise of a row
    for k in ("disp_wpm_m", "pred_error_m", "disp_corrected_m"):
        np.testing.assert_allclose(out[k], plain[k], atol=0.01)
    np.testing.assert_array_equal(out["disp_gnss_m"], plain["disp_gnss_m"])


@pytest.mark.parametrize("sizes", [[100_000], [7] * 1000, [10] * 200])
def test_a_yaw_rate_s_invalid_code_is_repaired_and_listed_whatever_the_blocking(bundle, sizes):
    # One row of 327.67 deg/s (an int16 at full scale) inside an outage moved the track's
    # end by 389 m; repaired from the rate's neighbours it moves it by millimetres. With
    # blocks of one second the second's own rows hold one glitch in ten, more than the
    # label's share (1 %): the stream's running count repairs it all the same.
    from support.corpus import weaving_target

    model = load_served(bundle["model_onnx"])
    clean = weaving_target()
    spiked = clean.copy()
    spiked.loc[704, "yaw_rate_rad_s"] = np.radians(327.67)
    outage = [parse_outage("60:140")]
    plain, _ = stream_all(model, blocks_of(clean, [len(clean)]), outage)
    out, s = stream_all(model, blocks_of(spiked, sizes), outage)
    assert [(g["row"], g["channel"], g.get("yaw")) for g in s.glitches] == [
        (705, "yaw_rate_rad_s", True)
    ]
    assert s.glitches[0]["found_rad_s"] == pytest.approx(np.radians(327.67))
    moved = np.hypot(out["east_m"] - plain["east_m"], out["north_m"] - plain["north_m"])
    assert np.isfinite(moved).sum() == 80 and np.nanmax(moved) < 0.05


def test_a_clean_drive_has_nothing_repaired(bundle):
    model = load_served(bundle["model_onnx"])
    out, s = stream_all(model, blocks_of(wavy_drive(120), [333] * 5))
    assert s.glitches == [] and len(out["t_s"]) == 120


def test_rows_the_resampler_flagged_are_repaired_though_the_10_hz_screen_passes_them(bundle):
    # A stream drive's grid row whose mean used a glitched sample can rise too little for
    # the 10 Hz screen (one 100 Hz sample of ten); the resampler's flag alone repairs it.
    from rwhonet.data import canonical as c
    from rwhonet.data.canonical import GLITCH_FLAG

    model = load_served(bundle["model_onnx"])
    clean = wavy_drive(120)
    glitched = clean.copy()
    glitched.loc[405, c.OMEGA_RL] *= 1.2  # what a x3 sample does to its row's mean
    flag = np.zeros(len(clean), dtype=bool)
    flag[405] = True
    plain, _ = stream_all(model, blocks_of(clean, [len(clean)]))
    unflagged, s0 = stream_all(model, blocks_of(glitched, [len(clean)]))
    assert s0.glitches == []  # the 10 Hz screen alone lets it through
    blocks = []
    for first, cols in blocks_of(glitched, [100, 305, 1, 1000]):
        n = len(cols[c.T_S])
        rows = flag[first - 1 : first - 1 + n]
        blocks.append(
            (first, {**cols, **{GLITCH_FLAG + w: rows & (w == c.OMEGA_RL) for w in c.WHEELS}})
        )
    out, s = stream_all(model, blocks)
    assert [(g["row"], g["channel"]) for g in s.glitches] == [(406, c.OMEGA_RL)]
    k = np.argmax(np.abs(unflagged["disp_wpm_m"] - plain["disp_wpm_m"]))
    assert abs(unflagged["disp_wpm_m"][k] - plain["disp_wpm_m"][k]) > 0.05  # it moved the WPM
    for q in ("disp_wpm_m", "pred_error_m", "disp_corrected_m"):
        np.testing.assert_allclose(out[q], plain[q], atol=0.01)


def _straight_reverse(signed: bool) -> pd.DataFrame:
    """Straight on at 15 m/s (azimuth 30 deg), then at 150 s a stop, 15 s straight back at
    2 m/s (about 30 m), a stop and on again; exact fixes, a gyro reading the straight road's
    zero turn; wheel speeds signed (a logger that signs them) or as magnitudes."""
    from geographiclib.geodesic import Geodesic

    from rwhonet.data import canonical as c

    t = np.round(45000.0 + 0.1 * np.arange(3001), 6)
    knots = [(0, 15), (150, 15), (155, 0), (157, 0), (158, -2), (172, -2), (173, 0), (175, 0)]
    knots += [(180, 15), (300, 15)]
    v = np.interp(t - t[0], *zip(*knots, strict=True))
    s = np.r_[0.0, np.cumsum(0.5 * (v[1:] + v[:-1]) * 0.1)]
    geo = [Geodesic.WGS84.Direct(52.4, -1.5, 30.0, d) for d in s]
    omega = (v if signed else np.abs(v)) / RADIUS_M
    return pd.DataFrame(
        {
            c.T_S: t,
            c.LAT_DEG: [g["lat2"] for g in geo],
            c.LON_DEG: [g["lon2"] for g in geo],
            **{w: omega for w in c.WHEELS},
            c.N_SATS: np.full(t.size, 9.0),
            c.YAW_RATE_RAD_S: np.random.default_rng(0).normal(0.0, 6e-4, t.size),
        }
    )


def test_a_straight_reverse_is_driven_backwards_when_the_logger_signs_its_wheel_speeds(bundle):
    """No turn tells a straight reverse; a logger that signs its wheel speeds does."""
    model = load_served(bundle["model_onnx"])
    ends, told = {}, {}
    for signed in (False, True):
        out, stream = stream_all(
            model, blocks_of(_straight_reverse(signed), [700] * 5), [Outage(100, 220)]
        )
        ends[signed] = stream.summary()[0]["pos_err_end_m"]
        told[signed] = stream.backwards_s
    # the seconds whose rear wheels' net angle is backwards: 157.5 ... 172.5 s in, by hand
    assert told[False] == [] and told[True] == list(range(158, 174)), told
    line = render_summary(
        {"file": "f.csv", "rows": 3001, "seconds": 300, "outages": [], "backwards_s": told[True]}
    )
    assert "backwards in 16 s (the seconds ending 158 ... 173 s into the drive)" in line, line
    # magnitudes: the 30 m back counted forwards, about 60 m off at the end
    assert ends[False] > 45.0 and ends[True] < 5.0, ends


def test_the_summary_says_wheels_where_the_yaw_column_has_no_value(bundle):
    """A yaw-rate column that is empty (a resampled gyro that never overlapped) is no gyro:
    the outage is said to be steered by the wheels alone; a gyro gap inside an outage is
    said too, with the seconds it lasted."""
    model = load_served(bundle["model_onnx"])
    empty = _straight(260.0)
    empty["yaw_rate_rad_s"] = np.nan
    _, stream = stream_all(model, blocks_of(empty, [700] * 5), [Outage(100, 250)])
    (summary,) = stream.summary()
    assert stream.control == "wheels" and summary["control"] == "wheels"
    assert summary["gyro_s"] == 0
    gap = _straight(260.0)
    gap.loc[1500:1800, "yaw_rate_rad_s"] = (
        np.nan
    )  # rows 150-180 s: the 32 seconds ending 150 ... 181 s use one
    _, stream = stream_all(model, blocks_of(gap, [700] * 5), [Outage(100, 250)])
    (summary,) = stream.summary()
    assert stream.control == "fused" and summary["control"] == "fused"
    assert summary["seconds"] == 150 and summary["gyro_s"] == 150 - 32
    line = render_summary(
        {"file": "f.csv", "rows": 2601, "seconds": 260, "outages": stream.summary()}
    )
    assert "yaw: gyro + wheels, wheels alone in 32 s without one)" in line, line


def _with_gap(df: pd.DataFrame, start_s: float, length_s: float) -> pd.DataFrame:
    """``df`` without its rows from ``start_s`` (s after its first row) for ``length_s``."""
    el = df["t_s"] - df["t_s"].iloc[0]
    return df[~((el > start_s) & (el < start_s + length_s))].reset_index(drop=True)


@pytest.mark.parametrize("yaw", [True, False])
@pytest.mark.parametrize("sizes", [[100_000], [333] * 20, [7] * 5000])
def test_a_logger_gap_inside_an_outage_is_bridged_not_the_end_of_the_position(bundle, yaw, sizes):
    """A 2 s logger gap 60 s into an outage: the filter went back to waiting for a GNSS
    course, so the outage's remaining 58 s had no position; now it goes on across."""
    model = load_served(bundle["model_onnx"])
    df = _straight(300.0, yaw=yaw)
    gapped = _with_gap(df, 160.05, 2.0)
    plain, _ = stream_all(model, blocks_of(df, [100_000]), [Outage(100, 220)])
    out, stream = stream_all(model, blocks_of(gapped, sizes), [Outage(100, 220)])
    inside = out["outage"] == "100:220"
    assert inside.sum() == 120 - 3  # the seconds the gap cut give no row
    for col in POSITION_COLUMNS:
        assert np.isfinite(out[col][inside]).all(), col
    assert stream.gaps == [
        {
            "from_s": pytest.approx(160.0),
            "gap_s": pytest.approx(2.1),
            "dropped": False,
            "bridged": True,
            "filtering": True,
        }
    ]
    # straight on at a steady speed: where the gapless drive's filter puts the car
    end = stream.summary()[0]
    ref = plain["outage"] == "100:220"
    assert end["east_end_m"] == pytest.approx(plain["east_m"][ref][-1], abs=0.5)
    assert end["north_end_m"] == pytest.approx(plain["north_m"][ref][-1], abs=0.5)
    assert end["pos_err_end_m"] < 5.0
    text = render_summary(
        {"file": "t.csv", "rows": 1, "seconds": 1, "outages": [end]}
        | {"gaps": stream.gaps, "max_gap_s": 0.5}
    )
    assert "logger gap: 1 time step(s) longer than 0.5 s" in text
    assert "2.1 s after 160 s (the position carried across)" in text


def test_a_bridge_widens_the_region_by_how_fast_the_drive_turned(bundle):
    """The same gap on a weaving drive: the line across it may miss the turn, so the
    region after it is wider than the gapless drive's, and still holds the fix."""
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(300)
    gapped = _with_gap(df, 160.05, 2.0)
    plain, _ = stream_all(model, blocks_of(df, [100_000]), [Outage(100, 200)])
    out, stream = stream_all(model, blocks_of(gapped, [100_000]), [Outage(100, 200)])
    assert stream.gaps[0]["bridged"]
    a, b = plain["outage"] == "100:200", out["outage"] == "100:200"
    assert out["r95_m"][b][-1] > plain["r95_m"][a][-1]
    assert out["pos_err_m"][b][-1] < out["r95_m"][b][-1]


def test_a_gap_longer_than_the_bridge_starts_the_filter_afresh(bundle):
    from rwhonet.serve.stream import BRIDGE_MAX_S

    model = load_served(bundle["model_onnx"])
    gapped = _with_gap(_straight(300.0), 160.05, BRIDGE_MAX_S + 2.0)
    out, stream = stream_all(model, blocks_of(gapped, [100_000]), [Outage(100, 220)])
    inside = out["outage"] == "100:220"
    after = inside & (out["elapsed_s"] > 160.0)
    assert (
        np.isfinite(out["east_m"][inside & ~after]).all() and np.isnan(out["east_m"][after]).all()
    )
    assert [g["bridged"] for g in stream.gaps] == [False] and stream.gaps[0]["filtering"]
    text = render_summary(
        {"file": "t.csv", "rows": 1, "seconds": 1, "outages": []}
        | {"gaps": stream.gaps, "max_gap_s": 0.5}
    )
    assert "(the position filter started afresh)" in text and "waits for the next course" in text


def _without_rows(df: pd.DataFrame, at_s: list[float]) -> pd.DataFrame:
    """``df`` without its rows ``at_s`` (s after its first row): samples a logger dropped."""
    el = np.round(df["t_s"].to_numpy() - df["t_s"].iloc[0], 6)
    return df[~np.isin(el, at_s)].reset_index(drop=True)


# Samples dropped 40.3 s in (inside a second), 80.1 s (the first slot of second 81: the
# second before it is whole), 120.0 s (the last slot of second 120: the second after it
# is whole, its start fix the row before the drop) and 160.3-160.4 s (two in a row);
# every piece between them at least validate's min_segment_s (30 s) long, so the label
# stage keeps every second the stream can cut.
DROPPED_S = [40.3, 80.1, 120.0, 160.3, 160.4]


@pytest.mark.parametrize("sizes", [[100_000], [7] * 3000, [401, 1, 399, 2] * 10])
def test_dropped_samples_cut_their_seconds_as_the_label_stage_does(bundle, tmp_path, sizes):
    """A dropped sample shifted every later second of a run by 0.1 s (ten rows cut a
    second, whatever their times): the seconds ended 0.1 s after whole seconds until the
    next gap, and validate refused the drive. Now the stream cuts the second that lost a
    row and starts again on the next whole second, where the label stage does."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = _without_rows(wavy_drive(200), DROPPED_S)
    assert len(df) == 2001 - len(DROPPED_S)
    path = write_iovnbd(df, tmp_path / "V-Dropped.csv")
    ref = reference_samples(path, seq_len=1)
    out, stream = stream_all(model, blocks_of(df, sizes))
    t_ref = ref.frame["t_s"].to_numpy()
    # every second ends on a whole second; the four cut ones are missing
    assert np.array_equal(out["t_s"], t_ref) and np.all(t_ref == np.round(t_ref))
    el = out["t_s"] - 45000.0
    assert len(el) == 200 - 4 and not np.isin([41.0, 81.0, 120.0, 161.0], el).any()
    assert np.isin([80.0, 121.0], el).all()  # whole: 121 from the row before the drop
    for k in ("disp_wpm_m", "disp_gnss_m"):
        np.testing.assert_allclose(out[k], ref.frame[k].to_numpy(), atol=1e-9)
    np.testing.assert_allclose(out["pred_error_m"], model.predict(ref.x), atol=1e-6)
    assert [(round(g["from_s"], 6), round(g["gap_s"], 6), g["dropped"]) for g in stream.gaps] == [
        (40.2, 0.2, True),
        (80.0, 0.2, True),
        (119.9, 0.2, True),
        (160.2, 0.3, True),
    ]


@pytest.mark.parametrize("sizes", [[100_000], [7] * 3000, [401, 1, 399, 2] * 10])
def test_a_row_without_a_wheel_speed_is_a_dropped_sample(bundle, tmp_path, sizes):
    """A row whose time is there but a wheel speed is empty (a CAN frame the logger
    missed) was refused, in predict and in validate. It is now dropped, so the stream,
    and the label stage from the same file, give the seconds of the drive without those
    rows; the rows are listed by their place in the file, a copy after them too."""
    from support.drives import write_iovnbd

    model = load_served(bundle["model_onnx"])
    df = wavy_drive(200)
    el = np.round(df["t_s"].to_numpy() - df["t_s"].iloc[0], 6)
    at = np.flatnonzero(np.isin(el, DROPPED_S))
    holes = df.copy()
    for i, wheel in zip(
        at, ["omega_rl_rad_s", "omega_fl_rad_s", "omega_rr_rad_s"] * 2, strict=False
    ):
        holes.loc[i, wheel] = np.nan
    holes = written_twice(holes, 1700)  # a copy after them: data row 1701
    path = write_iovnbd(holes, tmp_path / "V-Holes.csv")
    dropped, _ = stream_all(model, blocks_of(_without_rows(df, DROPPED_S), [100_000]))
    out, stream = stream_all(model, blocks_of(holes, sizes))
    assert_same_seconds(out, dropped)
    assert stream.dropped.wheelless == [int(i) + 1 for i in at]
    assert stream.dropped.dropped == [1701]
    ref = reference_samples(path, seq_len=1)  # rwhonet recalibrate's reader, ingest's drop
    np.testing.assert_array_equal(out["t_s"], ref.frame["t_s"].to_numpy())
    np.testing.assert_allclose(out["disp_gnss_m"], ref.frame["disp_gnss_m"].to_numpy(), atol=1e-9)
    copy, holes_note = stream.dropped.notes("t.csv")
    assert "5 data row(s) have an empty wheel speed (row(s) 404, 802, 1201, 1604, 1605)" in (
        holes_note
    )


def test_dropped_samples_inside_an_outage_keep_the_position(bundle):
    model = load_served(bundle["model_onnx"])
    df = _straight(300.0)
    plain, _ = stream_all(model, blocks_of(df, [100_000]), [Outage(100, 220)])
    out, stream = stream_all(
        model, blocks_of(_without_rows(df, [130.5, 170.1, 200.0]), [333] * 20), [Outage(100, 220)]
    )
    inside = out["outage"] == "100:220"
    assert inside.sum() == 120 - 3
    for col in POSITION_COLUMNS:
        assert np.isfinite(out[col][inside]).all(), col
    assert [g["bridged"] for g in stream.gaps] == [True] * 3
    end, ref = stream.summary()[0], plain["outage"] == "100:220"
    assert end["east_end_m"] == pytest.approx(plain["east_m"][ref][-1], abs=0.5)
    assert end["north_end_m"] == pytest.approx(plain["north_m"][ref][-1], abs=0.5)
    text = render_summary(
        {"file": "t.csv", "rows": 1, "seconds": 1, "outages": [end]}
        | {"gaps": stream.gaps, "max_gap_s": 0.5}
    )
    assert "dropped samples: 3 time step(s) that skip a slot" in text
    assert "0.2 s after 130.4 s (the position carried across)" in text
    assert "logger gap" not in text
