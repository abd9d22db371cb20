"""The mesh record's building (datagen.mesh_excitation.mesh_record): its minimal period, and the moving-centre pair
stiffnesses it reuses from one record to the next."""
from __future__ import annotations

import numpy as np
import pytest

from datagen.geometry import preset
from datagen.stiffness import mesh_stiffness


def test_minimal_period_equals_the_whole_array_test_on_every_divisor():
    """datagen.mesh_excitation.minimal_period tries a divisor on the second period first; its answer must be the
    definition's (the smallest divisor ``d`` of ``P`` after which every array repeats, tested on the whole array),
    also for arrays whose second period repeats the first and a later one does not. Reference: the definition,
    written out here; exact (integers)."""
    from datagen.mesh_excitation import minimal_period

    def definition(P, ppc, *arrays):
        for d in range(1, P + 1):
            if P % d == 0 and all(np.allclose(a.reshape(P // d, d * ppc), a[None, :d * ppc], rtol=1e-12,
                                              atol=1e-12 * np.abs(a).max()) for a in arrays):
                return d
        return P

    rng = np.random.default_rng(4)
    P, ppc = 60, 5
    seen = set()
    for d_true in (1, 2, 3, 4, 6, 12, 20, 60):
        for spoil in (None, 1, 2, 3, P // d_true - 1):
            a = np.tile(rng.normal(size=d_true * ppc), P // d_true)
            b = np.tile(rng.normal(size=d_true * ppc), P // d_true)
            if spoil is not None and spoil * d_true < P:
                a[spoil * d_true * ppc + 2] += 1.0        # one later period differs
            got = minimal_period(P, ppc, a, b)
            assert got == definition(P, ppc, a, b), (d_true, spoil)
            seen.add(got)
    assert {1, 2, 3, 4, 6, 12, 20, 60} <= seen       # the cases reach every answer, the spoiled ones included


def test_a_record_reuses_the_moving_centres_pairs_only_for_the_same_pair_and_displacements(monkeypatch):
    """mesh_record keeps the last pair stiffnesses at the moved centres (datagen.mesh_excitation
    ._slots_at_centre_offset_reused): a second record with the same stiffness record and the same eccentricity
    (another pitch error) reuses them; another eccentricity or another stiffness record computes them again; a
    record made with the reused pairs equals one made from scratch to the bit, and the kept array is read-only."""
    import datagen.mesh_excitation as me
    from datagen.effects import EffectContext, get

    calls = []
    real = me.slots_at_centre_offset
    monkeypatch.setattr(me, "slots_at_centre_offset", lambda *a, **k: calls.append(1) or real(*a, **k))
    monkeypatch.setattr(me, "_LAST_SLOTS", [])
    pair = preset("spur-gds")
    ms = mesh_stiffness(pair)
    ctx = EffectContext(pair=pair, speed_rpm=1000.0, torque_nm=50.0)
    ecc = get("eccentricity_pinion")

    def record(grade, amplitude_m, stiffness=ms):
        return me.mesh_record(stiffness, (get("pitch_error")(grade=grade), ecc(amplitude_m=amplitude_m)), ctx)

    record(6.0, 30e-6)
    reused = record(8.0, 30e-6)
    assert len(calls) == 1
    with pytest.raises(ValueError):
        reused.k_slots[0, 0] = 0.0
    record(8.0, 31e-6)
    assert len(calls) == 2
    other = mesh_stiffness(pair, positions_per_cycle=ms.positions_per_cycle, edges=ms.edges)   # the cached object
    assert other is ms
    import copy
    record(8.0, 31e-6, stiffness=copy.copy(ms))
    assert len(calls) == 3
    me._LAST_SLOTS.clear()
    fresh = record(8.0, 30e-6)
    assert len(calls) == 4
    for name in ("k", "error_force", "k_slots", "e_slots"):
        assert np.array_equal(getattr(fresh, name), getattr(reused, name)), name

