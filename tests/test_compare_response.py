"""compare.response: what a fitted drive-train fluctuation does to the shafts (the pinion speed's and the mesh
force's swing), reported beside the fitted reference amplitude."""
from __future__ import annotations

import math

import numpy as np
import pytest

from compare.candidates import CandidateResult
from compare.model import ComparisonModel
from compare.response import (acts_on_operating_point, attach_responses, contact_state, fluctuation_response,
                              line_amplitude, response_text)
from datagen.effects import EffectSpec
from datagen.geometry import preset
from gearpit.errors import InputError

SPEED_RPM, TORQUE_NM = 1500.0, 80.0


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return ComparisonModel.load(tmp_path_factory.mktemp("m") / "none.toml")      # the bare model


def effect(name, **params):
    return EffectSpec.from_dict({"name": name, **params}).build()


def response(model, name, f_hz, a):
    return fluctuation_response(model, preset("spur-gds"), effect(name, frequency_hz=f_hz, amplitude_fraction=a),
                                speed_rpm=SPEED_RPM, torque_nm=TORQUE_NM)


def test_line_amplitude_reads_a_sine_beside_another_and_an_offset():
    """The lock-in over whole cycles: a 0.3 sine at 19 Hz beside a 1.0 sine at 57 Hz and an offset of 5 (1 s at
    5 kHz). Analytic: 0.3, exact to rounding (the two lines are orthogonal over whole cycles); tolerance 1e-9."""
    t = np.arange(5000) / 5000.0
    x = 5.0 + 0.3 * np.sin(2 * np.pi * 19 * t + 0.4) + np.sin(2 * np.pi * 57 * t)
    assert abs(line_amplitude(x, 19.0, 5000.0) - 0.3) < 1e-9
    assert abs(line_amplitude(x, 57.0, 5000.0) - 1.0) < 1e-9


def test_slow_fluctuations_pass_the_drive_train_unchanged(model):
    """Quasi-static limits. A speed reference swinging at 1 Hz, well inside the ~5 Hz bandwidth of the model's
    PI speed loop (datagen.lumped_model), is followed by the pinion: a loop with integral action has unit gain at
    low frequency (Ogata, Modern Control Engineering, steady-state error of a type-1 loop); a load torque swinging
    at 1 Hz, far below the drive train's torsional modes, is carried by the mesh: the mesh force swings by the same
    fraction (static balance T / r_b1). Tolerance 10 % (measured +3.9 % and +1.5 %: the loop's and the modes'
    residual dynamics at 1 Hz)."""
    sp = response(model, "speed_fluctuation", 1.0, 0.01)
    assert abs(sp["speed_pinion_amplitude_fraction"] / 0.01 - 1) < 0.10, sp
    tq = response(model, "torque_fluctuation", 1.0, 0.1)
    assert abs(tq["mesh_force_amplitude_fraction"] / 0.1 - 1) < 0.10, tq
    assert tq["reference_amplitude_fraction"] == 0.1 and tq["frequency_hz"] == 1.0


def test_the_speed_loop_cannot_follow_a_fast_reference(model):
    """Above the loop's bandwidth the inertias filter the reference: at 40 Hz the pinion swings by well under half
    the reference (measured 0.17, and 0.16 on the 23/61 probe pair), and less than at 10 Hz (0.72: the trend of a
    low-pass). The amplitude is linear in the reference (a linear drive train): doubling it doubles the swing to
    2 %."""
    fast = response(model, "speed_fluctuation", 40.0, 0.01)["speed_pinion_amplitude_fraction"]
    mid = response(model, "speed_fluctuation", 10.0, 0.01)["speed_pinion_amplitude_fraction"]
    assert fast < 0.5 * 0.01 and fast < mid, (fast, mid)
    double = response(model, "speed_fluctuation", 40.0, 0.02)["speed_pinion_amplitude_fraction"]
    assert abs(double / fast - 2) < 0.02, (fast, double)


