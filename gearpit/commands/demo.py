"""``gearpit demo``: the main job end to end on a small embedded default (no downloads).

Stages (each writes into its own folder under ``--out``):

1. ``stiffness``: healthy and pitted mesh stiffness of both preset pairs (CSV, PNG, JSON).
2. ``simulate``: a healthy and a pitted simulation of each preset pair (CSV, NPZ, JSON, PNG).
3. ``dataset``: a tiny labelled dataset from the embedded demo sweep (Parquet index + .npy shards).
4. ``features``: the feature table (incl. HHT) of the demo dataset and the ranking of every feature.
5. ``models``: the CNN trained on a small dataset of the demo sweep's classes and evaluated on held-out records.
6. ``compare``: one full model-vs-measurement loop on a "measurement" simulated with a hidden pitch error and
   nuisance physics unlike the model's: compare, rank the candidate effects (calibrating the model's drive-train
   nuisances only if no effect explains the mismatch as written: compare.escalation), add the claimed one,
   compare again.

Later stages are appended to :data:`STAGES` as the pipeline grows.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from gearpit.atomic import atomic_path


def stage_stiffness(out: Path) -> dict:
    """Healthy and pitted (cluster pitting, 20 %, pinion teeth 0 and 5) stiffness of both presets."""
    from datagen.geometry import PRESETS, preset
    from datagen.pits import PitSpec
    from datagen.stiffness import mesh_stiffness
    from datagen.stiffness_plot import plot_stiffness
    from gearpit.commands.stiffness import write_stiffness_csv

    results = {}
    for name in sorted(PRESETS):
        pair = preset(name)
        grid = pair.flank_grid("pinion", 110, 200)
        pits = PitSpec(shape="cluster", teeth=(0, 5), severity=0.2, seed=7).build(grid, "pinion")
        healthy = mesh_stiffness(pair, positions_per_cycle=64, n_slices=200)
        pitted = mesh_stiffness(pair, pits=pits, positions_per_cycle=64, n_slices=200)
        d = out / name
        d.mkdir(parents=True, exist_ok=True)
        write_stiffness_csv(healthy, d / "stiffness_healthy.csv")
        write_stiffness_csv(pitted, d / "stiffness_pitted.csv")
        with atomic_path(d / "stiffness.png") as tmp:
            plot_stiffness({"healthy": healthy, "pitted teeth 0, 5 (20 %)": pitted}, tmp, title=name)
        results[name] = {"healthy": healthy.summary(), "pitted": pitted.summary()}
    return results


def stage_simulate(out: Path) -> dict:
    """Healthy and pitted (ellipse, 15 %, pinion tooth 0) simulation of both presets, with a housing path and noise.

    Operating points: spur-gds at 1500 rpm / 11.3 N m (the spur paper's rig), helical-dct at 2500 rpm / 240 N m
    (the helical paper's test); 0.5 s at 12.8 kHz.
    """
    from datagen.geometry import preset
    from datagen.pits import PitSpec
    from datagen.signals_plot import plot_signals
    from datagen.simulate import Case, OperatingPoint, simulate

    points = {"spur-gds": (1500.0, 11.3), "helical-dct": (2500.0, 240.0)}
    effects = ({"name": "transmission_path"}, {"name": "noise", "snr_db": 30.0})
    results = {}
    for name, (speed, torque) in points.items():
        pair = preset(name)
        cases = {state: Case(pair=pair, operating=OperatingPoint(speed, torque), duration_s=0.5, fs_hz=12800.0,
                             pits=None if state == "healthy" else PitSpec(shape="ellipse", teeth=(0,), severity=0.15),
                             pit_grid=(60, 120), effects=effects, seed=1)
                 for state in ("healthy", "pitted")}
        for (state, case), sig in zip(cases.items(), simulate(list(cases.values()))):
            d = out / name
            d.mkdir(parents=True, exist_ok=True)
            sig.save_npz(d / f"{state}.npz")
            sig.save_csv(d / f"{state}.csv")
            with atomic_path(d / f"{state}.png") as tmp:
                plot_signals(sig, tmp, channel="acc_pinion_loa_m_s2", title=f"{name} {state}: pinion housing")
            acc = sig.channels["acc_pinion_loa_m_s2"]
            results[f"{name}/{state}"] = {"rms_acc_m_s2": float(acc.std()), "speed_rpm": speed, "torque_nm": torque,
                                          "solver": sig.metadata["solver"]["method"]}
    return results


def stage_dataset(out: Path) -> dict:
    """A tiny labelled dataset from the embedded demo sweep, and its summary."""
    from datagen.dataset import dataset_info
    from datagen.generate import generate
    from datagen.sweep_examples import demo_sweep

    generate(demo_sweep(), out, progress=False)
    info = dataset_info(out)
    return {k: info[k] for k in ("n_samples", "class_counts", "size_bytes", "fingerprint") if k in info}


def stage_features(out: Path) -> dict:
    """``gearpit rank-features`` on the demo dataset (stage 3), with EMD; the five best features."""
    import pandas as pd

    from gearpit.cli import main

    code = main(["rank-features", str(out.parent / "dataset"), "--out", str(out), "--hht", "emd", "--jobs", "2"])
    if code != 0:
        raise RuntimeError(f"rank-features exited with {code}")
    ranking = pd.read_csv(out / "feature_ranking.csv")
    return {"n_features": int(len(ranking)), "top5": ranking.iloc[:5, 0].tolist()}


def stage_models(out: Path) -> dict:
    """Train the CNN on a small dataset of the demo sweep's classes (10 records per class) and evaluate it
    on a stratified 30 % held out (accuracy, macro-F1, confusion matrices, severity MAE)."""
    import tomllib

    from datagen.generate import generate
    from datagen.sweep import sweep_from_dict
    from datagen.sweep_examples import DEMO_TOML
    from models.workflow import train_and_evaluate

    doc = tomllib.loads(DEMO_TOML)
    doc["sweep"].update(name="demo-models", samples_per_class=10, shard_size=10, seed=2)
    generate(sweep_from_dict(doc), out / "dataset", progress=False)
    return train_and_evaluate(out / "dataset", out)


def stage_compare(out: Path) -> dict:
    """The README's full comparison loop (about a minute): reports, model TOML and ledger in ``out``."""
    from compare.workflow import hidden_effect_loop

    summary, _, _ = hidden_effect_loop(out, "pitch_error")
    cal = summary["calibration_before"]
    return {**{k: summary[k] for k in ("hidden", "claimed", "fitted", "error_before_db", "error_after_db")},
            "calibrated_nuisances": cal["parameters"] if cal is not None else None}


#: (name, function(out_dir) -> JSON-able summary), in pipeline order
STAGES = [("stiffness", stage_stiffness), ("simulate", stage_simulate), ("dataset", stage_dataset),
          ("features", stage_features), ("models", stage_models), ("compare", stage_compare)]


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job end to end on a small embedded default", description=__doc__)
    p.add_argument("--out", type=Path, default=Path("gearpit_out"), help="output directory (default gearpit_out)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    report = {}
    for name, fn in STAGES:
        t0 = time.perf_counter()
        print(f"[demo] {name} ...", flush=True)
        report[name] = fn(args.out / name)
        print(f"[demo] {name} done in {time.perf_counter() - t0:.1f} s -> {args.out / name}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "demo_summary.json") as tmp:
        tmp.write_text(json.dumps(report, indent=2, default=str))
    print(f"[demo] summary: {args.out / 'demo_summary.json'}")
    return 0
