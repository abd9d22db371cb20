"""Eccentricity (run-out) of the pinion or of the wheel: a transmission error (hook 2b) and a moving centre (hook 2c).

A gear whose pitch circle is offset by ``a`` from its axis of rotation moves
its teeth along the line of action by

    e(theta) = a sin(theta + phi)

(the component of the rotating offset along the line of action), which adds
to the mesh deflection as a once-per-revolution transmission error. Through
the time-varying mesh stiffness it also modulates the mesh force: the error
force ``k(x) e(theta)`` carries ``+/- fr`` sidebands around every mesh
harmonic. The radial run-out a ball probe reads is ``F_r = 2 a``
(ISO 1328-2: ``F_r = 0.8 F_p`` at a grade, :mod:`datagen.effects.accuracy_grade`).

Through the moving centre (hook 2c, :func:`datagen.centre_offset.slots_at_centre_offset`)
it also changes the mesh itself, once per revolution: the centre distance
varies by up to ``a``, which moves the start of contact by up to
``a / sin(alpha_w)`` (a contact-ratio modulation of ``a / (p_bt sin alpha_w)``:
0.074 for ``a = 150 um`` on ``spur-gds``), and the line of centres and the
pressure angle turn, which shifts the mesh timing by up to
``r_b1 a / (a_w sin alpha_w)`` (0.016 of a base pitch for 150 um). That
stiffness modulation, not the transmission error, makes the ``+/- fr``
sidebands: on ``spur-gds`` at 1000 rpm and 50 N m with ``a = 50 um`` the
``f_m +/- fr`` lines of the pinion-bearing acceleration are at -27 to -28 dB
re the ``f_m`` line with it, -54 to -56 dB without it (pinion; wheel: -28 to
-30 dB against -68 to -69 dB). The transmission error alone is a
once-per-revolution error, slow compared with the drive train's torsion modes,
so the gears simply turn by ``e / r_b`` to follow it and the tooth load barely
changes.

Geometry: in the frame of hook 2c (``x`` from pinion to wheel centre, the line
of action along ``(sin alpha_w, cos alpha_w)``, the pinion turning so that
contact runs from T1 to T2), the offset of the pinion's centre points at
``psi_1 = theta_1 + phi + pi - alpha_w`` and that of the wheel at
``psi_2 = pi - theta_2 - phi - alpha_w`` (the wheel turns the other way).
These are the angles at which the offset's component along the line of action
is the transmission error above with its sign (positive: the flanks part).

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

    def centre_offset_m(self, theta_pinion_rad, theta_wheel_rad, ctx):
        """The wheel centre relative to the pinion centre (module docstring, 'Geometry')."""
        alpha = ctx.pair.working_pressure_angle_rad
        if self.gear == "pinion":   # the pinion centre moves: the wheel's relative offset is minus that
            psi = np.asarray(theta_pinion_rad, dtype=float) + self.phase_rad + math.pi - alpha
            return -self.amplitude_m * np.array([np.cos(psi), np.sin(psi)])
        psi = math.pi - np.asarray(theta_wheel_rad, dtype=float) - self.phase_rad - alpha
        return self.amplitude_m * np.array([np.cos(psi), np.sin(psi)])


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
