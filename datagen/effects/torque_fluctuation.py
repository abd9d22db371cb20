"""Load torque ripple: the load (brake) torque modulated sinusoidally (hook 5).

    T(t) = T0 (1 + a sin(2 pi f_t t + phi)),   f_t = frequency_hz + order * n0 / 60,

with ``T0`` the nominal pinion torque (the brake carries ``T z2 / z1``) and the
frequency given in Hz, in pinion shaft orders, or both (their sum). The motor
torque stays at its nominal value (the speed controller reacts to the angle
error), so the ripple passes through the mesh: the mesh force, and with it the
bearing forces, carry a line at ``f_t`` (amplified or attenuated by the
drive-train torsion modes near ``f_t``) and the mesh tone is amplitude
modulated (the loaded transmission error follows the load): sidebands
``k f_m +/- f_t``.

Signature (checked in ``tests/test_effects_signatures.py``)

===========================  =====================================================
line                         change
===========================  =====================================================
``f_t`` (and harmonics)      up (mesh-force / bearing-force ripple)
``k f_m +/- f_t``            up (load modulation of the mesh tone)
===========================  =====================================================

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley (load modulation of gear-mesh tones).
Smith, J. D. (2003). Gear Noise and Vibration, 2nd ed. (loaded transmission error grows with load).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, Fit, register
from datagen.effects.speed_fluctuation import check_frequency, modulation


@register
@dataclass(frozen=True)
class TorqueFluctuation(Effect):
    """Sinusoidal ripple of the load torque (module docstring).

    Parameters
    ----------
    amplitude_fraction : float
        Torque ripple amplitude a relative to the nominal torque (-).
    frequency_hz : float
        Ripple frequency part given in Hz (Hz).
    order : float
        Ripple frequency part given in pinion shaft orders (-).
    phase_rad : float
        Phase phi at t = 0 (rad).
    """

    name = "torque_fluctuation"
    signature = "line at the ripple frequency f_t (mesh/bearing force) and +/-f_t sidebands around mesh harmonics"
    #: frequency first: it is seeded from the lines the measurement shows (compare.fitspace.frequency_seeds)
    fit_parameters = ("frequency_hz", Fit("amplitude_fraction", scale="log"))
    amplitude_fraction: float = field(default=0.1, metadata={"unit": "-", "bounds": (0.0, 1.0)})
    frequency_hz: float = field(default=10.0, metadata={"unit": "Hz", "bounds": (0.0, 1000.0)})
    order: float = field(default=0.0, metadata={"unit": "-", "bounds": (0.0, 50.0)})
    phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-math.pi, math.pi)})

    def __post_init__(self):
        super().__post_init__()
        check_frequency(self)

    def operating_point(self, t_s, speed_rpm, torque_nm, ctx):
        return speed_rpm, np.asarray(torque_nm, dtype=float) * modulation(self, t_s, ctx)


__all__ = ["TorqueFluctuation"]
