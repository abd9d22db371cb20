"""What the SpectraQuest recordings say about their own gearbox, and whether a localized tooth fault shows on it.

The recordings of ``../shared/data/spectraquest_gfd`` have no documented sampling rate, speed or tooth counts
(the data README). Everything here is in cycles per sample:

1. the mesh frequency of each file and channel (:func:`models.unknown_rate.estimate_mesh_cps`), and the tooth
   count of the gear whose once-per-turn sidebands the spectrum carries most strongly
   (:func:`models.unknown_rate.estimate_tooth_count`), with the margin to the next count that is no alias of it;
2. the envelope spectrum's strongest lines in orders of that gear's shaft (the other shaft and the assembly's
   repeat period show there);
3. the synchronous average of that shaft (angle from the mesh tone's phase, no tachometer:
   :func:`features.tsa.angle_track_from_mesh_phase`) and of the other shaft (its count from step 2), and the
   localized-fault indicators of each (FM4, NA4 on the difference/residual signal: ~3 for a healthy gear, rising
   with an impulsive once-per-turn event, McFadden 1987 / Zakrajsek 1993);
4. the orders of each average whose level (dB re the average's RMS) differs between the broken-tooth and the
   healthy file by more than 3 dB with the same sign at all five loads.

Run: ``python experiments/real_data_pair.py [--data DIR] [--json OUT]`` (~1 min). Reported in
experiments/RESULTS.md, "Real data: what was assumed, and what limits the figure".
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from features.envelope import envelope_spectrum
from features.indicators import gear_condition_indicators
from features.tsa import AngleTrack, angle_track_from_mesh_phase, synchronous_average
from models.unknown_rate import estimate_mesh_cps, estimate_tooth_count

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "spectraquest_gfd"
LOADS = (0, 30, 50, 70, 90)
CHANNELS = ("a1", "a2", "a3", "a4")


def _load(data: Path, cond: str, load: int) -> np.ndarray:
    x = np.loadtxt(data / f"{cond}30hz{load}.csv", delimiter=",", skiprows=1)
    return x - x.mean(axis=0)


def envelope_lines(x: np.ndarray, shaft_cps: float, *, n: int = 6) -> list[float]:
    """The ``n`` strongest envelope-spectrum lines (band 0.05-0.45 cycles/sample) below 8 shaft orders, in orders
    of ``shaft_cps``."""
    f, a = envelope_spectrum(x, 1.0, band_hz=(0.05, 0.45))
    keep = (f > 0.1 * shaft_cps) & (f < 8 * shaft_cps)
    idx = np.nonzero(keep)[0]
    loc = idx[(a[idx] > a[idx - 1]) & (a[idx] >= a[idx + 1])]           # local maxima only
    top = loc[np.argsort(a[loc])[::-1][:n]]
    return sorted(round(float(f[i] / shaft_cps), 2) for i in top)


def shaft_averages(x: np.ndarray, mesh_cps: float, z: int, z_other: int, track_from: np.ndarray) -> dict:
    """Synchronous averages of both shafts (angle from the mesh phase of ``track_from``) and their indicators."""
    tr = angle_track_from_mesh_phase(track_from, 1.0, mesh_order=z, shaft_hz_nominal=mesh_cps / z)
    out = {}
    for name, teeth in (("first", z), ("other", z_other)):
        ratio = z / teeth
        spr = int(2 ** np.ceil(np.log2(teeth / mesh_cps)))
        avg = synchronous_average(x, 1.0, AngleTrack(tr.time_s, tr.angle_rad * ratio), samples_per_rev=spr).average
        ci = gear_condition_indicators(avg, teeth)
        amp = np.abs(np.fft.rfft(avg))[:4 * teeth + 1]
        level = 20 * np.log10(amp / np.sqrt(np.sum(amp[1:] ** 2)) + 1e-12)
        out[name] = {"teeth": teeth, "fm4": ci["fm4"], "na4": ci["na4"], "level_db": level}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    files = {(c, ld): _load(args.data, c, ld) for c in "hb" for ld in LOADS}

    print("## 1. Mesh frequency and tooth count per file and channel (cycles/sample; score and runner-up in dB)\n")
    print("| file | mesh | " + " | ".join(f"{ch}: z (score / next)" for ch in CHANNELS) + " |")
    print("|---|---|" + "---|" * len(CHANNELS))
    counts, table = [], []
    for (c, ld), x in files.items():
        mesh = estimate_mesh_cps(x[:, 1])
        cells = []
        for j, ch in enumerate(CHANNELS):
            z, score, nxt = estimate_tooth_count(x[:, j], estimate_mesh_cps(x[:, j]))
            counts.append(z)
            cells.append(f"{z} ({score:.1f} / {nxt:.1f})")
            table.append({"file": f"{c}30hz{ld}", "channel": ch, "mesh_cps": mesh, "z": z, "score_db": score,
                          "runner_up_db": nxt})
        print(f"| {c}30hz{ld} | {mesh:.5f} | " + " | ".join(cells) + " |")
    z = int(np.bincount(counts).argmax())
    print(f"\nmost frequent count: {z} ({counts.count(z)} of {len(counts)} file-channels)\n")

    print(f"## 2. Strongest envelope lines, in orders of the {z}-tooth shaft (mesh / {z})\n")
    env = {}
    for (c, ld), x in files.items():
        mesh = estimate_mesh_cps(x[:, 1])
        env[f"{c}30hz{ld}"] = lines = envelope_lines(x[:, 1], mesh / z)
        print(f"- {c}30hz{ld} (a2): {lines}")
    frac = [v for ls in env.values() for v in ls if abs(v - round(v)) > 0.05]
    z_other = None
    if frac:
        # the other shaft: the fractional order o = z / z_other seen most often -> z_other = z / o
        o = float(np.median([v for v in frac if v < 1.0] or frac))
        z_other = int(round(z / o))
        print(f"\nfractional orders seen: {sorted(set(frac))}; the one below 1 (median {o:.2f}) read as the other "
              f"shaft: z_other = {z} / {o:.2f} = {z_other}; assembly repeat period mesh / lcm = "
              f"{z / np.lcm(z, z_other):.2f} orders\n")

    print("## 3. Localized-fault indicators of each shaft's synchronous average (FM4 / NA4; ~3 when healthy)\n")
    avgs = {}
    print("| file | " + " | ".join(f"{ch} first ({z}) | {ch} other ({z_other})" for ch in CHANNELS) + " |")
    print("|---|" + "---|---|" * len(CHANNELS))
    for (c, ld), x in files.items():
        mesh = estimate_mesh_cps(x[:, 1])
        cells = []
        for j, ch in enumerate(CHANNELS):
            avgs[(c, ld, ch)] = a = shaft_averages(x[:, j], mesh, z, z_other or z, x[:, 1])
            cells += [f"{a['first']['fm4']:.1f} / {a['first']['na4']:.1f}",
                      f"{a['other']['fm4']:.1f} / {a['other']['na4']:.1f}"]
        print(f"| {c}30hz{ld} | " + " | ".join(cells) + " |")
    fm4 = {c: [avgs[(c, ld, ch)][s]["fm4"] for ld in LOADS for ch in CHANNELS for s in ("first", "other")]
           for c in "hb"}
    print(f"\nFM4 over every load, channel and shaft: healthy {np.min(fm4['h']):.1f}-{np.max(fm4['h']):.1f}, "
          f"broken {np.min(fm4['b']):.1f}-{np.max(fm4['b']):.1f}\n")

    print("## 4. Orders whose level differs (broken - healthy) by > 3 dB with one sign at all five loads\n")
    consistent = {}
    for ch in CHANNELS:
        for s in ("first", "other"):
            d = np.array([avgs[("b", ld, ch)][s]["level_db"] - avgs[("h", ld, ch)][s]["level_db"] for ld in LOADS])
            ok = (np.sign(d) == np.sign(d[0])).all(axis=0) & (np.abs(d).min(axis=0) > 3.0)
            orders = [int(o) for o in np.nonzero(ok)[0] if o > 0]
            consistent[f"{ch}/{s}"] = orders
            teeth = avgs[("h", LOADS[0], ch)][s]["teeth"]
            side = [o for o in orders if min(o % teeth, teeth - o % teeth) <= 3 and o >= teeth - 3]
            print(f"- {ch}, {s} shaft ({teeth} teeth): {len(orders)} of {4 * teeth} orders; within 3 orders of a "
                  f"mesh harmonic: {side}")
    if args.json:
        doc = {"counts": table, "z": z, "z_other": z_other, "envelope_orders": env,
               "fm4": {k: [float(v) for v in vs] for k, vs in fm4.items()}, "consistent_orders": consistent}
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(doc, indent=1))
        tmp.replace(args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
