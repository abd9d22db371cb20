"""Envelope analysis: band-limited analytic signal, envelope spectrum, and a
spectral-kurtosis finder for the band to demodulate.

The band-pass and the Hilbert transform are one ideal FFT-domain filter: positive
frequencies inside the band doubled, everything else zeroed; the modulus of the
inverse transform is the envelope. For ``x = (1 + m cos 2 pi f_a t) cos 2 pi f_c t``
with the band covering ``f_c +/- f_a`` this returns ``1 + m cos 2 pi f_a t``
(Bedrosian's theorem), exactly when the record holds whole periods.

References
----------
.. [1] Randall, R. B., Antoni, J. (2011). Rolling element bearing diagnostics - a
   tutorial. Mechanical Systems and Signal Processing 25(2), 485-520 (envelope
   analysis, band selection).
.. [2] Antoni, J. (2006). The spectral kurtosis: a useful tool for characterising
   non-stationary signals. Mechanical Systems and Signal Processing 20(2),
   282-307 (STFT estimator ``SK(f) = <|X|^4> / <|X|^2>^2 - 2``).
.. [3] Antoni, J., Randall, R. B. (2006). The spectral kurtosis: application to the
   vibratory surveillance and diagnostics of rotating machines. Mechanical
   Systems and Signal Processing 20(2), 308-331 (kurtogram: best window length).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import stft

from features.spectra import Window, amplitude_spectrum, line_amplitudes
from gearpit.errors import require, require_positive


def _check_band(band_hz, fs_hz: float) -> tuple[float, float] | None:
    if band_hz is None:
        return None
    ok = isinstance(band_hz, (tuple, list)) and len(band_hz) == 2
    if ok:
        lo, hi = float(band_hz[0]), float(band_hz[1])
        ok = 0 <= lo < hi <= fs_hz / 2
    require(ok, "band_hz", band_hz, f"None or (lo, hi) with 0 <= lo < hi <= {fs_hz / 2} Hz")
    return lo, hi


def analytic_signal(x: np.ndarray, fs_hz: float, *, band_hz: tuple[float, float] | None = None) -> np.ndarray:
    """Analytic signal of ``x``, optionally restricted to ``band_hz = (lo, hi)`` (Hz).

    Without a band this equals :func:`scipy.signal.hilbert` (DC and Nyquist kept
    once). With a band only positive frequencies in ``[lo, hi]`` are kept (doubled).
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 4, "x", a.shape, "a 1-D array of >= 4 samples")
    require_positive("fs_hz", fs_hz)
    band = _check_band(band_hz, fs_hz)
    n = a.size
    spec = np.fft.fft(a)
    f = np.fft.fftfreq(n, 1.0 / fs_hz)
    if band is None:
        gain = np.where(f > 0, 2.0, 0.0)
        gain[0] = 1.0
        if n % 2 == 0:
            gain[n // 2] = 1.0
    else:
        gain = np.where((f >= band[0]) & (f <= band[1]) & (f > 0), 2.0, 0.0)
    return np.fft.ifft(spec * gain)


def envelope(x: np.ndarray, fs_hz: float, *, band_hz: tuple[float, float] | None = None) -> np.ndarray:
    """Envelope ``|x + i H(x)|`` of ``x`` (optionally band-passed to ``band_hz``)."""
    return np.abs(analytic_signal(x, fs_hz, band_hz=band_hz))


def envelope_spectrum(x: np.ndarray, fs_hz: float, *, band_hz: tuple[float, float] | None = None,
                      window: Window = "hann") -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum of the mean-removed envelope (see :func:`envelope`).

    A localised tooth fault modulates the mesh tone (or rings a resonance) once per
    revolution of its shaft: lines at ``k fr`` of that shaft.
    """
    e = envelope(x, fs_hz, band_hz=band_hz)
    return amplitude_spectrum(e - e.mean(), fs_hz, window=window)


def envelope_order_amplitudes(x: np.ndarray, fs_hz: float, *, fr_pinion_hz: float, fr_wheel_hz: float,
                              n_orders: int = 3, band_hz: tuple[float, float] | None = None,
                              window: Window = "hann") -> dict[str, float]:
    """Envelope-spectrum amplitudes at shaft orders ``1..n_orders`` of both shafts.

    Returns ``{"env_pinion_order1": ..., "env_wheel_order1": ...}`` (unit of ``x``).
    """
    require_positive("fr_pinion_hz", fr_pinion_hz)
    require_positive("fr_wheel_hz", fr_wheel_hz)
    require(isinstance(n_orders, (int, np.integer)) and n_orders >= 1, "n_orders", n_orders, "an integer >= 1")
    e = envelope(x, fs_hz, band_hz=band_hz)
    names, freqs = [], []
    for shaft, fr in (("pinion", fr_pinion_hz), ("wheel", fr_wheel_hz)):
        for k in range(1, n_orders + 1):
            names.append(f"env_{shaft}_order{k}")
            freqs.append(k * fr)
    amps = line_amplitudes(e - e.mean(), fs_hz, freqs, window=window)
    return dict(zip(names, (float(a) for a in amps)))


def spectral_kurtosis(x: np.ndarray, fs_hz: float, *, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """STFT estimate of the spectral kurtosis ``SK(f) = <|X(t,f)|^4> / <|X(t,f)|^2>^2 - 2``.

    Antoni (2006): 0 for stationary Gaussian noise, -1 for a stationary tone,
    large where impulsive (transient) content dominates. Hann window, 75 % overlap.
    """
    a = np.asarray(x, dtype=float)
    require(isinstance(nperseg, (int, np.integer)) and 8 <= nperseg <= a.size // 4, "nperseg", nperseg,
            f"an integer in [8, {a.size // 4}] (at least 4 segments)")
    f, _, z = stft(a, fs=fs_hz, window="hann", nperseg=nperseg, noverlap=3 * nperseg // 4, boundary=None,
                   padded=False)
    p = np.abs(z) ** 2
    m2 = p.mean(axis=1)
    m4 = (p * p).mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        sk = np.where(m2 > 0, m4 / np.where(m2 > 0, m2, 1.0) ** 2 - 2.0, np.nan)
    return f, sk


@dataclass(frozen=True)
class ResonanceBand:
    """Band chosen for envelope analysis and the spectral kurtosis that chose it."""

    band_hz: tuple[float, float]
    centre_hz: float
    spectral_kurtosis: float
    nperseg: int


def find_resonance_band(x: np.ndarray, fs_hz: float, *, npersegs=(32, 64, 128, 256),
                        min_hz: float = 0.0) -> ResonanceBand:
    """Band of maximum spectral kurtosis over several STFT window lengths (a coarse kurtogram).

    For each window length ``L`` in ``npersegs`` the STFT spectral kurtosis is
    computed; the (frequency, ``L``) pair with the largest SK wins and the band is
    its centre ``+/- fs / L`` (one bin each side), clipped to ``[min_hz, fs/2]``.
    Centres within two bins of DC or Nyquist are skipped (real-valued bins there
    have SK = 1 even for Gaussian noise). Antoni & Randall (2006) use the same criterion on a
    filter-bank (the fast kurtogram); the STFT version trades its dyadic bands
    for simplicity.

    Parameters
    ----------
    x : array_like
        Record.
    fs_hz : float
        Sampling rate (Hz).
    npersegs : sequence of int
        STFT window lengths to try (samples).
    min_hz : float
        Lowest centre frequency considered (Hz), e.g. above the mesh harmonics.
    """
    require_positive("fs_hz", fs_hz)
    require(0 <= min_hz < fs_hz / 2, "min_hz", min_hz, f"[0, {fs_hz / 2}) Hz")
    best = None
    for L in npersegs:
        f, sk = spectral_kurtosis(x, fs_hz, nperseg=int(L))
        half = fs_hz / L
        # DC and Nyquist bins are real-valued (SK = 1 for noise): keep two bins away
        ok = (f >= max(min_hz, 2 * half)) & (f <= fs_hz / 2 - 2 * half) & np.isfinite(sk)
        if not ok.any():
            continue
        i = int(np.argmax(np.where(ok, sk, -np.inf)))
        if best is None or sk[i] > best[0]:
            best = (float(sk[i]), float(f[i]), int(L), half)
    require(best is not None, "npersegs", tuple(npersegs), "window lengths leaving a band above min_hz")
    sk, fc, L, half = best
    band = (max(min_hz, fc - half), min(fs_hz / 2, fc + half))
    return ResonanceBand(band_hz=band, centre_hz=fc, spectral_kurtosis=sk, nperseg=L)
