"""Input speed fluctuation: the pinion reference speed modulated sinusoidally (hook 5).

    n(t) = n0 (1 + a sin(2 pi f_s t + phi)),   f_s = frequency_hz + order * n0 / 60,

i.e. the fluctuation is given in Hz, as an order of the pinion shaft, or both
(their sum; set the other to 0). ``n(t)`` is the *reference* of the speed
controller of :mod:`datagen.lumped_model` (a PI loop acting on the angle
error, ~5 Hz bandwidth by default): well below the loop bandwidth the pinion
follows it, above it the actual fluctuation is smaller (0.58 % for a 1 %
reference at 12.5 Hz on ``spur-gds``; the ``speed_pinion_rpm`` channel shows
it). The mesh phase is modulated: with ``a`` the actual speed amplitude, the
mesh angle ``z1 theta(t)`` swings by ``beta = a f_m / f_s`` rad and every mesh
harmonic ``k f_m`` spreads into sidebands ``k f_m +/- j f_s`` with Bessel
amplitudes ``J_j(k beta)`` (frequency modulation; matched within 1 % in the
tests). The angular acceleration also drives the drive-train inertias at ``f_s``.

Signature (checked in ``tests/test_effects_signatures.py``)

===========================  =====================================================
line                         change
===========================  =====================================================
``k f_m +/- f_s``            up (FM sidebands, ratio to ``k f_m`` ~ J_1(k beta) / J_0(k beta))
``k f_m``                    down by the factor J_0(k beta) (energy moves to sidebands)
===========================  =====================================================

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley (amplitude and frequency
    modulation of gear-mesh tones; Bessel sidebands).
McFadden, P. D., Smith, J. D. (1985). Proc. Inst. Mech. Eng. C 199(1), 65-70 (combined AM/FM sidebands).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, Fit, register
from gearpit.errors import InputError


def fluctuation_frequency_hz(frequency_hz: float, order: float, speed_rpm: float) -> float:
    """``frequency_hz + order * speed_rpm / 60`` (Hz): a fluctuation in Hz, in pinion orders, or both."""
    return frequency_hz + order * speed_rpm / 60.0


def check_frequency(effect) -> None:
    """Raise unless the effect's ``frequency_hz`` or ``order`` is > 0 (a zero frequency is a constant offset)."""
    if effect.frequency_hz <= 0 and effect.order <= 0:
        raise InputError(f"effects.{effect.name}.frequency_hz", effect.frequency_hz,
                         "> 0, or order > 0 (the fluctuation frequency is frequency_hz + order * pinion speed)")


def modulation(effect, t_s, ctx) -> np.ndarray:
    """``1 + a sin(2 pi f t + phi)`` of a fluctuation effect (fields amplitude_fraction, frequency_hz, order, phase_rad)."""
    f = fluctuation_frequency_hz(effect.frequency_hz, effect.order, ctx.speed_rpm)
    return 1.0 + effect.amplitude_fraction * np.sin(2.0 * np.pi * f * np.asarray(t_s, dtype=float) + effect.phase_rad)


@register
@dataclass(frozen=True)
class SpeedFluctuation(Effect):
    """Sinusoidal fluctuation of the pinion reference speed (module docstring).

    Parameters
    ----------
    amplitude_fraction : float
        Speed amplitude a relative to the nominal speed (-).
    frequency_hz : float
        Fluctuation frequency part given in Hz (Hz).
    order : float
        Fluctuation frequency part given in pinion shaft orders (-).
    phase_rad : float
        Phase phi at t = 0 (rad).
    """

    name = "speed_fluctuation"
    signature = "FM sidebands k*fm +/- j*f_s around mesh harmonics at the fluctuation frequency f_s; k*fm lines drop"
    #: frequency first: it is seeded from the lines the measurement shows (compare.fitspace.frequency_seeds)
    fit_parameters = ("frequency_hz", Fit("amplitude_fraction", scale="log"))
    amplitude_fraction: float = field(default=0.01, metadata={"unit": "-", "bounds": (0.0, 0.2)})
    frequency_hz: float = field(default=10.0, metadata={"unit": "Hz", "bounds": (0.0, 1000.0)})
    order: float = field(default=0.0, metadata={"unit": "-", "bounds": (0.0, 50.0)})
    phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-math.pi, math.pi)})

    def __post_init__(self):
        super().__post_init__()
        check_frequency(self)

    def operating_point(self, t_s, speed_rpm, torque_nm, ctx):
        return np.asarray(speed_rpm, dtype=float) * modulation(self, t_s, ctx), torque_nm


__all__ = ["SpeedFluctuation", "fluctuation_frequency_hz", "check_frequency", "modulation"]
