"""``gearpit compare``: a measurement versus the model -> error per view, disagreements, missing effects, ledger."""
from __future__ import annotations

import argparse
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("compare", help="compare a measured vibration record with the model; rank missing effects",
                       description=__doc__)
    p.add_argument("measurement", type=Path, help="CSV/TXT, NPY, NPZ, WAV or MAT file (see the README for the format)")
    p.add_argument("--meta", type=Path, help="sidecar JSON/TOML (default: <measurement stem>.toml/.json beside it)")
    p.add_argument("--model", type=Path, help="model TOML (default: <measurement stem>.model.toml; created if missing)")
    p.add_argument("--add", action="append", default=[], metavar="EFFECT[:param=value,...]",
                   help="add an effect to the model file (without values: the parameters last fitted); repeatable")
    p.add_argument("--plugin", action="append", default=[], type=str, metavar="FILE.py",
                   help="Python file registering user effects; recorded in the model; repeatable")
    p.add_argument("--refit", nargs="?", const="all", default=None, metavar="EFFECT,...",
                   help="before comparing, fit the model's effects again (all, or these), each against the model "
                        "without it; kept where the error falls, written to the model file")
    p.add_argument("--candidates", help="comma-separated effects to try (default: every registered one not in the model)")
    p.add_argument("--no-attribution", action="store_true", help="only compare; do not fit missing effects")
    p.add_argument("--calibrate", action=argparse.BooleanOptionalAction, default=None,
                   help="fit the mesh damping, bearing stiffness and bearing damping to the measurement before "
                        "the attribution; --no-calibrate: never (default: as the model's [calibration] enabled "
                        "says, else \"auto\": only when no effect explains the mismatch of the model as written)")
    p.add_argument("--report", type=Path, help="write a self-contained HTML report")
    p.add_argument("--json", type=Path, help="write the JSON document (schema gearpit.compare/2)")
    p.add_argument("--seed", type=int, default=0, help="seed of the noise matched to the measured floor")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from compare.candidates import bound_note
    from compare.path_regime import path_regime_text
    from compare.response import response_text
    from compare.chaos import describe_interval, drivetrains_message
    from compare.ledger import history_table
    from compare.report import gain_text
    from compare.workflow import run as run_loop

    cands = [c.strip() for c in args.candidates.split(",") if c.strip()] if args.candidates else None
    out = run_loop(args.measurement, meta=args.meta, model_path=args.model, add=args.add, plugins=args.plugin,
                   attribution=not args.no_attribution, candidates=cands, report=args.report, json_path=args.json,
                   seed=args.seed, calibrate=args.calibrate,
                   refit=None if args.refit is None else
                   (True if args.refit == "all" else [r.strip() for r in args.refit.split(",") if r.strip()]))
    c = out.comparison
    for msg in out.messages:
        print(msg)
    ref = c.reference
    print(f"speed {ref.speed.speed_rpm:.3f} rpm ({ref.speed.method}), "
          + gain_text(ref.measurement, c.evaluation.residuals.gain_db))
    print("error (dB): " + ", ".join(f"{k} {v:.2f}" for k, v in c.error_db.items()))
    if c.disagreements:
        print("largest disagreements:")
        for d in c.disagreements[:10]:
            print(f"  {d.text}")
    if out.attribution is not None:
        print("candidate effects (error reduction, fitted parameters +/- 1 sigma):")
        for cand in out.attribution.candidates:
            ps = ", ".join((f"{k}={v:.4g}" + describe_interval(cand.interval[k]) if k in cand.interval else
                            (f"{k}={v:.4g} +/- {cand.sigma[k]:.2g}" if k in cand.sigma else f"{k}={v}"))
                           + bound_note(k, cand.at_bound, cand.pinned)
                           for k, v in cand.params.items())
            res = out.attribution.resolution
            settled = res is not None and res.get("claimed") == cand.effect and res.get("before") != cand.effect
            mark = ("  <- claimed" + (" (on the further channels)" if settled else "")) if cand.claimed else ""
            print(f"  {cand.effect:20s} {100 * cand.reduction:6.1f} %  {ps}{mark}")
            if cand.response:
                print(f"  {'':20s} {'':8s} {response_text(cand.response, cand.effect)}")
            if path_regime_text(cand.path_regime):
                print(f"  {'':20s} {'':8s} {path_regime_text(cand.path_regime)}")
            if cand.drivetrain_intervals:
                print(f"  {'':20s} {'':8s} {drivetrains_message(cand.effect, cand.drivetrain_intervals)}")
        for u in out.attribution.unexplained:
            print(f"  unexplained by every registered effect: {u['text']}")
    print("ledger:")
    print(history_table(out.ledger))
    return 0