def test_the_response_equals_a_long_simulation_read_by_a_least_squares_sine_fit(model):
    """Independent reading: the same model and effect simulated for 3 s after 1 s of settling, the pinion speed
    fitted by least squares with a sine, cosine and offset at 19 Hz (not the lock-in, not whole cycles). The short
    record of fluctuation_response (10 cycles after 0.5 s) must agree within 2 %: its settling time is long
    enough."""
    from datagen.simulate import simulate

    eff = effect("speed_fluctuation", frequency_hz=19.0, amplitude_fraction=0.02)
    short = fluctuation_response(model, preset("spur-gds"), eff, speed_rpm=SPEED_RPM, torque_nm=TORQUE_NM)
    case = model.case(preset("spur-gds"), speed_rpm=SPEED_RPM, torque_nm=TORQUE_NM, duration_s=3.0, fs_hz=4000.0,
                      extra_effects=(eff,), solver={"method": "transient", "transient_s": 1.0})
    (sig,) = simulate([case], channels=["speed_pinion_rpm"])
    w = np.asarray(sig.channels["speed_pinion_rpm"])
    t = np.arange(w.size) / sig.fs_hz
    a = np.column_stack([np.sin(2 * np.pi * 19 * t), np.cos(2 * np.pi * 19 * t), np.ones_like(t)])
    c, *_ = np.linalg.lstsq(a, w, rcond=None)
    long_fraction = math.hypot(c[0], c[1]) / c[2]
    assert abs(short["speed_pinion_amplitude_fraction"] / long_fraction - 1) < 0.02, (short, long_fraction)


def _cand(name, reduction=0.5, status="fitted", **params):
    return CandidateResult(effect=name, signature="", params=params, sigma={}, error_db=10 * (1 - reduction),
                           baseline_error_db=10.0, view_error_db={}, window="1 s", n_evaluations=1, status=status)


def test_responses_go_to_fitted_fluctuations_only(model):
    """attach_responses sets ``response`` on the fitted candidates acting through the operating point (hook 5)
    with a positive reduction, at most ``limit``, in list order; a pitch error, a failed fit, a fluctuation that
    made the error worse get none. acts_on_operating_point picks exactly the two fluctuations of the registry."""
    from datagen.effects import names

    assert sorted(n for n in names() if acts_on_operating_point(n)) == ["speed_fluctuation", "torque_fluctuation"]
    cands = [_cand("pitch_error", grade=7.0), _cand("speed_fluctuation", status="failed", frequency_hz=19.0,
                                                   amplitude_fraction=0.02),
             _cand("torque_fluctuation", reduction=-0.1, frequency_hz=19.0, amplitude_fraction=0.05),
             _cand("speed_fluctuation", frequency_hz=19.0, amplitude_fraction=0.02),
             _cand("torque_fluctuation", frequency_hz=19.0, amplitude_fraction=0.05)]
    n = attach_responses(cands, model, preset("spur-gds"), speed_rpm=SPEED_RPM, torque_nm=TORQUE_NM, limit=1)
    assert n == 1
    assert [bool(c.response) for c in cands] == [False, False, False, True, False]
    assert cands[3].to_dict()["response"]["reference_amplitude_fraction"] == 0.02
    with pytest.raises(InputError, match="effect"):
        fluctuation_response(model, preset("spur-gds"), effect("pitch_error", grade=7.0), speed_rpm=SPEED_RPM,
                             torque_nm=TORQUE_NM)


def test_a_candidate_with_a_response_fits_the_documented_schema(model):
    """The JSON of a candidate with a response validates against compare.schema (the candidate items of
    ``attribution``), and a response with a string where a number belongs does not: the schema describes it."""
    import copy

    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA

    item = SCHEMA["properties"]["attribution"]["properties"]["candidates"]["items"]
    c = _cand("speed_fluctuation", frequency_hz=19.0, amplitude_fraction=0.02)
    attach_responses([c], model, preset("spur-gds"), speed_rpm=SPEED_RPM, torque_nm=TORQUE_NM)
    doc = c.to_dict()
    jsonschema.validate(doc, item)
    assert set(doc["response"]) == {"frequency_hz", "reference_amplitude_fraction", "speed_pinion_amplitude_fraction",
                                    "mesh_force_amplitude_fraction", "mesh_force_min_fraction", "contact"}
    for key, wrong in (("speed_pinion_amplitude_fraction", "1 %"), ("contact", "separated")):
        bad = copy.deepcopy(doc)
        bad["response"][key] = wrong
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(bad, item)


