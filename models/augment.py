"""Training-time augmentation that mimics what changes between runs of a rig.

For each record of a batch, drawn independently from the given generator:

- **phase / crop**: where the segment starts in the record (uniform fraction of
  the free room), i.e. the shaft angle at the start of the segment;
- **gain**: a sensor-sensitivity or mounting change, ``+/- gain_db`` (uniform in dB);
- **noise**: with probability ``noise_probability``, white Gaussian noise at an SNR
  drawn uniformly in ``snr_db_range`` (dB, relative to the record's power);
- **speed error**: the shaft turned at ``1 + u`` times the labelled speed, ``u``
  uniform in ``+/- speed_error`` (applied by the representation, see
  :mod:`models.representations`);
- **polarity**: with probability ``polarity_flip_probability`` the record is
  negated (an accelerometer mounted the other way round);
- **transmission path** (off by default, ``path_probability`` = 0): with
  probability ``path_probability`` the record passes through ``path_modes``
  random mounting resonances in series, each the absolute transmissibility of a
  base-excited single-degree-of-freedom oscillator (an accelerometer on a stud,
  magnet or bracket; Ewins [1]_, Harris [2]_)

      T(f) = (1 + 2 i zeta r) / (1 - r^2 + 2 i zeta r),   r = f / f_n,

  unit gain well below ``f_n``, ``sqrt(1 + 4 zeta^2) / (2 zeta)`` at ``f_n``,
  falling as ``2 zeta / r`` above. ``f_n`` is drawn uniformly in ``path_hz_range``
  (upper end clipped to 0.45 fs; an error if the lower end is above it) and
  ``zeta`` log-uniformly in ``path_damping_range``. The filtered record is scaled
  back to its own RMS (the gain draw stays the only level change, and a model
  reading the record level keeps the level it was given). Why: a housing or
  mounting resonance sits at a fixed *frequency*, so when the speed changes it
  moves in the *order* domain of the TSA and order representations; a network
  trained at low speeds sees it at other orders than a test at high speeds.
  Random resonances teach the network to ignore where the colouring sits;
- **bandwidth** (off by default, ``lowpass_probability`` = 0): with probability
  ``lowpass_probability`` the record is low-passed at a cut-off drawn uniformly
  in ``lowpass_fs_fraction_range`` times the sampling rate: a Butterworth filter
  of order ``LOWPASS_ORDER`` run forwards and backwards (zero phase, so the TSA
  waveform does not shift; digital Butterworth, so the gain is
  ``1 / (1 + (tan(pi f / fs) / tan(pi f_c / fs))^(2 LOWPASS_ORDER))``, 1/2 at
  ``f_c``), then scaled back to the record's RMS. Physically an acquisition chain
  with a lower bandwidth (anti-alias filter, sensor); in the *order* domain it is
  what a higher speed does to the TSA: orders above ``fs / 2 / f_shaft`` are
  absent, so at 1800 rpm the TSA ends at order 213 while at 600 rpm it reaches
  order 512. A network trained at low speeds never saw that cut.

Order of application: path filter, bandwidth, then gain and polarity, then noise (sensor
noise comes after the mount); the random *start* and the *speed error* are
applied by the representation. :func:`augment_batch` works on the time records
and :func:`models.train.train_cnn` calls it before the representation
(``represent``), so the TSA, the order spectra and the raw segment all see the
filtered record. The path and bandwidth draws come from the same generator
*after* every other draw (path first) and only when their probability is > 0:
with both off, a given seed gives the same batch as before they existed.

The path filter (:func:`path_filter`) is a linear convolution by FFT of the
record with a history prepended, so that the mode does not start at rest at
the record's start: the history is the record's start mirrored (odd reflection,
continuous in value and slope), ``PATH_PRE_ROLL_TAUS`` decay times
``1 / (2 pi zeta f_n)`` long (capped at the record length), and the zero-padded
tail is longer than the history, so nothing wraps round. What remains is the
mode's response to the difference between the mirrored and the true history,
which decays within a few decay times (<= 8 ms at 1 kHz / 2 %).

Per-signal normalisation in the representation removes the gain again for the
network; the gain still matters for the noise level and is kept so that
augmented records are plausible records.

The defaults are deliberately light (noise in a quarter of the records at
20-40 dB, speed error 0.2 %). Measured on the default dataset (CNN, tsa input,
experiments/RESULTS.md): light 82 % severity / 93 % teeth accuracy; none 77 % /
84 %; heavier (5-30 dB noise in half the records, 1 % speed error) 80 % / 81 %.

Path and bandwidth, measured on the datasets of the previous protocol run (train < 1200 rpm, test
>= 1200 rpm; severity / teeth accuracy, one seed): on ONE rig (rig.toml, one fixed 3.2 kHz housing path;
CNN ``tsa_level``) resonances in half the records lift the speed split from 82.4 / 84.8 % to 88.6 / 89.2 %;
on the many-rig default dataset, whose records already carry a path drawn at 2-5 kHz, they cost 3-4 points
(``tsa``: 76.5 / 88.9 % -> 73.3 / 84.9 %); the bandwidth augmentation (half the records) changes the
default speed split by +0.5 / +0.5 points, within the run-to-run spread. Hence both stay off by default
and the one-rig protocol (experiments/eval_protocol.py, ``RIG_AUGMENT``) turns the path on.

References
----------
.. [1] Ewins, D. J. (2000). Modal Testing: Theory, Practice and Application, 2nd ed.,
   Research Studies Press, sec. 2.2 (SDOF frequency response functions).
.. [2] Harris, C. M., Piersol, A. G. (2002). Harris' Shock and Vibration Handbook,
   5th ed., McGraw-Hill, ch. 2 (transmissibility of a base-excited SDOF system)
   and ch. 15 (accelerometer mounting resonance).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from scipy.signal import butter, sosfiltfilt

from gearpit.errors import InputError, require, require_range

#: history prepended by :func:`path_filter`, in decay times of the mode (e^-20 ~ 2e-9)
PATH_PRE_ROLL_TAUS = 20.0
#: highest resonance frequency drawn, as a fraction of the sampling rate
PATH_MAX_FS_FRACTION = 0.45
#: Butterworth order of the bandwidth augmentation (run forwards and backwards)
LOWPASS_ORDER = 8


@dataclass(frozen=True)
class AugmentConfig:
    """Augmentation ranges (see module docstring); ``AugmentConfig.none()`` switches all off."""

    random_start: bool = True
    gain_db: float = 3.0
    noise_probability: float = 0.25
    snr_db_range: tuple[float, float] = (20.0, 40.0)
    speed_error: float = 0.002
    polarity_flip_probability: float = 0.5
    path_probability: float = 0.0
    path_hz_range: tuple[float, float] = (1000.0, 6000.0)
    path_damping_range: tuple[float, float] = (0.02, 0.10)
    path_modes: int = 1
    lowpass_probability: float = 0.0
    lowpass_fs_fraction_range: tuple[float, float] = (0.15, 0.45)

    def __post_init__(self):
        require(isinstance(self.random_start, bool), "augment.random_start", self.random_start, "true or false")
        require_range("augment.gain_db", self.gain_db, 0.0, 20.0)
        require_range("augment.noise_probability", self.noise_probability, 0.0, 1.0)
        r = tuple(self.snr_db_range)
        require(len(r) == 2 and float(r[0]) <= float(r[1]), "augment.snr_db_range", self.snr_db_range,
                "(lo, hi) with lo <= hi (dB)")
        object.__setattr__(self, "snr_db_range", (float(r[0]), float(r[1])))
        require_range("augment.speed_error", self.speed_error, 0.0, 0.2)
        require_range("augment.polarity_flip_probability", self.polarity_flip_probability, 0.0, 1.0)
        require_range("augment.path_probability", self.path_probability, 0.0, 1.0)
        for name, lo, hi, what in (("path_hz_range", 1.0, 1e6, "Hz"), ("path_damping_range", 1e-3, 0.5, "")):
            r = getattr(self, name)
            ok = (isinstance(r, (tuple, list)) and len(r) == 2
                  and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in r))
            ok = ok and lo <= float(r[0]) <= float(r[1]) <= hi
            require(ok, f"augment.{name}", r, f"(lo, hi) with {lo:g} <= lo <= hi <= {hi:g}" + (f" ({what})" if what else ""))
            object.__setattr__(self, name, (float(r[0]), float(r[1])))
        require_range("augment.lowpass_probability", self.lowpass_probability, 0.0, 1.0)
        r = self.lowpass_fs_fraction_range
        ok = (isinstance(r, (tuple, list)) and len(r) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in r))
        require(ok and 0.01 <= float(r[0]) <= float(r[1]) < 0.5, "augment.lowpass_fs_fraction_range", r,
                "(lo, hi) with 0.01 <= lo <= hi < 0.5 (cut-off over sampling rate)")
        object.__setattr__(self, "lowpass_fs_fraction_range", (float(r[0]), float(r[1])))
        m = self.path_modes
        require(isinstance(m, (int, np.integer)) and not isinstance(m, bool) and 1 <= m <= 3, "augment.path_modes", m,
                "an integer in [1, 3] (resonances in series)")

    @classmethod
    def none(cls) -> "AugmentConfig":
        """No augmentation at all (segments start at the record's start)."""
        return cls(random_start=False, gain_db=0.0, noise_probability=0.0, speed_error=0.0,
                   polarity_flip_probability=0.0)

    @classmethod
    def from_dict(cls, values: dict) -> "AugmentConfig":
        known = {f.name for f in fields(cls)}
        for key in values:
            if key not in known:
                raise InputError(f"augment.{key}", values[key], "one of: " + ", ".join(sorted(known)))
        return cls(**values)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["snr_db_range"] = list(self.snr_db_range)
        d["path_hz_range"] = list(self.path_hz_range)
        d["path_damping_range"] = list(self.path_damping_range)
        d["lowpass_fs_fraction_range"] = list(self.lowpass_fs_fraction_range)
        return d


def mount_transmissibility(f_hz, natural_hz: float, damping_ratio: float) -> np.ndarray:
    """Absolute transmissibility ``T(f)`` of a base-excited SDOF oscillator (complex; module docstring).
    Arguments broadcast against each other."""
    r = np.asarray(f_hz, dtype=float) / np.asarray(natural_hz, dtype=float)
    c = 2j * np.asarray(damping_ratio, dtype=float) * r
    return (1.0 + c) / (1.0 - r * r + c)


def path_filter(x: np.ndarray, fs_hz: float, natural_hz, damping_ratio) -> np.ndarray:
    """Records ``x`` (n, n_samples) through SDOF mounting resonances in series.

    ``natural_hz`` and ``damping_ratio``: scalars (one mode for every record) or arrays (n, modes).
    The history and the zero padding are described in the module docstring; no RMS rescaling here.
    """
    a = np.atleast_2d(np.asarray(x, dtype=np.float64))
    n, ns = a.shape
    fn = np.asarray(natural_hz, dtype=float)
    ze = np.asarray(damping_ratio, dtype=float)
    fn = np.full((n, 1), float(fn)) if fn.ndim == 0 else fn
    ze = np.full(fn.shape, float(ze)) if ze.ndim == 0 else ze
    require(fn.ndim == 2 and fn.shape[0] == n and ze.shape == fn.shape, "natural_hz", fn.shape,
            f"scalars or two arrays of shape ({n}, modes)")
    require(bool(np.all((fn > 0) & (fn < fs_hz / 2))), "natural_hz", float(fn.max()),
            f"resonance frequencies in (0, {fs_hz / 2:g}) Hz (below Nyquist)")
    require(bool(np.all(ze > 0)), "damping_ratio", float(ze.min()), "damping ratios > 0")
    tau_s = 1.0 / (2 * np.pi * float(np.min(ze * fn)))
    n_pre = int(min(ns - 1, np.ceil(PATH_PRE_ROLL_TAUS * tau_s * fs_hz)))
    pre = 2.0 * a[:, :1] - a[:, n_pre:0:-1]                                 # odd reflection of the start
    y = np.concatenate([pre, a], axis=1)
    m = 1 << int(np.ceil(np.log2(y.shape[1] + n_pre + 1)))                  # zero tail > history: no wrap
    f = np.fft.rfftfreq(m, 1.0 / fs_hz)[None, :]
    h = np.ones((n, f.size), dtype=complex)
    for j in range(fn.shape[1]):
        h *= mount_transmissibility(f, fn[:, j:j + 1], ze[:, j:j + 1])
    return np.fft.irfft(np.fft.rfft(y, n=m, axis=1) * h, n=m, axis=1)[:, n_pre:n_pre + ns]


def lowpass_filter(x: np.ndarray, cutoff_fs_fraction: float) -> np.ndarray:
    """Records ``x`` (n, n_samples) low-passed at ``cutoff_fs_fraction`` x fs: Butterworth of order
    ``LOWPASS_ORDER``, forwards and backwards (zero phase, gain 1/2 at the cut-off); no RMS rescaling."""
    require(0 < cutoff_fs_fraction < 0.5, "cutoff_fs_fraction", cutoff_fs_fraction, "a number in (0, 0.5)")
    sos = butter(LOWPASS_ORDER, 2.0 * cutoff_fs_fraction, output="sos")
    return sosfiltfilt(sos, np.atleast_2d(np.asarray(x, dtype=np.float64)), axis=1)


def _keep_rms(src: np.ndarray, filt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r_in, r_out = np.std(src, axis=1), np.std(filt, axis=1)
    s = np.where(r_out > 0, r_in / np.where(r_out > 0, r_out, 1.0), 1.0)
    return filt * s[:, None], s


def augment_batch(x: np.ndarray, config: AugmentConfig, rng: np.random.Generator, *, fs_hz: float | None = None,
                  info: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Augmented copy of the records ``x`` (n, n_samples), segment starts and speed factors.

    ``fs_hz`` (the records' sampling rate) is needed when ``config.path_probability > 0``.
    ``info``, if given, receives the path draws: ``path_applied`` (n,) bool, ``path_hz`` and
    ``path_damping`` (n, path_modes) (drawn for every record, used where applied), ``path_rms_scale`` (n,);
    and the bandwidth draws: ``lowpass_applied`` (n,) bool, ``lowpass_fs_fraction`` (n,).

    Returns
    -------
    records : ndarray, shape (n, n_samples), float32
    starts : ndarray, shape (n,)
        Segment start, fraction of the free room.
    speed_factors : ndarray, shape (n,)
    """
    a = np.asarray(x, dtype=np.float64)
    n = a.shape[0]
    # draws in the order they had before the path existed (same seed, same batch with the path off)
    starts = rng.uniform(0.0, 1.0, n) if config.random_start else np.zeros(n)
    gain = 10.0 ** (rng.uniform(-config.gain_db, config.gain_db, n) / 20.0)
    sign = np.where(rng.uniform(size=n) < config.polarity_flip_probability, -1.0, 1.0)
    noisy = rng.uniform(size=n) < config.noise_probability
    snr = rng.uniform(config.snr_db_range[0], config.snr_db_range[1], n)
    white = rng.standard_normal((int(noisy.sum()), a.shape[1])) if noisy.any() else None
    speed = 1.0 + rng.uniform(-config.speed_error, config.speed_error, n)
    if config.path_probability > 0:
        require(fs_hz is not None and float(fs_hz) > 0, "fs_hz", fs_hz,
                "the sampling rate (augmentation with a transmission path)")
        fs = float(fs_hz)
        lo, hi = config.path_hz_range
        hi = min(hi, PATH_MAX_FS_FRACTION * fs)
        require(lo <= hi, "augment.path_hz_range", config.path_hz_range,
                f"a lower end <= {PATH_MAX_FS_FRACTION:g} fs = {PATH_MAX_FS_FRACTION * fs:g} Hz at fs {fs:g} Hz")
        applied = rng.uniform(size=n) < config.path_probability
        k = config.path_modes
        f_draw = rng.uniform(lo, hi, (n, k))
        z_lo, z_hi = np.log(config.path_damping_range)
        z_draw = np.exp(rng.uniform(z_lo, z_hi, (n, k)))
        scale = np.ones(n)
        if applied.any():
            src = a[applied]
            a = a.copy()
            a[applied], scale[applied] = _keep_rms(src, path_filter(src, fs, f_draw[applied], z_draw[applied]))
        if info is not None:
            info.update(path_applied=applied, path_hz=f_draw, path_damping=z_draw, path_rms_scale=scale)
    if config.lowpass_probability > 0:
        low = rng.uniform(size=n) < config.lowpass_probability
        cut = rng.uniform(*config.lowpass_fs_fraction_range, n)
        if low.any():
            a = a.copy() if a is x else a
            for i in np.nonzero(low)[0]:
                a[i:i + 1] = _keep_rms(a[i:i + 1], lowpass_filter(a[i:i + 1], float(cut[i])))[0]
        if info is not None:
            info.update(lowpass_applied=low, lowpass_fs_fraction=cut)
    out = a * (gain * sign)[:, None]
    if white is not None:
        power = np.mean(out[noisy] ** 2, axis=1)
        std = np.sqrt(power / 10.0 ** (snr[noisy] / 10.0))
        out[noisy] += std[:, None] * white
    return out.astype(np.float32), starts, speed
