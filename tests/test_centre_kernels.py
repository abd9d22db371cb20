"""The moving-centre record's fast paths (hook 2c) against their references: the banded sum of a staggered pair's
slices against the slice-by-slice rule, the unstaggered slices summed first, and the compiled kernels
(datagen.compiled_records, datagen.compiled_centre) against the numpy rules (``COMPILED = False``). The
geometry itself is checked in test_centre_offset.py."""
from __future__ import annotations

import numpy as np
import pytest

from datagen.geometry import preset
from datagen.stiffness import face_slices, mesh_stiffness
from test_centre_offset import _rect_pit


@pytest.mark.parametrize("ppc,edges,pitted", [(64, "box", False), (256, "box", True), (64, "point", False)])
@pytest.mark.parametrize("q", [8, 3])
def test_banded_slice_sums_equal_the_slice_by_slice_rule(ppc, edges, pitted, q):
    """A helical pair's record on subdivided steps sums each point's slices by contact bands
    (datagen.centre_banded.points_banded: the inside run from prefix sums, the two edge bands by the full
    rule). Reference: the slice-by-slice rule (_points), the same formula on every slice. Tolerance: rounding,
    1e-12 of the largest pair stiffness (measured 1e-15). Displacements: none, sub-step, 30 um and 150 um
    towards the pinion (early entry), turning over the record, so every band case occurs."""
    import datagen.centre_banded as co

    pair = preset("helical-dct")
    ms = mesh_stiffness(pair, pits=_rect_pit(pair) if pitted else None, positions_per_cycle=ppc, edges=edges)
    h = pair.base_pitch_m / ppc
    _, _, shift = face_slices(pair, ms.n_slices)
    assert co.banded_pays(shift / h, ms.n_slices)       # the banded path is the one taken
    assert not co.banded_pays(np.zeros(200), 200)       # a spur pair's pixel slices keep the slice-by-slice sum
    n = ms.period_cycles * ppc * q
    th = 2 * np.pi * np.arange(n) / n * 1.3 + 0.4
    for amp, toward in ((0.0, 0.0), (0.3e-6, 0.0), (30e-6, 0.0), (150e-6, -100e-6)):
        dx, dy = amp * np.cos(th) + toward, amp * np.sin(th)
        fast = ms.slots_at_centre_offset(dx, dy, subdivisions=q)
        old, co.BANDED_MIN_SLICES = co.BANDED_MIN_SLICES, 10 ** 9
        try:
            slow = ms.slots_at_centre_offset(dx, dy, subdivisions=q)
        finally:
            co.BANDED_MIN_SLICES = old
        assert np.abs(fast).max() > 0 and (amp < 100e-6 or np.any(slow[:, -1] > 0))
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12 * np.abs(slow).max())


def test_unstaggered_slices_summed_before_the_rule_equal_the_slice_by_slice_sum(monkeypatch):
    """A pitted spur flank has one slice per pixel column, all with the same contact edges: the rule's weights
    are the same on every slice and it is linear in the slice values, so slots_at_centre_offset sums the slices
    first (MERGE_UNSTAGGERED). Reference: the rule slice by slice. Tolerance: rounding, 1e-12 of the largest
    pair stiffness; a 30 um eccentricity turning over the record on 8 points per step."""
    import datagen.centre_offset as co

    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, pits=_rect_pit(pair), n_slices=200)
    q, ppc = 8, ms.positions_per_cycle
    n = ms.period_cycles * ppc * q
    th = 2 * np.pi * np.arange(n) / n
    dx, dy = 30e-6 * np.cos(th), 30e-6 * np.sin(th)
    merged = ms.slots_at_centre_offset(dx, dy, subdivisions=q)
    monkeypatch.setattr(co, "MERGE_UNSTAGGERED", False)
    slow = ms.slots_at_centre_offset(dx, dy, subdivisions=q)
    assert ms.n_slices == 200 and np.abs(merged).max() > 0
    np.testing.assert_allclose(merged, slow, rtol=0, atol=1e-12 * np.abs(slow).max())
    assert not np.array_equal(slow[:, 0], np.roll(slow[:, 0], 1))      # the record is not trivial


