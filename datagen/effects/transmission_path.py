"""Transmission path: bearing force -> housing mode -> housing acceleration (hook 6).

Each bearing housing is a single-degree-of-freedom oscillator (mass ``m_h``,
natural frequency ``f_h``, damping ratio ``zeta_h``) driven by the force that
its bearing transmits; the sensor reads the housing acceleration

    A(f) = -w^2 / (k_h - w^2 m_h + i w c_h) * F_bearing(f),  w = 2 pi f,

with ``k_h = m_h (2 pi f_h)^2`` and ``c_h = 2 zeta_h sqrt(k_h m_h)``.

A simulated record is a steady state but in general not a whole number of its
periods, so filtering it circularly (one FFT over the record) joins its end to
its start: the jump excites the housing mode and rings through the first
milliseconds (measured on a 1 s stretch of a simulated steady state: 17 % RMS
error over the first 20 ms at 3 kHz / 5 % damping). Instead the force's mean is
removed (``A(0) = 0``), a history of ``PRE_ROLL_TAUS`` housing decay times
``1 / (zeta_h 2 pi f_h)`` is prepended - the stretch of the record that ends
where the record best repeats its own start - the result is convolved linearly
(zero-padded FFT, the mode starting at rest) and the history dropped. What remains
is the mode's response to the mismatch between that history and the true one:
none for a periodic steady state, whose history is the stretch one period back
(found in the record itself, :func:`_history`); for a record that does not
repeat, a transient that decays within a few ``1 / (zeta_h 2 pi f_h)`` (about
1 ms at 3 kHz / 5 %). A record shorter than three histories (a lightly damped
low mode: 0.1 % at 127 Hz decays over 1.2 s) gets a history read backwards
periodically at its best self-repeat (:func:`_tiled_history`); filtering it
circularly instead, as before stop 55, left a ring at the mode worth 24 % of
the RMS on a 7.4 s record of a 12 Hz comb, and the attribution fitted that
ring to a real recording's low shaft orders.

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring, sec. 2.2 (transfer path as a modal filter).
Ewins, D. J. (2000). Modal Testing, ch. 2 (SDOF accelerance).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, Fit, register

#: (bearing force channel, acceleration channel it feeds)
PATHS = (("force_bearing_pinion_loa_n", "acc_pinion_loa_m_s2"),
         ("force_bearing_wheel_loa_n", "acc_wheel_loa_m_s2"),
         ("force_bearing_pinion_axial_n", "acc_pinion_axial_m_s2"),
         ("force_bearing_wheel_axial_n", "acc_wheel_axial_m_s2"))


#: history prepended before filtering, in housing decay times (e^-20 ~ 2e-9 of a start-up transient left)
PRE_ROLL_TAUS = 20.0
#: the history of :func:`_tiled_history`, in decay times (e^-10 ~ 5e-5 of the start-up transient left, under the
#: history's own sub-sample error; it costs an FFT of the history's length: 0.2 s at 20 kHz for 50 Hz / 0.1 %)
TILED_PRE_ROLL_TAUS = 10.0
#: a record shorter than three histories repeats itself when the best repeat's squared mismatch is below this
#: fraction of the window's energy (:func:`_tiled_history`)
REPEAT_TOLERANCE = 1e-2


def housing_response(force_n: np.ndarray, fs_hz: float, mass_kg: float, natural_hz: float,
                     damping_ratio: float) -> np.ndarray:
    """Housing acceleration (m/s^2) of a steady-state bearing-force record (module docstring)."""
    x = np.asarray(force_n, dtype=float)
    n = x.size
    if n < 2:
        return np.zeros_like(x)
    x = x - x.mean()
    tau_s = 1.0 / (damping_ratio * 2 * np.pi * natural_hz)
    n_pre = int(np.ceil(PRE_ROLL_TAUS * tau_s * fs_hz))
    if n < 24:                     # nothing to find a repeat in: circular (exact for whole periods)
        f = np.fft.rfftfreq(n, 1.0 / fs_hz)
        return np.fft.irfft(np.fft.rfft(x) * housing_accelerance(f, mass_kg, natural_hz, damping_ratio), n=n)
    if n < 3 * max(n_pre, 8):      # a decay longer than a third of the record: a periodic history, half as long
        n_pre = int(np.ceil(TILED_PRE_ROLL_TAUS * tau_s * fs_hz))
        history = _tiled_history(x, n_pre)
    else:
        history = _history(x, n_pre)
    y = np.concatenate([history, x])
    m = 1 << int(np.ceil(np.log2(y.size + n_pre)))     # zero tail >= the history: no wrap into the record
    h = housing_accelerance(np.fft.rfftfreq(m, 1.0 / fs_hz), mass_kg, natural_hz, damping_ratio)
    return np.fft.irfft(np.fft.rfft(y, n=m) * h, n=m)[n_pre:n_pre + n]


def _history(x: np.ndarray, n_pre: int) -> np.ndarray:
    """``n_pre`` samples to put before ``x``: the stretch of ``x`` that ends where ``x`` repeats its own start
    best (least squares over a window of ``n_pre`` samples, found by FFT cross-correlation): one period back
    for a periodic steady state. Needs ``x.size >= 3 n_pre``."""
    j, _ = _repeat_lag(x, max(n_pre, 8), n_pre + 1)       # a whole history before j, and j clear of 0
    return x[j - n_pre:j]


def _repeat_lag(x: np.ndarray, w: int, lo: int) -> int:
    """The lag ``j >= lo`` at which ``x[j:j + w]`` matches ``x[:w]`` best (least squares, FFT cross-correlation),
    and the squared mismatch at every lag."""
    n = x.size
    head = x[:w]
    m = 1 << int(np.ceil(np.log2(2 * n)))
    cross = np.fft.irfft(np.fft.rfft(x, m) * np.conj(np.fft.rfft(head, m)), m)[:n - w + 1]   # sum x[j+i] head[i]
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])
    energy = c2[w:n + 1] - c2[:n - w + 1]                                                  # sum x[j+i]^2
    err = energy - 2 * cross + np.dot(head, head)
    return lo + int(np.argmin(err[lo:])), err


def _tiled_history(x: np.ndarray, n_pre: int) -> np.ndarray:
    """``n_pre`` samples to put before ``x`` when the record is shorter than three of them (a decay time longer
    than a third of the record): the record read backwards periodically with its best self-repeat ``j``
    (:func:`_repeat_lag`, a window of a third of the record), ``x[m mod j]`` for ``m = -n_pre .. -1``. For a
    periodic steady state whose period is not a whole number of samples each repeat is off by under a sample,
    a phase error of ``2 pi f / fs`` per repeat that matters only where the history matters, near the mode,
    at a low frequency when the decay is this long. Measured (``tests/test_effects_transmission_path.py``): a
    12 Hz line comb through a 127 Hz mode with 0.1 % damping, 7.4 s at 12.9 kHz, is filtered to 4e-3 of the RMS
    of its exact steady state, against 0.24 with the circular filter used before. A record that does not repeat
    within :data:`REPEAT_TOLERANCE` of its start's energy is read as one period (the circular filter)."""
    n = x.size
    w = max(n // 3, 8)
    j, err = _repeat_lag(x, w, max(n // 8, 1))
    if err[j] > REPEAT_TOLERANCE * max(float(np.dot(x[:w], x[:w])), 1e-300):
        j = n                      # no repeat within the record: read it as one period (the circular filter)
    return x[np.arange(-n_pre, 0) % j]


def housing_accelerance(f_hz: np.ndarray, mass_kg: float, natural_hz: float, damping_ratio: float) -> np.ndarray:
    """Accelerance A/F (1/kg) of the SDOF housing at frequencies ``f_hz``."""
    w = 2 * np.pi * np.asarray(f_hz, dtype=float)
    k = mass_kg * (2 * np.pi * natural_hz) ** 2
    c = 2 * damping_ratio * np.sqrt(k * mass_kg)
    return -w**2 / (k - w**2 * mass_kg + 1j * w * c)


@register
@dataclass(frozen=True)
class TransmissionPath(Effect):
    """Housing resonance between bearing force and accelerometer.

    Parameters
    ----------
    housing_mass_kg : float
        Modal mass of the housing at the sensor (kg).
    housing_frequency_hz : float
        Housing natural frequency (Hz).
    housing_damping_ratio : float
        Housing modal damping ratio (-).
    """

    name = "transmission_path"
    signature = "amplifies the band around the housing resonance; mesh harmonics and sidebands there grow"
    #: the housing mass only scales the level, which the sensor-gain fit absorbs: not fitted
    fit_parameters = (Fit("housing_frequency_hz", scale="log"), Fit("housing_damping_ratio", scale="log"))
    housing_mass_kg: float = field(default=5.0, metadata={"unit": "kg", "bounds": (0.1, 500.0)})
    housing_frequency_hz: float = field(default=3000.0, metadata={"unit": "Hz", "bounds": (50.0, 50000.0)})
    housing_damping_ratio: float = field(default=0.05, metadata={"unit": "-", "bounds": (0.001, 0.5)})

    def output_path(self, channels, fs_hz, ctx):
        out = dict(channels)
        for force_key, acc_key in PATHS:
            if force_key not in channels:
                continue
            out[acc_key] = housing_response(channels[force_key], fs_hz, self.housing_mass_kg,
                                            self.housing_frequency_hz, self.housing_damping_ratio)
        return out

    def channels_read(self, wanted):
        """A housing acceleration is made from its bearing force alone (a solver channel exists with its force:
        the axial pair of each on helical pairs only); the other channels pass."""
        return frozenset(k for k in wanted if k not in {a for _, a in PATHS}) | {f for f, a in PATHS if a in wanted}
