"""Time-domain statistics against closed-form values (features.statistics)."""
import numpy as np
import pytest
from scipy.special import gamma

from features import statistics as st
from gearpit.errors import InputError


def _sine(n_periods=50, n=100_000, amp=2.0):
    t = np.arange(n) / n
    return amp * np.sin(2 * np.pi * n_periods * t)


def test_kurtosis_of_sine_is_1_5():
    """Kurtosis of a sine = E[sin^4]/E[sin^2]^2 = (3/8)/(1/4) = 1.5 (whole periods; tol 1e-9)."""
    assert st.kurtosis(_sine()) == pytest.approx(1.5, abs=1e-9)


def test_kurtosis_of_gaussian_noise_is_3():
    """Pearson kurtosis of Gaussian noise = 3; n = 2e5 gives std sqrt(24/n) = 0.011, tol 0.05 (seeded)."""
    x = np.random.default_rng(1).standard_normal(200_000)
    assert st.kurtosis(x) == pytest.approx(3.0, abs=0.05)
    assert st.skewness(x) == pytest.approx(0.0, abs=0.03)


def test_sine_factors_match_closed_forms():
    """Sine of amplitude A: rms A/sqrt2, crest sqrt2, shape pi/(2 sqrt2), impulse pi/2,
    clearance 1/m^2 with m = mean sqrt|sin| = Gamma(3/4)/(sqrt(pi) Gamma(5/4)); tol 1e-4."""
    x = _sine(amp=2.0)
    s = st.time_domain_statistics(x)
    m = gamma(0.75) / (np.sqrt(np.pi) * gamma(1.25))
    assert s["rms"] == pytest.approx(2 / np.sqrt(2), rel=1e-9)
    assert s["peak"] == pytest.approx(2.0, rel=1e-6)
    assert s["peak_to_peak"] == pytest.approx(4.0, rel=1e-6)
    assert s["crest_factor"] == pytest.approx(np.sqrt(2), rel=1e-6)
    assert s["shape_factor"] == pytest.approx(np.pi / (2 * np.sqrt(2)), rel=1e-6)
    assert s["impulse_factor"] == pytest.approx(np.pi / 2, rel=1e-6)
    assert s["clearance_factor"] == pytest.approx(1 / m**2, rel=1e-4)
    assert s["skewness"] == pytest.approx(0.0, abs=1e-9)


def test_skewness_of_exponential_is_2():
    """Skewness of an exponential distribution = 2 (n = 4e5, seeded; tol 0.1)."""
    x = np.random.default_rng(2).exponential(size=400_000)
    assert st.skewness(x) == pytest.approx(2.0, abs=0.1)


def test_batch_equals_rows_and_bad_input_raises():
    """A (3, n) batch gives the three per-row values (exact); NaN input raises InputError."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((3, 1000))
    np.testing.assert_array_equal(st.kurtosis(x), [st.kurtosis(r) for r in x])
    bad = x[0].copy()
    bad[5] = np.nan
    with pytest.raises(InputError):
        st.rms(bad)
