"""Eccentricity (run-out) of the pinion or of the wheel along the line of action (hook 2b).

A gear whose pitch circle is offset by ``a`` from its axis of rotation moves
its teeth along the line of action by

    e(theta) = a sin(theta + phi)

(the component of the rotating offset along the line of action), which adds
to the mesh deflection as a once-per-revolution transmission error. Through
the time-varying mesh stiffness it also modulates the mesh force: the error
force ``k(x) e(theta)`` carries ``+/- fr`` sidebands around every mesh
harmonic. The radial run-out a ball probe reads is ``F_r = 2 a``
(ISO 1328-2: ``F_r = 0.8 F_p`` at a grade, :mod:`datagen.effects.accuracy_grade`).

In this model the signature is *weak*: a once-per-revolution error is slow
compared with the drive train's torsion modes, so the gears simply turn by
``e / r_b`` to follow it (the transmission error ``dte_m`` carries the 1x line
of amplitude ``a``) and the tooth load barely changes. On ``spur-gds`` with a
25-tooth pinion at 1500 rpm and 20 N m, ``a = 10 um`` gives sidebands of about
-55 to -60 dB (pinion) and -71 to -73 dB (wheel) re the ``f_m`` line. Not
modelled, and also of that order for ``a = 10 um``: the shift of mesh timing
(a phase modulation of the stiffness, ``2 pi a / p_bt`` rad, -46 dB) - the
time-stepping solver includes it only through the pinion's vibration angle -
and the change of centre distance and contact ratio (``a / sin(alpha_w)`` of
path of contact). Both would need a contract hook that shifts the mesh
position.

Two effects, one per gear, so that attribution names the gear and each fit
has two parameters: ``eccentricity_pinion`` and ``eccentricity_wheel``.

Signature (checked in ``tests/test_effects_signatures.py``)

======================================  ==========================================================
line                                    change
======================================  ==========================================================
``m f_m +/- fr`` of that gear           up (McFadden & Smith 1985 sideband family of a
                                        once-per-revolution modulation)
``fr`` of that gear                     up (transmission error at 1x)
sidebands of the other shaft            unchanged
======================================  ==========================================================

References
----------
Randall, R. B. (1982). A new method of modeling gear faults. J. Mech. Des. 104(2), 259-267
    (eccentricity as low-frequency modulation of the tooth-meshing components).
McFadden, P. D., Smith, J. D. (1985). An explanation for the asymmetry of the modulation sidebands about
    the tooth meshing frequency in epicyclic gear vibration. Proc. Inst. Mech. Eng. C 199(1), 65-70.
ISO 1328-2:1997 (radial run-out F_r).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from datagen.effects.base import Effect, Fit, register


@dataclass(frozen=True)
class _Eccentricity(Effect):
    """Offset ``amplitude_m`` of one gear's pitch circle, at angle ``phase_rad`` (module docstring).

    Parameters
    ----------
    amplitude_m : float
        Eccentricity a (m): half the radial run-out F_r.
    phase_rad : float
        Angle phi of the offset at the start of the simulation (rad).
    """

    gear: ClassVar[str] = ""
    #: the phase leaves amplitude spectra, envelope and TSA levels unchanged: not fitted
    fit_parameters = (Fit("amplitude_m", scale="log"),)
    amplitude_m: float = field(default=10e-6, metadata={"unit": "m", "bounds": (0.0, 200e-6)})
    phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-math.pi, math.pi)})

    def deviation_period_cycles(self, ctx):
        return ctx.pair.pinion.teeth if self.gear == "pinion" else ctx.pair.wheel.teeth

    def angle_deviation_m(self, theta_pinion_rad, theta_wheel_rad, ctx):
        theta = theta_pinion_rad if self.gear == "pinion" else theta_wheel_rad
        return self.amplitude_m * np.sin(np.asarray(theta, dtype=float) + self.phase_rad)


@register
@dataclass(frozen=True)
class EccentricityPinion(_Eccentricity):
    __doc__ = _Eccentricity.__doc__
    name = "eccentricity_pinion"
    signature = "+/-fr_pinion sidebands around mesh harmonics k*fm and the 1x pinion shaft order"
    gear = "pinion"


@register
@dataclass(frozen=True)
class EccentricityWheel(_Eccentricity):
    __doc__ = _Eccentricity.__doc__
    name = "eccentricity_wheel"
    signature = "+/-fr_wheel sidebands around mesh harmonics k*fm and the 1x wheel shaft order"
    gear = "wheel"


__all__ = ["EccentricityPinion", "EccentricityWheel"]
