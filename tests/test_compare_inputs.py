"""Input checks of ``gearpit compare``: plugin files, sidecars and the sidecar template (refused by name, before
any work, nothing written). Analytic tier: each test states the message it expects; none runs a comparison."""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from gearpit.errors import InputError

EFFECT_PLUGIN = textwrap.dedent('''
    from dataclasses import dataclass, field
    import numpy as np
    from datagen.effects import Effect, register

    @register
    @dataclass(frozen=True)
    class InputsRunout(Effect):
        name = "inputs_runout"
        signature = "wheel order 1"
        amplitude_m: float = field(default=5e-6, metadata={"unit": "m", "bounds": (0.0, 50e-6)})

        def deviation_period_cycles(self, ctx):
            return ctx.pair.wheel.teeth

        def angle_deviation_m(self, th1, th2, ctx):
            return self.amplitude_m * np.sin(th2)
''')


# ---------------------------------------------------------------------- plugins
@pytest.mark.parametrize("body, message", [
    ("x = 1\ndef broken(:\n    pass\n", r"^plugin syntax\.py: line 2: invalid syntax$"),
    ("x = 1\nraise RuntimeError('boom at import')\n",
     r"^plugin syntax\.py: raised RuntimeError: boom at import while loading$"),
    ("import not_a_real_module_xyz\n",
     r"^plugin syntax\.py: raised ModuleNotFoundError: No module named 'not_a_real_module_xyz' while loading$"),
])
def test_plugin_that_fails_to_import_is_one_line_naming_file(tmp_path, body, message):
    from datagen.effects import load_plugin

    (tmp_path / "syntax.py").write_text(body)
    with pytest.raises(InputError, match=message):
        load_plugin(tmp_path / "syntax.py")


def test_plugin_failing_after_register_leaves_registry_clean(tmp_path):
    from datagen.effects import load_plugin, names

    (tmp_path / "half.py").write_text(EFFECT_PLUGIN + "\nraise RuntimeError('late')\n")
    with pytest.raises(InputError, match="plugin half.py: raised RuntimeError: late"):
        load_plugin(tmp_path / "half.py")
    assert "inputs_runout" not in names()


def test_plugin_registering_no_effect_is_refused(tmp_path):
    from datagen.effects import load_plugin

    (tmp_path / "noeffect.py").write_text("x = 1\n")
    with pytest.raises(InputError, match=r"plugin noeffect\.py.*registers no effect: decorate an Effect subclass "
                                         r"with @register"):
        load_plugin(tmp_path / "noeffect.py")


def test_plugin_loaded_twice_is_not_refused_as_empty(tmp_path):
    """Loading the same file again (the CLI's --plugin, then the model's plugins list) registers the same class."""
    from datagen.effects.registry import load_plugin, unregister

    (tmp_path / "mine.py").write_text(EFFECT_PLUGIN)
    try:
        assert load_plugin(tmp_path / "mine.py") == ["inputs_runout"]
        assert load_plugin(tmp_path / "mine.py") == []
    finally:
        unregister("inputs_runout")


def test_model_stores_plugin_relative_to_its_folder(tmp_path):
    """A plugin under the model's folder is written relative to the model file, so the folder can move."""
    import shutil

    from compare.model import ComparisonModel
    from datagen.effects.registry import unregister

    rig = tmp_path / "rig"
    (rig / "fx").mkdir(parents=True)
    (rig / "fx" / "mine.py").write_text(EFFECT_PLUGIN)
    outside = tmp_path / "outside.py"
    outside.write_text(EFFECT_PLUGIN.replace("inputs_runout", "inputs_runout2").replace("InputsRunout", "R2"))
    try:
        m = ComparisonModel.load(rig / "rig.model.toml")
        m = m.with_plugin(str((rig / "fx" / "mine.py").resolve())).with_plugin(str(outside.resolve()))
        m = m.with_plugin(str((rig / "fx" / "mine.py").resolve()))      # once only
        assert m.plugins == ("fx/mine.py", str(outside.resolve()))
        m.save()
        shutil.move(str(rig), str(tmp_path / "moved"))
        back = ComparisonModel.load(tmp_path / "moved" / "rig.model.toml")
        assert back.plugins == ("fx/mine.py", str(outside.resolve()))
        assert back.with_plugin(str((tmp_path / "moved" / "fx" / "mine.py").resolve())).plugins == back.plugins
    finally:
        unregister("inputs_runout")
        unregister("inputs_runout2")


