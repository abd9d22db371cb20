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



def _pitted_pinion(pair, tooth):
    from datagen.flank import PitMap

    grid = pair.flank_grid("pinion", 40, 20)
    d = np.zeros(grid.shape)
    d[10:25, 5:15] = 0.2e-3
    return PitMap(grid=grid, depth_m={tooth: d}, gear="pinion")


def test_a_truncated_record_holds_the_whole_records_values_at_the_cycles_it_keeps():
    """mesh_record with ``cycles_needed`` (a time-stepped case's cycles) and moving centres keeps cycles
    0 .. needed (one spare, whose last grid step interpolates towards the next stored cycle) and the last
    TRUNCATE_BEHIND_CYCLES of the period (stored after them, where a periodic lookup of a slightly negative
    position reads them). Reference: the record of the whole period (a pinion pitch error and a wheel
    eccentricity, 29 / 100 teeth: hunting period 2900 cycles), built without truncation, at the same cycles;
    with a pitted pinion tooth (the pitted samples depend on which cycle a record cycle stands for). Equal to
    rounding (1e-12 of the record's largest value); the period is the whole record's; the mean stiffness too for a
    healthy pair (its stiffness repeats every wheel revolution: 1e-12), within 1e-3 for the pitted one (it repeats
    every 2900 cycles: an estimate over 300), the mean error force within 2 % of its standard deviation.
    A record without moving centres is not truncated (it is cheap whole)."""
    import datagen.mesh_excitation as me
    from datagen.effects import EffectContext, get

    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, pits=_pitted_pinion(pair, 7), positions_per_cycle=32)
    ctx = EffectContext(pair=pair, speed_rpm=1000.0, torque_nm=50.0)
    fx = (get("pitch_error")(grade=7.0), get("eccentricity_wheel")(amplitude_m=30e-6))
    both = (get("pitch_error")(grade=7.0, gears="both"),)
    assert me.mesh_record(ms, both, ctx, cycles_needed=300).valid_cycles is None
    full = me.mesh_record(ms, fx, ctx)
    me._LAST_SLOTS.clear()
    needed = 300
    cut = me.mesh_record(ms, fx, ctx, cycles_needed=needed)
    P, ppc = full.period_cycles, full.positions_per_cycle
    behind = me.TRUNCATE_BEHIND_CYCLES
    assert P == 2900 and cut.period_cycles == P
    assert cut.valid_cycles == (-behind, needed) and cut.stored_cycles == needed + 1 + behind
    keep = np.concatenate([np.arange(needed), np.arange(P - behind, P)])
    held = np.concatenate([np.arange(needed), needed + 1 + np.arange(behind)])     # where cut stores them
    for name in ("k", "error_force", "k_slots", "e_slots"):
        a = getattr(full, name).reshape((P, ppc) + getattr(full, name).shape[1:])[keep]
        b = getattr(cut, name).reshape((cut.stored_cycles, ppc) + a.shape[2:])[held]
        assert np.allclose(b, a, rtol=0, atol=1e-12 * np.abs(a).max()), name
    # pitted: the stiffness repeats only after 2900 cycles too, its mean over 300 is an estimate
    assert cut.mean_k_n_per_m == pytest.approx(float(np.mean(full.k)), rel=1e-3)
    e_scale = float(np.std(full.error_force))
    assert abs(cut.mean_error_force_n - float(np.mean(full.error_force))) <= 0.02 * e_scale
    healthy = mesh_stiffness(pair, positions_per_cycle=32)
    me._LAST_SLOTS.clear()
    h_full = me.mesh_record(healthy, fx, ctx)
    h_cut = me.mesh_record(healthy, fx, ctx, cycles_needed=needed)
    assert h_cut.valid_cycles is not None
    assert h_cut.mean_k_n_per_m == pytest.approx(float(np.mean(h_full.k)), rel=1e-12)
    with pytest.raises(ValueError, match="truncated"):
        cut.distinct_cycles()
    # a period barely longer than the cycles needed is kept whole
    me._LAST_SLOTS.clear()
    whole = me.mesh_record(ms, fx, ctx, cycles_needed=P - me.TRUNCATE_MARGIN_CYCLES - 1)
    assert whole.valid_cycles is None and whole.stored_cycles == P


