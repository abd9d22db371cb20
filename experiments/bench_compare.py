"""Benchmark: compare + attribution over every registered effect, 2 s measurement, 2 cores.

    python experiments/bench_compare.py

The measurement (spur-gds, 1000 rpm, 50 N m, fs 20 kHz, 2 s) hides a pitch error; the budget is 60 s for the
whole loop: the measurement side (speed refinement, plan, views), the nuisance calibration and the
calibrated comparison (:func:`compare.calibration.calibrated_compare`), plus ``attribute`` over all
registered effects (with the nuisance refit of the leading candidates). The joint refit of the claimed effect
with the nuisances over their whole box (:mod:`compare.joint_refit`), which a calibrated run adds after the
claim, is timed beside it and reported with and without it (``joint_refit_s``, ``total_with_joint_refit_s``).
The reference, measured in the same run, is one plain comparison (baseline simulation and evaluation, no
calibration): the ratio says how many comparisons the calibration and attribution cost.

Also timed: the default path (calibration "auto", :func:`compare.escalation.compare_and_attribute`) on the same
measurement, where the model as written explains the pitch error and nothing is calibrated, and on its rig
without a hidden effect, where nothing is explained and the run escalates (compare, attribute, calibrate,
attribute again), and on a rig whose drive train is 2-3 times off the model's defaults with a hidden pitch
error (the helical rig of :data:`compare.synthetic.OTHER_RIGS`, 2 s, noise seed 11): the run escalates, claims
the pitch error in its calibrated pass and refits it jointly with the drive train - the costliest path of the
default, a case a user with a rig unlike the defaults meets. Each escalated run is split into its stages
(first attribution, calibration, second attribution, joint refit). Last line: JSON.
"""
from __future__ import annotations

import json
import os
import time

from compare.attribution import attribute
from compare.calibration import calibrated_compare
from compare.candidates import AttributionSettings
from compare.comparison import compare, prepare_reference
from compare.escalation import compare_and_attribute
from compare.joint_refit import refit_claim_jointly
from compare.model import ComparisonModel
from compare.synthetic import HIDDEN_EXAMPLES, OTHER_RIGS, hidden_effect_measurement, rig_measurement
from datagen.effects import names

BUDGET_S = 60.0


def main() -> None:
    m, _ = hidden_effect_measurement("pitch_error")
    t0 = time.perf_counter()
    ref = prepare_reference(m)
    t_ref = time.perf_counter() - t0              # speed refinement, plan, measured views
    t0 = time.perf_counter()
    compare(m, ComparisonModel(), reference=ref)
    t_compare = time.perf_counter() - t0          # one plain comparison: the unit of cost (not in the total)
    t1 = time.perf_counter()
    c = calibrated_compare(m, ComparisonModel(), reference=ref, calibrate_nuisances=True)  # the costlier path
    t_cal = time.perf_counter() - t1
    t2 = time.perf_counter()
    a = attribute(ref, c.model, c.evaluation.residuals.residual_db, disagreements=c.disagreements,
                  calibration=c.calibration)
    t_attr = time.perf_counter() - t2
    total = t_ref + t_cal + t_attr
    t4 = time.perf_counter()
    joint = refit_claim_jointly(ref, c, a, AttributionSettings())
    t_joint = time.perf_counter() - t4
    auto = {}
    helical, less_db = OTHER_RIGS["helical"]
    far, far_ex = hidden_effect_measurement("pitch_error", seed=11, duration_s=2.0,
                                            **{**helical, "snr_db": HIDDEN_EXAMPLES["pitch_error"].snr_db - less_db})
    for tag, meas, model in (("explained", m, ComparisonModel()), ("escalated", rig_measurement(), ComparisonModel()),
                             ("escalated_claim_far_rig", far, far_ex.model())):
        t3 = time.perf_counter()
        staged = compare_and_attribute(meas, model)
        elapsed = time.perf_counter() - t3
        auto[tag] = {"total_s": round(elapsed, 3), "escalated": staged.escalated, "within_budget": elapsed < BUDGET_S,
                     "claimed": staged.attribution.claimed[0].effect if staged.attribution.claimed else None,
                     "stages_s": _stages(staged)}
    print(f"cores available: {os.cpu_count()}, load average: {os.getloadavg()[0]:.2f}")
    print(f"registered effects: {len(names())}, candidates fitted: {len(a.candidates)}, simulations: {a.n_simulations}")
    print(f"measurement side: {t_ref:.2f} s; one plain comparison (reference): {t_compare:.2f} s; "
          f"nuisance calibration + calibrated comparison: {t_cal:.2f} s "
          f"({c.calibration.n_simulations} simulations); attribution: {t_attr:.2f} s "
          f"(groups: {', '.join(f'{k} {v:.1f} s' for k, v in a.group_seconds.items())})")
    print(f"total {total:.2f} s against a budget of {BUDGET_S:.0f} s; calibration + attribution = "
          f"{(t_cal + t_attr) / t_compare:.1f} comparisons")
    print(f"top candidate: {a.candidates[0].effect} ({100 * a.candidates[0].reduction:.1f} % error reduction)")
    print(f"joint refit of the claim with the nuisances: {t_joint:.2f} s"
          + (f" ({'kept' if joint['kept'] else 'not kept'}: error {joint['error_before_db']:.2f} -> "
             f"{joint['error_after_db']:.2f} dB)" if joint else " (not run: nothing claimed)")
          + f"; calibrated path with it: {total + t_joint:.2f} s against {BUDGET_S:.0f} s")
    for tag, r in auto.items():
        print(f"default (auto) path, {tag} ({'escalated' if r['escalated'] else 'not calibrated'}; claimed: "
              f"{r['claimed']}): {r['total_s']:.2f} s, measurement side included, against {BUDGET_S:.0f} s "
              f"({', '.join(f'{k} {v:.1f} s' for k, v in r['stages_s'].items())})")
    print(json.dumps({"benchmark": "compare_attribution", "duration_s": m.duration_s, "fs_hz": m.fs_hz,
                      "n_candidates": len(a.candidates), "n_simulations": a.n_simulations,
                      "reference_s": round(t_ref, 3), "compare_s": round(t_compare, 3),
                      "calibration_s": round(t_cal, 3),
                      "attribution_s": round(t_attr, 3), "total_s": round(total, 3),
                      "ratio_to_one_comparison": round((t_cal + t_attr) / t_compare, 2), "budget_s": BUDGET_S,
                      "within_budget": total < BUDGET_S, "joint_refit_s": round(t_joint, 3),
                      "total_with_joint_refit_s": round(total + t_joint, 3),
                      "within_budget_with_joint_refit": total + t_joint < BUDGET_S, "load_average_1min": round(os.getloadavg()[0], 2),
                      "top": a.candidates[0].effect, "auto": auto}))


def _stages(staged) -> dict:
    """Seconds of the stages of a default-path run: the attribution of the model as written, the calibration, the
    attribution of the calibrated model, the joint refit of its claim (those that ran)."""
    out = {}
    if staged.as_written is not None:
        out["attribution_as_written"] = staged.as_written[1].elapsed_s
    cal = staged.comparison.calibration
    if cal is not None:
        out["calibration"] = cal.elapsed_s
    if staged.attribution is not None:
        out["attribution_calibrated" if cal is not None else "attribution"] = staged.attribution.elapsed_s
        claimed = staged.attribution.claimed
        if claimed and claimed[0].joint_refit:
            out["joint_refit"] = claimed[0].joint_refit["elapsed_s"]
    return {k: round(float(v), 2) for k, v in out.items()}


if __name__ == "__main__":
    main()
