"""Hilbert-Huang transform: decompositions, IMF selection, Hilbert spectrum, energy index (features.hht)."""
import numpy as np
import pytest

from features import hht
from gearpit.errors import InputError

FS = 2000.0
T = np.arange(2000) / FS


def _n_extrema(y):
    d = np.diff(y)
    return int(np.count_nonzero(d[:-1] * d[1:] < 0))


def _two_tones():
    return np.cos(2 * np.pi * 300 * T) + 0.8 * np.cos(2 * np.pi * 20 * T) + 0.3 * T


@pytest.mark.parametrize("method", ["emd", "eemd", "ceemdan"])
def test_imfs_plus_residue_rebuild_the_signal(method):
    """Completeness of EMD / EEMD / CEEMDAN (Huang 1998; Wu & Huang 2009; Torres 2011): sum of IMFs + residue
    equals the signal to 1e-10 (8 trials for the ensembles, seed 3)."""
    x = _two_tones()
    d = hht.decompose(x, method=method, trials=8, seed=3)
    assert d.n_imfs >= 2
    np.testing.assert_allclose(d.imfs.sum(axis=0) + d.residue, x, atol=1e-10)


def test_emd_separates_tones_and_leaves_the_trend():
    """EMD of cos(300 Hz) + 0.8 cos(20 Hz) + 0.3 t: IMF1 is the 300 Hz tone (correlation > 0.999), IMF2 the 20 Hz
    tone (> 0.99), and the residue is the monotone trend (<= 2 extrema, max deviation from 0.3 t < 0.1)."""
    d = hht.decompose(_two_tones(), method="emd")
    assert np.corrcoef(d.imfs[0], np.cos(2 * np.pi * 300 * T))[0, 1] > 0.999
    assert np.corrcoef(d.imfs[1], np.cos(2 * np.pi * 20 * T))[0, 1] > 0.99
    assert _n_extrema(d.residue) <= 2
    assert np.max(np.abs(d.residue - 0.3 * T)) < 0.1


@pytest.mark.parametrize("method", ["eemd", "ceemdan"])
def test_ensemble_noise_is_seeded(method):
    """Same seed -> identical IMFs (bytes); another seed -> different IMFs (PyEMD noise_seed)."""
    x = _two_tones()
    a = hht.decompose(x, method=method, trials=5, seed=3)
    b = hht.decompose(x, method=method, trials=5, seed=3)
    c = hht.decompose(x, method=method, trials=5, seed=4)
    assert a.imfs.tobytes() == b.imfs.tobytes()
    assert a.imfs.shape != c.imfs.shape or not np.array_equal(a.imfs, c.imfs)


def test_energy_index_of_pure_tone_is_constant():
    """E(t) = sum_f H(f,t)^2 of A cos(2 pi 100 t) with A = 1.7 over whole periods is A^2 = 2.89 at every sample
    (analytic signal exact), instantaneous frequency 100 Hz; tol 1e-9."""
    x = 1.7 * np.cos(2 * np.pi * 100 * T + 0.2)
    e = hht.energy_index(hht.hilbert_spectrum(x, FS, n_freq_bins=50))
    np.testing.assert_allclose(e, 1.7**2, atol=1e-9)
    a, f = hht.instantaneous_amplitude_frequency(x, FS)
    np.testing.assert_allclose(a, 1.7, atol=1e-9)
    np.testing.assert_allclose(f, 100.0, atol=1e-9)


def test_hilbert_spectrum_places_and_conserves_energy():
    """Two IMFs (0.5 at 55 Hz, 1.0 at 605 Hz; bin centres), 100 bins of 10 Hz: energy 0.25 in bin 5 and 1.0 in bin 60 at every
    sample, and sum over bins = a1^2 + a2^2 (tol 1e-9)."""
    imfs = np.stack([np.cos(2 * np.pi * 605 * T), 0.5 * np.cos(2 * np.pi * 55 * T)])
    hs = hht.hilbert_spectrum(imfs, FS, n_freq_bins=100)
    np.testing.assert_allclose(hs.amplitude[60] ** 2, 1.0, atol=1e-9)
    np.testing.assert_allclose(hs.amplitude[5] ** 2, 0.25, atol=1e-9)
    np.testing.assert_allclose(hht.energy_index(hs), 1.25, atol=1e-9)


