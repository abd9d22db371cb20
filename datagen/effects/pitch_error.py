"""Pitch error: each tooth of a gear displaced from its ideal angular position (hook 2a).

Tooth ``j`` of a gear with ``z`` teeth sits, along the line of action,

    e_j = cos(alpha_t) * [ (F_p / 2) sin(2 pi j / z + phi) + c f_pt [j = 0] ]

out of place: a sinusoidal cumulative pitch deviation over the revolution,
whose range is the total cumulative pitch deviation ``F_p`` (the usual shape
of the cumulative error of a gear cut or ground with its axis off the machine
axis), plus an optional single displaced tooth (tooth 0) carrying ``c`` times
the single pitch deviation ``f_pt``, which gives two adjacent single-pitch
deviations ``+c f_pt`` and ``-c f_pt``. ``F_p`` and ``f_pt`` come from the
gear's ISO 1328-1 accuracy grade (:mod:`datagen.effects.accuracy_grade`);
pitch deviations are measured on the reference circle, so along the line of
action they scale by ``r_b / r = cos(alpha_t)``. Positive ``e`` = material
missing (the contract's sign). The whole tooth moves: ``e_j`` is constant
over its profile.

Random single pitch deviations (``random_single_factor`` > 0): every real gear's teeth also sit randomly
off their places, tooth by tooth (ISO 1328-1 bounds them by f_pt). Each single pitch deviation (tooth j to
j + 1) is then drawn normal with standard deviation ``random_single_factor * f_pt`` (from ``random_seed``),
the steps are closed (they sum to zero once round) and the positions are their cumulative sum: a random walk
that adds a random cumulative error to the sinusoid. Why it matters: unlike the sinusoid and the displaced
tooth, these deviations differ from tooth to tooth and survive the TSA difference signal, just like pits on
many teeth. Measured (experiments/foreign_classifier_check.py): a CNN trained without them called 21 of 24
healthy records of an independent simulator, which has them, pitted (with 3+ teeth); without them in that
simulator all 24 were called healthy.

The deviation repeats once per revolution of the erroneous gear (``z``
mesh cycles; ``lcm(z1, z2)`` when both carry errors).

Signature (checked in ``tests/test_effects_signatures.py``)

=================================  ===============================================================
line                               change
=================================  ===============================================================
``k fr`` of the erroneous gear     up: 1x from the cumulative error, a comb of harmonics from the
                                   single displaced tooth (once-per-revolution impulse)
``m f_m +/- k fr``                 up (McFadden & Smith 1985: once-per-revolution modulation of
                                   the tooth-meshing vibration)
=================================  ===============================================================

References
----------
ISO 1328-1:1995 (definitions of single and cumulative pitch deviations; tolerance formulas).
McFadden, P. D., Smith, J. D. (1985). An explanation for the asymmetry of the modulation sidebands about
    the tooth meshing frequency in epicyclic gear vibration. Proc. Inst. Mech. Eng. C 199(1), 65-70
    (modulation of the meshing vibration once per revolution -> sideband families).
Randall, R. B. (1982). A new method of modeling gear faults. J. Mech. Des. 104(2), 259-267.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from datagen.effects.accuracy_grade import GEAR_CHOICES, GRADE_RANGE, gear_tolerances, selected_gears
from datagen.effects.base import Effect, register


def tooth_pitch_deviations_m(teeth: int, cumulative_m: float, single_m: float, phase_rad: float,
                             random_single_m: float = 0.0, seed: int = 0) -> np.ndarray:
    """Position deviation of each tooth (m, on the reference circle): ``(F_p/2) sin(2 pi j/z + phi) + f [j=0]``,
    plus, with ``random_single_m`` > 0, a closed random walk whose steps (the random single pitch deviations)
    have that standard deviation (drawn from ``seed`` and ``teeth``; module docstring)."""
    j = np.arange(teeth)
    e = 0.5 * cumulative_m * np.sin(2.0 * np.pi * j / teeth + phase_rad)
    e[0] += single_m
    if random_single_m > 0.0:
        steps = np.random.default_rng([int(seed), int(teeth)]).standard_normal(teeth)
        steps = (steps - steps.mean()) / steps.std()          # closed: the teeth go once round
        walk = np.cumsum(steps)
        e = e + random_single_m * (walk - walk.mean())
    return e


@register
@dataclass(frozen=True)
class PitchError(Effect):
    """Sinusoidal cumulative pitch error plus an optional displaced tooth (module docstring).

    Parameters
    ----------
    grade : float
        ISO 1328-1 accuracy grade Q (-); sets F_p and f_pt of each gear.
    phase_rad : float
        Phase phi of the cumulative error (rad): tooth j's angle 2 pi j / z + phi.
    single_tooth_factor : float
        Extra displacement of tooth 0, in units of the grade's single pitch deviation f_pt (-).
    random_single_factor : float
        Standard deviation of random single pitch deviations, in units of the grade's f_pt (-; 0: none).
    random_seed : int
        Seed of those random deviations (recorded with the data, like every draw).
    gears : {"both", "pinion", "wheel"}
        Which gears carry the error.
    """

    name = "pitch_error"
    signature = "shaft orders k*fr of the erroneous gear and +/-k*fr sidebands around mesh harmonics"
    #: the displaced tooth is given in units of the grade's f_pt: grade and single_tooth_factor trade off
    #: along a valley, so only the grade is fitted (and which gear)
    fit_parameters = ("grade", "gears")
    #: a tooth's pitch deviation displaces the whole flank: the same at every contact position
    tooth_deviation_position_free = True
    grade: float = field(default=6.0, metadata={"unit": "-", "bounds": GRADE_RANGE})
    phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-math.pi, math.pi)})
    single_tooth_factor: float = field(default=0.0, metadata={"unit": "-", "bounds": (0.0, 5.0)})
    random_single_factor: float = field(default=0.0, metadata={"unit": "-", "bounds": (0.0, 2.0)})
    random_seed: int = field(default=0, metadata={"unit": "-", "bounds": (0, 2**31 - 1)})
    gears: str = field(default="pinion", metadata={"unit": "-", "choices": GEAR_CHOICES})

    def deviation_period_cycles(self, ctx):
        z = {"pinion": ctx.pair.pinion.teeth, "wheel": ctx.pair.wheel.teeth}
        return math.lcm(*(z[w] for w in selected_gears(self.gears)))

    def tooth_table_m(self, pair, which: str) -> np.ndarray:
        """Deviation of each tooth of ``which`` along the line of action (m)."""
        tol = gear_tolerances(pair, which, self.grade)
        z = pair.pinion.teeth if which == "pinion" else pair.wheel.teeth
        e = tooth_pitch_deviations_m(z, tol.cumulative_pitch_m, self.single_tooth_factor * tol.single_pitch_m,
                                     self.phase_rad, self.random_single_factor * tol.single_pitch_m, self.random_seed)
        return e * math.cos(pair.pressure_angle_t_rad)

    def tooth_deviation_m(self, g_m, pinion_tooth, wheel_tooth, ctx):
        pt = np.asarray(pinion_tooth, dtype=np.int64)
        wt = np.asarray(wheel_tooth, dtype=np.int64)
        out = np.zeros(np.broadcast(g_m, pt, wt).shape)
        for which in selected_gears(self.gears):
            table = self.tooth_table_m(ctx.pair, which)
            out = out + table[pt if which == "pinion" else wt]
        return out


__all__ = ["PitchError", "tooth_pitch_deviations_m"]
