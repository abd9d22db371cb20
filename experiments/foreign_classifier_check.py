"""The classifiers on records from another simulator: does a CNN trained on gearpit's data recognise pitting there?

Run: ``python experiments/foreign_classifier_check.py [--records N] [--seed S] [--train SWEEP ...]``. The last
line is JSON.

``experiments/eval_protocol.py`` tests every classifier on records of gearpit's own simulator (other speeds,
loads, sensor paths, but the same physics). Here the test records come from ``tests/foreign_rig.py``, an
independent textbook simulator (ISO 6336 pair stiffness, a 3-DOF line-of-action model, RK4; its docstring lists
what differs). Its pit is the textbook one (Chaari et al. 2009): a pitted tooth loses the fraction ``w`` of its
pair stiffness (the pitted share of the contact line) while the contact is in the pitted band ``[u0, u1]`` of
the path; the pitted area of the flank is ``w (u1 - u0)``. The records are labelled like the default dataset
(``experiments/models_sweeps/default.toml``): severity = pitted area of the worst tooth in the bands minor
3-6 %, moderate 10-14 %, severe 20-28 %; 1, 2 or 3-4 pitted pinion teeth; 600-1800 rpm, 20-80 N m; a housing
mode at 2-5 kHz, SNR 20-40 dB, a small random-walk pitch error; 1 s at 12.8 kHz, the accelerometer at the
pinion bearing. They are written as measurement files (NPZ + JSON sidecar + ``labels.csv``, the format
``gearpit evaluate`` reads) and read back through :func:`models.sources.load_measurements`, i.e. the user's path,
speed measured from the tachometer.

The CNN is the protocol's chosen variant (``tsa_op``), the best baseline beside it, trained on the in-domain
training split (70 %, the protocol's seed) of each training sweep: ``default`` (what every protocol uses) and
``default_pitch`` (the same plus random single pitch deviations, ``datagen/effects/pitch_error.py``). Each is tested
on its own held-out 30 % (in-domain) and on the foreign records twice: as drawn (each with a random-walk pitch
error of 5-15 um, like any real gear) and the same draws without it. Printed: severity / teeth accuracy, and
the novelty warning of each model (:mod:`models.novelty`): the share of records it flags as unlike the training
records, and the severity accuracy on the flagged and on the other records.

Run: about 25 min on 2 cores (two datasets of 1200 records generated once, 4 min; two CNN trainings; feature
tables).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "experiments"))

from foreign_rig import ForeignRig, simulate_foreign  # noqa: E402

OUT = ROOT / "experiments" / "out" / "models" / "foreign"
#: severity bands of the default dataset (area of the worst tooth) and its teeth classes
BANDS = {"minor": (0.03, 0.06), "moderate": (0.10, 0.14), "severe": (0.20, 0.28)}
TEETH = {"1": (1, 1), "2": (2, 2), "3+": (3, 4)}


def draw_record(rng: np.random.Generator, severity_class: str, teeth_class: str, seed: int,
                pitch: bool = True) -> tuple[ForeignRig, dict]:
    """One foreign record's rig and its labels."""
    pits, areas = {}, []
    if severity_class != "healthy":
        lo_n, hi_n = TEETH[teeth_class]
        n = int(rng.integers(lo_n, hi_n + 1))
        teeth = rng.choice(29, size=n, replace=False)
        lo, hi = BANDS[severity_class]
        worst = rng.uniform(lo, hi)
        for i, t in enumerate(teeth):
            area = worst if i == 0 else rng.uniform(lo, worst)
            w = rng.uniform(0.3, 0.7)                   # pitted share of the face width
            du = min(area / w, 0.8)
            w = area / du
            u0 = rng.uniform(0.1, 0.9 - du) if du < 0.8 else 0.1
            pits[int(t)] = (w, u0, u0 + du)
            areas.append(area)
    rig = ForeignRig(
        speed_rpm=rng.uniform(600, 1800), torque_nm=rng.uniform(20, 80), fs_hz=12800.0, duration_s=1.0,
        settle_s=0.3, gain=1.0, snr_db=rng.uniform(20, 40), seed=seed,
        housing=(rng.uniform(2000, 5000), rng.uniform(0.03, 0.08)), pitch_fp_m=rng.uniform(5e-6, 15e-6) * pitch,
        mesh_damping_ratio=rng.uniform(0.03, 0.08), bearing_n_per_m=rng.uniform(1e8, 3e8), pits=pits)
    labels = {"severity_class": severity_class, "severity": max(areas) if areas else 0.0,
              "n_pitted_teeth": len(pits)}
    return rig, labels


