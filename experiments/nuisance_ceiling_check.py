"""Which nuisance holds the accelerometer's severity accuracy near 82 %? The in-domain protocol's ``tsa_op`` CNN on
the default dataset made again with the nuisances taken away one group at a time.

experiments/RESULTS.md ("What limits the severity accuracy", "A healthy reference at a second load") reads the
ceiling two ways: the pit's size reaches the sensor through an unknown housing path and beside a profile error of
random size and phase (a *scale* problem), and the low orders that carry the pit's area sit under the sensor noise
(a *noise* problem). Neither reading was tested by removing the nuisance itself. This script regenerates
``experiments/models_sweeps/default*.toml`` with some draws narrowed (``VARIANTS``), splits each dataset as the
protocol does (70/30, stratified, split seed 0), trains ``tsa_op`` (training seed 0) and prints the held-out
severity and teeth accuracy beside the protocol's figure.

A narrowed draw keeps a range (``[60, 80]`` dB, ``[3200, 3200.001]`` Hz), never a single value: a range draws one
number per record as the protocol's does, so every other parameter of every record (pit, speed, load, the other
nuisances) is the protocol's draw; a single value would draw nothing and shift every later draw. Only the
accelerometer is stored.

Run: ``python experiments/nuisance_ceiling_check.py [--only VARIANT ...]`` (generation 1.5-3 min with 2 workers,
each CNN 4-6 min on an idle core). The last line is JSON. Datasets and reports go under
``experiments/out/models/nuisance_ceiling/``.
"""
from __future__ import annotations

import argparse
import copy
import functools
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import classifier_runs as cr  # noqa: E402  (experiments/classifier_runs.py)

OUT = ROOT / "experiments" / "out" / "models" / "nuisance_ceiling"

_QUIET = {("effects", "noise", "snr_db"): [60.0, 80.0]}
_ONE_PATH = {("effects", "transmission_path", "housing_frequency_hz"): [3200.0, 3200.001],
             ("effects", "transmission_path", "housing_damping_ratio"): [0.05, 0.050001]}
_ONE_GEAR = {("effects", "profile_error", "grade"): [4.0, 4.0001],
             ("effects", "profile_error", "phase_rad"): [0.5, 0.5001],
             ("effects", "pitch_error", "grade"): [4.0, 4.0001],
             ("drive_train", "mesh_damping_ratio"): [0.06, 0.060001]}
#: variant -> the narrowed draws (path in the sweep document -> new range)
VARIANTS = {
    "protocol": {},                                    # the protocol's draws: the figure of this run to read against
    "quiet": _QUIET,                                   # sensor noise 60-80 dB below the signal (protocol: 20-40)
    "one_path": _ONE_PATH,                             # one housing mode, 3.2 kHz, 5 % (protocol: 2-5 kHz, 3-8 %)
    "quiet_one_rig": {**_QUIET, **_ONE_PATH, **_ONE_GEAR},   # and one gear's errors and mesh damping
    "quiet_one_path": {**_QUIET, **_ONE_PATH},
    "quiet_one_rig_x2": {**_QUIET, **_ONE_PATH, **_ONE_GEAR},   # the same, twice the records (RECORDS)
}
#: variant -> factor on the records of each class (and of the healthy sweep): a point of the learning curve
RECORDS = {"quiet_one_rig_x2": 2}


def cnn_variants() -> dict:
    """The protocol's ``tsa_op`` and the integrated TSA inputs tried beside it (``RepresentationSpec.integrate``:
    the accelerometer's TSA integrated twice over the angle, the mesh force it hears below the structural modes;
    ``lp2``: only shaft orders below two mesh orders kept)."""
    from models.representation_spec import RepresentationSpec

    tsa = dict(kind="tsa", n_revs=8, samples_per_rev=1024)
    return {"tsa_op": cr.VARIANTS["tsa_op"], "tsa_level": cr.VARIANTS["tsa_level"],
            "tsa_int2_op": (RepresentationSpec(**tsa, integrate=2), cr.OPERATING),
            "tsa_int2_lp2_op": (RepresentationSpec(**tsa, integrate=2, lowpass_mesh_orders=2.0), cr.OPERATING)}


def narrowed(doc: dict, changes: dict) -> dict:
    """A copy of the sweep document ``doc`` with each ``changes`` path set to its new range; a path the sweep does
    not have is an error (a renamed field would otherwise leave the nuisance in silently)."""
    from gearpit.errors import require

    out = copy.deepcopy(doc)
    for path, value in changes.items():
        table = out
        for key in path[:-1]:
            require(isinstance(table.get(key), dict), ".".join(path), "missing", "a table of the sweep file")
            table = table[key]
        require(path[-1] in table, ".".join(path), "missing", "a field of the sweep file")
        require(isinstance(value, list) and len(value) == 2 and value[1] > value[0], ".".join(path), value,
                "a range [lo, hi] with hi > lo (one draw per record, as the protocol's)")
        table[path[-1]] = list(value)
    return out


def variant_doc(name: str, doc: dict) -> dict:
    """The sweep document ``doc`` as variant ``name`` makes it: its draws narrowed (:data:`VARIANTS`) and its
    records per class multiplied (:data:`RECORDS`)."""
    doc = narrowed(doc, VARIANTS[name])
    return {**doc, "sweep": dict(doc["sweep"], samples_per_class=doc["sweep"]["samples_per_class"] * RECORDS.get(name, 1))}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=sorted(VARIANTS), default=None, help="these variants only")
    ap.add_argument("--cnn", nargs="+", default=["tsa_op"], choices=sorted(cnn_variants()),
                    help="CNN variants trained on each dataset")
    ap.add_argument("--training-seed", type=int, default=0, help="the CNN's training seed (the protocol's: 0)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)

    names = args.only or list(VARIANTS)
    cr.OUT = OUT
    rows = {}
    for name in names:
        edit = functools.partial(variant_doc, name)
        train, test = cr.edited_default_split(OUT / name, edit, args.workers, name)
        for cnn in args.cnn:
            run = cnn if args.training_seed == 0 else f"{cnn}_seed{args.training_seed}"
            r = cr.cnn_run(train, {"test": test}, cnn, OUT / name / run, variants=cnn_variants(),
                           seed=args.training_seed)
            rows[f"{name}/{run}"] = {
                "dataset": name, "cnn": cnn, "training_seed": args.training_seed,
                "severity_accuracy": r["test"]["accuracy"],
                "teeth_accuracy": r["test"]["teeth_accuracy"], "severity_mae": r["test"]["severity_mae"],
                "epochs": r["epochs"], "train_seconds": r["train_seconds"], "n_train": len(train), "n_test": len(test)}
            cr.log(f"{name}, {cnn}: severity {100 * r['test']['accuracy']:.1f} %, "
                   f"teeth {100 * r['test']['teeth_accuracy']:.1f} %")
    print("\n| dataset | narrowed draws | CNN | training seed | severity acc. % | teeth acc. % | epochs | training (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows.values():
        what = ", ".join(".".join(p[1:]) for p in VARIANTS[r["dataset"]]) or "none"
        print(f"| {r['dataset']} | {what} | {r['cnn']} | {r['training_seed']} | {100 * r['severity_accuracy']:.1f} | "
              f"{100 * r['teeth_accuracy']:.1f} | {r['epochs']} | {r['train_seconds']:.0f} |")
    out = {"variants": {n: {".".join(p): v for p, v in VARIANTS[n].items()} for n in names}, "runs": rows}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