def test_a_time_stepped_case_on_a_truncated_record_gives_the_whole_records_response(monkeypatch):
    """A time-stepped case (given start-up) whose record period exceeds its run (pitch error on both gears and a
    wheel eccentricity: spur-gds hunting period 2900 cycles, 2.9 s at 1000 rpm; run 0.05 + 0.2 s) reads a
    truncated record (datagen.batch_solve.cycles_rolled). Reference: the same case on the whole record
    (cycles_rolled patched to None). Tolerance: 1e-4 of the RMS, for every channel; the records' means (mean
    stiffness, hence mesh damping, and the static start) are taken over the cycles held, which differ from the
    period's by a fraction of the eccentricity's modulation (measured 4e-5 of the RMS at most). And a run that
    rolls beyond its record (cycles_rolled patched to too few) raises instead of reading the wrong cycles."""
    import datagen.batch_solve as batch
    from datagen.case_options import SolverOptions
    from datagen.effects import EffectSpec
    from datagen.simulate import Case, OperatingPoint, simulate

    fx = tuple(EffectSpec.from_dict(d).build() for d in ({"name": "pitch_error", "grade": 7.0},
                                                          {"name": "eccentricity_wheel", "amplitude_m": 30e-6}))
    case = Case(pair=preset("spur-gds"), operating=OperatingPoint(1000.0, 50.0), duration_s=0.2, fs_hz=10000.0,
                effects=fx, solver=SolverOptions(method="transient", transient_s=0.15))
    assert batch.cycles_rolled(case) < 0.5 * 2900
    cut_rec = batch.prepare(case).record
    assert cut_rec.valid_cycles is not None and cut_rec.period_cycles == 2900
    got = simulate([case])[0]
    assert got.metadata["solver"]["record_cycles"] < 2900
    monkeypatch.setattr(batch, "cycles_rolled", lambda c, ctx=None: None)
    ref = simulate([case])[0]
    assert ref.metadata["solver"]["record_cycles"] == 2900
    for name, b in ref.channels.items():
        a = got.channels[name]
        rms = np.sqrt(np.mean(np.square(b - np.mean(b))))
        if rms > 0:
            print(name, np.sqrt(np.mean(np.square(a - b))) / rms, np.sqrt(np.mean(np.square(a - b)[-500:])) / rms)
            pass
    monkeypatch.setattr(batch, "cycles_rolled", lambda c, ctx=None: 40)
    with pytest.raises(RuntimeError, match="rolled through mesh cycles"):
        simulate([case])


def test_a_speed_fluctuation_that_runs_fast_gets_a_record_long_enough():
    """cycles_rolled integrates the speed of an operating-point effect: a speed fluctuation of 20 % (its bound) at
    0.5 Hz starting at its crest runs the pinion about 19 % ahead of its mean angle over a 0.35 s run, beyond
    ROLL_FACTOR's 10 %. Reference: the integral of ``1 + 0.2 cos(2 pi 0.5 t)`` written out (1.19 of the mean cycles
    over 0.35 s), within 1 %; and the case (wheel eccentricity beside a pinion pitch error: a truncated record)
    simulates without leaving its record, its accelerations as on the whole record to 5e-4 of their RMS."""
    import math

    import datagen.batch_solve as batch
    from datagen.case_options import SolverOptions
    from datagen.effects import EffectSpec
    from datagen.simulate import Case, OperatingPoint, simulate

    fx = tuple(EffectSpec.from_dict(d).build() for d in (
        {"name": "pitch_error", "grade": 7.0}, {"name": "eccentricity_wheel", "amplitude_m": 30e-6},
        {"name": "speed_fluctuation", "amplitude_fraction": 0.2, "frequency_hz": 0.5, "phase_rad": math.pi / 2}))
    pair = preset("spur-gds")
    case = Case(pair=pair, operating=OperatingPoint(1000.0, 50.0), duration_s=0.2, fs_hz=10000.0,
                effects=fx, solver=SolverOptions(method="transient", transient_s=0.15))
    T = 0.15 + 0.2 + 2.0 / 10000.0
    turns = 1000.0 / 60.0 * (T + 0.2 * math.sin(2 * math.pi * 0.5 * T) / (2 * math.pi * 0.5))
    expected = batch.ROLL_FACTOR * turns * pair.pinion.teeth + batch.ROLL_SPARE_CYCLES
    got_cycles = batch.cycles_rolled(case)
    assert got_cycles == pytest.approx(expected, rel=0.01)
    assert got_cycles > 1.05 * batch.ROLL_FACTOR * T * pair.mesh_frequency_hz(1000.0)    # the nominal would be short
    got = simulate([case])[0]
    assert got.metadata["solver"]["record_cycles"] < 2900
    monkey = pytest.MonkeyPatch()
    try:
        monkey.setattr(batch, "cycles_rolled", lambda c, ctx=None: None)
        ref = simulate([case])[0]
    finally:
        monkey.undo()
    for name in ("acc_pinion_loa_m_s2", "acc_wheel_loa_m_s2"):
        a, b = got.channels[name], ref.channels[name]
        rms = np.sqrt(np.mean(np.square(b - np.mean(b))))
        assert np.sqrt(np.mean(np.square(a - b))) <= 5e-4 * rms, name
