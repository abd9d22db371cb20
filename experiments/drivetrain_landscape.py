"""How a hidden effect's error depends on its amount, at the model's drive train and at the rig's.

    python experiments/drivetrain_landscape.py [--effect tooth_pit] [--values 0.1,0.15,0.2,0.25,0.3,0.35]
        [--param severity] [--set gears=pinion] [--rig helical] [--seed 11]

The rig is one of :data:`compare.synthetic.OTHER_RIGS` (default: the far helical rig of
``experiments/generalisation_check.py``, drive train 2-3 times off the model's defaults) with the example of
:data:`compare.synthetic.HIDDEN_EXAMPLES` ``[effect]`` hidden in it. For each value of the effect's parameter the
example's model with the effect at that value is compared with the measurement (no calibration, no attribution):
once with the drive train as written (the defaults) and once with the rig's own drive train. Printed: the excess
error per view and in total (dB), and which value is lowest in each case. What it answers: whether the amount is
readable at the model's drive train (a minimum near the truth) or only at the rig's, i.e. whether sizing the
effect needs the drive train calibrated (docs/compare_validation.md, stop 60). Last line: JSON.
"""
from __future__ import annotations

import argparse
import json

from compare.calibration import calibrated_compare
from compare.comparison import prepare_reference
from compare.synthetic import HIDDEN_EXAMPLES, OTHER_RIGS, hidden_effect_measurement
from datagen.effects import EffectSpec


def _value(text: str):
    try:
        return float(text)
    except ValueError:
        return text


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", default="tooth_pit", choices=sorted(HIDDEN_EXAMPLES))
    ap.add_argument("--param", default=None, help="the parameter varied (default: the example's checked one)")
    ap.add_argument("--values", default="0.1,0.15,0.2,0.25,0.3,0.35", help="comma-separated values of it")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="other parameters of the effect")
    ap.add_argument("--rig", default="helical", choices=sorted(OTHER_RIGS))
    ap.add_argument("--seed", type=int, default=11, help="the rig's noise draw")
    args = ap.parse_args(argv)
    ex = HIDDEN_EXAMPLES[args.effect]
    param = args.param or (ex.check[0] if ex.check else None)
    if param is None:
        raise SystemExit(f"--param: {args.effect} has no checked parameter; name one")
    values = [float(v) for v in args.values.split(",")]
    extra = dict(kv.split("=", 1) for kv in args.set)
    extra = {k: _value(v) for k, v in extra.items()}
    base, less = OTHER_RIGS[args.rig]
    m, ex = hidden_effect_measurement(args.effect, seed=args.seed, **{**base, "snr_db": ex.snr_db - less})
    ref = prepare_reference(m)
    model = ex.model()
    out = {}
    for label, start in (("as_written", model), ("rig_drivetrain", model.with_drivetrain(base["nuisance"]))):
        rows = []
        for v in values:
            effect = EffectSpec.from_dict({"name": args.effect, **extra, param: v}).build()
            err = calibrated_compare(m, start.with_effect(effect), reference=ref, calibrate_nuisances=False).error_db
            rows.append({"value": v, **{k: round(float(x), 3) for k, x in err.items()}})
            print(f"{label:15s} {param} = {v:<8g} " + "  ".join(f"{k} {x:6.2f}" for k, x in err.items()), flush=True)
        best = min(rows, key=lambda r: r["total"])
        print(f"{label}: lowest total at {param} = {best['value']:g} ({best['total']:.2f} dB); "
              f"true {ex.effect[param]:g}")
        out[label] = {"rows": rows, "best": best["value"]}
    print(json.dumps({"effect": args.effect, "param": param, "true": ex.effect[param], "rig": args.rig,
                      "seed": args.seed, **out}))


if __name__ == "__main__":
    main()
