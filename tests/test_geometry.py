"""Gear geometry: derived quantities against hand formulas and the papers; impossible pairs refused."""
import math
from dataclasses import replace

import pytest

from datagen.geometry import Gear, GearPair, helical_pair_example, preset, spur_pair_example
from datagen.pair_file import load_pair, pair_from_dict
from gearpit.errors import DesignError, InputError


def test_helical_paper_frequencies():
    """Helical paper eqs: fr = 2500/60 = 41.67 Hz, fm = 17 fr = 708.3 Hz (tolerance 0.1 Hz)."""
    p = helical_pair_example()
    assert p.shaft_frequency_hz("pinion", 2500) == pytest.approx(41.67, abs=0.01)
    assert p.mesh_frequency_hz(2500) == pytest.approx(708.3, abs=0.1)
    assert p.shaft_frequency_hz("wheel", 2500) == pytest.approx(41.667 * 17 / 60, rel=1e-4)


def test_spur_paper_mesh_frequency():
    """Spur paper: fm = 241.6 Hz at 500 rpm with a 29-tooth pinion (paper rounds down; 0.1 Hz)."""
    assert spur_pair_example().mesh_frequency_hz(500) == pytest.approx(241.6, abs=0.1)


def test_contact_ratio_matches_physics_md_formula():
    """PHYSICS.md section 1 closed form for eps_alpha (unshifted pair, alpha_w = alpha_t); rel 1e-12."""
    for p in (spur_pair_example(), helical_pair_example()):
        rb1, rb2 = p.base_radius_m("pinion"), p.base_radius_m("wheel")
        ra1, ra2 = p.tip_radius_m("pinion"), p.tip_radius_m("wheel")
        a = p.pitch_radius_m("pinion") + p.pitch_radius_m("wheel")
        at = p.pressure_angle_t_rad
        eps = (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - a * math.sin(at)) / (math.pi * p.module_t_m * math.cos(at))
        assert p.contact_ratio_transverse == pytest.approx(eps, rel=1e-12)
        assert p.contact_ratio_overlap == pytest.approx(p.contact_face_width_m * math.sin(p.helix_angle_rad) / (math.pi * p.module_n_m), rel=1e-12)


def test_helical_preset_values():
    """Helical paper Table 1: 17/60, mn 2.1 mm, 17.5 deg, 29 deg; hand-computed transverse module 2.401 mm."""
    p = preset("helical-dct")
    assert p.module_t_m == pytest.approx(2.1e-3 / math.cos(math.radians(29)), rel=1e-12)
    assert p.module_t_m == pytest.approx(2.401e-3, abs=1e-6)
    assert p.contact_ratio_overlap > 1.0  # 16.9 mm * sin 29 / (pi * 2.1 mm) = 1.242
    assert p.contact_ratio_overlap == pytest.approx(1.242, abs=1e-3)


def test_profile_shift_changes_centre_distance():
    """Positive shift sum widens the centre distance: a_w > a_0 (ISO 21771 working pressure angle)."""
    p = spur_pair_example()
    q = replace(p, pinion=replace(p.pinion, profile_shift=0.3))
    assert q.centre_distance_m > p.centre_distance_m
    assert q.working_pressure_angle_rad > p.working_pressure_angle_rad


@pytest.mark.parametrize("change, word", [
    (dict(pinion=Gear(teeth=10, face_width_m=0.02, bore_radius_m=0.005)), "undercut"),
    (dict(pinion=Gear(teeth=29, face_width_m=0.02, profile_shift=1.4, bore_radius_m=0.012)), "pointed"),
    (dict(addendum_coef=0.5, dedendum_coef=0.8, pressure_angle_n_rad=math.radians(25)), "contact ratio"),
    (dict(pinion=Gear(teeth=29, face_width_m=0.02, bore_radius_m=0.027)), "rim"),
])
def test_impossible_pairs_refused(change, word):
    """Undercut, pointed tip, contact ratio < 1 and a bore through the root: DesignError naming the cause."""
    with pytest.raises(DesignError, match=word):
        replace(spur_pair_example(), **change)


def test_interference_refused():
    """A 12-tooth pinion with a long-addendum wheel: wheel tip beyond T1 (involute interference)."""
    with pytest.raises(DesignError, match="interference|undercut"):
        GearPair(pinion=Gear(teeth=14, face_width_m=0.02, profile_shift=0.4, bore_radius_m=0.004),
                 wheel=Gear(teeth=200, face_width_m=0.02, profile_shift=0.0, bore_radius_m=0.04),
                 module_n_m=2e-3, addendum_coef=1.4, dedendum_coef=1.65)


@pytest.mark.parametrize("field, value", [("face_width_mm", -5.0), ("teeth", 0), ("teeth", 2.5)])
def test_non_positive_sizes_refused(field, value):
    d = spur_pair_example().to_dict()
    d["pinion"][field] = value
    with pytest.raises(InputError, match=f"pinion.{field}"):
        pair_from_dict(d)


def test_toml_round_trip_and_unknown_key(tmp_path):
    """to_dict -> TOML -> load gives the same derived geometry; a typo key is refused by name."""
    p = helical_pair_example()
    lines = ['[pair]', 'name = "x"', 'preset = "helical-dct"', 'helix_angle_deg = 29.0']
    f = tmp_path / "pair.toml"
    f.write_text("\n".join(lines))
    q = load_pair(f)
    assert q.contact_ratio_transverse == pytest.approx(p.contact_ratio_transverse, rel=1e-12)
    f.write_text('[pair]\npreset = "spur-gds"\nmodul_n_mm = 2\n')
    with pytest.raises(InputError, match="modul_n_mm"):
        load_pair(f)
    f.write_text('[pair\n')
    with pytest.raises(InputError, match="valid TOML"):
        load_pair(f)


def test_preset_with_overrides_gets_its_own_name():
    """A pair made from a preset with a changed key must not carry the preset's name: sweeps key their classes and
    models check pairs by it, so ``spur-gds`` with a 15 deg helix would have been taken for ``spur-gds``."""
    helical = pair_from_dict({"preset": "spur-gds", "helix_angle_deg": 15})
    assert helical.name == "spur-gds[helix_angle_deg=15]"
    assert helical.helix_angle_rad == pytest.approx(math.radians(15))
    nested = pair_from_dict({"preset": "spur-gds", "pinion": {"teeth": 30}, "material": {"youngs_modulus_gpa": 200}})
    assert nested.name == "spur-gds[pinion.teeth=30,material.youngs_modulus_gpa=200]"
    assert pair_from_dict({"preset": "spur-gds", "helix_angle_deg": 0}) == preset("spur-gds")   # no change: same pair
    assert pair_from_dict({"preset": "spur-gds", "name": "rig 2", "helix_angle_deg": 15}).name == "rig 2"