def write_folder(folder: Path, n_per_cell: int, seed: int, pitch: bool = True, references: bool = False) -> Path:
    """Healthy + every (severity, teeth) cell, ``n_per_cell`` records each, as measurement files; with
    ``references``, each record's healthy twin (the same rig without pits, other noise) in ``references/``, named
    by the record's sidecar key ``reference`` (experiments/reference_check.py). The same draws either way."""
    import dataclasses

    import pandas as pd

    folder.mkdir(parents=True, exist_ok=True)
    if references:
        (folder / "references").mkdir(exist_ok=True)
    rng = np.random.default_rng(seed)
    cells = [("healthy", "0")] * 3 + [(s, t) for s in BANDS for t in TEETH]
    rows = []
    k = 0
    for s, t in cells:
        for _ in range(n_per_cell):
            name = f"foreign_{k:04d}.npz"
            rig, labels = draw_record(rng, s, t, seed * 100000 + k, pitch)
            if not (folder / name).is_file():
                todo = [(folder / name, rig, {"reference": f"references/{name}"} if references else {})]
                if references:   # the twin first: the record's file is the commit mark of both
                    twin = dataclasses.replace(rig, pits={}, noise_seed=rig.seed + 7919)
                    todo.insert(0, (folder / "references" / name, twin, {}))
                for where, r, extra in todo:
                    out = simulate_foreign(r)
                    meta = {"pair": "spur-gds", "speed_rpm": r.speed_rpm, "torque_nm": r.torque_nm,
                            "fs_hz": r.fs_hz, "sensor": "acc", "tacho": "tacho", **extra}
                    (where.parent / (where.stem + ".json")).write_text(json.dumps(meta))
                    tmp = where.parent / (where.name + ".tmp.npz")
                    np.savez(tmp, acc=out["acc"].astype(np.float32), tacho=out["tacho"].astype(np.float32))
                    tmp.rename(where)
            rows.append({"file": name, **labels})
            k += 1
    pd.DataFrame(rows).to_csv(folder / "labels.csv", index=False)
    return folder


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--records", type=int, default=8, help="records per cell (12 cells)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--train", nargs="+", default=["default", "default_pitch"],
                    help="training sweeps (experiments/models_sweeps/NAME.toml + NAME_healthy.toml)")
    ap.add_argument("--no-baselines", action="store_true")
    args = ap.parse_args(argv)
    from classifier_runs import OUT as DATA_OUT, SEED, baseline_runs, cnn_run, dataset, features, log, strata
    from models.baselines import feature_table
    from models.sources import load_measurements, measurement_files
    from models.train import stratified_split

    t0 = time.perf_counter()
    folder = write_folder(OUT / f"records_seed{args.seed}", args.records, args.seed)
    plain = write_folder(OUT / f"records_seed{args.seed}_no_pitch_error", args.records, args.seed, pitch=False)
    log(f"foreign records: {folder}, {plain} ({time.perf_counter() - t0:.0f} s)")
    foreign = {"foreign": load_measurements(measurement_files(folder)),
               "foreign_no_pitch_error": load_measurements(measurement_files(plain))}
    res = {"n_foreign": len(foreign["foreign"]), "runs": {}}
    for name in args.train:
        data = dataset(name, DATA_OUT / "data")
        tr, te = stratified_split(strata(data), 0.3, SEED)         # the protocol's in-domain split
        train, tests = data.subset(tr), {"in_domain": data.subset(te), **foreign}
        where = OUT / f"runs_seed{args.seed}" / name
        run = {"n_train": int(tr.size), "cnn": cnn_run(train, tests, "tsa_op", where / "cnn_tsa_op")}
        if not args.no_baselines:
            x, names, cfg = features(name, data, 2)
            tx = {"in_domain": (tests["in_domain"], x[te]),
                  **{k: (v, feature_table(v, cfg, n_jobs=2)[0]) for k, v in foreign.items()}}
            run["baselines"] = baseline_runs(train, x[tr], tx, names, cfg, where)
        res["runs"][name] = run
    print("| trained on | model | in-domain | foreign | foreign, no pitch deviations |")
    print("|---|---|---|---|---|")
    flagged_rows = []
    for name, run in res["runs"].items():
        rows = [("CNN tsa_op", run["cnn"])]
        if "baselines" in run:
            rows.append((f"{run['baselines']['best']} (best baseline)", run["baselines"][run["baselines"]["best"]]))
        for label, r in rows:
            cells = [f"{100 * r[k]['accuracy']:.1f} / {100 * r[k]['teeth_accuracy']:.1f}"
                     for k in ("in_domain", "foreign", "foreign_no_pitch_error")]
            print(f"| {name} | {label} | " + " | ".join(cells) + " |")
            flagged_rows.append((name, label, r))
    # the novelty warning (models/novelty.py): share of records flagged, severity accuracy on flagged / others
    print("\n| trained on | model | " + " | ".join(f"{k}: flagged, acc. flagged / not" for k in
                                                 ("in-domain", "foreign", "foreign, no pitch deviations")) + " |")
    print("|---|---|---|---|---|")
    for name, label, r in flagged_rows:
        cells = []
        for k in ("in_domain", "foreign", "foreign_no_pitch_error"):
            nv = r[k].get("novelty")
            if nv is None:
                cells.append("-")
                continue
            acc = [("-" if v is None else f"{100 * v:.0f}") for v in (nv["accuracy_flagged"], nv["accuracy_not_flagged"])]
            cells.append(f"{100 * nv['flagged_fraction']:.1f} %, {acc[0]} / {acc[1]} %")
        print(f"| {name} | {label} | " + " | ".join(cells) + " |")
    print(json.dumps(res, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