@pytest.mark.parametrize("edges", ["box", "point"])
@pytest.mark.parametrize("pitted", [False, True])
def test_compiled_one_slice_rule_gives_the_numpy_rule_to_the_bit(monkeypatch, edges, pitted):
    """A record of one slice (a healthy spur pair, or a pitted spur flank's pixel columns summed) takes the
    compiled point rule (``compiled_records.points_one_slice``): the same IEEE operations as the numpy rule ``_points``
    (``COMPILED = False``), so the records must be equal to the bit, signed zeros included, for an eccentric
    wheel over a revolution at 4 and 8 points per step."""
    from datagen import centre_offset
    from datagen.centre_offset import slots_at_centre_offset
    from datagen.flank import PitMap

    pair = preset("spur-gds")
    pits = None
    if pitted:
        grid = pair.flank_grid("pinion", 30, 40)
        d = np.zeros(grid.shape)
        d[8:20, 5:25] = 0.2e-3
        pits = PitMap(grid=grid, depth_m={2: d}, gear="pinion")
    ms = mesh_stiffness(pair, pits=pits, positions_per_cycle=32, edges=edges)
    for q in (4, 8):
        n = ms.period_cycles * 32 * q
        th = 2 * np.pi * np.arange(n) / n * 3.0
        dx, dy = 25e-6 * np.cos(th + 0.4), 25e-6 * np.sin(th + 0.4)
        compiled = slots_at_centre_offset(ms, dx, dy, subdivisions=q)
        monkeypatch.setattr(centre_offset, "COMPILED", False)
        reference = slots_at_centre_offset(ms, dx, dy, subdivisions=q)
        monkeypatch.setattr(centre_offset, "COMPILED", True)
        assert np.array_equal(compiled, reference) and np.array_equal(np.signbit(compiled), np.signbit(reference))
        assert np.ptp(compiled.sum(axis=1)) > 0.1 * compiled.sum(axis=1).mean()    # a stiffness that varies


@pytest.mark.parametrize("ppc,q,slots", [(4, 8, 3), (5, 3, 1), (1, 2, 2), (64, 8, 4)])
def test_compiled_refinement_equals_the_numpy_rule_to_the_bit(monkeypatch, ppc, q, slots):
    """refine_slots by the compiled kernel (datagen.compiled_records.refine_slots_into) against the numpy rule
    (COMPILED = False), on random records with zeros, negative values and signed zeros: the same IEEE operations
    in the same order, so the same bits; also across the record's end (the last cycle wraps to the first)."""
    import datagen.centre_offset as co

    rng = np.random.default_rng(slots)
    x = rng.normal(size=(3 * ppc, slots)) * 1e8
    x[rng.random(x.shape) < 0.2] = 0.0
    x[rng.random(x.shape) < 0.05] = -0.0
    fast = co.refine_slots(x, ppc, q)
    monkeypatch.setattr(co, "COMPILED", False)
    slow = co.refine_slots(x, ppc, q)
    assert fast.shape == slow.shape == (3 * ppc * q, slots + 1)
    assert fast.tobytes() == slow.tobytes()


