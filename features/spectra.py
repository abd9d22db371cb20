"""Amplitude spectra and the amplitudes of named lines: mesh harmonics, their
shaft-order sidebands for both shafts, and the shaft orders themselves.

Amplitudes are window-corrected (coherent gain): a sinusoid ``a cos(2 pi f t)``
reads ``a``. Single lines are evaluated by a windowed DFT at the exact line
frequency rather than read off the nearest FFT bin, so there is no scalloping
loss when a line falls between bins (:func:`line_phasors`). The named lines of a
gear mesh, some a few bins apart, are fitted jointly by weighted least squares
(:func:`fitted_line_phasors`), so that they do not leak into each other.

References
----------
.. [1] Harris, F. J. (1978). On the use of windows for harmonic analysis with the
   discrete Fourier transform. Proceedings of the IEEE 66(1), 51-83.
.. [2] Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley,
   chapter 3 (sidebands at ``m f_m +/- k f_r`` from tooth and shaft modulation).
"""
from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.signal import get_window
from threadpoolctl import threadpool_limits

from gearpit.errors import require, require_positive

Window = Literal["hann", "boxcar", "flattop", "blackmanharris"]
WINDOWS: tuple[str, ...] = ("hann", "boxcar", "flattop", "blackmanharris")


def check_window(window: str) -> None:
    """Raise :class:`gearpit.errors.InputError` unless ``window`` is one of :data:`WINDOWS`."""
    require(window in WINDOWS, "window", window, "one of: " + ", ".join(WINDOWS))


def _window(n: int, window: str) -> np.ndarray:
    check_window(window)
    return get_window(window, n, fftbins=True)


def amplitude_spectrum(x: np.ndarray, fs_hz: float, *, window: Window = "hann") -> tuple[np.ndarray, np.ndarray]:
    """One-sided amplitude spectrum ``2 |FFT(x w)| / sum(w)``.

    Parameters
    ----------
    x : array_like, shape (n,)
        Record.
    fs_hz : float
        Sampling rate (Hz).
    window : str
        One of :data:`WINDOWS`.

    Returns
    -------
    freqs_hz, amplitude : ndarray
        Bin frequencies (Hz) and amplitudes (unit of ``x``); DC and Nyquist are
        not doubled.
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 4, "x", a.shape, "a 1-D array of >= 4 samples")
    require_positive("fs_hz", fs_hz)
    w = _window(a.size, window)
    amp = 2.0 * np.abs(np.fft.rfft(a * w)) / w.sum()
    amp[0] /= 2.0
    if a.size % 2 == 0:
        amp[-1] /= 2.0
    return np.fft.rfftfreq(a.size, 1.0 / fs_hz), amp


def line_amplitudes(x: np.ndarray, fs_hz: float, freqs_hz, *, window: Window = "hann") -> np.ndarray:
    """Amplitudes of ``x`` at arbitrary frequencies by a windowed DFT (no scalloping): ``|line_phasors|``."""
    return np.abs(line_phasors(x, fs_hz, freqs_hz, window=window))


def line_phasors(x: np.ndarray, fs_hz: float, freqs_hz, *, window: Window = "hann") -> np.ndarray:
    """Complex amplitudes of ``x`` at arbitrary frequencies by a windowed DFT: ``A cos(2 pi f t + p)`` gives
    ``A exp(i p)``.

    ``P(f) = 2 sum_n x_n w_n exp(-2 pi i f n / fs) / sum(w)``. Lines closer than
    the window's main-lobe half width (2 bins for Hann, i.e. ``2 fs / n``) leak
    into each other.

    Parameters
    ----------
    x : array_like, shape (n,)
    fs_hz : float
    freqs_hz : array_like
        Line frequencies (Hz), each in ``(0, fs_hz / 2)``.
    window : str
        One of :data:`WINDOWS`.
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 4, "x", a.shape, "a 1-D array of >= 4 samples")
    require_positive("fs_hz", fs_hz)
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    require(bool(np.all((f > 0) & (f < fs_hz / 2))), "freqs_hz", f.tolist(), f"frequencies in (0, {fs_hz / 2}) Hz")
    w = _window(a.size, window)
    xw = a * w
    n = np.arange(a.size)
    out = np.empty(f.size, dtype=complex)
    # blocks keep the complex exponential matrix small
    for i0 in range(0, f.size, 64):
        fb = f[i0:i0 + 64]
        e = np.exp(-2j * np.pi * np.outer(fb / fs_hz, n))
        out[i0:i0 + 64] = 2.0 * (e @ xw) / w.sum()
    return out


