"""Amplitude spectra, named lines, envelope and spectral kurtosis (features.spectra, features.envelope)."""
import numpy as np
import pytest
from scipy.signal import hilbert

from features import envelope as env
from features import spectra
from gearpit.errors import InputError

FS = 12800.0
T = np.arange(12800) / FS  # 1 s: integer-Hz tones hold whole periods


def test_amplitude_spectrum_is_window_corrected():
    """A 0.7 cos at an exact bin (1000 Hz) reads 0.7 with the Hann and flat-top windows (coherent gain, Harris
    1978); tol 1e-12."""
    for w in ("hann", "flattop", "boxcar"):
        f, a = spectra.amplitude_spectrum(0.7 * np.cos(2 * np.pi * 1000 * T), FS, window=w)
        assert a[np.argmin(np.abs(f - 1000))] == pytest.approx(0.7, abs=1e-12)


def test_line_amplitude_between_bins_has_no_scalloping():
    """A 1.3 cos at 1234.5 Hz (half-way between bins, where a Hann FFT bin loses 15 %) reads 1.3 by the windowed
    DFT at its exact frequency; tol 1e-4 (negative-frequency image leakage)."""
    x = 1.3 * np.cos(2 * np.pi * 1234.5 * T + 0.4)
    assert spectra.line_amplitudes(x, FS, [1234.5])[0] == pytest.approx(1.3, abs=1e-4)


def test_mesh_sidebands_of_both_shafts():
    """x = (1 + 0.2 cos 2pi fp t)(1 + 0.1 cos 2pi fw t) cos 2pi fm t, fp = 25, fw = 20, fm = 700 Hz:
    mesh1 = 1, pinion sidebands 0.1, wheel sidebands 0.05 (AM: m/2 per side), second-order cross terms at
    fm +/- (fp +/- fw) only; unused lines < 1e-6; tol 1e-6."""
    fp, fw, fm = 25.0, 20.0, 700.0
    x = (1 + 0.2 * np.cos(2 * np.pi * fp * T)) * (1 + 0.1 * np.cos(2 * np.pi * fw * T)) * np.cos(2 * np.pi * fm * T)
    a = spectra.mesh_sideband_amplitudes(x, FS, fm_hz=fm, fr_pinion_hz=fp, fr_wheel_hz=fw, n_harmonics=2,
                                         n_sidebands=2)
    assert a["mesh1"] == pytest.approx(1.0, abs=1e-6)
    for side in ("lsb1", "usb1"):
        assert a[f"mesh1_pinion_{side}"] == pytest.approx(0.1, abs=1e-6)
        assert a[f"mesh1_wheel_{side}"] == pytest.approx(0.05, abs=1e-6)
    assert a["mesh2"] < 1e-6 and a["mesh1_pinion_usb2"] < 1e-6 and a["pinion_order1"] < 1e-6
    assert a["pinion_sideband_ratio"] == pytest.approx(np.sqrt(2 * 0.1**2), abs=1e-6)


def test_lines_above_nyquist_are_rejected():
    """Asking for the 10th mesh harmonic of 700 Hz at 12.8 kHz is an InputError, not a silent NaN."""
    with pytest.raises(InputError):
        spectra.mesh_sideband_amplitudes(np.zeros(1000), FS, fm_hz=700.0, fr_pinion_hz=25.0, fr_wheel_hz=20.0,
                                         n_harmonics=10)


def test_envelope_of_am_tone_equals_modulation():
    """Hilbert envelope of (1 + 0.5 cos 2pi 25 t) cos 2pi 1000 t is 1 + 0.5 cos 2pi 25 t (Bedrosian), full band and
    band-passed to 900-1100 Hz; whole periods -> tol 1e-9. Full band equals |scipy.signal.hilbert| (1e-12)."""
    mod = 1 + 0.5 * np.cos(2 * np.pi * 25 * T)
    x = mod * np.cos(2 * np.pi * 1000 * T)
    np.testing.assert_allclose(env.envelope(x, FS), mod, atol=1e-9)
    np.testing.assert_allclose(env.envelope(x, FS, band_hz=(900.0, 1100.0)), mod, atol=1e-9)
    np.testing.assert_allclose(env.envelope(x, FS), np.abs(hilbert(x)), atol=1e-12)


