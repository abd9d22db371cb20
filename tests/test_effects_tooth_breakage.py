"""datagen.effects.tooth_breakage: one tooth broken over part of its face width, as an effect the comparison fits.

References: Chaari et al. (2008), Eur. J. Mech. A/Solids 27, 691-705: a tooth breakage is a loss of the width that
carries load, and every energy term of the potential-energy method (Hertz, bending, shear, axial compression,
fillet foundation) scales with that width, so the broken pair keeps (1 - broken fraction) of its stiffness over
its whole mesh; the pair's transverse contact ratio (ISO 21771) sets how long that mesh lasts. Pair: spur-gds with
a 25-tooth pinion (ratio exactly 4), 1500 rpm, 20 N m, 0.48 s at 10 kHz = 12 pinion / 3 wheel revolutions.
"""
from __future__ import annotations

import numpy as np
import pytest
# the same rig as the pit's tests (spur-gds with 25 pinion teeth, 1500 rpm, 20 N m, 0.48 s at 10 kHz)
from test_effects_tooth_pit import CH, FS, PAIR, case

from datagen.effects import EffectSpec
from datagen.effects.tooth_breakage import BROKEN_DEPTH_M, ToothBreakage, broken_band
from datagen.effects.tooth_pit import GRID
from datagen.flank import PitMap
from datagen.geometry import preset
from datagen.simulate import prepare, simulate
from datagen.stiffness import mesh_stiffness
from features.spectra import line_amplitudes
from gearpit.errors import InputError


def breakage(**kw):
    return case(effects=({"name": "tooth_breakage", **kw},))


def test_the_effect_is_the_pit_map_of_the_broken_band():
    """The record with the effect equals the stiffness of the same band written as a pit map by hand (columns 0..19
    of 64 for 0.3 of the face, every profile row; the top 32 rows for half the height), spur and helical."""
    for pair in (PAIR, preset("helical-dct")):
        grid = pair.flank_grid("pinion", *GRID)
        for height, rows in ((1.0, slice(0, 64)), (0.5, slice(32, 64))):
            got = prepare(case(pair, effects=({"name": "tooth_breakage", "width_fraction": 0.3,
                                               "height_fraction": height},))).record
            d = np.zeros(grid.shape)
            d[rows, :19] = BROKEN_DEPTH_M          # round(0.3 * 64) = 19 columns
            want = mesh_stiffness(pair, pits=PitMap(grid=grid, depth_m={0: d}, gear="pinion"),
                                  positions_per_cycle=got.positions_per_cycle)
            assert np.array_equal(got.k, want.k_n_per_m[:got.k.size]), (pair.name, height)


def test_the_broken_pair_keeps_the_unbroken_fraction_of_its_stiffness_over_its_whole_mesh():
    """Chaari et al. (2008): the stiffness lost is the broken fraction w of the broken tooth's pair stiffness, so
    (k_healthy - k_broken) / w is the same for w = 1/4 and 1/2 (16 and 32 of 64 columns: exact) to rounding
    (1e-9); where the broken tooth meshes alone (single contact) it is the whole mesh stiffness; it is lost over
    the broken tooth's mesh only, eps_alpha mesh cycles of the 25 (within one position of the record)."""
    h = prepare(case()).record
    recs = {w: prepare(breakage(width_fraction=w)).record for w in (0.25, 0.5)}
    kh = np.tile(h.k, recs[0.25].period_cycles)
    losses = {w: (kh - r.k) / w for w, r in recs.items()}
    scale = kh.max()
    assert np.allclose(losses[0.25], losses[0.5], rtol=0, atol=1e-9 * scale)
    lost = losses[0.5] > 1e-9 * scale
    ppc = h.positions_per_cycle
    eps = PAIR.contact_ratio_transverse
    assert abs(lost.sum() / ppc - eps) <= 1.5 / ppc, (lost.sum() / ppc, eps)
    # single contact: the broken tooth alone carries the load, so the whole stiffness is its pair's
    low = h.k < 0.8 * h.k.max()
    low &= np.roll(low, 1) & np.roll(low, -1)        # inside the single-contact zone (its box-edge cells mix both)
    single = np.tile(low, recs[0.5].period_cycles) & lost
    assert single.sum() >= 0.5 * (2 - eps) * ppc
    assert np.allclose(losses[0.5][single], kh[single], rtol=1e-9)
    # never more than the pair has (outside the broken tooth's mesh the records agree to rounding: the count above)
    assert np.all(losses[0.5] <= kh * (1 + 1e-12))


def test_a_tip_break_loses_stiffness_only_while_the_tip_meshes():
    """Half the profile broken from the tip: the positions that lose stiffness are a proper subset of those of the
    break at the root, and they are one run at the end of the pinion tooth's mesh (the driving pinion's flank is
    in contact from its root to its tip)."""
    root = prepare(breakage(width_fraction=0.5)).record
    tip = prepare(breakage(width_fraction=0.5, height_fraction=0.5)).record
    h = np.tile(prepare(case()).record.k, root.period_cycles)
    lr, lt = (h - root.k) > 1e-9 * h.max(), (h - tip.k) > 1e-9 * h.max()
    assert np.all(lr[lt]) and 0 < lt.sum() < lr.sum()
    idx_r, idx_t = np.flatnonzero(lr), np.flatnonzero(lt)
    assert np.all(np.diff(idx_t) == 1) and idx_t[-1] == idx_r[-1] and idx_t[0] > idx_r[0]


def test_width_zero_is_the_healthy_pair_and_a_wheel_break_repeats_once_per_wheel_revolution():
    healthy = prepare(case()).record
    none = prepare(breakage(width_fraction=0.0)).record
    assert np.array_equal(healthy.k, none.k) and none.period_cycles == 1
    assert prepare(breakage(gear="wheel")).record.period_cycles == 100
    assert broken_band(PAIR.flank_grid("pinion", *GRID), 0.005, 1.0) is None     # under half a column


def test_a_pinion_break_raises_the_pinion_sidebands_and_not_the_wheels():
    """Signature (module docstring): a break of 0.2 of the pinion tooth's width raises the sidebands fm +/- k
    fr_pinion (k = 1..3) from nothing (< 1e-6 of fm) to >= 0.5 % of fm; the wheel's fm +/- fr_wheel stay < 1e-6."""
    fm, fr1, fr2 = 25 * 25.0, 25.0, 6.25
    h, b = simulate([case(), breakage(width_fraction=0.2)], channels=[CH])
    freqs = [fm] + [fm + s * k * fr1 for k in (1, 2, 3) for s in (-1, 1)] + [fm - fr2, fm + fr2]
    ah, ab = (line_amplitudes(r.channels[CH], FS, freqs, window="boxcar") for r in (h, b))
    assert np.all(ah[1:] < 1e-6 * ah[0])
    assert np.all(ab[1:7] > 0.005 * ab[0])
    assert np.all(ab[7:] < 1e-6 * ab[0])


def test_bad_parameters_are_refused_naming_the_field():
    with pytest.raises(InputError, match="width_fraction"):
        EffectSpec.from_dict({"name": "tooth_breakage", "width_fraction": 0.9}).build()
    with pytest.raises(InputError, match="height_fraction"):
        EffectSpec.from_dict({"name": "tooth_breakage", "height_fraction": 0.0}).build()
    with pytest.raises(InputError, match="gear"):
        EffectSpec.from_dict({"name": "tooth_breakage", "gear": "ring"}).build()
    assert ToothBreakage().width_fraction == 0.3 and ToothBreakage.rebuilds_stiffness
