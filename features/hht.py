"""Hilbert-Huang transform: EMD / EEMD / CEEMDAN (PyEMD), IMF selection,
instantaneous amplitude and frequency, Hilbert spectrum and the energy index E(t).

Decompositions run serially inside one signal (``parallel=False`` in PyEMD: its
process pool copies the noise generator into every worker, so trials would share
noise, and parallelism belongs one level up, over signals). EEMD and CEEMDAN noise
comes from PyEMD's own ``RandomState`` seeded with ``seed`` through
``noise_seed``: same seed, same IMFs.

The Hilbert spectrum ``H(f, t)`` puts each IMF's instantaneous amplitude
``a_j(t)`` in the frequency bin of its instantaneous frequency ``f_j(t)``; IMFs
meeting in one bin add in energy, so ``sum_f H(f, t)^2 = sum_j a_j(t)^2``. The
spur paper's energy index ``E(t) = integral H(w, t)^2 dw`` is taken as that sum
over bins (unit bin weight), i.e. the instantaneous energy ``a(t)^2`` of the
selected IMF - independent of the binning. A pure tone of amplitude ``A`` gives
``E(t) = A^2``, constant.

References
----------
.. [1] Huang, N. E. et al. (1998). The empirical mode decomposition and the Hilbert
   spectrum for nonlinear and non-stationary time series analysis. Proc. R. Soc.
   Lond. A 454, 903-995.
.. [2] Wu, Z., Huang, N. E. (2009). Ensemble empirical mode decomposition: a
   noise-assisted data analysis method. Advances in Adaptive Data Analysis 1(1),
   1-41 (noise std 0.2 of the signal std, 100 trials).
.. [3] Torres, M. E., Colominas, M. A., Schlotthauer, G., Flandrin, P. (2011). A
   complete ensemble empirical mode decomposition with adaptive noise. ICASSP
   2011, 4144-4147.
.. [4] Laszuk, D. (2017). Python implementation of empirical mode decomposition
   algorithm. https://github.com/laszukdawid/PyEMD (package ``EMD-signal``).
.. [5] The spur paper: dynamic model of a spur pair with image-based pitting,
   HHT energy spectrum, IMF6 statistics and energy index E(t) (seed 000 in
   /work/shared/seeds).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from PyEMD import CEEMDAN, EEMD, EMD

from features.envelope import analytic_signal
from features.statistics import kurtosis
from gearpit.errors import require, require_positive

Method = Literal["emd", "eemd", "ceemdan"]
METHODS: tuple[str, ...] = ("emd", "eemd", "ceemdan")
Criterion = Literal["mesh_band_energy", "envelope_kurtosis", "fixed"]
CRITERIA: tuple[str, ...] = ("mesh_band_energy", "envelope_kurtosis", "fixed")


@dataclass(frozen=True)
class Decomposition:
    """IMFs (rows, highest frequency first) and the residue; ``imfs.sum(0) + residue == x``."""

    imfs: np.ndarray
    residue: np.ndarray

    @property
    def n_imfs(self) -> int:
        return int(self.imfs.shape[0])


def _n_extrema(y: np.ndarray) -> int:
    d = np.diff(y)
    return int(np.count_nonzero(d[:-1] * d[1:] < 0))


def decompose(x: np.ndarray, *, method: Method = "emd", trials: int = 100, noise_std_ratio: float = 0.2,
              seed: int = 0, max_imf: int = -1) -> Decomposition:
    """Empirical mode decomposition of one record.

    Parameters
    ----------
    x : array_like, shape (n,)
        Record.
    method : {"emd", "eemd", "ceemdan"}
        Plain EMD (Huang 1998), ensemble EMD (Wu & Huang 2009) or complete EEMD
        with adaptive noise (Torres et al. 2011), all from PyEMD.
    trials : int
        Ensemble size (EEMD, CEEMDAN).
    noise_std_ratio : float
        Added-noise standard deviation over the record's standard deviation
        (EEMD: converted to PyEMD's range-relative ``noise_width``; CEEMDAN: its
        ``epsilon``, with the noise modes scaled to unit first-mode std).
    seed : int
        Seed of the added noise (EEMD, CEEMDAN); ignored by EMD, which is deterministic.
    max_imf : int
        Maximum number of IMFs, -1 for no limit.

    Returns
    -------
    Decomposition
        No IMF at all (``imfs`` of shape ``(0, n)``, the record its own residue) for a constant record, or one
        EMD finds no oscillation in (fewer than three extrema). An ensemble's last row is moved into the residue
        when it has fewer than
        three extrema (a trend, not an oscillation). The EEMD residue also holds
        the ensemble mean of the added noise (std about
        ``noise_std_ratio * std(x) / sqrt(trials)``). EMD uses PyEMD's default
        stopping criteria (cubic splines, ``std_thr`` 0.2, ``energy_ratio_thr`` 0.2).
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 16, "x", a.shape, "a 1-D array of >= 16 samples")
    require(bool(np.all(np.isfinite(a))), "x", "non-finite values", "finite samples only")
    require(method in METHODS, "method", method, "one of: " + ", ".join(METHODS))
    require(isinstance(trials, (int, np.integer)) and trials >= 1, "trials", trials, "an integer >= 1")
    require_positive("noise_std_ratio", noise_std_ratio)
    require(isinstance(seed, (int, np.integer)) and 0 <= seed < 2**32, "seed", seed, "an integer in [0, 2**32)")
    require(isinstance(max_imf, (int, np.integer)) and (max_imf == -1 or max_imf >= 1), "max_imf", max_imf,
            "-1 or an integer >= 1")
    if np.ptp(a) == 0:      # nothing to decompose (and CEEMDAN would divide by the record's zero std)
        return Decomposition(imfs=np.zeros((0, a.size)), residue=a.copy())
    if method == "emd":
        emd = EMD()
        emd.emd(a, max_imf=max_imf)
        imfs, _ = emd.get_imfs_and_residue()
    elif method == "eemd":
        span = float(np.ptp(a))
        width = noise_std_ratio * float(np.std(a)) / span if span > 0 else noise_std_ratio
        eemd = EEMD(trials=int(trials), noise_width=width, parallel=False)
        eemd.noise_seed(int(seed))
        imfs = eemd.eemd(a, max_imf=max_imf)
    else:
        ceemdan = CEEMDAN(trials=int(trials), epsilon=noise_std_ratio, parallel=False)
        ceemdan.noise_seed(int(seed))
        imfs = ceemdan.ceemdan(a, max_imf=max_imf)
    imfs = np.asarray(imfs, dtype=float)
    imfs = np.atleast_2d(imfs) if imfs.size else np.zeros((0, a.size))
    if method != "emd" and imfs.shape[0] > 1 and _n_extrema(imfs[-1]) < 3:
        imfs = imfs[:-1]
    return Decomposition(imfs=imfs, residue=a - imfs.sum(axis=0))


