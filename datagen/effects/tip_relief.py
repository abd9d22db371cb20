"""Tip relief: material removed near the tips, linear or parabolic (hook 2a).

Relief of amount ``C_a`` at the tip, fading to zero over a roll length
``L_a`` along the line of action. With ``A``, ``E`` the start and end of
contact (from T1), the pinion tip is in contact near ``E`` and the wheel tip
near ``A``:

    e_pinion(g) = C_a ((g - (E - L_a)) / L_a)^p   for g > E - L_a
    e_wheel(g)  = C_a (((A + L_a) - g) / L_a)^p   for g < A + L_a

with ``p = 1`` (linear) or ``p = 2`` (parabolic), and
``L_a = length_fraction (eps_alpha - 1) p_bt``: ``length_fraction = 1`` is
"long" relief (the whole double-contact zone at that end), ``0.5`` "short"
relief. Positive ``e`` = material missing (the contract's sign). Every tooth
is relieved alike, so the deviation repeats every mesh cycle.

Relief lets the incoming and outgoing pair take up load gradually. When
``C_a`` is about the static deflection of a single pair at the design load
(:func:`design_relief_m`) the loaded transmission error is nearly constant and
the mesh-harmonic excitation drops; far below that load the relief itself
becomes an excitation and the mesh harmonics rise.

Signature (checked in ``tests/test_effects_signatures.py``)

=====================  ================================================================
line                   change
=====================  ================================================================
``f_m`` near the       down (the relief cancels the step of the loaded transmission
design load            error as pairs enter and leave contact)
``k f_m`` at light     up
load
=====================  ================================================================

References
----------
Tavakoli, M. S., Houser, D. R. (1986). Optimum profile modifications for the minimization of static
    transmission errors of spur gears. J. Mech. Trans. Autom. Des. 108(1), 86-94.
Smith, J. D. (2003). Gear Noise and Vibration, 2nd ed., Marcel Dekker ("long" and "short" relief,
    relief matched to the deflection at the design load).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.accuracy_grade import GEAR_CHOICES, selected_gears
from datagen.effects.base import Effect, Fit, register
from gearpit.errors import require_positive

RELIEF_SHAPES = ("linear", "parabolic")


def relief_length_m(pair, length_fraction: float) -> float:
    """Roll length of relief ``L_a = length_fraction (eps_alpha - 1) p_bt`` (m)."""
    return length_fraction * (pair.contact_ratio_transverse - 1.0) * pair.base_pitch_m


def relief_profile_m(distance_into_zone_m, amount_m: float, length_m: float, exponent: int) -> np.ndarray:
    """``amount_m (d / length_m)^exponent`` for ``0 <= d <= length_m``, 0 for ``d <= 0``, capped at the tip."""
    u = np.clip(np.asarray(distance_into_zone_m, dtype=float) / length_m, 0.0, 1.0)
    return amount_m * u**exponent


def design_relief_m(stiffness, torque_nm: float) -> float:
    """Static deflection of a single tooth pair at the pitch point under ``torque_nm`` (m).

    ``F / k_pair`` with ``F = T / r_b1`` the static mesh force and ``k_pair``
    the largest single-pair stiffness of the healthy record
    (:class:`datagen.stiffness.MeshStiffness`), the usual first choice of ``C_a``
    for a "design load" relief (Smith 2003).
    """
    require_positive("torque_nm", torque_nm)
    k_pair = float(np.max(stiffness.k_slots_n_per_m))
    return torque_nm / stiffness.pair.base_radius_m("pinion") / k_pair


@register
@dataclass(frozen=True)
class TipRelief(Effect):
    """Linear or parabolic tip relief on every tooth (module docstring).

    Parameters
    ----------
    amount_m : float
        Relief C_a at the tip, along the line of action (m).
    length_fraction : float
        Relief roll length as a fraction of the double-contact zone (eps_alpha - 1) p_bt (-).
    shape : {"linear", "parabolic"}
        Exponent p = 1 or 2.
    gears : {"both", "pinion", "wheel"}
        Which gears' tips are relieved.
    """

    name = "tip_relief"
    signature = "near the design load the mesh harmonics k*fm fall; at light load they rise"
    mesh_harmonics_only = True
    fit_parameters = (Fit("amount_m", scale="log"), "length_fraction", "shape")
    amount_m: float = field(default=10e-6, metadata={"unit": "m", "bounds": (0.0, 100e-6)})
    length_fraction: float = field(default=1.0, metadata={"unit": "-", "bounds": (0.05, 1.5)})
    shape: str = field(default="linear", metadata={"unit": "-", "choices": RELIEF_SHAPES})
    gears: str = field(default="both", metadata={"unit": "-", "choices": GEAR_CHOICES})

    @classmethod
    def fit_seeds(cls, ctx, stiffness) -> dict:
        """Reliefs from half to two and a half times the single-pair deflection at the measured load
        (:func:`design_relief_m`), in steps of a tenth of it. Near that deflection the relief cancels the
        loaded transmission error's step, so the mesh-harmonic levels pass through a notch: a relief a
        little above it and one a little below give similar levels (the views are levels), and the minimum of
        the error at the true relief is only about +/- 15 % wide, narrower than a grid over decades."""
        if ctx.torque_nm <= 0:
            return {}
        return {"amount_m": design_relief_m(stiffness, ctx.torque_nm) * np.round(np.arange(0.5, 2.55, 0.1), 2)}

    def tooth_deviation_m(self, g_m, pinion_tooth, wheel_tooth, ctx):
        pair = ctx.pair
        g = np.asarray(g_m, dtype=float)
        la = relief_length_m(pair, self.length_fraction)
        p = RELIEF_SHAPES.index(self.shape) + 1
        out = np.zeros(np.broadcast(g, pinion_tooth, wheel_tooth).shape)
        if la <= 0 or self.amount_m == 0:
            return out
        for which in selected_gears(self.gears):
            d = g - (pair.contact_end_m - la) if which == "pinion" else (pair.contact_start_m + la) - g
            out = out + relief_profile_m(d, self.amount_m, la, p)
        return out


__all__ = ["TipRelief", "RELIEF_SHAPES", "design_relief_m", "relief_length_m", "relief_profile_m"]
