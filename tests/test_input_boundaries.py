"""Values at the file and command-line boundary: one allowed range per quantity, stated in the unit the user wrote,
checked before any work (pit depth, torque, effect parameters, pair keys)."""
from __future__ import annotations

import copy

import pytest

from datagen.effects.base import EffectSpec
from datagen.effects.pitch_error import PitchError
from datagen.effects.tooth_pit import ToothPit
from datagen.pair_file import pair_from_dict
import datagen.pits as pits
from datagen.pits import PitSpec
from datagen.simulate import Case
from datagen.sweep import sweep_from_dict
from gearpit.cli import main
from gearpit.errors import DesignError, InputError

SWEEP = {
    "sweep": {"name": "t", "seed": 3, "samples_per_class": 1, "fs_hz": 4096.0, "duration_s": 0.1,
              "pairs": ["spur-gds"]},
    "classes": {"shapes": ["ellipse"], "teeth": ["0", "1"],
                "severity_bins": {"healthy": [0.0, 0.0], "minor": [0.03, 0.08]}},
    "pits": {"grid_px": [30, 60], "depth_mm": [0.1, 0.3]},
    "operating": {"speed_rpm": [1150.0, 1250.0], "torque_nm": [20.0, 40.0]},
}
CASE = {"duration_s": 0.1, "fs_hz": 4096.0, "pair": {"preset": "spur-gds"},
        "operating": {"speed_rpm": 1200.0, "torque_nm": 20.0},
        "pits": {"shape": "ellipse", "teeth": [0], "severity": 0.2, "depth_mm": 0.2}}


def _sweep(section, key, value):
    doc = copy.deepcopy(SWEEP)
    doc[section][key] = value
    return doc


def _case(section, key, value):
    doc = copy.deepcopy(CASE)
    doc[section][key] = value
    return doc


# ------------------------------------------------------------------ pit depth (defect: range checked in metres)
def test_depth_range_is_the_tooth_pit_effects():
    """One range, from one place: the tooth_pit effect's bounds are datagen.pits.DEPTH_RANGE_M = 1 um .. 5 mm."""
    assert pits.DEPTH_RANGE_M == (1e-6, 5e-3)
    field = next(f for f in ToothPit.__dataclass_fields__.values() if f.name == "depth_m")
    assert tuple(field.metadata["bounds"]) == pits.DEPTH_RANGE_M


@pytest.mark.parametrize("depth_mm, ok", [([4000.0, 4001.0], False), ([10.0, 30.0], False), (5.5, False),
                                          ([0.0005, 0.001], False), ([0.001, 5.0], True), (0.2, True)])
def test_sweep_depth_mm_range_in_mm(depth_mm, ok):
    """Before: 4 m accepted (checked in m against [1e-6, 5]); 0.0005 mm refused with a range that contains it."""
    doc = _sweep("pits", "depth_mm", depth_mm)
    if ok:
        assert sweep_from_dict(doc).depth_m.span[-1] <= 5e-3
        return
    with pytest.raises(InputError) as exc:
        sweep_from_dict(doc)
    assert exc.value.field == "pits.depth_mm" and exc.value.value == depth_mm
    assert "within [0.001, 5]" in exc.value.allowed


@pytest.mark.parametrize("depth_mm", [4000.0, 5.01, 0.0009])
def test_case_depth_mm_range_in_mm(depth_mm):
    with pytest.raises(InputError) as exc:
        Case.from_dict(_case("pits", "depth_mm", depth_mm))
    assert exc.value.field == "pits.depth_mm" and exc.value.value == depth_mm
    assert exc.value.allowed == "a number in [0.001, 5] mm"
    assert PitSpec.from_dict({"shape": "ellipse", "teeth": [0], "severity": 0.1, "depth_mm": 5.0}).depth_m == 5e-3