def test_the_foreign_load_swing_reads_as_amplitude_and_gearpits_fluctuations_as_frequency_modulation(model):
    """The independent simulator of tests/foreign_rig.py holds the speed and swings the mesh force by 20 % at 37 Hz:
    its sidebands are amplitude modulation. gearpit's speed fluctuation fitted to it (36.45 Hz, reference 1.43 %,
    docs/compare_validation.md "Stop 44") and its torque fluctuation alike swing the pinion's speed: frequency
    modulation. attach_responses with the comparison's reference reports both, and the CLI's line names the
    difference. Source: compare.modulation (Randall 2011, 3.6.2); measured 8 of 10 harmonics each way."""
    from compare.comparison import prepare_reference
    from compare.response import response_text
    from foreign_rig import ForeignRig, foreign_measurement

    m = foreign_measurement(ForeignRig(seed=5, duration_s=1.0, torque_fluctuation=(0.2, 37.0)))
    ref = prepare_reference(m)
    cands = [_cand("speed_fluctuation", frequency_hz=36.45, amplitude_fraction=0.0143),
             _cand("torque_fluctuation", frequency_hz=36.95, amplitude_fraction=0.0169)]
    attach_responses(cands, model, m.pair, speed_rpm=ref.speed.speed_rpm, torque_nm=m.torque_nm, reference=ref)
    for c in cands:
        mod = c.response["modulation"]
        assert mod["measured"]["type"] == "amplitude", mod["measured"]
        assert mod["model"]["type"] == "frequency", mod["model"]
    text = response_text(cands[0].response, "speed_fluctuation")
    assert "the load swings while the speed holds" in text and "in the model the speed swings" in text
    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA

    jsonschema.validate(cands[0].to_dict(), SCHEMA["properties"]["attribution"]["properties"]["candidates"]["items"])


def test_a_fluctuation_on_a_shaft_order_is_said_to_twin_a_once_per_revolution_error():
    """A fitted fluctuation at a shaft's rotation frequency (1000 rpm: pinion 16.67 Hz, wheel 4.83 Hz on 29/100
    teeth) within the record's resolution gets ``shaft_order`` and a line saying that an eccentricity or pitch
    error of that shaft makes the same sidebands; 37 Hz (no order up to 3 of either shaft within 0.5 Hz) and a
    frequency 1.1 resolutions off the order get none. The line without it is unchanged."""
    from compare.response import response_text, shaft_order_of

    assert shaft_order_of(16.6667, 1000.0, 29, 100, 0.5) == {"shaft": "pinion", "order": 1}
    assert shaft_order_of(2 * 1000 / 60 * 29 / 100 + 0.3, 1000.0, 29, 100, 0.5) == {"shaft": "wheel", "order": 2}
    assert shaft_order_of(37.0, 1000.0, 29, 100, 0.5) is None
    assert shaft_order_of(1000 / 60 + 0.55, 1000.0, 29, 100, 0.5) is None
    base = {"frequency_hz": 16.6667, "reference_amplitude_fraction": 0.75, "speed_pinion_amplitude_fraction": 0.01,
            "mesh_force_amplitude_fraction": 0.2}
    plain = response_text(base, "torque_fluctuation")
    locked = response_text({**base, "shaft_order": {"shaft": "pinion", "order": 1}}, "torque_fluctuation")
    assert locked.startswith(plain) and "pinion's order 1" in locked and "eccentricity" in locked
    assert "order" not in plain.split("Hz (")[0]


def test_a_swing_past_the_mean_force_is_flagged_as_tension(model):
    """A mesh that only pushes cannot swing by more than its mean force; the model without backlash lets it pull.
    Static balance: the same absolute swing of the pinion torque is a 16x larger fraction of the mesh force at
    5 N m than at 80 N m. A 20 % speed reference at 40 Hz swings the mesh force by 13.6 % at 80 N m (contact
    kept: least force above half the mean) and by 217 % at 5 N m, where the least force must lie below
    1 - 2.17 < 0 (minus the mesh ripple's share): the response says "tension", the text says the fit is outside
    what the model can make, and the 80 N m one says nothing of contact."""
    e = effect("speed_fluctuation", frequency_hz=40.0, amplitude_fraction=0.2)
    loaded = fluctuation_response(model, preset("spur-gds"), e, speed_rpm=SPEED_RPM, torque_nm=80.0)
    light = fluctuation_response(model, preset("spur-gds"), e, speed_rpm=SPEED_RPM, torque_nm=5.0)
    assert light["mesh_force_amplitude_fraction"] > 1.0 > 0.5 > loaded["mesh_force_amplitude_fraction"]
    assert loaded["contact"] == "kept" and loaded["mesh_force_min_fraction"] > 0.5
    assert light["contact"] == "tension"
    assert light["mesh_force_min_fraction"] < 1.0 - light["mesh_force_amplitude_fraction"] + 0.2
    assert "outside what the model can make" in response_text(light, "speed_fluctuation")
    assert "contact" not in response_text(loaded, "speed_fluctuation")
    assert contact_state({"mesh_force_min_fraction": 0.0}) == "lost"
    assert "separate in the model" in response_text({**loaded, "mesh_force_min_fraction": 0.0}, "x")
