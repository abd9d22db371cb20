"""Reproduce the spur paper's stiffness study and its helical counterpart (figures + printed numbers).

Spur (spur-gds, 219 x 1000 pixel flank, pits on pinion tooth 0 near the pitch line, as the paper's Figs 9-14):
healthy, one irregular pit, and 15 / 20 / 25 % cluster pitting: TVMS over the pitted tooth's mesh and the
pixel stiffness maps; also the pixel "no-contact" model vs the paper's "weak spring" model.
Helical (helical-dct): 1, 2 and 3 pitted teeth (the helical paper's ellipses: 5 x 1.5 mm minor, 10 x 1.5 mm
severe, 0.2 mm deep).
Usage: python experiments/stiffness_study.py [--out experiments/out/stiffness]
"""
from __future__ import annotations

import argparse
from pathlib import Path

from datagen.flank import PitMap
from datagen.geometry import helical_pair_example, spur_pair_example
from datagen.pit_stiffness import pixel_stiffness_map
from datagen.pits import PitSpec, ellipse
from datagen.stiffness import mesh_stiffness
from datagen.stiffness_plot import plot_pixel_map, plot_stiffness


def helical_ellipse(grid, major_m):
    """The helical paper's pit: ellipse, major axis across the face, 1.5 mm along the profile, 0.2 mm deep."""
    return ellipse(grid, centre_s_m=grid.pitch_s_m, centre_w_m=grid.face_width_m / 2, axis_s_m=1.5e-3,
                   axis_w_m=major_m, depth_m=0.2e-3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("experiments/out/stiffness"))
    out = ap.parse_args().out
    out.mkdir(parents=True, exist_ok=True)

    pair = spur_pair_example()
    grid = pair.flank_grid("pinion", 219, 1000)
    cases = {"irregular pit": PitSpec(shape="cluster", teeth=(0,), severity=0.06, seed=11).build(grid)}
    for sev in (0.15, 0.20, 0.25):
        cases[f"{sev:.0%} pitting"] = PitSpec(shape="cluster", teeth=(0,), severity=sev, seed=3).build(grid)
    ppc = 200
    healthy = mesh_stiffness(pair, positions_per_cycle=ppc, n_slices=1000)
    curves = {"healthy": healthy}
    print(f"spur-gds healthy: mean {healthy.mean_n_per_m / 1e6:.1f} N/um, "
          f"{healthy.summary()['mean_n_per_mm_um']:.2f} N/(mm um)")
    print(f"{'case':>15} {'severity':>9} {'min k (N/um)':>13} {'max drop %':>10} {'weak-spring max drop %':>22}")
    for name, pm in cases.items():
        ms = mesh_stiffness(pair, pits=pm, positions_per_cycle=ppc)
        ws = mesh_stiffness(pair, pits=pm, positions_per_cycle=ppc, pit_model="weak_spring")
        curves[name] = ms
        drop = (healthy.k_n_per_m - ms.k_n_per_m).max() / healthy.mean_n_per_m
        drop_ws = (healthy.k_n_per_m - ws.k_n_per_m).max() / healthy.mean_n_per_m
        print(f"{name:>15} {pm.severity(0):9.3f} {ms.k_n_per_m.min() / 1e6:13.1f} {100 * drop:10.1f} {100 * drop_ws:22.1f}")
        plot_pixel_map(pixel_stiffness_map(pair, pm, 0), grid, out / f"spur_pixel_map_{name.split()[0]}.png",
                       title=f"spur-gds tooth 0, {name}: pixel stiffness")
    plot_pixel_map(pixel_stiffness_map(pair, PitMap.healthy(grid), 0), grid, out / "spur_pixel_map_healthy.png",
                   title="spur-gds healthy tooth: pixel stiffness")
    window = slice(0, 4 * ppc)
    zoom = {k: _window(v, window) for k, v in curves.items()}
    plot_stiffness(zoom, out / "spur_tvms.png", title="spur-gds: TVMS while pitted tooth 0 meshes")

    hpair = helical_pair_example()
    hgrid = hpair.flank_grid("pinion", 120, 400)
    minor, severe = helical_ellipse(hgrid, 5e-3), helical_ellipse(hgrid, 10e-3)
    hcases = {"single minor": {0: minor}, "single severe": {0: severe}, "two teeth": {0: severe, 6: minor},
              "three teeth": {0: severe, 6: minor, 11: severe}}
    hh = mesh_stiffness(hpair, positions_per_cycle=64, n_slices=400)
    hcurves = {"healthy": hh}
    print(f"\nhelical-dct healthy: mean {hh.mean_n_per_m / 1e6:.1f} N/um (paper's Table 3: 374.1 N/um), "
          f"ripple {hh.summary()['ripple_peak_to_peak_over_mean']:.3f}")
    for name, depth in hcases.items():
        pm = PitMap(grid=hgrid, depth_m=depth, gear="pinion")
        ms = mesh_stiffness(hpair, pits=pm, positions_per_cycle=64)
        hcurves[name] = ms
        drop = (hh.k_n_per_m - ms.k_n_per_m).max() / hh.mean_n_per_m
        print(f"{name:>15}: severities {', '.join(f'{s:.3f}' for s in pm.severities().values())}; "
              f"max drop {100 * drop:.1f} %, mean drop {100 * (1 - ms.mean_n_per_m / hh.mean_n_per_m):.2f} %")
    plot_stiffness(hcurves, out / "helical_tvms.png", title="helical-dct: 1, 2 and 3 pitted teeth")
    print(f"\nfigures in {out}")


def _window(ms, sl):
    from dataclasses import replace

    return replace(ms, x_cycles=ms.x_cycles[sl], k_n_per_m=ms.k_n_per_m[sl])


if __name__ == "__main__":
    main()
