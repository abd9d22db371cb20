"""A calibrated pass that claims nothing re-examines its leading candidate (compare.joint_refit.reexamine_leader).

Source: the simulator's truth. The rig is the helical rig of compare.synthetic.OTHER_RIGS (mesh damping 0.03,
bearing stiffness 3e8 N/m, bearing damping 0.03; 2-3 times off the model's defaults), 1 s, noise seed 11. The
starting point is what the escalated loop produced on that rig with a hidden 3 kHz / 5 % housing mode (measured on
2 s, stop 58): the calibration without the housing at 0.057 / 2.43e8 / 0.181, the housing mode ranked first there
at 3076 Hz / 0.65 % and 36.9 % (0.74 dB off against a noise error of 0.88 dB), not claimed. The control is the
same rig without the housing mode through the calibrated loop: its leader, re-examined alike, stays unclaimed.
"""
from __future__ import annotations

import math

import pytest

from compare.calibration import Calibration
from compare.candidates import Attribution, AttributionSettings, CandidateResult, choose_claim
from compare.comparison import compare, prepare_reference
from compare.synthetic import HIDDEN_EXAMPLES, OTHER_RIGS, check_fit, hidden_effect_measurement, rig_measurement
from datagen.effects import EffectSpec

HOUSING = HIDDEN_EXAMPLES["transmission_path"]
#: the escalated loop's calibration on this rig, made without the housing mode (module docstring)
BENT = {"mesh_damping_ratio": 0.0570, "bearing_n_per_m": 2.434e8, "bearing_damping_ratio": 0.1813}
#: the housing mode as the attribution fitted it at those nuisances
FITTED = {"housing_frequency_hz": 3076.0, "housing_damping_ratio": 0.00645}
SAMPLES = 256


def _rig(hidden: bool):
    rig, less_db = OTHER_RIGS["helical"]
    kw = {**rig, "snr_db": HOUSING.snr_db - less_db, "duration_s": 1.0}
    if hidden:
        m, ex = hidden_effect_measurement("transmission_path", seed=11, **kw)
        return m, prepare_reference(m), ex.model()
    m = rig_measurement(HOUSING.known, seed=11, torque_nm=HOUSING.torque_nm, **kw)
    return m, prepare_reference(m), HOUSING.model()


def _unclaimed_at(m, ref, model):
    """A calibrated comparison at :data:`BENT` and an attribution whose only candidate is the housing mode at
    :data:`FITTED`, scored as the attribution scores it, and not claimed by the claim rule."""
    model = model.with_drivetrain(BENT)
    cal = Calibration(values=dict(BENT), sigma={}, start=dict(BENT), error_before_db=math.nan,
                      error_db=math.nan, gain_db=0.0, n_simulations=0, elapsed_s=0.0)
    c0 = compare(m, model, reference=ref, calibration=cal)
    c1 = compare(m, model.with_effect(EffectSpec.from_dict({"name": "transmission_path", **FITTED}).build()),
                 reference=ref)
    r0, r1 = c0.evaluation.residuals, c1.evaluation.residuals
    cand = CandidateResult(effect="transmission_path", signature="", params=dict(FITTED),
                           sigma={k: 0.01 for k in FITTED}, error_db=r1.excess_total_db,
                           baseline_error_db=r0.excess_total_db, view_error_db=dict(r1.excess_view_db),
                           window="record", n_evaluations=0, nuisance=dict(BENT),
                           raw_error_db=r1.total_db, raw_baseline_error_db=r0.total_db,
                           noise_view_db=dict(r0.noise_view_db or {}), baseline_view_error_db=dict(r0.excess_view_db))
    a = Attribution(candidates=[cand], unexplained=[], elapsed_s=0.0, n_simulations=0)
    choose_claim(a.candidates, AttributionSettings())
    return c0, a


@pytest.fixture(scope="module")
def hidden():
    return _rig(True)


