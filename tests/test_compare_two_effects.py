"""The compare loop on a rig with two hidden effects at once (compare.synthetic.hidden_effects_loop,
experiments/two_hidden_effects.py), and the two faults that rig exposed: the nuisance refit crediting a null
effect (compare.nuisance_refit.refine_nuisances) and "auto" using a calibrated pass that ends above the model as
written (compare.escalation). Source: the simulator's truth; measured values in each test's docstring.
"""
from __future__ import annotations

import numpy as np
import pytest

from compare.calibration import calibrated_compare
from compare.comparison import prepare_reference
from compare.escalation import compare_and_attribute
from compare.model import ComparisonModel
from compare.synthetic import HIDDEN_EXAMPLES, NUISANCE, rig_measurement


def _two_effect_rig_with_both_fitted():
    """The examples' rig with the pitch error and housing mode on together (1 s), and the model with both as the
    two-effect loop fitted them (grade 7.5, 2900 Hz / 7.75 %; experiments/two_hidden_effects.py):
    (measurement, reference, model)."""
    from datagen.effects import build_effects

    rig = (HIDDEN_EXAMPLES["pitch_error"].effect, HIDDEN_EXAMPLES["transmission_path"].effect)
    m = rig_measurement(rig, duration_s=1.0)
    model = ComparisonModel(effects=build_effects((
        {"name": "pitch_error", "grade": 7.5, "gears": "pinion"},
        {"name": "transmission_path", "housing_frequency_hz": 2900.0, "housing_damping_ratio": 0.0775})))
    return m, prepare_reference(m), model


@pytest.mark.slow
def test_a_null_effect_gains_nothing_from_the_nuisance_refit():
    """compare.nuisance_refit.refine_nuisances. Source: a null effect changes nothing (a wheel eccentricity at its
    lower bound, 0.2 um: its sidebands sit ~80 dB under the mesh line), so no refit may credit it. The rig carries
    the pitch error and housing mode of the hidden examples, the model both as fitted by the loop before it
    (grade 7.5, 2900 Hz / 7.75 %; experiments/two_hidden_effects.py), 1 s, calibrated. Before the fix the
    candidate's refit ran time-stepped (its record period, a wheel revolution, made "auto" choose that path,
    whose steady state differs from the periodic one at weak mesh harmonics) and was measured against the
    calibration's baseline, which the same refit of the nuisances alone lowers from 2.07 to 1.46 dB: the null
    effect was credited 22 % (36 % on the 2 s record of the loop, where it was claimed). Asserted: at most 5 %,
    and the refitted baseline no worse than the calibrated one."""
    from compare.nuisance_refit import refine_nuisances
    from compare.candidates import AttributionSettings, CandidateResult
    from compare.comparison import NOISE_DRAWS, evaluate, simulate_model
    from datagen.effects import EffectSpec

    m, ref, model = _two_effect_rig_with_both_fitted()
    c = calibrated_compare(m, model, reference=ref, calibrate_nuisances=True)
    params = {"amplitude_m": 2e-7}
    null = EffectSpec.from_dict({"name": "eccentricity_wheel", **params}).build()
    y_base, y_null = simulate_model(ref, c.model, extra_effects_list=[(), (null,)], solver={"method": "periodic"})
    base = evaluate(ref, y_base, ref.fs_hz, noise_draws=NOISE_DRAWS).residuals
    ev = evaluate(ref, y_null, ref.fs_hz).residuals
    cand = CandidateResult("eccentricity_wheel", "", dict(params), {}, np.inf, base.excess_total_db, {}, "whole", 1,
                           raw_baseline_error_db=base.total_db, noise_view_db=dict(base.noise_view_db or {}),
                           baseline_view_error_db=base.excess_view_db)
    cand.set_raw(ev.view_error_db, ev.total_db)
    before = cand.baseline_error_db
    refine_nuisances([cand], ref, c.model, c.calibration, AttributionSettings(), [])
    assert cand.baseline_error_db <= before + 1e-9, (cand.baseline_error_db, before)
    assert cand.reduction <= 0.05, (cand.reduction, cand.error_db, cand.baseline_error_db, cand.params)


def test_auto_keeps_the_model_as_written_when_calibrating_raises_the_error(tmp_path):
    """compare.escalation: a calibrated pass that ends above the model as written is not used. Source: the
    headline error is the one documented scalar (compare.error); the nuisances are fitted to the order view alone,
    so they can lower it at the other views' expense. Rig: the pitch error and housing mode of the hidden
    examples, 1 s; the model with both as the two-effect loop fitted them (experiments/two_hidden_effects.py).
    Measured: as written 0.67 dB, calibrated 2.07 dB (the envelope view rises; on the 2 s record a tip relief the
    rig lacks was then claimed, 34 %, ending at 0.98 against 0.87 dB). Asserted: "auto" reports the model as
    written (no calibration, not escalated), its error below the calibrated model's, and says so in the JSON
    (valid against the schema) and the HTML."""
    import jsonschema

    from compare.report import document, write_html
    from compare.schema import SCHEMA

    m, ref, model = _two_effect_rig_with_both_fitted()
    staged = compare_and_attribute(m, model, reference=ref, candidates=["tip_relief"])
    calibrated = calibrated_compare(m, model, reference=ref, calibrate_nuisances=True)
    assert not staged.escalated and staged.comparison.calibration is None
    e = staged.comparison.error_db["total"]
    assert e < calibrated.error_db["total"], (e, calibrated.error_db["total"])
    summary = staged.summary()
    rej = summary["calibration_rejected"]
    assert rej["as_written_error_db"] == pytest.approx(e) and e < rej["error_db"], (rej, e)
    assert set(rej["parameters"]) == set(NUISANCE)
    assert not any(c.claimed for c in staged.attribution.candidates)
    doc = document(staged.comparison, staged.attribution, [], measurement_path="rig", escalation=summary)
    jsonschema.validate(doc, SCHEMA)
    html = write_html(staged.comparison, doc, tmp_path / "report.html").read_text()
    assert "so the calibration was not used" in html


