"""``gearpit demo``: the main job end to end on a small embedded default (no downloads).

Stages (each writes into its own folder under ``--out``):

1. ``stiffness``: healthy and pitted mesh stiffness of both preset pairs (CSV, PNG, JSON).

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


#: (name, function(out_dir) -> JSON-able summary), in pipeline order
STAGES = [("stiffness", stage_stiffness)]


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
