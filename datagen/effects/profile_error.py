"""Profile error: slope plus sinusoidal form deviation of every tooth flank (hook 2a).

The spur paper's profile error (after Mucchi et al.), along the active profile
of length ``l`` of the pinion and/or the wheel:

    e(s) = f_H s / l + (f_f / 2) sin(2 pi n s / l + phi),

with ``s`` the involute arc length from the start of active profile (0 .. l),
``f_H`` the profile slope deviation and ``f_f`` the profile form deviation
taken from the gear's ISO 1328-1 accuracy grade
(:mod:`datagen.effects.accuracy_grade`), ``n`` the number of sinusoid cycles
along the profile and ``phi`` its phase. ISO 1328-1 defines ``f_f`` as the
*range* of the form deviation, so the sinusoid's amplitude is ``f_f / 2`` (the
spur paper writes ``f sin(...)``; with ``f = f_f`` its range would be twice
the tolerance). Positive ``e`` = material missing (the contract's sign).

Every tooth of a gear carries the same error, so the deviation repeats every
mesh cycle: the signature is the mesh harmonics ``k f_m`` only (no shaft-order
sidebands). Tooth-to-tooth scatter is what :mod:`~datagen.effects.pitch_error`
adds; keeping the two apart keeps their signatures apart.

Signature (what the tests check, ``tests/test_effects_signatures.py``)

=====================  ========================================================
line                   change
=====================  ========================================================
``k f_m``, k = 1..3    up (the error adds a mesh-periodic transmission error)
``f_m +/- fr``         unchanged (same error on every tooth)
=====================  ========================================================

References
----------
The spur paper, ../shared/seeds/000_3879ffd8da6fd0be.txt, "Dynamic model of the gear system" (e formula).
Mucchi et al., the spur paper's ref. 30 (its reference list is not in the available text), for the
    derivation of the formula.
ISO 1328-1:1995, Annex B (f_f_alpha, f_H_alpha).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from datagen.effects.accuracy_grade import GEAR_CHOICES, GRADE_RANGE, gear_tolerances, selected_gears
from datagen.effects.base import Effect, register


def profile_deviation_m(s_over_l, slope_m: float, form_m: float, cycles: float, phase_rad: float) -> np.ndarray:
    """``slope_m * s/l + (form_m / 2) sin(2 pi cycles s/l + phase_rad)`` (m), ``s/l`` clipped to [0, 1]."""
    u = np.clip(np.asarray(s_over_l, dtype=float), 0.0, 1.0)
    return slope_m * u + 0.5 * form_m * np.sin(2.0 * np.pi * cycles * u + phase_rad)


def profile_fraction(pair, which: str, g_m) -> np.ndarray:
    """Position ``s / l`` on ``which``'s active profile of the contact at line-of-action position ``g_m``.

    ``s`` is the involute arc length from the start of active profile,
    ``rb (t^2 - t_sap^2) / 2`` with ``t`` the roll angle (:meth:`GearPair.roll_angle_rad`).
    """
    t0, t1 = pair.active_roll_range_rad(which)
    t = pair.roll_angle_rad(which, np.asarray(g_m, dtype=float))
    return (t * t - t0 * t0) / (t1 * t1 - t0 * t0)


@register
@dataclass(frozen=True)
class ProfileError(Effect):
    """Profile slope + form deviation, identical on every tooth (module docstring).

    Parameters
    ----------
    grade : float
        ISO 1328-1 accuracy grade Q (-); sets f_H_alpha and f_f_alpha of each gear.
    cycles : float
        Sinusoid cycles n along the active profile (-).
    phase_rad : float
        Phase phi of the sinusoid (rad).
    gears : {"both", "pinion", "wheel"}
        Which gears' flanks carry the error.
    """

    name = "profile_error"
    signature = "mesh harmonics k*fm rise (same error on every tooth: no shaft-order sidebands)"
    mesh_harmonics_only = True
    fit_parameters = ("grade", "cycles", "gears")
    grade: float = field(default=6.0, metadata={"unit": "-", "bounds": GRADE_RANGE})
    cycles: float = field(default=2.0, metadata={"unit": "-", "bounds": (0.0, 10.0)})
    phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-math.pi, math.pi)})
    gears: str = field(default="both", metadata={"unit": "-", "choices": GEAR_CHOICES})

    def tooth_deviation_m(self, g_m, pinion_tooth, wheel_tooth, ctx):
        g = np.asarray(g_m, dtype=float)
        out = np.zeros(np.broadcast(g, pinion_tooth, wheel_tooth).shape)
        for which in selected_gears(self.gears):
            tol = gear_tolerances(ctx.pair, which, self.grade)
            out = out + profile_deviation_m(profile_fraction(ctx.pair, which, g), tol.profile_slope_m,
                                            tol.profile_form_m, self.cycles, self.phase_rad)
        return out


__all__ = ["ProfileError", "profile_deviation_m", "profile_fraction"]
