"""Is a time-stepped record converged in its time step, as the comparison reads it?

For each case a 'measurement' is made at a fine step (``omega_max dt`` = :data:`REFERENCE_OMEGA_DT`, 30 dB
white sensor noise) and the same case simulated again, without noise, at each step of :data:`OMEGA_DTS`; the
comparison's total error (``compare.comparison.evaluate``, raw ``E`` in dB, sensor gain fitted) between the
two is printed beside the yardstick of the noise alone: the fine record with another noise draw. A step whose
error sits at that yardstick gives the comparison the same record as a fine one; a step far above it puts a
numerical error into every fit made at it.

Source of truth: the integrator itself at a 12x finer step (no outside reference: these records are nonlinear).
Cases: linear and nonlinear mesh laws (backlash, Hertz) on the spur and the helical preset, light loads where
the teeth lose contact, the drive trains of ``compare.synthetic``. Run: ``python experiments/step_convergence.py``
(about 5 min on 2 cores for the nine cases); the last line is JSON.

Measured at stop 49 (the step the attribution searches at is 0.5, ``AttributionSettings.search_solver``; the
default is 0.3): linear and spur records are converged at 0.5; the helical pair with backlash at 2 N m (its pairs
part at their contact edges every cycle) is not: 5.9-6.3 dB at 0.3 against a noise yardstick of 0.6-0.8 dB at 600
and 1500 rpm, converged only at 0.05, and the linear helical record was 1.68 / 3.45 dB off at 0.3 / 0.15.
Re-measured at stop 51, with the record read as its mean over each step (``MeshRecords.window_all_at``): the linear
helical record 0.81 dB at every step (yardstick 0.71); the backlash rows converge monotonically, 5.8 / 3.4 / 1.6 /
0.6 dB at 0.3 / 0.15 / 0.1 / 0.05 (600 rpm), still only at 0.05.
Stop 53: the spur pair with backlash at 5 N m is not converged at 0.3 either (1.87 dB against 0.57; 0.50 at 0.05),
the helical pair with the Hertz law at 2 N m is (0.68 against 0.82), and with backlash at 20 N m, where no pair
parts, it is within 0.3 dB of its 0.05 value at every step. So backlash declares the step it needs
(``Backlash.max_omega_dt = 0.05``): a case that leaves ``[solver] omega_dt`` unset is stepped there
(``SolverOptions.step_for``); the rows here set the step explicitly, as the attribution's search does.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare.comparison import evaluate, prepare_reference  # noqa: E402
from compare.measurement import measurement_from_arrays  # noqa: E402
from compare.sidecar import Sidecar  # noqa: E402
from compare.synthetic import NUISANCE, OTHER_RIGS  # noqa: E402
from datagen.case_options import SolverOptions  # noqa: E402
from datagen.geometry import preset  # noqa: E402
from datagen.lumped_model import DriveTrain  # noqa: E402
from datagen.simulate import Case, OperatingPoint, simulate  # noqa: E402

REFERENCE_OMEGA_DT = 0.025
OMEGA_DTS = (0.5, 0.3, 0.15, 0.1, 0.05)
FS_HZ = 20000.0
DURATION_S = 2.0
SNR_DB = 30.0
SENSOR = "acc_pinion_loa_m_s2"

_PE = {"name": "profile_error", "grade": 9.0}
_PITCH = {"name": "pitch_error", "grade": 8.0}
_BL = {"name": "backlash", "backlash_m": 30e-6}
_HELICAL = OTHER_RIGS["helical"][0]["nuisance"]
#: name -> (pair, speed_rpm, torque_nm, drive-train fields, effects)
CASES = {
    "spur, linear, 50 N m": ("spur-gds", 1000.0, 50.0, NUISANCE, (_PE, _PITCH)),
    "spur, Hertz, 5 N m": ("spur-gds", 1000.0, 5.0, NUISANCE, (_PITCH, {"name": "hertz_nonlinear"})),
    "helical, linear, 2 N m": ("helical-dct", 1500.0, 2.0, _HELICAL, (_PE,)),
    "helical, backlash, 2 N m, 600 rpm": ("helical-dct", 600.0, 2.0, _HELICAL, (_PE, _BL)),
    "helical, backlash, 2 N m, 1500 rpm": ("helical-dct", 1500.0, 2.0, _HELICAL, (_PE, _BL)),
    "helical, backlash, 2 N m, 3000 rpm": ("helical-dct", 3000.0, 2.0, _HELICAL, (_PE, _BL)),
    "spur, backlash, 5 N m": ("spur-gds", 1000.0, 5.0, NUISANCE, (_PE, _BL)),
    "helical, Hertz, 2 N m": ("helical-dct", 1500.0, 2.0, _HELICAL, (_PE, {"name": "hertz_nonlinear"})),
    "helical, backlash, 20 N m": ("helical-dct", 1500.0, 20.0, _HELICAL, (_PE, _BL)),
}


def _record(pair, speed_rpm, torque_nm, drivetrain, effects, omega_dt, *, duration_s, seed, noise_db=None):
    effs = tuple(effects) + (({"name": "noise", "snr_db": noise_db},) if noise_db is not None else ())
    (s,) = simulate([Case(preset(pair), OperatingPoint(speed_rpm, torque_nm), duration_s=duration_s, fs_hz=FS_HZ,
                          seed=seed, drivetrain=DriveTrain(**drivetrain), effects=effs,
                          solver=SolverOptions(omega_dt=omega_dt, method="transient"))])
    return s


def case_row(name: str, omega_dts=OMEGA_DTS) -> dict:
    pair, speed, torque, dt, effects = CASES[name]
    t0 = time.perf_counter()
    meas = _record(pair, speed, torque, dt, effects, REFERENCE_OMEGA_DT, duration_s=DURATION_S, seed=3,
                   noise_db=SNR_DB)
    sc = Sidecar(pair=preset(pair), speed_rpm=speed, torque_nm=torque, fs_hz=FS_HZ, sensor="acc", tacho="tacho")
    ref = prepare_reference(measurement_from_arrays({"acc": meas.channels[SENSOR], "tacho": meas.channels["tacho_pinion"]},
                                                    sc, source="fine step"))
    dur = ref.model_duration_s()
    other = _record(pair, speed, torque, dt, effects, REFERENCE_OMEGA_DT, duration_s=dur, seed=4, noise_db=SNR_DB)
    yard = evaluate(ref, other.channels[SENSOR], FS_HZ, seed=0).residuals.total_db
    errors = {}
    for od in omega_dts:
        y = _record(pair, speed, torque, dt, effects, od, duration_s=dur, seed=0).channels[SENSOR]
        errors[od] = evaluate(ref, y, FS_HZ, seed=0).residuals.total_db
    return {"case": name, "noise_yardstick_db": yard, "error_db": errors, "seconds": time.perf_counter() - t0}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=sorted(CASES), default=None, help="these cases only")
    args = ap.parse_args(argv)
    names = args.only or list(CASES)
    print(f"| case | noise yardstick (dB) | " + " | ".join(f"omega_dt {od}" for od in OMEGA_DTS) + " |")
    print("|---|---|" + "---|" * len(OMEGA_DTS))
    rows = []
    for name in names:
        r = case_row(name)
        rows.append(r)
        print(f"| {name} | {r['noise_yardstick_db']:.2f} | " + " | ".join(f"{r['error_db'][od]:.2f}" for od in OMEGA_DTS)
              + " |", flush=True)
    out = {"reference_omega_dt": REFERENCE_OMEGA_DT, "rows": [{**r, "error_db": {str(k): v for k, v in r["error_db"].items()}}
                                                               for r in rows]}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