def test_cli_depth_mm_refused_before_work(tmp_path, capsys):
    """--depth-mm 50 on a 3 mm thick tooth: refused, exit 2, nothing written."""
    out = tmp_path / "o"
    assert main(["stiffness", "--mask", str(tmp_path / "none.png"), "--depth-mm", "50", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--depth-mm: got 50.0; allowed: a number in [0.001, 5] mm" in err
    assert not out.exists()


# ------------------------------------------------------------------ torque (defect: 0 N m simulated to NaN)
def test_zero_torque_refused_alike_in_case_and_sweep():
    """A case refused torque < 0 only and simulated 0 N m to all-zero channels and a NaN periodicity error; a
    sweep refused torque < 0.001 N m. Both now refuse it by the same field and bound."""
    with pytest.raises(InputError) as case_exc:
        Case.from_dict(_case("operating", "torque_nm", 0.0))
    with pytest.raises(InputError) as sweep_exc:
        sweep_from_dict(_sweep("operating", "torque_nm", [0.0, 10.0]))
    assert case_exc.value.field == sweep_exc.value.field == "operating.torque_nm"
    assert "[0.001, 1e+06]" in case_exc.value.allowed and "[0.001, 1e+06]" in sweep_exc.value.allowed
    Case.from_dict(_case("operating", "torque_nm", 0.001))


# ------------------------------------------------------------------ effect parameters (defect: loose parsing)
def test_integer_field_refuses_a_fraction_on_every_path():
    """random_seed = 1.5 was accepted (recorded as 1.5, used as 1): CLI, case table and Python refuse it."""
    with pytest.raises(InputError) as exc:
        EffectSpec.from_string("pitch_error:random_seed=1.5,random_single_factor=1")
    assert exc.value.field == "effects.pitch_error.random_seed" and exc.value.value == 1.5
    assert exc.value.allowed.startswith("an integer")
    with pytest.raises(InputError, match="random_seed.*an integer"):
        Case.from_dict({**CASE, "effects": [{"name": "pitch_error", "random_seed": 1.5}]})
    with pytest.raises(InputError, match="an integer"):
        PitchError(random_seed=2.0)
    assert PitchError(random_seed=2).random_seed == 2
    doc = copy.deepcopy(SWEEP)
    doc["effects"] = {"pitch_error": {"random_seed": [0.5, 3]}}
    with pytest.raises(InputError, match="an integer") as exc:
        sweep_from_dict(doc)
    assert exc.value.field == "effects.pitch_error.random_seed"


def test_effect_key_given_twice_is_refused():
    """noise:snr_db=30,snr_db=10 silently took 10 (a TOML table refuses a repeated key; so does the CLI now)."""
    with pytest.raises(InputError) as exc:
        EffectSpec.from_string("noise:snr_db=30,snr_db=10")
    assert exc.value.field == "effect.noise.snr_db" and "once" in exc.value.allowed
    assert dict(EffectSpec.from_string("noise:snr_db=30").params) == {"snr_db": 30}


# ------------------------------------------------------------------ pair keys (defect: errors named SI fields)
@pytest.mark.parametrize("table, where, field, value, allowed", [
    ({"preset": "helical-dct", "helix_angle_deg": 80}, "pair", "pair.helix_angle_deg", 80, "a number in [0, 45] deg"),
    ({"preset": "spur-gds", "helix_angle_deg": 60}, "sweep.pairs[0]", "sweep.pairs[0].helix_angle_deg", 60,
     "a number in [0, 45] deg"),
    ({"preset": "spur-gds", "pressure_angle_n_deg": 5}, "pair", "pair.pressure_angle_n_deg", 5,
     "a number in [10, 35] deg"),
    ({"preset": "spur-gds", "dedendum_coef": 0.9}, "sweep.pairs[1]", "sweep.pairs[1].dedendum_coef", 0.9,
     "a number in (1.0, 2.0]"),
])
def test_pair_errors_name_the_key_as_written(table, where, field, value, allowed):
    """helix_angle_deg = 80 was reported as 'helix_angle_rad: got 1.396...; allowed [0.0, 0.785...]', without
    the sweep path."""
    with pytest.raises(InputError) as exc:
        pair_from_dict(table, where=where)
    assert (exc.value.field, exc.value.value, exc.value.allowed) == (field, value, allowed)


def test_bore_error_in_mm_with_path():
    """bore_radius_mm = 40 was reported as 'pinion.bore_radius_m: 0.04 m'; the limit is root radius - module."""
    with pytest.raises(DesignError) as exc:
        pair_from_dict({"preset": "spur-gds", "pinion": {"bore_radius_mm": 40}}, where="sweep.pairs[0]")
    msg = str(exc.value)
    assert msg.startswith("sweep.pairs[0].pinion.bore_radius_mm: 40 mm leaves no rim; allowed: < 24.5 mm"), msg
    with pytest.raises(InputError) as exc:
        sweep_from_dict(_sweep("sweep", "pairs", [{"preset": "spur-gds", "helix_angle_deg": 60}]))
    assert exc.value.field == "sweep.pairs[0].helix_angle_deg"


def test_tooth_and_depth_flags_without_a_mask_or_photo_are_refused(tmp_path, capsys):
    """--tooth 3 and --depth-mm 0.3 apply to --mask/--photo only; given with --pits or no pit source they were
    silently ignored. Now refused before any work, nothing written."""
    out = tmp_path / "o"
    pits = tmp_path / "pits.toml"
    pits.write_text('[pits]\nshape = "ellipse"\nteeth = [0]\nseverity = 0.1\n')
    for extra in (["--tooth", "3"], ["--depth-mm", "0.3"], ["--pits", str(pits), "--tooth", "3"]):
        assert main(["stiffness", *extra, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert ("--tooth" in err or "--depth-mm" in err) and "only with --mask or --photo" in err
    assert not out.exists()
