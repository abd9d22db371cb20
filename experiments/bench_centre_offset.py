"""Benchmark: the moving-centre stiffness record of a helical pair (hook 2c), compiled against the numpy rules.

    python experiments/bench_centre_offset.py [--cycles N]

The record is the one a comparison on the far helical rig of :data:`compare.synthetic.OTHER_RIGS` builds for a
wheel-eccentricity candidate (``experiments/bench_long_period.py``'s case: ``helical-dct``, 17/60 teeth, 1500 rpm,
a grade-7 pinion pitch error in the model, a 40 um wheel eccentricity): :func:`datagen.simulate.simulate` builds
it once, and the inputs of its :func:`datagen.centre_offset.slots_at_centre_offset` call (stiffness record,
centre displacements, held cycles) are timed again, by default on the whole hunting period (1020 cycles, as the
whole-record confirmation of a long-period candidate reads it; ``--cycles 311``: the cycles a 0.5 s window fit
rolls through). Ours: ``COMPILED = True`` (:mod:`datagen.compiled_centre`). Reference, measured in the same run:
the numpy rules (``COMPILED = False``), the code before stop 60. Also printed: the largest difference of the two
records over their largest value. Last line: JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import datagen.centre_offset as co
import datagen.mesh_excitation as mx
from datagen.simulate import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_long_period import cases  # noqa: E402


def timed(args: tuple, compiled: bool, repeats: int) -> tuple[np.ndarray, float]:
    stiffness, q, dx, dy, cycles = args
    old = co.COMPILED
    co.COMPILED = compiled
    try:
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            out = co.slots_at_centre_offset(stiffness, dx, dy, subdivisions=q, cycles=cycles)
            best = min(best, time.perf_counter() - t0)
        return out, best
    finally:
        co.COMPILED = old


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cycles", type=int, default=0, help="mesh cycles of the record (default: the whole period)")
    ap.add_argument("--repeats", type=int, default=2, help="timed runs of each (the best is printed)")
    args = ap.parse_args(argv)
    case = cases(4)[1]
    if not args.cycles:
        from dataclasses import replace

        from datagen.case_options import SolverOptions
        case = replace(case, solver=SolverOptions(method="transient", omega_dt=0.5))      # no start-up: whole record
    simulate([case], channels=["acc_pinion_loa_m_s2"])
    stiffness, q, dx, dy, _, cycles = mx._LAST_SLOTS
    ppc = stiffness.positions_per_cycle
    n = dx.size // (ppc * q)
    if args.cycles:
        if args.cycles > n:
            raise SystemExit(f"--cycles: {args.cycles}, the case's record holds {n}")
        n = args.cycles
        dx, dy = dx[:n * ppc * q], dy[:n * ppc * q]
        cycles = np.arange(n) if cycles is None else cycles[:n]
    inputs = (stiffness, q, np.array(dx), np.array(dy), cycles)
    timed(inputs, True, 1)                         # compile (cached on disk after the first run)
    ours, t_ours = timed(inputs, True, args.repeats)
    ref, t_ref = timed(inputs, False, args.repeats)
    diff = float(np.abs(ours - ref).max() / np.abs(ref).max())
    print(f"helical-dct wheel eccentricity, {n} mesh cycles x {ppc} positions x {q} points, {stiffness.n_slices} "
          f"slices: compiled {t_ours:.3f} s, numpy rules (reference) {t_ref:.3f} s, ratio {t_ref / t_ours:.2f}; "
          f"records differ by {diff:.1e} of the largest value")
    print(json.dumps({"benchmark": "centre_offset_record", "cycles": n, "positions_per_cycle": ppc,
                      "subdivisions": q, "slices": stiffness.n_slices, "seconds": round(t_ours, 3),
                      "reference_numpy_s": round(t_ref, 3), "speedup": round(t_ref / t_ours, 2),
                      "max_relative_difference": diff}))


if __name__ == "__main__":
    main()