def test_model_rewrite_keeps_the_users_comments(tmp_path):
    """``--add`` rewrites the model file the user edits: their comments, key order and untouched values must
    survive, changed values change, a new effect is appended and a removed one goes (the file was written afresh
    before, losing every comment)."""
    from compare.model import ComparisonModel
    from datagen.effects import build_effects

    p = tmp_path / "rig.model.toml"
    p.write_text("# rig A, bay 3\n"
                 "description = \"rig A\"  # first guess\n"
                 "sensor = \"acc_pinion_loa_m_s2\"\n\n"
                 "[drivetrain]\n# from the rig drawing\nmesh_damping_ratio = 0.07\n\n"
                 "[[effects]]\n# dial gauge, 2026-11\nname = \"eccentricity_pinion\"\namplitude_m = 2e-05\n")
    m = ComparisonModel.load(p)
    ecc, tip = build_effects([{"name": "eccentricity_pinion", "amplitude_m": 3e-5},
                              {"name": "tip_relief", "amount_m": 1e-5}])
    m.with_effect(ecc).with_effect(tip).with_drivetrain({"bearing_n_per_m": 2e8}).save()
    text = p.read_text()
    for kept in ("# rig A, bay 3", "# first guess", "# from the rig drawing", "# dial gauge, 2026-11"):
        assert kept in text
    back = ComparisonModel.load(p)
    assert back.effect_names == ("eccentricity_pinion", "tip_relief")
    assert back.effects[0].params()["amplitude_m"] == 3e-5
    assert back.tables["drivetrain"] == {"mesh_damping_ratio": 0.07, "bearing_n_per_m": 2e8}
    assert text.index("# dial gauge") < text.index("amplitude_m = 3e-05")      # the comment stays with its effect
    back.__class__.from_dict({**back.to_dict(), "effects": back.to_dict()["effects"][1:]}, path=p).save()
    again = p.read_text()
    assert "eccentricity_pinion" not in again and "tip_relief" in again and "# from the rig drawing" in again
    assert ComparisonModel.load(p).effect_names == ("tip_relief",)


# ---------------------------------------------------------------------- sidecars
SIM_META = {"case": {"duration_s": 1.0, "fs_hz": 20000.0,
                     "pair": {"name": "spur-gds", "module_n_mm": 2.0, "pressure_angle_n_deg": 20.0,
                              "pinion": {"teeth": 29, "face_width_mm": 20.0}, "wheel": {"teeth": 100}},
                     "operating": {"speed_rpm": 1500.0, "torque_nm": 11.3}},
            "seed": 7, "software_version": "0.1.0", "solver": {"method": "x"}, "dofs": ["a", "b"],
            "mesh_frequency_hz": 725.0, "shaft_frequency_pinion_hz": 25.0, "shaft_frequency_wheel_hz": 7.25,
            "mean_mesh_stiffness_n_per_m": 3.7e8, "warnings": []}


def _record(folder: Path, name: str = "case.csv", seconds: float = 2.0, fs_hz: float = 2000.0) -> Path:
    """A small CSV record (time, sensor, tacho) of ``seconds`` at ``fs_hz``."""
    import numpy as np

    t = np.arange(int(seconds * fs_hz)) / fs_hz
    rows = np.column_stack([t, np.sin(2 * np.pi * 300 * t), (np.sin(2 * np.pi * 25 * t) > 0.99).astype(float)])
    path = folder / name
    np.savetxt(path, rows, delimiter=",", header="time,acc,tacho", comments="")
    return path


def test_simulate_metadata_beside_record_is_not_taken_as_sidecar(tmp_path):
    """gearpit simulate's case.json (keys case, software_version, mesh_frequency_hz) is passed over: the usual
    no-sidecar path writes the template, and the message says what case.json is."""
    import json

    from compare.measurement import load_measurement

    rec = _record(tmp_path)
    (tmp_path / "case.json").write_text(json.dumps(SIM_META))
    with pytest.raises(InputError) as err:
        load_measurement(rec)
    msg = str(err.value)
    assert "case.json beside it is gearpit simulate's metadata, not a sidecar" in msg
    assert "case.csv.toml.template" in msg and (tmp_path / "case.csv.toml.template").is_file()
    assert len(msg) < 500


def test_simulate_metadata_given_as_meta_is_refused_shortly(tmp_path):
    import json

    from compare.measurement import load_measurement

    rec = _record(tmp_path)
    (tmp_path / "case.json").write_text(json.dumps(SIM_META))
    with pytest.raises(InputError, match="gearpit simulate's metadata") as err:
        load_measurement(rec, tmp_path / "case.json")
    assert len(str(err.value)) < 300


def test_error_on_a_whole_table_shows_its_keys_only():
    """An error whose value is a long table (a case dict) names its keys instead of dumping it; short ones stay."""
    from gearpit.tomlio import check_keys

    with pytest.raises(InputError) as err:
        check_keys(SIM_META, {"fs_hz", "pair"}, "case.json")
    assert str(err.value).startswith("case.json.case: got a table with keys duration_s, fs_hz, pair, operating;")
    assert "spur-gds" not in str(err.value)
    assert str(InputError("x", {"a": 1}, "b")) == "x: got {'a': 1}; allowed: b"