def test_select_imf_criteria():
    """mesh_band_energy picks the IMF holding [fm, 2 fm] (fm = 200 Hz: the 300 Hz tone, not the 20 Hz one);
    envelope_kurtosis picks the IMF carrying sparse bursts; fixed returns number - 1, clipped to the last IMF."""
    d = hht.decompose(_two_tones(), method="emd")
    sel = hht.select_imf(d.imfs, FS, criterion="mesh_band_energy", fm_hz=200.0)
    assert np.corrcoef(d.imfs[sel.index], np.cos(2 * np.pi * 300 * T))[0, 1] > 0.999
    bursts = np.zeros_like(T)
    bursts[::250] = 1.0
    imfs = np.stack([np.convolve(bursts, np.hanning(15), mode="same") * np.cos(2 * np.pi * 500 * T),
                     np.cos(2 * np.pi * 40 * T)])
    assert hht.select_imf(imfs, FS, criterion="envelope_kurtosis").index == 0
    assert hht.select_imf(d.imfs, FS, criterion="fixed", imf_number=6).index == d.n_imfs - 1
    assert hht.select_imf(d.imfs, FS, criterion="fixed", imf_number=1).index == 0
    with pytest.raises(InputError):
        hht.select_imf(d.imfs, FS, criterion="max_energy")


@pytest.mark.parametrize("method", ["emd", "eemd", "ceemdan"])
def test_a_constant_record_has_no_imf_and_is_its_own_residue(method):
    """An IMF oscillates (Huang et al. 1998: its extrema and zero crossings differ by at most one), so a constant
    record has none: zero IMFs and the record as the residue (exact); nothing for select_imf to pick, an
    InputError naming the IMFs (before: PyEMD's zero IMFs reached np.argmax of an empty array, a bare ValueError;
    CEEMDAN divided by the record's zero std)."""
    x = np.full(512, 3.0)
    d = hht.decompose(x, method=method, trials=3, seed=1)
    assert d.n_imfs == 0 and d.imfs.shape == (0, 512)
    np.testing.assert_array_equal(d.residue, x)
    with pytest.raises(InputError, match="imfs"):
        hht.select_imf(d.imfs, 12800.0, fm_hz=700.0)


def test_a_dead_record_gets_nan_hht_features_and_the_batch_goes_on():
    """A dead channel (all zeros) among three records, EMD on (the default): its imf_* features are NaN and one
    NoImfWarning names it; the other records' rows equal their features computed alone (exact: same per-record
    seeds). Before, np.argmax of the empty IMF scores aborted the whole table."""
    from features.table import HHT_FEATURES, FeatureConfig, NoImfWarning, extract_features

    x = np.random.default_rng(0).standard_normal((3, 3200))
    x[1] = 0.0
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=29, z_wheel=100)
    with pytest.warns(NoImfWarning, match=r"1 record\(s\) without IMF.*: dead"):
        table = extract_features(x, cfg, fr_pinion_hz=25.0, record_names=["a", "dead", "c"])
    hht_cols = [c for c in table.columns if c.split("[")[0] in HHT_FEATURES]
    assert len(hht_cols) == 8 and table.loc[1, hht_cols].isna().all()
    for i in (0, 2):
        alone = extract_features(x[[i]], cfg, fr_pinion_hz=25.0, seeds=[int(np.uint64(
            np.random.SeedSequence([0, i]).generate_state(1)[0]))])
        np.testing.assert_array_equal(table.iloc[[i]].to_numpy(), alone.to_numpy())
        assert np.isfinite(table.loc[i, hht_cols].to_numpy(dtype=float)).all()
