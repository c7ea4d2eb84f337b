"""Streaming seconds: the label stage's grid, whatever the blocks, with outage cumulatives."""

import numpy as np
import pandas as pd
import pytest

from rwhonet.cli.drive import calibration_of, load_drive
from rwhonet.config import load_params
from rwhonet.data.stream import read_rows
from rwhonet.errors import InputError
from rwhonet.serve.model import load_served
from rwhonet.serve.stream import COLUMNS, Outage, SecondStream, parse_outage
from support.serving import RADIUS_M, SCALER, base_bundle, wavy_drive


def stream_all(model, blocks, outages=()):
    s = SecondStream(model, list(outages), file="t.csv")
    parts = [s.push(first, cols) for first, cols in blocks]
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
        )
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


def test_seconds_match_the_label_stage_and_the_model(bundle, drive_csv):
    model = load_served(bundle["model_onnx"])
    with open(drive_csv, "rb") as f:
        _, blocks = read_rows(f, "V-Wavy.csv", block_bytes=5000)
        out, _ = stream_all(model, list(blocks))
    ref = load_drive(
        drive_csv,
        load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of((RADIUS_M, RADIUS_M), "t"),
        scaler=SCALER,
        wpm_mode="integrated",
        seq_len=1,
    ).samples
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
    ref = load_drive(
        drive_csv,
        load_params(),
        vehicle="target",
        fmt="iovnbd",
        calibration=calibration_of((RADIUS_M, RADIUS_M), "t"),
        scaler=SCALER,
        wpm_mode="integrated",
        seq_len=32,
    ).samples
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


def test_missing_wheel_speed_and_time_going_back_are_named(bundle):
    model = load_served(bundle["model_onnx"])
    df = wavy_drive(30)
    df.loc[55, "omega_rl_rad_s"] = np.nan
    with pytest.raises(InputError, match="row 56"):
        stream_all(model, blocks_of(df, [len(df)]))
    df = wavy_drive(30)
    df.loc[120, "t_s"] = df.loc[118, "t_s"]
    with pytest.raises(InputError, match="row 121.*a time after"):
        stream_all(model, blocks_of(df, [100] * 5))
