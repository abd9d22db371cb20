"""Limits of a mesh-stiffness computation, checked before any work: the fewest slices that represent a helical
pair's stagger, and the memory a record of a given resolution needs (refused above a budget, with the largest
resolution that fits). Used by :func:`datagen.stiffness.mesh_stiffness`, the case and sweep readers and
``gearpit stiffness``.
"""
from __future__ import annotations

import math

from gearpit.errors import require

#: largest step (base pitches) of a helical pair's contact line between neighbouring slices (:func:`min_n_slices`)
MAX_SLICE_STEP_PITCHES = 0.1
#: most slices across the face width
MAX_N_SLICES = 20000


def min_n_slices(pair) -> int:
    """Fewest slices that represent a helical pair's stagger: neighbouring slices are ``eps_beta / n`` base pitches
    apart on the line of action (``b tan(beta_b) / n``), at most :data:`MAX_SLICE_STEP_PITCHES`; 1 for a spur pair
    (every slice at the same contact position).

    Measured (RMS of the difference from 2000 slices over a cycle, 256 positions, box edges; helical-dct at 29,
    35, 40 deg and spur-gds given 15 and 25 deg): at this step 1.3-2.4 % of the mean stiffness and the minimum
    within 4 %; one slice 21-32 % (helical-dct's record then drops to 0.72 of its mean, 0.95 converged; with a
    pit on the one slice, to 0), steps of ~0.2 base pitch 2-4 %.

    >>> from datagen.geometry import helical_pair_example, spur_pair_example
    >>> min_n_slices(helical_pair_example()), min_n_slices(spur_pair_example())
    (13, 1)
    """
    return max(1, math.ceil(pair.contact_ratio_overlap / MAX_SLICE_STEP_PITCHES - 1e-9))


def require_n_slices(pair, n_slices, field: str = "n_slices") -> None:
    """Raise :class:`InputError` naming ``field`` unless ``n_slices`` is an integer in
    ``[min_n_slices(pair), MAX_N_SLICES]``."""
    lo = min_n_slices(pair)
    why = (f" for the helical pair {pair.name} (overlap ratio {pair.contact_ratio_overlap:.3f}: the contact line "
           f"steps at most {MAX_SLICE_STEP_PITCHES:g} base pitch between slices)" if lo > 1 else "")
    require(isinstance(n_slices, int) and not isinstance(n_slices, bool) and lo <= n_slices <= MAX_N_SLICES, field,
            n_slices, f"an integer in [{lo}, {MAX_N_SLICES}]{why}")


#: memory (bytes) of a stiffness computation whatever its size (:func:`record_bytes`)
RECORD_FIXED_BYTES = 2e6
#: memory (bytes) one stiffness record may take while it is computed; a larger request is refused before any work
#: (:func:`require_record_fits`)
STIFFNESS_BUDGET_BYTES = 2e9


def record_bytes(pair, positions_per_cycle: int, n_slices: int, pitted_teeth=None) -> float:
    """Estimated peak memory (bytes) of :func:`mesh_stiffness` for ``pitted_teeth`` (``{gear: count}``) pitted
    teeth.

    The arrays over one mesh cycle, ``(ppc, pairs in contact S, n_slices)`` float64, dominate: contact fractions,
    positions and stiffness with their temporaries (6 such arrays), the per-pair tables of the pitted
    engagements (3 more) and one override per pitted engagement ``E`` (teeth x record cycles / teeth of their
    gear); then the record over ``P`` cycles, ``P ppc (3 S + 2)`` values. Measured with tracemalloc (helical-dct,
    spur-gds; 1 to 1000 slices, 0 to 4 pitted teeth on either gear): 5.3-10.9 cycle arrays at the peak, under
    this estimate (6 healthy, 9 + E pitted), plus :data:`RECORD_FIXED_BYTES` whatever the size (the pair's
    tables; 0.3-0.5 MB measured). At the largest count the budget allows (helical-dct, pits on 2 teeth over
    1000 slices, healthy and pitted records: 2819 positions) ``gearpit stiffness`` peaked at 1.2 GB resident.
    """
    z = {"pinion": pair.pinion.teeth, "wheel": pair.wheel.teeth}
    pitted = {g: int(k) for g, k in (pitted_teeth or {}).items() if k}
    period = math.lcm(*(z[g] for g in pitted)) if pitted else z["pinion"]
    engagements = sum(k * period // z[g] for g, k in pitted.items())
    n_slots = int(math.floor(pair.contact_ratio_total)) + 2
    cycle_arrays = 6.0 + (3.0 + engagements if engagements else 0.0)
    return RECORD_FIXED_BYTES + 8.0 * positions_per_cycle * (n_slots * n_slices * cycle_arrays
                                                            + period * (3 * n_slots + 2))


def require_record_fits(pair, positions_per_cycle: int, n_slices: int, pitted_teeth=None,
                        field: str = "positions_per_cycle", records: int = 1) -> None:
    """Raise :class:`InputError` naming ``field`` when ``records`` stiffness records of ``positions_per_cycle``
    positions need more than :data:`STIFFNESS_BUDGET_BYTES` (:func:`record_bytes`); the message gives the
    largest count that fits."""
    fixed = records * record_bytes(pair, 0, n_slices, pitted_teeth)
    per_position = records * record_bytes(pair, 1, n_slices, pitted_teeth) - fixed
    top = int((STIFFNESS_BUDGET_BYTES - fixed) // per_position)
    need = fixed + per_position * positions_per_cycle
    pits = ", ".join(f"{k} pitted {g} teeth" for g, k in (pitted_teeth or {}).items() if k) or "no pits"
    require(need <= STIFFNESS_BUDGET_BYTES, field, positions_per_cycle,
            f"an integer in [4, {max(top, 4)}] for pair {pair.name} with {n_slices} slices and {pits}: "
            f"{positions_per_cycle} positions would need ~{need / 1e9:.1f} GB to compute "
            f"(budget {STIFFNESS_BUDGET_BYTES / 1e9:g} GB)")


def check_case_record(case) -> None:
    """A :class:`datagen.simulate.Case`'s stiffness options against its pair and pits, before any work: enough
    slices for a helical pair, and a record that fits :data:`STIFFNESS_BUDGET_BYTES` to compute (pits drawn by an
    effect count as one more pitted tooth on its gear)."""
    from datagen.case_options import auto_positions_per_cycle
    from datagen.flank import PitMap
    from datagen.stiffness import default_n_slices

    so = case.stiffness
    if so.n_slices is not None:
        require_n_slices(case.pair, so.n_slices, "stiffness.n_slices")
    pitted, cols = {}, None
    if isinstance(case.pits, PitMap) and case.pits.pitted_teeth:
        pitted, cols = {case.pits.gear: len(case.pits.pitted_teeth)}, case.pits.grid.n_face
    elif case.pits is not None and not isinstance(case.pits, PitMap):
        pitted, cols = {case.pit_gear: sum(1 for v in case.pits.severity if v > 0)}, case.pit_grid[1]
    for e in case.effects:
        if getattr(e, "rebuilds_stiffness", False) and getattr(e, "gear", None) in ("pinion", "wheel"):
            pitted[e.gear] = pitted.get(e.gear, 0) + 1
    n_slices = so.n_slices
    if n_slices is None:
        n_slices = max(cols, min_n_slices(case.pair)) if cols else default_n_slices(case.pair)
    ppc = so.positions_per_cycle or auto_positions_per_cycle(
        case.fs_hz, case.pair.mesh_frequency_hz(case.operating.speed_rpm))
    require_record_fits(case.pair, ppc, n_slices, pitted, "stiffness.positions_per_cycle")