def test_envelope_spectrum_shows_modulation_line():
    """Envelope spectrum of that AM tone: a 0.5 line at 25 Hz (tol 1e-9), nothing at 50 Hz (< 1e-9)."""
    x = (1 + 0.5 * np.cos(2 * np.pi * 25 * T)) * np.cos(2 * np.pi * 1000 * T)
    a = env.envelope_order_amplitudes(x, FS, fr_pinion_hz=25.0, fr_wheel_hz=20.0, n_orders=2)
    assert a["env_pinion_order1"] == pytest.approx(0.5, abs=1e-9)
    assert a["env_pinion_order2"] < 1e-9


def test_spectral_kurtosis_of_noise_and_tone():
    """STFT spectral kurtosis (Antoni 2006): Gaussian noise ~ 0 (mean over bins |.| < 0.05), a stationary tone -1
    at its bin (tol 0.02); seeded."""
    rng = np.random.default_rng(11)
    f, sk = env.spectral_kurtosis(rng.standard_normal(T.size), FS, nperseg=128)
    assert abs(np.mean(sk[2:-2])) < 0.05
    f, sk = env.spectral_kurtosis(np.cos(2 * np.pi * 2000 * T) + 1e-3 * rng.standard_normal(T.size), FS, nperseg=128)
    assert sk[np.argmin(np.abs(f - 2000))] == pytest.approx(-1.0, abs=0.02)


def test_find_resonance_band_locates_ringing():
    """Noise + a 3 kHz resonance rung 25 times a second (damping 0.03): the max-SK band contains 3 kHz and the
    band-passed envelope spectrum shows the 25 Hz ring rate above the noise floor (x5)."""
    rng = np.random.default_rng(12)
    x = 0.5 * rng.standard_normal(T.size)
    tr = np.arange(200) / FS
    ring = np.exp(-0.03 * 2 * np.pi * 3000 * tr) * np.sin(2 * np.pi * 3000 * tr)
    for start in range(100, T.size - 200, 512):
        x[start:start + 200] += 2.0 * ring
    band = env.find_resonance_band(x, FS, min_hz=1000.0)
    assert band.band_hz[0] <= 3000.0 <= band.band_hz[1]
    assert band.spectral_kurtosis > 1.0
    a = env.envelope_order_amplitudes(x, FS, fr_pinion_hz=25.0, fr_wheel_hz=17.0, n_orders=1, band_hz=band.band_hz)
    assert a["env_pinion_order1"] > 5 * a["env_wheel_order1"]


HALF_S = np.arange(6400) / FS  # 0.5 s: 2 Hz resolution, as the demo's records


@pytest.mark.parametrize("window", ["hann", "blackmanharris", "flattop"])
@pytest.mark.parametrize("phase", [0.0, 1.0, 2.0])
def test_wheel_sidebands_beside_the_mesh_line_read_their_amplitude(window, phase):
    """29/100 teeth at 25 Hz, 0.5 s: the wheel's first sidebands (0.01) lie 7.25 Hz = 3.6 bins from the mesh line
    (1.0), inside a windowed DFT's reach of it. Fitted jointly (weighted least squares, Kay 1993 sec. 4.6) a record
    made of the named lines is returned exactly: 0.01 each, wheel second sidebands 0, sideband ratio
    sqrt(2) 0.01, whatever the mesh phase; tol 1e-9 (rounding). The windowed DFT read 0.003-0.017 (Hann),
    0.040-0.060 (flat top)."""
    fm, fw = 725.0, 7.25
    x = (np.cos(2 * np.pi * fm * HALF_S + phase) + 0.01 * np.cos(2 * np.pi * (fm - fw) * HALF_S)
         + 0.01 * np.cos(2 * np.pi * (fm + fw) * HALF_S))
    a = spectra.mesh_sideband_amplitudes(x, FS, fm_hz=fm, fr_pinion_hz=25.0, fr_wheel_hz=fw, n_harmonics=1,
                                         window=window)
    assert a["mesh1"] == pytest.approx(1.0, abs=1e-9)
    assert a["mesh1_wheel_lsb1"] == pytest.approx(0.01, abs=1e-9)
    assert a["mesh1_wheel_usb1"] == pytest.approx(0.01, abs=1e-9)
    assert a["mesh1_wheel_lsb2"] < 1e-9 and a["mesh1_pinion_lsb1"] < 1e-9
    assert a["wheel_sideband_ratio"] == pytest.approx(np.sqrt(2) * 0.01, abs=1e-9)


