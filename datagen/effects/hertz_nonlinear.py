"""Load-dependent Hertzian contact stiffness at the mean load (hook 1).

The healthy mesh stiffness of :mod:`datagen.stiffness` uses the linear,
load-independent Hertz compliance per unit face width
``c_h = 4 (1 - nu^2) / (pi E)``. The spur paper instead takes the empirical
load-dependent form it attributes to Ma and Zeng,

    k_h = E^0.9 L^0.8 F^0.1 / 1.275      (SI: Pa, m, N -> N/m),

with ``L`` the contact length of a tooth pair and ``F`` the load that pair
carries. This effect replaces, in every slice of every tooth pair in contact,
``c_h`` by ``L / k_h`` (the pair's Hertz compliance spread evenly over its
contact length) with ``F`` the pair's share of the *mean* (static) mesh force
``T / r_b1`` by load sharing (``F_pair = F k_pair / k_total``, iterated to a
fixed point, since ``k_pair`` itself depends on ``F_pair``). The mesh
stiffness stays a function of the mesh position only - the dynamic load does
not feed back - which keeps the mesh law linear (the periodic solver applies).

At the loads of the presets (F of the order of 1 kN) ``k_h`` is a few times
softer than the linear value, so the mean mesh stiffness falls (by 14 % on
``spur-gds`` at 20 N m), the mesh resonance moves down, and the stiffness
dips where a pair enters or leaves contact with little load are deeper.
Raising the torque raises ``k_h`` as ``F^0.1``.

Approximations: with ``pit_model="weak_spring"`` the pitted slices (whose
Hertz compliance is that of a weak spring, :data:`datagen.pit_stiffness.WEAK_SPRING_RATIO`)
have one linear Hertz term replaced as the healthy ones, the weakening kept; the force is the transverse line-of-action force (for helical
pairs the normal load is larger by ``1 / cos(beta_b)``).

Signature (checked in ``tests/test_effects_signatures.py``)

=============================  ==================================================
quantity                       change
=============================  ==================================================
mean mesh stiffness            down (the Hertz term is softer at these loads)
mesh-mode natural frequency    down (about half the relative stiffness change)
mesh harmonics ``k f_m``       change (larger ripple where pairs enter/leave)
=============================  ==================================================

References
----------
The spur paper, ../shared/seeds/000_3879ffd8da6fd0be.txt, "Stiffness calculation and verification"
    (k_h formula, citing Ma and Zeng, its ref. 31, and the load sharing ratio).
../shared/PHYSICS.md section 2 (linear and load-dependent Hertz stiffness).
Yang, D. C. H., Lin, J. Y. (1987). J. Mech. Trans. Autom. Des. 109, 189-196 (linear c_h).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from datagen.compliance import hertz_compliance
from datagen.effects.base import Effect, register
from gearpit.errors import InputError

#: fixed-point iterations of the load sharing (k_h ~ F^0.1 contracts by ~0.1 per pass)
ITERATIONS = 8
#: pairs are credited at least this fraction of the mean force (k_h -> 0 as F -> 0)
MIN_LOAD_FRACTION = 1e-3


def ma_zeng_hertz_stiffness_n_per_m(youngs_modulus_pa: float, length_m, force_n) -> np.ndarray:
    """``E^0.9 L^0.8 F^0.1 / 1.275`` (N/m): load-dependent Hertz stiffness of a tooth pair."""
    return youngs_modulus_pa**0.9 * np.asarray(length_m, float) ** 0.8 * np.asarray(force_n, float) ** 0.1 / 1.275


def _corrected_block(k_block: np.ndarray, force_n: float, dw: float, E: float, c_h: float) -> np.ndarray:
    """Slice stiffness (ppc, S, n_slices) with the linear Hertz term replaced at the shared mean load."""
    contact = k_block > 0
    c_slice = np.where(contact, dw / np.where(contact, k_block, 1.0), 0.0)   # compliance per unit width
    length = contact.sum(axis=2) * dw                                           # (ppc, S) contact length
    k_new = k_block
    for _ in range(ITERATIONS):
        k_pair = k_new.sum(axis=2)
        k_tot = np.maximum(k_pair.sum(axis=1, keepdims=True), 1e-30)
        f_pair = np.maximum(force_n * k_pair / k_tot, MIN_LOAD_FRACTION * force_n)
        kh = ma_zeng_hertz_stiffness_n_per_m(E, np.maximum(length, dw), f_pair)
        c_new = c_slice - c_h + (np.maximum(length, dw) / kh)[..., None]
        k_new = np.where(contact, dw / np.where(contact, c_new, 1.0), 0.0)
    return k_new


def hertz_nonlinear_stiffness(stiffness, torque_nm: float):
    """``stiffness`` (a :class:`datagen.stiffness.MeshStiffness`) with the load-dependent Hertz term.

    See the module docstring. The corrected record has the same grid and
    engagements; every cycle in which a pitted pair is in contact is stored as
    its own slice-stiffness block (the load sharing couples all pairs of a cycle).
    """
    if not torque_nm > 0:
        raise InputError("operating.torque_nm", torque_nm, "> 0 for hertz_nonlinear (k_h depends on the load)")
    ms = stiffness
    pair = ms.pair
    E = pair.material.youngs_modulus_pa
    c_h = hertz_compliance(E, pair.material.poisson)
    dw = pair.contact_face_width_m / ms.n_slices
    force = torque_nm / pair.base_radius_m("pinion")
    return ms.map_cycle_blocks(lambda block: _corrected_block(block, force, dw, E, c_h))


@register
@dataclass(frozen=True)
class HertzNonlinear(Effect):
    """Load-dependent Hertz contact stiffness at the mean load (module docstring). No parameters."""

    name = "hertz_nonlinear"
    signature = "mean mesh stiffness falls (Ma & Zeng k_h at the mean load): mesh resonance moves down"
    mesh_harmonics_only = True
    #: no free parameter: the effect is tried as it is
    fit_parameters = ()

    def mesh_stiffness(self, stiffness, ctx):
        return hertz_nonlinear_stiffness(stiffness, ctx.torque_nm)


__all__ = ["HertzNonlinear", "hertz_nonlinear_stiffness", "ma_zeng_hertz_stiffness_n_per_m"]