def test_compiled_table_lookup_and_slice_stiffness_give_numpy_bits():
    """The compiled slice stiffnesses (datagen.compiled_centre.slice_stiffness_into) read the compliance table by
    index instead of np.interp's binary search: the same IEEE operations, so the same bits. Reference: np.interp on
    the pair's own table (points on nodes, between them, outside both ends, on the last node) and on a table of
    uneven steps (the index guess is then wrong and corrected); the slice stiffness against
    dw / np.interp(slot_positions + dg), slots -1..S-1 of a helical pair with displacements of +/-1 mm."""
    from datagen.compiled_centre import _interp_uniform, slice_stiffness_into
    from datagen.compliance import pair_compliance
    from datagen.stiffness import slot_positions

    pair = preset("helical-dct")
    table = pair_compliance(pair)
    g, c = table.g_table_m, table.c_table
    rng = np.random.default_rng(4)
    x = np.concatenate([rng.uniform(g[0] - 1e-3, g[-1] + 1e-3, 20000), g, [g[0], g[-1], np.nextafter(g[-1], 0)]])
    inv = (g.size - 1) / (g[-1] - g[0])
    assert np.array_equal([_interp_uniform(v, g, c, inv) for v in x], np.interp(x, g, c))
    g2 = np.sort(rng.uniform(0.0, 1.0, 50))
    c2 = rng.normal(size=50)
    x2 = rng.uniform(-0.1, 1.1, 5000)
    inv2 = (g2.size - 1) / (g2[-1] - g2[0])
    assert np.array_equal([_interp_uniform(v, g2, c2, inv2) for v in x2], np.interp(x2, g2, c2))

    ms = mesh_stiffness(pair, positions_per_cycle=32)
    dw, _, shift = face_slices(pair, ms.n_slices)
    slots = np.arange(-1, ms.n_slots)
    rows = np.arange(3 * 32)[::-1].copy()
    dg = rng.uniform(-1e-3, 1e-3, rows.size)
    v = np.empty((rows.size, slots.size + 1, shift.size))
    slice_stiffness_into(32, float(pair.contact_start_m), float(pair.base_pitch_m), slots, shift, rows, dg, g, c,
                         float(dw), v)
    pos = slot_positions(pair, (rows % 32) / 32, slots, shift)
    pos += dg[:, None, None]
    ref = dw / table(pos)
    assert np.array_equal(v[:, :-1], ref) and np.array_equal(v[:, -1], ref[:, -1])
    assert np.any(pos < g[0]) and np.any(pos > g[-1]) and np.any((pos > g[0]) & (pos < g[-1]))  # every branch


@pytest.mark.parametrize("pitted,edges", [(False, "box"), (True, "box"), (True, "point")])
def test_compiled_banded_record_block_by_block_equals_the_numpy_rules(monkeypatch, pitted, edges):
    """A helical pair's moving-centre record, compiled and block by block (datagen.centre_banded.banded_record:
    the slice values of 37 grid samples at a time, so blocks end inside cycles and the last one wraps to the
    record's first sample), against the numpy rules on the whole record (COMPILED = False: np.interp, the
    numpy banded rule). Tolerance: rounding, 1e-12 of the largest pair stiffness (measured: the same bits).
    A truncated record of a pitted pinion (held cycles 5..9 of its period, so the pitted engagement is found
    through ``cycles``) with a 60 um eccentricity turning over it and an early entry."""
    import datagen.centre_offset as co

    pair = preset("helical-dct")
    ms = mesh_stiffness(pair, pits=_rect_pit(pair, tooth=7) if pitted else None, positions_per_cycle=64,
                        edges=edges)
    q, ppc, n = 8, 64, 5
    th = 2 * np.pi * np.arange(n * ppc * q) / (n * ppc * q) * 0.7
    dx, dy = 60e-6 * np.cos(th) - 40e-6, 60e-6 * np.sin(th)
    cycles = np.arange(5, 10)
    monkeypatch.setattr(co.banded_record, "__defaults__", (37,))
    fast = co.slots_at_centre_offset(ms, dx, dy, subdivisions=q, cycles=cycles)
    monkeypatch.setattr(co, "COMPILED", False)
    slow = co.slots_at_centre_offset(ms, dx, dy, subdivisions=q, cycles=cycles)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12 * np.abs(slow).max())
    assert np.any(slow[:, -1] > 0)                                       # the early pair enters
    if pitted:       # the pit is in the held cycles: the record differs from the healthy pair's
        healthy = co.slots_at_centre_offset(mesh_stiffness(pair, positions_per_cycle=64, edges=edges,
                                                           n_slices=ms.n_slices), dx, dy, subdivisions=q)
        assert np.abs(healthy.sum(axis=1) - slow.sum(axis=1)).max() > 0.02 * slow.sum(axis=1).max()
