"""The compare loop on 'measurements' from another simulator: does the attribution generalise beyond gearpit's physics?

Run: ``python experiments/foreign_rig_check.py [--only CASE ...] [--seed N] [--duration S] [--steps N]``
(1-35 min per case on 2 cores: a model holding an eccentricity simulates a whole gear revolution per trial). The
last line is JSON.

Every other check of the comparison (tests, ``hidden_effect_table.py``, ``generalisation_check.py``) makes its
"measurements" with gearpit's own simulator, so the model and the rig share every modelling choice but the
nuisance values. Here the rig is ``tests/foreign_rig.py``: an independent textbook simulator (ISO 6336 pair
stiffness instead of the potential-energy method, a 3-DOF line-of-action model instead of the drive train,
explicit RK4 instead of Newmark, a random-walk pitch error, a kinematic speed fluctuation, a base-excited housing
filter; its docstring lists the differences). Only the gear geometry is shared, since a comparison is always
told the pair. The comparison model is gearpit's bare default (``ComparisonModel()``), the loop the user's
(compare, attribute over every registered effect with calibration "auto", add the best candidate, compare
again).

What counts as right for a foreign rig. Between two simulators the mesh harmonics differ even for a healthy
pair (another stiffness model, other modes), and a comparison with the bare model claims an effect that reshapes
them (profile error, tip relief, transmission path, Hertz stiffness, backlash: ``foreign_rig.MESH_SHAPE``): that is the
models' difference, and the user's loop (``gearpit compare --add``, :func:`compare.synthetic.compare_loop`, up to
three comparisons) adds it and goes on. So a case passes when, along the loop, the hidden effect's *family* is
claimed (the same physical signature in gearpit's registry: :data:`FOREIGN_CASES`) with only mesh-shape effects
claimed before it, the final model keeps at most half of the first comparison's error, and the parameter a user
would read off (a frequency, an eccentricity; for a fluctuation also what it does to the shafts in the model,
:data:`RESPONSE_CHECKS`) is within the stated tolerance. A control (no effect, a bearing
defect) passes when no effect outside the mesh-shape ones is claimed. The stricter reading - the hidden effect
claimed at the first comparison and halving the error alone - is printed beside it.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from foreign_rig import MESH_SHAPE, ForeignRig, foreign_measurement  # noqa: E402

#: case -> (ForeignRig overrides, accepted effects, (parameter, kind, tolerance, true value) or None)
FOREIGN_CASES = {
    "none": ({}, None, None),
    "bearing_defect": ({"bearing_defect": (71.3, 3900.0, 40.0)}, None, None),
    "eccentricity_pinion": ({"eccentricity_m": (150e-6, 0.0)}, {"eccentricity_pinion"},
                            ("amplitude_m", "ratio", 2.0, 150e-6)),
    "eccentricity_wheel": ({"eccentricity_m": (0.0, 50e-6)}, {"eccentricity_wheel"},
                           ("amplitude_m", "ratio", 2.0, 50e-6)),
    # a random-walk cumulative pitch error: its first order is a once-per-revolution transmission error, as an
    # eccentricity's is; both are the pinion's once-per-revolution family
    "pitch_error": ({"pitch_fp_m": 40e-6}, {"pitch_error", "eccentricity_pinion"}, None),
    # local tooth faults (stop 57): the foreign rig's pit is a loss of that pair's stiffness over part of its path
    # of contact (its own model, not a pit map); over the whole path it is a tooth broken across that share of its
    # width (Chaari et al. 2008). Either local fault of gearpit's registry is the family; the width is checked
    # when the break is what was claimed
    "broken_tooth": ({"pits": {3: (0.3, 0.0, 1.0)}}, {"tooth_breakage", "tooth_pit"},
                     ("width_fraction", "ratio", 1.5, 0.3)),
    "pit": ({"pits": {3: (0.6, 0.35, 0.65)}}, {"tooth_pit", "tooth_breakage"}, None),
    "transmission_path": ({"housing": (3000.0, 0.05)}, {"transmission_path"},
                          ("housing_frequency_hz", "ratio", 1.1, 3000.0)),
    "speed_fluctuation": ({"speed_fluctuation": (0.01, 23.0)}, {"speed_fluctuation", "torque_fluctuation"},
                          ("frequency_hz", "ratio", 1.05, 23.0)),
    "torque_fluctuation": ({"torque_fluctuation": (0.2, 37.0)}, {"speed_fluctuation", "torque_fluctuation"},
                           ("frequency_hz", "ratio", 1.05, 37.0)),
}

#: case -> (response quantity of compare.response, tolerance as a ratio, true value): what the foreign rig's
#: fluctuation does to the shafts. Its speed fluctuation is imposed on the pinion's rotation (a swing of 1 %); its
#: torque fluctuation passes the mesh quasi-statically (the mesh force swings by 20 %). The fitted
#: ``amplitude_fraction`` is what enters gearpit's drive train (the speed loop's reference, the load torque), so
#: the claimed fluctuation's response in the model is what is compared with the truth.
RESPONSE_CHECKS = {"speed_fluctuation": ("speed_pinion_amplitude_fraction", 1.5, 0.01),
                   "torque_fluctuation": ("mesh_force_amplitude_fraction", 1.5, 0.2)}


def run_case(name: str, *, seed: int = 5, duration_s: float = 2.0, steps: int = 3, log=print) -> dict:
    """The loop (:func:`compare.synthetic.compare_loop`, up to ``steps`` comparisons) on one foreign case; returns
    the row (errors in dB: the excess over the noise error)."""
    from compare.synthetic import compare_loop

    t0 = time.perf_counter()
    over, accepted, check = FOREIGN_CASES[name]
    m = foreign_measurement(ForeignRig(seed=seed, duration_s=duration_s, **over))
    ledger, model, final = compare_loop(m, steps=steps, log=lambda s: log("    " + s))
    claims = [r["claimed"] for r in ledger if r["claimed"]]
    first = ledger[0]
    row = {"case": name, "error_before_db": first["error_db"], "escalated": first["escalated"],
           "best": first["candidates"][0]["effect"], "reduction": first["candidates"][0]["reduction"],
           "claimed_first": first["claimed"], "claims": claims, "error_after_db": float(final.error_db["total"]),
           "ledger": ledger}
    if accepted is None:
        wrong = [c for c in claims if c not in MESH_SHAPE]
        row["pass"] = not wrong
        row["verdict"] = ("nothing claimed" if not claims else f"only mesh-shape effects ({', '.join(claims)}): "
                          "the simulators differ" if not wrong else f"claimed {', '.join(wrong)}: a fault the rig lacks")
        row["first_step_pass"] = first["claimed"] is None or first["claimed"] in MESH_SHAPE
    else:
        at = next((i for i, r in enumerate(ledger) if r["claimed"] in accepted), None)
        before = [r["claimed"] for r in ledger[:at if at is not None else len(ledger)] if r["claimed"]]
        ok_effect = at is not None and all(c in MESH_SHAPE for c in before)
        ok_half = row["error_after_db"] <= 0.5 * row["error_before_db"]
        ok_fit = True
        if at is not None and check is not None and check[0] in ledger[at]["claimed_params"]:
            p, kind, tol, true = check
            fit = float(ledger[at]["claimed_params"][p])
            ratio = max(fit / true, true / fit) if fit > 0 else float("inf")
            ok_fit = ratio <= tol
            row["fit"] = f"{p}: {fit:.4g} vs {true:.4g} (ratio {ratio:.3g} <= {tol})"
        if at is not None and name in RESPONSE_CHECKS:
            from compare.response import fluctuation_response, modulations
            from datagen.effects import EffectSpec

            q, tol, true = RESPONSE_CHECKS[name]
            eff = EffectSpec.from_dict({"name": ledger[at]["claimed"], **ledger[at]["claimed_params"]}).build()
            from compare.comparison import prepare_reference

            ref = prepare_reference(m)
            speed = ref.speed.speed_rpm                                      # measured, as the comparison's
            resp = fluctuation_response(model, m.pair, eff, speed_rpm=speed, torque_nm=m.torque_nm)
            resp["modulation"] = modulations(ref, model, eff, resp["frequency_hz"])
            ratio = max(resp[q] / true, true / resp[q]) if resp[q] > 0 else float("inf")
            ok_fit = ok_fit and ratio <= tol
            row["response"] = resp
            mod = resp["modulation"]
            row["fit"] = (row.get("fit", "") + f"; {ledger[at]['claimed']} in the model: {q} {resp[q]:.4g} vs "
                          f"{true:.4g} (ratio {ratio:.3g} <= {tol}); sidebands measured {mod['measured']['type']}, "
                          f"model {mod['model']['type']} modulation")
        row["found_at_step"] = at
        row["pass"] = ok_effect and ok_half and ok_fit
        row["verdict"] = ("yes" if row["pass"] else
                          "no: " + ", ".join(w for w, ok in (("effect", ok_effect), ("halving", ok_half),
                                                                ("fit", ok_fit)) if not ok))
        # the stricter single-step reading: claimed at the first comparison, and that comparison's claim alone
        # halves the error (ledger[1] is the model with it)
        after1 = ledger[1]["error_db"] if len(ledger) > 1 else row["error_after_db"]
        row["first_step_pass"] = at == 0 and ok_fit and after1 <= 0.5 * row["error_before_db"]
    row["seconds"] = time.perf_counter() - t0
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", default=None, choices=sorted(FOREIGN_CASES))
    ap.add_argument("--seed", type=int, default=5, help="the foreign rig's draws (noise, pitch errors)")
    ap.add_argument("--duration", type=float, default=2.0, help="record length, s")
    ap.add_argument("--steps", type=int, default=3, help="comparisons in the loop at most")
    args = ap.parse_args(argv)
    rows = []
    for name in args.only or list(FOREIGN_CASES):
        rows.append(run_case(name, seed=args.seed, duration_s=args.duration, steps=args.steps))
    print("| case | error before (dB) | first comparison: best, reduction | claims, in order | error after (dB) "
          "| fit | pass (loop) | pass (first comparison alone) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['error_before_db']:.2f}{' (calibrated)' if r['escalated'] else ''} | "
              f"{r['best']}, {100 * r['reduction']:.1f} % | {', '.join(r['claims']) or '-'} | "
              f"{r['error_after_db']:.2f} | {r.get('fit', '-')} | {r['verdict']} | "
              f"{'yes' if r['first_step_pass'] else 'no'} |")
    print(json.dumps({"seed": args.seed, "duration_s": args.duration, "passed": sum(r["pass"] for r in rows),
                      "passed_first_comparison": sum(r["first_step_pass"] for r in rows),
                      "of": len(rows), "rows": rows}, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
