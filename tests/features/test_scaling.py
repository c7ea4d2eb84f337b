"""Min-max scaling: global vs per-wheel statistics, no clipping, JSON round trip."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rwhonet.errors import InputError
from rwhonet.features.scaling import fit_scaler, scaler_from_dict


def features(rng: np.random.Generator, n: int, wheel_ranges) -> np.ndarray:
    """(n, 40) features with wheel w uniform in wheel_ranges[w] (order RR, RL, FR, FL)."""
    return np.concatenate([rng.uniform(lo, hi, (n, 10)) for lo, hi in wheel_ranges], axis=1)


RANGES = [(0.0, 50.0), (1.0, 52.0), (0.5, 49.0), (2.0, 60.0)]


def test_global_scaling_maps_the_overall_range_to_0_1_and_keeps_wheel_differences():
    x = features(np.random.default_rng(0), 500, RANGES)
    scaler = fit_scaler([x], "global", ["d1"])
    assert len(set(scaler.min_rad_s)) == 1 and len(set(scaler.max_rad_s)) == 1
    z = scaler.transform(x)
    assert z.dtype == np.float32
    assert z.min() == pytest.approx(0.0, abs=1e-7) and z.max() == pytest.approx(1.0, abs=1e-6)
    # One affine map for all wheels: differences between wheels scale by one factor.
    diff_raw = x[:, 0:10] - x[:, 10:20]
    diff_scaled = z[:, 0:10].astype(np.float64) - z[:, 10:20]
    np.testing.assert_allclose(diff_scaled, diff_raw / (x.max() - x.min()), atol=1e-6)


def test_per_wheel_scaling_maps_each_wheel_to_0_1():
    x = features(np.random.default_rng(1), 500, RANGES)
    scaler = fit_scaler([x], "per_wheel", ["d1"])
    z = scaler.transform(x).reshape(-1, 4, 10)
    np.testing.assert_allclose(z.min(axis=(0, 2)), 0.0, atol=1e-7)
    np.testing.assert_allclose(z.max(axis=(0, 2)), 1.0, atol=1e-6)
    assert scaler.max_rad_s[3] == pytest.approx(x[:, 30:].max())


def test_values_outside_the_fitted_range_are_not_clipped():
    rng = np.random.default_rng(2)
    scaler = fit_scaler([features(rng, 200, RANGES)], "global", ["src"])
    target = features(rng, 50, [(lo - 5, hi * 1.3) for lo, hi in RANGES])
    z = scaler.transform(target)
    assert z.min() < 0.0 and z.max() > 1.0


def test_degenerate_inputs_are_refused():
    with pytest.raises(ValueError, match="constant"):
        fit_scaler([np.ones((5, 40))], "global", [])
    with pytest.raises(ValueError, match="zero seconds"):
        fit_scaler([np.ones((0, 40))], "per_wheel", [])
    with pytest.raises(ValueError, match="kind"):
        fit_scaler([np.ones((5, 40))], "zscore", [])
    with pytest.raises(ValueError, match="shape"):
        fit_scaler([np.ones((5, 39))], "global", [])


@pytest.mark.parametrize("kind", ["global", "per_wheel"])
def test_scaler_round_trip_through_json(kind):
    x = features(np.random.default_rng(3), 100, RANGES)
    scaler = fit_scaler([x], kind, ["V-S1", "V-S2"])
    raw = json.loads(json.dumps(scaler.to_dict()))
    assert raw["wheels"][0] == "omega_rr_rad_s"
    loaded = scaler_from_dict(raw, "scaler.json")
    assert loaded == scaler
    np.testing.assert_array_equal(loaded.transform(x), scaler.transform(x))


def test_malformed_scaler_is_refused():
    raw = {"kind": "global", "wheels": ["a"], "min_rad_s": [0, 0], "max_rad_s": "x"}
    with pytest.raises(InputError) as err:
        scaler_from_dict(raw, "scaler.json")
    assert {p.column for p in err.value.problems} == {"wheels", "min_rad_s", "max_rad_s"}


@pytest.mark.parametrize("kind", ["global", "per_wheel"])
def test_fitting_on_blocks_equals_fitting_on_their_concatenation(kind):
    rng = np.random.default_rng(4)
    # Each block holds one wheel's extreme: only reducing across blocks finds them all.
    blocks = [features(rng, n, ranges) for n, ranges in ((7, RANGES), (0, RANGES), (30, RANGES))]
    blocks[0][3, 12] = -4.0  # RL minimum in the first block
    blocks[2][5, 39] = 75.0  # FL maximum in the last
    scaler = fit_scaler(blocks, kind, ["a", "b"])
    assert scaler == fit_scaler([np.concatenate(blocks)], kind, ["a", "b"])
    assert scaler.n_seconds == 37 and min(scaler.min_rad_s) == -4.0
    assert max(scaler.max_rad_s) == 75.0
    blocks[2][0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        fit_scaler(blocks, kind, [])
    with pytest.raises(ValueError, match="zero seconds"):
        fit_scaler([np.ones((0, 40))], kind, [])
