"""How far the exact truth gets: the floor under the hidden-effect test's "error at most half".

Run: ``python experiments/halving_floor.py [NAME ...] [--torque T] [--seeds 3 4 5 6 7] [--snr-db DB]
[--reliability-db S0]``
(on 2 cores about 10 s per effect and seed; an effect that needs time stepping, e.g. backlash, about 2.5 min).

For a hidden example of :data:`compare.synthetic.HIDDEN_EXAMPLES` (its effect, optionally at another torque),
the rig is simulated with several noise seeds, and four models are compared with each record (headline
error: the excess over the noise error, :mod:`compare.error` step 7):

- ``base``: the baseline (the example's known effects, drive train at the model's defaults);
- ``base_true_nuisance``: the baseline with the rig's drive train (:data:`compare.synthetic.NUISANCE`);
- ``effect``: the baseline plus the hidden effect at its true parameters, nuisances at the defaults;
- ``truth``: the hidden effect at its true parameters *and* the rig's drive train: the rig's own model, which
  differs from the rig only by the noise draw.

``truth / base`` is the best ratio any fit can reach on that record; ``effect / base`` the best one without
a nuisance calibration. When ``truth`` itself scatters over the seeds by a sizeable fraction of ``base`` (the
effect's whole signature), the test's halving is decided by the noise draw, not by the attribution.

The last line is JSON.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare.comparison import compare, prepare_reference  # noqa: E402
from compare.synthetic import HIDDEN_EXAMPLES, NUISANCE, rig_measurement  # noqa: E402

MODELS = ("base", "base_true_nuisance", "effect", "truth")


def floor_rows(name: str, seeds, *, torque_nm: float | None = None, snr_db: float | None = None) -> list[dict]:
    """One row per seed: the excess error of each of :data:`MODELS` on that rig record."""
    from datagen.effects import build_effects

    ex = HIDDEN_EXAMPLES[name]
    if torque_nm is not None:
        ex = dataclasses.replace(ex, torque_nm=float(torque_nm))
    if snr_db is not None:
        ex = dataclasses.replace(ex, snr_db=float(snr_db))
    base = ex.model()
    with_effect = base.with_effect(build_effects((ex.effect,))[0])
    models = {"base": base, "base_true_nuisance": base.with_drivetrain(NUISANCE), "effect": with_effect,
              "truth": with_effect.with_drivetrain(NUISANCE)}
    rows = []
    for seed in seeds:
        m = rig_measurement(ex.known + (ex.effect,), speed_rpm=ex.speed_rpm, torque_nm=ex.torque_nm, seed=int(seed),
                            snr_db=ex.snr_db)
        ref = prepare_reference(m)
        row = {"effect": name, "torque_nm": ex.torque_nm, "snr_db": ex.snr_db, "seed": int(seed)}
        for key, model in models.items():
            c = compare(m, model, reference=ref)
            row[key] = c.error_db["total"]
            row["noise_error_db"] = c.noise_error_db["total"]
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=["hertz_nonlinear", "tip_relief", "pitch_error"])
    ap.add_argument("--torque", type=float, default=None, help="torque (N m) instead of the example's")
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5, 6, 7])
    ap.add_argument("--snr-db", type=float, default=None, help="rig sensor noise (default: the example's)")
    ap.add_argument("--reliability-db", type=float, default=None,
                    help="switch on the error's reliability weights with this s0 (dB; compare/error.py step 5)")
    args = ap.parse_args(argv)
    if args.reliability_db is not None:
        if not args.reliability_db > 0:
            ap.error(f"--reliability-db: {args.reliability_db} is not > 0 dB")
        import compare.error

        compare.error.MODEL_TOLERANCE_DB = float(args.reliability_db)
    for n in args.names:
        if n not in HIDDEN_EXAMPLES:
            ap.error(f"names: {n!r} is not a hidden example (one of {', '.join(sorted(HIDDEN_EXAMPLES))})")
    out = []
    print("| effect | torque (N m) | SNR (dB) | " + " | ".join(f"{k} (dB)" for k in MODELS)
          + " | truth / base, worst | effect / base, worst |")
    print("|---|---|---|" + "---|" * (len(MODELS) + 2))
    for n in args.names:
        rows = floor_rows(n, args.seeds, torque_nm=args.torque, snr_db=args.snr_db)
        cols = {k: np.array([r[k] for r in rows]) for k in MODELS}
        t_ratio = float(np.max(cols["truth"] / cols["base"]))
        e_ratio = float(np.max(cols["effect"] / cols["base"]))
        cells = " | ".join(f"{cols[k].min():.2f}-{cols[k].max():.2f}" for k in MODELS)
        print(f"| {n} | {rows[0]['torque_nm']:g} | {rows[0]['snr_db']:g} | {cells} | {t_ratio:.2f} | {e_ratio:.2f} |", flush=True)
        out.append({"effect": n, "rows": rows, "worst_truth_ratio": t_ratio, "worst_effect_ratio": e_ratio})
    print(json.dumps({"seeds": args.seeds, "results": out}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
