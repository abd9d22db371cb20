"""Walkthrough of the model-versus-measurement loop on a measurement with a hidden effect.

    python experiments/compare_walkthrough.py [--out DIR] [--hidden pitch_error]

1. makes a 'measurement' with the simulator (compare.synthetic): spur-gds at 1000 rpm / 50 N m, a hidden
   effect the model lacks, rig damping and bearing stiffness unlike the model's defaults, sensor noise (SNR
   30 dB) and an unknown sensor gain (x3.7); writes it as DIR/rig.csv (time, sensor, tacho) with its sidecar
   DIR/rig.toml - from here on it is treated exactly like a file from a rig;
2. runs ``gearpit compare DIR/rig.csv`` (baseline model, attribution over every registered effect):
   error per view, largest disagreements, ranked candidate effects;
3. runs ``gearpit compare DIR/rig.csv --add <claimed effect>`` (parameters from the ledger): the error falls;
4. prints the ledger. Reports: DIR/report_1.html, DIR/report_2.html (+ .json). Last line: JSON summary.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from compare.ledger import history_table
from compare.synthetic import HIDDEN_EXAMPLES, hidden_effect_measurement
from compare.workflow import run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("gearpit_out/compare_walkthrough"))
    ap.add_argument("--hidden", default="pitch_error", choices=sorted(HIDDEN_EXAMPLES))
    args = ap.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("rig.model.toml", "rig.model.ledger.jsonl"):
        (out / stale).unlink(missing_ok=True)

    m, ex = hidden_effect_measurement(args.hidden)
    t = np.arange(m.n_samples) / m.fs_hz
    np.savetxt(out / "rig.csv", np.column_stack([t, m.channels["acc"], m.channels["tacho"]]), delimiter=",",
               header="time_s,acc_x,tacho", comments="", fmt="%.10g")
    (out / "rig.toml").write_text(f'speed_rpm = {m.speed_rpm}\ntorque_nm = {m.torque_nm}\npair = "spur-gds"\n'
                                  'sensor = "acc_x"\ntacho = "tacho"\n')
    print(f"hidden effect: {ex.effect} (the model does not have it); measurement: {out / 'rig.csv'}")

    t0 = time.perf_counter()
    first = run(out / "rig.csv", report=out / "report_1.html", json_path=out / "report_1.json")
    t1 = time.perf_counter() - t0
    e0 = first.comparison.error_db["total"]
    print(f"\n== run 1: baseline model, error {e0:.2f} dB ({t1:.1f} s)")
    for d in first.comparison.disagreements[:6]:
        print("  ", d.text)
    print("ranked candidate effects:")
    for c in first.attribution.candidates:
        ps = ", ".join(f"{k}={v:.4g} +/- {c.sigma[k]:.2g}" if k in c.sigma else f"{k}={v}" for k, v in c.params.items())
        print(f"   {c.effect:20s} {100 * c.reduction:6.1f} %  {ps}{'  <- claimed' if c.claimed else ''}")
    claimed = first.attribution.claimed[0].effect if first.attribution.claimed else None
    for u in first.attribution.unexplained:
        print("   unexplained:", u["text"])

    e1 = None
    if claimed is not None:
        second = run(out / "rig.csv", add=[claimed], report=out / "report_2.html", json_path=out / "report_2.json")
        e1 = second.comparison.error_db["total"]
        print(f"\n== run 2: model + {claimed} (fitted parameters), error {e1:.2f} dB")
        for msg in second.messages:
            print("  ", msg)
        rows = second.ledger
    else:
        rows = first.ledger
    print("\nledger:")
    print(history_table(rows))
    print(json.dumps({"hidden": args.hidden, "claimed": claimed, "error_before_db": round(e0, 3),
                      "error_after_db": None if e1 is None else round(e1, 3),
                      "ratio": None if e1 is None else round(e1 / e0, 3), "attribution_s": round(t1, 1)}))


if __name__ == "__main__":
    main()