def test_lines_of_the_other_shaft_do_not_bleed_in():
    """Pinion sidebands (0.1) and pinion order 1 (0.05) only, 0.5 s: the wheel's third sidebands and third order lie
    3.25 Hz = 1.6 bins from them and read 0 (tol 1e-9; the windowed DFT read 0.011 and 0.0055), the pinion lines
    their amplitudes (tol 1e-9)."""
    fm, fp, fw = 725.0, 25.0, 7.25
    x = (np.cos(2 * np.pi * fm * HALF_S) + 0.1 * np.cos(2 * np.pi * (fm - fp) * HALF_S)
         + 0.1 * np.cos(2 * np.pi * (fm + fp) * HALF_S) + 0.05 * np.cos(2 * np.pi * fp * HALF_S))
    a = spectra.mesh_sideband_amplitudes(x, FS, fm_hz=fm, fr_pinion_hz=fp, fr_wheel_hz=fw, n_harmonics=1)
    for k in ("mesh1_wheel_lsb3", "mesh1_wheel_usb3", "mesh1_wheel_lsb1", "wheel_order3", "wheel_sideband_ratio"):
        assert a[k] < 1e-9, k
    assert a["mesh1_pinion_lsb1"] == pytest.approx(0.1, abs=1e-9)
    assert a["pinion_order1"] == pytest.approx(0.05, abs=1e-9)
    assert a["pinion_sideband_ratio"] == pytest.approx(np.sqrt(2) * 0.1, abs=1e-9)


def test_lines_closer_than_the_resolution_read_their_groups_amplitude():
    """Lines less than fs / n apart cannot be separated by any fit of the record: they are fitted as one and each
    reads the group's amplitude. Coincident lines (equal shaft speeds: a pinion and a wheel sideband at the same
    frequency) both read the line's 0.1 (tol 1e-9); 100 and 100.5 Hz in 0.5 s (a quarter of the 2 Hz resolution)
    read the same value for a 0.3 line at 100.5 Hz (within 2 %: fitted 0.125 resolution off its frequency). A line
    far from the others reads what the windowed DFT reads (the same normal equation; tol 1e-9, measured 1.5e-10
    from the fitted constant)."""
    fm, fr = 725.0, 25.0
    x = np.cos(2 * np.pi * fm * HALF_S) + 0.1 * np.cos(2 * np.pi * (fm - fr) * HALF_S + 0.3)
    a = spectra.mesh_sideband_amplitudes(x, FS, fm_hz=fm, fr_pinion_hz=fr, fr_wheel_hz=fr, n_harmonics=1)
    assert a["mesh1_pinion_lsb1"] == pytest.approx(0.1, abs=1e-9)
    assert a["mesh1_wheel_lsb1"] == pytest.approx(0.1, abs=1e-9)
    p = np.abs(spectra.fitted_line_phasors(0.3 * np.cos(2 * np.pi * 100.5 * HALF_S + 0.2), FS, [100.0, 100.5]))
    assert p[0] == p[1] and p[0] == pytest.approx(0.3, rel=0.02)
    y = np.cos(2 * np.pi * 1234.56 * HALF_S + 0.4) + 0.2 * np.cos(2 * np.pi * 3000.3 * HALF_S)
    assert spectra.fitted_line_phasors(y, FS, [1234.56])[0] == pytest.approx(
        spectra.line_phasors(y, FS, [1234.56])[0], abs=1e-9)
    with pytest.raises(InputError, match="freqs_hz"):
        spectra.fitted_line_phasors(y, FS, [1.0])   # within the resolution of DC
