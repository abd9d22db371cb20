"""A broken tooth, as an effect: part of one tooth missing across the face width (hook 1).

A tooth breaks at its root or loses a corner; what meshes afterwards is the tooth over the face width that is
left. Chaari et al. (2008) model a breakage as a loss of tooth width, every energy term of the potential-energy
method scaling with the width that carries load; the slices of :mod:`datagen.stiffness` give exactly that. The
broken part is a band of the face (from the face edge at column 0, ``width_fraction`` of the face) over the top
``height_fraction`` of the active profile (1: the whole active flank, a tooth broken at its root over that width;
less: a corner broken off at the tip). On it no contact is made, as on a pitted pixel under the default pit model
("no_contact", :mod:`datagen.pit_stiffness`), so the broken part is written into the gear's pit map on tooth 0
(depth: the largest a pit may have, 5 mm; under "weak_spring" the band is then a pit of that depth, which still
carries load without its Hertz term: the literal pit model of the spur paper has no broken tooth).

How it differs from :mod:`datagen.effects.tooth_pit`: a pit at the pitch line takes load off abruptly, only while
the contact line crosses it (the single-contact zone of a spur pair); a break takes the broken fraction of the
pair's own stiffness off over its whole mesh, double-contact zones included, so the loss rises and falls with the
pair's stiffness. Measured on spur-gds with a 25-tooth pinion at 20 N m: for the same 20 % of the flank the low
orders of the stiffness loss are alike (0.81 % against 0.88 % of the mean stiffness at order 1), the
acceleration's sidebands fm +/- k fr_pinion are 0.9-1.5 % of fm for the break and 7.4-8.0 % for the pit (one
accelerometer tells them apart by that shape only: the comparison names the other as a rival). Which tooth
carries it sets only a phase (as for the pit); several broken teeth, or a break of another shape, belong in
``[pits]``.

Signature: a once-per-revolution loss of stiffness of the broken gear over a whole tooth mesh: sidebands at that
gear's shaft orders around every mesh harmonic, envelope lines at its orders, one weaker tooth in its synchronous
average.

References
----------
Chaari, F., Baccar, W., Abbes, M. S., Haddar, M. (2008). Effect of spalling or tooth breakage on gearmesh
    stiffness and dynamic response of a one-stage spur gear transmission. Eur. J. Mech. A/Solids 27, 691-705.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, Fit, register
from datagen.effects.tooth_pit import with_tooth_fault

#: depth written into the pit map on the broken part (m): the deepest a pit may be (weak_spring's section loss)
BROKEN_DEPTH_M = 5e-3


def broken_band(grid, width_fraction: float, height_fraction: float) -> np.ndarray | None:
    """Depth map (m) of a tooth broken over ``width_fraction`` of the face (columns from 0) and the top
    ``height_fraction`` of the active profile, on ``grid``; None when no pixel is broken (both rounded to whole
    pixels)."""
    n_cols = int(round(width_fraction * grid.n_face))
    n_rows = int(round(height_fraction * grid.n_profile))
    if n_cols == 0 or n_rows == 0:
        return None
    depth = np.zeros(grid.shape)
    depth[grid.n_profile - n_rows:, :n_cols] = BROKEN_DEPTH_M
    return depth


@register
@dataclass(frozen=True)
class ToothBreakage(Effect):
    """Tooth 0 of one gear broken over part of its face width (module docstring).

    Parameters
    ----------
    width_fraction : float
        Fraction of the face width broken away (0: intact), at most 0.8; rounded to the flank grid's columns (64
        unless the case has a pit map on that gear). A tooth gone over its whole width would leave the pair with
        no stiffness while it alone should mesh; a real one hands its load to its neighbours through premature
        contact, which the pair's slices (each tooth in contact only on its line of action) do not model.
    height_fraction : float
        Fraction of the active profile, from the tip down, that is missing on that width (1: broken at the root).
    gear : {"pinion", "wheel"}
    """

    name = "tooth_breakage"
    signature = ("a once-per-revolution stiffness loss of the broken gear over a whole tooth mesh: shaft-order "
                 "sidebands of that gear around every mesh harmonic, envelope lines at its orders, one weaker tooth "
                 "in its TSA")
    #: the comparison fits how much of the width is gone and on which gear (the tooth is a phase only)
    fit_parameters = (Fit("width_fraction", scale="linear", bounds=(0.0, 0.8)), "gear")
    #: a broken pinion tooth and a broken wheel tooth put their lines at different shafts' orders
    fit_choice_grid = True
    #: the hook builds the stiffness from the pair and its pits, so it runs before the other hook-1 effects
    rebuilds_stiffness = True

    width_fraction: float = field(default=0.3, metadata={"unit": "-", "bounds": (0.0, 0.8)})
    height_fraction: float = field(default=1.0, metadata={"unit": "-", "bounds": (0.05, 1.0)})
    gear: str = field(default="pinion", metadata={"unit": "-", "choices": ("pinion", "wheel")})

    def mesh_stiffness(self, stiffness, ctx):
        if self.width_fraction <= 0:
            return stiffness
        return with_tooth_fault(stiffness, self.gear,
                                lambda grid: broken_band(grid, self.width_fraction, self.height_fraction))


__all__ = ["BROKEN_DEPTH_M", "ToothBreakage", "broken_band"]