def instantaneous_amplitude_frequency(imf: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Instantaneous amplitude ``a(t) = |z(t)|`` and frequency ``f(t)`` (Hz) of one IMF.

    ``z`` is the analytic signal (:func:`scipy.signal.hilbert` equivalent);
    ``f`` is the phase derivative, the mean of the backward and forward phase
    steps ``angle(z[n+1] conj(z[n]))`` (one-sided at the ends), which needs no
    unwrapping and is unambiguous up to ``fs / 2``.
    """
    require_positive("fs_hz", fs_hz)
    z = analytic_signal(np.asarray(imf, dtype=float), fs_hz)
    amp = np.abs(z)
    step = np.angle(z[1:] * np.conj(z[:-1])) * fs_hz / (2 * np.pi)
    f = np.empty(z.size)
    f[1:-1] = 0.5 * (step[1:] + step[:-1])
    f[0] = step[0]
    f[-1] = step[-1]
    return amp, f


@dataclass(frozen=True)
class HilbertSpectrum:
    """``amplitude[k, t]`` = H at frequency bin ``k`` (edges ``freq_edges_hz``) and sample ``t``."""

    amplitude: np.ndarray
    freq_edges_hz: np.ndarray
    fs_hz: float


def hilbert_spectrum(imfs: np.ndarray, fs_hz: float, *, n_freq_bins: int = 128,
                     freq_range_hz: tuple[float, float] | None = None) -> HilbertSpectrum:
    """Hilbert spectrum ``H(f, t)`` of one or more IMFs (Huang et al. 1998).

    Instantaneous frequencies outside ``freq_range_hz`` (default ``[0, fs/2]``)
    are put in the first or last bin, so no energy is lost.
    """
    m = np.atleast_2d(np.asarray(imfs, dtype=float))
    require_positive("fs_hz", fs_hz)
    require(isinstance(n_freq_bins, (int, np.integer)) and n_freq_bins >= 1, "n_freq_bins", n_freq_bins,
            "an integer >= 1")
    lo, hi = (0.0, fs_hz / 2) if freq_range_hz is None else (float(freq_range_hz[0]), float(freq_range_hz[1]))
    require(0 <= lo < hi, "freq_range_hz", freq_range_hz, "(lo, hi) with 0 <= lo < hi")
    edges = np.linspace(lo, hi, n_freq_bins + 1)
    energy = np.zeros((n_freq_bins, m.shape[1]))
    cols = np.arange(m.shape[1])
    for imf in m:
        a, f = instantaneous_amplitude_frequency(imf, fs_hz)
        k = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, n_freq_bins - 1)
        np.add.at(energy, (k, cols), a * a)
    return HilbertSpectrum(amplitude=np.sqrt(energy), freq_edges_hz=edges, fs_hz=float(fs_hz))


def energy_index(spectrum: HilbertSpectrum) -> np.ndarray:
    """Energy index ``E(t) = sum_f H(f, t)^2`` (the spur paper's ``integral H^2 dw``, unit bin weight).

    Unit: square of the signal unit.
    """
    return np.sum(spectrum.amplitude**2, axis=0)


@dataclass(frozen=True)
class ImfSelection:
    """Chosen IMF (0-based ``index``) and the criterion's score for every IMF."""

    index: int
    scores: np.ndarray
    criterion: str


def select_imf(imfs: np.ndarray, fs_hz: float, *, criterion: Criterion = "mesh_band_energy",
               fm_hz: float | None = None, imf_number: int = 6) -> ImfSelection:
    """Pick the most fault-sensitive IMF by a stated criterion.

    - ``"mesh_band_energy"`` (default): the IMF with the largest energy in the band
      ``[fm, 2 fm]`` of its periodogram. The spur paper picked its IMF6 because its
      instantaneous frequency moved between ``fm`` and ``2 fm``, the band the
      pitting changed most; this picks the IMF holding that band whatever its
      number (the number depends on the sampling rate and the noise).
    - ``"envelope_kurtosis"``: the IMF whose Hilbert envelope has the largest
      kurtosis (most impulsive).
    - ``"fixed"``: IMF number ``imf_number`` (1-based as in the paper, IMF6 ->
      6); the last IMF if there are fewer.

    A decomposition without IMFs (:func:`decompose` of a constant record) has nothing to pick: an
    :class:`~gearpit.errors.InputError`.
    """
    m = np.asarray(imfs, dtype=float)
    require(m.ndim in (1, 2) and m.size > 0, "imfs", m.shape,
            "at least one IMF (a decomposition of a record with >= 3 extrema)")
    m = np.atleast_2d(m)
    require(criterion in CRITERIA, "criterion", criterion, "one of: " + ", ".join(CRITERIA))
    require_positive("fs_hz", fs_hz)
    if criterion == "fixed":
        require(isinstance(imf_number, (int, np.integer)) and imf_number >= 1, "imf_number", imf_number,
                "an integer >= 1")
        idx = min(int(imf_number), m.shape[0]) - 1
        scores = np.zeros(m.shape[0])
        scores[idx] = 1.0
        return ImfSelection(idx, scores, criterion)
    if criterion == "mesh_band_energy":
        require(fm_hz is not None and fm_hz > 0 and 2 * fm_hz <= fs_hz / 2, "fm_hz", fm_hz,
                f"a mesh frequency with 2 fm <= {fs_hz / 2} Hz")
        f = np.fft.rfftfreq(m.shape[1], 1.0 / fs_hz)
        band = (f >= fm_hz) & (f <= 2 * fm_hz)
        scores = np.sum(np.abs(np.fft.rfft(m, axis=1)[:, band]) ** 2, axis=1)
    else:
        scores = np.array([float(kurtosis(np.abs(analytic_signal(imf, fs_hz)))) for imf in m])
        scores = np.nan_to_num(scores, nan=-np.inf)
    return ImfSelection(int(np.argmax(scores)), scores, criterion)