# ---------------------------------------------------------------------- the template and the operating point
def test_unfilled_template_is_refused_by_name_for_each_required_key(tmp_path):
    """Every required key of the template holds no valid value: filling them in one at a time, each unfilled one is
    refused by name, before any work; filled in, the sidecar reads."""
    from compare.measurement import read_sidecar
    from compare.sidecar_template import write_template

    rec = _record(tmp_path, "rig.csv")
    text = write_template(rec).read_text()
    filled = {"pair": ('pair = ""', 'pair = "spur-gds"'), "speed_rpm": ("speed_rpm = 0", "speed_rpm = 1500"),
              "torque_nm": ("torque_nm = 0", "torque_nm = 11.3"), "sensor": ('sensor = ""', 'sensor = "acc"')}
    for key, (blank, value) in filled.items():
        assert blank in text
        (tmp_path / "rig.toml").write_text(text)
        with pytest.raises(InputError, match=rf"^rig\.toml\.{key}: got"):
            read_sidecar(tmp_path / "rig.toml")
        text = text.replace(blank, value)
    (tmp_path / "rig.toml").write_text(text)
    side = read_sidecar(tmp_path / "rig.toml")
    assert (side.speed_rpm, side.torque_nm, side.sensor) == (1500.0, 11.3, "acc")


@pytest.mark.parametrize("line, field, allowed", [
    ("torque_nm = 0", "torque_nm", r"a number in \[0\.001, 1e\+06\] N m"),
    ("torque_nm = -5.0", "torque_nm", r"a number in \[0\.001, 1e\+06\] N m"),
    ("torque_nm = 2e6", "torque_nm", r"a number in \[0\.001, 1e\+06\] N m"),
    ("speed_rpm = 0", "speed_rpm", "a finite number > 0"),
    ('pair = ""', "pair", r"a preset \(helical-dct, spur-gds\) or a \[pair\] table"),
])
def test_operating_point_outside_its_range_is_refused(tmp_path, line, field, allowed):
    from compare.measurement import read_sidecar

    base = {"speed_rpm": "speed_rpm = 1500", "torque_nm": "torque_nm = 11.3", "pair": 'pair = "spur-gds"'}
    base[field] = line
    (tmp_path / "rig.toml").write_text("\n".join(base.values()) + '\nsensor = "acc"\n')
    with pytest.raises(InputError, match=rf"^rig\.toml\.{field}: got .*; allowed: {allowed}"):
        read_sidecar(tmp_path / "rig.toml")


def test_torque_range_is_datagens():
    """The sidecar's torque range is the simulator's (imported, not copied)."""
    from compare.measurement import Sidecar
    from datagen import case_options

    lo, _ = case_options.TORQUE_RANGE_NM
    assert Sidecar.from_dict({"pair": "spur-gds", "torque_nm": lo}).torque_nm == lo
    with pytest.raises(InputError, match="torque_nm"):
        Sidecar.from_dict({"pair": "spur-gds", "torque_nm": lo / 2})


def test_start_past_the_end_is_refused_naming_start_s(tmp_path):
    """start_s = 5 s on a 2 s record (spur-gds at 1500 rpm: two wheel revolutions are 0.276 s) is refused with the
    latest allowed start, 2 - 0.276 = 1.724 s, instead of a zero-size array traceback."""
    from compare.measurement import Sidecar, load_measurement

    rec = _record(tmp_path, "rig.csv")
    side = {"pair": "spur-gds", "speed_rpm": 1500.0, "torque_nm": 11.3, "sensor": "acc"}
    with pytest.raises(InputError, match=r"^start_s: got 5\.0; allowed: <= 1\.724 s: the record length 2 s minus "
                                         r"two revolutions of the slower shaft \(0\.276 s at 1500 rpm\)"):
        load_measurement(rec, Sidecar.from_dict({**side, "start_s": 5.0}))
    assert load_measurement(rec, Sidecar.from_dict({**side, "start_s": 1.7})).n_samples == 600


