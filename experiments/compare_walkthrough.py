"""Walkthrough of the model-versus-measurement loop on a measurement with a hidden effect.

    python experiments/compare_walkthrough.py [--out DIR] [--hidden pitch_error] [--calibrate]

1. makes a 'measurement' with the simulator (compare.synthetic): spur-gds at 1000 rpm / 50 N m, a hidden
   effect the model lacks, rig damping and bearing stiffness unlike the model's defaults, sensor noise (SNR
   30 dB) and an unknown sensor gain (x3.7); writes it as DIR/rig.csv (time, sensor, tacho) with its sidecar
   DIR/rig.toml - from here on it is treated exactly like a file from a rig;
2. ``gearpit compare DIR/rig.csv`` (baseline model, attribution over every registered effect; its drive-train
   nuisances calibrated to the measurement first with ``--calibrate``, by default only when the model as written
   explains nothing, compare.escalation): error per view, largest disagreements, ranked candidate effects with
   fitted parameters;
3. ``gearpit compare DIR/rig.csv --add <claimed effect>`` (parameters from the ledger): the error falls;
4. prints the ledger. Reports: DIR/report_1.html, DIR/report_2.html (+ .json). Last line: JSON summary.
(:func:`compare.workflow.hidden_effect_loop` does steps 1-3; ``gearpit demo`` can call it too.)
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from compare.ledger import history_table
from compare.synthetic import HIDDEN_EXAMPLES
from compare.workflow import hidden_effect_loop


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearpit_out/compare_walkthrough"))
    ap.add_argument("--hidden", default="pitch_error", choices=sorted(HIDDEN_EXAMPLES))
    ap.add_argument("--calibrate", action="store_true", help="calibrate the drive-train nuisances first")
    args = ap.parse_args()
    summary, first, second = hidden_effect_loop(args.out, args.hidden, calibrate=args.calibrate or None)
    print(f"hidden effect: {summary['hidden']} (the model does not have it); measurement: {args.out / 'rig.csv'}")
    print(f"\n== run 1: baseline model, error {summary['error_before_db']:.2f} dB "
          f"(attribution {summary['attribution_s']:.1f} s)")
    for tag, cal in (("run 1", summary["calibration_before"]), ("run 2", summary["calibration_after"])):
        if cal is not None:
            vals = ", ".join(f"{k} {v:.4g}" + (f" +/- {cal['sigma'][k]:.2g}" if cal["sigma"][k] is not None else "")
                             for k, v in cal["parameters"].items())
            print(f"   nuisances calibrated ({tag}): {vals}; error {cal['error_before_db']:.2f} -> "
                  f"{cal['error_db']:.2f} dB")
    for d in first.comparison.disagreements[:6]:
        print("  ", d.text)
    print("ranked candidate effects (error reduction, fitted parameters +/- 1 sigma):")
    for c in first.attribution.candidates:
        ps = ", ".join(f"{k}={v:.4g} +/- {c.sigma[k]:.2g}" if k in c.sigma else f"{k}={v}" for k, v in c.params.items())
        print(f"   {c.effect:20s} {100 * c.reduction:6.1f} %  {ps}{'  <- claimed' if c.claimed else ''}")
    for u in first.attribution.unexplained:
        print("   unexplained:", u["text"])
    if summary["claimed"]:
        print(f"\n== run 2: model + {summary['claimed']} (fitted parameters), error {summary['error_after_db']:.2f} dB")
        for msg in second.messages:
            print("  ", msg)
    print("\nledger:")
    print(history_table(second.ledger))
    ratio = None if summary["error_after_db"] is None else summary["error_after_db"] / summary["error_before_db"]
    print(json.dumps({"hidden": args.hidden, "claimed": summary["claimed"],
                      "error_before_db": round(summary["error_before_db"], 3),
                      "error_after_db": None if ratio is None else round(summary["error_after_db"], 3),
                      "ratio": None if ratio is None else round(ratio, 3),
                      "attribution_s": round(summary["attribution_s"], 1),
                      "calibrated": None if summary["calibration_before"] is None
                      else {k: round(v, 6) for k, v in summary["calibration_before"]["parameters"].items()}}))


if __name__ == "__main__":
    main()
