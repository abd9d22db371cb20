"""A pit on one tooth flank, as an effect: the local tooth fault the comparison can fit (hook 1).

The case's ``[pits]`` table describes the pits of a simulated gear in full (any shape, any teeth, a photo); a
comparison model names the effects it may be missing, and a pit is the fault this toolkit is about. So the same
pit maps are offered as an effect with the two numbers a comparison can read from one sensor: how large the pit
is (``severity``, the pitted fraction of the active flank, :mod:`datagen.pits`) and on which gear (``gear``).
The pit is an ellipse centred on the flank (:func:`datagen.pits.sized_pit`: across the pitch line, where pitting
starts, its axes in the flank's proportions) on tooth 0 of that gear, ``depth_m`` deep, on a
``GRID`` pixel flank. Which tooth carries it sets only the phase of the once-per-revolution pattern, which no
amplitude spectrum, envelope or synchronous-average level reads; several pitted teeth, other shapes or a
measured flank belong in ``[pits]``.

The hook rebuilds the mesh stiffness of the pair with the pit added to the pits the case already has (their grid
is kept; a pit on the same tooth of the same gear is merged by the deeper of the two depths), with the incoming
stiffness's own options (positions per cycle, pit model, edges; its slices unless it has no pits and the default
slicing, which is then that of a ``[pits]`` table: the pit map's face columns), so that the effect and the same
pit in ``[pits]`` give the same record. It therefore runs before every other
hook 1 (:attr:`rebuilds_stiffness`: the Hertz correction is applied to the pitted pair, not lost).

Signature: a local loss of stiffness once per revolution of the pitted gear. The loaded transmission error dips
while the tooth meshes, so every mesh harmonic carries sidebands at that gear's shaft orders, the envelope has
lines at its orders, and its synchronous average has one impulsive tooth (FM4, NA4 up). A cumulative pitch error
puts sidebands at the same orders, but spread over the revolution, not on one tooth.

References
----------
Chaari, F., Baccar, W., Abbes, M. S., Haddar, M. (2008). Effect of spalling or tooth breakage on gearmesh
    stiffness and dynamic response of a one-stage spur gear transmission. Eur. J. Mech. A/Solids 27, 691-705.
../shared/seeds (the pitting papers this toolkit follows): pits on the contact line carry no load.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, Fit, register
from datagen.flank import PitMap
from datagen.pits import DEFAULT_DEPTH_M, DEPTH_RANGE_M

#: flank pixels (profile x face) of the pit when the case has no pit map on that gear (Case's default grid)
GRID = (64, 64)


def with_pit(stiffness, gear: str, severity: float, depth_m: float):
    """``stiffness`` (a :class:`datagen.stiffness.MeshStiffness`) rebuilt with an elliptical pit of ``severity``
    on tooth 0 of ``gear`` added to its pits, with its own options; the ellipse's outline at sub-pixel resolution
    (:func:`datagen.pitshapes.subpixel_pit`), so that the record moves continuously with the fitted severity."""
    from datagen.pits import make_pit_map

    def ellipse(grid):
        new = make_pit_map(grid, shape="ellipse", severity=float(severity), teeth=[0], gear=gear, depth_m=depth_m,
                           subpixel=True)
        return (new.depth_m[0], new.coverage[0]) if 0 in new.depth_m else None

    return with_tooth_fault(stiffness, gear, ellipse)


def with_tooth_fault(stiffness, gear: str, tooth0_depth_m):
    """``stiffness`` rebuilt with a fault on tooth 0 of ``gear`` added to its pits, with its own options:
    ``tooth0_depth_m(grid)`` gives the fault's depth map (m) on that gear's flank grid (None: no pixel), or a
    pair (depth map, pitted share of each pixel: :attr:`datagen.flank.PitMap.coverage`). The grid is the case's
    when it has a pit map on that gear, else :data:`GRID`; a fault on a tooth that already has pits merges by the
    deeper of the two depths and the larger of the two shares."""
    from datagen.stiffness import default_n_slices, mesh_stiffness

    pair = stiffness.pair
    maps = {pm.gear: pm for pm in stiffness.pits}
    old = maps.get(gear)
    grid = old.grid if old is not None else pair.flank_grid(gear, *GRID)
    new = tooth0_depth_m(grid)
    depth = dict(old.depth_m) if old is not None else {}
    coverage = dict(old.coverage) if old is not None else {}
    if isinstance(new, tuple):
        new, share = (np.asarray(a, dtype=np.float64) for a in new)
        old_share = old.share(0) if old is not None and 0 in depth else np.zeros(grid.shape)
        coverage[0] = np.maximum(old_share, share)
    elif new is not None and 0 in coverage:       # a whole-pixel fault over a tooth with sub-pixel edges
        coverage[0] = np.maximum(coverage[0], (np.asarray(new) > 0).astype(np.float64))
    if new is not None:
        depth[0] = np.maximum(depth[0], new) if 0 in depth else np.asarray(new, dtype=np.float64)
    maps[gear] = PitMap(grid=grid, depth_m=depth, gear=gear, coverage=coverage)
    # slices as a [pits] table gets them: a record without pits at the default slicing (1 for a spur pair, 100
    # for a helical one) is resliced at the pit maps' face columns (a spur pit on one slice would take the whole
    # face out of contact); a record that has pits, or other slices, keeps its own
    unpitted = not any(pm.pitted_teeth for pm in stiffness.pits)
    n_slices = None if unpitted and stiffness.n_slices == default_n_slices(pair) else stiffness.n_slices
    return mesh_stiffness(pair, pits=tuple(maps.values()), positions_per_cycle=stiffness.positions_per_cycle,
                          n_slices=n_slices, pit_model=stiffness.pit_model, edges=stiffness.edges)


@register
@dataclass(frozen=True)
class ToothPit(Effect):
    """An elliptical pit on tooth 0 of one gear (module docstring).

    Parameters
    ----------
    severity : float
        Pitted fraction of the tooth's active flank (0: no pit), at most 0.6 (the ellipse's largest is ~0.79).
    gear : {"pinion", "wheel"}
    depth_m : float
        Pit depth (m); with the default pit model ("no_contact") a pitted pixel carries no load whatever its
        depth, so the depth matters only to the "weak_spring" model.
    """

    name = "tooth_pit"
    signature = ("a local stiffness loss once per revolution of the pitted gear: sidebands at its shaft orders "
                 "around every mesh harmonic, envelope lines at its orders, one impulsive tooth in its TSA")
    #: the comparison fits the size and the gear (the tooth sets only a phase, the depth nothing under no_contact)
    fit_parameters = (Fit("severity", scale="linear", bounds=(0.0, 0.5)), "gear")
    #: a pinion pit and a wheel pit put their lines at different shafts' orders: each gear gets its own first round
    fit_choice_grid = True
    #: the hook builds the stiffness from the pair and its pits, so it runs before the other hook-1 effects
    rebuilds_stiffness = True

    severity: float = field(default=0.2, metadata={"unit": "-", "bounds": (0.0, 0.6)})
    gear: str = field(default="pinion", metadata={"unit": "-", "choices": ("pinion", "wheel")})
    depth_m: float = field(default=DEFAULT_DEPTH_M, metadata={"unit": "m", "bounds": DEPTH_RANGE_M})

    def mesh_stiffness(self, stiffness, ctx):
        if self.severity <= 0:
            return stiffness
        return with_pit(stiffness, self.gear, self.severity, self.depth_m)


__all__ = ["GRID", "ToothPit", "with_pit", "with_tooth_fault"]
