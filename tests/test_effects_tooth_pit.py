"""datagen.effects.tooth_pit: a pit on one tooth as an effect the comparison can fit.

Reference: the case's ``[pits]`` table (datagen.pits, datagen.stiffness; tested against the potential-energy
method and the papers in tests/test_stiffness*.py). The effect must give the record that table gives for the same
pit, to the bit; everything else follows from it. Pair: spur-gds with a 25-tooth pinion (ratio exactly 4), so a
wheel revolution is 100 mesh cycles; 1500 rpm, 20 N m, 0.48 s at 10 kHz = 12 pinion / 3 wheel revolutions, every
shaft order on an FFT bin (periodic steady state, rectangular window: exact line amplitudes).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from datagen.effects import EffectSpec
from datagen.effects.tooth_pit import GRID, ToothPit
from datagen.geometry import preset, spur_pair_example
from datagen.pits import PitSpec
from datagen.simulate import Case, OperatingPoint, StiffnessOptions, prepare, simulate
from datagen.stiffness import mesh_stiffness
from features.spectra import line_amplitudes
from gearpit.errors import InputError

_SPUR = spur_pair_example()
PAIR = replace(_SPUR, pinion=replace(_SPUR.pinion, teeth=25), name="spur-gds-z25")
OP = OperatingPoint(speed_rpm=1500.0, torque_nm=20.0)
FS, DUR = 10000.0, 0.48
CH = "acc_pinion_loa_m_s2"


def case(pair=PAIR, **kw):
    return Case(pair=pair, operating=OP, duration_s=DUR, fs_hz=FS, **kw)


def test_the_effect_gives_the_record_of_the_same_pit_in_a_pits_table():
    """Tooth 0 of the pinion, an ellipse of 20 % of the flank drawn with sub-pixel edges (``subpixel``, as the
    effect draws it): the sensor channel of the case with the effect equals that of the case with ``[pits]`` to the
    bit (spur, where the default slicing is resliced at the pit map's columns, and helical); and the healthy case
    differs (the pit is there)."""
    for pair in (PAIR, preset("helical-dct")):
        # one case per call: cases batched together agree only to rounding (1e-12 of the peak)
        (a,), (b,), (c,) = (simulate([cs], channels=[CH]) for cs in (
            case(pair, pits=PitSpec(shape="ellipse", teeth=(0,), severity=0.2, subpixel=True)),
            case(pair, effects=({"name": "tooth_pit", "severity": 0.2},)), case(pair)))
        assert np.array_equal(a.channels[CH], b.channels[CH]), pair.name
        assert np.abs(a.channels[CH] - c.channels[CH]).max() > 0.05 * np.abs(c.channels[CH]).max()


def test_severity_zero_is_the_healthy_pair_and_the_period_is_the_pitted_gears_revolution():
    """No pit: the healthy record, to the bit. A pinion pit repeats once per pinion revolution (25 mesh cycles),
    a wheel pit once per wheel revolution (100)."""
    healthy = prepare(case())
    none = prepare(case(effects=({"name": "tooth_pit", "severity": 0.0},)))
    assert np.array_equal(healthy.record.k, none.record.k) and healthy.record.period_cycles == 1
    assert prepare(case(effects=({"name": "tooth_pit", "gear": "pinion"},))).record.period_cycles == 25
    assert prepare(case(effects=({"name": "tooth_pit", "gear": "wheel"},))).record.period_cycles == 100


def test_a_pit_added_to_a_pitted_case_merges_with_its_pits_and_keeps_its_grid():
    """A case with a [pits] cluster on pinion tooth 3 (96 x 48 grid, 64 slices) plus the effect: the record is that
    of one pit map holding both teeth on that grid (the effect's ellipse drawn there); the effect on the wheel
    beside it gives the record of the two gears' maps."""
    grid = (96, 48)
    spec = PitSpec(shape="cluster", teeth=(3,), severity=0.15, seed=4)
    so = StiffnessOptions(n_slices=64)
    got = prepare(case(pits=spec, pit_grid=grid, stiffness=so, effects=({"name": "tooth_pit", "severity": 0.1},)))
    g = PAIR.flank_grid("pinion", *grid)
    both = spec.build(g, "pinion")
    ell = PitSpec(shape="ellipse", teeth=(0,), severity=0.1, subpixel=True).build(g, "pinion")
    merged = replace(both, depth_m={**both.depth_m, 0: ell.depth_m[0]}, coverage={0: ell.coverage[0]})
    ppc = got.record.positions_per_cycle
    want = mesh_stiffness(PAIR, pits=merged, positions_per_cycle=ppc, n_slices=64)
    assert np.array_equal(got.record.k, want.k_n_per_m[:got.record.k.size])
    wheel = prepare(case(pits=spec, pit_grid=grid, stiffness=so,
                         effects=({"name": "tooth_pit", "severity": 0.1, "gear": "wheel"},)))
    wmap = PitSpec(shape="ellipse", teeth=(0,), severity=0.1, subpixel=True).build(PAIR.flank_grid("wheel", *GRID),
                                                                                   "wheel")
    want_w = mesh_stiffness(PAIR, pits=(both, wmap), positions_per_cycle=ppc, n_slices=64)
    assert wheel.record.period_cycles == 100
    assert np.array_equal(wheel.record.k, want_w.k_n_per_m[:wheel.record.k.size])


def test_the_hertz_correction_applies_to_the_pitted_pair_in_either_order():
    """The pit rebuilds the stiffness, so it runs before the Hertz correction whatever the case's order: both
    orders give the same record, and it is neither the pit alone nor the Hertz term alone."""
    pit = {"name": "tooth_pit", "severity": 0.2}
    hz = {"name": "hertz_nonlinear"}
    a, b = prepare(case(effects=(hz, pit))), prepare(case(effects=(pit, hz)))
    assert np.array_equal(a.record.k, b.record.k)
    assert not np.allclose(a.record.k, prepare(case(effects=(pit,))).record.k)
    assert a.record.period_cycles == 25


def test_a_pinion_pit_raises_the_pinion_sidebands_and_not_the_wheels():
    """Signature (module docstring): a pinion pit modulates the mesh once per pinion revolution, so the sidebands
    fm +/- k fr_pinion (k = 1..3) rise from the healthy pair's (which has none: < 1e-6 of fm) to >= 1 % of fm,
    while the wheel-rate sidebands fm +/- fr_wheel stay at the healthy level (< 1e-6 of fm)."""
    fm, fr1, fr2 = 25 * 25.0, 25.0, 6.25
    h, p = simulate([case(), case(effects=({"name": "tooth_pit", "severity": 0.25},))], channels=[CH])
    freqs = [fm] + [fm + s * k * fr1 for k in (1, 2, 3) for s in (-1, 1)] + [fm - fr2, fm + fr2]
    ah = line_amplitudes(h.channels[CH], FS, freqs, window="boxcar")
    ap = line_amplitudes(p.channels[CH], FS, freqs, window="boxcar")
    assert np.all(ah[1:] < 1e-6 * ah[0])
    assert np.all(ap[1:7] > 0.01 * ap[0])
    assert np.all(ap[7:] < 1e-6 * ap[0])


def test_bad_parameters_are_refused_naming_the_field():
    with pytest.raises(InputError, match="severity"):
        EffectSpec.from_dict({"name": "tooth_pit", "severity": 0.7}).build()
    with pytest.raises(InputError, match="gear"):
        EffectSpec.from_dict({"name": "tooth_pit", "gear": "sun"}).build()
    assert ToothPit().severity == 0.2 and ToothPit.rebuilds_stiffness
