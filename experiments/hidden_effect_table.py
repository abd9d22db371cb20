"""The README's hidden-effect table: the user's loop on every example of compare.synthetic.HIDDEN_EXAMPLES.

Run: ``python experiments/hidden_effect_table.py [--calibrate | --no-calibrate] [--only NAME ...] [--seed N]
[--encoders]`` (about 1 min per effect on 2 idle cores; the slow test suite checks the same runs:
tests/test_compare_attribution.py). ``--encoders``: the rig also records the transmission error of two shaft
encoders, named as a further channel (compare.channels), which settles effects the accelerometer leaves as rivals.

For each hidden effect: the rig ("measurement") has that effect and nuisances unlike the model's
(compare.synthetic: damping, bearing stiffness, 30 dB noise, sensor gain x3.7, nominal speed 0.5 % off); the
baseline model is compared with it, every registered effect is fitted and ranked
(compare.attribution), the best is added with its fitted parameters and the model compared again
(compare.synthetic.run_hidden_case). Printed: the error before (excess over the noise error, the headline
``error_db``, and the raw error), the best candidate and its reduction, the error after, the fitted
parameter against the truth, and whether the issue's three checks hold (ranks first and claimed; error at most
half; parameter within the stated tolerance): "yes", or "tie" when the hidden effect is a rival of the claimed
one (compare.candidates.rivals_of: the views cannot tell them apart). The last line is JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare.synthetic import HIDDEN_EXAMPLES, case_checks, run_hidden_case, verdict  # noqa: E402


def row(name: str, calibrate, seed: int = 3, encoders: bool = False) -> dict:
    t0 = time.perf_counter()
    ex, c0, a, c1 = run_hidden_case(name, calibrate=calibrate, seed=seed, rig={"encoders": True} if encoders else None)
    top = a.candidates[0]
    return {"effect": name, "hidden": ex.effect, "raw_error_before_db": c0.raw_error_db["total"],
            "noise_error_db": c0.noise_error_db["total"], "sigma": top.sigma,
            "worst_view_rise_db": top.worst_view_rise_db, "resolution": a.resolution, **case_checks(name, ex, c0, a, c1),
            "seconds": time.perf_counter() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calibrate", action=argparse.BooleanOptionalAction, default=None,
                    help="calibrate the nuisances first (--no-calibrate: never; default \"auto\": only when the "
                         "model as written explains nothing, compare.escalation)")
    ap.add_argument("--only", nargs="*", default=None, help="these hidden effects only")
    ap.add_argument("--seed", type=int, default=3, help="the rig's noise draw (the slow tests use 3)")
    ap.add_argument("--encoders", action="store_true",
                    help="the rig also records the encoders' transmission error, a further channel")
    args = ap.parse_args(argv)
    names = args.only or sorted(HIDDEN_EXAMPLES)
    rows = []
    print("| hidden effect | error before (dB) | best candidate, reduction | error after (dB) | after / before "
          "| fitted vs true | all checks pass |")
    print("|---|---|---|---|---|---|---|")
    for name in names:
        r = row(name, args.calibrate, args.seed, args.encoders)
        rows.append(r)
        rivals = f" (rivals: {', '.join(r['rivals'])})" if r["rivals"] else ""
        print(f"| {name} | {r['error_before_db']:.2f} (raw {r['raw_error_before_db']:.2f}) | {r['best']}, "
              f"{100 * r['reduction']:.1f} %{'' if r['claimed'] else ' (not claimed)'}{rivals} | "
              f"{r['error_after_db']:.2f} | {r['ratio']:.2f} | {r['fit']} | {verdict(r)} |", flush=True)
    passed = sum(verdict(r) == "yes" for r in rows)
    ties = sum(verdict(r) == "tie" for r in rows)
    print(json.dumps({"calibrate": args.calibrate, "seed": args.seed, "encoders": args.encoders, "passed": passed, "tied": ties, "of": len(rows),
                      "rows": rows}, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
