"""Why a speed fluctuation and a torque fluctuation tie in the comparison: their sideband asymmetry, measured.

Run: ``python experiments/twin_fluctuations.py [--hidden speed_fluctuation|torque_fluctuation] [--seed N]``
(about 2 min on 2 cores).

The hidden-effect rig of :data:`compare.synthetic.HIDDEN_EXAMPLES` with the chosen fluctuation; both twins
are fitted to it (:func:`compare.synthetic.run_hidden_case` restricted to the two candidates) and compared on
the whole record. Printed per mesh harmonic ``k``: the upper-minus-lower sideband level
``10 log10((P(k fm + f) + 4 F) / (P(k fm - f) + 4 F))`` (dB; ``P`` the power of the three bins around the line
in the pinion-angle spectrum, ``F`` the local floor, so that bins of noise only read 0 dB) of the measurement
and of each fitted twin, and the sidebands' height over the floor. A motor-side and a load-side excitation
give opposite signs to the mesh-torque (amplitude) modulation at the same pinion motion
(tests/test_dynamics_simulate.py::test_motor_side_and_load_side_fluctuations_differ_only_in_the_mesh_torque);
the asymmetry is where that sign would show. Last line: JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare.comparison import compare  # noqa: E402
from compare.spectra import angle_records, non_order, power_spectrum, smooth_floor  # noqa: E402
from compare.synthetic import HIDDEN_EXAMPLES, run_hidden_case  # noqa: E402
from datagen.effects import EffectSpec  # noqa: E402

TWINS = ("speed_fluctuation", "torque_fluctuation")
#: a sideband pair is read where both stand this far above the floor (dB)
CLEAR_DB = 25.0


def asymmetry(x: np.ndarray, ref, f_hz: float) -> np.ndarray:
    """(k, 3): upper-minus-lower sideband level (dB) and the two sidebands' heights over the floor (dB)."""
    plan = ref.plan
    rec = angle_records(x, ref.fs_hz, ref.speed.track, plan)
    p = power_spectrum(rec.pinion.ravel())
    fl = smooth_floor(p, non_order(p.size, plan))
    out = []
    for k in range(1, plan.n_harmonics + 1):
        side = []
        for s in (1, -1):
            i = int(round((k * plan.fm_hz + s * f_hz) / plan.bin_hz))
            side.append((p[i - 1:i + 2].sum(), 3 * fl[i]))
        (pu, fu), (pl, fl_) = side
        out.append((10 * np.log10((pu + 4 * fu) / (pl + 4 * fl_)), 10 * np.log10(pu / fu), 10 * np.log10(pl / fl_)))
    return np.array(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hidden", choices=TWINS, default="speed_fluctuation")
    ap.add_argument("--seed", type=int, default=3, help="the rig's noise seed")
    args = ap.parse_args(argv)
    ex, c0, a, _ = run_hidden_case(args.hidden, candidates=list(TWINS), seed=args.seed)
    ref = c0.reference
    m = ref.measurement
    f_hz = float(HIDDEN_EXAMPLES[args.hidden].effect["frequency_hz"])
    meas = asymmetry(ref.x, ref, f_hz)
    fits, errors = {}, {}
    for cand in a.candidates:
        model = ex.model().with_effect(EffectSpec.from_dict({"name": cand.effect, **cand.params}).build())
        c = compare(m, model, reference=ref)
        fits[cand.effect] = asymmetry(c.model_signal[:len(ref.x)], ref, f_hz)
        errors[cand.effect] = {"params": cand.params, "window_error_db": cand.error_db,
                               "record_error_db": c.error_db["total"]}
        print(f"{cand.effect}: fitted {cand.params}; whole-record error {c.error_db['total']:.3f} dB")
    print(f"\nhidden: {args.hidden} at {f_hz:g} Hz; upper - lower sideband (dB)")
    print(f"{'k':>3} {'measured':>9} {'heights':>9} " + " ".join(f"{e:>19}" for e in fits))
    for k in range(meas.shape[0]):
        print(f"{k + 1:>3} {meas[k, 0]:+9.2f} {meas[k, 1]:4.0f},{meas[k, 2]:<4.0f} "
              + " ".join(f"{fits[e][k, 0]:+19.2f}" for e in fits))
    clear = (meas[:, 1] > CLEAR_DB) & (meas[:, 2] > CLEAR_DB)
    summary = {e: float(np.sqrt(np.mean((meas[clear, 0] - fits[e][clear, 0]) ** 2))) for e in fits}
    print(f"\nRMS asymmetry residual over the {int(clear.sum())} harmonics whose sidebands stand > {CLEAR_DB:g} dB "
          f"above the floor: " + ", ".join(f"{e} {v:.3f} dB" for e, v in summary.items()))
    print(json.dumps({"experiment": "twin_fluctuations", "hidden": args.hidden, "seed": args.seed,
                      "harmonics_clear": [int(k) + 1 for k in np.nonzero(clear)[0]],
                      "asymmetry_rms_db": summary, "fits": errors}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
