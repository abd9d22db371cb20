"""``gearpit compare`` end to end: files, model TOML, --add, ledger, JSON schema, HTML report, clear errors.

Reference: the issue's loop (compare -> ranked candidates -> --add -> error falls, ledger grows) and the schema
in compare/schema.py. The measurement is simulated with a hidden pitch error (grade 8) on a rig whose damping,
bearing stiffness, noise and gain differ from the model's defaults (compare.synthetic).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from compare.ledger import read_ledger
from compare.synthetic import rig_measurement
from gearpit.cli import main


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("rig")
    m = rig_measurement(({"name": "pitch_error", "grade": 8.0},), duration_s=1.0)
    t = np.arange(m.n_samples) / m.fs_hz
    np.savetxt(d / "rig.csv", np.column_stack([t, m.channels["acc"], m.channels["tacho"]]), delimiter=",",
               header="time_s,acc_x,tacho", comments="", fmt="%.10g")
    (d / "rig.toml").write_text('speed_rpm = 1005.0\ntorque_nm = 50.0\npair = "spur-gds"\nsensor = "acc_x"\n'
                                'tacho = "tacho"\n')
    return d


def test_loop_compare_add_and_watch_the_error_fall(rig, capsys):
    """Run 1 (nuisances calibrated) ranks pitch_error first, refits it jointly with the nuisances and says so
    (CLI line, JSON ``joint_refit``); run 2 (--add pitch_error, parameters and the
    nuisances they were fitted with taken from the ledger, calibrated again) cuts the total error by more than half; the ledger has both rows with the
    calibrated nuisances; the JSON validates against the schema; the HTML embeds its figures (no external
    src)."""
    assert main(["compare", str(rig / "rig.csv"), "--candidates", "pitch_error,eccentricity_wheel", "--calibrate",
                 "--json", str(rig / "run1.json")]) == 0
    out1 = capsys.readouterr().out
    assert "pitch_error" in out1 and "<- claimed" in out1
    doc = json.loads((rig / "run1.json").read_text())
    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA

    jsonschema.validate(doc, SCHEMA)
    assert doc["attribution"]["candidates"][0]["effect"] == "pitch_error"
    # the calibrated claim was refitted jointly with the nuisances (compare.joint_refit): recorded and reported
    joint = doc["attribution"]["candidates"][0]["joint_refit"]
    assert joint is not None and joint["samples"] == 256 and "refitted jointly with the drive-train" in out1, joint
    assert main(["compare", str(rig / "rig.csv"), "--add", "pitch_error", "--no-attribution", "--calibrate",
                 "--report", str(rig / "run2.html"), "--json", str(rig / "run2.json")]) == 0
    capsys.readouterr()
    rows = read_ledger(rig / "rig.model.ledger.jsonl")
    assert [r["run"] for r in rows] == [1, 2]
    assert rows[1]["error_db"]["total"] < 0.5 * rows[0]["error_db"]["total"]
    assert "pitch_error" in (rig / "rig.model.toml").read_text()
    # --add took the nuisances pitch_error was fitted with into the model's drive train (the calibration's start)
    from compare.model import ComparisonModel

    nuisance = doc["attribution"]["candidates"][0]["nuisance"]
    assert set(nuisance) == {"mesh_damping_ratio", "bearing_n_per_m", "bearing_damping_ratio"}
    saved = ComparisonModel.load(rig / "rig.model.toml").tables["drivetrain"]
    assert all(abs(saved[k] / v - 1) < 1e-9 for k, v in nuisance.items()), (saved, nuisance)
    html = (rig / "run2.html").read_text()
    assert html.count("data:image/png;base64,") >= 8 and 'src="http' not in html
    assert "Nuisance calibration" in html
    jsonschema.validate(json.loads((rig / "run2.json").read_text()), SCHEMA)
    # the calibrated nuisances are in the output, the JSON and every ledger row
    assert "nuisances calibrated: mesh_damping_ratio" in out1
    assert set(doc["calibration"]["parameters"]) == {"mesh_damping_ratio", "bearing_n_per_m", "bearing_damping_ratio"}
    assert all(r["calibration"]["parameters"]["bearing_n_per_m"] > 0 for r in rows)


def test_no_calibrate_keeps_the_model_drive_train(rig, capsys, tmp_path):
    """--no-calibrate (also over [calibration] enabled = true in the model): no calibration in the JSON or the
    ledger; the model file's drive train is used as is."""
    model = tmp_path / "m.toml"
    model.write_text('[drivetrain]\nmesh_damping_ratio = 0.08\n[calibration]\nenabled = true\n')
    assert main(["compare", str(rig / "rig.csv"), "--model", str(model), "--no-attribution", "--no-calibrate",
                 "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "nuisances calibrated" not in out
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["calibration"] is None
    rows = read_ledger(tmp_path / "m.ledger.jsonl")
    assert rows[-1]["calibration"] is None


@pytest.mark.slow   # 158 s once the time step was bounded by the band-chosen mesh record (default suite 963 s)
def test_auto_calibrates_only_when_the_model_as_written_explains_nothing(rig, capsys, tmp_path):
    """Default calibration mode "auto" (compare.escalation). On the pitch-error rig the model as written explains
    the mismatch (pitch_error claimed, >= 50 % of the error): no calibration, one ledger row. On a rig without
    hidden effect nothing explains it: the drive train is calibrated and the attribution repeated; the ledger has
    the uncalibrated row, then the calibrated one, and the JSON is the calibrated pass's."""
    from compare.escalation import EXPLAINED_REDUCTION
    from compare.workflow import write_rig_files

    cands = "pitch_error,eccentricity_wheel"
    assert main(["compare", str(rig / "rig.csv"), "--model", str(tmp_path / "a.toml"), "--candidates", cands,
                 "--json", str(tmp_path / "a.json")]) == 0
    out = capsys.readouterr().out
    assert "nuisances calibrated" not in out and "<- claimed" in out
    doc = json.loads((tmp_path / "a.json").read_text())
    top = doc["attribution"]["candidates"][0]
    assert top["effect"] == "pitch_error" and top["claimed"] and top["reduction"] >= EXPLAINED_REDUCTION
    assert doc["calibration"] is None and len(read_ledger(tmp_path / "a.ledger.jsonl")) == 1
    assert doc["escalation"] == {"mode": "auto", "escalated": False, "explained_reduction": EXPLAINED_REDUCTION}

    csv = write_rig_files(rig_measurement(duration_s=1.0), tmp_path / "healthy")
    assert main(["compare", str(csv), "--model", str(tmp_path / "b.toml"), "--candidates", cands,
                 "--json", str(tmp_path / "b.json"), "--report", str(tmp_path / "b.html")]) == 0
    out = capsys.readouterr().out
    assert "nuisances were calibrated and the attribution repeated" in out and "nuisances calibrated:" in out
    rows = read_ledger(tmp_path / "b.ledger.jsonl")
    assert [r["calibration"] is None for r in rows] == [True, False]
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["calibration"] is not None and not doc["attribution"]["claimed"]
    esc = doc["escalation"]
    assert esc["mode"] == "auto" and esc["escalated"]
    assert esc["as_written_error_db"] == pytest.approx(rows[0]["error_db"]["total"])
    assert esc["as_written_best"]["reduction"] < EXPLAINED_REDUCTION or not esc["as_written_best"]["claimed"]
    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA

    jsonschema.validate(doc, SCHEMA)
    assert "Calibrated because the model as written" in (tmp_path / "b.html").read_text()


def test_bad_file_gives_one_line_and_exit_2(tmp_path, capsys):
    """A NaN in the sensor column: exit code 2 and one stderr line naming the channel and the NaN."""
    x = np.sin(np.arange(20000) * 0.3)
    x[777] = np.nan
    np.savetxt(tmp_path / "bad.csv", x, fmt="%.6g")
    (tmp_path / "bad.json").write_text(json.dumps({"fs_hz": 20000.0, "speed_rpm": 1000.0, "torque_nm": 5.0,
                                                    "pair": "spur-gds", "sensor": 0}))
    assert main(["compare", str(tmp_path / "bad.csv"), "--no-attribution"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "NaN" in err[0] and "ch0" in err[0]


def test_plugin_effect_is_a_candidate_like_any_other(tmp_path):
    """A user effect written in a plugin file (a once-per-wheel-revolution sensor-path modulation, hook 7) is
    hidden in the measurement; attribution fits it like a built-in one: it ranks first and its depth is within
    25 % of the truth."""
    plugin = tmp_path / "my_effects.py"
    plugin.write_text('''
from dataclasses import dataclass, field
import numpy as np
from datagen.effects.base import Effect, register

@register
@dataclass(frozen=True)
class HousingWobble(Effect):
    name = "housing_wobble"
    signature = "sensor gain modulated once per wheel revolution: +/- fr_wheel sidebands on every line"
    depth: float = field(default=0.1, metadata={"unit": "-", "bounds": (0.0, 0.9)})

    def measurement(self, channels, fs_hz, rng, ctx):
        t = np.arange(len(channels["acc_pinion_loa_m_s2"])) / fs_hz
        frw = ctx.pair.shaft_frequency_hz("wheel", ctx.speed_rpm)
        out = dict(channels)
        out["acc_pinion_loa_m_s2"] = channels["acc_pinion_loa_m_s2"] * (1 + self.depth * np.cos(2 * np.pi * frw * t))
        return out
''')
    from compare.attribution import attribute
    from compare.comparison import compare, prepare_reference
    from compare.model import ComparisonModel
    from datagen.effects import load_plugin

    assert load_plugin(plugin) == ["housing_wobble"]
    m = rig_measurement(({"name": "housing_wobble", "depth": 0.3},), duration_s=1.0)
    ref = prepare_reference(m)
    c = compare(m, ComparisonModel(), reference=ref)
    a = attribute(ref, ComparisonModel(), c.evaluation.residuals.residual_db,
                  candidates=["housing_wobble", "eccentricity_wheel", "pitch_error"], disagreements=c.disagreements)
    top = a.candidates[0]
    assert top.effect == "housing_wobble" and top.claimed
    assert top.params["depth"] == pytest.approx(0.3, rel=0.25)


def test_model_toml_round_trip_and_refusals(tmp_path):
    """The model file written by --add reads back to the same effects; unknown keys and effect parameters
    outside their bounds are refused naming the field."""
    from compare.model import ComparisonModel
    from datagen.effects import EffectSpec
    from gearpit.errors import InputError

    m = ComparisonModel(description="rig A", tables={"drivetrain": {"mesh_damping_ratio": 0.06}})
    m = m.with_effect(EffectSpec.from_string("tip_relief:amount_m=1.5e-05").build())
    m = m.with_effect(EffectSpec.from_string("eccentricity_pinion:amplitude_m=2e-05").build())
    path = m.save(tmp_path / "model.toml")
    back = ComparisonModel.load(path)
    assert [e.to_dict() for e in back.effects] == [e.to_dict() for e in m.effects]
    assert back.tables == m.tables and back.description == "rig A"
    assert back.describe().startswith("tip_relief(amount_m=1.5e-05")
    (tmp_path / "bad.toml").write_text('sensr = "acc"\n')
    with pytest.raises(InputError, match="model.sensr"):
        ComparisonModel.load(tmp_path / "bad.toml")
    (tmp_path / "bad2.toml").write_text('[[effects]]\nname = "tip_relief"\namount_m = 1.0\n')
    with pytest.raises(InputError, match="amount_m"):
        ComparisonModel.load(tmp_path / "bad2.toml")
    # the calibration mode: true, false or "auto" (the default), anything else refused naming the field
    assert ComparisonModel().calibration_mode == "auto" and not ComparisonModel().calibrates
    (tmp_path / "auto.toml").write_text('[calibration]\nenabled = "auto"\n')
    assert ComparisonModel.load(tmp_path / "auto.toml").calibration_mode == "auto"
    (tmp_path / "bad3.toml").write_text('[calibration]\nenabled = "sometimes"\n')
    with pytest.raises(InputError, match="model.calibration.enabled"):
        ComparisonModel.load(tmp_path / "bad3.toml")
    from compare.escalation import resolve_mode

    with pytest.raises(InputError, match="calibrate"):
        resolve_mode(ComparisonModel(), "yes")


@pytest.mark.slow
def test_walkthrough_starts_from_what_rig_and_model_both_know(tmp_path):
    """compare.workflow.hidden_effect_loop on the tip-relief example, whose rig carries a grade-7 pitch error that
    the user's model knows (compare.synthetic): the model file written before the first comparison holds that
    pitch error, tip_relief is claimed and added, and the error falls to at most half (the slow hidden-effect
    tests' criterion; the walkthrough runs with the model file's calibration setting)."""
    from compare.model import ComparisonModel
    from compare.workflow import hidden_effect_loop

    summary, first, second = hidden_effect_loop(tmp_path, "tip_relief", calibrate=False)
    assert summary["claimed"] == "tip_relief", summary
    names = ComparisonModel.load(tmp_path / "rig.model.toml").effect_names
    assert "pitch_error" in names and "tip_relief" in names, names
    assert summary["error_after_db"] <= 0.5 * summary["error_before_db"], summary


def test_a_claim_that_only_reshapes_the_mesh_harmonics_comes_with_its_caveat(tmp_path):
    """A hidden profile error (grade 9, the README table's example) claimed through the user's loop prints the
    caveat that two models of one healthy pair differ in the mesh harmonics too; the effects flagged as acting
    only on the mesh harmonics are exactly the three that act alike on every tooth."""
    from compare.synthetic import hidden_effect_measurement
    from compare.workflow import run, write_rig_files
    from datagen.effects import get, names

    assert {n for n in names() if get(n).mesh_harmonics_only} == {"profile_error", "tip_relief",
                                                                              "hertz_nonlinear"}
    m, _ = hidden_effect_measurement("profile_error", duration_s=1.0)
    csv = write_rig_files(m, tmp_path)
    out = run(csv, candidates=["profile_error", "eccentricity_pinion"], calibrate=False)
    assert out.attribution.claimed and out.attribution.claimed[0].effect == "profile_error"
    assert any("changes only the levels of the mesh harmonics" in s for s in out.messages)