@pytest.mark.slow
def test_two_hidden_effects_are_found_in_turn_and_the_loop_stops():
    """The user's loop (compare.synthetic.hidden_effects_loop, experiments/two_hidden_effects.py) on the examples'
    rig with two effects on at once, the grade-8 pitch error and the 3 kHz housing mode. Source: the simulator's
    truth. Measured (seed 3, 2 s): 9.00 -> 2.52 -> 0.98 dB, pitch_error claimed first (72 %, grade 7.0),
    transmission_path second (51 %), after which the pitch error is refitted (grade 7.5), then nothing (best
    17 %); fitted 2900 Hz. (Before the periodic path read the mesh at the actual pinion angle: 8.87 -> 2.36 ->
    0.87 dB, grade 7.5 without a refit.) Asserted: the first two claims are the two
    hidden effects, each step at least halves the error, each fit within its example's tolerance, and the third
    comparison claims nothing (before the fixes of compare.nuisance_refit.refine_nuisances and the rejected
    calibration of compare.escalation it claimed a wheel eccentricity of 0.2 um, then a tip relief)."""
    from compare.synthetic import hidden_effects_loop

    names = ["pitch_error", "transmission_path"]
    out = hidden_effects_loop(names, steps=3)
    ledger = out["ledger"]
    assert [r["claimed"] for r in ledger] == names + [None], [(r["claimed"], r["candidates"]) for r in ledger]
    errors = [r["error_db"] for r in ledger]
    assert errors[1] <= 0.5 * errors[0] and errors[2] <= 0.5 * errors[1], errors
    assert all(f["ok"] for f in out["fits"].values()), out["fits"]


@pytest.mark.slow   # 257 s once the time step was bounded by the band-chosen mesh record (default suite 963 s)
def test_a_model_that_holds_a_time_stepped_effect_still_attributes():
    """After ``--add torque_fluctuation`` the model has no periodic steady state; the next attribution fitted its
    periodic candidates on the periodic path with it and stopped with "a model that simulates at this operating
    point" (found on the foreign rig, experiments/foreign_rig_check.py). Source: the simulator's truth: the rig
    carries the example's 20 % / 37 Hz torque fluctuation and a grade-8 pitch error, the model the torque
    fluctuation at its true values; the pitch error must be the one effect left to find (claimed, grade within
    the example's 0.5)."""
    from compare.attribution import attribute
    from compare.comparison import compare
    from datagen.effects import build_effects

    fluct = HIDDEN_EXAMPLES["torque_fluctuation"].effect
    m = rig_measurement((fluct, HIDDEN_EXAMPLES["pitch_error"].effect), duration_s=1.0)
    ref = prepare_reference(m)
    model = ComparisonModel(effects=build_effects((fluct,)))
    c = compare(m, model, reference=ref)
    a = attribute(ref, model, c.evaluation.residuals.residual_db, candidates=["pitch_error", "eccentricity_wheel"],
                  disagreements=c.disagreements)
    top = a.candidates[0]
    assert top.effect == "pitch_error" and top.claimed, [(x.effect, x.reduction, x.status) for x in a.candidates]
    assert abs(top.params["grade"] - 8.0) <= 0.5, top.params


def test_candidates_that_would_repeat_only_over_the_hunting_period_are_fitted_time_stepped():
    """compare.attribution.long_period_candidates. Source: the pair's kinematics. With a wheel eccentricity in the
    model (its record repeats every wheel revolution, 100 mesh cycles), a pinion eccentricity or a pinion pitch
    error makes it repeat only over the hunting period, 100 pinion revolutions (6 s at 1000 rpm, longer than the
    1 s measurement): those two go to the time-stepped fit; an error of every tooth alike (profile error, tip
    relief) keeps the wheel's period and stays periodic. The bare model (its record repeats every mesh cycle)
    sends nothing there."""
    from compare.attribution import long_period_candidates
    from datagen.effects import build_effects

    m = rig_measurement((), duration_s=1.0)
    ref = prepare_reference(m)
    pool = ["pitch_error", "eccentricity_pinion", "profile_error", "tip_relief"]
    ecc = ComparisonModel(effects=build_effects(({"name": "eccentricity_wheel", "amplitude_m": 5e-5},)))
    assert long_period_candidates(pool, ref, ecc) == ["pitch_error", "eccentricity_pinion"]
    assert long_period_candidates(pool, ref, ComparisonModel()) == []
