"""The joint refit of a claimed effect with the drive train over the whole nuisance box (compare.joint_refit).

Source: the simulator's truth. The rig is the helical rig of compare.synthetic.OTHER_RIGS (mesh damping 0.03,
bearing stiffness 3e8 N/m, bearing damping 0.03; 2-3 times off the model's defaults) with a hidden grade-8 pitch
error, 1 s. The starting point is what the escalated loop produced on that rig (measured, 2 s, noise seed 11): the
calibration without the effect at 0.042 / 3.9e8 / 0.136 and the pitch error claimed there at grade 5.
"""
from __future__ import annotations

import math

import pytest

from compare.calibration import Calibration
from compare.candidates import Attribution, AttributionSettings, CandidateResult
from compare.comparison import compare, prepare_reference
from compare.synthetic import HIDDEN_EXAMPLES, OTHER_RIGS, hidden_effect_measurement
from datagen.effects import EffectSpec

PITCH = HIDDEN_EXAMPLES["pitch_error"]
#: the escalated loop's calibration on this rig, made without the pitch error (module docstring)
BENT = {"mesh_damping_ratio": 0.0417, "bearing_n_per_m": 3.895e8, "bearing_damping_ratio": 0.136}
#: the default number of Sobol points (with 128 the grade came out at 7.2 on this record)
SAMPLES = 256
#: the grade's tolerance on this 1 s record: measured 7.7 here (noise seed 11, Sobol seed 0), 6.7-7.7 over noise
#: seeds 11 and 12 and two Sobol seeds (compare.joint_refit); the loop's 2 s record keeps the example's 0.5
#: (tests/test_compare_attribution.py)
GRADE_TOL = 1.0


@pytest.fixture(scope="module")
def rig():
    rig, less_db = OTHER_RIGS["helical"]
    m, ex = hidden_effect_measurement("pitch_error", seed=11, duration_s=1.0, **{**rig, "snr_db": PITCH.snr_db - less_db})
    return m, prepare_reference(m), ex


def _claimed_at(m, ref, ex, nuisance: dict, grade: float):
    """A calibrated comparison at ``nuisance`` and an attribution claiming the pitch error at ``grade`` there."""
    model = ex.model().with_drivetrain(nuisance)
    cal = Calibration(values=dict(nuisance), sigma={}, start=dict(nuisance), error_before_db=math.nan,
                      error_db=math.nan, gain_db=0.0, n_simulations=0, elapsed_s=0.0)
    c0 = compare(m, model, reference=ref, calibration=cal)
    params = {"grade": grade, "gears": "pinion"}
    c1 = compare(m, model.with_effect(EffectSpec.from_dict({"name": "pitch_error", **params}).build()), reference=ref)
    cand = CandidateResult(effect="pitch_error", signature="", params=params, sigma={"grade": 0.1},
                           error_db=c1.error_db["total"], baseline_error_db=c0.error_db["total"],
                           view_error_db={}, window="record", n_evaluations=0, claimed=True, nuisance=dict(nuisance))
    return c0, Attribution(candidates=[cand], unexplained=[], elapsed_s=0.0, n_simulations=0)


def test_a_fit_made_at_bent_nuisances_reaches_the_truth(rig):
    """From the bent calibration and grade 5 (3 grades off), the joint refit moves the grade within
    :data:`GRADE_TOL` of the true 8 and the bearing damping to within a factor 2 of the rig's 0.03 (from 0.136,
    4.5 times off); the model with it keeps at most half of the error it had (measured: 2.59 -> 0.36 dB). The
    local refit of the attribution (scans of +/-0.1 in the search coordinate) cannot reach this: it fails if
    the global stage is missing or the refit is not adopted."""
    from compare.joint_refit import refit_claim_jointly

    m, ref, ex = rig
    c0, a = _claimed_at(m, ref, ex, BENT, 5.0)
    before = a.candidates[0].error_db
    rec = refit_claim_jointly(ref, c0, a, AttributionSettings(joint_samples=SAMPLES))
    cand = a.candidates[0]
    assert rec is not None and rec["kept"] and cand.joint_refit is rec, rec
    assert abs(cand.params["grade"] - 8.0) <= GRADE_TOL, rec
    assert 0.015 <= cand.nuisance["bearing_damping_ratio"] <= 0.06, cand.nuisance
    assert cand.error_db <= 0.5 * before, (cand.error_db, before)
    assert rec["error_after_db"] == pytest.approx(cand.error_db) and rec["error_before_db"] == pytest.approx(before)
    # the comparison the user's --add makes gives the error the candidate reports
    after = compare(m, ex.model().with_drivetrain(cand.nuisance).with_effect(
        EffectSpec.from_dict({"name": "pitch_error", **cand.params}).build()), reference=ref)
    assert after.error_db["total"] == pytest.approx(cand.error_db, rel=1e-6)


@pytest.mark.slow
def test_a_fit_at_the_truth_is_kept(rig):
    """Control: claimed at the rig's own nuisances and grade, no refit lowers the error by 10 % (the rule of
    compare.refit.MIN_GAIN), so nothing changes: the step does not chase the noise."""
    from compare.joint_refit import refit_claim_jointly

    m, ref, ex = rig
    true = OTHER_RIGS["helical"][0]["nuisance"]
    c0, a = _claimed_at(m, ref, ex, true, 8.0)
    rec = refit_claim_jointly(ref, c0, a, AttributionSettings(joint_samples=SAMPLES))
    assert rec is not None and not rec["kept"], rec
    assert a.candidates[0].params["grade"] == 8.0 and a.candidates[0].nuisance == true


def test_the_step_applies_only_to_a_calibrated_periodic_claim(rig):
    """Not run (None, nothing changed) without a calibration, with joint_samples = 0, without a claim, for a
    time-stepped effect, and for a pitch error of the wheel (its record repeats once per wheel revolution, 60
    mesh cycles: too costly per sample, compare.joint_refit)."""
    from compare.joint_refit import refit_claim_jointly

    m, ref, ex = rig
    c0, a = _claimed_at(m, ref, ex, BENT, 5.0)
    on = AttributionSettings(joint_samples=SAMPLES)
    c_uncal = compare(m, c0.model, reference=ref)
    assert refit_claim_jointly(ref, c_uncal, a, on) is None
    assert refit_claim_jointly(ref, c0, a, AttributionSettings(joint_samples=0)) is None
    a.candidates[0].claimed = False
    assert refit_claim_jointly(ref, c0, a, on) is None
    a.candidates[0].claimed = True
    a.candidates[0].params = {"grade": 5.0, "gears": "wheel"}
    assert refit_claim_jointly(ref, c0, a, on) is None
    a.candidates[0].effect = "speed_fluctuation"
    assert refit_claim_jointly(ref, c0, a, on) is None
    assert a.candidates[0].joint_refit is None and a.candidates[0].params["grade"] == 5.0
