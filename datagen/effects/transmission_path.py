"""Transmission path: bearing force -> housing mode -> housing acceleration (hook 6).

Each bearing housing is a single-degree-of-freedom oscillator (mass ``m_h``,
natural frequency ``f_h``, damping ratio ``zeta_h``) driven by the force that
its bearing transmits; the sensor reads the housing acceleration

    A(f) = -w^2 / (k_h - w^2 m_h + i w c_h) * F_bearing(f),  w = 2 pi f,

with ``k_h = m_h (2 pi f_h)^2`` and ``c_h = 2 zeta_h sqrt(k_h m_h)``. Applied
in the frequency domain over the whole (steady-state) record, i.e. circularly.

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
            x = channels[force_key]
            h = housing_accelerance(np.fft.rfftfreq(len(x), 1.0 / fs_hz), self.housing_mass_kg,
                                    self.housing_frequency_hz, self.housing_damping_ratio)
            out[acc_key] = np.fft.irfft(np.fft.rfft(x) * h, n=len(x))
        return out
