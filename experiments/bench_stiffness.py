"""Benchmark: mesh stiffness of a full pinion revolution with 219 x 1000 pixel flanks and 3 pitted teeth.

Prints the seconds per revolution (best of 5) and the speed-up against the slow reference
(tests/stiffness_reference.py: scipy quad per position and slice), timed on a sample of positions
and scaled to the same revolution. Last line: JSON.
Usage: python experiments/bench_stiffness.py
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from datagen.geometry import spur_pair_example  # noqa: E402
from datagen.pits import PitSpec  # noqa: E402
from datagen.stiffness import mesh_stiffness  # noqa: E402
from stiffness_reference import pair_stiffness_per_width  # noqa: E402


def main() -> None:
    pair = spur_pair_example()
    grid = pair.flank_grid("pinion", 219, 1000)
    pits = PitSpec(shape="cluster", teeth=(0, 9, 19), severity=(0.15, 0.20, 0.25), seed=1).build(grid, "pinion")
    ppc = math.ceil(3600 / pair.pinion.teeth)  # >= 10 positions per degree
    mesh_stiffness(pair, pits=pits, positions_per_cycle=ppc)  # warm-up
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        ms = mesh_stiffness(pair, pits=pits, positions_per_cycle=ppc)
        times.append(time.perf_counter() - t0)
    fast = min(times)
    n_pos = ms.k_n_per_m.size
    # reference: quad per contact point; per position one call per slice and pair in contact
    sample = 20
    t0 = time.perf_counter()
    for x in np.linspace(0, 1, sample, endpoint=False):
        for s in range(3):
            g = pair.contact_start_m + (x + s) * pair.base_pitch_m
            if g <= pair.contact_end_m:
                pair_stiffness_per_width(pair, g)
    n_calls = sum(1 for x in np.linspace(0, 1, sample, endpoint=False) for s in range(3)
                  if pair.contact_start_m + (x + s) * pair.base_pitch_m <= pair.contact_end_m)
    per_point = (time.perf_counter() - t0) / n_calls
    # a fair reference reuses one evaluation for all healthy slices of a pair (spur slices are identical) and
    # evaluates every slice separately only where a pitted tooth is in contact (section loss differs per slice)
    healthy_points = int((ms.k_slots_n_per_m > 0).sum())
    pitted_points = sum(int((k > 0).sum()) for k in ms._overrides.values())
    ref = per_point * (healthy_points + pitted_points)
    print(f"pair {pair.name}: {n_pos} positions ({n_pos / 360:.1f} per degree), {ms.n_slices} slices, "
          f"3 pitted teeth on a 219 x 1000 flank")
    print(f"gearpit: {fast:.4f} s per revolution (best of 5; all: {', '.join(f'{t:.3f}' for t in times)})")
    print(f"reference (scipy quad per contact point: {healthy_points} healthy pair points + {pitted_points} pitted "
          f"slice points, {per_point * 1e3:.2f} ms each, timed on {n_calls} points): {ref:.0f} s")
    print(json.dumps({"seconds_per_revolution": fast, "speedup_vs_reference": ref / fast,
                      "positions_per_degree": n_pos / 360, "n_slices": ms.n_slices, "pitted_teeth": 3}))


if __name__ == "__main__":
    main()
