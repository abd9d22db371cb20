"""The user's loop on a rig with TWO effects the model lacks: compare, add the claimed effect, compare again.

Run: ``python experiments/two_hidden_effects.py [EFFECT EFFECT] [--seed N] [--steps K]`` (default: the pitch error
of grade 8 and the 3 kHz housing mode of :data:`compare.synthetic.HIDDEN_EXAMPLES`, on the examples' rig; about
5 min on 2 idle cores: the third comparison escalates to the calibrated pass). The last line is JSON.

Why: a real gearbox always lacks more than one effect in a first model. The hidden-effect tests put one effect
at a time in the rig; here two are on together, with the nuisances of :data:`compare.synthetic.NUISANCE`, and
the loop is the one ``gearpit compare --add`` runs: each step compares and attributes with the default
calibration ("auto", :mod:`compare.escalation`), adds the claimed effect with its fitted parameters (and the
nuisances it was fitted with, when the step was calibrated), and compares again, until nothing is claimed or
``--steps`` comparisons were made. Printed per step: the model, its error (excess over the noise error, dB),
whether the step escalated, the four best candidates; at the end each hidden effect's fitted parameter against
the truth (the examples' tolerances).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare.synthetic import HIDDEN_EXAMPLES, hidden_effects_loop  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("effects", nargs="*", default=["pitch_error", "transmission_path"],
                    help="two hidden effects (names of compare.synthetic.HIDDEN_EXAMPLES)")
    ap.add_argument("--seed", type=int, default=3, help="the rig's noise draw")
    ap.add_argument("--steps", type=int, default=3, help="comparisons at most")
    args = ap.parse_args(argv)
    for n in args.effects:
        if n not in HIDDEN_EXAMPLES:
            ap.error(f"effects: {n!r} is not one of {', '.join(HIDDEN_EXAMPLES)}")
    out = hidden_effects_loop(args.effects, seed=args.seed, steps=args.steps, log=lambda s: print(s, flush=True))
    print(json.dumps(out, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
