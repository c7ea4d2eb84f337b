"""rwhonet.data.robust: scipy's median_abs_deviation(scale="normal") and
cumulative_trapezoid(initial=0), to the bit, without importing scipy."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid as scipy_cumulative_trapezoid
from scipy.stats import median_abs_deviation

from rwhonet.data.robust import cumulative_trapezoid, mad_normal


@pytest.mark.parametrize("n", [1, 2, 3, 10, 11, 1000])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mad_normal_is_scipys_to_the_bit(n, seed):
    rng = np.random.default_rng(seed)
    x = rng.standard_t(3, n) * 0.05 + rng.uniform(-1, 1)  # heavy tails, an offset
    assert mad_normal(x) == float(median_abs_deviation(x, scale="normal"))


def test_mad_normal_estimates_a_normal_sigma_and_ignores_outliers():
    rng = np.random.default_rng(3)
    x = rng.normal(0.0, 0.2, 200_000)
    assert mad_normal(x) == pytest.approx(0.2, rel=0.01)
    x[:20_000] = 1e6  # a tenth of the sample wild
    assert mad_normal(x) == pytest.approx(0.2 * 1.16, rel=0.05)  # moved, not destroyed
    assert mad_normal([5.0, 5.0, 5.0]) == 0.0


def test_mad_normal_of_nothing_or_a_nan_is_nan():
    assert np.isnan(mad_normal([]))
    assert np.isnan(mad_normal([1.0, np.nan, 2.0]))


@pytest.mark.parametrize("n", [1, 2, 3, 50, 10_001])
def test_cumulative_trapezoid_is_scipys_to_the_bit_on_uneven_steps(n):
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.uniform(0.005, 0.03, n)) + 1.7e4  # jittered stamps, far from 0
    y = rng.normal(20.0, 5.0, n)
    got = cumulative_trapezoid(y, x)
    np.testing.assert_array_equal(got, scipy_cumulative_trapezoid(y, x, initial=0.0))
    assert got[0] == 0.0 and got.shape == (n,)


def test_cumulative_trapezoid_of_a_line_is_exact_and_refuses_mismatched_arrays():
    x = np.array([0.0, 0.5, 2.0, 3.0])
    np.testing.assert_allclose(cumulative_trapezoid(2.0 * x, x), x**2, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="1-D of one length"):
        cumulative_trapezoid([1.0, 2.0], [0.0])


def test_the_stream_readers_import_no_scipy():
    # scipy.stats, .integrate and .ndimage cost a stream drive's `rwhonet predict` 1.1 s
    code = (
        "import sys, rwhonet.data.streams, rwhonet.data.signalmap, rwhonet.data.comma2k19; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