def test_two_sidecars_beside_a_file_are_refused_naming_both(tmp_path):
    """rig.toml and rig.json with different content: neither is taken silently; --meta picks one, and the
    measurement records which (the JSON report's measurement.sidecar)."""
    from compare.measurement import find_sidecar, load_measurement
    from compare.schema import SCHEMA

    rec = _record(tmp_path, "rig.csv")
    (tmp_path / "rig.toml").write_text('pair = "spur-gds"\nspeed_rpm = 1500\ntorque_nm = 11.3\nsensor = "acc"\n')
    (tmp_path / "rig.json").write_text('{"pair": "spur-gds", "speed_rpm": 1400, "torque_nm": 20, "sensor": "acc"}')
    with pytest.raises(InputError, match=r"^sidecar: got 'rig\.toml and rig\.json'; allowed: one sidecar beside "
                                         r"rig\.csv \(give the one to use with --meta"):
        load_measurement(rec)
    with pytest.raises(InputError, match="rig.toml and rig.json"):
        find_sidecar(rec)
    assert not (tmp_path / "rig.csv.toml.template").exists()
    m = load_measurement(rec, tmp_path / "rig.json")
    assert (m.speed_rpm, m.sidecar_path) == (1400.0, str(tmp_path / "rig.json"))
    (tmp_path / "rig.json").unlink()
    assert load_measurement(rec).sidecar_path == str(tmp_path / "rig.toml")
    assert "sidecar" in SCHEMA["properties"]["measurement"]["properties"]


def test_missing_reference_is_refused_when_the_sidecar_is_read(tmp_path):
    """A sidecar whose reference does not exist is refused naming the key and the resolved path (it was accepted
    silently by gearpit compare)."""
    from compare.measurement import load_measurement

    rec = _record(tmp_path, "rig.csv")
    (tmp_path / "rig.toml").write_text('pair = "spur-gds"\nspeed_rpm = 1500\ntorque_nm = 11.3\nsensor = "acc"\n'
                                       'reference = "nothere.npz"\n')
    resolved = (tmp_path / "nothere.npz").resolve()
    with pytest.raises(InputError, match=r"^rig\.toml\.reference: got 'nothere\.npz'; allowed: an existing "
                                         r"measurement file") as err:
        load_measurement(rec)
    assert str(resolved) in str(err.value)
    _record(tmp_path, "nothere.csv")
    (tmp_path / "rig.toml").write_text((tmp_path / "rig.toml").read_text().replace("nothere.npz", "nothere.csv"))
    assert load_measurement(rec).sidecar.reference == "nothere.csv"


# ---------------------------------------------------------------------- wording of ranges and bounds
def test_dimensionless_range_has_no_unit_dash():
    """A dimensionless parameter's range reads "[0.0, 0.6]", not "[0.0, 0.6] -"; a dimensional one keeps its unit."""
    from datagen.effects import EffectSpec

    with pytest.raises(InputError) as err:
        EffectSpec.from_string("tooth_pit:severity=5")
    assert str(err.value).endswith("allowed: a number in [0.0, 0.6]")
    with pytest.raises(InputError) as err:
        EffectSpec.from_string("eccentricity_pinion:amplitude_m=1")
    assert str(err.value).endswith("allowed: a number in [0.0, 0.0002] m")


def test_calibration_on_its_bound_is_worded_as_on_its_bound():
    """A rig whose mesh damping (0.25) lies above the calibration's box (0.03-0.1): the fit ends on the upper bound,
    recorded as at_bound, and the CLI line and the HTML say "on its upper bound", not "not identifiable"."""
    from compare.calibration import CalibrationSettings, calibrate, calibration_message
    from compare.comparison import prepare_reference
    from compare.model import ComparisonModel
    from compare.report import _calibration_html
    from compare.synthetic import NUISANCE, rig_measurement

    m = rig_measurement(duration_s=0.5, nuisance={**NUISANCE, "mesh_damping_ratio": 0.25})
    cal = calibrate(prepare_reference(m), ComparisonModel(),
                    settings=CalibrationSettings(parameters=("mesh_damping_ratio",), widths_u=(0.3, 0.1),
                                                 points_per_side=(2, 1)))
    assert cal.values["mesh_damping_ratio"] == pytest.approx(0.1)
    assert cal.at_bound == {"mesh_damping_ratio": "upper"} and cal.to_dict()["at_bound"] == cal.at_bound
    assert calibration_message(cal).startswith("nuisances calibrated: mesh_damping_ratio 0.1 (on its upper bound) (")
    page = "".join(_calibration_html(cal.to_dict()))
    assert "0.1 (on its upper bound)" in page and "on a bound" in page


def test_calibration_message_gives_sigma_inside_and_not_identifiable_when_flat():
    from compare.calibration import Calibration, calibration_message

    cal = Calibration(values={"bearing_n_per_m": 1.115e8, "bearing_damping_ratio": 0.05},
                      sigma={"bearing_n_per_m": 1.15e7, "bearing_damping_ratio": float("inf")},
                      start={}, error_before_db=9.36, error_db=8.98, gain_db=0.0, n_simulations=1, elapsed_s=0.0)
    assert calibration_message(cal) == ("nuisances calibrated: bearing_n_per_m 1.115e+08 +/- 1.2e+07, "
                                        "bearing_damping_ratio 0.05 (not identifiable) (error 9.36 -> 8.98 dB)")
