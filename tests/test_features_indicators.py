"""Gear condition indicators against hand-computed values (features.indicators).

Signals are built from cosines at whole shaft orders over one revolution, so every
moment is a closed form: E[cos^2] = 1/2, E[cos^4] = 3/8, E[cos^6] = 5/16, E[cos^8] = 35/128.
"""
import numpy as np
import pytest

from features import indicators as ci
from features.tsa import split_tsa

Z = 16


def theta(n):
    return 2 * np.pi * np.arange(n) / n


def test_fm0_hand_value():
    """FM0 (Stewart 1977; Zakrajsek 1993) of x = cos(z th) + 0.5 cos(2 z th): max 1.5 (u = 0), min -0.75
    (cos u = -1/2, sampled since N = 384 = 24 z), sum of mesh amplitudes 1.5 -> 2.25 / 1.5 = 1.5; tol 1e-12."""
    th = theta(384)
    assert ci.fm0(np.cos(Z * th) + 0.5 * np.cos(2 * Z * th), Z) == pytest.approx(1.5, abs=1e-12)


def test_fm4_m6a_m8a_of_sinusoidal_difference():
    """Difference signal = 0.25 cos(7 th) (the only non-regular component): FM4 = (3/8)/(1/2)^2 = 1.5,
    M6A = (5/16)/(1/2)^3 = 2.5, M8A = (35/128)/(1/2)^4 = 4.375 (Zakrajsek 1993 definitions); tol 1e-10."""
    th = theta(256)
    x = np.cos(Z * th) + 0.4 * np.cos((Z + 1) * th) + 0.3 * np.cos(th) + 0.25 * np.cos(7 * th)
    d = split_tsa(x, Z).difference
    assert ci.fm4(d) == pytest.approx(1.5, abs=1e-10)
    assert ci.m6a(d) == pytest.approx(2.5, abs=1e-10)
    assert ci.m8a(d) == pytest.approx(4.375, abs=1e-10)


def test_fm4_of_gaussian_difference_is_about_3():
    """Healthy gear: mesh tones + Gaussian noise -> difference signal Gaussian, FM4 ~ 3, M6A ~ 15, M8A ~ 105
    (Gaussian moments; N = 2**15, std of FM4 ~ sqrt(24/N) = 0.027; tol 0.15 / 1.5 / 20, seeded)."""
    n = 2**15
    th = theta(n)
    x = np.cos(Z * th) + 0.5 * np.cos(2 * Z * th) + 0.3 * np.random.default_rng(7).standard_normal(n)
    d = split_tsa(x, Z).difference
    assert ci.fm4(d) == pytest.approx(3.0, abs=0.15)
    assert ci.m6a(d) == pytest.approx(15.0, abs=1.5)
    assert ci.m8a(d) == pytest.approx(105.0, abs=20.0)


def test_na4_single_record_and_run_normalised():
    """NA4 (Zakrajsek, Townsend, Decker 1993). Residual r = a cos(7 th): single record -> kurtosis 1.5.
    Run of two records (a = 1, then a = 2): record 2 gives E[r^4] / mean(var)^2 = (3/8 * 16) / (1.25)^2 = 3.84;
    tol 1e-10."""
    th = theta(256)
    r1 = split_tsa(np.cos(Z * th) + np.cos(7 * th), Z).residual
    r2 = split_tsa(np.cos(Z * th) + 2 * np.cos(7 * th), Z).residual
    assert ci.na4(r2) == pytest.approx(1.5, abs=1e-10)
    assert ci.na4(r2, ensemble_variances=[np.var(r1)]) == pytest.approx(3.84, abs=1e-10)
    np.testing.assert_allclose(ci.na4_trend(np.stack([r1, r2])), [1.5, 3.84], atol=1e-10)


def test_nb4_envelope_of_am_mesh_tone():
    """NB4 (Zakrajsek, Handschuh, Decker 1994): x = (1 + 0.5 cos th) cos(z th); the band-passed envelope is
    1 + 0.5 cos th exactly (tol 1e-12) and NB4 of one record is its kurtosis 1.5 (tol 1e-10)."""
    th = theta(256)
    x = (1 + 0.5 * np.cos(th)) * np.cos(Z * th)
    np.testing.assert_allclose(ci.mesh_band_envelope(x, Z), 1 + 0.5 * np.cos(th), atol=1e-12)
    assert ci.nb4(x, Z) == pytest.approx(1.5, abs=1e-10)


def test_energy_ratio_hand_value():
    """ER = RMS(d)/RMS(regular) (Swansson 1980): regular = cos z th + 0.5 cos 2z th + 0.3 cos th + 0.2 cos (z+1) th
    (RMS sqrt(1.38/2)), d = 0.25 cos 7 th (RMS 0.25/sqrt 2) -> 0.25 / sqrt(1.38); tol 1e-12."""
    th = theta(256)
    x = np.cos(Z * th) + 0.5 * np.cos(2 * Z * th) + 0.3 * np.cos(th) + 0.2 * np.cos((Z + 1) * th) \
        + 0.25 * np.cos(7 * th)
    p = split_tsa(x, Z)
    assert ci.energy_ratio(p.difference, p.regular) == pytest.approx(0.25 / np.sqrt(1.38), abs=1e-12)


def test_sideband_level_factor_and_index_hand_values():
    """Lebold et al. (2000): x = cos z th + 0.2 cos (z-1) th + 0.4 cos (z+1) th. SI = (0.2 + 0.4)/2 = 0.3;
    SLF = 0.6 / std(x) = 0.6 / sqrt(0.6); tol 1e-12."""
    th = theta(256)
    x = np.cos(Z * th) + 0.2 * np.cos((Z - 1) * th) + 0.4 * np.cos((Z + 1) * th)
    assert ci.sideband_index(x, Z) == pytest.approx(0.3, abs=1e-12)
    assert ci.sideband_level_factor(x, Z) == pytest.approx(0.6 / np.sqrt(0.6), abs=1e-12)


def test_all_indicators_dictionary_matches_single_functions():
    """gear_condition_indicators returns the same numbers as the single functions (exact) for a faulty-like TSA."""
    th = theta(512)
    x = np.cos(28 * th) * (1 - 0.3 * np.exp(-((th - np.pi) / 0.1) ** 2)) + 0.05 * np.cos(th)
    d = ci.gear_condition_indicators(x, 28)
    p = split_tsa(x, 28)
    assert d["fm4"] == ci.fm4(p.difference)
    assert d["na4"] == ci.na4(p.residual)
    assert d["nb4"] == ci.nb4(x, 28)
    assert d["fm4"] > 3.0  # a localised dip makes the difference signal impulsive
    assert set(d) == set(ci.INDICATOR_UNITS)