def fitted_line_phasors(x: np.ndarray, fs_hz: float, freqs_hz, *, window: Window = "hann") -> np.ndarray:
    """Complex amplitudes of ``x`` at the given frequencies, fitted jointly: ``A cos(2 pi f t + p)`` gives
    ``A exp(i p)``.

    The record is modelled as a constant plus a sinusoid at each frequency, and the model's coefficients are the
    weighted least-squares fit with the window as the weights (minimising ``sum_n w_n (x_n - model_n)^2``). A
    record made of those lines only is returned exactly, however close they are, so neighbouring named lines do not
    leak into each other as they do in a windowed DFT (:func:`line_phasors`: a Hann window's main lobe is 2 bins
    wide each side). A single line far from the others reads what that windowed DFT reads (the normal equations
    of one sinusoid are that DFT, up to its negative-frequency image), so lines not in the model (noise, unnamed
    harmonics) leak in no more than there.

    Lines closer than the record's resolution ``fs / n`` (chains of them) cannot be told apart from the record:
    they are fitted as one sinusoid at their mean frequency, and each of them reads that group's amplitude (the
    group's, not a split of it; exactly coincident lines, e.g. a pinion and a wheel order at an integer ratio,
    are the common case).

    Parameters
    ----------
    x : array_like, shape (n,)
    fs_hz : float
    freqs_hz : array_like
        Line frequencies (Hz), each in ``[fs / n, fs / 2 - fs / n]`` (a line nearer DC or Nyquist cannot be told
        from the record's mean or the alternating sequence).
    window : str
        One of :data:`WINDOWS` (the weights; "boxcar" gives ordinary least squares).

    References
    ----------
    Kay, S. M. (1993). Fundamentals of Statistical Signal Processing: Estimation Theory. Prentice Hall, section
    4.6 (the linear model: least-squares amplitudes of sinusoids of known frequencies).

    Examples
    --------
    >>> t = np.arange(6400) / 12800.0                  # 0.5 s: 2 Hz resolution
    >>> x = np.cos(2 * np.pi * 725.0 * t) + 0.01 * np.cos(2 * np.pi * 717.75 * t + 1.0)
    >>> p = fitted_line_phasors(x, 12800.0, [725.0, 717.75])
    >>> np.round(np.abs(p), 6).tolist(), round(float(np.angle(p[1])), 6)
    ([1.0, 0.01], 1.0)
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 4, "x", a.shape, "a 1-D array of >= 4 samples")
    require_positive("fs_hz", fs_hz)
    f = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    resolution = fs_hz / a.size
    require(bool(np.all((f >= resolution) & (f <= fs_hz / 2 - resolution))), "freqs_hz", f.tolist(),
            f"frequencies in [{resolution:.6g}, {fs_hz / 2 - resolution:.6g}] Hz (one resolution fs/n from DC and "
            "Nyquist)")
    w = _window(a.size, window)
    # groups of lines closer than the resolution (sorted, chained)
    order = np.argsort(f, kind="stable")
    group = np.zeros(f.size, dtype=int)
    if f.size:
        group[order] = np.concatenate(([0], np.cumsum(np.diff(f[order]) >= resolution)))
    n_groups = int(group.max()) + 1 if f.size else 0
    centre = np.array([np.unique(f[group == g]).mean() for g in range(n_groups)])
    # design matrix (rows = regressors): constant, cosines, sines; the weighted normal equations (a few ms; lines
    # at least one resolution apart keep them well conditioned: Hann, one bin apart, correlation 0.5)
    phase = np.outer(centre / fs_hz, np.arange(a.size))
    phase = 2 * np.pi * (phase - np.round(phase))       # reduced to [-pi, pi]: cos/sin as exact as the fraction
    design = np.vstack([np.ones((1, a.size)), np.cos(phase), np.sin(phase)])
    # one BLAS thread: on a loaded machine a threaded product this small waits for its threads (measured 244 ms
    # instead of 1.4 ms for 91 x 6400 on 2 busy cores)
    with threadpool_limits(1, user_api="blas"):
        coef = np.linalg.solve((design * w) @ design.T, design @ (a * w))
    phasor = coef[1:1 + n_groups] - 1j * coef[1 + n_groups:]
    return phasor[group]


def mesh_line_frequencies(*, fm_hz: float, fr_pinion_hz: float, fr_wheel_hz: float, n_harmonics: int = 3,
                          n_sidebands: int = 3, n_shaft_orders: int = 3) -> dict[str, float]:
    """Names and frequencies (Hz) of the lines read by :func:`mesh_sideband_amplitudes`.

    Names: ``mesh{m}`` at ``m fm``; ``mesh{m}_{shaft}_lsb{k}`` / ``_usb{k}`` at
    ``m fm -/+ k fr_shaft`` for ``shaft`` in (``pinion``, ``wheel``);
    ``{shaft}_order{k}`` at ``k fr_shaft``.
    """
    for name, v in (("fm_hz", fm_hz), ("fr_pinion_hz", fr_pinion_hz), ("fr_wheel_hz", fr_wheel_hz)):
        require_positive(name, v)
    for name, v in (("n_harmonics", n_harmonics), ("n_sidebands", n_sidebands), ("n_shaft_orders", n_shaft_orders)):
        require(isinstance(v, (int, np.integer)) and v >= 0, name, v, "an integer >= 0")
    lines: dict[str, float] = {}
    shafts = (("pinion", fr_pinion_hz), ("wheel", fr_wheel_hz))
    for m in range(1, n_harmonics + 1):
        lines[f"mesh{m}"] = m * fm_hz
        for shaft, fr in shafts:
            for k in range(1, n_sidebands + 1):
                lines[f"mesh{m}_{shaft}_lsb{k}"] = m * fm_hz - k * fr
                lines[f"mesh{m}_{shaft}_usb{k}"] = m * fm_hz + k * fr
    for shaft, fr in shafts:
        for k in range(1, n_shaft_orders + 1):
            lines[f"{shaft}_order{k}"] = k * fr
    return lines


def mesh_sideband_amplitudes(x: np.ndarray, fs_hz: float, *, fm_hz: float, fr_pinion_hz: float, fr_wheel_hz: float,
                             n_harmonics: int = 3, n_sidebands: int = 3, n_shaft_orders: int = 3,
                             window: Window = "hann") -> dict[str, float]:
    """Amplitudes of the mesh harmonics, their sidebands for both shafts, and the shaft orders.

    All the lines are fitted at once (:func:`fitted_line_phasors`, the window as weights): a wheel sideband a few
    bins from its mesh harmonic, or a wheel order next to a pinion order, reads its own amplitude, not the leakage
    of its neighbour. Lines closer than the resolution ``fs / n`` (e.g. a pinion and a wheel line at an integer
    tooth ratio) each read the amplitude of their group.

    Also two summaries per shaft, ``{shaft}_sideband_ratio`` =
    ``sqrt(sum of squared sideband amplitudes) / sqrt(sum of squared mesh
    harmonic amplitudes)`` over all harmonics and sidebands read.

    Parameters
    ----------
    x : array_like, shape (n,)
        Record.
    fs_hz : float
        Sampling rate (Hz).
    fm_hz : float
        Mesh frequency ``z_pinion * fr_pinion_hz`` (Hz).
    fr_pinion_hz, fr_wheel_hz : float
        Shaft frequencies (Hz).
    n_harmonics, n_sidebands, n_shaft_orders : int
        How many mesh harmonics, sidebands per side and shaft orders to read.
    window : str
        One of :data:`WINDOWS`.

    Returns
    -------
    dict
        ``name -> amplitude`` (unit of ``x``; ratios dimensionless), names as in
        :func:`mesh_line_frequencies`.
    """
    lines = mesh_line_frequencies(fm_hz=fm_hz, fr_pinion_hz=fr_pinion_hz, fr_wheel_hz=fr_wheel_hz,
                                  n_harmonics=n_harmonics, n_sidebands=n_sidebands, n_shaft_orders=n_shaft_orders)
    top = max(lines.values()) if lines else 0.0
    require(top < fs_hz / 2, "n_harmonics", n_harmonics,
            f"lines below Nyquist {fs_hz / 2} Hz (highest asked: {top:.1f} Hz)")
    amps = np.abs(fitted_line_phasors(x, fs_hz, list(lines.values()), window=window))
    out = dict(zip(lines, (float(a) for a in amps)))
    mesh_energy = sum(out[f"mesh{m}"] ** 2 for m in range(1, n_harmonics + 1))
    for shaft in ("pinion", "wheel"):
        sb = sum(v**2 for k, v in out.items() if k.startswith("mesh") and f"_{shaft}_" in k)
        out[f"{shaft}_sideband_ratio"] = float(np.sqrt(sb / mesh_energy)) if mesh_energy > 0 else float("nan")
    return out