def test_a_leader_the_bent_calibration_hid_is_claimed_and_fitted(hidden):
    """With the housing mode hidden: unclaimed at the bent calibration (the loop's state, module docstring); after
    the re-examination it is claimed, its reduction against the baseline given the same global search is at least
    one half, the model with it keeps at most half the calibrated baseline's error, the frequency is within 10 %
    of 3000 Hz (the example's tolerance) and the bearing damping within a factor 2 of the rig's 0.03 (from 0.18);
    the candidate's baseline is the lower of the calibrated one and the baseline's own refit."""
    from compare.joint_refit import reexamine_leader

    m, ref, model = hidden
    c0, a = _unclaimed_at(m, ref, model)
    cand = a.candidates[0]
    before, base_before = cand.error_db, cand.baseline_error_db
    assert not a.claimed, (cand.reduction, before, base_before)
    rec = reexamine_leader(ref, c0, a, AttributionSettings(joint_samples=SAMPLES))
    assert rec is not None and rec["reexamined"] and cand.joint_refit is rec, rec
    assert a.claimed == [cand] and rec["claimed"], rec
    assert cand.reduction >= 0.5, rec
    assert cand.baseline_error_db == pytest.approx(min(base_before, rec["baseline_refitted_db"])), rec
    assert cand.error_db <= 0.5 * base_before, (cand.error_db, base_before)
    ok, text = check_fit(HOUSING, cand.params)
    assert ok, text
    assert 0.015 <= cand.nuisance["bearing_damping_ratio"] <= 0.06, cand.nuisance
    from compare.joint_refit import joint_refit_message
    text = joint_refit_message(cand.effect, rec, cand.params, cand.nuisance)
    assert "re-examined" in text and text.endswith(", claimed"), text
    # the comparison the user's --add makes gives the error the candidate reports
    after = compare(m, model.with_drivetrain(cand.nuisance).with_effect(cand.build_effect()), reference=ref)
    assert after.evaluation.residuals.excess_total_db == pytest.approx(cand.error_db, rel=1e-6)


def test_a_leader_with_nothing_hidden_stays_unclaimed():
    """Control: the same rig without the housing mode, through the calibrated loop
    (:func:`compare.escalation.compare_and_attribute`, calibrated first) over the candidates that reshape the mesh
    harmonics (housing mode, profile error, tip relief, Hertz stiffness). The re-examination runs (asserted: the
    leader ranked first with a positive reduction and claimed nothing; measured: the housing mode at 47 %) and
    nothing is claimed after it: the baseline's own global search gains what the leader's does (measured: the
    baseline 2.35 -> 0.42 dB, the housing mode 0.44 dB, -5 %)."""
    from compare.escalation import compare_and_attribute

    m, ref, model = _rig(False)
    st = compare_and_attribute(m, model, reference=ref, calibrate=True,
                               candidates=["transmission_path", "profile_error", "tip_relief", "hertz_nonlinear"])
    a = st.attribution
    assert not a.claimed, [(x.effect, round(x.reduction, 3)) for x in a.candidates]
    recs = [c.joint_refit for c in a.candidates if c.joint_refit is not None]
    assert len(recs) == 1 and recs[0]["reexamined"] and recs[0]["reduction_before"] > 0, recs
    assert recs[0]["baseline_refitted_db"] < recs[0]["baseline_before_db"] and not recs[0]["claimed"], recs


def test_the_step_applies_only_to_a_calibrated_pass_that_claims_nothing(hidden):
    """Not run (None, nothing changed) without a calibration, with joint_samples = 0, when a candidate is
    already claimed, and for a time-stepped effect."""
    from compare.joint_refit import reexamine_leader

    m, ref, model = hidden
    c0, a = _unclaimed_at(m, ref, model)
    on = AttributionSettings(joint_samples=SAMPLES)
    cand = a.candidates[0]
    assert reexamine_leader(ref, compare(m, c0.model, reference=ref), a, on) is None
    assert reexamine_leader(ref, c0, a, AttributionSettings(joint_samples=0)) is None
    cand.claimed = True
    assert reexamine_leader(ref, c0, a, on) is None
    cand.claimed = False
    cand.effect, cand.params = "speed_fluctuation", {"frequency_hz": 20.0, "amplitude_fraction": 0.01}
    assert reexamine_leader(ref, c0, a, on) is None
    assert cand.joint_refit is None and cand.nuisance == BENT
