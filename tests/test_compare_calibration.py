"""Nuisance calibration (compare.calibration; source: the simulator's known truth).

On a rig without hidden effect it recovers the nuisances within NUISANCE_TOLERANCE; with model and rig identical
it stays at the truth and its error at the noise floor (two independent noise draws); the model file switches it;
switched on, it lets transmission_path (nuisance-limited without it) be claimed and halve the calibrated
baseline's error. (Moved out of tests/test_compare_attribution.py, which keeps the attribution's tests.)
"""
from __future__ import annotations

import pytest

from compare.calibration import calibrate, calibrated_compare
from compare.comparison import compare, prepare_reference
from compare.model import ComparisonModel
from compare.synthetic import NUISANCE, check_fit, rig_measurement, run_hidden_case

#: how closely the calibration recovers each nuisance on a rig without hidden effect (source: the simulator's
#: truth): max(fit / true, true / fit) at most this. The bearing stiffness sets the mesh resonance and is pinned
#: down to a few % (measured on the 1 s rigs below: 1.04, 1.03; asserted 1.08); the mesh damping sets the
#: resonance peak (measured 1.12, 1.15; asserted 1.25); the bearing damping only damps bearing modes far from
#: the excitation and is weakly identifiable (measured 1.43, 1.07; asserted a factor 2).
NUISANCE_TOLERANCE = {"mesh_damping_ratio": 1.25, "bearing_n_per_m": 1.08, "bearing_damping_ratio": 2.0}


def _within(values, truth):
    return {k: max(values[k] / truth[k], truth[k] / values[k]) <= tol for k, tol in NUISANCE_TOLERANCE.items()}


def test_calibration_recovers_the_nuisances_of_a_rig_without_hidden_effect():
    """Rig with NUISANCE drive train, model at the defaults: the calibrated values are within
    NUISANCE_TOLERANCE of the rig's, and the error falls to at most that of the true model (+0.05 dB)."""
    m = rig_measurement(duration_s=1.0)
    ref = prepare_reference(m)
    cal = calibrate(ref, ComparisonModel())
    ok = _within(cal.values, NUISANCE)
    assert all(ok.values()), (cal.values, NUISANCE)
    true_error = compare(m, ComparisonModel().with_drivetrain(NUISANCE), reference=ref).raw_error_db["total"]
    assert cal.error_db < cal.error_before_db and cal.error_db <= true_error + 0.05, (cal.error_db, true_error)
    assert set(cal.to_dict()["parameters"]) == set(NUISANCE)


def test_calibration_of_an_identical_model_stays_at_the_truth_and_the_noise_floor():
    """Rig and model with the same (default) drive train: the calibration leaves the values within
    NUISANCE_TOLERANCE of the truth, and the error stays at the noise floor: within 0.05 dB of the identical
    model's own error, which is below 1 dB (independent noise draws at SNR 30 dB). A 2 s record: on 1 s the noise
    alone moved the mesh damping 15-27 % (0.0609 or 0.0550 for 0.07, as the simulator's mesh timing changed) for
    0.02 dB of error; on 2 s it stays within 4 %."""
    from datagen.lumped_model import DriveTrain

    m = rig_measurement(duration_s=2.0, nuisance={})
    ref = prepare_reference(m)
    cal = calibrate(ref, ComparisonModel())
    truth = {k: getattr(DriveTrain(), k) for k in NUISANCE}
    assert cal.start == truth
    ok = _within(cal.values, truth)
    assert all(ok.values()), (cal.values, truth)
    assert cal.error_before_db < 1.0 and abs(cal.error_db - cal.error_before_db) <= 0.05
    assert cal.objective_db <= cal.objective_before_db


def test_calibration_is_switched_by_the_model_file():
    """Default and [calibration] enabled = false: the model's drive train as it is, no calibration recorded;
    enabled = true with a parameter list: only those are calibrated."""
    m = rig_measurement(duration_s=1.0)
    for table in ({}, {"calibration": {"enabled": False}}):
        model = ComparisonModel.from_dict({**table, "drivetrain": {"mesh_damping_ratio": 0.08}})
        c = calibrated_compare(m, model)
        assert c.calibration is None and c.model.tables["drivetrain"] == {"mesh_damping_ratio": 0.08}
    model = ComparisonModel.from_dict({"calibration": {"enabled": True, "parameters": ["bearing_n_per_m"]}})
    c = calibrated_compare(m, model)
    assert set(c.calibration.values) == {"bearing_n_per_m"}
    assert c.model.tables["drivetrain"]["bearing_n_per_m"] == c.calibration.values["bearing_n_per_m"]


@pytest.mark.slow
def test_calibration_lets_transmission_path_halve_the_error():
    """With the nuisance calibration on (whole registry): transmission_path ranks first and is claimed; the model
    with it (fitted parameters and the nuisances they were fitted with, calibrated again) has at most half the
    calibrated baseline's error; the housing frequency is within the example's tolerance. Measured (seed 3):
    1.59 -> 0.47 dB, 2969 vs 3000 Hz. (It kept 0.75 of the error, 1.59 -> 1.19 dB, while the search refined only
    the first round's best point: compare.search, basins.)"""
    ex, c0, a, c1 = run_hidden_case("transmission_path", calibrate=True)
    top = a.candidates[0]
    assert top.effect == "transmission_path" and top.claimed, [(x.effect, x.reduction) for x in a.candidates[:3]]
    assert c1.error_db["total"] <= 0.5 * c0.error_db["total"], (c1.error_db["total"], c0.error_db["total"])
    ok, text = check_fit(ex, top.params)
    assert ok, text
