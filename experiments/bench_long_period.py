"""Benchmark: time-stepped cases whose mesh record repeats only over a long hunting period.

    python experiments/bench_long_period.py [--cases N]

The cases are those of a comparison's window fit on the far helical rig of
:data:`compare.synthetic.OTHER_RIGS` (``experiments/generalisation_check.py --only tip_relief``): the pair
``helical-dct`` (17/60 teeth) at 1500 rpm, 50 N m, 20 kHz, a grade-7 pinion pitch error in the model and a wheel
eccentricity as the candidate (amplitudes 10-80 um), so the record repeats only over the hunting period (1020 mesh
cycles, 2.4 s); time-stepped as the attribution's window fits are (``AttributionSettings.search_solver``: 0.5 s
after a 0.15 s start-up). Ours: :func:`datagen.simulate.simulate` with each case's mesh record holding only the
cycles it rolls through (:func:`datagen.batch_solve.cycles_rolled`, :func:`datagen.mesh_excitation.mesh_record`).
Reference, measured in the same run: the same call with the whole record (``cycles_rolled`` switched off), the
behaviour before stop 59. Also printed: how far the two runs' pinion accelerations differ (RMS of the difference
over the RMS). Last line: JSON.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

import datagen.batch_solve as batch_solve
from datagen.case_options import SolverOptions
from datagen.effects import EffectSpec
from datagen.geometry import preset
from datagen.simulate import Case, OperatingPoint, simulate

RPM, TORQUE_NM, FS_HZ, DURATION_S, START_S = 1500.0, 50.0, 20000.0, 0.5, 0.15


def cases(n: int) -> list:
    pair = preset("helical-dct")
    out = []
    for a in np.linspace(10e-6, 80e-6, n):
        fx = tuple(EffectSpec.from_dict(d).build() for d in ({"name": "pitch_error", "grade": 7.0},
                                                              {"name": "eccentricity_wheel", "amplitude_m": float(a)}))
        out.append(Case(pair=pair, operating=OperatingPoint(RPM, TORQUE_NM), duration_s=DURATION_S, fs_hz=FS_HZ,
                        effects=fx, solver=SolverOptions(method="transient", transient_s=START_S, omega_dt=0.5)))
    return out


def run(batch, whole: bool):
    real = batch_solve.cycles_rolled
    if whole:
        batch_solve.cycles_rolled = lambda case, ctx=None: None
    try:
        t0 = time.perf_counter()
        out = simulate(batch, channels=["acc_pinion_loa_m_s2"])
        return out, time.perf_counter() - t0
    finally:
        batch_solve.cycles_rolled = real


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=4, help="cases in the batch")
    args = ap.parse_args(argv)
    batch = cases(args.cases)
    run(batch[:1], False)                      # warm-up: compiled loops, the stiffness cache
    ours, t_ours = run(batch, False)
    ref, t_ref = run(batch, True)
    diffs = []
    for a, b in zip(ours, ref):
        x, y = a.channels["acc_pinion_loa_m_s2"], b.channels["acc_pinion_loa_m_s2"]
        diffs.append(float(np.sqrt(np.mean((x - y) ** 2)) / np.sqrt(np.mean((y - y.mean()) ** 2))))
    meta = ours[0].metadata["solver"]
    print(f"{args.cases} cases, record {meta['record_cycles']} of {meta['period_cycles']} cycles: "
          f"{t_ours:.2f} s ({t_ours / args.cases:.2f} s a case); whole record (reference): {t_ref:.2f} s "
          f"({t_ref / args.cases:.2f} s a case); ratio {t_ref / t_ours:.2f}; "
          f"pinion acceleration differs by at most {max(diffs):.1e} of its RMS")
    print(json.dumps({"benchmark": "long_period_time_stepped", "cases": args.cases,
                      "record_cycles": meta["record_cycles"], "period_cycles": meta["period_cycles"],
                      "seconds": round(t_ours, 3), "reference_whole_record_s": round(t_ref, 3),
                      "speedup": round(t_ref / t_ours, 2), "max_relative_rms_difference": max(diffs)}))


if __name__ == "__main__":
    main()
